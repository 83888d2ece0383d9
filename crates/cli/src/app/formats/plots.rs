//! Line plots and heat maps as PNG (plotters, bitmap backend, embedded DejaVu Sans font).
//! Callers convert units for display and say so in the axis labels.

use crate::app::output::render_atomic;
pub use crate::app::text::tick;
use anyhow::{Result, anyhow};
use plotters::prelude::*;
use plotters::style::FontStyle;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;
use std::sync::Once;

static FONT: &[u8] = include_bytes!("../../../assets/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

fn register_font() {
    REGISTER.call_once(|| {
        // The font is compiled in; registration only fails on a corrupt font file.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// Distinguishable line colours (red, green, blue, black, then more).
pub const PALETTE: [RGBColor; 8] = [
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(31, 119, 180),
    RGBColor(0, 0, 0),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
    RGBColor(140, 86, 75),
];

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Style {
    /// A solid line (measured values).
    #[default]
    Line,
    /// A dashed line (desired/reference values).
    Dashed,
    /// Unjoined points (one value per ply, per trial).
    Points,
}

/// One series of a panel.
#[derive(Debug, Clone, Default)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    /// Index into [`PALETTE`].
    pub color: usize,
    pub style: Style,
}

/// A horizontal line across a panel: a limit or a tolerance.
#[derive(Debug, Clone)]
pub struct Level {
    pub value: f64,
    pub label: String,
    /// Index into [`PALETTE`].
    pub color: usize,
}

/// A marked instant: a vertical line with a label written beside it (e.g. the grip and the
/// errors there).
#[derive(Debug, Clone)]
pub struct Mark {
    pub x: f64,
    pub label: String,
}

/// One chart of a stacked figure.
#[derive(Debug, Clone, Default)]
pub struct Panel {
    pub title: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Horizontal lines (limits, tolerances), in the legend.
    pub levels: Vec<Level>,
    /// Vertical lines at instants, labelled on the plot.
    pub marks: Vec<Mark>,
    /// Stretches of x shaded, and what they mean (for the legend).
    pub shaded: Vec<(f64, f64)>,
    pub shaded_label: String,
    /// y on a logarithmic scale (values ≤ 0 are left out): for errors that span decades.
    pub log_y: bool,
    /// Show only this x range (a zoom); all the data otherwise.
    pub x_range: Option<(f64, f64)>,
    /// Whole-number x ticks only (plies).
    pub integer_x: bool,
    /// Where the legend goes.
    pub legend: Corner,
}

/// A corner of a panel, for its legend.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Corner {
    #[default]
    UpperRight,
    LowerRight,
    UpperLeft,
    LowerLeft,
    /// No legend: the title says what is drawn.
    Hidden,
}

/// Largest |value| an axis takes in: beyond it the span and its padding could overflow to
/// infinity, on which the axis' ticks never end (a torque limit of 1e308 drawn as a level).
/// Such values are left off the axis (and a level there is not drawn).
const AXIS_LIMIT: f64 = 1e300;

fn range_of(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (low, high) = values
        .filter(|v| v.is_finite() && v.abs() <= AXIS_LIMIT)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if !low.is_finite() {
        return (-1.0, 1.0);
    }
    let span = high - low;
    let pad = if span > 1e-12 { 0.05 * span } else { low.abs().max(1.0) * 0.05 };
    (low - pad, high + pad)
}

/// The label of an axis position: its value, or on a log scale (positions are log10 of the
/// value) the value at whole decades only.
fn scale_tick(position: f64, log: bool) -> String {
    if !log {
        tick(position)
    } else if (position - position.round()).abs() > 1e-6 {
        String::new()
    } else {
        tick(10f64.powf(position))
    }
}

/// Draws `panels` stacked vertically over a shared x axis into the PNG at `path`.
pub fn plot_panels(path: &Path, title: &str, x_label: &str, panels: &[Panel]) -> Result<()> {
    register_font();
    let height = 40 + 300 * panels.len() as u32;
    render_atomic(path, |temporary| {
        let root = BitMapBackend::new(temporary, (1200, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
        let root = root.titled(title, ("sans-serif", 26)).map_err(|e| anyhow!("{e}"))?;
        let areas = root.split_evenly((panels.len(), 1));
        for (area, panel) in areas.iter().zip(panels) {
            draw_panel(area, panel, x_label).map_err(|e| anyhow!("{e}"))?;
        }
        root.present().map_err(|e| anyhow!("{e}"))?;
        Ok(())
    })
}

fn draw_panel(
    area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    panel: &Panel,
    x_label: &str,
) -> Result<(), Box<dyn std::error::Error>> {
    let inside = |x: f64| panel.x_range.is_none_or(|(a, b)| x >= a && x <= b);
    let positive = panel.series.iter().flat_map(|s| s.points.iter()).filter(|p| inside(p.0) && p.1 > 0.0);
    let (smallest, largest) = positive.fold((f64::INFINITY, 0.0f64), |(lo, hi), p| (lo.min(p.1), hi.max(p.1)));
    // A log scale where the values span two decades or more (else the linear one reads
    // better); on it the values drawn are log10(y), the labels show y, and at most six decades
    // under the largest value are shown (below that is rounding): smaller values are left out.
    let log = panel.log_y && largest >= 100.0 * smallest;
    let floor = largest.log10() - 6.0;
    let shown = |y: f64| {
        if log {
            if y > 0.0 && y.log10() >= floor { y.log10() } else { f64::NAN }
        } else if y.abs() <= AXIS_LIMIT {
            y
        } else {
            // Off any axis (and its pixel row would overflow): left out, as a NaN is.
            f64::NAN
        }
    };
    // Each series as runs of drawable points: a left-out value breaks the line.
    let series: Vec<Vec<Vec<(f64, f64)>>> = panel
        .series
        .iter()
        .map(|s| {
            let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
            for &(x, y) in s.points.iter().filter(|p| inside(p.0)) {
                let y = shown(y);
                if y.is_finite() {
                    if let Some(run) = runs.last_mut() {
                        run.push((x, y));
                    }
                } else if runs.last().is_some_and(|run| !run.is_empty()) {
                    runs.push(Vec::new());
                }
            }
            runs
        })
        .collect();
    let all = || series.iter().flatten().flatten();
    let (x_low, x_high) = match panel.x_range {
        Some(range) => range,
        None => range_of(all().map(|p| p.0)),
    };
    let levels = panel.levels.iter().map(|l| shown(l.value));
    let (y_low, y_high) = range_of(all().map(|p| p.1).chain(levels));
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, ("sans-serif", 20))
        .margin(10)
        .margin_right(20)
        .x_label_area_size(40)
        .y_label_area_size(80)
        .build_cartesian_2d(x_low..x_high, y_low..y_high)?;
    let integer_x = panel.integer_x;
    let x_format = move |x: &f64| {
        if integer_x {
            if (x - x.round()).abs() < 1e-6 { format!("{}", x.round() as i64) } else { String::new() }
        } else {
            tick(*x)
        }
    };
    let y_format = move |y: &f64| scale_tick(*y, log);
    let x_ticks = if integer_x { ((x_high - x_low).round() as usize + 1).clamp(2, 20) } else { 10 };
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(&panel.y_label)
        .x_labels(x_ticks)
        .x_label_formatter(&x_format)
        .y_label_formatter(&y_format)
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .draw()?;
    if !panel.shaded.is_empty() {
        let shade = RGBColor(255, 160, 160).mix(0.45);
        let annotation = chart.draw_series(
            panel
                .shaded
                .iter()
                .map(|&(a, b)| Rectangle::new([(a.max(x_low), y_low), (b.min(x_high), y_high)], shade.filled())),
        )?;
        annotation
            .label(panel.shaded_label.clone())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 20, y + 5)], shade.filled()));
    }
    for level in &panel.levels {
        let color = PALETTE[level.color % PALETTE.len()];
        let y = shown(level.value);
        // A level off the axis (one left out of its range) is not drawn: its pixel position
        // would overflow.
        if !(y >= y_low && y <= y_high) {
            continue;
        }
        let annotation =
            chart.draw_series(DashedLineSeries::new([(x_low, y), (x_high, y)], 10, 6, color.stroke_width(2)))?;
        annotation
            .label(level.label.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
    }
    for (series, runs) in panel.series.iter().zip(series) {
        let color = PALETTE[series.color % PALETTE.len()];
        let style = color.stroke_width(2);
        let mut runs: Vec<Vec<(f64, f64)>> = runs.into_iter().filter(|run| !run.is_empty()).collect();
        if runs.is_empty() {
            continue;
        }
        // Every run but the first, then the first, which carries the legend entry.
        let first = runs.remove(0);
        for points in runs {
            match series.style {
                Style::Dashed => chart.draw_series(DashedLineSeries::new(points, 8, 5, style))?,
                Style::Line => chart.draw_series(LineSeries::new(points, style))?,
                Style::Points => chart.draw_series(points.into_iter().map(|p| Circle::new(p, 4, color.filled())))?,
            };
        }
        let annotation = match series.style {
            Style::Dashed => chart.draw_series(DashedLineSeries::new(first, 8, 5, style))?,
            Style::Line => chart.draw_series(LineSeries::new(first, style))?,
            Style::Points => chart.draw_series(first.into_iter().map(|p| Circle::new(p, 4, color.filled())))?,
        };
        let points_only = series.style == Style::Points;
        annotation.label(series.label.clone()).legend(
            move |(x, y)| -> DynElement<'static, BitMapBackend<'_>, (i32, i32)> {
                if points_only {
                    Circle::new((x + 10, y), 4, color.filled()).into_dyn()
                } else {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)).into_dyn()
                }
            },
        );
    }
    // Instants: a vertical line each, the label beside it, staggered so neighbours do not overlap.
    for (index, mark) in panel.marks.iter().enumerate() {
        let grey = RGBColor(90, 90, 90);
        chart.draw_series(DashedLineSeries::new([(mark.x, y_low), (mark.x, y_high)], 6, 4, grey.stroke_width(1)))?;
        let y = y_high - (y_high - y_low) * (0.04 + 0.08 * (index % 3) as f64);
        // Right of the line in the left part of the panel, left of it in the right part.
        let right_half = mark.x > x_low + 0.55 * (x_high - x_low);
        let anchor = if right_half { HPos::Right } else { HPos::Left };
        let style = ("sans-serif", 14).into_font().color(&BLACK).pos(Pos::new(anchor, VPos::Top));
        // On a white box, so that lines under it do not make it unreadable (DejaVu Sans at 14
        // px is about 8 px a character).
        let (px, py) = chart.backend_coord(&(mark.x, y));
        let width = 8 * mark.label.chars().count() as i32 + 8;
        let (left, right) = if right_half { (px - width - 4, px - 4) } else { (px + 4, px + width + 4) };
        let pixels = chart.plotting_area().strip_coord_spec();
        let (offset_x, offset_y) = pixels.get_base_pixel();
        let local = |x: i32, y: i32| (x - offset_x, y - offset_y);
        pixels.draw(&Rectangle::new([local(left, py - 2), local(right, py + 17)], WHITE.mix(0.6).filled()))?;
        let text_x = if right_half { right - 4 } else { left + 4 };
        pixels.draw(&Text::new(mark.label.clone(), local(text_x, py), style))?;
    }
    let position = match panel.legend {
        Corner::UpperRight => SeriesLabelPosition::UpperRight,
        Corner::LowerRight => SeriesLabelPosition::LowerRight,
        Corner::UpperLeft => SeriesLabelPosition::UpperLeft,
        Corner::LowerLeft => SeriesLabelPosition::LowerLeft,
        Corner::Hidden => return Ok(()),
    };
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()?;
    Ok(())
}

