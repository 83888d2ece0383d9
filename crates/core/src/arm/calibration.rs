//! Calibration from touched points: where the board lies, and how far the joints' zeros are
//! off, from the joint angles read while the tool tip touched known points of the board.
//!
//! Each touch `i` gives the angles read `qᵢ` and the touched point's place on the board `sᵢ`
//! (m, in the board's own frame: from its centre along the files and the ranks). With the board's
//! centre `c`, yaw `ψ` and surface height `h`, and the joints' zero errors `δ` (the true angle is
//! the read one plus `δ`), the tip should be where the point is:
//!
//! `rᵢ = tip(qᵢ + δ) − [c + R(ψ) sᵢ ; h] = 0`,
//!
//! three equations a touch. The fit is least squares over `(c, ψ, h)` and, asked for, `δ₂, δ₃,
//! δ₄`: Gauss–Newton, the step `Δ = −J⁺ r` by SVD, `J` analytic (the tip's Jacobian for `δ`;
//! `−I`, `−R'(ψ) sᵢ` and `−1` for the board). It starts from the closed form for the board alone
//! (the 2-D Procrustes fit of the touched tips to the board's points: the centroids' difference
//! turned by the cross-covariance's angle). The base joint's zero error is not fitted: turning
//! the base's zero turns every tip about the base axis, which the board's yaw and centre take up
//! exactly (it is the same as the board lying turned); its effect is in the board's pose.
//!
//! Touches that cannot tell where the board is are refused before the fit, and a fit whose
//! touches disagree with it after: the touched squares on one line ([`CalibrationError::PointsInLine`]),
//! two touches' tips much closer together than their squares ([`CalibrationError::TooClose`]: the
//! arm did not move between them), the tips of the widest three touches nearly on one line
//! ([`CalibrationError::TipsInLine`]), and, checked by [`CalibrationFit::check_residuals`], a
//! touch further from the fitted board's point than a bound ([`MAX_RESIDUAL`] by default).

use crate::arm::model::{ArmModel, JointVector};
use crate::arm::task::task_jacobian;
use nalgebra::{DMatrix, DVector, Rotation2, Vector2, Vector3};

/// One touch: the joint angles read (rad) and the touched point on the board (m, board frame:
/// along the files, along the ranks, from the centre).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Touch {
    pub q: JointVector<4>,
    pub point: Vector2<f64>,
}

/// The fitted board pose and zero errors, with each touch's residual.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationFit {
    /// The board's centre (x, y, m), yaw (rad) and surface height (m).
    pub center: Vector2<f64>,
    pub yaw: f64,
    pub surface_height: f64,
    /// Zero errors `δ` (rad; the true angle is the read one plus `δ`); `δ₁` is 0 (see the
    /// module's docs), all 0 when not fitted.
    pub zero_errors: [f64; 4],
    /// Per touch, `tip(qᵢ + δ) − point` (m).
    pub residuals: Vec<Vector3<f64>>,
    /// The least-squares problem's singular values, largest first (its conditioning).
    pub singular_values: Vec<f64>,
    pub iterations: usize,
}

