//! The setup file (`--arm FILE`): the arm model and the board, as TOML.
//!
//! Every section and field is optional and defaults to the report's setup, so a file may say
//! only what differs. Units are SI: m, rad, kg, kg·m², N·m, s.

use crate::app::setup::condition_tables::{SensorFile, UncertaintyFile};
use anyhow::{Context, Result, anyhow, bail};
use chessarm_chess::board::BoardGeometry;
use chessarm_chess::clearance::moves::ClearanceCheck;
use chessarm_chess::motion::TimingMode;
use chessarm_chess::pieces::{PieceDimensions, PieceSet};
use chessarm_chess::tasks::{MotionLimits, TaskError};
use chessarm_core::arm::link::{DhParameters, Friction, Inertial, JointLimits, Link};
use chessarm_core::arm::model::ArmModel;
use chessarm_core::arm::outline::{Block, Outline};
use chessarm_core::arm::preset::report_arm;
use chessarm_core::nalgebra::{Matrix3, Rotation3, Vector2, Vector3};
use chessarm_core::sim::actuator::Actuators;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// One link of the arm in the file; every field left out keeps the report's value for that
/// link.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct LinkFile {
    /// DH link length a, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub a: Option<f64>,
    /// DH twist alpha, rad.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub alpha: Option<f64>,
    /// DH offset d, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub d: Option<f64>,
    /// Constant added to the joint angle, rad.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub theta_offset: Option<f64>,
    /// Link mass, kg.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mass: Option<f64>,
    /// Centre of mass in DH frame i, m (3 numbers).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub com: Option<Vec<f64>>,
    /// Inertia tensor about the COM, kg·m², in the frame given by `inertia_rpy` (3 rows of 3).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inertia: Option<Vec<Vec<f64>>>,
    /// Roll, pitch, yaw (rad) of the tensor's frame relative to DH frame i. The report's CAD
    /// tensors for links 2 and 3 look exported with the link along y; state that here.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inertia_rpy: Option<Vec<f64>>,
    /// Motor mass at this joint, kg (a point mass on link i−1 at the joint axis).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub motor_mass: Option<f64>,
    /// Reflected rotor inertia, kg·m².
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rotor_inertia: Option<f64>,
    /// Lowest joint angle, rad.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lower: Option<f64>,
    /// Highest joint angle, rad.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub upper: Option<f64>,
    /// Largest joint speed, rad/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub velocity_limit: Option<f64>,
    /// Largest motor torque, N·m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub torque_limit: Option<f64>,
    /// Viscous friction, N·m·s/rad (plant only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub viscous: Option<f64>,
    /// Coulomb friction, N·m (plant only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coulomb: Option<f64>,
    /// What drives the joint: `torque` (the default), a built-in servo or an `[actuators.NAME]`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub actuator: Option<String>,
}

/// The board in the file; fields left out keep the default board's.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct BoardFile {
    /// Distance between square centres, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub square_size: Option<f64>,
    /// Centre of the board in the base frame (x, y), m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub center: Option<Vec<f64>>,
    /// Height of the board surface, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub surface_height: Option<f64>,
    /// Turn of the board about the vertical, rad (0: files along x, ranks along y, away from
    /// the arm).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub yaw: Option<f64>,
    /// How far every square, slot and traverse stays from the base axis, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub base_clearance: Option<f64>,
    /// The squares turned half a turn on the table (rank 8 where rank 1 would be), the slots
    /// and the home point where they were.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub squares_turned: Option<bool>,
}

/// One kind of chess piece in the file; fields left out keep that kind's default.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct PieceFile {
    /// Height, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub height: Option<f64>,
    /// Base diameter, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub base_diameter: Option<f64>,
    /// Mass, kg.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mass: Option<f64>,
    /// Height above the piece's base where the tool tip grips it, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grip_height: Option<f64>,
    /// The profile as rings `[height, diameter]` from the base up, fractions of `height` and
    /// `base_diameter` (first `[0, …]`, last at the top unless a `head_block` stands on it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outline: Option<Vec<[f64; 2]>>,
    /// A block on the outline's last ring (a knight's head): `[top, length, width]`, the top a
    /// fraction of `height`, length (along the ranks) and width fractions of `base_diameter`;
    /// `[]` for none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub head_block: Option<Vec<f64>>,
}

/// The piece set in the file (each kind optional).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct PiecesFile {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pawn: Option<PieceFile>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub knight: Option<PieceFile>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bishop: Option<PieceFile>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rook: Option<PieceFile>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub queen: Option<PieceFile>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub king: Option<PieceFile>,
}

/// One number for every joint, or one per joint (as the flags take them: `--joint-acceleration
/// 20` or `20,20,15,15`).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(untagged, expecting = "expected a number (every joint) or a list of numbers (one per joint)")]
pub enum OneOrEach {
    One(f64),
    Each(Vec<f64>),
}

