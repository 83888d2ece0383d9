//! Computed torque with a joint-space disturbance observer (DOB).
//!
//! The nominal model says the command `τ = M̂(q) u + N̂(q, q̇)` produces `q̈ = u`. Whatever the
//! model gets wrong (an unknown payload, wrong link masses, friction) shows up as a lumped
//! acceleration error per joint, `d = q̈ − u`. The observer estimates it through a Q-filter and
//! the controller subtracts it:
//!
//! `d̂ = Q(s) [q̈ − u]`, `Q(s) = ω_q / (s + ω_q)`, `u = v − d̂`,
//! `τ = M̂(q) (v − d̂) + N̂(q, q̇)`, `v = q̈_d + kd ė + kp e` (PD outer loop),
//!
//! so that below `ω_q` the plant behaves as `q̈ ≈ v` again. `Q` has unit DC gain: a constant
//! disturbance is removed completely (at rest `q̈ = 0` forces `d̂ = −u`, hence `v = 0` and
//! `e = 0`: PD's steady error becomes zero).
//!
//! # Discrete form
//!
//! `q̈` is never measured. Over each sample interval the command is held, so the mean
//! acceleration `a_k = (q̇_k − q̇_{k−1}) / h` (from the rates the controller sees) answers the
//! acceleration `u_{k−1}` asked for over that interval, and the Q-filter is the exact
//! discretisation of `ω_q / (s + ω_q)` for values held over a sample:
//!
//! `d̂_k = d̂_{k−1} + (1 − e^{−ω_q h}) (a_k − u_{k−1} − d̂_{k−1})`
//!
//! (the discrete form of the usual velocity-based DOB, `d̂ = ω_q (q̇ − q̇_f) − Q[u]`, which never
//! differentiates a measured signal outside the filter). When the command saturates the model's
//! torque limits, `u_{k−1}` is replaced by the acceleration the clipped torque realises,
//! `M̂⁻¹(clip(τ) − N̂)`, so that saturation is not mistaken for a disturbance (the estimate would
//! otherwise wind up like an integrator).
//!
//! The default bandwidth `ω_q` = 50 rad/s is 2.5 × the report's PD natural frequency (20 rad/s),
//! so the observer is faster than the loop it serves, yet its one-sample delay costs only
//! `ω_q h` = 0.05 rad of phase at 1 kHz. Rate noise reaches `d̂` amplified (a difference of
//! rates divided by `h`, then filtered): lower `ω_q` for noisy sensors.

use super::gains::{GainError, Gains};
use super::{Controller, JointState, Reference};
use crate::arm::dynamics::DynamicsTerms;
use crate::arm::mass_matrix::MassMatrixFactor;
use crate::arm::model::{ArmModel, JointVector};

/// Default Q-filter bandwidth `ω_q`, rad/s (see the module documentation).
pub const DEFAULT_OBSERVER_BANDWIDTH: f64 = 50.0;

/// What the observer keeps from one sample for the next.
#[derive(Debug, Clone, Copy)]
struct Previous<const N: usize> {
    rate: JointVector<N>,
    /// The acceleration the (clipped) command asks of the nominal model, rad/s².
    acceleration: JointVector<N>,
    /// s.
    period: f64,
}

/// Computed torque with a PD outer loop and a disturbance observer.
#[derive(Debug, Clone)]
pub struct DisturbanceObserver<const N: usize> {
    model: ArmModel<N>,
    gains: Gains<N>,
    /// `ω_q`, rad/s.
    bandwidth: f64,
    /// `d̂`, rad/s².
    disturbance: JointVector<N>,
    previous: Option<Previous<N>>,
    /// `u = v − d̂` of the latest command, rad/s².
    commanded: JointVector<N>,
}

impl<const N: usize> DisturbanceObserver<N> {
    /// With the report's PD gains (kp = 400, kd = 20) and `ω_q` =
    /// [`DEFAULT_OBSERVER_BANDWIDTH`].
    pub fn new(model: ArmModel<N>) -> Self {
        Self {
            model,
            gains: Gains::report_pd(),
            bandwidth: DEFAULT_OBSERVER_BANDWIDTH,
            disturbance: JointVector::zeros(),
            previous: None,
            commanded: JointVector::zeros(),
        }
    }

    /// Other outer-loop gains; the outer loop is PD (the observer does the integral's job), so
    /// `ki` must be zero.
    pub fn with_gains(self, gains: Gains<N>) -> Result<Self, GainError> {
        gains.require_pd("the disturbance observer's outer loop is PD: ki must be 0")?;
        Ok(Self { gains, ..self })
    }

    /// Another Q-filter bandwidth `ω_q`, rad/s (finite, > 0).
    pub fn with_bandwidth(self, bandwidth: f64) -> Result<Self, GainError> {
        if !(bandwidth.is_finite() && bandwidth > 0.0) {
            return Err(GainError::Invalid {
                name: "observer bandwidth".into(),
                value: bandwidth,
                reason: "must be finite and > 0",
            });
        }
        Ok(Self { bandwidth, ..self })
    }

    pub fn gains(&self) -> &Gains<N> {
        &self.gains
    }

    pub fn model(&self) -> &ArmModel<N> {
        &self.model
    }

    /// `ω_q`, rad/s.
    pub fn bandwidth(&self) -> f64 {
        self.bandwidth
    }

    /// The current estimate `d̂`, rad/s².
    pub fn disturbance_estimate(&self) -> &JointVector<N> {
        &self.disturbance
    }
}

impl<const N: usize> Controller<N> for DisturbanceObserver<N> {
    fn name(&self) -> &str {
        "dob"
    }

    fn reset(&mut self) {
        self.disturbance = JointVector::zeros();
        self.previous = None;
        self.commanded = JointVector::zeros();
    }

    super::model_based_controller_methods!();

    fn command_with_terms(
        &mut self,
        state: &JointState<N>,
        reference: &Reference<N>,
        period: f64,
        terms: &DynamicsTerms<N>,
    ) -> JointVector<N> {
        if let Some(previous) = self.previous {
            let h = previous.period;
            let mean_acceleration = (state.qd - previous.rate) / h;
            let blend = 1.0 - (-self.bandwidth * h).exp();
            self.disturbance += (mean_acceleration - previous.acceleration - self.disturbance) * blend;
        }
        let outer = self.gains.pd_outer_loop(reference, state);
        let compensated = outer - self.disturbance;
        let torque = super::compensate_friction(
            &self.model,
            &state.qd,
            super::computed_torque::torque_of_terms(terms, &compensated.into()).into(),
        );
        let limits = self.model.torque_limits();
        let saturated = (0..N).any(|j| torque[j].abs() > limits[j]);
        let realised = if saturated && let Some(factor) = MassMatrixFactor::new(&terms.mass_matrix) {
            let clipped = torque.zip_map(&limits, |t, limit| t.clamp(-limit, limit));
            factor.solve(&(clipped - terms.bias))
        } else {
            compensated
        };
        self.previous = Some(Previous { rate: state.qd, acceleration: realised, period });
        self.commanded = compensated;
        torque
    }
}
