//! The closed loop: controller ⇄ (sensors, estimator) ⇄ plant.
//!
//! The plant is integrated every `dt` by a fixed-step fourth-order method (or another the
//! config names); the controller is sampled every
//! `control_period` (an integer multiple of `dt`) and sees the state through the sensors and
//! the estimator of a [`Feedback`] (the exact state with [`Feedback::ideal`]). Its torque,
//! clipped to the joint torque limits, is held in between (zero-order hold) and reaches the
//! joints through each motor's first-order lag, if it has one. Payload events grip or release objects at
//! given instants of the plan, or, at fine points ([`simulate_fine_points`]), once the arm is in
//! position there. Metrics accumulate on the fly; time series go to an [`Observer`] only if the
//! caller wants them, so a run allocates nothing per step.

use crate::arm::dynamics::{DynamicsError, DynamicsTerms};
use crate::arm::kinematics::FrameChain;
use crate::arm::model::{ArmModel, JointVector, ModelError, Payload};
use crate::control::{Controller, JointState, Reference};
use crate::lanes::Real;
use crate::plan::fine_point::{InPosition, Wait};
use crate::plan::trajectory::JointTrajectory;
use crate::sense::{Estimator, Feedback, JointKalman, Measurement};
use crate::sim::actuator::{Actuators, PositionBank, ServoRecord};
use crate::sim::integrator::Integrator;
use crate::sim::plant::Plant;
use nalgebra::Vector3;

/// The running error and torque metrics of one run (`S = f64`) or of `L` side by side
/// ([`crate::lanes::Lanes`], a batch's lanes), each lane's bits the scalar run's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Tracking<S, const N: usize> {
    /// Σ e² per joint over the tracked steps, rad².
    pub squared_joint_error: [S; N],
    /// max |e| per joint over the tracked steps, rad.
    pub max_joint_error: [S; N],
    /// Σ |tip error|² over the tracked steps, m².
    pub squared_tip_error: S,
    pub max_tip_error: S,
    /// Peak |τ| applied per joint, N·m.
    pub peak_torque: [S; N],
}

impl<S: Real, const N: usize> Tracking<S, N> {
    pub fn new() -> Self {
        let zero = S::splat(0.0);
        Self {
            squared_joint_error: [zero; N],
            max_joint_error: [zero; N],
            squared_tip_error: zero,
            max_tip_error: zero,
            peak_torque: [zero; N],
        }
    }

    /// One step's applied `torque` (N·m) and, if the step is `tracked`, its joint errors
    /// `error = q_d − q` (rad) and tip error (m).
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // the torques and errors indexed by joint, as the metrics
    pub fn record(&mut self, torque: &[S; N], error: &[S; N], tip_error: S, tracked: bool) {
        for j in 0..N {
            self.peak_torque[j] = self.peak_torque[j].sup(torque[j].abs());
        }
        if tracked {
            for j in 0..N {
                self.squared_joint_error[j] += error[j] * error[j];
                self.max_joint_error[j] = self.max_joint_error[j].sup(error[j].abs());
            }
            self.squared_tip_error += tip_error * tip_error;
            self.max_tip_error = self.max_tip_error.max(tip_error);
        }
    }

    /// Lane `i`'s metrics.
    pub fn lane(&self, i: usize) -> Tracking<f64, N> {
        Tracking {
            squared_joint_error: self.squared_joint_error.map(|v| v.lane(i)),
            max_joint_error: self.max_joint_error.map(|v| v.lane(i)),
            squared_tip_error: self.squared_tip_error.lane(i),
            max_tip_error: self.max_tip_error.lane(i),
            peak_torque: self.peak_torque.map(|v| v.lane(i)),
        }
    }
}

/// `|tip − desired|` (m) as nalgebra's `norm` computes it: `√((dx² + dy²) + dz²)`.
#[inline(always)]
pub(crate) fn tip_error<S: Real>(tip: &[S; 3], desired: &[S; 3]) -> S {
    let d: [S; 3] = [tip[0] - desired[0], tip[1] - desired[1], tip[2] - desired[2]];
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

/// `raw` clipped to `±limit`: `f64::clamp`'s steps (without its check of the bounds, which
/// are validated positive), so a batch's lanes clip as a run does.
#[inline(always)]
pub(crate) fn limit_torque(raw: f64, limit: f64) -> f64 {
    let mut torque = raw;
    if torque < -limit {
        torque = -limit;
    }
    if torque > limit {
        torque = limit;
    }
    torque
}

/// The controller's `raw` torque (N·m) clipped to `±limits`, counting the joints it clips in
/// `saturated_per_joint`, and whether it clipped any; or why the command is refused (a
/// non-finite entry), at time `t` (s).
pub(crate) fn clip_command<const N: usize>(
    raw: &[f64; N],
    limits: &JointVector<N>,
    saturated_per_joint: &mut [usize; N],
    t: f64,
) -> Result<(JointVector<N>, bool), SimError> {
    let mut command = JointVector::<N>::zeros();
    let mut clipped = false;
    for j in 0..N {
        if !raw[j].is_finite() {
            return Err(SimError::Diverged { time: t, joint: j + 1, quantity: "torque command", value: raw[j] });
        }
        command[j] = limit_torque(raw[j], limits[j]);
        if command[j] != raw[j] {
            saturated_per_joint[j] += 1;
            clipped = true;
        }
    }
    Ok((command, clipped))
}

/// Settings of a closed-loop run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimConfig<const N: usize> {
    /// Integration step, s (default 1 ms).
    pub dt: f64,
    /// Controller sample period, s (default 1 ms = 1 kHz); a multiple of `dt`.
    pub control_period: f64,
    /// Torque limits, N·m (default: the plant model's joint limits).
    pub torque_limits: JointVector<N>,
    /// A joint faster than this (rad/s) means the run diverged (default 100 rad/s).
    pub runaway_speed: f64,
    /// How the plant is integrated over each `dt` (default: Nyström's fourth-order method).
    pub integrator: Integrator,
    /// Start of the tracking metrics, s (default 0): the RMS and largest joint and tip errors
    /// count the steps from this instant on, so that a deliberate start-up transient (a run
    /// started off the trajectory) does not dominate them. Torques, saturation and the errors
    /// at the marks count over the whole run.
    pub tracking_from: f64,
    /// Per joint, the time constant of the motor's torque response, s (default 0: the
    /// command is applied at once). The motor torque follows the clipped command `τ_c` by the
    /// exact response of `T τ̇ + τ = τ_c`, `τ_{k+1} = τ_c + (τ_k − τ_c) e^{−dt/T}`, and the plant
    /// is given its mean over each integration step,
    /// `τ_c + (τ_k − τ_c)(T/dt)(1 − e^{−dt/T})`, held over the step.
    pub torque_lag: JointVector<N>,
    /// What drives each joint (default: torque motors, the command applied as above). With
    /// position servos ([`Actuators::servos`]) the controller is a host sending goal angles
    /// every `control_period` (the bus rate); each servo's firmware and gearmotor turn them into
    /// the torque on its joint ([`crate::sim::actuator::servo`]). The plant's model must then
    /// carry the servos' gears ([`Actuators::plant_model`]); `torque_limits` and `torque_lag`
    /// are the torque motors' and are not used.
    pub actuators: Actuators<N>,
    /// The servos' and steppers' state at the start: where a previous run of the same arm left
    /// them ([`SimSummary::actuators`]: a stepper's step count, a servo's target and backlash
    /// carry over, as on the robot). `None`: holding the host's first goal, settled.
    pub actuator_start: Option<PositionBank<N>>,
}

