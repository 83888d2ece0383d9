//! Which actuator drives each joint, as a setup file and `--actuator` name them: the built-in
//! servos (`chessarm_core::sim::actuator::profiles`), a user's own `[actuators.NAME]` tables,
//! or `torque` (a torque motor, today's plant). Units are SI as everywhere in a setup file
//! (rad, s, V, Ω, N·m); the P gain may be given as the firmware's register (`p_gain`), converted
//! here by the built-in servo it is `base`d on. With servos, the hosts that replace the torque
//! controllers and the bus's period are also decided here, for every command.

use crate::app::setup::file::Setup;
use anyhow::{Result, bail};
use chessarm_core::control::choice::{ControllerKind, ControllerSpec};
use chessarm_core::sim::actuator::{Actuator, Actuators, ServoSpec, profiles};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The name of a torque motor (today's plant).
pub const TORQUE: &str = "torque";

/// `[actuators.NAME]`: a servo of the user's, as a built-in one (`base`) with some numbers
/// changed, or every number given.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct ActuatorFile {
    /// The built-in actuator the rest changes (sts3215, sts3215-12v, xl430, xm430, mg996r; the
    /// stepper nema17).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub base: Option<String>,
    /// The P gain register's value (the base's conversion to duty per rad).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub p_gain: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub supply_voltage: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resistance: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub torque_constant: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_torque: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub armature: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coulomb_friction: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub viscous_friction: Option<f64>,
    /// rad.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub backlash: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub counts_per_revolution: Option<f64>,
    /// s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub period: Option<f64>,
    /// Duty per rad (instead of `p_gain`), per rad·s, per rad/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kp: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ki: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kd: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_duty: Option<f64>,
    /// rad.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub deadband: Option<f64>,
    /// rad/s and rad/s² (0: unlimited).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_target_speed: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_target_acceleration: Option<f64>,
    /// A stepper's: full steps per motor turn, microsteps per full step, motor turns per output
    /// turn, holding torque at the output (N·m), the speed above which its pull-out torque falls
    /// (rad/s at the output), and its step generator's speed (rad/s) and acceleration (rad/s²)
    /// limits. Any of them (or `base = "nema17"`) makes the table a stepper's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub steps_per_revolution: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub microsteps: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gear_ratio: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub holding_torque: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub corner_speed: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_speed: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_acceleration: Option<f64>,
}

