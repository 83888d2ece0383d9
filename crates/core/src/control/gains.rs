//! Outer-loop gains of computed-torque control and their design.
//!
//! Computed torque makes every joint's error a decoupled linear system (report: `ë = u`):
//! PD `ë + kd ė + kp e = 0`, poles of `s² + kd s + kp`; PID
//! `e⃛ + kd ë + kp ė + ki e = 0`, poles of `s³ + kd s² + kp s + ki`.

use crate::arm::model::JointVector;
use nalgebra::{Complex, Matrix3, Vector3};
use std::f64::consts::PI;

/// Why gains are not usable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GainError {
    #[error("gain {name} = {}: {reason}", crate::short_number(*.value))]
    Invalid { name: String, value: f64, reason: &'static str },
    #[error(
        "overshoot {requested}% is below what PID reaches from an initial error ({least:.2}% at best: its integral must unwind); allow more overshoot"
    )]
    UnreachableOvershoot { requested: f64, least: f64 },
}

/// Per-joint gains: `kp` (1/s²), `kd` (1/s), `ki` (1/s³; zero for PD).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gains<const N: usize> {
    pub kp: JointVector<N>,
    pub kd: JointVector<N>,
    pub ki: JointVector<N>,
}

/// The report's PD gains: kp = 400, kd = 20.
pub const REPORT_PD: (f64, f64) = (400.0, 20.0);
/// The report's PID gains: kp = 600, kd = 25, ki = 75.
pub const REPORT_PID: (f64, f64, f64) = (600.0, 25.0, 75.0);
/// The gains of whole games (`play`, and `robustness` of a game): kp = 2500, kd = 100
/// (ωn = 50 rad/s, ζ = 1), chosen by measurement (docs/realistic-robot.md, "Defaults chosen by measurement"):
/// with hobby encoders and model errors the report's PD left the fine points waiting 1.0 s a
/// ply on average (Kasparov–Topalov, 4.04 s a ply in all); these gains wait 0.27 s (2.94 s a
/// ply), at 2 % more peak torque. Every computed-torque controller takes them, PID with the
/// report's `ki`.
pub const GAME_PD: (f64, f64) = (2500.0, 100.0);

impl<const N: usize> Gains<N> {
    /// Per-joint gains, each finite and ≥ 0, with kp > 0.
    pub fn per_joint(kp: JointVector<N>, kd: JointVector<N>, ki: JointVector<N>) -> Result<Self, GainError> {
        for (name, values) in [("kp", &kp), ("kd", &kd), ("ki", &ki)] {
            for (j, &value) in values.iter().enumerate() {
                let name = format!("{name}[joint {}]", j + 1);
                if !value.is_finite() {
                    return Err(GainError::Invalid { name, value, reason: "must be finite" });
                }
                if value < 0.0 {
                    return Err(GainError::Invalid { name, value, reason: "must be >= 0" });
                }
            }
        }
        if let Some((j, &value)) = kp.iter().enumerate().find(|(_, v)| **v == 0.0) {
            return Err(GainError::Invalid { name: format!("kp[joint {}]", j + 1), value, reason: "must be > 0" });
        }
        Ok(Self { kp, kd, ki })
    }

    /// The PD outer loop of computed torque, rad/s²: `v = q̈_d + kd (q̇_d − q̇) + kp (q_d − q)`
    /// (the integral term, if any, is the caller's).
    pub fn pd_outer_loop(
        &self,
        desired: &crate::control::Reference<N>,
        state: &crate::control::JointState<N>,
    ) -> JointVector<N> {
        desired.qdd + self.kd.component_mul(&(desired.qd - state.qd)) + self.kp.component_mul(&(desired.q - state.q))
    }

    /// Refuses an integral gain, with `reason` (the controller's outer loop is PD).
    pub fn require_pd(&self, reason: &'static str) -> Result<(), GainError> {
        match self.ki.iter().enumerate().find(|(_, k)| **k != 0.0) {
            Some((j, &value)) => Err(GainError::Invalid { name: format!("ki[joint {}]", j + 1), value, reason }),
            None => Ok(()),
        }
    }

    /// The same scalar gains on every joint.
    pub fn uniform(kp: f64, kd: f64, ki: f64) -> Result<Self, GainError> {
        Self::per_joint(JointVector::repeat(kp), JointVector::repeat(kd), JointVector::repeat(ki))
    }

    /// The report's PD gains ([`REPORT_PD`]) on every joint, no integral: the model-based
    /// controllers' default outer loop.
    pub(crate) fn report_pd() -> Self {
        let (kp, kd) = REPORT_PD;
        Self { kp: JointVector::repeat(kp), kd: JointVector::repeat(kd), ki: JointVector::zeros() }
    }

    /// PD from natural frequency `wn` (rad/s) and damping ratio `zeta`: `kp = ωn²`, `kd = 2ζωn`.
    pub fn pd_from_natural_frequency(wn: f64, zeta: f64) -> Result<Self, GainError> {
        check_design(wn, zeta)?;
        Self::uniform(wn * wn, 2.0 * zeta * wn, 0.0)
    }