impl OneOrEach {
    /// The values, `count` of them for one number.
    pub fn each(&self, count: usize) -> Vec<f64> {
        match self {
            OneOrEach::One(value) => vec![*value; count],
            OneOrEach::Each(values) => values.clone(),
        }
    }
}

/// The motion limits in the file (`[motion]`); fields left out keep the defaults.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct MotionFile {
    /// Largest tool-tip speed of time-optimal motions, m/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tool_speed: Option<f64>,
    /// Largest |joint acceleration| of time-optimal motions, rad/s² (4 numbers).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub joint_acceleration: Option<OneOrEach>,
    /// Share of each motor's torque limit a time-optimal plan may use, in (0, 1].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub torque_margin: Option<f64>,
    /// Largest corner cut of a blend, m (0: stop at every corner).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub blend: Option<f64>,
    /// Planning grid step along the path, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grid_step: Option<f64>,
    /// Largest jerk along the path of time-optimal motions, m/s³ (0: no limit).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub jerk: Option<f64>,
    /// Largest tracking error the motion may add while carrying a piece of uncertain mass, m
    /// (0: no budget).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tracking_budget: Option<f64>,
    /// Clearance over the tallest piece passed over, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub clearance_margin: Option<f64>,
    /// How far from straight down the tool may tilt to grip, rad (0: always straight down).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_tilt: Option<f64>,
    /// The smallest distance a planned move keeps between the arm, its fingers and a carried
    /// piece and every standing piece, the table and the arm itself, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub arm_clearance: Option<f64>,
    /// LSPB traverses: speed (m/s) and acceleration (m/s²).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub traverse_speed: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub traverse_acceleration: Option<f64>,
    /// LSPB rises and descents: speed (m/s) and acceleration (m/s²).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vertical_speed: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vertical_acceleration: Option<f64>,
    /// Rest between LSPB moves, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pause: Option<f64>,
}

/// The gripper in the file (`[gripper]`); fields left out keep the defaults.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct GripperFile {
    /// Largest tool acceleration while carrying a piece, m/s² (gravity not counted).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub carry_acceleration: Option<f64>,
    /// Largest |acceleration − gravity| of a carried piece the friction grip holds, m/s²
    /// (above 9.81, or a piece slips at rest).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grip_strength: Option<f64>,
    /// Time to close and to open the gripper, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grip_dwell: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub release_dwell: Option<f64>,
    /// The fingers, m: length from the palm, how far they reach past the grip point, their
    /// thickness along the closing direction and width across it, and the gap each side
    /// between a finger and a piece when open around it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub finger_length: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub finger_reach: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub finger_thickness: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub finger_width: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub finger_opening: Option<f64>,
}

impl GripperFile {
    /// The file's fingers and `[motion] arm_clearance` over `default`, checked.
    pub fn to_clearance(&self, motion: &MotionFile, default: &ClearanceCheck) -> Result<ClearanceCheck> {
        let g = |name: &str, given: Option<f64>, default: f64| number_or(&format!("gripper.{name}"), given, default);
        let d = &default.gripper;
        let gripper = chessarm_core::arm::bodies::Gripper {
            finger_length: g("finger_length", self.finger_length, d.finger_length)?,
            finger_reach: g("finger_reach", self.finger_reach, d.finger_reach)?,
            finger_thickness: g("finger_thickness", self.finger_thickness, d.finger_thickness)?,
            finger_width: g("finger_width", self.finger_width, d.finger_width)?,
            finger_opening: g("finger_opening", self.finger_opening, d.finger_opening)?,
        };
        let margin = number_or("motion.arm_clearance", motion.arm_clearance, default.margin)?;
        ClearanceCheck { gripper, margin, bodies: default.bodies.clone(), held_turn: 0.0 }.validated().map_err(
            |(field, value, reason)| {
                let table = if field == "arm_clearance" { "motion" } else { "gripper" };
                anyhow!("{table}.{field} = {}: {reason}", chessarm_core::short_number(value))
            },
        )
    }
}

