//! Board geometry and the report's scenario, through the arm's kinematics.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

use chessarm_chess::board::{BoardGeometry, parse_square};
use chessarm_chess::scenario::{queens_gambit, scenario};
use chessarm_chess::shakmaty::Square;
use chessarm_core::arm::preset::report_arm;
use chessarm_core::arm::task::{TOOL_DOWN, inverse_kinematics, tool_point};
use chessarm_core::nalgebra::{Vector2, Vector3};
use chessarm_core::plan::path::GripperAction;
use chessarm_core::plan::trajectory::JointTrajectory;

#[test]
fn report_layout_of_the_squares() {
    let board = BoardGeometry::default();
    let close = |a: Vector3<f64>, b: Vector3<f64>| (a - b).norm() < 1e-12;
    assert!(close(board.square_center(Square::A1), Vector3::new(-0.21, 0.12, 0.0)));
    assert!(close(board.square_center(Square::H1), Vector3::new(0.21, 0.12, 0.0)));
    assert!(close(board.square_center(Square::D4), Vector3::new(-0.03, 0.30, 0.0)));
    assert!(close(board.square_center(Square::H8), Vector3::new(0.21, 0.54, 0.0)));
    // Configurable size and offset.
    let small = BoardGeometry {
        square_size: 0.05,
        center: Vector2::new(0.1, 0.4),
        surface_height: 0.02,
        yaw: 0.0,
        base_clearance: 0.05,
        squares_turned: false,
    };
    assert!(close(small.square_center(Square::A1), Vector3::new(0.1 - 0.175, 0.4 - 0.175, 0.02)));
}

#[test]
fn square_names_round_trip_and_bad_names_fail() {
    let board = BoardGeometry::default();
    for square in Square::ALL {
        assert_eq!(parse_square(&square.to_string()).unwrap(), square);
        let (found, offset) = board.square_at(&board.square_center(square)).unwrap();
        assert_eq!(found, square);
        assert!(offset.norm() < 1e-12);
    }
    let (found, offset) = board.square_at(&Vector3::new(-0.03 + 0.02, 0.30 - 0.01, 0.0)).unwrap();
    assert_eq!(found, Square::D4);
    assert!((offset - Vector2::new(0.02, -0.01)).norm() < 1e-12);
    assert!(board.square_at(&Vector3::new(0.0, 0.05, 0.0)).is_none());
    for bad in ["i1", "d9", "", "e44", "4e"] {
        let error = parse_square(bad).unwrap_err();
        assert!(error.to_string().contains(&format!("'{bad}'")), "{error}");
    }
    let bad = BoardGeometry { square_size: -0.06, ..BoardGeometry::default() }.validated().unwrap_err();
    assert!(bad.to_string().contains("square_size = -0.06"));
}

#[test]
fn fk_of_ik_hits_every_square_at_grip_and_clearance_height() {
    let model = report_arm();
    let board = BoardGeometry::default();
    for square in Square::ALL {
        for height in [0.05, 0.15] {
            let target = board.above(square, height);
            let q = inverse_kinematics(&model, &target, TOOL_DOWN)
                .unwrap_or_else(|e| panic!("{square} at {height} m: {e}"));
            let reached = tool_point(&model, &q);
            assert!((reached.xyz() - target).norm() < 1e-9, "{square} at {height} m");
            assert!((reached.w - TOOL_DOWN).abs() < 1e-12);
        }
    }
}

#[test]
fn queens_gambit_matches_the_report() {
    let board = BoardGeometry::default();
    let scenario = queens_gambit(&board);
    let path = scenario.path(&board).unwrap();
    assert!((path.duration() - 13.0).abs() < 1e-12);
    assert!((path.start() - Vector3::new(0.21, 0.0, 0.0)).norm() < 1e-12);
    let expected = [
        (0.0, Vector3::new(0.21, 0.0, 0.0)),
        (1.0, Vector3::new(0.21, 0.0, 0.15)),
        (4.5, Vector3::new(-0.03, 0.18, 0.15)),
        (6.0, Vector3::new(-0.03, 0.18, 0.05)),
        (7.5, Vector3::new(-0.03, 0.18, 0.15)),
        (10.0, Vector3::new(-0.03, 0.30, 0.15)),
        (11.5, Vector3::new(-0.03, 0.30, 0.05)),
        (13.0, Vector3::new(-0.03, 0.30, 0.15)),
    ];
    let waypoints = path.waypoints();
    assert_eq!(waypoints.len(), expected.len());
    for ((t, p), (t_expected, p_expected)) in waypoints.iter().zip(expected) {
        assert!((t - t_expected).abs() < 1e-12, "{t} vs {t_expected}");
        assert!((p - p_expected).norm() < 1e-12);
        assert!((path.sample(*t).position - p_expected).norm() < 1e-12);
    }
    let events: Vec<_> = path.events().iter().map(|e| (e.action, e.time)).collect();
    assert_eq!(events, vec![(GripperAction::Grip, 6.0), (GripperAction::Release, 11.5)]);
    assert!(scenario_lookup_is_consistent(&board));
}

