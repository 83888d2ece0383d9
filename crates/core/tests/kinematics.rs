//! Kinematics identities: FK ∘ IK = id, Jacobians against finite differences, errors.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

use chessarm_core::arm::kinematics::FrameChain;
use chessarm_core::arm::link::Inertial;
use chessarm_core::arm::model::{JointVector, ModelError};
use chessarm_core::arm::preset::{REPORT_L1, REPORT_L4, report_arm};
use chessarm_core::arm::task::{
    IkError, TOOL_DOWN, inverse_kinematics, task_jacobian, task_jacobian_derivative, tool_point, wrap_angle,
};
use chessarm_core::nalgebra::{Matrix3, Matrix4, Vector3};
use proptest::prelude::*;

/// Central differences with h = 1e-6 rad: truncation error ~h²·|f'''| ≈ 1e-12 and round-off
/// ~ε·|f|/h ≈ 1e-10 for |f| ≲ 1, so 1e-8 separates a wrong derivative from numerical noise.
const FD_STEP: f64 = 1e-6;
const FD_TOLERANCE: f64 = 1e-8;

fn random_configuration(seed: [f64; 4]) -> JointVector<4> {
    JointVector::<4>::from_fn(|i, _| seed[i])
}

#[test]
fn fk_of_ik_returns_the_target_over_the_workspace() {
    let model = report_arm();
    let mut checked = 0;
    for radial_step in 0..30 {
        for height_step in 0..12 {
            for angle_step in 0..8 {
                let radial = 0.1 + 0.02 * radial_step as f64;
                let height = -0.05 + 0.03 * height_step as f64;
                let angle = -3.0 + 0.8 * angle_step as f64;
                let target = Vector3::new(radial * angle.cos(), radial * angle.sin(), height);
                let Ok(q) = inverse_kinematics(&model, &target, TOOL_DOWN) else { continue };
                let reached = tool_point(&model, &q);
                assert!((reached.xyz() - target).norm() < 1e-9, "target {target:?} reached {reached:?}");
                assert!((reached.w - TOOL_DOWN).abs() < 1e-12);
                checked += 1;
            }
        }
    }
    assert!(checked > 1500, "only {checked} targets reachable: the IK rejects too much");
}

proptest! {
    #[test]
    fn fk_of_ik_at_random_points_and_pitches(
        radial in 0.05f64..0.75, angle in -3.1f64..3.1, height in -0.2f64..0.6, pitch in -2.5f64..0.5
    ) {
        let model = report_arm();
        let target = Vector3::new(radial * angle.cos(), radial * angle.sin(), height);
        if let Ok(q) = inverse_kinematics(&model, &target, pitch) {
            let reached = tool_point(&model, &q);
            prop_assert!((reached.xyz() - target).norm() < 1e-9);
            prop_assert!((wrap_angle(reached.w - pitch)).abs() < 1e-12);
            // Elbow up: the elbow is above the line from the shoulder to the wrist.
            let chain = FrameChain::new(&model, &q);
            let shoulder = Vector3::new(0.0, 0.0, REPORT_L1);
            let elbow = chain.body_pose(1).translation.vector;
            let wrist = chain.body_pose(2).translation.vector;
            let radial_of = |p: &Vector3<f64>| p.x * angle.cos() + p.y * angle.sin();
            let line = wrist - shoulder;
            let side = radial_of(&line) * (elbow.z - shoulder.z) - line.z * radial_of(&(elbow - shoulder));
            prop_assert!(side >= -1e-12, "elbow below the shoulder-wrist line");
        }
    }

    #[test]
    fn task_jacobian_matches_finite_differences(a in -3.0f64..3.0, b in -0.5f64..2.5, c in -2.9f64..2.9, d in -2.5f64..2.5) {
        let model = report_arm();
        let q = random_configuration([a, b, c, d]);
        let jacobian = task_jacobian(&model, &q);
        for j in 0..4 {
            let mut step = JointVector::<4>::zeros();
            step[j] = FD_STEP;
            let numeric = (tool_point(&model, &(q + step)) - tool_point(&model, &(q - step))) / (2.0 * FD_STEP);
            prop_assert!((jacobian.column(j) - numeric).norm() < FD_TOLERANCE, "column {} {} vs {}", j, jacobian.column(j), numeric);
        }
    }

    #[test]
    fn jacobian_derivative_matches_finite_differences(
        a in -3.0f64..3.0, b in -0.5f64..2.5, c in -2.9f64..2.9, d in -2.5f64..2.5,
        va in -2.0f64..2.0, vb in -2.0f64..2.0, vc in -2.0f64..2.0, vd in -2.0f64..2.0
    ) {
        let model = report_arm();
        let q = random_configuration([a, b, c, d]);
        let qd = random_configuration([va, vb, vc, vd]);
        let analytic = task_jacobian_derivative(&model, &q, &qd);
        let numeric: Matrix4<f64> =
            (task_jacobian(&model, &(q + qd * FD_STEP)) - task_jacobian(&model, &(q - qd * FD_STEP))) / (2.0 * FD_STEP);
        prop_assert!((analytic - numeric).abs().max() < 1e-7, "{} vs {}", analytic, numeric);
    }
}

