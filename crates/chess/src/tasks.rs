//! From a chess move to pick-and-place tasks, and from a task to a tool-tip path.
//!
//! A move becomes one to four tasks (captures clear the destination first, castling moves the
//! king then the rook, a promotion swaps the pawn for a piece from the graveyard or the
//! reserve). Each task becomes the report's pattern of straight moves: rise, traverse, descend
//! and grip, rise, traverse, descend and release, rise, with LSPB timing at the fastest the
//! speed and acceleration limits allow.

use crate::pieces::{PieceSet, piece_name};
use crate::table::{Location, Table, TableError};
use chessarm_core::arm::model::{ArmModel, JointVector};
use chessarm_core::arm::task::{IkError, TOOL_DOWN, inverse_kinematics};
use chessarm_core::nalgebra::{Vector2, Vector3};
use chessarm_core::plan::path::{CartesianPath, GripperAction, Segment};
use chessarm_core::plan::profile::ProfileError;
use chessarm_core::sim::actuator::Actuators;
use shakmaty::san::San;
use shakmaty::uci::UciMove;
use shakmaty::{CastlingMode, Chess, File, Move, Piece, Position, Role, Square};
use std::fmt;

/// Longest distance between two IK-checked points of a straight move, m.
const CHECK_STEP: f64 = 0.005;

/// What kind of chess move it is, as far as moving pieces is concerned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MoveKind {
    /// A piece moves to an empty square.
    Quiet,
    /// A piece takes the piece on its destination square.
    Capture,
    /// A pawn takes en passant: the taken pawn is not on the destination square.
    EnPassant,
    /// King and rook castle on the king's side (O-O).
    CastleKingside,
    /// King and rook castle on the queen's side (O-O-O).
    CastleQueenside,
    /// A pawn reaches the last rank on an empty square and is exchanged.
    Promotion,
    /// A pawn takes on the last rank and is exchanged.
    PromotionCapture,
}

impl MoveKind {
    /// Short name: "quiet", "capture", "en-passant", "castle-kingside", "castle-queenside",
    /// "promotion", "promotion-capture".
    pub fn name(&self) -> &'static str {
        match self {
            MoveKind::Quiet => "quiet",
            MoveKind::Capture => "capture",
            MoveKind::EnPassant => "en-passant",
            MoveKind::CastleKingside => "castle-kingside",
            MoveKind::CastleQueenside => "castle-queenside",
            MoveKind::Promotion => "promotion",
            MoveKind::PromotionCapture => "promotion-capture",
        }
    }
}

impl fmt::Display for MoveKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One pick-and-place: carry `piece` from `from` to `to`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Task {
    /// The piece carried.
    pub piece: Piece,
    /// Where it is picked up.
    pub from: Location,
    /// Where it is put down.
    pub to: Location,
}

impl fmt::Display for Task {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} from {} to {}", piece_name(self.piece), self.from, self.to)
    }
}

