//! Closed-loop simulation against closed forms: energy in free motion, the PD error response,
//! the steady error of an unknown payload, and PID removing it.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

mod common;

use chessarm_core::arm::dynamics::gravity_torques;
use chessarm_core::arm::lagrange::energy;
use chessarm_core::arm::model::{ArmModel, JointVector, Payload};
use chessarm_core::arm::preset::report_arm;
use chessarm_core::control::computed_torque::ComputedTorque;
use chessarm_core::control::gains::{Gains, REPORT_PD, normalised_error_response};
use chessarm_core::control::{JointState, Reference};
use chessarm_core::nalgebra::Vector3;
use chessarm_core::plan::path::CartesianPath;
use chessarm_core::plan::trajectory::JointTrajectory;
use chessarm_core::sim::{NoObserver, PayloadEvent, Plant, SimConfig, SimError, StepRecord, simulate};
use common::{Hold, Prefix, q, steady_error_prediction};

/// Holds `target` for `duration` s from `start` (default: at rest on the target), recording
/// nothing.
fn hold(
    plant: &mut Plant<4>,
    controller: &mut ComputedTorque<4>,
    target: JointVector<4>,
    duration: f64,
    start: Option<JointState<4>>,
    config: &SimConfig<4>,
) -> Result<chessarm_core::sim::SimSummary<4>, SimError> {
    let start = start.or(Some(JointState::at_rest(target)));
    simulate(plant, controller, &Hold { q: target, duration }, start, &[], &[], config, &mut NoObserver)
}

#[test]
fn energy_is_conserved_in_free_motion() {
    use chessarm_core::sim::Integrator;
    // No torque, no friction: the arm falls and swings. A fourth-order method at 0.1 ms has
    // local error ~(ω dt)⁵ with ω ≲ 20 rad/s, i.e. ~3e-11 per step, ~1e-6 J over 2 s at worst.
    for integrator in [Integrator::RungeKutta4, Integrator::RungeKuttaNystrom4] {
        let mut plant = Plant::new(report_arm());
        let mut state = JointState { q: q([0.2, 1.2, -0.5, -0.3]), qd: q([1.0, -0.5, 2.0, 1.5]) };
        let (kinetic, potential) = energy(plant.model(), &state.q, &state.qd);
        let initial = kinetic + potential;
        let dt = 1e-4;
        let mut largest_kinetic = kinetic;
        let mut worst_drift = 0.0f64;
        for _ in 0..20_000 {
            state = plant.step(&state, &JointVector::zeros(), dt, integrator).unwrap();
            let (kinetic, potential) = energy(plant.model(), &state.q, &state.qd);
            largest_kinetic = largest_kinetic.max(kinetic);
            worst_drift = worst_drift.max((kinetic + potential - initial).abs());
        }
        // Relative to the largest kinetic energy reached (the energy actually exchanged), not
        // to the potential energy's arbitrary zero.
        let name = integrator.name();
        assert!(largest_kinetic > 1.0, "{name}: the arm barely moved: {largest_kinetic} J");
        assert!(worst_drift / largest_kinetic < 1e-6, "{name}: drift {worst_drift} J of {largest_kinetic} J");
    }
}

fn pd_controller(model: ArmModel<4>) -> ComputedTorque<4> {
    ComputedTorque::new("pd", model, Gains::uniform(REPORT_PD.0, REPORT_PD.1, 0.0).unwrap())
}

fn report_move() -> CartesianPath {
    let mut path = CartesianPath::new(Vector3::new(0.21, 0.0, 0.0));
    path.move_to(Vector3::new(0.21, 0.0, 0.15), 1.0).unwrap();
    path.move_to(Vector3::new(-0.03, 0.18, 0.15), 3.0).unwrap();
    path
}