#[test]
fn pitch_is_the_elevation_of_the_tool_x_axis() {
    let model = report_arm();
    for seed in [[0.3, 0.7, -1.9, -0.2], [-2.0, 1.2, -2.5, 0.9], [1.0, -0.3, 0.4, -1.8]] {
        let q = random_configuration(seed);
        let chain = FrameChain::new(&model, &q);
        let tool_x = chain.body_pose(3).rotation.matrix().column(0).into_owned();
        let pitch = tool_point(&model, &q).w;
        let expected = Vector3::new(pitch.cos() * q[0].cos(), pitch.cos() * q[0].sin(), pitch.sin());
        assert!((tool_x - expected).norm() < 1e-12, "{tool_x} vs {expected}");
    }
}

#[test]
fn tool_pointing_down_puts_the_wrist_l4_above_the_tip() {
    let model = report_arm();
    let target = Vector3::new(-0.03, 0.24, 0.05);
    let q = inverse_kinematics(&model, &target, TOOL_DOWN).expect("d4 at grip height is reachable");
    let wrist = FrameChain::new(&model, &q).body_pose(2).translation.vector;
    assert!((wrist - (target + Vector3::new(0.0, 0.0, REPORT_L4))).norm() < 1e-12);
}

/// The arm fully stretched (wrist exactly at the longest reach) is reachable: rounding in the
/// law of cosines must not turn the boundary into "out of reach … reaches 0.0000 m to 0.6096 m".
#[test]
fn the_fully_stretched_arm_is_reachable_and_a_near_miss_says_by_how_much() {
    let model = report_arm();
    let reach = 0.6096; // l2 + l3 of the report's arm
    for elevation in [0.3f64, 0.5, 0.7, 1.0] {
        // Wrist at full stretch from the shoulder, tool pointing down: the tip is l4 below it.
        let wrist = Vector3::new(0.0, reach * elevation.cos(), REPORT_L1 + reach * elevation.sin());
        let target = wrist - Vector3::new(0.0, 0.0, REPORT_L4);
        let q = inverse_kinematics(&model, &target, TOOL_DOWN).unwrap();
        assert!((FrameChain::new(&model, &q).tip() - target).norm() < 1e-9, "elevation {elevation}");
        // 10 nm further is out of reach, and the message gives the miss in scientific form.
        let beyond = wrist * (1.0 + 1e-8 / wrist.norm()) - Vector3::new(0.0, 0.0, REPORT_L4);
        let beyond = Vector3::new(0.0, beyond.y, beyond.z);
        let text =
            inverse_kinematics(&model, &beyond, TOOL_DOWN).map(|_| String::new()).unwrap_or_else(|e| e.to_string());
        assert!(text.contains("beyond the arm's full stretch of 0.6096 m") && text.contains("e-"), "{text}");
    }
}

