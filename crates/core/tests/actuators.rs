//! Position servos against closed forms: the static error of the P loop under a load, the
//! friction band around it, the internal target's speed clamp, the duty's saturation at stall,
//! the backlash band as a hysteresis, and the hosts' goal offsets that cancel the sag.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

use chessarm_core::arm::dynamics::gravity_torques;
use chessarm_core::arm::model::{ArmModel, JointVector, Payload};
use chessarm_core::arm::preset::report_arm;
use chessarm_core::control::servo_host::{ServoCommand, ServoHost};
use chessarm_core::control::{JointState, Reference};
use chessarm_core::sim::actuator::{Actuator, Actuators, PositionBank, ServoSpec, StepperSpec, profiles};
use chessarm_core::sim::{Plant, ReferenceSource, SimConfig, StepRecord, simulate};

/// A reference held at `q` for `duration` seconds, or moving by `wave` (rad, per joint) as a
/// triangle of `period` seconds.
struct Held {
    q: JointVector<4>,
    wave: JointVector<4>,
    period: f64,
    duration: f64,
}

impl ReferenceSource<4> for Held {
    fn reference(&self, t: f64) -> Reference<4> {
        if self.period == 0.0 {
            return Reference::hold(self.q);
        }
        // Triangle 0 → 1 → 0 → −1 → 0 over a period.
        let phase = (t / self.period).fract();
        let (shape, slope) = if phase < 0.25 {
            (4.0 * phase, 4.0)
        } else if phase < 0.75 {
            (2.0 - 4.0 * phase, -4.0)
        } else {
            (4.0 * phase - 4.0, 4.0)
        };
        Reference { q: self.q + self.wave * shape, qd: self.wave * (slope / self.period), qdd: JointVector::zeros() }
    }
    fn duration(&self) -> f64 {
        self.duration
    }
}

const POSE: [f64; 4] = [0.3, 0.9, -1.4, -0.6];

/// An ideal servo strong enough for the report's arm: no counts to speak of, no deadband, no
/// backlash, no friction, a 1 ms firmware.
fn ideal() -> ServoSpec {
    ServoSpec {
        supply_voltage: 24.0,
        resistance: 1.0,
        torque_constant: 2.0,
        max_torque: 40.0,
        armature: 0.01,
        coulomb_friction: 0.0,
        viscous_friction: 0.0,
        backlash: 0.0,
        counts_per_revolution: 1e12,
        period: 1e-3,
        kp: 0.5,
        ki: 0.0,
        kd: 0.0,
        max_duty: 1.0,
        deadband: 0.0,
        max_target_speed: 0.0,
        max_target_acceleration: 0.0,
    }
}

struct Run {
    records: Vec<StepRecord<4>>,
    plant: ArmModel<4>,
    final_state: JointState<4>,
    saturated: [usize; 4],
}

fn run(
    specs: [ServoSpec; 4],
    model: ArmModel<4>,
    strategy: ServoCommand,
    reference: &Held,
    initial: Option<JointState<4>>,
) -> Run {
    let actuators = Actuators::servos(specs);
    let plant_model = actuators.plant_model(&model).unwrap();
    let mut plant = Plant::new(plant_model);
    let mut host = ServoHost::new(strategy, model, Actuators::servos(specs)).unwrap();
    let config = SimConfig { control_period: 0.01, actuators, ..SimConfig::new(&plant) };
    let mut records = Vec::new();
    let summary = simulate(&mut plant, &mut host, reference, initial, &[], &[], &config, &mut records).unwrap();
    Run { records, plant: plant_model, final_state: summary.final_state, saturated: summary.saturated_per_joint }
}

