//! Many independent closed-loop runs at once: `L` runs side by side in SIMD lanes (structure of
//! arrays), for sweeps and Monte-Carlo campaigns.
//!
//! The plant of every lane steps on the structured dynamics ([`super::structured`] with
//! `S = Lanes<L>`); each lane keeps its own controller, sensors, estimator, torque hold, motor
//! lag, payload events and metrics (`closed_loop::Run`, the scalar simulator's own
//! code), except in a batch of plain computed-torque runs that see the exact state or Kalman
//! estimates (`lane_law`): there the controllers' laws, the filters and the metrics are
//! computed in lanes too, by the same generic formulas as the scalar code's, and the sensors
//! too where they draw alike (each lane's noise from its run's own generator). A lane that
//! finishes or fails is masked — its state frozen, its result kept — while the others go on. Each lane's
//! [`SimSummary`] equals what [`super::simulate_sensed`] computes for the same run, bit for
//! bit, at every lane count and SIMD level: the kernels are the same IEEE operations in the
//! same order (see [`crate::lanes`]).
//!
//! A run whose plant is not of the yaw–pitch family, or whose time step or integrator differs
//! from its batch's, is simulated alone by the scalar simulator; so is the whole slice when the
//! lane count is 1.

use super::closed_loop::{PlantView, ReferenceNow, Run, SimConfig, SimError, SimSummary, diverged_lanes, limit_torque};
use super::lane_law::LaneLaw;
use super::plant::Integrator;
use super::structured::{self, Failures, Start, State};
use super::{NoObserver, PayloadEvent, Plant, ReferenceSource};
use crate::arm::dynamics::{DynamicsError, DynamicsTerms, MassMatrix};
use crate::arm::model::{ArmModel, JointVector};
use crate::arm::yaw_pitch::YawPitch;
use crate::control::{Controller, JointState};
pub use crate::lanes::SimdLevel;
use crate::lanes::{Lanes, Real, array4};
use crate::sense::Feedback;
use nalgebra::Vector3;

/// One run of a batch: what [`super::simulate_sensed`] takes, owned where it is per run.
pub struct LaneRun<'a> {
    pub plant: ArmModel<4>,
    pub feedback: Feedback<4>,
    pub controller: Box<dyn Controller<4> + 'a>,
    pub reference: &'a (dyn ReferenceSource<4> + Sync),
    pub initial: Option<JointState<4>>,
    pub events: &'a [PayloadEvent],
    pub marks: &'a [f64],
    pub config: SimConfig<4>,
}

impl std::fmt::Debug for LaneRun<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LaneRun").field("controller", &self.controller.name()).finish_non_exhaustive()
    }
}

impl LaneRun<'_> {
    /// This run alone, on the scalar simulator.
    pub fn simulate_alone(&mut self) -> Result<SimSummary<4>, SimError> {
        self.simulate_alone_at(SimdLevel::for_one_run())
    }

    /// [`LaneRun::simulate_alone`] with the plant's kernels at `level`.
    pub fn simulate_alone_at(&mut self, level: SimdLevel) -> Result<SimSummary<4>, SimError> {
        let mut plant = Plant::new(self.plant).with_simd_level(level);
        super::simulate_sensed(
            &mut plant,
            &mut self.feedback,
            self.controller.as_mut(),
            self.reference,
            self.initial,
            self.events,
            self.marks,
            &self.config,
            &mut NoObserver,
        )
    }
}

/// How many runs share a batch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LaneCount {
    /// One at a time, on the scalar simulator.
    One,
    /// Four side by side (one AVX2 register of f64).
    Four,
    /// Eight side by side (one AVX-512 register, two AVX2 ones): the default.
    #[default]
    Eight,
}

impl LaneCount {
    pub const ALL: [LaneCount; 3] = [LaneCount::One, LaneCount::Four, LaneCount::Eight];

    pub fn get(self) -> usize {
        match self {
            LaneCount::One => 1,
            LaneCount::Four => 4,
            LaneCount::Eight => 8,
        }
    }

    /// From a count as typed (1, 4 or 8).
    pub fn from_count(count: usize) -> Option<Self> {
        Self::ALL.into_iter().find(|lanes| lanes.get() == count)
    }
}