#[test]
fn ik_errors_name_target_reason_and_reach() {
    let model = report_arm();
    let far = inverse_kinematics(&model, &Vector3::new(0.0, 0.9, 0.05), TOOL_DOWN).unwrap_err();
    match &far {
        IkError::OutOfReach { needed, min, max, .. } => {
            assert!(*needed > *max && *min == 0.0 && (*max - 0.6096).abs() < 1e-12);
        }
        other => panic!("expected OutOfReach, got {other:?}"),
    }
    let text = far.to_string();
    assert!(text.contains("(0.0000, 0.9000, 0.0500) m") && text.contains("out of reach") && text.contains("0.6096"));
    assert!(text.contains("beyond the arm's full stretch"), "{text}");

    let axis = inverse_kinematics(&model, &Vector3::new(0.0, 0.0, 0.1), TOOL_DOWN).unwrap_err();
    assert!(matches!(axis, IkError::OnBaseAxis { .. }), "{axis:?}");

    let nan = inverse_kinematics(&model, &Vector3::new(f64::NAN, 0.2, 0.1), TOOL_DOWN).unwrap_err();
    assert!(matches!(nan, IkError::NotFinite { .. }), "{nan:?}");

    // Right under the shoulder, close to the base: the shoulder must tip past its limit.
    let limited = inverse_kinematics(&model, &Vector3::new(0.0, 0.02, -0.25), TOOL_DOWN).unwrap_err();
    match &limited {
        IkError::JointLimit { joint, value, lower, upper, .. } => {
            assert!(*value < *lower || *value > *upper, "joint {joint} at {value} is inside its limits");
            assert!(limited.to_string().contains(&format!("joint {joint}")));
        }
        other => panic!("expected JointLimit, got {other:?}"),
    }
}

#[test]
fn model_validation_names_the_wrong_field() {
    let model = report_arm();
    let mut links = *model.links();
    links[2].inertial.mass = -0.5;
    let error = model.with_links(links).unwrap_err();
    assert!(error.to_string().starts_with("link 3 mass = -0.5"), "{error}");

    let mut links = *model.links();
    links[1].inertial.inertia = Matrix3::from_diagonal(&Vector3::new(0.001, 0.001, 0.01));
    let ModelError::InvalidField { field, reason, .. } = model.with_links(links).unwrap_err();
    assert_eq!(field, "link 2 inertia");
    assert!(reason.contains("triangle"), "{reason}");

    let mut links = *model.links();
    links[0].inertial.inertia[(0, 1)] = 1e-4;
    let error = model.with_links(links).unwrap_err();
    assert!(error.to_string().contains("symmetric"), "{error}");

    let mut links = *model.links();
    links[3].dh.a = f64::INFINITY;
    assert!(model.with_links(links).unwrap_err().to_string().contains("link 4 (a) = inf"));

    let mut links = *model.links();
    links[1].limits.lower = 2.0;
    links[1].limits.upper = 1.0;
    assert!(model.with_links(links).unwrap_err().to_string().contains("lower < upper"));

    let negative_moment = Inertial {
        mass: 1.0,
        com: Vector3::zeros(),
        inertia: Matrix3::from_diagonal(&Vector3::new(-1e-3, 1e-3, 1e-3)),
    };
    let mut links = *model.links();
    links[0].inertial = negative_moment;
    assert!(model.with_links(links).unwrap_err().to_string().contains("positive"));
}

#[test]
fn wrap_angle_stays_in_half_open_interval() {
    use std::f64::consts::PI;
    for (input, expected) in
        [(0.0, 0.0), (PI, PI), (-PI, PI), (3.0 * PI, PI), (2.5 * PI, 0.5 * PI), (-2.5 * PI, -0.5 * PI)]
    {
        assert!((wrap_angle(input) - expected).abs() < 1e-12, "{input} → {}", wrap_angle(input));
    }
}

proptest! {
    #[test]
    fn frame_chain_equals_the_product_of_dh_transforms(
        a in -3.0f64..3.0, b in -3.0f64..3.0, c in -3.0f64..3.0, d in -3.0f64..3.0, twist in -1.5f64..1.5
    ) {
        use chessarm_core::arm::kinematics::dh_transform;
        let mut links = *report_arm().links();
        links[2].dh.alpha = twist;
        links[1].dh.d = 0.03;
        links[3].dh.theta_offset = 0.4;
        let model = report_arm().with_links(links).unwrap();
        let q = random_configuration([a, b, c, d]);
        let chain = FrameChain::new(&model, &q);
        let mut product = chessarm_core::arm::kinematics::Pose::identity();
        for i in 0..4 {
            product *= dh_transform(&model.link(i).dh, q[i]);
            let difference = chain.body_pose(i).to_homogeneous() - product.to_homogeneous();
            prop_assert!(difference.abs().max() < 1e-14, "frame {} differs by {}", i + 1, difference.abs().max());
        }
    }
}

