//! What a game asks of the arm's reach, checked before it starts, and the largest board that
//! an arm serves (`chessarm board --fit`).
//!
//! **The set a game can ask for.** Every move is vertical moves over a location (a square, a
//! graveyard or reserve slot) between a piece's grip height and a traverse height, and
//! traverses between two locations (or the home point) at a traverse height, their corners
//! blended in the vertical plane of the traverse within [`MotionLimits::blend`] of the ends. So
//! the tool tip, pointing down, stays on the straight segments between any two of those points
//! (in the table plane): within the blend of an end at any height from the lowest grip height to
//! the highest traverse ([`MotionLimits::highest_traverse`]), farther from both ends at a
//! traverse height, never below the clearance margin plus the lowest grip height. A point
//! is *served* when inverse kinematics reaches it within the joint limits and the motors hold
//! the arm there with the heaviest piece within their torque limits times the planner's torque
//! margin (`|g_i(q)| ≤ margin·τ_max,i`).
//!
//! **The check** ([`check_table`]) samples that set: every location and the home point at
//! every grip height, the highest traverse and every [`HEIGHT_STEP`] between, and every segment
//! between two of them every [`SEGMENT_STEP`] at those heights (beyond the blends, those of a
//! traverse).
//!
//! **The fit** ([`fit_board`]) uses that for the yaw–pitch family, reach depends on the radial
//! distance `r` from the base axis and the height only, and the base angle on the bearing:
//! it tabulates, along the bearing of the base joint's mid-range, which `r` (every
//! [`RADIAL_STEP`]) are served at every height, so a board is served when the radial interval
//! its points span (from the segments' closest approach to the farthest point) lies in one
//! served stretch and its bearings within the base joint's range. It searches the square size
//! by bisection, and per size the board's distance along that bearing and its turn (rank 1
//! towards the arm, or a side), keeping the pose of the largest margin; the winner is then
//! checked with [`check_table`], shrinking by 1 % until it passes.

use crate::board::BoardGeometry;
use crate::clearance::columns::{check_columns, crowded_columns};
use crate::clearance::moves::ClearanceCheck;
use crate::pieces::PieceSet;
use crate::table::{Location, Table, closest_on_segment};
use crate::tasks::MotionLimits;
use chessarm_core::arm::dynamics::gravity_torques;
use chessarm_core::arm::model::{ArmModel, JointVector};
use chessarm_core::arm::task::{IkError, TOOL_DOWN, held_turn, inverse_kinematics};
use chessarm_core::nalgebra::{Vector2, Vector3};
use shakmaty::{Board, Square};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Heights between the lowest grip and the highest traverse are checked this far apart, m.
pub const HEIGHT_STEP: f64 = 0.01;
/// The fit keeps every point of its board at least this far inside the served stretch, m: the
/// default placement tolerance (a piece may stand that far off its nominal place).
pub const FIT_MARGIN: f64 = 0.005;
/// Points along a traverse are checked this far apart, m.
pub const SEGMENT_STEP: f64 = 0.01;
/// The fit's radial table has a point every this, m.
pub const RADIAL_STEP: f64 = 0.001;

/// Why the arm does not serve a table, naming the point.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReachError {
    #[error("{place} {height:.4} m above the table at ({x:.4}, {y:.4}) m: {source}")]
    Unreachable { place: String, height: f64, x: f64, y: f64, source: IkError },
    #[error(
        "{place} {height:.4} m above the table at ({x:.4}, {y:.4}) m: joint {joint} needs {need:.3} N·m to hold the arm \
         and the heaviest piece, above {limit:.3} N·m (its torque limit {torque} N·m × the margin {margin})"
    )]
    TooHeavy {
        place: String,
        height: f64,
        x: f64,
        y: f64,
        joint: usize,
        need: f64,
        limit: f64,
        torque: f64,
        margin: f64,
    },
    #[error(
        "{place} at ({x:.4}, {y:.4}) m passes {distance:.4} m from the arm's base axis, within board.base_clearance = \
         {clearance} m (the base's own room): give board.center farther from it, or `chessarm board --fit`"
    )]
    NearBase { place: String, x: f64, y: f64, distance: f64, clearance: f64 },
    #[error(
        "the board and its slots surround the arm's base at ({x:.4}, {y:.4}) m: give board.center away from it (the \
         board's squares, graveyard and reserve must lie to one side of the base)"
    )]
    AroundBase { x: f64, y: f64 },
    #[error("no board with squares of at least {smallest} m is served by this arm: {why}")]
    NoFit { smallest: f64, why: String },
    #[error("{0}")]
    Crowded(crate::clearance::columns::Crowded),
    #[error("{0}")]
    Unplaced(Box<Unplaced>),
    #[error(
        "{source} (with the tool straight down; no pitch within [motion] max_tilt = {:.0}° serves the board either)",
        .max_tilt.to_degrees()
    )]
    AtEveryPitch { max_tilt: f64, source: Box<ReachError> },
}

