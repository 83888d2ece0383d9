//! A sweep's files: `tune.csv`, one row per candidate in sweep order, and the heat map of the
//! ranking metric over the swept gains.

use crate::app::formats::plots::{HeatMap, plot_heat_map};
use crate::app::output::write_atomic;
use crate::app::setup::file::Setup;
use crate::app::studies::tune::{Candidate, Metric, TuneOptions, Tuned, edge_warning};
use anyhow::{Result, bail};
use std::path::Path;

/// A torque sweep's columns (tip errors in mm, torques in N·m).
pub const CSV_HEADER: &str = "index,kp,kd,ki,status,max_tip_error_mm,rms_tip_error_mm,place_error_mm,rms_joint_error_rad,max_joint_error_rad,peak_torque_nm,peak_torque_ratio,saturated_samples,misplaced";
/// A servo sweep's columns: the host strategy and the P register instead of the gains;
/// `saturated_samples` counts the servos' duty at its limit (a servo's normal state on a fast
/// move, not a failure).
pub const SERVO_CSV_HEADER: &str = "index,servo_command,p_gain,status,max_tip_error_mm,rms_tip_error_mm,place_error_mm,rms_joint_error_rad,max_joint_error_rad,peak_torque_nm,peak_torque_ratio,saturated_samples,misplaced";

/// A candidate's CSV row.
pub fn csv_line(candidate: &Candidate) -> String {
    let c = candidate;
    let setting = match c.servo_command {
        Some(command) => format!("{},{:?}", command.name(), c.p_gain),
        None => format!("{:?},{:?},{:?}", c.kp, c.kd, c.ki),
    };
    format!(
        "{},{setting},{},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{},{}",
        c.index,
        c.status.replace(',', ";"),
        c.max_tip_error_mm,
        c.rms_tip_error_mm,
        c.place_error_mm,
        c.rms_joint_error_rad,
        c.max_joint_error_rad,
        c.peak_torque_nm,
        c.peak_torque_ratio,
        c.saturated_samples,
        c.misplaced
    )
}

/// Writes `tuned`'s rows to `path` (atomically), the header first when `with_header` (a
/// shard's CSV after the first has none, so that the shards concatenate).
pub fn write_csv(path: &Path, tuned: &Tuned, with_header: bool) -> Result<()> {
    write_atomic(path, |writer| {
        if with_header {
            writeln!(writer, "{}", if tuned.servos { SERVO_CSV_HEADER } else { CSV_HEADER })?;
        }
        for candidate in &tuned.candidates {
            writeln!(writer, "{}", csv_line(candidate))?;
        }
        Ok(())
    })
}

/// The sweep's heat map of `metric`: over kp and kd for a torque sweep, over the P register
/// and the host strategy for servos.
pub fn draw_heat_map(setup: &Setup, options: &TuneOptions, tuned: &Tuned, metric: Metric, path: &Path) -> Result<()> {
    if tuned.servos {
        draw_servo_heat_map(setup, options, tuned, metric, path)
    } else {
        draw_torque_heat_map(options, tuned, metric, path)
    }
}

/// Heat map over kp (x) and kd (y); with a ki sweep each cell shows the best over ki. Failed
/// candidates are grey; the best one within the torque limits is framed.
fn draw_torque_heat_map(options: &TuneOptions, tuned: &Tuned, metric: Metric, path: &Path) -> Result<()> {
    let candidates = &tuned.candidates;
    let (Some(kp_range), Some(kd_range)) = (options.kp, options.kd) else {
        bail!("a torque sweep has --kp and --kd ranges")
    };
    let (kp_values, kd_values) = (kp_range.values(), kd_range.values());
    let per_cell = options.ki.map_or(1, |r| r.count);
    let mut cells = vec![vec![None::<f64>; kp_values.len()]; kd_values.len()];
    let mut best: Option<(f64, (usize, usize))> = None;
    for candidate in candidates {
        let cell = candidate.index / per_cell;
        let (row, column) = (cell % kd_values.len(), cell / kd_values.len());
        let value = candidate.metric(metric);
        if candidate.status == "ok" && value.is_finite() {
            let slot = &mut cells[row][column];
            *slot = Some(slot.map_or(value, |v: f64| v.min(value)));
            if candidate.respects_limits() && best.is_none_or(|(b, _)| value < b) {
                best = Some((value, (row, column)));
            }
        }
    }
    let mut title = format!("{} sweep: {}", if per_cell > 1 { "PID" } else { "PD" }, metric.label());
    let from = options.tracking_from();
    if from > 0.0 && matches!(metric, Metric::MaxTipError | Metric::RmsJointError) {
        title.push_str(&format!(" from t = {} s", crate::app::resources::show(from)));
    }
    plot_heat_map(
        path,
        &HeatMap {
            title: &title,
            x_label: "kp (1/s²)",
            y_label: "kd (1/s)",
            value_label: metric.label(),
            x_values: &kp_values,
            y_values: &kd_values,
            y_names: None,
            values: &cells,
            marked: best.map(|(_, cell)| cell),
            grey: "failed",
            note: edge_warning(options, tuned.best(metric, 1).first().copied()),
        },
    )
}

/// A servo sweep's heat map: the P register (x) against the host strategy (y).
fn draw_servo_heat_map(setup: &Setup, options: &TuneOptions, tuned: &Tuned, metric: Metric, path: &Path) -> Result<()> {
    let candidates = &tuned.candidates;
    let Some(range) = options.p_gain else { bail!("a servo sweep has a --p-gain range") };
    let p_values = range.values();
    let names: Vec<String> = setup.servo_commands.iter().map(|c| c.name().to_string()).collect();
    let rows: Vec<f64> = (0..names.len()).map(|k| k as f64).collect();
    let mut cells = vec![vec![None::<f64>; p_values.len()]; names.len()];
    let mut best: Option<(f64, (usize, usize))> = None;
    for candidate in candidates {
        let (row, column) = (candidate.index / p_values.len(), candidate.index % p_values.len());
        let value = candidate.metric(metric);
        if candidate.status == "ok" && value.is_finite() {
            cells[row][column] = Some(value);
            if candidate.respects_limits() && best.is_none_or(|(b, _)| value < b) {
                best = Some((value, (row, column)));
            }
        }
    }
    let mut servos = setup.actuator_names.to_vec();
    servos.dedup();
    let title = format!("servo sweep ({}): {}", servos.join(", "), metric.label());
    plot_heat_map(
        path,
        &HeatMap {
            title: &title,
            x_label: "P gain (the servo's register)",
            y_label: "host strategy",
            value_label: metric.label(),
            x_values: &p_values,
            y_values: &rows,
            y_names: Some(&names),
            values: &cells,
            marked: best.map(|(_, cell)| cell),
            grey: "failed",
            note: edge_warning(options, tuned.best(metric, 1).first().copied()),
        },
    )
}
