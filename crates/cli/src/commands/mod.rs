//! One module per command.

pub mod kinematics;
pub mod plan;
