//! The arm: model, kinematics, inverse kinematics and dynamics.

pub mod bodies;
pub mod calibration;
pub mod chain;
pub mod dynamics;
pub mod kinematics;
pub mod lagrange;
pub mod link;
pub mod mass_matrix;
pub mod model;
pub mod outline;
pub mod payload;
pub mod preset;
pub mod task;
pub mod uncertainty;
pub mod yaw_pitch;
