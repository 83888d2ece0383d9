//! A move's motion checked for clearance, planned or simulated: cut at the gripper's commands
//! into stretches over which the hand and the table stay as they are — the fingers open around
//! the next piece before its grip, closed on it and carrying it from the grip to the release
//! (the carried piece is then a solid of the arm, not a standing piece), open again after the
//! release with the piece standing where it was put — and each stretch swept by conservative
//! advancement ([`super::sweep`]).
//!
//! The motion is the piecewise-linear interpolant of the joint angles sampled at the control
//! period (the planned trajectory's, or the simulated arm's): between two samples each joint
//! turns at the samples' difference over the period, so the largest difference is an exact
//! rate bound for the interpolant. It differs from the smooth motion by at most
//! `q̈max Δt² / 8` (2.5 µrad at 20 rad/s² and 1 ms: a few µm at the tool).

use super::{Closest, Obstacle, Placed, Rules, Scratch, StandingPiece, Stretch, near_pairs, reach_bound, sweep};
use crate::pieces::{PieceSet, piece_name};
use crate::table::{Location, Table};
use chessarm_core::arm::bodies::{Bodies, Gripper, Hand, Held, Part};
use chessarm_core::arm::model::{ArmModel, JointVector};
use chessarm_core::nalgebra::{Vector2, Vector3};

/// How a move's clearance is checked.
#[derive(Debug, Clone, PartialEq)]
pub struct ClearanceCheck {
    pub gripper: Gripper,
    /// The smallest clearance a planned move must keep from every piece, the table and the
    /// arm itself, m: a plan that comes nearer is changed, or refused.
    pub margin: f64,
    /// What the arm's pedestal, housings and links are made of (the fingers are `gripper`).
    pub bodies: Bodies,
    /// Where a held piece's axis lies in the tool frame: the angle (rad) about the tool's z
    /// axis from where the tool points ([`chessarm_core::arm::task::held_turn`] of the game's
    /// pitch; 0 with the tool straight down).
    pub held_turn: f64,
}

impl ClearanceCheck {
    /// Checks the gripper ([`Gripper::validated`]) and that the margin (`arm_clearance`) is
    /// finite and ≥ 0: the first field that is not, its value and what is required.
    pub fn validated(self) -> Result<Self, (&'static str, f64, &'static str)> {
        let gripper = self.gripper.validated()?;
        if !(self.margin.is_finite() && self.margin >= 0.0) {
            return Err(("arm_clearance", self.margin, "must be finite and >= 0"));
        }
        Ok(Self { gripper, ..self })
    }
}

impl Default for ClearanceCheck {
    fn default() -> Self {
        Self { gripper: Gripper::default(), margin: DEFAULT_MARGIN, bodies: Bodies::Drawn, held_turn: 0.0 }
    }
}

/// The distance at or below which a clearance counts as a contact, m: a contact shorter than
/// the sweep's smallest step shows as at most this (0.5 mm, a quarter of the default margin; it
/// does not depend on the margin, so a small opening of the fingers is not a contact).
pub const RESOLUTION: f64 = 0.0005;

/// Narrowest gap a side the planner opens the fingers to beside a piece, m.
pub const MIN_OPENING: f64 = 0.001;

/// Longest stretch of motion swept with one rate bound, s.
const WINDOW: f64 = 0.025;

/// How far beyond the box the arm can sweep a piece is still checked, m.
const NEAR: f64 = 0.05;

/// Default smallest clearance of a planned move, m (2 mm: the fine point's tolerance is 5 mm,
/// and a tracking error of the same order would otherwise touch).
pub const DEFAULT_MARGIN: f64 = 0.002;

/// One pick-and-place of the move as executed: the table index of the piece, where it goes, when the gripper
/// closed and opened (s from the move's start) and where the piece was put (x, y, m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Carry {
    pub piece: usize,
    /// Where it goes.
    pub to: Location,
    pub grip: f64,
    pub release: f64,
    pub placed: Vector2<f64>,
}

/// A move's closest approach.
#[derive(Debug, Clone, PartialEq)]
pub struct MoveClearance {
    /// The smallest clearance, m (0: a contact).
    pub distance: f64,
    /// When, s from the move's start.
    pub time: f64,
    /// The arm's part and what it came close to.
    pub part: Part,
    pub obstacle: Obstacle,
    /// The obstacle for people: "the white pawn on e5", "the table", "link 2".
    pub obstacle_name: String,
    /// The table index of the piece it came close to, if a piece.
    pub piece: Option<usize>,
    /// The fingers' smallest gap to the pieces they open around (about to grip, just
    /// released), m: the gripper's opening less what the motion takes off it.
    pub gripped: Option<f64>,
    /// The number of poses checked, and the distance below which a contact shorter than the
    /// smallest step could hide (m): a clearance at or below it counts as a contact.
    pub checks: usize,
    pub resolution: f64,
    /// Where the closest pair is at `time`: the point on the arm's part and the point on the
    /// obstacle, base frame, m (for showing it; `None` if it could not be placed).
    pub points: Option<[Vector3<f64>; 2]>,
}

