//! LSPB profiles, Cartesian paths and joint trajectories.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

use chessarm_core::arm::preset::report_arm;
use chessarm_core::arm::task::{TOOL_DOWN, inverse_kinematics, task_jacobian, tool_point};
use chessarm_core::nalgebra::Vector3;
use chessarm_core::plan::path::{CartesianPath, GripperAction};
use chessarm_core::plan::profile::{Lspb, ProfileError};
use chessarm_core::plan::trajectory::{JointTrajectory, PlanError, joint_state_at};
use proptest::prelude::*;

proptest! {
    #[test]
    fn lspb_boundary_values_blend_timing_and_peak_velocity(start in -2.0f64..2.0, delta in -3.0f64..3.0, duration in 0.1f64..5.0) {
        prop_assume!(delta.abs() > 1e-3);
        let end = start + delta;
        let profile = Lspb::new(start, end, duration).unwrap();
        let at_start = profile.sample(0.0);
        let at_end = profile.sample(duration);
        prop_assert!((at_start.position - start).abs() < 1e-12 && at_start.velocity == 0.0);
        prop_assert!((at_end.position - end).abs() < 1e-12 && at_end.velocity == 0.0);
        // Report default: cruise at 1.5× the average, so the blend lasts T/3.
        prop_assert!((profile.blend_time() - duration / 3.0).abs() < 1e-12);
        prop_assert!((profile.cruise_velocity() - 1.5 * delta / duration).abs() < 1e-12);
        // Peak velocity over a dense sampling equals the cruise velocity and is never exceeded.
        let peak = (0..=1000).map(|k| profile.sample(duration * k as f64 / 1000.0).velocity.abs()).fold(0.0, f64::max);
        prop_assert!((peak - 1.5 * delta.abs() / duration).abs() < 1e-9);
        // Velocity integrates to the displacement (trapezoid area = Δ).
        let area = profile.cruise_velocity() * (duration - profile.blend_time());
        prop_assert!((area - delta).abs() < 1e-9);
    }

    #[test]
    fn lspb_is_continuous_in_position_and_velocity(cruise_factor in 1.05f64..2.0, duration in 0.2f64..4.0) {
        let profile = Lspb::with_cruise_velocity(0.3, -0.7, duration, -cruise_factor / duration).unwrap();
        let epsilon = 1e-9;
        for boundary in [profile.blend_time(), duration - profile.blend_time()] {
            let before = profile.sample(boundary - epsilon);
            let after = profile.sample(boundary + epsilon);
            // Across 2ε the position moves by at most 2ε·|V| ≤ 2e-9 · 10 = 2e-8.
            prop_assert!((before.position - after.position).abs() < 2.0 * epsilon * profile.cruise_velocity().abs() + 1e-12);
            prop_assert!((before.velocity - after.velocity).abs() < 1e-6);
        }
        // Acceleration is the derivative of velocity inside each phase.
        for t in [0.1 * profile.blend_time(), 0.5 * duration, duration - 0.1 * profile.blend_time()] {
            let h = 1e-6;
            let numeric = (profile.sample(t + h).velocity - profile.sample(t - h).velocity) / (2.0 * h);
            prop_assert!((numeric - profile.sample(t).acceleration).abs() < 1e-5);
            let numeric_velocity = (profile.sample(t + h).position - profile.sample(t - h).position) / (2.0 * h);
            prop_assert!((numeric_velocity - profile.sample(t).velocity).abs() < 1e-6);
        }
    }
}

