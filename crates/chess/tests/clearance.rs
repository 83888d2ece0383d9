//! Constructed cases the clearance check must catch, and the games that place every piece with
//! room to spare (no contact reported on them).

use chessarm_chess::board::BoardGeometry;
use chessarm_chess::clearance::moves::square_for_fingers;
use chessarm_chess::notation::{parse_fen, parse_pgn};
use chessarm_chess::play::{Game, MoveReport, Mover, PlayError, PlaySettings};
use chessarm_chess::shakmaty::uci::UciMove;
use chessarm_core::arm::bodies::Part;
use chessarm_core::arm::preset::report_arm;
use chessarm_core::control::gains::{Gains, REPORT_PD};
use chessarm_core::nalgebra::Vector2;

const START: &str = "rnbqkbnr/pppppppp/8/8/8/8/PPPPPPPP/RNBQKBNR w KQkq - 0 1";

fn settings() -> PlaySettings {
    let mut settings =
        PlaySettings::new("pd", Gains::uniform(REPORT_PD.0, REPORT_PD.1, 0.0).expect("the report's gains"));
    settings.record_every = 0;
    settings
}

/// The report's board with squares of `size` m, rank 1 where it is.
fn board(size: f64) -> BoardGeometry {
    BoardGeometry { square_size: size, center: Vector2::new(0.0, 0.12 + 4.0 * size), ..BoardGeometry::default() }
}

/// Plays one move on `board` with the pre-flight's column check off: the planner's own
/// changes and refusals (the column check refuses these boards before any move, see
/// `the_pre_flight_refuses_a_board_whose_columns_are_crowded`).
fn play(board: BoardGeometry, fen: &str, uci: &str) -> Result<MoveReport, PlayError> {
    let position = parse_fen(fen).expect("a FEN");
    let mv = uci.parse::<UciMove>().expect("a UCI move").to_move(&position).expect("a legal move");
    let settings = PlaySettings { check_columns: false, ..settings() };
    Game::new(report_arm(), board, position, settings).expect("a served board").play(&mv, Mover::Robot)
}

/// The boards of the planner's refusals below are refused before the first move: with the
/// tallest, widest piece on every place around a square, the wrist (34 mm squares) or a
/// finger (36 mm) comes within the margin of a neighbour; the message names the place, the
/// part and the neighbour. On the report's own board every column is clear.
#[test]
fn the_pre_flight_refuses_a_board_whose_columns_are_crowded() {
    use chessarm_chess::reach::ReachError;
    let start = || parse_fen(START).expect("a FEN");
    for (size, part) in [(0.034, "link"), (0.036, "")] {
        let Err(error) = Game::new(report_arm(), board(size), start(), settings()) else {
            panic!("squares of {size} m accepted")
        };
        // Crowded straight down, and at every tilt within max_tilt.
        let PlayError::Reach(ReachError::AtEveryPitch { source, .. }) = &error else { panic!("{error}") };
        let ReachError::Crowded(crowded) = source.as_ref() else { panic!("{error}") };
        assert!(crowded.distance < 0.002 && crowded.part.to_string().starts_with(part), "{error}");
        let message = error.to_string();
        assert!(message.contains(&crowded.place) && message.contains(&crowded.neighbour), "{message}");
    }
    assert!(Game::new(report_arm(), BoardGeometry::default(), start(), settings()).is_ok());
}

/// A finger opening into the neighbour's square: on 42 mm squares the default fingers (6 mm
/// thick, opened 6 mm beside a 29 mm pawn) reach 26.5 mm from the pawn's axis, 1 mm short of
/// the neighbouring pawns' bases; the planner opens them less (3 mm) and says so, and the move
/// keeps the 2 mm margin. On 44 mm squares nothing needs changing.
#[test]
fn a_finger_opening_into_the_neighbours_square_is_narrowed() {
    let roomy = play(board(0.044), START, "e2e4").unwrap();
    assert!(roomy.adjustments.is_empty(), "{:?}", roomy.adjustments);
    let tight = play(board(0.042), START, "e2e4").unwrap();
    assert_eq!(tight.adjustments.len(), 1, "{:?}", tight.adjustments);
    assert!(
        tight.adjustments[0].starts_with("fingers opened 3 mm beside the piece instead of 6"),
        "{:?}",
        tight.adjustments
    );
    assert!(tight.adjustments[0].contains("the white pawn on"), "{:?}", tight.adjustments);
    assert_eq!(tight.opening, Some(0.003));
    let clearance = tight.clearance.as_ref().unwrap();
    assert!(clearance.distance >= 0.002, "{clearance:?}");
    // The fingers keep (nearly) the narrowed opening from the pawn they grip.
    assert!((clearance.gripped.unwrap() - 0.003).abs() < 1e-6, "{clearance:?}");
    assert!(!tight.executed_clearance.unwrap().is_contact());
    assert!(tight.new_misplaced.is_empty());
}

