//! The robustness campaign: trials drawn from the setup's uncertainty (the arm's and pieces'
//! model errors, the sensors' noise, the servos' spread), each controller run on each trial of
//! a scenario or a whole game, one row per controller and trial; per controller the success
//! rate and the placement error's distribution.
//!
//! Trial `k` draws from the seed `derive_seed(seed, k)`, so the rows do not depend on the
//! threads, the batch of runs side by side or the shard.

use crate::app::setup::conditions::{ConditionOptions, Study, Trial};
use crate::app::setup::file::Setup;
use crate::app::studies::placement::Placement;
use crate::app::studies::plan::{Plan, plan_scenario};
use crate::app::studies::simulate::{
    ControllerName, DefaultGains, GivenGains, controller_specs, pawn_events, placement_error,
};
use crate::app::studies::{Progress, Stop, interrupted};
use anyhow::{Context, Result};
use chessarm_chess::notation::GameRecord;
use chessarm_chess::play::{Game, Mover, PlaySettings};
use chessarm_core::control::choice::ControllerSpec;
use chessarm_core::sense::rng::derive_seed;
use chessarm_core::sim::batch::{LaneCount, LaneRun, SimdLevel, simulate_lanes};
use chessarm_core::sim::{Integrator, PayloadEvent, Plant, SimConfig, SimSummary};
use rayon::prelude::*;
use std::time::Instant;

/// A campaign, as the `robustness` command's flags give it (the flags' names are in its
/// messages).
#[derive(Debug, Clone)]
pub struct RobustnessOptions {
    /// A game each trial plays whole; `None`: the scenario.
    pub game: Option<GameRecord>,
    pub scenario: String,
    /// The torque controllers compared (with servos, the setup's host strategies instead).
    pub controllers: Vec<ControllerName>,
    pub gains: GivenGains,
    /// Mass of a scenario's gripped piece, kg (default: the setup's pawn).
    pub payload_mass: Option<f64>,
    pub controller_knows_payload: bool,
    /// Sensors, estimator, lag and model errors; `conditions.seed` is the campaign's seed.
    pub conditions: ConditionOptions,
    /// How a game's pieces are put down.
    pub placement: Placement,
    /// A piece further than this from its square centre is misplaced, m.
    pub tolerance: f64,
    pub trials: usize,
    /// Slice K of N (1-based) of the trials.
    pub shard: Option<(usize, usize)>,
    pub integrator: Integrator,
    /// Worker threads (`None`: all cores).
    pub threads: Option<usize>,
}

impl RobustnessOptions {
    /// `trials` trials of the four torque controllers on the default scenario with the
    /// setup's uncertainty and the default tolerance (the command's defaults).
    pub fn new(trials: usize) -> Self {
        Self {
            game: None,
            scenario: "queens-gambit".into(),
            controllers: vec![ControllerName::Pd, ControllerName::Pid, ControllerName::Adaptive, ControllerName::Dob],
            gains: GivenGains::default(),
            payload_mass: None,
            controller_knows_payload: false,
            conditions: ConditionOptions::default(),
            placement: Placement::default(),
            tolerance: chessarm_chess::play::DEFAULT_TOLERANCE,
            trials,
            shard: None,
            integrator: Integrator::default(),
            threads: None,
        }
    }
}

/// A campaign checked and ready to run: every check of the options is made here, before
/// anything runs (but the memory bound, [`Prepared::ensure_fits`]).
#[derive(Debug)]
pub struct Prepared<'a> {
    setup: &'a Setup,
    pub options: &'a RobustnessOptions,
    /// The controllers, in the rows' order.
    pub specs: Vec<ControllerSpec>,
    /// What the setup's servos' hosts replace (`None` with torque motors).
    pub servo_note: Option<String>,
    pub study: Study,
    pub work: Work,
    pub trial_options: TrialOptions,
    pub range: std::ops::Range<usize>,
    /// Worker threads the campaign runs on.
    pub threads: usize,
}

