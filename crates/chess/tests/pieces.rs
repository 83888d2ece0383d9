//! Pieces as profiles: the grip width, the payload, and the profile as the clearance check
//! measures it.

#![allow(clippy::unwrap_used)]

use chessarm_chess::clearance::{Placed, StandingPiece};
use chessarm_chess::pieces::{PieceDimensions, PieceSet};
use chessarm_core::arm::bodies::Solid;
use chessarm_core::arm::outline::{Block, Outline};
use chessarm_core::nalgebra::{Vector2, Vector3};

/// A king and a knight of a Staunton set, as profiles (fractions of the height and the base):
/// plinth, waist, collar, crown; the knight's head a block.
fn staunton(mut d: PieceDimensions, knight: bool) -> PieceDimensions {
    d.shape = if knight {
        Outline::new(
            &[[0.0, 1.0], [0.10, 1.0], [0.16, 0.74], [0.28, 0.58], [0.42, 0.56]],
            Some(Block { top: 1.0, half_length: 0.78, half_width: 0.36 }),
        )
    } else {
        Outline::new(
            &[
                [0.0, 1.0],
                [0.08, 1.0],
                [0.13, 0.72],
                [0.22, 0.50],
                [0.58, 0.34],
                [0.62, 0.64],
                [0.66, 0.64],
                [0.70, 0.38],
                [0.82, 0.60],
                [0.86, 0.60],
                [0.88, 0.26],
                [1.0, 0.26],
            ],
            None,
        )
    }
    .unwrap();
    d
}

/// The default set is cylinders of the bases; a profile keeps the height and the base, and its
/// payload's centre of mass (uniform density) comes lower, the plinth being widest.
#[test]
fn a_profile_keeps_the_pieces_height_and_base() {
    let set = PieceSet::default();
    for (role, d) in set.all() {
        assert_eq!(d.outline(), Outline::cylinder(0.5 * d.base_diameter, d.height), "{role:?}");
        assert_eq!(d.grip_width(0.005), d.base_diameter);
    }
    let king = staunton(set.king, false);
    let outline = king.outline();
    assert!((outline.height() - king.height).abs() < 1e-15);
    assert!((outline.widest() - 0.5 * king.base_diameter).abs() < 1e-15);
    let (com, _, _) = outline.mass_properties(king.mass);
    assert!(com < 0.4 * king.height, "{com}");
    assert!((king.payload().inertial.com.x - (king.grip_height - com)).abs() < 1e-15);
}

/// The fingers hold a piece at its widest part above their ends: on a Staunton king gripped at
/// 80 % of its height, the crown, narrower than the base; with their ends on the plinth, the
/// whole base. A knight's head counts turned any way (half its diagonal).
#[test]
fn the_grip_width_is_the_widest_part_above_the_fingers_ends() {
    let set = PieceSet::default();
    let king = staunton(set.king, false);
    let crown = 2.0 * king.outline().widest_above(king.grip_height - 0.005);
    assert_eq!(king.grip_width(0.005), crown);
    assert!((crown - 0.6 * king.base_diameter).abs() < 1e-12, "{crown}");
    let low = PieceDimensions { grip_height: 0.005, ..king };
    assert_eq!(low.grip_width(0.005), king.base_diameter);
    let knight = staunton(set.knight, true);
    let diagonal = 0.78_f64.hypot(0.36) * knight.base_diameter;
    assert!((knight.grip_width(0.005) - diagonal).abs() < 1e-12);
}

