//! A simulated scenario's files: per controller `<name>.csv` (every step) and its joint and
//! torque plots, the comparison plots, `replay.html` and `summary.json`; and the terminal's
//! comparison table.

use crate::app::formats::plots::{Corner, Level, Mark, Panel, Series, Style, plot_panels, tick};
use crate::app::formats::replay::{Frame, Replay, ReplayMove, ReplayRun, thin, write_replay};
use crate::app::output::{ensure_dir, numbered, remove_stale, write_csv, write_json};
use crate::app::setup::conditions::Trial;
use crate::app::setup::file::{JointConvention, Setup};
use crate::app::studies::plan::Plan;
use crate::app::studies::simulate::{
    ControllerRun, RunOptions, ScenarioRuns, TRANSIENT_S, max_tip_error_from, placement_error, true_pawn_mass,
};
use anyhow::Result;
use chessarm_chess::play::{DEFAULT_TOLERANCE, Handling, placed_position};
use chessarm_chess::shakmaty::Chess;
use chessarm_chess::table::{Location, Table};
use chessarm_core::control::choice::ControllerKind;
use chessarm_core::nalgebra::Vector3;
use chessarm_core::plan::path::GripperAction;
use chessarm_core::sim::StepRecord;
use serde_json::{Value, json};
use std::path::Path;

/// The per-controller summary written to summary.json (SI, plus mm for tip errors).
pub fn summary_json(run: &ControllerRun, plan: &Plan) -> Value {
    let summary = &run.summary;
    let gains = &run.spec.gains;
    let poles: Vec<Vec<[f64; 2]>> =
        (0..4).map(|j| gains.closed_loop_poles(j).iter().map(|p| [p.re, p.im]).collect()).collect();
    let events: Vec<Value> = plan
        .path
        .events()
        .iter()
        .zip(&summary.tip_error_at_marks)
        .map(|(event, error)| {
            let kind = match event.action {
                GripperAction::Grip => "grip",
                GripperAction::Release => "release",
            };
            json!({ "event": kind, "t_s": event.time, "tip_error_mm": error * 1e3 })
        })
        .collect();
    // A servo host has no gains of its own (the servos' loops are theirs): none written.
    let host = matches!(run.spec.kind, ControllerKind::ServoHost(_));
    let gains_json =
        (!host).then(|| json!({ "kp": gains.kp.as_slice(), "kd": gains.kd.as_slice(), "ki": gains.ki.as_slice() }));
    let poles = (!host).then_some(poles);
    json!({
        "controller": run.spec.name,
        "servo_command": host.then(|| run.spec.name.clone()),
        "gains": gains_json,
        "closed_loop_poles": poles,
        "rms_joint_error_rad": summary.rms_joint_error.as_slice(),
        "max_joint_error_rad": summary.max_joint_error.as_slice(),
        "rms_tip_error_mm": summary.rms_tip_error * 1e3,
        "max_tip_error_mm": summary.max_tip_error * 1e3,
        "tip_error_at_events": events,
        "placement_error_mm": placement_error(plan, summary).map(|e| e * 1e3),
        "rms_angle_estimate_error_rad": summary.rms_angle_estimate_error.as_slice(),
        "rms_rate_estimate_error_rad_per_s": summary.rms_rate_estimate_error.as_slice(),
        "peak_torque_nm": summary.peak_torque.as_slice(),
        "saturation_count": summary.saturated_samples,
        "saturation_per_joint": summary.saturated_per_joint,
        "duration_s": summary.duration,
        "steps": summary.steps,
        "wall_time_s": run.wall_time_s,
    })
}

fn run_header() -> Vec<String> {
    let mut header = vec!["t".to_string()];
    for prefix in ["q", "qd", "q_des", "qd_des", "e", "tau"] {
        header.extend(numbered(prefix, 4));
    }
    header.extend(["x", "y", "z", "x_des", "y_des", "z_des"].map(String::from));
    header
}

