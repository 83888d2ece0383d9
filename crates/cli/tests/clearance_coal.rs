//! The clearance check's distances against an independent library: Coal (the maintained
//! hpp-fcl, PyPI `coal`, which CI's virtual environment has with Pinocchio), on configurations
//! sampled from a real game.

mod common;

use chessarm_chess::board::BoardGeometry;
use chessarm_chess::clearance::{Placed, StandingPiece};
use chessarm_chess::notation::parse_pgn;
use chessarm_chess::play::{Game, Mover, PlaySettings};
use chessarm_core::arm::bodies::{Bodies, Gripper, Hand, Solid, solids_into};
use chessarm_core::arm::preset::report_arm;
use chessarm_core::control::gains::{Gains, REPORT_PD};
use chessarm_core::nalgebra::Vector3;
use serde_json::{Value, json};
use std::path::Path;

use common::OPERA;

/// How far parry's distance may be from Coal's, m. Coal converges to well under a micrometre
/// here (its distances move by less than 0.5 µm with its GJK tolerance cut from 1e-6 to
/// 1e-10); parry's GJK stops earlier on the curved supports of cylinders and comes out up to
/// 20 µm long (measured, box or cylinder against a piece). 50 µm is a tenth of the sweep's
/// resolution (0.5 mm, below which a clearance counts as a contact) and a fortieth of the
/// 2 mm margin the planner keeps.
const TOLERANCE: f64 = 5e-5;

fn point(v: &Vector3<f64>) -> Value {
    json!([v.x, v.y, v.z])
}

fn solid_json(solid: &Solid) -> Value {
    match solid {
        Solid::Cylinder { a, b, radius } => json!({"kind": "cylinder", "a": point(a), "b": point(b), "radius": radius}),
        Solid::Sphere { .. } | Solid::Hull { .. } | Solid::Frustum { .. } => {
            unreachable!("the report's arm has no spheres or hulls, and the hand holds no piece here")
        }
        Solid::Cuboid { centre, axes, half } => {
            let columns: Vec<Value> = (0..3).map(|k| point(&axes.column(k).into_owned())).collect();
            json!({"kind": "box", "centre": point(centre), "axes": columns, "half": point(half)})
        }
    }
}

/// Every 5th recorded pose (every 50 ms) of every robot move of the Opera game, the fingers
/// open around a pawn, against the pieces standing before the move and a wide piece under the
/// tool that the fingers reach into: chessarm's distance of every pair of a solid and a piece
/// within 5 cm, and Coal's, agree to 50 µm, and both call the same pairs touching.
#[test]
#[cfg_attr(not(tool_python), ignore = "needs CHESSARM_PYTHON, a Python with coal; see docs/testing.md")]
fn distances_equal_coals_on_a_real_games_poses() {
    let python = common::python_with("coal").expect("CHESSARM_PYTHON (or python3) with coal installed");
    let record = parse_pgn(&std::fs::read_to_string(OPERA).unwrap()).unwrap().remove(0);
    let mut settings = PlaySettings::new("pd", Gains::uniform(REPORT_PD.0, REPORT_PD.1, 0.0).unwrap());
    settings.record_every = 50;
    let pieces = settings.pieces;
    let mut game = Game::new(report_arm(), BoardGeometry::default(), record.start.clone(), settings).unwrap();
    let gripper = Gripper::default();
    let hand = Hand { gripper, gap: gripper.open_gap(pieces.pawn.base_diameter), held: None };
    let arm = report_arm();
    let mut samples = Vec::new();
    let mut touching = 0;
    let mut solids = Vec::new();
    for mv in &record.moves {
        let standing: Vec<StandingPiece> = game
            .table()
            .pieces()
            .iter()
            .map(|p| {
                let d = pieces.dimensions(p.piece.role);
                // Cylinders of the base (coal's shapes): the profile's own sections are checked
                // against a hull of their rings elsewhere.
                StandingPiece::cylinder(Vector3::new(p.position.x, p.position.y, 0.0), 0.5 * d.base_diameter, d.height)
            })
            .collect();
        let report = game.play(mv, Mover::Robot).unwrap();
        for step in report.records.iter().step_by(5) {
            // And a wide piece standing under the tool, up to the tip, that the fingers (open
            // 35 mm) reach into: contacts for both libraries to see.
            let tip = step.tip;
            let mut standing = standing.clone();
            standing.push(StandingPiece::cylinder(Vector3::new(tip.x, tip.y, 0.0), 0.025, tip.z.max(0.01)));
            let placed: Vec<Placed> = standing.iter().map(Placed::piece).collect();
            solids_into(&arm, &step.state.q, &hand, &Bodies::Drawn, &mut solids);
            let mut distances = Vec::new();
            for (i, solid) in solids.iter().enumerate() {
                let shape = Placed::of(&solid.solid);
                for (k, piece) in placed.iter().enumerate() {
                    let d = shape.distance(piece);
                    if d < 0.05 {
                        touching += usize::from(d == 0.0);
                        distances.push(json!([i, k, d]));
                    }
                }
            }
            samples.push(json!({
                "solids": solids.iter().map(|s| solid_json(&s.solid)).collect::<Vec<_>>(),
                "pieces": standing.iter().map(|p| json!({"base": point(&p.base), "radius": p.outline.widest(), "height": p.outline.height()})).collect::<Vec<_>>(),
                "distances": distances,
            }));
        }
    }
    assert!(touching > 100, "{touching}");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("samples.json");
    std::fs::write(&path, json!({"tolerance": TOLERANCE, "samples": samples}).to_string()).unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/coal/check_distances.py");
    let output = std::process::Command::new(&python).arg(&script).arg(&path).output().unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let result: Value = serde_json::from_slice(&output.stdout).unwrap();
    eprintln!("{result}");
    assert!(result["pairs"].as_u64().unwrap() > 3000, "{result}");
    assert_eq!(result["disagree"], json!([]), "{result}");
    assert!(result["largest_difference"].as_f64().unwrap() <= TOLERANCE, "{result}");
    assert_eq!(result["both_touching"].as_u64().unwrap() as usize, touching, "{result}");
}
