//! Chess moves to pick-and-place tasks and tool-tip paths: every kind of move for both
//! colours, promotions from the graveyard and the reserve, traverse clearance, reach of the
//! off-board zones, and the table's verification.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

use chessarm_chess::board::BoardGeometry;
use chessarm_chess::pieces::{PieceError, PieceSet};
use chessarm_chess::shakmaty::fen::Fen;
use chessarm_chess::shakmaty::uci::UciMove;
use chessarm_chess::shakmaty::{Board, CastlingMode, Chess, Color, Move, Position, Role, Square};
use chessarm_chess::table::{GRAVEYARD_SLOTS, Location, RESERVE_ROLES, Table, TableError};
use chessarm_chess::tasks::{
    MotionLimits, MoveKind, Task, TaskError, append_move_path, append_task_path, classify, move_tasks,
};
use chessarm_core::arm::preset::report_arm;
use chessarm_core::arm::task::{TOOL_DOWN, inverse_kinematics};
use chessarm_core::nalgebra::{Vector2, Vector3};
use chessarm_core::plan::path::{CartesianPath, GripperAction, Segment};

use Color::{Black, White};

fn position(fen: &str) -> Chess {
    fen.parse::<Fen>().unwrap().into_position(CastlingMode::Standard).unwrap()
}

fn parse_move(position: &Chess, uci: &str) -> Move {
    uci.parse::<UciMove>().unwrap().to_move(position).unwrap()
}

/// The report's start: below file h's x at the base line, on the table.
fn start_point() -> Vector3<f64> {
    Vector3::new(0.21, 0.0, 0.0)
}

fn sq(square: Square) -> Location {
    Location::Square(square)
}

fn grave(color: Color, slot: usize) -> Location {
    Location::Graveyard { color, slot }
}

fn reserve(color: Color, slot: usize) -> Location {
    Location::Reserve { color, slot }
}

fn table_for(position: &Chess) -> Table {
    Table::from_position(BoardGeometry::default(), position)
}

/// Applies tasks with perfect placement.
fn apply(table: &mut Table, tasks: &[Task]) {
    for task in tasks {
        let actual = table.nominal_position(task.to);
        table.relocate(task.from, task.to, actual).unwrap();
    }
}

/// Checks the move's kind, plans its path with the report's arm, applies its tasks with
/// perfect placement and checks the table against the rules afterwards. Returns the tasks and
/// the position after the move.
fn play_and_check(table: &mut Table, position: &Chess, uci: &str, kind: MoveKind) -> (Vec<Task>, Chess) {
    let mv = parse_move(position, uci);
    assert_eq!(classify(position, &mv), kind, "{uci}");
    let tasks = move_tasks(position, &mv, table).unwrap();

    let arm = report_arm();
    let mut path = CartesianPath::new(start_point());
    let planned =
        append_move_path(&mut path, position, &mv, table, &PieceSet::default(), &MotionLimits::default(), &arm)
            .unwrap();
    assert_eq!(planned.iter().map(|p| p.task).collect::<Vec<_>>(), tasks);
    assert_eq!(path.events().len(), 2 * tasks.len());
    for (k, p) in planned.iter().enumerate() {
        let (grip, release) = (&path.events()[2 * k], &path.events()[2 * k + 1]);
        assert_eq!((grip.action, release.action), (GripperAction::Grip, GripperAction::Release));
        assert_eq!((grip.time, release.time), (p.plan.grip_time, p.plan.release_time));
        assert!(p.plan.grip_time < p.plan.release_time);
        assert!((release.position - p.plan.release_point).norm() < 1e-12);
    }
    for (_, point) in path.waypoints().iter().skip(1) {
        inverse_kinematics(&arm, point, TOOL_DOWN).unwrap();
    }

    apply(table, &tasks);
    let after = position.clone().play(mv).unwrap();
    let (board, standing) = table.snapped_board();
    assert_eq!(&board, after.board(), "{uci}: the table's board differs from the rules'");
    assert_eq!(standing.len(), after.board().occupied().count());
    let misplaced = table.verify(after.board(), 0.001);
    assert!(misplaced.is_empty(), "{uci}: {misplaced:?}");
    (tasks, after)
}

#[test]
fn move_kind_names() {
    let kinds = [
        MoveKind::Quiet,
        MoveKind::Capture,
        MoveKind::EnPassant,
        MoveKind::CastleKingside,
        MoveKind::CastleQueenside,
        MoveKind::Promotion,
        MoveKind::PromotionCapture,
    ];
    assert_eq!(
        kinds.map(|k| k.name()),
        ["quiet", "capture", "en-passant", "castle-kingside", "castle-queenside", "promotion", "promotion-capture"]
    );
}

