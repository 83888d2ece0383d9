//! The controllers on the report's scenario, queens-gambit (d2 → d4), as the demo runs it:
//! the report's arm (plant = model), 1 kHz control and 1 ms steps, tip errors at the grip and
//! release instants. PID with and without anti-windup, the adaptive controller's payload
//! estimate, and the disturbance observer against PD with an unknown pawn.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

#[path = "../../core/tests/common/mod.rs"]
mod common;

use chessarm_chess::board::BoardGeometry;
use chessarm_chess::pieces::PieceSet;
use chessarm_chess::scenario::scenario;
use chessarm_core::arm::dynamics::inverse_dynamics;
use chessarm_core::arm::model::{ArmModel, JointVector, Payload};
use chessarm_core::arm::payload::payload_regressor;
use chessarm_core::arm::preset::report_arm;
use chessarm_core::control::adaptive::AdaptiveComputedTorque;
use chessarm_core::control::computed_torque::{AntiWindup, ComputedTorque, DEFAULT_ERROR_BAND};
use chessarm_core::control::disturbance_observer::DisturbanceObserver;
use chessarm_core::control::gains::{Gains, REPORT_PD, REPORT_PID};
use chessarm_core::control::{Controller, JointState};
use chessarm_core::plan::path::{CartesianPath, GripperAction};
use chessarm_core::plan::trajectory::JointTrajectory;
use chessarm_core::sim::{NoObserver, PayloadEvent, Plant, SimConfig, SimSummary, StepRecord, simulate};
use common::Prefix;

/// The report's scenario as the demo plans it: path, and joint trajectory at 1 ms.
struct Scenario {
    arm: ArmModel<4>,
    path: CartesianPath,
    trajectory: JointTrajectory,
}

impl Scenario {
    fn queens_gambit() -> Self {
        let board = BoardGeometry::default();
        let path = scenario("queens-gambit", &board).unwrap().path(&board).unwrap();
        let arm = report_arm();
        let trajectory = JointTrajectory::from_path(&arm, &path, 1e-3).unwrap();
        Self { arm, path, trajectory }
    }

    fn time_of(&self, action: GripperAction) -> f64 {
        self.path.events().iter().find(|e| e.action == action).unwrap().time
    }

    /// The grip and release instants, s: the demo's marks.
    fn marks(&self) -> Vec<f64> {
        self.path.events().iter().map(|e| e.time).collect()
    }

    /// `payload` gripped at the grip and released at the release, the controller not told.
    fn unknown(&self, payload: Payload) -> Vec<PayloadEvent> {
        self.path
            .events()
            .iter()
            .map(|e| PayloadEvent::new(e.time, (e.action == GripperAction::Grip).then_some(payload), false))
            .collect()
    }

    /// Runs `controller` for the first `duration` s (the whole scenario with `None`) from
    /// `start` (at rest on the trajectory with `None`), recording every step.
    fn run(
        &self,
        controller: &mut dyn Controller<4>,
        start: Option<JointState<4>>,
        events: &[PayloadEvent],
        duration: Option<f64>,
    ) -> (SimSummary<4>, Vec<StepRecord<4>>) {
        let mut plant = Plant::new(self.arm);
        let config = SimConfig::new(&plant);
        let reference = Prefix { trajectory: &self.trajectory, duration: duration.unwrap_or(self.path.duration()) };
        let mut records = Vec::new();
        let summary =
            simulate(&mut plant, controller, &reference, start, events, &self.marks(), &config, &mut records).unwrap();
        (summary, records)
    }

    fn run_quietly(
        &self,
        controller: &mut dyn Controller<4>,
        start: Option<JointState<4>>,
        events: &[PayloadEvent],
        duration: f64,
    ) {
        let mut plant = Plant::new(self.arm);
        let config = SimConfig::new(&plant);
        let reference = Prefix { trajectory: &self.trajectory, duration };
        simulate(&mut plant, controller, &reference, start, events, &[], &config, &mut NoObserver).unwrap();
    }
}

/// The demo's start: at rest at q = 0, off the trajectory.
fn at_zero() -> Option<JointState<4>> {
    Some(JointState::at_rest(JointVector::zeros()))
}