#[test]
fn shifted_joint_trig_agrees_with_sin_cos() {
    use chessarm_core::arm::kinematics::{FrameChain, JointTrig};
    let model = report_arm();
    let base = JointVector::<4>::new(1.67, 0.90, -2.09, -0.37);
    let trig = JointTrig::new(&model, &base);
    // Steps inside the series' range (down to a micro-radian), at its edge, and beyond it.
    for step in [1e-6, -3e-4, 2e-3, -0.01, 0.05, -0.05, 0.0500001, 0.3, -2.5] {
        let delta = JointVector::<4>::new(step, -step, 0.5 * step, 0.0);
        let shifted = trig.shifted(&delta);
        let direct = JointTrig::new(&model, &(base + delta));
        for i in 0..4 {
            let ((s, c), (s0, c0)) = (shifted.get(i), direct.get(i));
            // Angle addition rounds a few times: within 4 ulp of 1.
            assert!((s - s0).abs() < 1e-15 && (c - c0).abs() < 1e-15, "joint {i}, step {step}: {s},{c} vs {s0},{c0}");
        }
        let tip = FrameChain::from_trig(&model, shifted).tip();
        assert!((tip - FrameChain::new(&model, &(base + delta)).tip()).norm() < 1e-15, "step {step}");
    }
}

/// An arm of the family with every freedom the IK allows: a shoulder beside the base axis,
/// frame 1 up or down, offsets along the pitch axes, reversed pitch axes, angle offsets, a
/// twisted tool frame, and unlimited joints (the limits are not what is tested here).
fn offset_arm(seed: &[f64; 12], down: bool, reversed: [bool; 2]) -> chessarm_core::arm::model::ArmModel<4> {
    use chessarm_core::arm::link::{DhParameters, Friction, JointLimits, Link};
    use chessarm_core::arm::model::ArmModel;
    use std::f64::consts::{FRAC_PI_2, PI};
    let base = report_arm();
    let alpha = |r: bool| if r { PI } else { 0.0 };
    let dh = [
        DhParameters {
            a: 0.03 * seed[0].abs(),
            alpha: if down { -FRAC_PI_2 } else { FRAC_PI_2 },
            d: 0.2,
            theta_offset: seed[1],
        },
        DhParameters { a: 0.3, alpha: alpha(reversed[0]), d: 0.04 * seed[2], theta_offset: seed[3] },
        DhParameters { a: 0.28, alpha: alpha(reversed[1]), d: 0.04 * seed[4], theta_offset: seed[5] },
        DhParameters { a: 0.1, alpha: seed[6], d: 0.04 * seed[7], theta_offset: seed[8] },
    ];
    let links: [Link; 4] = std::array::from_fn(|i| Link {
        dh: dh[i],
        limits: JointLimits { lower: -10.0, upper: 10.0, ..base.link(i).limits },
        friction: Friction::default(),
        ..*base.link(i)
    });
    ArmModel::new(links, base.gravity()).unwrap()
}

proptest! {
    #[test]
    fn fk_of_ik_on_arms_with_offsets(
        seed in proptest::array::uniform12(-1.0f64..1.0), down: bool, reversed: [bool; 2],
        radial in 0.15f64..0.6, angle in -3.1f64..3.1, height in -0.1f64..0.4, pitch in -2.0f64..0.0,
    ) {
        let model = offset_arm(&seed, down, reversed);
        let target = Vector3::new(radial * angle.cos(), radial * angle.sin(), height);
        if let Ok(q) = inverse_kinematics(&model, &target, pitch) {
            let reached = tool_point(&model, &q);
            prop_assert!((reached.xyz() - target).norm() < 1e-9, "{} vs {}", reached.xyz(), target);
            prop_assert!(wrap_angle(reached.w - pitch).abs() < 1e-12);
            // The pitch is the elevation of the tool's x axis (from the last pitch axis to the tip).
            let chain = FrameChain::new(&model, &q);
            let tool_x = chain.body_pose(3).rotation.matrix().column(0).into_owned();
            prop_assert!((tool_x.z - pitch.sin()).abs() < 1e-12);
            prop_assert!((tool_x.xy().norm() - pitch.cos().abs()).abs() < 1e-9);
            // The task Jacobian's pitch row is that pitch's derivative.
            let jacobian = task_jacobian(&model, &q);
            for j in 0..4 {
                let mut step = JointVector::<4>::zeros();
                step[j] = FD_STEP;
                let numeric = (tool_point(&model, &(q + step)) - tool_point(&model, &(q - step))) / (2.0 * FD_STEP);
                prop_assert!((jacobian.column(j) - numeric).norm() < FD_TOLERANCE, "column {}", j);
            }
        } else {
            // Only for want of reach: every radial of 0.15–0.6 m clears the sideways offset.
            let error = inverse_kinematics(&model, &target, pitch).unwrap_err();
            prop_assert!(matches!(error, IkError::OutOfReach { .. }), "{error}");
        }
    }
}

