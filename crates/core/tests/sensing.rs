//! The closed loop through sensors and motors: the ideal feedback is today's loop bit for bit,
//! the controller sees delayed quantised angles, and the torque lag follows its closed form.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

use chessarm_core::arm::model::{ArmModel, JointVector, ModelError, Payload};
use chessarm_core::arm::preset::report_arm;
use chessarm_core::arm::uncertainty::{InertiaRotation, ModelUncertainty};
use chessarm_core::control::computed_torque::ComputedTorque;
use chessarm_core::control::gains::Gains;
use chessarm_core::control::{Controller, JointState, Reference};
use chessarm_core::sense::rng::SeededRng;
use chessarm_core::sense::{Conditions, EncoderSpec, EstimatorSpec, Feedback, SensorProfile, Sensors};
use chessarm_core::sim::{PayloadEvent, Plant, ReferenceSource, SimConfig, StepRecord, simulate, simulate_sensed};

/// A slow sine on every joint around a pose.
struct Wave;

impl ReferenceSource<4> for Wave {
    fn reference(&self, t: f64) -> Reference<4> {
        let w = 2.0;
        let base = JointVector::<4>::new(0.3, 1.0, -1.6, -0.9);
        let amplitude = JointVector::<4>::new(0.2, 0.1, 0.15, 0.1);
        Reference {
            q: base + amplitude * (w * t).sin(),
            qd: amplitude * (w * (w * t).cos()),
            qdd: amplitude * (-w * w * (w * t).sin()),
        }
    }
    fn duration(&self) -> f64 {
        2.0
    }
}

fn pd() -> ComputedTorque<4> {
    ComputedTorque::new("pd", report_arm(), Gains::uniform(400.0, 40.0, 0.0).unwrap())
}

fn run(feedback: &mut Feedback<4>, config_lag: f64) -> Vec<StepRecord<4>> {
    let mut plant = Plant::new(report_arm().with_payload(Some(Payload::point_mass(0.05))).unwrap());
    let config = SimConfig { torque_lag: JointVector::repeat(config_lag), ..SimConfig::new(&plant) };
    let mut records = Vec::new();
    let events = [PayloadEvent::new(0.5, None, false)];
    simulate_sensed(&mut plant, feedback, &mut pd(), &Wave, None, &events, &[], &config, &mut records).unwrap();
    records
}

#[test]
fn ideal_feedback_is_the_exact_loop_bit_for_bit() {
    let mut plant = Plant::new(report_arm().with_payload(Some(Payload::point_mass(0.05))).unwrap());
    let config = SimConfig::new(&plant);
    let mut exact = Vec::new();
    let events = [PayloadEvent::new(0.5, None, false)];
    simulate(&mut plant, &mut pd(), &Wave, None, &events, &[], &config, &mut exact).unwrap();
    let mut ideal = Conditions::<4>::ideal().feedback(1e-3).unwrap();
    assert!(ideal.is_exact());
    assert_eq!(run(&mut ideal, 0.0), exact);
}

#[test]
fn the_controller_sees_delayed_angles_on_the_encoder_grid() {
    // 1024 counts, no noise, a 3 sample delay, an exact rate sensor: the controller's angle is
    // the plant's of 3 samples before, rounded to the grid.
    let profile = SensorProfile {
        name: "test".into(),
        encoders: [EncoderSpec::counts(1024.0, 0.0); 4],
        delay_samples: 3,
        rate_noise: Some(JointVector::zeros()),
    };
    let mut feedback = Feedback::new(
        Sensors::new(profile, 1).unwrap(),
        EstimatorSpec::Direct.build(&SensorProfile::<4>::ideal(), 1e-3).unwrap(),
    )
    .unwrap();
    let records = run(&mut feedback, 0.0);
    let step = std::f64::consts::TAU / 1024.0;
    for k in 3..records.len() {
        for j in 0..4 {
            let seen = records[k].estimate.q[j];
            let expected = step * (records[k - 3].state.q[j] / step).round();
            assert_eq!(seen, expected, "sample {k} joint {j}");
        }
    }
    // The first samples see the reading of the start, as before the run.
    let start = step * (records[0].state.q[1] / step).round();
    assert_eq!(records[1].estimate.q[1], start);
}

