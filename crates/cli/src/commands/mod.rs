//! One module per command.

pub mod demo;
pub mod kinematics;
pub mod plan;
pub mod simulate;