#[test]
fn pd_error_follows_the_closed_form_when_the_model_is_exact() {
    let model = report_arm();
    let dt = 1e-4;
    let trajectory = JointTrajectory::from_path(&model, &report_move(), dt).unwrap();
    let mut plant = Plant::new(model);
    let mut controller = pd_controller(model);
    let initial_error = q([0.02, -0.03, 0.04, 0.01]);
    let start = JointState::at_rest(trajectory.first().q - initial_error);
    let config = SimConfig { dt, control_period: dt, ..SimConfig::new(&plant) };
    let mut records: Vec<StepRecord<4>> = Vec::new();
    let reference = Prefix { trajectory: &trajectory, duration: 1.5 };
    let summary =
        simulate(&mut plant, &mut controller, &reference, Some(start), &[], &[], &config, &mut records).unwrap();
    assert_eq!(summary.saturated_samples, 0);
    // ë + 20ė + 400e = 0: ωn = 20 rad/s, ζ = 0.5. The trajectory starts at rest, so ė(0) = 0.
    let (wn, zeta) = (20.0, 0.5);
    let mut worst = 0.0f64;
    for record in &records {
        let expected = initial_error * normalised_error_response(zeta, wn * record.t);
        let error = record.reference.q - record.state.q;
        worst = worst.max((error - expected).amax());
    }
    // The zero-order hold delays the control by dt/2 on average: a phase error ≈ ωn·dt/2 =
    // 1e-3 of the response, so 2e-3 × |e0| = 8e-5 rad bounds it with margin.
    assert!(worst < 2e-3 * initial_error.amax(), "worst deviation {worst} rad");
}

#[test]
fn unknown_payload_leaves_the_predicted_steady_error_and_pid_removes_it() {
    let model = report_arm();
    let loaded = model.with_payload(Some(Payload::point_mass(0.25))).unwrap();
    let target = q([0.8, 0.9, -2.1, -0.37]);
    let mut plant = Plant::new(loaded);
    let config = SimConfig::new(&plant);
    let mut pd = pd_controller(model);
    let summary = hold(&mut plant, &mut pd, target, 10.0, None, &config).unwrap();
    let predicted = steady_error_prediction(&loaded, &model, &target, REPORT_PD.0);
    let measured = target - summary.final_state.q;
    // The unknown payload makes the plant up to ~3× heavier than the controller believes, so
    // the transient decays at ≈ kd/(2·3) ≈ 3 1/s: after 10 s by e⁻³⁰; the fixed point remains.
    assert!(predicted.amax() > 1e-3, "payload too light to test: {predicted}");
    assert!((measured - predicted).amax() < 1e-9, "measured {measured} predicted {predicted}");

    // PID with poles at −20 (triple): the integral drives the error to zero.
    let gains = Gains::pid_from_poles(20.0, 1.0, 1.0).unwrap();
    let mut pid = ComputedTorque::new("pid", model, gains);
    let mut plant = Plant::new(loaded);
    let summary = hold(&mut plant, &mut pid, target, 4.0, None, &config).unwrap();
    let residual = (target - summary.final_state.q).amax();
    assert!(residual < 1e-6 * predicted.amax().max(1.0), "PID left {residual} rad");
}

#[test]
fn a_payload_event_changes_the_plant_and_informed_controllers() {
    let model = report_arm();
    let target = q([0.8, 0.9, -2.1, -0.37]);
    let reference = Hold { q: target, duration: 3.0 };
    let grip = |knows| [PayloadEvent::new(0.5, Some(Payload::point_mass(0.25)), knows)];
    let run = |events: &[PayloadEvent]| {
        let mut plant = Plant::new(model);
        let config = SimConfig::new(&plant);
        let mut pd = pd_controller(model);
        let start = Some(JointState::at_rest(target));
        simulate(&mut plant, &mut pd, &reference, start, events, &[0.0, 3.0], &config, &mut NoObserver).unwrap()
    };
    let unknown = run(&grip(false));
    let known = run(&grip(true));
    assert!((target - unknown.final_state.q).amax() > 1e-3);
    assert!((target - known.final_state.q).amax() < 1e-9);
    assert!(unknown.tip_error_at_marks[1] > 1e-4 && unknown.tip_error_at_marks[0] < 1e-12);
}

#[test]
fn divergence_is_an_error_not_garbage() {
    let model = report_arm();
    let target = q([0.8, 0.9, -2.1, -0.37]);
    let mut plant = Plant::new(model);
    // kp = 1e7 with a 1 kHz hold: the sampled loop is unstable.
    let mut controller = ComputedTorque::new("wild", model, Gains::uniform(1e7, 0.0, 0.0).unwrap());
    let config = SimConfig { torque_limits: JointVector::repeat(1e9), ..SimConfig::new(&plant) };
    let start = Some(JointState::at_rest(target + q([0.0, 0.01, 0.0, 0.0])));
    let error = hold(&mut plant, &mut controller, target, 2.0, start, &config).unwrap_err();
    assert!(matches!(error, SimError::Diverged { .. }), "{error:?}");
    assert!(error.to_string().contains("diverged"));
}

