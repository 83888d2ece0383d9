//! Trajectories for real hardware: `plan` and `play` write, per robot move, the planned joint
//! motion at `--export-rate` Hz with the gripper's commands, as ROS 2 JointTrajectory JSON and
//! as CSV with a gripper column.

#![allow(clippy::unwrap_used)]

mod common;

use common::{assert_one_line_error, chessarm, json_of, numbers};
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::Path;

use common::json_file as read_json;

/// Rows of a CSV as (header, rows of strings).
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let mut reader = csv::Reader::from_path(path).unwrap();
    let header = reader.headers().unwrap().iter().map(String::from).collect();
    let rows = reader.records().map(|r| r.unwrap().iter().map(String::from).collect()).collect();
    (header, rows)
}

fn seconds(duration: &Value) -> f64 {
    duration["sec"].as_i64().unwrap() as f64 + duration["nanosec"].as_i64().unwrap() as f64 * 1e-9
}

/// Checks one move's pair of files against each other and the ROS 2 layout; returns the JSON.
fn check_move_files(dir: &Path, stem: &str, rate: f64, joint_names: &[&str]) -> Value {
    let value = read_json(&dir.join(format!("{stem}.json")));
    let trajectory = &value["trajectory"];
    // Exactly the fields of trajectory_msgs/msg/JointTrajectory and JointTrajectoryPoint.
    let keys = |v: &Value| v.as_object().unwrap().keys().cloned().collect::<BTreeSet<_>>();
    assert_eq!(keys(trajectory), ["header", "joint_names", "points"].map(String::from).into());
    assert_eq!(keys(&trajectory["header"]), ["frame_id", "stamp"].map(String::from).into());
    assert_eq!(trajectory["header"]["frame_id"], "base_link", "{stem}: the base frame (the URDF's root link)");
    let names: Vec<&str> = trajectory["joint_names"].as_array().unwrap().iter().map(|n| n.as_str().unwrap()).collect();
    assert_eq!(names, joint_names);
    let points = trajectory["points"].as_array().unwrap();
    let (header, rows) = read_csv(&dir.join(format!("{stem}.csv")));
    assert_eq!(
        header.join(","),
        "t,q1,q2,q3,q4,qd1,qd2,qd3,qd4,qdd1,qdd2,qdd3,qdd4,gripper,piece",
        "{stem}.csv header"
    );
    assert_eq!(points.len(), rows.len(), "{stem}: one CSV row per point");
    let commands = value["gripper"].as_array().unwrap();
    assert_eq!(commands.len() % 2, 0, "{stem}: a close and an open per piece");
    let command_times: Vec<f64> = commands.iter().map(|c| c["t"].as_f64().unwrap()).collect();
    let mut previous = -1.0;
    for (point, row) in points.iter().zip(&rows) {
        assert_eq!(
            keys(point),
            ["accelerations", "effort", "positions", "time_from_start", "velocities"].map(String::from).into()
        );
        let t: f64 = row[0].parse().unwrap();
        let stamp = seconds(&point["time_from_start"]);
        assert!((stamp - t).abs() <= 0.5e-9, "{stem}: time_from_start {stamp} for t = {t}");
        assert!(point["time_from_start"]["nanosec"].as_i64().unwrap() < 1_000_000_000);
        assert!(t > previous, "{stem}: times increase ({previous} then {t})");
        // Every sample is on the rate's grid, or is a gripper command's instant, or the end.
        let on_grid = ((t * rate).round() - t * rate).abs() < 1e-6;
        let is_command = command_times.iter().any(|c| (c - t).abs() < 1e-9);
        assert!(on_grid || is_command || std::ptr::eq(point, points.last().unwrap()), "{stem}: t = {t} off the grid");
        previous = t;
        for (field, offset) in [("positions", 1), ("velocities", 5), ("accelerations", 9)] {
            let json_values = numbers(&point[field]);
            let csv_values: Vec<f64> = row[offset..offset + 4].iter().map(|v| v.parse().unwrap()).collect();
            assert_eq!(json_values, csv_values, "{stem} {field} at t = {t}: JSON and CSV differ");
        }
        assert_eq!(point["effort"].as_array().unwrap().len(), 0);
        // The gripper is closed from a close command (inclusive) to its open command.
        let closed = commands
            .chunks(2)
            .position(|pair| pair[0]["t"].as_f64().unwrap() <= t + 1e-9 && t + 1e-9 < pair[1]["t"].as_f64().unwrap());
        assert_eq!(row[13], if closed.is_some() { "closed" } else { "open" }, "{stem} gripper at t = {t}");
        let piece = closed.map_or("", |k| commands[2 * k]["piece"].as_str().unwrap());
        assert_eq!(row[14], piece, "{stem} piece at t = {t}");
    }
    for t in &command_times {
        assert!(rows.iter().any(|r| (r[0].parse::<f64>().unwrap() - t).abs() < 1e-12), "{stem}: no row at command {t}");
    }
    // The grid is complete: one sample per 1/rate up to the end.
    let end: f64 = rows.last().unwrap()[0].parse().unwrap();
    let grid = rows.iter().filter(|r| {
        let t: f64 = r[0].parse().unwrap();
        ((t * rate).round() - t * rate).abs() < 1e-6
    });
    assert_eq!(grid.count(), (end * rate + 1e-9).floor() as usize + 1, "{stem}: grid samples");
    value
}

