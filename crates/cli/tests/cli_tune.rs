//! The binary, end to end: gains from specs and parallel sweeps.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

mod common;
use common::{assert_one_line_error, assert_same_at_every_batching, chessarm, json_of};

use serde_json::Value;

#[test]
fn specs_give_gains_whose_simulated_response_meets_them() {
    for (controller, settling, overshoot) in [("pd", "0.3", "0"), ("pd", "0.5", "10"), ("pid", "0.4", "8")] {
        let output = json_of(&chessarm(&[
            "gains",
            "--settling-time",
            settling,
            "--overshoot",
            overshoot,
            "--controller",
            controller,
        ]));
        let design = &output["designs"][0];
        let measured = &design["measured"];
        let (settling, overshoot): (f64, f64) = (settling.parse().unwrap(), overshoot.parse().unwrap());
        let measured_settling = measured["worst_settling_time_s"].as_f64().unwrap();
        let measured_overshoot = measured["worst_overshoot_percent"].as_f64().unwrap();
        // Within 10 % of the spec; an overshoot of 0 % is met within half a percentage point.
        assert!((measured_settling - settling).abs() <= 0.1 * settling, "{controller}: {measured}");
        assert!((measured_overshoot - overshoot).abs() <= (0.1 * overshoot).max(0.5), "{controller}: {measured}");
        assert_eq!(measured["saturation_count"].as_u64(), Some(0));
        let poles = design["closed_loop_poles"].as_array().unwrap();
        assert_eq!(poles.len(), if controller == "pid" { 3 } else { 2 });
        assert!(poles.iter().all(|p| p[0].as_f64().unwrap() < 0.0), "unstable design {poles:?}");
    }
    // ωn and ζ directly: kp = ωn², kd = 2ζωn.
    let output = json_of(&chessarm(&["gains", "--wn", "20", "--zeta", "0.5", "--no-verify"]));
    assert_eq!(output["designs"][0]["kp"][0].as_f64(), Some(400.0));
    assert_eq!(output["designs"][0]["kd"][0].as_f64(), Some(20.0));
    assert_one_line_error(
        &chessarm(&["gains", "--settling-time", "0.3", "--controller", "pid"]),
        &["overshoot 0%", "at best"],
    );
    assert_one_line_error(&chessarm(&["gains", "--settling-time", "-1"]), &["-1"]);
    assert_one_line_error(&chessarm(&["gains", "--settling-time", "0.3", "--overshoot", "150"]), &["150"]);
    assert_one_line_error(&chessarm(&["gains"]), &["--settling-time"]);
}

fn rows(csv: &str) -> Vec<Vec<String>> {
    csv.lines().skip(1).map(|line| line.split(',').map(String::from).collect()).collect()
}

#[test]
fn a_sweep_has_one_row_per_candidate_and_its_best_row_re_simulates() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("tune");
    let result = json_of(&chessarm(&[
        "tune",
        "--kp",
        "100..900:3",
        "--kd",
        "10..40:2",
        "--q0",
        "0,0.8,-2.4,0",
        "--out",
        out.to_str().unwrap(),
    ]));
    assert_eq!(result["candidates"].as_u64(), Some(6));
    let csv = std::fs::read_to_string(out.join("tune.csv")).unwrap();
    assert!(csv.starts_with("index,kp,kd,ki,status,max_tip_error_mm"));
    let rows = rows(&csv);
    assert_eq!(rows.len(), 6);
    let gains: Vec<(f64, f64)> = rows.iter().map(|r| (r[1].parse().unwrap(), r[2].parse().unwrap())).collect();
    assert_eq!(gains, [(100.0, 10.0), (100.0, 40.0), (500.0, 10.0), (500.0, 40.0), (900.0, 10.0), (900.0, 40.0)]);
    assert!(std::fs::metadata(out.join("tune.png")).unwrap().len() > 10_000);
    // The best candidate, simulated on its own, gives the same metric.
    let best = &result["best"][0];
    let (kp, kd) = (best["kp"].as_f64().unwrap(), best["kd"].as_f64().unwrap());
    let single = dir.path().join("single");
    json_of(&chessarm(&[
        "simulate",
        "--controller",
        "pd",
        "--kp",
        &format!("{kp:?}"),
        "--kd",
        &format!("{kd:?}"),
        "--q0",
        "0,0.8,-2.4,0",
        // The sweep's metrics start at 1 s after a start at --q0 (the deliberate transient).
        "--tracking-from",
        "1",
        "--out",
        single.to_str().unwrap(),
    ]));
    let summary: Value = serde_json::from_str(&std::fs::read_to_string(single.join("summary.json")).unwrap()).unwrap();
    let again = summary["controllers"][0]["max_tip_error_mm"].as_f64().unwrap();
    assert_eq!(again, best["metric"].as_f64().unwrap(), "the sweep and a single run disagree");
    // The best is the smallest metric among candidates within the torque limits.
    let smallest = rows
        .iter()
        .filter(|r| r[4] == "ok" && r[12] == "0")
        .map(|r| r[5].parse::<f64>().unwrap())
        .fold(f64::INFINITY, f64::min);
    assert_eq!(smallest, again);
}

