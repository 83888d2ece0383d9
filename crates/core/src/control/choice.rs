//! Which controller a run uses, built from its settings: the one place the CLI, the game
//! runner and the Monte-Carlo trials turn a name into a controller.

use super::Controller;
use super::computed_torque::ComputedTorque;
use super::gains::Gains;
use crate::arm::model::ArmModel;

/// The controllers behind the [`Controller`] trait.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ControllerKind {
    /// Computed torque with a PD outer loop, or PID when the gains have an integral term.
    ComputedTorque,
    /// Computed torque that estimates the gripped payload online.
    Adaptive,
    /// Computed torque with a disturbance observer.
    DisturbanceObserver,
}

/// A controller to build: its report name, kind and outer-loop gains.
#[derive(Debug, Clone, PartialEq)]
pub struct ControllerSpec {
    pub name: String,
    pub kind: ControllerKind,
    pub gains: Gains<4>,
}

impl ControllerSpec {
    /// The controller, using `model` as its model of the arm.
    pub fn build(&self, model: ArmModel<4>) -> Box<dyn Controller<4>> {
        match self.kind {
            ControllerKind::ComputedTorque | ControllerKind::Adaptive | ControllerKind::DisturbanceObserver => {
                Box::new(ComputedTorque::new(self.name.clone(), model, self.gains))
            }
        }
    }
}
