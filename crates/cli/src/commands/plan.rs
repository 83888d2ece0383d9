//! `plan`: a scenario's Cartesian path and joint trajectory, as CSV, plots and XLSX.

use crate::app::formats::hardware::MoveLabel;
use crate::app::formats::plots::{Panel, Series, Style, plot_panels};
use crate::app::output::{ensure_dir, numbered, refuse_unlisted, remove_listed_in, write_csv};
use crate::app::setup::file::JointConvention;
use crate::app::setup::file::Setup;
use crate::app::setup::file::checked_limits;
use crate::cli::PlanArgs;
use anyhow::{Result, anyhow, bail};
use chessarm_chess::motion::{PlannedMove, TimingMode, plan_move};
use chessarm_chess::notation::{parse_fen, parse_move_list};
use chessarm_chess::play::home_tool;
use chessarm_chess::scenario::{SCENARIOS, scenario};
use chessarm_chess::shakmaty::san::SanPlus;
use chessarm_chess::shakmaty::uci::UciMove;
use chessarm_chess::shakmaty::{CastlingMode, Chess, Position};
use chessarm_chess::table::Table;
use chessarm_chess::tasks::classify;
use chessarm_core::arm::task::TOOL_DOWN;
use chessarm_core::nalgebra::Vector2;
use chessarm_core::plan::hardware::{GripperCommand, hardware_points};
use chessarm_core::plan::path::sample_times;
use chessarm_core::plan::path::{CartesianPath, CartesianSample};
use chessarm_core::plan::topp::limit_curve;
use chessarm_core::plan::trajectory::ToolMotion;
use chessarm_core::plan::trajectory::{JointSample, JointTrajectory};
use serde_json::json;
use std::path::Path;

/// A planned scenario: its path, samples and joint trajectory.
#[derive(Debug)]
pub struct Plan {
    pub name: String,
    pub path: CartesianPath,
    pub cartesian: Vec<CartesianSample>,
    pub joint: JointTrajectory,
    /// Where the scenario's piece stands and the centre of its target square (board plane, m).
    pub placement: Option<(Vector2<f64>, Vector2<f64>)>,
    /// Where the arm's base axis stands (x, y, m): a gripped piece turns about it.
    pub base: Vector2<f64>,
}

/// Bytes one planned sample takes in memory: the Cartesian and joint samples and the points of
/// the plots drawn from them (3 × 3 Cartesian and 3 × 4 joint series of (t, value) pairs).
const BYTES_PER_PLAN_SAMPLE: usize = std::mem::size_of::<CartesianSample>()
    + std::mem::size_of::<JointSample>()
    + 21 * std::mem::size_of::<(f64, f64)>();

/// Plans a built-in scenario sampled every `dt` s. `cause` names the flags that set `dt` (as
/// typed), for the error when the samples would not fit in memory.
pub fn plan_scenario(setup: &Setup, name: &str, dt: f64, cause: &str) -> Result<Plan> {
    let scenario = scenario(name, &setup.board)
        .ok_or_else(|| anyhow!("unknown scenario '{name}' (known: {})", SCENARIOS.join(", ")))?;
    let path = scenario.path(&setup.board)?;
    if dt > path.duration() {
        bail!(
            "{cause}: a sample every {} s is longer than the {:.0} s scenario",
            crate::app::resources::show(dt),
            path.duration()
        );
    }
    let samples = (path.duration() / dt).ceil() + 1.0;
    crate::app::resources::ensure_fits(
        cause,
        &format!("samples of the {:.0} s scenario", path.duration()),
        samples,
        BYTES_PER_PLAN_SAMPLE as f64,
    )?;
    let cartesian = path.sample_uniform(dt)?;
    let joint = JointTrajectory::from_path(&setup.arm, &path, dt, TOOL_DOWN)
        .map_err(|e| anyhow!("scenario '{name}' cannot be followed: {e}"))?;
    let placement = Some((setup.board.square_center(scenario.from).xy(), setup.board.square_center(scenario.to).xy()));
    Ok(Plan { name: name.to_string(), path, cartesian, joint, placement, base: setup.arm.base().xy() })
}

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

/// Rows of an Excel worksheet (the header takes one).
const XLSX_ROWS: usize = 1_048_576;

/// Writes cartesian.csv, joint.csv, the two plots and (with `xlsx`) joint.xlsx into `out`.
pub fn write_plan(plan: &Plan, out: &Path, xlsx: bool, convention: &JointConvention) -> Result<Vec<String>> {
    let samples = Samples { name: &plan.name, cartesian: &plan.cartesian, joint: plan.joint.samples(), convention };
    write_samples(&samples, out, xlsx)
}

/// What [`write_samples`] writes: a name for the plots and the samples.
struct Samples<'a> {
    name: &'a str,
    cartesian: &'a [CartesianSample],
    joint: &'a [JointSample],
    /// The joints' convention of the files (a URDF's own sense).
    convention: &'a JointConvention,
}