#[test]
fn shards_concatenate_to_the_full_sweep() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec!["tune", "--kp", "200..800:3", "--kd", "15..35:2", "--out", out.to_str().unwrap()];
        args.extend_from_slice(extra);
        json_of(&chessarm(&args));
        std::fs::read_to_string(out.join("tune.csv")).unwrap()
    };
    let full = sweep("full", &["--threads", "2"]);
    let parts: String = ["1/4", "2/4", "3/4", "4/4"]
        .iter()
        .map(|k| sweep(&k.replace('/', "-"), &["--shard", k, "--threads", "1"]))
        .collect();
    assert_eq!(parts, full);
}

#[test]
fn a_sweep_where_every_candidate_fails_still_finishes() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("wild");
    // kp = 1e7 with no damping cannot be held by a 1 kHz loop: every run diverges.
    let result = json_of(&chessarm(&["tune", "--kp", "1e7..1e7:1", "--kd", "0..0:1", "--out", out.to_str().unwrap()]));
    assert_eq!(result["failed"].as_u64(), Some(1));
    assert_eq!(result["best"].as_array().unwrap().len(), 0);
    let csv = std::fs::read_to_string(out.join("tune.csv")).unwrap();
    assert!(rows(&csv)[0][4].starts_with("failed: "), "{csv}");
    // An empty shard writes an empty slice.
    let shard = dir.path().join("shard");
    let result = json_of(&chessarm(&[
        "tune",
        "--kp",
        "400..400:1",
        "--kd",
        "20..20:1",
        "--shard",
        "2/3",
        "--out",
        shard.to_str().unwrap(),
    ]));
    assert_eq!(result["candidates"].as_u64(), Some(0));
    assert_eq!(std::fs::read_to_string(shard.join("tune.csv")).unwrap(), "");
}

#[test]
fn bad_ranges_are_one_line_errors_naming_the_value() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let tune = |kp: &str| chessarm(&["tune", "--kp", kp, "--kd", "10..20:2", "--out", out]);
    assert_one_line_error(&tune(".."), &["'..'"]);
    assert_one_line_error(&tune("100..200:0"), &["count 0"]);
    assert_one_line_error(&tune("300..200:4"), &["300", "200"]);
    assert_one_line_error(&tune("-5..200:4"), &["-5"]);
    assert_one_line_error(&tune("NaN..200:4"), &["NaN"]);
    assert_one_line_error(&tune("100..200:x"), &["'x'"]);
    assert_one_line_error(&tune("0..200:3"), &["kp must be > 0"]);
    assert_one_line_error(
        &chessarm(&["tune", "--kp", "1..2:2", "--kd", "1..2:2", "--shard", "5/4", "--out", out]),
        &["5/4"],
    );
    assert_one_line_error(
        &chessarm(&["tune", "--kp", "1..2:2", "--kd", "1..2:2", "--controller", "pid", "--out", out]),
        &["--ki"],
    );
}

#[test]
fn a_sweep_over_a_game_counts_misplaced_pieces() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("game");
    let result = json_of(&chessarm(&[
        "tune",
        common::OPERA,
        "--kp",
        "25..900:2",
        "--kd",
        "4..40:2",
        "--metric",
        "place-error",
        "--release-by-clock",
        "--no-payload-feedforward",
        "--out",
        out.to_str().unwrap(),
    ]));
    let csv = std::fs::read_to_string(out.join("tune.csv")).unwrap();
    let rows = rows(&csv);
    assert_eq!(rows.len(), 4);
    // kp = 25 1/s² with kd = 4 1/s (ωn = 5 rad/s, ζ = 0.4) is far too soft for the moves'
    // speed: released by the clock (no fine points) and told nothing of the piece it carries,
    // it puts pieces down off their squares; kp = 900,
    // kd = 40 (ωn = 30 rad/s, ζ = 0.67) places every piece.
    let row = |kp: &str, kd: &str| rows.iter().find(|r| r[1] == kp && r[2] == kd).unwrap();
    // The soft loop either counts its misplaced pieces or stops where the pieces it put down
    // off their squares leave a later move no room to keep clear (the planner refuses it).
    let soft = row("25.0", "4.0");
    assert!(
        soft[13].parse::<usize>().unwrap() > 0
            || (soft[4].contains("would come") && soft[4].contains("nothing was run")),
        "{csv}"
    );
    assert_eq!(row("900.0", "40.0")[13], "0", "{csv}");
    // The best pick is among the candidates that misplaced nothing.
    assert_eq!(result["best"][0]["kp"].as_f64(), Some(900.0));
    assert!(result["best"][0]["metric"].as_f64().unwrap() < 5.0);
}

