//! `plan`: a scenario's Cartesian path and joint trajectory, as CSV, plots and XLSX.

use crate::app::formats::hardware::MoveLabel;
use crate::app::formats::plan::{Samples, write_plan, write_samples};
use crate::app::formats::plots::{Panel, Series, Style, plot_panels};
use crate::app::output::{ensure_dir, refuse_unlisted, remove_listed_in};
use crate::app::setup::file::Setup;
use crate::app::studies::plan::{plan_moves, plan_scenario};
use crate::cli::PlanArgs;
use anyhow::{Result, anyhow};
use chessarm_chess::motion::{PlannedMove, TimingMode};
use chessarm_core::plan::hardware::{GripperCommand, hardware_points};
use chessarm_core::plan::topp::limit_curve;
use chessarm_core::plan::trajectory::JointSample;
use chessarm_core::plan::trajectory::ToolMotion;
use serde_json::json;
use std::path::Path;

pub fn run(setup: &Setup, args: &PlanArgs) -> Result<()> {
    if let Some(moves) = &args.moves {
        let setup = args.motion.apply(setup)?;
        if setup.motion.tracking.budget > 0.0 {
            crate::tell(
                "note: plan has no controller and no model errors, so the tracking budget does not apply \
                 (it does in play, robustness and tune)",
            );
        }
        return run_moves(&setup, args, moves);
    }
    let cause = format!("--dt {}", crate::app::resources::show(args.dt));
    let plan = plan_scenario(setup, &args.scenario, args.dt, &cause)?;
    let mut files = write_plan(&plan, &args.out, args.xlsx, &setup.convention)?;
    let hardware = hardware_dir(&args.out)?;
    let commands: Vec<GripperCommand> =
        plan.path.events().iter().map(|e| GripperCommand { time: e.time, action: e.action }).collect();
    let grips = vec![format!("the {} scenario's piece", plan.name); commands.len() / 2];
    // The report's scenario goes by the clock, as its Simulink model did.
    let label = MoveLabel {
        ply: 1,
        san: &plan.name,
        uci: "",
        grips,
        fine_points: Vec::new(),
        in_position: None,
        finger_opening: Some(setup.clearance.gripper.finger_opening),
        widths: Vec::new(),
    };
    files.extend(write_hardware(setup, &hardware, "scenario", &plan.path, &commands, &label, args.export_rate)?);
    let samples = plan.joint.samples();
    let peak = |f: fn(&JointSample) -> [f64; 4]| -> Vec<f64> {
        (0..4).map(|j| samples.iter().map(|s| f(s)[j].abs()).fold(0.0, f64::max)).collect()
    };
    let peaks = |values: &[f64]| values.iter().map(|v| format!("{v:.3}")).collect::<Vec<_>>().join(", ");
    let human = format!(
        "planned {}: {:.2} s, {} samples every {} s; peak joint rates [{}] rad/s, accelerations [{}] rad/s²\n{}",
        plan.name,
        plan.path.duration(),
        samples.len(),
        crate::app::resources::show(args.dt),
        peaks(&peak(|s| s.qd.into())),
        peaks(&peak(|s| s.qdd.into())),
        crate::files_text(&files)
    );
    crate::emit(
        &human,
        &json!({
            "scenario": plan.name,
            "duration_s": plan.path.duration(),
            "dt_s": args.dt,
            "samples": samples.len(),
            "peak_joint_rate_rad_s": peak(|s| s.qd.into()),
            "peak_joint_acceleration_rad_s2": peak(|s| s.qdd.into()),
            "files": files,
        }),
    )?;
    Ok(())
}

