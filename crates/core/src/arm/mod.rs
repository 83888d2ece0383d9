//! The arm: model, kinematics, inverse kinematics and dynamics.

pub mod kinematics;
pub mod model;
pub mod preset;
pub mod task;