impl<const N: usize> SimConfig<N> {
    /// 1 ms steps of the default integrator, 1 kHz control, the plant's torque limits.
    pub fn new(plant: &Plant<N>) -> Self {
        Self {
            dt: 1e-3,
            control_period: 1e-3,
            torque_limits: plant.model().torque_limits(),
            runaway_speed: 100.0,
            integrator: Integrator::default(),
            tracking_from: 0.0,
            torque_lag: JointVector::zeros(),
            actuators: Actuators::torque(),
            actuator_start: None,
        }
    }

    /// Checks the numbers and returns the number of integration steps per controller sample.
    fn steps_per_sample(&self) -> Result<usize, SimError> {
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return Err(SimError::Config(format!("time step dt = {} s must be finite and > 0", self.dt)));
        }
        if !(self.control_period.is_finite() && self.control_period > 0.0) {
            return Err(SimError::Config(format!("control period {} s must be finite and > 0", self.control_period)));
        }
        let ratio = self.control_period / self.dt;
        let steps = ratio.round();
        if steps < 1.0 || (ratio - steps).abs() > 1e-9 * ratio {
            return Err(SimError::Config(format!(
                "control period {} s must be a whole multiple of the time step {} s",
                self.control_period, self.dt
            )));
        }
        if !(self.tracking_from.is_finite() && self.tracking_from >= 0.0) {
            return Err(SimError::Config(format!(
                "tracking metrics from t = {} s: must be finite and >= 0",
                self.tracking_from
            )));
        }
        if let Some((j, lag)) = self.torque_lag.iter().enumerate().find(|(_, l)| !(l.is_finite() && **l >= 0.0)) {
            return Err(SimError::Config(format!("torque lag of joint {} = {lag} s must be finite and >= 0", j + 1)));
        }
        if let Some((j, limit)) = self.torque_limits.iter().enumerate().find(|(_, l)| !(l.is_finite() && **l > 0.0)) {
            return Err(SimError::Config(format!(
                "torque limit of joint {} = {limit} N·m must be finite and > 0",
                j + 1
            )));
        }
        self.actuators.validate(self.dt).map_err(|e| SimError::Config(e.to_string()))?;
        Ok(steps as usize)
    }
}

/// A payload gripped (`Some`) or released (`None`) at `time` (s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PayloadEvent {
    pub time: f64,
    /// What the plant takes.
    pub payload: Option<Payload>,
    /// What the controller's model is told.
    pub told: Told,
}

/// What a controller's model is told at a payload event (it always learns that the gripper
/// closed or opened, [`Controller::gripper_changed`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Told {
    /// Nothing: its model keeps the payload it had.
    Nothing,
    /// Its model takes this payload: the plant's (a controller told the truth), or a nominal
    /// one (a robot that knows which piece it grips, not that piece's true mass).
    Payload(Option<Payload>),
}

impl PayloadEvent {
    /// The plant takes `payload` at `time` (s); the controller's model is told the same
    /// payload if `controller_knows`, else nothing.
    pub fn new(time: f64, payload: Option<Payload>, controller_knows: bool) -> Self {
        let told = if controller_knows { Told::Payload(payload) } else { Told::Nothing };
        Self { time, payload, told }
    }
}

/// Desired joint motion over time.
pub trait ReferenceSource<const N: usize> {
    fn reference(&self, t: f64) -> Reference<N>;
    /// The desired tool tip at `t`, m, if known without forward kinematics.
    fn desired_tip(&self, _t: f64) -> Option<Vector3<f64>> {
        None
    }
    /// [`ReferenceSource::reference`] and [`ReferenceSource::desired_tip`] at `t`, for a source
    /// that finds both in one look-up.
    fn reference_and_tip(&self, t: f64) -> (Reference<N>, Option<Vector3<f64>>) {
        (self.reference(t), self.desired_tip(t))
    }
    /// s.
    fn duration(&self) -> f64;
}

impl ReferenceSource<4> for JointTrajectory {
    fn reference(&self, t: f64) -> Reference<4> {
        let sample = self.held_at(t);
        Reference { q: sample.q, qd: sample.qd, qdd: sample.qdd }
    }

    fn desired_tip(&self, t: f64) -> Option<Vector3<f64>> {
        Some(self.held_at(t).position)
    }

    // Inlined into a closed loop generic over the trajectory (one run; a batch calls it
    // through `dyn`): returned through memory, the profile put the time at the caller's wide
    // load of the tip, stored entry by entry just before. One run 3.25 → 3.21 ms, fastest of
    // 300 back to back, near this VM's noise.
    #[inline(always)]
    fn reference_and_tip(&self, t: f64) -> (Reference<4>, Option<Vector3<f64>>) {
        let sample = self.held_at(t);
        (Reference { q: sample.q, qd: sample.qd, qdd: sample.qdd }, Some(sample.position))
    }

    fn duration(&self) -> f64 {
        JointTrajectory::duration(self)
    }
}

/// What happened at one integration step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepRecord<const N: usize> {
    pub t: f64,
    pub state: JointState<N>,
    /// The state the controller saw at its latest sample (the estimate; the exact state with
    /// ideal sensors).
    pub estimate: JointState<N>,
    pub reference: Reference<N>,
    /// Applied (saturated) torque, N·m: with servos, their motors' torque at the output, the
    /// back-EMF's included.
    pub torque: JointVector<N>,
    /// Tool tip, actual and desired (FK of the reference), m.
    pub tip: Vector3<f64>,
    pub tip_desired: Vector3<f64>,
    /// The servos' goals, targets, duties and backlash gaps, where servos drive the joints.
    pub servo: Option<ServoRecord<N>>,
}

/// Receives every step of a run.
pub trait Observer<const N: usize> {
    fn observe(&mut self, record: &StepRecord<N>);
}

/// An observer that keeps nothing.
#[derive(Debug, Default, Clone, Copy)]
pub struct NoObserver;

impl<const N: usize> Observer<N> for NoObserver {
    fn observe(&mut self, _record: &StepRecord<N>) {}
}

impl<const N: usize> Observer<N> for Vec<StepRecord<N>> {
    fn observe(&mut self, record: &StepRecord<N>) {
        self.push(*record);
    }
}

