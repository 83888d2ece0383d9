//! chessarm-chess: the chess layer of chessarm. Board geometry, pieces, rules and notation
//! (through shakmaty and pgn-reader), chess moves to pick-and-place tasks, and opponents.

pub mod board;
pub mod clearance;
pub mod motion;
pub mod notation;
pub mod occupancy;
pub mod opponent;
pub mod outcome;
pub mod pieces;
pub mod play;
pub mod reach;
pub mod sag;
pub mod scenario;
pub mod table;
pub mod tasks;
pub mod trial;

pub use shakmaty;
