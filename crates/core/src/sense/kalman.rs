//! Placeholder of the joint Kalman filter (being written on its own branch): a two-state
//! per-joint filter without delay compensation.

use super::{Measurement, SenseError, invalid};
use crate::arm::model::JointVector;
use crate::control::JointState;
use nalgebra::{Matrix2, Vector2};

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
    /// Default tuning (placeholder value).
    pub const DEFAULT: KalmanSettings = KalmanSettings { acceleration_noise: 20.0, disturbance_noise: None };
    /// Default σ of the disturbance state's increments per sample, rad/s² (placeholder).
    pub const DEFAULT_DISTURBANCE_NOISE: f64 = 1.0;
}

/// Per-joint Kalman filters of `(q, q̇)`.
#[derive(Debug, Clone, PartialEq)]
pub struct JointKalman<const N: usize> {
    period: f64,
    angle_std: JointVector<N>,
    settings: KalmanSettings,
    x: [Vector2<f64>; N],
    p: [Matrix2<f64>; N],
}

impl<const N: usize> JointKalman<N> {
    pub fn new(
        period: f64,
        angle_std: JointVector<N>,
        _rate_std: Option<JointVector<N>>,
        _delay_samples: usize,
        settings: KalmanSettings,
    ) -> Result<Self, SenseError> {
        if !(period.is_finite() && period > 0.0) {
            return Err(invalid("control period", period, "must be finite and > 0 s"));
        }
        Ok(Self { period, angle_std, settings, x: [Vector2::zeros(); N], p: [Matrix2::zeros(); N] })
    }

    pub fn reset(&mut self, initial: &JointState<N>) {
        for j in 0..N {
            self.x[j] = Vector2::new(initial.q[j], initial.qd[j]);
            self.p[j] = Matrix2::from_diagonal(&Vector2::new(self.angle_std[j].powi(2), 0.0));
        }
    }

    pub fn update(&mut self, measurement: &Measurement<N>, applied: &JointVector<N>) -> JointState<N> {
        let t = self.period;
        let f = Matrix2::new(1.0, t, 0.0, 1.0);
        let g = Vector2::new(t * t / 2.0, t);
        let q = g * g.transpose() * self.settings.acceleration_noise.powi(2);
        let mut out = JointState { q: JointVector::zeros(), qd: JointVector::zeros() };
        for j in 0..N {
            let x = f * self.x[j] + g * applied[j];
            let p = f * self.p[j] * f.transpose() + q;
            let s = p[(0, 0)] + self.angle_std[j].powi(2);
            let k = p.column(0) / s;
            self.x[j] = x + k * (measurement.q[j] - x[0]);
            self.p[j] = p - k * p.row(0);
            out.q[j] = self.x[j][0];
            out.qd[j] = self.x[j][1];
        }
        out
    }
}