/// Why a move or task cannot be carried out.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TaskError {
    /// The move is not legal in the position.
    #[error("move {mv} is not legal in this position")]
    IllegalMove {
        /// The move in UCI notation.
        mv: String,
    },
    /// Drops (crazyhouse) have no pick-and-place here.
    #[error("move {mv} is a piece drop, which standard chess does not have")]
    UnsupportedMove {
        /// The move in UCI notation.
        mv: String,
    },
    /// The table does not hold the piece the rules expect.
    #[error("move {mv}: the rules have a {expected} on {location}, the table has {found}")]
    TableMismatch {
        /// The move (SAN and UCI).
        mv: String,
        /// Where the piece should be.
        location: Location,
        /// The piece the rules expect.
        expected: String,
        /// What the table holds there.
        found: String,
    },
    /// A promotion's new piece is neither in the graveyard nor in the reserve.
    #[error("move {mv}: no {piece} in the graveyard or the reserve to promote to")]
    MissingPiece {
        /// The move (SAN and UCI).
        mv: String,
        /// The piece needed, e.g. "white queen".
        piece: String,
    },
    /// A table operation failed while sequencing a move.
    #[error("move {mv}: {source}")]
    Table {
        /// The move (SAN and UCI).
        mv: String,
        /// The table's error.
        source: TableError,
    },
    /// A move would last so long that its trajectory could not be held in memory.
    #[error(
        "the move would last {} s at these limits ({samples:.3e} control periods, at most {max:.0e}): {binding}",
        chessarm_core::short_number(duration.round())
    )]
    TooLong { duration: f64, samples: f64, max: f64, binding: String },
    /// A motion limit is not usable.
    #[error("motion limit {field} = {value}: {reason}")]
    Limits {
        /// Field of [`MotionLimits`].
        field: &'static str,
        /// The offending value (m, s, m/s or m/s²).
        value: f64,
        /// What is required.
        reason: &'static str,
    },
    /// No piece stands where the task picks one up.
    #[error("task {task}: {source}")]
    TaskTable {
        /// The task.
        task: String,
        /// The table's error.
        source: TableError,
    },
    /// A point of the task's path is out of the arm's reach.
    #[error("task {task}: {source}")]
    Unreachable {
        /// The task.
        task: String,
        /// Why inverse kinematics failed.
        source: IkError,
    },
    /// The path's timing could not be built.
    #[error("task {task}: {source}")]
    Profile {
        /// The task.
        task: String,
        /// The profile's error.
        source: ProfileError,
    },
    /// A leg of a time-optimal motion cannot be timed within the limits.
    #[error("{0}")]
    Leg(chessarm_core::plan::optimal::LegError),
    /// A leg's geometry is unusable.
    #[error("{0}")]
    Geometry(chessarm_core::plan::geometric::GeometryError),
    /// The planned motion has no joint trajectory.
    #[error("{0}")]
    Trajectory(chessarm_core::plan::trajectory::PlanError),
    /// The planned motion exceeds a limit.
    #[error("{0}")]
    Violation(chessarm_core::plan::optimal::Violation),
    /// The arm cannot carry a piece.
    #[error("{0}")]
    Model(chessarm_core::arm::model::ModelError),
    /// A task of a move failed.
    #[error("move {mv}: {source}")]
    Move {
        /// The move (SAN and UCI).
        mv: String,
        /// The task's error.
        source: Box<TaskError>,
    },
}

/// The kind of a move played in `position`. shakmaty's [`Move`] carries the capture,
/// promotion and castling itself, so the position is not consulted; it is taken so that
/// callers need not know that.
pub fn classify(_position: &Chess, mv: &Move) -> MoveKind {
    match *mv {
        Move::Normal { capture, promotion, .. } => match (capture.is_some(), promotion.is_some()) {
            (true, true) => MoveKind::PromotionCapture,
            (false, true) => MoveKind::Promotion,
            (true, false) => MoveKind::Capture,
            (false, false) => MoveKind::Quiet,
        },
        Move::EnPassant { .. } => MoveKind::EnPassant,
        Move::Castle { king, rook } => {
            if rook.file() > king.file() {
                MoveKind::CastleKingside
            } else {
                MoveKind::CastleQueenside
            }
        }
        Move::Put { .. } => MoveKind::Quiet,
    }
}

/// A move for messages: SAN and UCI, e.g. "exd8=Q (e7d8q)".
pub fn describe_move(position: &Chess, mv: &Move) -> String {
    let uci = UciMove::from_move(*mv, CastlingMode::Standard);
    if position.is_legal(*mv) { format!("{} ({uci})", San::from_move(position, *mv)) } else { uci.to_string() }
}

