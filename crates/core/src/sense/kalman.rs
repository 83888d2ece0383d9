//! The joint Kalman filter: per joint, a linear Kalman filter of the angle `q` and rate `q̇`
//! (and optionally a disturbance acceleration `d`) from the encoder angles (and a velocity
//! sensor's rates, where there is one), with the commanded acceleration as the motion model's
//! input and the sensors' delay compensated by prediction.
//!
//! # Model
//!
//! Computed torque makes each joint a double integrator, `q̈ = u (+ d)`, with `u` the commanded
//! acceleration held over each sample of period `T`; the joints are decoupled and filtered one
//! by one. The state of a joint is `x = (q, q̇, d)`:
//!
//! ```text
//! x_{k+1} = F x_k + G u_k + w_k,   F = ⎡1  T  T²/2⎤,   G = ⎡T²/2⎤
//!                                      ⎢0  1  T   ⎥        ⎢T   ⎥
//!                                      ⎣0  0  1   ⎦        ⎣0   ⎦
//! Q = Cov(w_k) = σ_a² G Gᵀ + σ_d² e₃ e₃ᵀ
//! ```
//!
//! `σ_a` ([`KalmanSettings::acceleration_noise`]) is a white acceleration held over each sample
//! (the discrete white noise acceleration model, Bar-Shalom, Li & Kirubarajan 2001, §6.3.2);
//! `d` is a random walk whose increment over one sample has σ `σ_d`
//! ([`KalmanSettings::disturbance_noise`]). Without the disturbance state the filter has two
//! states: the third row and column of `F`, `G`, `Q` and `P` are zero throughout (so are the
//! third rows of what [`JointKalman::covariance`] and [`JointKalman::gain`] return).
//!
//! The measurement is the angle, and the rate with a velocity sensor:
//!
//! ```text
//! z_k = H x_k + v_k,   H = [1 0 0]  (or ⎡1 0 0⎤ with a rate sensor),   R = σ_q²  (or diag(σ_q², σ_r²))
//!                                       ⎣0 1 0⎦
//! ```
//!
//! # Recursion
//!
//! ```text
//! predict:  x⁻ = F x + G u,               P⁻ = F P Fᵀ + Q
//! update:   K = P⁻ Hᵀ (H P⁻ Hᵀ + R)⁻¹,     x = x⁻ + K (z − H x⁻),
//!           P = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ        (Joseph form: symmetric, ≥ 0)
//! ```
//!
//! `R` is diagonal, so the angle and the rate are processed one after the other as scalar
//! measurements, which is exactly the batch update; [`JointKalman::gain`] reports the batch
//! gain `K` the two scalar updates amount to. A non-finite reading is treated as missing (the
//! sample is a prediction only); a non-finite input is taken as 0.
//!
//! # Timing and delay
//!
//! [`JointKalman::update`] is called at sample `k` with the reading of the state at sample
//! `k − δ` (`δ` = `delay_samples`) and `applied = u_{k−1}`, the acceleration commanded over
//! `[k−1, k]`. The filter itself runs `δ` samples behind: it predicts from `k−δ−1` to `k−δ`
//! with `u_{k−δ−1}` and updates with the reading. A ring of the last `δ + 1` inputs holds
//! `u_{k−δ−1} … u_{k−1}`. The estimate returned is the filter's state carried forward by pure
//! prediction through `u_{k−δ} … u_{k−1}`:
//!
//! ```text
//! x̂_{k|k−δ} = F^δ x̂_{k−δ|k−δ} + Σ_{i=0}^{δ−1} F^{δ−1−i} G u_{k−δ+i},
//! P_{k|k−δ} = F^δ P_{k−δ|k−δ} F^δᵀ + Σ_{i=0}^{δ−1} F^i Q F^iᵀ
//! ```
//!
//! ([`JointKalman::covariance`]; the filter's own is [`JointKalman::filter_covariance`]).
//!
//! # Start
//!
//! [`JointKalman::reset`] sets the filter's state (at the sample before its first measurement,
//! `−δ−1`) to the given angles and rates, no disturbance, and the ring of inputs to zeros (the
//! sensors' delay line holds readings of the same state, as if the arm had been there). The
//! covariance starts at the steady a-posteriori covariance `P₀ = (I − K∞ H) P∞`, with `P∞` the
//! a-priori steady covariance ([`solve_dare`]) and `K∞` its gain: the filter starts converged, as
//! if it had been tracking the arm before the run, so its gain is the steady gain from the first
//! sample on (no start-up transient of large gains to kick the controller).
//! [`JointKalman::reset_with_covariance`] starts from another `P₀`.

use super::sensors::MAX_DELAY_SAMPLES;
use super::{Measurement, SenseError, invalid};
use crate::arm::model::JointVector;
use crate::control::JointState;
use crate::lanes::{Lanes, Real, array3, array4};
use nalgebra::{ArrayStorage, Matrix2, Matrix2x3, Matrix3, Matrix3x2, SMatrix, Vector3};

/// Tuning of the joint Kalman filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KalmanSettings {
    /// σ of the joint acceleration the motion model does not know, rad/s² (white, held over a
    /// sample).
    pub acceleration_noise: f64,
    /// `Some(σ)`: also estimate a disturbance acceleration `d` (`q̈ = u + d`), a random walk whose
    /// increments over one sample have σ rad/s²; `None`: angle and rate only.
    pub disturbance_noise: Option<f64>,
}

impl KalmanSettings {
    /// σ of the disturbance state's increments per sample, rad/s², when it is asked for
    /// without a value: 0.01 lets `d̂` follow an unknown payload's acceleration error (of the
    /// order of 1 rad/s², near constant between grip and release) within ~0.1 s.
    pub const DEFAULT_DISTURBANCE_NOISE: f64 = 0.01;

    /// The default tuning, with the disturbance state: σ_a = 1 rad/s² (what is left of
    /// "actual − commanded acceleration" once its slow part is the disturbance's: the hold's
    /// and the lag's effect on a smooth move), σ_d = [`Self::DEFAULT_DISTURBANCE_NOISE`]. On
    /// the seed scenario with hobby encoders and an unknown pawn, PD: RMS rate error
    /// 0.005–0.013 rad/s per joint, against 0.03–0.04 for [`Self::TWO_STATE`] and 0.087 for the
    /// low-pass baseline.
    pub const DEFAULT: KalmanSettings =
        KalmanSettings { acceleration_noise: 1.0, disturbance_noise: Some(Self::DEFAULT_DISTURBANCE_NOISE) };

    /// The two-state filter: σ_a = 20 rad/s². Under computed torque the acceleration the
    /// filter does not know is the model error, a near-constant offset of up to a few rad/s²
    /// with an unknown piece or ±10 % link masses; without a disturbance state it must be
    /// absorbed as noise, which a smaller σ_a turns into a biased rate (0.5 rad/s at σ_a = 1).
    pub const TWO_STATE: KalmanSettings = KalmanSettings { acceleration_noise: 20.0, disturbance_noise: None };
}

/// Relative change of the solution below which [`solve_dare`]'s doubling iteration has
/// converged (with the doubled transition matrix below [`DARE_TRANSITION_TOLERANCE`]).
pub const DARE_TOLERANCE: f64 = 1e-13;

/// Frobenius norm the doubled transition matrix `A_k` of [`solve_dare`] must fall below: it is
/// the closed-loop transition over `2^k` samples, and reaching zero means the solution found is
/// the stabilising one.
pub const DARE_TRANSITION_TOLERANCE: f64 = 1e-10;

/// Most doubling steps of [`solve_dare`]: step `k` covers `2^k` Riccati steps.
pub const DARE_MAX_DOUBLINGS: usize = 64;

