//! A small built-in chess engine, so that the simulator can play without anything installed.
//!
//! Iterative-deepening negamax with alpha-beta pruning, a quiescence search over captures (and queen
//! promotions; all evasions when in check), a small transposition table, MVV-LVA + killer move
//! ordering, check extension, and a material + piece-square-table evaluation (tapered king tables, a
//! bishop-pair bonus and a "mop-up" term that drives a lone king to the edge). Mates are scored so that
//! faster mates are preferred; the fifty-move rule, insufficient material and repetitions inside the
//! search tree score as draws.
//!
//! The search is fully deterministic for a given position and settings, unless a time budget cuts it
//! short (then the result depends on the machine's speed).

use std::cmp::Reverse;
use std::time::{Duration, Instant};

use shakmaty::zobrist::Zobrist64;
use shakmaty::{Chess, Color, EnPassantMode, Move, MoveList, Position, Role, Square};

use super::{Opponent, OpponentError};
use crate::outcome::position_key;

/// Score of being checkmated at the root; a mate found `n` plies from the root scores `MATE - n`.
const MATE: i32 = 30_000;
/// Scores whose absolute value is at least this are mate scores.
const MATE_BOUND: i32 = MATE - 1_000;
/// Larger than any score.
const INF: i32 = 32_000;
/// Hard limit on the search ply (also bounds extensions and the quiescence search).
const MAX_PLY: usize = 96;
/// Largest accepted `max_depth`.
const MAX_DEPTH: u32 = 64;
/// Transposition-table slots (a power of two).
const TT_SIZE: usize = 1 << 16;
/// The clock is looked at once per this many nodes.
const CLOCK_CHECK_INTERVAL: u64 = 1024;

/// A deterministic alpha-beta engine of modest strength that needs no external program.
///
/// The search stops at `max_depth` plies (default 3) or when the optional time budget is used up,
/// whichever comes first. Depth 1 is always completed, so a move is returned even with a tiny budget.
///
/// Without a time budget (`movetime: None`), [`BuiltinEngine::search`] is a pure function of the
/// position and the depth: the same [`SearchSummary`] (move, score, depth, nodes) on every call, in
/// any thread and on any machine (each search has its own tables; nothing is shared, random or
/// timed). A `movetime` cap makes the result machine-dependent: where the search is cut off, and so
/// the depth reached and possibly the move, depends on the machine's speed and load.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BuiltinEngine {
    max_depth: u32,
    movetime: Option<Duration>,
}

/// What [`BuiltinEngine::search`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SearchSummary {
    /// The move to play.
    pub best_move: Move,
    /// Score in centipawns from the point of view of the side to move. Mate scores are
    /// `±(30000 - plies to mate)`, see [`SearchSummary::mate_in_plies`].
    pub score: i32,
    /// Deepest fully completed iteration (0 if there was a single legal move and no search was needed).
    pub depth: u32,
    /// Nodes visited (main search and quiescence search).
    pub nodes: u64,
}

impl SearchSummary {
    /// If the score is a forced mate, the number of plies until mate: positive if the side to move
    /// mates, negative if it gets mated.
    pub fn mate_in_plies(&self) -> Option<i32> {
        if self.score >= MATE_BOUND {
            Some(MATE - self.score)
        } else if self.score <= -MATE_BOUND {
            Some(-(MATE + self.score))
        } else {
            None
        }
    }
}

impl Default for BuiltinEngine {
    /// Depth 3, no time budget.
    fn default() -> Self {
        Self::new(Self::DEFAULT_DEPTH, None)
    }
}

impl BuiltinEngine {
    /// Default search depth in plies.
    pub const DEFAULT_DEPTH: u32 = 3;

    /// Creates an engine searching `max_depth` plies (clamped to 1..=64) and, if `movetime` is given,
    /// stopping after roughly that much time.
    pub fn new(max_depth: u32, movetime: Option<Duration>) -> Self {
        Self { max_depth: max_depth.clamp(1, MAX_DEPTH), movetime }
    }

    /// The maximum search depth in plies.
    pub fn max_depth(&self) -> u32 {
        self.max_depth
    }

    /// The time budget per move, if any.
    pub fn movetime(&self) -> Option<Duration> {
        self.movetime
    }