/// Why a run stopped.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    #[error("invalid simulation settings: {0}")]
    Config(String),
    #[error(
        "the simulation diverged at t = {time:.4} s: joint {joint} {quantity} = {value:.4e} (runaway or NaN); lower the gains or the time step"
    )]
    Diverged { time: f64, joint: usize, quantity: &'static str, value: f64 },
    #[error("at t = {time:.4} s: {source}")]
    Dynamics { time: f64, source: DynamicsError },
    #[error("payload event at t = {time:.4} s: {source}")]
    Payload { time: f64, source: ModelError },
}

/// Metrics of a run (SI: rad, m, N·m, s).
#[derive(Debug, Clone, PartialEq)]
pub struct SimSummary<const N: usize> {
    pub duration: f64,
    pub steps: usize,
    /// RMS and largest joint error over the tracked steps, rad.
    pub rms_joint_error: JointVector<N>,
    pub max_joint_error: JointVector<N>,
    /// RMS and largest tool-tip error over the tracked steps, m.
    pub rms_tip_error: f64,
    pub max_tip_error: f64,
    /// Steps the RMS and largest errors count (those from [`SimConfig::tracking_from`] on).
    pub tracked_steps: usize,
    /// Peak |τ| applied per joint.
    pub peak_torque: JointVector<N>,
    /// Controller samples at which at least one joint's torque was clipped.
    pub saturated_samples: usize,
    /// Per joint: controller samples at which its torque was clipped.
    pub saturated_per_joint: [usize; N],
    /// Actual tool tip at each requested instant (the `marks`), m.
    pub tip_at_marks: Vec<Vector3<f64>>,
    /// |actual − desired tip| at each mark, m.
    pub tip_error_at_marks: Vec<f64>,
    pub final_state: JointState<N>,
    /// RMS over the controller samples of the estimate's error (estimate − true), per joint:
    /// angles (rad) and rates (rad/s). Zero with ideal sensors.
    pub rms_angle_estimate_error: JointVector<N>,
    pub rms_rate_estimate_error: JointVector<N>,
    /// Full steps each joint's stepper lost (open loop, the host does not know), with their
    /// sign (positive: fell behind a rising command); 0 without steppers.
    pub lost_steps: [i64; N],
    /// The servos' and steppers' state at the end, to start the next run from
    /// ([`SimConfig::actuator_start`]); `None` with torque motors.
    pub actuators: Option<PositionBank<N>>,
}

/// Runs `controller` against `plant` along `reference` from `initial` (default: at rest on
/// the reference's first point) for the reference's duration, the controller seeing the exact
/// state.
///
/// `events` must be sorted by time; `marks` are instants (s) at which the tip position and
/// error are reported (e.g. grip and release).
#[allow(clippy::too_many_arguments)]
pub fn simulate<const N: usize, C, R, O>(
    plant: &mut Plant<N>,
    controller: &mut C,
    reference: &R,
    initial: Option<JointState<N>>,
    events: &[PayloadEvent],
    marks: &[f64],
    config: &SimConfig<N>,
    observer: &mut O,
) -> Result<SimSummary<N>, SimError>
where
    C: Controller<N> + ?Sized,
    R: ReferenceSource<N> + ?Sized,
    O: Observer<N> + ?Sized,
{
    simulate_sensed(plant, &mut Feedback::ideal(), controller, reference, initial, events, marks, config, observer)
}

/// [`simulate`] with the controller seeing the plant through `feedback`'s sensors and
/// estimator, which are reset to the initial state first. The estimator's motion-model input
/// is the controller's [`Controller::commanded_acceleration`] of the sample just ended.
#[allow(clippy::too_many_arguments)]
pub fn simulate_sensed<const N: usize, C, R, O>(
    plant: &mut Plant<N>,
    feedback: &mut Feedback<N>,
    controller: &mut C,
    reference: &R,
    initial: Option<JointState<N>>,
    events: &[PayloadEvent],
    marks: &[f64],
    config: &SimConfig<N>,
    observer: &mut O,
) -> Result<SimSummary<N>, SimError>
where
    C: Controller<N> + ?Sized,
    R: ReferenceSource<N> + ?Sized,
    O: Observer<N> + ?Sized,
{
    simulate_fine_points(plant, feedback, controller, reference, initial, events, marks, None, config, observer)
        .map(|(summary, _)| summary)
}

/// [`simulate_sensed`] with every payload event a fine point ([`crate::plan::fine_point`]):
/// when the plan reaches an event, it waits (the reference held at rest at the planned point)
/// until `gate` holds for the estimate the controller saw at its latest sample, through the
/// controller's model's kinematics (the plant's where the controller has none), or until the
/// gate's timeout. The run lasts the plan plus its waits; `marks` are instants of the plan (a
/// mark at an event is taken when the event goes ahead). Returns the metrics and each event's
/// wait, in order. Without a gate it is [`simulate_sensed`] (and no waits), whose scalar closed
/// loop this is.
#[allow(clippy::too_many_arguments)]
pub fn simulate_fine_points<const N: usize, C, R, O>(
    plant: &mut Plant<N>,
    feedback: &mut Feedback<N>,
    controller: &mut C,
    reference: &R,
    initial: Option<JointState<N>>,
    events: &[PayloadEvent],
    marks: &[f64],
    gate: Option<&InPosition>,
    config: &SimConfig<N>,
    observer: &mut O,
) -> Result<(SimSummary<N>, Vec<Wait>), SimError>
where
    C: Controller<N> + ?Sized,
    R: ReferenceSource<N> + ?Sized,
    O: Observer<N> + ?Sized,
{
    let gate = gate.map(|g| g.validated()).transpose().map_err(|e| SimError::Config(e.to_string()))?;
    let gate = gate.as_ref();
    let mut run = Run::new(feedback, controller, reference, initial, events, marks, config, plant.model())?;
    let mut waits = Vec::with_capacity(if gate.is_some() { events.len() } else { 0 });
    let mut waiting = None;
    loop {
        while let Some(event) = run.due_event() {
            if !gate_open(&mut run, plant.model(), gate, &mut waiting, &mut waits) {
                break;
            }
            plant.set_payload(event.payload).map_err(|source| SimError::Payload { time: run.time(), source })?;
            run.apply_event(&event, plant.model())?;
        }
        plant.evaluate(&run.state).map_err(|source| SimError::Dynamics { time: run.time(), source })?;
        let at_state = plant.evaluated();
        let view = PlantView { tip: at_state.tip(), terms: at_state.terms() };
        let torque = run.control(&view, plant.model(), observer)?;
        if run.finished() {
            break;
        }
        // A stepper's pull is evaluated at every stage of the step; anything else is held.
        let next = match run.steppers() {
            Some(bank) => plant.step_with(&run.state, |q, qd| bank.torque_at(q, qd), run.dt, run.config.integrator),
            None => plant.step(&run.state, &torque, run.dt, run.config.integrator),
        };
        run.advance(next)?;
    }
    Ok((run.summary(), waits))
}

/// Where an event is in its fine point's wait: the step the plan reached it.
#[derive(Debug, Clone, Copy)]
struct Waiting {
    event: usize,
    since: usize,
}