impl MotionFile {
    /// The file's `[motion]` and `[gripper]` over `default`, checked.
    pub fn to_limits(&self, gripper: &GripperFile, default: &MotionLimits) -> Result<MotionLimits> {
        let m = |name: &str, given: Option<f64>, default: f64| number_or(&format!("motion.{name}"), given, default);
        let g = |name: &str, given: Option<f64>, default: f64| number_or(&format!("gripper.{name}"), given, default);
        let limits = MotionLimits {
            traverse_speed: m("traverse_speed", self.traverse_speed, default.traverse_speed)?,
            traverse_acceleration: m(
                "traverse_acceleration",
                self.traverse_acceleration,
                default.traverse_acceleration,
            )?,
            vertical_speed: m("vertical_speed", self.vertical_speed, default.vertical_speed)?,
            vertical_acceleration: m(
                "vertical_acceleration",
                self.vertical_acceleration,
                default.vertical_acceleration,
            )?,
            pause: m("pause", self.pause, default.pause)?,
            clearance_margin: m("clearance_margin", self.clearance_margin, default.clearance_margin)?,
            grip_dwell: g("grip_dwell", gripper.grip_dwell, default.grip_dwell)?,
            release_dwell: g("release_dwell", gripper.release_dwell, default.release_dwell)?,
            tool_speed: m("tool_speed", self.tool_speed, default.tool_speed)?,
            joint_acceleration: numbers_or(
                "motion.joint_acceleration",
                self.joint_acceleration.as_ref().map(|given| given.each(4)).as_ref(),
                "one per joint, rad/s²",
                default.joint_acceleration,
            )?,
            torque_margin: m("torque_margin", self.torque_margin, default.torque_margin)?,
            carry_acceleration: g("carry_acceleration", gripper.carry_acceleration, default.carry_acceleration)?,
            grip_strength: g("grip_strength", gripper.grip_strength, default.grip_strength)?,
            blend: m("blend", self.blend, default.blend)?,
            grid_step: m("grid_step", self.grid_step, default.grid_step)?,
            jerk: m("jerk", self.jerk, default.jerk)?,
            tracking: chessarm_chess::tasks::Tracking {
                budget: m("tracking_budget", self.tracking_budget, default.tracking.budget)?,
                ..default.tracking
            },
            pitch: default.pitch,
            max_tilt: m("max_tilt", self.max_tilt, default.max_tilt)?,
        };
        checked_limits(limits, "motion", "gripper")
    }
}

/// `limits` validated, an error naming the field as `TABLE.FIELD` (the gripper's fields in
/// `gripper_table`).
pub fn checked_limits(limits: MotionLimits, motion_table: &str, gripper_table: &str) -> Result<MotionLimits> {
    limits.validated().map_err(|error| match error {
        TaskError::Limits { field, value, reason } => {
            let gripper = ["carry_acceleration", "grip_strength", "grip_dwell", "release_dwell"];
            let table = if gripper.contains(&field) { gripper_table } else { motion_table };
            anyhow!("{table}.{field} = {}: {reason}", chessarm_core::short_number(value))
        }
        other => anyhow!(other),
    })
}

/// The whole setup file. Every table and field may be left out: what is missing keeps the
/// report's value (per link, per piece kind, per board field).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct SetupFile {
    /// Gravitational acceleration in the base frame, m/s² (3 numbers).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gravity: Option<Vec<f64>>,
    #[serde(default)]
    pub board: BoardFile,
    /// The chess pieces as physical objects.
    #[serde(default)]
    pub pieces: PiecesFile,
    /// Links from the base to the tool, in order (none: the report's four).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub links: Vec<LinkFile>,
    /// Named sensor profiles for `--sensors NAME`.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub sensors: BTreeMap<String, SensorFile>,
    /// Random model errors for `robustness` and the simulating commands.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<UncertaintyFile>,
    /// Motion limits of the pick-and-place planners.
    #[serde(default)]
    pub motion: MotionFile,
    /// The gripper's limits and dwell times.
    #[serde(default)]
    pub gripper: GripperFile,
    /// Where the base axis stands in the base frame, m (x, y, z; default the origin).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub base: Option<Vec<f64>>,
    /// How the arm of `--urdf` is read: joints held, the tool link and point.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub urdf: Option<UrdfFile>,
    /// What drives the joints: one name for all, or one per joint (instead of each
    /// `[[links]] actuator`; for an arm of `--urdf`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub actuator: Option<ActuatorNames>,
    /// The user's own servos, `[actuators.NAME]`.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub actuators: BTreeMap<String, crate::app::setup::actuators::ActuatorFile>,
    /// `[servo_bus]`: the servos' IDs, directions and zero ticks (for the goals in ticks).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub servo_bus: Option<crate::app::setup::actuators::ServoBusFile>,
}

/// `actuator = "NAME"` or `actuator = ["NAME", …]` (one per joint).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum ActuatorNames {
    One(String),
    Each(Vec<String>),
}

/// `[urdf]`: for `--urdf`, as its flags say (the flags win).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct UrdfFile {
    /// Joints held at a value, rad (m for a prismatic joint), as `--lock`.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub lock: BTreeMap<String, f64>,
    /// The tool link, as `--tool`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tool: Option<String>,
    /// The tool point in the tool link's frame, m, as `--tool-offset`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tool_offset: Option<Vec<f64>>,
}

/// How often a host sends servo goals when `--bus-rate` does not say, Hz (LeRobot's
/// teleoperation runs at 30–60 Hz; a Dynamixel or Feetech bus at 1 Mbit/s carries a few hundred).
pub const DEFAULT_BUS_RATE: f64 = 100.0;