/// A controller that asks for the same torque whatever it sees.
#[derive(Debug)]
struct Constant(JointVector<4>);

impl Controller<4> for Constant {
    fn name(&self) -> &str {
        "constant"
    }
    fn reset(&mut self) {}
    fn command(&mut self, _: &JointState<4>, _: &Reference<4>, _: f64) -> JointVector<4> {
        self.0
    }
    fn set_payload(&mut self, _: Option<Payload>) -> Result<(), ModelError> {
        Ok(())
    }
}

#[test]
fn the_torque_lag_follows_its_first_order_response() {
    let lag = 0.02;
    let arm: ArmModel<4> = report_arm();
    let mut plant = Plant::new(arm);
    let config = SimConfig { torque_lag: JointVector::repeat(lag), ..SimConfig::new(&plant) };
    let command = JointVector::<4>::new(0.1, 2.0, 1.0, 0.05);
    let mut records = Vec::new();
    // 0.25 s: long enough for the response (12 time constants), short enough for the arm,
    // pushed by a constant torque, to stay slow.
    struct Short;
    impl ReferenceSource<4> for Short {
        fn reference(&self, t: f64) -> Reference<4> {
            Wave.reference(t)
        }
        fn duration(&self) -> f64 {
            0.25
        }
    }
    simulate(&mut plant, &mut Constant(command), &Short, None, &[], &[], &config, &mut records).unwrap();
    // The torque held over step k is the mean over [k dt, (k + 1) dt] of the exact response
    // of T τ̇ + τ = τ_c from zero, τ_c (1 − e^{−t/T}):
    // τ_c (1 − (T/dt)(e^{−k dt/T} − e^{−(k+1) dt/T})).
    let dt: f64 = 1e-3;
    for (k, record) in records.iter().enumerate().take(200) {
        let k = k as f64;
        let expected = command * (1.0 - lag / dt * ((-k * dt / lag).exp() - (-(k + 1.0) * dt / lag).exp()));
        assert!((record.torque - expected).abs().max() < 1e-12, "step {k}: {} vs {expected}", record.torque);
    }
}

#[test]
fn model_draws_are_seeded_and_the_errata_rotation_turns_links_2_and_3() {
    let nominal = report_arm();
    let spread = ModelUncertainty {
        link_mass: 0.1,
        com: 0.003,
        inertia_rotation: InertiaRotation::Errata,
        ..Default::default()
    };
    let (a, drawn_a) = spread.draw(&nominal, &mut SeededRng::new(5)).unwrap();
    let (b, _) = spread.draw(&nominal, &mut SeededRng::new(5)).unwrap();
    let (c, _) = spread.draw(&nominal, &mut SeededRng::new(6)).unwrap();
    assert_eq!(a, b);
    assert_ne!(a, c);
    for i in 0..4 {
        let scale = a.link(i).inertial.mass / nominal.link(i).inertial.mass;
        assert!((0.9..=1.1).contains(&scale) && (scale - drawn_a.mass_scale[i]).abs() < 1e-15);
        let shift = a.link(i).inertial.com - nominal.link(i).inertial.com;
        assert!(shift.abs().max() <= 0.003);
        // Links 2 and 3: the smallest principal moment moves from y to x (the long axis).
        let inertia = a.link(i).inertial.inertia;
        let nominal_inertia = nominal.link(i).inertial.inertia * scale;
        if i == 1 || i == 2 {
            assert!((inertia[(0, 0)] - nominal_inertia[(1, 1)]).abs() < 1e-15);
            assert!((inertia[(1, 1)] - nominal_inertia[(0, 0)]).abs() < 1e-15);
        } else {
            assert!((inertia - nominal_inertia).abs().max() < 1e-18);
        }
    }
}
