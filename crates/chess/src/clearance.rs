//! How far the arm stays from the standing pieces: distances between the arm's solids
//! ([`chessarm_core::arm::bodies`]) and the pieces, each an upright cylinder of its base radius
//! and height standing on the board, computed by parry3d's GJK on the convex shapes.
//!
//! A motion is checked continuously, not only at samples, by conservative advancement: at time
//! `t` the arm is `d(t)` from the nearest piece, and no point of the arm moves faster than
//! `v̄ = Σ_j |q̇_j|max · ρ_j` (`ρ_j` the farthest any solid reaches from joint `j`'s axis over
//! the motion), so no contact can happen before `t + d(t) / v̄`: the next check is there. A
//! contact between two samples of a fixed grid is not stepped over; one shorter than the
//! smallest step is seen as a distance of at most `v̄ · min_step`. `ρ_j` depends on the joints
//! beyond `j`: [`reach_from_axes`] at one pose bounds it only for motions that do not stretch
//! them (a sweep of the base, say); a motion of the elbow needs a bound over its range.

use chessarm_core::arm::bodies::{ArmSolid, Part, Solid, solids_into};
use chessarm_core::arm::kinematics::FrameChain;
use chessarm_core::arm::model::{ArmModel, JointVector};
use chessarm_core::nalgebra::Vector3;
use parry3d_f64::math::{Pose, Rotation, Vector};
use parry3d_f64::query;
use parry3d_f64::shape::{Ball, Cylinder, Shape};

/// A standing piece as a solid: an upright cylinder whose base is centred on `base` (on the
/// board's surface), m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StandingPiece {
    pub base: Vector3<f64>,
    pub radius: f64,
    pub height: f64,
}

/// The closest approach of the arm to a piece: the distance (m, 0 when they touch or overlap),
/// the arm's part and the piece's index in the list checked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closest {
    pub distance: f64,
    pub part: Part,
    pub piece: usize,
}

fn vector(v: &Vector3<f64>) -> Vector {
    Vector::new(v.x, v.y, v.z)
}

/// A parry cylinder (its axis is its local y) between the face centres `a` and `b`.
fn cylinder_between(a: &Vector3<f64>, b: &Vector3<f64>, radius: f64) -> (Pose, Cylinder) {
    let axis = b - a;
    let length = axis.norm();
    let direction = if length > 0.0 { vector(&(axis / length)) } else { Vector::Y };
    let rotation = Rotation::from_rotation_arc(Vector::Y, direction);
    (Pose::from_parts(vector(&((a + b) * 0.5)), rotation), Cylinder::new(0.5 * length, radius))
}

/// The distance between one solid of the arm and a standing piece, m (0 when they touch).
pub fn solid_to_piece(solid: &Solid, piece: &StandingPiece) -> f64 {
    let top = piece.base + Vector3::new(0.0, 0.0, piece.height);
    let (piece_pose, piece_shape) = cylinder_between(&piece.base, &top, piece.radius);
    let measured = match solid {
        Solid::Cylinder { a, b, radius } => {
            let (pose, shape) = cylinder_between(a, b, *radius);
            query::distance(&pose, &shape as &dyn Shape, &piece_pose, &piece_shape)
        }
        Solid::Sphere { centre, radius } => {
            query::distance(&Pose::from_translation(vector(centre)), &Ball::new(*radius), &piece_pose, &piece_shape)
        }
    };
    // Cylinders and balls are convex: parry's dispatcher supports every pair of them.
    measured.map_or(0.0, |d| d.distance)
}

/// The closest approach of `solids` to `pieces` (`None` without either).
pub fn closest(solids: &[ArmSolid], pieces: &[StandingPiece]) -> Option<Closest> {
    let mut best: Option<Closest> = None;
    for solid in solids {
        for (index, piece) in pieces.iter().enumerate() {
            let distance = solid_to_piece(&solid.solid, piece);
            if best.is_none_or(|b| distance < b.distance) {
                best = Some(Closest { distance, part: solid.part, piece: index });
            }
        }
    }
    best
}

/// Per joint `j`, the farthest any point of the arm's solids reaches from joint `j`'s axis at
/// angles `q`, m: the bound `ρ_j` of a solid point's speed per rad/s of that joint.
pub fn reach_from_axes<const N: usize>(model: &ArmModel<N>, q: &JointVector<N>, solids: &[ArmSolid]) -> [f64; N] {
    let chain = FrameChain::new(model, q);
    std::array::from_fn(|j| {
        let (axis, point) = chain.joint_axis(j);
        let from_axis = |p: &Vector3<f64>| {
            let r = p - point;
            (r - axis * axis.dot(&r)).norm()
        };
        solids
            .iter()
            .map(|s| match s.solid {
                Solid::Cylinder { a, b, radius } => from_axis(&a).max(from_axis(&b)) + radius,
                Solid::Sphere { centre, radius } => from_axis(&centre) + radius,
            })
            .fold(0.0, f64::max)
    })
}

