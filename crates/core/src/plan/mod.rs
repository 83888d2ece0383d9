//! Planning: LSPB profiles, Cartesian paths, joint trajectories, and time-optimal timing of
//! geometric paths (TOPP-RA) under joint, torque, tool and grip limits.

pub mod constraints;
pub mod fine_point;
pub mod geometric;
pub mod hardware;
pub mod optimal;
pub mod path;
pub mod profile;
pub mod topp;
pub mod trajectory;