#[test]
fn a_target_within_the_sideways_offset_is_refused_by_name() {
    let model = offset_arm(&[0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0], false, [false, false]);
    let error = inverse_kinematics(&model, &Vector3::new(0.05, 0.05, 0.1), TOOL_DOWN).unwrap_err();
    assert!(matches!(error, IkError::InsideOffset { .. }), "{error}");
    assert!(error.to_string().contains("sideways offset of 0.1200 m"), "{error}");
}

/// The report's arm with other joint limits and a base angle offset.
fn report_arm_with(limits: [(f64, f64); 4], base_offset: f64) -> chessarm_core::arm::model::ArmModel<4> {
    use chessarm_core::arm::link::{DhParameters, JointLimits, Link};
    let base = report_arm();
    let links: [Link; 4] = std::array::from_fn(|i| Link {
        limits: JointLimits { lower: limits[i].0, upper: limits[i].1, ..base.link(i).limits },
        dh: DhParameters { theta_offset: if i == 0 { base_offset } else { 0.0 }, ..base.link(i).dh },
        ..*base.link(i)
    });
    base.with_links(links).unwrap()
}

#[test]
fn ik_takes_an_angle_a_turn_away_when_that_lies_within_the_limits() {
    use std::f64::consts::PI;
    let limits = report_arm().links().map(|l| (l.limits.lower, l.limits.upper));
    // The base turns over [0, 6.2] rad: a target at −72° needs q1 = 2π − 1.25 rad.
    let model = report_arm_with([(0.0, 6.2), limits[1], limits[2], limits[3]], 0.0);
    let target = Vector3::new(0.1, -0.3, 0.05);
    let q = inverse_kinematics(&model, &target, TOOL_DOWN).unwrap();
    assert!((q[0] - (2.0 * PI + target.y.atan2(target.x))).abs() < 1e-12, "{q}");
    assert!((tool_point(&model, &q).xyz() - target).norm() < 1e-12);
}