impl MoveClearance {
    /// Whether the arm touched (or may have touched, within the resolution) what it came
    /// closest to.
    pub fn is_contact(&self) -> bool {
        self.distance <= self.resolution || self.gripped.is_some_and(|g| g <= self.resolution)
    }
}

/// The piece of `index` held (its outline gripped at its grip height) and the gap the fingers
/// hold it at, m: its grip width with the fingers' ends `reach` m below the tool tip.
fn held(pieces: &PieceSet, table: &Table, index: usize, turn: f64, reach: f64) -> (Held, f64) {
    let d = pieces.dimensions(table.pieces()[index].piece.role);
    (Held { outline: d.outline(), grip_height: d.grip_height, turn }, d.grip_width(reach))
}

/// Checks a move's motion `samples` (times, s from the move's start, and joint angles, rad;
/// at least one) against `table` as it stood before the move, with the pick-and-places
/// `carries` in order, under `rules` (which parts are checked against what). `pieces` gives
/// each kind's size. Returns the closest approach over the
/// whole move (`None` when there is nothing to come close to).
#[allow(clippy::too_many_arguments)]
pub fn check_move(
    arm: &ArmModel<4>,
    check: &ClearanceCheck,
    rules: &Rules,
    table: &Table,
    pieces: &PieceSet,
    samples: &[(f64, JointVector<4>)],
    carries: &[Carry],
    scratch: &mut Scratch,
) -> Option<MoveClearance> {
    let (&(first, _), &(last, _)) = (samples.first()?, samples.last()?);
    let mut positions: Vec<Vector2<f64>> = table.pieces().iter().map(|p| p.position).collect();
    let mut locations: Vec<Location> = table.pieces().iter().map(|p| p.location).collect();
    // Where the nearest piece stood at the nearest instant.
    let mut nearest_location = None;
    let gripper = check.gripper;
    let open =
        |k: usize| gripper.open_gap(held(pieces, table, carries[k].piece, check.held_turn, gripper.finger_reach).1);
    let mut best: Option<(f64, Closest, Option<usize>)> = None;
    // What places the best pair: the hand then and the obstacle, if a piece.
    let mut best_scene: Option<(Hand, Option<Placed>)> = None;
    let mut gripped_best: Option<f64> = None;
    let mut checks = 0;
    // Stretches: before each grip (open), grip to release (closed on the piece), and after the
    // last release (open).
    let mut start = first;
    for k in 0..=carries.len() {
        // (start, end, hand, the piece carried, the pieces the fingers are open around)
        let mut stretches: Vec<Phase> = Vec::with_capacity(2);
        let released: Vec<usize> = k.checked_sub(1).map(|p| carries[p].piece).into_iter().collect();
        if let Some(carry) = carries.get(k) {
            let gap = if k > 0 { open(k).max(open(k - 1)) } else { open(k) };
            let mut around = released.clone();
            around.push(carry.piece);
            stretches.push(Phase {
                from: start,
                to: carry.grip,
                hand: Hand { gripper, gap, held: None },
                carried: None,
                around,
            });
            let (held, diameter) = held(pieces, table, carry.piece, check.held_turn, gripper.finger_reach);
            let hand = Hand { gripper, gap: diameter, held: Some(held) };
            stretches.push(Phase {
                from: carry.grip,
                to: carry.release,
                hand,
                carried: Some(carry.piece),
                around: Vec::new(),
            });
            start = carry.release;
        } else {
            let gap = if k > 0 { open(k - 1) } else { gripper.open_gap(0.0) };
            stretches.push(Phase {
                from: start,
                to: last,
                hand: Hand { gripper, gap, held: None },
                carried: None,
                around: released,
            });
        }
        for Phase { from, to, hand, carried, around } in stretches {
            let (from, to) = (from.clamp(first, last), to.clamp(first, last));
            let standing: Vec<(usize, Placed)> = table
                .pieces()
                .iter()
                .enumerate()
                .filter(|(i, _)| Some(*i) != carried)
                .map(|(i, p)| {
                    let d = pieces.dimensions(p.piece.role);
                    let base = table.geometry().surface_height;
                    let at = positions[i];
                    (
                        i,
                        Placed::piece(&StandingPiece {
                            base: Vector3::new(at.x, at.y, base),
                            outline: d.outline(),
                            facing: table.geometry().ranks_direction(),
                        }),
                    )
                })
                .collect();
            let placed: Vec<Placed> = standing.iter().map(|(_, p)| p.clone()).collect();
            let around: Vec<usize> =
                standing.iter().enumerate().filter(|(_, (i, _))| around.contains(i)).map(|(k, _)| k).collect();
            let q = |t: f64| interpolate(samples, t);
            let reach = reach_bound(arm, &hand, &check.bodies);
            // Windows with their own rate bounds: the arm is slow where it is near the pieces
            // (at the grips and releases), so the steps there are long.
            let windows = ((to - from) / WINDOW).ceil().max(1.0) as usize;
            for w in 0..windows {
                let start = from + (to - from) * w as f64 / windows as f64;
                let end = if w + 1 == windows { to } else { from + (to - from) * (w + 1) as f64 / windows as f64 };
                let rate_bound = rate_bound(samples, start, end);
                let speed: f64 = rate_bound.iter().zip(&reach).map(|(w, r)| w * r).sum();
                // Steps short enough that a contact between two checks shows as at most
                // `RESOLUTION` (the arm's own pairs close at up to twice the speed).
                let min_step = if speed > 0.0 { 0.5 * RESOLUTION / speed } else { end - start };
                // Only the pairs of a solid and a piece whose boxes come within `NEAR` of each
                // other over the window are checked (no point moves more than
                // `v̄ (end − start)`); the others stay at least `NEAR` apart throughout.
                let mut pairs = std::mem::take(&mut scratch.pairs);
                near_pairs(
                    arm,
                    &q(start),
                    &hand,
                    &check.bodies,
                    &placed,
                    speed * (end - start) + NEAR,
                    scratch,
                    &mut pairs,
                );
                let open_end = w + 1 < windows;
                let stretch = Stretch {
                    q: &q,
                    start,
                    end,
                    rate_bound,
                    hand,
                    bodies: &check.bodies,
                    gripped: &around,
                    beyond: NEAR,
                    open_end,
                    candidates: Some(&pairs),
                };
                let swept = sweep(arm, &stretch, &reach, &placed, rules, min_step, scratch);
                scratch.pairs = pairs;
                checks += swept.checks;
                if let Some((t, c)) = swept.closest
                    && best.is_none_or(|b| c.distance < b.1.distance)
                {
                    let piece = match c.obstacle {
                        Obstacle::Piece(i) => Some(standing[i].0),
                        _ => None,
                    };
                    nearest_location = piece.map(|i| locations[i]);
                    let obstacle = match c.obstacle {
                        Obstacle::Piece(i) => Some(placed[i].clone()),
                        _ => None,
                    };
                    best_scene = Some((hand, obstacle));
                    best = Some((t, c, piece));
                }
                if let Some((_, g)) = swept.gripped {
                    gripped_best = Some(gripped_best.map_or(g.distance, |b: f64| b.min(g.distance)));
                }
            }
        }
        if let Some(carry) = carries.get(k) {
            positions[carry.piece] = carry.placed;
            locations[carry.piece] = carry.to;
        }
    }
    let (time, closest, piece) = best?;
    let points = best_scene.and_then(|(hand, obstacle)| {
        super::witness_points(
            arm,
            &interpolate(samples, time),
            &hand,
            &check.bodies,
            &closest,
            obstacle.as_ref(),
            rules,
        )
    });
    let obstacle_name = match (closest.obstacle, piece) {
        (Obstacle::Piece(_), Some(i)) => {
            let p = &table.pieces()[i];
            format!("the {} on {}", piece_name(p.piece), nearest_location.unwrap_or(p.location))
        }
        (Obstacle::Table, _) => "the table".to_string(),
        (Obstacle::Arm(part), _) => part.to_string(),
        (Obstacle::Piece(_), None) => unreachable!("a piece's index is kept"),
    };
    let obstacle = match (closest.obstacle, piece) {
        (Obstacle::Piece(_), Some(i)) => Obstacle::Piece(i),
        (other, _) => other,
    };
    Some(MoveClearance {
        distance: closest.distance,
        time,
        part: closest.part,
        obstacle,
        obstacle_name,
        piece,
        gripped: gripped_best,
        checks,
        // The steps above keep every contact's trace at or below it.
        resolution: RESOLUTION,
        points,
    })
}