    /// Searches `position` and reports the best move with its score, depth and node count.
    ///
    /// # Errors
    ///
    /// [`OpponentError::NoLegalMoves`] if the side to move is checkmated or stalemated.
    pub fn search(&self, position: &Chess) -> Result<SearchSummary, OpponentError> {
        let start = Instant::now();
        let mut root_moves = position.legal_moves();
        if root_moves.is_empty() {
            return Err(OpponentError::NoLegalMoves);
        }
        order_moves(&mut root_moves, None, [None, None]);
        let Some(&first) = root_moves.first() else {
            return Err(OpponentError::NoLegalMoves);
        };
        if root_moves.len() == 1 {
            return Ok(SearchSummary { best_move: first, score: evaluate(position), depth: 0, nodes: 1 });
        }

        let mut searcher = Searcher::new(self.movetime.map(|budget| start + budget));
        let root_hash = position_key(position);
        let mut best = SearchSummary { best_move: first, score: 0, depth: 0, nodes: 0 };
        for depth in 1..=self.max_depth {
            // The next iteration takes several times longer than this one: do not start it when it
            // would surely be cut off.
            if depth > 1
                && let Some(budget) = self.movetime
                && start.elapsed() * 2 >= budget
            {
                break;
            }
            searcher.enforce_deadline = depth > 1;
            let Some((best_move, score)) = searcher.search_root(position, root_hash, &mut root_moves, depth) else {
                break;
            };
            best = SearchSummary { best_move, score, depth, nodes: searcher.nodes };
            if score >= MATE_BOUND {
                // A forced mate: iterative deepening found the shortest one already.
                break;
            }
        }
        best.nodes = searcher.nodes;
        Ok(best)
    }
}

impl Opponent for BuiltinEngine {
    fn choose_move(&mut self, position: &Chess) -> Result<Move, OpponentError> {
        self.search(position).map(|summary| summary.best_move)
    }

    fn name(&self) -> String {
        match self.movetime {
            Some(budget) => format!("builtin (depth {}, {} ms)", self.max_depth, budget.as_millis()),
            None => format!("builtin (depth {})", self.max_depth),
        }
    }
}

/// How a stored score relates to the true score.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Bound {
    Exact,
    /// The true score is at least the stored one (fail high).
    Lower,
    /// The true score is at most the stored one (fail low).
    Upper,
}

#[derive(Debug, Clone, Copy)]
struct TtEntry {
    key: u64,
    depth: i32,
    score: i32,
    bound: Bound,
    best: Option<Move>,
}

/// State of one search.
#[derive(Debug)]
struct Searcher {
    deadline: Option<Instant>,
    /// Whether the deadline may stop the current iteration (not during depth 1).
    enforce_deadline: bool,
    stopped: bool,
    nodes: u64,
    tt: Vec<Option<TtEntry>>,
    killers: Vec<[Option<Move>; 2]>,
    /// Zobrist hashes from the root to the current node, for repetition detection.
    path: Vec<u64>,
}

impl Searcher {
    fn new(deadline: Option<Instant>) -> Self {
        Self {
            deadline,
            enforce_deadline: false,
            stopped: false,
            nodes: 0,
            tt: vec![None; TT_SIZE],
            killers: vec![[None, None]; MAX_PLY + 1],
            path: Vec::with_capacity(MAX_PLY + 1),
        }
    }

    /// Searches all root moves to `depth`; returns the best move and its score, or `None` if the time
    /// ran out. Reorders `moves` so that the best one is searched first in the next iteration.
    fn search_root(&mut self, pos: &Chess, hash: u64, moves: &mut MoveList, depth: u32) -> Option<(Move, i32)> {
        let depth = i32::try_from(depth).unwrap_or(i32::MAX);
        let mut alpha = -INF;
        let mut best: Option<(usize, Move, i32)> = None;
        self.path.clear();
        self.path.push(hash);
        for (index, &m) in moves.iter().enumerate() {
            let (child, child_hash) = play(pos, hash, m);
            self.path.push(child_hash);
            let score = -self.negamax(&child, child_hash, depth - 1, 1, -INF, -alpha);
            self.path.pop();
            if self.stopped {
                return None;
            }
            if best.is_none() || score > alpha {
                alpha = score;
                best = Some((index, m, score));
            }
        }
        let (index, m, score) = best?;
        moves[..=index].rotate_right(1);
        self.store(hash, depth, score, Bound::Exact, Some(m), 0);
        Some((m, score))
    }