fn scenario_lookup_is_consistent(board: &BoardGeometry) -> bool {
    scenario("queens-gambit", board) == Some(queens_gambit(board)) && scenario("sicilian", board).is_none()
}

#[test]
fn scenario_joint_path_traces_the_tip_path() {
    let model = report_arm();
    let board = BoardGeometry::default();
    let path = queens_gambit(&board).path(&board).unwrap();
    let trajectory = JointTrajectory::from_path(&model, &path, 0.005).unwrap();
    assert_eq!(trajectory.samples().len(), 2601);
    for sample in trajectory.samples() {
        let tip = tool_point(&model, &sample.q);
        assert!((tip.xyz() - path.sample(sample.t).position).norm() < 1e-9, "t = {}", sample.t);
        assert!(sample.q.iter().chain(sample.qd.iter()).chain(sample.qdd.iter()).all(|v| v.is_finite()));
    }
    // The report's joint accelerations were 200× too small (ERRATA 5): ours are rad/s² of the
    // right size, a few rad/s² at most for this slow move.
    let peak_acceleration = trajectory.samples().iter().map(|s| s.qdd.amax()).fold(0.0, f64::max);
    assert!(peak_acceleration > 0.1 && peak_acceleration < 20.0, "{peak_acceleration}");
}

/// Squares turned half a turn on the table: each square stands where its point-mirror through
/// the board's centre stood (a1 where h8 was), the square under a point is found back, the
/// slots and the home point stay, and the arm serves the turned board, its columns checked,
/// exactly when it serves the board unturned, at the same pitch.
#[test]
fn turned_squares_are_the_same_points_and_served_alike() {
    use chessarm_chess::pieces::PieceSet;
    use chessarm_chess::reach::check_table;
    use chessarm_chess::table::{Location, Table};
    use chessarm_chess::tasks::{MotionLimits, home_tool};
    use chessarm_core::arm::preset::report_arm;
    let arm = report_arm();
    let limits = MotionLimits::default();
    let pieces = PieceSet::default();
    for board in [
        BoardGeometry::default(),
        BoardGeometry { yaw: 0.3, center: Vector2::new(0.05, 0.35), ..BoardGeometry::default() },
        // Too far: not served, turned or not.
        BoardGeometry { center: Vector2::new(0.0, 0.6), ..BoardGeometry::default() },
    ] {
        let turned = BoardGeometry { squares_turned: true, ..board };
        let empty = chessarm_chess::shakmaty::Board::empty();
        for square in Square::ALL {
            let mirror = Square::from_coords(
                chessarm_chess::shakmaty::File::new(7 - u32::from(square.file())),
                chessarm_chess::shakmaty::Rank::new(7 - u32::from(square.rank())),
            );
            assert!((turned.square_center(square) - board.square_center(mirror)).norm() < 1e-12, "{square}");
            let (found, offset) = turned.square_at(&turned.above(square, 0.01)).expect("on the board");
            assert_eq!(found, square);
            assert!(offset.norm() < 1e-12);
        }
        let (table, turned_table) = (Table::new(board, &empty), Table::new(turned, &empty));
        for slot in Location::off_board() {
            assert_eq!(table.nominal_position(slot), turned_table.nominal_position(slot), "{slot}");
        }
        assert_eq!(home_tool(&board, &pieces, &limits), home_tool(&turned, &pieces, &limits));
        let columns = chessarm_chess::clearance::moves::ClearanceCheck::default();
        let served = check_table(&arm, &board, &pieces, &limits, Some(&columns));
        let served_turned = check_table(&arm, &turned, &pieces, &limits, Some(&columns));
        assert_eq!(served.is_ok(), served_turned.is_ok(), "{served:?} / {served_turned:?}");
        if let (Ok(pitch), Ok(turned_pitch)) = (&served, &served_turned) {
            assert_eq!(pitch, turned_pitch);
        }
    }
}