/// The a-priori steady covariance of a Kalman filter: the stabilising solution of the discrete
/// algebraic Riccati equation
///
/// ```text
/// P = F P Fᵀ − F P Hᵀ (H P Hᵀ + R)⁻¹ H P Fᵀ + Q,
/// ```
///
/// for `S` states and `M` measurements, `Q` symmetric ≥ 0 and `R` symmetric > 0.
///
/// By the structure-preserving doubling algorithm (Chu, Fan, Lin & Wang 2004) on the equivalent
/// form `P = Aᵀ P (I + G P)⁻¹ A + Q` with `A = Fᵀ`, `G = Hᵀ R⁻¹ H`: from `A₀ = A`, `G₀ = G`,
/// `P₀ = Q`,
///
/// ```text
/// W_k = (I + G_k P_k)⁻¹,   A_{k+1} = A_k W_k A_k,   G_{k+1} = G_k + A_k W_k G_k A_kᵀ,
/// P_{k+1} = P_k + A_kᵀ P_k W_k A_k,
/// ```
///
/// `P_k` is the Riccati recursion after `2^k` steps from zero, so it converges quadratically.
/// Stops when `‖P_{k+1} − P_k‖ ≤` [`DARE_TOLERANCE`] `‖P_{k+1}‖` and `‖A_{k+1}‖ ≤`
/// [`DARE_TRANSITION_TOLERANCE`] (Frobenius norms); an error if that takes more than
/// [`DARE_MAX_DOUBLINGS`] steps (no stabilising solution: `(F, Q)` not stabilisable or `(F, H)`
/// not detectable), or if an input is not finite, `Q` or `R` not symmetric, or `R` not positive
/// definite.
pub fn solve_dare<const S: usize, const M: usize>(
    f: &SMatrix<f64, S, S>,
    h: &SMatrix<f64, M, S>,
    q: &SMatrix<f64, S, S>,
    r: &SMatrix<f64, M, M>,
) -> Result<SMatrix<f64, S, S>, SenseError> {
    let finite = |values: &[f64]| values.iter().all(|v| v.is_finite());
    for (name, ok) in [
        ("riccati F", finite(f.as_slice())),
        ("riccati H", finite(h.as_slice())),
        ("riccati Q", finite(q.as_slice())),
        ("riccati R", finite(r.as_slice())),
    ] {
        if !ok {
            return Err(invalid(name, "(not finite)", "every entry must be finite"));
        }
    }
    let asymmetry = |m: &SMatrix<f64, S, S>| (m - m.transpose()).norm();
    if asymmetry(q) > 1e-12 * q.norm() {
        return Err(invalid("riccati Q", asymmetry(q), "must be symmetric (the value is ‖Q − Qᵀ‖)"));
    }
    if (r - r.transpose()).norm() > 1e-12 * r.norm() {
        return Err(invalid("riccati R", (r - r.transpose()).norm(), "must be symmetric (the value is ‖R − Rᵀ‖)"));
    }
    let r_inverse = r.cholesky().ok_or_else(|| invalid("riccati R", r.norm(), "must be positive definite"))?.inverse();
    let identity = SMatrix::<f64, S, S>::identity();
    let mut a = f.transpose();
    let mut g = h.transpose() * r_inverse * h;
    let mut p = *q;
    for _ in 0..DARE_MAX_DOUBLINGS {
        let w = (identity + g * p)
            .try_inverse()
            .ok_or_else(|| invalid("riccati equation", p.norm(), "I + G P became singular while doubling"))?;
        let a_w = a * w;
        let next_a = a_w * a;
        let next_g = g + a_w * g * a.transpose();
        let next_p = p + a.transpose() * p * w * a;
        a = next_a;
        g = (next_g + next_g.transpose()) * 0.5;
        let change = (next_p - p).norm();
        p = (next_p + next_p.transpose()) * 0.5;
        if !(finite(p.as_slice()) && finite(a.as_slice()) && finite(g.as_slice())) {
            return Err(invalid(
                "riccati equation",
                "(not finite)",
                "the doubling iteration diverged: no stabilising solution",
            ));
        }
        if change <= DARE_TOLERANCE * p.norm() && a.norm() <= DARE_TRANSITION_TOLERANCE {
            return Ok(p);
        }
    }
    Err(invalid(
        "riccati equation",
        DARE_MAX_DOUBLINGS,
        "doubling steps did not converge: no stabilising solution ((F, Q) not stabilisable or (F, H) not detectable)",
    ))
}

/// Per-joint Kalman filters of `(q, q̇)` or `(q, q̇, d)`; see the module documentation for the
/// model, the timing and the start.
#[derive(Debug, Clone, PartialEq)]
pub struct JointKalman<const N: usize> {
    period: f64,
    settings: KalmanSettings,
    delay: usize,
    /// Whether the filter takes the rate measurement.
    measures_rate: bool,
    /// `F`, `G`, `Q` (the same for every joint).
    f: Matrix3<f64>,
    g: Vector3<f64>,
    q: Matrix3<f64>,
    /// `F^δ` and `Σ_{i<δ} F^i Q F^iᵀ`: the forward prediction's covariance terms.
    f_ahead: Matrix3<f64>,
    q_ahead: Matrix3<f64>,
    /// Per joint, the variances of the angle and of the rate measurement.
    angle_variance: JointVector<N>,
    rate_variance: JointVector<N>,
    /// Per joint, the a-priori steady covariance `P∞`, its gain `K∞` and `P₀ = (I − K∞ H) P∞`.
    steady_covariance: [Matrix3<f64>; N],
    steady_gain: [Matrix3x2<f64>; N],
    initial_covariance: [Matrix3<f64>; N],
    /// The filter's state and covariance at sample `k − δ`.
    x: [Vector3<f64>; N],
    p: [Matrix3<f64>; N],
    /// The gain of the last update.
    gain: [Matrix3x2<f64>; N],
    /// The estimate of `x_k` last returned.
    ahead: [Vector3<f64>; N],
    /// The last `δ + 1` inputs, `u_{k−δ−1}` at `head` after an update.
    inputs: [JointVector<N>; MAX_DELAY_SAMPLES + 1],
    head: usize,
    /// The last covariance steps, to reuse.
    remembered: Remembered<N>,
}

/// One joint's covariance step: from the a-posteriori covariance `from` with the readings that
/// arrived (`angle`, `rate`), the gains and the covariance `to` it gave.
///
/// The step is a function of these alone (`F`, `Q` and `R` are fixed for the filter's life), so
/// a step from the same bits with the same readings can be skipped and its result reused: the
/// estimates are the same bits as computing it. With finite readings the recursion soon
/// reaches a fixed point in floating point or a cycle of two (measured: after 69 samples for
/// the hobby encoders at 1 kHz with the default tuning, none for the two-state filter, whose
/// start is its fixed point, and cycles of two with some rate sensors), so the filter remembers
/// its last two steps per joint ([`Remembered`]), which saves most of its arithmetic a sample.
#[derive(Debug, Clone, Copy)]
struct CovarianceStep {
    from: Matrix3<f64>,
    angle: bool,
    rate: bool,
    angle_gain: Vector3<f64>,
    /// The batch gain the two scalar updates amount to ([`JointKalman::gain`]); its second
    /// column is the rate reading's gain.
    gain: Matrix3x2<f64>,
    to: Matrix3<f64>,
}

/// Per joint, the last two covariance steps computed, newest first. A cache, not part of the
/// filter's state: two filters compare equal whatever it holds.
#[derive(Debug, Clone, Copy)]
struct Remembered<const N: usize>([[Option<CovarianceStep>; 2]; N]);

impl<const N: usize> PartialEq for Remembered<N> {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// Bit-for-bit equality (`+0 ≠ −0`, a NaN equals the same NaN): no entry's bits differ, all
/// nine compared without a branch.
fn same_bits(a: &Matrix3<f64>, b: &Matrix3<f64>) -> bool {
    a.iter().zip(b.iter()).fold(0, |differ, (a, b)| differ | (a.to_bits() ^ b.to_bits())) == 0
}

impl<const N: usize> JointKalman<N> {
    /// Filters for samples every `period` s, angle readings of σ `angle_std` rad per joint,
    /// rate readings of σ `rate_std` rad/s where there is a velocity sensor, readings
    /// `delay_samples` samples old, and `settings`. Checks every number, naming the field; the
    /// measurement σ must be > 0 (a zero σ declares an exact reading, which needs no filter:
    /// use the direct estimator), and so must the process noises (without them the gains decay
    /// to zero and the filter stops following the sensors; a constant disturbance is a random
    /// walk of small σ). Solves each joint's Riccati equation for its steady covariance.
    pub fn new(
        period: f64,
        angle_std: JointVector<N>,
        rate_std: Option<JointVector<N>>,
        delay_samples: usize,
        settings: KalmanSettings,
    ) -> Result<Self, SenseError> {
        let positive = |field: String, value: f64, unit: &str| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(invalid(field, value, format!("must be finite and > 0 {unit}")))
            }
        };
        positive("kalman period".into(), period, "s")?;
        for (j, value) in angle_std.iter().enumerate() {
            positive(format!("kalman angle_std joint {}", j + 1), *value, "rad (an exact angle needs no filter)")?;
        }
        if let Some(rate_std) = &rate_std {
            for (j, value) in rate_std.iter().enumerate() {
                positive(format!("kalman rate_std joint {}", j + 1), *value, "rad/s (an exact rate needs no filter)")?;
            }
        }
        if delay_samples > MAX_DELAY_SAMPLES {
            return Err(invalid("kalman delay_samples", delay_samples, format!("must be at most {MAX_DELAY_SAMPLES}")));
        }
        positive("kalman acceleration_noise".into(), settings.acceleration_noise, "rad/s²")?;
        if let Some(noise) = settings.disturbance_noise {
            positive("kalman disturbance_noise".into(), noise, "rad/s² per sample (None: no disturbance state)")?;
        }

