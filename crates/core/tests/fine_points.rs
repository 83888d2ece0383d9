//! Fine points: a gripper command goes ahead only when the estimated arm is in position
//! (`simulate_fine_points`), or when its wait times out, and the run says which.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

use chessarm_core::arm::kinematics::FrameChain;
use chessarm_core::arm::model::{JointVector, Payload};
use chessarm_core::arm::preset::report_arm;
use chessarm_core::control::computed_torque::ComputedTorque;
use chessarm_core::control::gains::Gains;
use chessarm_core::control::{JointState, Reference};
use chessarm_core::plan::fine_point::{InPosition, Wait};
use chessarm_core::sense::{Conditions, EstimatorSpec, Feedback, SensorProfile};
use chessarm_core::sim::{
    PayloadEvent, Plant, ReferenceSource, SimConfig, SimError, StepRecord, simulate_fine_points, simulate_sensed,
};

/// A quick quintic move of every joint from `A` to `B` in `MOVE` s, then at rest at `B` until
/// `END`; a grip at the arrival, a release at `RELEASE`.
struct Move;

const A: [f64; 4] = [0.3, 1.0, -1.6, -0.9];
const B: [f64; 4] = [0.6, 1.2, -1.9, -0.7];
const MOVE: f64 = 0.25;
const RELEASE: f64 = 0.6;
const END: f64 = 0.9;

impl ReferenceSource<4> for Move {
    fn reference(&self, t: f64) -> Reference<4> {
        let s = (t / MOVE).clamp(0.0, 1.0);
        // Quintic rest-to-rest: 10s³ − 15s⁴ + 6s⁵ and its derivatives.
        let (p, v, a) = (
            s * s * s * (10.0 - 15.0 * s + 6.0 * s * s),
            30.0 * s * s * (1.0 - s) * (1.0 - s) / MOVE,
            60.0 * s * (1.0 - s) * (1.0 - 2.0 * s) / (MOVE * MOVE),
        );
        let (a0, b0) = (JointVector::from(A), JointVector::from(B));
        let d = b0 - a0;
        Reference { q: a0 + d * p, qd: d * v, qdd: d * a }
    }
    fn duration(&self) -> f64 {
        END
    }
}

fn events() -> [PayloadEvent; 2] {
    // The controller is told the payload: its steady state is on the reference.
    [PayloadEvent::new(MOVE, Some(Payload::point_mass(0.05)), true), PayloadEvent::new(RELEASE, None, true)]
}

/// A sluggish PD (ωn 5 rad/s, ζ 0.7): far behind the quick move when it arrives.
fn sluggish() -> ComputedTorque<4> {
    ComputedTorque::new("sluggish", report_arm(), Gains::uniform(25.0, 7.0, 0.0).unwrap())
}

fn hobby() -> Feedback<4> {
    let conditions = Conditions {
        sensors: SensorProfile::hobby(),
        estimator: EstimatorSpec::KALMAN,
        torque_lag: JointVector::zeros(),
        seed: 7,
    };
    conditions.feedback(1e-3).unwrap()
}

fn gated(
    feedback: &mut Feedback<4>,
    controller: &mut ComputedTorque<4>,
    gate: &InPosition,
) -> Result<(chessarm_core::sim::SimSummary<4>, Vec<Wait>, Vec<StepRecord<4>>), SimError> {
    let mut plant = Plant::new(report_arm());
    let config = SimConfig::new(&plant);
    let mut records = Vec::new();
    let marks = [MOVE, RELEASE];
    let (summary, waits) = simulate_fine_points(
        &mut plant,
        feedback,
        controller,
        &Move,
        None,
        &events(),
        &marks,
        Some(gate),
        &config,
        &mut records,
    )?;
    Ok((summary, waits, records))
}

/// Whether the estimate the controller saw at a step is in position at the move's end.
fn in_position(gate: &InPosition, estimate: &JointState<4>) -> bool {
    let target = FrameChain::new(&report_arm(), &JointVector::from(B)).tip();
    gate.holds(&InPosition::measure(&report_arm(), &estimate.q, &estimate.qd, &target))
}

