//! The baseline velocity estimate: finite differences of the measured angles through a
//! first-order low-pass, `v_k = v_{k−1} + a ((q̃_k − q̃_{k−1})/T − v_{k−1})` with
//! `a = 1 − e^{−T/τ}` (the exact discretisation of `τ v̇ + v = q̇̃` for a difference held over the
//! sample). The angle is the measured one. What many hobby controllers do; the Kalman filter
//! must beat it.

use super::{Measurement, SenseError, invalid};
use crate::arm::model::JointVector;
use crate::control::JointState;

/// Finite-difference velocity with a first-order low-pass.
#[derive(Debug, Clone, PartialEq)]
pub struct LowPassVelocity<const N: usize> {
    period: f64,
    /// `1 − e^{−T/τ}`.
    blend: f64,
    time_constant: f64,
    last_q: JointVector<N>,
    velocity: JointVector<N>,
}

impl<const N: usize> LowPassVelocity<N> {
    /// Default time constant of the low-pass, s: 10 ms (a 16 Hz corner).
    pub const DEFAULT_TIME_CONSTANT: f64 = 0.01;

    /// A filter for samples every `period` s with time constant `time_constant` s (0: the raw
    /// difference).
    pub fn new(period: f64, time_constant: f64) -> Result<Self, SenseError> {
        if !(period.is_finite() && period > 0.0) {
            return Err(invalid("control period", period, "must be finite and > 0 s"));
        }
        if !(time_constant.is_finite() && time_constant >= 0.0) {
            return Err(invalid("lowpass time_constant", time_constant, "must be finite and >= 0 s"));
        }
        let blend = if time_constant == 0.0 { 1.0 } else { 1.0 - (-period / time_constant).exp() };
        Ok(Self { period, blend, time_constant, last_q: JointVector::zeros(), velocity: JointVector::zeros() })
    }

    /// The low-pass time constant, s.
    pub fn time_constant(&self) -> f64 {
        self.time_constant
    }

    /// Starts at `initial` (its rate is taken as known, as the arm's state before the run).
    pub fn reset(&mut self, initial: &JointState<N>) {
        self.last_q = initial.q;
        self.velocity = initial.qd;
    }

    /// One sample.
    pub fn update(&mut self, measurement: &Measurement<N>) -> JointState<N> {
        let difference = (measurement.q - self.last_q) / self.period;
        self.velocity += (difference - self.velocity) * self.blend;
        self.last_q = measurement.q;
        JointState { q: measurement.q, qd: self.velocity }
    }
}
