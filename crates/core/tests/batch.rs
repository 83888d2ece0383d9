//! The batched simulator against the scalar one: every lane's summary equals, bit for bit, what
//! `simulate_sensed` computes for the same run, on random candidates (gains, controllers,
//! payloads, plants, sensors with the Kalman filter, motor lags, torque limits), including
//! lanes that diverge, fail or finish early, at every lane count and every SIMD level this CPU
//! has.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

mod common;

use std::io::Write;

use chessarm_core::arm::link::Friction;

use chessarm_core::arm::model::{ArmModel, JointVector, Payload};
use chessarm_core::arm::preset::report_arm;
use chessarm_core::control::choice::{ControllerKind, ControllerSpec};
use chessarm_core::control::gains::Gains;
use chessarm_core::control::{Controller, JointState, Reference};
use chessarm_core::nalgebra::Vector3;
use chessarm_core::plan::path::CartesianPath;
use chessarm_core::plan::trajectory::JointTrajectory;
use chessarm_core::sense::{Estimator, Feedback, JointKalman, KalmanSettings, SensorProfile, Sensors};
use chessarm_core::sim::batch::{LaneCount, LaneRun, SimdLevel, simulate_lanes, takes_in_lanes};
use chessarm_core::sim::{Integrator, PayloadEvent, ReferenceSource, SimConfig, SimError, SimSummary};
use common::Hold;

/// A short pick-and-place-like move: 1.2 s along a line at the board's height.
fn trajectory() -> JointTrajectory {
    let mut path = CartesianPath::new(Vector3::new(0.25, -0.1, 0.12));
    path.move_to(Vector3::new(0.32, 0.12, 0.05), 0.6).unwrap();
    path.move_to(Vector3::new(0.2, 0.05, 0.1), 0.6).unwrap();
    JointTrajectory::from_path(&report_arm(), &path, 1e-3).unwrap()
}

/// A cheap deterministic generator for the candidates.
struct Draw(u64);

impl Draw {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, low: f64, high: f64) -> f64 {
        low + (high - low) * self.next()
    }
    /// Proportional and derivative gains: one time in about seven far beyond what a 1 kHz
    /// sampled loop can hold, the run diverging within ~0.1 s (`true` says so), else moderate.
    fn pd_gains(&mut self) -> (bool, f64, f64) {
        let diverging = self.next() < 0.15;
        let (kp, kd) = if diverging {
            (self.range(4e6, 8e6), self.range(3e3, 6e3))
        } else {
            (self.range(20.0, 400.0), self.range(2.0, 40.0))
        };
        (diverging, kp, kd)
    }
}

/// Hobby encoders (noise seeded by `seed`) with the Kalman filter at 1 kHz.
fn hobby_kalman(seed: u64) -> Feedback<4> {
    let profile = SensorProfile::<4>::hobby();
    let filter =
        JointKalman::new(1e-3, profile.angle_std(), None, profile.delay_samples, KalmanSettings::DEFAULT).unwrap();
    Feedback::new(Sensors::new(profile, seed).unwrap(), Estimator::Kalman(Box::new(filter))).unwrap()
}

