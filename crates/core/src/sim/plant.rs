//! The simulated arm: true dynamics (the plant's own model, with payload and friction) and
//! fixed-step integrators of `ẋ = (q̇, q̈(q, q̇, τ))` (Nyström's fourth-order Runge–Kutta by
//! default).

use crate::arm::dynamics::{ConfigurationDynamics, DynamicsError, DynamicsTerms};
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

    /// The plant's kinematics, mass matrix and bias torques at `state`: the first stage of
    /// every integrator, and what a controller with the same model needs.
    pub fn evaluate(&self, state: &JointState<N>) -> StateDynamics<N> {
        let chain = FrameChain::new(&self.model, &state.q);
        let terms = DynamicsTerms::from_chain(&self.model, &chain, &state.qd);
        StateDynamics { chain, terms }
    }

    /// One classical RK4 step of `dt` seconds with `torque` held constant (zero-order hold).
    pub fn rk4_step(
        &self,
        state: &JointState<N>,
        torque: &JointVector<N>,
        dt: f64,
    ) -> Result<JointState<N>, DynamicsError> {
        self.step(state, &self.evaluate(state), torque, dt, Integrator::RungeKutta4)
    }

    /// The dynamics at configuration `q` near the step's start, whose sines and cosines come
    /// from the start's by angle addition ([`JointTrig::shifted`]).
    #[inline(always)]
    fn configuration_near(
        &self,
        start: &JointState<N>,
        at_start: &StateDynamics<N>,
        q: &JointVector<N>,
    ) -> Result<ConfigurationDynamics<N>, DynamicsError> {
        let trig = at_start.chain.trig().shifted(&(q - start.q));
        ConfigurationDynamics::from_chain(&self.model, &FrameChain::from_trig(&self.model, trig), q)
    }

    /// One step of `dt` seconds with `torque` held constant, by `integrator`. `at_state` is
    /// [`Plant::evaluate`] at `state`, passed in so a caller that needs it anyway (the closed
    /// loop: the tool tip, the controller's terms) computes it once.
    pub fn step(
        &self,
        state: &JointState<N>,
        at_state: &StateDynamics<N>,
        torque: &JointVector<N>,
        dt: f64,
        integrator: Integrator,
    ) -> Result<JointState<N>, DynamicsError> {
        let model = &self.model;
        let (q, qd) = (&state.q, &state.qd);
        let q1dd = at_state.terms.acceleration(model, q, qd, torque)?;
        let acceleration_at = |s: &JointState<N>| -> Result<JointVector<N>, DynamicsError> {
            Ok(self.configuration_near(state, at_state, &s.q)?.acceleration(model, &s.qd, torque))
        };
        Ok(match integrator {
            Integrator::RungeKutta4 => {
                let stage = |qd_k: &JointVector<N>, qdd_k: &JointVector<N>, h: f64| JointState {
                    q: q + qd_k * h,
                    qd: qd + qdd_k * h,
                };
                let s2 = stage(qd, &q1dd, dt / 2.0);
                let q2dd = acceleration_at(&s2)?;
                let s3 = stage(&s2.qd, &q2dd, dt / 2.0);
                let q3dd = acceleration_at(&s3)?;
                let s4 = stage(&s3.qd, &q3dd, dt);
                let q4dd = acceleration_at(&s4)?;
                JointState {
                    q: q + (qd + s2.qd * 2.0 + s3.qd * 2.0 + s4.qd) * (dt / 6.0),
                    qd: qd + (q1dd + q2dd * 2.0 + q3dd * 2.0 + q4dd) * (dt / 6.0),
                }
            }
            Integrator::RungeKuttaNystrom4 => {
                // Stages 2 and 3 share the configuration q + dt/2 q̇ + dt²/8 q̈₁.
                let middle =
                    self.configuration_near(state, at_state, &(q + qd * (dt / 2.0) + q1dd * (dt * dt / 8.0)))?;
                let q2dd = middle.acceleration(model, &(qd + q1dd * (dt / 2.0)), torque);
                let q3dd = middle.acceleration(model, &(qd + q2dd * (dt / 2.0)), torque);
                let end = self.configuration_near(state, at_state, &(q + qd * dt + q3dd * (dt * dt / 2.0)))?;
                let q4dd = end.acceleration(model, &(qd + q3dd * dt), torque);
                JointState {
                    q: q + qd * dt + (q1dd + q2dd + q3dd) * (dt * dt / 6.0),
                    qd: qd + (q1dd + q2dd * 2.0 + q3dd * 2.0 + q4dd) * (dt / 6.0),
                }
            }
            Integrator::Midpoint => {
                let middle = JointState { q: q + qd * (dt / 2.0), qd: qd + q1dd * (dt / 2.0) };
                let middle_qdd = acceleration_at(&middle)?;
                JointState { q: q + middle.qd * dt, qd: qd + middle_qdd * dt }
            }
            Integrator::SemiImplicitEuler => {
                let qd = qd + q1dd * dt;
                JointState { q: q + qd * dt, qd }
            }
        })
    }
}

