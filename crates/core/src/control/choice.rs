//! Which controller a run uses, built from its settings: the one place the CLI, the game
//! runner and the Monte-Carlo trials turn a name into a controller.

use super::adaptive::AdaptiveComputedTorque;
use super::computed_torque::{AntiWindup, ComputedTorque};
use super::disturbance_observer::DisturbanceObserver;
use super::gains::{GainError, Gains};
use super::servo_host::{Drives, ServoCommand, ServoHost};
use super::{CommandInterface, Controller};
use crate::arm::model::{ArmModel, ModelError};

/// The controllers behind the [`Controller`] trait.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ControllerKind {
    /// Computed torque with a PD outer loop, or the report's plain PID when the gains have an
    /// integral term (kept to reproduce the report's start-up wind-up).
    ComputedTorque,
    /// Computed torque with a PID outer loop and the default anti-windup
    /// ([`AntiWindup::default`]).
    AntiWindupPid,
    /// Computed torque that estimates the gripped payload online ([`AdaptiveComputedTorque`]).
    Adaptive,
    /// Computed torque with a disturbance observer ([`DisturbanceObserver`]).
    DisturbanceObserver,
    /// The host of a servo arm, sending goal positions by this strategy ([`ServoHost`]); its
    /// gains are not used (the servos' loops are the servos').
    ServoHost(ServoCommand),
}

/// Why a controller cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BuildError {
    #[error(transparent)]
    Gain(#[from] GainError),
    #[error(transparent)]
    Model(#[from] ModelError),
    #[error(
        "controller {name} sends joint torques but the joints have position servos: choose the host's goals with --servo-command plain|sag|feedforward"
    )]
    TorqueToServos { name: String },
    #[error(
        "the servo host ({name}) sends goal positions but the joints have torque motors: give the servos with --actuator"
    )]
    GoalsToTorqueMotors { name: String },
}

/// A controller to build: its report name, kind and outer-loop gains.
#[derive(Debug, Clone, PartialEq)]
pub struct ControllerSpec {
    pub name: String,
    pub kind: ControllerKind,
    pub gains: Gains<4>,
    /// Whether the controller is told the arm's friction (its model's `viscous`, `coulomb`)
    /// and compensates it; otherwise its model has none.
    pub knows_friction: bool,
}

impl ControllerSpec {
    /// The controller, using `model` as its model of the arm. Refuses gains the kind cannot
    /// use (an integral gain for the adaptive controller or the disturbance observer).
    pub fn build(&self, model: ArmModel<4>) -> Result<Box<dyn Controller<4>>, GainError> {
        let model = if self.knows_friction || !model.has_friction() {
            model
        } else {
            let mut links = *model.links();
            for link in &mut links {
                link.friction = Default::default();
            }
            // The same links without friction: valid whenever the model was.
            model.with_links(links).unwrap_or(model)
        };
        Ok(match self.kind {
            ControllerKind::ComputedTorque => Box::new(ComputedTorque::new(self.name.clone(), model, self.gains)),
            ControllerKind::AntiWindupPid => Box::new(
                ComputedTorque::new(self.name.clone(), model, self.gains).with_anti_windup(AntiWindup::default())?,
            ),
            ControllerKind::Adaptive => Box::new(AdaptiveComputedTorque::new(model).with_gains(self.gains)?),
            ControllerKind::DisturbanceObserver => Box::new(DisturbanceObserver::new(model).with_gains(self.gains)?),
            // Without servos' numbers: a host of ideal servos is not what anyone builds.
            ControllerKind::ServoHost(_) => {
                return Err(GainError::Invalid {
                    name: format!("{} (a servo host needs the servos: ControllerSpec::build_for)", self.name),
                    value: 0.0,
                    reason: "not a torque controller",
                });
            }
        })
    }

    /// The controller for joints driven by `actuators` (the run's actuators beside the plant):
    /// [`ControllerSpec::build`] for torque motors, the [`ServoHost`] of the spec's strategy for
    /// servos; refuses a torque controller on servos and a host on torque motors.
    pub fn build_for(
        &self,
        model: ArmModel<4>,
        actuators: &impl Drives<4>,
    ) -> Result<Box<dyn Controller<4>>, BuildError> {
        match (self.kind, actuators.interface() == CommandInterface::Position) {
            (ControllerKind::ServoHost(command), true) => Ok(Box::new(ServoHost::new(command, model, *actuators)?)),
            (ControllerKind::ServoHost(_), false) => Err(BuildError::GoalsToTorqueMotors { name: self.name.clone() }),
            (_, true) => Err(BuildError::TorqueToServos { name: self.name.clone() }),
            (_, false) => Ok(self.build(model)?),
        }
    }
}