/// The pick-and-place tasks of a legal move in `position` (side to move), in execution order,
/// given the table before the move:
///
/// - capture: the captured piece first, to the lowest free graveyard slot of its colour;
/// - en passant: the captured pawn (beside the destination) to the graveyard, then the pawn;
/// - castling: the king (to the g or c file), then the rook (to the f or d file);
/// - promotion: the captured piece (if any), the pawn to its colour's graveyard, then the new
///   piece from the graveyard if one of that kind and colour lies there, else from the reserve.
pub fn move_tasks(position: &Chess, mv: &Move, table: &Table) -> Result<Vec<Task>, TaskError> {
    if !position.is_legal(*mv) {
        return Err(TaskError::IllegalMove { mv: UciMove::from_move(*mv, CastlingMode::Standard).to_string() });
    }
    let name = describe_move(position, mv);
    let us = position.turn();
    let them = us.other();
    // The tasks are applied to a copy of the table as they are made, so later tasks see the
    // slots that earlier ones filled or freed.
    let mut scratch = table.clone();
    let mut tasks = Vec::new();
    let mut push = |scratch: &mut Table, piece: Piece, from: Location, to: Location| -> Result<(), TaskError> {
        let found = scratch.piece_at(from).map(|p| p.piece);
        if found != Some(piece) {
            return Err(TaskError::TableMismatch {
                mv: name.clone(),
                location: from,
                expected: piece_name(piece),
                found: found.map_or_else(|| "nothing".to_string(), |p| format!("a {}", piece_name(p))),
            });
        }
        let actual = scratch.nominal_position(to);
        scratch.relocate(from, to, actual).map_err(|source| TaskError::Table { mv: name.clone(), source })?;
        tasks.push(Task { piece, from, to });
        Ok(())
    };
    let to_graveyard = |scratch: &Table, color| {
        scratch
            .free_graveyard_slot(color)
            .map(|slot| Location::Graveyard { color, slot })
            .map_err(|source| TaskError::Table { mv: name.clone(), source })
    };
    match *mv {
        Move::Normal { role, from, capture, to, promotion } => {
            if let Some(captured) = capture {
                let grave = to_graveyard(&scratch, them)?;
                push(&mut scratch, captured.of(them), Location::Square(to), grave)?;
            }
            match promotion {
                None => push(&mut scratch, role.of(us), Location::Square(from), Location::Square(to))?,
                Some(new_role) => {
                    let grave = to_graveyard(&scratch, us)?;
                    push(&mut scratch, us.pawn(), Location::Square(from), grave)?;
                    let new_piece = new_role.of(us);
                    let source = scratch
                        .graveyard_slot_holding(new_piece)
                        .map(|slot| Location::Graveyard { color: us, slot })
                        .or_else(|| {
                            scratch.reserve_slot_holding(new_piece).map(|slot| Location::Reserve { color: us, slot })
                        })
                        .ok_or_else(|| TaskError::MissingPiece { mv: name.clone(), piece: piece_name(new_piece) })?;
                    push(&mut scratch, new_piece, source, Location::Square(to))?;
                }
            }
        }
        Move::EnPassant { from, to } => {
            let taken = Square::from_coords(to.file(), from.rank());
            let grave = to_graveyard(&scratch, them)?;
            push(&mut scratch, Role::Pawn.of(them), Location::Square(taken), grave)?;
            push(&mut scratch, us.pawn(), Location::Square(from), Location::Square(to))?;
        }
        Move::Castle { king, rook } => {
            let kingside = rook.file() > king.file();
            let (king_file, rook_file) = if kingside { (File::G, File::F) } else { (File::C, File::D) };
            let king_to = Square::from_coords(king_file, king.rank());
            let rook_to = Square::from_coords(rook_file, rook.rank());
            let king_task = (us.king(), Location::Square(king), Location::Square(king_to));
            let rook_task = (us.rook(), Location::Square(rook), Location::Square(rook_to));
            // King first; in Chess960 the king may land on its rook's square, then the rook goes first.
            let order = if king_to == rook { [rook_task, king_task] } else { [king_task, rook_task] };
            for (piece, from, to) in order {
                if from != to {
                    push(&mut scratch, piece, from, to)?;
                }
            }
        }
        Move::Put { .. } => {
            return Err(TaskError::UnsupportedMove { mv: UciMove::from_move(*mv, CastlingMode::Standard).to_string() });
        }
    }
    Ok(tasks)
}

/// The finest planning grid step, m: a 0.5 m leg then has 5 000 points (40 000 after the
/// planner's refinements), tens of MB of rows at most.
pub const MIN_GRID_STEP: f64 = 1e-4;
/// The longest grip or release dwell and pause between moves, s (see
/// [`MotionLimits::validated`]).
pub const MAX_WAIT: f64 = 60.0;

/// The most control periods a move's trajectory may have: 10⁷ (2.8 h at 1 kHz), 1.3 GB of
/// samples; a move that would last longer has a limit set far too low.
pub const MAX_MOVE_SAMPLES: f64 = 1e7;

/// The longest a move may last, s: ten minutes for one chess move means a limit set far too
/// low, and the move's simulation, records and hardware export grow with it (at the highest
/// export rate, 10 kHz, gigabytes a move).
pub const MAX_MOVE_DURATION: f64 = 600.0;