fn report_pid() -> Gains<4> {
    Gains::uniform(REPORT_PID.0, REPORT_PID.1, REPORT_PID.2).unwrap()
}

fn report_pd(arm: ArmModel<4>) -> ComputedTorque<4> {
    ComputedTorque::new("pd", arm, Gains::uniform(REPORT_PD.0, REPORT_PD.1, 0.0).unwrap())
}

fn pawn() -> Payload {
    PieceSet::default().pawn.payload()
}

fn millimetres(summary: &SimSummary<4>) -> [f64; 2] {
    [summary.tip_error_at_marks[0] * 1e3, summary.tip_error_at_marks[1] * 1e3]
}

#[test]
fn anti_windup_pid_places_the_pawn_where_the_reports_pid_misses_by_millimetres() {
    let scene = Scenario::queens_gambit();
    // The demo: no piece carried (payload 0 kg, so no payload events), start at rest at q = 0.
    let (plain, _) = scene.run(&mut ComputedTorque::new("pid", scene.arm, report_pid()), at_zero(), &[], None);
    let (protected, _) = scene.run(&mut ComputedTorque::pid(scene.arm, report_pid()), at_zero(), &[], None);
    let [plain_grip, plain_release] = millimetres(&plain);
    let [grip, release] = millimetres(&protected);
    println!(
        "tip error at grip / release, mm: plain PID {plain_grip:.4} / {plain_release:.4}, anti-windup PID {grip:.4} / {release:.4}"
    );
    // The report's PID keeps today's figures, 2.364 and 1.109 mm (the run is deterministic;
    // 0.5 % allows for reordered rounding elsewhere, while any protection of the integral
    // moves them by more than 25 %: clamping on saturation alone gives 1.77 mm).
    assert!((plain_grip - 2.3642).abs() < 0.005 * 2.3642, "plain PID at the grip: {plain_grip} mm");
    assert!((plain_release - 1.1090).abs() < 0.005 * 1.1090, "plain PID at the release: {plain_release} mm");
    // The target: below 0.1 mm at the grip (and at the release).
    assert!(grip < 0.1, "anti-windup PID at the grip: {grip} mm");
    assert!(release < 0.1, "anti-windup PID at the release: {release} mm");
    // Both saturate during the start-up: the comparison is of the same transient.
    assert!(plain.saturated_samples > 0 && protected.saturated_samples > 0);
}

#[test]
fn anti_windup_pid_equals_the_plain_pid_bit_for_bit_when_it_never_engages() {
    let scene = Scenario::queens_gambit();
    // Started on the trajectory: normal tracking, without and with an unknown pawn.
    for events in [Vec::new(), scene.unknown(pawn())] {
        let mut plain = ComputedTorque::new("pid", scene.arm, report_pid());
        let mut protected = ComputedTorque::pid(scene.arm, report_pid());
        let (plain_summary, plain_records) = scene.run(&mut plain, None, &events, None);
        let (summary, records) = scene.run(&mut protected, None, &events, None);
        // The protection never engages: every error within the band, no saturation.
        println!("{} payload events: largest joint error {:.2e} rad", events.len(), summary.max_joint_error.amax());
        assert!(summary.max_joint_error.amax() < DEFAULT_ERROR_BAND, "{}", summary.max_joint_error);
        assert_eq!(summary.saturated_samples, 0);
        // The integral is at work (so that freezing it would show in the records).
        assert!(protected.integral().amax() > 0.0, "the integral never integrated");
        assert_eq!(plain_records.len(), records.len());
        for (a, b) in plain_records.iter().zip(&records) {
            assert_eq!(a, b, "t = {} s, {} payload events", a.t, events.len());
        }
        assert_eq!(plain.integral(), protected.integral());
        assert_eq!(plain_summary, summary);
    }
}

#[test]
fn saturation_clamping_alone_cannot_undo_the_start_up_wind_up() {
    // The measurement behind the default scheme: most of the wind-up is the linear integral of
    // the initial error, so clamping on saturation helps only in part.
    let scene = Scenario::queens_gambit();
    let clamping = AntiWindup::Clamp { error_band: f64::INFINITY };
    let mut controller = ComputedTorque::new("pid", scene.arm, report_pid()).with_anti_windup(clamping).unwrap();
    let (summary, _) = scene.run(&mut controller, at_zero(), &[], None);
    let [grip, _] = millimetres(&summary);
    println!("clamping on saturation alone: {grip:.4} mm at the grip");
    // Measured 1.77 mm: between the plain PID's 2.36 mm and ten times the 0.1 mm target.
    assert!(grip > 1.0 && grip < 2.3, "{grip} mm");
}