/// Whether the event due now may go ahead: without a gate, always; with one, when the estimate
/// is in position or the wait has lasted the timeout (the wait is then pushed to `waits`).
fn gate_open<const N: usize, C, R>(
    run: &mut Run<'_, N, C, R>,
    plant: &ArmModel<N>,
    gate: Option<&InPosition>,
    waiting: &mut Option<Waiting>,
    waits: &mut Vec<Wait>,
) -> bool
where
    C: Controller<N> + ?Sized,
    R: ReferenceSource<N> + ?Sized,
{
    let Some(gate) = gate else { return true };
    let event = run.next_event_index();
    let since = match *waiting {
        Some(w) if w.event == event => w.since,
        _ => run.step,
    };
    let model = run.controller_model().copied().unwrap_or(*plant);
    let estimate = run.estimate();
    let now = run.reference_now();
    let target = now.tip.unwrap_or_else(|| FrameChain::new(&model, &now.desired.q).tip());
    let check = InPosition::measure(&model, &estimate.q, &estimate.qd, &target);
    let waited = (run.step - since) as f64 * run.dt;
    let in_position = gate.holds(&check);
    let timed_out = waited + 0.5 * run.dt >= gate.timeout;
    if in_position || timed_out {
        let reached = since as f64 * run.dt;
        waits.push(Wait { event, reached, duration: waited, timed_out: timed_out && !in_position, check });
        *waiting = None;
        true
    } else {
        *waiting = Some(Waiting { event, since });
        run.hold();
        false
    }
}

/// What the closed loop needs of the plant at the current state: the tool tip (m) and the
/// plant's `M` and `C q̇ + g` (handed to a controller with the plant's model).
#[derive(Debug, Clone, Copy)]
pub(crate) struct PlantView<'a, const N: usize> {
    pub tip: Vector3<f64>,
    /// Where the plant keeps them, not a copy (the profile put a copy's time at its loads,
    /// right after the plant's stores).
    pub terms: &'a crate::arm::dynamics::DynamicsTerms<N>,
}

/// A reference at one step ([`Run::reference_now`]): the desired joint state, and the desired
/// tip (m) where the reference knows it without forward kinematics.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ReferenceNow<const N: usize> {
    pub desired: Reference<N>,
    pub tip: Option<Vector3<f64>>,
}

/// One closed-loop run between plant steps: the controller, sensors and estimator, the torque
/// hold and motor lag, the payload events and the metrics. The driver ([`simulate_sensed`] with
/// one [`Plant`], or [`super::batch`] with a lane of a batched plant) evaluates and steps the
/// plant; everything else happens here, in the same order for both, so a lane's metrics are
/// the scalar run's bit for bit.
pub(crate) struct Run<'a, const N: usize, C: ?Sized, R: ?Sized> {
    feedback: &'a mut Feedback<N>,
    controller: &'a mut C,
    reference: &'a R,
    events: &'a [PayloadEvent],
    pub config: SimConfig<N>,
    pub dt: f64,
    steps_per_sample: usize,
    pub steps: usize,
    /// The step about to be taken (`0..=steps`).
    pub step: usize,
    pub state: JointState<N>,
    exact: bool,
    estimate: JointState<N>,
    applied_acceleration: JointVector<N>,
    command: JointVector<N>,
    lag_decay: JointVector<N>,
    lag_mean: JointVector<N>,
    has_lag: bool,
    motor_torque: JointVector<N>,
    /// The servos and steppers, where they drive the joints.
    servos: Option<PositionBank<N>>,
    squared_angle_estimate_error: JointVector<N>,
    squared_rate_estimate_error: JointVector<N>,
    samples_taken: usize,
    first_tracked_step: usize,
    tracking: Tracking<f64, N>,
    saturated_samples: usize,
    saturated_per_joint: [usize; N],
    mark_steps: Vec<usize>,
    tip_at_marks: Vec<Vector3<f64>>,
    tip_error_at_marks: Vec<f64>,
    next_event: usize,
    controller_shares_terms: bool,
    /// Whether [`Run::seen_for_terms`] has already run the feedback for the current sample.
    observed: bool,
    /// Steps at which the reference was held at a fine point ([`Run::hold`]) so far: the plan's
    /// time is `(step − held_steps) dt`.
    held_steps: usize,
    /// Whether the reference is held at the current step.
    holding: bool,
}

impl<const N: usize, C: ?Sized, R: ?Sized> std::fmt::Debug for Run<'_, N, C, R> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Run").field("step", &self.step).field("state", &self.state).finish_non_exhaustive()
    }
}

