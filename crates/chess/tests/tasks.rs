//! Chess moves to pick-and-place tasks and tool-tip paths: every kind of move for both
//! colours, promotions from the graveyard and the reserve, traverse clearance, reach of the
//! off-board zones, and the table's verification.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

use chessarm_chess::board::BoardGeometry;
use chessarm_chess::pieces::{PieceError, PieceSet};
use chessarm_chess::shakmaty::fen::Fen;
use chessarm_chess::shakmaty::uci::UciMove;
use chessarm_chess::shakmaty::{Board, CastlingMode, Chess, Color, Move, Piece, Position, Role, Square};
use chessarm_chess::table::{GRAVEYARD_SLOTS, Location, Table, TableError};
use chessarm_chess::tasks::{
    MotionLimits, MoveKind, Task, TaskError, append_move_path, append_task_path, classify, move_tasks,
};
use chessarm_core::arm::preset::report_arm;
use chessarm_core::arm::task::{TOOL_DOWN, inverse_kinematics};
use chessarm_core::nalgebra::{Vector2, Vector3};
use chessarm_core::plan::path::{CartesianPath, GripperAction};

fn position(fen: &str) -> Chess {
    fen.parse::<Fen>().unwrap().into_position(CastlingMode::Standard).unwrap()
}

fn parse_move(position: &Chess, uci: &str) -> Move {
    uci.parse::<UciMove>().unwrap().to_move(position).unwrap()
}

fn start_point() -> Vector3<f64> {
    // The report's start: below file h's x at the base line, on the table.
    Vector3::new(0.21, 0.0, 0.0)
}

/// Applies tasks with perfect placement.
fn apply(table: &mut Table, tasks: &[Task]) {
    for task in tasks {
        let actual = table.nominal_position(task.to);
        table.relocate(task.from, task.to, actual).unwrap();
    }
}

/// Plans the move's path with the report's arm, applies its tasks, checks the table against
/// the rules afterwards and returns the tasks.
fn play_and_check(table: &mut Table, position: &Chess, uci: &str, kind: MoveKind) -> (Vec<Task>, Chess) {
    let mv = parse_move(position, uci);
    assert_eq!(classify(position, &mv), kind, "{uci}");
    let tasks = move_tasks(position, &mv, table).unwrap();

    // The path: two gripper events per task, grip before release, every waypoint reachable.
    let arm = report_arm();
    let pieces = PieceSet::default();
    let limits = MotionLimits::default();
    let mut path = CartesianPath::new(start_point());
    let planned = append_move_path(&mut path, position, &mv, table, &pieces, &limits, &arm).unwrap();
    assert_eq!(planned.iter().map(|p| p.task).collect::<Vec<_>>(), tasks);
    assert_eq!(path.events().len(), 2 * tasks.len());
    for (k, p) in planned.iter().enumerate() {
        assert_eq!(path.events()[2 * k].action, GripperAction::Grip);
        assert_eq!(path.events()[2 * k + 1].action, GripperAction::Release);
        assert!(p.plan.grip_time < p.plan.release_time);
        assert_eq!(path.events()[2 * k + 1].time, p.plan.release_time);
        assert!((path.events()[2 * k + 1].position - p.plan.release_point).norm() < 1e-12);
    }
    for (_, point) in path.waypoints() {
        if point != start_point() {
            inverse_kinematics(&arm, &point, TOOL_DOWN).unwrap();
        }
    }

    apply(table, &tasks);
    let after = position.clone().play(mv).unwrap();
    let (board, standing) = table.snapped_board();
    assert_eq!(&board, after.board(), "{uci}: table board differs from the rules");
    assert_eq!(standing.len(), after.board().occupied().count());
    assert!(table.verify(after.board(), 0.001).is_empty(), "{uci}: {:?}", table.verify(after.board(), 0.001));
    (tasks, after)
}