/// `plan --moves`: plans each move by the robot from the start position (pieces put exactly on
/// their targets), writes the whole sequence's path and joint trajectory sampled every `--dt`
/// and, for time-optimal timing, one phase-plane plot per move (`phase-NNN-UCI.png`: ṡ against
/// s of every leg with each family of limits' own speed limit curve and the controllable set).
fn run_moves(setup: &Setup, args: &PlanArgs, moves: &str) -> Result<()> {
    let plan = plan_moves(setup, args.fen.as_deref(), moves, args.dt)?;
    ensure_dir(&args.out)?;
    // An earlier run's phase planes of other moves would pass for this run's: those chessarm
    // wrote are removed (a file of that name it did not write is an error, and stays).
    let earlier: Vec<std::path::PathBuf> = std::fs::read_dir(&args.out)?
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with("phase-") && n.ends_with(".png"))
        })
        .collect();
    crate::app::output::remove_stale(&earlier)?;
    let mut summaries = Vec::new();
    let mut files = Vec::new();
    let mut phase_files = Vec::new();
    let hardware = hardware_dir(&args.out)?;
    for ply in &plan.plies {
        let (planned, san, uci, duration) = (&ply.planned, &ply.san, &ply.uci, ply.planned.motion.duration());
        let motion = &planned.motion;
        let name = format!("{:03}-{uci}", ply.ply);
        let grips = planned.tasks.iter().map(|t| t.task.to_string()).collect();
        let reach = setup.clearance.gripper.finger_reach;
        let widths =
            planned.tasks.iter().map(|t| setup.pieces.dimensions(t.task.piece.role).grip_width(reach)).collect();
        let commands = planned.gripper_commands();
        // The fine points at `play`'s default tolerance for sensors of unknown resolution (the
        // coarsest default band, a tenth of the tolerance; plan has no --sensors).
        let label = MoveLabel {
            ply: ply.ply,
            san,
            uci,
            grips,
            fine_points: commands.iter().map(|c| motion.sample(c.time).position).collect(),
            in_position: Some(chessarm_core::plan::fine_point::InPosition::for_tolerance(
                chessarm_chess::play::DEFAULT_TOLERANCE,
            )),
            finger_opening: Some(setup.clearance.gripper.finger_opening),
            widths,
        };
        files.extend(write_hardware(setup, &hardware, &name, motion, &commands, &label, args.export_rate)?);
        if !planned.legs.is_empty() {
            let png = args.out.join(format!("phase-{name}.png"));
            plot_phase_plane(&png, &format!("Phase plane of {san} ({uci}): why it takes {duration:.2} s"), planned)?;
            phase_files.push(png.display().to_string());
        }
        summaries.push(json!({
            "ply": ply.ply,
            "san": san,
            "uci": uci,
            "kind": ply.kind,
            "start_s": ply.start,
            "duration_s": duration,
            "phases_s": {
                "travel": planned.phases.travel,
                "vertical": planned.phases.vertical,
                "grip": planned.phases.grip,
                "pause": planned.phases.pause,
            },
            "longest_limit": planned.longest_limit().map(|(limit, time)| json!({"limit": limit, "time_s": time})),
            "most_used_limit": planned.usage.as_ref().map(|u| json!({"limit": u.limit, "share": u.share})),
            "legs": planned.legs.iter().map(|leg| json!({
                "length_m": leg.leg.path.length(),
                "duration_s": leg.leg.duration(),
                "limit_time_s": leg
                    .time_per_limit()
                    .into_iter()
                    .filter(|(_, t)| *t > 0.0)
                    .map(|(name, t)| (name, json!(t * leg.leg.scale)))
                    .collect::<serde_json::Map<_, _>>(),
            })).collect::<Vec<_>>(),
        }));
    }
    let (cartesian, joint, offset) = (&plan.cartesian, &plan.joint, plan.duration);
    let name = format!("moves {moves}");
    files.extend(write_samples(
        &Samples { name: &name, cartesian, joint, convention: &setup.convention },
        &args.out,
        args.xlsx,
    )?);
    files.extend(phase_files);
    let mut human = format!("{:>4} {:>8} {:>8} {:>10}  {}\n", "ply", "san", "uci", "time s", "longest limit");
    for summary in &summaries {
        let limit = &summary["longest_limit"];
        human.push_str(&format!(
            "{:>4} {:>8} {:>8} {:>10.3}  {}\n",
            summary["ply"].as_u64().unwrap_or(0),
            summary["san"].as_str().unwrap_or(""),
            summary["uci"].as_str().unwrap_or(""),
            summary["duration_s"].as_f64().unwrap_or(f64::NAN),
            limit["limit"]
                .as_str()
                .map_or("-".to_string(), |l| format!("{l} for {:.3} s", limit["time_s"].as_f64().unwrap_or(f64::NAN)))
        ));
    }
    human.push_str(&format!("{offset:.3} s in all\n{}", crate::files_text(&files)));
    crate::emit(
        &human,
        &json!({
            "moves": summaries,
            "timing": match setup.timing { TimingMode::Optimal => "optimal", TimingMode::Lspb => "lspb" },
            "duration_s": offset,
            "dt_s": args.dt,
            "files": files,
        }),
    )?;
    Ok(())
}

/// `<out>/hardware`, made, with an earlier run's files there removed (only those chessarm
/// listed; another file named like one of its own is an error).
fn hardware_dir(out: &Path) -> Result<std::path::PathBuf> {
    let dir = out.join("hardware");
    remove_listed_in(&dir)?;
    refuse_unlisted(&dir, |name| name.ends_with(".csv") || name.ends_with(".json"))?;
    ensure_dir(&dir)?;
    Ok(dir)
}