/// Held still from rest on the goal, a servo settles at the error its loop needs to drive the
/// gravity torque: `e = g(q) / (kp kt V / R)`, here 0.05–0.6 rad on the arm's joints.
#[test]
fn a_loaded_servo_settles_at_the_error_of_its_p_loop() {
    let goal = JointVector::from(POSE);
    let held = Held { q: goal, wave: JointVector::zeros(), period: 0.0, duration: 6.0 };
    let spec = ideal();
    let out = run([spec; 4], report_arm(), ServoCommand::Plain, &held, Some(JointState::at_rest(goal)));
    let q = out.final_state.q;
    let g = gravity_torques(&out.plant, &q);
    for j in 0..4 {
        let expected = g[j] / spec.stiffness();
        let error = goal[j] - q[j];
        // The residual of an underdamped settle after 6 s (ζ ≥ 0.2 at ≥ 10 rad/s: e^{-12}
        // of the initial error) and of the counts (1e-12 of a turn).
        assert!((error - expected).abs() < 1e-6 * (1.0 + expected.abs()), "joint {}: {error} vs {expected}", j + 1);
        assert!(out.final_state.qd[j].abs() < 1e-5);
    }
    // The arm's shoulder and elbow carry load: the test is not of a zero error.
    assert!((g[1] / spec.stiffness()).abs() > 0.05);
    // And `PositionBank::settled` finds the same equilibrium without simulating.
    let settled = PositionBank::settled(&Actuators::servos([spec; 4]), &out.plant, &goal);
    assert!((settled - q).amax() < 1e-6);
}

/// With Coulomb friction `c` in the gear the servo stops anywhere its loop's torque and gravity
/// differ by at most `c`: within `c / stiffness` of the frictionless error.
#[test]
fn gear_friction_leaves_a_band_around_the_static_error() {
    let goal = JointVector::from(POSE);
    let held = Held { q: goal, wave: JointVector::zeros(), period: 0.0, duration: 6.0 };
    let spec = ServoSpec { coulomb_friction: 0.4, viscous_friction: 0.1, ..ideal() };
    let out = run([spec; 4], report_arm(), ServoCommand::Plain, &held, Some(JointState::at_rest(goal)));
    let q = out.final_state.q;
    let g = gravity_torques(&out.plant, &q);
    let mut outside_frictionless = 0;
    for j in 0..4 {
        let frictionless = g[j] / spec.stiffness();
        let error = goal[j] - q[j];
        let band = spec.coulomb_friction / spec.stiffness();
        // The smoothed Coulomb law (tanh of q̇ / 1e-3 rad/s) lets it creep on slowly: the band
        // holds, with 1 % of it for the creep's direction.
        assert!((error - frictionless).abs() <= band * 1.01, "joint {}: {error} vs {frictionless} ± {band}", j + 1);
        if (error - frictionless).abs() > 1e-4 {
            outside_frictionless += 1;
        }
    }
    assert!(outside_frictionless > 0, "friction made no difference: the test does not test the band");
}

/// The firmware moves its internal target toward a far goal at `max_target_speed`: a step of
/// the goal becomes a ramp of that slope, `max_target_speed · period` a period.
#[test]
fn the_internal_target_ramps_at_the_speed_limit() {
    let spec = ServoSpec { max_target_speed: 2.0, ..ideal() };
    let start = JointVector::from(POSE);
    let step = JointVector::<4>::new(0.5, 0.0, 0.0, 0.0);
    // The reference jumps at t = 0 by 0.5 rad on the base yaw (no gravity there).
    struct Step(JointVector<4>, JointVector<4>);
    impl ReferenceSource<4> for Step {
        fn reference(&self, t: f64) -> Reference<4> {
            Reference::hold(if t < 0.1 { self.0 } else { self.0 + self.1 })
        }
        fn duration(&self) -> f64 {
            1.0
        }
    }
    let actuators = Actuators::servos([spec; 4]);
    let model = actuators.plant_model(&report_arm()).unwrap();
    let mut plant = Plant::new(model);
    let mut host = ServoHost::new(ServoCommand::Plain, report_arm(), Actuators::servos([spec; 4])).unwrap();
    let config = SimConfig { control_period: 0.01, actuators, ..SimConfig::new(&plant) };
    let mut records: Vec<StepRecord<4>> = Vec::new();
    simulate(&mut plant, &mut host, &Step(start, step), None, &[], &[], &config, &mut records).unwrap();
    let target = |r: &StepRecord<4>| r.servo.unwrap().target[0] - start[0];
    // The goal changes at the bus sample at 0.1 s; the firmware period that starts there moves
    // the target by 2 rad/s × 1 ms. Each later period adds as much until the goal is reached at
    // 0.1 + 0.25 s.
    for r in &records {
        let expected = ((r.t - 0.1 + 1e-3 + 1e-9).max(0.0) * 2.0).min(0.5);
        let expected = if r.t < 0.1 - 1e-9 { 0.0 } else { expected };
        assert!((target(r) - expected).abs() < 1e-8, "t = {}: target {} vs {expected}", r.t, target(r));
    }
    // On the goal, in whole counts.
    assert!((target(records.last().unwrap()) - 0.5).abs() <= spec.resolution());
}