impl ActuatorFile {
    /// The servo's own fields (what a stepper's table may not have): name, whether given.
    fn servo_fields(&self) -> [(&'static str, bool); 14] {
        [
            ("p_gain", self.p_gain.is_some()),
            ("supply_voltage", self.supply_voltage.is_some()),
            ("resistance", self.resistance.is_some()),
            ("torque_constant", self.torque_constant.is_some()),
            ("max_torque", self.max_torque.is_some()),
            ("backlash", self.backlash.is_some()),
            ("counts_per_revolution", self.counts_per_revolution.is_some()),
            ("kp", self.kp.is_some()),
            ("ki", self.ki.is_some()),
            ("kd", self.kd.is_some()),
            ("max_duty", self.max_duty.is_some()),
            ("deadband", self.deadband.is_some()),
            ("max_target_speed", self.max_target_speed.is_some()),
            ("max_target_acceleration", self.max_target_acceleration.is_some()),
        ]
    }

    /// The stepper's own fields, as (name, value).
    fn stepper_fields(&self) -> [(&'static str, Option<f64>); 7] {
        [
            ("steps_per_revolution", self.steps_per_revolution),
            ("microsteps", self.microsteps),
            ("gear_ratio", self.gear_ratio),
            ("holding_torque", self.holding_torque),
            ("corner_speed", self.corner_speed),
            ("max_speed", self.max_speed),
            ("max_acceleration", self.max_acceleration),
        ]
    }

    /// The actuator this table describes (a stepper's if it is based on one or has a
    /// stepper's field, else a servo's); `name` is its table's name, for messages.
    pub fn to_actuator(&self, name: &str) -> Result<Actuator> {
        let stepper_base = self.base.as_deref() == Some(profiles::NEMA17.name);
        let stepper_field = self.stepper_fields().iter().find(|(_, v)| v.is_some()).map(|(f, _)| *f);
        if !stepper_base && stepper_field.is_none() {
            return Ok(Actuator::Servo(self.to_spec(name)?));
        }
        let field = |f: &str| format!("actuators.{name}.{f}");
        if let Some((servo_field, _)) = self.servo_fields().iter().find(|(_, given)| *given) {
            bail!(
                "{} is a servo's; this table is a stepper's ({}): give a stepper's fields (steps_per_revolution, microsteps, gear_ratio, holding_torque, corner_speed, max_speed, max_acceleration, armature, coulomb_friction, viscous_friction, period)",
                field(servo_field),
                if stepper_base {
                    "base = \"nema17\"".to_string()
                } else {
                    format!("{} given", stepper_field.unwrap_or("?"))
                }
            );
        }
        if let Some(base) = &self.base
            && !stepper_base
        {
            bail!(
                "{} = \"{base}\" is a servo; a stepper's table is based on nema17 or gives every field",
                field("base")
            );
        }
        let b = stepper_base.then_some(profiles::NEMA17.spec);
        let take = |f: &str, given: Option<f64>, from_base: Option<f64>| -> Result<f64> {
            match (given, from_base) {
                (Some(v), _) if !v.is_finite() => bail!("{} = {v} is not a finite number", field(f)),
                (Some(v), _) => Ok(v),
                (None, Some(v)) => Ok(v),
                (None, None) => bail!("{} is missing: give it, or `base = \"nema17\"`", field(f)),
            }
        };
        let spec = chessarm_core::sim::actuator::StepperSpec {
            steps_per_revolution: take(
                "steps_per_revolution",
                self.steps_per_revolution,
                b.map(|s| s.steps_per_revolution),
            )?,
            microsteps: take("microsteps", self.microsteps, b.map(|s| s.microsteps))?,
            gear_ratio: take("gear_ratio", self.gear_ratio, b.map(|s| s.gear_ratio))?,
            holding_torque: take("holding_torque", self.holding_torque, b.map(|s| s.holding_torque))?,
            corner_speed: take("corner_speed", self.corner_speed, b.map(|s| s.corner_speed))?,
            armature: take("armature", self.armature, b.map(|s| s.armature))?,
            coulomb_friction: take("coulomb_friction", self.coulomb_friction, b.map(|s| s.coulomb_friction))?,
            viscous_friction: take("viscous_friction", self.viscous_friction, b.map(|s| s.viscous_friction))?,
            max_speed: take("max_speed", self.max_speed, b.map(|s| s.max_speed))?,
            max_acceleration: take("max_acceleration", self.max_acceleration, b.map(|s| s.max_acceleration))?,
            period: take("period", self.period, b.map(|s| s.period))?,
        };
        if let Some((f, value, reason)) = spec.invalid_field() {
            bail!("{} = {value}: {reason}", field(f));
        }
        Ok(Actuator::Stepper(spec))
    }

    /// The servo this table describes; `name` is its table's name, for messages.
    pub fn to_spec(&self, name: &str) -> Result<ServoSpec> {
        let field = |f: &str| format!("actuators.{name}.{f}");
        let base = match &self.base {
            Some(base) => Some(profiles::profile(base).ok_or_else(|| {
                anyhow::anyhow!(
                    "{} = \"{base}\" is not a built-in servo; the built-in ones are {}",
                    field("base"),
                    profiles::names().join(", ")
                )
            })?),
            None => None,
        };
        let take = |f: &str, given: Option<f64>, from_base: Option<f64>| -> Result<f64> {
            match (given, from_base) {
                (Some(v), _) if !v.is_finite() => bail!("{} = {v} is not a finite number", field(f)),
                (Some(v), _) => Ok(v),
                (None, Some(v)) => Ok(v),
                (None, None) => bail!("{} is missing: give it, or `base = \"NAME\"` of a built-in servo", field(f)),
            }
        };
        let b = base.map(|p| p.spec);
        let kp = match (self.p_gain, self.kp) {
            (Some(_), Some(_)) => bail!("{}: give p_gain (the register) or kp (duty per rad), not both", field("kp")),
            (Some(p), None) => {
                let Some(base) = base else {
                    bail!("{} needs `base` (its conversion to duty per rad is the base servo's)", field("p_gain"))
                };
                if !(p.is_finite() && p > 0.0) {
                    bail!("{} = {p} must be finite and > 0", field("p_gain"));
                }
                p * base.duty_per_rad_per_p
            }
            (None, kp) => take("kp", kp, b.map(|s| s.kp))?,
        };
        let spec = ServoSpec {
            supply_voltage: take("supply_voltage", self.supply_voltage, b.map(|s| s.supply_voltage))?,
            resistance: take("resistance", self.resistance, b.map(|s| s.resistance))?,
            torque_constant: take("torque_constant", self.torque_constant, b.map(|s| s.torque_constant))?,
            max_torque: take("max_torque", self.max_torque, b.map(|s| s.max_torque))?,
            armature: take("armature", self.armature, b.map(|s| s.armature))?,
            coulomb_friction: take("coulomb_friction", self.coulomb_friction, b.map(|s| s.coulomb_friction))?,
            viscous_friction: take("viscous_friction", self.viscous_friction, b.map(|s| s.viscous_friction))?,
            backlash: take("backlash", self.backlash, b.map(|s| s.backlash))?,
            counts_per_revolution: take(
                "counts_per_revolution",
                self.counts_per_revolution,
                b.map(|s| s.counts_per_revolution),
            )?,
            period: take("period", self.period, b.map(|s| s.period))?,
            kp,
            ki: take("ki", self.ki, b.map(|s| s.ki))?,
            kd: take("kd", self.kd, b.map(|s| s.kd))?,
            max_duty: take("max_duty", self.max_duty, b.map(|s| s.max_duty))?,
            deadband: take("deadband", self.deadband, b.map(|s| s.deadband))?,
            max_target_speed: take("max_target_speed", self.max_target_speed, b.map(|s| s.max_target_speed))?,
            max_target_acceleration: take(
                "max_target_acceleration",
                self.max_target_acceleration,
                b.map(|s| s.max_target_acceleration),
            )?,
        };
        if let Some((f, value, reason)) = spec.invalid_field() {
            bail!("{} = {value}: {reason}", field(f));
        }
        Ok(spec)
    }
}

/// The actuator called `name`: `torque`, a user's table, or a built-in servo (a user's table
/// of a built-in's name is refused when the file is read). `what` names where the name was
/// given, for messages.
pub fn actuator(name: &str, user: &BTreeMap<String, ActuatorFile>, what: &str) -> Result<Actuator> {
    if name == TORQUE {
        return Ok(Actuator::Torque);
    }
    if let Some(table) = user.get(name) {
        return table.to_actuator(name);
    }
    match profiles::actuator(name) {
        Some(actuator) => Ok(actuator),
        None => {
            let mut known: Vec<&str> = vec![TORQUE];
            known.extend(profiles::all_names());
            known.extend(user.keys().map(String::as_str));
            bail!("{what} = \"{name}\" is not an actuator; the known ones are {}", known.join(", "))
        }
    }
}

/// The actuators of the four joints from their names (one for all, or one per joint).
pub fn resolve(names: &[String], user: &BTreeMap<String, ActuatorFile>, what: &str) -> Result<Actuators<4>> {
    let names: Vec<&String> = match names.len() {
        1 => vec![&names[0]; 4],
        4 => names.iter().collect(),
        n => bail!("{what} has {n} names; give one for every joint or one per joint (4)"),
    };
    let mut joints = [Actuator::Torque; 4];
    for (joint, name) in joints.iter_mut().zip(&names) {
        *joint = actuator(name, user, what)?;
    }
    let actuators = Actuators { joints };
    // The time step is checked with the run's; here the kinds and the numbers.
    actuators.validate(1e-3).or_else(|e| match e {
        chessarm_core::sim::actuator::ActuatorError::Period { .. } => Ok(()),
        other => Err(other),
    })?;
    Ok(actuators)
}

/// The user's tables, checked: none named like a built-in actuator, each complete.
pub fn check_tables(user: &BTreeMap<String, ActuatorFile>) -> Result<()> {
    for (name, table) in user {
        if name == TORQUE || profiles::actuator(name).is_some() {
            bail!("actuators.{name}: a built-in actuator has this name; choose another (or `base = \"{name}\"`)");
        }
        table.to_actuator(name)?;
    }
    Ok(())
}

/// With servos, the hosts the setup's `--servo-command` asks for (their gains unused), with a
/// note on the terminal that they replace the torque controllers; `None` with torque motors.
pub fn servo_hosts(setup: &Setup) -> Option<Vec<ControllerSpec>> {
    setup.actuators.take_positions().then_some(())?;
    if !crate::json_output() {
        eprintln!(
            "servos ({}): the host sends goal positions at {} Hz ({}); the torque controllers are not used",
            setup.actuator_names.join(", "),
            setup.bus_rate,
            setup.servo_commands.iter().map(|c| c.name()).collect::<Vec<_>>().join(", ")
        );
    }
    Some(
        setup
            .servo_commands
            .iter()
            .map(|command| ControllerSpec {
                name: command.name().to_string(),
                kind: ControllerKind::ServoHost(*command),
                gains: chessarm_core::control::gains::Gains::uniform(1.0, 1.0, 0.0).expect("positive gains"),
                knows_friction: false,
            })
            .collect(),
    )
}

/// Whether a controller of `kind` cancels the inertia of the piece it is told of: every torque
/// controller and the `feedforward` host do; the `plain` host ignores the piece and `sag` only
/// its weight, so a carried piece's whole mass is their tracking budget's mass error.
pub fn cancels_inertia(kind: &ControllerKind) -> bool {
    !matches!(
        kind,
        ControllerKind::ServoHost(
            chessarm_core::control::servo_host::ServoCommand::Plain
                | chessarm_core::control::servo_host::ServoCommand::Sag
        )
    )
}

/// The controller's period: with servos, the bus's (`1 / --bus-rate`); else `torque_period`, s.
pub fn control_period(setup: &Setup, torque_period: f64) -> f64 {
    if setup.actuators.take_positions() { 1.0 / setup.bus_rate } else { torque_period }
}

/// Refuses, before any work, a bus period (`1 / --bus-rate`) that is not a whole number of the
/// simulation's time steps `dt` (`dt_flag` the flag that gave it, if one did): the simulated servos take
/// their goals at whole steps, and the simulation would refuse at its first move.
///
/// # Errors
///
/// The period is not a whole multiple of `dt`, naming both flags as typed.
pub fn check_bus_period(setup: &Setup, dt: f64, dt_flag: &str) -> anyhow::Result<()> {
    if !setup.actuators.take_positions() {
        return Ok(());
    }
    let period = 1.0 / setup.bus_rate;
    let ratio = period / dt;
    if ratio.round() < 1.0 || (ratio - ratio.round()).abs() > 1e-9 * ratio {
        let show = crate::app::resources::show;
        anyhow::bail!(
            "--bus-rate {} Hz (a goal every {} s) must be a whole multiple of the simulation's time step{dt_flag} {} s: \
             e.g. --bus-rate {}, or a smaller time step",
            show(setup.bus_rate),
            show(period),
            show(dt),
            show(1.0 / (ratio.round().max(1.0) * dt))
        );
    }
    Ok(())
}

/// `settings` driving the setup's servos or steppers (their host at the bus's period); left
/// as they are with torque motors.
pub fn drive(setup: &Setup, settings: &mut chessarm_chess::play::PlaySettings) {
    if setup.actuators.take_positions() {
        settings.actuators = setup.actuators;
        settings.control_period = 1.0 / setup.bus_rate;
    }
}

/// Each joint's servo's P register conversion, duty per rad per unit of the register: a
/// built-in servo's, or the `base`'s of a user's table (`None`: a torque motor, a stepper, or
/// a table without a base, whose P has no register to sweep).
pub fn p_register_conversions(setup: &Setup) -> [Option<f64>; 4] {
    std::array::from_fn(|j| {
        let name = &setup.actuator_names[j];
        let base = match setup.actuator_tables.get(name) {
            Some(table) => table.base.as_deref()?,
            None => name.as_str(),
        };
        profiles::profile(base).map(|p| p.duty_per_rad_per_p)
    })
}

/// `actuators` with every servo's P loop at the register value `p` (`conversions` from
/// [`p_register_conversions`]).
pub fn with_p_register(actuators: &Actuators<4>, conversions: &[Option<f64>; 4], p: f64) -> Actuators<4> {
    let mut out = *actuators;
    for (joint, conversion) in out.joints.iter_mut().zip(conversions) {
        if let (Actuator::Servo(spec), Some(conversion)) = (joint, conversion) {
            spec.kp = p * conversion;
        }
    }
    out
}

/// `[servo_bus]`: how the arm's four joint servos are addressed and how their position register
/// maps to the joint's angle: `ticks = zero_ticks + direction × q / count` (`q` in rad in the
/// setup's sense, a count `2π / counts_per_revolution`). Defaults: IDs 1–4 (the SO-101's and
/// the OpenManipulator-X's first four are 1–4 and 11–14: give yours), directions +1, the zero
/// at half a turn of counts (2048 of 4096, both vendors' centre).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct ServoBusFile {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ids: Option<Vec<u8>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub directions: Option<Vec<i8>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub zero_ticks: Option<Vec<f64>>,
    /// `feetech` or `dynamixel` (default: the servos' own: STS → Feetech, XL/XM → Dynamixel).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub protocol: Option<crate::app::bus::Protocol>,
    /// The gripper's servo, driven to `gripper_open_ticks` and `gripper_closed_ticks` as the
    /// plan opens and closes it (none: the gripper is not driven).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gripper_id: Option<u8>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gripper_open_ticks: Option<i64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gripper_closed_ticks: Option<i64>,
}

/// The servos' addresses and register mapping, checked ([`ServoBusFile`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoBus {
    pub ids: [u8; 4],
    pub directions: [f64; 4],
    pub zero_ticks: [f64; 4],
    /// Counts per output revolution of each joint's servo (a stepper's microsteps).
    pub counts_per_revolution: [f64; 4],
    /// The bus's protocol (`None`: the servos speak neither, e.g. a hobby PWM servo or a
    /// stepper; the goals are then only exported).
    pub protocol: Option<crate::app::bus::Protocol>,
    pub gripper: Option<crate::app::bus::driver::GripperServo>,
}

