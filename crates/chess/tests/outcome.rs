//! Game results: the pure rules in `chessarm_chess::outcome` and `Game::outcome` after every move.
#![allow(clippy::unwrap_used)]

use chessarm_chess::board::BoardGeometry;
use chessarm_chess::notation::{parse_fen, parse_move_list};
use chessarm_chess::outcome::{GameOutcome, OutcomeReason, outcome, position_key};
use chessarm_chess::play::{Game, Mover, PlaySettings};
use chessarm_core::arm::preset::report_arm;
use chessarm_core::control::gains::{Gains, REPORT_PD};
use shakmaty::Chess;

fn settings() -> PlaySettings {
    let mut settings = PlaySettings::new("pd", Gains::uniform(REPORT_PD.0, REPORT_PD.1, 0.0).unwrap());
    settings.record_every = 0;
    settings
}

/// Plays `moves` (SAN or UCI) from `start` with the opponent's hand (no simulation) and returns
/// `Game::outcome` after every ply.
fn outcomes_of_game(start: Chess, moves: &str) -> Vec<Option<GameOutcome>> {
    let record = parse_move_list(moves, start.clone()).unwrap();
    let mut game = Game::new(report_arm(), BoardGeometry::default(), start, settings()).unwrap();
    assert_eq!(game.outcome(), None);
    record
        .moves
        .iter()
        .map(|mv| {
            game.play(mv, Mover::Opponent).unwrap();
            game.outcome()
        })
        .collect()
}

/// The outcome after the last ply, checking that every earlier ply had none.
fn final_outcome(start: Chess, moves: &str) -> Option<GameOutcome> {
    let outcomes = outcomes_of_game(start, moves);
    let (last, before) = outcomes.split_last().unwrap();
    for (ply, earlier) in before.iter().enumerate() {
        assert_eq!(*earlier, None, "{moves}: ended early at ply {}", ply + 1);
    }
    *last
}

fn decisive(result: &'static str) -> Option<GameOutcome> {
    Some(GameOutcome { result, reason: OutcomeReason::Checkmate })
}

fn draw(reason: OutcomeReason) -> Option<GameOutcome> {
    Some(GameOutcome { result: "1/2-1/2", reason })
}

#[test]
fn fools_mate_is_won_by_black() {
    assert_eq!(final_outcome(Chess::default(), "f3 e5 g4 Qh4#"), decisive("0-1"));
    assert_eq!(final_outcome(Chess::default(), "e4 e5 Bc4 Nc6 Qh5 Nf6 Qxf7#"), decisive("1-0"));
    assert_eq!(decisive("0-1").unwrap().to_string(), "0-1 (checkmate)");
}

#[test]
fn stalemate_is_a_draw() {
    // Qf7 leaves the black king on h8 without a move, not in check.
    let start = parse_fen("7k/4Q3/6K1/8/8/8/8/8 w - - 0 1").unwrap();
    assert_eq!(final_outcome(start, "Qf7"), draw(OutcomeReason::Stalemate));
    let position = parse_fen("7k/5Q2/6K1/8/8/8/8/8 b - - 0 1").unwrap();
    assert_eq!(outcome(&position, &[position_key(&position)]), draw(OutcomeReason::Stalemate));
}

#[test]
fn bare_kings_are_insufficient_material() {
    let start = parse_fen("8/8/4k3/8/3p4/4K3/8/8 w - - 0 1").unwrap();
    assert_eq!(final_outcome(start, "Kxd4"), draw(OutcomeReason::InsufficientMaterial));
    let kings = parse_fen("8/8/4k3/8/8/4K3/8/8 b - - 0 1").unwrap();
    assert_eq!(outcome(&kings, &[]), draw(OutcomeReason::InsufficientMaterial));
    // A rook is enough to mate.
    let rook = parse_fen("8/8/4k3/8/8/4K3/8/R7 b - - 0 1").unwrap();
    assert_eq!(outcome(&rook, &[position_key(&rook)]), None);
}

#[test]
fn knight_shuffles_repeat_the_start_position_a_third_time_at_ply_8() {
    let outcomes = outcomes_of_game(Chess::default(), "Nf3 Nf6 Ng1 Ng8 Nf3 Nf6 Ng1 Ng8");
    assert_eq!(outcomes.len(), 8);
    // The start position is the first occurrence, ply 4 the second, ply 8 the third; the positions
    // after plies 5-7 occur for the second time only.
    assert!(outcomes[..7].iter().all(Option::is_none), "{outcomes:?}");
    assert_eq!(outcomes[7], draw(OutcomeReason::ThreefoldRepetition));
}

#[test]
fn an_en_passant_square_without_a_legal_capture_does_not_make_a_position_new() {
    // After 1. e4 the FEN has an en-passant square, but no black pawn can take: the position equals
    // the one after 3. Ng1 and 5. Ng1.
    let outcomes = outcomes_of_game(Chess::default(), "e4 Nf6 Nf3 Ng8 Ng1 Nf6 Nf3 Ng8 Ng1");
    assert!(outcomes[..8].iter().all(Option::is_none), "{outcomes:?}");
    assert_eq!(outcomes[8], draw(OutcomeReason::ThreefoldRepetition));
}

#[test]
fn repetition_counts_the_current_position_in_the_history() {
    let position = Chess::default();
    let key = position_key(&position);
    let other = position_key(&parse_fen("8/8/4k3/8/8/4K3/8/R7 b - - 0 1").unwrap());
    assert_eq!(outcome(&position, &[key, other, key]), None);
    assert_eq!(outcome(&position, &[key, other, key, other, key]), draw(OutcomeReason::ThreefoldRepetition));
}

#[test]
fn fifty_move_rule_counts_the_fen_clock_and_a_capture_resets_it() {
    let start = || parse_fen("4k3/8/8/8/8/8/8/R2nK3 w - - 99 80").unwrap();
    assert_eq!(final_outcome(start(), "Ra2"), draw(OutcomeReason::FiftyMoveRule));
    assert_eq!(outcomes_of_game(start(), "Rxd1"), [None]);
    // Ninety-nine plies are not enough.
    let position = parse_fen("4k3/8/8/8/8/8/8/R2nK3 b - - 99 80").unwrap();
    assert_eq!(outcome(&position, &[position_key(&position)]), None);
    // Checkmate on the hundredth quiet ply wins.
    let back_rank = parse_fen("6k1/5ppp/8/8/8/8/8/R5K1 w - - 99 80").unwrap();
    assert_eq!(final_outcome(back_rank, "Ra8#"), decisive("1-0"));
}

#[test]
fn reasons_have_names() {
    let names: Vec<String> = [
        OutcomeReason::Checkmate,
        OutcomeReason::Stalemate,
        OutcomeReason::InsufficientMaterial,
        OutcomeReason::ThreefoldRepetition,
        OutcomeReason::FiftyMoveRule,
    ]
    .iter()
    .map(|reason| {
        assert_eq!(reason.to_string(), reason.name());
        reason.to_string()
    })
    .collect();
    assert_eq!(names, ["checkmate", "stalemate", "insufficient material", "threefold repetition", "fifty-move rule"]);
    assert_eq!(draw(OutcomeReason::FiftyMoveRule).unwrap().to_string(), "1/2-1/2 (fifty-move rule)");
}