/// Every location a game uses and the home point, with a name for messages.
fn places(geometry: &BoardGeometry, pieces: &PieceSet, limits: &MotionLimits) -> Vec<(String, Vector2<f64>)> {
    let table = Table::new(*geometry, &Board::empty());
    let mut all: Vec<(String, Vector2<f64>)> = Square::ALL
        .into_iter()
        .map(Location::Square)
        .chain(Location::off_board())
        .map(|location| (location.to_string(), table.nominal_position(location)))
        .collect();
    let home = crate::tasks::home_tool(geometry, pieces, limits);
    all.push(("the home point".to_string(), home.xy()));
    all
}

/// The heights to check, m above the table: each grip height, the highest traverse and every
/// [`HEIGHT_STEP`] from the lowest grip up to it.
fn heights(pieces: &PieceSet, limits: &MotionLimits) -> Vec<f64> {
    let mut heights: Vec<f64> = pieces.all().iter().map(|(_, d)| d.grip_height).collect();
    let top = limits.highest_traverse(pieces);
    let low = heights.iter().copied().fold(top, f64::min);
    let steps = ((top - low) / HEIGHT_STEP).ceil() as usize;
    heights.extend((0..=steps).map(|k| (low + k as f64 * HEIGHT_STEP).min(top)));
    heights.sort_by(f64::total_cmp);
    heights.dedup();
    heights
}

/// The heaviest piece's payload (upright in the tool frame with the tool straight down), for
/// the holding check.
fn heaviest(pieces: &PieceSet) -> chessarm_core::arm::model::Payload {
    let (role, _) = pieces
        .all()
        .into_iter()
        .max_by(|a, b| a.1.mass.total_cmp(&b.1.mass))
        .unwrap_or((shakmaty::Role::King, &pieces.king));
    pieces.payload(role)
}

/// Whether the arm serves the tool tip at `point` with the tool at `pitch` (rad), holding the
/// heaviest piece (`loaded`, the piece upright at that pitch).
fn serve(
    arm: &ArmModel<4>,
    loaded: &ArmModel<4>,
    point: &Vector3<f64>,
    pitch: f64,
    margin: f64,
) -> Result<JointVector<4>, Failure> {
    let q = inverse_kinematics(arm, point, pitch).map_err(Failure::Ik)?;
    let need = gravity_torques(loaded, &q);
    for j in 0..4 {
        let limit = margin * loaded.link(j).limits.torque;
        if need[j].abs() > limit {
            return Err(Failure::Torque {
                joint: j + 1,
                need: need[j].abs(),
                limit,
                torque: loaded.link(j).limits.torque,
            });
        }
    }
    Ok(q)
}

/// Why one point is not served.
#[derive(Debug, Clone, PartialEq)]
enum Failure {
    Ik(IkError),
    Torque { joint: usize, need: f64, limit: f64, torque: f64 },
}

fn failure(place: String, height: f64, point: &Vector3<f64>, why: Failure, margin: f64) -> ReachError {
    let (x, y) = (point.x, point.y);
    match why {
        Failure::Ik(source) => ReachError::Unreachable { place, height, x, y, source },
        Failure::Torque { joint, need, limit, torque } => {
            ReachError::TooHeavy { place, height, x, y, joint, need, limit, torque, margin }
        }
    }
}

/// The arm with the heaviest piece in its grip, for the holding check.
fn loaded(arm: &ArmModel<4>, pieces: &PieceSet, pitch: f64) -> ArmModel<4> {
    arm.with_payload(Some(heaviest(pieces).turned(held_turn(arm, pitch)))).unwrap_or(*arm)
}

/// Steps between the pitches [`check_table`] tries, rad (1°).
pub const PITCH_STEP: f64 = std::f64::consts::PI / 180.0;

/// The pitches within `max_tilt` of straight down, `step` apart, nearest straight down first
/// (down, then tilted out, then in, one step further each time).
fn pitches(max_tilt: f64, step: f64) -> impl Iterator<Item = f64> {
    let most = (max_tilt / step + 1e-9).floor() as i64;
    (0..=most).flat_map(move |k| {
        let out = TOOL_DOWN + k as f64 * step;
        let inward = TOOL_DOWN - k as f64 * step;
        if k == 0 { vec![TOOL_DOWN] } else { vec![out, inward] }
    })
}

/// Whether the base point lies inside the polygon of the points (as seen by the bearings: the
/// points surround it when no half-plane through it holds them all).
fn surrounds(base: &Vector2<f64>, points: &[Vector2<f64>]) -> bool {
    let mut bearings: Vec<f64> = points.iter().map(|p| (p.y - base.y).atan2(p.x - base.x)).collect();
    bearings.sort_by(f64::total_cmp);
    // The largest gap between neighbouring bearings; the points lie in a half-plane through the
    // base when it is at least π.
    let gap = bearings.windows(2).map(|w| w[1] - w[0]).fold(bearings[0] + TAU - bearings[bearings.len() - 1], f64::max);
    gap < PI
}