/// `(t, [q, qd, qdd])` rows of a numeric CSV, from column `first` on.
fn numeric_rows(path: &Path, first: usize, count: usize) -> Vec<(f64, Vec<f64>)> {
    let (_, rows) = read_csv(path);
    rows.iter()
        .map(|r| (r[0].parse().unwrap(), r[first..first + count].iter().map(|v| v.parse().unwrap()).collect()))
        .collect()
}

#[test]
fn plan_writes_each_moves_planned_trajectory_with_its_gripper_commands() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plan");
    // 3. exd5 is a capture: two pieces, two grips, in one move.
    let report = json_of(&chessarm(&["plan", "--moves", "e4 d5 exd5", "--out", out.to_str().unwrap()]));
    let hardware = out.join("hardware");
    let joint = numeric_rows(&out.join("joint.csv"), 1, 12);
    for (index, stem) in ["001-e2e4", "002-d7d5", "003-e4d5"].iter().enumerate() {
        let value = check_move_files(&hardware, stem, 100.0, &["joint1", "joint2", "joint3", "joint4"]);
        let summary = &report["moves"][index];
        assert_eq!(value["move"]["san"], summary["san"]);
        let start = summary["start_s"].as_f64().unwrap();
        let duration = summary["duration_s"].as_f64().unwrap();
        let (_, rows) = read_csv(&hardware.join(format!("{stem}.csv")));
        let end: f64 = rows.last().unwrap()[0].parse().unwrap();
        assert!((end - duration).abs() < 1e-12, "{stem}: ends at {end}, the move at {duration}");
        // The same planned motion as joint.csv (5 ms samples of the whole plan): equal q, q̇, q̈
        // wherever the times meet (the rounding of t is ~1e-16 s: 1e-9 is far above it).
        // At a gripper command the tool comes to rest or starts off: q̈ jumps there, and either
        // side's value is the plan's, so q̈ is compared at the other instants only.
        let commands: Vec<f64> =
            value["gripper"].as_array().unwrap().iter().map(|c| c["t"].as_f64().unwrap()).collect();
        let mut met = 0;
        for row in &rows {
            let t: f64 = row[0].parse().unwrap();
            // The move's ends too: joint.csv holds the neighbouring move's sample at the same instant.
            let jump = commands.iter().any(|c| (c - t).abs() < 1e-9) || t == 0.0 || (t - end).abs() < 1e-9;
            let columns = if jump { 8 } else { 12 };
            if let Some((_, planned)) = joint.iter().find(|(tj, _)| (tj - start - t).abs() < 1e-9) {
                let values = row[1..=columns].iter().map(|v| v.parse::<f64>().unwrap());
                for (k, (got, want)) in values.zip(planned).enumerate() {
                    assert!((got - want).abs() < 1e-9, "{stem} column {} at t = {t}: {got} vs {want}", k + 1);
                }
                met += 1;
            }
        }
        // All but the commands' instants and the end, which need not lie on joint.csv's 5 ms grid.
        assert!(met + commands.len() + 1 >= rows.len(), "{stem}: only {met} of {} samples met joint.csv", rows.len());
    }
    let capture = read_json(&hardware.join("003-e4d5.json"));
    let pieces: Vec<&str> =
        capture["gripper"].as_array().unwrap().iter().map(|c| c["piece"].as_str().unwrap()).collect();
    assert_eq!(pieces.len(), 4, "{capture}");
    assert!(pieces[0].starts_with("black pawn from d5 to black graveyard"), "{pieces:?}");
    assert_eq!(pieces[2], "white pawn from e4 to d5");
    // --export-rate sets the grid.
    let slow = dir.path().join("slow");
    json_of(&chessarm(&["plan", "--moves", "e4", "--export-rate", "25", "--out", slow.to_str().unwrap()]));
    check_move_files(&slow.join("hardware"), "001-e2e4", 25.0, &["joint1", "joint2", "joint3", "joint4"]);
    // The scenario too (the report's move with its grip and release).
    let scenario = dir.path().join("scenario");
    json_of(&chessarm(&["plan", "--out", scenario.to_str().unwrap()]));
    let value =
        check_move_files(&scenario.join("hardware"), "scenario", 100.0, &["joint1", "joint2", "joint3", "joint4"]);
    assert_eq!(value["gripper"].as_array().unwrap().len(), 2);
}

