//! Dynamics identities: RNEA/CRBA against the Jacobian/Christoffel method, M SPD, Ṁ − 2C skew,
//! inverse ∘ forward = identity, closed-form gravity torques, payload and motor masses.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

use chessarm_core::arm::dynamics::{
    coriolis_torques, forward_dynamics, gravity_torques, inverse_dynamics, mass_matrix,
};
use chessarm_core::arm::lagrange;
use chessarm_core::arm::link::Inertial;
use chessarm_core::arm::mass_matrix::MassMatrixFactor;
use chessarm_core::arm::model::{ArmModel, JointVector, Payload};
use chessarm_core::arm::preset::{REPORT_L2, REPORT_L3, REPORT_L4, report_arm};
use chessarm_core::nalgebra::{Matrix3, Matrix4, Vector3};
use proptest::prelude::*;

/// Agreement of two exact formulations: a few hundred flops on O(1) numbers, so 1e-10 is
/// ~1e5 ε — far above round-off, far below any modelling mistake.
const EXACT: f64 = 1e-10;

fn state(values: [f64; 4]) -> JointVector<4> {
    JointVector::<4>::from(values)
}

/// An arm with nothing special about it: tilted joints, offsets and off-axis COMs, so that
/// identities are not satisfied by accident of the report arm's symmetry (ERRATA 7).
fn general_arm() -> ArmModel<4> {
    let mut links = *report_arm().links();
    links[1].dh.alpha = 0.3;
    links[1].dh.d = 0.02;
    links[2].dh.alpha = -0.5;
    links[2].dh.theta_offset = 0.2;
    links[3].dh.d = -0.01;
    links[2].inertial.com = Vector3::new(-0.12, 0.01, 0.02);
    links[3].inertial.inertia = Matrix3::new(0.0007, 0.00005, 0.0, 0.00005, 0.0006, 0.00002, 0.0, 0.00002, 0.0008);
    links[2].motor_mass = 0.2;
    links[3].rotor_inertia = 0.001;
    ArmModel::new(links, Vector3::new(0.5, -0.2, -9.81)).unwrap()
}

fn models() -> [ArmModel<4>; 2] {
    [report_arm(), general_arm()]
}