#[test]
fn quiet_moves_both_colours() {
    let start = Chess::default();
    let mut table = table_for(&start);
    let (tasks, after) = play_and_check(&mut table, &start, "e2e4", MoveKind::Quiet);
    assert_eq!(tasks, [Task { piece: White.pawn(), from: sq(Square::E2), to: sq(Square::E4) }]);
    let (tasks, _) = play_and_check(&mut table, &after, "g8f6", MoveKind::Quiet);
    assert_eq!(tasks, [Task { piece: Black.knight(), from: sq(Square::G8), to: sq(Square::F6) }]);
    // Nothing went to the graveyards; the reserves are full.
    assert_eq!(table.free_graveyard_slot(White).unwrap(), 0);
    assert_eq!(table.free_graveyard_slot(Black).unwrap(), 0);
    assert_eq!(table.reserve_slot_holding(White.queen()), Some(0));
    assert_eq!(table.reserve_slot_holding(Black.knight()), Some(3));
    assert_eq!(table.pieces().len(), 32 + 2 * RESERVE_ROLES.len());
}

#[test]
fn captures_both_colours() {
    let white = position("rnbqkbnr/ppp1pppp/8/3p4/4P3/8/PPPP1PPP/RNBQKBNR w KQkq - 0 2");
    let mut table = table_for(&white);
    let (tasks, _) = play_and_check(&mut table, &white, "e4d5", MoveKind::Capture);
    assert_eq!(
        tasks,
        [
            Task { piece: Black.pawn(), from: sq(Square::D5), to: grave(Black, 0) },
            Task { piece: White.pawn(), from: sq(Square::E4), to: sq(Square::D5) },
        ]
    );
    assert_eq!(table.piece_at(grave(Black, 0)).unwrap().piece, Black.pawn());

    let black = position("rnbqkbnr/ppp1pppp/8/3p4/4P3/8/PPPP1PPP/RNBQKBNR b KQkq - 0 2");
    let mut table = table_for(&black);
    let (tasks, _) = play_and_check(&mut table, &black, "d5e4", MoveKind::Capture);
    assert_eq!(
        tasks,
        [
            Task { piece: White.pawn(), from: sq(Square::E4), to: grave(White, 0) },
            Task { piece: Black.pawn(), from: sq(Square::D5), to: sq(Square::E4) },
        ]
    );
}

#[test]
fn a_line_with_several_captures_fills_the_graveyards_in_order() {
    // 1. e4 d5 2. exd5 Qxd5 3. Nc3 Qxa2 4. Rxa2
    let line = [
        ("e2e4", MoveKind::Quiet),
        ("d7d5", MoveKind::Quiet),
        ("e4d5", MoveKind::Capture),
        ("d8d5", MoveKind::Capture),
        ("b1c3", MoveKind::Quiet),
        ("d5a2", MoveKind::Capture),
        ("a1a2", MoveKind::Capture),
    ];
    let mut chess = Chess::default();
    let mut table = table_for(&chess);
    for (uci, kind) in line {
        chess = play_and_check(&mut table, &chess, uci, kind).1;
    }
    assert_eq!(table.piece_at(grave(Black, 0)).unwrap().piece, Black.pawn());
    assert_eq!(table.piece_at(grave(Black, 1)).unwrap().piece, Black.queen());
    assert_eq!(table.piece_at(grave(White, 0)).unwrap().piece, White.pawn());
    assert_eq!(table.piece_at(grave(White, 1)).unwrap().piece, White.pawn());
    assert_eq!(table.graveyard_slot_holding(Black.queen()), Some(1));
    assert_eq!(table.free_graveyard_slot(White).unwrap(), 2);
}

#[test]
fn en_passant_both_colours() {
    let white = position("4k3/8/8/3pP3/8/8/8/4K3 w - d6 0 2");
    let mut table = table_for(&white);
    let (tasks, _) = play_and_check(&mut table, &white, "e5d6", MoveKind::EnPassant);
    assert_eq!(
        tasks,
        [
            // The taken pawn stands on d5, not on the destination d6.
            Task { piece: Black.pawn(), from: sq(Square::D5), to: grave(Black, 0) },
            Task { piece: White.pawn(), from: sq(Square::E5), to: sq(Square::D6) },
        ]
    );

    let black = position("4k3/8/8/8/3Pp3/8/8/4K3 b - d3 0 2");
    let mut table = table_for(&black);
    let (tasks, _) = play_and_check(&mut table, &black, "e4d3", MoveKind::EnPassant);
    assert_eq!(
        tasks,
        [
            Task { piece: White.pawn(), from: sq(Square::D4), to: grave(White, 0) },
            Task { piece: Black.pawn(), from: sq(Square::E4), to: sq(Square::D3) },
        ]
    );
}