impl<'a, const N: usize, C, R> Run<'a, N, C, R>
where
    C: Controller<N> + ?Sized,
    R: ReferenceSource<N> + ?Sized,
{
    /// Checks the settings and the initial state (default: at rest on the reference's first
    /// point) and resets the controller and the feedback. `plant` is the plant's model.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        feedback: &'a mut Feedback<N>,
        controller: &'a mut C,
        reference: &'a R,
        initial: Option<JointState<N>>,
        events: &'a [PayloadEvent],
        marks: &[f64],
        config: &SimConfig<N>,
        plant: &ArmModel<N>,
    ) -> Result<Self, SimError> {
        let steps_per_sample = config.steps_per_sample()?;
        let dt = config.dt;
        let steps = (reference.duration() / dt).round();
        if steps > crate::plan::path::MAX_SAMPLES as f64 {
            return Err(SimError::Config(format!(
                "{} s at a time step of {dt} s is more than {} steps; use a larger time step",
                reference.duration(),
                crate::plan::path::MAX_SAMPLES
            )));
        }
        let steps = steps as usize;
        if controller.interface() != config.actuators.interface() {
            return Err(SimError::Config(format!(
                "the controller sends {} but the joints' actuators take {}",
                interface_name(controller.interface()),
                interface_name(config.actuators.interface())
            )));
        }
        let positions = config.actuators.take_positions();
        if positions {
            let wanted = config.actuators.plant_model(plant).map_err(|e| SimError::Config(e.to_string()))?;
            if wanted.links() != plant.links() {
                return Err(SimError::Config(
                    "the plant's model must carry the servos' gears (armature, friction, back-EMF): build it with Actuators::plant_model"
                        .into(),
                ));
            }
        }
        let first = reference.reference(0.0);
        // Servos start as they hold the host's first goal: at rest where gravity leaves them.
        let (state, servos) = match (positions, config.actuator_start) {
            (false, _) => (initial.unwrap_or_else(|| JointState::at_rest(first.q)), None),
            // Where the previous run left the actuators (and the arm, if it says).
            (true, Some(bank)) => {
                if bank.actuators() != config.actuators {
                    return Err(SimError::Config(
                        "the actuators' start state is of other actuators than the run's".into(),
                    ));
                }
                let state = initial.unwrap_or_else(|| JointState::at_rest(first.q));
                check_stepper_springs(&config.actuators, plant, &state.q, dt)?;
                (state, Some(bank.restarted(dt)))
            }
            (true, None) => {
                controller.reset();
                let goal = controller.command(&JointState::at_rest(first.q), &first, config.control_period);
                let limits = plant.links().map(|l| l.limits);
                let (lower, upper) = (limits.map(|l| l.lower).into(), limits.map(|l| l.upper).into());
                // The goals as the bus carries them (whole counts), then where they hold the arm.
                let sent = PositionBank::holding(&config.actuators, dt, plant, &goal, &first.q)
                    .expect("every joint takes positions")
                    .send(&goal, &lower, &upper);
                let q = initial.map_or_else(|| PositionBank::settled(&config.actuators, plant, &sent), |s| s.q);
                let state = initial.unwrap_or_else(|| JointState::at_rest(q));
                check_stepper_springs(&config.actuators, plant, &state.q, dt)?;
                let mut bank = PositionBank::holding(&config.actuators, dt, plant, &sent, &q)
                    .expect("every joint takes positions");
                bank.send(&sent, &lower, &upper);
                (state, Some(bank))
            }
        };
        if let Some((j, value)) = state.q.iter().chain(state.qd.iter()).enumerate().find(|(_, v)| !v.is_finite()) {
            let what = if j < N { "angle" } else { "rate" };
            return Err(SimError::Config(format!("initial joint {} {what} = {value} must be finite", j % N + 1)));
        }
        controller.reset();
        feedback.reset(&state);
        let exact = feedback.is_exact();
        // Per joint: e^{−dt/T} (the decay over a step) and (T/dt)(1 − e^{−dt/T}) (the mean over
        // a step of the decaying part).
        let lag_decay = config.torque_lag.map(|lag| if lag > 0.0 { (-dt / lag).exp() } else { 0.0 });
        let lag_mean = config.torque_lag.map(|lag| if lag > 0.0 { lag / dt * (1.0 - (-dt / lag).exp()) } else { 0.0 });
        let has_lag = config.torque_lag.iter().any(|lag| *lag > 0.0);
        // The first step at or after `tracking_from` (to the nearest step, like the marks).
        let first_tracked_step = ((config.tracking_from / dt).round() as usize).min(steps);
        // Each mark belongs to the step nearest to it, once (a mark half-way between two steps
        // goes to one of them, whatever the rounding of its time). Unreached marks stay NaN.
        let mark_steps: Vec<usize> = marks.iter().map(|mark| (mark / dt).round().max(0.0) as usize).collect();
        // The plant's M and C q̇ + g at each step are the first stage of its integrator; a
        // controller with the same model gets them too instead of computing them again.
        let controller_shares_terms = controller.dynamics_model() == Some(plant);
        Ok(Self {
            feedback,
            controller,
            reference,
            events,
            config: *config,
            dt,
            steps_per_sample,
            steps,
            step: 0,
            state,
            exact,
            estimate: state,
            applied_acceleration: JointVector::zeros(),
            command: JointVector::zeros(),
            lag_decay,
            lag_mean,
            has_lag,
            motor_torque: JointVector::zeros(),
            servos,
            squared_angle_estimate_error: JointVector::zeros(),
            squared_rate_estimate_error: JointVector::zeros(),
            samples_taken: 0,
            first_tracked_step,
            tracking: Tracking::new(),
            saturated_samples: 0,
            saturated_per_joint: [0; N],
            tip_at_marks: vec![Vector3::repeat(f64::NAN); marks.len()],
            tip_error_at_marks: vec![f64::NAN; marks.len()],
            mark_steps,
            next_event: 0,
            controller_shares_terms,
            observed: false,
            held_steps: 0,
            holding: false,
        })
    }

    /// The time of the current step, s.
    pub fn time(&self) -> f64 {
        self.step as f64 * self.dt
    }

    /// The plan's time at the current step, s: [`Run::time`] less the steps the reference was
    /// held at fine points ([`Run::hold`]).
    pub fn plan_time(&self) -> f64 {
        (self.step - self.held_steps) as f64 * self.dt
    }

    /// Whether the current step is the run's last (nothing to integrate after it).
    pub fn finished(&self) -> bool {
        // A fine point's wait at the plan's last step goes on (the step is held).
        self.step == self.steps + self.held_steps && !self.holding
    }

    /// The next payload event due at the current step of the plan, if any; the driver applies
    /// it to the plant, then hands it to [`Run::apply_event`].
    pub fn due_event(&self) -> Option<PayloadEvent> {
        let t = self.plan_time();
        self.events.get(self.next_event).filter(|event| event.time <= t + 0.5 * self.dt).copied()
    }

    /// Holds the reference over the current step: the plan's time stays where it is and the
    /// desired state is its point at rest (a fine point's wait).
    pub fn hold(&mut self) {
        self.holding = true;
    }

    /// The position actuators, if any joint has a stepper (whose torque the plant evaluates at
    /// every stage, [`PositionBank::torque_at`]).
    pub fn steppers(&self) -> Option<&PositionBank<N>> {
        self.servos.as_ref().filter(|bank| bank.has_steppers())
    }

    /// The index of the next payload event, due or not.
    pub fn next_event_index(&self) -> usize {
        self.next_event
    }

    /// The state the controller saw at its latest sample (the estimate; the exact state with
    /// ideal sensors).
    pub fn estimate(&self) -> JointState<N> {
        self.estimate
    }

    /// Tells the controller about an event the plant (now `plant`) has taken.
    pub fn apply_event(&mut self, event: &PayloadEvent, plant: &ArmModel<N>) -> Result<(), SimError> {
        if let Told::Payload(payload) = event.told {
            self.controller.set_payload(payload).map_err(|source| SimError::Payload { time: self.time(), source })?;
        }
        self.controller.gripper_changed(event.payload.is_some());
        self.next_event += 1;
        self.controller_shares_terms = self.controller.dynamics_model() == Some(plant);
        Ok(())
    }

    /// The model the controller computes its dynamics with, if any
    /// ([`Controller::dynamics_model`]).
    pub fn controller_model(&self) -> Option<&ArmModel<N>> {
        self.controller.dynamics_model()
    }

    /// The reference this run follows.
    pub fn reference(&self) -> &'a R {
        self.reference
    }

    /// The reference at the current step: the desired joint state and, where the reference
    /// knows it, the desired tip.
    pub fn reference_now(&self) -> ReferenceNow<N> {
        let t = self.plan_time();
        let (mut desired, tip) = self.reference.reference_and_tip(t);
        if self.holding {
            desired.qd = JointVector::zeros();
            desired.qdd = JointVector::zeros();
        }
        ReferenceNow { desired, tip }
    }

    /// The controller's sample (when one is due), the torque over the coming step (after the
    /// motors' lag) and the metrics of the current step, which `observer` sees. `at_state` is the
    /// plant at [`Run::state`], `plant` its model.
    pub fn control<O: Observer<N> + ?Sized>(
        &mut self,
        at_state: &PlantView<'_, N>,
        plant: &ArmModel<N>,
        observer: &mut O,
    ) -> Result<JointVector<N>, SimError> {
        let now = self.reference_now();
        self.control_at(at_state, plant, observer, &now, None)
    }

    /// Runs the feedback (sensors and estimator) for the state the controller sees, and the
    /// estimate's error statistics.
    fn observe(&mut self) {
        let state = self.state;
        if self.exact {
            self.estimate = state;
            return;
        }
        self.estimate = self.feedback.observe(&state, &self.applied_acceleration);
        let error_q = self.estimate.q - state.q;
        let error_qd = self.estimate.qd - state.qd;
        self.squared_angle_estimate_error += error_q.component_mul(&error_q);
        self.squared_rate_estimate_error += error_qd.component_mul(&error_qd);
    }

    /// At a controller sample where the controller computes its own `M̂` and `Ĉ q̇ + ĝ` (it
    /// sees an estimate, or its model is not the plant's): runs the feedback now and returns
    /// the state the controller sees, and its model (of any arm), for the driver to compute
    /// the terms ([`crate::arm::dynamics::DynamicsTerms::new`]) and hand them to
    /// [`Run::control_at`], which must follow at the same step (with or without the terms). A
    /// batch computes them for all its lanes at once. `None` where no sample is due, the
    /// controller shares the plant's terms, or it has no model.
    pub fn seen_for_terms(&mut self) -> Option<(JointState<N>, &ArmModel<N>)> {
        let due = self.step.is_multiple_of(self.steps_per_sample);
        if !due || (self.exact && self.controller_shares_terms) || self.controller.dynamics_model().is_none() {
            return None;
        }
        if !self.observed {
            self.observe();
            self.observed = true;
        }
        self.controller.dynamics_model().map(|model| (self.estimate, model))
    }

    /// [`Run::control`] with the reference at the current step given (`now`, what
    /// [`Run::reference_now`] returns: a batch's lanes on one reference sample it once) and,
    /// after [`Run::seen_for_terms`], the controller's terms at the state it sees.
    pub fn control_at<O: Observer<N> + ?Sized>(
        &mut self,
        at_state: &PlantView<'_, N>,
        plant: &ArmModel<N>,
        observer: &mut O,
        now: &ReferenceNow<N>,
        controller_terms: Option<&DynamicsTerms<N>>,
    ) -> Result<JointVector<N>, SimError> {
        let (t, step, state) = (self.time(), self.step, self.state);
        let period = self.config.control_period;
        let desired = now.desired;
        let tip = at_state.tip;
        // The command held over the step: a new sample's from where it was clipped, not read
        // back from `self.command` (the profile put the time at that wider load, right after
        // the entries' stores; one run 3.97 → 3.86 ms, fastest of 300, near this VM's noise).
        let command = if step.is_multiple_of(self.steps_per_sample) {
            let raw = if self.exact && self.controller_shares_terms {
                self.estimate = state;
                self.controller.command_with_terms(&state, &desired, period, at_state.terms)
            } else {
                if !self.observed {
                    self.observe();
                }
                self.observed = false;
                let seen = self.estimate;
                match controller_terms {
                    Some(terms) => self.controller.command_with_terms(&seen, &desired, period, terms),
                    None => self.controller.command(&seen, &desired, period),
                }
            };
            if let Some(servos) = &mut self.servos {
                // Goal angles onto the bus: checked, inside the joints' limits, in counts.
                if let Some((j, value)) = raw.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                    return Err(SimError::Diverged { time: t, joint: j + 1, quantity: "goal angle", value: *value });
                }
                let limits = plant.links().map(|l| l.limits);
                self.samples_taken += 1;
                self.command = servos.send(&raw, &limits.map(|l| l.lower).into(), &limits.map(|l| l.upper).into());
                if !self.exact {
                    self.applied_acceleration = acceleration_of(&*self.controller, &self.estimate, &raw, false, None);
                }
                self.command
            } else {
                let (command, clipped) = self.clip(&raw.into())?;
                if !self.exact {
                    self.applied_acceleration =
                        acceleration_of(&*self.controller, &self.estimate, &command, clipped, controller_terms);
                }
                command
            }
        } else {
            self.command
        };
        // What the plant is given over the step (a servo's held drive), and what the joints'
        // motors exert now, recorded (they differ by a servo's back-EMF, which the plant adds).
        let mut applied = None;
        let torque = if let Some(servos) = &mut self.servos {
            let saturated = servos.update(step, &state.q, &state.qd, self.dt);
            if saturated != 0 {
                self.saturated_samples += 1;
                for (j, count) in self.saturated_per_joint.iter_mut().enumerate() {
                    *count += ((saturated >> j) & 1) as usize;
                }
            }
            applied = Some(servos.motor_torque(&state.q, &state.qd));
            servos.torque_at(&state.q, &state.qd)
        } else if self.has_lag {
            // The exact response of T τ̇ + τ = τ_c over the step, held as its mean (what
            // the step integrates): τ̄ = τ_c + (τ_k − τ_c)(T/dt)(1 − e^{−dt/T}),
            // τ_{k+1} = τ_c + (τ_k − τ_c) e^{−dt/T}.
            let gap = self.motor_torque - command;
            self.motor_torque = command + gap.component_mul(&self.lag_decay);
            command + gap.component_mul(&self.lag_mean)
        } else {
            command
        };
        let error = desired.q - state.q;
        let tip_desired = now.tip.unwrap_or_else(|| FrameChain::new(plant, &desired.q).tip());
        let tip_error = tip_error(&tip.into(), &tip_desired.into());
        let applied = applied.unwrap_or(torque);
        self.tracking.record(&applied.into(), &error.into(), tip_error, self.tracked());
        self.mark(tip, tip_error);
        observer.observe(&StepRecord {
            t,
            state,
            estimate: self.estimate,
            reference: desired,
            torque: applied,
            tip,
            tip_desired,
            servo: self.servos.as_ref().map(|bank| bank.record(&state.q, &state.qd)),
        });
        Ok(torque)
    }

    /// A controller sample's `raw` torque (N·m): clipped to the torque limits into the command
    /// held until the next sample, and counted. Whether it clipped, or why it is refused.
    pub fn sample(&mut self, raw: &[f64; N]) -> Result<bool, SimError> {
        self.clip(raw).map(|(_, clipped)| clipped)
    }

    /// [`Run::sample`], with the command it now holds.
    fn clip(&mut self, raw: &[f64; N]) -> Result<(JointVector<N>, bool), SimError> {
        self.samples_taken += 1;
        let t = self.time();
        let (command, clipped) = clip_command(raw, &self.config.torque_limits, &mut self.saturated_per_joint, t)?;
        self.command = command;
        self.saturated_samples += usize::from(clipped);
        Ok((command, clipped))
    }

    /// [`Run::sample`] of a finite raw command that a batch clipped in lanes, as
    /// [`clip_command`] does: `command` (N·m) is the clipped command, bit `j` of
    /// `clipped_joints` whether joint `j`'s was clipped. Returns whether any was.
    pub(crate) fn take_clipped(&mut self, command: JointVector<N>, clipped_joints: u64) -> bool {
        self.samples_taken += 1;
        self.command = command;
        for (j, count) in self.saturated_per_joint.iter_mut().enumerate() {
            *count += ((clipped_joints >> j) & 1) as usize;
        }
        let clipped = clipped_joints != 0;
        self.saturated_samples += usize::from(clipped);
        clipped
    }

    /// Whether a batch may run this run's feedback, controller sample, torque and metrics in
    /// lanes ([`super::batch`]): the controller samples at every step, the motors have no lag,
    /// and the controller sees the exact state or the estimate of a Kalman filter
    /// ([`Run::kalman`]). (The batch also asks for the plain computed-torque law.)
    pub fn runs_in_lanes(&self) -> bool {
        self.steps_per_sample == 1 && !self.has_lag && self.servos.is_none() && (self.exact || self.kalman().is_some())
    }

    /// Whether the controller sees the plant's exact state.
    pub fn is_exact(&self) -> bool {
        self.exact
    }

    /// The Kalman filter between the sensors and the controller, if that is the estimator.
    pub fn kalman(&self) -> Option<&JointKalman<N>> {
        match &self.feedback.estimator {
            Estimator::Kalman(filter) if !self.exact => Some(filter),
            _ => None,
        }
    }

    /// [`Run::kalman`], to hand it back its state.
    pub fn kalman_mut(&mut self) -> Option<&mut JointKalman<N>> {
        match &mut self.feedback.estimator {
            Estimator::Kalman(filter) if !self.exact => Some(filter),
            _ => None,
        }
    }

    /// The sensors' reading due at this sample ([`crate::sense::Sensors::measure`] of the
    /// plant's state), for a batch that runs the estimator in lanes.
    pub fn measure(&mut self) -> Measurement<N> {
        self.feedback.sensors.measure(&self.state)
    }

    /// The run's sensors, for a batch that reads them in lanes.
    pub(crate) fn sensors(&self) -> &crate::sense::Sensors<N> {
        &self.feedback.sensors
    }

    /// [`Run::sensors`], to hand them back their state.
    pub(crate) fn sensors_mut(&mut self) -> &mut crate::sense::Sensors<N> {
        &mut self.feedback.sensors
    }

    /// The first step the RMS and largest errors count.
    pub fn first_tracked_step(&self) -> usize {
        self.first_tracked_step
    }

    /// Whether the controller takes the plant's `M` and `C q̇ + g` (its model is the plant's).
    pub fn shares_terms(&self) -> bool {
        self.controller_shares_terms
    }

    /// The controller as the plain computed-torque law, if it is one
    /// ([`Controller::as_computed_torque`]).
    pub fn as_computed_torque(&mut self) -> Option<&mut crate::control::computed_torque::ComputedTorque<N>> {
        self.controller.as_computed_torque()
    }

    /// The metrics of a run whose steps a batch recorded in lanes ([`Run::runs_in_lanes`]):
    /// `tracking` is its lane's, and `estimate_errors` the sums of the squared angle and rate
    /// errors of its estimates where the batch ran its estimator (rad², rad²/s²).
    pub fn summary_with(
        mut self,
        tracking: Tracking<f64, N>,
        estimate_errors: Option<(JointVector<N>, JointVector<N>)>,
    ) -> SimSummary<N> {
        self.tracking = tracking;
        if let Some((angle, rate)) = estimate_errors {
            self.squared_angle_estimate_error = angle;
            self.squared_rate_estimate_error = rate;
        }
        self.summary()
    }

    /// Whether the current step counts in the RMS and largest errors.
    pub fn tracked(&self) -> bool {
        self.step >= self.first_tracked_step
    }

    /// The tip (m) and its error (m) at the current step, if a mark falls on it: a mark is an
    /// instant of the plan, and where the reference is held there ([`Run::hold`]), the last
    /// held step's (the instant the plan goes on) stays.
    pub fn mark(&mut self, tip: Vector3<f64>, tip_error: f64) {
        let plan_step = self.step - self.held_steps;
        for (k, &mark_step) in self.mark_steps.iter().enumerate() {
            if mark_step == plan_step {
                self.tip_at_marks[k] = tip;
                self.tip_error_at_marks[k] = tip_error;
            }
        }
    }

    /// Takes the plant's state after the step (or why the step failed) and moves to the next.
    pub fn advance(&mut self, next: Result<JointState<N>, DynamicsError>) -> Result<(), SimError> {
        let t = self.time();
        self.state = next.map_err(|source| SimError::Dynamics { time: t, source })?;
        check_state(&self.state, t + self.dt, self.config.runaway_speed)?;
        if let Some(bank) = &mut self.servos {
            bank.after_step(&self.state.q);
        }
        self.step += 1;
        if self.holding {
            self.held_steps += 1;
            self.holding = false;
        }
        Ok(())
    }

    /// Brings a run whose steps a batch took in lanes up to date ([`super::batch`]): at `step`
    /// with `state`, after `samples` controller samples taken in lanes since it was last
    /// brought up to date (checked and clipped there, as [`Run::take_clipped`] takes them),
    /// `saturated` of them clipped, `saturated_per_joint` per joint. The held command is left
    /// as it was: the batch samples in lanes only runs that sample at every step without a
    /// motor lag ([`Run::runs_in_lanes`]), whose command nothing reads.
    pub(crate) fn catch_up(
        &mut self,
        step: usize,
        state: JointState<N>,
        samples: usize,
        (saturated, saturated_per_joint): (usize, &[usize; N]),
    ) {
        self.step = step;
        self.state = state;
        self.samples_taken += samples;
        self.saturated_samples += saturated;
        for (count, clipped) in self.saturated_per_joint.iter_mut().zip(saturated_per_joint) {
            *count += clipped;
        }
    }

    /// The time (s) of the next payload event, due or not, if any is left.
    pub(crate) fn next_event_time(&self) -> Option<f64> {
        self.events.get(self.next_event).map(|event| event.time)
    }

    /// The steps the marks fall on ([`Run::mark`]).
    pub(crate) fn mark_steps(&self) -> &[usize] {
        &self.mark_steps
    }

    /// The metrics of the finished run.
    pub fn summary(self) -> SimSummary<N> {
        let steps = self.steps + self.held_steps;
        let tracked_steps = steps + 1 - self.first_tracked_step;
        let samples = tracked_steps as f64;
        let sampled = self.samples_taken.max(1) as f64;
        SimSummary {
            duration: steps as f64 * self.dt,
            steps,
            rms_joint_error: (JointVector::from(self.tracking.squared_joint_error) / samples).map(f64::sqrt),
            max_joint_error: self.tracking.max_joint_error.into(),
            rms_tip_error: (self.tracking.squared_tip_error / samples).sqrt(),
            max_tip_error: self.tracking.max_tip_error,
            tracked_steps,
            peak_torque: self.tracking.peak_torque.into(),
            saturated_samples: self.saturated_samples,
            saturated_per_joint: self.saturated_per_joint,
            tip_at_marks: self.tip_at_marks,
            tip_error_at_marks: self.tip_error_at_marks,
            final_state: self.state,
            rms_angle_estimate_error: (self.squared_angle_estimate_error / sampled).map(f64::sqrt),
            rms_rate_estimate_error: (self.squared_rate_estimate_error / sampled).map(f64::sqrt),
            lost_steps: self.servos.as_ref().map_or([0; N], PositionBank::lost_steps),
            actuators: self.servos,
        }
    }
}