proptest! {
    #[test]
    fn mass_matrix_is_symmetric_positive_definite_and_matches_jacobian_method(
        a in -3.0f64..3.0, b in -1.0f64..2.5, c in -2.9f64..2.9, d in -2.5f64..2.5
    ) {
        for model in models() {
            let q = state([a, b, c, d]);
            let recursive = mass_matrix(&model, &q);
            prop_assert!((recursive - recursive.transpose()).abs().max() < 1e-15);
            let eigen = recursive.symmetric_eigen().eigenvalues;
            prop_assert!(eigen.min() > 0.0, "eigenvalues {}", eigen);
            prop_assert!((recursive - lagrange::mass_matrix(&model, &q)).abs().max() < EXACT);
        }
    }

    #[test]
    fn rnea_matches_jacobian_christoffel_method(
        a in -3.0f64..3.0, b in -1.0f64..2.5, c in -2.9f64..2.9, d in -2.5f64..2.5,
        va in -3.0f64..3.0, vb in -3.0f64..3.0, vc in -3.0f64..3.0, vd in -3.0f64..3.0,
        aa in -10.0f64..10.0, ab in -10.0f64..10.0, ac in -10.0f64..10.0, ad in -10.0f64..10.0
    ) {
        for model in models() {
            let (q, qd, qdd) = (state([a, b, c, d]), state([va, vb, vc, vd]), state([aa, ab, ac, ad]));
            let lagrangian = lagrange::mass_matrix(&model, &q) * qdd
                + lagrange::coriolis_matrix(&model, &q, &qd) * qd
                + lagrange::gravity_torques(&model, &q);
            let recursive = inverse_dynamics(&model, &q, &qd, &qdd);
            prop_assert!((recursive - lagrangian).amax() < EXACT, "{} vs {}", recursive, lagrangian);
            prop_assert!((gravity_torques(&model, &q) - lagrange::gravity_torques(&model, &q)).amax() < EXACT);
            let christoffel = lagrange::coriolis_matrix(&model, &q, &qd) * qd;
            prop_assert!((coriolis_torques(&model, &q, &qd) - christoffel).amax() < EXACT);
        }
    }

    #[test]
    fn mass_matrix_rate_minus_twice_coriolis_is_skew(
        a in -3.0f64..3.0, b in -1.0f64..2.5, c in -2.9f64..2.9, d in -2.5f64..2.5,
        va in -3.0f64..3.0, vb in -3.0f64..3.0, vc in -3.0f64..3.0, vd in -3.0f64..3.0
    ) {
        for model in models() {
            let (q, qd) = (state([a, b, c, d]), state([va, vb, vc, vd]));
            // Ṁ by central differences along q̇ (h = 1e-6: truncation ~1e-12, round-off ~1e-10).
            let h = 1e-6;
            let numeric: Matrix4<f64> = (mass_matrix(&model, &(q + qd * h)) - mass_matrix(&model, &(q - qd * h))) / (2.0 * h);
            let analytic = lagrange::mass_matrix_rate(&model, &q, &qd);
            prop_assert!((numeric - analytic).abs().max() < 1e-8, "{} vs {}", numeric, analytic);
            let skew = numeric - lagrange::coriolis_matrix(&model, &q, &qd) * 2.0;
            prop_assert!((skew + skew.transpose()).abs().max() < 1e-8);
            // Hence q̇ᵀ(Ṁ − 2C)q̇ = 0: the power balance of the Lagrangian.
            prop_assert!(qd.dot(&(skew * qd)).abs() < 1e-8);
        }
    }

    #[test]
    fn forward_dynamics_inverts_inverse_dynamics(
        a in -3.0f64..3.0, b in -1.0f64..2.5, c in -2.9f64..2.9, d in -2.5f64..2.5,
        va in -3.0f64..3.0, vb in -3.0f64..3.0, vc in -3.0f64..3.0, vd in -3.0f64..3.0,
        aa in -10.0f64..10.0, ab in -10.0f64..10.0, ac in -10.0f64..10.0, ad in -10.0f64..10.0
    ) {
        for model in models() {
            let (q, qd, qdd) = (state([a, b, c, d]), state([va, vb, vc, vd]), state([aa, ab, ac, ad]));
            let torque = inverse_dynamics(&model, &q, &qd, &qdd);
            let recovered = forward_dynamics(&model, &q, &qd, &torque).unwrap();
            // Solving with M (condition number ≲ 1e4 here) loses ~4 digits.
            prop_assert!((recovered - qdd).amax() < 1e-8 * (1.0 + qdd.amax()), "{} vs {}", recovered, qdd);
        }
    }
}

#[test]
fn gravity_of_the_outstretched_arm_matches_the_closed_form() {
    // Arm horizontal along x (q2 = q3 = q4 = 0): the shoulder carries every moment arm.
    let model = report_arm();
    let g = 9.8;
    let [_, m2, m3, m4] = [0, 1, 2, 3].map(|i| model.body(i).mass);
    let shoulder = g
        * (m2 * REPORT_L2 / 2.0 + m3 * (REPORT_L2 + REPORT_L3 / 2.0) + m4 * (REPORT_L2 + REPORT_L3 + REPORT_L4 / 2.0));
    let elbow = g * (m3 * REPORT_L3 / 2.0 + m4 * (REPORT_L3 + REPORT_L4 / 2.0));
    let wrist = g * m4 * REPORT_L4 / 2.0;
    let torques = gravity_torques(&model, &JointVector::<4>::zeros());
    // Positive joint angles raise the arm, so holding it up takes positive torque.
    let expected = JointVector::<4>::new(0.0, shoulder, elbow, wrist);
    assert!((torques - expected).amax() < 1e-12, "{torques} vs {expected}");
    // Pointing straight up, gravity exerts no torque.
    let up = gravity_torques(&model, &state([0.4, std::f64::consts::FRAC_PI_2, 0.0, 0.0]));
    assert!(up.amax() < 1e-12, "{up}");
}