/// What a setup file describes, validated.
#[derive(Debug, Clone)]
pub struct Setup {
    pub arm: ArmModel<4>,
    pub board: BoardGeometry,
    pub pieces: PieceSet,
    /// Named sensor profiles (each checked when the file is read).
    pub sensor_profiles: BTreeMap<String, SensorFile>,
    /// The `[uncertainty]` table (checked when the file is read).
    pub uncertainty: Option<UncertaintyFile>,
    /// The file this setup was read from (`None`: the built-in setup).
    pub path: Option<std::path::PathBuf>,
    /// The URDF file the arm was read from (`--urdf`), if any.
    pub urdf_path: Option<std::path::PathBuf>,
    /// The joints' names (the URDF's, or `joint1`…`joint4`), for exports.
    pub joint_names: [String; 4],
    /// The base frame's name (the URDF's root link, or `base_link`), for exports.
    pub base_link: String,
    /// The file's sense of each arm joint and the joints it holds (a URDF's), for every angle
    /// a user gives or reads.
    pub convention: JointConvention,
    /// `[urdf]`: how `--urdf` is read (with the flags applied once it is); `None` when the
    /// setup file has no such table (a file with one is for `--urdf` only, even empty).
    pub urdf: Option<UrdfFile>,
    /// What drives each joint, and the names the setup gave them (`torque` for a torque motor).
    pub actuators: Actuators<4>,
    pub actuator_names: [String; 4],
    /// The user's own servos (`[actuators.NAME]`), checked.
    pub actuator_tables: BTreeMap<String, crate::app::setup::actuators::ActuatorFile>,
    /// The `[servo_bus]` table as given (checked against the actuators when the goals are
    /// written in ticks).
    pub servo_bus: Option<crate::app::setup::actuators::ServoBusFile>,
    /// With servos: the host's strategies (`--servo-command`; `simulate` compares them) and its
    /// bus rate, Hz (`--bus-rate`).
    pub servo_commands: Vec<chessarm_core::control::servo_host::ServoCommand>,
    pub bus_rate: f64,
    /// The motion limits (`[motion]`, `[gripper]`, then the motion flags).
    pub motion: MotionLimits,
    /// How robot moves are timed (set by `--timing`; the file does not say).
    pub timing: TimingMode,
    /// The gripper's fingers and the clearance every planned move keeps (`[gripper]`,
    /// `[motion] arm_clearance`).
    pub clearance: ClearanceCheck,
}

impl Default for Setup {
    fn default() -> Self {
        Self {
            arm: report_arm(),
            board: BoardGeometry::default(),
            pieces: PieceSet::default(),
            sensor_profiles: BTreeMap::new(),
            uncertainty: None,
            path: None,
            urdf_path: None,
            joint_names: default_joint_names(),
            base_link: "base_link".into(),
            convention: JointConvention::default(),
            urdf: None,
            actuators: Actuators::torque(),
            actuator_names: std::array::from_fn(|_| crate::app::setup::actuators::TORQUE.to_string()),
            actuator_tables: BTreeMap::new(),
            servo_bus: None,
            servo_commands: vec![Default::default()],
            bus_rate: DEFAULT_BUS_RATE,
            motion: MotionLimits::default(),
            timing: TimingMode::default(),
            clearance: ClearanceCheck::default(),
        }
    }
}

/// How the model's joints are the user's: the sign of each arm joint (the file's angle, rate
/// and torque are `sign ·` the model's) and the other joints of the file, held.
#[derive(Debug, Clone, PartialEq)]
pub struct JointConvention {
    pub signs: [f64; 4],
    pub locked: Vec<crate::app::setup::urdf_import::LockedJoint>,
    /// The file's fingers on prismatic joints, which its gripper joints slide to each gap
    /// ([`chessarm_core::arm::bodies::finger_value`]); empty without.
    pub fingers: std::sync::Arc<[chessarm_core::arm::bodies::BodyShape]>,
}

impl Default for JointConvention {
    fn default() -> Self {
        Self { signs: [1.0; 4], locked: Vec::new(), fingers: Vec::new().into() }
    }
}

impl JointConvention {
    /// Each held joint's value (the file's convention, rad or m) with the gripper closed or
    /// open: with the file's fingers and the gap they are at (m), the value that slides them
    /// there (a gripper joint, a follower by its `<mimic>`); else a gripper joint's close or
    /// open value, any other's held value.
    pub fn held_value(
        &self,
        joint: &crate::app::setup::urdf_import::LockedJoint,
        closed: bool,
        gap: Option<f64>,
    ) -> f64 {
        let value = gap.and_then(|gap| chessarm_core::arm::bodies::finger_value(&self.fingers, gap));
        match (joint.finger, value) {
            (Some((m, o)), Some(v)) => m * v + o,
            _ => joint.at(closed),
        }
    }
}

impl JointConvention {
    /// Joint values in the user's convention from the model's (or back: the map is its own
    /// inverse), rad, rad/s, rad/s² or N·m.
    pub fn user(&self, values: impl Into<[f64; 4]>) -> [f64; 4] {
        let values = values.into();
        // `+ 0.0`: no negative zero for a zero in a flipped joint.
        std::array::from_fn(|i| self.signs[i] * values[i] + 0.0)
    }
}