/// Squares too small for any opening: the move is refused before anything runs, naming the
/// move, the finger and the pawn beside it.
#[test]
fn a_move_that_cannot_keep_clear_is_refused_naming_the_part_and_the_piece() {
    let error = play(board(0.036), START, "e2e4").unwrap_err();
    let PlayError::Contact { mv, part, obstacle, distance, .. } = &error else { panic!("{error}") };
    assert_eq!(mv, "1. e4 (e2e4)");
    assert!(part.starts_with("finger"), "{error}");
    assert!(obstacle == "the white pawn on d2" || obstacle == "the white pawn on f2", "{error}");
    assert!(*distance < 0.002);
    let message = error.to_string();
    assert!(message.contains("nothing was run") && message.contains("fingers opened less"), "{message}");
    assert!(message.contains("traverses raised"), "{message}");
}

/// The wrist beside a tall piece: on 34 mm squares the last link (15 mm radius) comes down to
/// e2 beside the king on e1 (40 mm base): refused, naming link 4 and the king.
#[test]
fn the_wrist_beside_the_king_is_refused() {
    let error = play(board(0.034), START, "e2e4").unwrap_err();
    let PlayError::Contact { part, obstacle, .. } = &error else { panic!("{error}") };
    assert_eq!(part, &Part::Link(4).to_string(), "{error}");
    assert_eq!(obstacle, "the white king on e1", "{error}");
}

/// The square the fingers need, against the planner: the default set and fingers need
/// 44.7 mm (the neighbour is the widest piece, a king, in the worst closing direction), and
/// the closed form is monotonic in the opening.
#[test]
fn the_square_the_fingers_need() {
    let pieces = chessarm_chess::pieces::PieceSet::default();
    let gripper = chessarm_core::arm::bodies::Gripper::default();
    let needed = square_for_fingers(&pieces, 0.06, &gripper, 0.002).unwrap();
    assert!((needed - 0.0447).abs() < 1e-4, "{needed}");
    // Along a file, a king gripped beside a king needs its radius, the opening, the finger's
    // thickness, the neighbour's radius and the margin (the kings scaled with the squares,
    // 40 mm on 60 mm): s (1 − 40/60) ≥ 6 + 6 + 2 mm, 42 mm; turned neighbours need more.
    assert!(needed * (1.0 - 0.040 / 0.06) >= 0.014 - 1e-6, "{needed}");
    let narrower = chessarm_core::arm::bodies::Gripper { finger_opening: 0.001, ..gripper };
    assert!(square_for_fingers(&pieces, 0.06, &narrower, 0.002).unwrap() < needed);
}

/// The games that place every piece today keep clear: every robot move of the Opera game and
/// Kasparov–Topalov 1999 has its clearance on the record, none touches (simulated), and the
/// plan keeps the margin everywhere.
#[test]
fn the_master_games_touch_nothing() {
    for file in ["opera_game.pgn", "kasparov_topalov_1999.pgn"] {
        let text = std::fs::read_to_string(format!("{}/tests/fixtures/{file}", env!("CARGO_MANIFEST_DIR"))).unwrap();
        let record = parse_pgn(&text).unwrap().remove(0);
        let mut game = Game::new(report_arm(), BoardGeometry::default(), record.start.clone(), settings()).unwrap();
        let mut smallest = f64::INFINITY;
        for mv in &record.moves {
            let before = game.table().clone();
            let report = game.play(mv, Mover::Robot).unwrap();
            let planned =
                report.clearance.as_ref().unwrap_or_else(|| panic!("{file} ply {}: no clearance", report.ply));
            assert!(planned.distance >= 0.002, "{file} ply {}: {planned:?}", report.ply);
            // The closest pair's points, for showing it: as far apart as the distance (GJK's
            // own tolerance on these solids: 1e-6 m is far above it and far below a mm), the
            // obstacle's on the piece's cylinder or on the table.
            let [on_arm, on_obstacle] = planned.points.unwrap_or_else(|| panic!("{file} ply {}", report.ply));
            assert!(
                ((on_arm - on_obstacle).norm() - planned.distance).abs() < 1e-6,
                "{file} ply {}: {planned:?}",
                report.ply
            );
            let surface = BoardGeometry::default().surface_height;
            match planned.piece {
                Some(i) => {
                    // On the piece where it stood before the move or stands after it.
                    let on = |table: &chessarm_chess::table::Table| {
                        let p = &table.pieces()[i];
                        let d = *settings().pieces.dimensions(p.piece.role);
                        let across = (on_obstacle.xy() - p.position).norm();
                        let up = on_obstacle.z - surface;
                        across <= 0.5 * d.base_diameter + 1e-9 && (-1e-9..=d.height + 1e-9).contains(&up)
                    };
                    assert!(on(&before) || on(game.table()), "{file} ply {}: {planned:?}", report.ply);
                }
                // The table: the point below the arm's lowest, on the surface.
                None if planned.obstacle == chessarm_chess::clearance::Obstacle::Table => {
                    assert!(on_obstacle.z == surface && on_arm.z >= surface, "{file} ply {}: {planned:?}", report.ply)
                }
                // The arm itself: both points are the arm's (checked by the distance above).
                None => {}
            }
            let executed = report.executed_clearance.as_ref().unwrap();
            assert!(!executed.is_contact(), "{file} ply {}: {executed:?}", report.ply);
            smallest = smallest.min(planned.distance);
        }
        assert!(game.misplaced().is_empty(), "{file}");
        // Measured 3.0 mm (Opera) and 2.4 mm (Kasparov–Topalov): a finger beside a queen or king.
        assert!(smallest < 0.01, "{file}: {smallest}");
    }
}