#[test]
fn castling_both_sides_both_colours() {
    let cases = [
        (
            "r3k2r/8/8/8/8/8/8/R3K2R w KQkq - 0 1",
            "e1g1",
            MoveKind::CastleKingside,
            [Square::E1, Square::G1, Square::H1, Square::F1],
        ),
        (
            "r3k2r/8/8/8/8/8/8/R3K2R w KQkq - 0 1",
            "e1c1",
            MoveKind::CastleQueenside,
            [Square::E1, Square::C1, Square::A1, Square::D1],
        ),
        (
            "r3k2r/8/8/8/8/8/8/R3K2R b KQkq - 0 1",
            "e8g8",
            MoveKind::CastleKingside,
            [Square::E8, Square::G8, Square::H8, Square::F8],
        ),
        (
            "r3k2r/8/8/8/8/8/8/R3K2R b KQkq - 0 1",
            "e8c8",
            MoveKind::CastleQueenside,
            [Square::E8, Square::C8, Square::A8, Square::D8],
        ),
    ];
    for (fen, uci, kind, [king_from, king_to, rook_from, rook_to]) in cases {
        let chess = position(fen);
        let color = chess.turn();
        let mv = parse_move(&chess, uci);
        // shakmaty writes castling as king takes rook.
        assert!(matches!(mv, Move::Castle { .. }), "{uci}");
        let mut table = table_for(&chess);
        let (tasks, _) = play_and_check(&mut table, &chess, uci, kind);
        assert_eq!(
            tasks,
            [
                Task { piece: color.king(), from: sq(king_from), to: sq(king_to) },
                Task { piece: color.rook(), from: sq(rook_from), to: sq(rook_to) },
            ],
            "{uci}"
        );
    }
}

#[test]
fn promotions_both_colours_from_the_reserve() {
    let cases = [
        ("4k3/P7/8/8/8/8/8/4K3 w - - 0 1", "a7a8q", Square::A7, Square::A8, Role::Queen, 0),
        ("4k3/P7/8/8/8/8/8/4K3 w - - 0 1", "a7a8n", Square::A7, Square::A8, Role::Knight, 3),
        ("4k3/8/8/8/8/8/p7/4K3 b - - 0 1", "a2a1q", Square::A2, Square::A1, Role::Queen, 0),
        ("4k3/8/8/8/8/8/p7/4K3 b - - 0 1", "a2a1n", Square::A2, Square::A1, Role::Knight, 3),
    ];
    for (fen, uci, from, to, role, reserve_slot) in cases {
        let chess = position(fen);
        let color = chess.turn();
        let mut table = table_for(&chess);
        let (tasks, _) = play_and_check(&mut table, &chess, uci, MoveKind::Promotion);
        assert_eq!(
            tasks,
            [
                Task { piece: color.pawn(), from: sq(from), to: grave(color, 0) },
                Task { piece: role.of(color), from: reserve(color, reserve_slot), to: sq(to) },
            ],
            "{uci}"
        );
        assert!(table.piece_at(reserve(color, reserve_slot)).is_none());
        // The spare came from that slot (a second spare queen may remain elsewhere).
        assert_ne!(table.reserve_slot_holding(role.of(color)), Some(reserve_slot));
        assert_eq!(table.piece_at(grave(color, 0)).unwrap().piece, color.pawn());
    }
}

#[test]
fn promotion_captures_both_colours() {
    let cases = [
        ("1r2k3/P7/8/8/8/8/8/4K3 w - - 0 1", "a7b8q", Square::A7, Square::B8, Role::Rook),
        ("4k3/8/8/8/8/8/p7/1R2K3 b - - 0 1", "a2b1q", Square::A2, Square::B1, Role::Rook),
    ];
    for (fen, uci, from, to, captured) in cases {
        let chess = position(fen);
        let (us, them) = (chess.turn(), chess.turn().other());
        let mut table = table_for(&chess);
        let (tasks, _) = play_and_check(&mut table, &chess, uci, MoveKind::PromotionCapture);
        assert_eq!(
            tasks,
            [
                Task { piece: captured.of(them), from: sq(to), to: grave(them, 0) },
                Task { piece: us.pawn(), from: sq(from), to: grave(us, 0) },
                Task { piece: us.queen(), from: reserve(us, 0), to: sq(to) },
            ],
            "{uci}"
        );
    }
}

