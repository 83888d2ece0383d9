//! `calibrate`: the board's pose (and the joints' zero errors) from touched square centres,
//! typed or read over the simulated servo bus while a hand moves the arm.

#![allow(clippy::unwrap_used)] // tests

mod common;

use chessarm::app::setup::file::Setup;
use chessarm_core::nalgebra::{Rotation2, Vector2};
use common::chessarm;
use serde_json::Value;
use std::io::Write;
use std::process::Stdio;

/// The joint angles (rad, the setup's sense, as `chessarm <setup> ik` gives them) at which the
/// tool tip touches `square`'s centre on the setup's board moved by `shift` (m) and turned by
/// `turn` (rad) about its centre, read with zero errors `errors` (the setup's sense: true = read
/// + error) and rounded to `counts` per turn.
fn touch(
    setup_args: &[&str],
    setup: &Setup,
    square: &str,
    shift: Vector2<f64>,
    turn: f64,
    errors: [f64; 4],
    counts: f64,
) -> [f64; 4] {
    let square = chessarm_chess::board::parse_square(square).unwrap();
    let board = &setup.board;
    let local = Vector2::new(f64::from(u8::from(square.file())) - 3.5, f64::from(u8::from(square.rank())) - 3.5)
        * board.square_size;
    let xy = board.center + shift + Rotation2::new(board.yaw + turn) * local;
    let xyz = format!("{:?},{:?},{:?}", xy.x, xy.y, board.surface_height);
    let ik = common::json_of(&chessarm(&[setup_args, &["ik", "--xyz", &xyz]].concat()));
    let count = std::f64::consts::TAU / counts;
    std::array::from_fn(|j| ((ik["q"][j].as_f64().unwrap() - errors[j]) / count).round() * count)
}

fn angles(q: [f64; 4]) -> String {
    q.iter().map(|v| format!("{v:?}")).collect::<Vec<_>>().join(",")
}

/// The target on the report's arm: a board shifted 8 mm and turned 2°, its four corner
/// squares touched and read in whole counts of a 4096-count servo: the fitted pose within
/// 0.5 mm and 0.1°, written as a setup that loads with that board; each touch's residual
/// printed, and plotted.
#[test]
fn a_board_shifted_8_mm_and_turned_2_degrees_is_found_from_four_typed_touches() {
    let dir = tempfile::tempdir().unwrap();
    let setup = Setup::load(None).unwrap();
    let shift = Vector2::new(0.008 * 0.6, -0.008 * 0.8);
    let turn = 2f64.to_radians();
    let mut args = vec!["calibrate".to_string()];
    for square in ["a1", "h1", "h8", "a8"] {
        args.push("--touch".into());
        args.push(format!("{square}={}", angles(touch(&[], &setup, square, shift, turn, [0.0; 4], 4096.0))));
    }
    let out = dir.path().join("cal");
    args.extend(["--out".into(), out.to_str().unwrap().into()]);
    let strs: Vec<&str> = args.iter().map(String::as_str).collect();
    let output = chessarm(&strs);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let result: Value = serde_json::from_slice(&output.stdout).unwrap();
    let center = Vector2::new(result["center_m"][0].as_f64().unwrap(), result["center_m"][1].as_f64().unwrap());
    let position_error = (center - (setup.board.center + shift)).norm();
    let yaw_error = (result["yaw_rad"].as_f64().unwrap() - setup.board.yaw - turn).abs().to_degrees();
    eprintln!("fitted within {:.3} mm and {yaw_error:.4}°; {result}", position_error * 1e3);
    assert!(position_error < 0.5e-3 && yaw_error < 0.1, "{position_error} m, {yaw_error}°");
    assert!((result["moved_mm"].as_f64().unwrap() - 8.0).abs() < 0.5);
    assert!((result["turned_deg"].as_f64().unwrap() - 2.0).abs() < 0.1);
    assert_eq!(result["touches"].as_array().unwrap().len(), 4);
    assert!(out.join("residuals.png").is_file());
    // The setup file carries the fitted board.
    let saved = Setup::load(Some(&out.join("setup.toml"))).unwrap();
    assert!((saved.board.center - center).norm() < 1e-12);
    // Too few touches, and a malformed one, are named.
    common::assert_one_line_error(
        &chessarm(&["calibrate", "--touch", strs[2], "--out", out.to_str().unwrap()]),
        &["1 touches"],
    );
    common::assert_one_line_error(&chessarm(&["calibrate", "--touch", "z9=1,2,3,4"]), &["--touch 'z9=1,2,3,4'"]);
    common::assert_one_line_error(&chessarm(&["calibrate", "--touch", "a1=1,2,3"]), &["--touch 'a1=1,2,3'"]);
}

