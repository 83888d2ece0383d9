//! Servos on the command line: `--actuator` (a built-in servo or a setup's `[actuators.NAME]`),
//! `--servo-command` compared in `simulate`, a game on the SO-101's fitted board with its
//! STS3215s, and the refusals a user meets.

#![allow(clippy::unwrap_used)]

mod common;

use common::{assert_one_line_error, chessarm, json_of, so101_fitted};
use std::path::Path;

use common::OPERA;

/// An XM430 on 48 V with a 20 N·m current limit: a servo strong enough for the report's arm
/// (the built-in ones stall under it), given as a user's table over a built-in.
const BIG_SERVO: &str = "[actuators.big]\nbase = \"xm430\"\nsupply_voltage = 48.0\nmax_torque = 20.0\n";

/// The three host strategies on the report's scenario: each runs, and the goals that carry the
/// arm's dynamics track best (RMS tip error feedforward < sag < plain); a host has no gains.
#[test]
fn simulate_compares_the_hosts_goal_strategies() {
    let dir = tempfile::tempdir().unwrap();
    let setup = dir.path().join("big.toml");
    std::fs::write(&setup, BIG_SERVO).unwrap();
    let out = dir.path().join("out");
    let json = json_of(&chessarm(&[
        "--arm",
        setup.to_str().unwrap(),
        "--actuator",
        "big",
        "--servo-command",
        "plain,sag,feedforward",
        "simulate",
        "--out",
        out.to_str().unwrap(),
    ]));
    let runs = json["summary"]["controllers"].as_array().unwrap();
    let names: Vec<&str> = runs.iter().map(|r| r["controller"].as_str().unwrap()).collect();
    assert_eq!(names, ["plain", "sag", "feedforward"]);
    let rms: Vec<f64> = runs.iter().map(|r| r["rms_tip_error_mm"].as_f64().unwrap()).collect();
    assert!(rms[2] < rms[1] && rms[1] < rms[0], "RMS tip error mm plain, sag, feedforward: {rms:?}");
    for run in runs {
        assert!(run["gains"].is_null() && run["closed_loop_poles"].is_null());
        assert_eq!(run["servo_command"], run["controller"]);
    }
    assert!(out.join("feedforward.csv").is_file());
}