/// A table for `fen` whose graveyard of the side to move already holds a queen (a queen
/// standing on `extra` when the table was set up, then carried to the graveyard).
fn table_with_queen_in_graveyard(chess: &Chess, extra: Square) -> Table {
    let color = chess.turn();
    let mut board = chess.board().clone();
    board.set_piece_at(extra, color.queen());
    let mut table = Table::new(BoardGeometry::default(), &board);
    let slot = table.free_graveyard_slot(color).unwrap();
    table.relocate(sq(extra), grave(color, slot), table.nominal_position(grave(color, slot))).unwrap();
    table
}

#[test]
fn promotion_takes_a_captured_queen_back_from_the_graveyard() {
    let cases = [
        ("4k3/P7/8/8/8/8/8/4K3 w - - 0 1", "a7a8q", MoveKind::Promotion, Square::A8),
        ("4k3/8/8/8/8/8/p7/4K3 b - - 0 1", "a2a1q", MoveKind::Promotion, Square::A1),
        ("1r2k3/P7/8/8/8/8/8/4K3 w - - 0 1", "a7b8q", MoveKind::PromotionCapture, Square::B8),
        ("4k3/8/8/8/8/8/p7/1R2K3 b - - 0 1", "a2b1q", MoveKind::PromotionCapture, Square::B1),
    ];
    for (fen, uci, kind, to) in cases {
        let chess = position(fen);
        let us = chess.turn();
        let mut table = table_with_queen_in_graveyard(&chess, Square::H4);
        assert_eq!(table.graveyard_slot_holding(us.queen()), Some(0));
        let (tasks, _) = play_and_check(&mut table, &chess, uci, kind);
        let n = tasks.len();
        // The pawn goes to the next free slot, the queen comes from slot 0, not from the reserve.
        assert_eq!(tasks[n - 2], Task { piece: us.pawn(), from: tasks[n - 2].from, to: grave(us, 1) }, "{uci}");
        assert_eq!(tasks[n - 1], Task { piece: us.queen(), from: grave(us, 0), to: sq(to) }, "{uci}");
        assert_eq!(table.reserve_slot_holding(us.queen()), Some(0), "{uci}: the reserve queen stays");
        assert!(table.piece_at(grave(us, 0)).is_none());
    }
}

#[test]
fn a_promotion_with_no_piece_left_names_the_move_and_the_piece() {
    // Two knight promotions: the first uses the reserve knight, the second has none.
    let chess = position("4k3/PP6/8/8/8/8/8/4K3 w - - 0 1");
    let mut table = table_for(&chess);
    let (_, chess) = play_and_check(&mut table, &chess, "a7a8n", MoveKind::Promotion);
    let (_, chess) = play_and_check(&mut table, &chess, "e8e7", MoveKind::Quiet);
    let mv = parse_move(&chess, "b7b8n");
    let error = move_tasks(&chess, &mv, &table).unwrap_err();
    assert!(matches!(error, TaskError::MissingPiece { .. }), "{error}");
    let message = error.to_string();
    assert!(message.contains("b8=N") && message.contains("b7b8n") && message.contains("white knight"), "{message}");
    // A queen is still available.
    play_and_check(&mut table, &chess, "b7b8q", MoveKind::Promotion);
}

#[test]
fn illegal_moves_and_mismatched_tables_are_refused() {
    let chess = Chess::default();
    let table = table_for(&chess);
    let illegal = Move::Normal { role: Role::Pawn, from: Square::E2, capture: None, to: Square::E5, promotion: None };
    let error = move_tasks(&chess, &illegal, &table).unwrap_err();
    assert!(error.to_string().contains("e2e5"), "{error}");
    // The table lost track of the e2 pawn.
    let mut table = table;
    table.relocate(sq(Square::E2), grave(White, 0), table.nominal_position(grave(White, 0))).unwrap();
    let error = move_tasks(&chess, &parse_move(&chess, "e2e4"), &table).unwrap_err();
    assert!(matches!(error, TaskError::TableMismatch { .. }), "{error}");
    assert!(error.to_string().contains("e4 (e2e4)"), "{error}");
}

