//! The spread of the true actuators around their datasheet values: what differs from servo to
//! servo of one model (the winding, the gear's friction and backlash) and from bench to bench
//! (the supply's voltage), drawn per trial of a robustness study.
//!
//! A draw scales each servo's torque constant `kt` (the back-EMF constant with it: one
//! constant; and its current limit's torque, `max_torque`, with it), its winding resistance `R` and its gear friction (Coulomb and viscous, one
//! factor) by factors uniform in `[1 − r, 1 + r]`, draws its backlash uniformly from a range,
//! and scales the one supply voltage `V` that feeds every servo; a stepper's holding torque
//! (and with it its pull-out torque) and gear friction are scaled alike. The firmware's
//! constants (gains, counts, limits) are the ones written to the servo and are not drawn. The
//! host keeps the datasheet's values: it computes its goals from them.

use super::{Actuator, Actuators};
use crate::arm::model::ModelError;
use crate::arm::uncertainty::Range;
use crate::sense::rng::SeededRng;

/// How far the true actuators may lie from their datasheet values. Relative spreads are ± a
/// fraction of the nominal value (0.1: ±10 %); 0 draws nothing.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ActuatorSpread {
    /// ± relative error of each servo's torque constant (and back-EMF constant).
    pub torque_constant: f64,
    /// ± relative error of each servo's winding resistance.
    pub resistance: f64,
    /// ± relative error of the supply voltage, one draw for the whole arm.
    pub supply_voltage: f64,
    /// ± relative error of each actuator's gear friction (Coulomb and viscous together).
    pub friction: f64,
    /// Each servo's backlash, full width, rad (`None`: the datasheet's).
    pub backlash: Option<Range>,
    /// ± relative error of each stepper's holding torque.
    pub holding_torque: f64,
}

/// What a draw gave, per joint (factors: true / nominal), for reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrawnActuators<const N: usize> {
    pub supply_voltage_scale: f64,
    pub torque_constant_scale: [f64; N],
    pub resistance_scale: [f64; N],
    pub friction_scale: [f64; N],
    /// True backlash, rad (0 for a stepper or a torque motor).
    pub backlash: [f64; N],
    pub holding_torque_scale: [f64; N],
}

impl ActuatorSpread {
    /// Whether the spread draws nothing.
    pub fn is_none(&self) -> bool {
        *self == Self::default()
    }

    /// The spreads that apply to servos, as `(field, relative)`, and to steppers.
    fn relative_fields(&self) -> [(&'static str, f64); 5] {
        [
            ("torque_constant", self.torque_constant),
            ("winding_resistance", self.resistance),
            ("supply_voltage", self.supply_voltage),
            ("gear_friction", self.friction),
            ("holding_torque", self.holding_torque),
        ]
    }

    /// Checks every number, naming the field (`uncertainty.torque_constant`).
    pub fn validate(&self) -> Result<(), ModelError> {
        for (field, value) in self.relative_fields() {
            if !(value.is_finite() && (0.0..1.0).contains(&value)) {
                return Err(ModelError::InvalidField {
                    field: format!("uncertainty.{field}"),
                    value: value.to_string(),
                    reason: "must be a relative error in [0, 1)",
                });
            }
        }
        if let Some(range) = &self.backlash {
            range.validate("uncertainty.backlash", 0.0)?;
            if range.high >= 0.5 {
                return Err(ModelError::InvalidField {
                    field: "uncertainty.backlash".into(),
                    value: format!("[{}, {}]", range.low, range.high),
                    reason: "a servo's backlash must be below 0.5 rad",
                });
            }
        }
        Ok(())
    }

    /// Checks that the spread is for the actuators it will be drawn around: a servo's spread
    /// needs a servo, a stepper's a stepper (a spread that would draw nothing is refused, so a
    /// study never claims a spread it did not apply).
    pub fn check_for<const N: usize>(&self, actuators: &Actuators<N>) -> Result<(), ModelError> {
        let servos = actuators.joints.iter().any(|a| matches!(a, Actuator::Servo(_)));
        let steppers = actuators.joints.iter().any(|a| matches!(a, Actuator::Stepper(_)));
        let refuse = |field: &str, value: String, reason: &'static str| {
            Err(ModelError::InvalidField { field: format!("uncertainty.{field}"), value, reason })
        };
        if !servos {
            for (field, value) in &self.relative_fields()[..3] {
                if *value > 0.0 {
                    return refuse(field, value.to_string(), "is a servo's spread; no joint has a servo (--actuator)");
                }
            }
            if let Some(range) = &self.backlash {
                return refuse(
                    "backlash",
                    format!("[{}, {}]", range.low, range.high),
                    "is a servo's spread; no joint has a servo (--actuator)",
                );
            }
        }
        if !servos && !steppers && self.friction > 0.0 {
            return refuse(
                "gear_friction",
                self.friction.to_string(),
                "is a servo's or stepper's spread; the joints have torque motors (--actuator)",
            );
        }
        if !steppers && self.holding_torque > 0.0 {
            return refuse(
                "holding_torque",
                self.holding_torque.to_string(),
                "is a stepper's spread; no joint has a stepper (--actuator)",
            );
        }
        Ok(())
    }

    /// The true actuators of one draw from `rng` around `nominal`, and what was drawn. The
    /// draws come in a fixed order (the supply voltage, then per joint: torque constant,
    /// resistance, friction, backlash, holding torque, each only where it applies and its
    /// spread is not zero), so a seed gives one set of actuators.
    pub fn draw<const N: usize>(
        &self,
        nominal: &Actuators<N>,
        rng: &mut SeededRng,
    ) -> Result<(Actuators<N>, DrawnActuators<N>), ModelError> {
        self.validate()?;
        let factor = |r: f64, rng: &mut SeededRng| Range::new(1.0 - r, 1.0 + r).draw(rng);
        let mut drawn = DrawnActuators {
            supply_voltage_scale: factor(self.supply_voltage, rng),
            torque_constant_scale: [1.0; N],
            resistance_scale: [1.0; N],
            friction_scale: [1.0; N],
            backlash: [0.0; N],
            holding_torque_scale: [1.0; N],
        };
        let mut actuators = *nominal;
        for (j, joint) in actuators.joints.iter_mut().enumerate() {
            match joint {
                Actuator::Torque => {}
                Actuator::Servo(spec) => {
                    let (kt, r, friction) =
                        (factor(self.torque_constant, rng), factor(self.resistance, rng), factor(self.friction, rng));
                    let backlash = self.backlash.map_or(spec.backlash, |range| range.draw(rng));
                    spec.supply_voltage *= drawn.supply_voltage_scale;
                    spec.torque_constant *= kt;
                    // The firmware limits the current: the torque it lets through scales with kt.
                    spec.max_torque *= kt;
                    spec.resistance *= r;
                    spec.coulomb_friction *= friction;
                    spec.viscous_friction *= friction;
                    spec.backlash = backlash;
                    drawn.torque_constant_scale[j] = kt;
                    drawn.resistance_scale[j] = r;
                    drawn.friction_scale[j] = friction;
                    drawn.backlash[j] = backlash;
                }
                Actuator::Stepper(spec) => {
                    let friction = factor(self.friction, rng);
                    let holding = factor(self.holding_torque, rng);
                    spec.coulomb_friction *= friction;
                    spec.viscous_friction *= friction;
                    spec.holding_torque *= holding;
                    drawn.friction_scale[j] = friction;
                    drawn.holding_torque_scale[j] = holding;
                }
            }
        }
        Ok((actuators, drawn))
    }
}
