//! Controllers behind one trait. A controller owns its own model of the arm, which may differ
//! from the plant's (the plant may carry a payload the controller does not know about).

/// The [`Controller`] methods that every law computing with its own model of the arm (a field
/// `model`) and keeping the acceleration it last asked for (a field `commanded`) implements
/// alike: its terms at the measured state computed for [`Controller::command_with_terms`], a
/// payload given to its model, and both fields handed out. A macro because these are trait
/// methods of each law's own `impl` (a function cannot stand in for them).
macro_rules! model_based_controller_methods {
    () => {
        fn command(
            &mut self,
            state: &$crate::control::JointState<N>,
            reference: &$crate::control::Reference<N>,
            period: f64,
        ) -> $crate::arm::model::JointVector<N> {
            let terms = $crate::arm::dynamics::DynamicsTerms::new(&self.model, &state.q, &state.qd);
            self.command_with_terms(state, reference, period, &terms)
        }

        fn set_payload(
            &mut self,
            payload: Option<$crate::arm::model::Payload>,
        ) -> Result<(), $crate::arm::model::ModelError> {
            self.model = self.model.with_payload(payload)?;
            Ok(())
        }

        fn commanded_acceleration(&self) -> Option<$crate::arm::model::JointVector<N>> {
            Some(self.commanded)
        }

        fn dynamics_model(&self) -> Option<&$crate::arm::model::ArmModel<N>> {
            Some(&self.model)
        }
    };
}
use model_based_controller_methods;

pub mod adaptive;
pub mod choice;
pub mod computed_torque;
pub mod disturbance_observer;
pub mod gains;
pub mod servo_host;

use crate::arm::dynamics::DynamicsTerms;
use crate::arm::model::{ArmModel, JointVector, ModelError, Payload};

/// `torque` plus the compensation of the friction in `model`, if it has any:
/// `τ + b q̇ + c tanh(q̇/ε)` (the opposite of [`crate::arm::dynamics::friction_torques`]). A
/// controller whose model has no friction (the default: the plant's friction is unknown to it)
/// gets `torque` unchanged, bit for bit.
pub fn compensate_friction<const N: usize>(
    model: &ArmModel<N>,
    qd: &JointVector<N>,
    torque: JointVector<N>,
) -> JointVector<N> {
    if model.has_friction() { torque - crate::arm::dynamics::friction_torques(model, qd) } else { torque }
}

/// Measured joint state: angles (rad) and rates (rad/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointState<const N: usize> {
    pub q: JointVector<N>,
    pub qd: JointVector<N>,
}

impl<const N: usize> JointState<N> {
    /// At rest at `q`.
    pub fn at_rest(q: JointVector<N>) -> Self {
        Self { q, qd: JointVector::zeros() }
    }
}

/// Desired joint motion: angles (rad), rates (rad/s), accelerations (rad/s²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reference<const N: usize> {
    pub q: JointVector<N>,
    pub qd: JointVector<N>,
    pub qdd: JointVector<N>,
}

impl<const N: usize> Reference<N> {
    /// Holding still at `q`.
    pub fn hold(q: JointVector<N>) -> Self {
        Self { q, qd: JointVector::zeros(), qdd: JointVector::zeros() }
    }
}

/// What a controller sends to the joints' actuators (ros2_control's command interfaces).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CommandInterface {
    /// Joint torques, N·m, for torque motors ([`crate::sim::actuator::Actuator::Torque`]).
    Torque,
    /// Goal angles, rad, for position servos and steppers, which close their own loops.
    Position,
}

/// A joint-space controller sampled every `period` seconds: a feedback law sending torques,
/// or a servo host sending goal positions ([`Controller::interface`]).
pub trait Controller<const N: usize>: std::fmt::Debug + Send {
    /// Short name for reports, e.g. "pd".
    fn name(&self) -> &str;
    /// Clears internal state (integrators) before a new run.
    fn reset(&mut self);
    /// The command for the measured `state` and the `reference`, in the unit of
    /// [`Controller::interface`] (joint torques, N·m, for a torque controller; goal angles, rad,
    /// for a servo host); `period` is the sample time (s) over which it will be held.
    fn command(&mut self, state: &JointState<N>, reference: &Reference<N>, period: f64) -> JointVector<N>;
    /// What the command is: joint torques (the default; the torque motors apply them) or goal
    /// positions (position servos run their own loops on them, [`crate::sim::actuator`]).
    fn interface(&self) -> CommandInterface {
        CommandInterface::Torque
    }
    /// Tells the controller's model about a gripped payload (or its release).
    fn set_payload(&mut self, payload: Option<Payload>) -> Result<(), ModelError>;
    /// The gripper has just closed (`true`) or opened (`false`). Called at every grip and
    /// release, whether or not the controller is told the payload ([`Controller::set_payload`]):
    /// the robot knows when it grips, not what the piece weighs.
    fn gripper_changed(&mut self, _closed: bool) {}
    /// The joint acceleration the last command asks for, rad/s², as the controller's model
    /// predicts it (the outer loop's output `v` of computed torque): the input of a state
    /// estimator's motion model. `None`: the controller cannot say.
    fn commanded_acceleration(&self) -> Option<JointVector<N>> {
        None
    }
    /// The model the controller computes `M̂(q)` and `Ĉ q̇ + ĝ` with, if it uses one. When it
    /// equals the plant's model, the closed loop hands the plant's terms at the measured state
    /// to [`Controller::command_with_terms`] rather than have them computed twice.
    ///
    /// It may change only in [`Controller::set_payload`]: the closed loop compares it with the
    /// plant's at payload events only, and the batch simulator computes the terms of the model
    /// it had then (a debug build checks this every step).
    fn dynamics_model(&self) -> Option<&ArmModel<N>> {
        None
    }
    /// This controller as the plain computed-torque law, if it is one: a batch of such runs
    /// computes their laws for all lanes at once ([`crate::sim::batch`]), the same operations
    /// per lane, and hands back the integral and the latest `v` when a run ends
    /// ([`computed_torque::ComputedTorque`]'s `command_with_terms` on one run).
    fn as_computed_torque(&mut self) -> Option<&mut computed_torque::ComputedTorque<N>> {
        None
    }
    /// [`Controller::command`] with `terms`, the mass matrix and bias torques of
    /// [`Controller::dynamics_model`] at `state`, already computed. Must return exactly what
    /// `torque` would.
    fn command_with_terms(
        &mut self,
        state: &JointState<N>,
        reference: &Reference<N>,
        period: f64,
        _terms: &DynamicsTerms<N>,
    ) -> JointVector<N> {
        self.command(state, reference, period)
    }
}