impl Setup {
    /// Joint `j`'s limits in the user's convention (a URDF's own sense), rad.
    pub fn user_limits(&self, j: usize) -> (f64, f64) {
        let limits = self.arm.link(j).limits;
        if self.convention.signs[j] < 0.0 { (-limits.upper, -limits.lower) } else { (limits.lower, limits.upper) }
    }

    /// The arm of a URDF in place of the setup's.
    pub fn take_urdf_arm(&mut self, imported: crate::app::setup::urdf_import::ImportedArm) {
        self.arm = imported.model;
        self.joint_names = imported.joint_names;
        self.base_link = imported.base_link;
        let fingers: Vec<chessarm_core::arm::bodies::BodyShape> = match &imported.bodies {
            chessarm_core::arm::bodies::Bodies::Described(shapes) => shapes
                .iter()
                .filter(|s| matches!(s.mount, chessarm_core::arm::bodies::Mount::Finger(_)))
                .cloned()
                .collect(),
            chessarm_core::arm::bodies::Bodies::Drawn => Vec::new(),
        };
        self.convention = JointConvention { signs: imported.signs, locked: imported.locked, fingers: fingers.into() };
        self.clearance.bodies = imported.bodies;
    }
}

/// `joint1`…`joint4`, the names `chessarm urdf` gives the joints.
pub fn default_joint_names() -> [String; 4] {
    std::array::from_fn(|i| format!("joint{}", i + 1))
}

impl Setup {
    /// The report's setup, or the one in `path` with defaults for what it leaves out.
    pub fn load(path: Option<&Path>) -> Result<Self> {
        match path {
            None => Ok(Self::default()),
            Some(path) => {
                let text = crate::app::input::read_text("arm file", path, crate::app::input::MAX_SETUP_BYTES)?;
                let setup = Self::parse(&text).with_context(|| format!("arm file {}", path.display()))?;
                Ok(Self { path: Some(path.to_path_buf()), ..setup })
            }
        }
    }

    /// Parses and validates a setup from TOML text.
    pub fn parse(text: &str) -> Result<Self> {
        let file: SetupFile = toml::from_str(text).map_err(|e| anyhow!(toml_error(text, &e)))?;
        file.to_setup()
    }

    /// The setup as TOML, with a header that names the units: the arm as standard DH (and its
    /// base), whatever it was read from.
    pub fn to_toml(&self) -> Result<String> {
        let body = toml::to_string_pretty(&SetupFile::from(self))?;
        Ok(format!("{HEADER}{body}"))
    }

    /// The setup as TOML for use with the arm it was made for: with `--urdf`, no `[[links]]` (the
    /// URDF gives the arm) and `[urdf]` with the joints held and the tool; else as [`Setup::to_toml`].
    pub fn to_toml_beside_urdf(&self) -> Result<String> {
        if self.urdf_path.is_none() {
            return self.to_toml();
        }
        let mut file = SetupFile::from(self);
        file.links = Vec::new();
        file.base = None;
        file.urdf = Some(self.urdf.clone().unwrap_or_default());
        let body = toml::to_string_pretty(&file)?;
        Ok(format!("{HEADER}{body}"))
    }
}

const HEADER: &str = "\
# chessarm setup: the arm (standard DH, one [[links]] table per joint, base to tool), the board
# and the chess pieces (height, base diameter, mass, grip height above the piece's base).
# Units: m, rad, kg, kg·m² (inertia about the COM in DH frame i, rotated by inertia_rpy), N·m, s.
# [motion] and [gripper] hold the pick-and-place planners' limits (m/s, m/s², rad/s², s).
# Every field may be left out; the report's values are the defaults.
";

/// `message (line L, column C)` from a TOML error, on one line.
pub(crate) fn toml_error(text: &str, error: &toml::de::Error) -> String {
    let message = error.message().trim().replace('\n', " ");
    match error.span() {
        Some(span) => {
            let before = &text[..span.start.min(text.len())];
            let line = before.matches('\n').count() + 1;
            let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
            format!("line {line}, column {column}: {message}")
        }
        None => message,
    }
}

/// A finite number from the file, or an error naming its field.
fn finite(field: &str, value: f64) -> Result<f64> {
    if value.is_finite() { Ok(value) } else { bail!("{field} = {value} is not a finite number") }
}

/// `field` if given (checked finite), else `default`.
fn number_or(field: &str, given: Option<f64>, default: f64) -> Result<f64> {
    given.map_or(Ok(default), |value| finite(field, value))
}

/// Exactly `N` finite numbers, or an error naming the field and what is wrong.
fn numbers<const N: usize>(field: &str, given: &[f64], meaning: &str) -> Result<[f64; N]> {
    if given.len() != N {
        bail!("{field} has {} numbers; it needs exactly {N} ({meaning})", given.len());
    }
    let mut values = [0.0; N];
    for (i, (value, given)) in values.iter_mut().zip(given).enumerate() {
        *value = finite(&format!("{field}[{i}]"), *given)?;
    }
    Ok(values)
}

