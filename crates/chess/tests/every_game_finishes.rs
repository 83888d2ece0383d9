//! Every legal game finishes on a board the pre-flight accepts: random legal games, drawn from
//! a seed, on the largest board the fit gives the report's arm with slim fingers (its pieces
//! scaled with the squares) and on the report's own board. None stops part-way, every piece
//! stands where the rules put it, and nothing is touched.

mod common;

use chessarm_chess::board::BoardGeometry;
use chessarm_chess::clearance::moves::ClearanceCheck;
use chessarm_chess::pieces::PieceSet;
use chessarm_chess::play::{Game, Mover, PlaySettings};
use chessarm_chess::reach::fit_board;
use chessarm_chess::shakmaty::{Chess, Position};
use chessarm_core::arm::preset::report_arm;
use chessarm_core::control::gains::{Gains, REPORT_PD};
use chessarm_core::sense::rng::SeededRng;
use common::slim;
use proptest::prelude::*;

fn settings(pieces: PieceSet, clearance: ClearanceCheck) -> PlaySettings {
    let mut settings =
        PlaySettings::new("pd", Gains::uniform(REPORT_PD.0, REPORT_PD.1, 0.0).expect("the report's gains"));
    settings.record_every = 0;
    settings.pieces = pieces;
    settings.clearance = Some(clearance);
    settings
}

/// Plays `plies` random legal moves (or to the game's end) by the arm from the start; returns
/// how many were played.
fn random_game(board: BoardGeometry, settings: PlaySettings, seed: u64, plies: usize) -> usize {
    let mut game = Game::new(report_arm(), board, Chess::default(), settings).expect("the board is accepted");
    let mut rng = SeededRng::new(seed);
    for ply in 0..plies {
        let moves = game.position().legal_moves();
        if moves.is_empty() {
            return ply;
        }
        let mv = moves[(rng.next_u64() % moves.len() as u64) as usize];
        let report = game.play(&mv, Mover::Robot).unwrap_or_else(|e| panic!("seed {seed}, ply {}: {e}", ply + 1));
        assert!(report.new_misplaced.is_empty(), "seed {seed}, ply {}: {:?}", ply + 1, report.new_misplaced);
        let clearance = report.executed_clearance.expect("the motion's clearance is measured");
        assert!(!clearance.is_contact(), "seed {seed}, ply {}: {clearance:?}", ply + 1);
    }
    plies
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 3, ..ProptestConfig::default() })]

    #[test]
    fn random_games_on_the_fitted_board_never_stop(seed in any::<u64>()) {
        let check = slim();
        let limits = chessarm_chess::tasks::MotionLimits::default();
        let fit = fit_board(&report_arm(), &PieceSet::default(), 0.06, &limits, (0.0, 0.05), Some(&check))
            .expect("a board fits");
        eprintln!("fitted: squares of {:.1} mm, pitch {:.4} rad", fit.board.square_size * 1e3, fit.pitch);
        prop_assert!(random_game(fit.board, settings(fit.pieces, check), seed, 60) > 0);
    }

    #[test]
    fn random_games_on_the_reports_board_never_stop(seed in any::<u64>()) {
        let played = random_game(BoardGeometry::default(), settings(PieceSet::default(), ClearanceCheck::default()), seed, 60);
        prop_assert!(played > 0);
    }
}