/// A campaign's result.
#[derive(Debug, Clone)]
pub struct Campaign {
    /// One row per trial and controller, in trial order (the shard's trials).
    pub rows: Vec<TrialRow>,
    pub specs: Vec<ControllerSpec>,
    /// Per controller, in `specs`' order.
    pub statistics: Vec<Statistics>,
    pub wall_time_s: f64,
    pub threads: usize,
}

impl<'a> Prepared<'a> {
    /// Checks `options` on `setup` (its motion limits as the campaign's) and plans the work.
    ///
    /// # Errors
    ///
    /// Bad conditions, controllers or thread count, a scenario the setup cannot plan.
    pub fn new(setup: &'a Setup, options: &'a RobustnessOptions) -> Result<Self> {
        crate::app::resources::batching()?;
        let defaults = if options.game.is_some() { DefaultGains::Game } else { DefaultGains::Report };
        let (mut specs, servo_note) = match crate::app::setup::servos::servo_hosts(setup) {
            Some((hosts, note)) => (hosts, Some(note)),
            None => (controller_specs(&options.controllers, &options.gains, defaults)?, None),
        };
        for spec in &mut specs {
            spec.knows_friction = options.conditions.knows_friction(setup);
        }
        let study = Study::for_trials(setup, &options.conditions, 1e-3)?;
        if options.conditions.trial_seed.is_some() {
            anyhow::bail!(
                "--trial-seed runs one trial: use it with simulate or play; robustness draws --trials trials from --seed"
            );
        }
        let work = match &options.game {
            Some(record) => {
                if options.payload_mass.is_some() {
                    anyhow::bail!("--payload-mass goes with a scenario; a game grips its real pieces");
                }
                Work::Game(record.clone())
            }
            None => {
                let plan = plan_scenario(setup, &options.scenario, 1e-3, "the trials")?;
                Work::Scenario { plan, payload_mass: options.payload_mass.unwrap_or(setup.pieces.pawn.mass) }
            }
        };
        let range = crate::app::resources::shard_range(options.trials, options.shard);
        let resolution = study.resolution(setup);
        // Every trial's game is played on the same board with the same arm and pieces: its
        // pre-flight (reach, the columns, the pitch) once for all (a board it refuses is then
        // refused by each trial's own).
        let pitch = matches!(work, Work::Game(_)).then(|| preflight_pitch(setup)).flatten();
        let trial_options = TrialOptions {
            pitch,
            seed: options.conditions.seed,
            integrator: options.integrator,
            controller_knows_payload: options.controller_knows_payload,
            payload_feedforward: options.placement.payload_feedforward,
            in_position: options.placement.in_position(options.tolerance, resolution),
            tolerance: options.tolerance,
        };
        let threads = crate::app::resources::worker_threads(options.threads)?;
        Ok(Self { setup, options, specs, servo_note, study, work, trial_options, range, threads })
    }

    /// Checks that the campaign's rows fit in memory (every row, with its drawn parameters'
    /// names and values, is held until the end).
    ///
    /// # Errors
    ///
    /// Too many rows for the memory there is.
    pub fn ensure_fits(&self) -> Result<()> {
        crate::app::resources::ensure_fits(
            &format!("--trials {} with {} controllers", self.options.trials, self.specs.len()),
            "trial rows",
            self.range.len() as f64 * self.specs.len() as f64,
            (std::mem::size_of::<TrialRow>() + 46 * 64) as f64,
        )
    }

