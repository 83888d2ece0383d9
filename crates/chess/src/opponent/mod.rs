//! Opponents that pick the next move: a small built-in engine ([`BuiltinEngine`]) that needs nothing
//! installed, and a client for external UCI engines such as Stockfish ([`UciEngine`]).
//!
//! Both implement [`Opponent`]. Neither ever panics on bad input or a misbehaving engine: every failure
//! is an [`OpponentError`] whose message names the problem and the offending value.

mod builtin;
mod uci;
mod uci_line;

use std::path::PathBuf;

pub use builtin::{BuiltinEngine, SearchSummary};
pub use uci::{MAX_UCI_LINE_BYTES, UciEngine, kill_all_engines};
pub use uci_line::{UciLine, parse_uci_line};

/// Something that picks a move for the side to move.
pub trait Opponent: std::fmt::Debug {
    /// Picks a legal move in `position` (side to move). Errors never panic.
    ///
    /// # Errors
    ///
    /// [`OpponentError::NoLegalMoves`] if the game is already over (checkmate or stalemate), and for
    /// external engines any of the process/protocol errors of [`OpponentError`].
    fn choose_move(&mut self, position: &shakmaty::Chess) -> Result<shakmaty::Move, OpponentError>;

    /// Human-readable name, e.g. "builtin (depth 3)" or the UCI `id name`.
    fn name(&self) -> String;
}

/// Why an [`Opponent`] could not produce a move.
#[derive(Debug, thiserror::Error)]
pub enum OpponentError {
    /// The side to move has no legal move (it is checkmated or stalemated), so there is nothing to play.
    #[error("no legal moves: the side to move is checkmated or stalemated")]
    NoLegalMoves,

    /// The engine executable could not be started.
    #[error("cannot start UCI engine {}: {cause}", path.display())]
    EngineSpawn {
        /// Path of the executable that was run.
        path: PathBuf,
        /// The operating-system error (in the message, so not also a `source`).
        cause: std::io::Error,
    },

    /// The engine process exited, crashed or closed its pipes.
    #[error("UCI engine {engine} died: {detail}")]
    EngineDied {
        /// Engine name and path.
        engine: String,
        /// What was observed (exit status, what we were waiting for).
        detail: String,
    },

    /// The engine did not answer in time; it has been killed.
    #[error("UCI engine {engine} did not send `{waiting_for}` within {waited_ms} ms; the engine was killed")]
    EngineTimeout {
        /// Engine name and path.
        engine: String,
        /// How long we waited, in milliseconds.
        waited_ms: u64,
        /// The reply we were waiting for (`uciok`, `readyok`, `bestmove`).
        waiting_for: &'static str,
    },

    /// The engine answered with a move that cannot be parsed or is not legal in the position.
    #[error("UCI engine {engine} played illegal move `{uci}` in position {fen}")]
    IllegalMove {
        /// Engine name and path.
        engine: String,
        /// The move text exactly as sent by the engine.
        uci: String,
        /// The position (FEN) the engine was asked to play in.
        fen: String,
    },

    /// The engine sent a line longer than [`MAX_UCI_LINE_BYTES`] (e.g. endless output without a
    /// newline); it has been killed.
    #[error("UCI engine {engine} sent a line longer than {max_bytes} bytes; the engine was killed")]
    LineTooLong {
        /// Engine name and path.
        engine: String,
        /// The limit, [`MAX_UCI_LINE_BYTES`].
        max_bytes: usize,
    },

    /// The engine sent a line that violates the UCI protocol.
    #[error("UCI engine {engine} violated the UCI protocol with line {line:?}")]
    Protocol {
        /// Engine name and path.
        engine: String,
        /// The offending line.
        line: String,
    },

    /// Another I/O error while talking to an engine.
    #[error("I/O error while talking to a UCI engine: {0}")]
    Io(#[from] std::io::Error),
}