    fn negamax(&mut self, pos: &Chess, hash: u64, depth: i32, ply: usize, mut alpha: i32, beta: i32) -> i32 {
        if self.out_of_time() {
            return 0;
        }
        self.nodes += 1;
        if pos.halfmoves() >= 100 || pos.is_insufficient_material() || self.is_repetition(hash, pos.halfmoves()) {
            return 0;
        }
        if ply >= MAX_PLY {
            return evaluate(pos);
        }
        let in_check = pos.is_check();
        let depth = if in_check { depth + 1 } else { depth };
        if depth <= 0 {
            return self.quiesce(pos, ply, alpha, beta);
        }

        let mut tt_move = None;
        if let Some(entry) = self.probe(hash) {
            tt_move = entry.best;
            if entry.depth >= depth {
                let score = score_from_tt(entry.score, ply);
                match entry.bound {
                    Bound::Exact => return score,
                    Bound::Lower if score >= beta => return score,
                    Bound::Upper if score <= alpha => return score,
                    _ => {}
                }
            }
        }

        let mut moves = pos.legal_moves();
        if moves.is_empty() {
            return if in_check { mated_score(ply) } else { 0 };
        }
        order_moves(&mut moves, tt_move, self.killers[ply]);

        let alpha_orig = alpha;
        let mut best_score = -INF;
        let mut best_move = None;
        for m in moves {
            let (child, child_hash) = play(pos, hash, m);
            self.path.push(child_hash);
            let score = -self.negamax(&child, child_hash, depth - 1, ply + 1, -beta, -alpha);
            self.path.pop();
            if self.stopped {
                return 0;
            }
            if score > best_score {
                best_score = score;
                best_move = Some(m);
            }
            if score > alpha {
                alpha = score;
            }
            if alpha >= beta {
                if !m.is_capture() && self.killers[ply][0] != Some(m) {
                    self.killers[ply] = [Some(m), self.killers[ply][0]];
                }
                break;
            }
        }

        let bound = if best_score <= alpha_orig {
            Bound::Upper
        } else if best_score >= beta {
            Bound::Lower
        } else {
            Bound::Exact
        };
        self.store(hash, depth, best_score, bound, best_move, ply);
        best_score
    }

    /// Searches captures and queen promotions (all moves when in check) until the position is quiet.
    fn quiesce(&mut self, pos: &Chess, ply: usize, mut alpha: i32, beta: i32) -> i32 {
        if self.out_of_time() {
            return 0;
        }
        self.nodes += 1;
        let in_check = pos.is_check();
        let mut moves = pos.legal_moves();
        if moves.is_empty() {
            return if in_check { mated_score(ply) } else { 0 };
        }
        if ply >= MAX_PLY {
            return evaluate(pos);
        }

        let mut best_score = -INF;
        if !in_check {
            let stand_pat = evaluate(pos);
            if stand_pat >= beta {
                return stand_pat;
            }
            alpha = alpha.max(stand_pat);
            best_score = stand_pat;
            moves.retain(|m| m.is_capture() || m.promotion() == Some(Role::Queen));
        }
        order_moves(&mut moves, None, [None, None]);

        for m in moves {
            let mut child = pos.clone();
            child.play_unchecked(m);
            let score = -self.quiesce(&child, ply + 1, -beta, -alpha);
            if self.stopped {
                return 0;
            }
            best_score = best_score.max(score);
            alpha = alpha.max(score);
            if alpha >= beta {
                break;
            }
        }
        best_score
    }

    fn out_of_time(&mut self) -> bool {
        if !self.stopped
            && self.enforce_deadline
            && self.nodes.is_multiple_of(CLOCK_CHECK_INTERVAL)
            && let Some(deadline) = self.deadline
        {
            self.stopped = Instant::now() >= deadline;
        }
        self.stopped
    }

