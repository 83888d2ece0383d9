//! The payload regressor against the inverse dynamics, and the controllers beyond plain
//! computed torque: PID anti-windup, adaptive computed torque, disturbance observer.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

mod common;

use chessarm_core::arm::dynamics::{DynamicsTerms, gravity_torques, inverse_dynamics};
use chessarm_core::arm::link::Inertial;
use chessarm_core::arm::model::{ArmModel, JointVector, Payload};
use chessarm_core::arm::payload::{payload_regressor, payload_terms};
use chessarm_core::arm::preset::report_arm;
use chessarm_core::control::adaptive::{AdaptiveComputedTorque, AdaptiveSettings};
use chessarm_core::control::computed_torque::{AntiWindup, ComputedTorque, DEFAULT_ERROR_BAND};
use chessarm_core::control::disturbance_observer::DisturbanceObserver;
use chessarm_core::control::gains::{GainError, Gains, REPORT_PD, REPORT_PID};
use chessarm_core::control::{Controller, JointState, Reference};
use chessarm_core::nalgebra::{Vector2, Vector3};
use chessarm_core::sense::rng::SeededRng;
use chessarm_core::sim::{NoObserver, PayloadEvent, Plant, SimConfig, SimSummary, StepRecord, simulate};
use common::{Hold, q, steady_error_prediction};

/// A point mass `mass` kg `offset` m along the tool x axis.
fn point(mass: f64, offset: f64) -> Payload {
    Payload { inertial: Inertial::point(mass, Vector3::new(offset, 0.0, 0.0)) }
}

fn random_vector(rng: &mut SeededRng, half_width: f64) -> JointVector<4> {
    JointVector::from_fn(|_, _| rng.uniform(-half_width, half_width))
}

#[test]
fn payload_regressor_is_the_inverse_dynamics_of_the_payload() {
    let model = report_arm();
    let mut rng = SeededRng::new(7);
    let mut largest_remainder = 0.0f64;
    for _ in 0..500 {
        let (qv, qd, qdd) = (random_vector(&mut rng, 2.5), random_vector(&mut rng, 3.0), random_vector(&mut rng, 20.0));
        let (mass, offset) = (rng.uniform(0.0, 0.5), rng.uniform(-0.1, 0.1));
        let theta = Vector2::new(mass, mass * offset);
        let payload_torque = inverse_dynamics(&model.with_payload(Some(point(mass, offset))).unwrap(), &qv, &qd, &qdd)
            - inverse_dynamics(&model, &qv, &qd, &qdd);
        let terms = payload_terms(&model, &qv, &qd, &qdd);
        let linear = terms.regressor * theta;
        let remainder = terms.quadratic * (mass * offset * offset);
        // Two RNEAs of torques up to ~30 N·m (accelerations of 20 rad/s²) differ in rounding
        // by ~1e-14 N·m; 1e-11 N·m leaves a wide margin and is still far below any payload
        // term checked (they reach 1e-1 N·m).
        let rounding = 1e-11;
        assert!(
            (payload_torque - linear - remainder).amax() < rounding,
            "q {qv} qd {qd} qdd {qdd} m {mass} c {offset}: {} vs {}",
            payload_torque,
            linear + remainder
        );
        // Y θ alone is the payload's torque up to the m c² term, as computed.
        assert!((payload_torque - linear).amax() <= remainder.amax() + rounding);
        assert_eq!(payload_regressor(&model, &qv, &qd, &qdd), terms.regressor);
        assert_eq!(terms.torque(mass, offset), linear + remainder);
        largest_remainder = largest_remainder.max(remainder.amax());
        // By linearity the central difference in the offset cancels the m c² term exactly:
        // (τ_p(c) − τ_p(−c)) / 2 = m c Y_·2.
        let mirrored = inverse_dynamics(&model.with_payload(Some(point(mass, -offset))).unwrap(), &qv, &qd, &qdd);
        let loaded = inverse_dynamics(&model.with_payload(Some(point(mass, offset))).unwrap(), &qv, &qd, &qdd);
        let odd = (loaded - mirrored) * 0.5;
        assert!((odd - terms.regressor.column(1) * (mass * offset)).amax() < rounding);
    }
    // The remainder is not trivially zero on these states (it is what the comparison allows).
    assert!(largest_remainder > 1e-4, "m c² term never exercised: {largest_remainder}");
}