/// Why a calibration cannot be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CalibrationError {
    #[error("{got} touches; the board's pose needs at least 3 (and the joints' zeros at least 4)")]
    TooFew { got: usize },
    #[error(
        "the touches do not pin the fit down (singular values {largest:.3e} … {smallest:.3e}): touch points further apart, at different distances from the base"
    )]
    Degenerate { largest: f64, smallest: f64 },
    #[error("a touch's angles or point are not finite numbers")]
    NotFinite,
    /// The touched points lie on one line (touch numbers from 1 in the messages, indices here).
    #[error(
        "the touched points lie on one line: the fit takes the board as flat and level, and touches along one line cannot show it tilted across that line"
    )]
    PointsInLine,
    /// Touches `first` and `second` (indices) put the tip `tips` apart (m), less than
    /// [`CLOSEST_TIP_SHARE`] of their points' distance `points` on the board (m).
    #[error(
        "touches {} and {} put the tool tip {:.1} mm apart, but their points are {:.1} mm apart on the board",
        first + 1, second + 1, tips * 1e3, points * 1e3
    )]
    TooClose { first: usize, second: usize, tips: f64, points: f64 },
    /// The three touches (indices) whose points span the widest triangle put the tip on a
    /// triangle of area `tips` (m²), less than [`CLOSEST_TIP_SHARE`] of their points' `points`.
    #[error(
        "touches {}, {} and {} put the tool tip nearly on one line (a triangle of {:.0} mm², their points' {:.0} mm²)",
        touches[0] + 1, touches[1] + 1, touches[2] + 1, tips * 1e6, points * 1e6
    )]
    TipsInLine { touches: [usize; 3], tips: f64, points: f64 },
    /// Touch `touch` (index) is `residual` (m) from where the fitted board puts its point, more
    /// than `bound` (m).
    #[error(
        "touch {} is {:.2} mm from where the fitted board puts its point, more than {:.2} mm",
        touch + 1, residual * 1e3, bound * 1e3
    )]
    ResidualTooLarge { touch: usize, residual: f64, bound: f64 },
}

/// The default bound on a touch's residual, m: half the default placement tolerance (5 mm, a
/// piece that far from its square's centre is misplaced). The fitted board's error reaches every
/// placement, so a calibration whose touches disagree with it by more than that leaves less than
/// half the tolerance to the arm itself. Honest touches fit within about 1 mm: a servo's count
/// (4096 a turn, 1.5 mrad) moves the tip 0.1–0.3 mm at the arm's reach, and a hand centres the
/// tip on a square by eye within about a millimetre; the report's touches read in counts fit
/// within 0.2 mm.
pub const MAX_RESIDUAL: f64 = 0.0025;

/// Two touches' tips may be no closer together than this share of their points' distance on
/// the board (and the widest three touches' tips span at least this share of their points'
/// triangle). Honest touches reproduce the board's distances within their residuals (a few mm
/// at most, against squares tens of mm apart) and the zero errors' stretch (a few percent for
/// errors of a few degrees); half is far outside both. Without `--zeros` a pair this far off
/// could not fit anyway: the larger of their residuals is at least a quarter of their points'
/// distance (the triangle inequality).
pub const CLOSEST_TIP_SHARE: f64 = 0.5;

/// The touched points count as on one line when the widest triangle three of them span is at
/// most this share of the square of their largest distance. Only rounding is below it: on the
/// board's grid any three squares not on one line span at least half a square², and no two are
/// more than 7√2 squares apart (98 squares²), a share of at least 1/196.
const IN_LINE_SHARE: f64 = 1e-6;

/// The area of the triangle `a`, `b`, `c`.
fn area(a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>) -> f64 {
    (b - a).cross(&(c - a)).norm() / 2.0
}

