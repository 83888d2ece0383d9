//! Fine points: a gripper command that waits until the arm is in position.
//!
//! An industrial controller does not open its gripper by the clock at the end of a planned
//! motion: at a *fine point* it waits until the axes are in position. Here the condition is
//! on the state the robot *believes* (its estimate `q̂, q̂̇`, through its own kinematics), as
//! a real controller has nothing else:
//!
//! - the estimated tip `FK(q̂)` lies within `tip_band` of the planned point, and
//! - the estimated tip speed `|J(q̂) q̂̇|` is at most `speed_band` (so an overshoot passing
//!   through the band does not count),
//!
//! checked at every integration step from the instant the plan reaches the command, against
//! the estimate of the latest controller sample (the one before that step). While
//! waiting, the reference holds the planned point at rest; a wait that reaches `timeout` gives
//! up, and the command goes ahead where the arm is (the run reports it).

use crate::arm::kinematics::{ChainVelocities, FrameChain};
use crate::arm::model::{ArmModel, JointVector};
use nalgebra::Vector3;

/// When a gripper command may go ahead (see the module's doc). SI: m, m/s, s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InPosition {
    /// Largest distance of the estimated tip from the planned point, m.
    pub tip_band: f64,
    /// Largest estimated tip speed, m/s.
    pub speed_band: f64,
    /// Longest wait, s; the command then goes ahead and the wait counts as timed out.
    pub timeout: f64,
}

/// Share of the placement tolerance that the tip band takes by default: the piece is put down
/// within a tenth of the tolerance of where the robot believes its tool is, leaving the rest
/// to the estimate's own error and to the grip's.
pub const BAND_SHARE_OF_TOLERANCE: f64 = 0.1;

/// Time over which the default speed band would move the tip across the tip band, s: at most
/// a band's width in 0.1 s.
pub const BAND_CROSSING_TIME: f64 = 0.1;

/// The smallest share of the tolerance the tip band takes by default, however fine the
/// sensors: 0.25 mm of a 5 mm tolerance.
pub const FINEST_BAND_SHARE: f64 = 0.05;

/// Default longest wait, s.
pub const DEFAULT_TIMEOUT: f64 = 1.0;

/// Why a condition cannot be used: the field and its value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("in-position {field} = {value}: must be a finite number > 0")]
pub struct InPositionError {
    pub field: &'static str,
    pub value: f64,
}

/// How far the estimate is from being in position: the estimated tip's distance from the
/// planned point (m) and its speed (m/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InPositionCheck {
    pub tip_error: f64,
    pub tip_speed: f64,
}

impl InPosition {
    /// The default condition for a placement tolerance (m): the tip within
    /// [`BAND_SHARE_OF_TOLERANCE`] of it, no faster than that band per [`BAND_CROSSING_TIME`],
    /// waiting at most [`DEFAULT_TIMEOUT`].
    pub fn for_tolerance(tolerance: f64) -> Self {
        let tip_band = BAND_SHARE_OF_TOLERANCE * tolerance;
        Self { tip_band, speed_band: tip_band / BAND_CROSSING_TIME, timeout: DEFAULT_TIMEOUT }
    }

    /// The default for sensors whose estimated tip moves by `tip_quantum` (m) when every
    /// encoder moves by a count ([`tip_quantum`]): a tip band of two quanta, between
    /// [`FINEST_BAND_SHARE`] and [`BAND_SHARE_OF_TOLERANCE`] of the tolerance (a band the
    /// estimate cannot resolve would wait on noise; a band finer than needed costs waits).
    /// Measured (docs/realistic-robot.md): 12-bit encoders keep the tenth (0.5 mm), 17-bit ones take the
    /// twentieth, which takes the p95 placement error from 0.33 to 0.20 mm on
    /// Kasparov–Topalov for 8.5 % more robot time (100 trials, PD, the model errors of examples/uncertainty.toml).
    pub fn for_sensors(tolerance: f64, tip_quantum: f64) -> Self {
        let tip_band = (2.0 * tip_quantum).clamp(FINEST_BAND_SHARE * tolerance, BAND_SHARE_OF_TOLERANCE * tolerance);
        Self { tip_band, speed_band: tip_band / BAND_CROSSING_TIME, ..Self::for_tolerance(tolerance) }
    }

    /// [`InPosition::for_sensors`] for actuators that hold the tip still only within
    /// `holding_band` (m) of their goal (servos, steppers:
    /// [`crate::sim::actuator::Actuators::holding_band`]; 0 for torque motors): the tip band
    /// widened to that band (at most the tolerance), the speed band kept, so the wait ends when
    /// the servos have stopped where they can — what a host polling their "moving" flag sees —
    /// rather than always at the timeout.
    pub fn for_actuators(tolerance: f64, tip_quantum: f64, holding_band: f64) -> Self {
        let mut gate = Self::for_sensors(tolerance, tip_quantum);
        if holding_band > 0.0 {
            gate.tip_band = gate.tip_band.max(holding_band.min(tolerance));
        }
        gate
    }

    /// Checks every field is finite and > 0, naming the first that is not.
    pub fn validated(self) -> Result<Self, InPositionError> {
        for (field, value) in [("tip_band", self.tip_band), ("speed_band", self.speed_band), ("timeout", self.timeout)]
        {
            if !(value.is_finite() && value > 0.0) {
                return Err(InPositionError { field, value });
            }
        }
        Ok(self)
    }

    /// The estimated tip's distance from `target` and its speed, through `model`'s kinematics
    /// at the estimate `(q̂, q̂̇)`: `|FK(q̂) − target|` and `|J(q̂) q̂̇|`.
    pub fn measure<const N: usize>(
        model: &ArmModel<N>,
        q: &JointVector<N>,
        qd: &JointVector<N>,
        target: &Vector3<f64>,
    ) -> InPositionCheck {
        let chain = FrameChain::new(model, q);
        let speed = ChainVelocities::new(&chain, qd).frame_origin[N - 1].norm();
        InPositionCheck { tip_error: (chain.tip() - target).norm(), tip_speed: speed }
    }

    /// Whether a check is within both bands.
    pub fn holds(&self, check: &InPositionCheck) -> bool {
        check.tip_error <= self.tip_band && check.tip_speed <= self.speed_band
    }
}

/// One gripper command's wait at its fine point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wait {
    /// Which payload event (gripper command) of the run, 0-based.
    pub event: usize,
    /// When the plan reached the command, s of the run's time (the waits before it included).
    pub reached: f64,
    /// How long the command waited, s (0 when the arm was in position on arrival).
    pub duration: f64,
    /// Whether the wait gave up at the timeout.
    pub timed_out: bool,
    /// The estimate when the command went ahead.
    pub check: InPositionCheck,
}

/// How far the tool tip can move while every encoder of `encoders` moves by one count, m: per
/// joint a count (`2π / counts_per_rev`, 0 for an exact angle) times its longest lever
/// ([`crate::arm::kinematics::longest_levers`]).
pub fn tip_quantum<const N: usize>(model: &ArmModel<N>, encoders: &[crate::sense::sensors::EncoderSpec; N]) -> f64 {
    let levers = crate::arm::kinematics::longest_levers(model);
    (0..N).map(|j| encoders[j].counts_per_rev.map_or(0.0, |counts| std::f64::consts::TAU / counts * levers[j])).sum()
}