/// The maker's case: the SO-101 as published, its fitted board, STS3215 (12 V) servos and
/// feedforward goals at 100 Hz: the Opera game with every piece in place.
#[test]
fn the_so101_with_its_sts3215s_plays_the_opera_game() {
    let dir = tempfile::tempdir().unwrap();
    let (urdf, board) = so101_fitted(dir.path());
    let mut setup = std::fs::read_to_string(&board).unwrap();
    setup.push_str(
        "\n[servo_bus]\nids = [11, 12, 13, 14]\ndirections = [1, -1, 1, 1]\nzero_ticks = [2048, 2000, 2048, 2100]\n",
    );
    std::fs::write(&board, setup).unwrap();
    let out = dir.path().join("game");
    let game = chessarm(&[
        "--urdf",
        urdf.to_str().unwrap(),
        "--arm",
        board.to_str().unwrap(),
        "--actuator",
        "sts3215-12v",
        "--servo-command",
        "feedforward",
        "play",
        OPERA,
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(game.status.success(), "{}", String::from_utf8_lossy(&game.stderr));
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("game.json")).unwrap()).unwrap();
    assert_eq!(report["controller"], "feedforward");
    assert_eq!(report["misplaced"].as_array().unwrap().len(), 0);
    // The 3D replay of the servo arm's game, as of a torque arm's.
    let replay = std::fs::read_to_string(out.join("replay.html")).unwrap();
    assert_eq!(replay.matches("\"by\":\"robot\"").count(), report["moves"].as_array().unwrap().len());
    // The fine points wait for the servos to stop within the band they can hold (their counts,
    // deadband and friction: wider than the 0.5 mm a torque arm's encoders give, at most the
    // 5 mm tolerance), and none waits out its timeout.
    let gate = &report["in_position"];
    let band = gate["tip_band_mm"].as_f64().unwrap();
    assert!(band > 0.5 && band <= 5.0, "{gate}");
    assert_eq!(gate["waits"]["timed_out"], 0, "{gate}");
    let errors: Vec<f64> = report["moves"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|m| m["place_errors_mm"].as_array().unwrap().iter().map(|e| e.as_f64().unwrap()))
        .collect();
    // Every piece within the game's 5 mm tolerance, and the servos leave some error (this is
    // not the torque plant's 0.001 mm).
    let worst = errors.iter().copied().fold(0.0, f64::max);
    assert!(worst < 5.0 && worst > 0.05, "largest placement error {worst} mm");
    // The goals the host sent, per move, in radians and in the servos' ticks of the setup's
    // [servo_bus]: every bus period's goal as the move's record has it (the move CSV keeps every
    // 10th 1 ms step, the bus's 100 Hz), each tick `zero + direction × goal / count` exactly.
    let hardware = out.join("hardware");
    let bus: serde_json::Value =
        serde_json::from_slice(&std::fs::read(hardware.join("servo_bus.json")).unwrap()).unwrap();
    assert_eq!(bus["joints"][1]["id"], 12);
    assert_eq!(bus["joints"][1]["joint"], "shoulder_lift");
    let count = std::f64::consts::TAU / 4096.0;
    let (zero, direction) = ([2048.0, 2000.0, 2048.0, 2100.0], [1.0, -1.0, 1.0, 1.0]);
    for (ply, uci) in [(1, "e2e4"), (33, "d1d8")] {
        let read = |name: &str| -> (Vec<String>, Vec<Vec<f64>>) {
            let mut reader = csv::Reader::from_path(name).unwrap();
            let header = reader.headers().unwrap().iter().map(String::from).collect();
            let rows = reader.records().map(|r| r.unwrap().iter().map(|v| v.parse().unwrap()).collect()).collect();
            (header, rows)
        };
        let (header, goals) = read(hardware.join(format!("{ply:03}-{uci}-goals.csv")).to_str().unwrap());
        assert_eq!(
            header[..9],
            ["t", "goal1", "goal2", "goal3", "goal4", "goal1_ticks", "goal2_ticks", "goal3_ticks", "goal4_ticks"]
        );
        let (header, records) = read(out.join("moves").join(format!("{ply:03}-{uci}.csv")).to_str().unwrap());
        let goal_column = header.iter().position(|h| h == "goal1").unwrap();
        assert_eq!(goals.len(), records.len(), "ply {ply}");
        for (goal, record) in goals.iter().zip(&records) {
            assert_eq!(goal[1..5], record[goal_column..goal_column + 4], "ply {ply} at {} s", goal[0]);
            for j in 0..4 {
                let counts = goal[1 + j] / count;
                assert!((counts - counts.round()).abs() < 1e-6, "a goal in whole counts: {counts}");
                assert_eq!(goal[5 + j], zero[j] + direction[j] * counts.round());
            }
        }
    }
}