/// A motion `q(t)` of `arm` over `[0, 1]` s swept against `pieces` (and the table at `table`,
/// parts at rest on it off the check) with an open hand; the closest approach and when.
fn swept(
    arm: &chessarm_core::arm::model::ArmModel<4>,
    q: &dyn Fn(f64) -> chessarm_core::arm::model::JointVector<4>,
    rate_bound: [f64; 4],
    pieces: &[chessarm_chess::clearance::StandingPiece],
    table: f64,
) -> (f64, chessarm_chess::clearance::Closest) {
    use chessarm_chess::clearance::{Placed, Rules, Scratch, Stretch, reach_bound, sweep};
    use chessarm_core::arm::bodies::{Bodies, Gripper, Hand};
    let hand = Hand { gripper: Gripper::default(), gap: 0.04, held: None };
    let rules = Rules::for_arm(arm, &hand, &Bodies::Drawn, &q(0.0), table);
    let placed: Vec<Placed> = pieces.iter().map(Placed::piece).collect();
    let stretch = Stretch {
        q,
        start: 0.0,
        end: 1.0,
        rate_bound,
        hand,
        bodies: &Bodies::Drawn,
        gripped: &[],
        beyond: f64::INFINITY,
        open_end: false,
        candidates: None,
    };
    let reach = reach_bound(arm, &hand, &Bodies::Drawn);
    let found = sweep(arm, &stretch, &reach, &placed, &rules, 1e-4, &mut Scratch::default());
    found.closest.expect("something near")
}

/// The solid of `part` at `q` (the first, for a drawn arm the only one).
fn solid_of(
    arm: &chessarm_core::arm::model::ArmModel<4>,
    q: &chessarm_core::arm::model::JointVector<4>,
    part: Part,
) -> chessarm_core::arm::bodies::Solid {
    use chessarm_core::arm::bodies::{Bodies, Gripper, Hand, solids_into};
    let mut solids = Vec::new();
    let hand = Hand { gripper: Gripper::default(), gap: 0.04, held: None };
    solids_into(arm, q, &hand, &Bodies::Drawn, &mut solids);
    solids.into_iter().find(|s| s.part == part).expect("the part").solid
}