        let t = period;
        let with_disturbance = settings.disturbance_noise.is_some();
        let f = if with_disturbance {
            Matrix3::new(1.0, t, 0.5 * t * t, 0.0, 1.0, t, 0.0, 0.0, 1.0)
        } else {
            Matrix3::new(1.0, t, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0)
        };
        let g = Vector3::new(0.5 * t * t, t, 0.0);
        let sigma_a = settings.acceleration_noise;
        let mut q = g * g.transpose() * (sigma_a * sigma_a);
        if let Some(sigma_d) = settings.disturbance_noise {
            q[(2, 2)] = sigma_d * sigma_d;
        }
        let (mut f_ahead, mut q_ahead) = (Matrix3::identity(), Matrix3::zeros());
        for _ in 0..delay_samples {
            q_ahead += f_ahead * q * f_ahead.transpose();
            f_ahead = f * f_ahead;
        }

        let measures_rate = rate_std.is_some();
        let angle_variance = angle_std.component_mul(&angle_std);
        let rate_variance = rate_std.map_or_else(JointVector::zeros, |s| s.component_mul(&s));
        // Without a rate sensor the second measurement row is zero; its placeholder variance
        // of 1 keeps R invertible and changes nothing (G = Hᵀ R⁻¹ H and K's second column are
        // zero).
        let h = if measures_rate {
            Matrix2x3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0)
        } else {
            Matrix2x3::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        };
        let mut steady_covariance = [Matrix3::zeros(); N];
        let mut steady_gain = [Matrix3x2::zeros(); N];
        let mut initial_covariance = [Matrix3::zeros(); N];
        for j in 0..N {
            let r = Matrix2::new(angle_variance[j], 0.0, 0.0, if measures_rate { rate_variance[j] } else { 1.0 });
            let p = solve_dare(&f, &h, &q, &r).map_err(|error| match error {
                SenseError::InvalidField { value, reason, .. } => SenseError::InvalidField {
                    field: format!("kalman settings (joint {} riccati equation)", j + 1),
                    value,
                    reason,
                },
            })?;
            let s = h * p * h.transpose() + r;
            let s_inverse = s.try_inverse().ok_or_else(|| {
                invalid(format!("kalman joint {} steady innovation covariance", j + 1), s.norm(), "is singular")
            })?;
            let k = p * h.transpose() * s_inverse;
            let a = Matrix3::identity() - k * h;
            let posterior = a * p * a.transpose() + k * r * k.transpose();
            steady_covariance[j] = p;
            steady_gain[j] = k;
            initial_covariance[j] = (posterior + posterior.transpose()) * 0.5;
        }

        let mut filter = Self {
            period,
            settings,
            delay: delay_samples,
            measures_rate,
            f,
            g,
            q,
            f_ahead,
            q_ahead,
            angle_variance,
            rate_variance,
            steady_covariance,
            steady_gain,
            initial_covariance,
            x: [Vector3::zeros(); N],
            p: initial_covariance,
            gain: steady_gain,
            ahead: [Vector3::zeros(); N],
            inputs: [JointVector::zeros(); MAX_DELAY_SAMPLES + 1],
            head: 0,
            remembered: Remembered([[None; 2]; N]),
        };
        filter.reset(&JointState::at_rest(JointVector::zeros()));
        Ok(filter)
    }

    /// The sample period, s.
    pub fn period(&self) -> f64 {
        self.period
    }

    pub fn settings(&self) -> &KalmanSettings {
        &self.settings
    }

    /// Samples between a reading and the update it arrives at.
    pub fn delay_samples(&self) -> usize {
        self.delay
    }

    /// Whether the filter has the disturbance state `d`.
    pub fn has_disturbance(&self) -> bool {
        self.settings.disturbance_noise.is_some()
    }

    /// Starts at `initial` (angles from the first due reading, rates as the arm was), no
    /// disturbance, covariance `P₀ = (I − K∞ H) P∞` (see the module documentation).
    pub fn reset(&mut self, initial: &JointState<N>) {
        let covariance = self.initial_covariance;
        self.start(initial, &covariance);
    }

    /// [`JointKalman::reset`] with every joint's covariance starting at `covariance` (rad²,
    /// rad²/s, …; without the disturbance state its third row and column are ignored). An error
    /// if it is not finite, symmetric and positive semi-definite.
    pub fn reset_with_covariance(
        &mut self,
        initial: &JointState<N>,
        covariance: &Matrix3<f64>,
    ) -> Result<(), SenseError> {
        let mut p = *covariance;
        if !self.has_disturbance() {
            p.row_mut(2).fill(0.0);
            p.column_mut(2).fill(0.0);
        }
        let field = "kalman initial covariance";
        if !p.iter().all(|v| v.is_finite()) {
            return Err(invalid(field, "(not finite)", "every entry must be finite"));
        }
        let asymmetry = (p - p.transpose()).norm();
        if asymmetry > 1e-12 * p.norm() {
            return Err(invalid(field, asymmetry, "must be symmetric (the value is ‖P − Pᵀ‖)"));
        }
        let smallest = p.symmetric_eigenvalues().min();
        if smallest < -1e-12 * p.norm() {
            return Err(invalid(field, smallest, "must be positive semi-definite (the value is its least eigenvalue)"));
        }
        self.start(initial, &[p; N]);
        Ok(())
    }

    fn start(&mut self, initial: &JointState<N>, covariance: &[Matrix3<f64>; N]) {
        self.x = std::array::from_fn(|j| Vector3::new(initial.q[j], initial.qd[j], 0.0));
        self.p = *covariance;
        self.gain = self.steady_gain;
        self.inputs = [JointVector::zeros(); MAX_DELAY_SAMPLES + 1];
        self.head = 0;
        self.ahead = self.x;
        for _ in 0..self.delay {
            for x in self.ahead.iter_mut() {
                *x = self.f * *x;
            }
        }
    }

    /// One control sample: `measurement` is the reading of the state `delay_samples` samples
    /// ago, `applied` the acceleration commanded over the sample just ended, rad/s². Returns the
    /// estimate of the state now (see the module documentation for the timing).
    pub fn update(&mut self, measurement: &Measurement<N>, applied: &JointVector<N>) -> JointState<N> {
        let span = self.delay + 1;
        self.inputs[self.head] = applied.map(|u| if u.is_finite() { u } else { 0.0 });
        self.head = if self.head + 1 == span { 0 } else { self.head + 1 };
        // Now `inputs[head]` is u_{k−δ−1}, and the next δ slots hold u_{k−δ} … u_{k−1}.
        let oldest = self.inputs[self.head];
        let mut out = JointState { q: JointVector::zeros(), qd: JointVector::zeros() };
        for j in 0..N {
            let angle = measurement.q[j];
            let rate = if self.measures_rate {
                measurement.qd.and_then(|qd| Some(qd[j]).filter(|r| r.is_finite()))
            } else {
                None
            };
            let angle = angle.is_finite().then_some(angle);
            let (has_angle, has_rate) = (angle.is_some(), rate.is_some());
            let before = &self.p[j];
            let slots = &self.remembered.0[j];
            let known = |slot: &Option<CovarianceStep>| {
                slot.as_ref().is_some_and(|step| {
                    step.angle == has_angle && step.rate == has_rate && same_bits(&step.from, before)
                })
            };
            let slot = if known(&slots[0]) {
                0
            } else if known(&slots[1]) {
                1
            } else {
                self.covariance_step(j, has_angle, has_rate);
                0
            };
            let Some(step) = &self.remembered.0[j][slot] else {
                unreachable!("a remembered slot was found or just filled")
            };
            self.p[j] = step.to;
            self.gain[j] = step.gain;
            let model = (&self.f.data.0, &self.g.data.0[0]);
            let angle = angle.map(|angle| (angle, &step.angle_gain.data.0[0]));
            let rate = rate.map(|rate| (rate, &step.gain.data.0[1]));
            let mut x = state_step(model, &self.x[j].data.0[0], oldest[j], angle, rate);
            self.x[j] = x.into();

            let mut at = self.head;
            for _ in 0..self.delay {
                at = if at + 1 == span { 0 } else { at + 1 };
                x = predict(model.0, model.1, &x, self.inputs[at][j]);
            }
            let x = Vector3::from(x);
            self.ahead[j] = x;
            out.q[j] = x[0];
            out.qd[j] = x[1];
        }
        out
    }

    /// Joint `j`'s covariance over one sample, with the angle and (`rate`) the rate reading or
    /// without ([`covariance_step`]). Remembers the step (newest first).
    fn covariance_step(&mut self, j: usize, angle: bool, rate: bool) {
        let from = self.p[j];
        let variances = (self.angle_variance[j], self.rate_variance[j]);
        let step = covariance_step((&self.f.data.0, &self.q.data.0), &from.data.0, variances, angle, rate);
        let step = CovarianceStep {
            from,
            angle,
            rate,
            angle_gain: step.angle_gain.into(),
            gain: Matrix3x2::from_data(ArrayStorage(step.gain)),
            to: Matrix3::from_data(ArrayStorage(step.to)),
        };
        let remembered = &mut self.remembered.0[j];
        remembered[1] = remembered[0];
        remembered[0] = Some(step);
    }

    /// The estimate of the state now (the one [`JointKalman::update`] last returned; after a
    /// reset, the start carried forward over the delay).
    pub fn estimate(&self) -> JointState<N> {
        JointState {
            q: JointVector::from_fn(|j, _| self.ahead[j][0]),
            qd: JointVector::from_fn(|j, _| self.ahead[j][1]),
        }
    }

    /// The estimated disturbance acceleration `d` per joint, rad/s² (zeros without the
    /// disturbance state).
    pub fn disturbance(&self) -> JointVector<N> {
        JointVector::from_fn(|j, _| self.ahead[j][2])
    }

    /// Covariance of joint `joint`'s estimate of the state now, `P_{k|k−δ}` (module
    /// documentation) of `(q, q̇, d)`; zero third row and column without the disturbance state.
    ///
    /// # Panics
    /// If `joint ≥ N`.
    pub fn covariance(&self, joint: usize) -> Matrix3<f64> {
        let p = self.f_ahead * self.p[joint] * self.f_ahead.transpose() + self.q_ahead;
        (p + p.transpose()) * 0.5
    }

    /// Covariance of the filter's own estimate, a posteriori at the sample of the last reading,
    /// `P_{k−δ|k−δ}` (equal to [`JointKalman::covariance`] without delay).
    ///
    /// # Panics
    /// If `joint ≥ N`.
    pub fn filter_covariance(&self, joint: usize) -> Matrix3<f64> {
        self.p[joint]
    }

    /// The gain `K` of joint `joint`'s last update (its steady value after a reset): columns
    /// for the angle and the rate reading (zero without a rate sensor or a rate reading).
    ///
    /// # Panics
    /// If `joint ≥ N`.
    pub fn gain(&self, joint: usize) -> Matrix3x2<f64> {
        self.gain[joint]
    }

    /// The steady gain `K∞ = P∞ Hᵀ (H P∞ Hᵀ + R)⁻¹` of joint `joint`, columns as
    /// [`JointKalman::gain`].
    ///
    /// # Panics
    /// If `joint ≥ N`.
    pub fn steady_state_gain(&self, joint: usize) -> Matrix3x2<f64> {
        self.steady_gain[joint]
    }

    /// The a-priori steady covariance `P∞` of joint `joint` ([`solve_dare`]).
    ///
    /// # Panics
    /// If `joint ≥ N`.
    pub fn steady_state_covariance(&self, joint: usize) -> Matrix3<f64> {
        self.steady_covariance[joint]
    }
}

