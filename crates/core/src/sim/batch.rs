//! Many independent closed-loop runs at once: `L` runs side by side in SIMD lanes (structure of
//! arrays), for sweeps and Monte-Carlo campaigns.
//!
//! The plant of every lane steps on the structured dynamics ([`super::structured`] with
//! `S = Lanes<L>`); each lane keeps its own controller, sensors, estimator, torque hold, motor
//! lag, payload events and metrics ([`super::closed_loop::Run`], the scalar simulator's own
//! code). A lane that finishes or fails is masked — its state frozen, its result kept — while
//! the others go on. Each lane's [`SimSummary`] equals what [`super::simulate_sensed`] computes
//! for the same run, bit for bit, at every lane count and SIMD level: the kernels are the same
//! IEEE operations in the same order (see [`crate::lanes`]).
//!
//! A run whose plant is not of the yaw–pitch family, or whose time step or integrator differs
//! from its batch's, is simulated alone by the scalar simulator; so is the whole slice when the
//! lane count is 1.

use super::closed_loop::{PlantView, Run, SimConfig, SimError, SimSummary};
use super::plant::Integrator;
use super::structured::{self, Failures, Start, State};
use super::{NoObserver, PayloadEvent, Plant, ReferenceSource};
use crate::arm::dynamics::{DynamicsError, DynamicsTerms};
use crate::arm::model::{ArmModel, JointVector};
use crate::arm::yaw_pitch::{YawPitch, from_rows};
use crate::control::{Controller, JointState};
use crate::lanes::Lanes;
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
        let mut plant = Plant::new(self.plant);
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

/// Which SIMD instructions the batched kernels are compiled for; the results are the same at
/// every level, only the speed differs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimdLevel {
    /// x86-64-v4: AVX-512 (8 f64 per register).
    Avx512,
    /// x86-64-v3: AVX2 (4 f64 per register).
    Avx2,
    /// The x86-64 baseline, SSE2 (2 f64 per register), or whatever the target has elsewhere.
    Baseline,
}

impl SimdLevel {
    pub const ALL: [SimdLevel; 3] = [SimdLevel::Avx512, SimdLevel::Avx2, SimdLevel::Baseline];

    /// The best level this CPU has.
    pub fn detect() -> Self {
        Self::ALL.into_iter().find(|level| level.available()).unwrap_or(SimdLevel::Baseline)
    }

    /// Whether this CPU can run the level.
    pub fn available(self) -> bool {
        match self {
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx512 => pulp::x86::V4::try_new().is_some(),
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx2 => pulp::x86::V3::try_new().is_some(),
            #[cfg(not(target_arch = "x86_64"))]
            SimdLevel::Avx512 | SimdLevel::Avx2 => false,
            SimdLevel::Baseline => true,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            SimdLevel::Avx512 => "avx512",
            SimdLevel::Avx2 => "avx2",
            SimdLevel::Baseline => "sse2",
        }
    }

    /// From its name (`avx512`, `avx2`, `sse2`).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|level| level.name() == name)
    }

    /// Runs `f` compiled for this level (the baseline when the CPU lacks it). `f` and what it
    /// must vectorise have to be `#[inline(always)]` to be compiled for the level.
    #[inline(always)]
    fn run<R>(self, f: impl FnOnce() -> R) -> R {
        #[cfg(target_arch = "x86_64")]
        match self {
            SimdLevel::Avx512 => {
                if let Some(simd) = pulp::x86::V4::try_new() {
                    return simd.vectorize(f);
                }
            }
            SimdLevel::Avx2 => {
                if let Some(simd) = pulp::x86::V3::try_new() {
                    return simd.vectorize(f);
                }
            }
            SimdLevel::Baseline => {}
        }
        f()
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
            results.push(batch[0].simulate_alone());
        } else if width == 4 {
            results.extend(simulate_batch::<4>(batch, level));
        } else {
            results.extend(simulate_batch::<8>(batch, level));
        }
    }
    results
}

/// Writes lane `lane` of the batch's constants from one arm's.
fn set_lane<const L: usize>(batch: &mut YawPitch<Lanes<L>>, lane: usize, arm: &YawPitch<f64>) {
    let mut lanes: [YawPitch<f64>; L] = [*arm; L];
    for (i, slot) in lanes.iter_mut().enumerate() {
        if i != lane {
            *slot = lane_of(batch, i);
        }
    }
    *batch = YawPitch::gather(std::array::from_fn(|i| &lanes[i]));
}

