//! chessarm-core: the numeric core of chessarm.
//!
//! Data flows one way: Cartesian waypoints → LSPB path ([`plan::path`]) → inverse kinematics
//! ([`arm::task`]) → joint trajectory ([`plan::trajectory`]) → controller ⇄ plant
//! ([`control`], [`sim`]) → metrics. Everything is SI (m, rad, s, kg, N·m) in the base frame:
//! origin at the arm's base on the board plane, z up.
//!
//! The model ([`arm::model::ArmModel`]) is immutable; algorithms are plain functions that take
//! it and return fixed-size values, so nothing allocates on the hot paths.

pub mod arm;
pub mod control;
pub mod lanes;
pub mod plan;
pub mod sense;
pub mod sim;

pub use nalgebra;

/// A number for a message, short: as Rust prints it when moderate, in scientific form with at
/// most 4 significant digits when huge or tiny (`1e308`, not 309 digits).
pub fn short_number(value: f64) -> String {
    let magnitude = value.abs();
    if value == 0.0 || !value.is_finite() || (1e-4..1e6).contains(&magnitude) {
        format!("{value}")
    } else {
        let text = format!("{value:.3e}");
        // 1.000e308 → 1e308, 1.250e-7 → 1.25e-7
        match text.split_once('e') {
            Some((mantissa, exponent)) if mantissa.contains('.') => {
                format!("{}e{exponent}", mantissa.trim_end_matches('0').trim_end_matches('.'))
            }
            _ => text,
        }
    }
}