/// A 3×3 matrix of `f64` or of lanes by columns, `m[c][r]`: nalgebra's layout, so a
/// `Matrix3<f64>` is one as it is (`m.data.0`).
pub(crate) type Columns<S> = [[S; 3]; 3];

/// `A x`, in nalgebra's order of operations (its `gemv`, column by column):
/// `yᵣ = (Aᵣ₀ x₀ + Aᵣ₁ x₁) + Aᵣ₂ x₂`.
#[inline(always)]
fn times<S: Real>(a: &Columns<S>, x: &[S; 3]) -> [S; 3] {
    array3(
        #[inline(always)]
        |r| a[0][r] * x[0] + a[1][r] * x[1] + a[2][r] * x[2],
    )
}

/// `A B`, column by column as [`times`] (nalgebra's `gemm` for fixed sizes).
#[inline(always)]
fn product<S: Real>(a: &Columns<S>, b: &Columns<S>) -> Columns<S> {
    array3(
        #[inline(always)]
        |c| times(a, &b[c]),
    )
}

#[inline(always)]
fn transpose<S: Real>(a: &Columns<S>) -> Columns<S> {
    array3(
        #[inline(always)]
        |c| {
            array3(
                #[inline(always)]
                |r| a[r][c],
            )
        },
    )
}

/// `F P Fᵀ + Q`, the covariance's prediction over one sample.
#[inline(always)]
fn predicted<S: Real>(f: &Columns<S>, p: &Columns<S>, q: &Columns<S>) -> Columns<S> {
    let fpf = product(&product(f, p), &transpose(f));
    array3(
        #[inline(always)]
        |c| {
            array3(
                #[inline(always)]
                |r| fpf[c][r] + q[c][r],
            )
        },
    )
}

/// `F x + G u`, the state's prediction over one sample with the input `u` (rad/s²).
#[inline(always)]
pub(crate) fn predict<S: Real>(f: &Columns<S>, g: &[S; 3], x: &[S; 3], u: S) -> [S; 3] {
    let fx = times(f, x);
    array3(
        #[inline(always)]
        |r| fx[r] + g[r] * u,
    )
}

/// One joint's state over one sample: `x⁻ = F x + G u`, then `x += k₁ (q̃ − x₀)` with the
/// angle's gain `k₁` where an angle `q̃` arrived, then `x += k₂ (q̃̇ − x₁)` with the rate's
/// gain `k₂` (the batch gain's second column) where a rate arrived.
#[inline(always)]
pub(crate) fn state_step<S: Real>(
    (f, g): (&Columns<S>, &[S; 3]),
    x: &[S; 3],
    u: S,
    angle: Option<(S, &[S; 3])>,
    rate: Option<(S, &[S; 3])>,
) -> [S; 3] {
    let mut x = predict(f, g, x, u);
    if let Some((z, k)) = angle {
        let innovation = z - x[0];
        x = array3(
            #[inline(always)]
            |r| x[r] + k[r] * innovation,
        );
    }
    if let Some((z, k)) = rate {
        let innovation = z - x[1];
        x = array3(
            #[inline(always)]
            |r| x[r] + k[r] * innovation,
        );
    }
    x
}

/// One joint's covariance step: what [`covariance_step`] gives.
#[derive(Debug, Clone, Copy)]
pub(crate) struct CovarianceUpdate<S> {
    /// The angle reading's gain (zero where it did not arrive).
    pub angle_gain: [S; 3],
    /// The batch gain by columns: angle, rate ([`JointKalman::gain`]).
    pub gain: [[S; 3]; 2],
    /// The covariance after the step.
    pub to: Columns<S>,
}

/// One joint's covariance over one sample from `from`, with the angle and (`rate`) the rate
/// reading or without: `P⁻ = F P Fᵀ + Q`, then a Joseph update per reading ([`scalar_gain`]), of
/// variances `angle_variance` and `rate_variance`; the gain of a reading that did not arrive is
/// zero. The two scalar updates as one batch gain: `x += k₁ r₁ + k₂ (r₂ − k₁[1] r₁)`.
#[inline(always)]
pub(crate) fn covariance_step<S: Real>(
    (f, q): (&Columns<S>, &Columns<S>),
    from: &Columns<S>,
    (angle_variance, rate_variance): (S, S),
    angle: bool,
    rate: bool,
) -> CovarianceUpdate<S> {
    let zero = [S::splat(0.0); 3];
    let mut to = predicted(f, from, q);
    let angle_gain = if angle { scalar_gain(&mut to, 0, angle_variance) } else { zero };
    let rate_gain = if rate { scalar_gain(&mut to, 1, rate_variance) } else { zero };
    let first = array3(
        #[inline(always)]
        |r| angle_gain[r] - rate_gain[r] * angle_gain[1],
    );
    CovarianceUpdate { angle_gain, gain: [first, rate_gain], to }
}

/// The covariance update with one scalar reading of state component `row`, variance `r > 0`:
/// `k = P eᵣ / (Pᵣᵣ + r)`, `P = (I − k eᵣᵀ) P (I − k eᵣᵀ)ᵀ + r k kᵀ`, made symmetric
/// (`(P + Pᵀ)/2`), in nalgebra's order of operations. Returns `k`; the state's update is
/// `x += k (z − xᵣ)`.
#[inline(always)]
fn scalar_gain<S: Real>(p: &mut Columns<S>, row: usize, r: S) -> [S; 3] {
    let innovation_variance = p[row][row] + r;
    let k = array3(
        #[inline(always)]
        |i| p[row][i] / innovation_variance,
    );
    // `I − k eᵣᵀ`: column `row` is `eᵣ − k` (each entry a subtraction, `0 − k` included).
    let a: Columns<S> = array3(
        #[inline(always)]
        |c| {
            array3(
                #[inline(always)]
                |i| {
                    let identity = S::splat(if i == c { 1.0 } else { 0.0 });
                    if c == row { identity - k[i] } else { identity }
                },
            )
        },
    );
    let apa = product(&product(&a, p), &transpose(&a));
    let joseph: Columns<S> = array3(
        #[inline(always)]
        |c| {
            array3(
                #[inline(always)]
                |i| apa[c][i] + k[i] * k[c] * r,
            )
        },
    );
    *p = array3(
        #[inline(always)]
        |c| {
            array3(
                #[inline(always)]
                |i| (joseph[c][i] + joseph[i][c]) * S::splat(0.5),
            )
        },
    );
    k
}