/// Refuses touches that cannot tell where the board lies (see the module's docs), before the
/// fit: `tips` are the touches' tool tips at the angles read.
fn check_span(touches: &[Touch], tips: &[Vector3<f64>]) -> Result<(), CalibrationError> {
    let point = |i: usize| Vector3::new(touches[i].point.x, touches[i].point.y, 0.0);
    let n = touches.len();
    // The widest triangle of points, and the largest distance between two.
    let mut widest = (0.0, [0, 1, 2]);
    let mut spread: f64 = 0.0;
    for i in 0..n {
        for j in i + 1..n {
            spread = spread.max((touches[i].point - touches[j].point).norm());
            for k in j + 1..n {
                let a = area(&point(i), &point(j), &point(k));
                if a > widest.0 {
                    widest = (a, [i, j, k]);
                }
            }
        }
    }
    if widest.0 <= IN_LINE_SHARE * spread * spread {
        return Err(CalibrationError::PointsInLine);
    }
    // The pair whose tips are closest for their points' distance.
    let mut closest: Option<(f64, usize, usize)> = None;
    for i in 0..n {
        for j in i + 1..n {
            let points = (touches[i].point - touches[j].point).norm();
            if points > 0.0 {
                let share = (tips[i] - tips[j]).norm() / points;
                if closest.is_none_or(|(s, _, _)| share < s) {
                    closest = Some((share, i, j));
                }
            }
        }
    }
    if let Some((share, first, second)) = closest
        && share < CLOSEST_TIP_SHARE
    {
        return Err(CalibrationError::TooClose {
            first,
            second,
            tips: (tips[first] - tips[second]).norm(),
            points: (touches[first].point - touches[second].point).norm(),
        });
    }
    let [i, j, k] = widest.1;
    let tips_area = area(&tips[i], &tips[j], &tips[k]);
    if tips_area < CLOSEST_TIP_SHARE * widest.0 {
        return Err(CalibrationError::TipsInLine { touches: [i, j, k], tips: tips_area, points: widest.0 });
    }
    Ok(())
}

impl CalibrationFit {
    /// Refuses a fit with a touch further than `bound` (m) from where the fitted board puts its
    /// point (the touches disagree: a wrong square, a wrong angle, the tip off the centre).
    ///
    /// # Errors
    ///
    /// [`CalibrationError::ResidualTooLarge`] naming the touch with the largest residual.
    pub fn check_residuals(&self, bound: f64) -> Result<(), CalibrationError> {
        let worst = self.residuals.iter().enumerate().map(|(i, r)| (i, r.norm())).max_by(|a, b| a.1.total_cmp(&b.1));
        match worst {
            // A NaN bound (or residual) passes nothing.
            Some((touch, residual))
                if matches!(residual.partial_cmp(&bound), Some(std::cmp::Ordering::Greater) | None) =>
            {
                Err(CalibrationError::ResidualTooLarge { touch, residual, bound })
            }
            _ => Ok(()),
        }
    }
}

/// The closed-form board pose from the touched tips alone (no zero errors): the 2-D rigid fit
/// of the board's points to the tips, and their mean height.
fn procrustes(tips: &[Vector3<f64>], touches: &[Touch]) -> (Vector2<f64>, f64, f64) {
    let n = tips.len() as f64;
    let tip_mean = tips.iter().fold(Vector2::zeros(), |a, t| a + t.xy()) / n;
    let point_mean = touches.iter().fold(Vector2::zeros(), |a, t| a + t.point) / n;
    // The angle maximising Σ (tip − mean)·R(ψ)(point − mean).
    let (mut sin, mut cos) = (0.0, 0.0);
    for (tip, touch) in tips.iter().zip(touches) {
        let (a, b) = (touch.point - point_mean, tip.xy() - tip_mean);
        cos += a.dot(&b);
        sin += a.x * b.y - a.y * b.x;
    }
    let yaw = sin.atan2(cos);
    let center = tip_mean - Rotation2::new(yaw) * point_mean;
    let height = tips.iter().map(|t| t.z).sum::<f64>() / n;
    (center, yaw, height)
}

