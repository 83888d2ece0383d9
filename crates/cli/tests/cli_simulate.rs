//! The binary, end to end: dynamics, closed-loop simulation and the demo.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

mod common;
use common::{assert_one_line_error, chessarm, json_of, numbers};

use chessarm_core::arm::dynamics::{coriolis_torques, gravity_torques, mass_matrix};
use chessarm_core::arm::model::JointVector;
use chessarm_core::arm::preset::report_arm;
use serde_json::Value;
use std::path::Path;

#[test]
fn dynamics_prints_the_library_terms() {
    let output = json_of(&chessarm(&["dynamics", "--q", "0.3,0.9,-1.7,-0.6", "--qd", "0.5,-0.2,0.3,1.0"]));
    let model = report_arm();
    let q = JointVector::<4>::new(0.3, 0.9, -1.7, -0.6);
    let qd = JointVector::<4>::new(0.5, -0.2, 0.3, 1.0);
    let m = mass_matrix(&model, &q);
    for (r, row) in output["M"].as_array().unwrap().iter().enumerate() {
        for (c, value) in numbers(row).iter().enumerate() {
            assert!((value - m[(r, c)]).abs() < 1e-15);
        }
    }
    let c = coriolis_torques(&model, &q, &qd);
    let g = gravity_torques(&model, &q);
    for j in 0..4 {
        assert!((numbers(&output["c"])[j] - c[j]).abs() < 1e-15);
        assert!((numbers(&output["g"])[j] - g[j]).abs() < 1e-15);
    }
    // A payload adds weight: the shoulder must hold more.
    let loaded = json_of(&chessarm(&["dynamics", "--q", "0.3,0.9,-1.7,-0.6", "--payload-mass", "0.2"]));
    assert!(numbers(&loaded["g"])[1] > g[1] + 0.2 * 9.8 * 0.3);
    assert_one_line_error(&chessarm(&["dynamics", "--q", "0,0,0"]), &["expected 4"]);
    assert_one_line_error(&chessarm(&["dynamics", "--q", "0,0,0,0", "--payload-mass", "-1"]), &["-1"]);
}

fn summary_of(dir: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

fn controller<'a>(summary: &'a Value, name: &str) -> &'a Value {
    summary["controllers"].as_array().unwrap().iter().find(|c| c["controller"] == name).unwrap()
}

#[test]
fn simulate_writes_series_summary_and_plots() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    let result = json_of(&chessarm(&["simulate", "--out", out.to_str().unwrap()]));
    assert!(result["files"].as_array().unwrap().len() >= 9);
    let summary = summary_of(&out);
    for name in ["pd", "pid"] {
        let run = controller(&summary, name);
        // Starting on the trajectory with an exact model, only the 1 kHz hold separates the
        // arm from the plan: far below a millimetre.
        assert!(run["max_tip_error_mm"].as_f64().unwrap() < 0.1, "{run}");
        assert_eq!(run["tip_error_at_events"].as_array().unwrap().len(), 2);
        assert_eq!(run["saturation_count"].as_u64(), Some(0));
        assert!(run["wall_time_s"].as_f64().unwrap() > 0.0);
        let mut reader = csv::Reader::from_path(out.join(format!("{name}.csv"))).unwrap();
        let header: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
        assert_eq!(header.len(), 31);
        assert_eq!(&header[..2], ["t", "q1"]);
        assert_eq!(&header[25..], ["x", "y", "z", "x_des", "y_des", "z_des"]);
        assert_eq!(reader.records().count(), 13001);
        for png in [format!("{name}_joints.png"), format!("{name}_torques.png")] {
            assert!(std::fs::metadata(out.join(png)).unwrap().len() > 20_000);
        }
    }
    assert_eq!(controller(&summary, "pd")["gains"]["kp"], serde_json::json!([400.0, 400.0, 400.0, 400.0]));
    assert_eq!(controller(&summary, "pid")["gains"]["ki"], serde_json::json!([75.0, 75.0, 75.0, 75.0]));
    assert!(out.join("tracking_error.png").exists() && out.join("tip_error.png").exists());
}

#[test]
fn an_unknown_payload_costs_precision_and_knowing_it_restores_it() {
    let dir = tempfile::tempdir().unwrap();
    let run = |extra: &[&str], name: &str| {
        let out = dir.path().join(name);
        let mut args = vec!["simulate", "--controller", "pd", "--payload-mass", "0.2", "--out", out.to_str().unwrap()];
        args.extend_from_slice(extra);
        json_of(&chessarm(&args));
        let summary = summary_of(&out);
        numbers(
            &controller(&summary, "pd")["tip_error_at_events"]
                .as_array()
                .unwrap()
                .iter()
                .map(|e| e["tip_error_mm"].clone())
                .collect(),
        )
    };
    let unknown = run(&[], "unknown");
    let known = run(&["--controller-knows-payload"], "known");
    // At the release the piece has been carried for 5.5 s: PD leaves the steady sag
    // M⁻¹Δg/kp, of order a millimetre; an informed model removes it.
    assert!(unknown[1] > 0.1, "release error {} mm", unknown[1]);
    assert!(known[1] < 0.01, "release error {} mm", known[1]);
}