/// The joint Kalman filters of `L` runs side by side ([`crate::sim::batch`]): each lane is one
/// run's [`JointKalman<4>`], its constants and state gathered into lanes and updated by the
/// same formulas ([`covariance_step`], [`state_step`], [`predict`]) in the same order, so each
/// lane's estimates, covariances and gains are its filter's, bit for bit. A joint where some
/// lane's reading is missing (not finite) is updated lane by lane, by the same formulas on
/// `f64`. Idle lanes are computed too: their readings must be finite (zeros will do), or they
/// send every joint down the lane-by-lane path.
///
/// Like the scalar filter, it remembers each joint's last two covariance steps (for every lane
/// at once, with both readings there) and reuses one whose starting covariance has the bits of
/// every lane's: once the lanes' recursions have settled into their fixed points or cycles of
/// two, the covariance costs a comparison a sample.
#[derive(Debug, Clone)]
pub(crate) struct KalmanLanes<const L: usize> {
    delay: usize,
    measures_rate: bool,
    f: Columns<Lanes<L>>,
    g: [Lanes<L>; 3],
    q: Columns<Lanes<L>>,
    angle_variance: [Lanes<L>; 4],
    rate_variance: [Lanes<L>; 4],
    x: [[Lanes<L>; 3]; 4],
    p: [Columns<Lanes<L>>; 4],
    gain: [[[Lanes<L>; 3]; 2]; 4],
    ahead: [[Lanes<L>; 3]; 4],
    inputs: [[Lanes<L>; 4]; MAX_DELAY_SAMPLES + 1],
    head: usize,
    /// Per joint, the last two covariance steps with every reading there (the covariance they
    /// started from, and what they gave), and which of the two is the newest.
    remembered: [[Option<RememberedLanes<L>>; 2]; 4],
    newest: [usize; 4],
    /// Per joint, the remembered step whose result is the covariance and gain now, or `None`
    /// where they are `p` and `gain` (not copied out of the step, which is most of the work a
    /// sample once the steps repeat).
    current: [Option<usize>; 4],
    /// Per joint and remembered step, the remembered step that starts from its result (bit for
    /// bit in every lane), [`NO_STEP`] where none does: found when a step is remembered, so
    /// that a sample after a remembered step compares no covariances.
    follows: [[usize; 2]; 4],
}

/// In [`KalmanLanes`]' `follows`: no remembered step starts there.
const NO_STEP: usize = 2;

/// A covariance step of every lane: the covariance it started from, and what it gave.
type RememberedLanes<const L: usize> = (Columns<Lanes<L>>, CovarianceUpdate<Lanes<L>>);

/// Whether every entry of `a` has the bits of `b`'s, in every lane (without a branch).
#[inline(always)]
fn same_lanes<const L: usize>(a: &Columns<Lanes<L>>, b: &Columns<Lanes<L>>) -> bool {
    let mut differ = 0;
    for (a, b) in a.iter().flatten().zip(b.iter().flatten()) {
        for (a, b) in a.0.iter().zip(&b.0) {
            differ |= a.to_bits() ^ b.to_bits();
        }
    }
    differ == 0
}

/// Whether `slot` holds a step from the covariance `now` (bit for bit in every lane).
#[inline(always)]
fn knows<const L: usize>(slot: &Option<RememberedLanes<L>>, now: &Columns<Lanes<L>>) -> bool {
    match slot {
        Some((from, _)) => same_lanes(from, now),
        None => false,
    }
}

impl<const L: usize> KalmanLanes<L> {
    /// The filters of `filters` side by side (lane `i` is `filters[i]`; a lane without one
    /// copies the first's, and its results are not read), if there is one and all have the
    /// same delay, velocity sensor (or none) and head of their ring of inputs.
    pub fn of(filters: [Option<&JointKalman<4>>; L]) -> Option<Self> {
        let first = *filters.iter().flatten().next()?;
        if filters
            .iter()
            .flatten()
            .any(|k| k.delay != first.delay || k.measures_rate != first.measures_rate || k.head != first.head)
        {
            return None;
        }
        let lane = |i: usize| filters[i].unwrap_or(first);
        let lanes = |f: &dyn Fn(&JointKalman<4>) -> f64| Lanes(std::array::from_fn(|i| f(lane(i))));
        let columns = |f: &dyn Fn(&JointKalman<4>) -> Matrix3<f64>| -> Columns<Lanes<L>> {
            array3(|c| array3(|r| lanes(&|k| f(k)[(r, c)])))
        };
        Some(Self {
            delay: first.delay,
            measures_rate: first.measures_rate,
            f: columns(&|k| k.f),
            g: array3(|r| lanes(&|k| k.g[r])),
            q: columns(&|k| k.q),
            angle_variance: array4(|j| lanes(&|k| k.angle_variance[j])),
            rate_variance: array4(|j| lanes(&|k| k.rate_variance[j])),
            x: array4(|j| array3(|r| lanes(&|k| k.x[j][r]))),
            p: array4(|j| columns(&|k| k.p[j])),
            gain: array4(|j| [0, 1].map(|c| array3(|r| lanes(&|k| k.gain[j][(r, c)])))),
            ahead: array4(|j| array3(|r| lanes(&|k| k.ahead[j][r]))),
            inputs: std::array::from_fn(|slot| array4(|j| lanes(&|k| k.inputs[slot][j]))),
            head: first.head,
            remembered: [[None; 2]; 4],
            // So that the first step computed goes to slot 0.
            newest: [1; 4],
            current: [None; 4],
            follows: [[NO_STEP; 2]; 4],
        })
    }

    /// Joint `j`'s covariance now, by columns.
    #[inline(always)]
    fn covariance(&self, j: usize) -> &Columns<Lanes<L>> {
        match self.current[j] {
            Some(slot) => &self.remembered_step(j, slot).to,
            None => &self.p[j],
        }
    }

    /// Joint `j`'s gain now, by columns.
    #[inline(always)]
    fn gain(&self, j: usize) -> &[[Lanes<L>; 3]; 2] {
        match self.current[j] {
            Some(slot) => &self.remembered_step(j, slot).gain,
            None => &self.gain[j],
        }
    }

    #[inline(always)]
    fn remembered_step(&self, j: usize, slot: usize) -> &CovarianceUpdate<Lanes<L>> {
        match &self.remembered[j][slot] {
            Some((_, step)) => step,
            None => unreachable!("a current step is a remembered one"),
        }
    }

    /// [`JointKalman::update`] of every lane: `q` the angle readings (rad), `qd` the rate
    /// readings (rad/s; read only with a velocity sensor, a missing one NaN), `applied` the
    /// accelerations commanded over the sample just ended (rad/s²). Returns the estimates of
    /// the state now, angles and rates.
    #[inline(always)]
    pub fn update(
        &mut self,
        q: &[Lanes<L>; 4],
        qd: &[Lanes<L>; 4],
        applied: &[Lanes<L>; 4],
    ) -> ([Lanes<L>; 4], [Lanes<L>; 4]) {
        let span = self.delay + 1;
        self.inputs[self.head] = array4(
            #[inline(always)]
            |j| applied[j].each(|u| if u.is_finite() { u } else { 0.0 }),
        );
        self.head = if self.head + 1 == span { 0 } else { self.head + 1 };
        // Now `inputs[head]` is u_{k−δ−1}, and the next δ slots hold u_{k−δ} … u_{k−1}.
        let oldest = self.inputs[self.head];
        // Every lane at once: `all` stops at the first lane that is not, a branch per lane.
        #[inline(always)]
        fn finite<const L: usize>(v: &Lanes<L>) -> bool {
            v.lanes_where(|v| !v.is_finite()) == 0
        }
        let rate = self.measures_rate;
        let (mut out_q, mut out_qd) = ([Lanes::splat(0.0); 4], [Lanes::splat(0.0); 4]);
        for j in 0..4 {
            if finite(&q[j]) && (!rate || finite(&qd[j])) {
                let now = self.covariance(j);
                // After a remembered step, the one that follows it, if any (known without a
                // compare); else the newest first, then the older. A step not remembered
                // replaces the older.
                let known = match self.current[j] {
                    Some(slot) => self.follows[j][slot],
                    None => self.starting_at(j, now),
                };
                let slot = if known != NO_STEP {
                    known
                } else {
                    let older = 1 - self.newest[j];
                    let from = *now;
                    let variances = (self.angle_variance[j], self.rate_variance[j]);
                    let step = covariance_step((&self.f, &self.q), &from, variances, true, rate);
                    self.remembered[j][older] = Some((from, step));
                    self.newest[j] = older;
                    self.link(j);
                    older
                };
                self.current[j] = Some(slot);
                let Some((_, step)) = &self.remembered[j][slot] else {
                    unreachable!("a remembered slot was found or just filled")
                };
                let rate = rate.then_some((qd[j], &step.gain[1]));
                let angle = Some((q[j], &step.angle_gain));
                self.x[j] = state_step((&self.f, &self.g), &self.x[j], oldest[j], angle, rate);
            } else {
                for i in 0..L {
                    self.update_lane(i, j, (q[j].0[i], qd[j].0[i]), oldest[j].0[i]);
                }
            }
            let mut x = self.x[j];
            let mut at = self.head;
            for _ in 0..self.delay {
                at = if at + 1 == span { 0 } else { at + 1 };
                x = predict(&self.f, &self.g, &x, self.inputs[at][j]);
            }
            self.ahead[j] = x;
            out_q[j] = x[0];
            out_qd[j] = x[1];
        }
        (out_q, out_qd)
    }

