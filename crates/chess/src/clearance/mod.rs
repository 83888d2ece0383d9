//! How far the arm stays from the standing pieces, the table and itself: distances between the
//! arm's solids ([`chessarm_core::arm::bodies`]) and the pieces, each an upright cylinder of its
//! kind's base radius and height standing on the board, computed by parry3d's GJK on the convex
//! shapes; the table is the plane of the board's surface; pairs of the arm's own solids are
//! checked where their bodies are not neighbours (and do not already touch at rest, as the
//! motor housings of a wrist whose joints meet do).
//!
//! A motion is checked continuously, not only at samples, by conservative advancement: at time
//! `t` the arm is `d(t)` from the nearest obstacle, and no point of the arm moves faster than
//! `v̄ = Σ_j |q̇_j|max · ρ_j` (`ρ_j` the farthest any solid can be from joint `j`'s axis:
//! [`reach_bound`], the chain's lengths beyond it, at any angles), so no contact with a still
//! obstacle can happen before `t + d(t) / v̄` (`2 v̄` between two of the arm's own solids, which
//! both move): the next check is there. A contact between two samples of a fixed grid is not
//! stepped over; one shorter than the smallest step is seen as a distance of at most
//! `v̄ · min_step` (the sweep's `resolution`).

pub mod moves;

use chessarm_core::arm::bodies::{ArmSolid, Hand, Part, Solid, solids_into};
use chessarm_core::arm::kinematics::FrameChain;
use chessarm_core::arm::model::{ArmModel, JointVector};
use chessarm_core::nalgebra::Vector3;
use parry3d_f64::math::{Matrix, Pose, Rotation, Vector};
use parry3d_f64::query;
use parry3d_f64::shape::{Ball, Cuboid, Cylinder, Shape};

/// A standing piece as a solid: an upright cylinder whose base is centred on `base` (on the
/// board's surface), m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StandingPiece {
    pub base: Vector3<f64>,
    pub radius: f64,
    pub height: f64,
}

/// What the arm comes close to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Obstacle {
    /// A standing piece, by its index in the list checked.
    Piece(usize),
    /// The table (the board's surface).
    Table,
    /// Another part of the arm.
    Arm(Part),
}

/// The closest approach of the arm to an obstacle: the distance (m, 0 when they touch or
/// overlap), the arm's part and the obstacle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closest {
    pub distance: f64,
    pub part: Part,
    pub obstacle: Obstacle,
}

/// One of parry's convex shapes, without a box on the heap.
#[derive(Debug, Clone, Copy)]
enum Convex {
    Cylinder(Cylinder),
    Ball(Ball),
    Cuboid(Cuboid),
}

impl Convex {
    fn shape(&self) -> &dyn Shape {
        match self {
            Convex::Cylinder(s) => s,
            Convex::Ball(s) => s,
            Convex::Cuboid(s) => s,
        }
    }
}

/// A solid as parry sees it, with its axis-aligned bounding box (m).
#[derive(Debug, Clone, Copy)]
pub struct Placed {
    pose: Pose,
    shape: Convex,
    low: Vector3<f64>,
    high: Vector3<f64>,
}

fn vector(v: &Vector3<f64>) -> Vector {
    Vector::new(v.x, v.y, v.z)
}

/// A cylinder's half extent along each world axis: `r √(1 − u_k²)` across plus `|u_k| L / 2`.
fn cylinder_box(a: &Vector3<f64>, b: &Vector3<f64>, radius: f64) -> (Vector3<f64>, Vector3<f64>) {
    let axis = b - a;
    let length = axis.norm();
    let u = if length > 0.0 { axis / length } else { Vector3::z() };
    let half = u.map(|c| radius * (1.0 - c * c).max(0.0).sqrt());
    (a.inf(b) - half, a.sup(b) + half)
}