/// The distance from a point to a frustum, by its closed form in the plane through the axis:
/// the distance from `(ρ, z)` to the trapezoid `(0, z0) (r0, z0) (r1, z1) (0, z1)` (0 inside);
/// against GJK on the frustum's support map (the point a ball of no radius).
#[test]
fn a_frustums_distance_is_the_closed_form() {
    let (z0, r0, z1, r1) = (0.01, 0.012, 0.05, 0.004);
    let frustum = Placed::of(&Solid::Frustum {
        a: Vector3::new(0.1, 0.2, z0),
        b: Vector3::new(0.1, 0.2, z1),
        radius_a: r0,
        radius_b: r1,
    });
    let segment = |p: Vector2<f64>, a: Vector2<f64>, b: Vector2<f64>| {
        let t = ((p - a).dot(&(b - a)) / (b - a).norm_squared()).clamp(0.0, 1.0);
        (p - (a + t * (b - a))).norm()
    };
    let corners = [Vector2::new(0.0, z0), Vector2::new(r0, z0), Vector2::new(r1, z1), Vector2::new(0.0, z1)];
    let mut state = 12345_u64;
    let mut random = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let radius = 0.0;
    for _ in 0..2000 {
        let centre =
            Vector3::new(0.1 + 0.06 * (random() - 0.5), 0.2 + 0.06 * (random() - 0.5), 0.07 * random() - 0.005);
        let p = Vector2::new((centre.xy() - Vector2::new(0.1, 0.2)).norm(), centre.z);
        let inside = p.y >= z0 && p.y <= z1 && p.x <= r0 + (r1 - r0) * (p.y - z0) / (z1 - z0);
        let edge = (0..4).map(|k| segment(p, corners[k], corners[(k + 1) % 4])).fold(f64::INFINITY, f64::min);
        let expected = if inside { 0.0 } else { (edge - radius).max(0.0) };
        let ball = Placed::of(&Solid::Sphere { centre, radius });
        let d = frustum.distance(&ball);
        // GJK between a point and one curved shape converges to its relative tolerance (about
        // 1e-7 of the distance); between two curved shapes it stops within tens of micrometres
        // near a rim, as chessarm's cylinders do against Coal's (clearance_coal.rs, 50 µm).
        assert!((d - expected).abs() < 1e-7, "at {centre}: {d} against {expected}");
    }
}

/// A Staunton piece is measured by its profile: a ball beside its waist, inside the cylinder of
/// its base, is clear of it; one against its collar or base touches it; the knight's head is a
/// block facing along the ranks, nearer ahead than beside.
#[test]
fn a_standing_piece_is_its_profile_not_its_bases_cylinder() {
    let set = PieceSet::default();
    let king = staunton(set.king, false);
    let base = Vector3::new(0.2, 0.0, 0.0);
    let standing = Placed::piece(&StandingPiece { base, outline: king.outline(), facing: Vector2::y() });
    let cylinder = Placed::piece(&StandingPiece::cylinder(base, 0.5 * king.base_diameter, king.height));
    let ball = |x: f64, z: f64| Placed::of(&Solid::Sphere { centre: Vector3::new(0.2 + x, 0.0, z), radius: 0.001 });
    let waist = 0.45 * king.height;
    let beside_waist = ball(0.5 * king.outline().radius_at(waist) + 0.5 * 0.5 * king.base_diameter, waist);
    assert!(standing.distance(&beside_waist) > 0.002, "{}", standing.distance(&beside_waist));
    assert_eq!(cylinder.distance(&beside_waist), 0.0);
    let collar = king.outline().widest_between(0.6 * king.height, 0.67 * king.height);
    assert_eq!(standing.distance(&ball(collar, 0.64 * king.height)), 0.0);
    assert_eq!(standing.distance(&ball(0.5 * king.base_diameter - 0.0005, 0.002)), 0.0);
    // The distance is the least of the sections': against the exact radius at that height.
    let z = 0.4 * king.height;
    let d = standing.distance(&ball(king.outline().radius_at(z) + 0.005, z));
    assert!((d - 0.004).abs() < 2e-4, "{d}");
    // The knight faces along y: its head reaches further ahead than beside.
    let knight = staunton(set.knight, true);
    let head = Placed::piece(&StandingPiece { base, outline: knight.outline(), facing: Vector2::y() });
    let block = knight.outline().block().unwrap();
    let high = 0.8 * knight.height;
    let ahead =
        Placed::of(&Solid::Sphere { centre: base + Vector3::new(0.0, block.half_length + 0.003, high), radius: 0.001 });
    let beside =
        Placed::of(&Solid::Sphere { centre: base + Vector3::new(block.half_width + 0.003, 0.0, high), radius: 0.001 });
    assert!((head.distance(&ahead) - 0.002).abs() < 1e-7, "{}", head.distance(&ahead));
    assert!((head.distance(&beside) - 0.002).abs() < 1e-7, "{}", head.distance(&beside));
    let turned = Placed::piece(&StandingPiece { base, outline: knight.outline(), facing: Vector2::x() });
    assert_eq!(turned.distance(&beside), 0.0, "turned, its head's length is where its width was");
}