/// A step's row, the joints in the user's convention (a URDF's own sense).
fn run_row(record: &StepRecord<4>, convention: &JointConvention) -> Vec<f64> {
    let error = record.reference.q - record.state.q;
    let mut row = vec![record.t];
    for part in [record.state.q, record.state.qd, record.reference.q, record.reference.qd, error, record.torque] {
        row.extend(convention.user(part));
    }
    row.extend(record.tip.iter().chain(record.tip_desired.iter()));
    row
}

/// Stretches where `saturated(record)` holds, as time spans, each at least `min_width` s wide
/// (so that a single saturated sample can be seen on a plot of the whole run).
fn stretches(records: &[StepRecord<4>], saturated: impl Fn(&StepRecord<4>) -> bool, min_width: f64) -> Vec<(f64, f64)> {
    let mut spans: Vec<(f64, f64)> = Vec::new();
    let mut open: Option<f64> = None;
    let mut last = 0.0;
    for record in records {
        match (saturated(record), open) {
            (true, None) => open = Some(record.t),
            (false, Some(start)) => {
                spans.push((start, last));
                open = None;
            }
            _ => {}
        }
        last = record.t;
    }
    if let Some(start) = open {
        spans.push((start, last));
    }
    spans
        .into_iter()
        .map(|(a, b)| {
            let grow = (min_width - (b - a)).max(0.0) / 2.0;
            (a - grow, b + grow)
        })
        .collect()
}

/// Writes `<name>.csv`, `<name>_joints.png` and `<name>_torques.png` for one run: the torque
/// plot has a panel per joint with its torque limits drawn and the stretches at a limit shaded.
pub fn write_run(
    run: &ControllerRun,
    out: &Path,
    torque_limits: &[f64; 4],
    convention: &JointConvention,
) -> Result<Vec<String>> {
    let name = &run.spec.name;
    let csv = out.join(format!("{name}.csv"));
    let servos = run.records.first().is_some_and(|r| r.servo.is_some());
    let mut header = run_header();
    if servos {
        header.extend(crate::app::setup::servos::servo_columns());
    }
    write_csv(
        &csv,
        &header,
        run.records.iter().map(|r| {
            let mut row = run_row(r, convention);
            crate::app::setup::servos::push_servo_values(&mut row, r, convention);
            row
        }),
    )?;
    let upper = name.to_uppercase();
    // The plots in the user's convention too (a URDF's own sense).
    let sign = convention.signs;
    let joints = out.join(format!("{name}_joints.png"));
    let panels: Vec<Panel> = (0..4)
        .map(|j| Panel {
            title: format!("joint {}", j + 1),
            y_label: "angle (rad)".into(),
            series: vec![
                Series {
                    label: format!("θ{} actual", j + 1),
                    points: run.records.iter().map(|r| (r.t, sign[j] * r.state.q[j])).collect(),
                    color: 2,
                    style: Style::Line,
                },
                Series {
                    label: format!("θ{} desired", j + 1),
                    points: run.records.iter().map(|r| (r.t, sign[j] * r.reference.q[j])).collect(),
                    color: 0,
                    style: Style::Dashed,
                },
            ]
            .into_iter()
            .chain(
                servos
                    .then(|| {
                        [
                            Series {
                                label: format!("goal {} sent", j + 1),
                                points: run
                                    .records
                                    .iter()
                                    .filter_map(|r| Some((r.t, sign[j] * r.servo?.goal[j])))
                                    .collect(),
                                color: 1,
                                style: Style::Dashed,
                            },
                            Series {
                                label: format!("servo {} target", j + 1),
                                points: run
                                    .records
                                    .iter()
                                    .filter_map(|r| Some((r.t, sign[j] * r.servo?.target[j])))
                                    .collect(),
                                color: 3,
                                style: Style::Line,
                            },
                        ]
                    })
                    .into_iter()
                    .flatten(),
            )
            .collect(),
            ..Panel::default()
        })
        .collect();
    let title = if servos {
        format!("{upper}: joint angles — actual, planned, the goal sent and the servo's internal target")
    } else {
        format!("{upper}: joint angles, actual and desired")
    };
    plot_panels(&joints, &title, "time (s)", &panels)?;
    let torques = out.join(format!("{name}_torques.png"));
    let span = run.records.last().map_or(1.0, |r| r.t) - run.records.first().map_or(0.0, |r| r.t);
    let panels: Vec<Panel> = (0..4)
        .map(|j| {
            let limit = torque_limits[j];
            let saturated = stretches(&run.records, |r| r.torque[j].abs() >= limit * (1.0 - 1e-9), 0.004 * span);
            let samples = run.summary.saturated_per_joint[j];
            Panel {
                title: format!(
                    "joint {} torque τ{}; dashed: its ±{} N·m limits; shaded: at a limit ({samples} samples)",
                    j + 1,
                    j + 1,
                    tick(limit)
                ),
                y_label: "torque (N·m)".into(),
                series: vec![Series {
                    label: format!("τ{}", j + 1),
                    points: run.records.iter().map(|r| (r.t, sign[j] * r.torque[j])).collect(),
                    color: j,
                    style: Style::Line,
                }],
                levels: vec![
                    Level { value: limit, label: String::new(), color: 5 },
                    Level { value: -limit, label: String::new(), color: 5 },
                ],
                shaded_label: "at the limit".into(),
                shaded: saturated,
                legend: Corner::Hidden,
                ..Panel::default()
            }
        })
        .collect();
    plot_panels(&torques, &format!("{upper}: joint torques"), "time (s)", &panels)?;
    Ok([csv, joints, torques].iter().map(|p| p.display().to_string()).collect())
}

