//! Whole pipeline: chess move → tasks → path → simulated arm → pieces where the tool let go →
//! physical board equal to the rules' board.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

use chessarm_chess::board::BoardGeometry;
use chessarm_chess::motion::TimingMode;
use chessarm_chess::notation::{parse_fen, parse_pgn};
use chessarm_chess::play::{Game, Mover, PlaySettings, gripper_events};
use chessarm_chess::shakmaty::Role;
use chessarm_chess::shakmaty::uci::UciMove;
use chessarm_chess::tasks::MoveKind;
use chessarm_core::arm::preset::report_arm;
use chessarm_core::control::choice::ControllerKind;
use chessarm_core::control::gains::{Gains, REPORT_PD};
use chessarm_core::plan::fine_point::InPosition;
use chessarm_core::sim::Told;

fn settings() -> PlaySettings {
    let mut settings = PlaySettings::new("pd", Gains::uniform(REPORT_PD.0, REPORT_PD.1, 0.0).unwrap());
    settings.record_every = 0;
    settings
}

fn play_one(fen: &str, uci: &str, expected: MoveKind) {
    let position = parse_fen(fen).unwrap();
    let mv = uci.parse::<UciMove>().unwrap().to_move(&position).unwrap();
    let mut game = Game::new(report_arm(), BoardGeometry::default(), position, settings()).unwrap();
    let report = game.play(&mv, Mover::Robot).unwrap();
    assert_eq!(report.kind, expected, "{uci} in {fen}");
    assert_eq!(game.fen_physical(), game.fen_rules(), "{uci} in {fen}: {:?}", game.misplaced());
    assert!(game.misplaced().is_empty(), "{uci}: {:?}", game.misplaced());
    assert!(report.duration > 1.0);
    // The exact model carries no payload knowledge, and the time-optimal motion stops hard on
    // the release point: the pieces still land within half the 5 mm tolerance (measured worst
    // over these cases 1.3 mm; with the report's LSPB timing 0.1 mm).
    for error in &report.place_errors {
        assert!(*error < 0.0025, "{uci}: placed {error} m off");
    }
    let tasks = match expected {
        MoveKind::Quiet => 1,
        MoveKind::Capture | MoveKind::EnPassant | MoveKind::CastleKingside | MoveKind::CastleQueenside => 2,
        MoveKind::Promotion => 2,
        MoveKind::PromotionCapture => 3,
    };
    assert_eq!(report.tasks.len(), tasks, "{uci}: {:?}", report.tasks);
}

#[test]
fn every_kind_of_move_for_both_colours_ends_with_the_physical_board_equal_to_the_rules() {
    let cases = [
        ("rnbqkbnr/pppppppp/8/8/8/8/PPPPPPPP/RNBQKBNR w KQkq - 0 1", "g1f3", MoveKind::Quiet),
        ("rnbqkbnr/pppppppp/8/8/4P3/8/PPPP1PPP/RNBQKBNR b KQkq - 0 1", "e7e5", MoveKind::Quiet),
        ("rnbqkbnr/ppp1pppp/8/3p4/4P3/8/PPPP1PPP/RNBQKBNR w KQkq - 0 2", "e4d5", MoveKind::Capture),
        ("rnbqkbnr/ppp1pppp/8/3p4/4P3/2N5/PPPP1PPP/R1BQKBNR b KQkq - 1 2", "d5e4", MoveKind::Capture),
        ("rnbqkbnr/ppp1p1pp/8/3pPp2/8/8/PPPP1PPP/RNBQKBNR w KQkq f6 0 3", "e5f6", MoveKind::EnPassant),
        ("rnbqkbnr/pppp1ppp/8/8/3Pp3/5N2/PPP1PPPP/RNBQKB1R b KQkq d3 0 3", "e4d3", MoveKind::EnPassant),
        ("r3k2r/pppq1ppp/2npbn2/4p3/4P3/2NPBN2/PPPQ1PPP/R3K2R w KQkq - 0 8", "e1g1", MoveKind::CastleKingside),
        ("r3k2r/pppq1ppp/2npbn2/4p3/4P3/2NPBN2/PPPQ1PPP/R3K2R w KQkq - 0 8", "e1c1", MoveKind::CastleQueenside),
        ("r3k2r/pppq1ppp/2npbn2/4p3/4P3/2NPBN2/PPPQ1PPP/R3K2R b KQkq - 0 8", "e8g8", MoveKind::CastleKingside),
        ("r3k2r/pppq1ppp/2npbn2/4p3/4P3/2NPBN2/PPPQ1PPP/R3K2R b KQkq - 0 8", "e8c8", MoveKind::CastleQueenside),
        ("8/1P5k/8/8/8/8/6K1/8 w - - 0 1", "b7b8q", MoveKind::Promotion),
        ("8/1P5k/8/8/8/8/6K1/8 w - - 0 1", "b7b8n", MoveKind::Promotion),
        ("2r4k/1P6/8/8/8/8/6K1/8 w - - 0 1", "b7c8q", MoveKind::PromotionCapture),
        ("8/6k1/8/8/8/8/1p5K/8 b - - 0 1", "b2b1q", MoveKind::Promotion),
        ("8/6k1/8/8/8/8/1p5K/8 b - - 0 1", "b2b1n", MoveKind::Promotion),
        ("8/6k1/8/8/8/8/1p5K/2R5 b - - 0 1", "b2c1r", MoveKind::PromotionCapture),
    ];
    for (fen, uci, kind) in cases {
        play_one(fen, uci, kind);
    }
}

