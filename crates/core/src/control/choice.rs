//! Which controller a run uses, built from its settings: the one place the CLI, the game
//! runner and the Monte-Carlo trials turn a name into a controller.

use super::Controller;
use super::adaptive::AdaptiveComputedTorque;
use super::computed_torque::{AntiWindup, ComputedTorque};
use super::disturbance_observer::DisturbanceObserver;
use super::gains::{GainError, Gains};
use crate::arm::model::ArmModel;

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
        })
    }
}