/// Checks that the arm serves everything a game on `geometry` can ask (see the module): the
/// first point it does not serve is the error.
///
/// # Errors
///
/// The point, its height, and why (out of reach, a joint limit, a torque), or the board around
/// the base.
pub fn check_table(
    arm: &ArmModel<4>,
    geometry: &BoardGeometry,
    pieces: &PieceSet,
    limits: &MotionLimits,
    columns: Option<&ClearanceCheck>,
) -> Result<f64, ReachError> {
    // What is wrong straight down: the first pitch tried.
    let mut first = None;
    let max_tilt = tilt_allowed(arm, limits);
    // The column last found crowded, checked first at the next pitch: a board refused for a
    // column (the same at most pitches) is refused at each pitch by one column, before the
    // reach check, which costs as much as all the columns.
    let mut hint = None;
    let heights = heights(pieces, limits);
    for pitch in pitches(max_tilt, PITCH_STEP) {
        let crowded_at = |hint: Option<usize>| match columns {
            Some(check) => check_columns(arm, check, geometry, pieces, &heights, pitch, hint),
            None => Ok(()),
        };
        let checked = match crowded_at(hint) {
            Err(crowded) => {
                hint = Some(crowded.place_index);
                Err(ReachError::Crowded(crowded))
            }
            Ok(()) => check_table_at(arm, geometry, pieces, limits, pitch, None),
        };
        match checked {
            Ok(()) => return Ok(pitch),
            // Where the board cannot be served at all, no pitch helps: say so at once.
            Err(error @ (ReachError::AroundBase { .. } | ReachError::NearBase { .. })) => return Err(error),
            Err(error) => {
                first.get_or_insert(error);
            }
        }
    }
    // Said as it is straight down (a weak motor, a point out of reach, a crowded column), and
    // that no tilt helps either.
    let error = match first {
        Some(first) if max_tilt > 0.0 => ReachError::AtEveryPitch { max_tilt, source: Box::new(first) },
        Some(first) => first,
        None => ReachError::NoFit { smallest: geometry.square_size, why: "no pitch to try".into() },
    };
    Err(error)
}

/// The tilt the planner may use: `[motion] max_tilt`, or none where the tool frame's z axis is
/// not the last pitch axis ([`chessarm_core::arm::task::tool_z_is_pitch_axis`]).
fn tilt_allowed(arm: &ArmModel<4>, limits: &MotionLimits) -> f64 {
    if chessarm_core::arm::task::tool_z_is_pitch_axis(arm) { limits.max_tilt } else { 0.0 }
}

/// [`check_table`] with the tool at `pitch` (rad) throughout.
pub fn check_table_at(
    arm: &ArmModel<4>,
    geometry: &BoardGeometry,
    pieces: &PieceSet,
    limits: &MotionLimits,
    pitch: f64,
    columns: Option<&ClearanceCheck>,
) -> Result<(), ReachError> {
    let all = places(geometry, pieces, limits);
    let base = arm.base().xy();
    let points: Vec<Vector2<f64>> = all.iter().map(|(_, p)| *p).collect();
    if surrounds(&base, &points) {
        return Err(ReachError::AroundBase { x: base.x, y: base.y });
    }
    let loaded = loaded(arm, pieces, pitch);
    let heights = heights(pieces, limits);
    let z0 = geometry.surface_height;
    let margin = limits.torque_margin;
    // Nothing within the base's own room: no location, no traverse.
    let clearance = geometry.base_clearance;
    for (name, p) in &all {
        outside_base(name, p, &base, clearance)?;
    }
    for (i, (from_name, a)) in all.iter().enumerate() {
        for (to_name, b) in &all[i + 1..] {
            let way = format!("the way from {from_name} to {to_name}");
            outside_base(&way, &closest_on_segment(base, *a, *b), &base, clearance)?;
        }
    }
    // The locations themselves first (their messages name them), then the traverses.
    for (name, p) in &all {
        serve_heights(arm, &loaded, name, p, z0, &heights, pitch, margin)?;
    }
    let lowest_traverse = limits.clearance_margin + heights[0];
    let blend = limits.blend;
    for (i, (from_name, a)) in all.iter().enumerate() {
        for (to_name, b) in &all[i + 1..] {
            let length = (b - a).norm();
            let steps = (length / SEGMENT_STEP).ceil().max(1.0) as usize;
            for k in 1..steps {
                let along = k as f64 / steps as f64;
                let p = a + (b - a) * along;
                let near_end = (along * length).min((1.0 - along) * length) <= blend;
                for &h in heights.iter().filter(|h| near_end || **h >= lowest_traverse - 1e-12) {
                    let point = Vector3::new(p.x, p.y, z0 + h);
                    serve(arm, &loaded, &point, pitch, margin).map_err(|why| {
                        failure(format!("the way from {from_name} to {to_name}"), h, &point, why, margin)
                    })?;
                }
            }
        }
    }
    match columns {
        Some(check) => check_columns(arm, check, geometry, pieces, &heights, pitch, None).map_err(ReachError::Crowded),
        None => Ok(()),
    }
}

