//! `plan`: a scenario's Cartesian path and joint trajectory, as CSV, plots and XLSX.

use crate::cli::PlanArgs;
use crate::config::Setup;
use crate::output::{ensure_dir, numbered, write_csv};
use crate::plots::{Panel, Series, plot_panels};
use crate::print_json;
use anyhow::{Result, anyhow, bail};
use chessarm_chess::scenario::{SCENARIOS, scenario};
use chessarm_core::arm::task::TOOL_DOWN;
use chessarm_core::nalgebra::Vector2;
use chessarm_core::plan::path::{CartesianPath, CartesianSample};
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
            crate::resources::show(dt),
            path.duration()
        );
    }
    let samples = (path.duration() / dt).ceil() + 1.0;
    crate::resources::ensure_fits(
        cause,
        &format!("samples of the {:.0} s scenario", path.duration()),
        samples,
        BYTES_PER_PLAN_SAMPLE as f64,
    )?;
    let cartesian = path.sample_uniform(dt)?;
    let joint = JointTrajectory::from_path(&setup.arm, &path, dt, TOOL_DOWN)
        .map_err(|e| anyhow!("scenario '{name}' cannot be followed: {e}"))?;
    let placement = Some((setup.board.square_center(scenario.from).xy(), setup.board.square_center(scenario.to).xy()));
    Ok(Plan { name: name.to_string(), path, cartesian, joint, placement })
}

pub fn run(setup: &Setup, args: &PlanArgs) -> Result<()> {
    let cause = format!("--dt {}", crate::resources::show(args.dt));
    let plan = plan_scenario(setup, &args.scenario, args.dt, &cause)?;
    let files = write_plan(&plan, &args.out, args.xlsx)?;
    let samples = plan.joint.samples();
    let peak = |f: fn(&JointSample) -> [f64; 4]| -> Vec<f64> {
        (0..4).map(|j| samples.iter().map(|s| f(s)[j].abs()).fold(0.0, f64::max)).collect()
    };
    print_json(&json!({
        "scenario": plan.name,
        "duration_s": plan.path.duration(),
        "dt_s": args.dt,
        "samples": samples.len(),
        "peak_joint_rate_rad_s": peak(|s| s.qd.into()),
        "peak_joint_acceleration_rad_s2": peak(|s| s.qdd.into()),
        "files": files,
    }))?;
    Ok(())
}

/// Rows of an Excel worksheet (the header takes one).
const XLSX_ROWS: usize = 1_048_576;

/// Writes cartesian.csv, joint.csv, the two plots and (with `xlsx`) joint.xlsx into `out`.
pub fn write_plan(plan: &Plan, out: &Path, xlsx: bool) -> Result<Vec<String>> {
    if xlsx && plan.joint.samples().len() >= XLSX_ROWS {
        bail!(
            "--xlsx with {} samples: a worksheet holds at most {} rows of samples; use a larger --dt or leave out --xlsx",
            plan.joint.samples().len(),
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
    write_csv(&joint_csv, &joint_header(), plan.joint.samples().iter().map(joint_row))?;
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
        crate::output::remove_stale(&[joint_xlsx])?;
    }
    Ok(files.iter().map(|p| p.display().to_string()).collect())
}

fn joint_header() -> Vec<String> {
    let mut header = vec!["t".to_string()];
    // The planned trajectory is what the controller will be asked to follow: the desired values.
    header.extend(numbered("q_des", 4).chain(numbered("qd_des", 4)).chain(numbered("qdd_des", 4)));
    header
}

fn joint_row(sample: &JointSample) -> Vec<f64> {
    let mut row = vec![sample.t];
    row.extend(sample.q.iter().chain(sample.qd.iter()).chain(sample.qdd.iter()));
    row
}

fn plot_cartesian(path: &Path, plan: &Plan) -> Result<()> {
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
                dashed: false,
            })
            .collect(),
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

fn plot_joint(path: &Path, plan: &Plan) -> Result<()> {
    let panel = |title: &str, unit: &str, pick: fn(&JointSample) -> [f64; 4]| Panel {
        title: title.to_string(),
        y_label: unit.to_string(),
        series: (0..4)
            .map(|j| Series {
                label: format!("θ{}", j + 1),
                points: plan.joint.samples().iter().map(|s| (s.t, pick(s)[j])).collect(),
                color: j,
                dashed: false,
            })
            .collect(),
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
fn write_xlsx(path: &Path, plan: &Plan) -> Result<()> {
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
    for (row, sample) in plan.joint.samples().iter().enumerate() {
        for (column, value) in joint_row(sample).iter().enumerate() {
            sheet.write_number(row as u32 + 1, column as u16, *value)?;
        }
    }
    let bytes = workbook.save_to_buffer()?;
    crate::output::write_atomic(path, |writer| Ok(writer.write_all(&bytes)?))
}

#[cfg(not(feature = "xlsx"))]
fn write_xlsx(_path: &Path, _plan: &Plan) -> Result<()> {
    anyhow::bail!("this chessarm was built without the 'xlsx' feature; rebuild with --features xlsx")
}