/// A heat map of `values[row][column]` over a grid of x (columns) and y (rows) values, with a
/// colour bar; `None` cells (failed candidates) are grey, `marked` cells get a black frame.
/// The grids are evenly spaced (`A..B:N`); the axes are in their values, with round ticks.
#[derive(Debug)]
pub struct HeatMap<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub value_label: &'a str,
    pub x_values: &'a [f64],
    pub y_values: &'a [f64],
    /// Names of the rows (at `y_values` 0, 1, …) instead of numbers.
    pub y_names: Option<&'a [String]>,
    pub values: &'a [Vec<Option<f64>>],
    pub marked: Option<(usize, usize)>,
    /// What a grey (`None`) cell means, in the key ("failed" for a sweep's candidates).
    pub grey: &'a str,
    /// A warning written under the title (e.g. the best pick on the edge of the sweep).
    pub note: Option<String>,
}

/// The values span decades: a log colour scale (all positive, largest ≥ 100 × smallest, so
/// that its labels, the decades, are at least three).
pub fn spans_decades(low: f64, high: f64) -> bool {
    low > 0.0 && high >= 100.0 * low
}

/// Whether `v` lies within the swept values (to rounding).
fn within(values: &[f64], v: f64) -> bool {
    let (first, last) = (values.first().copied().unwrap_or(0.0), values.last().copied().unwrap_or(0.0));
    let slack = 1e-9 * (last - first).abs().max(first.abs()).max(1e-300);
    v >= first.min(last) - slack && v <= first.max(last) + slack
}