/// `place` at `p` keeps `clearance` (m) from the base axis at `base` (the base's own room).
fn outside_base(place: &str, p: &Vector2<f64>, base: &Vector2<f64>, clearance: f64) -> Result<(), ReachError> {
    let distance = (p - base).norm();
    if distance < clearance {
        return Err(ReachError::NearBase { place: place.to_string(), x: p.x, y: p.y, distance, clearance });
    }
    Ok(())
}

/// The arm serves the tool tip over `place` at `p` at every height of `heights` (m above the
/// table at `z0`) with the tool at `pitch`, holding `loaded`: the first height it does not.
#[allow(clippy::too_many_arguments)]
fn serve_heights(
    arm: &ArmModel<4>,
    loaded: &ArmModel<4>,
    place: &str,
    p: &Vector2<f64>,
    z0: f64,
    heights: &[f64],
    pitch: f64,
    margin: f64,
) -> Result<(), ReachError> {
    for &h in heights {
        let point = Vector3::new(p.x, p.y, z0 + h);
        serve(arm, loaded, &point, pitch, margin).map_err(|why| failure(place.to_string(), h, &point, why, margin))?;
    }
    Ok(())
}

/// The radial reach of an arm along one bearing: which distances from the base axis are served
/// at every height a game uses.
struct Radial {
    /// The bearing (rad, in the base frame) the table was taken along.
    bearing: f64,
    /// Served at every height, per `RADIAL_STEP` from 0.
    served: Vec<bool>,
    /// The base angle's range as bearings of the front branch, rad.
    bearings: (f64, f64),
}

impl Radial {
    fn new(
        arm: &ArmModel<4>,
        pieces: &PieceSet,
        limits: &MotionLimits,
        (surface, clearance): (f64, f64),
        pitch: f64,
    ) -> Self {
        let links = arm.links();
        let (lower, upper) = (links[0].limits.lower, links[0].limits.upper);
        let offset = links[0].dh.theta_offset;
        // The bearing of the base joint's mid-range (a joint of more than a turn: its 0).
        let middle = if upper - lower >= TAU { 0.0 } else { 0.5 * (lower + upper) };
        let bearing = middle + offset;
        let reach: f64 = links.iter().map(|l| l.dh.a.abs() + l.dh.d.abs()).sum();
        let count = (reach / RADIAL_STEP).ceil() as usize + 1;
        let heights = heights(pieces, limits);
        let loaded = loaded(arm, pieces, pitch);
        let base = arm.base();
        let direction = Vector3::new(bearing.cos(), bearing.sin(), 0.0);
        let served = (0..count)
            .map(|k| {
                let r = k as f64 * RADIAL_STEP;
                r >= clearance
                    && heights.iter().all(|h| {
                        let point = base + direction * r + Vector3::new(0.0, 0.0, surface + h);
                        serve(arm, &loaded, &point, pitch, limits.torque_margin)
                            // The front branch only: the base turned towards the point.
                            .is_ok_and(|q| wrap(q[0] + offset - bearing).abs() < FRAC_PI_2)
                    })
            })
            .collect();
        Self { bearing, served, bearings: (lower + offset, upper + offset) }
    }

    /// The served stretch `[low, high]` (m) that holds `r`, if `r` is served.
    fn stretch(&self, r: f64) -> Option<(f64, f64)> {
        let k = (r / RADIAL_STEP).round() as usize;
        if !self.served.get(k).copied().unwrap_or(false) {
            return None;
        }
        let low = (0..=k).rev().take_while(|i| self.served[*i]).last().unwrap_or(k);
        let high = (k..self.served.len()).take_while(|i| self.served[*i]).last().unwrap_or(k);
        Some((low as f64 * RADIAL_STEP, high as f64 * RADIAL_STEP))
    }
}

/// `angle` in `(−π, π]`.
fn wrap(angle: f64) -> f64 {
    chessarm_core::arm::task::wrap_angle(angle)
}

/// How far a board pose's points spread from the base axis: the farthest point's distance and
/// the closest approach of any straight way between two of them (m), or `None` when they
/// surround the base.
fn spread(base: &Vector2<f64>, points: &[Vector2<f64>]) -> Option<(f64, f64)> {
    if surrounds(base, points) {
        return None;
    }
    let far = points.iter().map(|p| (p - base).norm()).fold(0.0, f64::max);
    let mut near = f64::INFINITY;
    for (i, a) in points.iter().enumerate() {
        for b in &points[i + 1..] {
            near = near.min((base - closest_on_segment(*base, *a, *b)).norm());
        }
    }
    Some((far, near))
}

