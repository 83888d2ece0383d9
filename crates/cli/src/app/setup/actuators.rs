//! Which actuator drives each joint, as a setup file and `--actuator` name them: the built-in
//! servos (`chessarm_core::sim::actuator::profiles`), a user's own `[actuators.NAME]` tables,
//! or `torque` (a torque motor, today's plant). Units are SI as everywhere in a setup file
//! (rad, s, V, Ω, N·m); the P gain may be given as the firmware's register (`p_gain`), converted
//! here by the built-in servo it is `base`d on; and the `[servo_bus]` table.

use anyhow::{Result, bail};
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