    /// Runs the shard's trials on the worker threads; `progress` is told of each trial done,
    /// `stop` asked before each task.
    ///
    /// # Errors
    ///
    /// Too many rows for the memory there is ([`Prepared::ensure_fits`], which a caller that
    /// writes files checks first), the worker threads cannot start, a cancelled run
    /// ([`interrupted`]).
    pub fn run(self, progress: Option<Progress<'_>>, stop: Stop<'_>) -> Result<Campaign> {
        self.ensure_fits()?;
        let threads = self.threads;
        let pool =
            rayon::ThreadPoolBuilder::new().num_threads(threads).build().context("cannot start the worker threads")?;
        let started = Instant::now();
        let rows = pool.install(|| {
            run_trials(
                self.setup,
                &self.work,
                &self.specs,
                &self.study,
                &self.trial_options,
                self.range.clone(),
                progress,
                stop,
            )
        })?;
        let wall_time_s = started.elapsed().as_secs_f64();
        let statistics = self.specs.iter().map(|spec| statistics(&rows, &spec.name)).collect();
        Ok(Campaign { rows, specs: self.specs, statistics, wall_time_s, threads })
    }
}

/// What every trial runs.
#[derive(Debug)]
pub enum Work {
    Scenario { plan: Plan, payload_mass: f64 },
    Game(GameRecord),
}

/// One controller's result in one trial (SI; tip and placement errors in mm).
#[derive(Debug, Clone)]
pub struct TrialRow {
    pub trial: usize,
    pub trial_seed: u64,
    pub controller: String,
    /// "ok", or why the run failed.
    pub status: String,
    /// Largest distance of a placed piece from its square centre, mm (NaN if it failed).
    pub place_error_mm: f64,
    pub pieces: usize,
    /// Pieces placed further than the tolerance.
    pub misplaced: usize,
    pub max_tip_error_mm: f64,
    pub rms_tip_error_mm: f64,
    pub peak_torque_nm: f64,
    pub peak_torque_ratio: f64,
    pub saturated_samples: usize,
    /// RMS over the joints and samples of the rate estimate's error, rad/s.
    pub rms_rate_estimate_error: f64,
    /// Robot time of the run (a game's moves, fine points' waits included), s.
    pub robot_time_s: f64,
    /// Robot moves simulated (1 for the scenario).
    pub plies: usize,
    /// Moves whose simulated motion touched a piece, the table or the arm itself, and the
    /// smallest clearance of the simulated motion, mm (at least: see `Executed`).
    pub contacts: usize,
    pub clearance_mm: f64,
    /// The trial's drawn parameters.
    pub drawn: Vec<(String, f64)>,
}

impl TrialRow {
    /// Every piece within the tolerance, and the run finished.
    /// Every piece placed and nothing touched.
    pub fn success(&self) -> bool {
        self.status == "ok" && self.misplaced == 0 && self.contacts == 0
    }
}

/// Metrics over one or more simulations of a trial.
#[derive(Default)]
struct Totals {
    samples: f64,
    squared_tip: f64,
    squared_rate: f64,
    max_tip: f64,
    peak_torque: f64,
    peak_ratio: f64,
    saturated: usize,
    places: Vec<f64>,
    robot_time: f64,
    moves: usize,
    /// Moves whose simulated motion touched a piece, the table or the arm itself.
    contacts: usize,
    /// The smallest clearance of the simulated motion over the trial, m (a lower bound where
    /// the move's was bounded, not measured).
    clearance: Option<f64>,
}

impl Totals {
    fn add(&mut self, summary: &SimSummary<4>, limits: &chessarm_core::arm::model::JointVector<4>) {
        let samples = summary.tracked_steps as f64;
        self.samples += samples;
        self.squared_tip += summary.rms_tip_error.powi(2) * samples;
        self.squared_rate += summary.rms_rate_estimate_error.norm_squared() / 4.0 * samples;
        self.max_tip = self.max_tip.max(summary.max_tip_error);
        self.peak_torque = self.peak_torque.max(summary.peak_torque.max());
        self.peak_ratio = self.peak_ratio.max(summary.peak_torque.component_div(limits).max());
        self.saturated += summary.saturated_samples;
        self.robot_time += summary.duration;
        self.moves += 1;
    }
}