    /// Whether the current node (last in `path`) repeats an earlier position of the search path.
    fn is_repetition(&self, hash: u64, halfmoves: u32) -> bool {
        let reversible = usize::try_from(halfmoves).unwrap_or(usize::MAX);
        let len = self.path.len();
        (2..len).step_by(2).take_while(|&back| back <= reversible).any(|back| self.path[len - 1 - back] == hash)
    }

    fn slot(hash: u64) -> usize {
        // Truncation is intended: the low bits select the slot.
        (hash as usize) & (TT_SIZE - 1)
    }

    fn probe(&self, hash: u64) -> Option<TtEntry> {
        self.tt[Self::slot(hash)].filter(|entry| entry.key == hash)
    }

    fn store(&mut self, hash: u64, depth: i32, score: i32, bound: Bound, best: Option<Move>, ply: usize) {
        let slot = &mut self.tt[Self::slot(hash)];
        // Depth-preferred replacement, but always replace entries of other positions' stale searches.
        if let Some(old) = slot
            && old.key == hash
            && old.depth > depth
            && bound != Bound::Exact
        {
            return;
        }
        *slot = Some(TtEntry { key: hash, depth, score: score_to_tt(score, ply), bound, best });
    }
}

fn mated_score(ply: usize) -> i32 {
    -MATE + i32::try_from(ply).unwrap_or(0)
}

/// Mate scores are stored relative to the node, not the root, so they stay valid at other plies.
fn score_to_tt(score: i32, ply: usize) -> i32 {
    let ply = i32::try_from(ply).unwrap_or(0);
    if score >= MATE_BOUND {
        score + ply
    } else if score <= -MATE_BOUND {
        score - ply
    } else {
        score
    }
}

fn score_from_tt(score: i32, ply: usize) -> i32 {
    let ply = i32::try_from(ply).unwrap_or(0);
    if score >= MATE_BOUND {
        score - ply
    } else if score <= -MATE_BOUND {
        score + ply
    } else {
        score
    }
}

/// Plays a legal move, returning the new position and its Zobrist hash.
fn play(pos: &Chess, hash: u64, m: Move) -> (Chess, u64) {
    let incremental = pos.update_zobrist_hash(Zobrist64(hash), m, EnPassantMode::Legal);
    let mut child = pos.clone();
    child.play_unchecked(m);
    let child_hash = incremental.map_or_else(|| position_key(&child), |z| z.0);
    (child, child_hash)
}

/// Sorts moves best-first: hash move, captures by MVV-LVA, promotions, killers, then quiet moves in
/// generation order (the sort is stable, so the order is deterministic).
fn order_moves(moves: &mut MoveList, hash_move: Option<Move>, killers: [Option<Move>; 2]) {
    moves.sort_by_key(|&m| Reverse(move_order_score(m, hash_move, killers)));
}

fn move_order_score(m: Move, hash_move: Option<Move>, killers: [Option<Move>; 2]) -> i32 {
    if hash_move == Some(m) {
        1_000_000
    } else if let Some(victim) = m.capture() {
        100_000 + 16 * piece_value(victim) - role_rank(m.role()) + m.promotion().map_or(0, piece_value)
    } else if let Some(promotion) = m.promotion() {
        90_000 + piece_value(promotion)
    } else if killers[0] == Some(m) {
        80_000
    } else if killers[1] == Some(m) {
        79_000
    } else {
        0
    }
}

fn piece_value(role: Role) -> i32 {
    match role {
        Role::Pawn => 100,
        Role::Knight => 320,
        Role::Bishop => 330,
        Role::Rook => 500,
        Role::Queen => 900,
        Role::King => 0,
    }
}

/// Attacker rank for least-valuable-attacker ordering.
fn role_rank(role: Role) -> i32 {
    match role {
        Role::Pawn => 1,
        Role::Knight => 2,
        Role::Bishop => 3,
        Role::Rook => 4,
        Role::Queen => 5,
        Role::King => 6,
    }
}

