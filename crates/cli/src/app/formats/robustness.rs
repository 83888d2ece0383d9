//! A robustness campaign's files: `robustness.csv`, one row per trial and controller in trial
//! order, and the placement errors' distribution per controller.

use crate::app::formats::plots::{Panel, Series, Style, plot_panels};
use crate::app::output::write_atomic;
use crate::app::studies::robustness::TrialRow;
use anyhow::Result;
use chessarm_core::control::choice::ControllerSpec;
use std::path::Path;

/// The rows' columns (SI but for the errors and clearance in mm), then the trial's drawn
/// parameters.
pub const HEADER: &str = "trial,trial_seed,controller,status,success,place_error_mm,pieces,misplaced,max_tip_error_mm,rms_tip_error_mm,peak_torque_nm,peak_torque_ratio,saturated_samples,rms_rate_estimate_error_rad_per_s,robot_time_s,plies,contacts,clearance_mm";

/// A row of the CSV.
pub fn csv_line(row: &TrialRow) -> String {
    let mut line = format!(
        "{},{},{},{},{},{:?},{},{},{:?},{:?},{:?},{:?},{},{:?},{:?},{},{},{:?}",
        row.trial,
        row.trial_seed,
        row.controller,
        row.status.replace(',', ";"),
        row.success(),
        row.place_error_mm,
        row.pieces,
        row.misplaced,
        row.max_tip_error_mm,
        row.rms_tip_error_mm,
        row.peak_torque_nm,
        row.peak_torque_ratio,
        row.saturated_samples,
        row.rms_rate_estimate_error,
        row.robot_time_s,
        row.plies,
        row.contacts,
        row.clearance_mm
    );
    for (_, value) in &row.drawn {
        line.push_str(&format!(",{value:?}"));
    }
    line
}

/// Writes `rows` to `path` (atomically), the header (with the drawn parameters' names) first
/// when `with_header` (a shard's CSV after the first has none, so that the shards concatenate).
pub fn write_csv(path: &Path, rows: &[TrialRow], with_header: bool) -> Result<()> {
    let drawn_names: Vec<String> = rows
        .iter()
        .find(|r| !r.drawn.is_empty())
        .map_or(Vec::new(), |r| r.drawn.iter().map(|(n, _)| n.clone()).collect());
    write_atomic(path, |writer| {
        if with_header {
            let mut header = HEADER.to_string();
            for name in &drawn_names {
                header.push(',');
                header.push_str(name);
            }
            writeln!(writer, "{header}")?;
        }
        for row in rows {
            writeln!(writer, "{}", csv_line(row))?;
        }
        Ok(())
    })
}

/// The placement-error distribution of each controller (empirical CDF, mm) with the tolerance.
pub fn draw_cdf(rows: &[TrialRow], specs: &[ControllerSpec], tolerance_mm: f64, path: &Path) -> Result<()> {
    let mut series: Vec<Series> = specs
        .iter()
        .enumerate()
        .map(|(k, spec)| {
            let mine: Vec<f64> = rows.iter().filter(|r| r.controller == spec.name).map(|r| r.place_error_mm).collect();
            // Fractions of all trials: failed runs (NaN) are left out of the curve, which then
            // ends below 1.
            let n = mine.len().max(1) as f64;
            let mut errors: Vec<f64> = mine.into_iter().filter(|e| e.is_finite()).collect();
            errors.sort_by(f64::total_cmp);
            Series {
                label: spec.name.clone(),
                points: errors.iter().enumerate().map(|(i, e)| (*e, (i + 1) as f64 / n)).collect(),
                color: k,
                style: Style::Line,
            }
        })
        .collect();
    series.push(Series {
        label: format!("tolerance {tolerance_mm} mm"),
        points: vec![(tolerance_mm, 0.0), (tolerance_mm, 1.0)],
        color: specs.len(),
        style: Style::Dashed,
    });
    let panel = Panel {
        title: "largest placement error per trial".into(),
        y_label: "fraction of trials".into(),
        series,
        ..Panel::default()
    };
    plot_panels(path, "Placement error distribution (CDF)", "placement error (mm)", &[panel])
}