/// How well one board pose is served by the radial table: the smallest margin (m) of any point
/// to the edge of the served stretch and of any bearing to the base joint's range (as arc
/// length at the farthest point), or `None` when something is not served. `(far, near)` is
/// the pose's [`spread`].
fn proxy_margin(radial: &Radial, base: &Vector2<f64>, points: &[Vector2<f64>], (far, near): (f64, f64)) -> Option<f64> {
    let (low, high) = radial.stretch(far)?;
    if near < low - 1e-12 {
        return None;
    }
    let radial_margin = (near - low).min(high - far);
    // Bearings relative to the table's bearing, within the base joint's range (front branch).
    let (from, to) = radial.bearings;
    let mut bearing_margin = f64::INFINITY;
    for p in points {
        let relative = wrap((p.y - base.y).atan2(p.x - base.x) - radial.bearing);
        let bearing = radial.bearing + relative;
        let inside = if to - from >= TAU { f64::INFINITY } else { (bearing - from).min(to - bearing) };
        if inside < 0.0 {
            return None;
        }
        bearing_margin = bearing_margin.min(inside * far);
    }
    Some(radial_margin.min(bearing_margin))
}

/// The fitted board and what it leaves.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    pub board: BoardGeometry,
    /// The piece set scaled to the fitted squares.
    pub pieces: PieceSet,
    /// The smallest margin of the radial table over the board's points, m.
    pub margin: f64,
    /// How many board poses the search tried.
    pub tried: usize,
    /// The tool's pitch nearest straight down that serves the board, rad ([`check_table`]).
    pub pitch: f64,
}

/// Steps between the pitches the fit's search tries, rad (5°); the fitted board's own pitch
/// is then found to [`PITCH_STEP`] by [`check_table`].
pub const FIT_PITCH_STEP: f64 = 5.0 * PITCH_STEP;

/// `pieces` scaled from squares of `from` m to `to` m ([`PieceSet::scaled`]).
pub fn scaled_pieces(pieces: &PieceSet, from: f64, to: f64) -> PieceSet {
    pieces.scaled(to / from)
}

/// The largest board (and its pose, and the pieces scaled to it from `pieces` on squares of
/// `square_size` m) that the arm serves, on a table at `surface` m (see the module).
///
/// # Errors
///
/// No board with squares of at least 1 cm is served.
pub fn fit_board(
    arm: &ArmModel<4>,
    pieces: &PieceSet,
    square_size: f64,
    limits: &MotionLimits,
    (surface, clearance): (f64, f64),
    columns: Option<&ClearanceCheck>,
) -> Result<Fit, ReachError> {
    const SMALLEST: f64 = 0.01;
    let base = arm.base().xy();
    let mut tried = 0;
    // The last column found crowded, for the message when no size is clear.
    let crowded = std::cell::RefCell::new(None);
    // The best pose for squares of `s` m at the pitch nearest straight down (of those
    // FIT_PITCH_STEP apart) that serves one, its columns clear when `clear` asks it:
    // (margin, board, pieces), or None. Each pose's points are spread once for every pitch.
    let mut best_at = |s: f64, clear: bool| -> Option<(f64, BoardGeometry, PieceSet)> {
        let scaled = scaled_pieces(pieces, square_size, s);
        let radials: Vec<(f64, Radial)> = pitches(tilt_allowed(arm, limits), FIT_PITCH_STEP)
            .map(|pitch| (pitch, Radial::new(arm, &scaled, limits, (surface, clearance), pitch)))
            .collect();
        let mut best: Vec<Option<(f64, BoardGeometry)>> = vec![None; radials.len()];
        for board in board_poses(arm, &radials[0].1, s, (surface, clearance)) {
            tried += 1;
            let points: Vec<Vector2<f64>> = places(&board, &scaled, limits).into_iter().map(|(_, p)| p).collect();
            let Some(spread) = spread(&base, &points) else { continue };
            for ((_, radial), best) in radials.iter().zip(best.iter_mut()) {
                // A margin for pieces that stand a little off their nominal places.
                if let Some(margin) = proxy_margin(radial, &base, &points, spread).filter(|m| *m >= FIT_MARGIN)
                    && best.is_none_or(|(m, _)| margin > m)
                {
                    *best = Some((margin, board));
                }
            }
        }
        let heights = heights(&scaled, limits);
        radials
            .iter()
            .zip(best)
            .filter_map(|((pitch, _), best)| best.map(|best| (*pitch, best)))
            // The columns' clearance at the pose found (the radial table knows reach only).
            .find(|(pitch, (_, board))| match columns.filter(|_| clear) {
                Some(check) => check_columns(arm, check, board, &scaled, &heights, *pitch, None)
                    .map_err(|c| *crowded.borrow_mut() = Some(c))
                    .is_ok(),
                None => true,
            })
            .map(|(_, (margin, board))| (margin, board, scaled))
    };
    let Some(mut found) = best_at(SMALLEST, false) else {
        return Err(ReachError::NoFit {
            smallest: SMALLEST,
            why: "not even squares of 1 cm: the arm's reach, with the tool within [motion] max_tilt of straight \
                  down, its joint limits or its torques leave no room"
                .into(),
        });
    };
    // Bisection on the square size, to 0.1 mm, on reach: a larger board reaches farther.
    bisect((SMALLEST, 0.2), &mut found, |s| best_at(s, false));
    // The columns' clearance is not monotone in the size (the arm's links are as thick on a
    // small board as on a large one): down from the largest reached, 3 % at a time, to the
    // first size whose columns are clear, then bisection between it and the step above.
    if columns.is_some() {
        let mut above = found.1.square_size;
        let mut size = above;
        let clear = loop {
            if let Some(fit) = best_at(size, true) {
                break fit;
            }
            above = size;
            size *= 0.97;
            if size < SMALLEST {
                let why = crowded.borrow().as_ref().map_or_else(String::new, ToString::to_string);
                return Err(ReachError::NoFit { smallest: SMALLEST, why });
            }
        };
        found = clear;
        bisect((found.1.square_size, above), &mut found, |s| best_at(s, true));
    }
    // The proxy's grid against the full check: shrink by 1 % until it passes (at most 20 times).
    let mut shrinks = 0;
    loop {
        let (margin, board, scaled) = found;
        let error = match check_table(arm, &board, &scaled, limits, columns) {
            Ok(pitch) => return Ok(Fit { board, pieces: scaled, margin, tried, pitch }),
            Err(error) => error,
        };
        let smaller = board.square_size * 0.99;
        let no_fit = || ReachError::NoFit { smallest: smaller, why: error.to_string() };
        shrinks += 1;
        if shrinks > 20 {
            return Err(no_fit());
        }
        found = best_at(smaller, true).ok_or_else(no_fit)?;
    }
}