fn sq(location: Square) -> Location {
    Location::Square(location)
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

#[test]
fn move_kind_names() {
    let names: Vec<_> = [
        MoveKind::Quiet,
        MoveKind::Capture,
        MoveKind::EnPassant,
        MoveKind::CastleKingside,
        MoveKind::CastleQueenside,
        MoveKind::Promotion,
        MoveKind::PromotionCapture,
    ]
    .iter()
    .map(MoveKind::name)
    .collect();
    assert_eq!(
        names,
        ["quiet", "capture", "en-passant", "castle-kingside", "castle-queenside", "promotion", "promotion-capture"]
    );
}

#[test]
fn quiet_moves_both_colours() {
    let start = Chess::default();
    let mut table = table_for(&start);
    let (tasks, after) = play_and_check(&mut table, &start, "e2e4", MoveKind::Quiet);
    assert_eq!(tasks, [Task { piece: Color::White.pawn(), from: sq(Square::E2), to: sq(Square::E4) }]);
    let (tasks, after) = play_and_check(&mut table, &after, "g8f6", MoveKind::Quiet);
    assert_eq!(tasks, [Task { piece: Color::Black.knight(), from: sq(Square::G8), to: sq(Square::F6) }]);
    // Nothing went to the graveyards, the reserves are full.
    assert_eq!(table.free_graveyard_slot(Color::White).unwrap(), 0);
    assert_eq!(table.free_graveyard_slot(Color::Black).unwrap(), 0);
    assert_eq!(table.reserve_slot_holding(Color::White.queen()), Some(0));
    assert_eq!(table.pieces().len(), 32 + 8);
    let _ = after;
}

#[test]
fn captures_both_colours() {
    let white = position("rnbqkbnr/ppp1pppp/8/3p4/4P3/8/PPPP1PPP/RNBQKBNR w KQkq - 0 2");
    let mut table = table_for(&white);
    let (tasks, _) = play_and_check(&mut table, &white, "e4d5", MoveKind::Capture);
    assert_eq!(
        tasks,
        [
            Task { piece: Color::Black.pawn(), from: sq(Square::D5), to: grave(Color::Black, 0) },
            Task { piece: Color::White.pawn(), from: sq(Square::E4), to: sq(Square::D5) },
        ]
    );
    assert_eq!(table.piece_at(grave(Color::Black, 0)).unwrap().piece, Color::Black.pawn());

    let black = position("rnbqkbnr/ppp1pppp/8/3p4/4P3/8/PPPP1PPP/RNBQKBNR b KQkq - 0 2");
    let mut table = table_for(&black);
    let (tasks, after) = play_and_check(&mut table, &black, "d5e4", MoveKind::Capture);
    assert_eq!(tasks[0], Task { piece: Color::White.pawn(), from: sq(Square::E4), to: grave(Color::White, 0) });
    assert_eq!(tasks[1], Task { piece: Color::Black.pawn(), from: sq(Square::D5), to: sq(Square::E4) });
    // A second capture fills the next slot: Nc3xe4.
    let after = after.play(parse_move(&after, "b1c3")).unwrap();
    apply(&mut table, &move_tasks(&black, &parse_move(&black, "d5e4"), &table_for(&black)).unwrap()[..0]);
    let mut table2 = table.clone();
    let knight_move = move_tasks(
        &position("rnbqkbnr/ppp1pppp/8/8/4p3/8/PPPP1PPP/RNBQKBNR w KQkq - 0 3"),
        &parse_move(&after, "b1c3"),
        &table2,
    );
    assert!(knight_move.is_err(), "b1c3 was already played in `after`, the FEN position differs");
    apply(&mut table2, &[Task { piece: Color::White.knight(), from: sq(Square::B1), to: sq(Square::C3) }]);
    let (tasks, _) = play_and_check(&mut table2, &after, "c6c5", MoveKind::Quiet).0.split_at(0).0.to_vec().pipe_quiet();
    let _ = tasks;
}

trait PipeQuiet {
    fn pipe_quiet(self) -> (Vec<Task>, ());
}

impl PipeQuiet for Vec<Task> {
    fn pipe_quiet(self) -> (Vec<Task>, ()) {
        (self, ())
    }
}
