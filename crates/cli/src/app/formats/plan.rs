//! The plan's files: `cartesian.csv`, `joint.csv` (and with `xlsx` `joint.xlsx`), and the two
//! plots of the tool's path and the joints' trajectory.

use crate::app::formats::plots::{Panel, Series, Style, plot_panels};
use crate::app::output::{ensure_dir, numbered, write_csv};
use crate::app::setup::file::JointConvention;
use crate::app::studies::plan::Plan;
use anyhow::{Result, bail};
use chessarm_core::plan::path::CartesianSample;
use chessarm_core::plan::trajectory::JointSample;
use std::path::Path;

/// Rows of an Excel worksheet (the header takes one).
const XLSX_ROWS: usize = 1_048_576;

/// Writes cartesian.csv, joint.csv, the two plots and (with `xlsx`) joint.xlsx into `out`.
pub fn write_plan(plan: &Plan, out: &Path, xlsx: bool, convention: &JointConvention) -> Result<Vec<String>> {
    let samples = Samples { name: &plan.name, cartesian: &plan.cartesian, joint: plan.joint.samples(), convention };
    write_samples(&samples, out, xlsx)
}

/// What [`write_samples`] writes: a name for the plots and the samples.
#[derive(Debug)]
pub struct Samples<'a> {
    pub name: &'a str,
    pub cartesian: &'a [CartesianSample],
    pub joint: &'a [JointSample],
    /// The joints' convention of the files (a URDF's own sense).
    pub convention: &'a JointConvention,
}

/// Writes the samples' CSV files, plots and (with `xlsx`) workbook into `out`; the files written.
pub fn write_samples(plan: &Samples<'_>, out: &Path, xlsx: bool) -> Result<Vec<String>> {
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