/// Speed, acceleration and timing limits of the pick-and-place motions.
///
/// The LSPB planner (the report's) uses the traverse and vertical limits and the pauses; the
/// time-optimal planner ([`crate::motion`]) uses the joint limits of the arm, the tool speed,
/// joint acceleration, torque margin, the gripper's limits and the blends. Both use the
/// clearance margin and the dwell times.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionLimits {
    /// Largest tool-tip speed on LSPB traverses, m/s.
    pub traverse_speed: f64,
    /// Largest tool-tip acceleration on LSPB traverses, m/s².
    pub traverse_acceleration: f64,
    /// Largest tool-tip speed on LSPB vertical moves (rise, descend), m/s.
    pub vertical_speed: f64,
    /// Largest tool-tip acceleration on LSPB vertical moves, m/s².
    pub vertical_acceleration: f64,
    /// Rest between consecutive LSPB moves, s (0 for none).
    pub pause: f64,
    /// Clearance between the lowest point of the tool or carried piece and the tallest piece
    /// passed over, m.
    pub clearance_margin: f64,
    /// Time the gripper needs to close, s (0 for none).
    pub grip_dwell: f64,
    /// Time the gripper needs to open, s (0 for none).
    pub release_dwell: f64,
    /// Largest tool-tip speed of time-optimal motions, m/s.
    pub tool_speed: f64,
    /// Largest |joint acceleration| of time-optimal motions, rad/s², per joint.
    pub joint_acceleration: [f64; 4],
    /// Share of each motor's torque limit a time-optimal plan may use (the rest is the
    /// feedback controller's headroom).
    pub torque_margin: f64,
    /// Largest tool acceleration while carrying a piece, m/s² (gravity not counted).
    pub carry_acceleration: f64,
    /// Largest `|p̈ − g|` the friction grip holds (its friction force over the piece's mass),
    /// m/s²: above `|g|`, or a piece slips even at rest.
    pub grip_strength: f64,
    /// Largest corner cut of a blend, m (0: stop at every corner).
    pub blend: f64,
    /// Planning grid step along the path, m.
    pub grid_step: f64,
    /// Largest jerk along the path of time-optimal motions, m/s³ (on lines, where the path
    /// parameter is the arc length, the tool's jerk from the timing): each leg's time-optimal
    /// law is smoothed by a moving average just long enough
    /// ([`chessarm_core::plan::geometric::TimedLeg`]). 0: no limit (acceleration steps).
    pub jerk: f64,
    /// The tracking error a carried piece of uncertain mass may add
    /// ([`chessarm_core::plan::constraints::TrackingBudget`]).
    pub tracking: Tracking,
    /// The tool's pitch for every grip, release and traverse, rad above the horizontal
    /// ([`TOOL_DOWN`] straight down): one pitch for the whole game, so a piece gripped upright
    /// is put down upright. [`crate::reach::check_table`] chooses it.
    pub pitch: f64,
    /// How far from straight down the tool may tilt, rad (`[motion] max_tilt`). A gripper
    /// whose jaws close across the arm's plane keeps its jaw faces vertical at any pitch (the
    /// pitch turns them about their own normal), so the grip holds as well tilted; what bounds
    /// the tilt is the fingers' slant towards the neighbouring squares and the piece's head
    /// against the palm: 30° leaves a finger 2 cm long within 1 cm of the piece's axis.
    pub max_tilt: f64,
}

/// The tracking budget of a carried piece and what it is derived from: the controller's
/// proportional gains and damping, and how far a piece's true mass may be from the nominal one
/// the controller is told. Off with a budget of 0 or where the mass error is 0.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Tracking {
    /// Largest tracking error the motion may add while carrying, m (0: no budget).
    pub budget: f64,
    /// The controller's proportional gains, 1/s².
    pub kp: [f64; 4],
    /// The largest overshoot factor of its joints' loops (1 at ζ ≥ 1).
    pub overshoot: f64,
    /// Per piece kind (pawn to king, shakmaty's `Role::ALL` order): the largest difference
    /// between a true and the nominal mass, kg.
    pub mass_error: [f64; 6],
    /// With position servos, their stiffnesses, N·m/rad (`kp` is then not used).
    pub stiffness: Option<[f64; 4]>,
}

impl Tracking {
    /// The budget for a computed-torque loop with `gains` (`ζ_j = kd_j / (2 √kp_j)`).
    pub fn with_gains(self, gains: &chessarm_core::control::gains::Gains<4>) -> Self {
        use chessarm_core::plan::constraints::TrackingBudget;
        let kp: [f64; 4] = std::array::from_fn(|j| gains.kp[j]);
        let overshoot = (0..4)
            .map(|j| TrackingBudget::<4>::overshoot_of(gains.kd[j] / (2.0 * gains.kp[j].sqrt())))
            .fold(1.0, f64::max);
        Self { kp, overshoot, stiffness: None, ..self }
    }