#[test]
fn a_non_finite_initial_state_is_a_settings_error_naming_the_joint() {
    let model = report_arm();
    let target = q([0.8, 0.9, -2.1, -0.37]);
    let config = SimConfig::new(&Plant::new(model));
    for (start, expected) in [
        (JointState::at_rest(q([0.8, f64::NAN, -2.1, -0.37])), "initial joint 2 angle = NaN"),
        (JointState { q: target, qd: q([0.0, 0.0, f64::INFINITY, 0.0]) }, "initial joint 3 rate = inf"),
    ] {
        let error =
            hold(&mut Plant::new(model), &mut pd_controller(model), target, 0.1, Some(start), &config).unwrap_err();
        assert!(matches!(error, SimError::Config(_)), "{error:?}");
        assert!(error.to_string().contains(expected), "{error}");
    }
}

#[test]
fn torque_limits_saturate_and_are_counted() {
    let model = report_arm();
    let target = q([0.8, 0.9, -2.1, -0.37]);
    let mut plant = Plant::new(model);
    let mut controller = pd_controller(model);
    let limits = q([10.0, 2.0, 15.0, 5.0]); // the shoulder needs ≈ 2.8 N·m just to hold
    let config = SimConfig { torque_limits: limits, ..SimConfig::new(&plant) };
    let summary = hold(&mut plant, &mut controller, target, 0.5, None, &config).unwrap();
    assert!(summary.saturated_per_joint[1] > 400, "{:?}", summary.saturated_per_joint);
    assert_eq!(summary.saturated_per_joint[0], 0);
    assert!((summary.peak_torque[1] - 2.0).abs() < 1e-12);
    assert!(summary.max_joint_error[1] > 0.01, "the arm should sag when the shoulder saturates");

    let bad = SimConfig { control_period: 1.5e-3, ..SimConfig::new(&plant) };
    let error = hold(&mut plant, &mut controller, target, 0.5, None, &bad).unwrap_err();
    assert!(error.to_string().contains("whole multiple"), "{error}");
}

#[test]
fn marks_between_steps_are_recorded_once() {
    let model = report_arm();
    let target = q([0.8, 0.9, -2.1, -0.37]);
    let mut plant = Plant::new(model);
    let mut controller = pd_controller(model);
    let config = SimConfig::new(&plant);
    // Half-way between steps, where the rounding of the time decides, and on steps.
    let marks: Vec<f64> = (0..299).map(|k| (k as f64 + 0.5) * 1e-3).chain([0.2325, 0.0, 0.3]).collect();
    let reference = Hold { q: target, duration: 0.3 };
    // Start 0.01 rad off so that the tip moves and every step's tip differs.
    let start = Some(JointState::at_rest(target + q([0.0, 0.01, 0.0, 0.0])));
    let mut records: Vec<StepRecord<4>> = Vec::new();
    let summary = simulate(&mut plant, &mut controller, &reference, start, &[], &marks, &config, &mut records).unwrap();
    for (mark, tip) in marks.iter().zip(&summary.tip_at_marks) {
        let nearest = &records[(mark / config.dt).round() as usize];
        assert_eq!(*tip, nearest.tip, "mark {mark} s was not taken at its nearest step");
    }
    assert!(summary.tip_error_at_marks.iter().all(|e| e.is_finite()));
}