/// The closest approach over a motion `q(t)`, `t ∈ [start, end]` (s), checked by conservative
/// advancement (see the module's documentation). `rate_bound` is the largest `|q̇_j|` of each
/// joint over the motion (rad/s), `reach` a bound of [`reach_from_axes`] over it (m); a step is
/// never shorter than `min_step` (s) — a contact then still shows as a distance of at most
/// `v̄ · min_step` — nor longer than `end − start`. Returns the closest approach and when, and
/// the number of checks made.
#[allow(clippy::too_many_arguments)]
pub fn sweep<const N: usize>(
    model: &ArmModel<N>,
    q: impl Fn(f64) -> JointVector<N>,
    (start, end): (f64, f64),
    rate_bound: &[f64; N],
    reach: &[f64; N],
    pieces: &[StandingPiece],
    min_step: f64,
    solids: &mut Vec<ArmSolid>,
) -> (Option<(f64, Closest)>, usize) {
    let speed: f64 = rate_bound.iter().zip(reach).map(|(w, r)| w.abs() * r).sum();
    // A zero step would never advance past a contact.
    let min_step = if min_step > 0.0 { min_step } else { 1e-6 * (end - start).abs().max(1e-9) };
    let mut t = start;
    let mut best: Option<(f64, Closest)> = None;
    let mut checks = 0;
    loop {
        solids_into(model, &q(t), solids);
        checks += 1;
        let Some(now) = closest(solids, pieces) else { return (None, checks) };
        if best.is_none_or(|(_, b)| now.distance < b.distance) {
            best = Some((t, now));
        }
        if t >= end {
            return (best, checks);
        }
        let step = if speed > 0.0 { now.distance / speed } else { end - t };
        t = (t + step.max(min_step)).min(end);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pawn_at(x: f64, y: f64) -> StandingPiece {
        StandingPiece { base: Vector3::new(x, y, 0.0), radius: 0.012, height: 0.04 }
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

    /// A contact between two samples of a fixed grid: the base yaw sweeps the tool across a thin
    /// piece that dips 1 mm into the tool's sphere only around θ = 0.025 rad, midway between
    /// the grid's samples at 0 and 0.05 rad. The grid sees a clear gap; conservative
    /// advancement finds the contact (a distance within `v̄ · min_step` of zero).
    #[test]
    fn a_contact_between_two_samples_is_found() {
        use chessarm_core::arm::bodies::TOOL_RADIUS;
        use chessarm_core::arm::preset::report_arm;
        let arm = report_arm();
        let q = |t: f64| JointVector::<4>::new(-0.5 + t, 0.6, -1.2, -0.9);
        let tip = FrameChain::new(&arm, &q(0.525)).tip();
        let piece =
            StandingPiece { base: Vector3::new(tip.x, tip.y, 0.0), radius: 0.002, height: tip.z - TOOL_RADIUS + 0.001 };
        let mut solids = Vec::new();
        let grid = (0..=20)
            .map(|k| {
                solids_into(&arm, &q(0.05 * k as f64), &mut solids);
                closest(&solids, &[piece]).map_or(f64::INFINITY, |c| c.distance)
            })
            .fold(f64::INFINITY, f64::min);
        assert!(grid > 1e-3, "the grid must miss it: {grid}");
        let rates = [1.0, 0.0, 0.0, 0.0];
        solids_into(&arm, &q(0.0), &mut solids);
        let reach = reach_from_axes(&arm, &q(0.0), &solids);
        let min_step = 1e-4;
        let (found, checks) = sweep(&arm, q, (0.0, 1.0), &rates, &reach, &[piece], min_step, &mut solids);
        let (when, closest) = found.unwrap();
        let speed: f64 = reach[0] * 1.0;
        // The dip lasts ≈ 23 ms, far longer than the smallest step: the sweep lands in it.
        assert!(speed * min_step < 1e-4);
        assert_eq!(closest.distance, 0.0, "{closest:?} at {when}");
        assert!((when - 0.525).abs() < 0.015, "at {when}");
        assert_eq!(closest.part, Part::Tool);
        // Far fewer checks than a grid fine enough to see a 1 mm dip.
        assert!(checks < 2000, "{checks}");
    }
}