    /// The budget for the controller of `gains` driving `actuators`: torque motors'
    /// ([`Self::with_gains`]), servos' ([`Self::with_servos`]), or none for steppers (open
    /// loop: no gain to budget; the budget is off and their lost steps are counted instead).
    pub fn for_actuators(
        self,
        gains: &chessarm_core::control::gains::Gains<4>,
        actuators: &Actuators<4>,
        arm: &ArmModel<4>,
    ) -> Self {
        if !actuators.take_positions() {
            return self.with_gains(gains);
        }
        self.with_servos(actuators, arm).unwrap_or(Self { budget: 0.0, ..self })
    }

    /// The budget for position servos: their proportional loops' stiffnesses `K_j`, and the
    /// overshoot of the loop `I q̈ + c q̇ + K q` each closes with its back-EMF, gear and
    /// firmware derivative damping `c = kt²/R + b + kd kt V / R` on the armature and the link's
    /// own inertia `I = I_a + M_jj` at the model's zero angles (an estimate: `M_jj` changes
    /// with the pose). `None` unless every joint has a servo.
    pub fn with_servos(self, actuators: &Actuators<4>, arm: &ArmModel<4>) -> Option<Self> {
        use chessarm_core::plan::constraints::TrackingBudget;
        use chessarm_core::sim::actuator::Actuator;
        let mass = chessarm_core::arm::dynamics::mass_matrix(arm, &JointVector::<4>::zeros());
        let mut stiffness = [0.0; 4];
        let mut overshoot = 1.0f64;
        for (j, joint) in actuators.joints.iter().enumerate() {
            let Actuator::Servo(spec) = joint else { return None };
            stiffness[j] = spec.stiffness();
            let damping = spec.back_emf_damping() + spec.viscous_friction + spec.kd * spec.torque_per_duty();
            let inertia = spec.armature + mass[(j, j)];
            overshoot =
                overshoot.max(TrackingBudget::<4>::overshoot_of(damping / (2.0 * (stiffness[j] * inertia).sqrt())));
        }
        Some(Self { stiffness: Some(stiffness), overshoot, ..self })
    }

    /// Whether a piece of kind `role` has a budget to keep.
    pub fn applies_to(&self, role: shakmaty::Role) -> bool {
        let gains = self.stiffness.unwrap_or(self.kp);
        self.budget > 0.0 && self.mass_error[role as usize - 1] > 0.0 && gains.iter().all(|k| *k > 0.0)
    }
}

impl Default for MotionLimits {
    /// LSPB: 0.25 m/s and 0.8 m/s² on traverses, 0.15 m/s and 0.6 m/s² vertically, 0.25 s
    /// pauses. Both: 3 cm clearance, 0.3 s to grip and to release. Time-optimal: 1 m/s tool
    /// speed, 20 rad/s² per joint, 85 % of the torque limits, 5 m/s² while carrying, a grip
    /// holding twice a piece's weight (2 × 9.81 m/s²), blends cutting corners by up to 4 cm
    /// on a 5 mm grid.
    fn default() -> Self {
        Self {
            traverse_speed: 0.25,
            traverse_acceleration: 0.8,
            vertical_speed: 0.15,
            vertical_acceleration: 0.6,
            pause: 0.25,
            clearance_margin: 0.03,
            grip_dwell: 0.3,
            release_dwell: 0.3,
            tool_speed: 1.0,
            joint_acceleration: [20.0; 4],
            torque_margin: 0.85,
            carry_acceleration: 5.0,
            grip_strength: 2.0 * 9.81,
            blend: 0.04,
            grid_step: 0.005,
            jerk: 0.0,
            tracking: Tracking::default(),
            pitch: TOOL_DOWN,
            max_tilt: DEFAULT_MAX_TILT,
        }
    }
}

/// The default [`MotionLimits::max_tilt`], rad (30°).
pub const DEFAULT_MAX_TILT: f64 = std::f64::consts::FRAC_PI_6;

/// The largest [`MotionLimits::max_tilt`], rad (60°): beyond it the fingers lie closer to the
/// board than to upright, and a piece's head meets the palm.
pub const MAX_TILT: f64 = std::f64::consts::FRAC_PI_3;