/// The `index`-th random candidate: its plant (perturbed masses, sometimes friction and a
/// heavier payload), controller (kind, gains, sometimes huge: a divergence), sensors (ideal, or
/// hobby encoders with the Kalman filter) and settings (torque limits low enough to clip, a lag).
fn candidate<'a>(
    index: u64,
    trajectory: &'a JointTrajectory,
    hold: &'a Hold,
    events: &'a [[PayloadEvent; 2]; 3],
    marks: &'a [f64],
) -> LaneRun<'a> {
    let mut draw = Draw(index * 7919 + 17);
    let mut links = *report_arm().links();
    for link in &mut links {
        link.inertial.mass *= draw.range(0.9, 1.1);
        if draw.next() < 0.3 {
            link.friction = Friction { viscous: draw.range(0.0, 0.05), coulomb: draw.range(0.0, 0.03) };
        }
    }
    // Every fourth candidate's plant is the controller's model, with ideal sensors: the
    // controller takes the plant's mass matrix and bias as they are (no second evaluation).
    let exact = index % 4 == 3;
    let plant = if exact { report_arm() } else { ArmModel::new(links, Vector3::new(0.0, 0.0, -9.8)).unwrap() };
    let kinds = [
        ControllerKind::ComputedTorque,
        ControllerKind::AntiWindupPid,
        ControllerKind::DisturbanceObserver,
        ControllerKind::Adaptive,
    ];
    let kind = kinds[(draw.next() * 4.0) as usize % 4];
    let (diverging, kp, kd) = draw.pd_gains();
    let ki = if kind == ControllerKind::AntiWindupPid { draw.range(1.0, 30.0) } else { 0.0 };
    let spec = ControllerSpec {
        name: format!("c{index}"),
        kind,
        gains: Gains::uniform(kp, kd, ki).unwrap(),
        knows_friction: draw.next() < 0.5,
    };
    let controller = spec.build(report_arm()).unwrap();
    let sensed = draw.next() < 0.5 && !exact;
    let feedback = if sensed { hobby_kalman(index) } else { Feedback::ideal() };
    let mut config = SimConfig {
        integrator: Integrator::RungeKuttaNystrom4,
        ..SimConfig::new(&chessarm_core::sim::Plant::new(plant))
    };
    if draw.next() < 0.4 {
        config.torque_limits = JointVector::from([3.0, 4.0, 2.0, 0.5]);
    }
    if diverging {
        // Unclipped, so that the instability runs away (past 100 rad/s) instead of saturating.
        config.torque_limits = JointVector::repeat(1e4);
    }
    if draw.next() < 0.3 {
        config.torque_lag = JointVector::repeat(draw.range(1e-3, 1e-2));
    }
    // A lane that holds still for a shorter time finishes before its batch.
    let short = draw.next() < 0.2;
    let reference: &(dyn ReferenceSource<4> + Sync) = if short { hold } else { trajectory };
    let initial = (draw.next() < 0.3 || diverging).then(|| {
        let start = trajectory.reference(0.0).q;
        JointState { q: start + JointVector::repeat(0.02), qd: JointVector::repeat(0.1) }
    });
    LaneRun {
        plant,
        feedback,
        controller,
        reference,
        initial,
        events: &events[(draw.next() * 3.0) as usize % 3],
        marks,
        config,
    }
}

/// A controller of `kind` with `gains` on the report's arm, not told its friction.
fn controller_of(name: String, kind: ControllerKind, gains: Gains<4>) -> Box<dyn Controller<4>> {
    ControllerSpec { name, kind, gains, knows_friction: false }.build(report_arm()).unwrap()
}

/// A fixed adaptive candidate (the random ones rarely reach its payload estimate): `index`'s
/// plant and settings, the adaptive controller with moderate gains on the whole trajectory,
/// hobby encoders with the Kalman filter when `sensed`, and the events of `events[which]`.
fn adaptive_candidate<'a>(
    index: u64,
    sensed: bool,
    which: usize,
    trajectory: &'a JointTrajectory,
    hold: &'a Hold,
    events: &'a [[PayloadEvent; 2]; 3],
    marks: &'a [f64],
) -> LaneRun<'a> {
    let mut run = candidate(index, trajectory, hold, events, marks);
    run.controller =
        controller_of(format!("adaptive{index}"), ControllerKind::Adaptive, Gains::uniform(150.0, 20.0, 0.0).unwrap());
    if sensed {
        run.feedback = hobby_kalman(index);
    }
    run.reference = trajectory;
    run.initial = None;
    run.events = &events[which];
    run.config.torque_limits = JointVector::repeat(1e4);
    run
}

/// Three runs' grips and releases: the pawn at 0.3 s, told, released at 0.9 s; a heavy
/// piece at 0.25 s, not told, released at 1 s; the pawn gripped and released at the times of
/// `third`, told or not.
fn grips(third: [(f64, bool); 2]) -> [[PayloadEvent; 2]; 3] {
    let pawn = Some(Payload::upright_cylinder(0.05, 0.05, 0.012, 0.03));
    let heavy = Some(Payload::upright_cylinder(0.4, 0.06, 0.015, 0.03));
    let event = |time, payload, knows| PayloadEvent::new(time, payload, knows);
    [
        [event(0.3, pawn, true), event(0.9, None, true)],
        [event(0.25, heavy, false), event(1.0, None, false)],
        [event(third[0].0, pawn, third[0].1), event(third[1].0, None, third[1].1)],
    ]
}