fn write_samples(plan: &Samples<'_>, out: &Path, xlsx: bool) -> Result<Vec<String>> {
    if xlsx && plan.joint.len() >= XLSX_ROWS {
        bail!(
            "--xlsx with {} samples: a worksheet holds at most {} rows of samples; use a larger --dt or leave out --xlsx",
            plan.joint.len(),
            XLSX_ROWS - 1
        );
    }
    ensure_dir(out)?;
    let mut files = Vec::new();
    let cartesian_csv = out.join("cartesian.csv");
    let header: Vec<String> = ["t", "x", "y", "z", "vx", "vy", "vz", "ax", "ay", "az"].map(String::from).to_vec();
    write_csv(
        &cartesian_csv,
        &header,
        plan.cartesian.iter().map(|s| {
            let mut row = vec![s.t];
            row.extend(s.position.iter().chain(s.velocity.iter()).chain(s.acceleration.iter()));
            row
        }),
    )?;
    files.push(cartesian_csv);
    let joint_csv = out.join("joint.csv");
    write_csv(&joint_csv, &joint_header(), plan.joint.iter().map(|s| joint_row(s, plan.convention)))?;
    files.push(joint_csv);
    let cartesian_png = out.join("cartesian.png");
    plot_cartesian(&cartesian_png, plan)?;
    files.push(cartesian_png);
    let joint_png = out.join("joint.png");
    plot_joint(&joint_png, plan)?;
    files.push(joint_png);
    let joint_xlsx = out.join("joint.xlsx");
    if xlsx {
        write_xlsx(&joint_xlsx, plan)?;
        files.push(joint_xlsx);
    } else {
        // An earlier run's spreadsheet would no longer match joint.csv.
        crate::app::output::remove_stale(&[joint_xlsx])?;
    }
    Ok(files.iter().map(|p| p.display().to_string()).collect())
}

fn joint_header() -> Vec<String> {
    let mut header = vec!["t".to_string()];
    // The planned trajectory is what the controller will be asked to follow: the desired values.
    header.extend(numbered("q_des", 4).chain(numbered("qd_des", 4)).chain(numbered("qdd_des", 4)));
    header
}

/// A sample's row, the joints in the user's convention (a URDF's own sense).
fn joint_row(sample: &JointSample, convention: &JointConvention) -> Vec<f64> {
    let mut row = vec![sample.t];
    for values in [sample.q, sample.qd, sample.qdd] {
        row.extend(convention.user(values));
    }
    row
}

fn plot_cartesian(path: &Path, plan: &Samples<'_>) -> Result<()> {
    // Shown in cm like the report's Figure 2; the CSV stays in m.
    let axis_names = ["x", "y", "z"];
    let panel = |title: &str, unit: &str, pick: fn(&CartesianSample) -> [f64; 3]| Panel {
        title: format!("{title} of the tool tip"),
        y_label: unit.to_string(),
        series: (0..3)
            .map(|axis| Series {
                label: format!("{} {}", axis_names[axis], title),
                points: plan.cartesian.iter().map(|s| (s.t, 100.0 * pick(s)[axis])).collect(),
                color: axis,
                style: Style::Line,
            })
            .collect(),
        ..Panel::default()
    };
    plot_panels(
        path,
        &format!("Cartesian path: {}", plan.name),
        "time (s)",
        &[
            panel("position", "position (cm)", |s| s.position.into()),
            panel("velocity", "velocity (cm/s)", |s| s.velocity.into()),
            panel("acceleration", "acceleration (cm/s²)", |s| s.acceleration.into()),
        ],
    )
}

fn plot_joint(path: &Path, plan: &Samples<'_>) -> Result<()> {
    let panel = |title: &str, unit: &str, pick: fn(&JointSample) -> [f64; 4]| Panel {
        title: title.to_string(),
        y_label: unit.to_string(),
        series: (0..4)
            .map(|j| Series {
                label: format!("θ{}", j + 1),
                // In the user's convention, as joint.csv (a URDF's own sense).
                points: plan.joint.iter().map(|s| (s.t, plan.convention.signs[j] * pick(s)[j])).collect(),
                color: j,
                style: Style::Line,
            })
            .collect(),
        ..Panel::default()
    };
    plot_panels(
        path,
        &format!("Joint-space trajectory: {}", plan.name),
        "time (s)",
        &[
            panel("joint angles", "angle (rad)", |s| s.q.into()),
            panel("joint velocities", "velocity (rad/s)", |s| s.qd.into()),
            panel("joint accelerations", "acceleration (rad/s²)", |s| s.qdd.into()),
        ],
    )
}

#[cfg(feature = "xlsx")]
fn write_xlsx(path: &Path, plan: &Samples<'_>) -> Result<()> {
    use rust_xlsxwriter::{DocProperties, ExcelDateTime, Workbook};
    let mut workbook = Workbook::new();
    // A fixed creation time (the Unix epoch) instead of the clock's: the same plan gives the
    // same bytes on every run.
    workbook.set_properties(&DocProperties::new().set_creation_datetime(&ExcelDateTime::from_timestamp(0)?));
    let sheet = workbook.add_worksheet();
    sheet.set_name("joint trajectory")?;
    for (column, name) in joint_header().iter().enumerate() {
        sheet.write_string(0, column as u16, name)?;
    }
    for (row, sample) in plan.joint.iter().enumerate() {
        for (column, value) in joint_row(sample, plan.convention).iter().enumerate() {
            sheet.write_number(row as u32 + 1, column as u16, *value)?;
        }
    }
    let bytes = workbook.save_to_buffer()?;
    crate::app::output::write_atomic(path, |writer| Ok(writer.write_all(&bytes)?))
}