/// A load beyond the stall torque drives the duty to its limit: the servo delivers its stall
/// torque and no more, and counts the saturated periods; below it, the same servo holds.
#[test]
fn beyond_stall_the_duty_saturates_and_the_joint_gives_way() {
    let goal = JointVector::from(POSE);
    let held = Held { q: goal, wave: JointVector::zeros(), period: 0.0, duration: 1.0 };
    let arm = report_arm();
    let g_shoulder = gravity_torques(&arm, &goal)[1].abs();
    for (factor, holds) in [(1.25, true), (0.8, false)] {
        let spec = ServoSpec { max_torque: g_shoulder * factor, kp: 50.0, ..ideal() };
        let out = run([spec; 4], arm, ServoCommand::Plain, &held, Some(JointState::at_rest(goal)));
        let error = (goal[1] - out.final_state.q[1]).abs();
        // The motor's torque at the output, the back-EMF's included: at the current limit.
        let torque = out.records.last().unwrap().torque[1];
        if holds {
            // Below stall: still, at the P loop's error (≤ g / (kp kt V / R)).
            assert!(error < 2.0 * g_shoulder / spec.stiffness(), "factor {factor}: error {error}");
            assert!(out.records.last().unwrap().servo.unwrap().duty[1].abs() < spec.max_duty);
        } else {
            // Beyond: the drive is the stall torque at every firmware period since the load took
            // over; the shoulder falls far beyond the loop's error.
            assert!(error > 0.1, "factor {factor}: error {error}");
            assert!((torque.abs() - spec.stall_torque()).abs() < 1e-9, "drive {torque} vs {}", spec.stall_torque());
            assert!(out.saturated[1] > 900, "saturated periods {}", out.saturated[1]);
        }
    }
}

/// On the base yaw (no gravity) sweeping slowly back and forth, the gear's gap closes on the
/// side the motor pushes: `+b/2` while the output turns up, `−b/2` while it turns down, and the
/// motor side's lead over the output traces the band of width `b` as a hysteresis.
#[test]
fn backlash_is_a_hysteresis_band_of_its_width() {
    let spec = ServoSpec { backlash: 0.02, coulomb_friction: 0.05, viscous_friction: 0.05, ..ideal() };
    let wave = JointVector::<4>::new(0.3, 0.0, 0.0, 0.0);
    let held = Held { q: JointVector::from(POSE), wave, period: 4.0, duration: 8.0 };
    let out = run([spec; 4], report_arm(), ServoCommand::Plain, &held, None);
    let (mut rising, mut falling) = (0, 0);
    let (mut lowest, mut highest) = (f64::MAX, f64::MIN);
    for r in &out.records {
        let gap = r.servo.unwrap().gap[0];
        lowest = lowest.min(gap);
        highest = highest.max(gap);
        // Well inside a stroke (not within 0.2 s of a reversal of the triangle).
        let phase = (r.t / 4.0).fract();
        let near_reversal = [0.25, 0.75].iter().any(|p| (phase - p).abs() < 0.05);
        if near_reversal || r.t < 0.5 {
            continue;
        }
        if r.reference.qd[0] > 0.0 {
            assert_eq!(gap, 0.01, "t = {}: gap {gap} while turning up", r.t);
            rising += 1;
        } else {
            assert_eq!(gap, -0.01, "t = {}: gap {gap} while turning down", r.t);
            falling += 1;
        }
    }
    assert!(rising > 1000 && falling > 1000);
    assert_eq!((lowest, highest), (-0.01, 0.01));
}