#[test]
fn payload_adds_its_weight_at_the_tip() {
    let model = report_arm();
    let mass = 0.03;
    let loaded = model.with_payload(Some(Payload::point_mass(mass))).unwrap();
    let q = JointVector::<4>::zeros();
    let extra = gravity_torques(&loaded, &q) - gravity_torques(&model, &q);
    let reach = REPORT_L2 + REPORT_L3 + REPORT_L4;
    let expected =
        JointVector::<4>::new(0.0, mass * 9.8 * reach, mass * 9.8 * (REPORT_L3 + REPORT_L4), mass * 9.8 * REPORT_L4);
    assert!((extra - expected).amax() < 1e-12, "{extra} vs {expected}");
    // Removing it restores the arm exactly.
    assert_eq!(loaded.with_payload(None).unwrap(), model);
}

#[test]
fn parallel_axis_rule_combines_bodies() {
    // Two 1 kg points 2 m apart: a rod-like body with I = 2 kg·m² about the transverse axes.
    let a = Inertial::point(1.0, Vector3::new(1.0, 0.0, 0.0));
    let b = Inertial::point(1.0, Vector3::new(-1.0, 0.0, 0.0));
    let combined = a.combine(&b);
    assert_eq!(combined.mass, 2.0);
    assert!(combined.com.norm() < 1e-15);
    assert!((combined.inertia - Matrix3::from_diagonal(&Vector3::new(0.0, 2.0, 2.0))).abs().max() < 1e-15);
    // An upright cylinder gripped at its top hangs its COM half a height below the tool tip.
    let pawn = Payload::upright_cylinder(0.03, 0.05, 0.0145, 0.05);
    assert!((pawn.inertial.com - Vector3::new(0.025, 0.0, 0.0)).norm() < 1e-15);
}

#[test]
fn motor_mass_equals_a_point_mass_at_the_joint() {
    let model = report_arm();
    let mut with_motor = *model.links();
    with_motor[2].motor_mass = 0.4; // motor of joint 3, carried by link 2 at the elbow
    let motorised = model.with_links(with_motor).unwrap();
    let mut with_point = *model.links();
    with_point[1].inertial = with_point[1].inertial.combine(&Inertial::point(0.4, Vector3::zeros()));
    let pointed = model.with_links(with_point).unwrap();
    let q = state([0.3, 0.9, -1.7, -0.6]);
    assert!((mass_matrix(&motorised, &q) - mass_matrix(&pointed, &q)).abs().max() < 1e-15);
    let shoulder_extra = gravity_torques(&motorised, &q)[1] - gravity_torques(&model, &q)[1];
    assert!((shoulder_extra - 0.4 * 9.8 * REPORT_L2 * 0.9f64.cos()).abs() < 1e-12);
}

#[test]
fn rotor_inertia_adds_to_the_diagonal() {
    let model = report_arm();
    let mut links = *model.links();
    links[0].rotor_inertia = 0.01;
    let geared = model.with_links(links).unwrap();
    let q = state([0.3, 0.9, -1.7, -0.6]);
    let difference = mass_matrix(&geared, &q) - mass_matrix(&model, &q);
    assert!((difference[(0, 0)] - 0.01).abs() < 1e-15);
    assert!(difference.abs().sum() - 0.01 < 1e-15);
}

/// A random symmetric positive-definite 4×4 matrix `A Aᵀ + ε E`, with entries spread over
/// several orders of magnitude like a mass matrix's (1e-4 to 1 kg·m²).
fn spd_matrix(entries: [f64; 16], scales: [f64; 4]) -> Matrix4<f64> {
    let a = Matrix4::from_row_slice(&entries);
    let scale = Matrix4::from_diagonal(&chessarm_core::nalgebra::Vector4::from(scales));
    scale * (a * a.transpose() + Matrix4::identity() * 1e-3) * scale
}