/// Simulates every run of `runs`, `lanes` at a time at SIMD level `level`, and returns their
/// results in order. The results do not depend on `lanes` or `level`.
pub fn simulate_lanes(
    runs: &mut [LaneRun<'_>],
    lanes: LaneCount,
    level: SimdLevel,
) -> Vec<Result<SimSummary<4>, SimError>> {
    let mut results = Vec::with_capacity(runs.len());
    let width = lanes.get();
    let mut rest = runs;
    while !rest.is_empty() {
        // A batch: the next runs that can share the first one's batch, up to `width`.
        let batchable = |run: &LaneRun<'_>| run.plant.yaw_pitch().is_some();
        let first = &rest[0];
        let take = if width == 1 || !batchable(first) {
            1
        } else {
            rest.iter()
                .take(width)
                .take_while(|run| {
                    batchable(run)
                        && run.config.dt == first.config.dt
                        && run.config.integrator == first.config.integrator
                })
                .count()
                // A NaN time step equals nothing, itself included: such a run goes alone, to
                // the scalar simulator's error.
                .max(1)
        };
        let (batch, tail) = rest.split_at_mut(take);
        rest = tail;
        if take == 1 {
            results.push(batch[0].simulate_alone_at(level));
        } else if width == 4 {
            results.extend(simulate_batch::<4>(batch, level));
        } else {
            results.extend(simulate_batch::<8>(batch, level));
        }
    }
    results
}

/// Whether a batch of `runs` (at most 8) would compute its controllers' laws in lanes, whether
/// also its Kalman filters, and whether also its sensors (`(laws, filters, sensors)`), as
/// [`simulate_lanes`] decides: for tests that the fast paths are taken. Resets the runs'
/// controllers and feedback.
#[doc(hidden)]
pub fn takes_in_lanes(runs: &mut [LaneRun<'_>]) -> (bool, bool, bool) {
    let mut loops: Vec<_> = runs
        .iter_mut()
        .map(|run| {
            let LaneRun { plant, feedback, controller, reference, initial, events, marks, config } = run;
            Run::new(feedback, controller.as_mut(), *reference, *initial, events, marks, config, plant).ok()
        })
        .collect();
    match LaneLaw::<8>::of(&mut loops) {
        Some(law) => (true, law.estimates(), law.reads()),
        None => (false, false, false),
    }
}

/// Writes lane `lane` of the batch's constants from one arm's.
fn set_lane<const L: usize>(batch: &mut YawPitch<Lanes<L>>, lane: usize, arm: &YawPitch<f64>) {
    let mut lanes: [YawPitch<f64>; L] = [*arm; L];
    for (i, slot) in lanes.iter_mut().enumerate() {
        if i != lane {
            *slot = batch.lane(i);
        }
    }
    *batch = YawPitch::gather(std::array::from_fn(|i| &lanes[i]));
}

/// The lanes' joint states side by side.
fn lane_state<const L: usize>(states: &[JointState<4>; L]) -> State<Lanes<L>> {
    State {
        q: lanes_of(states.map(|s| std::array::from_fn(|j| s.q[j]))),
        qd: lanes_of(states.map(|s| std::array::from_fn(|j| s.qd[j]))),
    }
}

/// Lane `i` of four lane vectors, entry by entry into registers (`from_fn` stored the entries
/// one by one, and the copies that followed waited on the stores).
#[inline(always)]
fn lane_vector<const L: usize>(values: &[Lanes<L>; 4], i: usize) -> JointVector<4> {
    JointVector::<4>::from([values[0].get(i), values[1].get(i), values[2].get(i), values[3].get(i)])
}

fn lanes_of<const L: usize>(values: [[f64; 4]; L]) -> [Lanes<L>; 4] {
    std::array::from_fn(|j| Lanes(std::array::from_fn(|i| values[i][j])))
}

/// The dynamics at the lanes' states, into `start`, compiled for `level`: with the inverse of
/// `M` for a plant's start, or (`with_inverse` false) `M` and the bias alone for controllers'
/// terms ([`Start::set_terms`]). Returns, with the inverse, the lanes whose `M` is not
/// positive definite (tested at the level too: the baseline's compare takes ~250
/// instructions for 4 lanes).
fn set_start<const L: usize>(
    level: SimdLevel,
    model: &YawPitch<Lanes<L>>,
    start: &mut Start<Lanes<L>>,
    state: &State<Lanes<L>>,
    with_inverse: bool,
) -> u64 {
    // `inline(always)`: the closure's body is compiled inside pulp's function for the level,
    // with its instructions; a closure of its own would get the baseline's. Two functions, not
    // one: compiled together for 8 lanes at AVX2, the sines and cosines, `M` and its inverse
    // left LLVM splitting lanes 1 + 4 + 2 + 1 and spilling, 3.2 k instructions a batch-step
    // against 2.0 k apart (callgrind, `lanes_once 8 8`).
    level.run(
        #[inline(always)]
        || {
            start.set_terms(model, state);
        },
    );
    if !with_inverse {
        return 0;
    }
    level.run(
        #[inline(always)]
        || {
            let configuration = &mut start.configuration;
            configuration.inverse.set(&configuration.mass_matrix)
        },
    )
}

/// One step of every lane ([`structured::step`]), compiled for `level`, with the lanes whose
/// new state diverged, faster than their `runaway_speed` (rad/s) or not finite
/// ([`diverged_lanes`]).
#[allow(clippy::too_many_arguments)] // the step's own arguments and the level
fn step_lanes<const L: usize>(
    level: SimdLevel,
    model: &YawPitch<Lanes<L>>,
    start: &mut Start<Lanes<L>>,
    state: &State<Lanes<L>>,
    torque: &[Lanes<L>; 4],
    (dt, integrator, runaway_speed): (f64, Integrator, Lanes<L>),
    failures: &mut Failures<L>,
) -> (State<Lanes<L>>, u64) {
    level.run(
        #[inline(always)]
        || {
            let next = structured::step(model, start, state, torque, dt, integrator, failures);
            let diverged = diverged_lanes(&next.q, &next.qd, runaway_speed);
            (next, diverged)
        },
    )
}

/// Lane `i`'s `M` and `C q̇ + g` at the start of the step.
fn terms_of<const L: usize>(start: &Start<Lanes<L>>, i: usize) -> DynamicsTerms<4> {
    let matrix = &start.configuration.mass_matrix;
    DynamicsTerms {
        mass_matrix: MassMatrix::from_fn(|r, c| matrix[r][c].get(i)),
        bias: JointVector::from_fn(|j, _| start.bias[j].get(i)),
    }
}

/// The structure of a lane's controller's model, or `plant`'s where it has none of the family.
fn controller_arm<C, R>(lane: Option<&Run<'_, 4, C, R>>, plant: &YawPitch<f64>) -> YawPitch<f64>
where
    C: Controller<4> + ?Sized,
    R: ReferenceSource<4> + ?Sized,
{
    lane.and_then(|lane| lane.controller_model()).and_then(ArmModel::yaw_pitch).copied().unwrap_or(*plant)
}

/// The error of a lane whose plant's `M` is not positive definite at `q` (rad), at `time` (s).
fn not_positive_definite_at(time: f64, q: impl Iterator<Item = f64>) -> SimError {
    SimError::Dynamics { time, source: DynamicsError::NotPositiveDefinite(q.collect()) }
}

/// Where a batch runs its runs' Kalman filters in lanes ([`LaneLaw::estimate`]): each lane's
/// sensors read its plant's state (in lanes where the runs' sensors draw alike,
/// [`LaneLaw::read_and_estimate`], else lane by lane), then the filters update in lanes,
/// compiled for `level`. A lane of `not_positive_definite` fails before its sample, as the
/// scalar run does before its sensors read: its filter and sensors are handed their state from
/// before the sample (in lanes they read on, unread). Returns the estimates.
fn estimate_in_lanes<const L: usize, C, R>(
    level: SimdLevel,
    law: &mut LaneLaw<L>,
    loops: &mut [Option<Run<'_, 4, C, R>>],
    state: &State<Lanes<L>>,
    not_positive_definite: u64,
) -> State<Lanes<L>>
where
    C: Controller<4> + ?Sized,
    R: ReferenceSource<4> + ?Sized,
{
    let in_lanes = law.reads();
    // Lanes that read nothing take readings of zero (finite, so the filters stay in lanes).
    let (mut q, mut qd) = ([Lanes::splat(0.0); 4], [Lanes::splat(0.0); 4]);
    for (i, slot) in loops.iter_mut().enumerate() {
        let Some(lane) = slot.as_mut() else { continue };
        if not_positive_definite & (1 << i) != 0 {
            law.hand_back_feedback(i, lane);
        } else if !in_lanes {
            let reading = lane.measure();
            for j in 0..4 {
                q[j].0[i] = reading.q[j];
                qd[j].0[i] = reading.qd.map_or(f64::NAN, |qd| qd[j]);
            }
        }
    }
    level
        .run(
            #[inline(always)]
            || if in_lanes { law.read_and_estimate(state) } else { law.estimate((&q, &qd), state) },
        )
        .unwrap_or_else(|| unreachable!("called where the batch runs the estimators"))
}

/// The controllers' samples, the torques and the metrics of every lane at once ([`LaneLaw`])
/// at the plant's `state` (the metrics) as the controllers `seen` it (the exact state, or the
/// filters' estimates), with the plant's and (for the lanes of `own`) the controllers' models'
/// terms; the lanes of `not_positive_definite` fail (their plant's `M` is not positive
/// definite). Each lane's torque over the coming step goes to `torques`; a lane that fails (its
/// plant's `M` not positive definite, a non-finite command) or finishes leaves `loops` with
/// its result. Returns how many lanes go on.
#[allow(clippy::too_many_arguments)] // the lanes' loops, results, models, state and terms
fn control_in_lanes<const L: usize, C, R>(
    level: SimdLevel,
    law: &mut LaneLaw<L>,
    loops: &mut [Option<Run<'_, 4, C, R>>],
    results: &mut [Option<Result<SimSummary<4>, SimError>>],
    models: &[ArmModel<4>; L],
    (state, seen): (&State<Lanes<L>>, &State<Lanes<L>>),
    (start, own_terms): (&Start<Lanes<L>>, &Start<Lanes<L>>),
    (own, not_positive_definite): (u64, u64),
    limits: &[Lanes<L>; 4],
    torques: &mut [[f64; 4]; L],
) -> usize
where
    C: Controller<4> + ?Sized,
    R: ReferenceSource<4> + ?Sized,
{
    let Some(first) = loops.iter().flatten().next() else { return 0 };
    // Every lane is at the same step of the same reference, with the same control period and
    // tracking start ([`LaneLaw::of`]).
    let (period, tracked, finished) = (first.config.control_period, first.tracked(), first.finished());
    // The reference sample and tip as the reference returns them, not copied on into a
    // `ReferenceNow`: the copy's wide loads right after its entry-by-entry stores waited for
    // them (a quarter of this function's own samples).
    let time = first.time();
    let (desired, desired_tip) = first.reference().reference_and_tip(time);
    // The torques, and their clipping as each run's `sample` clips them: the lanes whose
    // command is not finite (`refused`) are sampled by their run, which refuses them.
    let (raw, command, clipped, refused) = level.run(
        #[inline(always)]
        || {
            let raw = law.torque((&seen.q, &seen.qd), start, own_terms, own, &desired, period);
            let command = array4(|j| raw[j].each2(limits[j], limit_torque));
            let clipped = array4(|j| command[j].lanes_where2(raw[j], |command, raw| command != raw));
            let refused = raw.iter().fold(0, |lanes, raw| lanes | raw.lanes_where(|raw| !raw.is_finite()));
            (raw, command, clipped, refused)
        },
    );
    for (i, slot) in loops.iter_mut().enumerate() {
        let Some(lane) = slot.as_mut() else { continue };
        let outcome = if not_positive_definite & (1 << i) == 0 {
            // The lane's command from the lanes where they clipped it, never read back from the
            // run or from a value just built with it (each stores it entry by entry, and a wider
            // load right after waits for the stores to retire: ~4 % of a sweep's time).
            let in_lanes = refused & (1 << i) == 0;
            let sampled = if in_lanes {
                let joints = (0..4).fold(0, |joints, j| joints | ((clipped[j] >> i) & 1) << j);
                Ok(lane.take_clipped(lane_vector(&command, i), joints))
            } else {
                lane.sample(&raw.map(|v| v.get(i)))
            };
            match sampled {
                Ok(clipped) => {
                    let lane_command = if in_lanes { lane_vector(&command, i) } else { lane.command() };
                    law.sampled(i, clipped, &lane_command, || terms_of(own_terms, i));
                    torques[i] =
                        if in_lanes { std::array::from_fn(|j| command[j].get(i)) } else { lane_command.into() };
                }
                Err(_) => law.hand_back(i, lane),
            }
            sampled.map(|_| ())
        } else {
            // The scalar run fails before its controller's sample.
            law.hand_back_unsampled(i, lane);
            Err(not_positive_definite_at(lane.time(), (0..4).map(|j| state.q[j].get(i))))
        };
        if let Err(error) = outcome {
            results[i] = Some(Err(error));
            *slot = None;
        }
    }
    // The metrics, as `Run::control_at` records them (no motor lag: the torque is the command).
    let tip_desired: [Lanes<L>; 3] = match desired_tip {
        Some(desired) => std::array::from_fn(|k| Lanes::splat(desired[k])),
        None => {
            // Only the lanes that go on (a finished or failed lane's tip is not read).
            let tips: [Vector3<f64>; L] = std::array::from_fn(|i| match loops[i] {
                Some(_) => crate::arm::kinematics::FrameChain::new(&models[i], &desired.q).tip(),
                None => Vector3::zeros(),
            });
            std::array::from_fn(|k| Lanes(std::array::from_fn(|i| tips[i][k])))
        }
    };
    let torque = lanes_of(*torques);
    let (tip, tip_error) = level.run(
        #[inline(always)]
        || {
            let tip = start.configuration.tip_in_base();
            let error = array4(|j| Lanes::splat(desired.q[j]) - state.q[j]);
            let tip_error = super::closed_loop::tip_error(&tip, &tip_desired);
            law.tracking.record(&torque, &error, tip_error, tracked);
            (tip, tip_error)
        },
    );
    let mut active = 0;
    for (i, slot) in loops.iter_mut().enumerate() {
        let Some(lane) = slot.as_mut() else { continue };
        lane.mark(Vector3::new(tip[0].get(i), tip[1].get(i), tip[2].get(i)), tip_error.get(i));
        if finished {
            law.hand_back(i, lane);
            results[i] = slot.take().map(|lane| Ok(lane.summary_with(law.tracking.lane(i), law.estimate_errors(i))));
        } else {
            active += 1;
        }
    }
    active
}

/// Up to `L` runs (all of the family, with one time step and integrator) side by side; lanes
/// beyond `runs.len()` are idle from the start. The lanes' arithmetic runs at `level`; the
/// rest (controllers, sensors, events, metrics) lane by lane, or, where [`LaneLaw::of`] takes
/// the batch, the controllers' laws, their Kalman filters and sensors ([`estimate_in_lanes`])
/// and the metrics in lanes too ([`control_in_lanes`]).
fn simulate_batch<const L: usize>(runs: &mut [LaneRun<'_>], level: SimdLevel) -> Vec<Result<SimSummary<4>, SimError>> {
    let count = runs.len();
    let (dt, integrator) = (runs[0].config.dt, runs[0].config.integrator);
    let mut models: [ArmModel<4>; L] = std::array::from_fn(|i| runs[i.min(count - 1)].plant);
    let mut results: Vec<Option<Result<SimSummary<4>, SimError>>> = (0..count).map(|_| None).collect();
    let mut loops = Vec::with_capacity(count);
    for (i, run) in runs.iter_mut().enumerate() {
        let LaneRun { plant, feedback, controller, reference, initial, events, marks, config } = run;
        match Run::new(feedback, controller.as_mut(), *reference, *initial, events, marks, config, plant) {
            Ok(lane) => loops.push(Some(lane)),
            Err(error) => {
                results[i] = Some(Err(error));
                loops.push(None);
            }
        }
    }
    let structure =
        |model: &ArmModel<4>| *model.yaw_pitch().unwrap_or_else(|| unreachable!("batched runs are of the family"));
    let arms: [YawPitch<f64>; L] = std::array::from_fn(|i| structure(&models[i]));
    let mut fast = YawPitch::gather(std::array::from_fn(|i| &arms[i]));
    let mut states: [JointState<4>; L] = std::array::from_fn(|i| match loops.get(i) {
        Some(Some(lane)) => lane.state,
        _ => loops.iter().flatten().next().map_or(JointState::at_rest(JointVector::zeros()), |lane| lane.state),
    });
    let mut torques = [[0.0; 4]; L];
    // Each lane's torque limits (N·m) and runaway speed (rad/s); a lane without a run takes
    // another's (it is never read), or 1 where no run started.
    let config = |i: usize| {
        loops.get(i).and_then(Option::as_ref).or_else(|| loops.iter().flatten().next()).map(|lane| lane.config)
    };
    let limits: [Lanes<L>; 4] = array4(|j| Lanes::from_fn(|i| config(i).map_or(1.0, |c| c.torque_limits[j])));
    let runaway_speed = Lanes::from_fn(|i| config(i).map_or(1.0, |c| c.runaway_speed));
    let mut start = Start::new(&fast, &lane_state(&states));
    // The controllers' models where they are of the family (the plant's arm elsewhere, unused),
    // for their terms at the states they see, all lanes at once; refreshed when a payload
    // event may have changed them (`Controller::dynamics_model` changes only then).
    let mut controller_arms: [YawPitch<f64>; L] =
        std::array::from_fn(|i| loops.get(i).map_or(arms[i], |lane| controller_arm(lane.as_ref(), &arms[i])));
    let mut controller_fast = YawPitch::gather(std::array::from_fn(|i| &controller_arms[i]));
    // Only its `M` and bias are read (`terms_of`): its inverse is not kept up to date.
    let mut controller_start = start;
    // The controllers' laws and the metrics in lanes, where every run allows it.
    let mut law = LaneLaw::<L>::of(&mut loops);
    loop {
        // Payload events, lane by lane: the plant's model first, then the controller.
        for i in 0..count {
            let Some(lane) = loops[i].as_mut() else { continue };
            while let Some(event) = lane.due_event() {
                let applied = models[i]
                    .with_payload(event.payload)
                    .map_err(|source| SimError::Payload { time: lane.time(), source });
                let outcome = applied.and_then(|model| {
                    models[i] = model;
                    set_lane(&mut fast, i, &structure(&models[i]));
                    lane.apply_event(&event, &models[i])
                });
                if let Err(error) = outcome {
                    if let Some(law) = law.as_ref() {
                        law.hand_back(i, lane);
                    }
                    results[i] = Some(Err(error));
                    loops[i] = None;
                    break;
                }
                // Always refreshed (an event is rare): no comparison to treat −0 as +0.
                controller_arms[i] = controller_arm(Some(&*lane), &structure(&models[i]));
                set_lane(&mut controller_fast, i, &controller_arms[i]);
            }
        }
        let state = lane_state(&states);
        let not_positive_definite = set_start(level, &fast, &mut start, &state, true);
        // Where the batch runs the estimators: the sensors' readings (in lanes or lane by lane),
        // the filters in lanes.
        let estimate = match law.as_mut() {
            Some(law) if law.estimates() => {
                Some(estimate_in_lanes(level, law, &mut loops, &state, not_positive_definite))
            }
            _ => None,
        };
        // The controllers that compute their own terms this step: their feedback runs now and
        // their terms are computed in lanes, as each would compute them alone.
        // The lanes' views, gathered only where a lane's controller computes its own terms
        // without the lane law (its view is then what it sees, the plant's state or not).
        let mut views: Option<[JointState<4>; L]> = None;
        let mut wants_terms = 0u64;
        for i in 0..count {
            let Some(lane) = loops[i].as_mut() else { continue };
            if law.is_some() {
                // The exact state, or the estimate computed above; with an estimate the
                // controller computes its terms at it (as `Run::seen_for_terms` says).
                if estimate.is_some() || !lane.shares_terms() {
                    debug_assert!(
                        controller_arm(Some(&*lane), &arms[i]) == controller_arms[i],
                        "a controller's model changed outside `set_payload`"
                    );
                    wants_terms |= 1 << i;
                }
            } else if let Some((state, model)) = lane.seen_for_terms()
                && let Some(arm) = model.yaw_pitch()
            {
                debug_assert!(*arm == controller_arms[i], "a controller's model changed outside `set_payload`");
                views.get_or_insert(states)[i] = state;
                wants_terms |= 1 << i;
            }
        }
        // What the controllers see: the filters' estimates, the exact state (with the lane law),
        // or each lane's view gathered, which only the controllers' terms read. Borrowed, not
        // moved: a move copied 512 bytes a step.
        let gathered;
        let seen = match (&estimate, &views) {
            (Some(estimate), _) => estimate,
            // Gathered only without the lane law, for a lane that wants terms.
            (None, Some(views)) => {
                gathered = lane_state(views);
                &gathered
            }
            (None, _) => &state,
        };
        if wants_terms != 0 {
            set_start(level, &controller_fast, &mut controller_start, seen, false);
        }
        let mut active = 0;
        match law.as_mut() {
            Some(law) => {
                let terms = (&start, &controller_start);
                active = control_in_lanes(
                    level,
                    law,
                    &mut loops,
                    &mut results,
                    &models,
                    (&state, seen),
                    terms,
                    (wants_terms, not_positive_definite),
                    &limits,
                    &mut torques,
                );
            }
            None => {
                let tip = start.configuration.tip_in_base();
                // The reference sample of the last lane that took one: lanes on the same reference
                // (a sweep's, a campaign's) are at the same step, so they share it.
                let mut shared: Option<(&(dyn ReferenceSource<4> + Sync), ReferenceNow<4>)> = None;
                for i in 0..count {
                    let Some(lane) = loops[i].as_mut() else { continue };
                    let time = lane.time();
                    let outcome = if not_positive_definite & (1 << i) == 0 {
                        let plant_terms = terms_of(&start, i);
                        let view = PlantView {
                            tip: Vector3::new(tip[0].get(i), tip[1].get(i), tip[2].get(i)),
                            terms: &plant_terms,
                        };
                        let reference = lane.reference();
                        let now = match shared {
                            Some((last, now)) if std::ptr::eq(last, reference) => now,
                            _ => shared.insert((reference, lane.reference_now())).1,
                        };
                        let terms = (wants_terms & (1 << i) != 0).then(|| terms_of(&controller_start, i));
                        lane.control_at(&view, &models[i], &mut NoObserver, &now, terms.as_ref())
                    } else {
                        Err(not_positive_definite_at(time, states[i].q.iter().copied()))
                    };
                    match outcome {
                        Ok(torque) if !lane.finished() => {
                            torques[i] = torque.into();
                            active += 1;
                        }
                        Ok(_) => {
                            let finished = loops[i].take().map(Run::summary);
                            results[i] = finished.map(Ok);
                        }
                        Err(error) => {
                            results[i] = Some(Err(error));
                            loops[i] = None;
                        }
                    }
                }
            }
        }
        if active == 0 {
            break;
        }
        let torque = lanes_of(torques);
        let mut failures = Failures::<L> { lanes: 0, at: [[0.0; 4]; L] };
        let (next, diverged) =
            step_lanes(level, &fast, &mut start, &state, &torque, (dt, integrator, runaway_speed), &mut failures);
        for i in 0..count {
            let Some(lane) = loops[i].as_mut() else { continue };
            let stepped = JointState { q: lane_vector(&next.q, i), qd: lane_vector(&next.qd, i) };
            let advanced = if failures.lanes & (1 << i) != 0 {
                lane.advance(Err(DynamicsError::NotPositiveDefinite(failures.at[i].to_vec())))
            } else if diverged & (1 << i) != 0 {
                // The run's own check says why.
                lane.advance(Ok(stepped))
            } else {
                lane.advance_checked(stepped);
                Ok(())
            };
            match advanced {
                // The state the run now holds (`stepped`), not read back from it: a load right
                // after the run's entry-by-entry stores waits for them (~3 % of a sweep).
                Ok(()) => states[i] = stepped,
                Err(error) => {
                    if let Some(law) = law.as_ref() {
                        law.hand_back(i, lane);
                    }
                    results[i] = Some(Err(error));
                    loops[i] = None;
                }
            }
        }
        // Idle and finished lanes keep their last state (and hold no torque).
        for (i, torque) in torques.iter_mut().enumerate() {
            if i >= count || loops[i].is_none() {
                *torque = [0.0; 4];
            }
        }
    }
    results.into_iter().map(|result| result.unwrap_or_else(|| unreachable!("every lane ends with a result"))).collect()
}
