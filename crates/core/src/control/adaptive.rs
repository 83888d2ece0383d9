//! Adaptive computed torque: the payload's mass and centre-of-mass offset estimated online by
//! recursive least squares while the gripper is closed.
//!
//! # Control law
//!
//! The controller's model `M̂, N̂` has no payload (unless one is told,
//! [`Controller::set_payload`]). A point-mass payload adds `Y(q, q̇, q̈) θ` to the joint torques
//! ([`crate::arm::payload`], `θ = (m, m c)`, the `m c²` term left out), so with the estimate
//! `θ̂`:
//!
//! `τ = M̂(q) v + N̂(q, q̇) + Y(q, q̇, v) θ̂`, `v = q̈_d + kd ė + kp e` (PD outer loop),
//!
//! which is computed torque with the estimated payload in the model: with `θ̂ = θ` every
//! joint's error obeys `ë + kd ė + kp e = 0` again.
//!
//! # Estimation
//!
//! Over each sample interval `[t_{k−1}, t_k]` the held command `τ_{k−1}` drives the plant:
//! `τ_{k−1} + τ_fric = M(q) q̈ + N(q, q̇)` at every instant, the true model being the controller's
//! plus the payload. Averaged over the interval and evaluated at the midpoint
//! `q̄ = (q_{k−1} + q_k)/2`, `q̄̇ = (q̇_{k−1} + q̇_k)/2` with the mean acceleration
//! `a_k = (q̇_k − q̇_{k−1})/h`, this is the residual equation
//!
//! `r_k = τ_{k−1} + τ̂_fric(q̄̇) − (M̂(q̄) a_k + N̂(q̄, q̄̇)) = Y(q̄, q̄̇, a_k) θ + ε_k`
//!
//! (one RNEA of the model and one regressor at the midpoint; `τ̂_fric` is the model's joint
//! friction, none on the report's arm). The approximation is the
//! midpoint rule over one sample, `ε_k = O(h²)` (with `h` = 1 ms below 10⁻⁶ N·m on the
//! report's move: measured 3.4·10⁻⁷ N·m), plus what the point mass leaves out of a real piece
//! (its own rotational inertia and the `m c²` term, both multiplied by angular
//! accelerations). The acceleration is the mean of the last interval, derived from the rates
//! the controller sees, never measured; the torque is the controller's own command, clipped
//! to its model's limits — a motor lag or other limits in the plant would enter `ε`.
//!
//! Both sides are filtered by the same first-order low-pass `λ/(s + λ)`, discretised exactly
//! for values held over a sample: `x_f ← x_f + (1 − e^{−λh}) (x − x_f)`. The filter is linear
//! and time-invariant and `θ` is constant while gripped, so `r_f = Y_f θ` holds exactly when
//! `r = Y θ` does: filtering costs no consistency. (Filtered alone, `a_k` would give the
//! discrete form of `q̈_f = λ (q̇ − q̇_f)`; filtering the residual and the regressor after they
//! are formed instead spares the usual approximation `F[M̂(q) q̈] ≈ M̂(q) q̈_f`, which needs
//! `M̂(q)` and `Y` to vary slowly over `1/λ`.) What the filter buys is
//! noise: the finite-difference acceleration of noisy rate estimates has a standard deviation of
//! `√2 σ_q̇ / h`, which the filter divides by about `√(2 / (λh))`. With noisy rates the
//! regressor carries noise correlated with the residual's (both come from `a_k`), which biases
//! least squares; `λ` trades that against speed.
//!
//! Recursive least squares on the filtered rows, one joint at a time (scalar updates, no
//! matrix inverse): with `φ = Y_f[j, ·]`, `y = r_f[j]`,
//! `k = P φᵀ / (σ² + φ P φᵀ)`, `θ̂ ← θ̂ + k (y − φ θ̂)`, `P ← P − k φ P`, no forgetting (the
//! payload is constant between a grip and a release). At every grip
//! ([`Controller::gripper_changed`]`(true)`) `θ̂` and `P` restart from the prior
//! ([`AdaptiveSettings::prior`]) and the filters from zero — so that the filtered signals
//! start with the payload — and the interval that ends at the grip's sample is skipped (the
//! payload was not yet carried). At a release the estimate is cleared to zero and estimation
//! stops: the gripper is then known to be empty.

use super::gains::{GainError, Gains};
use super::{Controller, JointState, Reference};
use crate::arm::dynamics::{BodyFrames, DynamicsTerms, friction_torques, rnea_with_frames};
use crate::arm::model::{ArmModel, JointVector};
use crate::arm::payload::{PayloadRegressor, payload_regressor};
use nalgebra::{Matrix2, Vector2};

/// The least estimated mass whose centre of mass [`AdaptiveComputedTorque::payload_estimate`]
/// reports, kg (1 g; the lightest piece of the default set weighs 30 g).
pub const LOCATABLE_MASS: f64 = 1e-3;

