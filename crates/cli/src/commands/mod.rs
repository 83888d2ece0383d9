//! One module per command.

pub mod board;
pub mod bus_sim;
pub mod calibrate;
pub mod demo;
pub mod gains;
pub mod kinematics;
pub mod plan;
pub mod play;
pub mod robustness;
pub mod simulate;
pub mod tune;