/// Runs chessarm with `args` and `env` set (and the schedulers' variables cleared otherwise).
fn with_env(args: &[&str], env: &[(&str, &str)]) -> std::process::Output {
    let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_chessarm"));
    for name in ["SLURM_ARRAY_TASK_ID", "SLURM_ARRAY_TASK_MIN", "SLURM_ARRAY_TASK_COUNT", "JOB_COMPLETION_INDEX"] {
        command.env_remove(name);
    }
    command.args(args).arg("--json").envs(env.iter().copied()).output().unwrap()
}

#[test]
fn batch_schedulers_choose_the_shard_from_their_environment() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = ["tune", "--kp", "200..800:3", "--kd", "15..35:2", "--threads", "1"];
    let run = |name: &str, extra: &[&str], env: &[(&str, &str)]| {
        let out = dir.path().join(name);
        let mut args = sweep.to_vec();
        args.extend_from_slice(&["--out", out.to_str().unwrap()]);
        args.extend_from_slice(extra);
        json_of(&with_env(&args, env));
        std::fs::read_to_string(out.join("tune.csv")).unwrap()
    };
    let full = run("full", &[], &[]);
    // Slurm: an array 5-7 (MIN 5, COUNT 3); task 6 is shard 2/3.
    let slurm: Vec<String> = ["5", "6", "7"]
        .iter()
        .map(|id| {
            let env = [("SLURM_ARRAY_TASK_ID", *id), ("SLURM_ARRAY_TASK_MIN", "5"), ("SLURM_ARRAY_TASK_COUNT", "3")];
            run(&format!("slurm-{id}"), &["--shard-from-env"], &env)
        })
        .collect();
    assert_eq!(slurm[1], run("given", &["--shard", "2/3"], &[]));
    assert_eq!(slurm.concat(), full);
    // Kubernetes: 0-based JOB_COMPLETION_INDEX of --shards 2.
    let k8s: String = ["0", "1"]
        .iter()
        .map(|i| run(&format!("k8s-{i}"), &["--shard-from-env", "--shards", "2"], &[("JOB_COMPLETION_INDEX", *i)]))
        .collect();
    assert_eq!(k8s, full);
    // Mistakes name the flag or the variable and the value.
    let out = dir.path().join("bad");
    let out = out.to_str().unwrap();
    let tune = |extra: &[&str], env: &[(&str, &str)]| {
        let mut args = sweep.to_vec();
        args.extend_from_slice(&["--out", out]);
        args.extend_from_slice(extra);
        with_env(&args, env)
    };
    assert_one_line_error(&tune(&["--shard-from-env"], &[]), &["neither SLURM_ARRAY_TASK_ID nor JOB_COMPLETION_INDEX"]);
    assert_one_line_error(&tune(&["--shards", "4"], &[]), &["--shards 4 goes with --shard-from-env"]);
    assert_one_line_error(
        &tune(&["--shard-from-env", "--shard", "1/2"], &[("JOB_COMPLETION_INDEX", "0")]),
        &["--shard 1/2 and --shard-from-env"],
    );
    assert_one_line_error(
        &tune(&["--shard-from-env"], &[("JOB_COMPLETION_INDEX", "1")]),
        &["JOB_COMPLETION_INDEX needs --shards N"],
    );
    assert_one_line_error(
        &tune(&["--shard-from-env", "--shards", "2"], &[("JOB_COMPLETION_INDEX", "2")]),
        &["JOB_COMPLETION_INDEX=2 of --shards 2 gives shard 3/2"],
    );
    assert_one_line_error(
        &tune(&["--shard-from-env"], &[("SLURM_ARRAY_TASK_ID", "x1"), ("SLURM_ARRAY_TASK_COUNT", "2")]),
        &["SLURM_ARRAY_TASK_ID=x1 is not a whole number"],
    );
    assert_one_line_error(
        &tune(&["--shard-from-env"], &[("SLURM_ARRAY_TASK_ID", "1")]),
        &["SLURM_ARRAY_TASK_COUNT is not"],
    );
}