#[test]
fn closed_loop_poles_are_the_roots_of_the_characteristic_polynomial() {
    use chessarm_core::nalgebra::Complex;
    for (kp, kd, ki) in [(400.0, 20.0, 0.0), (100.0, 40.0, 0.0), (100.0, 1e7, 0.0), (600.0, 25.0, 75.0)] {
        let gains = Gains::<4>::uniform(kp, kd, ki).unwrap();
        for pole in gains.closed_loop_poles(0) {
            let value = if ki > 0.0 {
                pole * pole * pole + pole * pole * kd + pole * kp + Complex::new(ki, 0.0)
            } else {
                pole * pole + pole * kd + Complex::new(kp, 0.0)
            };
            // Relative to the polynomial's largest term at that pole.
            let scale = (pole.norm().powi(2) + kd * pole.norm() + kp + ki).max(1.0);
            assert!(value.norm() / scale < 1e-12, "pole {pole} of {kp},{kd},{ki}: residual {}", value.norm());
            assert!(pole.re < 0.0, "pole {pole} of {kp},{kd},{ki} is not in the left half-plane");
        }
    }
}

/// A controller that hides its model, so the closed loop cannot hand it the plant's terms.
#[derive(Debug)]
struct Opaque(ComputedTorque<4>);

impl chessarm_core::control::Controller<4> for Opaque {
    fn name(&self) -> &str {
        "opaque"
    }
    fn reset(&mut self) {
        self.0.reset();
    }
    fn command(&mut self, state: &JointState<4>, reference: &Reference<4>, period: f64) -> JointVector<4> {
        self.0.command(state, reference, period)
    }
    fn set_payload(&mut self, payload: Option<Payload>) -> Result<(), chessarm_core::arm::model::ModelError> {
        self.0.set_payload(payload)
    }
}

#[test]
fn sharing_the_plants_terms_with_the_controller_changes_nothing() {
    use chessarm_core::control::Controller;
    // Known and unknown payloads: the models agree before the grip, then agree (known) or
    // differ (unknown) until the release, so the loop switches between shared and own terms.
    let model = report_arm();
    let dt = 1e-3;
    let trajectory = JointTrajectory::from_path(&model, &report_move(), dt).unwrap();
    let pawn = Some(Payload::upright_cylinder(0.25, 0.05, 0.012, 0.04));
    for knows in [true, false] {
        let events = [PayloadEvent::new(1.2, pawn, knows), PayloadEvent::new(3.1, None, knows)];
        let run = |controller: &mut dyn Controller<4>| {
            let mut plant = Plant::new(model);
            let config = SimConfig::new(&plant);
            let mut records: Vec<StepRecord<4>> = Vec::new();
            let start = Some(JointState::at_rest(trajectory.first().q + q([0.01, -0.02, 0.0, 0.01])));
            simulate(&mut plant, controller, &trajectory, start, &events, &[1.2, 3.1], &config, &mut records).unwrap();
            records
        };
        let shared = run(&mut pd_controller(model));
        let own = run(&mut Opaque(pd_controller(model)));
        assert_eq!(shared.len(), own.len());
        // Bit for bit: the terms handed over are the very numbers the controller would compute.
        for (a, b) in shared.iter().zip(&own) {
            assert_eq!(a, b, "t = {} s, payload known: {knows}", a.t);
        }
    }
}

/// Largest |state − reference state| after `duration` s of free motion (no torque) from a
/// moving start, integrated with `integrator` at `dt`.
fn free_motion_error(integrator: chessarm_core::sim::Integrator, dt: f64, reference: &JointState<4>) -> f64 {
    let mut plant = Plant::new(report_arm());
    let mut state = JointState { q: q([0.2, 1.2, -0.5, -0.3]), qd: q([1.0, -0.5, 2.0, 1.5]) };
    let torque = gravity_torques(plant.model(), &state.q) * 0.5; // half the arm's weight held
    for _ in 0..(0.2 / dt).round() as usize {
        state = plant.step(&state, &torque, dt, integrator).unwrap();
    }
    (state.q - reference.q).amax().max((state.qd - reference.qd).amax())
}