#[test]
fn traverse_clears_the_king_it_passes_over() {
    // Nb1–d2 passes over c1, where the white king stands.
    let chess = position("4k3/8/8/8/8/8/8/1NK5 w - - 0 1");
    let table = table_for(&chess);
    let pieces = PieceSet::default();
    let limits = MotionLimits::default();
    let arm = report_arm();
    let task = Task { piece: White.knight(), from: sq(Square::B1), to: sq(Square::D2) };
    let mut path = CartesianPath::new(table.geometry().above(Square::B1, 0.1));
    let plan = append_task_path(&mut path, &task, &table, &pieces, &limits, &arm).unwrap();
    let needed = pieces.king.height + limits.clearance_margin + pieces.knight.grip_height;
    assert!(plan.traverse_height >= needed - 1e-12, "{} < {needed}", plan.traverse_height);
    // Every traverse of the path (a horizontal move) runs at the traverse height, and the
    // carried knight's base stays above the king's top by the margin.
    for segment in path.segments() {
        if let Segment::Move { from, to, .. } = segment
            && (from.xy() - to.xy()).norm() > 0.0
        {
            assert!((from.z - plan.traverse_height).abs() < 1e-12 && (to.z - plan.traverse_height).abs() < 1e-12);
            let knight_base = to.z - pieces.knight.grip_height;
            assert!(knight_base >= pieces.king.height + limits.clearance_margin - 1e-12);
        }
    }
    // Grip and release at the knight's grip height, above b1 and d2.
    let grip = table.geometry().above(Square::B1, pieces.knight.grip_height);
    let release = table.geometry().above(Square::D2, pieces.knight.grip_height);
    assert!((path.events()[0].position - grip).norm() < 1e-12);
    assert!((path.events()[1].position - release).norm() < 1e-12);
    assert!((plan.release_point - release).norm() < 1e-12);

    // Without the king in the way the traverse is lower: only the knight itself matters.
    let open = position("4k3/8/8/8/8/8/8/1N5K w - - 0 1");
    let mut path = CartesianPath::new(table.geometry().above(Square::B1, 0.1));
    let plan = append_task_path(&mut path, &task, &table_for(&open), &pieces, &limits, &arm).unwrap();
    let expected =
        (pieces.knight.height + limits.clearance_margin).max(limits.clearance_margin + pieces.knight.grip_height);
    assert!((plan.traverse_height - expected).abs() < 1e-12, "{}", plan.traverse_height);
}

#[test]
fn carrying_a_king_over_a_queen_and_the_empty_gripper_case() {
    let pieces = PieceSet::default();
    let limits = MotionLimits::default();
    let table = table_for(&position("4k3/8/8/8/8/8/8/2KQ4 w - - 0 1"));
    // Tallest under the king's path c1 → e1: the queen on d1 (the king itself left out).
    let from = table.nominal_position(sq(Square::C1));
    let to = table.nominal_position(sq(Square::E1));
    let radius = pieces.widest();
    assert_eq!(table.tallest_under(from, to, radius, &pieces, Some(sq(Square::C1))), pieces.queen.height);
    assert_eq!(table.tallest_under(from, to, radius, &pieces, None), pieces.king.height);
    let far = table.nominal_position(sq(Square::C4));
    assert_eq!(table.tallest_under(far, far + Vector2::new(0.06, 0.0), radius, &pieces, None), 0.0);
    let task = Task { piece: White.king(), from: sq(Square::C1), to: sq(Square::E1) };
    let mut path = CartesianPath::new(start_point());
    let plan = append_task_path(&mut path, &task, &table, &pieces, &limits, &report_arm()).unwrap();
    let loaded = pieces.queen.height + limits.clearance_margin + pieces.king.grip_height;
    assert!((plan.traverse_height - loaded).abs() < 1e-12);
}