/// Writes the comparison plots of several runs: joint tracking errors (report Figure 11, on a
/// log scale of |e| so that the start-up and the tracking after it both show) and the tool-tip
/// error (the whole run, then from [`TRANSIENT_S`] on on a log scale), with the grip and
/// release instants `events` (time, name) marked and each run's error there written beside them.
pub fn write_comparison(runs: &[ControllerRun], events: &[(f64, &str)], out: &Path) -> Result<Vec<String>> {
    // Displayed in mrad and mm; the CSVs keep rad and m.
    let color_of = |name: &str| match name {
        "pd" => 2,
        "pid" => 0,
        "pid-plain" => 1,
        "adaptive" => 3,
        _ => 4,
    };
    let plain_marks: Vec<Mark> = events.iter().map(|&(t, name)| Mark { x: t, label: name.into() }).collect();
    let errors = out.join("tracking_error.png");
    let panels: Vec<Panel> = (0..4)
        .map(|j| Panel {
            title: format!("joint {} tracking error |θ desired − θ| (log scale)", j + 1),
            y_label: "|error| (mrad)".into(),
            series: runs
                .iter()
                .map(|run| Series {
                    label: run.spec.name.to_uppercase(),
                    points: run.records.iter().map(|r| (r.t, 1e3 * (r.reference.q[j] - r.state.q[j]).abs())).collect(),
                    color: color_of(&run.spec.name),
                    style: Style::Line,
                })
                .collect(),
            marks: plain_marks.clone(),
            log_y: true,
            ..Panel::default()
        })
        .collect();
    let names: Vec<String> = runs.iter().map(|run| run.spec.name.to_uppercase()).collect();
    plot_panels(&errors, &format!("Tracking error: {}", names.join(" vs ")), "time (s)", &panels)?;
    let tip = out.join("tip_error.png");
    let tip_series: Vec<Series> = runs
        .iter()
        .map(|run| Series {
            label: run.spec.name.to_uppercase(),
            points: run.records.iter().map(|r| (r.t, 1e3 * (r.tip - r.tip_desired).norm())).collect(),
            color: color_of(&run.spec.name),
            style: Style::Line,
        })
        .collect();
    let labelled: Vec<Mark> = events
        .iter()
        .enumerate()
        .map(|(i, &(t, name))| {
            let values: Vec<String> = runs
                .iter()
                .filter_map(|run| {
                    let e = run.summary.tip_error_at_marks.get(i)? * 1e3;
                    Some(format!("{} {}", run.spec.name.to_uppercase(), tick(e)))
                })
                .collect();
            Mark { x: t, label: format!("{name}: {} mm", values.join(", ")) }
        })
        .collect();
    let end = runs.iter().filter_map(|r| r.records.last()).map(|r| r.t).fold(0.0, f64::max);
    let whole = Panel {
        title: "distance between the actual and the desired tool tip, whole run".into(),
        y_label: "tip error (mm)".into(),
        series: tip_series.clone(),
        marks: plain_marks,
        ..Panel::default()
    };
    let after = Panel {
        title: format!(
            "the same from {TRANSIENT_S} s on (log scale), with the errors at the grip and release instants"
        ),
        y_label: "tip error (mm)".into(),
        series: tip_series,
        marks: labelled,
        log_y: true,
        x_range: (end > TRANSIENT_S).then_some((TRANSIENT_S, end)),
        legend: Corner::LowerRight,
        ..Panel::default()
    };
    plot_panels(&tip, "Tool-tip error", "time (s)", &[whole, after])?;
    Ok([errors, tip].iter().map(|p| p.display().to_string()).collect())
}

