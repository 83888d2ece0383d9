//! The simulated arm: true dynamics (the plant's own model, with payload and friction) and
//! fixed-step integrators of `ẋ = (q̇, q̈(q, q̇, τ))` (fourth-order Runge–Kutta by default).

use crate::arm::dynamics::{DynamicsError, DynamicsTerms, forward_dynamics};
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

    /// The plant's mass matrix and bias torques at `state`.
    pub fn dynamics_terms(&self, state: &JointState<N>) -> DynamicsTerms<N> {
        DynamicsTerms::new(&self.model, &state.q, &state.qd)
    }

    /// One classical RK4 step of `dt` seconds with `torque` held constant (zero-order hold).
    pub fn rk4_step(
        &self,
        state: &JointState<N>,
        torque: &JointVector<N>,
        dt: f64,
    ) -> Result<JointState<N>, DynamicsError> {
        self.step(state, &self.dynamics_terms(state), torque, dt, Integrator::RungeKutta4)
    }

    /// One step of `dt` seconds with `torque` held constant, by `integrator`. `terms` are the
    /// plant's [`Plant::dynamics_terms`] at `state` (the first stage of every method), passed in
    /// so a caller that needs them anyway computes them once.
    pub fn step(
        &self,
        state: &JointState<N>,
        terms: &DynamicsTerms<N>,
        torque: &JointVector<N>,
        dt: f64,
        integrator: Integrator,
    ) -> Result<JointState<N>, DynamicsError> {
        let derivative = |s: &JointState<N>| -> Result<JointState<N>, DynamicsError> {
            Ok(JointState { q: s.qd, qd: self.acceleration(s, torque)? })
        };
        let offset =
            |s: &JointState<N>, k: &JointState<N>, h: f64| JointState { q: s.q + k.q * h, qd: s.qd + k.qd * h };
        let k1 = JointState { q: state.qd, qd: terms.acceleration(&self.model, &state.q, &state.qd, torque)? };
        Ok(match integrator {
            Integrator::RungeKutta4 => {
                let k2 = derivative(&offset(state, &k1, dt / 2.0))?;
                let k3 = derivative(&offset(state, &k2, dt / 2.0))?;
                let k4 = derivative(&offset(state, &k3, dt))?;
                JointState {
                    q: state.q + (k1.q + k2.q * 2.0 + k3.q * 2.0 + k4.q) * (dt / 6.0),
                    qd: state.qd + (k1.qd + k2.qd * 2.0 + k3.qd * 2.0 + k4.qd) * (dt / 6.0),
                }
            }
            Integrator::Midpoint => offset(state, &derivative(&offset(state, &k1, dt / 2.0))?, dt),
            Integrator::SemiImplicitEuler => {
                let qd = state.qd + k1.qd * dt;
                JointState { q: state.q + qd * dt, qd }
            }
        })
    }
}

/// How the plant's state advances over one step of `dt` with the torque held (zero-order hold).
/// Costs are in evaluations of the forward dynamics per step; the first one is shared with
/// the controller when its model equals the plant's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Integrator {
    /// Classical fourth-order Runge–Kutta: 4 evaluations, global error O(dt⁴).
    #[default]
    RungeKutta4,
    /// Explicit midpoint rule, a second-order Runge–Kutta method:
    /// `x⁺ = x + dt f(x + dt/2 · f(x))`; 2 evaluations, global error O(dt²).
    Midpoint,
    /// Semi-implicit (symplectic) Euler, the default of MuJoCo and most game engines:
    /// `q̇⁺ = q̇ + dt q̈(q, q̇)`, `q⁺ = q + dt q̇⁺`; 1 evaluation, global error O(dt).
    SemiImplicitEuler,
}

impl Integrator {
    pub const ALL: [Integrator; 3] = [Integrator::RungeKutta4, Integrator::Midpoint, Integrator::SemiImplicitEuler];

    /// Short name, as the CLI spells it.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::RungeKutta4 => "rk4",
            Integrator::Midpoint => "midpoint",
            Integrator::SemiImplicitEuler => "euler",
        }
    }
}