#[test]
fn play_writes_a_trajectory_for_each_robot_move_with_the_urdfs_joint_names() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("play");
    let output = common::on_offset_arm_board(&[
        "play",
        "--moves",
        "e4 e5 Nf3",
        "--robot",
        "white",
        "--out",
        out.to_str().unwrap(),
    ]);
    let report = json_of(&output);
    assert!(report["files"].as_array().unwrap().iter().any(|f| f.as_str().unwrap().ends_with("hardware")));
    let hardware = out.join("hardware");
    let mut names = common::file_names(&hardware);
    // chessarm's list of the files it wrote there.
    names.retain(|name| !name.starts_with('.'));
    // Only the robot's moves (White's); black's e5 is the opponent's hand.
    assert_eq!(names, ["001-e2e4.csv", "001-e2e4.json", "003-g1f3.csv", "003-g1f3.json"]);
    for (stem, moves_csv) in [("001-e2e4", "001-e2e4.csv"), ("003-g1f3", "003-g1f3.csv")] {
        check_move_files(&hardware, stem, 100.0, &["waist", "shoulder", "elbow", "wrist"]);
        // The simulation followed the same plan: its reference q_des (every 10 ms of robot time)
        // equals the exported positions at the same instants of the move.
        let reference = numeric_rows(&out.join("moves").join(moves_csv), 5, 4);
        let start = reference[0].0;
        let exported = numeric_rows(&hardware.join(format!("{stem}.csv")), 1, 4);
        // The fine points' waits (robot time from the move's start, and how long): the plan
        // stands still during each and runs that much later after it.
        let game: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("game.json")).unwrap()).unwrap();
        let uci = &stem[4..];
        let played = game["moves"].as_array().unwrap().iter().find(|m| m["uci"] == uci).unwrap();
        let waits: Vec<(f64, f64)> = played["in_position_waits"]["commands"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| (c["reached_s"].as_f64().unwrap(), c["wait_s"].as_f64().unwrap()))
            .collect();
        let mut met = 0;
        for (t, q_des) in &reference {
            let robot = t - start;
            if waits.iter().any(|(reached, wait)| robot > *reached && robot < reached + wait) {
                continue;
            }
            let plan =
                robot - waits.iter().filter(|(reached, wait)| reached + wait <= robot).map(|(_, w)| w).sum::<f64>();
            // Waits are whole integration steps, not whole export periods: after one, the
            // recorded instants fall between the exported ones, except where they meet again.
            let on_grid = ((plan / 0.01) - (plan / 0.01).round()).abs() < 1e-6;
            let last = exported.last().unwrap().0;
            assert!(
                !on_grid || plan > last + 1e-9 || exported.iter().any(|(te, _)| (te - plan).abs() < 1e-9),
                "{stem}: no exported sample at plan time {plan}"
            );
            if let Some((_, q)) = exported.iter().find(|(te, _)| (te - plan).abs() < 1e-9) {
                for (got, want) in q.iter().zip(q_des) {
                    // The simulator holds the reference sampled each 1 ms control period; at the
                    // recorded instants the sample is the same instant's: equal to rounding.
                    assert!((got - want).abs() < 1e-9, "{stem} at {t}: {got} vs {want}");
                }
                met += 1;
            }
        }
        // Every instant before the first wait at least (the approach to the piece: ~1 s).
        let first_wait = waits.first().map_or(f64::INFINITY, |w| w.0);
        let before = reference.iter().filter(|(t, _)| t - start <= first_wait).count();
        assert!(met >= before && before >= 50, "{stem}: {met} instants met, {before} before the first wait");
    }
}

#[test]
fn a_bad_export_rate_is_refused_by_name() {
    for (rate, needle) in [
        ("0", "must be finite and > 0"),
        ("-5", "must be finite and > 0"),
        ("0.5", "below the lowest export rate, 1 Hz"),
        ("20000", "above the highest"),
        ("fast", "not a number"),
    ] {
        let output = chessarm(&["plan", "--moves", "e4", "--export-rate", rate, "--out", "unused"]);
        assert_one_line_error(&output, &["--export-rate", rate, needle]);
        assert!(!Path::new("unused").exists());
    }
}
