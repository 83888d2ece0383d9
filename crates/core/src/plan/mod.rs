//! Planning: LSPB profiles, Cartesian paths and joint trajectories.

pub mod path;
pub mod profile;
pub mod trajectory;