/// The board poses the fit and the placement try for squares of `s` m, along the bearing of
/// `radial` (the base joint's mid-range) every 2 mm out to the arm's reach: rank 1 towards the
/// arm, the board turned a quarter either way (the arm beside the a- or h-file), or rank 8
/// towards the arm.
fn board_poses(
    arm: &ArmModel<4>,
    radial: &Radial,
    s: f64,
    (surface, clearance): (f64, f64),
) -> impl Iterator<Item = BoardGeometry> {
    const STEP: f64 = 0.002;
    let base = arm.base().xy();
    let reach = radial.served.len() as f64 * RADIAL_STEP;
    let direction = Vector2::new(radial.bearing.cos(), radial.bearing.sin());
    let bearing = radial.bearing;
    let steps = (reach / STEP).ceil() as usize;
    [0.0, FRAC_PI_2, -FRAC_PI_2, PI].into_iter().flat_map(move |turn| {
        let yaw = wrap(bearing - FRAC_PI_2 + turn);
        (0..=steps).map(move |k| BoardGeometry {
            square_size: s,
            center: base + direction * (k as f64 * STEP),
            surface_height: surface,
            yaw: if yaw.abs() < 1e-12 { 0.0 } else { yaw },
            base_clearance: clearance,
            squares_turned: false,
        })
    })
}

/// A board of given squares that no pose tried serves: the pose that failed the fewest places
/// (by the radial table), the pitch it was checked at, and per place that fails why.
#[derive(Debug, Clone, PartialEq)]
pub struct Unplaced {
    pub board: BoardGeometry,
    /// The piece set scaled to the board's squares.
    pub pieces: PieceSet,
    /// The tool's pitch the failures were found at, rad.
    pub pitch: f64,
    /// Per failing place (a square, a slot, the home point, or a way between two of them when
    /// every place is served): its name and why.
    pub failures: Vec<(String, String)>,
    /// How many board poses the search tried.
    pub tried: usize,
}

impl std::fmt::Display for Unplaced {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "no pose found serves squares of {:.1} mm ({} poses tried on the reach, the best checked in full); the \
             nearest, centre ({:.4}, {:.4}) m, yaw {:.4} rad, with the tool {}, fails {} place{}",
            self.board.square_size * 1e3,
            self.tried,
            self.board.center.x,
            self.board.center.y,
            self.board.yaw,
            crate::clearance::columns::tilt_words(self.pitch),
            self.failures.len(),
            if self.failures.len() == 1 { "" } else { "s" }
        )
    }
}

impl std::error::Error for Unplaced {}

