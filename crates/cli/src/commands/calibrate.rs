//! `calibrate`: where the board really lies (and, with `--zeros`, how far the joints' zeros are
//! off) from the arm touching the centres of a few squares — the angles typed (`--touch`) or
//! read from the servos over the bus (`--port`: torque off, the person moves the arm).
//! The fit is `chessarm_core::arm::calibration::fit`; the result is a setup file with the fitted
//! board (and `[servo_bus] zero_ticks`), the residual per touch printed and plotted. Touches that
//! cannot tell where the board is, residuals above `--max-residual-mm`, and a fitted board the
//! arm does not serve are refused, naming the touches, before anything is written.

use crate::app::output::{ensure_dir, write_json};
use crate::app::setup::file::Setup;
use crate::app::studies::calibrate::{Calibration, calibrate};
use crate::cli::CalibrateArgs;
use anyhow::{Context, Result, bail};
use chessarm_chess::board::parse_square;
use chessarm_chess::shakmaty::Square;
use serde_json::json;
use std::io::BufRead;

/// `SQUARE=Q1,Q2,Q3,Q4` (rad, the setup's sense).
fn parse_touch(text: &str) -> Result<(Square, [f64; 4])> {
    let (square, angles) = text
        .split_once('=')
        .ok_or_else(|| anyhow::anyhow!("--touch '{text}' is not SQUARE=Q1,Q2,Q3,Q4 (e.g. a1=0.1,0.9,-1.2,-1.3)"))?;
    let square = parse_square(square.trim()).map_err(|e| anyhow::anyhow!("--touch '{text}': {e}"))?;
    let angles = crate::args::angles(angles).map_err(|e| anyhow::anyhow!("--touch '{text}': {e}"))?;
    Ok((square, angles))
}

/// The touches read over the bus: torque off, then for each square the person moves the tool
/// tip onto its centre and presses Enter (a line on standard input).
fn read_over_bus(setup: &Setup, args: &CalibrateArgs, port: &std::path::Path) -> Result<Vec<(Square, [f64; 4])>> {
    // Every square named before anyone touches one.
    let squares: Vec<Square> = args
        .squares
        .iter()
        .map(|name| parse_square(name).map_err(|e| anyhow::anyhow!("--squares {}: {e}", args.squares.join(","))))
        .collect::<Result<_>>()?;
    let mut arm = crate::app::bus::arm::RealArm::open(
        &crate::app::setup::servos::wiring(setup)?,
        crate::app::bus::arm::ArmOptions {
            port: Some(port),
            dry_run: false,
            max_step: std::f64::consts::PI,
            reply_timeout: std::time::Duration::from_millis(args.reply_timeout_ms),
            log: Box::new(|| crate::app::output::create_log(&args.out.join("bus.jsonl"), false)),
        },
    )?;
    arm.torque_off().context("cannot turn the servos' torque off")?;
    let mut stdin = std::io::stdin().lock();
    let mut touches = Vec::new();
    for square in squares {
        crate::tell(&format!("move the tool tip onto the centre of {square} and press Enter\n"));
        let mut line = String::new();
        if stdin.read_line(&mut line).context("reading standard input")? == 0 {
            bail!("the input ended before {square} was touched");
        }
        let angles = arm.read_angles()?;
        crate::tell(&format!(
            "{square}: {}\n",
            angles.iter().map(|a| format!("{a:.4}")).collect::<Vec<_>>().join(", ")
        ));
        touches.push((square, angles));
    }
    Ok(touches)
}

