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
pub mod plan;
pub mod sim;

pub use nalgebra;