/// Places a board of squares of `size` m (the pieces scaled to it from `pieces` on squares of
/// `square_size` m) where the arm serves it, on a table at `surface` m: the fit's poses
/// ([`fit_board`]) at one size, at every pitch [`check_table`] tries ([`PITCH_STEP`] apart).
/// The poses the radial table serves are the candidates, [`PLACE_POSES_PER_PITCH`] of each
/// pitch (the largest margins): those keeping [`FIT_MARGIN`] first, then by pitch (nearest
/// straight down first), then by margin; each has its columns checked at its pitch, and those
/// clear the full reach check ([`check_table_at`]), at most [`PLACE_COLUMN_CHECKS`] and
/// [`PLACE_FULL_CHECKS`] of them; the first that passes is the placement (its margin may be below [`FIT_MARGIN`] when
/// no pose keeping it passes: [`Fit::margin`] says).
///
/// # Errors
///
/// No pose checked is served: the nearest, and what fails there ([`Unplaced`]).
pub fn place_board(
    arm: &ArmModel<4>,
    pieces: &PieceSet,
    square_size: f64,
    size: f64,
    limits: &MotionLimits,
    (surface, clearance): (f64, f64),
    columns: Option<&ClearanceCheck>,
) -> Result<Fit, Box<Unplaced>> {
    let base = arm.base().xy();
    let scaled = scaled_pieces(pieces, square_size, size);
    // Every pitch the pre-flight tries (one size: the tables are cheap next to the checks).
    let radials: Vec<(f64, Radial)> = pitches(tilt_allowed(arm, limits), PITCH_STEP)
        .map(|pitch| (pitch, Radial::new(arm, &scaled, limits, (surface, clearance), pitch)))
        .collect();
    let heights = heights(&scaled, limits);
    let mut tried = 0;
    // Every served pose (pitch's index, margin, board); per pitch the pose of fewest points
    // out of reach among those not served.
    let mut served: Vec<(usize, f64, BoardGeometry)> = Vec::new();
    let mut fewest: Vec<Option<(usize, BoardGeometry)>> = vec![None; radials.len()];
    for board in board_poses(arm, &radials[0].1, size, (surface, clearance)) {
        tried += 1;
        let points: Vec<Vector2<f64>> = places(&board, &scaled, limits).into_iter().map(|(_, p)| p).collect();
        let Some(spread) = spread(&base, &points) else { continue };
        for (index, ((_, radial), fewest)) in radials.iter().zip(fewest.iter_mut()).enumerate() {
            if let Some(margin) = proxy_margin(radial, &base, &points, spread) {
                served.push((index, margin, board));
            } else {
                let unserved = points.iter().filter(|p| radial.stretch((*p - base).norm()).is_none()).count();
                if fewest.is_none_or(|(count, _)| unserved < count) {
                    *fewest = Some((unserved, board));
                }
            }
        }
    }
    served.sort_by(|a, b| (a.1 < FIT_MARGIN).cmp(&(b.1 < FIT_MARGIN)).then(a.0.cmp(&b.0)).then(b.1.total_cmp(&a.1)));
    // The best few of each pitch, so that the checks reach the tilted ones.
    let mut per_pitch = vec![0; radials.len()];
    served.retain(|(index, _, _)| {
        per_pitch[*index] += 1;
        per_pitch[*index] <= PLACE_POSES_PER_PITCH
    });
    let (mut column_checks, mut full_checks) = (0, 0);
    let mut hint = None;
    // Poses the radial table serves that a column or the full check refused, the first few.
    let mut refused = Vec::new();
    for (index, margin, board) in served {
        if column_checks == PLACE_COLUMN_CHECKS || full_checks == PLACE_FULL_CHECKS {
            break;
        }
        let pitch = radials[index].0;
        if let Some(check) = columns {
            column_checks += 1;
            // The column last found crowded first: the next pose usually crowds it too.
            if let Err(crowded) = check_columns(arm, check, &board, &scaled, &heights, pitch, hint) {
                hint = Some(crowded.place_index);
                if refused.len() < PLACE_FULL_CHECKS {
                    refused.push((pitch, board));
                }
                continue;
            }
        }
        full_checks += 1;
        match check_table_at(arm, &board, &scaled, limits, pitch, None) {
            Ok(()) => return Ok(Fit { board, pieces: scaled, margin, tried, pitch }),
            Err(_) if refused.len() < PLACE_FULL_CHECKS => refused.push((pitch, board)),
            Err(_) => {}
        }
    }
    // The nearest pose: of those the radial table serves but a column or the full check
    // refused, and per pitch the one of fewest points out of reach, the one that fails fewest
    // places (nearest straight down of those that fail as few).
    // (Of the latter, the few of fewest points out of reach: listing a pose's failures checks
    // every column, which with a maker's meshes takes a good part of a second.)
    let mut off_table: Vec<(usize, usize, f64, BoardGeometry)> = radials
        .iter()
        .zip(&fewest)
        .enumerate()
        .filter_map(|(index, ((pitch, _), f))| f.map(|(count, board)| (count, index, *pitch, board)))
        .collect();
    off_table.sort_by_key(|(count, index, _, _)| (*count, *index));
    let nearest = refused
        .into_iter()
        .chain(off_table.into_iter().take(PLACE_NEAREST_OFF_TABLE).map(|(_, _, pitch, board)| (pitch, board)))
        .map(|(pitch, board)| (place_failures(arm, &board, &scaled, limits, pitch, columns), pitch, board))
        .min_by_key(|(failures, _, _)| failures.len());
    if let Some((failures, pitch, board)) = nearest {
        return Err(Box::new(Unplaced { board, pieces: scaled, pitch, failures, tried }));
    }
    // Every pose surrounds the base (squares larger than the reach): the board five squares
    // out along the base's mid-range, straight down.
    let radial = &radials[0].1;
    let board = BoardGeometry {
        square_size: size,
        center: base + Vector2::new(radial.bearing.cos(), radial.bearing.sin()) * size * 5.0,
        surface_height: surface,
        yaw: wrap(radial.bearing - FRAC_PI_2),
        base_clearance: clearance,
        squares_turned: false,
    };
    let failures = place_failures(arm, &board, &scaled, limits, TOOL_DOWN, columns);
    Err(Box::new(Unplaced { board, pieces: scaled, pitch: TOOL_DOWN, failures, tried }))
}