/// The smallest square size (m) on which the fingers, open around any piece, keep `margin`
/// from the widest piece on each of the eight neighbouring squares, whatever the angle of the
/// closing direction to the board's files: the pieces are `pieces` on squares of `square` m,
/// scaled with the squares (as `board --fit` scales them), the fingers as `gripper` has them.
/// Each finger is the rectangle `[g/2, g/2 + t] × [−w/2, w/2]` in the closing frame (`g` the
/// open gap around the piece's grip width, `t` the thickness, `w` the width), each neighbour a
/// circle of the widest any piece is over the fingers' height (from their ends `reach` below
/// the grip to the palm); the closing angle is tried every degree. `None` when even 0.2 m
/// squares are too small.
pub fn square_for_fingers(pieces: &PieceSet, square: f64, gripper: &Gripper, margin: f64) -> Option<f64> {
    let clear = |s: f64| {
        let scaled = pieces.scaled(s / square);
        let envelope = scaled.envelope();
        scaled.all().iter().all(|(_, d)| {
            let ends = d.grip_height - gripper.finger_reach;
            let neighbour = envelope.widest_between(ends, ends + gripper.finger_length);
            let inner = 0.5 * gripper.open_gap(d.grip_width(gripper.finger_reach));
            let outer = inner + gripper.finger_thickness;
            let half_width = 0.5 * gripper.finger_width;
            (0..=90).all(|degrees| {
                let (sin, cos) = (degrees as f64).to_radians().sin_cos();
                (-1..=1).flat_map(|i| (-1..=1).map(move |j| (i, j))).filter(|&(i, j)| (i, j) != (0, 0)).all(|(i, j)| {
                    let (x, y) = (s * (i as f64 * cos + j as f64 * sin), s * (j as f64 * cos - i as f64 * sin));
                    // Either finger: mirror the neighbour onto the positive side.
                    let x = x.abs();
                    let dx = x - x.clamp(inner, outer);
                    let dy = y - y.clamp(-half_width, half_width);
                    (dx * dx + dy * dy).sqrt() - neighbour >= margin
                })
            })
        })
    };
    let (mut low, mut high) = (1e-3, 0.2);
    if !clear(high) {
        return None;
    }
    while high - low > 1e-5 {
        let middle = 0.5 * (low + high);
        if clear(middle) { high = middle } else { low = middle }
    }
    Some(high)
}