/// A maker's spread (servo windings, supply, gear friction, 0–2° backlash, link and piece
/// masses) under hobby sensors: robustness draws each trial's servos (their draws in the CSV,
/// within the file's ranges), feedforward places every piece, and the worst trial's replay
/// command (with the URDF's lock and the servos) gives that trial's placement error exactly.
#[test]
fn robustness_draws_the_servos_per_trial_and_replays_the_worst() {
    let dir = tempfile::tempdir().unwrap();
    let (urdf, board) = so101_fitted(dir.path());
    let spread = dir.path().join("hobby.toml");
    std::fs::write(
        &spread,
        "link_mass = 0.1\npiece_mass = 0.3\ntorque_constant = 0.1\nwinding_resistance = 0.15\n\
         supply_voltage = 0.08\ngear_friction = 0.5\nbacklash = [0.0, 0.035]\n",
    )
    .unwrap();
    let out = dir.path().join("study");
    let (urdf, board, spread, out) =
        (urdf.to_str().unwrap(), board.to_str().unwrap(), spread.to_str().unwrap(), out.to_str().unwrap());
    let study = json_of(&chessarm(&[
        "--urdf",
        urdf,
        "--arm",
        board,
        "--lock",
        "wrist_roll=0",
        "--actuator",
        "sts3215-12v",
        "--servo-command",
        "plain,feedforward",
        "robustness",
        OPERA,
        "--trials",
        "3",
        "--sensors",
        "hobby",
        "--uncertainty",
        spread,
        "--out",
        out,
    ]));
    let controllers = study["summary"]["controllers"].as_array().unwrap();
    assert_eq!(controllers.len(), 2);
    let ff = &controllers[1];
    assert_eq!(ff["controller"], "feedforward");
    let mut rows = csv::Reader::from_path(Path::new(out).join("robustness.csv")).unwrap();
    let header = rows.headers().unwrap().clone();
    let column = |name: &str| header.iter().position(|h| h == name).unwrap_or_else(|| panic!("no column {name}"));
    let records: Vec<csv::StringRecord> = rows.records().map(|r| r.unwrap()).collect();
    assert_eq!(records.len(), 6);
    // Feedforward places every piece in every trial. The needle fingers, opened 1.5 mm beside a
    // piece (all the 15 mm squares leave them), are touched by the servos' tracking error:
    // plain goals, which leave the arm sagging by millimetres, touch on many moves, feedforward
    // on few; a trial with a contact is no success.
    let contacts = |host: &str| -> Vec<usize> {
        records
            .iter()
            .filter(|r| &r[column("controller")] == host)
            .map(|r| r[column("contacts")].parse().unwrap())
            .collect()
    };
    for record in records.iter().filter(|r| &r[column("controller")] == "feedforward") {
        assert_eq!(&record[column("misplaced")], "0");
    }
    let (plain, feedforward) = (contacts("plain"), contacts("feedforward"));
    assert!(feedforward.iter().sum::<usize>() < plain.iter().sum::<usize>(), "{plain:?} vs {feedforward:?}");
    let clean = feedforward.iter().filter(|c| **c == 0).count() as f64 / feedforward.len() as f64;
    assert_eq!(ff["success_rate"].as_f64().unwrap(), clean);
    assert_eq!(ff["contacts"].as_u64().unwrap() as usize, feedforward.iter().sum::<usize>());
    for record in &records {
        let number = |name: &str| record[column(name)].parse::<f64>().unwrap();
        assert!((number("supply_voltage_scale") - 1.0).abs() <= 0.08);
        for j in 1..=4 {
            assert!((0.0..=0.035).contains(&number(&format!("backlash_rad_{j}"))));
            assert!((number(&format!("torque_constant_scale_{j}")) - 1.0).abs() <= 0.1);
        }
    }
    // The replay of feedforward's worst trial, as the study prints it (its --out in this
    // test's folder), places the pieces as that trial did.
    let replay = ff["replay_worst_trial"].as_str().unwrap();
    assert!(replay.contains("--actuator sts3215-12v") && replay.contains("--servo-command feedforward"), "{replay}");
    assert!(replay.contains("--lock wrist_roll=0"), "{replay}");
    let words: Vec<&str> = replay.split_whitespace().skip(1).collect();
    let replayed = chessarm(&words);
    assert!(replayed.status.success(), "{}", String::from_utf8_lossy(&replayed.stderr));
    let folder = words[words.iter().position(|w| *w == "--out").unwrap() + 1];
    let game: serde_json::Value =
        serde_json::from_slice(&std::fs::read(Path::new(folder).join("game.json")).unwrap()).unwrap();
    let worst = game["moves"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|m| m["place_errors_mm"].as_array().unwrap().iter().map(|e| e.as_f64().unwrap()))
        .fold(0.0, f64::max);
    assert_eq!(worst, ff["place_error_mm"]["max"].as_f64().unwrap());
    // A servo's spread on torque motors is refused by its field.
    assert_one_line_error(
        &chessarm(&["robustness", "--trials", "1", "--uncertainty", spread, "--out", out]),
        &["uncertainty.torque_constant", "no joint has a servo"],
    );
}