impl Placed {
    /// The parry shape and pose of `solid` (a parry cylinder's axis is its local y).
    pub fn of(solid: &Solid) -> Self {
        match solid {
            Solid::Cylinder { a, b, radius } => {
                let axis = b - a;
                let length = axis.norm();
                let direction = if length > 0.0 { vector(&(axis / length)) } else { Vector::Y };
                let rotation = Rotation::from_rotation_arc(Vector::Y, direction);
                let (low, high) = cylinder_box(a, b, *radius);
                Self {
                    pose: Pose::from_parts(vector(&((a + b) * 0.5)), rotation),
                    shape: Convex::Cylinder(Cylinder::new(0.5 * length, *radius)),
                    low,
                    high,
                }
            }
            Solid::Sphere { centre, radius } => Self {
                pose: Pose::from_translation(vector(centre)),
                shape: Convex::Ball(Ball::new(*radius)),
                low: centre.add_scalar(-radius),
                high: centre.add_scalar(*radius),
            },
            Solid::Cuboid { centre, axes, half } => {
                let columns = [0, 1, 2].map(|k| vector(&axes.column(k).into_owned()));
                let rotation = Rotation::from_mat3(&Matrix::from_cols(columns[0], columns[1], columns[2]));
                let extent = axes.abs() * half;
                Self {
                    pose: Pose::from_parts(vector(centre), rotation),
                    shape: Convex::Cuboid(Cuboid::new(vector(half))),
                    low: centre - extent,
                    high: centre + extent,
                }
            }
        }
    }

    /// A piece standing upright.
    pub fn piece(piece: &StandingPiece) -> Self {
        let top = piece.base + Vector3::new(0.0, 0.0, piece.height);
        Self::of(&Solid::Cylinder { a: piece.base, b: top, radius: piece.radius })
    }

    /// The distance between the two boxes, m: a lower bound of the solids'.
    fn box_gap(&self, other: &Placed) -> f64 {
        let gap = (self.low - other.high).sup(&(other.low - self.high)).sup(&Vector3::zeros());
        gap.norm()
    }

    /// The distance to `other`, m (0 when they touch or overlap). Cylinders, balls and boxes
    /// are convex: parry's dispatcher supports every pair of them, so an error is a bug.
    pub fn distance(&self, other: &Placed) -> f64 {
        match query::distance(&self.pose, self.shape.shape(), &other.pose, other.shape.shape()) {
            Ok(d) => d.distance,
            Err(error) => unreachable!("parry has no distance between convex primitives: {error:?}"),
        }
    }
}

/// The distance between one solid of the arm and a standing piece, m (0 when they touch).
pub fn solid_to_piece(solid: &Solid, piece: &StandingPiece) -> f64 {
    Placed::of(solid).distance(&Placed::piece(piece))
}

/// Which of the arm's parts are checked against which obstacles.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Rules {
    /// The table's height (the board's surface), m; `None`: no table check.
    pub table: Option<f64>,
    /// Parts not checked against the table (the pedestal stands on it; a held piece's base
    /// touches it at the grip and the release).
    pub off_table: Vec<Part>,
    /// Pairs of the arm's parts that are not checked against each other (besides parts of
    /// the same or neighbouring bodies): those that touch at rest by construction.
    pub touching: Vec<(Part, Part)>,
    /// Whether the arm's own solids are checked against each other at all.
    pub self_check: bool,
}

impl Rules {
    /// The rules for `model` with `hand`: the table at `table` m, the pedestal and a held
    /// piece off it, and the pairs of non-neighbouring parts that already touch at `rest`
    /// (as a setup assistant marks pairs "always in collision").
    pub fn for_arm<const N: usize>(model: &ArmModel<N>, hand: &Hand, rest: &JointVector<N>, table: f64) -> Self {
        let mut solids = Vec::new();
        solids_into(model, rest, hand, &mut solids);
        let placed: Vec<Placed> = solids.iter().map(|s| Placed::of(&s.solid)).collect();
        let mut touching = Vec::new();
        for i in 0..solids.len() {
            for k in i + 1..solids.len() {
                if apart(solids[i].part, solids[k].part, N) && placed[i].distance(&placed[k]) <= 0.0 {
                    touching.push((solids[i].part, solids[k].part));
                }
            }
        }
        Self { table: Some(table), off_table: vec![Part::Pedestal, Part::Held], touching, self_check: true }
    }

