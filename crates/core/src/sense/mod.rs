//! Sensing: what the controller sees of the plant. Encoders sample the joint angles at the
//! control rate, quantised, noisy, delayed and offset ([`sensors`]); an estimator turns the
//! measurements into the joint angles and rates the controller needs ([`kalman`], or the
//! finite-difference baseline of [`lowpass`]). [`Feedback`] chains the two for the closed loop.
//!
//! The ideal profile hands the controller the plant's exact state, bit for bit.

pub mod kalman;
pub mod lowpass;
pub mod rng;
pub mod sensors;

use crate::arm::model::JointVector;
use crate::control::JointState;
pub use kalman::{JointKalman, KalmanSettings};
pub use lowpass::LowPassVelocity;
pub use sensors::{EncoderSpec, SensorProfile, Sensors};

/// What the sensors report at one control sample: joint angles (rad) and, from a velocity
/// sensor, rates (rad/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement<const N: usize> {
    pub q: JointVector<N>,
    pub qd: Option<JointVector<N>>,
}

/// A sensor profile, estimator setting or measurement that cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SenseError {
    #[error("{field} = {value}: {reason}")]
    InvalidField { field: String, value: String, reason: String },
}

pub(crate) fn invalid(
    field: impl Into<String>,
    value: impl std::fmt::Display,
    reason: impl Into<String>,
) -> SenseError {
    SenseError::InvalidField { field: field.into(), value: value.to_string(), reason: reason.into() }
}

/// How measurements become the controller's joint state.
#[derive(Debug, Clone)]
pub enum Estimator<const N: usize> {
    /// The measurement as it is: angles, and rates from the velocity sensor (the profile must
    /// have one). With the ideal profile, the plant's exact state.
    Direct,
    /// Rates by finite differences of the angles through a first-order low-pass: the baseline.
    LowPass(LowPassVelocity<N>),
    /// The joint Kalman filter.
    Kalman(Box<JointKalman<N>>),
}

impl<const N: usize> Estimator<N> {
    /// Short name, as the CLI spells it.
    pub fn name(&self) -> &'static str {
        match self {
            Estimator::Direct => "direct",
            Estimator::LowPass(_) => "lowpass",
            Estimator::Kalman(_) => "kalman",
        }
    }
}

/// Sensors and estimator between the plant and the controller, sampled at the control period.
#[derive(Debug, Clone)]
pub struct Feedback<const N: usize> {
    pub sensors: Sensors<N>,
    pub estimator: Estimator<N>,
}

impl<const N: usize> Feedback<N> {
    /// Exact state to the controller: today's closed loop.
    pub fn ideal() -> Self {
        Self { sensors: Sensors::ideal(), estimator: Estimator::Direct }
    }

    /// Checks that the estimator can work with the sensors' measurements.
    pub fn new(sensors: Sensors<N>, estimator: Estimator<N>) -> Result<Self, SenseError> {
        if matches!(estimator, Estimator::Direct) && !sensors.profile().measures_rate() {
            return Err(invalid(
                "estimator",
                "direct",
                format!(
                    "the sensor profile {} has no velocity sensor: use the Kalman filter or the low-pass estimator",
                    sensors.profile().name
                ),
            ));
        }
        Ok(Self { sensors, estimator })
    }

    /// Whether the controller sees the plant's exact state.
    pub fn is_exact(&self) -> bool {
        self.sensors.profile().is_ideal() && matches!(self.estimator, Estimator::Direct)
    }

    /// Starts a run with the arm at `initial` (at rest or moving, as it was before t = 0):
    /// the delay line holds its measurement, the estimators start on it.
    pub fn reset(&mut self, initial: &JointState<N>) {
        let due = self.sensors.reset(initial);
        // The estimators start on the reading due at the first sample, with the rate the arm
        // had (at rest, or as the previous run left it).
        let start = JointState { q: due.q, qd: initial.qd };
        match &mut self.estimator {
            Estimator::Direct => {}
            Estimator::LowPass(filter) => filter.reset(&start),
            Estimator::Kalman(filter) => filter.reset(&start),
        }
    }