/// Runs one controller on one trial of a game. `tolerance` in m.
fn run_trial(
    setup: &Setup,
    record: &GameRecord,
    spec: &ControllerSpec,
    trial: &Trial,
    study: &Study,
    options: &TrialOptions,
) -> (String, Totals) {
    let mut totals = Totals::default();
    let limits = setup.arm.torque_limits();
    let outcome: Result<()> = (|| {
        let mut settings = PlaySettings::new(spec.name.clone(), spec.gains);
        settings.controller = spec.clone();
        crate::app::setup::servos::drive(setup, &mut settings);
        settings.pieces = setup.pieces;
        settings.clearance = Some(setup.clearance.clone());
        settings.limits = setup.motion;
        settings.limits.tracking = study.tracking(
            setup,
            &spec.gains,
            options.payload_feedforward && crate::app::setup::servos::cancels_inertia(&spec.kind),
            options.controller_knows_payload,
        );
        settings.timing = setup.timing;
        settings.record_every = 0;
        settings.controller_knows_payload = options.controller_knows_payload;
        settings.payload_feedforward = options.payload_feedforward;
        settings.in_position = options.in_position;
        settings.integrator = options.integrator;
        settings.tolerance = options.tolerance;
        // The campaign measures the pace it is given (--pace, --paces): no move is slowed.
        settings.choose_pace = false;
        trial.apply_to(&mut settings);
        let mut game = Game::new(setup.arm, setup.board, record.start.clone(), settings)?;
        for mv in &record.moves {
            let report = game.play(mv, Mover::Robot)?;
            if let Some(summary) = &report.summary {
                totals.add(summary, &limits);
            }
            totals.places.extend(&report.place_errors);
            if let Some(executed) = &report.executed_clearance {
                totals.contacts += usize::from(executed.is_contact());
                totals.clearance = Some(totals.clearance.map_or(executed.distance(), |c| c.min(executed.distance())));
            }
        }
        Ok(())
    })();
    let status = match outcome {
        Ok(()) => "ok".to_string(),
        Err(error) => format!("failed: {}", crate::app::text::one_line(&error)),
    };
    (status, totals)
}

fn row(
    trial_index: usize,
    trial: &Trial,
    spec: &ControllerSpec,
    status: String,
    totals: &Totals,
    tolerance: f64,
) -> TrialRow {
    let ok = status == "ok";
    let worst = totals.places.iter().copied().fold(0.0f64, f64::max);
    TrialRow {
        trial: trial_index,
        trial_seed: trial.seed,
        controller: spec.name.clone(),
        place_error_mm: if ok { worst * 1e3 } else { f64::NAN },
        pieces: totals.places.len(),
        misplaced: totals.places.iter().filter(|e| **e > tolerance).count(),
        max_tip_error_mm: totals.max_tip * 1e3,
        rms_tip_error_mm: (totals.squared_tip / totals.samples.max(1.0)).sqrt() * 1e3,
        peak_torque_nm: totals.peak_torque,
        peak_torque_ratio: totals.peak_ratio,
        saturated_samples: totals.saturated,
        rms_rate_estimate_error: (totals.squared_rate / totals.samples.max(1.0)).sqrt(),
        robot_time_s: if ok { totals.robot_time } else { f64::NAN },
        plies: totals.moves,
        contacts: totals.contacts,
        clearance_mm: totals.clearance.map_or(f64::NAN, |c| c * 1e3),
        drawn: trial.columns(),
        status,
    }
}

/// The `q`-quantile (0–1) of sorted `values` by linear interpolation between order statistics.
fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let position = q * (sorted.len() - 1) as f64;
    let (low, high) = (position.floor() as usize, position.ceil() as usize);
    if sorted[high].is_infinite() {
        return f64::INFINITY;
    }
    sorted[low] + (sorted[high] - sorted[low]) * (position - low as f64)
}

/// The mean over the finished runs of robot seconds per simulated move (NaN without one).
fn seconds_per_ply(rows: &[&TrialRow]) -> f64 {
    let finished: Vec<f64> = rows
        .iter()
        .filter(|r| r.robot_time_s.is_finite() && r.plies > 0)
        .map(|r| r.robot_time_s / r.plies as f64)
        .collect();
    finished.iter().sum::<f64>() / finished.len() as f64
}