/// Largest payload mass the control law uses, kg: twenty times the heaviest default piece.
pub const MAX_PAYLOAD_MASS: f64 = 1.0;
/// Largest centre-of-mass offset along the tool the control law uses, m: half the tallest
/// default piece (9.5 cm) and some.
pub const MAX_COM_OFFSET: f64 = 0.05;

/// The estimate the control law applies: `θ̂` projected onto the physical set
/// `0 ≤ m ≤ MAX_PAYLOAD_MASS`, `|m c| ≤ m · MAX_COM_OFFSET`. With noisy rates the least-squares
/// estimate can wander outside it (a negative mass, a piece 30 cm off the tip); used as it
/// is, that estimate injects its noise into the torque through `Y(q, q̇, v)`. The estimator
/// itself keeps the unprojected `θ̂`, so the projection biases nothing it learns.
fn physical(estimate: &Vector2<f64>) -> Vector2<f64> {
    let mass = estimate[0].clamp(0.0, MAX_PAYLOAD_MASS);
    let bound = mass * MAX_COM_OFFSET;
    Vector2::new(mass, estimate[1].clamp(-bound, bound))
}

/// Settings of the payload estimator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptiveSettings {
    /// Bandwidth `λ` of the residual and regressor filter, rad/s.
    pub bandwidth: f64,
    /// `θ̂` at each grip: mass (kg) and first moment `m c` (kg·m) along the tool x axis.
    pub prior: Vector2<f64>,
    /// Standard deviations of the prior, kg and kg·m (`P = diag(std²)` at each grip).
    pub prior_std: Vector2<f64>,
    /// Standard deviation `σ` of one joint's filtered torque residual per sample, N·m: the
    /// weight of the data against the prior.
    pub residual_std: f64,
}

impl Default for AdaptiveSettings {
    /// `λ` = 25 rad/s (a 40 ms time constant, well within the 0.3 s after a grip, which
    /// divides the noise of finite-difference accelerations by ≈ 9 at 1 kHz); prior: an empty
    /// gripper, `θ̂ = 0`, with standard deviations 0.5 kg and 0.05 kg·m (a 0.5 kg piece 10 cm
    /// off the tip: far beyond any chess piece); `σ` = 0.01 N·m, so that a few samples outweigh
    /// the prior (one row's information `φ²/σ²` with a weight lever `φ` ≈ 2 N·m/kg is
    /// 4·10⁴ kg⁻², the prior's 4 kg⁻²).
    fn default() -> Self {
        Self { bandwidth: 25.0, prior: Vector2::zeros(), prior_std: Vector2::new(0.5, 0.05), residual_std: 0.01 }
    }
}

impl AdaptiveSettings {
    fn validate(&self) -> Result<(), GainError> {
        let positive = |name: &str, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(GainError::Invalid { name: name.into(), value, reason: "must be finite and > 0" })
            }
        };
        positive("adaptive filter bandwidth", self.bandwidth)?;
        positive("adaptive prior mass std", self.prior_std[0])?;
        positive("adaptive prior moment std", self.prior_std[1])?;
        positive("adaptive residual std", self.residual_std)?;
        for (name, value) in [("adaptive prior mass", self.prior[0]), ("adaptive prior moment", self.prior[1])] {
            if !value.is_finite() {
                return Err(GainError::Invalid { name: name.into(), value, reason: "must be finite" });
            }
        }
        Ok(())
    }
}

/// What the estimator keeps from one sample for the next.
#[derive(Debug, Clone, Copy)]
struct Previous<const N: usize> {
    state: JointState<N>,
    /// The command as the plant receives it, clipped to the model's torque limits, N·m.
    torque: JointVector<N>,
    /// s.
    period: f64,
}

/// Computed torque with a PD outer loop and an online estimate of the gripped payload.
#[derive(Debug, Clone)]
pub struct AdaptiveComputedTorque<const N: usize> {
    model: ArmModel<N>,
    gains: Gains<N>,
    settings: AdaptiveSettings,
    /// Whether the gripper is closed (estimation running).
    gripping: bool,
    /// `θ̂ = (m̂, m̂ ĉ)`.
    estimate: Vector2<f64>,
    covariance: Matrix2<f64>,
    filtered_residual: JointVector<N>,
    filtered_regressor: PayloadRegressor<N>,
    previous: Option<Previous<N>>,
    commanded: JointVector<N>,
}

impl<const N: usize> AdaptiveComputedTorque<N> {
    /// With the report's PD gains (kp = 400, kd = 20) and the default settings.
    pub fn new(model: ArmModel<N>) -> Self {
        let gains = Gains::report_pd();
        let settings = AdaptiveSettings::default();
        Self {
            model,
            gains,
            settings,
            gripping: false,
            estimate: Vector2::zeros(),
            covariance: Matrix2::from_diagonal(&settings.prior_std.component_mul(&settings.prior_std)),
            filtered_residual: JointVector::zeros(),
            filtered_regressor: PayloadRegressor::zeros(),
            previous: None,
            commanded: JointVector::zeros(),
        }
    }