/// Over the bus: the SO-101's servos on the simulated bus, their torque turned off by
/// calibrate, a hand (bus-sim's `pose` lines) putting the tool tip on each of six squares, the
/// angles read back over the Feetech protocol: the board's pose and joints 2–4's zero errors
/// (1.5°, −1°, 2°, seen as an offset of the servos' zero ticks) found, and the setup written
/// with the corrected zero ticks.
#[test]
fn touches_read_over_the_bus_give_the_board_and_the_zero_errors() {
    let dir = tempfile::tempdir().unwrap();
    let (urdf, board) = common::so101_fitted(dir.path());
    let setup_args = ["--urdf", urdf.to_str().unwrap(), "--arm", board.to_str().unwrap(), "--actuator", "sts3215-12v"];
    // The board as chessarm loads it with these flags.
    let arm_toml = common::chessarm_human(&[&setup_args[..], &["arm"]].concat());
    assert!(arm_toml.status.success());
    let setup = Setup::parse(&String::from_utf8(arm_toml.stdout).unwrap()).unwrap();
    let errors = [0.0, 1.5f64.to_radians(), -1f64.to_radians(), 2f64.to_radians()];
    let shift = Vector2::new(0.004, 0.003);
    let turn = (-1.5f64).to_radians();
    let squares = ["a1", "d1", "h1", "a4", "e5", "h4", "a8", "d8", "h8"];
    let mut sim = common::BusSim::start_with_stdin(dir.path(), &setup_args, &[]);
    let out = dir.path().join("cal");
    let squares_arg = squares.join(",");
    let calibrate = ["calibrate", "--zeros", "--port", &sim.device, "--squares", &squares_arg, "--json"];
    let mut child =
        common::spawn(&[&setup_args[..], &calibrate, &["--out", out.to_str().unwrap()]].concat(), Stdio::piped());
    let mut enter = child.stdin.take().unwrap();
    // Each square: the hand puts the tip there (once calibrate has turned the torque off), then
    // Enter. The servos' counts: 4096 a turn.
    std::thread::sleep(std::time::Duration::from_millis(500));
    for square in squares {
        let q = touch(&setup_args, &setup, square, shift, turn, errors, 1e9);
        sim.say(&format!("pose {}", angles(q)));
        std::thread::sleep(std::time::Duration::from_millis(200));
        enter.write_all(b"\n").unwrap();
        std::thread::sleep(std::time::Duration::from_millis(200));
    }
    let output = child.wait_with_output().unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let result: Value = serde_json::from_slice(&output.stdout).unwrap();
    eprintln!("{result}");
    let center = Vector2::new(result["center_m"][0].as_f64().unwrap(), result["center_m"][1].as_f64().unwrap());
    let position_error = (center - (setup.board.center + shift)).norm();
    let yaw_error = (result["yaw_rad"].as_f64().unwrap() - setup.board.yaw - turn).abs().to_degrees();
    assert!(position_error < 0.5e-3 && yaw_error < 0.1, "{position_error} m, {yaw_error}°");
    // The zero errors, each within 0.3°: the bus reads whole counts (0.088°, about 0.3 mm at
    // the tool, uniform: 0.09 mm standard deviation a coordinate), and the fit's smallest
    // singular value (about 0.02 m/rad on this small arm's board: the zeros of the three pitch
    // joints move the tip nearly alike) turns that into about 0.005 rad, 0.3°.
    let fitted: Vec<f64> = result["zero_errors_rad"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    let smallest = result["singular_values"].as_array().unwrap().last().unwrap().as_f64().unwrap();
    eprintln!("zero errors fitted {fitted:?}, true {errors:?}; smallest singular value {smallest}");
    for j in 1..4 {
        assert!((fitted[j] - errors[j]).abs().to_degrees() < 0.3, "joint {}: {fitted:?} vs {errors:?}", j + 1);
    }
    // The servos' zero ticks move by the fitted errors (direction +1, 4096 counts a turn: the
    // true angle is the read one plus the error, so the zero moves down by error / count).
    let count = std::f64::consts::TAU / 4096.0;
    let ticks: Vec<f64> = result["zero_ticks"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    for j in 0..4 {
        assert_eq!(ticks[j], (2048.0 - fitted[j] / count).round(), "joint {}: {ticks:?}", j + 1);
    }
    let saved = std::fs::read_to_string(out.join("setup.toml")).unwrap();
    assert!(saved.contains("zero_ticks"), "{saved}");
}

/// `calibrate --touch …` for `squares`, each touched at the angles `q_of(square)`, into `out`.
fn typed(squares: &[&str], q_of: impl Fn(&str) -> [f64; 4], out: &std::path::Path, extra: &[&str]) -> Vec<String> {
    let mut args = vec!["calibrate".to_string()];
    for square in squares {
        args.push("--touch".into());
        args.push(format!("{square}={}", angles(q_of(square))));
    }
    args.extend(["--out".into(), out.to_str().unwrap().into()]);
    args.extend(extra.iter().map(|s| (*s).to_string()));
    args
}

/// A refusal: exit 2, one line naming every `needle`, and no setup, plot or result in `out`.
fn assert_refused(args: &[String], out: &std::path::Path, needles: &[&str]) {
    let strs: Vec<&str> = args.iter().map(String::as_str).collect();
    common::assert_one_line_error(&chessarm(&strs), needles);
    for file in ["setup.toml", "residuals.png", "calibration.json"] {
        assert!(!out.join(file).exists(), "{file} written by a refused calibration");
    }
}

/// The same angles typed for all four corners (the arm not moved between touches): before,
/// a fit with 297 mm residuals, exit 0 and a setup `board` refuses; now refused before the
/// fit, naming the first pair whose tips are too close for their squares' distance.
#[test]
fn four_identical_touches_are_refused_naming_the_pair() {
    let dir = tempfile::tempdir().unwrap();
    let setup = Setup::load(None).unwrap();
    let q = touch(&[], &setup, "a1", Vector2::zeros(), 0.0, [0.0; 4], 4096.0);
    let out = dir.path().join("cal");
    assert_refused(
        &typed(&["a1", "h1", "h8", "a8"], |_| q, &out, &[]),
        &out,
        &["the touches of a1 and h1", "0.0 mm apart", "420.0 mm apart"],
    );
}

/// Squares on one line (a1, b1, c1, d1, touched exactly where they are): their tips fit a
/// board, but one that could lie tilted across that line unseen: refused, naming them.
#[test]
fn squares_on_one_line_are_refused_naming_them() {
    let dir = tempfile::tempdir().unwrap();
    let setup = Setup::load(None).unwrap();
    let out = dir.path().join("cal");
    let q_of = |square: &str| touch(&[], &setup, square, Vector2::zeros(), 0.0, [0.0; 4], 4096.0);
    assert_refused(
        &typed(&["a1", "b1", "c1", "d1"], q_of, &out, &[]),
        &out,
        &["the touched squares a1, b1, c1, d1 lie on one line"],
    );
}

/// a1 and h1 touched where they are, h8 at the angles of a point on their line 210 mm past
/// h1: every pair of tips at least half its squares' distance apart, but the three tips on
/// one line: refused, naming the three.
#[test]
fn tips_on_one_line_are_refused_naming_the_touches() {
    let dir = tempfile::tempdir().unwrap();
    let setup = Setup::load(None).unwrap();
    let out = dir.path().join("cal");
    let past_h1 = touch(&[], &setup, "h1", Vector2::new(0.21, 0.0), 0.0, [0.0; 4], 1e12);
    let q_of = |square: &str| {
        if square == "h8" { past_h1 } else { touch(&[], &setup, square, Vector2::zeros(), 0.0, [0.0; 4], 1e12) }
    };
    assert_refused(
        &typed(&["a1", "h1", "h8"], q_of, &out, &[]),
        &out,
        &["the touches of a1, h1 and h8", "nearly on one line"],
    );
}

/// Touches that span the board but disagree with it: before, exit 0 with residuals of
/// hundreds of mm; now refused naming the worst touch, its residual and the bound. Honest
/// touches (read in counts, residuals up to 0.2 mm) pass the default 2.5 mm, and fail a bound
/// below their worst residual; the bound itself is checked as typed.
#[test]
fn residuals_above_the_bound_are_refused_naming_the_worst_touch() {
    let dir = tempfile::tempdir().unwrap();
    let setup = Setup::load(None).unwrap();
    let out = dir.path().join("cal");
    // Angles no hand would read at these squares (each joint well inside its range).
    let random = |square: &str| match square {
        "a1" => [0.3, 1.1, -0.4, 2.0],
        "h1" => [-1.2, 0.2, 1.5, -0.7],
        "h8" => [2.2, -0.9, 0.6, 0.1],
        _ => [1.0, 0.5, -2.5, 1.3],
    };
    assert_refused(
        &typed(&["a1", "h1", "h8", "a8"], random, &out, &[]),
        &out,
        &["the touch of h1 is 641.47 mm", "above --max-residual-mm 2.5"],
    );
    // a1's and h1's angles swapped: every distance between tips is one the board has, but no
    // pose puts all four on their squares.
    let shift = Vector2::new(0.0048, -0.0064);
    let turn = 2f64.to_radians();
    let honest = |square: &str| touch(&[], &setup, square, shift, turn, [0.0; 4], 4096.0);
    let swapped = |square: &str| match square {
        "a1" => honest("h1"),
        "h1" => honest("a1"),
        other => honest(other),
    };
    assert_refused(&typed(&["a1", "h1", "h8", "a8"], swapped, &out, &[]), &out, &["--max-residual-mm 2.5", "mm from"]);
    // The honest touches: written at the default bound; at 0.1 mm, below their worst residual
    // (about 0.2 mm: a count of 1.5 mrad moves the tip 0.1–0.3 mm), refused naming that touch.
    let good = typed(&["a1", "h1", "h8", "a8"], honest, &out, &[]);
    let strs: Vec<&str> = good.iter().map(String::as_str).collect();
    let result = common::json_of(&chessarm(&strs));
    let worst = result["largest_residual_mm"].as_f64().unwrap();
    assert!(worst > 0.1 && worst < 0.5, "{worst}");
    let worst_square = result["touches"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| {
            let r = common::numbers(&t["residual_mm"]);
            ((r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt() - worst).abs() < 1e-9
        })
        .unwrap()["square"]
        .as_str()
        .unwrap()
        .to_string();
    let strict = dir.path().join("strict");
    assert_refused(
        &typed(&["a1", "h1", "h8", "a8"], honest, &strict, &["--max-residual-mm", "0.1"]),
        &strict,
        &[&format!("the touch of {worst_square} is {worst:.2} mm"), "above --max-residual-mm 0.1"],
    );
    for bad in ["0", "-1", "nan", "2.5mm"] {
        assert_refused(
            &typed(&["a1", "h1", "h8", "a8"], honest, &strict, &["--max-residual-mm", bad]),
            &strict,
            &["--max-residual-mm", &format!("'{bad}'")],
        );
    }
}

/// A board touched 30 mm nearer the base than the setup's: the touches fit it (residuals
/// under 0.01 mm), but its reserve slots then pass within the base's own room, so `board` and
/// `play` would refuse the setup written: refused with that reason, nothing written.
#[test]
fn a_fitted_board_the_arm_does_not_serve_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let setup = Setup::load(None).unwrap();
    let out = dir.path().join("cal");
    let nearer = |square: &str| touch(&[], &setup, square, Vector2::new(0.0, -0.03), 0.0, [0.0; 4], 1e12);
    assert_refused(
        &typed(&["a1", "h1", "h8", "a8"], nearer, &out, &[]),
        &out,
        &["the fitted board (centre (0.0, 300.0) mm", "is not served", "base_clearance"],
    );
}

/// Over the simulated bus, Enter pressed four times without moving the arm: the four touches
/// read the same pose. Before, a fit with 75 mm residuals and exit 0; now refused naming the
/// first two squares, with no setup written into --out (only the bus log).
#[test]
fn pressing_enter_four_times_without_moving_the_arm_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (urdf, board) = common::so101_fitted(dir.path());
    let setup_args = ["--urdf", urdf.to_str().unwrap(), "--arm", board.to_str().unwrap(), "--actuator", "sts3215-12v"];
    let sim = common::BusSim::start_with_stdin(dir.path(), &setup_args, &[]);
    let out = dir.path().join("cal");
    let calibrate = ["calibrate", "--port", &sim.device, "--json", "--out", out.to_str().unwrap()];
    let mut child = common::spawn(&[&setup_args[..], &calibrate].concat(), Stdio::piped());
    let mut enter = child.stdin.take().unwrap();
    for _ in 0..4 {
        std::thread::sleep(std::time::Duration::from_millis(200));
        enter.write_all(b"\n").unwrap();
    }
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr} {}", String::from_utf8_lossy(&output.stdout));
    let last = stderr.trim_end().lines().last().unwrap();
    assert!(last.starts_with("error: the touches of a1 and h1 put the tool tip 0.0 mm apart"), "{stderr}");
    for file in ["setup.toml", "residuals.png", "calibration.json"] {
        assert!(!out.join(file).exists(), "{file} written by a refused calibration");
    }
    assert!(output.stdout.is_empty(), "{}", String::from_utf8_lossy(&output.stdout));
}