#[test]
fn a_master_game_plays_through_with_every_piece_on_its_square() {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/opera_game.pgn")).unwrap();
    let record = parse_pgn(&text).unwrap().remove(0);
    // With the controller not told the pieces' masses, the report's LSPB timing places every
    // piece within 1 mm and the time-optimal timing, which stops hard on the release point,
    // within the 5 mm tolerance (measured worst 2.6 mm) in half the robot time or less; the
    // adaptive controller, which learns the mass, places within 0.5 mm at the optimal pace
    // (measured 0.14 mm on Kasparov–Topalov).
    let mut robot_times = Vec::new();
    let adaptive = |mut s: PlaySettings| {
        s.controller.kind = ControllerKind::Adaptive;
        s
    };
    for (timing, settings, tolerance) in [
        (TimingMode::Lspb, settings(), 0.001),
        (TimingMode::Optimal, settings(), 0.005),
        (TimingMode::Optimal, adaptive(settings()), 0.0005),
    ] {
        let settings = PlaySettings { timing, ..settings };
        let mut game = Game::new(report_arm(), BoardGeometry::default(), record.start.clone(), settings).unwrap();
        let mut worst = 0.0f64;
        for (ply, mv) in record.moves.iter().enumerate() {
            let report = game.play(mv, Mover::Robot).unwrap();
            assert!(report.new_misplaced.is_empty(), "ply {}: {:?}", ply + 1, report.new_misplaced);
            assert_eq!(report.summary.as_ref().unwrap().saturated_samples, 0, "{timing:?} ply {}", ply + 1);
            worst = report.place_errors.iter().fold(worst, |a, b| a.max(*b));
        }
        assert_eq!(game.fen_physical(), game.fen_rules());
        assert_eq!(
            game.fen_rules(),
            chessarm_chess::shakmaty::fen::Fen::from_position(
                &record.final_position(),
                chessarm_chess::shakmaty::EnPassantMode::Legal
            )
            .to_string()
        );
        assert!(worst < tolerance, "{timing:?}: worst placement {worst} m");
        robot_times.push(game.robot_time());
    }
    assert!(robot_times[0] > 60.0, "{robot_times:?}");
    assert!(robot_times[1] < 0.5 * robot_times[0], "{robot_times:?}");
    // (The two optimal games differ a little: each picks the pieces where its arm put them.)
    assert!((robot_times[1] - robot_times[2]).abs() < 0.01 * robot_times[1], "{robot_times:?}");
}

#[test]
fn a_sloppy_controller_misplaces_pieces_and_the_check_names_the_move() {
    // Gains far too soft for the speed: the arm lags by centimetres and sags under a knight it
    // is not told of; with the gripper going by the clock, it drops pieces off-centre.
    let mut settings = settings();
    settings.controller.gains = Gains::uniform(4.0, 1.0, 0.0).unwrap();
    settings.in_position = None;
    settings.payload_feedforward = false;
    let position = parse_fen("rnbqkbnr/pppppppp/8/8/8/8/PPPPPPPP/RNBQKBNR w KQkq - 0 1").unwrap();
    let mut game = Game::new(report_arm(), BoardGeometry::default(), position, settings).unwrap();
    let mv = "g1f3".parse::<UciMove>().unwrap().to_move(game.position()).unwrap();
    let report = game.play(&mv, Mover::Robot).unwrap();
    assert!(report.place_errors[0] > 0.005, "{:?}", report.place_errors);
    assert!(!report.new_misplaced.is_empty());
    assert!(report.waits.is_empty());
    assert_eq!(game.misplaced()[0].1, "Nf3");
}

