//! The makers' own arms (`tests/fixtures/real-arms`, their official URDFs as published): the two
//! commands a maker runs — `board --fit`, then `play` on the fitted board — play the Opera game
//! with every piece in place, with ideal and with hobby sensors; the hardware export lists every
//! joint of the file, and its angles, put into the file's own kinematics (parsed by urdf-rs, not
//! chessarm, every joint in the file's sense and the held ones at their exported values), put
//! the tool link where the game planned each grip and release.
//! (The dynamics of the same files against Pinocchio: `crates/python/tests/test_real_arms.py`.)

#![allow(clippy::unwrap_used)]

mod common;

use chessarm_core::nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};
use common::{chessarm, json_of};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use common::OPERA;

/// Castling on both sides, en passant, promotion to a queen and, capturing, to a knight.
const SPECIAL_MOVES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../chess/tests/fixtures/special_moves.pgn");
use common::REAL_ARMS as FIXTURES;

/// Each file, the flags it needs (the SO-101's fifth joint held), its tool link, and how far
/// the file's own kinematics may be from chessarm's: the SO-101's CAD export rounds π to
/// 3.14159 and π/2 to 1.5708 (≤ 3.7e-6 rad), which chessarm's import makes exact for the arm's
/// axes (within 1e-5 rad), so the two differ by that rounding times the levers (≤ 0.5 m):
/// 5e-6 m; the other two files write their angles in full: rounding of the products, 1e-9 m.
const ARMS: [(&str, &[&str], &str, f64); 3] = [
    ("open_manipulator_x", &[], "end_effector_link", 1e-9),
    ("px100", &[], "px100/ee_gripper_link", 1e-9),
    ("so101_new_calib", &["--lock", "wrist_roll=0"], "gripper_frame_link", 5e-6),
];

fn urdf(name: &str) -> PathBuf {
    Path::new(FIXTURES).join(format!("{name}.urdf"))
}

/// The pose of `link` in the root link's frame for the joint values `values` (by name; a joint
/// not named is at 0), composed from the file's origins, axes and joint types.
fn file_fk(robot: &urdf_rs::Robot, link: &str, values: &BTreeMap<String, f64>) -> Isometry3<f64> {
    let mut pose = Isometry3::identity();
    let mut current = link.to_string();
    while let Some(joint) = robot.joints.iter().find(|j| j.child.link == current) {
        let o = &joint.origin;
        let origin = Isometry3::from_parts(
            Translation3::new(o.xyz[0], o.xyz[1], o.xyz[2]),
            UnitQuaternion::from_euler_angles(o.rpy[0], o.rpy[1], o.rpy[2]),
        );
        let axis = Unit::new_normalize(Vector3::new(joint.axis.xyz[0], joint.axis.xyz[1], joint.axis.xyz[2]));
        let value = values.get(&joint.name).copied().unwrap_or(0.0);
        let motion = match joint.joint_type {
            urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous => {
                Isometry3::from_parts(Translation3::identity(), UnitQuaternion::from_axis_angle(&axis, value))
            }
            urdf_rs::JointType::Prismatic => {
                Isometry3::from_parts(Translation3::from(axis.into_inner() * value), UnitQuaternion::identity())
            }
            _ => Isometry3::identity(),
        };
        pose = origin * motion * pose;
        current = joint.parent.link.clone();
    }
    pose
}

