//! A board of given squares placed where the arm serves it (`chessarm board --fit
//! --square-size`), or the nearest pose and what fails there: the placement passes the full
//! check, every size the fit serves is placed, and at the nearest pose of squares no pose
//! serves the full check fails too.

mod common;

use chessarm_chess::clearance::moves::ClearanceCheck;
use chessarm_chess::pieces::PieceSet;
use chessarm_chess::reach::{check_table, check_table_at, fit_board, place_board, place_failures};
use chessarm_chess::tasks::MotionLimits;
use chessarm_core::arm::preset::report_arm;
use common::slim;

#[test]
fn a_board_of_given_squares_is_placed_where_the_full_check_passes() {
    let arm = report_arm();
    let check = slim();
    let limits = MotionLimits::default();
    let pieces = PieceSet::default();
    for size in [0.04, 0.05] {
        let placed = place_board(&arm, &pieces, 0.06, size, &limits, (0.0, 0.05), Some(&check))
            .unwrap_or_else(|e| panic!("squares of {size} m: {e}"));
        assert_eq!(placed.board.square_size, size);
        // The pieces scaled with the squares: lengths by size/0.06, masses by its cube.
        let k = size / 0.06;
        assert!((placed.pieces.king.height - pieces.king.height * k).abs() < 1e-12);
        assert!((placed.pieces.king.mass - pieces.king.mass * k * k * k).abs() < 1e-12);
        let pitch = check_table(&arm, &placed.board, &placed.pieces, &limits, Some(&check))
            .unwrap_or_else(|e| panic!("squares of {size} m placed at {:?}: {e}", placed.board));
        assert_eq!(pitch, placed.pitch);
        // Nothing fails at the placement's own pitch.
        let failures = place_failures(&arm, &placed.board, &placed.pieces, &limits, pitch, Some(&check));
        assert!(failures.is_empty(), "{failures:?}");
    }
}

#[test]
fn squares_too_large_give_the_nearest_pose_and_failures_the_full_check_confirms() {
    let arm = report_arm();
    let check = slim();
    let limits = MotionLimits::default();
    // 15 cm squares: a 1.2 m board, twice the report's arm's reach.
    let unplaced = place_board(&arm, &PieceSet::default(), 0.06, 0.15, &limits, (0.0, 0.05), Some(&check))
        .expect_err("no pose serves 15 cm squares");
    assert!(!unplaced.failures.is_empty());
    assert_eq!(unplaced.board.square_size, 0.15);
    // Every reason names its place.
    for (place, why) in &unplaced.failures {
        assert!(why.contains(place.as_str()) || place.starts_with("a way"), "{place}: {why}");
    }
    // The full check at the same pose and pitch fails too.
    let full = check_table_at(&arm, &unplaced.board, &unplaced.pieces, &limits, unplaced.pitch, Some(&check));
    assert!(full.is_err());
    assert!(unplaced.to_string().contains(&format!("fails {} places", unplaced.failures.len())), "{unplaced}");
}

/// The fit's largest board, and one a little smaller, are placed at their size: what the fit
/// serves the placement finds, with the report's default fingers and with slim ones.
#[test]
fn every_size_the_fit_serves_is_placed() {
    let arm = report_arm();
    let limits = MotionLimits::default();
    let pieces = PieceSet::default();
    for check in [ClearanceCheck::default(), slim()] {
        let fit = fit_board(&arm, &pieces, 0.06, &limits, (0.0, 0.05), Some(&check)).expect("a board fits");
        for size in [fit.board.square_size, 0.9 * fit.board.square_size] {
            let placed = place_board(&arm, &pieces, 0.06, size, &limits, (0.0, 0.05), Some(&check))
                .unwrap_or_else(|e| panic!("squares of {size} m, the fit's largest {}: {e}", fit.board.square_size));
            check_table(&arm, &placed.board, &placed.pieces, &limits, Some(&check)).expect("served");
        }
    }
}