#[cfg(not(feature = "xlsx"))]
fn write_xlsx(_path: &Path, _plan: &Samples<'_>) -> Result<()> {
    anyhow::bail!("this chessarm was built without the 'xlsx' feature; rebuild with --features xlsx")
}

/// `plan --moves`: plans each move by the robot from the start position (pieces put exactly on
/// their targets), writes the whole sequence's path and joint trajectory sampled every `--dt`
/// and, for time-optimal timing, one phase-plane plot per move (`phase-NNN-UCI.png`: ṡ against
/// s of every leg with each family of limits' own speed limit curve and the controllable set).
fn run_moves(setup: &Setup, args: &PlanArgs, moves: &str) -> Result<()> {
    let start = match &args.fen {
        Some(fen) => parse_fen(fen)?,
        None => Chess::default(),
    };
    let record = parse_move_list(moves, start)?;
    let limits = checked_limits(setup.motion, "motion", "gripper")?;
    let mut table = Table::from_position(setup.board, &record.start);
    // The same check as `play`'s before its first move.
    chessarm_chess::reach::check_table(&setup.arm, &setup.board, &setup.pieces, &limits).map_err(|e| {
        anyhow!("the table cannot be served by this arm: {e}; `chessarm board --fit` finds a board it serves")
    })?;
    let mut tool = home_tool(&setup.board, &setup.pieces, &limits);
    let mut position = record.start.clone();
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
    let mut cartesian = Vec::new();
    let mut joint = Vec::new();
    let mut offset = 0.0;
    let mut summaries = Vec::new();
    let mut files = Vec::new();
    let mut phase_files = Vec::new();
    let hardware = hardware_dir(&args.out)?;
    for (index, mv) in record.moves.iter().enumerate() {
        let san = SanPlus::from_move(position.clone(), *mv).to_string();
        let uci = UciMove::from_move(*mv, CastlingMode::Standard).to_string();
        let planned =
            plan_move(tool, &position, mv, &table, &setup.pieces, &limits, &setup.arm, setup.timing, CONTROL_PERIOD)?;
        let motion = &planned.motion;
        let duration = motion.duration();
        let sampled = JointTrajectory::from_path(&setup.arm, motion, args.dt, TOOL_DOWN)
            .map_err(|e| anyhow!("move {san}: {e}"))?;
        cartesian
            .extend(sample_times(duration, args.dt)?.map(|t| CartesianSample { t: t + offset, ..motion.sample(t) }));
        joint.extend(sampled.samples().iter().map(|s| JointSample { t: s.t + offset, ..*s }));
        let name = format!("{:03}-{uci}", index + 1);
        let grips = planned.tasks.iter().map(|t| t.task.to_string()).collect();
        let commands = planned.gripper_commands();
        // The fine points at `play`'s default tolerance for sensors of unknown resolution (the
        // coarsest default band, a tenth of the tolerance; plan has no --sensors).
        let label = MoveLabel {
            ply: index + 1,
            san: &san,
            uci: &uci,
            grips,
            fine_points: commands.iter().map(|c| motion.sample(c.time).position).collect(),
            in_position: Some(chessarm_core::plan::fine_point::InPosition::for_tolerance(
                chessarm_chess::play::DEFAULT_TOLERANCE,
            )),
            finger_opening: Some(setup.clearance.gripper.finger_opening),
        };
        files.extend(write_hardware(setup, &hardware, &name, motion, &commands, &label, args.export_rate)?);
        if !planned.legs.is_empty() {
            let png = args.out.join(format!("phase-{name}.png"));
            plot_phase_plane(&png, &format!("Phase plane of {san} ({uci}): why it takes {duration:.2} s"), &planned)?;
            phase_files.push(png.display().to_string());
        }
        summaries.push(json!({
            "ply": index + 1,
            "san": san,
            "uci": uci,
            "kind": classify(&position, mv).name(),
            "start_s": offset,
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
        for task in &planned.tasks {
            let target = table.nominal_position(task.task.to);
            table.relocate(task.task.from, task.task.to, target).map_err(|e| anyhow!("move {san}: {e}"))?;
        }
        tool = motion.end();
        position.play_unchecked(*mv);
        offset += duration;
    }
    let name = format!("moves {moves}");
    files.extend(write_samples(
        &Samples { name: &name, cartesian: &cartesian, joint: &joint, convention: &setup.convention },
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
    let points = hardware_points(&setup.arm, motion, commands, TOOL_DOWN, rate).map_err(|e| {
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

/// The control period moves are planned for, s (as `play` simulates them).
const CONTROL_PERIOD: f64 = 1e-3;

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