#[test]
fn integrators_converge_at_their_orders() {
    use chessarm_core::sim::Integrator;
    // Reference: RK4 at 10 µs, whose own error (~(dt/1 ms)⁴ × the 1 ms error) is below 1e-13.
    let mut plant = Plant::new(report_arm());
    let mut reference = JointState { q: q([0.2, 1.2, -0.5, -0.3]), qd: q([1.0, -0.5, 2.0, 1.5]) };
    let torque = gravity_torques(plant.model(), &reference.q) * 0.5;
    for _ in 0..20_000 {
        reference = plant.rk4_step(&reference, &torque, 1e-5).unwrap();
    }
    // Halving dt divides the global error by 2^order; over one halving the ratio of a method
    // of order p lies within a factor 1.3 of 2^p once dt is in the asymptotic range.
    for (integrator, order, dt) in [
        (Integrator::RungeKutta4, 4, 4e-3),
        (Integrator::RungeKuttaNystrom4, 4, 4e-3),
        (Integrator::Midpoint, 2, 1e-3),
        (Integrator::SemiImplicitEuler, 1, 1e-3),
    ] {
        let coarse = free_motion_error(integrator, dt, &reference);
        let fine = free_motion_error(integrator, dt / 2.0, &reference);
        let ratio = coarse / fine;
        let expected = f64::from(1 << order);
        assert!(
            ratio > expected / 1.3 && ratio < expected * 1.3,
            "{}: error {coarse:e} at {dt} s, {fine:e} at {} s, ratio {ratio} (expected {expected})",
            integrator.name(),
            dt / 2.0
        );
    }
}

#[test]
fn a_plant_step_does_not_depend_on_what_its_scratch_held_before() {
    use chessarm_core::sim::Integrator;
    let state = JointState { q: q([0.4, 1.1, -0.9, -0.2]), qd: q([0.5, -0.3, 0.8, 0.2]) };
    let torque = q([0.3, 4.0, 1.5, 0.2]);
    let pawn = Some(Payload::point_mass(0.25));
    for integrator in Integrator::ALL {
        let fresh = |payload| {
            let mut plant = Plant::new(report_arm());
            plant.set_payload(payload).unwrap();
            plant.step(&state, &torque, 1e-3, integrator).unwrap()
        };
        let (unloaded, loaded) = (fresh(None), fresh(pawn));
        assert_ne!(unloaded, loaded, "{}: the pawn must change the step", integrator.name());
        // The scratch evaluated at this very state, then the payload changes: the step must
        // use the new model, not the kept evaluation.
        let mut plant = Plant::new(report_arm());
        plant.evaluate(&state).unwrap();
        plant.set_payload(pawn).unwrap();
        assert_eq!(plant.step(&state, &torque, 1e-3, integrator).unwrap(), loaded, "{}", integrator.name());
        // Evaluated at another state: re-evaluated at the step's own.
        plant.evaluate(&JointState::at_rest(q([0.0; 4]))).unwrap();
        assert_eq!(plant.step(&state, &torque, 1e-3, integrator).unwrap(), loaded, "{}", integrator.name());
        // Evaluated at this state, then a step from another: that step is its own.
        let other = JointState { q: state.q * 0.5, qd: -state.qd };
        let mut fresh_plant = Plant::new(report_arm());
        fresh_plant.set_payload(pawn).unwrap();
        let from_other = fresh_plant.step(&other, &torque, 1e-3, integrator).unwrap();
        plant.evaluate(&state).unwrap();
        assert_eq!(plant.step(&other, &torque, 1e-3, integrator).unwrap(), from_other, "{}", integrator.name());
    }
}