pub fn run(setup: &Setup, args: &CalibrateArgs) -> Result<()> {
    let touched: Vec<(Square, [f64; 4])> = match &args.port {
        Some(port) => {
            if !args.touches.is_empty() {
                bail!("--touch gives the angles; --port reads them: give one of the two");
            }
            ensure_dir(&args.out)?;
            read_over_bus(setup, args, port)?
        }
        None => args.touches.iter().map(|t| parse_touch(t)).collect::<Result<_>>()?,
    };
    let calibration = calibrate(setup, &touched, args.zeros, args.max_residual_mm * 1e-3)?;
    let Calibration { fitted, calibrated, .. } = &calibration;
    ensure_dir(&args.out)?;
    let setup_path = args.out.join("setup.toml");
    let text = calibrated.to_toml_beside_urdf()?;
    crate::app::output::write_atomic(&setup_path, |out| Ok(out.write_all(text.as_bytes())?))?;
    let plot = args.out.join("residuals.png");
    let residual_of: Vec<(Square, f64)> =
        touched.iter().zip(&fitted.residuals).map(|((square, _), r)| (*square, r.norm() * 1e3)).collect();
    crate::app::formats::plots::plot_squares(
        &plot,
        &format!("calibration: each touch's residual (mm), {} touches", touched.len()),
        "residual (mm)",
        residual_of.iter().map(|(s, r)| (*s, Ok(*r))),
        "not touched",
    )?;
    let json_path = args.out.join("calibration.json");
    let value = result_json(setup, &calibration, &touched, args.zeros);
    write_json(&json_path, &value)?;
    let mut human = text_of(setup, &calibration, &touched, args.zeros);
    let files = vec![setup_path.display().to_string(), plot.display().to_string(), json_path.display().to_string()];
    human.push_str(&crate::files_text(&files));
    crate::emit(&human, &value)
}

fn result_json(
    setup: &Setup,
    calibration: &Calibration,
    touched: &[(Square, [f64; 4])],
    zeros: bool,
) -> serde_json::Value {
    let Calibration { fitted, zero_errors, zero_ticks, .. } = calibration;
    let zero_ticks = zero_ticks.as_deref();
    json!({
        "center_m": [fitted.center.x, fitted.center.y],
        "yaw_rad": fitted.yaw,
        "surface_height_m": fitted.surface_height,
        "moved_mm": (fitted.center - setup.board.center).norm() * 1e3,
        "turned_deg": (fitted.yaw - setup.board.yaw).to_degrees(),
        "raised_mm": (fitted.surface_height - setup.board.surface_height) * 1e3,
        "zero_errors_rad": zeros.then_some(zero_errors),
        "zero_ticks": zero_ticks,
        "touches": touched.iter().zip(&fitted.residuals).map(|((square, q), r)| json!({
            "square": square.to_string(),
            "q_rad": q,
            "residual_mm": [r.x * 1e3, r.y * 1e3, r.z * 1e3],
        })).collect::<Vec<_>>(),
        "largest_residual_mm": fitted.residuals.iter().map(|r| r.norm() * 1e3).fold(0.0, f64::max),
        "singular_values": fitted.singular_values,
    })
}

fn text_of(setup: &Setup, calibration: &Calibration, touched: &[(Square, [f64; 4])], zeros: bool) -> String {
    let Calibration { fitted, zero_errors, zero_ticks, .. } = calibration;
    let zero_ticks = zero_ticks.as_deref();
    let mut text = format!(
        "board centre ({:.2}, {:.2}) mm, yaw {:.3}°, surface {:.2} mm: moved {:.2} mm, turned {:.3}°, raised {:.2} mm from the setup's\n",
        fitted.center.x * 1e3,
        fitted.center.y * 1e3,
        fitted.yaw.to_degrees(),
        fitted.surface_height * 1e3,
        (fitted.center - setup.board.center).norm() * 1e3,
        (fitted.yaw - setup.board.yaw).to_degrees(),
        (fitted.surface_height - setup.board.surface_height) * 1e3
    );
    if zeros {
        text.push_str(&format!(
            "zero errors (true angle = read + error), joints 2–4: {} ° (joint 1's is in the board's yaw){}\n",
            zero_errors[1..].iter().map(|e| format!("{:.3}", e.to_degrees())).collect::<Vec<_>>().join(", "),
            zero_ticks.map_or(String::from("; torque motors: not written"), |t| format!("; zero_ticks now {t:?}"))
        ));
    }
    text.push_str("residual per touch (mm, x y z | length):\n");
    for ((square, _), r) in touched.iter().zip(&fitted.residuals) {
        text.push_str(&format!(
            "  {square}  {:7.3} {:7.3} {:7.3} | {:.3}\n",
            r.x * 1e3,
            r.y * 1e3,
            r.z * 1e3,
            r.norm() * 1e3
        ));
    }
    text
}