#[test]
fn at_rest_the_payload_torque_is_its_weight_and_a_tool_down_offset_moves_nothing() {
    let model = report_arm();
    let zero = JointVector::<4>::zeros();
    // Tool pointing down: q2 + q3 + q4 = −π/2.
    let down = q([0.3, 0.9, -1.7, -std::f64::consts::FRAC_PI_2 + 0.8]);
    let terms = payload_terms(&model, &down, &zero, &zero);
    assert_eq!(terms.quadratic, zero, "no motion, no m c² term");
    // The offset along a vertical tool changes no lever arm: exactly zero up to rounding.
    assert!(terms.regressor.column(1).amax() < 1e-12, "{}", terms.regressor);
    // The mass column is the weight's torque per kg.
    let weight = gravity_torques(&model.with_payload(Some(Payload::point_mass(1.0))).unwrap(), &down)
        - gravity_torques(&model, &down);
    assert!((terms.regressor.column(0) - weight).amax() < 1e-12);
    assert!(weight.amax() > 1.0, "a 1 kg weight at the tip must load the shoulder: {weight}");
}

/// Holds `target` for `duration` s from rest on it; the plant is `plant_model`, whose payload
/// (if any) the controller is not told.
fn hold(
    plant_model: ArmModel<4>,
    controller: &mut dyn Controller<4>,
    target: JointVector<4>,
    duration: f64,
    events: &[PayloadEvent],
    config: Option<SimConfig<4>>,
) -> SimSummary<4> {
    let mut plant = Plant::new(plant_model);
    let config = config.unwrap_or_else(|| SimConfig::new(&plant));
    let start = Some(JointState::at_rest(target));
    let reference = Hold { q: target, duration };
    simulate(&mut plant, controller, &reference, start, events, &[], &config, &mut NoObserver).unwrap()
}

fn report_pd(model: ArmModel<4>) -> ComputedTorque<4> {
    ComputedTorque::new("pd", model, Gains::uniform(REPORT_PD.0, REPORT_PD.1, 0.0).unwrap())
}

fn report_pid() -> Gains<4> {
    Gains::uniform(REPORT_PID.0, REPORT_PID.1, REPORT_PID.2).unwrap()
}

const HOLD_TARGET: [f64; 4] = [0.8, 0.9, -2.1, -0.37];

#[test]
fn anti_windup_settings_are_checked() {
    let pid = || ComputedTorque::new("pid", report_arm(), report_pid());
    for bad in [
        AntiWindup::Clamp { error_band: 0.0 },
        AntiWindup::Clamp { error_band: -0.1 },
        AntiWindup::Clamp { error_band: f64::NAN },
    ] {
        let error = pid().with_anti_windup(bad).unwrap_err();
        assert!(matches!(error, GainError::Invalid { .. }), "{bad:?}: {error:?}");
    }
    let clamping = AntiWindup::Clamp { error_band: f64::INFINITY };
    assert_eq!(pid().with_anti_windup(clamping).unwrap().anti_windup(), clamping);
    assert_eq!(ComputedTorque::new("pid", report_arm(), report_pid()).anti_windup(), AntiWindup::None);
    let default = ComputedTorque::pid(report_arm(), report_pid());
    assert_eq!((default.name(), default.anti_windup()), ("pid", AntiWindup::default()));
}

#[test]
fn under_saturation_clamping_freezes_the_integral() {
    let model = report_arm();
    let target = q(HOLD_TARGET);
    // The shoulder's limit is below the 2.8 N·m its weight needs: it saturates throughout and
    // the arm sags, whatever the integral does.
    let limits = q([10.0, 2.5, 15.0, 5.0]);
    let weak = {
        let mut links = *model.links();
        for (link, limit) in links.iter_mut().zip(limits.iter()) {
            link.limits.torque = *limit;
        }
        model.with_links(links).unwrap()
    };
    let run = |anti_windup: AntiWindup, duration: f64| {
        let mut controller = ComputedTorque::new("pid", weak, report_pid()).with_anti_windup(anti_windup).unwrap();
        let summary = hold(weak, &mut controller, target, duration, &[], None);
        assert!(summary.saturated_per_joint[1] as f64 > 0.99 * duration * 1e3, "{:?}", summary.saturated_per_joint);
        controller.integral()[1]
    };
    let plain = (run(AntiWindup::None, 0.3), run(AntiWindup::None, 0.6));
    let clamped = run(AntiWindup::Clamp { error_band: f64::INFINITY }, 0.6);
    println!("shoulder ∫e after 0.3 / 0.6 s: plain {plain:?}, clamped {clamped}");
    // Plain: the sagging shoulder's error integrates on and on.
    assert!(plain.1 > 1.5 * plain.0 && plain.0 > 0.0, "{plain:?}");
    // Clamped: the command exceeds the limit at every sample with the error pushing the same
    // way, so nothing is ever integrated (the first sample has zero error).
    assert_eq!(clamped, 0.0);
    assert_eq!(run(AntiWindup::default(), 0.6), 0.0, "the default clamps on saturation too");
}