/// The summary's numbers, bit for bit, and the error's text.
fn fingerprint(result: &Result<SimSummary<4>, SimError>) -> String {
    match result {
        Ok(summary) => {
            let bits = |v: &[f64]| v.iter().map(|x| format!("{:016x}", x.to_bits())).collect::<Vec<_>>().join(",");
            format!(
                "{} {} {} {} {} {} {} {:?} {} {} {} {} {} {}",
                summary.steps,
                summary.tracked_steps,
                bits(summary.rms_joint_error.as_slice()),
                bits(summary.max_joint_error.as_slice()),
                bits(&[summary.rms_tip_error, summary.max_tip_error, summary.duration]),
                bits(summary.peak_torque.as_slice()),
                summary.saturated_samples,
                summary.saturated_per_joint,
                bits(&summary.tip_at_marks.iter().flat_map(|t| t.iter().copied()).collect::<Vec<_>>()),
                bits(&summary.tip_error_at_marks),
                bits(summary.final_state.q.as_slice()),
                bits(summary.final_state.qd.as_slice()),
                bits(summary.rms_angle_estimate_error.as_slice()),
                bits(summary.rms_rate_estimate_error.as_slice()),
            )
        }
        Err(error) => format!("error: {error}"),
    }
}

#[test]
fn every_lane_equals_the_scalar_run_bit_for_bit_at_every_lane_count_and_level() {
    let trajectory = trajectory();
    let hold = Hold { q: trajectory.reference(0.0).q, duration: 0.37 };
    let events = grips([(0.5, false), (5.0, false)]);
    let marks = [0.3, 0.9, 1.1];
    let count = 27;
    // Then four adaptive runs: sensed and told of the pawn, sensed and not told, ideal sensors
    // and told (a perturbed plant: the controller's own terms), ideal and not told (the plant
    // its model: the plant's terms).
    let adaptive = [(true, 0), (true, 2), (false, 0), (false, 1)];
    let make = || {
        let mut runs: Vec<_> = (0..count).map(|i| candidate(i, &trajectory, &hold, &events, &marks)).collect();
        for (k, (sensed, which)) in adaptive.iter().enumerate() {
            runs.push(adaptive_candidate(40 + k as u64, *sensed, *which, &trajectory, &hold, &events, &marks));
        }
        runs
    };
    let scalar: Vec<String> = make().iter_mut().map(|run| fingerprint(&run.simulate_alone())).collect();
    // The candidates cover what they are meant to: failures, clipping, sensors, early ends.
    assert!(scalar.iter().any(|f| f.contains("diverged")), "no diverging lane: {scalar:#?}");
    assert!(scalar.iter().filter(|f| !f.starts_with("error")).count() >= count as usize / 2, "{scalar:#?}");
    let ok: Vec<&String> = scalar.iter().filter(|f| !f.starts_with("error")).collect();
    assert!(ok.iter().any(|f| f.split(' ').nth(6).is_some_and(|s| s != "0")), "no clipped lane");
    assert!(ok.iter().any(|f| f.starts_with("370 ")), "no lane that ends early");
    // The adaptive runs go to the end (a payload estimate through grip and release).
    for f in &scalar[count as usize..] {
        assert!(!f.starts_with("error"), "an adaptive run failed: {f}");
    }
    let mut levels = 0;
    for level in SimdLevel::ALL {
        if !level.available() {
            // Past the harness's capture, so that it shows on the terminal.
            let _ = writeln!(
                std::io::stderr(),
                "test every_lane_equals_the_scalar_run ... SIMD level {} SKIPPED (this CPU does not have it)",
                level.name()
            );
            continue;
        }
        levels += 1;
        for lanes in LaneCount::ALL {
            let batched: Vec<String> = simulate_lanes(&mut make(), lanes, level).iter().map(fingerprint).collect();
            for (i, (a, b)) in scalar.iter().zip(&batched).enumerate() {
                assert_eq!(a, b, "run {i}, {} lanes at {}", lanes.get(), level.name());
            }
        }
    }
    assert!(levels >= 1);
}