/// Refuses a time step too long for a stepper's magnetic spring: its ringing frequency on the
/// joint's inertia at `q`, `ω = √(n τ_hold / M_jj)`, must keep `ω dt ≤ 1` (a fourth-order
/// integrator's error per step is then below 1 % of the oscillation; at `ω dt ≈ 2` it rings up).
fn check_stepper_springs<const N: usize>(
    actuators: &Actuators<N>,
    plant: &ArmModel<N>,
    q: &JointVector<N>,
    dt: f64,
) -> Result<(), SimError> {
    let mass = crate::arm::dynamics::mass_matrix(plant, q);
    for (j, joint) in actuators.joints.iter().enumerate() {
        if let crate::sim::actuator::Actuator::Stepper(spec) = joint {
            let stiffness = spec.electrical_per_output() * spec.holding_torque;
            let omega = (stiffness / mass[(j, j)]).sqrt();
            if omega * dt > 1.0 {
                return Err(SimError::Config(format!(
                    "joint {}'s stepper rings at {omega:.0} rad/s ({stiffness:.0} N·m/rad on {:.3e} kg·m²): a time step of {dt} s cannot follow it; use a time step of at most {:.1e} s",
                    j + 1,
                    mass[(j, j)],
                    1.0 / omega
                )));
            }
        }
    }
    Ok(())
}