/// tune with servos sweeps their P register for each host strategy on the SO-101's Opera
/// game: a stiffer loop sags less (each strategy places better at P 32 than at P 8), the goals
/// that carry the dynamics place better than plain ones at the same P, the best pick at the
/// edge of the range is said, and the torque controllers' gains are refused.
#[test]
fn tune_sweeps_the_servos_p_register_and_host_strategies() {
    let dir = tempfile::tempdir().unwrap();
    let (urdf, board) = so101_fitted(dir.path());
    let out = dir.path().join("tune");
    let (urdf, board, out) = (urdf.to_str().unwrap(), board.to_str().unwrap(), out.to_str().unwrap());
    let servo = ["--urdf", urdf, "--arm", board, "--actuator", "sts3215-12v"];
    let sweep = json_of(&chessarm(
        &[
            &servo[..],
            &["--servo-command", "plain,feedforward", "tune", OPERA, "--p-gain", "8..32:2", "--metric", "place-error"],
            &["--out", out],
        ]
        .concat(),
    ));
    assert_eq!(sweep["candidates"], 4);
    let mut reader = csv::Reader::from_path(Path::new(out).join("tune.csv")).unwrap();
    assert_eq!(reader.headers().unwrap().iter().take(3).collect::<Vec<_>>(), ["index", "servo_command", "p_gain"]);
    // At P 8 a strategy may stop part-way: the pieces it put down millimetres off leave a later
    // move no room for the needle fingers, and the planner refuses that move (placed worse
    // than at P 32 either way).
    let place: Vec<(String, f64, f64)> = reader
        .records()
        .map(|r| {
            let r = r.unwrap();
            let p: f64 = r[2].parse().unwrap();
            let error = if &r[3] == "ok" {
                r[6].parse().unwrap()
            } else {
                assert!(p == 8.0 && r[3].contains("would come") && r[3].contains("nothing was run"), "{r:?}");
                f64::INFINITY
            };
            (r[1].to_string(), p, error)
        })
        .collect();
    let at = |host: &str, p: f64| place.iter().find(|(h, g, _)| h == host && *g == p).unwrap().2;
    for host in ["plain", "feedforward"] {
        assert!(at(host, 32.0) < at(host, 8.0), "{host}: {place:?}");
    }
    assert!(at("feedforward", 32.0) < at("plain", 32.0), "{place:?}");
    let best = &sweep["best"][0];
    assert_eq!((best["servo_command"].as_str(), best["p_gain"].as_f64()), (Some("feedforward"), Some(32.0)));
    assert!(Path::new(out).join("tune.png").is_file());
    // (The report's arm: the SO-101's URDF notes would be more lines on stderr.)
    assert_one_line_error(
        &chessarm(&["--actuator", "sts3215", "tune", "--kp", "1..2:2", "--kd", "1..2:2", "--out", out]),
        &["--kp, --kd and --ki are a torque controller's", "--p-gain"],
    );
    assert_one_line_error(
        &chessarm(&["tune", "--p-gain", "8..32:2", "--out", out]),
        &["--p-gain sweeps servos' P register", "--actuator"],
    );
}

/// An independent model of the servo: MuJoCo's position actuator with the same gain
/// (`kp kt V / R`), damping (`kt²/R`) and force range, on the arm of chessarm's URDF, fed the
/// goals chessarm's host sent (crates/cli/tests/mujoco/check_servo.py), against chessarm's servo
/// reduced to that ideal law (no counts, deadband, friction, backlash or armature; 0.1 ms
/// firmware period and steps). chessarm holds the P term over each firmware period (its encoder
/// is read at the period's start) where MuJoCo's RK4 re-evaluates it at every stage: the P
/// term lags by up to a period, so the torques may differ by `kp |q̇| dt` and the angles by
/// `|q̇| dt`, at the run's largest speed. The settled start is the closed form's sag `g(q)/kp`.
#[test]
#[cfg_attr(not(tool_python), ignore = "needs CHESSARM_PYTHON, a Python with mujoco; see docs/testing.md")]
fn mujoco_position_actuators_follow_the_same_goals_as_the_ideal_servo() {
    let python = common::python_with_mujoco().expect("CHESSARM_PYTHON (or python3) with mujoco installed");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mujoco/check_servo.py");
    let dir = tempfile::tempdir().unwrap();
    let output = std::process::Command::new(&python)
        .arg(&script)
        .arg(env!("CARGO_BIN_EXE_chessarm"))
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let report: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    eprintln!("mujoco servo: {report}");
    let number = |key: &str| report[key].as_f64().unwrap();
    let (speed, dt, kp) = (number("largest_speed_rad_per_s"), number("dt_s"), number("kp_nm_per_rad"));
    assert!(number("steps") > 100_000.0 && speed > 0.5, "{report}");
    assert!(number("largest_angle_difference_rad") <= speed * dt, "{report}");
    assert!(number("largest_torque_difference_nm") <= kp * speed * dt, "{report}");
    // The comparison means something: the arm moved by radians and held torques of N·m.
    assert!(number("largest_angle_rad") > 1.0 && number("largest_torque_nm") > 1.0, "{report}");
    assert_eq!(report["saturated_steps_mujoco"], 0);
    for (sag, closed) in
        common::numbers(&report["start_sag_rad"]).iter().zip(common::numbers(&report["start_sag_closed_form_rad"]))
    {
        assert!((sag - closed).abs() <= 1e-9 * closed.abs().max(1e-6), "{report}");
    }
}