/// A tall king beside the forearm's sweep: the base turns the report's arm (elbow up, tool
/// down over the board) through 0.6 rad while a 20 cm king stands beside the tool's path,
/// under the forearm's sweep, reaching 2 mm into the forearm only at mid-motion. The sweep
/// finds link 3 touching the king there, the fingers then 4 cm and more from it (a check of
/// the tool or the carried piece alone would not see it).
#[test]
fn a_tall_king_beside_the_forearm_s_sweep_is_caught() {
    use chessarm_chess::clearance::{Obstacle, StandingPiece};
    use chessarm_core::arm::bodies::Solid;
    use chessarm_core::arm::model::JointVector;
    let arm = report_arm();
    let q = |t: f64| JointVector::<4>::new(1.3 + 0.6 * t, 1.2, -1.6, -1.17);
    let Solid::Cylinder { a, b, radius } = solid_of(&arm, &q(0.5), Part::Link(3)) else { panic!("a cylinder") };
    // Under the forearm's middle, 2 mm into its underside.
    let middle = 0.5 * (a + b);
    let slope = ((b - a).z / (b - a).norm()).abs();
    let top = middle.z - radius / (1.0 - slope * slope).sqrt() + 0.002;
    let king = StandingPiece::cylinder(chessarm_core::nalgebra::Vector3::new(middle.x, middle.y, 0.0), 0.02, top);
    assert!(top > 0.15, "a tall king: {top}");
    let (when, closest) = swept(&arm, &q, [0.6, 0.0, 0.0, 0.0], &[king], 0.0);
    assert_eq!(closest.distance, 0.0, "{closest:?}");
    assert_eq!(closest.part, Part::Link(3), "{closest:?}");
    assert_eq!(closest.obstacle, Obstacle::Piece(0));
    // Only around mid-motion: clear at the start and the end.
    assert!((when - 0.5).abs() < 0.25, "at {when}");
    for t in [0.0, 1.0] {
        let forearm = chessarm_chess::clearance::Placed::of(&solid_of(&arm, &q(t), Part::Link(3)));
        assert!(forearm.distance(&chessarm_chess::clearance::Placed::piece(&king)) > 0.01, "at {t}");
    }
    let Solid::Cuboid { centre, .. } = solid_of(&arm, &q(when), Part::Finger(1)) else { panic!("a box") };
    assert!((centre.xy() - king.base.xy()).norm() > 0.04, "the fingers are far: {centre}");
}

/// A long forearm on a low elbow path: an arm with a short upper arm (15 cm) on a low
/// shoulder (8 cm) and a forearm half a metre long, rising from its elbow to a wrist that holds
/// the tool high; as the shoulder lowers the elbow comes down, and a pawn standing just in
/// front of the elbow meets the forearm's underside. The sweep finds the forearm touching the
/// pawn, the fingers then 10 cm and more from it.
#[test]
fn a_long_forearm_on_a_low_elbow_path_is_caught() {
    use chessarm_chess::clearance::{Obstacle, StandingPiece};
    use chessarm_core::arm::bodies::Solid;
    use chessarm_core::arm::model::{ArmModel, JointVector};
    let report = report_arm();
    let mut links = *report.links();
    links[0].dh.d = 0.08;
    links[1].dh.a = 0.15;
    links[2].dh.a = 0.5;
    let arm = ArmModel::new(links, report.gravity()).unwrap();
    // The shoulder lowers from 0.3 to −0.06 rad, the upper arm dipping below the shoulder, the
    // forearm rising from the low elbow (+0.6 rad) and the tool pointing down.
    let q = |t: f64| {
        let shoulder = 0.3 - 0.36 * t;
        JointVector::<4>::new(std::f64::consts::FRAC_PI_2, shoulder, 0.6, -std::f64::consts::FRAC_PI_2 - shoulder - 0.6)
    };
    let Solid::Cylinder { a, b, radius } = solid_of(&arm, &q(0.9), Part::Link(3)) else { panic!("a cylinder") };
    // A pawn (50 mm) under the forearm's point 10 % of the way from the elbow (4 cm in front of
    // its axis), 1 mm into it at t = 0.9 s: the table is put so.
    let under = a + 0.1 * (b - a);
    let slope = ((b - a).z / (b - a).norm()).abs();
    let table = under.z - radius / (1.0 - slope * slope).sqrt() + 0.001 - 0.05;
    let pawn = StandingPiece::cylinder(chessarm_core::nalgebra::Vector3::new(under.x, under.y, table), 0.0145, 0.05);
    let (when, closest) = swept(&arm, &q, [0.0, 0.36, 0.0, 0.36], &[pawn], table);
    // Nothing else comes down to the table: the elbow's housing stays above it throughout.
    for t in [0.0, 0.5, 1.0] {
        assert!(solid_of(&arm, &q(t), Part::Housing(3)).lowest() > table, "at {t}");
    }
    assert_eq!(closest.distance, 0.0, "{closest:?} at {when}");
    assert_eq!(closest.part, Part::Link(3), "{closest:?}");
    assert_eq!(closest.obstacle, Obstacle::Piece(0));
    let Solid::Cuboid { centre, .. } = solid_of(&arm, &q(when), Part::Finger(1)) else { panic!("a box") };
    assert!((centre.xy() - pawn.base.xy()).norm() > 0.1, "the fingers are far: {centre}");
}