/// Half a grid step on each side of an evenly spaced grid: the cells' outer edges.
fn cell_edges(values: &[f64]) -> (f64, f64, f64) {
    let (first, last) = (values.first().copied().unwrap_or(0.0), values.last().copied().unwrap_or(1.0));
    let step = if values.len() > 1 { (last - first) / (values.len() - 1) as f64 } else { first.abs().max(1.0) * 0.2 };
    (first - step / 2.0, last + step / 2.0, step)
}

fn heat_color(fraction: f64) -> RGBColor {
    // Viridis-like ramp from dark blue (low, good for error metrics) to yellow (high).
    let stops =
        [(68.0, 1.0, 84.0), (59.0, 82.0, 139.0), (33.0, 145.0, 140.0), (94.0, 201.0, 98.0), (253.0, 231.0, 37.0)];
    let scaled = fraction.clamp(0.0, 1.0) * (stops.len() - 1) as f64;
    let index = (scaled.floor() as usize).min(stops.len() - 2);
    let t = scaled - index as f64;
    let (a, b) = (stops[index], stops[index + 1]);
    let mix = |u: f64, v: f64| (u + (v - u) * t).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// Draws a heat map into the PNG at `path`.
pub fn plot_heat_map(path: &Path, map: &HeatMap<'_>) -> Result<()> {
    register_font();
    let finite: Vec<f64> = map.values.iter().flatten().flatten().copied().filter(|v| v.is_finite()).collect();
    // With no finite value (every candidate failed, or an empty shard) the scale is 0..1.
    let (low, high) = match finite.iter().copied().reduce(f64::min) {
        Some(low) => (low, finite.iter().copied().fold(low, f64::max)),
        None => (0.0, 1.0),
    };
    // Colours by log10 of the value where it spans decades; the bar is drawn in that scale.
    let log = spans_decades(low, high);
    let scale = move |v: f64| if log { v.log10() } else { v };
    let (scaled_low, scaled_high) = (scale(low), scale(high));
    let span = if scaled_high > scaled_low { scaled_high - scaled_low } else { 1.0 };
    let (x_low, x_high, x_step) = cell_edges(map.x_values);
    let (y_low, y_high, y_step) = cell_edges(map.y_values);
    let any_failed = map.values.iter().flatten().any(|v| v.is_none_or(|v| !v.is_finite()));
    render_atomic(path, |temporary| {
        let root = BitMapBackend::new(temporary, (1000, 820)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
        let (top, rest) = root.split_vertically(if map.note.is_some() { 64 } else { 40 });
        top.draw(&Text::new(
            map.title.to_string(),
            (500, 8),
            ("sans-serif", 22).into_font().color(&BLACK).pos(Pos::new(HPos::Center, VPos::Top)),
        ))
        .map_err(|e| anyhow!("{e}"))?;
        if let Some(note) = &map.note {
            let red = RGBColor(190, 20, 20);
            top.draw(&Text::new(
                note.clone(),
                (500, 38),
                ("sans-serif", 15).into_font().color(&red).pos(Pos::new(HPos::Center, VPos::Top)),
            ))
            .map_err(|e| anyhow!("{e}"))?;
        }
        let (chart_area, bar_area) = rest.split_horizontally(800);
        let mut chart = ChartBuilder::on(&chart_area)
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d(x_low..x_high, y_low..y_high)
            .map_err(|e| anyhow!("{e}"))?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(map.x_label)
            .y_desc(map.y_label)
            .x_labels(10)
            .y_labels(10)
            // Ticks only over the swept values, not the half cells beyond them.
            .x_label_formatter(&|v| if within(map.x_values, *v) { tick(*v) } else { String::new() })
            .y_label_formatter(&|v| match map.y_names {
                Some(names) if (v - v.round()).abs() < 1e-6 && *v >= 0.0 => {
                    names.get(v.round() as usize).cloned().unwrap_or_default()
                }
                Some(_) => String::new(),
                None if within(map.y_values, *v) => tick(*v),
                None => String::new(),
            })
            .label_style(("sans-serif", 14))
            .axis_desc_style(("sans-serif", 16))
            .draw()
            .map_err(|e| anyhow!("{e}"))?;
        let centre = |row: usize, column: usize| (map.x_values[column], map.y_values[row]);
        let cell = |(x, y): (f64, f64)| [(x - x_step / 2.0, y - y_step / 2.0), (x + x_step / 2.0, y + y_step / 2.0)];
        let cells = map.values.iter().enumerate().flat_map(|(row, line)| {
            line.iter().enumerate().map(move |(column, value)| {
                let color = match value {
                    Some(v) if v.is_finite() => heat_color((scale(*v) - scaled_low) / span),
                    _ => RGBColor(190, 190, 190),
                };
                Rectangle::new(cell(centre(row, column)), color.filled())
            })
        });
        chart.draw_series(cells).map_err(|e| anyhow!("{e}"))?;
        if let Some((row, column)) = map.marked {
            chart
                .draw_series(std::iter::once(Rectangle::new(cell(centre(row, column)), BLACK.stroke_width(3))))
                .map_err(|e| anyhow!("{e}"))?;
        }
        // Colour bar, with round ticks of the value (decades on a log scale).
        let (bar_area, key_area) = bar_area.split_vertically(700);
        let mut bar = ChartBuilder::on(&bar_area)
            .margin_top(20)
            .margin_bottom(20)
            .margin_left(10)
            .margin_right(80)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..1.0, scaled_low..scaled_low + span)
            .map_err(|e| anyhow!("{e}"))?;
        bar.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_desc(if log { format!("{} (log scale)", map.value_label) } else { map.value_label.to_string() })
            .y_labels(8)
            .y_label_formatter(&|v| scale_tick(*v, log))
            .axis_desc_style(("sans-serif", 14))
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(|e| anyhow!("{e}"))?;
        let steps = 100;
        bar.draw_series((0..steps).map(|k| {
            let from = scaled_low + span * k as f64 / steps as f64;
            let to = scaled_low + span * (k + 1) as f64 / steps as f64;
            Rectangle::new([(0.0, from), (1.0, to)], heat_color(k as f64 / steps as f64).filled())
        }))
        .map_err(|e| anyhow!("{e}"))?;
        let key = ("sans-serif", 13).into_font().color(&BLACK);
        if any_failed {
            key_area
                .draw(&Rectangle::new([(10, 10), (30, 26)], RGBColor(190, 190, 190).filled()))
                .map_err(|e| anyhow!("{e}"))?;
            key_area.draw(&Text::new(map.grey, (36, 11), key.clone())).map_err(|e| anyhow!("{e}"))?;
        }
        if map.marked.is_some() {
            key_area.draw(&Rectangle::new([(10, 36), (30, 52)], BLACK.stroke_width(3))).map_err(|e| anyhow!("{e}"))?;
            key_area.draw(&Text::new("best pick", (36, 37), key)).map_err(|e| anyhow!("{e}"))?;
        }
        root.present().map_err(|e| anyhow!("{e}"))?;
        Ok(())
    })
}

/// The most characters of a squares plot's note that fit across the picture.
const NOTE_CHARS: usize = 150;

/// A heat map of the board: each square's value, grey where it has none (`grey` says why, with
/// the first square's reason).
pub fn plot_squares(
    path: &std::path::Path,
    title: &str,
    value_label: &str,
    values: impl Iterator<Item = (chessarm_chess::shakmaty::Square, std::result::Result<f64, String>)>,
    grey: &str,
) -> Result<()> {
    let mut cells = vec![vec![None; 8]; 8];
    let mut failed = Vec::new();
    for (square, value) in values {
        let (file, rank) = (usize::from(u8::from(square.file())), usize::from(u8::from(square.rank())));
        match value {
            Ok(v) => cells[rank][file] = Some(v),
            Err(why) => failed.push(why),
        }
    }
    let files: Vec<f64> = (1..=8).map(f64::from).collect();
    plot_heat_map(
        path,
        &HeatMap {
            title,
            x_label: "file (1 = a)",
            y_label: "rank",
            value_label,
            x_values: &files,
            y_values: &files,
            y_names: None,
            values: &cells,
            marked: None,
            grey,
            // The note is one line across the picture: a long reason (a crowded column's) is
            // cut to what fits, the whole of it on the terminal and in --json.
            note: failed.first().map(|why| {
                let note = format!("grey: {grey} ({} squares), e.g. {why}", failed.len());
                match note.char_indices().nth(NOTE_CHARS) {
                    Some((cut, _)) => format!("{}…", &note[..cut]),
                    None => note,
                }
            }),
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_axis_stays_finite_whatever_the_values() {
        for values in
            [vec![-1e308, 1e308, 1.0], vec![f64::MAX, 2.0], vec![1e300, -1e300], vec![f64::NAN, f64::INFINITY]]
        {
            let (low, high) = range_of(values.iter().copied());
            assert!(low.is_finite() && high.is_finite() && (high - low).is_finite() && high > low, "{values:?}");
        }
        // A panel with a level at 1e308 draws (it hung in the axis ticks before).
        let dir = tempfile::tempdir().unwrap();
        let panel = Panel {
            title: "torque".into(),
            y_label: "N·m".into(),
            series: vec![Series { label: "τ".into(), points: vec![(0.0, 1.0), (1.0, 2.0)], ..Series::default() }],
            levels: vec![
                Level { value: 1e308, label: "limit".into(), color: 1 },
                Level { value: -1e308, label: "limit".into(), color: 1 },
            ],
            ..Panel::default()
        };
        plot_panels(&dir.path().join("p.png"), "t", "s", &[panel]).unwrap();
    }

    #[test]
    fn ticks_are_short_and_never_negative_zero() {
        assert_eq!(tick(700.0), "700");
        assert_eq!(tick(-0.0), "0");
        assert_eq!(tick(-1e-17), "0");
        assert_eq!(tick(0.1 + 0.2), "0.3");
        assert_eq!(tick(12.5), "12.5");
        assert_eq!(tick(36.578947), "36.58");
        assert_eq!(tick(0.000_342_8), "0.0003428");
        assert_eq!(tick(9.2e-6), "9.2e-6");
        assert_eq!(tick(2.5e7), "2.5e7");
        assert_eq!(tick(-250.0), "-250");
    }

    #[test]
    fn a_log_colour_scale_only_where_the_values_span_decades() {
        assert!(spans_decades(0.009, 220.0));
        assert!(!spans_decades(1.0, 20.0));
        assert!(!spans_decades(1.0, 68.0));
        assert!(!spans_decades(0.0, 220.0));
        assert!(!spans_decades(-1.0, 220.0));
    }
}