#[test]
fn a_run_outside_the_family_or_with_other_settings_is_simulated_alone() {
    let trajectory = trajectory();
    let hold = Hold { q: trajectory.reference(0.0).q, duration: 0.2 };
    let events = [[PayloadEvent::new(10.0, None, true); 2]; 3];
    let mut runs: Vec<LaneRun<'_>> = (0..5).map(|i| candidate(i, &trajectory, &hold, &events, &[])).collect();
    let mut links = *report_arm().links();
    links[1].dh.alpha = 0.2;
    runs[1].plant = ArmModel::new(links, Vector3::new(0.0, 0.0, -9.8)).unwrap();
    runs[3].config.integrator = Integrator::Midpoint;
    let scalar: Vec<String> = (0..5)
        .map(|i| {
            let mut run = candidate(i, &trajectory, &hold, &events, &[]);
            run.plant = runs[i as usize].plant;
            run.config = runs[i as usize].config;
            fingerprint(&run.simulate_alone())
        })
        .collect();
    let batched: Vec<String> =
        simulate_lanes(&mut runs, LaneCount::Four, SimdLevel::detect()).iter().map(fingerprint).collect();
    assert_eq!(scalar, batched);
}

#[test]
fn every_integrator_batches_bit_for_bit() {
    let trajectory = trajectory();
    let hold = Hold { q: trajectory.reference(0.0).q, duration: 0.3 };
    let pawn = Some(Payload::upright_cylinder(0.05, 0.05, 0.012, 0.03));
    let events = [[PayloadEvent::new(0.2, pawn, true); 2]; 3];
    for integrator in [Integrator::RungeKutta4, Integrator::Midpoint, Integrator::SemiImplicitEuler] {
        let make = || {
            (0..10)
                .map(|i| {
                    let mut run = candidate(i, &trajectory, &hold, &events, &[0.25]);
                    run.config.integrator = integrator;
                    run
                })
                .collect::<Vec<_>>()
        };
        alone_equals_batched(&make, &|_, result| fingerprint(result));
    }
}

/// A single run takes Nyström's stages written out (unrolled), a batch in its loop: at a
/// large time step from fast joints, where a stage moves an angle by more than the series
/// covers and its sines and cosines are computed afresh, they still agree bit for bit.
#[test]
fn nystrom_at_a_large_time_step_batches_bit_for_bit() {
    let trajectory = trajectory();
    let hold = Hold { q: trajectory.reference(0.0).q, duration: 0.3 };
    let events = [[PayloadEvent::new(0.2, None, true); 2]; 3];
    let make = || {
        (0..12)
            .map(|i| {
                let mut run = candidate(i, &trajectory, &hold, &events, &[0.25]);
                // 3 rad/s for 25 ms: the first stage moves each pitch by ≥ 0.075 rad, past the
                // series' 0.05.
                (run.config.dt, run.config.control_period) = (0.05, 0.05);
                run.initial =
                    Some(JointState { q: trajectory.reference(0.0).q, qd: JointVector::repeat(3.0 - 0.2 * i as f64) });
                run
            })
            .collect::<Vec<_>>()
    };
    let scalar = alone_equals_batched(&make, &|_, result| fingerprint(result));
    assert!(scalar.iter().filter(|f| !f.starts_with("error")).count() >= 4, "{scalar:?}");
}