    /// Joint `j`'s remembered step that starts from `covariance` (bit for bit in every lane),
    /// the newest first: at a fixed point the only one compared. [`NO_STEP`] where none does.
    #[inline(always)]
    fn starting_at(&self, j: usize, covariance: &Columns<Lanes<L>>) -> usize {
        let (newest, older) = (self.newest[j], 1 - self.newest[j]);
        if knows(&self.remembered[j][newest], covariance) {
            newest
        } else if knows(&self.remembered[j][older], covariance) {
            older
        } else {
            NO_STEP
        }
    }

    /// Finds, for each of joint `j`'s remembered steps, the remembered step that starts from
    /// its result (`follows`), as a sample's search would.
    fn link(&mut self, j: usize) {
        for slot in 0..2 {
            self.follows[j][slot] = match &self.remembered[j][slot] {
                Some((_, step)) => self.starting_at(j, &step.to),
                None => NO_STEP,
            };
        }
    }

    /// Lane `i`'s joint `j` over one sample with its readings `(angle, rate)` (either may be
    /// missing: not finite) and input `u`, as its own filter takes it.
    fn update_lane(&mut self, i: usize, j: usize, (angle, rate): (f64, f64), u: f64) {
        if self.current[j].is_some() {
            self.p[j] = *self.covariance(j);
            self.gain[j] = *self.gain(j);
            self.current[j] = None;
        }
        let one = |m: &Columns<Lanes<L>>| -> Columns<f64> { array3(|c| array3(|r| m[c][r].0[i])) };
        let (f, q) = (one(&self.f), one(&self.q));
        let g = self.g.map(|v| v.0[i]);
        let has_angle = angle.is_finite();
        let has_rate = self.measures_rate && rate.is_finite();
        let variances = (self.angle_variance[j].0[i], self.rate_variance[j].0[i]);
        let step = covariance_step((&f, &q), &one(&self.p[j]), variances, has_angle, has_rate);
        let angle = has_angle.then_some((angle, &step.angle_gain));
        let rate = has_rate.then_some((rate, &step.gain[1]));
        let x = state_step((&f, &g), &self.x[j].map(|v| v.0[i]), u, angle, rate);
        for (r, x) in x.into_iter().enumerate() {
            self.x[j][r].0[i] = x;
            for c in 0..3 {
                self.p[j][c][r].0[i] = step.to[c][r];
            }
            for c in 0..2 {
                self.gain[j][c][r].0[i] = step.gain[c][r];
            }
        }
    }

