//! Outer-loop gains of computed-torque control and their design.
//!
//! Computed torque makes every joint's error a decoupled linear system (report: `ë = u`):
//! PD `ë + kd ė + kp e = 0`, poles of `s² + kd s + kp`; PID
//! `e⃛ + kd ë + kp ė + ki e = 0`, poles of `s³ + kd s² + kp s + ki`.

use crate::arm::model::JointVector;
use nalgebra::{Complex, Matrix3};
use std::f64::consts::PI;

/// Why gains are not usable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GainError {
    #[error("gain {name} = {value}: {reason}")]
    Invalid { name: String, value: f64, reason: &'static str },
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

    /// The same scalar gains on every joint.
    pub fn uniform(kp: f64, kd: f64, ki: f64) -> Result<Self, GainError> {
        Self::per_joint(JointVector::repeat(kp), JointVector::repeat(kd), JointVector::repeat(ki))
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
            let root = Complex::new(discriminant, 0.0).sqrt();
            vec![(Complex::new(-kd, 0.0) - root) / 2.0, (Complex::new(-kd, 0.0) + root) / 2.0]
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

/// Normalised 2 % settling time `ωn·Ts` of the error response for damping `zeta`: the last
/// instant `|e| > 0.02`, found on a dense grid (step 1e-4) of the exact solution.
pub fn normalised_settling_time(zeta: f64) -> f64 {
    let step = 1e-4;
    let horizon = 20.0 / zeta.min(1.0) + 40.0 * zeta;
    let count = (horizon / step) as usize;
    (0..=count)
        .rev()
        .map(|k| k as f64 * step)
        .find(|&tau| normalised_error_response(zeta, tau).abs() > 0.02)
        .unwrap_or(0.0)
}

/// PD gains meeting a 2 % settling time (s) and a percent overshoot of the error response.
pub fn pd_from_specs<const N: usize>(settling_time: f64, overshoot_percent: f64) -> Result<Gains<N>, GainError> {
    if !(settling_time.is_finite() && settling_time > 0.0) {
        return Err(GainError::Invalid {
            name: "settling time".into(),
            value: settling_time,
            reason: "must be finite and > 0",
        });
    }
    let zeta = damping_for_overshoot(overshoot_percent)?;
    Gains::pd_from_natural_frequency(normalised_settling_time(zeta) / settling_time, zeta)
}