#[test]
fn a_run_with_a_nan_time_step_gets_the_scalar_simulators_error() {
    let trajectory = trajectory();
    let hold = Hold { q: trajectory.reference(0.0).q, duration: 0.2 };
    let events = [[PayloadEvent::new(10.0, None, true); 2]; 3];
    let mut runs: Vec<LaneRun<'_>> = (0..3).map(|i| candidate(i, &trajectory, &hold, &events, &[])).collect();
    runs[0].config.dt = f64::NAN;
    let mut alone = candidate(0, &trajectory, &hold, &events, &[]);
    alone.config.dt = f64::NAN;
    let expected = fingerprint(&alone.simulate_alone());
    assert!(expected.starts_with("error"), "{expected}");
    let batched = simulate_lanes(&mut runs, LaneCount::Eight, SimdLevel::detect());
    assert_eq!(fingerprint(&batched[0]), expected);
}

/// A run whose controller's law and metrics a batch computes in lanes: the plain
/// computed-torque law (PD, the report's PID, the anti-windup PID), the exact state, no motor
/// lag, on `reference`; the `index`-th random plant, gains (some diverging), torque limits
/// (some clipping), start and events of `candidate`.
fn lane_law_candidate<'a>(
    index: u64,
    reference: &'a (dyn ReferenceSource<4> + Sync),
    trajectory: &'a JointTrajectory,
    hold: &'a Hold,
    events: &'a [[PayloadEvent; 2]; 3],
    marks: &'a [f64],
) -> LaneRun<'a> {
    let mut run = candidate(index, trajectory, hold, events, marks);
    let mut draw = Draw(index * 104_729 + 5);
    let kinds = [ControllerKind::ComputedTorque, ControllerKind::AntiWindupPid];
    let kind = kinds[(draw.next() * 2.0) as usize % 2];
    let (diverging, kp, kd) = draw.pd_gains();
    // The plain PID (ComputedTorque with an integral) as well as PD.
    let ki = if draw.next() < 0.5 { draw.range(1.0, 30.0) } else { 0.0 };
    let mut gains = Gains::uniform(kp, kd, ki).unwrap();
    if draw.next() < 0.3 {
        // One joint without an integral: the clamping holds only the others.
        gains.ki[1] = 0.0;
    }
    run.controller = controller_of(format!("law{index}"), kind, gains);
    run.feedback = Feedback::ideal();
    run.config.torque_lag = JointVector::zeros();
    run.config.torque_limits = if diverging {
        JointVector::repeat(1e4)
    } else if draw.next() < 0.5 {
        JointVector::from([3.0, 4.0, 2.0, 0.5])
    } else {
        report_arm().torque_limits()
    };
    run.reference = reference;
    if index % 6 == 1 {
        // The report's start-up: at rest at q = 0, far off the reference, with the anti-windup
        // PID, whose commands lie beyond its model's limits (the clamping holds the integral).
        let gains = Gains::uniform(300.0, 25.0, 40.0).unwrap();
        run.controller = controller_of(format!("windup{index}"), ControllerKind::AntiWindupPid, gains);
        run.initial = Some(JointState::at_rest(JointVector::zeros()));
        run.config.torque_limits = report_arm().torque_limits();
    }
    run
}