#[test]
fn infeasible_profiles_are_errors() {
    // Too slow to cover the distance, too fast for a blend, wrong sign, bad durations.
    assert!(matches!(Lspb::with_cruise_velocity(0.0, 1.0, 1.0, 0.9), Err(ProfileError::CruiseVelocity { .. })));
    assert!(matches!(Lspb::with_cruise_velocity(0.0, 1.0, 1.0, 2.1), Err(ProfileError::CruiseVelocity { .. })));
    assert!(matches!(Lspb::with_cruise_velocity(0.0, 1.0, 1.0, -1.5), Err(ProfileError::CruiseVelocity { .. })));
    assert!(matches!(Lspb::new(0.0, 1.0, 0.0), Err(ProfileError::Duration(_))));
    assert!(matches!(Lspb::new(0.0, 1.0, f64::NAN), Err(ProfileError::Duration(_))));
    assert!(matches!(Lspb::new(0.0, f64::INFINITY, 1.0), Err(ProfileError::EndPoints(..))));
    let message = Lspb::with_cruise_velocity(0.0, 1.0, 1.0, 3.0).unwrap_err().to_string();
    assert!(message.contains("cruise velocity 3") && message.contains("(1, 2]"), "{message}");
    // The pure parabolic profile (V = 2Δ/T) is the feasible extreme.
    let triangle = Lspb::with_cruise_velocity(0.0, 1.0, 1.0, 2.0).unwrap();
    assert!((triangle.blend_time() - 0.5).abs() < 1e-12);
}

#[test]
fn minimum_time_profile_respects_its_limits() {
    for (distance, v_max, a_max) in [(1.0, 0.5, 2.0), (0.01, 0.5, 2.0), (-0.3, 0.2, 0.5)] {
        let profile = Lspb::min_time(0.0, distance, v_max, a_max).unwrap();
        let peak_velocity = (0..=2000)
            .map(|k| profile.sample(profile.duration() * k as f64 / 2000.0).velocity.abs())
            .fold(0.0, f64::max);
        assert!(peak_velocity <= v_max * (1.0 + 1e-12));
        assert!(profile.blend_acceleration().abs() <= a_max * (1.0 + 1e-12));
        assert!((profile.sample(profile.duration()).position - distance).abs() < 1e-12);
        // Minimal: one of the limits is reached.
        let saturated =
            (peak_velocity - v_max).abs() < 1e-9 || (profile.blend_acceleration().abs() - a_max).abs() < 1e-9;
        assert!(saturated);
    }
    assert!(Lspb::min_time(0.0, 1.0, 0.0, 1.0).is_err());
}

fn square_path() -> CartesianPath {
    let mut path = CartesianPath::new(Vector3::new(0.21, 0.0, 0.0));
    path.move_to(Vector3::new(0.21, 0.0, 0.15), 1.0).unwrap();
    path.pause(0.5).unwrap();
    path.move_to(Vector3::new(-0.03, 0.18, 0.15), 3.0).unwrap();
    path.pause(0.5).unwrap();
    path.move_to(Vector3::new(-0.03, 0.18, 0.05), 1.0).unwrap().mark(GripperAction::Grip);
    path
}

#[test]
fn path_hits_waypoints_and_is_continuous() {
    let path = square_path();
    assert!((path.duration() - 6.0).abs() < 1e-12);
    for (t, point) in path.waypoints() {
        assert!((path.sample(t).position - point).norm() < 1e-12, "waypoint at {t}");
        assert!(path.sample(t).velocity.norm() < 1e-12);
    }
    let epsilon = 1e-9;
    for k in 1..600 {
        let t = k as f64 * 0.01;
        let (before, after) = (path.sample(t - epsilon), path.sample(t + epsilon));
        assert!((before.position - after.position).norm() < 1e-7);
        assert!((before.velocity - after.velocity).norm() < 1e-6);
    }
    // The tip moves on the straight segment between waypoints.
    let mid = path.sample(3.0).position;
    let (a, b) = (Vector3::new(0.21, 0.0, 0.15), Vector3::new(-0.03, 0.18, 0.15));
    let off_line = (mid - a).cross(&(b - a)).norm() / (b - a).norm();
    assert!(off_line < 1e-12);
    assert_eq!(path.events().len(), 1);
    assert!((path.events()[0].time - 6.0).abs() < 1e-12);
}