    fn pair_checked(&self, a: Part, b: Part, n: usize) -> bool {
        self.self_check && apart(a, b, n) && !self.touching.iter().any(|&(x, y)| (x, y) == (a, b) || (x, y) == (b, a))
    }
}

/// Whether two parts move with bodies that are not the same or neighbours.
fn apart(a: Part, b: Part, n: usize) -> bool {
    a.body(n).abs_diff(b.body(n)) >= 2
}

/// The closest approaches at one instant: to still obstacles (pieces, table) and between the
/// arm's own solids (`None` without any).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Nearest {
    pub still: Option<Closest>,
    pub own: Option<Closest>,
}

impl Nearest {
    /// The nearer of the two.
    pub fn overall(&self) -> Option<Closest> {
        match (self.still, self.own) {
            (Some(a), Some(b)) => Some(if b.distance < a.distance { b } else { a }),
            (a, b) => a.or(b),
        }
    }
}

fn better(best: &mut Option<Closest>, candidate: Closest) {
    if best.is_none_or(|b| candidate.distance < b.distance) {
        *best = Some(candidate);
    }
}

/// The closest approaches of `solids` (placed into `placed`, a buffer kept by the caller) to
/// `pieces` (already placed), the table and each other under `rules`. Exact distances are
/// computed only for pairs whose bounding boxes are nearer than the best so far.
pub fn nearest<const N: usize>(
    solids: &[ArmSolid],
    pieces: &[Placed],
    rules: &Rules,
    placed: &mut Vec<Placed>,
) -> Nearest {
    placed.clear();
    placed.extend(solids.iter().map(|s| Placed::of(&s.solid)));
    let mut still: Option<Closest> = None;
    if let Some(table) = rules.table {
        for solid in solids.iter().filter(|s| !rules.off_table.contains(&s.part)) {
            better(
                &mut still,
                Closest { distance: (solid.solid.lowest() - table).max(0.0), part: solid.part, obstacle: Obstacle::Table },
            );
        }
    }
    for (solid, shape) in solids.iter().zip(placed.iter()) {
        for (index, piece) in pieces.iter().enumerate() {
            if still.is_some_and(|b| shape.box_gap(piece) >= b.distance) {
                continue;
            }
            better(
                &mut still,
                Closest { distance: shape.distance(piece), part: solid.part, obstacle: Obstacle::Piece(index) },
            );
        }
    }
    let mut own: Option<Closest> = None;
    for i in 0..solids.len() {
        for k in i + 1..solids.len() {
            if !rules.pair_checked(solids[i].part, solids[k].part, N)
                || own.is_some_and(|b| placed[i].box_gap(&placed[k]) >= b.distance)
            {
                continue;
            }
            better(
                &mut own,
                Closest {
                    distance: placed[i].distance(&placed[k]),
                    part: solids[i].part,
                    obstacle: Obstacle::Arm(solids[k].part),
                },
            );
        }
    }
    Nearest { still, own }
}

