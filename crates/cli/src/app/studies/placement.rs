//! How the robot puts a game's pieces down: at fine points (the gripper waits until the arm is
//! in position) or by the clock, and whether the controller is told the mass it carries.

use crate::app::setup::conditions::Resolution;
use chessarm_chess::play::PlaySettings;
use chessarm_core::plan::fine_point::{BAND_CROSSING_TIME, InPosition};

/// The placement choices of a game (SI: the command line's mm and mm/s are converted where it
/// reads them).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Close and open the gripper at the plan's instants, in position or not.
    pub release_by_clock: bool,
    /// In position: the estimated tip within this distance of the planned point, m (default:
    /// two counts of every encoder at the tip, see [`InPosition::for_actuators`]).
    pub in_position_band: Option<f64>,
    /// In position: the estimated tip no faster than this, m/s (default: the band per
    /// [`BAND_CROSSING_TIME`]).
    pub in_position_speed: Option<f64>,
    /// Longest wait for the arm to be in position, s.
    pub in_position_timeout: Option<f64>,
    /// The controller is told the nominal mass of the piece kind it grips.
    pub payload_feedforward: bool,
}

impl Default for Placement {
    fn default() -> Self {
        Self {
            release_by_clock: false,
            in_position_band: None,
            in_position_speed: None,
            in_position_timeout: None,
            payload_feedforward: true,
        }
    }
}

impl Placement {
    /// The fine points' condition for a placement tolerance of `tolerance` m, or `None` by
    /// the clock.
    pub fn in_position(&self, tolerance: f64, resolution: Resolution) -> Option<InPosition> {
        if self.release_by_clock {
            return None;
        }
        let mut gate = InPosition::for_actuators(tolerance, resolution.tip_quantum, resolution.holding_band);
        if let Some(band) = self.in_position_band {
            gate.tip_band = band;
            gate.speed_band = gate.tip_band / BAND_CROSSING_TIME;
        }
        if let Some(speed) = self.in_position_speed {
            gate.speed_band = speed;
        }
        if let Some(timeout) = self.in_position_timeout {
            gate.timeout = timeout;
        }
        Some(gate)
    }

    /// Sets a game's fine points and payload feed-forward; `tolerance` in m, `resolution` the
    /// sensors' and actuators' ([`crate::app::setup::conditions::Study::resolution`]).
    pub fn apply(&self, settings: &mut PlaySettings, tolerance: f64, resolution: Resolution) {
        settings.in_position = self.in_position(tolerance, resolution);
        settings.payload_feedforward = self.payload_feedforward;
    }
}