#[test]
fn the_path_follows_the_reports_pattern_with_limited_timing() {
    let chess = Chess::default();
    let table = table_for(&chess);
    let pieces = PieceSet::default();
    let limits = MotionLimits::default();
    let task = Task { piece: White.pawn(), from: sq(Square::D2), to: sq(Square::D4) };
    let mut path = CartesianPath::new(start_point());
    let plan = append_task_path(&mut path, &task, &table, &pieces, &limits, &report_arm()).unwrap();
    let h = plan.traverse_height;
    let g = table.geometry();
    let grip = pieces.pawn.grip_height;
    assert_eq!(grip, 0.05, "the report's grip height");
    let expected = [
        start_point(),
        Vector3::new(start_point().x, start_point().y, h),
        g.above(Square::D2, h),
        g.above(Square::D2, grip),
        g.above(Square::D2, h),
        g.above(Square::D4, h),
        g.above(Square::D4, grip),
        g.above(Square::D4, h),
    ];
    let waypoints: Vec<_> = path.waypoints().into_iter().map(|(_, p)| p).collect();
    assert_eq!(waypoints.len(), expected.len());
    for (got, want) in waypoints.iter().zip(&expected) {
        assert!((got - want).norm() < 1e-12, "{got:?} vs {want:?}");
    }
    // Speeds and accelerations stay within the limits; vertical moves use the vertical limits.
    let samples = path.sample_uniform(0.002).unwrap();
    for s in &samples {
        let (horizontal, vertical) = (s.velocity.xy().norm(), s.velocity.z.abs());
        assert!(horizontal <= limits.traverse_speed + 1e-9 && vertical <= limits.vertical_speed + 1e-9, "{s:?}");
        assert!(s.acceleration.norm() <= limits.traverse_acceleration.max(limits.vertical_acceleration) + 1e-9);
    }
    // Gripper dwell after each event, pauses between moves.
    let pauses: Vec<f64> = path
        .segments()
        .iter()
        .filter_map(|s| if let Segment::Pause { duration, .. } = s { Some(*duration) } else { None })
        .collect();
    assert_eq!(pauses.iter().filter(|&&d| d == limits.grip_dwell).count(), 2);
    assert_eq!(pauses.iter().filter(|&&d| d == limits.pause).count(), 4);
    assert!(plan.grip_time > 0.0 && plan.release_time > plan.grip_time + limits.grip_dwell);
    // Slower limits give a longer path.
    let slow = MotionLimits { traverse_speed: 0.1, ..limits };
    let mut slow_path = CartesianPath::new(start_point());
    append_task_path(&mut slow_path, &task, &table, &pieces, &slow, &report_arm()).unwrap();
    assert!(slow_path.duration() > path.duration());
    // Bad limits are named.
    let bad = MotionLimits { vertical_speed: -1.0, ..limits };
    let error = append_task_path(&mut slow_path, &task, &table, &pieces, &bad, &report_arm()).unwrap_err();
    assert!(error.to_string().contains("vertical_speed = -1"), "{error}");
}

#[test]
fn graveyard_and_reserve_slots_are_reachable_by_the_report_arm() {
    let table = table_for(&Chess::default());
    let pieces = PieceSet::default();
    let limits = MotionLimits::default();
    let arm = report_arm();
    let highest = limits.highest_traverse(&pieces);
    assert!((highest - (0.095 + 0.03 + 0.076)).abs() < 1e-12);
    // Every location at every height and every traverse a game can ask for (reach.rs).
    chessarm_chess::reach::check_table(&arm, table.geometry(), &pieces, &limits, None).unwrap();
    // With 5 cm to spare in height (a 5 cm larger clearance margin).
    let higher = MotionLimits { clearance_margin: limits.clearance_margin + 0.05, ..limits };
    chessarm_chess::reach::check_table(&arm, table.geometry(), &pieces, &higher, None).unwrap();
    // Slots do not overlap each other or the board.
    let widest = pieces.widest();
    let slots: Vec<_> = Location::off_board().map(|l| table.nominal_position(l)).collect();
    assert_eq!(slots.len(), 2 * (GRAVEYARD_SLOTS + RESERVE_ROLES.len()));
    for (i, a) in slots.iter().enumerate() {
        for b in &slots[i + 1..] {
            assert!((a - b).norm() > widest, "{a:?} {b:?}");
        }
        // Each slot's widest piece stands clear of the board's edge.
        let g = table.geometry();
        let half = 4.0 * g.square_size;
        let dx = ((a.x - g.center.x).abs() - half).max(0.0);
        let dy = ((a.y - g.center.y).abs() - half).max(0.0);
        assert!(dx.hypot(dy) >= widest / 2.0, "{a:?} touches the board");
    }
    // The zones move with the board.
    let moved = BoardGeometry { center: Vector2::new(0.02, 0.31), ..BoardGeometry::default() };
    let moved_table = Table::new(moved, &Board::new());
    let shift = moved_table.nominal_position(grave(Black, 7)) - table.nominal_position(grave(Black, 7));
    assert!((shift - Vector2::new(0.02, -0.02)).norm() < 1e-12);
}