#[test]
fn each_makers_arm_fits_a_board_and_plays_the_opera_game_with_every_piece_in_place() {
    let dir = tempfile::tempdir().unwrap();
    for (name, flags, tool, tolerance) in ARMS {
        let path = urdf(name);
        let base: Vec<&str> = [&["--urdf", path.to_str().unwrap()][..], flags].concat();
        // 1. With the default fingers (a common printed gripper's) no board the arm serves
        // has squares large enough for them: the fit says what they need.
        let too_thick = chessarm(&[&base[..], &["board", "--fit"]].concat());
        assert!(!too_thick.status.success(), "{name}");
        let said = String::from_utf8_lossy(&too_thick.stderr);
        assert!(
            said.contains("need 44.7 mm to open around a piece") && said.contains("slimmer fingers"),
            "{name}: {said}"
        );
        // The largest board the arm serves with needle fingers, as a setup file.
        let fit = json_of(&chessarm(&[&base[..], &["--arm", common::NEEDLE_FINGERS, "board", "--fit"]].concat()));
        assert!(fit["fingers_need_square_size_m"].as_f64().unwrap() <= fit["square_size_m"].as_f64().unwrap());
        assert_eq!(fit["served"], true, "{name}: {fit}");
        let square = fit["square_size_m"].as_f64().unwrap();
        // Smaller than the default 6 cm squares (every file refuses the default board), and a
        // playable board (at least a 1 cm square).
        assert!((0.01..0.06).contains(&square), "{name}: {square}");
        eprintln!("{name}: squares of {:.1} mm in {:.2} s", square * 1e3, fit["seconds"].as_f64().unwrap());
        let setup = dir.path().join(format!("{name}.toml"));
        std::fs::write(&setup, fit["setup"].as_str().unwrap()).unwrap();
        // The default board is not served, and says which command finds one that is.
        let refused = chessarm(
            &[&base[..], &["play", "--moves", "e4", "--out"], &[dir.path().join("x").to_str().unwrap()]].concat(),
        );
        assert!(!refused.status.success());
        assert!(String::from_utf8_lossy(&refused.stderr).contains("chessarm board --fit"), "{name}");
        // The tool tilts where that serves a larger board, never beyond [motion] max_tilt
        // (30°), and a board the arm serves straight down is smaller.
        let pitch = fit["tool_pitch_rad"].as_f64().unwrap();
        assert!((pitch + std::f64::consts::FRAC_PI_2).abs() <= std::f64::consts::FRAC_PI_6 + 1e-12, "{name}: {pitch}");
        let straight = dir.path().join(format!("{name}-straight.toml"));
        let needle = std::fs::read_to_string(common::NEEDLE_FINGERS).unwrap();
        std::fs::write(&straight, needle.replace("[motion]\n", "[motion]\nmax_tilt = 0.0\n")).unwrap();
        let down = json_of(&chessarm(&[&base[..], &["--arm", straight.to_str().unwrap(), "board", "--fit"]].concat()));
        assert_eq!(down["tool_pitch_rad"].as_f64(), Some(-std::f64::consts::FRAC_PI_2), "{name}: {down}");
        let tilted = pitch > -std::f64::consts::FRAC_PI_2;
        let smaller = down["square_size_m"].as_f64().unwrap();
        assert!(if tilted { smaller < square } else { smaller == square }, "{name}: {smaller} against {square}");
        eprintln!(
            "{name}: squares of {:.1} mm straight down, {:.1} mm at pitch {pitch:.4} rad",
            smaller * 1e3,
            square * 1e3
        );
        // 2. The Opera game on it, ideal sensors and hobby ones; with hobby ones a game of
        // castling on both sides, en passant and promotions (to a queen and, capturing, to a
        // knight).
        for (game, sensors) in [(OPERA, "ideal"), (OPERA, "hobby"), (SPECIAL_MOVES, "hobby")] {
            let out = dir.path().join(format!("{name}-{sensors}-{}", game.len()));
            let args = [
                &base[..],
                &["--arm", setup.to_str().unwrap(), "play", game, "--sensors", sensors, "--out"],
                &[out.to_str().unwrap()],
            ]
            .concat();
            let played = json_of(&chessarm(&args));
            if game == OPERA {
                assert_eq!(played["result"], "1-0", "{name} {sensors}: {played}");
            }
            assert_eq!(played["misplaced"], 0, "{name} {sensors}: {played}");
            assert_eq!(played["final_fen_physical"], played["final_fen_rules"], "{name} {sensors}");
            // Nothing touched: the plan keeps the fingers' margin, the simulated motion touches
            // nothing (measured in full wherever its deviation from the plan could).
            let record: Value = serde_json::from_slice(&std::fs::read(out.join("game.json")).unwrap()).unwrap();
            assert_eq!(record["complete"], true, "{name} {sensors}: {played}");
            let clearance = &record["clearance"];
            assert_eq!(clearance["contacts"], 0, "{name} {sensors}: {clearance}");
            assert!(clearance["smallest_mm"].as_f64().unwrap() >= 1.0, "{name} {sensors}: {clearance}");
            eprintln!(
                "{name} {sensors}: smallest clearance {:.2} mm ({} – {})",
                clearance["smallest_mm"].as_f64().unwrap(),
                clearance["part"],
                clearance["obstacle"]
            );
            if sensors == "ideal" && game == OPERA {
                check_hardware(name, &out.join("hardware"), tool, tolerance);
            }
        }
    }
}

