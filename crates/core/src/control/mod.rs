//! Controllers behind one trait. A controller owns its own model of the arm, which may differ
//! from the plant's (the plant may carry a payload the controller does not know about).

pub mod computed_torque;
pub mod gains;

use crate::arm::model::{JointVector, ModelError, Payload};

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

/// A joint-space feedback controller sampled every `period` seconds.
pub trait Controller<const N: usize>: std::fmt::Debug + Send {
    /// Short name for reports, e.g. "pd".
    fn name(&self) -> &str;
    /// Clears internal state (integrators) before a new run.
    fn reset(&mut self);
    /// Torque command, N·m, for the measured `state` and the `reference`; `period` is the
    /// sample time (s) over which the command will be held.
    fn torque(&mut self, state: &JointState<N>, reference: &Reference<N>, period: f64) -> JointVector<N>;
    /// Tells the controller's model about a gripped payload (or its release).
    fn set_payload(&mut self, payload: Option<Payload>) -> Result<(), ModelError>;
}
