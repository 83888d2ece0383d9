//! A piece's outline: volumes and mass properties against closed forms, and the envelope of
//! several outlines holding each of them.

#![allow(clippy::unwrap_used)]

use chessarm_core::arm::model::Payload;
use chessarm_core::arm::outline::{Block, OUTLINE_RINGS, Outline, OutlineError};
use std::f64::consts::PI;

fn close(a: f64, b: f64, what: &str) {
    assert!((a - b).abs() <= 1e-12 * b.abs().max(1e-9), "{what}: {a} against {b}");
}

/// A cylinder: `V = π r² h`, centre of mass at `h/2`, `I = m r²/2` about the axis and
/// `m (3r² + h²)/12` across it; the payload gripped at `g` has its centre `g − h/2` along the
/// tool's x.
#[test]
fn a_cylinders_mass_properties_are_the_closed_forms() {
    let (r, h, m, g) = (0.0145, 0.05, 0.03, 0.04);
    let cylinder = Outline::cylinder(r, h);
    close(cylinder.volume(), PI * r * r * h, "volume");
    let (com, axial, transverse) = cylinder.mass_properties(m);
    close(com, h / 2.0, "centre of mass");
    close(axial, m * r * r / 2.0, "axial");
    close(transverse, m * (3.0 * r * r + h * h) / 12.0, "transverse");
    let payload = Payload::upright_cylinder(m, h, r, g);
    close(payload.inertial.com.x, g - h / 2.0, "payload's centre");
    close(payload.inertial.inertia[(1, 1)], transverse, "payload's transverse");
}

/// A solid cone of base radius `r` and height `h` (a frustum to a point): `V = π r² h / 3`,
/// centre of mass `h/4` above the base, `I = 3 m r² / 10` about the axis and
/// `3 m (4 r² + h²) / 80` across it through the centre of mass. Cut in three sections, the same.
#[test]
fn a_cones_mass_properties_are_the_closed_forms() {
    let (r, h, m) = (0.02, 0.07, 0.05);
    for rings in [vec![[0.0, r], [h, 0.0]], vec![[0.0, r], [0.3 * h, 0.7 * r], [0.5 * h, 0.5 * r], [h, 0.0]]] {
        let cone = Outline::new(&rings, None).unwrap();
        close(cone.volume(), PI * r * r * h / 3.0, "volume");
        let (com, axial, transverse) = cone.mass_properties(m);
        close(com, h / 4.0, "centre of mass");
        close(axial, 0.3 * m * r * r, "axial");
        close(transverse, 3.0 * m * (4.0 * r * r + h * h) / 80.0, "transverse");
    }
}

/// A block alone (on rings of no size): a box's volume, centre and moments, the two transverse
/// ones averaged; on a cylinder, the parallel axes theorem puts the two together.
#[test]
fn a_blocks_mass_properties_are_a_boxs() {
    let (a, c, h, m) = (0.024, 0.011, 0.03, 0.02);
    let block = Block { top: h, half_length: a / 2.0, half_width: c / 2.0 };
    let alone = Outline::new(&[[0.0, 0.0], [0.0, 0.0]], Some(block)).unwrap();
    close(alone.volume(), a * c * h, "volume");
    let (com, axial, transverse) = alone.mass_properties(m);
    close(com, h / 2.0, "centre");
    close(axial, m * (a * a + c * c) / 12.0, "axial");
    close(transverse, m * (0.5 * (a * a + c * c) + h * h) / 12.0, "transverse");
    // On a cylinder of radius ρ and height b: the two bodies' centres and moments combined.
    let (rho, b) = (0.015, 0.02);
    let knight = Outline::new(&[[0.0, rho], [b, rho]], Some(Block { top: b + h, ..block })).unwrap();
    let (v1, v2) = (PI * rho * rho * b, a * c * h);
    let (m1, m2) = (m * v1 / (v1 + v2), m * v2 / (v1 + v2));
    let (z1, z2) = (b / 2.0, b + h / 2.0);
    let zc = (m1 * z1 + m2 * z2) / m;
    let (com, axial, transverse) = knight.mass_properties(m);
    close(com, zc, "centre");
    close(axial, m1 * rho * rho / 2.0 + m2 * (a * a + c * c) / 12.0, "axial");
    let across = m1 * (3.0 * rho * rho + b * b) / 12.0
        + m1 * (z1 - zc).powi(2)
        + m2 * (0.5 * (a * a + c * c) + h * h) / 12.0
        + m2 * (z2 - zc).powi(2);
    close(transverse, across, "transverse");
}

fn pawn() -> Outline {
    Outline::new(
        &[
            [0.0, 0.0125],
            [0.005, 0.0125],
            [0.008, 0.009],
            [0.028, 0.0045],
            [0.030, 0.0083],
            [0.033, 0.0083],
            [0.035, 0.0055],
            [0.043, 0.008],
            [0.05, 0.0],
        ],
        None,
    )
    .unwrap()
}