/// How a message names what a command interface carries.
fn interface_name(interface: crate::control::CommandInterface) -> &'static str {
    match interface {
        crate::control::CommandInterface::Torque => "joint torques",
        crate::control::CommandInterface::Position => "goal positions",
    }
}

/// The joint acceleration the controller's command will produce as its model predicts it, the
/// estimator's input for the coming sample: the controller's own `v`, unless the command was
/// clipped, when its model's `M̂⁻¹(τ_clipped − N̂)` at the state it saw (only then computed, and
/// only if the controller has a model), rad/s².
fn acceleration_of<const N: usize, C: Controller<N> + ?Sized>(
    controller: &C,
    seen: &JointState<N>,
    clipped_command: &JointVector<N>,
    clipped: bool,
    terms: Option<&DynamicsTerms<N>>,
) -> JointVector<N> {
    let commanded = controller.commanded_acceleration().unwrap_or_else(JointVector::zeros);
    if !clipped {
        return commanded;
    }
    match controller.dynamics_model() {
        Some(model) => {
            let terms = terms.copied().unwrap_or_else(|| DynamicsTerms::new(model, &seen.q, &seen.qd));
            clipped_acceleration(commanded, clipped_command, &terms)
        }
        None => commanded,
    }
}

/// The acceleration a clipped command produces as the controller's model predicts it,
/// `M̂⁻¹(τ_clipped − N̂)` with its terms, rad/s²; `commanded` where `M̂` is not positive
/// definite.
pub(crate) fn clipped_acceleration<const N: usize>(
    commanded: JointVector<N>,
    clipped_command: &JointVector<N>,
    terms: &DynamicsTerms<N>,
) -> JointVector<N> {
    crate::arm::mass_matrix::MassMatrixFactor::new(&terms.mass_matrix)
        .map_or(commanded, |factor| factor.solve(&(clipped_command - terms.bias)))
}