    /// PID by pole placement: `(s + αωn)(s² + 2ζωn s + ωn²)`, so `kd = (2ζ + α)ωn`,
    /// `kp = (1 + 2ζα)ωn²`, `ki = αωn³`; `alpha` places the integral pole (> 0).
    pub fn pid_from_poles(wn: f64, zeta: f64, alpha: f64) -> Result<Self, GainError> {
        check_design(wn, zeta)?;
        if !(alpha.is_finite() && alpha > 0.0) {
            return Err(GainError::Invalid {
                name: "integral pole ratio".into(),
                value: alpha,
                reason: "must be finite and > 0",
            });
        }
        Self::uniform((1.0 + 2.0 * zeta * alpha) * wn * wn, (2.0 * zeta + alpha) * wn, alpha * wn * wn * wn)
    }

    /// Whether any joint has integral action.
    pub fn has_integral(&self) -> bool {
        self.ki.iter().any(|&k| k > 0.0)
    }

    /// Closed-loop poles of joint `j`'s error dynamics, rad/s.
    pub fn closed_loop_poles(&self, j: usize) -> Vec<Complex<f64>> {
        let (kp, kd, ki) = (self.kp[j], self.kd[j], self.ki[j]);
        if ki > 0.0 {
            // Companion matrix of s³ + kd s² + kp s + ki.
            let companion = Matrix3::new(-kd, -kp, -ki, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
            let mut poles: Vec<_> = companion.complex_eigenvalues().iter().copied().collect();
            poles.sort_by(|a, b| a.re.total_cmp(&b.re).then(a.im.total_cmp(&b.im)));
            poles
        } else {
            let discriminant = kd * kd - 4.0 * kp;
            if discriminant < 0.0 {
                let imaginary = (-discriminant).sqrt() / 2.0;
                return vec![Complex::new(-kd / 2.0, -imaginary), Complex::new(-kd / 2.0, imaginary)];
            }
            // Real poles: the large one directly, the small one as kp / large (no cancellation).
            let large = -(kd + discriminant.sqrt()) / 2.0;
            let small = if large != 0.0 { kp / large } else { 0.0 };
            vec![Complex::new(large, 0.0), Complex::new(small, 0.0)]
        }
    }
}

fn check_design(wn: f64, zeta: f64) -> Result<(), GainError> {
    if !(wn.is_finite() && wn > 0.0) {
        return Err(GainError::Invalid {
            name: "natural frequency".into(),
            value: wn,
            reason: "must be finite and > 0",
        });
    }
    if !(zeta.is_finite() && zeta > 0.0) {
        return Err(GainError::Invalid { name: "damping ratio".into(), value: zeta, reason: "must be finite and > 0" });
    }
    Ok(())
}

/// Damping ratio giving a percent overshoot of a second-order response:
/// `ζ = −ln(OS) / √(π² + ln²(OS))`; 0 % overshoot gives critical damping (ζ = 1).
pub fn damping_for_overshoot(overshoot_percent: f64) -> Result<f64, GainError> {
    if !(overshoot_percent.is_finite() && (0.0..100.0).contains(&overshoot_percent)) {
        return Err(GainError::Invalid {
            name: "overshoot".into(),
            value: overshoot_percent,
            reason: "must be a percentage in [0, 100)",
        });
    }
    if overshoot_percent == 0.0 {
        return Ok(1.0);
    }
    let log = (overshoot_percent / 100.0).ln();
    Ok(-log / (PI * PI + log * log).sqrt())
}

/// Error of `ë + 2ζωn ė + ωn² e = 0` from `e(0) = 1`, `ė(0) = 0`, at normalised time
/// `τ = ωn t` (ωn = 1), for any ζ > 0.
pub fn normalised_error_response(zeta: f64, tau: f64) -> f64 {
    if (zeta - 1.0).abs() < 1e-9 {
        (1.0 + tau) * (-tau).exp()
    } else if zeta < 1.0 {
        let wd = (1.0 - zeta * zeta).sqrt();
        (-zeta * tau).exp() * ((wd * tau).cos() + zeta / wd * (wd * tau).sin())
    } else {
        let root = (zeta * zeta - 1.0).sqrt();
        let (s1, s2) = (-zeta + root, -zeta - root);
        (s2 * (s1 * tau).exp() - s1 * (s2 * tau).exp()) / (s2 - s1)
    }
}

/// Shape of the error response from `e(0) = 1`, `ė(0) = 0`, `∫e(0) = 0`, in normalised time
/// `τ = ωn t`, for gains designed by [`Gains::pid_from_poles`] (`alpha = 0`: PD).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResponseShape {
    /// 2 % settling time × ωn.
    pub settling: f64,
    /// Largest excursion past zero, % of `e(0)`.
    pub overshoot_percent: f64,
}