    /// Other outer-loop gains; the outer loop is PD, so `ki` must be zero.
    pub fn with_gains(self, gains: Gains<N>) -> Result<Self, GainError> {
        gains.require_pd("the adaptive controller's outer loop is PD: ki must be 0")?;
        Ok(Self { gains, ..self })
    }

    /// Other estimator settings.
    pub fn with_settings(self, settings: AdaptiveSettings) -> Result<Self, GainError> {
        settings.validate()?;
        Ok(Self { settings, ..self })
    }

    pub fn gains(&self) -> &Gains<N> {
        &self.gains
    }

    pub fn settings(&self) -> &AdaptiveSettings {
        &self.settings
    }

    pub fn model(&self) -> &ArmModel<N> {
        &self.model
    }

    /// `θ̂ = (m̂, m̂ ĉ)`, kg and kg·m: zero while the gripper is open.
    pub fn parameter_estimate(&self) -> Vector2<f64> {
        self.estimate
    }

    /// The estimated payload: mass (kg) and centre-of-mass offset along the tool x axis (m),
    /// `ĉ = θ̂₂ / θ̂₁`, reported as 0 when `|m̂|` is below [`LOCATABLE_MASS`] (an empty gripper's
    /// estimate is a few µg of noise, whose ratio means nothing).
    pub fn payload_estimate(&self) -> (f64, f64) {
        let mass = self.estimate[0];
        let offset = if mass.abs() >= LOCATABLE_MASS { self.estimate[1] / mass } else { 0.0 };
        (mass, offset)
    }

    fn restart_estimate(&mut self) {
        let std = self.settings.prior_std;
        self.estimate = self.settings.prior;
        self.covariance = Matrix2::from_diagonal(&std.component_mul(&std));
        self.filtered_residual = JointVector::zeros();
        self.filtered_regressor = PayloadRegressor::zeros();
        // The interval ending at the next sample began before the grip.
        self.previous = None;
    }

    /// One estimator update from the interval between the previous sample and `state`.
    fn update_estimate(&mut self, state: &JointState<N>) {
        let Some(previous) = self.previous else { return };
        let h = previous.period;
        let q = (previous.state.q + state.q) * 0.5;
        let qd = (previous.state.qd + state.qd) * 0.5;
        let acceleration = (state.qd - previous.state.qd) / h;
        let frames = BodyFrames::new(&self.model, &q);
        let predicted = rnea_with_frames(&self.model, &frames, &qd, &acceleration, &self.model.gravity());
        let residual = previous.torque + friction_torques(&self.model, &qd) - predicted;
        let regressor = payload_regressor(&self.model, &q, &qd, &acceleration);
        let blend = 1.0 - (-self.settings.bandwidth * h).exp();
        self.filtered_residual += (residual - self.filtered_residual) * blend;
        self.filtered_regressor += (regressor - self.filtered_regressor) * blend;
        let noise = self.settings.residual_std * self.settings.residual_std;
        for j in 0..N {
            let row = self.filtered_regressor.row(j).transpose();
            let spread = self.covariance * row;
            let gain = spread / (noise + row.dot(&spread));
            self.estimate += gain * (self.filtered_residual[j] - row.dot(&self.estimate));
            self.covariance -= gain * spread.transpose();
            // Keep P exactly symmetric against rounding.
            let off_diagonal = 0.5 * (self.covariance[(0, 1)] + self.covariance[(1, 0)]);
            self.covariance[(0, 1)] = off_diagonal;
            self.covariance[(1, 0)] = off_diagonal;
        }
    }
}

impl<const N: usize> Controller<N> for AdaptiveComputedTorque<N> {
    fn name(&self) -> &str {
        "adaptive"
    }

    fn reset(&mut self) {
        self.restart_estimate();
        self.estimate = Vector2::zeros();
        self.gripping = false;
        self.commanded = JointVector::zeros();
    }

    super::model_based_controller_methods!();

    fn gripper_changed(&mut self, closed: bool) {
        self.gripping = closed;
        if closed {
            self.restart_estimate();
        } else {
            self.estimate = Vector2::zeros();
            self.previous = None;
        }
    }

    fn command_with_terms(
        &mut self,
        state: &JointState<N>,
        reference: &Reference<N>,
        period: f64,
        terms: &DynamicsTerms<N>,
    ) -> JointVector<N> {
        if self.gripping {
            self.update_estimate(state);
        }
        let outer = self.gains.pd_outer_loop(reference, state);
        let mut torque = super::compensate_friction(
            &self.model,
            &state.qd,
            super::computed_torque::torque_of_terms(terms, &outer.into()).into(),
        );
        if self.gripping {
            torque += payload_regressor(&self.model, &state.q, &state.qd, &outer) * physical(&self.estimate);
            let limits = self.model.torque_limits();
            let applied = torque.zip_map(&limits, |t, limit| t.clamp(-limit, limit));
            self.previous = Some(Previous { state: *state, torque: applied, period });
        }
        self.commanded = outer;
        torque
    }
}