/// Fits the board's pose (and, with `fit_zeros`, the zero errors of joints 2–4) to `touches` on
/// `model` (the formulation in the module's docs).
///
/// # Errors
///
/// Fewer than 3 touches (4 with `fit_zeros`), a non-finite input, touches that cannot tell
/// where the board lies (their points on one line, two tips much closer together than their
/// points, the tips nearly on one line), or touches that leave the fit undetermined (at one
/// distance from the base for the zeros).
pub fn fit(model: &ArmModel<4>, touches: &[Touch], fit_zeros: bool) -> Result<CalibrationFit, CalibrationError> {
    let needed = if fit_zeros { 4 } else { 3 };
    if touches.len() < needed {
        return Err(CalibrationError::TooFew { got: touches.len() });
    }
    if touches.iter().any(|t| t.q.iter().chain(t.point.iter()).any(|v| !v.is_finite())) {
        return Err(CalibrationError::NotFinite);
    }
    let tip = |q: &JointVector<4>| crate::arm::task::tool_point(model, q).xyz();
    let tips: Vec<Vector3<f64>> = touches.iter().map(|t| tip(&t.q)).collect();
    check_span(touches, &tips)?;
    let (center, yaw, height) = procrustes(&tips, touches);
    // Parameters: centre x, y, yaw, height, then δ₂, δ₃, δ₄.
    let count = if fit_zeros { 7 } else { 4 };
    let mut p = DVector::<f64>::zeros(count);
    p[0] = center.x;
    p[1] = center.y;
    p[2] = yaw;
    p[3] = height;
    let zeros_of = |p: &DVector<f64>| -> JointVector<4> {
        if fit_zeros { JointVector::<4>::new(0.0, p[4], p[5], p[6]) } else { JointVector::<4>::zeros() }
    };
    let residuals_of = |p: &DVector<f64>| -> Vec<Vector3<f64>> {
        let rotation = Rotation2::new(p[2]);
        let zeros = zeros_of(p);
        touches
            .iter()
            .map(|t| {
                let target = Vector2::new(p[0], p[1]) + rotation * t.point;
                tip(&(t.q + zeros)) - Vector3::new(target.x, target.y, p[3])
            })
            .collect()
    };
    let rows = 3 * touches.len();
    let mut singular_values = Vec::new();
    let mut iterations = 0;
    for iteration in 1..=50 {
        iterations = iteration;
        let zeros = zeros_of(&p);
        let (sin, cos) = p[2].sin_cos();
        let mut jacobian = DMatrix::<f64>::zeros(rows, count);
        let mut r = DVector::<f64>::zeros(rows);
        for (i, (touch, residual)) in touches.iter().zip(residuals_of(&p)).enumerate() {
            for k in 0..3 {
                r[3 * i + k] = residual[k];
            }
            jacobian[(3 * i, 0)] = -1.0;
            jacobian[(3 * i + 1, 1)] = -1.0;
            // −R'(ψ) s.
            jacobian[(3 * i, 2)] = sin * touch.point.x + cos * touch.point.y;
            jacobian[(3 * i + 1, 2)] = -(cos * touch.point.x - sin * touch.point.y);
            jacobian[(3 * i + 2, 3)] = -1.0;
            if fit_zeros {
                let tip_jacobian = task_jacobian(model, &(touch.q + zeros));
                for k in 0..3 {
                    for j in 1..4 {
                        jacobian[(3 * i + k, 3 + j)] = tip_jacobian[(k, j)];
                    }
                }
            }
        }
        let svd = jacobian.clone().svd(true, true);
        let mut values: Vec<f64> = svd.singular_values.iter().copied().collect();
        values.sort_by(|a, b| b.total_cmp(a));
        let (largest, smallest) = (values[0], values[values.len() - 1]);
        if smallest <= largest * 1e-9 {
            return Err(CalibrationError::Degenerate { largest, smallest });
        }
        singular_values = values;
        let step = svd.solve(&(-r), 0.0).map_err(|_| CalibrationError::Degenerate { largest, smallest })?;
        p += &step;
        if step.amax() < 1e-13 {
            break;
        }
    }
    let zeros = zeros_of(&p);
    Ok(CalibrationFit {
        center: Vector2::new(p[0], p[1]),
        yaw: p[2],
        surface_height: p[3],
        zero_errors: [0.0, zeros[1], zeros[2], zeros[3]],
        residuals: residuals_of(&p),
        singular_values,
        iterations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arm::preset::report_arm;
    use crate::arm::task::{TOOL_DOWN, inverse_kinematics};

    /// Touches of the board turned by `yaw` about the point `center`, read with zero errors
    /// `zeros` and rounded to `counts` per turn.
    fn touches(
        model: &ArmModel<4>,
        points: &[Vector2<f64>],
        center: Vector2<f64>,
        yaw: f64,
        height: f64,
        zeros: JointVector<4>,
        counts: f64,
    ) -> Vec<Touch> {
        let count = std::f64::consts::TAU / counts;
        points
            .iter()
            .map(|point| {
                let xy = center + Rotation2::new(yaw) * point;
                let q = inverse_kinematics(model, &Vector3::new(xy.x, xy.y, height), TOOL_DOWN).unwrap();
                let read = (q - zeros).map(|v| (v / count).round() * count);
                Touch { q: read, point: *point }
            })
            .collect()
    }

    fn corners(square: f64) -> Vec<Vector2<f64>> {
        [(-3.5, -3.5), (3.5, -3.5), (3.5, 3.5), (-3.5, 3.5)]
            .iter()
            .map(|(f, r)| Vector2::new(*f, *r) * square)
            .collect()
    }

    /// Exact angles give the board back exactly (the closed form and Gauss–Newton agree to
    /// rounding), with and without zero errors.
    #[test]
    fn exact_touches_give_the_pose_and_zeros_back() {
        let model = report_arm();
        let center = Vector2::new(0.008, 0.33);
        let yaw = 2f64.to_radians();
        let zeros = JointVector::<4>::new(0.0, 0.02, -0.015, 0.01);
        let mut points = corners(0.06);
        points.extend([Vector2::new(0.0, 0.0), Vector2::new(0.09, -0.15), Vector2::new(-0.15, 0.09)]);
        let fitted = fit(&model, &touches(&model, &points, center, yaw, 0.0, zeros, 1e12), true).unwrap();
        assert!((fitted.center - center).norm() < 1e-9, "{:?}", fitted.center);
        assert!((fitted.yaw - yaw).abs() < 1e-9 && fitted.surface_height.abs() < 1e-9);
        for j in 1..4 {
            assert!((fitted.zero_errors[j] - zeros[j]).abs() < 1e-9, "{:?}", fitted.zero_errors);
        }
        assert!(fitted.residuals.iter().all(|r| r.norm() < 1e-9));
        let pose_only =
            fit(&model, &touches(&model, &corners(0.06), center, yaw, 0.0, JointVector::zeros(), 1e12), false).unwrap();
        assert!((pose_only.center - center).norm() < 1e-9 && (pose_only.yaw - yaw).abs() < 1e-9);
    }

    /// The target: a board shifted 8 mm and turned 2°, its four corner squares touched
    /// and read in whole counts of a 4096-count servo: the pose within 0.5 mm and 0.1°.
    #[test]
    fn a_shifted_turned_board_is_found_from_four_corners_read_in_counts() {
        let model = report_arm();
        let nominal = Vector2::new(0.0, 0.33);
        let shift = Vector2::new(0.008 / 2f64.sqrt(), 0.008 / 2f64.sqrt());
        let yaw = 2f64.to_radians();
        let fitted = fit(
            &model,
            &touches(&model, &corners(0.06), nominal + shift, yaw, 0.0, JointVector::zeros(), 4096.0),
            false,
        )
        .unwrap();
        let position_error = (fitted.center - (nominal + shift)).norm();
        let yaw_error = (fitted.yaw - yaw).abs().to_degrees();
        eprintln!("fitted within {:.3} mm and {yaw_error:.4}°", position_error * 1e3);
        assert!(position_error < 0.5e-3 && yaw_error < 0.1, "{position_error} m, {yaw_error}°");
    }

    /// Touches in one line cannot show the board tilted across it (nor, with the zeros, pin
    /// them down): refused, not guessed, with or without the zeros.
    #[test]
    fn touches_in_a_line_are_refused() {
        let model = report_arm();
        let points: Vec<Vector2<f64>> = (0..4).map(|k| Vector2::new(0.0, 0.05 * f64::from(k) - 0.1)).collect();
        let line = touches(&model, &points, Vector2::new(0.0, 0.33), 0.0, 0.0, JointVector::zeros(), 1e12);
        assert!(fit(&model, &line[..2], false).is_err());
        assert_eq!(fit(&model, &line, false), Err(CalibrationError::PointsInLine));
        assert_eq!(fit(&model, &line, true), Err(CalibrationError::PointsInLine));
    }

    /// The same angles read at every corner (the arm not moved between touches): refused
    /// before the fit, naming the pair whose tips are closest for their points' distance.
    #[test]
    fn the_same_angles_at_every_corner_are_refused() {
        let model = report_arm();
        let mut same = touches(&model, &corners(0.06), Vector2::new(0.0, 0.33), 0.0, 0.0, JointVector::zeros(), 1e12);
        let q = same[0].q;
        for touch in &mut same {
            touch.q = q;
        }
        match fit(&model, &same, false) {
            Err(CalibrationError::TooClose { first: 0, second: 1, tips, points }) => {
                assert!(tips < 1e-12 && (points - 0.42).abs() < 1e-12, "{tips} {points}");
            }
            other => panic!("{other:?}"),
        }
    }

    /// Three corners touched where the tips lie on one line (the third touch's angles those
    /// of a point on the line through the first two): every pair's distance is plausible, but
    /// the tips span no triangle.
    #[test]
    fn tips_on_one_line_are_refused() {
        let model = report_arm();
        let center = Vector2::new(0.0, 0.33);
        let mut three = touches(&model, &corners(0.06)[..3], center, 0.0, 0.0, JointVector::zeros(), 1e12);
        // a1 (−0.21, 0.12), h1 (0.21, 0.12): h8's angles those of (0.42, 0.12) on their line,
        // 0.63 m from a1 and 0.21 m from h1 (h8 is 0.59 and 0.42 m from them: above half).
        let on_line = touches(&model, &[Vector2::new(0.42, -0.21)], center, 0.0, 0.0, JointVector::zeros(), 1e12);
        three[2].q = on_line[0].q;
        match fit(&model, &three, false) {
            Err(CalibrationError::TipsInLine { touches: [0, 1, 2], tips, points }) => {
                assert!(tips < 1e-9 && (points - 0.42 * 0.42 / 2.0).abs() < 1e-12, "{tips} {points}");
            }
            other => panic!("{other:?}"),
        }
    }

    /// The residual bound: the corners read in whole counts fit within 0.5 mm (a count is
    /// 1.5 mrad, 0.1–0.3 mm at the tip per joint), refused at half their worst residual, naming
    /// that touch; two corners' angles swapped fit no board within the default.
    #[test]
    fn residuals_above_the_bound_are_refused() {
        let model = report_arm();
        let read = touches(&model, &corners(0.06), Vector2::new(0.005, 0.33), 0.03, 0.0, JointVector::zeros(), 4096.0);
        let fitted = fit(&model, &read, false).unwrap();
        assert_eq!(fitted.check_residuals(MAX_RESIDUAL), Ok(()));
        let worst = fitted.residuals.iter().map(|r| r.norm()).fold(0.0, f64::max);
        assert!(worst < 0.5e-3, "{worst}");
        match fitted.check_residuals(worst / 2.0) {
            Err(CalibrationError::ResidualTooLarge { touch, residual, .. }) => {
                assert_eq!(residual, worst);
                assert_eq!(fitted.residuals[touch].norm(), worst);
            }
            other => panic!("{other:?}"),
        }
        let mut swapped = read.clone();
        swapped[0].q = read[1].q;
        swapped[1].q = read[0].q;
        let fitted = fit(&model, &swapped, false).unwrap();
        assert!(matches!(fitted.check_residuals(MAX_RESIDUAL), Err(CalibrationError::ResidualTooLarge { .. })));
        assert!(fitted.check_residuals(f64::NAN).is_err(), "a NaN bound passes nothing");
    }
}