/// Every move's export names every moving joint of the file, and at every gripper command the
/// file's own kinematics put the tool link where the game planned it.
fn check_hardware(name: &str, dir: &Path, tool: &str, tolerance: f64) {
    let robot = urdf_rs::read_file(urdf(name)).unwrap();
    let moving: std::collections::BTreeSet<String> = robot
        .joints
        .iter()
        .filter(|j| !matches!(j.joint_type, urdf_rs::JointType::Fixed))
        .map(|j| j.name.clone())
        .collect();
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    files.sort();
    assert_eq!(files.len(), 33, "{name}: one export per robot move");
    let mut checked = 0;
    for file in &files {
        let value: Value = serde_json::from_str(&std::fs::read_to_string(file).unwrap()).unwrap();
        let trajectory = &value["trajectory"];
        let names: Vec<String> =
            trajectory["joint_names"].as_array().unwrap().iter().map(|n| n.as_str().unwrap().to_string()).collect();
        assert_eq!(names.iter().cloned().collect::<std::collections::BTreeSet<_>>(), moving, "{name}: {file:?}");
        let time = |p: &Value| {
            p["time_from_start"]["sec"].as_f64().unwrap() + p["time_from_start"]["nanosec"].as_f64().unwrap() * 1e-9
        };
        for command in value["gripper"].as_array().unwrap() {
            let planned: Vec<f64> = common::numbers(&command["wait_until_in_position"]["tool_tip_m"]);
            let t = command["t"].as_f64().unwrap();
            let point = trajectory["points"]
                .as_array()
                .unwrap()
                .iter()
                .find(|p| (time(p) - t).abs() < 1e-9)
                .unwrap_or_else(|| panic!("{name}: no sample at the command's time {t} s in {file:?}"));
            let values: BTreeMap<String, f64> =
                names.iter().cloned().zip(common::numbers(&point["positions"])).collect();
            let tip = file_fk(&robot, tool, &values).translation.vector;
            let error = (tip - Vector3::new(planned[0], planned[1], planned[2])).norm();
            assert!(error < tolerance, "{name} {file:?} at {t} s: the file's FK puts the tool {error:e} m off");
            checked += 1;
        }
    }
    // Two commands (close, open) per grip; the Opera game's robot moves grip 33 times or more.
    assert!(checked >= 66, "{name}: {checked}");
}

