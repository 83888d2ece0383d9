//! The result of a game from its position and history: checkmate, stalemate, insufficient
//! material, threefold repetition and the fifty-move rule.
//!
//! Pure functions over a [`Chess`] position and the [`position_key`]s of the positions so far, so
//! that the rules are tested without simulating the arm; [`crate::play::Game::outcome`] applies them
//! to a game in progress.
//!
//! Repetitions and the fifty-move rule end the game here as soon as they occur (as if claimed at
//! once); the automatic fivefold and seventy-five-move rules are thus never needed.

use std::fmt;

use shakmaty::zobrist::Zobrist64;
use shakmaty::{Chess, Color, EnPassantMode, Position};

/// Why a game ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum OutcomeReason {
    /// The side to move is in check and has no legal move.
    Checkmate,
    /// The side to move is not in check and has no legal move.
    Stalemate,
    /// Neither side can ever mate (e.g. king against king, or king and minor piece against king).
    InsufficientMaterial,
    /// The same position occurred for the third time.
    ThreefoldRepetition,
    /// Fifty moves by each side (100 plies) without a capture or a pawn move.
    FiftyMoveRule,
}

impl OutcomeReason {
    /// Lower-case name, e.g. "checkmate", "threefold repetition".
    pub fn name(self) -> &'static str {
        match self {
            OutcomeReason::Checkmate => "checkmate",
            OutcomeReason::Stalemate => "stalemate",
            OutcomeReason::InsufficientMaterial => "insufficient material",
            OutcomeReason::ThreefoldRepetition => "threefold repetition",
            OutcomeReason::FiftyMoveRule => "fifty-move rule",
        }
    }
}

impl fmt::Display for OutcomeReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// How a game ended: the PGN result and the reason.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct GameOutcome {
    /// `"1-0"`, `"0-1"` or `"1/2-1/2"`.
    pub result: &'static str,
    /// Why.
    pub reason: OutcomeReason,
}

impl fmt::Display for GameOutcome {
    /// E.g. "0-1 (checkmate)".
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({})", self.result, self.reason)
    }
}

/// The key under which positions are compared for repetitions: piece placement, side to move,
/// castling rights and the en-passant square only when an en-passant capture is legal (FIDE's
/// "same position"), as a Zobrist hash.
pub fn position_key(position: &Chess) -> u64 {
    position.zobrist_hash::<Zobrist64>(EnPassantMode::Legal).0
}

/// The outcome of a game now at `position`, or `None` if it goes on.
///
/// `history` holds the [`position_key`] of every position of the game so far, the start position
/// first and `position` itself last (a key missing from it only makes repetitions count less). A FEN
/// start's halfmove clock counts towards the fifty-move rule. Checkmate takes precedence over the
/// draws (a mate on the hundredth quiet ply wins), then stalemate, insufficient material, repetition
/// and the fifty-move rule.
pub fn outcome(position: &Chess, history: &[u64]) -> Option<GameOutcome> {
    let draw = |reason| Some(GameOutcome { result: "1/2-1/2", reason });
    if position.is_checkmate() {
        let result = match position.turn() {
            Color::White => "0-1",
            Color::Black => "1-0",
        };
        return Some(GameOutcome { result, reason: OutcomeReason::Checkmate });
    }
    if position.is_stalemate() {
        return draw(OutcomeReason::Stalemate);
    }
    if position.is_insufficient_material() {
        return draw(OutcomeReason::InsufficientMaterial);
    }
    let key = position_key(position);
    if history.iter().filter(|&&seen| seen == key).count() >= 3 {
        return draw(OutcomeReason::ThreefoldRepetition);
    }
    if position.halfmoves() >= 100 {
        return draw(OutcomeReason::FiftyMoveRule);
    }
    None
}
