//! One room per file kind chessarm reads or writes besides its setup: PGN games ([`pgn`]),
//! plots ([`plots`]), the replay page ([`replay`]), the hardware export ([`hardware`]), the URDF
//! export ([`urdf`]), and the studies' tables and figures ([`plan`], [`simulation`], [`tune`], [`robustness`]).

pub mod hardware;
pub mod pgn;
pub mod plan;
pub mod plots;
pub mod replay;
pub mod robustness;
pub mod simulation;
pub mod tune;
pub mod urdf;