    /// Writes lane `i`'s state (estimates, covariances, gains, inputs) into `filter`, the
    /// filter it was gathered from: as the filter would be had it taken the same samples.
    pub fn hand_back(&self, i: usize, filter: &mut JointKalman<4>) {
        for j in 0..4 {
            filter.x[j] = Vector3::from(self.x[j].map(|v| v.0[i]));
            filter.ahead[j] = Vector3::from(self.ahead[j].map(|v| v.0[i]));
            let (p, gain) = (self.covariance(j), self.gain(j));
            filter.p[j] = Matrix3::from_fn(|r, c| p[c][r].0[i]);
            filter.gain[j] = Matrix3x2::from_fn(|r, c| gain[c][r].0[i]);
        }
        for (slot, inputs) in filter.inputs.iter_mut().zip(&self.inputs) {
            *slot = JointVector::from_fn(|j, _| inputs[j].0[i]);
        }
        filter.head = self.head;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sense::rng::SeededRng;

    /// The textbook filter, written out without any remembered step: per joint, predict
    /// `x ← F x + G u`, `P ← F P Fᵀ + Q`, then take the angle and then the rate reading one at a
    /// time, each with `k = P e / (eᵀ P e + r)`, `x ← x + k (z − eᵀ x)` and Joseph's
    /// `P ← (I − k eᵀ) P (I − k eᵀ)ᵀ + k r kᵀ` made symmetric; then the delayed inputs ahead.
    /// The filter's state update must keep these operations, in this order.
    fn textbook_update<const N: usize>(
        s: &mut JointKalman<N>,
        measurement: &Measurement<N>,
        applied: &JointVector<N>,
    ) -> JointState<N> {
        fn reading(x: &mut Vector3<f64>, p: &mut Matrix3<f64>, row: usize, z: f64, r: f64) -> Vector3<f64> {
            let k: Vector3<f64> = p.column(row) / (p[(row, row)] + r);
            *x += k * (z - x[row]);
            let mut a = Matrix3::<f64>::identity();
            for i in 0..3 {
                a[(i, row)] -= k[i];
            }
            let joseph = a * *p * a.transpose() + k * k.transpose() * r;
            *p = (joseph + joseph.transpose()) * 0.5;
            k
        }
        let span = s.delay + 1;
        s.inputs[s.head] = applied.map(|u| if u.is_finite() { u } else { 0.0 });
        s.head = (s.head + 1) % span;
        let oldest = s.inputs[s.head];
        let mut out = JointState { q: JointVector::zeros(), qd: JointVector::zeros() };
        for j in 0..N {
            let mut x = s.f * s.x[j] + s.g * oldest[j];
            let mut p = s.f * s.p[j] * s.f.transpose() + s.q;
            let angle = measurement.q[j];
            let angle_gain = if angle.is_finite() {
                reading(&mut x, &mut p, 0, angle, s.angle_variance[j])
            } else {
                Vector3::zeros()
            };
            let rate = if s.measures_rate { measurement.qd.map(|qd| qd[j]) } else { None };
            let rate_gain = match rate {
                Some(rate) if rate.is_finite() => reading(&mut x, &mut p, 1, rate, s.rate_variance[j]),
                _ => Vector3::zeros(),
            };
            s.gain[j].set_column(0, &(angle_gain - rate_gain * angle_gain[1]));
            s.gain[j].set_column(1, &rate_gain);
            s.x[j] = x;
            s.p[j] = p;
            for i in 1..=s.delay {
                x = s.f * x + s.g * s.inputs[(s.head + i) % span][j];
            }
            s.ahead[j] = x;
            out.q[j] = x[0];
            out.qd[j] = x[1];
        }
        out
    }

    /// The filter equals [`textbook_update`] bit for bit (estimates, covariances, gains,
    /// disturbance) over 40 tunings (with and without a rate sensor, delays up to the most,
    /// both state models, several periods) and 4 000 samples each, through readings that go
    /// missing or are NaN, ±∞, 1e300 or ±0 in stretches, a missing rate reading, non-finite
    /// inputs, resets (with a covariance holding −0) and a clone midway.
    #[test]
    fn the_filter_equals_the_textbook_update_bit_for_bit() {
        let mut rng = SeededRng::new(99);
        let odd = [f64::NAN, f64::INFINITY, -f64::INFINITY, 1e300, -0.0, 0.0];
        for case in 0..40u64 {
            let rate_std = (case % 2 == 1).then(|| JointVector::<2>::new(0.01 + 0.01 * (case % 5) as f64, 0.3));
            let delay = [0, 1, 2, 5, MAX_DELAY_SAMPLES][(case % 5) as usize];
            let settings = if case % 3 == 0 { KalmanSettings::TWO_STATE } else { KalmanSettings::DEFAULT };
            let angle_std = JointVector::<2>::new(1e-4 * (1 + case % 7) as f64, 3e-3);
            let mut filter =
                JointKalman::new(1e-3 * (1 + case % 4) as f64, angle_std, rate_std, delay, settings).unwrap();
            let mut textbook = filter.clone();
            let bits = |s: &JointState<2>| s.q.iter().chain(s.qd.iter()).map(|v| v.to_bits()).collect::<Vec<_>>();
            for k in 0..4000 {
                // Every other stretch of 300 samples loses a tenth of its readings.
                let loss = if (k / 300) % 2 == 0 { 0.0 } else { 0.1 };
                let t = k as f64 * 1e-3;
                let spoil = |v: &mut JointVector<2>, rng: &mut SeededRng| {
                    for j in 0..2 {
                        if rng.unit() < loss {
                            v[j] = odd[(rng.next_u64() % 6) as usize];
                        }
                    }
                };
                let mut q = JointVector::<2>::from_fn(|j, _| (t + j as f64).sin() + 1e-3 * rng.normal());
                spoil(&mut q, &mut rng);
                let mut qd =
                    rate_std.map(|_| JointVector::<2>::from_fn(|j, _| (t + j as f64).cos() + 0.02 * rng.normal()));
                if let Some(qd) = qd.as_mut() {
                    spoil(qd, &mut rng);
                }
                let qd = if rate_std.is_some() && rng.unit() < loss { None } else { qd };
                let applied =
                    JointVector::<2>::from_fn(|j, _| if rng.unit() < 0.01 { f64::NAN } else { -(t + j as f64).sin() });
                if k % 997 == 500 {
                    let at = JointState { q: JointVector::<2>::new(0.1, -0.0), qd: JointVector::<2>::new(0.0, 1.0) };
                    filter.reset(&at);
                    textbook.reset(&at);
                }
                if k % 1231 == 700 {
                    let at = JointState::at_rest(JointVector::<2>::new(0.3, 0.2));
                    let covariance = Matrix3::new(1e-6, -0.0, 0.0, -0.0, 1e-4, 0.0, 0.0, 0.0, 1e-2);
                    filter.reset_with_covariance(&at, &covariance).unwrap();
                    textbook.reset_with_covariance(&at, &covariance).unwrap();
                }
                if k % 1500 == 1499 {
                    filter = filter.clone();
                }
                let measurement = Measurement { q, qd };
                let a = filter.update(&measurement, &applied);
                let b = textbook_update(&mut textbook, &measurement, &applied);
                assert_eq!(bits(&a), bits(&b), "case {case}, sample {k}: estimates");
                for j in 0..2 {
                    assert!(same_bits(&filter.p[j], &textbook.p[j]), "case {case}, sample {k}: covariance");
                    assert!(same_bits(&filter.covariance(j), &textbook.covariance(j)), "case {case}, sample {k}");
                    let mut gains = filter.gain[j].iter().zip(textbook.gain[j].iter());
                    assert!(gains.all(|(a, b)| a.to_bits() == b.to_bits()), "case {case}, sample {k}: gain");
                }
                let (d1, d2) = (filter.disturbance(), textbook.disturbance());
                assert!(d1.iter().zip(d2.iter()).all(|(a, b)| a.to_bits() == b.to_bits()), "case {case}, sample {k}");
            }
        }
    }

    /// A reset forgets everything of the run before: a filter that has run (inputs in its ring,
    /// its gain and covariance moved by missing readings) and is then reset equals a new filter
    /// reset to the same state, field by field (the ring of inputs zeroed, the head at 0, the
    /// steady gain, the start's covariance), and the two give the same bits from then on; the
    /// same for a reset to a given covariance.
    #[test]
    fn a_reset_filter_is_a_new_one() {
        let angle_std = JointVector::<4>::from_fn(|j, _| 4e-4 * (j + 1) as f64);
        let cases = [
            (None, 2, KalmanSettings::DEFAULT),
            (Some(JointVector::<4>::from_element(0.02)), 3, KalmanSettings::TWO_STATE),
            (None, 0, KalmanSettings::DEFAULT),
        ];
        for (case, (rate_std, delay, settings)) in cases.into_iter().enumerate() {
            let fresh = JointKalman::new(1e-3, angle_std, rate_std, delay, settings).unwrap();
            let mut used = fresh.clone();
            let mut rng = SeededRng::new(case as u64 + 11);
            let reading = |rng: &mut SeededRng, k: usize| {
                let q = JointVector::<4>::from_fn(|j, _| {
                    if rng.unit() < 0.1 { f64::NAN } else { (k as f64 * 1e-2 + j as f64).sin() }
                });
                let qd = rate_std.map(|_| JointVector::<4>::from_fn(|j, _| (k as f64 * 1e-2 + j as f64).cos()));
                (Measurement { q, qd }, JointVector::<4>::from_fn(|j, _| 3.0 + j as f64 + rng.normal()))
            };
            for k in 0..50 {
                let (measurement, applied) = reading(&mut rng, k);
                used.update(&measurement, &applied);
            }
            let start = JointState { q: JointVector::from_fn(|j, _| 0.1 * j as f64), qd: JointVector::repeat(-0.2) };
            let mut again = fresh.clone();
            used.reset(&start);
            again.reset(&start);
            assert!(used == again, "case {case}: reset after a run differs from a new filter's");
            let mut p0 = Matrix3::identity() * 1e-6;
            p0[(0, 1)] = 2e-7;
            p0[(1, 0)] = 2e-7;
            let (mut used_p, mut again_p) = (used.clone(), fresh.clone());
            for k in 0..20 {
                let (measurement, applied) = reading(&mut rng, k);
                used_p.update(&measurement, &applied);
            }
            assert!(used_p.reset_with_covariance(&start, &p0).is_ok());
            assert!(again_p.reset_with_covariance(&start, &p0).is_ok());
            assert!(used_p == again_p, "case {case}: reset to a covariance after a run differs");
            for k in 0..200 {
                let (measurement, applied) = reading(&mut rng, k);
                let bits = |s: JointState<4>| s.q.iter().chain(s.qd.iter()).map(|v| v.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(used.update(&measurement, &applied)), bits(again.update(&measurement, &applied)));
                let (a, b) = (used_p.update(&measurement, &applied), again_p.update(&measurement, &applied));
                assert_eq!(bits(a), bits(b), "case {case}, sample {k}");
            }
        }
    }

    /// The remembered covariance steps change no bit: a filter that keeps it and one that forgets it
    /// before every sample give the same estimates, gains and covariances, through readings
    /// that go missing (NaN) now and then after the covariance has settled, with and without a
    /// rate sensor, delay and disturbance state; and from sample 400 on (readings all there)
    /// every step is one remembered: the recursion has reached its fixed point or 2-cycle.
    #[test]
    fn the_settled_covariance_step_gives_the_bits_of_the_full_step() {
        let cases = [
            (None, 1, KalmanSettings::DEFAULT),
            (None, 0, KalmanSettings::TWO_STATE),
            (Some(JointVector::<4>::from_element(0.02)), 2, KalmanSettings::DEFAULT),
            (Some(JointVector::<4>::from_element(0.05)), 0, KalmanSettings::TWO_STATE),
        ];
        for (case, (rate_std, delay, settings)) in cases.into_iter().enumerate() {
            let angle_std = JointVector::<4>::from_fn(|j, _| 4e-4 * (j + 1) as f64);
            let mut keeps = JointKalman::new(1e-3, angle_std, rate_std, delay, settings).unwrap();
            let mut forgets = keeps.clone();
            let mut rng = SeededRng::new(case as u64);
            let mut reused = 0;
            for k in 0..3000 {
                let missing = |rng: &mut SeededRng| k > 500 && rng.unit() < 0.02;
                let q = JointVector::<4>::from_fn(|j, _| {
                    if missing(&mut rng) { f64::NAN } else { (k as f64 * 1e-3 + j as f64).sin() + 1e-3 * rng.normal() }
                });
                let qd = rate_std.map(|_| {
                    JointVector::<4>::from_fn(|j, _| {
                        if missing(&mut rng) {
                            f64::NAN
                        } else {
                            (k as f64 * 1e-3 + j as f64).cos() + 0.02 * rng.normal()
                        }
                    })
                });
                let applied = JointVector::<4>::from_fn(|j, _| -((k as f64 * 1e-3 + j as f64).sin()));
                forgets.remembered = Remembered([[None; 2]; 4]);
                if (400..500).contains(&k) {
                    let rate = rate_std.is_some();
                    let knows = |j: usize| {
                        keeps.remembered.0[j]
                            .iter()
                            .flatten()
                            .any(|step| step.angle && step.rate == rate && same_bits(&step.from, &keeps.p[j]))
                    };
                    reused += usize::from((0..4).all(knows));
                }
                let a = keeps.update(&Measurement { q, qd }, &applied);
                let b = forgets.update(&Measurement { q, qd }, &applied);
                let bits = |s: &JointState<4>| s.q.iter().chain(s.qd.iter()).map(|v| v.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&a), bits(&b), "case {case}, sample {k}");
                for j in 0..4 {
                    assert!(same_bits(&keeps.filter_covariance(j), &forgets.filter_covariance(j)), "case {case}, {k}");
                    let (ka, kb) = (keeps.gain(j), forgets.gain(j));
                    assert!(ka.iter().zip(kb.iter()).all(|(a, b)| a.to_bits() == b.to_bits()), "case {case}, {k}");
                }
            }
            assert_eq!(reused, 100, "case {case}: from sample 400 on, every joint's covariance step is one remembered");
        }
    }

    /// Per joint, a value of each of eight lanes.
    type PerLane = [[f64; 8]; 4];