/// A fixed-width comparison table of the runs, for the terminal. With `started_off` (the
/// runs started at rest at `--q0`, off the trajectory) the largest tip error is also shown
/// from [`TRANSIENT_S`] on, and a note says what the overall one measures.
pub fn comparison_table(runs: &[ControllerRun], started_off: bool) -> String {
    let after = format!("max tip ≥{TRANSIENT_S} s mm");
    let mut table = format!(
        "{:<10} {:>12} {:>12} {:>16} {:>22} {:>30} {:>9} {:>9}\n",
        "control",
        "rms tip mm",
        "max tip mm",
        if started_off { after.as_str() } else { "" },
        "tip at grip/release mm",
        "peak |τ| per joint N·m",
        "saturated",
        "wall ms"
    );
    for run in runs {
        let s = &run.summary;
        let events = s.tip_error_at_marks.iter().map(|e| format!("{:.4}", e * 1e3)).collect::<Vec<_>>().join(" / ");
        let torques = s.peak_torque.iter().map(|t| format!("{t:.2}")).collect::<Vec<_>>().join(" ");
        let after =
            if started_off { format!("{:.4}", max_tip_error_from(run, TRANSIENT_S) * 1e3) } else { String::new() };
        table.push_str(&format!(
            "{:<10} {:>12.4} {:>12.4} {:>16} {:>22} {:>30} {:>9} {:>9.1}\n",
            run.spec.name,
            s.rms_tip_error * 1e3,
            s.max_tip_error * 1e3,
            after,
            events,
            torques,
            s.saturated_samples,
            run.wall_time_s * 1e3
        ));
    }
    if started_off && let Some(first) = runs.first().and_then(|run| run.records.first()) {
        table.push_str(&format!(
            "rms and max tip mm include the deliberate start at rest off the trajectory ({:.2} mm at t = 0); \
             the column after it leaves out the first {TRANSIENT_S} s\n",
            (first.tip - first.tip_desired).norm() * 1e3
        ));
    }
    table
}

/// Writes a simulated scenario's files into `out`: every run's, the comparison plots, the
/// replay page and `summary.json`. Returns `{"summary": …, "files": […]}`.
///
/// # Errors
///
/// A file that cannot be written.
pub fn write_study(
    setup: &Setup,
    scenario: &str,
    study: &ScenarioRuns,
    options: &RunOptions,
    out: &Path,
) -> Result<Value> {
    let ScenarioRuns { plan, runs } = study;
    ensure_dir(out)?;
    remove_stale(&[out.join("summary.json")])?;
    let mut files = Vec::new();
    let torque_limits: [f64; 4] = std::array::from_fn(|j| setup.arm.link(j).limits.torque);
    for run in runs {
        files.extend(write_run(run, out, &torque_limits, &setup.convention)?);
    }
    let events: Vec<(f64, &str)> = plan
        .path
        .events()
        .iter()
        .map(|e| (e.time, if e.action == GripperAction::Grip { "grip" } else { "release" }))
        .collect();
    files.extend(write_comparison(runs, &events, out)?);
    let replay_path = out.join("replay.html");
    write_study_replay(&replay_path, setup, scenario, plan, runs, options)?;
    files.push(replay_path.display().to_string());
    let summary = json!({
        "scenario": scenario,
        "dt_s": options.dt,
        "integrator": options.integrator.name(),
        // A servo host's period is its bus's.
        "control_period_s": crate::app::setup::servos::control_period(setup, options.control_period),
        "actuators": setup.actuator_names,
        "payload_mass_kg": options.payload_mass,
        "true_payload_mass_kg": true_pawn_mass(setup, options.trial.as_ref(), options.payload_mass),
        "controller_knows_payload": options.controller_knows_payload,
        "q0_rad": options.q0,
        "tracking_metrics_from_s": options.tracking_from,
        "conditions": options.conditions,
        "trial": options.trial.as_ref().map(Trial::describe),
        "controllers": runs.iter().map(|run| summary_json(run, plan)).collect::<Vec<_>>(),
    });
    let summary_path = out.join("summary.json");
    write_json(&summary_path, &summary)?;
    files.push(summary_path.display().to_string());
    Ok(json!({ "summary": summary, "files": files }))
}

