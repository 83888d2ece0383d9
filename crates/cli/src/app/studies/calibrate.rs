//! Calibrating the board from touches: the tool tip put on squares' centres, its joint
//! angles read; the fit of the board's centre, yaw and surface height (and with `zeros` the
//! joints' zero errors) to them, checked, and the setup calibrated.

use crate::app::setup::file::Setup;
use anyhow::Result;
use chessarm_chess::shakmaty::Square;
use chessarm_core::arm::calibration::{CalibrationError, CalibrationFit, Touch, fit};
use chessarm_core::arm::model::JointVector;
use chessarm_core::nalgebra::Vector2;

/// A calibration's result.
#[derive(Debug, Clone)]
pub struct Calibration {
    pub fitted: CalibrationFit,
    /// The setup with the fitted board (and the servos' new zero ticks).
    pub calibrated: Setup,
    /// The joints' zero errors in the setup's sense, rad (true angle = read + error).
    pub zero_errors: [f64; 4],
    /// With `zeros` and servos: their zero positions, ticks, after the fit.
    pub zero_ticks: Option<Vec<f64>>,
}

/// Fits the board (and with `zeros` the joints' zero errors) to the touches `touched` (a
/// square and the joint angles read there, rad, the setup's sense); a touch further than
/// `max_residual` m from where the fit puts its square refuses the fit, as does a fitted board
/// the setup's own check refuses.
///
/// # Errors
///
/// Touches that cannot fix the board (in a line, the arm not moved), residuals too large, a
/// fitted board not served; each message names the touches by their squares.
pub fn calibrate(setup: &Setup, touched: &[(Square, [f64; 4])], zeros: bool, max_residual: f64) -> Result<Calibration> {
    let signs = setup.convention.signs;
    let touches: Vec<Touch> = touched
        .iter()
        .map(|(square, user)| Touch {
            q: JointVector::<4>::from(std::array::from_fn::<f64, 4, _>(|j| signs[j] * user[j])),
            point: board_point(setup, *square),
        })
        .collect();
    let fitted = fit(&setup.arm, &touches, zeros)
        .and_then(|fitted| fitted.check_residuals(max_residual).map(|()| fitted))
        .map_err(|e| anyhow::anyhow!("{}", refusal(&e, touched)))?;
    let mut calibrated = setup.clone();
    calibrated.board.center = fitted.center;
    calibrated.board.yaw = fitted.yaw;
    calibrated.board.surface_height = fitted.surface_height;
    // The zero errors in the setup's sense (δ user = sign · δ model).
    let zero_errors: [f64; 4] = std::array::from_fn(|j| signs[j] * fitted.zero_errors[j] + 0.0);
    let mut zero_ticks = None;
    if zeros && setup.actuators.take_positions() {
        let bus = crate::app::setup::servos::ServoBus::of(setup)?;
        // ticks = zero + direction · q / count with q the true angle = read + δ: the zero moves
        // by −direction · δ / count.
        let ticks: Vec<f64> = (0..4)
            .map(|j| {
                let count = std::f64::consts::TAU / bus.counts_per_revolution[j];
                (bus.zero_ticks[j] - bus.directions[j] * zero_errors[j] / count).round()
            })
            .collect();
        let mut file = calibrated.servo_bus.clone().unwrap_or_default();
        file.zero_ticks = Some(ticks.clone());
        calibrated.servo_bus = Some(file);
        crate::app::setup::servos::ServoBus::of(&calibrated)?;
        zero_ticks = Some(ticks);
    }
    // The fitted board must be one the setup's own check (`board`, `play`) accepts.
    let columns = Some(&setup.clearance);
    chessarm_chess::reach::check_table(&setup.arm, &calibrated.board, &calibrated.pieces, &setup.motion, columns)
        .map_err(|e| {
            anyhow::anyhow!(
                "the fitted board (centre ({:.1}, {:.1}) mm, yaw {:.2}°) is not served: {e}; nothing was written",
                fitted.center.x * 1e3,
                fitted.center.y * 1e3,
                fitted.yaw.to_degrees()
            )
        })?;
    Ok(Calibration { fitted, calibrated, zero_errors, zero_ticks })
}

/// A square's centre in the board's own frame (m, from its centre along files and ranks).
fn board_point(setup: &Setup, square: Square) -> Vector2<f64> {
    let (file, rank) = setup.board.square_on_table(square);
    Vector2::new(file, rank) * setup.board.square_size
}

/// Why the touches are refused, naming them by their squares (mm, as typed and printed).
fn refusal(error: &CalibrationError, touched: &[(Square, [f64; 4])]) -> String {
    let square = |i: usize| touched.get(i).map_or_else(|| format!("touch {}", i + 1), |(s, _)| s.to_string());
    let end = "nothing was written";
    match error {
        CalibrationError::PointsInLine => format!(
            "the touched squares {} lie on one line: touch squares that span the board (e.g. a1, h1, h8, a8) — the \
             fit takes the board as flat and level, and touches along one line cannot show it tilted across that \
             line; {end}",
            touched.iter().map(|(s, _)| s.to_string()).collect::<Vec<_>>().join(", ")
        ),
        CalibrationError::TooClose { first, second, tips, points } => format!(
            "the touches of {} and {} put the tool tip {:.1} mm apart, but their squares' centres are {:.1} mm \
             apart (at least half that expected): the arm was not moved between them, or an angle is wrong; {end}",
            square(*first),
            square(*second),
            tips * 1e3,
            points * 1e3
        ),
        CalibrationError::TipsInLine { touches, tips, points } => format!(
            "the touches of {}, {} and {} put the tool tip nearly on one line (a triangle of {:.0} mm², their \
             squares' centres {:.0} mm², at least half that expected): an angle is wrong; {end}",
            square(touches[0]),
            square(touches[1]),
            square(touches[2]),
            tips * 1e6,
            points * 1e6
        ),
        CalibrationError::ResidualTooLarge { touch, residual, bound } => format!(
            "the touch of {} is {:.2} mm from where the fitted board puts its centre, above --max-residual-mm {} \
             (the touches disagree: a wrong square, a wrong angle, or the tip off the centre); {end}",
            square(*touch),
            residual * 1e3,
            bound * 1e3
        ),
        other => format!("{other}; {end}"),
    }
}