/// The placement error's distribution over a controller's trials, mm: a failed run counts as
/// an infinite error, so a median, p95 or largest error over failures is not a number
/// (infinite; JSON null).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PlaceErrors {
    pub median: f64,
    pub p95: f64,
    pub max: f64,
}

/// One controller's statistics over its trials.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Statistics {
    pub controller: String,
    pub trials: usize,
    /// Trials with every piece within the tolerance and nothing touched, of all.
    pub success_rate: f64,
    pub failed_runs: usize,
    pub place_error_mm: PlaceErrors,
    pub trials_with_contacts: usize,
    pub contacts: usize,
    /// The smallest clearance of any trial's simulated motion, mm (infinite without one).
    pub smallest_clearance_mm: f64,
    pub peak_torque_nm: f64,
    pub peak_torque_ratio: f64,
    pub trials_with_saturation: usize,
    /// Mean over the finished trials of the robot time per simulated move, s.
    pub seconds_per_ply: f64,
    pub rms_rate_estimate_error_rad_per_s: f64,
    /// The seed of the trial with the largest finite placement error.
    pub worst_trial_seed: Option<u64>,
}

/// Controller `name`'s statistics over `rows`.
pub fn statistics(rows: &[TrialRow], name: &str) -> Statistics {
    let mine: Vec<&TrialRow> = rows.iter().filter(|r| r.controller == name).collect();
    let mut errors: Vec<f64> =
        mine.iter().map(|r| if r.place_error_mm.is_finite() { r.place_error_mm } else { f64::INFINITY }).collect();
    errors.sort_by(f64::total_cmp);
    let worst = mine
        .iter()
        .filter(|r| r.place_error_mm.is_finite())
        .max_by(|a, b| a.place_error_mm.total_cmp(&b.place_error_mm));
    let successes = mine.iter().filter(|r| r.success()).count();
    Statistics {
        controller: name.to_string(),
        trials: mine.len(),
        success_rate: successes as f64 / mine.len().max(1) as f64,
        failed_runs: mine.iter().filter(|r| r.status != "ok").count(),
        place_error_mm: PlaceErrors {
            median: quantile(&errors, 0.5),
            p95: quantile(&errors, 0.95),
            max: errors.last().copied().unwrap_or(f64::NAN),
        },
        trials_with_contacts: mine.iter().filter(|r| r.contacts > 0).count(),
        contacts: mine.iter().map(|r| r.contacts).sum::<usize>(),
        smallest_clearance_mm: mine
            .iter()
            .map(|r| r.clearance_mm)
            .filter(|c| c.is_finite())
            .fold(f64::INFINITY, f64::min),
        peak_torque_nm: mine.iter().map(|r| r.peak_torque_nm).fold(0.0f64, f64::max),
        peak_torque_ratio: mine.iter().map(|r| r.peak_torque_ratio).fold(0.0f64, f64::max),
        trials_with_saturation: mine.iter().filter(|r| r.saturated_samples > 0).count(),
        seconds_per_ply: seconds_per_ply(&mine),
        rms_rate_estimate_error_rad_per_s: mine.iter().map(|r| r.rms_rate_estimate_error).sum::<f64>()
            / mine.len().max(1) as f64,
        worst_trial_seed: worst.map(|r| r.trial_seed),
    }
}

/// Settings every trial shares.
#[derive(Debug, Clone, Copy)]
pub struct TrialOptions {
    /// The game's tool pitch, rad, when the pre-flight accepted the board (see
    /// [`chessarm_chess::play::PlaySettings::checked_pitch`]).
    pub pitch: Option<f64>,
    /// The study's seed: trial `k` has the seed `derive_seed(seed, k)`.
    pub seed: u64,
    pub integrator: Integrator,
    pub controller_knows_payload: bool,
    /// A game's controllers are told the nominal mass of the piece kind they grip.
    pub payload_feedforward: bool,
    /// A game's fine points (`None`: the gripper goes by the clock).
    pub in_position: Option<chessarm_core::plan::fine_point::InPosition>,
    /// A piece further than this from its square centre is misplaced, m.
    pub tolerance: f64,
}