/// Gravity pre-compensation: `sag` offsets the goals by `g(q)/stiffness`, so the servos hold the
/// planned angles where `plain` leaves the P loop's error; `feedforward` does the same at rest.
#[test]
fn sag_and_feedforward_goals_hold_the_planned_angles() {
    let goal = JointVector::from(POSE);
    let held = Held { q: goal, wave: JointVector::zeros(), period: 0.0, duration: 3.0 };
    let spec = ideal();
    let arm = report_arm().with_payload(Some(Payload::point_mass(0.2))).unwrap();
    let plain = run([spec; 4], arm, ServoCommand::Plain, &held, None);
    let sag = run([spec; 4], arm, ServoCommand::Sag, &held, None);
    let feedforward = run([spec; 4], arm, ServoCommand::Feedforward, &held, None);
    let plain_error = (plain.final_state.q - goal).amax();
    assert!(plain_error > 0.05, "plain {plain_error}");
    for out in [&sag, &feedforward] {
        let error = (out.final_state.q - goal).amax();
        // The host and the plant share the model: only the settle's residual is left.
        assert!(error < 1e-6, "error {error}");
    }
}

/// A sine on every joint from rest at [`POSE`], `amplitude` (rad) at `w` (rad/s).
struct Sine {
    amplitude: JointVector<4>,
    w: f64,
}

impl ReferenceSource<4> for Sine {
    fn reference(&self, t: f64) -> Reference<4> {
        let w = self.w;
        Reference {
            q: JointVector::from(POSE) + self.amplitude * (1.0 - (w * t).cos()),
            qd: self.amplitude * (w * (w * t).sin()),
            qdd: self.amplitude * (w * w * (w * t).cos()),
        }
    }
    fn duration(&self) -> f64 {
        2.0
    }
}

/// Along a brisk motion, `feedforward` (inverse dynamics, back-EMF and friction into goal
/// offsets) tracks the plan better than `sag`, and `sag` better than `plain`, on the built-in
/// STS3215 with its counts, deadband and backlash.
#[test]
fn feedforward_tracks_a_motion_best_on_a_real_servo() {
    let sts = profiles::profile("sts3215").unwrap().spec;
    // The report's arm is heavier than an STS3215's arms: the servo gets 8 times the supply and
    // the current limit, its firmware and gear as they are.
    let spec = ServoSpec { max_torque: sts.max_torque * 8.0, supply_voltage: sts.supply_voltage * 8.0, ..sts };
    let sine = Sine { amplitude: JointVector::<4>::new(0.3, 0.15, 0.2, 0.15), w: 6.0 };
    let mut rms = Vec::new();
    for strategy in ServoCommand::ALL {
        let actuators = Actuators::servos([spec; 4]);
        let mut plant = Plant::new(actuators.plant_model(&report_arm()).unwrap());
        let mut host = ServoHost::new(strategy, report_arm(), Actuators::servos([spec; 4])).unwrap();
        // 100 Hz on the bus; the RMS from 0.5 s on (the loops' start-up transient decayed).
        let config = SimConfig { control_period: 0.01, actuators, tracking_from: 0.5, ..SimConfig::new(&plant) };
        let summary = simulate(&mut plant, &mut host, &sine, None, &[], &[], &config, &mut Vec::new()).unwrap();
        rms.push(summary.rms_joint_error.norm());
    }
    let [plain, sag, feedforward] = rms[..] else { unreachable!() };
    assert!(
        feedforward < 0.5 * sag && sag < plain,
        "RMS joint error: plain {plain}, sag {sag}, feedforward {feedforward}"
    );
}

/// A stepper as strong as the report's arm needs (the built-in NEMA 17 with about four times the
/// holding torque), no Coulomb friction, its step generator fast.
fn strong_stepper() -> StepperSpec {
    StepperSpec {
        holding_torque: 8.0,
        coulomb_friction: 0.0,
        viscous_friction: 0.5,
        max_speed: 10.0,
        max_acceleration: 2.0,
        corner_speed: 100.0,
        ..profiles::NEMA17.spec
    }
}

fn stepper_run(
    spec: StepperSpec,
    model: ArmModel<4>,
    reference: &dyn ReferenceSource<4>,
    initial: Option<JointState<4>>,
) -> (Vec<StepRecord<4>>, chessarm_core::sim::SimSummary<4>) {
    let actuators = Actuators { joints: [Actuator::Stepper(spec); 4] };
    let mut plant = Plant::new(actuators.plant_model(&model).unwrap());
    let mut host = ServoHost::new(ServoCommand::Plain, model, actuators).unwrap();
    // The wrist's spring rings at ≈ 1200 rad/s: half-millisecond steps follow it.
    let config = SimConfig { dt: 5e-4, control_period: 0.01, actuators, ..SimConfig::new(&plant) };
    let mut records = Vec::new();
    let summary = simulate(&mut plant, &mut host, reference, initial, &[], &[], &config, &mut records).unwrap();
    (records, summary)
}