/// How many served poses [`place_board`] checks the columns of, at most.
pub const PLACE_COLUMN_CHECKS: usize = 128;
/// How many poses the radial table does not serve (those of fewest points out of reach)
/// [`place_board`] weighs as the nearest, besides those it refused.
pub const PLACE_NEAREST_OFF_TABLE: usize = 4;
/// How many served poses of each pitch (those of the largest margins) [`place_board`] checks.
pub const PLACE_POSES_PER_PITCH: usize = 2;
/// How many poses with clear columns [`place_board`] checks in full, at most.
pub const PLACE_FULL_CHECKS: usize = 8;

/// Per place of `geometry` (every square, slot and the home point), the first thing that fails
/// there with the tool at `pitch`: within the base's room, a height out of reach or too heavy,
/// a crowded column; when every place passes, the first way between two that is not served.
pub fn place_failures(
    arm: &ArmModel<4>,
    geometry: &BoardGeometry,
    pieces: &PieceSet,
    limits: &MotionLimits,
    pitch: f64,
    columns: Option<&ClearanceCheck>,
) -> Vec<(String, String)> {
    let all = places(geometry, pieces, limits);
    let base = arm.base().xy();
    let loaded = loaded(arm, pieces, pitch);
    let heights = heights(pieces, limits);
    let z0 = geometry.surface_height;
    let margin = limits.torque_margin;
    let mut failures: Vec<(String, String)> = Vec::new();
    for (name, p) in &all {
        let checked = outside_base(name, p, &base, geometry.base_clearance)
            .and_then(|()| serve_heights(arm, &loaded, name, p, z0, &heights, pitch, margin));
        if let Err(why) = checked {
            failures.push((name.clone(), why.to_string()));
        }
    }
    if let Some(check) = columns {
        for crowded in crowded_columns(arm, check, geometry, pieces, &heights, pitch) {
            if !failures.iter().any(|(name, _)| *name == crowded.place) {
                failures.push((crowded.place.clone(), crowded.to_string()));
            }
        }
    }
    if failures.is_empty()
        && let Err(error) = check_table_at(arm, geometry, pieces, limits, pitch, None)
    {
        failures.push(("a way between two places".to_string(), error.to_string()));
    }
    failures
}

/// Bisection between a size that serves (`low`, m) and one that does not (`high`), to 0.1 mm:
/// `found` becomes `at`'s result at the largest size that served.
fn bisect<T>((mut low, mut high): (f64, f64), found: &mut T, mut at: impl FnMut(f64) -> Option<T>) {
    while high - low > 1e-4 {
        let middle = 0.5 * (low + high);
        match at(middle) {
            Some(fit) => {
                low = middle;
                *found = fit;
            }
            None => high = middle,
        }
    }
}

/// Per square, the radial table's margin (m) at the square's centre over all heights, or why
/// it is not served: for the reach map.
pub fn square_margins(
    arm: &ArmModel<4>,
    geometry: &BoardGeometry,
    pieces: &PieceSet,
    limits: &MotionLimits,
) -> Vec<(Square, Result<f64, String>)> {
    let radial = Radial::new(arm, pieces, limits, (geometry.surface_height, geometry.base_clearance), limits.pitch);
    let base = arm.base().xy();
    let loaded = loaded(arm, pieces, limits.pitch);
    let heights = heights(pieces, limits);
    Square::ALL
        .into_iter()
        .map(|square| {
            let c = geometry.square_center(square);
            let r = (c.xy() - base).norm();
            for &h in &heights {
                let point = Vector3::new(c.x, c.y, geometry.surface_height + h);
                if let Err(why) = serve(arm, &loaded, &point, limits.pitch, limits.torque_margin) {
                    return (
                        square,
                        Err(failure(square.to_string(), h, &point, why, limits.torque_margin).to_string()),
                    );
                }
            }
            // To the table's resolution (RADIAL_STEP): a point within a step of an edge has 0.
            let margin = radial.stretch(r).map_or(0.0, |(low, high)| (r - low).min(high - r).max(0.0));
            (square, Ok(margin))
        })
        .collect()
}