#[test]
fn adaptive_controller_weighs_the_unknown_pawn_within_0_3_s_of_the_grip() {
    let scene = Scenario::queens_gambit();
    let pawn = pawn();
    let true_mass = pawn.inertial.mass;
    let events = scene.unknown(pawn);
    let grip = scene.time_of(GripperAction::Grip);
    let mut controller = AdaptiveComputedTorque::new(scene.arm);
    scene.run_quietly(&mut controller, at_zero(), &events, grip + 0.3);
    let (mass, offset) = controller.payload_estimate();
    let relative = (mass - true_mass).abs() / true_mass;
    println!(
        "adaptive at grip + 0.3 s: m̂ = {:.6} g (true {:.1} g, error {:.2e}), ĉ = {:.4} m (true {:.4} m)",
        mass * 1e3,
        true_mass * 1e3,
        relative,
        offset,
        pawn.inertial.com.x
    );
    assert!(relative < 0.05, "mass estimate {mass} kg, true {true_mass} kg");
    // Before the grip the gripper is known to be empty, and after the release again.
    let mut controller = AdaptiveComputedTorque::new(scene.arm);
    scene.run_quietly(&mut controller, at_zero(), &events, grip - 0.1);
    assert_eq!(controller.payload_estimate(), (0.0, 0.0));
    let mut controller = AdaptiveComputedTorque::new(scene.arm);
    scene.run_quietly(&mut controller, at_zero(), &events, scene.time_of(GripperAction::Release) + 0.1);
    assert_eq!(controller.payload_estimate(), (0.0, 0.0));
}

#[test]
fn adaptive_controller_grips_nothing_and_estimates_nothing() {
    let scene = Scenario::queens_gambit();
    // The gripper closes on nothing: a payload of zero mass (the model accepts it).
    let events = scene.unknown(Payload::point_mass(0.0));
    let (grip, release) = (scene.time_of(GripperAction::Grip), scene.time_of(GripperAction::Release));
    // The residual the estimator sees, recomputed from the recorded run with the inverse
    // dynamics: with plant = model it is the midpoint rule's error alone, and it bounds the
    // estimate through the smallest gravity lever `|Y_·1|` (N·m per kg) of the gripped span.
    let (_, records) = scene.run(&mut AdaptiveComputedTorque::new(scene.arm), at_zero(), &events, None);
    let (mut residual, mut lever) = (0.0f64, f64::INFINITY);
    for pair in records.windows(2).filter(|pair| pair[0].t > grip && pair[1].t < release) {
        let (before, after) = (&pair[0], &pair[1]);
        let q = (before.state.q + after.state.q) * 0.5;
        let qd = (before.state.qd + after.state.qd) * 0.5;
        let qdd = (after.state.qd - before.state.qd) / (after.t - before.t);
        residual = residual.max((before.torque - inverse_dynamics(&scene.arm, &q, &qd, &qdd)).amax());
        lever = lever.min(payload_regressor(&scene.arm, &q, &qd, &qdd).column(0).amax());
    }
    // O(h²) with h = 1 ms: measured 3.4e-7 N·m.
    assert!(residual < 1e-5, "residual {residual} N·m");
    // One row of least squares would be off by residual / lever (≈ 2e-7 kg); ten times that
    // allows for the weighting across joints and samples and for the poorly excited offset
    // column's correlation with the mass column: 2 mg, under 0.01 % of a pawn.
    let bound = 10.0 * residual / lever;
    for instant in [grip + 0.3, grip + 2.0, 0.5 * (grip + release), release - 1e-3] {
        let mut controller = AdaptiveComputedTorque::new(scene.arm);
        scene.run_quietly(&mut controller, at_zero(), &events, instant);
        let (mass, _) = controller.payload_estimate();
        println!("gripping nothing, t = {instant:.3} s: m̂ = {mass:.3e} kg (bound {bound:.1e} kg)");
        assert!(mass.abs() < bound, "t = {instant} s: m̂ = {mass} kg, bound {bound} kg");
    }
}