/// Per joint `j`, the farthest any point of the arm's solids can be from joint `j`'s axis at
/// any angles, m: the lengths of the chain from `p_j` to the tip (the distances between
/// consecutive frame origins, the same at every pose) plus the farthest any solid reaches
/// beyond the frame origin it hangs from (measured at the zero pose: the fingers' and a held
/// piece's reach from the tip, a housing's half-diagonal, a link's radius).
pub fn reach_bound<const N: usize>(model: &ArmModel<N>, hand: &Hand) -> [f64; N] {
    let zero = JointVector::<N>::zeros();
    let chain = FrameChain::new(model, &zero);
    let origins: Vec<Vector3<f64>> = (0..=N).map(|i| if i == 0 { model.base() } else { chain.body_pose(i - 1).translation.vector }).collect();
    let mut solids = Vec::new();
    solids_into(model, &zero, hand, &mut solids);
    let tip = chain.tip();
    let extent = solids
        .iter()
        .map(|s| match s.part {
            Part::Finger(_) | Part::Held => s.solid.farthest_from(&tip),
            Part::Housing(j) => s.solid.farthest_from(&chain.joint_axis(j - 1).1),
            Part::Link(_) => chessarm_core::arm::bodies::LINK_RADIUS,
            // The pedestal does not move.
            Part::Pedestal => 0.0,
        })
        .fold(0.0, f64::max);
    std::array::from_fn(|j| (j..N).map(|i| (origins[i + 1] - origins[i]).norm()).sum::<f64>() + extent)
}

/// What a sweep found: the closest approach and when (s), the number of checks, and the
/// resolution (m): a contact shorter than the smallest step shows as at most this distance.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Swept {
    pub closest: Option<(f64, Closest)>,
    pub checks: usize,
    pub resolution: f64,
}

/// A motion to sweep: joint angles `q(t)` (rad) for `t ∈ [start, end]` (s), a bound of each
/// joint's `|q̇|` over it (rad/s), and the hand, constant over it.
pub struct Stretch<'a, const N: usize> {
    pub q: &'a dyn Fn(f64) -> JointVector<N>,
    pub start: f64,
    pub end: f64,
    pub rate_bound: [f64; N],
    pub hand: Hand,
}

impl<const N: usize> std::fmt::Debug for Stretch<'_, N> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Stretch")
            .field("start", &self.start)
            .field("end", &self.end)
            .field("rate_bound", &self.rate_bound)
            .field("hand", &self.hand)
            .finish_non_exhaustive()
    }
}

/// Reused buffers of a sweep (no allocation after the first motions).
#[derive(Debug, Default)]
pub struct Scratch {
    solids: Vec<ArmSolid>,
    placed: Vec<Placed>,
}