/// A stepper holding a load lags its commanded angle by `asin(τ / τ_hold) / n` (its magnetic
/// spring's static angle): started there (the closed loop's default start), the simulated arm
/// stays put to 1e-9 rad over 3 s, and loses no step. (Its spring is lightly damped: started
/// elsewhere it would ring for many seconds.)
#[test]
fn a_loaded_stepper_lags_by_its_load_angle() {
    let spec = strong_stepper();
    let goal = JointVector::from(POSE);
    let held = Held { q: goal, wave: JointVector::zeros(), period: 0.0, duration: 3.0 };
    let (records, summary) = stepper_run(spec, report_arm(), &held, None);
    let plant = Actuators { joints: [Actuator::Stepper(spec); 4] }.plant_model(&report_arm()).unwrap();
    let first = records.first().unwrap();
    let commanded = first.servo.unwrap().target;
    let g = gravity_torques(&plant, &first.state.q);
    for j in 0..4 {
        let expected = spec.static_lag(g[j]).unwrap();
        let lag = commanded[j] - first.state.q[j];
        // The start is the fixed point of the lag formula (to 1e-12 rad) ...
        assert!((lag - expected).abs() < 1e-10, "joint {}: lag {lag} vs {expected}", j + 1);
        // ... and the dynamics keep it there.
        let moved = records.iter().map(|r| (r.state.q[j] - first.state.q[j]).abs()).fold(0.0, f64::max);
        assert!(moved < 1e-9, "joint {} moved {moved} rad", j + 1);
    }
    assert!(spec.static_lag(g[1]).unwrap().abs() > 1e-4, "the shoulder carries load");
    assert_eq!(summary.lost_steps, [0; 4]);
    // The commanded angles are whole microsteps.
    for value in commanded.iter() {
        let steps = value / spec.resolution();
        assert!((steps - steps.round()).abs() < 1e-6);
    }
}

/// A load beyond the holding torque pulls the rotor from well to well: every slip is four full
/// steps lost, counted with its sign, and the joint falls; the same stepper 25 % stronger holds.
#[test]
fn a_stepper_beyond_its_holding_torque_loses_steps() {
    let goal = JointVector::from(POSE);
    let held = Held { q: goal, wave: JointVector::zeros(), period: 0.0, duration: 1.0 };
    let g_shoulder = gravity_torques(&report_arm(), &goal)[1].abs();
    for (factor, holds) in [(1.25, true), (0.8, false)] {
        let spec = StepperSpec { holding_torque: g_shoulder * factor, ..strong_stepper() };
        let (_, summary) = stepper_run(spec, report_arm(), &held, None);
        let lost = summary.lost_steps[1];
        if holds {
            assert_eq!(lost, 0, "factor {factor}");
        } else {
            assert!(lost.abs() >= 4 && lost % 4 == 0, "factor {factor}: lost {lost}");
            // The joint is that many steps' worth away from its command, within a well.
            let well = std::f64::consts::TAU / spec.electrical_per_output();
            let drop = (summary.final_state.q[1] - goal[1]).abs();
            assert!(drop > (lost.abs() as f64 / 4.0 - 0.5) * well, "drop {drop} rad for {lost} steps");
        }
    }
}

/// The pull-out torque falls above the corner speed: a load the stepper holds at rest makes it
/// lose steps when the step generator drives it fast enough that `τ_hold ω_c / ω` is below it.
#[test]
fn a_stepper_driven_past_its_pull_out_torque_loses_steps() {
    let base = JointVector::from(POSE);
    // The shoulder swings ±0.5 rad in 4 s (0.5 rad/s on the ramps of the triangle).
    let sweep = Held { q: base, wave: JointVector::<4>::new(0.0, 0.5, 0.0, 0.0), period: 4.0, duration: 4.0 };
    let g_shoulder = gravity_torques(&report_arm(), &base)[1].abs();
    let slow = StepperSpec { holding_torque: 2.0 * g_shoulder, corner_speed: 10.0, ..strong_stepper() };
    let (_, at_low_speed) = stepper_run(slow, report_arm(), &sweep, None);
    assert_eq!(at_low_speed.lost_steps, [0; 4]);
    // Above a corner of 0.1 rad/s the pull-out torque at 0.5 rad/s is 2 g × 0.1 / 0.5 = 0.4 g:
    // the shoulder must slip.
    let fast = StepperSpec { corner_speed: 0.1, ..slow };
    let (_, past_corner) = stepper_run(fast, report_arm(), &sweep, None);
    assert!(past_corner.lost_steps[1] != 0, "lost {:?}", past_corner.lost_steps);
}