#[test]
fn the_urdf_export_of_a_makers_arm_keeps_the_files_joint_senses() {
    // The SO-101's base yaw turns about −z: chessarm's URDF export writes it so (axis 0 0 -1),
    // so the same angles put the tool at the same point in the export as in the file.
    let dir = tempfile::tempdir().unwrap();
    let path = urdf("so101_new_calib");
    let base = ["--urdf", path.to_str().unwrap(), "--lock", "wrist_roll=0"];
    let exported = common::chessarm_human(&[&base[..], &["urdf"]].concat());
    assert!(exported.status.success());
    let text = String::from_utf8(exported.stdout).unwrap();
    assert!(text.contains(r#"<axis xyz="0 0 -1"/>"#), "{text}");
    let copy = dir.path().join("so101-export.urdf");
    std::fs::write(&copy, &text).unwrap();
    let q = "0.3,0.2,-0.4,0.6";
    let tip = |args: &[&str]| common::numbers(&json_of(&chessarm(&[args, &["fk", "--q", q]].concat()))["tip"]);
    let (original, again) = (tip(&base), tip(&["--urdf", copy.to_str().unwrap()]));
    // The export writes shortest round-trip decimals and the import fits DH by atan2: 1e-12 m.
    for (a, b) in original.iter().zip(&again) {
        assert!((a - b).abs() < 1e-12, "{original:?} vs {again:?}");
    }
    assert!(original[1] < 0.0, "a positive base angle turns clockwise seen from above: {original:?}");
}

/// `board --fit --square-size`: a board of the maker's squares placed where the arm serves it,
/// written as a setup file the check then accepts; squares no pose serves are refused with the
/// nearest pose's failures (each naming its place), no setup file, and its reach map drawn.
#[test]
fn a_board_of_given_squares_is_placed_or_its_failing_places_are_listed() {
    let dir = tempfile::tempdir().unwrap();
    let path = urdf("so101_new_calib");
    let base = ["--urdf", path.to_str().unwrap(), "--lock", "wrist_roll=0", "--arm", common::NEEDLE_FINGERS];
    let largest = json_of(&chessarm(&[&base[..], &["board", "--fit"]].concat()));
    let square = largest["square_size_m"].as_f64().unwrap();
    // A millimetre under the largest, rounded to a tenth of a millimetre, as a maker types it.
    let size = ((square - 0.001) * 1e4).floor() / 1e4;
    let saved = dir.path().join("placed.toml");
    let placed = chessarm(
        &[&base[..], &["board", "--fit", "--square-size", &size.to_string(), "--save", saved.to_str().unwrap()]]
            .concat(),
    );
    assert!(placed.status.success(), "{}", String::from_utf8_lossy(&placed.stderr));
    let value = json_of(&placed);
    assert_eq!(value["served"], true, "{value}");
    assert_eq!(value["square_size_m"].as_f64(), Some(size), "{value}");
    // The setup file holds exactly those squares, and the check (no fit) serves it.
    let text = std::fs::read_to_string(&saved).unwrap();
    assert!(text.contains(&format!("square_size = {size}")), "{text}");
    let setup = ["--urdf", path.to_str().unwrap(), "--arm", saved.to_str().unwrap()];
    let checked = json_of(&chessarm(&[&setup[..], &["board"]].concat()));
    assert_eq!(checked["served"], true, "{checked}");

    // 3 cm squares: no pose serves them. The failures, no setup file (the one the run above
    // wrote there is removed, not left looking like this run's), the nearest pose's map.
    let refused_save = saved.clone();
    let map = dir.path().join("nearest.png");
    let refused = chessarm(
        &[
            &base[..],
            &["board", "--fit", "--square-size", "0.03", "--save", refused_save.to_str().unwrap()],
            &["--map", map.to_str().unwrap()],
        ]
        .concat(),
    );
    assert_eq!(refused.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(stderr.contains("--square-size 0.03") && stderr.contains("fails"), "{stderr}");
    let value: Value = serde_json::from_slice(&refused.stdout).unwrap();
    assert_eq!(value["served"], false);
    let failures = value["failures"].as_array().unwrap();
    assert!(!failures.is_empty());
    for failure in failures {
        let (place, why) = (failure["place"].as_str().unwrap(), failure["why"].as_str().unwrap());
        assert!(why.contains(place) || place.starts_with("a way"), "{place}: {why}");
    }
    assert!(!refused_save.exists(), "a setup file of a board that is not served");
    assert!(std::fs::metadata(&map).unwrap().len() > 1000, "the nearest pose's reach map");

    // Bad sizes name the flag and the value as typed.
    for (typed, said) in [
        ("25", "give metres"),
        ("nan", "finite"),
        ("0.001", "at least 0.01 m"),
        ("-0.03", "finite number of metres > 0"),
    ] {
        let output = chessarm(&["board", "--fit", "--square-size", typed]);
        assert_eq!(output.status.code(), Some(2), "{typed}");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains("--square-size") && stderr.contains(typed) && stderr.contains(said), "{stderr}");
    }
    // Squares the fingers cannot open on are refused before any search, and a setup file an
    // earlier run wrote at --save goes with the failed run.
    let placed_again = chessarm(
        &[&base[..], &["board", "--fit", "--square-size", &size.to_string(), "--save", saved.to_str().unwrap()]]
            .concat(),
    );
    assert!(placed_again.status.success() && saved.exists());
    let too_small = chessarm(
        &[&base[..], &["board", "--fit", "--square-size", "0.011", "--save", saved.to_str().unwrap()]].concat(),
    );
    assert_eq!(too_small.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&too_small.stderr);
    assert!(stderr.contains("--square-size") && stderr.contains("11.0 mm are too small"), "{stderr}");
    assert!(!saved.exists(), "a setup file of an earlier run left at --save");
    // Without --fit it has nothing to place.
    assert_eq!(chessarm(&["board", "--square-size", "0.03"]).status.code(), Some(2));
}

/// The pace the servos keep clear: on the SO-101's fitted board, its 12 V servos sent
/// feedforward goals and hobby encoders, the Opera game at the limits' own pace touches pieces
/// in the simulated motion (`--keep-pace`); by default each such move is run again at 0.7× its
/// pace until it keeps `arm_clearance`, and the game has no contact. A slowed move's pace is
/// 0.7 to the number of tries that came too near, each nearer than the margin, and its last
/// try keeps the margin.
#[test]
fn the_planner_slows_a_move_the_servos_would_not_keep_clear() {
    let dir = tempfile::tempdir().unwrap();
    let path = urdf("so101_new_calib");
    let base = ["--urdf", path.to_str().unwrap(), "--lock", "wrist_roll=0", "--arm", common::NEEDLE_FINGERS];
    let fit = json_of(&chessarm(&[&base[..], &["board", "--fit"]].concat()));
    let setup = dir.path().join("so101.toml");
    std::fs::write(&setup, fit["setup"].as_str().unwrap()).unwrap();
    let servos = [
        "--urdf",
        path.to_str().unwrap(),
        "--arm",
        setup.to_str().unwrap(),
        "--actuator",
        "sts3215-12v",
        "--servo-command",
        "feedforward",
    ];
    let game = |name: &str, extra: &[&str]| -> Value {
        let out = dir.path().join(name);
        json_of(&chessarm(
            &[&servos[..], &["play", OPERA, "--sensors", "hobby", "--out", out.to_str().unwrap()], extra].concat(),
        ));
        common::json_file(&out.join("game.json"))
    };
    let kept = game("kept", &["--keep-pace"]);
    assert!(kept["clearance"]["contacts"].as_u64().unwrap() > 0, "{}", kept["clearance"]);
    assert_eq!(kept["clearance"]["slowed_moves"], 0);
    let chosen = game("chosen", &[]);
    let clearance = &chosen["clearance"];
    assert_eq!(clearance["contacts"], 0, "{clearance}");
    assert_eq!(chosen["complete"], true);
    assert_eq!(chosen["misplaced"].as_array().unwrap().len(), 0);
    let margin_mm = 1.0; // the needle fingers' [motion] arm_clearance
    let moves = chosen["moves"].as_array().unwrap();
    let slowed: Vec<&Value> = moves.iter().filter(|m| m["pace"].as_f64().unwrap() < 1.0).collect();
    assert!(!slowed.is_empty());
    assert_eq!(clearance["slowed_moves"].as_u64().unwrap() as usize, slowed.len());
    for m in &slowed {
        let tries = m["too_near_tries_mm"].as_array().unwrap();
        assert!(!tries.is_empty() && tries.iter().all(|d| d.as_f64().unwrap() < margin_mm), "{m}");
        let pace = m["pace"].as_f64().unwrap();
        assert!((pace - 0.7f64.powi(tries.len() as i32)).abs() < 1e-12, "{m}");
        let executed = &m["clearance"]["executed"];
        let last = executed["smallest_mm"].as_f64().or_else(|| executed["at_least_mm"].as_f64()).unwrap();
        assert!(last >= margin_mm && executed["contact"] == false, "{m}");
    }
    // Moves that kept clear the first time ran at the pace given, as with --keep-pace.
    for (m, k) in moves.iter().zip(kept["moves"].as_array().unwrap()).take_while(|(m, _)| m["pace"] == 1.0) {
        assert_eq!(m["duration_s"], k["duration_s"], "ply {}", m["ply"]);
    }
    // Slower moves cost robot time: reported per move.
    let per_move = chosen["robot_time_per_robot_move_s"].as_f64().unwrap();
    let total = chosen["total_robot_time_s"].as_f64().unwrap();
    assert!((per_move * moves.len() as f64 - total).abs() < 1e-6 * total, "{per_move} {total}");
    assert!(total > kept["total_robot_time_s"].as_f64().unwrap());
    eprintln!(
        "SO-101 servos, Opera game: {} contacts at the pace given; {} moves slowed, 0 contacts, {per_move:.2} s per move",
        kept["clearance"]["contacts"],
        slowed.len()
    );
}

/// A board that is not served (the report's 6 cm board before a PincherX-100) is refused with
/// every place that fails, not only the first: each reason names its place, and squares out of
/// reach are among them.
#[test]
fn a_board_not_served_lists_every_failing_place() {
    let path = urdf("px100");
    let output = chessarm(&["--urdf", path.to_str().unwrap(), "--arm", common::NEEDLE_FINGERS, "board"]);
    assert_eq!(output.status.code(), Some(2));
    let value: Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(value["served"], false);
    let failures = value["failures"].as_array().unwrap();
    assert!(failures.len() > 1, "{value}");
    for failure in failures {
        let (place, why) = (failure["place"].as_str().unwrap(), failure["why"].as_str().unwrap());
        assert!(why.contains(place) || place.starts_with("a way"), "{place}: {why}");
    }
    assert!(failures.iter().any(|f| f["place"] == "a1" && f["why"].as_str().unwrap().contains("out of reach")));
}