/// `field` if given (exactly `N` finite numbers), else `default`.
fn numbers_or<const N: usize>(
    field: &str,
    given: Option<&Vec<f64>>,
    meaning: &str,
    default: [f64; N],
) -> Result<[f64; N]> {
    given.map_or(Ok(default), |given| numbers(field, given, meaning))
}

impl SetupFile {
    fn to_setup(&self) -> Result<Setup> {
        let defaults = Setup::default();
        let links: [Link; 4] = if self.links.is_empty() {
            *defaults.arm.links()
        } else {
            if self.links.len() != 4 {
                bail!("links: the chess arm has 4 joints, the file lists {}", self.links.len());
            }
            let mut links = *defaults.arm.links();
            for (i, (link, given)) in links.iter_mut().zip(&self.links).enumerate() {
                *link = given.to_link(i + 1, link)?;
            }
            links
        };
        let gravity = numbers_or("gravity", self.gravity.as_ref(), "x, y, z in m/s²", defaults.arm.gravity().into())?;
        let base = numbers_or("base", self.base.as_ref(), "x, y, z of the base axis' foot in m", [0.0; 3])?;
        let arm = ArmModel::new(links, Vector3::from(gravity))?.with_base(Vector3::from(base))?;
        if let Some(urdf) = &self.urdf {
            for (name, value) in &urdf.lock {
                finite(&format!("urdf.lock.{name}"), *value)?;
            }
            if let Some(offset) = &urdf.tool_offset {
                numbers::<3>("urdf.tool_offset", offset, "x, y, z in the tool link's frame, m")?;
            }
        }
        let board = &self.board;
        let default_board = defaults.board;
        let board = BoardGeometry {
            square_size: number_or("board.square_size", board.square_size, default_board.square_size)?,
            center: Vector2::from(numbers_or(
                "board.center",
                board.center.as_ref(),
                "x, y of the board's centre in m",
                default_board.center.into(),
            )?),
            surface_height: number_or("board.surface_height", board.surface_height, default_board.surface_height)?,
            yaw: number_or("board.yaw", board.yaw, default_board.yaw)?,
            base_clearance: number_or("board.base_clearance", board.base_clearance, default_board.base_clearance)?,
            squares_turned: board.squares_turned.unwrap_or(default_board.squares_turned),
        }
        .validated()?;
        let pick = |kind: &str, given: Option<PieceFile>, default: PieceDimensions| -> Result<PieceDimensions> {
            let Some(given) = given else { return Ok(default) };
            let field = |name: &str| format!("pieces.{kind}.{name}");
            let block = match given.head_block.as_deref() {
                None => default.shape.block(),
                Some([]) => None,
                Some(&[top, length, width]) => Some(Block { top, half_length: length, half_width: width }),
                Some(other) => bail!(
                    "{} = {other:?}: give [top, length, width] (fractions of height and base_diameter), or [] for none",
                    field("head_block")
                ),
            };
            let rings = given.outline.clone().unwrap_or_else(|| default.shape.rings().to_vec());
            let shape = Outline::new(&rings, block)
                .map_err(|e| anyhow::anyhow!("{} / {}: {e}", field("outline"), field("head_block")))?;
            if (shape.height() - 1.0).abs() > 1e-9 || shape.widest() > 1.0 + 1e-9 {
                bail!(
                    "{} reaches {} of the height and {} of the base_diameter: the profile's top must be at 1 and no \
                     part wider than the base (1)",
                    field("outline"),
                    shape.height(),
                    shape.widest()
                );
            }
            Ok(PieceDimensions {
                height: number_or(&field("height"), given.height, default.height)?,
                base_diameter: number_or(&field("base_diameter"), given.base_diameter, default.base_diameter)?,
                mass: number_or(&field("mass"), given.mass, default.mass)?,
                grip_height: number_or(&field("grip_height"), given.grip_height, default.grip_height)?,
                shape,
            })
        };
        let (given, default) = (&self.pieces, defaults.pieces);
        let pieces = PieceSet {
            pawn: pick("pawn", given.pawn.clone(), default.pawn)?,
            knight: pick("knight", given.knight.clone(), default.knight)?,
            bishop: pick("bishop", given.bishop.clone(), default.bishop)?,
            rook: pick("rook", given.rook.clone(), default.rook)?,
            queen: pick("queen", given.queen.clone(), default.queen)?,
            king: pick("king", given.king.clone(), default.king)?,
        }
        .validated()?;
        // A piece wider than a square would touch its neighbours where they stand.
        for (role, d) in pieces.all() {
            if d.base_diameter >= board.square_size {
                bail!(
                    "pieces.{}.base_diameter = {} m is not narrower than a square (board.square_size = {} m): a piece \
                     must fit its square (`chessarm board --fit` scales the pieces with the squares)",
                    chessarm_chess::pieces::role_name(role),
                    d.base_diameter,
                    board.square_size
                );
            }
        }
        for (name, profile) in &self.sensors {
            if chessarm_core::sense::SensorProfile::<4>::named(name).is_some() {
                bail!("sensors.{name}: a built-in profile has this name; choose another");
            }
            profile.to_profile(name)?;
        }
        if let Some(uncertainty) = &self.uncertainty {
            uncertainty.to_uncertainty()?;
        }
        crate::app::setup::actuators::check_tables(&self.actuators)?;
        let per_link: Vec<Option<&String>> = self.links.iter().map(|l| l.actuator.as_ref()).collect();
        let (names, what): (Vec<String>, &str) = match (&self.actuator, per_link.iter().any(Option::is_some)) {
            (Some(_), true) => bail!("actuator is given both at the top and in [[links]]: give it in one place"),
            (Some(ActuatorNames::One(name)), false) => (vec![name.clone()], "actuator"),
            (Some(ActuatorNames::Each(names)), false) => (names.clone(), "actuator"),
            (None, true) => (
                per_link
                    .iter()
                    .map(|n| n.cloned().unwrap_or_else(|| crate::app::setup::actuators::TORQUE.into()))
                    .collect(),
                "[[links]] actuator",
            ),
            (None, false) => (vec![crate::app::setup::actuators::TORQUE.into()], "actuator"),
        };
        let actuators = crate::app::setup::actuators::resolve(&names, &self.actuators, what)?;
        let actuator_names: [String; 4] = std::array::from_fn(|j| names.get(j).unwrap_or(&names[0]).clone());
        Ok(Setup {
            arm,
            board,
            pieces,
            sensor_profiles: self.sensors.clone(),
            uncertainty: self.uncertainty.clone(),
            path: None,
            urdf_path: None,
            joint_names: default_joint_names(),
            base_link: "base_link".into(),
            convention: JointConvention::default(),
            urdf: self.urdf.clone(),
            actuators,
            actuator_names,
            actuator_tables: self.actuators.clone(),
            servo_bus: self.servo_bus.clone(),
            servo_commands: vec![Default::default()],
            bus_rate: DEFAULT_BUS_RATE,
            motion: self.motion.to_limits(&self.gripper, &defaults.motion)?,
            timing: TimingMode::default(),
            clearance: self.gripper.to_clearance(&self.motion, &defaults.clearance)?,
        })
    }
}