/// Runs trials `range` of every controller on the current rayon pool, in trial order. A
/// scenario's trials run on the batch simulator, a batch of trials per task (their runs side
/// by side, see [`crate::app::resources::batching`]); a game's trial by trial.
///
/// # Errors
///
/// [`interrupted`], when `stop` said so; a bad `CHESSARM_LANES` or
/// `CHESSARM_SIMD`.
#[allow(clippy::too_many_arguments)]
pub fn run_trials(
    setup: &Setup,
    work: &Work,
    specs: &[ControllerSpec],
    study: &Study,
    options: &TrialOptions,
    range: std::ops::Range<usize>,
    progress: Option<Progress<'_>>,
    stop: Stop<'_>,
) -> Result<Vec<TrialRow>> {
    if matches!(work, Work::Game(_)) {
        crate::app::setup::gripper::check_file_fingers(setup)?;
    }
    let batching = crate::app::resources::batching()?;
    let indices: Vec<usize> = range.collect();
    let per_task = match work {
        Work::Scenario { .. } => {
            crate::app::resources::per_task(indices.len(), rayon::current_num_threads(), batching.0)
        }
        Work::Game(_) => 1,
    };
    let rows: Result<Vec<Vec<TrialRow>>> = indices
        .par_chunks(per_task)
        .map(|chunk| {
            if stop() {
                return Err(interrupted());
            }
            let drawn: Vec<Drawn> = chunk
                .iter()
                .map(|&index| {
                    let seed = derive_seed(options.seed, index as u64);
                    Drawn { index, seed, trial: study.trial(seed) }
                })
                .collect();
            let rows = match work {
                Work::Scenario { plan, payload_mass } => {
                    scenario_rows(setup, plan, *payload_mass, specs, &drawn, options, batching)
                }
                Work::Game(record) => drawn
                    .iter()
                    .flat_map(|drawn| match &drawn.trial {
                        Ok(trial) => specs
                            .iter()
                            .map(|spec| {
                                let (status, totals) = run_trial(setup, record, spec, trial, study, options);
                                row(drawn.index, trial, spec, status, &totals, options.tolerance)
                            })
                            .collect(),
                        Err(error) => vec![failed_draw(drawn, error)],
                    })
                    .collect(),
            };
            if let Some(progress) = progress {
                progress(chunk.len() as u64);
            }
            Ok(rows)
        })
        .collect();
    Ok(rows?.into_iter().flatten().collect())
}

/// A trial's index, seed and drawn arm, pieces and sensors (or why they could not be drawn).
struct Drawn {
    index: usize,
    seed: u64,
    trial: Result<Trial>,
}

/// The row of a trial whose draw failed.
fn failed_draw(drawn: &Drawn, error: &anyhow::Error) -> TrialRow {
    TrialRow {
        trial: drawn.index,
        trial_seed: drawn.seed,
        controller: "-".into(),
        status: format!("failed: {}", crate::app::text::one_line(error)),
        place_error_mm: f64::NAN,
        pieces: 0,
        misplaced: 0,
        max_tip_error_mm: f64::NAN,
        rms_tip_error_mm: f64::NAN,
        peak_torque_nm: f64::NAN,
        peak_torque_ratio: f64::NAN,
        saturated_samples: 0,
        rms_rate_estimate_error: f64::NAN,
        robot_time_s: f64::NAN,
        plies: 0,
        contacts: 0,
        clearance_mm: f64::NAN,
        drawn: Vec::new(),
    }
}