/// A user's stepper as an `[actuators.NAME]` table over the built-in NEMA 17 (a 10.36:1 gear,
/// 3.7 N·m held): the SO-101's sag map takes it, each joint's lag the load angle
/// `asin(τ / τ_hold) / n` (`n = steps/4 × gear`) and its headroom `1 − |τ| / τ_hold`.
#[test]
fn a_users_stepper_table_holds_the_load_at_its_load_angle() {
    let dir = tempfile::tempdir().unwrap();
    let (urdf, board) = so101_fitted(dir.path());
    let mut setup = std::fs::read_to_string(&board).unwrap();
    setup.push_str("\n[actuators.geared]\nbase = \"nema17\"\ngear_ratio = 10.36\nholding_torque = 3.7\n");
    std::fs::write(&board, setup).unwrap();
    let map = json_of(&chessarm(&[
        "--urdf",
        urdf.to_str().unwrap(),
        "--arm",
        board.to_str().unwrap(),
        "--actuator",
        "geared",
        "board",
    ]));
    let electrical = 200.0 / 4.0 * 10.36;
    let mut checked = 0;
    for square in map["sag"]["squares"].as_array().unwrap() {
        for piece in square["pieces"].as_array().unwrap() {
            let (load, sag, headroom) = (
                common::numbers(&piece["load_nm"]),
                common::numbers(&piece["sag_rad"]),
                common::numbers(&piece["headroom"]),
            );
            for j in 0..4 {
                let lag = (load[j] / 3.7).asin() / electrical;
                assert!((sag[j] - lag).abs() < 1e-9, "joint {j}: sag {} against {lag}", sag[j]);
                assert!((headroom[j] - (1.0 - load[j].abs() / 3.7)).abs() < 1e-12);
                checked += 1;
            }
        }
    }
    assert!(checked >= 4 * 6 * 32, "{checked}");
}