#[test]
fn anti_windup_pid_removes_an_unknown_payloads_steady_error_as_plain_pid_does() {
    let model = report_arm();
    let loaded = model.with_payload(Some(Payload::point_mass(0.25))).unwrap();
    let target = q(HOLD_TARGET);
    let predicted = steady_error_prediction(&loaded, &model, &target, REPORT_PD.0);
    assert!(predicted.amax() > DEFAULT_ERROR_BAND, "PD's error should exceed the band: {predicted}");
    let mut plain = ComputedTorque::new("pid", model, report_pid());
    let mut protected = ComputedTorque::pid(model, report_pid());
    let plain_summary = hold(loaded, &mut plain, target, 100.0, &[], None);
    let summary = hold(loaded, &mut protected, target, 100.0, &[], None);
    // The PID's error leaves the band (the integrand is clipped: the protection engages)...
    assert!(summary.max_joint_error.amax() > DEFAULT_ERROR_BAND, "{}", summary.max_joint_error);
    // ...and the error is removed all the same. The integral must reach ≈ 0.29 rad·s
    // (M̂⁻¹Δg / ki), at most 0.02 rad·s per second while clipped: ≈ 15 s; the rest decays
    // through the slow pole ≈ −ki/kp = −0.125 1/s, by e^{−10} over the remaining 85 s. A
    // thousandth of PD's error is a loose bound that no PID without working integral meets.
    for (name, summary) in [("plain", &plain_summary), ("anti-windup", &summary)] {
        let residual = (target - summary.final_state.q).amax();
        println!("{name} PID after 100 s: {residual:.3e} rad of PD's {:.3e} rad", predicted.amax());
        assert!(residual < 1e-3 * predicted.amax(), "{name} PID left {residual} rad of PD's {}", predicted.amax());
    }
}

#[test]
fn observer_removes_the_steady_error_pd_leaves() {
    let model = report_arm();
    let target = q(HOLD_TARGET);
    // Two unknown constant disturbances: a gripped 0.25 kg the controller is not told of,
    // and link masses 20 % above the controller's.
    let heavier = {
        let mut links = *model.links();
        for link in &mut links {
            link.inertial.mass *= 1.2;
        }
        model.with_links(links).unwrap()
    };
    let gripped = [PayloadEvent::new(0.0, Some(Payload::point_mass(0.25)), false)];
    let loaded = model.with_payload(Some(Payload::point_mass(0.25))).unwrap();
    for (name, plant_model, events, effective) in
        [("unknown payload", model, &gripped[..], loaded), ("heavier links", heavier, &[][..], heavier)]
    {
        let predicted = steady_error_prediction(&effective, &model, &target, REPORT_PD.0);
        let pd = hold(plant_model, &mut report_pd(model), target, 10.0, events, None);
        let pd_error = target - pd.final_state.q;
        // The plant is up to ~3× heavier than the controller believes: PD's transient decays
        // at ≈ kd/(2·3) ≈ 3 1/s, by e⁻³⁰ after 10 s; the fixed point remains.
        assert!(predicted.amax() > 1e-3, "{name}: disturbance too small to test: {predicted}");
        assert!((pd_error - predicted).amax() < 1e-9, "{name}: PD {pd_error} predicted {predicted}");
        let mut dob = DisturbanceObserver::new(model);
        let observed = hold(plant_model, &mut dob, target, 10.0, events, None);
        let dob_error = (target - observed.final_state.q).amax();
        println!("{name}: steady error PD {:.3e} rad, DOB {dob_error:.3e} rad", pd_error.amax());
        // The Q-filter's unit DC gain leaves no steady error at all (at rest q̈ = 0 forces
        // d̂ = −u, so v = 0 and e = 0); what remains after 10 s is the transient, whose slowest
        // rate is the outer loop's kd/2 = 10 1/s once the observer has taken the mismatch
        // (e⁻¹⁰⁰), so only rounding is left: 1e-6 of PD's error is a loose bound.
        assert!(dob_error < 1e-6 * pd_error.amax(), "{name}: DOB left {dob_error} rad");
        // The observer carries the disturbance (at rest d̂ = −u = M̂⁻¹(ĝ − g) ≠ 0).
        assert!(dob.disturbance_estimate().amax() > 0.1, "{name}: d̂ = {}", dob.disturbance_estimate());
    }
}