/// Lane `i` of a batch's constants.
fn lane_of<const L: usize>(batch: &YawPitch<Lanes<L>>, i: usize) -> YawPitch<f64> {
    let v3 = |v: &[Lanes<L>; 3]| v.map(|x| x.get(i));
    let v4 = |v: &[Lanes<L>; 4]| v.map(|x| x.get(i));
    YawPitch {
        offset: v4(&batch.offset),
        sign: v4(&batch.sign),
        shoulder: v3(&batch.shoulder),
        link: batch.link.map(|v| v3(&v)),
        com: batch.com.map(|v| v3(&v)),
        mass: v4(&batch.mass),
        inertia: batch.inertia.map(|t| crate::arm::yaw_pitch::Sym {
            xx: t.xx.get(i),
            yy: t.yy.get(i),
            zz: t.zz.get(i),
            xy: t.xy.get(i),
            xz: t.xz.get(i),
            yz: t.yz.get(i),
        }),
        inertia_mean: v4(&batch.inertia_mean),
        inertia_half: v4(&batch.inertia_half),
        rotor: v4(&batch.rotor),
        gravity_z: batch.gravity_z.get(i),
        viscous: v4(&batch.viscous),
        coulomb: v4(&batch.coulomb),
        // Recomputed by `gather` from the lanes' own values.
        has_friction: v4(&batch.viscous).iter().chain(&v4(&batch.coulomb)).any(|v| *v != 0.0),
    }
}

/// The lanes' joint states side by side.
fn lane_state<const L: usize>(states: &[JointState<4>; L]) -> State<Lanes<L>> {
    State {
        q: lanes_of(states.map(|s| std::array::from_fn(|j| s.q[j]))),
        qd: lanes_of(states.map(|s| std::array::from_fn(|j| s.qd[j]))),
    }
}

fn lanes_of<const L: usize>(values: [[f64; 4]; L]) -> [Lanes<L>; 4] {
    std::array::from_fn(|j| Lanes(std::array::from_fn(|i| values[i][j])))
}

/// The dynamics at the lanes' states, into `start`, compiled for `level`.
fn set_start<const L: usize>(
    level: SimdLevel,
    model: &YawPitch<Lanes<L>>,
    start: &mut Start<Lanes<L>>,
    state: &State<Lanes<L>>,
) {
    // `inline(always)`: the closure's body is compiled inside pulp's function for the level,
    // with its instructions; a closure of its own would get the baseline's.
    level.run(
        #[inline(always)]
        || start.set(model, state),
    );
}

/// One step of every lane ([`structured::step`]), compiled for `level`.
#[allow(clippy::too_many_arguments)] // the step's own arguments and the level
fn step_lanes<const L: usize>(
    level: SimdLevel,
    model: &YawPitch<Lanes<L>>,
    start: &mut Start<Lanes<L>>,
    state: &State<Lanes<L>>,
    torque: &[Lanes<L>; 4],
    dt: f64,
    integrator: Integrator,
    failures: &mut Failures<L>,
) -> State<Lanes<L>> {
    level.run(
        #[inline(always)]
        || structured::step(model, start, state, torque, dt, integrator, failures),
    )
}

/// Up to `L` runs (all of the family, with one time step and integrator) side by side; lanes
/// beyond `runs.len()` are idle from the start. The lanes' arithmetic runs at `level`; the
/// rest (controllers, sensors, events, metrics) lane by lane.
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
    let mut start = Start::new(&fast, &lane_state(&states));
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
                    results[i] = Some(Err(error));
                    loops[i] = None;
                    break;
                }
            }
        }
        let state = lane_state(&states);
        set_start(level, &fast, &mut start, &state);
        let tip = start.configuration.tip_in_base();
        let mut active = 0;
        for i in 0..count {
            let Some(lane) = loops[i].as_mut() else { continue };
            let time = lane.time();
            let outcome = if start.configuration.factor.positive_definite(i) {
                let view = PlantView {
                    tip: Vector3::new(tip[0].get(i), tip[1].get(i), tip[2].get(i)),
                    terms: DynamicsTerms {
                        mass_matrix: from_rows(&start.configuration.mass_matrix.map(|row| row.map(|x| x.get(i)))),
                        bias: JointVector::from(start.bias.map(|x| x.get(i))),
                    },
                };
                lane.control(&view, &models[i], &mut NoObserver)
            } else {
                let q = states[i].q.iter().copied().collect();
                Err(SimError::Dynamics { time, source: DynamicsError::NotPositiveDefinite(q) })
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
        if active == 0 {
            break;
        }
        let torque = lanes_of(torques);
        let mut failures = Failures::<L> { lanes: 0, at: [[0.0; 4]; L] };
        let next = step_lanes(level, &fast, &mut start, &state, &torque, dt, integrator, &mut failures);
        for i in 0..count {
            let Some(lane) = loops[i].as_mut() else { continue };
            let stepped = if failures.lanes & (1 << i) != 0 {
                Err(DynamicsError::NotPositiveDefinite(failures.at[i].to_vec()))
            } else {
                Ok(JointState {
                    q: JointVector::from(next.q.map(|x| x.get(i))),
                    qd: JointVector::from(next.qd.map(|x| x.get(i))),
                })
            };
            match lane.advance(stepped) {
                Ok(()) => states[i] = lane.state,
                Err(error) => {
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