impl MotionLimits {
    /// The limits at pace `k`: the motion's own limits as a uniform speed-up by `k` would
    /// scale them (tool speed by `k`, joint and carry accelerations by `k²`, the jerk by `k³`),
    /// the LSPB speeds by `k` and accelerations by `k²`. The arm's joint speeds and torques,
    /// the torque margin, the grip, the dwells and the grid stay: above 1 they may bind, and
    /// the time falls by less than `1/k`.
    pub fn at_pace(self, k: f64) -> Self {
        let k2 = k * k;
        Self {
            traverse_speed: self.traverse_speed * k,
            traverse_acceleration: self.traverse_acceleration * k2,
            vertical_speed: self.vertical_speed * k,
            vertical_acceleration: self.vertical_acceleration * k2,
            tool_speed: self.tool_speed * k,
            joint_acceleration: self.joint_acceleration.map(|a| a * k2),
            carry_acceleration: self.carry_acceleration * k2,
            jerk: self.jerk * k2 * k,
            ..self
        }
    }

    /// Checks that speeds, accelerations, the margin and the grid step are finite and > 0,
    /// the pauses, dwells and blend finite and ≥ 0, and the torque margin in (0, 1].
    pub fn validated(self) -> Result<Self, TaskError> {
        let [a1, a2, a3, a4] = self.joint_acceleration;
        let positive = [
            ("traverse_speed", self.traverse_speed),
            ("traverse_acceleration", self.traverse_acceleration),
            ("vertical_speed", self.vertical_speed),
            ("vertical_acceleration", self.vertical_acceleration),
            ("clearance_margin", self.clearance_margin),
            ("tool_speed", self.tool_speed),
            ("joint_acceleration[1]", a1),
            ("joint_acceleration[2]", a2),
            ("joint_acceleration[3]", a3),
            ("joint_acceleration[4]", a4),
            ("carry_acceleration", self.carry_acceleration),
            ("grip_strength", self.grip_strength),
            ("grid_step", self.grid_step),
        ];
        for (field, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(TaskError::Limits { field, value, reason: "must be finite and > 0" });
            }
        }
        let non_negative = [
            ("pause", self.pause),
            ("grip_dwell", self.grip_dwell),
            ("release_dwell", self.release_dwell),
            ("blend", self.blend),
            ("jerk", self.jerk),
            ("tracking_budget", self.tracking.budget),
        ];
        for (field, value) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return Err(TaskError::Limits { field, value, reason: "must be finite and >= 0" });
            }
        }
        // The dwells and pauses are simulated step by step (and exported sample by sample): a
        // gripper that takes longer than a minute to close or open is no gripper, a pause of
        // more than a minute between a move's parts is no chess move, and either would size a
        // move's simulation and its files by the hour.
        let waits = [("grip_dwell", self.grip_dwell), ("release_dwell", self.release_dwell), ("pause", self.pause)];
        for (field, value) in waits {
            if value > MAX_WAIT {
                return Err(TaskError::Limits {
                    field,
                    value,
                    reason: "must be at most 60 s: a gripper closes or opens, and the arm rests, in well under a second",
                });
            }
        }
        if self.grid_step < MIN_GRID_STEP {
            return Err(TaskError::Limits {
                field: "grid_step",
                value: self.grid_step,
                reason: "must be at least 1e-4 m (0.1 mm): a finer grid only costs the planner memory and time",
            });
        }
        if !(self.max_tilt.is_finite() && (0.0..=MAX_TILT).contains(&self.max_tilt)) {
            return Err(TaskError::Limits {
                field: "max_tilt",
                value: self.max_tilt,
                reason: "must lie in [0, 1.0472] rad (0° to 60° from straight down)",
            });
        }
        if !(self.pitch.is_finite() && (self.pitch - TOOL_DOWN).abs() <= self.max_tilt + 1e-12) {
            return Err(TaskError::Limits {
                field: "pitch",
                value: self.pitch,
                reason: "must lie within max_tilt of straight down (-1.5708 rad)",
            });
        }
        if !(self.torque_margin > 0.0 && self.torque_margin <= 1.0) {
            return Err(TaskError::Limits {
                field: "torque_margin",
                value: self.torque_margin,
                reason: "must lie in (0, 1]",
            });
        }
        Ok(self)
    }

    /// The highest traverse any task can need, m above the table: the tallest piece, the
    /// margin, and the longest carried piece below the tool (the largest grip height).
    /// The top of the heights [`crate::reach::check_table`] checks.
    pub fn highest_traverse(&self, pieces: &PieceSet) -> f64 {
        pieces.tallest() + self.clearance_margin + pieces.highest_grip()
    }
}