#[test]
fn batches_of_computed_torque_runs_take_their_laws_and_metrics_in_lanes_bit_for_bit() {
    let trajectory = trajectory();
    // A reference without a desired tip: the metrics take it from the plants' kinematics.
    let hold = Hold { q: trajectory.reference(0.0).q + JointVector::repeat(0.05), duration: 0.4 };
    let events = grips([(0.1, false), (0.35, true)]);
    let marks = [0.3, 0.9, 1.1, 0.2];
    // Every third run marks other instants (one shared): a batch's lanes mark at different steps.
    let other_marks = [0.25, 1.1, 0.55];
    // Groups of eight on one reference each (a batch shares its reference): on the trajectory,
    // on the hold, tracked from 0.1 s, with the controllers' model as the plant (the plant's
    // terms until a payload the controller is not told of), and three that a batch cannot take
    // in lanes, for one run each: with a motor lag, tracked from another instant, with sensors.
    let make = || {
        (0..56)
            .map(|i| {
                let reference: &(dyn ReferenceSource<4> + Sync) =
                    if (8..16).contains(&i) { &hold } else { &trajectory };
                let marks: &[f64] = if i % 3 == 2 { &other_marks } else { &marks };
                let mut run = lane_law_candidate(i, reference, &trajectory, &hold, &events, marks);
                match i {
                    16..=23 => run.config.tracking_from = 0.1,
                    24..=31 => run.plant = report_arm(),
                    33 => run.config.torque_lag = JointVector::repeat(4e-3),
                    41 => run.config.tracking_from = 0.2,
                    49 => run.feedback = hobby_kalman(i),
                    _ => {}
                }
                run
            })
            .collect::<Vec<_>>()
    };
    // The summary, and the state the run leaves its controller in.
    let print = |run: &mut LaneRun<'_>, result: &Result<SimSummary<4>, SimError>| {
        let bits = |v: &JointVector<4>| v.iter().map(|x| format!("{:016x}", x.to_bits())).collect::<Vec<_>>().join(",");
        let commanded = run.controller.commanded_acceleration().map(|v| bits(&v));
        let integral = run.controller.as_computed_torque().map(|law| bits(law.integral()));
        format!("{} | {commanded:?} {integral:?}", fingerprint(result))
    };
    let scalar = alone_equals_batched(&make, &print);
    assert!(scalar.iter().any(|f| f.contains("diverged")), "no diverging run: {scalar:#?}");
    let ok: Vec<&String> = scalar.iter().filter(|f| !f.starts_with("error")).collect();
    assert!(ok.len() >= 36, "{scalar:#?}");
    assert!(ok.iter().any(|f| f.split(' ').nth(6).is_some_and(|s| s != "0")), "no clipped run");
    assert!(ok.iter().any(|f| f.starts_with("400 ")), "no run on the hold");
}

#[test]
fn payload_events_between_steps_are_due_where_each_run_says() {
    // A batch looks at its lanes' events only when the earliest is due, by the run's own test
    // (`time <= t + dt/2`): events exactly half-way between two steps, and just before, after
    // the first step's time; in batches whose laws run in lanes and batches that do not.
    let trajectory = trajectory();
    let hold = Hold { q: trajectory.reference(0.0).q, duration: 0.4 };
    let pawn = Some(Payload::upright_cylinder(0.05, 0.05, 0.012, 0.03));
    let dt = 1e-3;
    let half_way = |step: usize| step as f64 * dt + 0.5 * dt;
    let event = |time, payload| PayloadEvent::new(time, payload, true);
    let events = [
        [event(half_way(0), pawn), event(half_way(200), None)],
        [event(0.1004, pawn), event(0.3004, None)],
        [event(half_way(150), pawn), event(0.2504, None)],
    ];
    let marks = [0.5];
    let make = || {
        (0..16)
            .map(|i| {
                if i < 8 {
                    lane_law_candidate(i, &trajectory, &trajectory, &hold, &events, &marks)
                } else {
                    candidate(i, &trajectory, &hold, &events, &marks)
                }
            })
            .collect::<Vec<_>>()
    };
    let scalar = alone_equals_batched(&make, &|_, result| fingerprint(result));
    assert!(scalar.iter().filter(|f| !f.starts_with("error")).count() >= 8, "{scalar:#?}");
}

/// Sensors of `profile` (noise seeded by `seed`) with a Kalman filter of `settings` at 1 kHz.
fn sensed(profile: SensorProfile<4>, settings: KalmanSettings, seed: u64) -> Feedback<4> {
    let rate_std = profile.rate_noise;
    let filter = JointKalman::new(1e-3, profile.angle_std(), rate_std, profile.delay_samples, settings).unwrap();
    Feedback::new(Sensors::new(profile, seed).unwrap(), Estimator::Kalman(Box::new(filter))).unwrap()
}