/// Samples `motion` for hardware at `rate` Hz and writes `<dir>/<stem>.json` and `.csv`.
fn write_hardware(
    setup: &Setup,
    dir: &Path,
    stem: &str,
    motion: &impl ToolMotion,
    commands: &[GripperCommand],
    label: &MoveLabel<'_>,
    rate: f64,
) -> Result<Vec<String>> {
    let points = hardware_points(&setup.arm, motion, commands, rate).map_err(|e| {
        anyhow!("{}: the hardware trajectory: {e}", if label.uci.is_empty() { label.san } else { label.uci })
    })?;
    crate::app::formats::hardware::write_move(
        dir,
        stem,
        (&setup.base_link, &setup.joint_names, &setup.convention),
        &points,
        commands,
        label,
        rate,
    )
}

/// One panel per leg: the planned ṡ(s), the bound of the controllable set, and for each family
/// of limits (joint speed, joint acceleration, joint torque, tool speed, carry acceleration,
/// grip) the largest ṡ it alone allows at each s (the lowest over its joints).
fn plot_phase_plane(path: &Path, title: &str, planned: &PlannedMove) -> Result<()> {
    let mut panels = Vec::with_capacity(planned.legs.len());
    for (k, leg) in planned.legs.iter().enumerate() {
        let timing = &leg.leg.timing;
        let table = &leg.table;
        // The motion runs stretched by the leg's scale (to whole control periods); the limit
        // curves and the controllable set belong to the path and are drawn unstretched.
        let speed = |x: f64| x.max(0.0).sqrt();
        let planned_speed: Vec<(f64, f64)> =
            timing.s.iter().zip(&timing.x).map(|(s, x)| (*s, speed(*x) / leg.leg.scale)).collect();
        let top = planned_speed.iter().map(|p| p.1).fold(0.0, f64::max).max(1e-3);
        // Curves far above the motion say nothing; they are cut at 3× its top speed.
        let cap = 3.0 * top;
        let mut series =
            vec![Series { label: "planned ṡ".into(), points: planned_speed, color: 3, style: Style::Line }];
        series.push(Series {
            label: "largest ṡ that can still stop (controllable set)".into(),
            points: timing.s.iter().zip(&timing.controllable).map(|(s, (_, hi))| (*s, speed(*hi).min(cap))).collect(),
            color: 7,
            style: Style::Dashed,
        });
        let mut families: Vec<String> = Vec::new();
        for name in &leg.names {
            let family = family_of(name);
            if !families.contains(&family) {
                families.push(family);
            }
        }
        for (color, family) in families.iter().enumerate() {
            let members: Vec<u16> =
                leg.names.iter().enumerate().filter(|(_, n)| family_of(n) == *family).map(|(i, _)| i as u16).collect();
            let points: Vec<(f64, f64)> = (0..table.len())
                .map(|i| {
                    let x = limit_curve(table, i, |id| members.contains(&id.0));
                    (table.grid()[i], speed(x).min(cap))
                })
                .collect();
            if points.iter().all(|p| p.1 >= cap) {
                continue;
            }
            series.push(Series {
                label: family.clone(),
                points,
                color: color % 3 + 4 * usize::from(color >= 3),
                style: Style::Line,
            });
        }
        let carrying = leg.names.iter().any(|n| n == "tool acceleration while carrying");
        let binding = leg
            .time_per_limit()
            .into_iter()
            .filter(|(_, t)| *t > 0.0)
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map_or_else(String::new, |(name, t)| format!("; binding longest: {name} ({:.2} s)", t * leg.leg.scale));
        panels.push(Panel {
            title: format!(
                "leg {} ({}): {:.3} m in {:.3} s{binding}",
                k + 1,
                if carrying { "carrying" } else { "empty" },
                leg.leg.path.length(),
                leg.leg.duration()
            ),
            y_label: "ṡ (m/s)".into(),
            series,
            ..Panel::default()
        });
    }
    plot_panels(path, title, "path parameter s (m; arc length on lines)", &panels)
}

/// "joint 2 torque" → "joint torque"; other names unchanged.
fn family_of(name: &str) -> String {
    match name.strip_prefix("joint ") {
        Some(rest) => match rest.split_once(' ') {
            Some((_, what)) => format!("joint {what}"),
            None => name.to_string(),
        },
        None => name.to_string(),
    }
}