#[test]
fn adaptive_and_observer_place_an_unknown_pawn_better_than_pd() {
    let scene = Scenario::queens_gambit();
    let events = scene.unknown(pawn());
    let (pd, _) = scene.run(&mut report_pd(scene.arm), at_zero(), &events, None);
    let (adaptive, _) = scene.run(&mut AdaptiveComputedTorque::new(scene.arm), at_zero(), &events, None);
    let (dob, _) = scene.run(&mut DisturbanceObserver::new(scene.arm), at_zero(), &events, None);
    let [_, pd_release] = millimetres(&pd);
    let [_, adaptive_release] = millimetres(&adaptive);
    let [_, dob_release] = millimetres(&dob);
    println!(
        "unknown pawn, tip error at the release, mm: PD {pd_release:.5}, adaptive {adaptive_release:.5}, DOB {dob_release:.5}"
    );
    // PD carries the pawn's weight as a steady error (measured 0.88 mm at the release). The
    // adaptive controller cancels the pawn's torques up to its estimate's error (1e-5 of the
    // mass) and the observer up to the Q-filter's lag; both should be better by far, so a
    // tenth of PD's error is a loose bound that still fails if either does nothing.
    assert!(pd_release > 0.1, "PD should visibly miss with an unknown pawn: {pd_release} mm");
    assert!(adaptive_release < 0.1 * pd_release, "adaptive {adaptive_release} mm, PD {pd_release} mm");
    assert!(dob_release < 0.1 * pd_release, "DOB {dob_release} mm, PD {pd_release} mm");
}

/// The adaptive controller's estimate at grip + 0.3 s with encoders and the Kalman filter.
fn noisy_estimate(sensors: chessarm_core::sense::SensorProfile<4>, seed: u64) -> f64 {
    use chessarm_core::sense::{Conditions, EstimatorSpec};
    let scene = Scenario::queens_gambit();
    let events = scene.unknown(pawn());
    let grip = scene.time_of(GripperAction::Grip);
    let conditions = Conditions { sensors, estimator: EstimatorSpec::KALMAN, torque_lag: JointVector::zeros(), seed };
    let mut feedback = conditions.feedback(1e-3).unwrap();
    let mut plant = Plant::new(scene.arm);
    let config = SimConfig::new(&plant);
    let reference = Prefix { trajectory: &scene.trajectory, duration: grip + 0.3 };
    let mut controller = AdaptiveComputedTorque::new(scene.arm);
    chessarm_core::sim::simulate_sensed(
        &mut plant,
        &mut feedback,
        &mut controller,
        &reference,
        None,
        &events,
        &[],
        &config,
        &mut NoObserver,
    )
    .unwrap();
    controller.payload_estimate().0
}

#[test]
fn adaptive_estimate_with_encoders_is_measured_against_its_target() {
    // The target (within 5 % of the true mass 0.3 s after the grip) holds with exact
    // states (above). With encoders the acceleration the estimator needs comes from estimated
    // rates, whose noise is in the regressor as well as in the residual (errors in variables).
    // Measured over 8 seeds: servo mean 0.2 %, worst 0.5 % (the target holds); hobby mean
    // 5.0 %, worst 8.0 % (it does not, by up to 3 points). The bounds are about twice the
    // measured worst, so that a regression shows.
    let true_mass = pawn().inertial.mass;
    for (name, sensors, bound) in [
        ("servo", chessarm_core::sense::SensorProfile::servo(), 0.01),
        ("hobby", chessarm_core::sense::SensorProfile::hobby(), 0.15),
    ] {
        let errors: Vec<f64> =
            (0..8).map(|seed| (noisy_estimate(sensors.clone(), seed) - true_mass).abs() / true_mass).collect();
        let worst = errors.iter().copied().fold(0.0, f64::max);
        let mean = errors.iter().sum::<f64>() / errors.len() as f64;
        println!("adaptive at grip + 0.3 s, {name} + kalman: relative mass error mean {mean:.3}, worst {worst:.3}");
        assert!(worst < bound, "{name}: {errors:?}");
    }
}