/// Writes the study's `replay.html`: one run per controller, the scenario's piece carried from
/// its grip to its release (drawn with the tool even when the study's payload is 0 kg).
fn write_study_replay(
    path: &Path,
    setup: &Setup,
    scenario: &str,
    plan: &Plan,
    runs: &[ControllerRun],
    options: &RunOptions,
) -> Result<()> {
    let table = Table::from_position(setup.board, &Chess::default());
    let events = plan.path.events();
    let grip = events.iter().find(|e| e.action == GripperAction::Grip).map(|e| e.time);
    let release = events.iter().find(|e| e.action == GripperAction::Release).map(|e| e.time);
    let moved = plan.placement.and_then(|(standing, target)| {
        let from = table.pieces().iter().position(|p| (p.position - standing).norm() < 1e-9)?;
        let square = setup.board.square_at(&Vector3::new(target.x, target.y, setup.board.surface_height))?.0;
        Some((from, standing, Location::Square(square)))
    });
    let replay_runs = runs
        .iter()
        .map(|run| {
            let mut frames = Vec::new();
            thin(run.records.iter().map(|r| Frame::of(r.t, r)), &mut frames);
            let handled =
                match (moved, grip, release, run.summary.tip_at_marks.first(), run.summary.tip_at_marks.get(1)) {
                    (
                        Some((piece, standing, to)),
                        Some(grip_time),
                        Some(release_time),
                        Some(at_grip),
                        Some(at_release),
                    ) => {
                        vec![Handling {
                            piece,
                            from: table.pieces()[piece].location,
                            to,
                            grip_time,
                            release_time,
                            standing,
                            placed: placed_position(&plan.base, at_grip, at_release, &standing),
                            grip_tip: Some(*at_grip),
                        }]
                    }
                    _ => Vec::new(),
                };
            let san = moved.map_or_else(|| scenario.to_string(), |(_, _, to)| to.to_string());
            let moves = vec![ReplayMove {
                ply: 1,
                number: "1.".into(),
                san,
                uci: scenario.to_string(),
                by: "robot",
                start: 0.0,
                end: run.summary.duration,
                closest: None,
            }];
            ReplayRun { name: run.spec.name.clone(), frames, handled, moves, waits: Vec::new() }
        })
        .collect();
    let names: Vec<String> = runs.iter().map(|r| r.spec.name.to_uppercase()).collect();
    let start = match options.q0 {
        Some(q0) => format!("starts at rest at q = {q0:?} rad, off the trajectory"),
        None => "starts on the trajectory".into(),
    };
    let replay = Replay {
        title: format!("chessarm: {scenario}, {}", names.join(" vs ")),
        arm: &setup.arm,
        board: &setup.board,
        pieces: &setup.pieces,
        table: &table,
        tolerance: DEFAULT_TOLERANCE,
        note: format!(
            "payload {} kg (the pawn is drawn where the tool would carry it); the arm {start}; choose the controller under run",
            options.payload_mass
        ),
        runs: replay_runs,
    };
    write_replay(path, &replay)
}

/// The `files` of a result, as strings.
pub fn files_of(result: &Value) -> Vec<String> {
    result["files"]
        .as_array()
        .map_or_else(Vec::new, |files| files.iter().filter_map(|f| f.as_str().map(String::from)).collect())
}
