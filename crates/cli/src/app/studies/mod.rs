//! The studies: each a library call with typed options and a typed result, nothing written.
pub mod plan;
pub mod simulate;