/// A time step the stepper's spring outruns is refused, naming the joint and the step to use.
#[test]
fn a_time_step_too_long_for_a_stepper_is_refused() {
    let actuators = Actuators { joints: [Actuator::Stepper(strong_stepper()); 4] };
    let mut plant = Plant::new(actuators.plant_model(&report_arm()).unwrap());
    let mut host = ServoHost::new(ServoCommand::Plain, report_arm(), actuators).unwrap();
    let config = SimConfig { control_period: 0.01, actuators, ..SimConfig::new(&plant) };
    let held = Held { q: JointVector::from(POSE), wave: JointVector::zeros(), period: 0.0, duration: 0.1 };
    let error =
        simulate(&mut plant, &mut host, &held, None, &[], &[], &config, &mut Vec::new()).unwrap_err().to_string();
    assert!(error.contains("joint 4's stepper rings at") && error.contains("use a time step of at most"), "{error}");
}

/// Sent far away on the base yaw (no gravity, no friction), a servo's output speeds up to its
/// no-load speed `u_max V / kt`, where the back-EMF leaves no current, and no further; and at
/// stall the current limit, not the winding, caps its torque.
#[test]
fn a_servo_runs_at_its_no_load_speed_and_stalls_at_its_current_limit() {
    let spec = ServoSpec { supply_voltage: 6.0, max_torque: 5.0, kp: 50.0, ..ideal() };
    let no_load = spec.no_load_speed();
    let start = JointVector::from(POSE);
    let held = Held {
        q: start + JointVector::<4>::new(2.5, 0.0, 0.0, 0.0),
        wave: JointVector::zeros(),
        period: 0.0,
        duration: 2.0,
    };
    let out = run([spec; 4], report_arm(), ServoCommand::Plain, &held, Some(JointState::at_rest(start)));
    let fastest = out.records.iter().map(|r| r.state.qd[0]).fold(0.0, f64::max);
    // 3 rad/s at full duty; the approach is exponential, 2.5 rad leave time for 99 % of it.
    // Up to 1e-4 over it: the drive is held over each 1 ms step while the speed changes (the
    // mechanical time constant is 80 ms).
    assert!(fastest <= no_load * (1.0 + 1e-4) && fastest > 0.99 * no_load, "fastest {fastest} rad/s vs {no_load}");
    // At the start (at rest, full duty) the winding would give u V kt / R = 12 N·m; the current
    // limit lets 5 through.
    let first = out.records[0].torque[0];
    assert!((first - spec.max_torque).abs() < 1e-12, "torque at rest {first}");
    assert!(spec.max_duty * spec.torque_per_duty() > 2.0 * spec.max_torque);
}