#[test]
fn a_board_out_of_reach_gives_errors_naming_the_move_and_the_slot() {
    let far = BoardGeometry { center: Vector2::new(0.0, 0.9), ..BoardGeometry::default() };
    let chess = Chess::default();
    let table = Table::from_position(far, &chess);
    let mv = parse_move(&chess, "e2e4");
    let mut path = CartesianPath::new(start_point());
    let before = path.clone();
    let error =
        append_move_path(&mut path, &chess, &mv, &table, &PieceSet::default(), &MotionLimits::default(), &report_arm())
            .unwrap_err();
    let message = error.to_string();
    assert!(message.contains("move e4 (e2e4)"), "{message}");
    assert!(message.contains("white pawn from e2 to e4") && message.contains("out of reach"), "{message}");
    assert_eq!(path, before, "a failed plan leaves the path unchanged");

    let error =
        chessarm_chess::reach::check_table(&report_arm(), &far, &PieceSet::default(), &MotionLimits::default(), None)
            .unwrap_err();
    // Out of reach straight down, and at every tilt within max_tilt.
    use chessarm_chess::reach::ReachError;
    let ReachError::AtEveryPitch { source, .. } = &error else { panic!("{error}") };
    assert!(matches!(**source, ReachError::Unreachable { .. }));
    assert!(error.to_string().contains("out of reach") && error.to_string().contains("max_tilt = 30°"), "{error}");
}

#[test]
fn verify_finds_off_centre_and_wrong_square_pieces() {
    let chess = Chess::default();
    let mut table = table_for(&chess);
    assert!(table.verify(chess.board(), 0.005).is_empty());

    // 6 mm off the centre of e2 with a 5 mm tolerance.
    let e2 = table.nominal_position(sq(Square::E2));
    table.relocate(sq(Square::E2), sq(Square::E2), e2 + Vector2::new(0.006, 0.0)).unwrap();
    let found = table.verify(chess.board(), 0.005);
    assert_eq!(found.len(), 1, "{found:?}");
    assert_eq!(found[0].square, Some(Square::E2));
    assert_eq!(found[0].piece, Some(White.pawn()));
    assert!((found[0].offset_m - 0.006).abs() < 1e-12);
    assert!(found[0].reason.contains("6.0 mm"), "{}", found[0].reason);
    // 4 mm is within tolerance; the snapped board is still right.
    table.relocate(sq(Square::E2), sq(Square::E2), e2 + Vector2::new(0.0, -0.004)).unwrap();
    assert!(table.verify(chess.board(), 0.005).is_empty());
    let (board, standing) = table.snapped_board();
    assert_eq!(&board, chess.board());
    let (_, _, offset) = standing.iter().find(|(s, _, _)| *s == Square::E2).unwrap();
    assert!((offset - Vector2::new(0.0, -0.004)).norm() < 1e-12);

    // Recorded on e2, but released over e3: wrong square (and e2 is empty).
    table.relocate(sq(Square::E2), sq(Square::E2), table.nominal_position(sq(Square::E3))).unwrap();
    let found = table.verify(chess.board(), 0.005);
    assert!(found.iter().any(|m| m.square == Some(Square::E3) && m.piece == Some(White.pawn())), "{found:?}");
    assert!(found.iter().any(|m| m.square == Some(Square::E2) && m.reason.contains("missing")), "{found:?}");
    let (board, _) = table.snapped_board();
    assert_eq!(board.piece_at(Square::E3), Some(White.pawn()));
    assert_eq!(board.piece_at(Square::E2), None);

    // Two pieces on one square; and a board piece knocked off the board.
    table.relocate(sq(Square::E2), sq(Square::E2), e2).unwrap();
    table.relocate(sq(Square::D2), sq(Square::D2), e2 + Vector2::new(0.01, 0.0)).unwrap();
    let found = table.verify(chess.board(), 0.005);
    assert!(found.iter().any(|m| m.reason.contains("2 pieces stand on e2")), "{found:?}");
    table.relocate(sq(Square::D2), sq(Square::D2), Vector2::new(0.0, 0.0)).unwrap();
    let found = table.verify(chess.board(), 0.005);
    assert!(found.iter().any(|m| m.square == Some(Square::D2) && m.reason.contains("off the board")), "{found:?}");
}