#[test]
fn batches_of_sensed_computed_torque_runs_take_their_filters_in_lanes_bit_for_bit() {
    let trajectory = trajectory();
    let hold = Hold { q: trajectory.reference(0.0).q, duration: 0.4 };
    let events = grips([(0.1, false), (0.35, true)]);
    let marks = [0.3, 0.9, 1.1];
    let mut with_rate = SensorProfile::<4>::hobby();
    with_rate.name = "hobby with tachometers".into();
    with_rate.rate_noise = Some(JointVector::from([0.01, 0.02, 0.015, 0.03]));
    with_rate.delay_samples = 2;
    let mut offset = SensorProfile::<4>::servo();
    offset.encoders[1].offset = 2e-3;
    // An encoder that quantises without noise (an exact one has no Kalman filter).
    offset.encoders[3].noise_counts = 0.0;
    let poisoned = Poisoned(&trajectory);
    let bad_payload = Some(Payload::upright_cylinder(f64::NAN, 0.05, 0.012, 0.03));
    let bad_events = [PayloadEvent::new(0.2, bad_payload, true), PayloadEvent::new(0.9, None, true)];
    // A payload of 1e200 kg the controller is not told of: the plant's `Δ₃ Δ` overflows, and
    // its `M` is refused (not positive definite) from 0.2 s.
    let huge = Some(Payload::upright_cylinder(1e200, 0.05, 0.012, 0.03));
    let huge_events = [PayloadEvent::new(0.2, huge, false)];
    // Groups of eight, each a batch: hobby encoders and the default filter (a delay of one
    // sample), servo encoders with an offset and the two-state filter (no delay), encoders with
    // tachometers and a delay of two samples; a group whose filters expect tachometers the
    // sensors of every other run lack (a missing rate reading: those joints lane by lane), with
    // a payload of NaN mass at 0.2 s in a quarter (an event's error); hobby encoders on a
    // reference whose third joint turns NaN after 0.2 s (a sample's error: a batch shares its
    // reference); a group whose delays differ (hobby and servo alternating), which the
    // batch must take lane by lane; then hobby encoders read in lanes with, in a quarter each,
    // the NaN-mass payload (an event's error) and a payload so heavy that the plant's `M` is
    // refused (each lane's sensors and filter handed back before the sample's reading).
    let groups = 7;
    let make = || {
        (0..8 * groups)
            .map(|i| {
                let reference: &(dyn ReferenceSource<4> + Sync) = if i / 8 == 4 { &poisoned } else { &trajectory };
                let mut run = lane_law_candidate(i, reference, &trajectory, &hold, &events, &marks);
                run.feedback = match (i / 8, i % 2) {
                    (0 | 4 | 6, _) | (5, 0) => sensed(SensorProfile::hobby(), KalmanSettings::DEFAULT, i),
                    (1, _) | (5, _) => sensed(offset.clone(), KalmanSettings::TWO_STATE, i),
                    (3, odd) => {
                        let mut feedback = sensed(with_rate.clone(), KalmanSettings::DEFAULT, i);
                        if odd == 1 {
                            // Sensors without tachometers, the filter still expecting them.
                            let mut profile = with_rate.clone();
                            profile.rate_noise = None;
                            feedback.sensors = Sensors::new(profile, i).unwrap();
                        }
                        feedback
                    }
                    _ => {
                        // Each lane's own counts, noise levels and offsets (drawn alike).
                        let mut profile = with_rate.clone();
                        profile.encoders[0].counts_per_rev = Some(4096.0 * (1 + i % 3) as f64);
                        profile.encoders[1].noise_counts = 0.25 + 0.1 * (i % 4) as f64;
                        profile.encoders[3].offset = -1e-3 * (i % 5) as f64;
                        profile.rate_noise = profile.rate_noise.map(|noise| noise * (1.0 + 0.5 * (i % 3) as f64));
                        sensed(profile, KalmanSettings::DEFAULT, i)
                    }
                };
                if (i / 8 == 3 || i / 8 == 6) && i % 4 == 1 {
                    run.events = &bad_events;
                }
                if i / 8 == 6 && i % 4 == 2 {
                    run.events = &huge_events;
                }
                run
            })
            .collect::<Vec<_>>()
    };
    // The first five groups' batches and the last take their laws and filters in lanes, and
    // but for the fourth (sensors with and without tachometers) their sensors; the sixth takes
    // none.
    let mut runs = make();
    for (k, batch) in runs.chunks_mut(8).enumerate() {
        let expected = match k {
            3 => (true, true, false),
            5 => (false, false, false),
            _ => (true, true, true),
        };
        assert_eq!(takes_in_lanes(batch), expected, "group {k}");
    }
    // The summary, and the state the run leaves its controller, its filter and its sensors in.
    let print = |run: &mut LaneRun<'_>, result: &Result<SimSummary<4>, SimError>| {
        let bits = |v: &[f64]| v.iter().map(|x| format!("{:016x}", x.to_bits())).collect::<Vec<_>>().join(",");
        let commanded = run.controller.commanded_acceleration().map(|v| bits(v.as_slice()));
        let integral = run.controller.as_computed_torque().map(|law| bits(law.integral().as_slice()));
        let Estimator::Kalman(filter) = &run.feedback.estimator else { unreachable!("every run has a filter") };
        let estimate = filter.estimate();
        let covariances: Vec<String> = (0..4)
            .map(|j| format!("{} {}", bits(filter.filter_covariance(j).as_slice()), bits(filter.gain(j).as_slice())))
            .collect();
        format!(
            "{} | {commanded:?} {integral:?} | {} {} {} | {covariances:?} | {:?}",
            fingerprint(result),
            bits(estimate.q.as_slice()),
            bits(estimate.qd.as_slice()),
            bits(filter.disturbance().as_slice()),
            run.feedback.sensors,
        )
    };
    let scalar = alone_equals_batched(&make, &print);
    assert!(scalar.iter().any(|f| f.contains("diverged")), "no diverging run: {scalar:#?}");
    let ok: Vec<&String> = scalar.iter().filter(|f| !f.starts_with("error")).collect();
    assert!(ok.len() >= 20, "{scalar:#?}");
    assert!(ok.iter().any(|f| f.split(' ').nth(6).is_some_and(|s| s != "0")), "no clipped run");
    let group = |k: usize| &scalar[8 * k..8 * k + 8];
    assert!(group(3).iter().any(|f| f.contains("payload")), "no event's error: {:#?}", group(3));
    let nan_commands = group(4).iter().filter(|f| f.contains("torque command = NaN")).count();
    assert!(nan_commands >= 4, "too few samples' errors: {:#?}", group(4));
    assert!(group(6).iter().any(|f| f.contains("payload")), "no event's error: {:#?}", group(6));
    let refused = group(6).iter().filter(|f| f.contains("not positive definite")).count();
    assert!(refused >= 2, "too few refused mass matrices: {:#?}", group(6));
}