proptest! {
    #[test]
    fn mass_matrix_factor_rebuilds_the_matrix_and_solves_like_cholesky(
        entries in prop::array::uniform16(-1.0f64..1.0),
        scales in prop::array::uniform4(0.01f64..1.0),
        rhs in prop::array::uniform4(-10.0f64..10.0),
    ) {
        let matrix = spd_matrix(entries, scales);
        let factor = MassMatrixFactor::new(&matrix).unwrap();
        // Relative to the matrix's largest entry: a few dozen flops per entry, 1e-12 ≫ ε.
        let size = matrix.abs().max();
        prop_assert!((factor.reconstruct() - matrix).abs().max() < 1e-12 * size);
        let b = JointVector::<4>::from(rhs);
        let x = factor.solve(&b);
        // The residual M x − b, the quantity a backward-stable solve keeps at round-off.
        prop_assert!((matrix * x - b).abs().max() < 1e-10 * b.abs().max().max(size * x.abs().max()));
        // Both solves are backward stable, so they differ by at most ~cond(M)·ε relative; the
        // smallest eigenvalue is ≥ 1e-3·0.01² and the largest ≤ 4, so cond(M) ≤ 4e7: 1e-7.
        let reference = matrix.cholesky().unwrap().solve(&b);
        prop_assert!((x - reference).norm() <= 1e-7 * reference.norm(), "{x} vs {reference}");
        prop_assert!((factor.pivots().product() - matrix.determinant()).abs() < 1e-9 * matrix.determinant().abs());
    }
}

#[test]
fn mass_matrix_factor_rejects_matrices_that_are_not_positive_definite() {
    let definite = mass_matrix(&report_arm(), &state([0.3, 0.8, -1.2, 0.4]));
    assert!(MassMatrixFactor::new(&definite).is_some());
    let mut indefinite = definite;
    indefinite[(2, 2)] = -indefinite[(2, 2)];
    assert!(MassMatrixFactor::new(&indefinite).is_none());
    // Singular: a joint that carries nothing (zero row and column), whose pivot is exactly 0.
    // (A matrix only within rounding of singular may pass with a tiny pivot, as with nalgebra's
    // Cholesky; mass matrices are far from that.)
    let mut singular = definite;
    for k in 0..4 {
        singular[(3, k)] = 0.0;
        singular[(k, 3)] = 0.0;
    }
    assert!(MassMatrixFactor::new(&singular).is_none());
    assert!(singular.cholesky().is_none());
    // A pivot so small that its reciprocal overflows is rejected rather than turned into NaN.
    let tiny = Matrix4::from_diagonal(&chessarm_core::nalgebra::Vector4::new(1.0, 1e-310, 1.0, 1.0));
    assert!(MassMatrixFactor::new(&tiny).is_none());
    assert_eq!(MassMatrixFactor::new(&Matrix4::identity()), Some(MassMatrixFactor::identity()));
    let mut not_a_number = definite;
    not_a_number[(1, 1)] = f64::NAN;
    assert!(MassMatrixFactor::new(&not_a_number).is_none());
    assert!(
        forward_dynamics(&report_arm(), &state([f64::NAN, 0.0, 0.0, 0.0]), &state([0.0; 4]), &state([0.0; 4])).is_err()
    );
}