/// The closest approach over a motion, checked by conservative advancement (see the module's
/// documentation) against `pieces` (placed), the table and the arm itself under `rules`.
/// `reach` is [`reach_bound`]'s; a step is never shorter than `min_step` (s, > 0; a
/// non-positive one is replaced by a millionth of the motion) nor longer than the rest of it.
pub fn sweep<const N: usize>(
    model: &ArmModel<N>,
    stretch: &Stretch<'_, N>,
    reach: &[f64; N],
    pieces: &[Placed],
    rules: &Rules,
    min_step: f64,
    scratch: &mut Scratch,
) -> Swept {
    let (start, end) = (stretch.start, stretch.end);
    let speed: f64 = stretch.rate_bound.iter().zip(reach).map(|(w, r)| w.abs() * r).sum();
    // A zero step would never advance past a contact.
    let min_step = if min_step > 0.0 { min_step } else { 1e-6 * (end - start).abs().max(1e-9) };
    let mut swept = Swept { resolution: speed * min_step, ..Swept::default() };
    let mut t = start;
    loop {
        solids_into(model, &(stretch.q)(t), &stretch.hand, &mut scratch.solids);
        swept.checks += 1;
        let now = nearest::<N>(&scratch.solids, pieces, rules, &mut scratch.placed);
        let Some(overall) = now.overall() else { return swept };
        if swept.closest.is_none_or(|(_, b)| overall.distance < b.distance) {
            swept.closest = Some((t, overall));
        }
        if t >= end {
            return swept;
        }
        let still = now.still.map_or(f64::INFINITY, |c| c.distance);
        let own = now.own.map_or(f64::INFINITY, |c| 0.5 * c.distance);
        let step = if speed > 0.0 { still.min(own) / speed } else { end - t };
        t = (t + step.max(min_step)).min(end);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use chessarm_core::arm::bodies::Gripper;
    use chessarm_core::arm::preset::report_arm;

    fn pawn_at(x: f64, y: f64) -> StandingPiece {
        StandingPiece { base: Vector3::new(x, y, 0.0), radius: 0.012, height: 0.04 }
    }

    fn open_hand() -> Hand {
        Hand { gripper: Gripper::default(), gap: 0.04, held: None }
    }

    /// A sphere beside an upright cylinder: the distance from its centre to the axis less both
    /// radii; above it: the height over the top less the sphere's radius.
    #[test]
    fn sphere_to_piece_is_the_closed_form() {
        let piece = pawn_at(0.2, 0.1);
        let side = Solid::Sphere { centre: Vector3::new(0.2 + 0.05, 0.1, 0.02), radius: 0.008 };
        assert!((solid_to_piece(&side, &piece) - (0.05 - 0.012 - 0.008)).abs() < 1e-9);
        let above = Solid::Sphere { centre: Vector3::new(0.2, 0.1, 0.07), radius: 0.008 };
        assert!((solid_to_piece(&above, &piece) - (0.07 - 0.04 - 0.008)).abs() < 1e-9);
        let inside = Solid::Sphere { centre: Vector3::new(0.2, 0.1, 0.02), radius: 0.008 };
        assert_eq!(solid_to_piece(&inside, &piece), 0.0);
    }

    /// A horizontal cylinder crossing above a piece: its underside's height above the top.
    #[test]
    fn a_link_over_a_piece_clears_it_by_its_underside() {
        let piece = pawn_at(0.0, 0.0);
        let link = Solid::Cylinder { a: Vector3::new(-0.1, 0.0, 0.1), b: Vector3::new(0.1, 0.0, 0.1), radius: 0.015 };
        assert!((solid_to_piece(&link, &piece) - (0.1 - 0.015 - 0.04)).abs() < 1e-9);
    }

    /// Two boxes in known poses: face to face, the gap between the faces; a cube turned 45°
    /// about z beside an upright one, its edge's distance `d − h√2 − h`.
    #[test]
    fn box_to_box_is_the_closed_form() {
        use chessarm_core::nalgebra::{Matrix3, Rotation3};
        let half = Vector3::repeat(0.01);
        let cube = |x: f64, axes: Matrix3<f64>| Placed::of(&Solid::Cuboid { centre: Vector3::new(x, 0.0, 0.0), axes, half });
        let upright = cube(0.0, Matrix3::identity());
        assert!((upright.distance(&cube(0.05, Matrix3::identity())) - 0.03).abs() < 1e-9);
        let turned = *Rotation3::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_4).matrix();
        let expected = 0.05 - 0.01 * 2f64.sqrt() - 0.01;
        assert!((upright.distance(&cube(0.05, turned)) - expected).abs() < 1e-9);
        // The bounding boxes' gap is a lower bound.
        assert!(upright.box_gap(&cube(0.05, turned)) <= expected + 1e-12);
    }

    /// A tilted cylinder above the table: its lowest point's height equals parry's distance to
    /// the half-space below the table (the plane's closed form checked by the library).
    #[test]
    fn the_table_distance_is_parrys_half_space_distance() {
        use parry3d_f64::shape::HalfSpace;
        let table = 0.02;
        let link =
            Solid::Cylinder { a: Vector3::new(0.1, 0.0, 0.09), b: Vector3::new(0.2, 0.05, 0.15), radius: 0.015 };
        let plane = HalfSpace::new(Vector::Z);
        let placed = Placed::of(&link);
        let parry = query::distance(&placed.pose, placed.shape.shape(), &Pose::from_translation(Vector::new(0.0, 0.0, table)), &plane)
            .unwrap()
            .distance;
        assert!((link.lowest() - table - parry).abs() < 1e-9, "{} vs {parry}", link.lowest() - table);
    }

    /// A contact between two samples of a fixed grid: the base yaw sweeps the fingers across
    /// a thin piece that reaches 1 mm above finger 2's lower end only around t = 0.525 s,
    /// midway between the grid's samples at 0.5 and 0.55 s (θ̇ = 1 rad/s; finger 1 passes
    /// the piece ≈ 0.13 s earlier, before the motion starts). The grid sees a clear gap;
    /// conservative advancement finds the contact (a distance of 0).
    #[test]
    fn a_contact_between_two_samples_is_found() {
        let arm = report_arm();
        let hand = open_hand();
        let q = |t: f64| JointVector::<4>::new(-0.5 + t, 0.6, -1.2, -0.9);
        let mut solids = Vec::new();
        solids_into(&arm, &q(0.525), &hand, &mut solids);
        let finger = solids.iter().find(|s| s.part == Part::Finger(2)).unwrap().solid;
        let Solid::Cuboid { centre, .. } = finger else { panic!() };
        let low = finger.lowest();
        let piece = StandingPiece { base: Vector3::new(centre.x, centre.y, 0.0), radius: 0.002, height: low + 0.001 };
        let pieces = [Placed::piece(&piece)];
        let rules = Rules::default();
        let mut placed = Vec::new();
        let (start, end) = (0.45, 0.6);
        let grid = (0..=3)
            .map(|k| {
                solids_into(&arm, &q(start + 0.05 * k as f64), &hand, &mut solids);
                nearest::<4>(&solids, &pieces, &rules, &mut placed).overall().map_or(f64::INFINITY, |c| c.distance)
            })
            .fold(f64::INFINITY, f64::min);
        assert!(grid > 1e-3, "the grid must miss it: {grid}");
        let reach = reach_bound(&arm, &hand);
        let stretch = Stretch { q: &q, start, end, rate_bound: [1.0, 0.0, 0.0, 0.0], hand };
        let min_step = 1e-4;
        let swept = sweep(&arm, &stretch, &reach, &pieces, &rules, min_step, &mut Scratch::default());
        let (when, closest) = swept.closest.unwrap();
        // The contact lasts ≈ 25 ms, far longer than the smallest step: the sweep lands in it.
        assert!(swept.resolution < 1e-4);
        assert_eq!(closest.distance, 0.0, "{closest:?} at {when}");
        assert!((when - 0.525).abs() < 0.015, "at {when}");
        assert_eq!(closest.part, Part::Finger(2));
        // Far fewer checks than a grid fine enough to see a 1 mm dip.
        assert!(swept.checks < 2000, "{}", swept.checks);
    }

    /// The reach bound holds at sampled poses: no solid is farther from joint j's axis.
    #[test]
    fn the_reach_bound_holds_at_any_angles() {
        let arm = report_arm();
        let hand = Hand { held: Some(chessarm_core::arm::bodies::Held { radius: 0.02, height: 0.095, grip_height: 0.076 }), ..open_hand() };
        let reach = reach_bound(&arm, &hand);
        let mut solids = Vec::new();
        let mut rng = chessarm_core::sense::rng::SeededRng::new(7);
        let pi = std::f64::consts::PI;
        for _ in 0..500 {
            let q = JointVector::<4>::from_fn(|_, _| rng.uniform(-pi, pi));
            solids_into(&arm, &q, &hand, &mut solids);
            let chain = FrameChain::new(&arm, &q);
            for j in 0..4 {
                let point = chain.joint_axis(j).1;
                // The solids joint j turns: those of the links after it.
                for s in solids.iter().filter(|s| s.part.body(4) > j) {
                    let far = s.solid.farthest_from(&point);
                    assert!(far <= reach[j] + 1e-12, "joint {} part {} {far} > {}", j + 1, s.part, reach[j]);
                }
            }
        }
    }
}