/// Static evaluation in centipawns from the point of view of the side to move.
fn evaluate(pos: &Chess) -> i32 {
    let board = pos.board();
    // Game phase: 24 with all minor and major pieces on the board, 0 with none.
    let phase_units =
        board.knights().count() + board.bishops().count() + 2 * board.rooks().count() + 4 * board.queens().count();
    let phase = i32::try_from(phase_units.min(24)).unwrap_or(24);

    let mut score = 0; // White's point of view.
    let mut material = [0i32; 2]; // Non-king material, [white, black].
    let mut bishops = [0u32; 2];
    for (square, piece) in board {
        // The tables are written from White's side with a8 first; mirror for Black.
        let index = piece.color.fold_wb(square.to_usize() ^ 56, square.to_usize());
        let side = piece.color.fold_wb(0, 1);
        let value = match piece.role {
            Role::Pawn => PAWN_TABLE[index],
            Role::Knight => KNIGHT_TABLE[index],
            Role::Bishop => {
                bishops[side] += 1;
                BISHOP_TABLE[index]
            }
            Role::Rook => ROOK_TABLE[index],
            Role::Queen => QUEEN_TABLE[index],
            Role::King => (KING_MIDDLEGAME_TABLE[index] * phase + KING_ENDGAME_TABLE[index] * (24 - phase)) / 24,
        } + piece_value(piece.role);
        material[side] += piece_value(piece.role);
        score += piece.color.fold_wb(value, -value);
    }
    if bishops[0] >= 2 {
        score += BISHOP_PAIR;
    }
    if bishops[1] >= 2 {
        score -= BISHOP_PAIR;
    }
    score += mop_up(pos, phase, material);
    pos.turn().fold_wb(score, -score)
}

const BISHOP_PAIR: i32 = 30;

/// In a won endgame, reward pushing the losing king to the edge and bringing the winning king close,
/// so that the engine actually converts (e.g. KR vs K) instead of shuffling. White's point of view.
fn mop_up(pos: &Chess, phase: i32, material: [i32; 2]) -> i32 {
    let advantage = material[0] - material[1];
    if phase > 8 || advantage.abs() < 300 {
        return 0;
    }
    let winner = if advantage > 0 { Color::White } else { Color::Black };
    let board = pos.board();
    let (Some(winning_king), Some(losing_king)) = (board.king_of(winner), board.king_of(!winner)) else {
        return 0;
    };
    let bonus = 10 * center_distance(losing_king) + 4 * (14 - manhattan_distance(winning_king, losing_king));
    winner.fold_wb(bonus, -bonus)
}

fn center_distance(square: Square) -> i32 {
    let from_center = |coordinate: u32| {
        let c = i32::try_from(coordinate).unwrap_or(0);
        if c < 4 { 3 - c } else { c - 4 }
    };
    from_center(square.file().to_u32()) + from_center(square.rank().to_u32())
}

fn manhattan_distance(a: Square, b: Square) -> i32 {
    let files = a.file().to_u32().abs_diff(b.file().to_u32());
    let ranks = a.rank().to_u32().abs_diff(b.rank().to_u32());
    i32::try_from(files + ranks).unwrap_or(14)
}

// Piece-square tables (Tomasz Michniewski's "simplified evaluation function"), from White's point of
// view, rank 8 first: index 0 is a8, index 63 is h1.
#[rustfmt::skip]
const PAWN_TABLE: [i32; 64] = [
     0,  0,  0,  0,  0,  0,  0,  0,
    50, 50, 50, 50, 50, 50, 50, 50,
    10, 10, 20, 30, 30, 20, 10, 10,
     5,  5, 10, 25, 25, 10,  5,  5,
     0,  0,  0, 20, 20,  0,  0,  0,
     5, -5,-10,  0,  0,-10, -5,  5,
     5, 10, 10,-20,-20, 10, 10,  5,
     0,  0,  0,  0,  0,  0,  0,  0,
];

#[rustfmt::skip]
const KNIGHT_TABLE: [i32; 64] = [
    -50,-40,-30,-30,-30,-30,-40,-50,
    -40,-20,  0,  0,  0,  0,-20,-40,
    -30,  0, 10, 15, 15, 10,  0,-30,
    -30,  5, 15, 20, 20, 15,  5,-30,
    -30,  0, 15, 20, 20, 15,  0,-30,
    -30,  5, 10, 15, 15, 10,  5,-30,
    -40,-20,  0,  5,  5,  0,-20,-40,
    -50,-40,-30,-30,-30,-30,-40,-50,
];