#[test]
fn the_deploy_scripts_run_their_shards_and_merge_to_the_full_sweep() {
    let dir = tempfile::tempdir().unwrap();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let sweep = "--kp 200..800:3 --kd 15..35:2";
    let full = dir.path().join("full");
    json_of(&chessarm(&["tune", "--kp", "200..800:3", "--kd", "15..35:2", "--out", full.to_str().unwrap()]));
    let full = std::fs::read_to_string(full.join("tune.csv")).unwrap();
    // The Slurm array script, as three array tasks 0-2, then the merge its header gives.
    let out = dir.path().join("slurm");
    let mut merged = String::new();
    for id in 0..3 {
        let status = std::process::Command::new("bash")
            .arg(root.join("deploy/slurm-tune.sh"))
            .env("CHESSARM", env!("CARGO_BIN_EXE_chessarm"))
            .env("CHESSARM_SWEEP", sweep)
            .env("CHESSARM_OUT", &out)
            .env("SLURM_ARRAY_TASK_ID", id.to_string())
            .env("SLURM_ARRAY_TASK_COUNT", "3")
            .env_remove("SLURM_ARRAY_TASK_MIN")
            .output()
            .unwrap();
        assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
        merged.push_str(&std::fs::read_to_string(out.join(format!("shard-{id}/tune.csv"))).unwrap());
    }
    assert_eq!(merged, full);
    // The Kubernetes Indexed Job: its container's command line, with the index set, for each
    // of its completions (the sweep made small and the folder a temporary one).
    let manifest = std::fs::read_to_string(root.join("deploy/k8s-tune-job.yaml")).unwrap();
    assert!(manifest.contains("completionMode: Indexed"));
    let completions: usize =
        manifest.lines().find_map(|l| l.trim().strip_prefix("completions: ")).and_then(|n| n.parse().ok()).unwrap();
    let line = manifest.lines().map(str::trim).find(|l| l.starts_with("- chessarm tune")).unwrap();
    assert!(line.contains(&format!("--shards {completions}")), "--shards must equal completions: {line}");
    let line = line
        .trim_start_matches("- ")
        .replacen("chessarm", env!("CARGO_BIN_EXE_chessarm"), 1)
        .replace("--kp 25..2000:100 --kd 2..80:100", "--kp 200..800:3 --kd 15..35:2")
        .replace("/results", dir.path().join("k8s").to_str().unwrap());
    let mut merged = String::new();
    for index in 0..completions {
        let status = std::process::Command::new("sh")
            .args(["-c", &line])
            .env("JOB_COMPLETION_INDEX", index.to_string())
            .output()
            .unwrap();
        assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
        merged.push_str(&std::fs::read_to_string(dir.path().join(format!("k8s/shard-{index}/tune.csv"))).unwrap());
    }
    assert_eq!(merged, full);
}

#[test]
fn a_sweep_is_the_same_at_every_lane_count_and_simd_level() {
    // Candidates that diverge (the larger kp with little damping), that clip at the torque
    // limits, and ordinary ones, under hobby sensors with the Kalman filter: the CSV must not
    // depend on how many candidates share a batch or on the SIMD instructions.
    let dir = tempfile::tempdir().unwrap();
    let sweep = |name: &str, env: &[(&str, &str)]| {
        let out = dir.path().join(name);
        let args = [
            "tune",
            "--kp",
            "200..30000:4",
            "--kd",
            "1..60:3",
            // A start away from the path: the start-up transient clips at the torque limits.
            "--q0",
            "0,0.8,-2.4,0",
            "--sensors",
            "hobby",
            "--estimator",
            "kalman",
            "--threads",
            "2",
            "--out",
            out.to_str().unwrap(),
        ];
        let output = with_env(&args, env);
        assert!(output.status.success(), "{env:?}: {}", String::from_utf8_lossy(&output.stderr));
        std::fs::read_to_string(out.join("tune.csv")).unwrap()
    };
    let scalar = sweep("scalar", &[("CHESSARM_LANES", "1")]);
    let statuses: Vec<Vec<String>> = rows(&scalar);
    assert!(statuses.iter().any(|r| r[4] != "ok"), "no failing candidate:\n{scalar}");
    assert!(statuses.iter().any(|r| r[4] == "ok" && r[12] != "0"), "no candidate at the torque limits:\n{scalar}");
    assert_same_at_every_batching("a_sweep_is_the_same_at_every_lane_count_and_simd_level", &scalar, sweep);
    // The variables as typed, when they are not a lane count or a level.
    let bad = |env: &[(&str, &str)]| {
        with_env(
            &["tune", "--kp", "200..800:2", "--kd", "15..35:2", "--out", dir.path().join("bad").to_str().unwrap()],
            env,
        )
    };
    assert_one_line_error(&bad(&[("CHESSARM_LANES", "3")]), &["CHESSARM_LANES=\"3\"", "1, 4 or 8"]);
    assert_one_line_error(&bad(&[("CHESSARM_SIMD", "neon")]), &["CHESSARM_SIMD=\"neon\"", "avx512, avx2 and sse2"]);
}