/// The trajectory, its third joint's angle NaN after 0.2 s: a controller's command turns NaN.
struct Poisoned<'a>(&'a JointTrajectory);

impl ReferenceSource<4> for Poisoned<'_> {
    fn reference(&self, t: f64) -> Reference<4> {
        let mut reference = self.0.reference(t);
        if t > 0.2 {
            reference.q[2] = f64::NAN;
        }
        reference
    }

    fn duration(&self) -> f64 {
        self.0.duration()
    }
}

/// Each run of `make()` alone, as `print` shows it (its summary and what it leaves behind), and
/// the same runs batched at 4 and 8 lanes at every SIMD level this CPU has, which must show the
/// same. Returns the runs alone.
fn alone_equals_batched<'a>(
    make: &dyn Fn() -> Vec<LaneRun<'a>>,
    print: &dyn Fn(&mut LaneRun<'a>, &Result<SimSummary<4>, SimError>) -> String,
) -> Vec<String> {
    let scalar: Vec<String> = make()
        .iter_mut()
        .map(|run| {
            let result = run.simulate_alone();
            print(run, &result)
        })
        .collect();
    for level in SimdLevel::ALL.into_iter().filter(|level| level.available()) {
        for lanes in [LaneCount::Four, LaneCount::Eight] {
            let mut runs = make();
            let results = simulate_lanes(&mut runs, lanes, level);
            let batched: Vec<String> = runs.iter_mut().zip(&results).map(|(run, result)| print(run, result)).collect();
            for (i, (a, b)) in scalar.iter().zip(&batched).enumerate() {
                assert_eq!(a, b, "run {i}, {} lanes at {}", lanes.get(), level.name());
            }
        }
    }
    scalar
}