/// One controller on one trial of the scenario, as a run of the batch simulator.
fn scenario_run<'a>(
    setup: &Setup,
    plan: &'a Plan,
    trial: &Trial,
    spec: &ControllerSpec,
    events: &'a [PayloadEvent],
    marks: &'a [f64],
    integrator: Integrator,
) -> Result<LaneRun<'a>> {
    let controller = spec.build_for(setup.arm, &setup.actuators)?;
    // Servos' gears are part of the true plant; their host samples at the bus rate.
    let plant = trial.actuators.plant_model(&trial.plant)?;
    let control_period = crate::app::setup::servos::control_period(setup, 1e-3);
    let feedback = trial.conditions.feedback(control_period)?;
    let config = SimConfig {
        integrator,
        torque_lag: trial.conditions.torque_lag,
        actuators: trial.actuators,
        control_period,
        ..SimConfig::new(&Plant::new(plant))
    };
    Ok(LaneRun { plant, feedback, controller, reference: &plan.joint, initial: None, events, marks, config })
}

/// The rows of the scenario trials `drawn`, every controller of each, their runs side by side.
fn scenario_rows(
    setup: &Setup,
    plan: &Plan,
    payload_mass: f64,
    specs: &[ControllerSpec],
    drawn: &[Drawn],
    options: &TrialOptions,
    (lanes, level): (LaneCount, SimdLevel),
) -> Vec<TrialRow> {
    let limits = setup.arm.torque_limits();
    let marks: Vec<f64> = plan.path.events().iter().map(|e| e.time).collect();
    let events: Vec<Vec<PayloadEvent>> = drawn
        .iter()
        .map(|d| match &d.trial {
            Ok(trial) => pawn_events(setup, Some(trial), &plan.path, payload_mass, options.controller_knows_payload),
            Err(_) => Vec::new(),
        })
        .collect();
    // The rows in order, those of runs still to simulate empty until they have run.
    let mut rows: Vec<Option<TrialRow>> = Vec::new();
    let mut runs = Vec::new();
    let mut pending = Vec::new();
    for (d, events) in drawn.iter().zip(&events) {
        let trial = match &d.trial {
            Ok(trial) => trial,
            Err(error) => {
                rows.push(Some(failed_draw(d, error)));
                continue;
            }
        };
        for (k, spec) in specs.iter().enumerate() {
            match scenario_run(setup, plan, trial, spec, events, &marks, options.integrator) {
                Ok(run) => {
                    pending.push((k, (rows.len(), d.index, trial, spec)));
                    runs.push(run);
                    rows.push(None);
                }
                Err(error) => {
                    let status = format!("failed: {}", crate::app::text::one_line(&error));
                    rows.push(Some(row(d.index, trial, spec, status, &Totals::default(), options.tolerance)));
                }
            }
        }
    }
    // One controller's runs side by side (its trials in order): a batch of runs of one
    // computed-torque controller computes its laws in lanes. A run's result does not depend on
    // its batch, so neither do the rows.
    let mut side_by_side: Vec<_> = pending.into_iter().zip(runs).collect();
    side_by_side.sort_by_key(|((controller, _), _)| *controller);
    let (pending, mut runs): (Vec<_>, Vec<_>) = side_by_side.into_iter().map(|((_, row), run)| (row, run)).unzip();
    for ((slot, index, trial, spec), result) in pending.into_iter().zip(simulate_lanes(&mut runs, lanes, level)) {
        let mut totals = Totals::default();
        let status = match result {
            Ok(summary) => {
                totals.add(&summary, &limits);
                totals.places.extend(placement_error(plan, &summary));
                "ok".to_string()
            }
            Err(error) => format!("failed: {}", crate::app::text::one_line(&anyhow::Error::from(error))),
        };
        rows[slot] = Some(row(index, trial, spec, status, &totals, options.tolerance));
    }
    rows.into_iter().map(|row| row.unwrap_or_else(|| unreachable!("every row is filled"))).collect()
}

/// The tool's pitch the pre-flight of a game on the setup's board finds, or `None` where it
/// refuses the board (each game's own pre-flight then says why).
pub fn preflight_pitch(setup: &Setup) -> Option<f64> {
    chessarm_chess::reach::check_table(&setup.arm, &setup.board, &setup.pieces, &setup.motion, Some(&setup.clearance))
        .ok()
}