#[rustfmt::skip]
const BISHOP_TABLE: [i32; 64] = [
    -20,-10,-10,-10,-10,-10,-10,-20,
    -10,  0,  0,  0,  0,  0,  0,-10,
    -10,  0,  5, 10, 10,  5,  0,-10,
    -10,  5,  5, 10, 10,  5,  5,-10,
    -10,  0, 10, 10, 10, 10,  0,-10,
    -10, 10, 10, 10, 10, 10, 10,-10,
    -10,  5,  0,  0,  0,  0,  5,-10,
    -20,-10,-10,-10,-10,-10,-10,-20,
];

#[rustfmt::skip]
const ROOK_TABLE: [i32; 64] = [
     0,  0,  0,  0,  0,  0,  0,  0,
     5, 10, 10, 10, 10, 10, 10,  5,
    -5,  0,  0,  0,  0,  0,  0, -5,
    -5,  0,  0,  0,  0,  0,  0, -5,
    -5,  0,  0,  0,  0,  0,  0, -5,
    -5,  0,  0,  0,  0,  0,  0, -5,
    -5,  0,  0,  0,  0,  0,  0, -5,
     0,  0,  0,  5,  5,  0,  0,  0,
];

#[rustfmt::skip]
const QUEEN_TABLE: [i32; 64] = [
    -20,-10,-10, -5, -5,-10,-10,-20,
    -10,  0,  0,  0,  0,  0,  0,-10,
    -10,  0,  5,  5,  5,  5,  0,-10,
     -5,  0,  5,  5,  5,  5,  0, -5,
      0,  0,  5,  5,  5,  5,  0, -5,
    -10,  5,  5,  5,  5,  5,  0,-10,
    -10,  0,  5,  0,  0,  0,  0,-10,
    -20,-10,-10, -5, -5,-10,-10,-20,
];

#[rustfmt::skip]
const KING_MIDDLEGAME_TABLE: [i32; 64] = [
    -30,-40,-40,-50,-50,-40,-40,-30,
    -30,-40,-40,-50,-50,-40,-40,-30,
    -30,-40,-40,-50,-50,-40,-40,-30,
    -30,-40,-40,-50,-50,-40,-40,-30,
    -20,-30,-30,-40,-40,-30,-30,-20,
    -10,-20,-20,-20,-20,-20,-20,-10,
     20, 20,  0,  0,  0,  0, 20, 20,
     20, 30, 10,  0,  0, 10, 30, 20,
];

#[rustfmt::skip]
const KING_ENDGAME_TABLE: [i32; 64] = [
    -50,-40,-30,-20,-20,-30,-40,-50,
    -30,-20,-10,  0,  0,-10,-20,-30,
    -30,-10, 20, 30, 30, 20,-10,-30,
    -30,-10, 30, 40, 40, 30,-10,-30,
    -30,-10, 30, 40, 40, 30,-10,-30,
    -30,-10, 20, 30, 30, 20,-10,-30,
    -30,-30,  0,  0,  0,  0,-30,-30,
    -50,-30,-30,-30,-30,-30,-30,-50,
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn start_position_is_balanced() {
        assert_eq!(evaluate(&Chess::default()), 0);
    }

    #[test]
    fn evaluation_is_symmetric() {
        let fen = "r1bqkbnr/pppp1ppp/2n5/4p3/4P3/5N2/PPPP1PPP/RNBQKB1R w KQkq - 2 3";
        let pos: Chess = fen
            .parse::<shakmaty::fen::Fen>()
            .expect("valid FEN")
            .into_position(shakmaty::CastlingMode::Standard)
            .expect("legal position");
        let mirrored = "rnbqkb1r/pppp1ppp/5n2/4p3/4P3/2N5/PPPP1PPP/R1BQKBNR b KQkq - 2 3";
        let mirrored: Chess = mirrored
            .parse::<shakmaty::fen::Fen>()
            .expect("valid FEN")
            .into_position(shakmaty::CastlingMode::Standard)
            .expect("legal position");
        assert_eq!(evaluate(&pos), evaluate(&mirrored));
    }

    #[test]
    fn mate_scores_round_trip_through_the_table() {
        for ply in [0, 1, 7] {
            for score in [MATE - 5, -MATE + 9, 123, -45] {
                assert_eq!(score_from_tt(score_to_tt(score, ply), ply), score);
            }
        }
    }
}