    /// Updates the filters in lanes and each lane's own filter with its readings `(q, qd)`
    /// (read only with a rate sensor) and input `applied`, and asserts each filter's estimate
    /// has the bits its lane's has.
    fn update_side_by_side(
        lanes: &mut KalmanLanes<8>,
        filters: &mut [JointKalman<4>],
        (q, qd, applied): (&PerLane, &PerLane, &PerLane),
        measures_rate: bool,
        context: &str,
    ) {
        let (lane_q, lane_qd) = lanes.update(&q.map(Lanes), &qd.map(Lanes), &applied.map(Lanes));
        for (i, filter) in filters.iter_mut().enumerate() {
            let measurement = Measurement {
                q: JointVector::from_fn(|j, _| q[j][i]),
                qd: measures_rate.then(|| JointVector::from_fn(|j, _| qd[j][i])),
            };
            let own = filter.update(&measurement, &JointVector::from_fn(|j, _| applied[j][i]));
            for j in 0..4 {
                assert_eq!(own.q[j].to_bits(), lane_q[j].0[i].to_bits(), "{context}, lane {i}");
                assert_eq!(own.qd[j].to_bits(), lane_qd[j].0[i].to_bits(), "{context}, lane {i}");
            }
        }
    }

    /// Filters that settle (each covariance at a fixed point or in a cycle of two), then a
    /// reading missing in one lane, which moves that joint off its remembered steps, then
    /// settle again and return to them, several times: the lanes equal each filter, bit for bit,
    /// throughout, and each remembered step's `follows` is what a search would find (one not
    /// refreshed when the other slot is replaced can point at a step that no longer follows it).
    /// Also counts, per joint, the samples whose covariance step was a
    /// cycle of two, so that the test says it reached one.
    #[test]
    fn filters_in_lanes_return_to_their_remembered_steps_bit_for_bit() {
        let mut rng = SeededRng::new(17);
        let mut cycles_of_two = 0;
        for case in 0..4u64 {
            let rate_std = (case % 2 == 1).then(|| JointVector::<4>::from_fn(|j, _| 0.01 + 0.005 * j as f64));
            let mut filters: Vec<JointKalman<4>> = (0..8)
                .map(|lane| {
                    let settings = if (lane + case as usize).is_multiple_of(3) {
                        KalmanSettings::TWO_STATE
                    } else {
                        KalmanSettings::DEFAULT
                    };
                    let angle_std = JointVector::<4>::from_fn(|j, _| 1e-4 * (1 + (lane + j) % 5) as f64);
                    let mut filter =
                        JointKalman::new(1e-3, angle_std, rate_std, (case / 2) as usize, settings).unwrap();
                    filter.reset(&JointState::at_rest(JointVector::zeros()));
                    filter
                })
                .collect();
            let mut lanes = KalmanLanes::<8>::of(std::array::from_fn(|i| Some(&filters[i]))).unwrap();
            let mut history: Vec<[Matrix3<f64>; 4]> = Vec::new();
            for k in 0..3000 {
                let t = k as f64 * 1e-3;
                // A missing angle in lane k/400 mod 8, joint k/400 mod 4, every 400 samples.
                let missing = (k % 400 == 399).then_some(((k / 400) % 8, (k / 400) % 4));
                let q: [[f64; 8]; 4] = std::array::from_fn(|j| {
                    std::array::from_fn(|i| {
                        if missing == Some((i, j)) {
                            f64::NAN
                        } else {
                            (t + (i + j) as f64).sin() + 1e-4 * rng.normal()
                        }
                    })
                });
                let qd: [[f64; 8]; 4] =
                    std::array::from_fn(|j| std::array::from_fn(|i| (t + j as f64).cos() + 0.01 * (i as f64)));
                let applied: [[f64; 8]; 4] =
                    std::array::from_fn(|j| std::array::from_fn(|i| (t * (i + j) as f64).cos()));
                let context = format!("case {case}, sample {k}");
                update_side_by_side(&mut lanes, &mut filters, (&q, &qd, &applied), rate_std.is_some(), &context);
                // Each remembered step's `follows` is what a search from its result finds now.
                for j in 0..4 {
                    for slot in 0..2 {
                        let Some((_, step)) = &lanes.remembered[j][slot] else { continue };
                        let found = lanes.starting_at(j, &step.to);
                        assert_eq!(lanes.follows[j][slot], found, "case {case}, sample {k}, joint {j}, slot {slot}");
                    }
                }
                // Lane 1's covariances (none of its readings is missing before sample 799).
                history.push(std::array::from_fn(|j| filters[1].p[j]));
                if let [.., a, b, c] = history.as_slice() {
                    cycles_of_two += (0..4).filter(|&j| same_bits(&a[j], &c[j]) && !same_bits(&a[j], &b[j])).count();
                }
            }
        }
        assert!(cycles_of_two > 0, "no covariance reached a cycle of two");
    }

    /// The filters of eight runs side by side equal each run's own filter bit for bit at every
    /// sample (estimates, and after a hand-back the whole state: covariances, gains, inputs):
    /// lanes of different angle σ, tunings and periods, with and without a rate sensor, at
    /// delays 0, 1 and 3, through readings that go missing (NaN, ±∞) in some lanes now and
    /// then, and non-finite inputs.
    #[test]
    fn filters_in_lanes_equal_each_filter_bit_for_bit() {
        let mut rng = SeededRng::new(5);
        for case in 0..6u64 {
            let delay = [0, 1, 3][(case % 3) as usize];
            let rate_std = (case >= 3).then(|| JointVector::<4>::from_fn(|j, _| 0.01 + 0.005 * j as f64));
            let mut filters: Vec<JointKalman<4>> = (0..8)
                .map(|lane| {
                    let settings = if lane % 3 == 0 { KalmanSettings::TWO_STATE } else { KalmanSettings::DEFAULT };
                    let angle_std = JointVector::<4>::from_fn(|j, _| 1e-4 * (1 + (lane + j) % 5) as f64);
                    let period = 1e-3 * (1 + lane % 2) as f64;
                    let mut filter = JointKalman::new(period, angle_std, rate_std, delay, settings).unwrap();
                    filter.reset(&JointState::at_rest(JointVector::from_fn(|j, _| 0.1 * (lane + j) as f64)));
                    filter
                })
                .collect();
            let mut lanes = KalmanLanes::<8>::of(std::array::from_fn(|i| Some(&filters[i]))).unwrap();
            let odd = [f64::NAN, f64::INFINITY, -f64::INFINITY];
            for k in 0..1500 {
                let t = k as f64 * 1e-3;
                let mut reading = |scale: f64, phase: f64| -> [[f64; 8]; 4] {
                    std::array::from_fn(|j| {
                        std::array::from_fn(|i| {
                            if k > 200 && rng.unit() < 0.01 {
                                odd[(rng.next_u64() % 3) as usize]
                            } else {
                                scale * (t + phase + (i + j) as f64).sin() + 1e-3 * rng.normal()
                            }
                        })
                    })
                };
                let (q, qd) = (reading(1.0, 0.0), reading(0.5, 1.0));
                let applied: [[f64; 8]; 4] = std::array::from_fn(|j| {
                    std::array::from_fn(|i| if rng.unit() < 0.005 { f64::NAN } else { (t * (i + j) as f64).cos() })
                });
                let context = format!("case {case}, sample {k}");
                update_side_by_side(&mut lanes, &mut filters, (&q, &qd, &applied), rate_std.is_some(), &context);
                if k % 97 == 0 || k == 1499 {
                    for (i, filter) in filters.iter().enumerate() {
                        let mut handed = filter.clone();
                        handed.reset(&JointState::at_rest(JointVector::repeat(9.0)));
                        lanes.hand_back(i, &mut handed);
                        assert!(handed == *filter, "case {case}, sample {k}, lane {i}: the state handed back");
                        for j in 0..4 {
                            assert!(same_bits(&handed.p[j], &filter.p[j]), "case {case}, sample {k}, lane {i}");
                            let gains = handed.gain[j].iter().zip(filter.gain[j].iter());
                            assert!(gains.clone().all(|(a, b)| a.to_bits() == b.to_bits()), "case {case}, lane {i}");
                        }
                    }
                }
            }
        }
        // Filters of different delays, or with and without a rate sensor, do not share lanes.
        let angle_std = JointVector::<4>::repeat(1e-3);
        let a = JointKalman::new(1e-3, angle_std, None, 1, KalmanSettings::DEFAULT).unwrap();
        let b = JointKalman::new(1e-3, angle_std, None, 2, KalmanSettings::DEFAULT).unwrap();
        let c = JointKalman::new(1e-3, angle_std, Some(angle_std), 1, KalmanSettings::DEFAULT).unwrap();
        assert!(KalmanLanes::<4>::of([Some(&a), None, Some(&b), None]).is_none());
        assert!(KalmanLanes::<4>::of([Some(&a), Some(&c), None, None]).is_none());
        assert!(KalmanLanes::<4>::of([None; 4]).is_none());
        assert!(KalmanLanes::<4>::of([None, Some(&a), None, Some(&a)]).is_some());
    }
}