    /// One control sample: measures the plant's `state` and returns what the controller
    /// sees. `applied` is the acceleration the controller commanded for the sample just ended
    /// (rad/s²), the estimator's motion model input.
    pub fn observe(&mut self, state: &JointState<N>, applied: &JointVector<N>) -> JointState<N> {
        if self.is_exact() {
            return *state;
        }
        let measurement = self.sensors.measure(state);
        match &mut self.estimator {
            Estimator::Direct => JointState { q: measurement.q, qd: measurement.qd.unwrap_or(state.qd) },
            Estimator::LowPass(filter) => filter.update(&measurement),
            Estimator::Kalman(filter) => filter.update(&measurement, applied),
        }
    }
}

/// Which estimator to build for a run (the settings; [`Estimator`] is the running filter).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EstimatorSpec {
    /// [`Estimator::Direct`].
    Direct,
    /// [`Estimator::LowPass`] with this time constant, s.
    LowPass { time_constant: f64 },
    /// [`Estimator::Kalman`] with these settings.
    Kalman(KalmanSettings),
}

impl EstimatorSpec {
    /// The Kalman filter with its default tuning ([`KalmanSettings::DEFAULT`]).
    pub const KALMAN: EstimatorSpec = EstimatorSpec::Kalman(KalmanSettings::DEFAULT);
    /// The low-pass baseline with its default time constant.
    pub const LOW_PASS: EstimatorSpec =
        EstimatorSpec::LowPass { time_constant: LowPassVelocity::<1>::DEFAULT_TIME_CONSTANT };

    /// Short name, as the CLI spells it.
    pub fn name(&self) -> &'static str {
        match self {
            EstimatorSpec::Direct => "direct",
            EstimatorSpec::LowPass { .. } => "lowpass",
            EstimatorSpec::Kalman(_) => "kalman",
        }
    }

    /// The estimator for `profile`'s measurements sampled every `period` s.
    pub fn build<const N: usize>(&self, profile: &SensorProfile<N>, period: f64) -> Result<Estimator<N>, SenseError> {
        Ok(match *self {
            EstimatorSpec::Direct => Estimator::Direct,
            EstimatorSpec::LowPass { time_constant } => {
                Estimator::LowPass(LowPassVelocity::new(period, time_constant)?)
            }
            EstimatorSpec::Kalman(settings) => Estimator::Kalman(Box::new(JointKalman::new(
                period,
                profile.angle_std(),
                profile.rate_noise,
                profile.delay_samples,
                settings,
            )?)),
        })
    }
}

/// What stands between the controller and the plant in a run: sensors, estimator, and the
/// motors' torque lag.
#[derive(Debug, Clone, PartialEq)]
pub struct Conditions<const N: usize> {
    pub sensors: SensorProfile<N>,
    pub estimator: EstimatorSpec,
    /// Per joint, the motor's torque time constant, s (0: none).
    pub torque_lag: JointVector<N>,
    /// Seed of the sensor noise.
    pub seed: u64,
}

impl<const N: usize> Conditions<N> {
    /// Exact state, no lag: today's closed loop.
    pub fn ideal() -> Self {
        Self {
            sensors: SensorProfile::ideal(),
            estimator: EstimatorSpec::Direct,
            torque_lag: JointVector::zeros(),
            seed: 0,
        }
    }

    /// The sensors and estimator of a run sampled every `period` s.
    pub fn feedback(&self, period: f64) -> Result<Feedback<N>, SenseError> {
        let sensors = Sensors::new(self.sensors.clone(), self.seed)?;
        let estimator = self.estimator.build(&self.sensors, period)?;
        Feedback::new(sensors, estimator)
    }
}