impl LinkFile {
    /// Link `number` (1-based) of the file over `default`, each given number checked finite.
    fn to_link(&self, number: usize, default: &Link) -> Result<Link> {
        let field = |name: &str| format!("link {number} {name}");
        let inertial = &default.inertial;
        let com = numbers_or(&field("com"), self.com.as_ref(), "x, y, z in m", inertial.com.into())?;
        // The tensor as given (or the default link's), then turned by `inertia_rpy` if given:
        // alone, it rotates the default tensor (e.g. the report's, exported with the link along y).
        let tensor = match &self.inertia {
            None => inertial.inertia,
            Some(rows) => {
                if rows.len() != 3 {
                    bail!("{} has {} rows; it needs 3 rows of 3 numbers", field("inertia"), rows.len());
                }
                let mut tensor = Matrix3::zeros();
                for (r, row) in rows.iter().enumerate() {
                    let row = numbers::<3>(&format!("{}[{r}]", field("inertia")), row, "a row of the tensor")?;
                    for (c, value) in row.iter().enumerate() {
                        tensor[(r, c)] = *value;
                    }
                }
                tensor
            }
        };
        let inertia = match &self.inertia_rpy {
            None => tensor,
            Some(rpy) => match numbers::<3>(&field("inertia_rpy"), rpy, "roll, pitch, yaw in rad")? {
                // No rotation: the tensor exactly as written (R I Rᵀ with R = E would turn a
                // -0.0 into 0.0, so `chessarm arm` would not print back what it read).
                [0.0, 0.0, 0.0] => tensor,
                [roll, pitch, yaw] => {
                    let rotation = Rotation3::from_euler_angles(roll, pitch, yaw);
                    rotation.matrix() * tensor * rotation.matrix().transpose()
                }
            },
        };
        Ok(Link {
            dh: DhParameters {
                a: number_or(&field("a"), self.a, default.dh.a)?,
                alpha: number_or(&field("alpha"), self.alpha, default.dh.alpha)?,
                d: number_or(&field("d"), self.d, default.dh.d)?,
                theta_offset: number_or(&field("theta_offset"), self.theta_offset, default.dh.theta_offset)?,
            },
            inertial: Inertial {
                mass: number_or(&field("mass"), self.mass, inertial.mass)?,
                com: Vector3::from(com),
                inertia,
            },
            motor_mass: number_or(&field("motor_mass"), self.motor_mass, default.motor_mass)?,
            rotor_inertia: number_or(&field("rotor_inertia"), self.rotor_inertia, default.rotor_inertia)?,
            limits: JointLimits {
                lower: number_or(&field("lower"), self.lower, default.limits.lower)?,
                upper: number_or(&field("upper"), self.upper, default.limits.upper)?,
                velocity: number_or(&field("velocity_limit"), self.velocity_limit, default.limits.velocity)?,
                torque: number_or(&field("torque_limit"), self.torque_limit, default.limits.torque)?,
            },
            friction: Friction {
                viscous: number_or(&field("viscous"), self.viscous, default.friction.viscous)?,
                coulomb: number_or(&field("coulomb"), self.coulomb, default.friction.coulomb)?,
            },
        })
    }
}