#[test]
fn adaptive_controller_identifies_a_point_mass_and_its_offset_holding_still() {
    let model = report_arm();
    // The tool tilted (q2 + q3 + q4 = −0.6 rad, not −π/2): the offset moves the lever arm of
    // the weight, so holding still excites both parameters.
    let target = q([0.3, 0.8, -1.2, -0.2]);
    let (mass, offset) = (0.2, 0.04);
    let events = [PayloadEvent::new(0.0, Some(point(mass, offset)), false)];
    let mut plant = Plant::new(model);
    let config = SimConfig::new(&plant);
    let mut adaptive = AdaptiveComputedTorque::new(model);
    let mut records: Vec<StepRecord<4>> = Vec::new();
    let reference = Hold { q: target, duration: 2.0 };
    let start = Some(JointState::at_rest(target));
    let summary = simulate(&mut plant, &mut adaptive, &reference, start, &events, &[], &config, &mut records).unwrap();
    let (estimated_mass, estimated_offset) = adaptive.payload_estimate();
    // What the estimator's linear model leaves out is the m c² w term (the midpoint rule's
    // error is below 1e-6 N·m); least squares over all samples since the grip averages it,
    // so its size relative to the modelled torque Y θ, summed over the run, sets the
    // estimate's relative error. Ten times that allows for the correlation of the two columns.
    let theta = Vector2::new(mass, mass * offset);
    let (mut left_out, mut modelled) = (0.0, 0.0);
    for pair in records.windows(2) {
        let qv = (pair[0].state.q + pair[1].state.q) * 0.5;
        let qd = (pair[0].state.qd + pair[1].state.qd) * 0.5;
        let qdd = (pair[1].state.qd - pair[0].state.qd) / config.dt;
        let terms = payload_terms(&model, &qv, &qd, &qdd);
        left_out += (terms.quadratic * (mass * offset * offset)).amax();
        modelled += (terms.regressor * theta).amax();
    }
    let relative = left_out / modelled;
    println!(
        "point mass {mass} kg at {offset} m: estimated {estimated_mass} kg at {estimated_offset} m; left out {relative:.1e}"
    );
    assert!(relative < 1e-3, "the test needs a small left-out term: {relative}");
    assert!((estimated_mass - mass).abs() < 10.0 * relative * mass, "{estimated_mass} kg");
    assert!((estimated_offset - offset).abs() < 10.0 * relative * offset, "{estimated_offset} m");
    // With the payload compensated the arm holds the target; PD alone sags by mrad.
    let pd = hold(model, &mut report_pd(model), target, 2.0, &events, None);
    let pd_error = (target - pd.final_state.q).amax();
    assert!(pd_error > 1e-3, "PD should sag: {pd_error} rad");
    assert!((target - summary.final_state.q).amax() < 1e-3 * pd_error);
}

#[test]
fn adaptive_settings_and_gains_are_checked() {
    let adaptive = || AdaptiveComputedTorque::new(report_arm());
    assert_eq!(adaptive().gains().kp, JointVector::<4>::repeat(REPORT_PD.0));
    assert_eq!(adaptive().gains().kd, JointVector::<4>::repeat(REPORT_PD.1));
    assert!(adaptive().with_gains(report_pid()).is_err(), "the outer loop is PD");
    assert!(DisturbanceObserver::new(report_arm()).with_gains(report_pid()).is_err(), "the outer loop is PD");
    assert!(DisturbanceObserver::new(report_arm()).with_bandwidth(0.0).is_err());
    let defaults = AdaptiveSettings::default();
    for bad in [
        AdaptiveSettings { bandwidth: 0.0, ..defaults },
        AdaptiveSettings { residual_std: -1.0, ..defaults },
        AdaptiveSettings { prior_std: Vector2::new(0.5, f64::NAN), ..defaults },
        AdaptiveSettings { prior: Vector2::new(f64::INFINITY, 0.0), ..defaults },
    ] {
        assert!(adaptive().with_settings(bad).is_err(), "{bad:?}");
    }
    assert_eq!(adaptive().with_settings(defaults).unwrap().settings(), &defaults);
}