#[test]
fn joint_trajectory_rates_match_differences_of_ik() {
    let model = report_arm();
    let path = square_path();
    let trajectory = JointTrajectory::from_path(&model, &path, 0.005).unwrap();
    assert_eq!(trajectory.samples().len(), 1201);
    let h = 1e-5;
    let ik = |t: f64| inverse_kinematics(&model, &path.sample(t).position, TOOL_DOWN).unwrap();
    for sample in trajectory.samples().iter().step_by(37) {
        let t = sample.t;
        if t < h || t > path.duration() - h {
            continue;
        }
        // FK of the joint path is the tip path.
        let tip = tool_point(&model, &sample.q).xyz();
        assert!((tip - path.sample(t).position).norm() < 1e-9);
        // q̇ = J⁻¹ẋ agrees with central differences of the IK (not smooth at blend corners:
        // skip samples within h of one, where the one-sided accelerations differ).
        let numeric_rate = (ik(t + h) - ik(t - h)) / (2.0 * h);
        assert!((numeric_rate - sample.qd).norm() < 1e-6, "t = {t}: {numeric_rate} vs {}", sample.qd);
        let numeric_acc = (joint_state_at(&model, &path.sample(t + h)).unwrap().qd
            - joint_state_at(&model, &path.sample(t - h)).unwrap().qd)
            / (2.0 * h);
        let near_corner = path.sample(t + h).acceleration != path.sample(t - h).acceleration;
        if !near_corner {
            assert!((numeric_acc - sample.qdd).norm() < 1e-4, "t = {t}: {numeric_acc} vs {}", sample.qdd);
        }
        // Velocity mapping: J q̇ reproduces the Cartesian velocity.
        let task_rate = task_jacobian(&model, &sample.q) * sample.qd;
        assert!((task_rate.xyz() - path.sample(t).velocity).norm() < 1e-12);
    }
}

#[test]
fn unreachable_path_reports_time_and_target() {
    let model = report_arm();
    // Approaching the reach boundary the joint rates blow up first (near-singular), so the
    // path starts outside the reach and comes back in.
    let mut path = CartesianPath::new(Vector3::new(0.21, 0.8, 0.0));
    path.move_to(Vector3::new(0.21, 0.2, 0.0), 2.0).unwrap();
    let error = JointTrajectory::from_path(&model, &path, 0.01).unwrap_err();
    assert!(matches!(error, PlanError::Ik { .. }), "{error:?}");
    assert!(error.to_string().starts_with("at t = "), "{error}");
    assert!(JointTrajectory::from_path(&model, &path, 0.0).is_err());
}

#[test]
fn too_fast_a_move_breaks_the_velocity_limit() {
    let model = report_arm();
    let mut path = CartesianPath::new(Vector3::new(0.21, 0.0, 0.05));
    path.move_to(Vector3::new(-0.21, 0.3, 0.05), 0.05).unwrap();
    let error = JointTrajectory::from_path(&model, &path, 0.001).unwrap_err();
    assert!(matches!(error, PlanError::VelocityLimit { .. }), "{error:?}");
}

#[test]
fn an_lspb_move_turns_the_tool_with_its_profile() {
    let model = report_arm();
    let mut path = CartesianPath::new(Vector3::new(0.1, 0.25, 0.12));
    let profile = Lspb::new(0.0, 1.0, 2.0).unwrap();
    path.turning_move(Vector3::new(-0.1, 0.35, 0.12), TOOL_DOWN + 0.3, profile);
    path.pause(0.5).unwrap();
    assert!((path.end_pitch() - (TOOL_DOWN + 0.3)).abs() < 1e-15);
    let trajectory = JointTrajectory::from_path(&model, &path, 0.01).unwrap();
    for sample in trajectory.samples() {
        let s = profile.sample(sample.t.min(2.0));
        let reached = tool_point(&model, &sample.q);
        assert!((reached.w - (TOOL_DOWN + 0.3 * s.position)).abs() < 1e-9, "t = {}", sample.t);
        // The pitch row of J q̇ is the profile's rate times the turn.
        let rate = task_jacobian(&model, &sample.q) * sample.qd;
        assert!((rate.w - 0.3 * s.velocity).abs() < 1e-9, "t = {}", sample.t);
    }
}