/// The plant's kinematics and dynamics terms at one state ([`Plant::evaluate`]).
#[derive(Debug, Clone, Copy)]
pub struct StateDynamics<const N: usize> {
    pub chain: FrameChain<N>,
    /// `M(q)` and `C(q, q̇) q̇ + g(q)` of the plant's model.
    pub terms: DynamicsTerms<N>,
}

/// How the plant's state advances over one step of `dt` with the torque held (zero-order hold).
/// Costs are in evaluations of the forward dynamics per step; the first one is shared with
/// the controller when its model equals the plant's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Integrator {
    /// Classical fourth-order Runge–Kutta: 4 evaluations, global error O(dt⁴).
    RungeKutta4,
    /// Nyström's fourth-order Runge–Kutta method for second-order systems `q̈ = f(q, q̇)`
    /// (Kreyszig, *Advanced Engineering Mathematics*, §21.3). With `h = dt` and `q̈ᵢ` its stages:
    /// `q̈₁ = f(q, q̇)`; `Q = q + h/2 q̇ + h²/8 q̈₁`; `q̈₂ = f(Q, q̇ + h/2 q̈₁)`;
    /// `q̈₃ = f(Q, q̇ + h/2 q̈₂)`; `q̈₄ = f(q + h q̇ + h²/2 q̈₃, q̇ + h q̈₃)`;
    /// `q⁺ = q + h q̇ + h²/6 (q̈₁ + q̈₂ + q̈₃)`, `q̇⁺ = q̇ + h/6 (q̈₁ + 2q̈₂ + 2q̈₃ + q̈₄)`.
    /// The same updates as RK4 with stages 2 and 3 at one configuration, so the mass matrix,
    /// its factor and the kinematics are computed 3 times per step instead of 4; global
    /// error O(dt⁴). The default.
    #[default]
    RungeKuttaNystrom4,
    /// Explicit midpoint rule, a second-order Runge–Kutta method:
    /// `x⁺ = x + dt f(x + dt/2 · f(x))`; 2 evaluations, global error O(dt²).
    Midpoint,
    /// Semi-implicit (symplectic) Euler, the default of MuJoCo and most game engines:
    /// `q̇⁺ = q̇ + dt q̈(q, q̇)`, `q⁺ = q + dt q̇⁺`; 1 evaluation, global error O(dt).
    SemiImplicitEuler,
}

impl Integrator {
    pub const ALL: [Integrator; 4] =
        [Integrator::RungeKutta4, Integrator::RungeKuttaNystrom4, Integrator::Midpoint, Integrator::SemiImplicitEuler];

    /// Short name, as the CLI spells it.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::RungeKutta4 => "rk4",
            Integrator::RungeKuttaNystrom4 => "rkn4",
            Integrator::Midpoint => "midpoint",
            Integrator::SemiImplicitEuler => "euler",
        }
    }
}