/// A few states and references near the hold target, with a moving reference.
fn samples() -> Vec<(JointState<4>, Reference<4>)> {
    let mut rng = SeededRng::new(11);
    (0..40)
        .map(|k| {
            let target = q(HOLD_TARGET) + random_vector(&mut rng, 0.01);
            let state =
                JointState { q: q(HOLD_TARGET) + random_vector(&mut rng, 0.02), qd: random_vector(&mut rng, 0.3) };
            let reference =
                Reference { q: target, qd: random_vector(&mut rng, 0.2), qdd: random_vector(&mut rng, 1.0) };
            // A saturating command now and then (a large error).
            if k % 13 == 5 {
                (JointState { q: state.q + q([0.0, 0.5, -0.5, 0.0]), ..state }, reference)
            } else {
                (state, reference)
            }
        })
        .collect()
}

#[test]
fn every_controller_computes_the_same_torque_with_the_terms_handed_over() {
    let model = report_arm();
    let period = 1e-3;
    let controllers: Vec<Box<dyn Fn() -> Box<dyn Controller<4>>>> = vec![
        Box::new(move || Box::new(report_pd(model))),
        Box::new(move || Box::new(ComputedTorque::new("pid", model, report_pid()))),
        Box::new(move || Box::new(ComputedTorque::pid(model, report_pid()))),
        Box::new(move || {
            let clamping = AntiWindup::Clamp { error_band: f64::INFINITY };
            Box::new(ComputedTorque::new("pid", model, report_pid()).with_anti_windup(clamping).unwrap())
        }),
        Box::new(move || Box::new(AdaptiveComputedTorque::new(model))),
        Box::new(move || Box::new(DisturbanceObserver::new(model))),
    ];
    for make in &controllers {
        let (mut own, mut handed) = (make(), make());
        own.reset();
        handed.reset();
        for (k, (state, reference)) in samples().iter().enumerate() {
            if k == 10 {
                own.gripper_changed(true);
                handed.gripper_changed(true);
            }
            let terms = DynamicsTerms::new(&model, &state.q, &state.qd);
            let a = own.command(state, reference, period);
            let b = handed.command_with_terms(state, reference, period, &terms);
            assert_eq!(a, b, "{} at sample {k}", own.name());
            assert_eq!(own.commanded_acceleration(), handed.commanded_acceleration());
        }
    }
}

#[test]
fn commanded_acceleration_is_what_the_model_predicts_for_the_command() {
    let model = report_arm();
    let period = 1e-3;
    // PD, PID and the observer: τ = M̂ u + N̂ with u the commanded acceleration (for the DOB
    // u = v − d̂, so d̂ must have moved off zero for the check to mean anything).
    let mut observer = DisturbanceObserver::new(model);
    let mut pid = ComputedTorque::pid(model, report_pid());
    let mut pd = report_pd(model);
    let controllers: [&mut dyn Controller<4>; 3] = [&mut pd, &mut pid, &mut observer];
    for controller in controllers {
        for (state, reference) in samples() {
            let torque = controller.command(&state, &reference, period);
            let u = controller.commanded_acceleration().unwrap();
            let predicted = inverse_dynamics(&model, &state.q, &state.qd, &u);
            // τ from M̂ u + N̂ against the RNEA's M u + C q̇ + g: rounding of ~10 N·m torques.
            assert!((torque - predicted).amax() < 1e-11, "{}: {torque} vs {predicted}", controller.name());
        }
    }
    assert!(observer.disturbance_estimate().amax() > 1.0, "d̂ = {}", observer.disturbance_estimate());
    // Adaptive: the model with the estimated payload predicts v for the command, up to the
    // m̂ ĉ² term the regressor leaves out.
    let target = q([0.3, 0.8, -1.2, -0.2]);
    let events = [PayloadEvent::new(0.0, Some(point(0.2, 0.04)), false)];
    let mut adaptive = AdaptiveComputedTorque::new(model);
    hold(model, &mut adaptive, target, 0.5, &events, None);
    assert!((adaptive.payload_estimate().0 - 0.2).abs() < 1e-3);
    for (state, reference) in samples() {
        let state = JointState { q: state.q - q(HOLD_TARGET) + target, ..state };
        let reference = Reference { q: reference.q - q(HOLD_TARGET) + target, ..reference };
        // Each call updates the estimate first (from the interval since the hold ended), then
        // commands with it.
        let mut probe = adaptive.clone();
        let torque = probe.command(&state, &reference, period);
        let v = probe.commanded_acceleration().unwrap();
        let (mass, offset) = probe.payload_estimate();
        let estimated = model.with_payload(Some(point(mass, offset))).unwrap();
        let predicted = inverse_dynamics(&estimated, &state.q, &state.qd, &v);
        let left_out = payload_terms(&model, &state.q, &state.qd, &v).quadratic * (mass * offset * offset);
        assert!((torque - predicted + left_out).amax() < 1e-11, "{torque} vs {predicted}");
    }
}