#[test]
fn at_fine_points_a_sloppy_controller_waits_and_places_within_the_band() {
    // The same soft gains, the gripper waiting at its fine points (the default): it closes and
    // opens only once the arm is within the band, so the knight lands within band + band of its
    // square (the grip's offset carried, the release's added).
    let mut settings = settings();
    settings.controller.gains = Gains::uniform(4.0, 1.0, 0.0).unwrap();
    let gate = InPosition { timeout: 10.0, ..InPosition::for_tolerance(0.005) };
    settings.in_position = Some(gate);
    let position = parse_fen("rnbqkbnr/pppppppp/8/8/8/8/PPPPPPPP/RNBQKBNR w KQkq - 0 1").unwrap();
    let mut game = Game::new(report_arm(), BoardGeometry::default(), position, settings).unwrap();
    let mv = "g1f3".parse::<UciMove>().unwrap().to_move(game.position()).unwrap();
    let report = game.play(&mv, Mover::Robot).unwrap();
    assert_eq!(report.waits.len(), 2);
    assert!(report.waits.iter().all(|w| w.duration > 0.1 && !w.timed_out), "{:?}", report.waits);
    assert!(report.place_errors[0] <= 2.0 * gate.tip_band, "{:?}", report.place_errors);
    assert!(report.new_misplaced.is_empty());
    // The move took its plan plus its waits, and the handling times are when the gripper went.
    let totals = report.wait_totals();
    assert!((report.duration - (report.planned_duration + totals.total)).abs() < 2e-3, "{report:?}");
    let handled = report.handled[0];
    let went = |k: usize| report.start_time + report.waits[k].reached + report.waits[k].duration;
    assert!((handled.grip_time - went(0)).abs() < 1e-12 && (handled.release_time - went(1)).abs() < 1e-12);
    // A wait that cannot end gives up at its timeout, and says so.
    let mut settings = self::settings();
    settings.controller.gains = Gains::uniform(4.0, 1.0, 0.0).unwrap();
    settings.in_position = Some(InPosition { tip_band: 1e-9, speed_band: 1e-9, timeout: 0.25 });
    let position = parse_fen("rnbqkbnr/pppppppp/8/8/8/8/PPPPPPPP/RNBQKBNR w KQkq - 0 1").unwrap();
    let mut game = Game::new(report_arm(), BoardGeometry::default(), position, settings).unwrap();
    let report = game.play(&mv, Mover::Robot).unwrap();
    let totals = report.wait_totals();
    assert_eq!((totals.count, totals.timed_out), (2, 2), "{:?}", report.waits);
    assert!((totals.longest - 0.25).abs() < 1e-9);
}

#[test]
fn the_controller_is_told_the_nominal_mass_of_the_piece_kind_it_grips() {
    let position = parse_fen("rnbqkbnr/pppppppp/8/8/8/8/PPPPPPPP/RNBQKBNR w KQkq - 0 1").unwrap();
    let mut settings = settings();
    // The true pieces weigh 1.7 times the setup's nominal ones.
    let mut heavy = settings.pieces;
    for role in chessarm_chess::shakmaty::Role::ALL {
        heavy.dimensions_mut(role).mass *= 1.7;
    }
    settings.true_pieces = Some(heavy);
    let table = chessarm_chess::table::Table::from_position(BoardGeometry::default(), &position);
    for (uci, role) in [("g1f3", Role::Knight), ("e2e4", Role::Pawn)] {
        let mv = uci.parse::<UciMove>().unwrap().to_move(&position).unwrap();
        let plan = chessarm_chess::motion::plan_move(
            chessarm_chess::play::home_tool(&BoardGeometry::default(), &settings.pieces, &settings.limits),
            &position,
            &mv,
            &table,
            &settings.pieces,
            &settings.limits,
            &report_arm(),
            settings.timing,
            settings.control_period,
        )
        .unwrap();
        let told_mass = |settings: &PlaySettings| {
            let events = gripper_events(settings, &report_arm(), &table, &plan.tasks);
            assert_eq!(events[0].payload.unwrap().inertial.mass, heavy.dimensions(role).mass);
            assert_eq!(events[1].payload, None);
            match (events[0].told, events[1].told) {
                (Told::Payload(Some(p)), Told::Payload(None)) => Some(p.inertial.mass),
                (Told::Nothing, Told::Nothing) => None,
                other => panic!("{other:?}"),
            }
        };
        // By default: the setup's nominal mass of the kind.
        assert_eq!(told_mass(&settings), Some(settings.pieces.dimensions(role).mass), "{uci}");
        let mut knows = settings.clone();
        knows.controller_knows_payload = true;
        assert_eq!(told_mass(&knows), Some(heavy.dimensions(role).mass), "{uci}");
        let mut blind = settings.clone();
        blind.payload_feedforward = false;
        assert_eq!(told_mass(&blind), None, "{uci}");
    }
}

#[test]
fn the_opponent_hand_places_exactly() {
    let position = parse_fen("rnbqkbnr/pppppppp/8/8/4P3/8/PPPP1PPP/RNBQKBNR b KQkq - 0 1").unwrap();
    let mut game = Game::new(report_arm(), BoardGeometry::default(), position, settings()).unwrap();
    let mv = "d7d5".parse::<UciMove>().unwrap().to_move(game.position()).unwrap();
    let report = game.play(&mv, Mover::Opponent).unwrap();
    assert_eq!(report.duration, 0.0);
    assert_eq!(report.place_errors, vec![0.0]);
    assert_eq!(game.fen_physical(), game.fen_rules());
}