#[test]
fn bad_actuator_input_is_refused_with_its_name() {
    assert_one_line_error(
        &chessarm(&["--actuator", "sts9999", "simulate", "--out", "/nonexistent/x"]),
        &["--actuator = \"sts9999\"", "sts3215", "xm430", "nema17", "torque"],
    );
    assert_one_line_error(
        &chessarm(&["--actuator", "torque,sts3215,sts3215,sts3215", "fk", "--q", "0,0,0,0"]),
        &["joint 2 has a servo or stepper and joint 1 a torque motor"],
    );
    assert_one_line_error(
        &chessarm(&["--actuator", "sts3215,xm430", "fk", "--q", "0,0,0,0"]),
        &["--actuator has 2 names"],
    );
    assert_one_line_error(
        &chessarm(&["--servo-command", "sag", "fk", "--q", "0,0,0,0"]),
        &["--servo-command and --bus-rate are for servos"],
    );
    let dir = tempfile::tempdir().unwrap();
    for (text, needles) in [
        ("[actuators.sts3215]\nbase = \"xm430\"\n", vec!["actuators.sts3215: a built-in actuator has this name"]),
        ("[actuators.mine]\nbase = \"xm430\"\nbacklash = -0.1\n", vec!["actuators.mine.backlash = -0.1"]),
        ("[actuators.mine]\nsupply_voltage = 12.0\n", vec!["actuators.mine.kp is missing", "base = \"NAME\""]),
        ("[actuators.mine]\nbase = \"xm430\"\np_gain = 400\nkp = 3\n", vec!["not both"]),
        (
            "[actuators.mine]\nbase = \"nema17\"\nkp = 3\n",
            vec!["actuators.mine.kp is a servo's; this table is a stepper's (base = \"nema17\")"],
        ),
        ("[actuators.mine]\nbase = \"xm430\"\ngear_ratio = 3\n", vec!["actuators.mine.base = \"xm430\" is a servo"]),
        ("[actuators.mine]\ngear_ratio = 3\n", vec!["actuators.mine.steps_per_revolution is missing", "nema17"]),
        ("[actuators.mine]\nbase = \"nema17\"\nholding_torque = -1\n", vec!["actuators.mine.holding_torque = -1"]),
    ] {
        let path = dir.path().join("setup.toml");
        std::fs::write(&path, text).unwrap();
        assert_one_line_error(&chessarm(&["--arm", path.to_str().unwrap(), "fk", "--q", "0,0,0,0"]), &needles);
    }
    // A bus that cannot address the servos is refused before the game runs.
    for (table, needles) in [
        ("ids = [1, 1, 2, 3]", vec!["servo_bus.ids = [1, 1, 2, 3]", "distinct"]),
        ("directions = [1, 2, 1, 1]", vec!["servo_bus.directions", "2 is not 1 or -1"]),
        ("zero_ticks = [2048, 2048]", vec!["servo_bus.zero_ticks has 2 values"]),
        ("zero_ticks = [0, 2048, 2048, 2048]", vec!["servo_bus.zero_ticks = 0", "joint 1's limits", "outside"]),
        ("directions = [-128, 1, 1, 1]", vec!["servo_bus.directions", "-128 is not 1 or -1"]),
    ] {
        let path = dir.path().join("bus.toml");
        std::fs::write(&path, format!("actuator = \"xm430\"\n[servo_bus]\n{table}\n")).unwrap();
        let out = dir.path().join("game");
        assert_one_line_error(
            &chessarm(&["--arm", path.to_str().unwrap(), "play", "--moves", "e4", "--out", out.to_str().unwrap()]),
            &needles,
        );
        assert!(!out.join("game.json").exists());
    }
}

/// The sag map of the SO-101 on its fitted board with STS3215s: every square reached; each
/// joint's sag is its gravity torque over the servo's stiffness `kp kt V / R` (the closed form
/// of the P loop at rest), and the headroom `1 − |g| / τ_stall`; the map is drawn.
#[test]
fn the_sag_map_gives_each_squares_sag_and_headroom() {
    use chessarm_core::sim::actuator::profiles;
    let dir = tempfile::tempdir().unwrap();
    let (urdf, board) = so101_fitted(dir.path());
    let png = dir.path().join("sag.png");
    let json = json_of(&chessarm(&[
        "--urdf",
        urdf.to_str().unwrap(),
        "--arm",
        board.to_str().unwrap(),
        "--actuator",
        "sts3215-12v",
        "board",
        "--sag-map",
        png.to_str().unwrap(),
    ]));
    assert!(std::fs::metadata(&png).unwrap().len() > 10_000);
    let spec = profiles::profile("sts3215-12v").unwrap().spec;
    let squares = json["sag"]["squares"].as_array().unwrap();
    assert_eq!(squares.len(), 64);
    let mut largest: f64 = 0.0;
    for square in squares {
        assert_eq!(square["reached"], true, "{square}");
        for piece in square["pieces"].as_array().unwrap() {
            for j in 0..4 {
                let sag = piece["sag_rad"][j].as_f64().unwrap();
                let load = piece["load_nm"][j].as_f64().unwrap();
                let headroom = piece["headroom"][j].as_f64().unwrap();
                // Settled to 1e-12 rad by the fixed point; the closed form to its rounding.
                assert!((sag - load / spec.stiffness()).abs() < 1e-9, "{}: sag {sag} vs {load} N·m", square["square"]);
                assert!((headroom - (1.0 - load.abs() / spec.stall_torque())).abs() < 1e-12);
            }
            largest = largest.max(piece["error_mm"].as_f64().unwrap());
        }
    }
    // The SO-101 sags by millimetres on STS3215s: the map is not of a stiff arm.
    assert!(largest > 1.0 && largest < 50.0, "largest tip error {largest} mm");
    assert_one_line_error(
        &chessarm(&["board", "--sag-map", png.to_str().unwrap()]),
        &["--sag-map is for servos or steppers"],
    );
}