#[test]
fn ik_reaches_back_over_the_shoulder_when_the_base_cannot_turn_to_the_target() {
    let limits = report_arm().links().map(|l| (l.limits.lower, l.limits.upper));
    // The base turns only ±1.5 rad: a target behind needs the base turned by π from it and the
    // shoulder tipped back (the other base branch), elbow still up.
    let model = report_arm_with([(-1.5, 1.5), limits[1], limits[2], limits[3]], 0.0);
    let target = Vector3::new(-0.3, -0.1, 0.05);
    let q = inverse_kinematics(&model, &target, TOOL_DOWN).unwrap();
    assert!(q[0].abs() <= 1.5 && q[1] > std::f64::consts::FRAC_PI_2, "{q}");
    let reached = tool_point(&model, &q);
    // The pitch is the joint angles' sum, here a turn away from −π/2: the same direction.
    assert!((reached.xyz() - target).norm() < 1e-12 && wrap_angle(reached.w - TOOL_DOWN).abs() < 1e-12, "{reached}");
    let chain = FrameChain::new(&model, &q);
    let tool_x = chain.body_pose(3).rotation.matrix().column(0).into_owned();
    assert!((tool_x - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-12, "the tool points down: {tool_x}");
    let (shoulder, elbow, wrist) = (
        Vector3::new(0.0, 0.0, REPORT_L1),
        chain.body_pose(1).translation.vector,
        chain.body_pose(2).translation.vector,
    );
    // Elbow up: above the shoulder–wrist line, at the elbow's distance along it.
    let along = (elbow - shoulder).dot(&(wrist - shoulder)) / (wrist - shoulder).norm_squared();
    assert!(elbow.z > shoulder.z + along * (wrist.z - shoulder.z), "elbow below the line: {elbow} {wrist}");
    // Where neither branch reaches, the front branch's reason is given.
    let error = inverse_kinematics(&model, &Vector3::new(0.0, 0.02, -0.25), TOOL_DOWN).unwrap_err();
    assert!(matches!(error, IkError::JointLimit { .. }), "{error}");
}

#[test]
fn a_path_across_the_base_joints_turn_is_refused_not_followed_as_a_jump() {
    use chessarm_core::plan::path::CartesianPath;
    use chessarm_core::plan::trajectory::{JointTrajectory, PlanError};
    use std::f64::consts::{FRAC_PI_2, PI};
    let limits = report_arm().links().map(|l| (l.limits.lower, l.limits.upper));
    // With θ offset −π/2 the base's ±π turn points along +y: a line from x = −0.1 to x = 0.1 at
    // y = 0.3 crosses it.
    let model = report_arm_with([(-PI, PI), limits[1], limits[2], limits[3]], -FRAC_PI_2);
    let mut path = CartesianPath::new(Vector3::new(-0.1, 0.3, 0.1));
    path.move_to(Vector3::new(0.1, 0.3, 0.1), 2.0).unwrap();
    match JointTrajectory::from_path(&model, &path, 0.01) {
        Err(error @ PlanError::Jump { joint: 1, .. }) => {
            assert!(error.to_string().contains("would jump"), "{error}");
        }
        other => panic!("expected a jump of joint 1, got {other:?}"),
    }
    // The same line with the turn behind the arm is followed smoothly.
    let smooth = JointTrajectory::from_path(&report_arm(), &path, 0.01).unwrap();
    let steps = smooth.samples().windows(2).map(|w| (w[1].q - w[0].q).abs().max()).fold(0.0, f64::max);
    assert!(steps < 0.05, "largest step {steps} rad");
}

#[test]
fn a_piece_gripped_with_the_tool_tilted_stays_upright_at_that_pitch() {
    use chessarm_core::arm::kinematics::FrameChain;
    use chessarm_core::arm::link::{DhParameters, JointLimits, Link};
    use chessarm_core::arm::task::held_turn;
    let report = report_arm();
    // The same arm with its pitch plane flipped (alpha of the base link −π/2: every pitch
    // axis reversed, and the pitch joints' limits with them), as a URDF with axes `0 -1 0`
    // gives.
    let links: [Link; 4] = std::array::from_fn(|i| {
        let (dh, limits) = (report.link(i).dh, report.link(i).limits);
        if i == 0 {
            Link { dh: DhParameters { alpha: -dh.alpha, ..dh }, ..*report.link(i) }
        } else {
            Link { limits: JointLimits { lower: -limits.upper, upper: -limits.lower, ..limits }, ..*report.link(i) }
        }
    });
    let flipped = report.with_links(links).unwrap();
    let mut checked = 0;
    for model in [report, flipped] {
        assert_eq!(held_turn(&model, TOOL_DOWN), 0.0);
        for tilt in [-0.4, -0.1, 0.2, 0.5] {
            let pitch = TOOL_DOWN + tilt;
            let turn = held_turn(&model, pitch);
            assert!((turn.abs() - tilt.abs()).abs() < 1e-12, "turn {turn} for a tilt of {tilt}");
            for (x, y, z) in [(0.25, 0.1, 0.05), (-0.1, 0.3, 0.12), (0.05, -0.28, 0.2)] {
                let Ok(q) = inverse_kinematics(&model, &Vector3::new(x, y, z), pitch) else { continue };
                let frame = FrameChain::new(&model, &q).body_pose(3).rotation;
                let axis = frame * Vector3::new(turn.cos(), turn.sin(), 0.0);
                assert!((axis + Vector3::z()).norm() < 1e-12, "tilt {tilt} at ({x}, {y}, {z}): {axis}");
                checked += 1;
            }
        }
    }
    assert!(checked >= 16, "{checked} of 24 configurations reached");
}
