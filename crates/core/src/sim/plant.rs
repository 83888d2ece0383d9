//! The simulated arm: true dynamics (the plant's own model, with payload and friction) and a
//! fixed-step fourth-order Runge–Kutta integrator of `ẋ = (q̇, q̈(q, q̇, τ))`.

use crate::arm::dynamics::{DynamicsError, forward_dynamics, forward_dynamics_from_chain};
use crate::arm::kinematics::FrameChain;
use crate::arm::model::{ArmModel, JointVector, ModelError, Payload};
use crate::control::JointState;

/// The physical arm being simulated.
#[derive(Debug, Clone)]
pub struct Plant<const N: usize> {
    model: ArmModel<N>,
}

impl<const N: usize> Plant<N> {
    pub fn new(model: ArmModel<N>) -> Self {
        Self { model }
    }

    pub fn model(&self) -> &ArmModel<N> {
        &self.model
    }

    /// Grips (`Some`) or releases (`None`) a payload at the tool.
    pub fn set_payload(&mut self, payload: Option<Payload>) -> Result<(), ModelError> {
        self.model = self.model.with_payload(payload)?;
        Ok(())
    }

    /// Joint accelerations under `torque` (N·m), rad/s².
    pub fn acceleration(
        &self,
        state: &JointState<N>,
        torque: &JointVector<N>,
    ) -> Result<JointVector<N>, DynamicsError> {
        forward_dynamics(&self.model, &state.q, &state.qd, torque)
    }

    /// One RK4 step of `dt` seconds with `torque` held constant (zero-order hold).
    pub fn rk4_step(
        &self,
        state: &JointState<N>,
        torque: &JointVector<N>,
        dt: f64,
    ) -> Result<JointState<N>, DynamicsError> {
        self.rk4_step_from_chain(state, &FrameChain::new(&self.model, &state.q), torque, dt)
    }

    /// [`Plant::rk4_step`] reusing forward kinematics at `state.q` for the first stage.
    pub fn rk4_step_from_chain(
        &self,
        state: &JointState<N>,
        chain: &FrameChain<N>,
        torque: &JointVector<N>,
        dt: f64,
    ) -> Result<JointState<N>, DynamicsError> {
        let derivative = |s: &JointState<N>| -> Result<JointState<N>, DynamicsError> {
            Ok(JointState { q: s.qd, qd: self.acceleration(s, torque)? })
        };
        let offset =
            |s: &JointState<N>, k: &JointState<N>, h: f64| JointState { q: s.q + k.q * h, qd: s.qd + k.qd * h };
        let k1 = JointState {
            q: state.qd,
            qd: forward_dynamics_from_chain(&self.model, chain, &state.q, &state.qd, torque)?,
        };
        let k2 = derivative(&offset(state, &k1, dt / 2.0))?;
        let k3 = derivative(&offset(state, &k2, dt / 2.0))?;
        let k4 = derivative(&offset(state, &k3, dt))?;
        Ok(JointState {
            q: state.q + (k1.q + k2.q * 2.0 + k3.q * 2.0 + k4.q) * (dt / 6.0),
            qd: state.qd + (k1.qd + k2.qd * 2.0 + k3.qd * 2.0 + k4.qd) * (dt / 6.0),
        })
    }
}