#[test]
fn rotated_inertia_equals_the_full_product_for_diagonal_and_general_tensors() {
    use chessarm_core::arm::dynamics::SymmetricMatrix3;
    use chessarm_core::nalgebra::Rotation3;
    let rotation = *Rotation3::from_euler_angles(0.3, -1.1, 2.4).matrix();
    let diagonal = Matrix3::from_diagonal(&Vector3::new(0.007, 0.0014, 0.0066));
    let general = Matrix3::new(0.0007, 0.00005, -0.00003, 0.00005, 0.0006, 0.00002, -0.00003, 0.00002, 0.0008);
    for inertia in [diagonal, general] {
        let full = rotation * inertia * rotation.transpose();
        let stored = SymmetricMatrix3::rotated(&rotation, &inertia);
        let unpacked = Matrix3::new(
            stored.xx, stored.xy, stored.xz, stored.xy, stored.yy, stored.yz, stored.xz, stored.yz, stored.zz,
        );
        // Entries ~1e-3 kg·m² after a dozen flops: 1e-18 is a few ulps.
        assert!((unpacked - full).abs().max() < 1e-18, "{unpacked} vs {full}");
    }
}

#[test]
fn friction_enters_forward_dynamics_and_opposes_motion() {
    use chessarm_core::arm::dynamics::friction_torques;
    use chessarm_core::arm::link::Friction;
    let mut links = *report_arm().links();
    for link in &mut links {
        link.friction = Friction { viscous: 0.05, coulomb: 0.02 };
    }
    let model = ArmModel::new(links, report_arm().gravity()).unwrap();
    assert!(model.has_friction() && !report_arm().has_friction());
    let q = state([0.4, 1.0, -1.3, 0.2]);
    let qd = state([0.8, -0.5, 1.1, -0.3]);
    let torque = state([0.2, 3.0, 1.0, 0.1]);
    let qdd = forward_dynamics(&model, &q, &qd, &torque).unwrap();
    // M q̈ + C q̇ + g = τ + τ_friction, checked through RNEA (another path than the factor).
    let residual = inverse_dynamics(&model, &q, &qd, &qdd) - (torque + friction_torques(&model, &qd));
    assert!(residual.amax() < EXACT, "residual {residual}");
    // Friction takes power out of the arm at every joint: q̇_j τ_f,j < 0.
    let friction = friction_torques(&model, &qd);
    assert!(qd.iter().zip(friction.iter()).all(|(v, f)| v * f < 0.0), "{friction}");
    // And it changes the motion: the same state without friction accelerates differently by
    // M⁻¹ τ_f, tens of mrad/s² here.
    let frictionless = forward_dynamics(&report_arm(), &q, &qd, &torque).unwrap();
    assert!((qdd - frictionless).amax() > 1e-3, "{qdd} vs {frictionless}");
}

#[test]
fn a_failed_factorisation_is_an_error_naming_q() {
    use chessarm_core::arm::dynamics::{ConfigurationDynamics, DynamicsError};
    use chessarm_core::arm::kinematics::JointTrig;
    // Validated links have positive principal moments, so the report's arm has a positive-
    // definite M everywhere; a NaN angle (a diverged run) is what makes factorisation fail.
    let model = report_arm();
    let good = state([0.3, 0.9, -1.1, 0.25]);
    let broken = state([0.3, f64::NAN, -1.1, 0.25]);
    let is_reported = |error: DynamicsError| match error {
        DynamicsError::NotPositiveDefinite(q) => {
            q.len() == 4 && q[1].is_nan() && q[0] == 0.3 && q[2] == -1.1 && q[3] == 0.25
        }
    };
    assert!(is_reported(ConfigurationDynamics::new(&model, &broken).unwrap_err()));
    // Scratch that held a good configuration, then asked for the broken one.
    let mut scratch = ConfigurationDynamics::new(&model, &good).unwrap();
    assert!(scratch.acceleration(&model, &good, &good).iter().all(|a| a.is_finite()));
    assert!(is_reported(scratch.set_configuration(&model, &broken, JointTrig::new(&model, &broken)).unwrap_err()));
    let acceleration = scratch.acceleration(&model, &state([0.0; 4]), &state([0.0; 4]));
    assert!(acceleration.iter().all(|a| a.is_nan()), "{acceleration}");
}