impl ServoBus {
    /// The setup's bus: its `[servo_bus]` table over the defaults, checked.
    pub fn of(setup: &Setup) -> Result<Self> {
        let counts_per_revolution = setup.actuators.joints.map(|a| a.counts_per_revolution().unwrap_or(f64::NAN));
        let file = setup.servo_bus.clone().unwrap_or_default();
        let four = |field: &str, n: usize| -> Result<()> {
            if n != 4 {
                bail!("servo_bus.{field} has {n} values; give one per arm joint (4)");
            }
            Ok(())
        };
        let ids: [u8; 4] = match &file.ids {
            Some(ids) => {
                four("ids", ids.len())?;
                std::array::from_fn(|j| ids[j])
            }
            None => [1, 2, 3, 4],
        };
        for (j, id) in ids.iter().enumerate() {
            if *id > 252 || ids[..j].contains(id) {
                bail!("servo_bus.ids = {ids:?}: IDs must be distinct and 0–252 (253–254 are the buses' own)");
            }
        }
        let directions: [f64; 4] = match &file.directions {
            Some(d) => {
                four("directions", d.len())?;
                if let Some(bad) = d.iter().find(|v| **v != 1 && **v != -1) {
                    bail!("servo_bus.directions = {d:?}: {bad} is not 1 or -1");
                }
                std::array::from_fn(|j| f64::from(d[j]))
            }
            None => [1.0; 4],
        };
        let zero_ticks: [f64; 4] = match &file.zero_ticks {
            Some(z) => {
                four("zero_ticks", z.len())?;
                if let Some(bad) = z.iter().find(|v| !(v.is_finite() && v.fract() == 0.0)) {
                    bail!("servo_bus.zero_ticks = {z:?}: {bad} is not a whole number of ticks");
                }
                std::array::from_fn(|j| z[j])
            }
            None => counts_per_revolution.map(|c| (c / 2.0).round()),
        };
        let protocol = file.protocol.or_else(|| {
            let of = |name: &String| {
                crate::app::bus::Protocol::of_servo(name).or_else(|| {
                    setup
                        .actuator_tables
                        .get(name)
                        .and_then(|t| t.base.as_deref())
                        .and_then(crate::app::bus::Protocol::of_servo)
                })
            };
            let each: Vec<Option<crate::app::bus::Protocol>> = setup.actuator_names.iter().map(of).collect();
            each[0].filter(|p| each.iter().all(|e| *e == Some(*p)))
        });
        let gripper = match (file.gripper_id, file.gripper_open_ticks, file.gripper_closed_ticks) {
            (None, None, None) => None,
            (Some(id), Some(open), Some(closed)) => {
                if id > 252 || ids.contains(&id) {
                    bail!("servo_bus.gripper_id = {id}: give an ID 0–252 that no joint's servo has ({ids:?})");
                }
                // The gripper's servo is taken to have both vendors' 12-bit register.
                for (field, tick) in [("gripper_open_ticks", open), ("gripper_closed_ticks", closed)] {
                    if !(0..=4095).contains(&tick) {
                        bail!("servo_bus.{field} = {tick}: a gripper servo's goal is a tick 0–4095");
                    }
                }
                Some(crate::app::bus::driver::GripperServo { id, open, closed })
            }
            _ => bail!("servo_bus: give gripper_id, gripper_open_ticks and gripper_closed_ticks together (or none)"),
        };
        let bus = Self { ids, directions, zero_ticks, counts_per_revolution, protocol, gripper };
        // Every angle the joint may take must be a tick of its servo's register (a joint that
        // turns a whole turn, ±π, may end on the register's wrap: each goal sent is checked too).
        for j in 0..4 {
            let (lower, upper) = setup.user_limits(j);
            let ticks = [bus.ticks(j, lower), bus.ticks(j, upper)];
            if let Some(tick) = ticks.iter().find(|t| !(**t >= 0.0 && **t <= counts_per_revolution[j])) {
                bail!(
                    "servo_bus.zero_ticks = {}: joint {}'s limits [{lower:.4}, {upper:.4}] rad reach tick {tick}, outside its \
                     servo's 0–{}; give the tick of the joint's zero",
                    zero_ticks[j],
                    j + 1,
                    counts_per_revolution[j] - 1.0
                );
            }
        }
        Ok(bus)
    }

