//! Computed-torque control (feedback linearisation), report section "Computed-Torque
//! Linearization": `τ = M̂(q) (q̈_d + kd ė + kp e + ki ∫e) + N̂(q, q̇)` with `e = q_d − q` and
//! `N̂ = Ĉ q̇ + ĝ` from the controller's own model `M̂, N̂`. With a perfect model every joint's
//! error obeys `ë + kd ė + kp e (+ ki ∫e) = 0`.

use super::gains::Gains;
use super::{Controller, JointState, Reference};
use crate::arm::dynamics::DynamicsTerms;
use crate::arm::model::{ArmModel, JointVector, ModelError, Payload};

/// Computed-torque controller with a PD or PID outer loop.
#[derive(Debug, Clone)]
pub struct ComputedTorque<const N: usize> {
    name: String,
    model: ArmModel<N>,
    gains: Gains<N>,
    /// `∫e dt`, rad·s.
    integral: JointVector<N>,
}

impl<const N: usize> ComputedTorque<N> {
    /// A controller named `name` using `model` for `M̂` and `N̂`.
    pub fn new(name: impl Into<String>, model: ArmModel<N>, gains: Gains<N>) -> Self {
        Self { name: name.into(), model, gains, integral: JointVector::zeros() }
    }

    pub fn gains(&self) -> &Gains<N> {
        &self.gains
    }

    pub fn model(&self) -> &ArmModel<N> {
        &self.model
    }
}

impl<const N: usize> Controller<N> for ComputedTorque<N> {
    fn name(&self) -> &str {
        &self.name
    }

    fn reset(&mut self) {
        self.integral = JointVector::zeros();
    }

    fn torque(&mut self, state: &JointState<N>, reference: &Reference<N>, period: f64) -> JointVector<N> {
        let terms = DynamicsTerms::new(&self.model, &state.q, &state.qd);
        self.torque_with_terms(state, reference, period, &terms)
    }

    fn dynamics_model(&self) -> Option<&ArmModel<N>> {
        Some(&self.model)
    }

    fn torque_with_terms(
        &mut self,
        state: &JointState<N>,
        reference: &Reference<N>,
        period: f64,
        terms: &DynamicsTerms<N>,
    ) -> JointVector<N> {
        let error = reference.q - state.q;
        let error_rate = reference.qd - state.qd;
        if self.gains.has_integral() {
            self.integral += error * period;
        }
        let outer = reference.qdd
            + self.gains.kd.component_mul(&error_rate)
            + self.gains.kp.component_mul(&error)
            + self.gains.ki.component_mul(&self.integral);
        terms.mass_matrix * outer + terms.bias
    }

    fn set_payload(&mut self, payload: Option<Payload>) -> Result<(), ModelError> {
        self.model = self.model.with_payload(payload)?;
        Ok(())
    }
}