/// The lanes whose state [`check_state`] refuses (bit `i` for lane `i`): a non-finite angle,
/// or a rate that is NaN or faster than the lane's `runaway_speed` (rad/s).
#[inline(always)]
pub(crate) fn diverged_lanes<S: Real>(q: &[S; 4], qd: &[S; 4], runaway_speed: S) -> u64 {
    let mut diverged = 0;
    for j in 0..4 {
        diverged |= q[j].lanes_where(|q| !q.is_finite())
            | qd[j].lanes_where2(runaway_speed, |qd, runaway| qd.is_nan() || qd.abs() > runaway);
    }
    diverged
}

fn check_state<const N: usize>(state: &JointState<N>, time: f64, runaway_speed: f64) -> Result<(), SimError> {
    for j in 0..N {
        if !state.q[j].is_finite() {
            return Err(SimError::Diverged { time, joint: j + 1, quantity: "angle", value: state.q[j] });
        }
        if state.qd[j].is_nan() || state.qd[j].abs() > runaway_speed {
            return Err(SimError::Diverged { time, joint: j + 1, quantity: "rate", value: state.qd[j] });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lanes::Lanes;

    /// The batch's checks in lanes refuse what the run's own refuse: `diverged_lanes` against
    /// `check_state`, and `limit_torque` against `f64::clamp`, on values around the bounds
    /// and the special ones.
    #[test]
    fn the_checks_in_lanes_equal_the_runs() {
        let values = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            99.9,
            100.0,
            100.0f64.next_up(),
            -100.5,
            1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        let runaway = 100.0;
        let mut diverged_seen = 0;
        for (a, &q) in values.iter().enumerate() {
            for (b, &qd) in values.iter().enumerate() {
                // Eight lanes, each a state with `q` or `qd` in one joint of four.
                let lane_state = |i: usize| {
                    let mut state = JointState::<4>::at_rest(JointVector::from_element(0.5));
                    let j = i % 4;
                    if i < 4 {
                        state.q[j] = q
                    } else {
                        state.qd[j] = qd
                    }
                    state
                };
                let qs: [Lanes<8>; 4] = std::array::from_fn(|j| Lanes::from_fn(|i| lane_state(i).q[j]));
                let qds: [Lanes<8>; 4] = std::array::from_fn(|j| Lanes::from_fn(|i| lane_state(i).qd[j]));
                let lanes = diverged_lanes(&qs, &qds, Lanes::splat(runaway));
                for i in 0..8 {
                    let refused = check_state(&lane_state(i), 0.0, runaway).is_err();
                    assert_eq!(lanes & (1 << i) != 0, refused, "q {q}, qd {qd} (pair {a}, {b}), lane {i}");
                    diverged_seen += usize::from(refused);
                }
            }
            for limit in [1.0, 100.0, 1e-3] {
                if q.is_nan() {
                    assert!(limit_torque(q, limit).is_nan());
                } else {
                    assert_eq!(limit_torque(q, limit).to_bits(), q.clamp(-limit, limit).to_bits(), "{q} to {limit}");
                }
            }
        }
        assert!(diverged_seen > 0);
    }
}