impl ResponseShape {
    /// Exact response of `x = (∫e, e, ė)`, `ẋ = A x` with `ki = α`, `kp = 1 + 2ζα`,
    /// `kd = 2ζ + α` (ωn = 1), stepped by the matrix exponential `exp(A h)` on a grid of
    /// `h = 2e-3` until it has stayed inside 1e-4 for a long stretch.
    pub fn of(zeta: f64, alpha: f64) -> Self {
        let (ki, kp, kd) = (alpha, 1.0 + 2.0 * zeta * alpha, 2.0 * zeta + alpha);
        let system = Matrix3::new(0.0, 1.0, 0.0, 0.0, 0.0, 1.0, -ki, -kp, -kd);
        let step: f64 = 2e-3;
        // Slowest decay rate: the integral pole α, the pair's ζ (underdamped) or ≈ 1/(2ζ).
        let pair = if zeta < 1.0 { zeta } else { 1.0 / (2.0 * zeta) };
        let slowest = if alpha > 0.0 { pair.min(alpha) } else { pair };
        let horizon = 40.0 / slowest;
        // At most 20 000 steps: slow tails get a coarser grid (settling error ≤ step/τs).
        let step = step.max(horizon / 20_000.0);
        let transition = (system * step).exp();
        let mut state = Vector3::new(0.0, 1.0, 0.0);
        let (mut settling, mut overshoot) = (0.0, 0.0f64);
        let mut tau = 0.0;
        while tau < horizon {
            state = transition * state;
            tau += step;
            let error = state[1];
            if error.abs() > 0.02 {
                settling = tau;
            }
            overshoot = overshoot.max(-error);
        }
        Self { settling, overshoot_percent: 100.0 * overshoot }
    }
}

/// Damping ratio in `[0.05, 4]` whose response (with integral pole ratio `alpha`) overshoots
/// by `overshoot_percent`, or `None` if that overshoot is below the least reachable. Overshoot
/// falls with ζ up to a minimum (≈ critical damping) and rises after it: bisect on the
/// falling branch. For PD with 0 % the answer is critical damping.
fn damping_for_response(overshoot_percent: f64, alpha: f64) -> Option<f64> {
    if alpha == 0.0 {
        return damping_for_overshoot(overshoot_percent).ok();
    }
    let grid: Vec<f64> = (0..=40).map(|k| 0.05 + 0.05 * k as f64).collect();
    let (least_zeta, least) =
        grid.iter().map(|&z| (z, ResponseShape::of(z, alpha).overshoot_percent)).min_by(|a, b| a.1.total_cmp(&b.1))?;
    if overshoot_percent < least {
        return None;
    }
    let (mut low, mut high) = (0.05, least_zeta);
    for _ in 0..40 {
        let middle = 0.5 * (low + high);
        if ResponseShape::of(middle, alpha).overshoot_percent > overshoot_percent {
            low = middle
        } else {
            high = middle
        }
    }
    Some(high)
}

/// Gains meeting a 2 % settling time `settling_time` (s) and `overshoot_percent` of the error
/// response from an initial error. PD: ζ from the overshoot, `ωn = (ωn Ts)(ζ) / Ts`. PID by
/// pole placement with the integral pole at `−α ωn`: for the given α (or, with `None`, the α on
/// a log grid 0.01…1 that settles fastest) ζ is found by bisection on the exact third-order
/// response, then ωn from its settling time. Returns the gains, ωn, ζ and α (0 for PD).
pub fn design_from_specs<const N: usize>(
    settling_time: f64,
    overshoot_percent: f64,
    pid: Option<Option<f64>>,
) -> Result<(Gains<N>, f64, f64, f64), GainError> {
    if !(settling_time.is_finite() && settling_time > 0.0) {
        return Err(GainError::Invalid {
            name: "settling time".into(),
            value: settling_time,
            reason: "must be finite and > 0",
        });
    }
    damping_for_overshoot(overshoot_percent)?;
    let alphas: Vec<f64> = match pid {
        None => vec![0.0],
        Some(Some(alpha)) => vec![alpha],
        Some(None) => (0..=16).map(|k| 0.01 * 10f64.powf(k as f64 / 8.0)).collect(),
    };
    let best = alphas
        .iter()
        .filter_map(|&alpha| {
            let zeta = damping_for_response(overshoot_percent, alpha)?;
            Some((alpha, zeta, ResponseShape::of(zeta, alpha).settling))
        })
        .min_by(|a, b| a.2.total_cmp(&b.2));
    let Some((alpha, zeta, normalised_settling)) = best else {
        let least = alphas
            .iter()
            .flat_map(|&alpha| (1..=80).map(move |k| ResponseShape::of(0.05 * k as f64, alpha).overshoot_percent))
            .fold(f64::INFINITY, f64::min);
        return Err(GainError::UnreachableOvershoot { requested: overshoot_percent, least });
    };
    let wn = normalised_settling / settling_time;
    let gains = if pid.is_some() {
        Gains::pid_from_poles(wn, zeta, alpha)?
    } else {
        Gains::pd_from_natural_frequency(wn, zeta)?
    };
    Ok((gains, wn, zeta, alpha))
}