impl From<&Setup> for SetupFile {
    fn from(setup: &Setup) -> Self {
        let links = setup
            .arm
            .links()
            .iter()
            .map(|link| LinkFile {
                a: Some(link.dh.a),
                alpha: Some(link.dh.alpha),
                d: Some(link.dh.d),
                theta_offset: Some(link.dh.theta_offset),
                mass: Some(link.inertial.mass),
                com: Some(link.inertial.com.iter().copied().collect()),
                inertia: Some((0..3).map(|r| (0..3).map(|c| link.inertial.inertia[(r, c)]).collect()).collect()),
                inertia_rpy: Some(vec![0.0; 3]),
                motor_mass: Some(link.motor_mass),
                rotor_inertia: Some(link.rotor_inertia),
                lower: Some(link.limits.lower),
                upper: Some(link.limits.upper),
                velocity_limit: Some(link.limits.velocity),
                torque_limit: Some(link.limits.torque),
                viscous: Some(link.friction.viscous),
                coulomb: Some(link.friction.coulomb),
                actuator: None,
            })
            .collect();
        // The profile only where it is not the kind's built-in one.
        let built_in = PieceSet::default();
        let piece = |d: &PieceDimensions, built_in: &PieceDimensions| {
            let own = built_in.shape != d.shape;
            Some(PieceFile {
                height: Some(d.height),
                base_diameter: Some(d.base_diameter),
                mass: Some(d.mass),
                grip_height: Some(d.grip_height),
                outline: own.then(|| d.shape.rings().to_vec()),
                head_block: own
                    .then(|| d.shape.block().map_or(Vec::new(), |b| vec![b.top, b.half_length, b.half_width])),
            })
        };
        let p = &setup.pieces;
        let m = &setup.motion;
        let base = setup.arm.base();
        SetupFile {
            base: (base != Vector3::zeros()).then(|| base.iter().copied().collect()),
            urdf: None,
            actuator: setup.actuator_names.iter().any(|n| n != crate::app::setup::actuators::TORQUE).then(|| {
                if setup.actuator_names.iter().all(|n| *n == setup.actuator_names[0]) {
                    ActuatorNames::One(setup.actuator_names[0].clone())
                } else {
                    ActuatorNames::Each(setup.actuator_names.to_vec())
                }
            }),
            actuators: setup.actuator_tables.clone(),
            servo_bus: setup.servo_bus.clone(),
            gravity: Some(setup.arm.gravity().iter().copied().collect()),
            board: BoardFile {
                square_size: Some(setup.board.square_size),
                center: Some(setup.board.center.iter().copied().collect()),
                surface_height: Some(setup.board.surface_height),
                yaw: (setup.board.yaw != 0.0).then_some(setup.board.yaw),
                base_clearance: Some(setup.board.base_clearance),
                squares_turned: setup.board.squares_turned.then_some(true),
            },
            pieces: PiecesFile {
                pawn: piece(&p.pawn, &built_in.pawn),
                knight: piece(&p.knight, &built_in.knight),
                bishop: piece(&p.bishop, &built_in.bishop),
                rook: piece(&p.rook, &built_in.rook),
                queen: piece(&p.queen, &built_in.queen),
                king: piece(&p.king, &built_in.king),
            },
            links,
            sensors: setup.sensor_profiles.clone(),
            uncertainty: setup.uncertainty.clone(),
            motion: MotionFile {
                tool_speed: Some(m.tool_speed),
                joint_acceleration: Some(OneOrEach::Each(m.joint_acceleration.to_vec())),
                torque_margin: Some(m.torque_margin),
                blend: Some(m.blend),
                grid_step: Some(m.grid_step),
                jerk: Some(m.jerk),
                tracking_budget: Some(m.tracking.budget),
                clearance_margin: Some(m.clearance_margin),
                max_tilt: Some(m.max_tilt),
                arm_clearance: Some(setup.clearance.margin),
                traverse_speed: Some(m.traverse_speed),
                traverse_acceleration: Some(m.traverse_acceleration),
                vertical_speed: Some(m.vertical_speed),
                vertical_acceleration: Some(m.vertical_acceleration),
                pause: Some(m.pause),
            },
            gripper: GripperFile {
                carry_acceleration: Some(m.carry_acceleration),
                grip_strength: Some(m.grip_strength),
                grip_dwell: Some(m.grip_dwell),
                release_dwell: Some(m.release_dwell),
                finger_length: Some(setup.clearance.gripper.finger_length),
                finger_reach: Some(setup.clearance.gripper.finger_reach),
                finger_thickness: Some(setup.clearance.gripper.finger_thickness),
                finger_width: Some(setup.clearance.gripper.finger_width),
                finger_opening: Some(setup.clearance.gripper.finger_opening),
            },
        }
    }
}
