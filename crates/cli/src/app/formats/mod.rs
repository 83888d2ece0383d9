//! One room per file kind chessarm reads or writes besides its setup: PGN games ([`pgn`]),
//! plots ([`plots`]), the replay page ([`replay`]), the hardware export ([`hardware`]) and the
//! URDF export ([`urdf`]).

pub mod hardware;
pub mod pgn;
pub mod plan;
pub mod plots;
pub mod replay;
pub mod simulation;
pub mod urdf;