/// A stretch of a move over which the hand and the table stay as they are: its times (s), the
/// hand, the table index of the piece carried, and those of the pieces the fingers open around.
struct Phase {
    from: f64,
    to: f64,
    hand: Hand,
    carried: Option<usize>,
    around: Vec<usize>,
}

/// The piecewise-linear interpolant of `samples` at `t` (held before the first and after the
/// last).
pub fn interpolate<const N: usize>(samples: &[(f64, JointVector<N>)], t: f64) -> JointVector<N> {
    let k = samples.partition_point(|(s, _)| *s <= t);
    if k == 0 {
        return samples[0].1;
    }
    if k == samples.len() {
        return samples[k - 1].1;
    }
    let ((t0, q0), (t1, q1)) = (&samples[k - 1], &samples[k]);
    let span = t1 - t0;
    if span <= 0.0 { *q1 } else { q0 + (q1 - q0) * ((t - t0) / span) }
}

/// Each joint's largest rate of the interpolant over `[from, to]`, rad/s: the largest
/// `|Δq| / Δt` of the sample intervals that overlap it.
pub fn rate_bound<const N: usize>(samples: &[(f64, JointVector<N>)], from: f64, to: f64) -> [f64; N] {
    let mut bound = [0.0; N];
    let begin = samples.partition_point(|(s, _)| *s <= from).saturating_sub(1);
    for pair in samples[begin..].windows(2) {
        let ((t0, q0), (t1, q1)) = (&pair[0], &pair[1]);
        if *t0 > to {
            break;
        }
        let span = t1 - t0;
        if span > 0.0 {
            for j in 0..N {
                bound[j] = f64::max(bound[j], (q1[j] - q0[j]).abs() / span);
            }
        }
    }
    bound
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The interpolant passes through the samples and its rate bound is the steepest chord.
    #[test]
    fn the_interpolant_and_its_rate_bound() {
        let samples: Vec<(f64, JointVector<2>)> = vec![
            (0.0, JointVector::<2>::new(0.0, 1.0)),
            (0.1, JointVector::<2>::new(0.2, 1.0)),
            (0.2, JointVector::<2>::new(0.2, 0.7)),
        ];
        assert_eq!(interpolate(&samples, 0.1), samples[1].1);
        assert!((interpolate(&samples, 0.05)[0] - 0.1).abs() < 1e-12);
        assert_eq!(interpolate(&samples, 5.0), samples[2].1);
        let all = rate_bound(&samples, 0.0, 0.2);
        assert!((all[0] - 2.0).abs() < 1e-12 && (all[1] - 3.0).abs() < 1e-12);
        let early = rate_bound(&samples, 0.0, 0.05);
        assert!((early[0] - 2.0).abs() < 1e-12 && early[1] == 0.0);
    }
}