#[test]
fn integrators_agree_to_their_order() {
    // The report's move from q = 0 with the pawn unknown to the controller: a saturated
    // start-up, a grip and a release. The fourth-order methods agree with each other to
    // nanometres; midpoint (second order) and Euler (first) drift by micrometres and
    // millimetres respectively (measured: 2e-5 m and 4e-3 m at worst against a 0.1 ms run).
    let dir = tempfile::tempdir().unwrap();
    let run = |integrator: &str| {
        let out = dir.path().join(integrator);
        let args = ["simulate", "--controller", "pd", "--q0", "0,0,0,0", "--payload-mass", "0.25"];
        json_of(&chessarm(&[&args[..], &["--integrator", integrator, "--out", out.to_str().unwrap()]].concat()));
        let summary = summary_of(&out);
        assert_eq!(summary["integrator"], integrator);
        let tips = |record: csv::StringRecord| -> Vec<f64> { (25..28).map(|k| record[k].parse().unwrap()).collect() };
        csv::Reader::from_path(out.join("pd.csv")).unwrap().records().map(|r| tips(r.unwrap())).collect::<Vec<_>>()
    };
    let deviation = |a: &[Vec<f64>], b: &[Vec<f64>]| {
        a.iter()
            .zip(b)
            .map(|(p, q)| p.iter().zip(q).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max))
            .fold(0.0, f64::max)
    };
    let rkn4 = run("rkn4");
    let rk4 = run("rk4");
    let midpoint = run("midpoint");
    let euler = run("euler");
    assert!(deviation(&rkn4, &rk4) < 1e-8, "rkn4 vs rk4: {} m", deviation(&rkn4, &rk4));
    let second_order = deviation(&rkn4, &midpoint);
    let first_order = deviation(&rkn4, &euler);
    assert!(second_order > 1e-7 && second_order < 1e-4, "midpoint: {second_order} m");
    assert!(first_order > 10.0 * second_order && first_order < 1e-2, "euler: {first_order} m");
}

#[test]
fn bad_simulation_input_is_one_line_with_exit_code_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bad");
    let out = out.to_str().unwrap();
    assert_one_line_error(&chessarm(&["simulate", "--kp", "-5", "--out", out]), &["-5"]);
    assert_one_line_error(&chessarm(&["simulate", "--kd", "nan", "--out", out]), &["NaN"]);
    assert_one_line_error(&chessarm(&["simulate", "--kp", "1,2", "--out", out]), &["expected 4"]);
    assert_one_line_error(&chessarm(&["simulate", "--kp", "0", "--out", out]), &["kp[joint 1] = 0"]);
    assert_one_line_error(&chessarm(&["simulate", "--dt", "0", "--out", out]), &["0"]);
    assert_one_line_error(&chessarm(&["simulate", "--control-rate", "300", "--out", out]), &["whole multiple"]);
    assert_one_line_error(&chessarm(&["simulate", "--controller", "pd", "--ki", "5", "--out", out]), &["--ki"]);
    assert_one_line_error(&chessarm(&["simulate", "--controller", "lqr", "--out", out]), &["lqr"]);
    assert_one_line_error(&chessarm(&["simulate", "--integrator", "rk45", "--out", out]), &["rk45"]);
    // Gains far beyond what a 1 kHz hold can stabilise: a clear error, and no summary.
    let diverged = chessarm(&["simulate", "--controller", "pd", "--kp", "1e7", "--kd", "0", "--out", out]);
    assert_one_line_error(&diverged, &["diverged", "controller pd"]);
    assert!(!Path::new(out).join("summary.json").exists());
}

#[test]
fn demo_reproduces_the_report_study() {
    let dir = tempfile::tempdir().unwrap();
    let output = chessarm(&["demo", "--out", dir.path().to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.contains("the report's conclusion holds"), "{stderr}");
    for file in ["plan/cartesian.csv", "plan/joint.png", "simulate/summary.json", "simulate/tracking_error.png"] {
        assert!(dir.path().join(file).exists(), "{file} missing");
    }
    let summary = summary_of(&dir.path().join("simulate"));
    let worst_at_events = |name: &str| {
        controller(&summary, name)["tip_error_at_events"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| e["tip_error_mm"].as_f64().unwrap())
            .fold(0.0, f64::max)
    };
    // Started at q = 0 like the report, the report's PID's slow integral (pole at −0.126 1/s)
    // is still unwinding at the grip: PD places the pawn more precisely (2.36 mm).
    assert!(worst_at_events("pd") < worst_at_events("pid-plain"));
    assert!(worst_at_events("pid-plain") > 0.5);
    // Anti-windup keeps the start-up from spoiling the grip (the target: < 0.1 mm).
    assert!(worst_at_events("pid") < 0.1, "{}", worst_at_events("pid"));
    assert!(stderr.contains("With anti-windup"), "{stderr}");
}