/// A trial's actuator draw: every factor within its range, the supply's one factor on every
/// servo, the firmware's constants untouched, the same seed the same servos, and nothing drawn
/// (the nominal servos, the generator not advanced) without a spread.
#[test]
fn a_drawn_servo_lies_within_its_spread_and_keeps_its_firmware() {
    use chessarm_core::arm::uncertainty::Range;
    use chessarm_core::sense::rng::SeededRng;
    use chessarm_core::sim::actuator::ActuatorSpread;
    let nominal = Actuators::servos([profiles::profile("sts3215-12v").unwrap().spec; 4]);
    let spread = ActuatorSpread {
        torque_constant: 0.1,
        resistance: 0.15,
        supply_voltage: 0.08,
        friction: 0.5,
        backlash: Some(Range::new(0.0, 0.035)),
        holding_torque: 0.0,
    };
    let mut rng = SeededRng::new(7);
    let (drawn, what) = spread.draw(&nominal, &mut rng).unwrap();
    let (again, _) = spread.draw(&nominal, &mut SeededRng::new(7)).unwrap();
    assert_eq!(drawn, again);
    assert!((what.supply_voltage_scale - 1.0).abs() <= 0.08);
    for (j, (joint, base)) in drawn.joints.iter().zip(&nominal.joints).enumerate() {
        let (Actuator::Servo(spec), Actuator::Servo(base)) = (joint, base) else { panic!("servos") };
        assert_eq!(spec.supply_voltage, base.supply_voltage * what.supply_voltage_scale);
        assert!((spec.torque_constant / base.torque_constant - 1.0).abs() <= 0.1);
        assert!((spec.resistance / base.resistance - 1.0).abs() <= 0.15);
        assert!((spec.coulomb_friction / base.coulomb_friction - 1.0).abs() <= 0.5);
        assert_eq!(spec.coulomb_friction / base.coulomb_friction, spec.viscous_friction / base.viscous_friction);
        assert!((0.0..=0.035).contains(&spec.backlash) && spec.backlash == what.backlash[j]);
        assert_eq!(
            (spec.kp, spec.max_duty, spec.counts_per_revolution),
            (base.kp, base.max_duty, base.counts_per_revolution)
        );
    }
    // Four servos, four different windings.
    let Actuator::Servo(first) = drawn.joints[0] else { unreachable!() };
    let Actuator::Servo(second) = drawn.joints[1] else { unreachable!() };
    assert_ne!(first.torque_constant, second.torque_constant);
    // No spread: the nominal servos, and the generator where it was.
    let mut untouched = SeededRng::new(7);
    let (same, _) = ActuatorSpread::default().draw(&nominal, &mut untouched).unwrap();
    assert_eq!(same, nominal);
    assert_eq!(untouched.uniform(0.0, 1.0), SeededRng::new(7).uniform(0.0, 1.0));
    // The firmware's current limit: its torque scales with the drawn torque constant.
    for (joint, base) in drawn.joints.iter().zip(&nominal.joints) {
        let (Actuator::Servo(spec), Actuator::Servo(base)) = (joint, base) else { unreachable!() };
        assert!((spec.max_torque / base.max_torque - spec.torque_constant / base.torque_constant).abs() < 1e-12);
    }
    // A backlash a servo cannot have is refused when the spread is read.
    let wide = ActuatorSpread { backlash: Some(Range::new(0.1, 0.6)), ..spread };
    assert!(wide.validate().unwrap_err().to_string().contains("uncertainty.backlash"));
    // A stepper's spread on servos, and a servo's on torque motors, are refused by name.
    let stepper_spread = ActuatorSpread { holding_torque: 0.2, ..ActuatorSpread::default() };
    assert!(stepper_spread.check_for(&nominal).unwrap_err().to_string().contains("uncertainty.holding_torque"));
    assert!(
        spread.check_for(&Actuators::<4>::torque()).unwrap_err().to_string().contains("uncertainty.torque_constant")
    );
}

/// The fine points' band with servos: widened to the band they hold still within (capped at
/// the tolerance), the speed band as the sensors': torque motors (band 0) keep the sensors'.
#[test]
fn servos_widen_the_fine_points_band_to_what_they_hold() {
    use chessarm_core::plan::fine_point::InPosition;
    let (tolerance, quantum) = (5e-3, 1e-4);
    let sensors = InPosition::for_sensors(tolerance, quantum);
    assert_eq!(InPosition::for_actuators(tolerance, quantum, 0.0), sensors);
    let servos = Actuators::servos([profiles::profile("xm430").unwrap().spec; 4]);
    let band = servos.holding_band(&report_arm());
    // Each servo rests within a count, its deadband and its friction's share of its stiffness:
    // at least a count's lever on the shoulder alone.
    let Actuator::Servo(spec) = servos.joints[1] else { unreachable!() };
    let reach: f64 = (1..4).map(|i| report_arm().link(i).dh.a.abs()).sum();
    assert!(band >= spec.resolution() * reach, "{band}");
    let gate = InPosition::for_actuators(tolerance, quantum, band);
    assert_eq!(gate.tip_band, sensors.tip_band.max(band.min(tolerance)));
    assert_eq!((gate.speed_band, gate.timeout), (sensors.speed_band, sensors.timeout));
    assert_eq!(InPosition::for_actuators(tolerance, quantum, 1.0).tip_band, tolerance);
    assert_eq!(Actuators::<4>::torque().holding_band(&report_arm()), 0.0);
}