    /// Joint `j`'s goal `q` (rad, the setup's sense) in ticks of its servo's position register.
    pub fn ticks(&self, j: usize, q: f64) -> f64 {
        let count = std::f64::consts::TAU / self.counts_per_revolution[j];
        self.zero_ticks[j] + self.directions[j] * (q / count).round()
    }

    /// Joint `j`'s angle (rad, the setup's sense) at tick `tick` of its servo's register
    /// ([`ServoBus::ticks`]' inverse on whole ticks).
    pub fn angle(&self, j: usize, tick: f64) -> f64 {
        let count = std::f64::consts::TAU / self.counts_per_revolution[j];
        self.directions[j] * (tick - self.zero_ticks[j]) * count
    }
}

/// The servo columns of a run's CSV (simulate's and play's): the goals and internal targets
/// (rad), duties (−1…1) and backlash gaps (rad) per joint.
pub fn servo_columns() -> impl Iterator<Item = String> {
    ["goal", "target", "duty", "gap"].into_iter().flat_map(|prefix| crate::app::output::numbered(prefix, 4))
}

/// Appends a record's [`servo_columns`] values (in the setup's sense), if servos drive it.
pub fn push_servo_values(
    row: &mut Vec<f64>,
    record: &chessarm_core::sim::StepRecord<4>,
    convention: &crate::app::setup::file::JointConvention,
) {
    if let Some(servo) = &record.servo {
        for part in [servo.goal, servo.target, servo.duty, servo.gap] {
            row.extend(convention.user(part));
        }
    }
}