/// Where the tool rests before the first move: above the middle of rank 1 at the highest
/// traverse height any task can need, m.
pub fn home_tool(board: &crate::board::BoardGeometry, pieces: &PieceSet, limits: &MotionLimits) -> Vector3<f64> {
    // Above the middle of rank 1, between d1 and e1.
    let home = board.on_table(0.0, -3.5);
    Vector3::new(home.x, home.y, board.surface_height + limits.highest_traverse(pieces))
}

/// Timing and heights of one planned task.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TaskPlan {
    /// Tool-tip height on both traverses, m above the table surface.
    pub traverse_height: f64,
    /// When the gripper closes on the piece, s from the path's start.
    pub grip_time: f64,
    /// When the gripper opens, s from the path's start.
    pub release_time: f64,
    /// Planned tool-tip position at release (x, y, z, m).
    pub release_point: Vector3<f64>,
}

/// Where a task picks and places, and at which heights (m above the table surface).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct TaskGeometry {
    pub traverse_height: f64,
    /// Where the piece stands and its target's centre (board plane, m).
    pub pick: Vector2<f64>,
    pub place: Vector2<f64>,
    /// Tool-tip height at the grip and the release (the piece's grip height).
    pub grip_z: f64,
    /// The table surface's height, m.
    pub surface: f64,
    /// How far from the tool's axis a piece counts as under it, m.
    pub radius: f64,
}

/// The heights of [`append_task_path`] for a task whose tool starts above `here`.
pub(crate) fn task_geometry(
    here: Vector2<f64>,
    task: &Task,
    table: &Table,
    pieces: &PieceSet,
    limits: &MotionLimits,
) -> Result<TaskGeometry, TaskError> {
    let standing = table
        .piece_at(task.from)
        .ok_or(TaskError::TaskTable { task: task.to_string(), source: TableError::Empty(task.from) })?;
    let carried = pieces.dimensions(task.piece.role);
    let pick = standing.position;
    let place = table.nominal_position(task.to);
    let radius = 0.5 * (carried.base_diameter + pieces.widest());
    let margin = limits.clearance_margin;
    let empty = table.tallest_under(here, pick, radius, pieces, None) + margin;
    let loaded = table.tallest_under(pick, place, radius, pieces, Some(task.from)) + margin + carried.grip_height;
    Ok(TaskGeometry {
        traverse_height: empty.max(loaded),
        pick,
        place,
        grip_z: carried.grip_height,
        surface: table.geometry().surface_height,
        radius,
    })
}