/// The tracking metrics from `tracking_from` on are the RMS and largest errors of exactly the
/// recorded steps from that instant: checked against the records of the same run.
#[test]
fn tracking_metrics_start_where_the_config_says() {
    let model = report_arm();
    let target = q([0.3, 0.8, -1.2, 0.4]);
    // Start 0.2 rad off on every joint, so the early steps hold the largest errors.
    let start = JointState::at_rest(target - JointVector::repeat(0.2));
    for tracking_from in [0.0, 0.25, 0.5004, 1.0] {
        let mut plant = Plant::new(model);
        let mut controller = pd_controller(model);
        let config = SimConfig { tracking_from, ..SimConfig::new(&plant) };
        let mut records: Vec<StepRecord<4>> = Vec::new();
        let summary = simulate(
            &mut plant,
            &mut controller,
            &Hold { q: target, duration: 1.0 },
            Some(start),
            &[],
            &[],
            &config,
            &mut records,
        )
        .unwrap();
        // Steps are at k·dt; the first tracked one is the nearest to tracking_from.
        let first = (tracking_from / config.dt).round() as usize;
        let tracked = &records[first..];
        assert_eq!(summary.tracked_steps, tracked.len());
        let tip_errors: Vec<f64> = tracked.iter().map(|r| (r.tip - r.tip_desired).norm()).collect();
        let max_tip = tip_errors.iter().copied().fold(0.0, f64::max);
        let rms_tip = (tip_errors.iter().map(|e| e * e).sum::<f64>() / tip_errors.len() as f64).sqrt();
        assert_eq!(summary.max_tip_error, max_tip);
        assert!((summary.rms_tip_error - rms_tip).abs() <= 1e-15 * rms_tip.max(1e-300), "{tracking_from}");
        let max_joint_1 = tracked.iter().map(|r| (r.reference.q[0] - r.state.q[0]).abs()).fold(0.0, f64::max);
        assert_eq!(summary.max_joint_error[0], max_joint_1);
        if tracking_from == 0.0 {
            assert!((summary.max_joint_error[0] - 0.2).abs() < 1e-12, "the start is counted");
        } else {
            assert!(summary.max_joint_error[0] < 0.2, "the start is left out");
        }
    }
    let plant = Plant::new(model);
    let bad = SimConfig { tracking_from: f64::NAN, ..SimConfig::new(&plant) };
    let mut controller = pd_controller(model);
    let error = hold(&mut Plant::new(model), &mut controller, target, 0.1, None, &bad).unwrap_err();
    assert!(error.to_string().contains("tracking metrics"), "{error}");
}

#[test]
fn the_tracking_budgets_compliance_is_the_closed_loops_steady_tip_error_per_unit_force() {
    // A computed-torque PD loop holding still with 5 g more at the tip than its model knows:
    // the tip settles Δm W (−g) off (TrackingBudget::compliance, W = J Kp⁻¹ M⁻¹ Jᵀ, the same
    // matrix the planner bounds Δm W p̈ with), to first order in Δm.
    use chessarm_core::arm::kinematics::FrameChain;
    use chessarm_core::plan::constraints::TrackingBudget;
    let model = report_arm();
    let extra = 0.005;
    let loaded = model.with_payload(Some(Payload::point_mass(extra))).unwrap();
    let target = q([0.8, 0.9, -2.1, -0.37]);
    let mut plant = Plant::new(loaded);
    let config = SimConfig::new(&plant);
    let mut pd = pd_controller(model);
    let summary = hold(&mut plant, &mut pd, target, 10.0, None, &config).unwrap();
    let tip = |q: &JointVector<4>| FrameChain::new(&model, q).tip();
    let measured = tip(&target) - tip(&summary.final_state.q);
    let budget = TrackingBudget {
        model,
        kp: [REPORT_PD.0; 4],
        overshoot: 1.0,
        mass_error: extra,
        budget: 1e-3,
        stiffness: None,
    };
    let predicted = budget.compliance(&target) * (-model.gravity()) * extra;
    assert!(predicted.norm() > 1e-4, "too small to test: {predicted}");
    // First order in Δm: the neglected terms are O(e) relative, e ≈ 3 mrad here; 1 % is
    // three times that, and a wrong W (another Kp, M without its inverse, J instead of Jᵀ)
    // is off by far more.
    assert!((measured - predicted).norm() < 0.01 * predicted.norm(), "measured {measured}, predicted {predicted}");
    // Symmetric (uniform gains) and positive definite, and scaled by 1/kp.
    let w = budget.compliance(&target);
    assert!((w - w.transpose()).amax() < 1e-12 * w.amax());
    assert!(w.symmetric_eigenvalues().min() > 0.0);
    let stiffer = TrackingBudget { kp: [4.0 * REPORT_PD.0; 4], ..budget };
    assert!((stiffer.compliance(&target) * 4.0 - w).amax() < 1e-12 * w.amax());
    // The overshoot of a step: 1 from critical damping on, 1 + e^{−πζ/√(1−ζ²)} below.
    assert_eq!(TrackingBudget::<4>::overshoot_of(1.0), 1.0);
    assert!(
        (TrackingBudget::<4>::overshoot_of(0.5) - (1.0 + (-std::f64::consts::PI * 0.5 / 0.75f64.sqrt()).exp())).abs()
            < 1e-15
    );
    assert_eq!(TrackingBudget::<4>::overshoot_of(0.0), 2.0);
}