/// The radius between rings is linear, the larger at a step; what fingers coming down must
/// open around is the widest part above their ends.
#[test]
fn radii_along_the_outline() {
    let p = pawn();
    close(p.radius_at(0.018), 0.5 * (0.009 + 0.0045), "half way up the waist");
    assert_eq!(p.radius_at(0.06), 0.0);
    close(p.widest_above(0.028), 0.0083, "the collar");
    close(p.widest_above(0.034), 0.008, "the head");
    close(p.widest_between(0.01, 0.02), p.radius_at(0.01), "the waist narrows up");
    assert_eq!(p.widest(), 0.0125);
    let step = Outline::new(&[[0.0, 0.01], [0.02, 0.01], [0.02, 0.005], [0.04, 0.005]], None).unwrap();
    assert_eq!(step.radius_at(0.02), 0.01);
    let knight =
        Outline::new(&[[0.0, 0.015], [0.025, 0.01]], Some(Block { top: 0.06, half_length: 0.012, half_width: 0.005 }))
            .unwrap();
    close(knight.widest_above(0.03), 0.012_f64.hypot(0.005), "the head turned any way");
    assert_eq!(knight.height(), 0.06);
}

/// The envelope of outlines (more ring heights than an outline holds, so some sections are
/// joined) is at every height at least as wide as each of them, the block counted turned.
#[test]
fn the_envelope_holds_every_outline() {
    let p = pawn();
    let tall = Outline::new(
        &[
            [0.0, 0.019],
            [0.007, 0.019],
            [0.012, 0.013],
            [0.055, 0.0065],
            [0.059, 0.012],
            [0.063, 0.012],
            [0.07, 0.007],
            [0.08, 0.0115],
            [0.083, 0.0115],
            [0.085, 0.005],
            [0.095, 0.005],
        ],
        None,
    )
    .unwrap();
    let knight = Outline::new(
        &[[0.0, 0.015], [0.006, 0.015], [0.0095, 0.011], [0.017, 0.0087], [0.025, 0.0084]],
        Some(Block { top: 0.06, half_length: 0.0117, half_width: 0.0054 }),
    )
    .unwrap();
    let all = [p, tall, knight];
    let envelope = Outline::envelope(&all).unwrap();
    assert!(envelope.rings().len() <= OUTLINE_RINGS);
    assert_eq!(envelope.height(), 0.095);
    for i in 0..=9500 {
        let z = i as f64 * 1e-5;
        for (k, o) in all.iter().enumerate() {
            let swept = if o.block().is_some_and(|b| z >= 0.025 && z <= b.top) { o.block_radius() } else { 0.0 };
            let need = o.radius_at(z).max(swept);
            assert!(envelope.radius_at(z) >= need - 1e-15, "outline {k} at {z}: {} < {need}", envelope.radius_at(z));
        }
    }
    // Not much more: the joined sections add little.
    let most: f64 = all.iter().map(Outline::volume).fold(0.0, f64::max);
    assert!(envelope.volume() < 1.6 * most, "{} against {most}", envelope.volume());
}

#[test]
fn rings_that_are_no_outline_are_refused() {
    assert_eq!(Outline::new(&[[0.0, 0.01]], None), Err(OutlineError::Rings(1)));
    assert_eq!(Outline::new(&[[0.001, 0.01], [0.02, 0.01]], None), Err(OutlineError::Base(0.001)));
    assert!(matches!(
        Outline::new(&[[0.0, 0.01], [0.02, 0.01], [0.01, 0.0]], None),
        Err(OutlineError::Order { index: 2, .. })
    ));
    assert!(matches!(Outline::new(&[[0.0, 0.01], [0.02, f64::NAN]], None), Err(OutlineError::Value { index: 1, .. })));
    assert!(matches!(Outline::new(&[[0.0, 0.01], [0.02, -0.01]], None), Err(OutlineError::Value { index: 1, .. })));
    assert_eq!(Outline::new(&[[0.0, 0.01], [0.0, 0.01]], None), Err(OutlineError::Flat));
    assert_eq!(Outline::new(&[[0.0, 0.0], [0.02, 0.0]], None), Err(OutlineError::Empty));
    let endless = Block { top: 0.03, half_length: f64::INFINITY, half_width: 0.01 };
    assert!(matches!(Outline::new(&[[0.0, 0.01], [0.02, 0.01]], Some(endless)), Err(OutlineError::Block { .. })));
    let low = Block { top: 0.01, half_length: 0.01, half_width: 0.01 };
    assert!(matches!(Outline::new(&[[0.0, 0.01], [0.02, 0.01]], Some(low)), Err(OutlineError::Block { .. })));
}