#[test]
fn no_gripper_command_goes_ahead_while_the_estimate_is_outside_its_bands() {
    let gate = InPosition::for_tolerance(0.005);
    let (summary, waits, records) = gated(&mut hobby(), &mut sluggish(), &gate).unwrap();
    assert_eq!(waits.len(), 2, "one wait per gripper command");
    let dt = 1e-3;
    for wait in &waits {
        assert!(!wait.timed_out, "{wait:?}");
        let reached = (wait.reached / dt).round() as usize;
        let went = ((wait.reached + wait.duration) / dt).round() as usize;
        // The gate at step k looks at the estimate of the sample taken at step k − 1.
        for k in reached..went {
            assert!(!in_position(&gate, &records[k - 1].estimate), "in position at step {k}, yet held");
            // Held: the reference stands still at the planned point.
            assert_eq!(records[k].reference.qd, JointVector::<4>::zeros());
            assert_eq!(records[k].reference.q, records[reached].reference.q);
        }
        assert!(in_position(&gate, &records[went - 1].estimate), "went ahead out of position at step {went}");
        assert!(gate.holds(&wait.check));
    }
    // The sluggish controller lags far behind the quick move: the grip waited.
    assert!(waits[0].duration > 0.1, "{:?}", waits[0]);
    // The run is the plan plus its waits, and the marks are taken when the commands go ahead.
    let waited: f64 = waits.iter().map(|w| w.duration).sum();
    assert!((summary.duration - (END + waited)).abs() < 0.5 * dt, "{} vs {}", summary.duration, END + waited);
    let grip_step = ((waits[0].reached + waits[0].duration) / dt).round() as usize;
    assert_eq!(summary.tip_at_marks[0], records[grip_step].tip);
}

#[test]
fn a_wait_that_reaches_its_timeout_is_reported_and_the_command_goes_ahead() {
    // A band no estimate of 12-bit encoders meets: every wait gives up after its timeout.
    let gate = InPosition { tip_band: 1e-9, speed_band: 1e-9, timeout: 0.2 };
    let (summary, waits, _) = gated(&mut hobby(), &mut sluggish(), &gate).unwrap();
    assert_eq!(waits.len(), 2);
    for wait in &waits {
        assert!(wait.timed_out, "{wait:?}");
        assert!((wait.duration - 0.2).abs() < 1e-9, "{wait:?}");
        assert!(!gate.holds(&wait.check));
    }
    assert!((summary.duration - (END + 0.4)).abs() < 5e-4);
}

#[test]
fn an_arm_in_position_on_arrival_runs_as_by_the_clock_bit_for_bit() {
    // Ideal sensors and a stiff PD on the plant's own model: in position at every arrival.
    let gate = InPosition::for_tolerance(0.005);
    let stiff = || ComputedTorque::new("stiff", report_arm(), Gains::uniform(900.0, 60.0, 0.0).unwrap());
    let (summary, waits, records) = gated(&mut Feedback::ideal(), &mut stiff(), &gate).unwrap();
    assert!(waits.iter().all(|w| w.duration == 0.0 && !w.timed_out), "{waits:?}");
    let mut plant = Plant::new(report_arm());
    let config = SimConfig::new(&plant);
    let mut clock_records = Vec::new();
    let clock = simulate_sensed(
        &mut plant,
        &mut Feedback::ideal(),
        &mut stiff(),
        &Move,
        None,
        &events(),
        &[MOVE, RELEASE],
        &config,
        &mut clock_records,
    )
    .unwrap();
    assert_eq!(summary, clock);
    assert_eq!(records, clock_records);
}

#[test]
fn a_condition_that_is_not_finite_and_positive_is_refused_by_name() {
    for (gate, field) in [
        (InPosition { tip_band: 0.0, ..InPosition::for_tolerance(0.005) }, "tip_band"),
        (InPosition { speed_band: f64::NAN, ..InPosition::for_tolerance(0.005) }, "speed_band"),
        (InPosition { timeout: f64::INFINITY, ..InPosition::for_tolerance(0.005) }, "timeout"),
    ] {
        let error = gated(&mut Feedback::ideal(), &mut sluggish(), &gate).unwrap_err();
        assert!(error.to_string().contains(field), "{error}");
    }
}

#[test]
fn the_default_bands_follow_the_tolerance() {
    let gate = InPosition::for_tolerance(0.005);
    assert_eq!(gate.tip_band, 0.0005);
    assert!((gate.speed_band - 0.005).abs() < 1e-15);
    assert_eq!(gate.timeout, 1.0);
}
