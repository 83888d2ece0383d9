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
use super::integrator::Integrator;
use super::lane_law::LaneLaw;
use super::structured::{self, Failures, Start, State};
use super::{NoObserver, PayloadEvent, Plant, ReferenceSource};
use crate::arm::dynamics::{DynamicsError, DynamicsTerms};
use crate::arm::mass_matrix::MassMatrix;
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
        // Servos and steppers run alone (their firmware and a stepper's pull per stage are the
        // scalar loop's).
        let batchable = |run: &LaneRun<'_>| run.plant.yaw_pitch().is_some() && !run.config.actuators.take_positions();
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

/// One step of every lane ([`structured::step`]) into `next`, compiled for `level`. Returns
/// the lanes whose new state diverged, faster than their `runaway_speed` (rad/s) or not finite
/// ([`diverged_lanes`]). (Written into `next`, not returned: the return was a 512-byte copy.)
#[allow(clippy::too_many_arguments)] // the step's own arguments and the level
fn step_lanes<const L: usize>(
    level: SimdLevel,
    model: &YawPitch<Lanes<L>>,
    start: &mut Start<Lanes<L>>,
    state: &State<Lanes<L>>,
    torque: &[Lanes<L>; 4],
    (dt, integrator, runaway_speed): (f64, Integrator, Lanes<L>),
    failures: &mut Failures<L>,
    next: &mut State<Lanes<L>>,
) -> u64 {
    level.run(
        #[inline(always)]
        || {
            *next = structured::step(model, start, state, torque, dt, integrator, failures);
            diverged_lanes(&next.q, &next.qd, runaway_speed)
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

/// The lanes whose run goes on and `f` of it holds (bit `i` for lane `i`).
fn runs_where<T>(loops: &[Option<T>], f: impl Fn(&T) -> bool) -> u64 {
    loops.iter().enumerate().fold(0, |lanes, (i, slot)| lanes | (u64::from(slot.as_ref().is_some_and(&f)) << i))
}

/// The lanes that go on (bit `i` for lane `i`).
fn live_lanes<T>(loops: &[Option<T>]) -> u64 {
    runs_where(loops, |_| true)
}

/// The lanes of `which` at `new`, the others as in `now`.
#[inline(always)]
fn select<const L: usize>(now: &mut [Lanes<L>; 4], new: &[Lanes<L>; 4], which: u64) {
    for j in 0..4 {
        now[j] = Lanes::from_fn(|i| if which & (1 << i) != 0 { new[j].0[i] } else { now[j].0[i] });
    }
}

/// Lane `i` of `state`.
fn lane_of<const L: usize>(state: &State<Lanes<L>>, i: usize) -> JointState<4> {
    JointState { q: lane_vector(&state.q, i), qd: lane_vector(&state.qd, i) }
}

/// What a batch keeps of its runs between the moments it looks at them lane by lane: the step
/// every live lane is at and, from the samples its laws took in lanes ([`control_in_lanes`]),
/// each lane's counts of samples and clipped samples. [`Ledger::settle`] hands them, with the
/// lanes' states, to the runs, before anything reads a run; between, no run is touched.
/// (Written into every lane's run at every step, they, the states and the commands took ~1.3 k
/// instructions of a batch-step's ~10.8 k at AVX2, `lanes_once 8 16`.) A run whose law runs in
/// lanes is not handed its latest command: it samples at every step without a motor lag, and
/// only a held command or a lag reads it ([`Run::catch_up`]).
struct Ledger<const L: usize> {
    /// The step every live lane is at.
    step: usize,
    /// Whether a run's step, state or counts are behind the batch's.
    behind: bool,
    /// Controller samples every live lane took in lanes since the runs were last settled.
    samples: usize,
    /// Per lane, how many of those samples clipped the command, and how many clipped each joint.
    saturated: [usize; L],
    saturated_per_joint: [[usize; 4]; L],
    /// The steps any run's marks fall on, in order, and the first not yet passed.
    marks: Vec<usize>,
    next_mark: usize,
}

impl<const L: usize> Ledger<L> {
    fn new<C, R>(loops: &[Option<Run<'_, 4, C, R>>]) -> Self
    where
        C: Controller<4> + ?Sized,
        R: ReferenceSource<4> + ?Sized,
    {
        let mut marks: Vec<usize> = loops.iter().flatten().flat_map(|lane| lane.mark_steps().iter().copied()).collect();
        marks.sort_unstable();
        marks.dedup();
        Self {
            step: 0,
            behind: false,
            samples: 0,
            saturated: [0; L],
            saturated_per_joint: [[0; 4]; L],
            marks,
            next_mark: 0,
        }
    }

    /// The time of the current step, s, as [`Run::time`] computes it.
    fn time(&self, dt: f64) -> f64 {
        self.step as f64 * dt
    }

    /// Brings every live run up to the batch ([`Run::catch_up`]), its state from `state`.
    fn settle<C, R>(&mut self, loops: &mut [Option<Run<'_, 4, C, R>>], state: &State<Lanes<L>>)
    where
        C: Controller<4> + ?Sized,
        R: ReferenceSource<4> + ?Sized,
    {
        if !self.behind {
            return;
        }
        for (i, slot) in loops.iter_mut().enumerate() {
            let Some(lane) = slot.as_mut() else { continue };
            let counts = (self.saturated[i], &self.saturated_per_joint[i]);
            lane.catch_up(self.step, lane_of(state, i), self.samples, counts);
        }
        self.samples = 0;
        self.saturated = [0; L];
        self.saturated_per_joint = [[0; 4]; L];
        self.behind = false;
    }

    /// A controller sample that every live lane (`live`) took in lanes: bit `i` of `clipped[j]`
    /// where lane `i` clipped joint `j`'s command. Returns the live lanes that clipped any.
    fn sampled(&mut self, clipped: &[u64; 4], live: u64) -> u64 {
        self.samples += 1;
        self.behind = true;
        let any = clipped.iter().fold(0, |any, lanes| any | lanes) & live;
        for i in (0..L).filter(|i| any & (1 << i) != 0) {
            self.saturated[i] += 1;
            for (count, joint) in self.saturated_per_joint[i].iter_mut().zip(clipped) {
                *count += ((joint >> i) & 1) as usize;
            }
        }
        any
    }

    /// Whether a mark falls on the current step (for some run).
    fn marks_now(&mut self) -> bool {
        while self.marks.get(self.next_mark).is_some_and(|&mark| mark < self.step) {
            self.next_mark += 1;
        }
        self.marks.get(self.next_mark) == Some(&self.step)
    }

    /// The step taken: the lanes of `moved` go to `next` (their runs now behind), the others
    /// keep their state. Selected at `level` (at the baseline, the selection's narrow loads
    /// waited on the kernel's wide stores).
    fn stepped(&mut self, level: SimdLevel, state: &mut State<Lanes<L>>, next: &State<Lanes<L>>, moved: u64) {
        level.run(
            #[inline(always)]
            || {
                select(&mut state.q, &next.q, moved);
                select(&mut state.qd, &next.qd, moved);
            },
        );
        self.step += 1;
        self.behind = true;
    }
}

/// The controllers' samples, the torques and the metrics of every lane at once ([`LaneLaw`])
/// at the plant's `state` (the metrics) as the controllers `seen` it (the exact state, or the
/// filters' estimates), with the plant's and (for the lanes of `own`) the controllers' models'
/// terms; the lanes of `not_positive_definite` fail (their plant's `M` is not positive
/// definite). Every live lane's sample goes to `ledger` where all of them sample in lanes;
/// otherwise the runs are settled and sampled lane by lane. Each lane's torque over the coming
/// step goes to `torque` (0 for a lane that failed); a lane that fails (its plant's `M`
/// not positive definite, a non-finite command) or finishes leaves `loops` with its result.
/// Returns how many lanes go on.
#[allow(clippy::too_many_arguments)] // the lanes' loops, results, models, state and terms
fn control_in_lanes<const L: usize, C, R>(
    level: SimdLevel,
    (law, ledger): (&mut LaneLaw<L>, &mut Ledger<L>),
    loops: &mut [Option<Run<'_, 4, C, R>>],
    results: &mut [Option<Result<SimSummary<4>, SimError>>],
    models: &[ArmModel<4>; L],
    (state, seen): (&State<Lanes<L>>, &State<Lanes<L>>),
    (start, own_terms): (&Start<Lanes<L>>, &Start<Lanes<L>>),
    (own, not_positive_definite): (u64, u64),
    limits: &[Lanes<L>; 4],
    torque: &mut [Lanes<L>; 4],
) -> usize
where
    C: Controller<4> + ?Sized,
    R: ReferenceSource<4> + ?Sized,
{
    let Some(first) = loops.iter().flatten().next() else { return 0 };
    // Every lane is at the ledger's step of the same reference, with the same control period,
    // step count and tracking start ([`LaneLaw::of`]); the runs themselves may be behind.
    let period = first.config.control_period;
    let time = ledger.time(first.dt);
    let tracked = ledger.step >= first.first_tracked_step();
    let finished = ledger.step == first.steps;
    // The reference sample and tip as the reference returns them, not copied on into a
    // `ReferenceNow`: the copy's wide loads right after its entry-by-entry stores waited for
    // them (a quarter of this function's own samples).
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
    let live = live_lanes(loops);
    if (not_positive_definite | refused) & live == 0 {
        // Every live lane's sample in lanes, its run untouched.
        let any = ledger.sampled(&clipped, live);
        law.sampled_lanes(any, &command, |i| terms_of(own_terms, i));
    } else {
        ledger.settle(loops, state);
        for (i, slot) in loops.iter_mut().enumerate() {
            let Some(lane) = slot.as_mut() else { continue };
            let outcome = if not_positive_definite & (1 << i) == 0 {
                let sampled = if refused & (1 << i) == 0 {
                    let joints = (0..4).fold(0, |joints, j| joints | ((clipped[j] >> i) & 1) << j);
                    Ok(lane.take_clipped(lane_vector(&command, i), joints))
                } else {
                    lane.sample(&raw.map(|v| v.get(i)))
                };
                match sampled {
                    Ok(clipped) => law.sampled(i, clipped, &lane_vector(&command, i), || terms_of(own_terms, i)),
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
    }
    // The metrics, as `Run::control_at` records them (no motor lag: the torque is the command;
    // a sampled lane's is its command, and a failed lane's is not read).
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
    // Each live lane holds its command over the coming step; the others none.
    let live = live_lanes(loops);
    let base: [Lanes<L>; 3] = std::array::from_fn(|k| Lanes(std::array::from_fn(|i| models[i].base()[k])));
    let (tip, tip_error) = level.run(
        #[inline(always)]
        || {
            let tip = start.configuration.tip_in_base(&base);
            let error = array4(|j| Lanes::splat(desired.q[j]) - state.q[j]);
            let tip_error = super::closed_loop::tip_error(&tip, &tip_desired);
            law.tracking.record(&command, &error, tip_error, tracked);
            *torque = [Lanes::splat(0.0); 4];
            select(torque, &command, live);
            (tip, tip_error)
        },
    );
    if ledger.marks_now() || finished {
        ledger.settle(loops, state);
        for (i, slot) in loops.iter_mut().enumerate() {
            let Some(lane) = slot.as_mut() else { continue };
            lane.mark(Vector3::new(tip[0].get(i), tip[1].get(i), tip[2].get(i)), tip_error.get(i));
            if finished {
                law.hand_back(i, lane);
                results[i] =
                    slot.take().map(|lane| Ok(lane.summary_with(law.tracking.lane(i), law.estimate_errors(i))));
            }
        }
    }
    if finished { 0 } else { live.count_ones() as usize }
}

/// The earliest next payload event of any live run, s (`None`: no event left, or every one NaN
/// and so never due). The batch keeps it until the next events are applied: a lane that
/// leaves meanwhile can only make it early, and an early check finds nothing due.
fn next_event_time<C, R>(loops: &[Option<Run<'_, 4, C, R>>]) -> Option<f64>
where
    C: Controller<4> + ?Sized,
    R: ReferenceSource<4> + ?Sized,
{
    loops.iter().flatten().filter_map(Run::next_event_time).filter(|time| !time.is_nan()).reduce(f64::min)
}

/// Up to `L` runs (all of the family, with one time step and integrator) side by side; lanes
/// beyond `runs.len()` are idle from the start. The lanes' arithmetic runs at `level`; the
/// rest (controllers, sensors, events, metrics) lane by lane, or, where [`LaneLaw::of`] takes
/// the batch, the controllers' laws, their Kalman filters and sensors ([`estimate_in_lanes`])
/// and the metrics in lanes too ([`control_in_lanes`]). The runs are brought up to date
/// ([`Ledger::settle`]) only where something reads them: a payload event, a sensor read lane
/// by lane or a filter handed back before its sample, a failure, a mark, the end; and at every
/// step without the lane law.
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
    // The lanes' states; a lane without a run takes another's (it is never read).
    let mut state = lane_state(&std::array::from_fn(|i| match loops.get(i) {
        Some(Some(lane)) => lane.state,
        _ => loops.iter().flatten().next().map_or(JointState::at_rest(JointVector::zeros()), |lane| lane.state),
    }));
    let mut torques = [[0.0; 4]; L];
    // Each lane's torque limits (N·m) and runaway speed (rad/s); a lane without a run takes
    // another's (it is never read), or 1 where no run started.
    let config = |i: usize| {
        loops.get(i).and_then(Option::as_ref).or_else(|| loops.iter().flatten().next()).map(|lane| lane.config)
    };
    let limits: [Lanes<L>; 4] = array4(|j| Lanes::from_fn(|i| config(i).map_or(1.0, |c| c.torque_limits[j])));
    let runaway_speed = Lanes::from_fn(|i| config(i).map_or(1.0, |c| c.runaway_speed));
    let mut start = Start::new(&fast, &state);
    // The lanes' states after a step, scratch.
    let mut next = state;
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
    let mut ledger = Ledger::<L>::new(&loops);
    let mut next_event = next_event_time(&loops);
    // The lanes whose controllers take terms of their own models rather than the plant's
    // ([`Run::shares_terms`]; a lane's changes only at a payload event).
    let own_models_of = |loops: &[Option<Run<'_, 4, _, _>>]| runs_where(loops, |lane| !lane.shares_terms());
    let mut own_models = own_models_of(&loops);
    loop {
        if law.is_none() {
            // Each lane's controller, sensors and metrics read its run at every step.
            ledger.settle(&mut loops, &state);
        }
        // Payload events, lane by lane: the plant's model first, then the controller. A run's
        // event is due where [`Run::due_event`] says; the lanes are looked at only when the
        // earliest of their next events is due.
        if next_event.is_some_and(|time| time <= ledger.time(dt) + 0.5 * dt) {
            ledger.settle(&mut loops, &state);
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
            next_event = next_event_time(&loops);
            own_models = own_models_of(&loops);
        }
        let not_positive_definite = set_start(level, &fast, &mut start, &state, true);
        let live = live_lanes(&loops);
        // Where the batch runs the estimators: the sensors' readings (in lanes or lane by lane),
        // the filters in lanes.
        let estimate = match law.as_mut() {
            Some(law) if law.estimates() => {
                if !law.reads() || not_positive_definite & live != 0 {
                    ledger.settle(&mut loops, &state);
                }
                Some(estimate_in_lanes(level, law, &mut loops, &state, not_positive_definite))
            }
            _ => None,
        };
        // The controllers that compute their own terms this step: with the lane law, where they
        // see an estimate or their model is not the plant's (as `Run::seen_for_terms` says);
        // without it, where a lane's controller computes its terms, its feedback run now and
        // its view (the plant's state or not) gathered.
        let mut views: Option<State<Lanes<L>>> = None;
        let wants_terms = if law.is_some() {
            #[cfg(debug_assertions)]
            for (i, lane) in loops.iter().enumerate().filter_map(|(i, slot)| slot.as_ref().map(|lane| (i, lane))) {
                debug_assert!(
                    controller_arm(Some(lane), &arms[i]) == controller_arms[i],
                    "a controller's model changed outside `set_payload`"
                );
            }
            live & if estimate.is_some() { !0 } else { own_models }
        } else {
            let mut wants_terms = 0u64;
            for i in 0..count {
                let Some(lane) = loops[i].as_mut() else { continue };
                if let Some((seen, model)) = lane.seen_for_terms()
                    && let Some(arm) = model.yaw_pitch()
                {
                    debug_assert!(*arm == controller_arms[i], "a controller's model changed outside `set_payload`");
                    let views = views.get_or_insert(state);
                    for j in 0..4 {
                        views.q[j].0[i] = seen.q[j];
                        views.qd[j].0[i] = seen.qd[j];
                    }
                    wants_terms |= 1 << i;
                }
            }
            wants_terms
        };
        // What the controllers see: the filters' estimates, the exact state (with the lane law),
        // or each lane's view gathered, which only the controllers' terms read. Borrowed, not
        // moved: a move copied 512 bytes a step.
        let seen = match (&estimate, &views) {
            (Some(estimate), _) => estimate,
            (None, Some(views)) => views,
            (None, _) => &state,
        };
        if wants_terms != 0 {
            set_start(level, &controller_fast, &mut controller_start, seen, false);
        }
        let mut torque = [Lanes::splat(0.0); 4];
        let active = match law.as_mut() {
            Some(law) => control_in_lanes(
                level,
                (law, &mut ledger),
                &mut loops,
                &mut results,
                &models,
                (&state, seen),
                (&start, &controller_start),
                (wants_terms, not_positive_definite),
                &limits,
                &mut torque,
            ),
            None => {
                let mut active = 0;
                let tip = start.configuration.tip_in_base(&fast.base);
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
                        Err(not_positive_definite_at(time, (0..4).map(|j| state.q[j].get(i))))
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
                // Idle, finished and failed lanes keep their last state and hold no torque.
                select(&mut torque, &lanes_of(torques), live_lanes(&loops));
                active
            }
        };
        if active == 0 {
            break;
        }
        let mut failures = Failures::<L> { lanes: 0, at: [[0.0; 4]; L] };
        let settings = (dt, integrator, runaway_speed);
        let diverged = step_lanes(level, &fast, &mut start, &state, &torque, settings, &mut failures, &mut next);
        let live = live_lanes(&loops);
        if (failures.lanes | diverged) & live == 0 {
            ledger.stepped(level, &mut state, &next, live);
            continue;
        }
        // A lane failed or diverged: each run says why, from its own step and state.
        ledger.settle(&mut loops, &state);
        let mut moved = 0;
        for i in 0..count {
            let Some(lane) = loops[i].as_mut() else { continue };
            let advanced = if failures.lanes & (1 << i) != 0 {
                lane.advance(Err(DynamicsError::NotPositiveDefinite(failures.at[i].to_vec())))
            } else if diverged & (1 << i) != 0 {
                lane.advance(Ok(lane_of(&next, i)))
            } else {
                moved |= 1 << i;
                Ok(())
            };
            if let Err(error) = advanced {
                if let Some(law) = law.as_ref() {
                    law.hand_back(i, lane);
                }
                results[i] = Some(Err(error));
                loops[i] = None;
            }
        }
        ledger.stepped(level, &mut state, &next, moved);
    }
    results.into_iter().map(|result| result.unwrap_or_else(|| unreachable!("every lane ends with a result"))).collect()
}