#[test]
fn table_operations_report_their_errors() {
    let mut table = table_for(&Chess::default());
    let here = table.nominal_position(sq(Square::E4));
    let error = table.relocate(sq(Square::E4), sq(Square::E5), here).unwrap_err();
    assert_eq!(error, TableError::Empty(sq(Square::E4)));
    assert_eq!(error.to_string(), "no piece stands at e4");
    let error = table.relocate(sq(Square::E2), sq(Square::E7), here).unwrap_err();
    assert!(error.to_string().contains("e7 is taken by a black pawn"), "{error}");
    let error = table.relocate(sq(Square::E2), grave(White, GRAVEYARD_SLOTS), here).unwrap_err();
    assert!(matches!(error, TableError::NoSuchSlot(_)), "{error}");
    let error = table.relocate(sq(Square::E2), sq(Square::E4), Vector2::new(f64::NAN, 0.0)).unwrap_err();
    assert!(matches!(error, TableError::Position { .. }), "{error}");
    // Fill white's graveyard.
    let whites: Vec<_> = table
        .pieces()
        .iter()
        .filter(|p| p.piece.color == White && matches!(p.location, Location::Square(_)))
        .map(|p| p.location)
        .collect();
    for location in whites {
        match table.free_graveyard_slot(White) {
            Ok(slot) => {
                table.relocate(location, grave(White, slot), table.nominal_position(grave(White, slot))).unwrap()
            }
            Err(error) => panic!("{error}"),
        }
    }
    assert_eq!(table.free_graveyard_slot(White), Err(TableError::GraveyardFull(White)));
    assert!(TableError::GraveyardFull(White).to_string().contains("white graveyard is full"));
}

#[test]
fn piece_set_defaults_and_validation() {
    let set = PieceSet::default().validated().unwrap();
    assert_eq!(set.tallest(), set.king.height);
    assert_eq!(set.dimensions(Role::Queen), &set.queen);
    assert_eq!((set.pawn.height, set.pawn.grip_height), (0.05, 0.05));
    for role in Role::ALL {
        let d = set.dimensions(role);
        assert!(d.base_diameter < 0.06 && d.grip_height <= d.height && d.grip_height > 0.0);
        // The payload is a cylinder of the piece's mass whose COM is half its height from its base.
        let payload = set.payload(role);
        assert_eq!(payload.inertial.mass, d.mass);
        assert!((payload.inertial.com.x - (d.grip_height - d.height / 2.0)).abs() < 1e-15);
    }
    let mut bad = PieceSet::default();
    bad.rook.grip_height = 0.07;
    let error = bad.validated().unwrap_err();
    assert!(matches!(error, PieceError::Dimension { role: "rook", field: "grip_height", .. }));
    assert!(error.to_string().contains("rook grip_height = 0.07"), "{error}");
    bad.rook.grip_height = 0.04;
    bad.king.mass = f64::NAN;
    assert!(bad.validated().unwrap_err().to_string().contains("king mass = NaN"));
}

#[test]
fn pseudo_random_games_keep_the_table_in_step_with_the_rules() {
    // Long deterministic games of random legal moves: every move's tasks, applied with perfect
    // placement, reproduce the rules' board, and every task's path is within the arm's reach.
    let arm = report_arm();
    let pieces = PieceSet::default();
    let limits = MotionLimits::default();
    let mut kinds = std::collections::HashSet::new();
    for seed in 1..=SEEDS {
        let mut chess = Chess::default();
        let mut table = table_for(&chess);
        let mut state: u64 = 0x2545_f491_4f6c_dd1d ^ seed;
        for _ in 0..300 {
            let moves = chess.legal_moves();
            if moves.is_empty() {
                break;
            }
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            // Castling and en passant are rare at random: take them whenever they are legal.
            let special = moves.iter().find(|m| matches!(m, Move::Castle { .. } | Move::EnPassant { .. }));
            let mv = special.copied().unwrap_or(moves[(state % moves.len() as u64) as usize]);
            let tasks = match move_tasks(&chess, &mv, &table) {
                Ok(tasks) => tasks,
                // A promotion with no such piece left: play another move.
                Err(TaskError::MissingPiece { .. }) => continue,
                Err(error) => panic!("{error}"),
            };
            kinds.insert(classify(&chess, &mv));
            let mut path = CartesianPath::new(start_point());
            append_move_path(&mut path, &chess, &mv, &table, &pieces, &limits, &arm).unwrap();
            apply(&mut table, &tasks);
            chess.play_unchecked(mv);
            assert_eq!(&table.snapped_board().0, chess.board());
            assert!(table.verify(chess.board(), 1e-9).is_empty());
        }
    }
    assert_eq!(kinds.len(), 7, "every kind of move was played: {kinds:?}");
}

/// Number of pseudo-random games.
const SEEDS: u64 = 20;