/// Extends `path` (which ends where the tool currently is) by one task: rise (or sink) to the
/// traverse height, traverse above `from`, descend to the grip height, mark
/// [`GripperAction::Grip`] and wait `grip_dwell`, rise, traverse above `to`, descend until the
/// piece's base touches the table, mark [`GripperAction::Release`] and wait `release_dwell`,
/// rise. Consecutive moves are separated by `pause`.
///
/// `table` is the table before this task (after the earlier tasks of the move). The piece is
/// picked where it actually stands and put on the nominal centre of `to`. The tool tip grips at
/// the piece's grip height above the table surface (`BoardGeometry::surface_height`).
///
/// Traverse height (above the table) = the largest of the tallest piece under the empty
/// traverse (towards `from`) + margin and the tallest piece under the loaded traverse
/// (`from` → `to`, the carried piece left out) + margin + the carried piece's grip height
/// (the length of piece below the tool). Pieces count as under a traverse when their base
/// centres lie within half the carried piece's base diameter plus half the widest base of the
/// set of it. Durations come from [`chessarm_core::plan::profile::Lspb::min_time`]; every
/// waypoint and points every 5 mm along each move are checked with inverse kinematics (tool
/// down) before anything is appended, so on error `path` is unchanged.
pub fn append_task_path(
    path: &mut CartesianPath,
    task: &Task,
    table: &Table,
    pieces: &PieceSet,
    limits: &MotionLimits,
    arm: &ArmModel<4>,
) -> Result<TaskPlan, TaskError> {
    let limits = limits.validated()?;
    let task_name = task.to_string();
    let start = path.end();
    let TaskGeometry { traverse_height, pick, place, grip_z, surface, .. } =
        task_geometry(Vector2::new(start.x, start.y), task, table, pieces, &limits)?;
    let here = Vector2::new(start.x, start.y);
    let at = |xy: Vector2<f64>, height: f64| Vector3::new(xy.x, xy.y, surface + height);
    // (target, vertical move?, gripper action at the end)
    let steps = [
        (at(here, traverse_height), true, None),
        (at(pick, traverse_height), false, None),
        (at(pick, grip_z), true, Some(GripperAction::Grip)),
        (at(pick, traverse_height), true, None),
        (at(place, traverse_height), false, None),
        (at(place, grip_z), true, Some(GripperAction::Release)),
        (at(place, traverse_height), true, None),
    ];

    let mut previous = start;
    for (target, _, _) in &steps {
        check_segment(arm, &previous, target, limits.pitch)
            .map_err(|source| TaskError::Unreachable { task: task_name.clone(), source })?;
        previous = *target;
    }

    let profile_error = |source| TaskError::Profile { task: task_name.clone(), source };
    let mut extended = path.clone();
    let mut grip_time = 0.0;
    let mut release_time = 0.0;
    for (target, vertical, action) in steps {
        if (target - extended.end()).norm() > 0.0 {
            let rested = matches!(extended.segments().last(), None | Some(Segment::Pause { .. }));
            if !rested && limits.pause > 0.0 {
                extended.pause(limits.pause).map_err(profile_error)?;
            }
            let (speed, acceleration) = if vertical {
                (limits.vertical_speed, limits.vertical_acceleration)
            } else {
                (limits.traverse_speed, limits.traverse_acceleration)
            };
            extended.move_to_limited(target, speed, acceleration).map_err(profile_error)?;
        }
        if let Some(action) = action {
            match action {
                GripperAction::Grip => grip_time = extended.duration(),
                GripperAction::Release => release_time = extended.duration(),
            }
            extended.mark(action);
            let dwell = match action {
                GripperAction::Grip => limits.grip_dwell,
                GripperAction::Release => limits.release_dwell,
            };
            if dwell > 0.0 {
                extended.pause(dwell).map_err(profile_error)?;
            }
        }
    }
    *path = extended;
    Ok(TaskPlan { traverse_height, grip_time, release_time, release_point: at(place, grip_z) })
}

/// Checks the straight move `from` → `to` with inverse kinematics (the tool at `pitch`, rad)
/// at its end and at points at most [`CHECK_STEP`] apart.
pub(crate) fn check_segment(
    arm: &ArmModel<4>,
    from: &Vector3<f64>,
    to: &Vector3<f64>,
    pitch: f64,
) -> Result<(), IkError> {
    let steps = ((to - from).norm() / CHECK_STEP).ceil().max(1.0) as usize;
    for k in 1..=steps {
        let point = from + (to - from) * (k as f64 / steps as f64);
        inverse_kinematics(arm, &point, pitch)?;
    }
    Ok(())
}

/// One task of a planned move with its plan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlannedTask {
    /// The pick-and-place.
    pub task: Task,
    /// Its heights and timing.
    pub plan: TaskPlan,
}

/// Plans every task of a legal move ([`move_tasks`]) into `path` with [`append_task_path`],
/// assuming each piece is released exactly on its nominal position (a copy of `table` is
/// updated between tasks; `table` itself is not changed). Errors name the move; on error `path`
/// is unchanged.
pub fn append_move_path(
    path: &mut CartesianPath,
    position: &Chess,
    mv: &Move,
    table: &Table,
    pieces: &PieceSet,
    limits: &MotionLimits,
    arm: &ArmModel<4>,
) -> Result<Vec<PlannedTask>, TaskError> {
    let tasks = move_tasks(position, mv, table)?;
    let wrap = |source: TaskError| TaskError::Move { mv: describe_move(position, mv), source: Box::new(source) };
    let mut scratch = table.clone();
    let mut extended = path.clone();
    let mut planned = Vec::with_capacity(tasks.len());
    for task in tasks {
        let plan = append_task_path(&mut extended, &task, &scratch, pieces, limits, arm).map_err(wrap)?;
        let actual = scratch.nominal_position(task.to);
        scratch
            .relocate(task.from, task.to, actual)
            .map_err(|source| wrap(TaskError::TaskTable { task: task.to_string(), source }))?;
        planned.push(PlannedTask { task, plan });
    }
    *path = extended;
    Ok(planned)
}
