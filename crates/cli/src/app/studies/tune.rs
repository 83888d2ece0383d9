//! The gain sweep: every candidate (a torque controller's gains, or the servos' P register
//! under a host strategy) simulated on the whole scenario or game without recording its time
//! series, one row of metrics per candidate.
//!
//! The rows come out in candidate order whatever the number of threads, so a sweep is
//! reproducible and its shards (`shard` K of N) concatenate to the full sweep.

use crate::app::setup::conditions::{ConditionOptions, Trial};
use crate::app::setup::file::Setup;
use crate::app::studies::placement::Placement;
use crate::app::studies::plan::plan_scenario;
use crate::app::studies::simulate::{
    ControllerName, DefaultGains, GivenGains, TRANSIENT_S, controller_specs, ensure_tracked, pawn_events,
};
use crate::app::studies::{Progress, Stop, interrupted};
use crate::app::text::tick;
use anyhow::{Context, Result, bail};
use chessarm_chess::notation::GameRecord;
use chessarm_chess::play::{Game, Mover, PlaySettings};
use chessarm_core::arm::model::JointVector;
use chessarm_core::control::JointState;
use chessarm_core::control::choice::{ControllerKind, ControllerSpec};
use chessarm_core::control::gains::Gains;
use chessarm_core::control::servo_host::ServoCommand;
use chessarm_core::plan::trajectory::JointTrajectory;
use chessarm_core::sense::Conditions;
use chessarm_core::sim::batch::{LaneCount, LaneRun, SimdLevel, simulate_lanes};
use chessarm_core::sim::{Integrator, PayloadEvent, Plant, SimConfig, SimError, SimSummary};
use rayon::prelude::*;
use std::time::Instant;

/// `N` evenly spaced gains from `A` to `B` inclusive (`A..B:N`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GainRange {
    pub from: f64,
    pub to: f64,
    pub count: usize,
}

impl GainRange {
    /// Parses `A..B:N`: finite `0 ≤ A ≤ B`, whole `N ≥ 1` (at most a million); the error names
    /// the text.
    pub fn parse(text: &str) -> Result<Self, String> {
        let shape = || format!("'{text}' is not a range A..B:N (e.g. 100..900:40)");
        let (bounds, count) = text.split_once(':').ok_or_else(shape)?;
        let (from, to) = bounds.split_once("..").ok_or_else(shape)?;
        let number = |part: &str| -> Result<f64, String> {
            match part.trim().parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                Ok(v) => Err(format!("{v} in '{text}' is not finite")),
                Err(_) => Err(format!("'{part}' in '{text}' is not a number")),
            }
        };
        let (from, to) = (number(from)?, number(to)?);
        let count: usize =
            count.trim().parse().map_err(|_| format!("count '{count}' in '{text}' is not a whole number"))?;
        if count == 0 {
            return Err(format!("count 0 in '{text}': need at least one value"));
        }
        if from < 0.0 {
            return Err(format!("gain {from} in '{text}' must be >= 0"));
        }
        if from > to {
            return Err(format!("start {from} is above end {to} in '{text}'"));
        }
        if count > 1_000_000 {
            return Err(format!("count {count} in '{text}' is too large (at most 1000000)"));
        }
        Ok(GainRange { from, to, count })
    }

    /// The values, `from` first.
    pub fn values(&self) -> Vec<f64> {
        if self.count == 1 {
            return vec![self.from];
        }
        let step = (self.to - self.from) / (self.count - 1) as f64;
        (0..self.count).map(|i| if i + 1 == self.count { self.to } else { self.from + step * i as f64 }).collect()
    }
}

/// A metric to rank candidates by (smaller is better).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Metric {
    /// Largest tool-tip error over the run, mm.
    MaxTipError,
    /// RMS joint error over all joints and samples, rad.
    RmsJointError,
    /// Largest |τ| over all joints relative to the joint's limit.
    PeakTorque,
    /// Largest tool-tip error at the grip and release instants, mm.
    PlaceError,
}

impl Metric {
    /// The metric's name with its unit, for tables and plots.
    pub fn label(self) -> &'static str {
        match self {
            Metric::MaxTipError => "max tip error (mm)",
            Metric::RmsJointError => "RMS joint error (rad)",
            Metric::PeakTorque => "peak |τ| / limit",
            Metric::PlaceError => "placement error (mm)",
        }
    }
}

/// What a sweep runs, as the `tune` command's flags give it (the flags' names are in its
/// messages).
#[derive(Debug, Clone)]
pub struct TuneOptions {
    /// A game each candidate plays whole; `None`: the scenario.
    pub game: Option<GameRecord>,
    pub scenario: String,
    /// The outer loop whose gains are swept (pd, pid, adaptive or dob).
    pub controller: ControllerName,
    /// A torque controller's ranges, 1/s², 1/s, 1/s³ (ki for pid only).
    pub kp: Option<GainRange>,
    pub kd: Option<GainRange>,
    pub ki: Option<GainRange>,
    /// With servos: the range of their P register, swept for each of the setup's host strategies.
    pub p_gain: Option<GainRange>,
    /// Mass of the gripped piece of a scenario, kg.
    pub payload_mass: f64,
    pub controller_knows_payload: bool,
    /// Sensors, estimator, lag and model errors: every candidate runs the same trial.
    pub conditions: ConditionOptions,
    /// How a game's pieces are put down.
    pub placement: Placement,
    /// A scenario's initial joint angles at rest, rad (user convention).
    pub q0: Option<[f64; 4]>,
    /// Start of the tracking metrics, s (default: [`TRANSIENT_S`] with `q0`, else 0).
    pub tracking_from: Option<f64>,
    /// Slice K of N (1-based) of the candidates.
    pub shard: Option<(usize, usize)>,
    pub integrator: Integrator,
    /// Worker threads (`None`: all cores).
    pub threads: Option<usize>,
}

impl TuneOptions {
    /// A sweep of `kp` × `kd` of the PD controller on the default scenario, ideal conditions.
    pub fn new(kp: GainRange, kd: GainRange) -> Self {
        Self {
            game: None,
            scenario: "queens-gambit".into(),
            controller: ControllerName::Pd,
            kp: Some(kp),
            kd: Some(kd),
            ki: None,
            p_gain: None,
            payload_mass: 0.0,
            controller_knows_payload: false,
            conditions: ConditionOptions::default(),
            placement: Placement::default(),
            q0: None,
            tracking_from: None,
            shard: None,
            integrator: Integrator::default(),
            threads: None,
        }
    }

    /// The start of the tracking metrics, s: with `q0` unless `tracking_from` is given, after
    /// the start-up transient ([`TRANSIENT_S`]), since the start-up jump (530 mm at t = 0 from
    /// q = 0) would be every candidate's largest error.
    pub fn tracking_from(&self) -> f64 {
        self.tracking_from.unwrap_or(if self.q0.is_some() { TRANSIENT_S } else { 0.0 })
    }
}

/// A sweep's result.
#[derive(Debug, Clone)]
pub struct Tuned {
    /// The candidates run, in sweep order (a shard's only).
    pub candidates: Vec<Candidate>,
    /// Candidates in the whole sweep.
    pub sweep_size: usize,
    /// The candidates are the servos' P register under host strategies.
    pub servos: bool,
    /// Start of the tracking metrics, s.
    pub tracking_from: f64,
    pub wall_time_s: f64,
}

impl Tuned {
    /// The `top` best candidates by `metric` among those within the limits
    /// ([`Candidate::respects_limits`]), ties broken by sweep order.
    pub fn best(&self, metric: Metric, top: usize) -> Vec<&Candidate> {
        let mut best: Vec<&Candidate> = self.candidates.iter().filter(|c| c.respects_limits()).collect();
        best.sort_by(|a, b| a.metric(metric).total_cmp(&b.metric(metric)).then(a.index.cmp(&b.index)));
        best.truncate(top);
        best
    }

    /// Candidates that failed, and those that finished but saturated a motor.
    pub fn failed_and_saturated(&self) -> (usize, usize) {
        let failed = self.candidates.iter().filter(|c| c.status != "ok").count();
        let saturated = self.candidates.iter().filter(|c| c.status == "ok" && c.saturated_samples > 0).count();
        (failed, saturated)
    }
}

/// A sweep checked and ready to run: its settings, the shard's range, the study and what every
/// candidate shares. Every check of the options is made here, before anything runs.
#[derive(Debug)]
pub struct Prepared<'a> {
    setup: &'a Setup,
    options: &'a TuneOptions,
    settings: Vec<Setting>,
    range: std::ops::Range<usize>,
    study: Study,
    candidates: CandidateOptions,
}

impl<'a> Prepared<'a> {
    /// Checks `options` on `setup` (its motion limits as the study's) and plans the study.
    ///
    /// # Errors
    ///
    /// Bad ranges, conditions or thread count, a scenario the setup cannot plan.
    pub fn new(setup: &'a Setup, options: &'a TuneOptions) -> Result<Self> {
        crate::app::resources::batching()?;
        crate::app::resources::worker_threads(options.threads)?;
        let settings = settings(setup, options)?;
        let range = crate::app::resources::shard_range(settings.len(), options.shard);
        let conditions = crate::app::setup::conditions::Study::new(setup, &options.conditions, 1e-3)?;
        let trial =
            if conditions.is_ideal(setup) { None } else { Some(conditions.trial(options.conditions.run_seed())?) };
        let study = study(setup, options, trial.as_ref())?;
        let kind =
            controller_specs(&[options.controller], &GivenGains::default(), DefaultGains::Report)?.remove(0).kind;
        let candidates = CandidateOptions {
            pitch: options.game.is_some().then(|| super::robustness::preflight_pitch(setup)).flatten(),
            controller_knows_payload: options.controller_knows_payload,
            placement: options.placement,
            kind,
            knows_friction: options.conditions.knows_friction(setup),
            trial,
            integrator: options.integrator,
            tracking_from: options.tracking_from(),
            mass_error: conditions.mass_errors(
                setup,
                options.placement.payload_feedforward,
                options.controller_knows_payload,
            ),
            resolution: conditions.resolution(setup),
            p_conversions: crate::app::setup::servos::p_register_conversions(setup),
        };
        if options.game.is_some() && options.tracking_from.is_some() {
            bail!("--tracking-from goes with a scenario; a game starts every move on its trajectory");
        }
        Ok(Self { setup, options, settings, range, study, candidates })
    }

    /// Candidates this run simulates (the shard's).
    pub fn len(&self) -> usize {
        self.range.len()
    }

    /// Whether the shard has no candidate.
    pub fn is_empty(&self) -> bool {
        self.range.is_empty()
    }

    /// Runs the candidates on `options.threads` worker threads; `progress` is told of each
    /// candidate done, `stop` asked before each task.
    ///
    /// # Errors
    ///
    /// No worker threads, a bad `CHESSARM_LANES`, a cancelled run ([`interrupted`]).
    pub fn run(self, progress: Option<Progress<'_>>, stop: Stop<'_>) -> Result<Tuned> {
        let started = Instant::now();
        let candidates = sweep(
            self.setup,
            &self.study,
            &self.candidates,
            &self.settings,
            self.range,
            self.options.threads,
            progress,
            stop,
        )?;
        Ok(Tuned {
            candidates,
            sweep_size: self.settings.len(),
            servos: self.setup.actuators.take_positions(),
            tracking_from: self.candidates.tracking_from,
            wall_time_s: started.elapsed().as_secs_f64(),
        })
    }
}

/// Every candidate's setting in sweep order: a torque controller's gains, or with servos each
/// host strategy's P registers.
pub fn settings(setup: &Setup, options: &TuneOptions) -> Result<Vec<Setting>> {
    crate::app::setup::gripper::check_file_fingers(setup)?;
    if setup.actuators.take_positions() {
        return servo_settings(setup, options);
    }
    if options.p_gain.is_some() {
        bail!("--p-gain sweeps servos' P register; the joints have torque motors (give --actuator NAME)");
    }
    Ok(candidate_gains(options)?.into_iter().map(Setting::Torque).collect())
}

/// What one candidate is simulated on: a scenario, or a whole game played by the arm.
#[derive(Debug)]
pub enum Study {
    Scenario(ScenarioStudy),
    Game(GameRecord),
}

/// A scenario's trajectory with its payload events.
#[derive(Debug)]
pub struct ScenarioStudy {
    pub trajectory: JointTrajectory,
    pub events: Vec<PayloadEvent>,
    /// Grip and release instants, s.
    pub marks: Vec<f64>,
    pub initial: Option<JointState<4>>,
}

/// What one candidate runs: a torque controller's gains, or servos' P register under a host
/// strategy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Setting {
    Torque(Gains<4>),
    Servo { command: ServoCommand, p_gain: f64 },
}

/// One candidate's gains and metrics (SI, tip errors in mm).
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    pub index: usize,
    pub kp: f64,
    pub kd: f64,
    pub ki: f64,
    /// A servo candidate's host strategy and P register (`None`, NaN for torque controllers).
    pub servo_command: Option<ServoCommand>,
    pub p_gain: f64,
    /// "ok", or why the run failed (e.g. it diverged).
    pub status: String,
    pub max_tip_error_mm: f64,
    pub rms_tip_error_mm: f64,
    pub place_error_mm: f64,
    pub rms_joint_error_rad: f64,
    pub max_joint_error_rad: f64,
    pub peak_torque_nm: f64,
    /// Largest peak |τ| / torque limit over the joints.
    pub peak_torque_ratio: f64,
    pub saturated_samples: usize,
    /// Pieces off their squares at the end (games only).
    pub misplaced: usize,
}

impl Candidate {
    pub fn metric(&self, metric: Metric) -> f64 {
        match metric {
            Metric::MaxTipError => self.max_tip_error_mm,
            Metric::RmsJointError => self.rms_joint_error_rad,
            Metric::PeakTorque => self.peak_torque_ratio,
            Metric::PlaceError => self.place_error_mm,
        }
    }

    /// Finished, never hit a torque limit and left no piece misplaced (a servo's duty at its
    /// limit is how it moves fast, not a torque limit hit: its stalls show as errors).
    pub fn respects_limits(&self) -> bool {
        self.status == "ok" && (self.saturated_samples == 0 || self.servo_command.is_some()) && self.misplaced == 0
    }
}

/// A candidate with its gains (or servo setting) and no results yet.
fn blank_candidate(index: usize, setting: &Setting) -> Candidate {
    let (gains, servo_command, p_gain) = match setting {
        Setting::Torque(gains) => ([gains.kp[0], gains.kd[0], gains.ki[0]], None, f64::NAN),
        Setting::Servo { command, p_gain } => ([f64::NAN; 3], Some(*command), *p_gain),
    };
    Candidate {
        index,
        kp: gains[0],
        kd: gains[1],
        ki: gains[2],
        servo_command,
        p_gain,
        status: "ok".into(),
        max_tip_error_mm: f64::NAN,
        rms_tip_error_mm: f64::NAN,
        place_error_mm: f64::NAN,
        rms_joint_error_rad: f64::NAN,
        max_joint_error_rad: f64::NAN,
        peak_torque_nm: f64::NAN,
        peak_torque_ratio: f64::NAN,
        saturated_samples: 0,
        misplaced: 0,
    }
}

/// Metrics accumulated over one or more simulations.
#[derive(Default)]
struct Totals {
    samples: f64,
    squared_tip: f64,
    squared_joint: f64,
    max_tip: f64,
    max_joint: f64,
    peak_torque: f64,
    peak_ratio: f64,
    saturated: usize,
}

impl Totals {
    fn add(&mut self, summary: &SimSummary<4>, limits: &JointVector<4>) {
        let samples = summary.tracked_steps as f64;
        self.samples += samples;
        self.squared_tip += summary.rms_tip_error.powi(2) * samples;
        self.squared_joint += summary.rms_joint_error.norm_squared() / 4.0 * samples;
        self.max_tip = self.max_tip.max(summary.max_tip_error);
        self.max_joint = self.max_joint.max(summary.max_joint_error.max());
        self.peak_torque = self.peak_torque.max(summary.peak_torque.max());
        self.peak_ratio = self.peak_ratio.max(summary.peak_torque.component_div(limits).max());
        self.saturated += summary.saturated_samples;
    }

    fn fill(&self, candidate: &mut Candidate, place_error: f64) {
        candidate.max_tip_error_mm = self.max_tip * 1e3;
        candidate.rms_tip_error_mm = (self.squared_tip / self.samples).sqrt() * 1e3;
        candidate.place_error_mm = place_error * 1e3;
        candidate.rms_joint_error_rad = (self.squared_joint / self.samples).sqrt();
        candidate.max_joint_error_rad = self.max_joint;
        candidate.peak_torque_nm = self.peak_torque;
        candidate.peak_torque_ratio = self.peak_ratio;
        candidate.saturated_samples = self.saturated;
    }
}

/// Plays one candidate through the game `record` (1 ms steps of `options.integrator`, 1 kHz
/// control, torque limits of the model); a scenario's candidates go to
/// [`scenario_candidates`].
fn game_candidate(
    setup: &Setup,
    record: &GameRecord,
    options: &CandidateOptions,
    index: usize,
    setting: &Setting,
) -> Candidate {
    let mut candidate = blank_candidate(index, setting);
    let limits = setup.arm.torque_limits();
    let mut totals = Totals::default();
    let drive = Drive::of(setup, options, setting);
    let mut settings = PlaySettings::new("candidate", drive.gains);
    settings.controller.kind = drive.kind;
    settings.pieces = setup.pieces;
    settings.clearance = Some(setup.clearance.clone());
    settings.limits = setup.motion;
    settings.limits.tracking = drive.tracking(setup);
    settings.limits.tracking.mass_error = options.mass_error;
    settings.timing = setup.timing;
    if let Some(trial) = &options.trial {
        trial.apply_to(&mut settings);
    }
    if setup.actuators.take_positions() {
        settings.actuators = drive.actuators;
        settings.true_actuators = Some(drive.true_actuators);
        settings.control_period = drive.control_period;
    }
    settings.record_every = 0;
    settings.controller_knows_payload = options.controller_knows_payload;
    // The fine points' band with this candidate's servos (their stiffness is swept).
    let resolution = crate::app::setup::conditions::Resolution {
        holding_band: drive.actuators.holding_band(&setup.arm),
        ..options.resolution
    };
    options.placement.apply(&mut settings, chessarm_chess::play::DEFAULT_TOLERANCE, resolution);
    settings.integrator = options.integrator;
    settings.checked_pitch = options.pitch;
    // Candidates are compared at the pace given: no move is slowed.
    settings.choose_pace = false;
    let played = Game::new(setup.arm, setup.board, record.start.clone(), settings).and_then(|mut game| {
        let mut place = 0.0f64;
        for mv in &record.moves {
            let report = game.play(mv, Mover::Robot)?;
            if let Some(summary) = &report.summary {
                totals.add(summary, &limits);
            }
            place = report.place_errors.iter().fold(place, |a, b| a.max(*b));
        }
        Ok((place, game.misplaced().len()))
    });
    match played {
        Ok((place, misplaced)) => {
            totals.fill(&mut candidate, place);
            candidate.misplaced = misplaced;
        }
        Err(error) => candidate.status = format!("failed: {error}"),
    }
    candidate
}

/// A scenario candidate as a run of the batch simulator (1 ms steps of `options.integrator`,
/// 1 kHz control, torque limits of the model), or its status saying why it cannot start.
fn scenario_run<'a>(
    setup: &Setup,
    scenario: &'a ScenarioStudy,
    options: &CandidateOptions,
    setting: &Setting,
) -> Result<LaneRun<'a>, String> {
    let failed = |error: &dyn std::fmt::Display| format!("failed: {error}");
    let trial = options.trial.as_ref();
    let drive = Drive::of(setup, options, setting);
    // Servos' gears are part of the true plant.
    let plant = drive.true_actuators.plant_model(&trial.map_or(setup.arm, |t| t.plant)).map_err(|e| failed(&e))?;
    let spec = ControllerSpec {
        name: "candidate".into(),
        kind: drive.kind,
        gains: drive.gains,
        knows_friction: options.knows_friction,
    };
    let controller = spec.build_for(setup.arm, &drive.actuators).map_err(|error| failed(&error))?;
    let conditions = trial.map_or_else(Conditions::ideal, |t| t.conditions.clone());
    let feedback = conditions.feedback(drive.control_period).map_err(|error| failed(&error))?;
    let config = SimConfig {
        integrator: options.integrator,
        tracking_from: options.tracking_from,
        torque_lag: conditions.torque_lag,
        actuators: drive.true_actuators,
        control_period: drive.control_period,
        ..SimConfig::new(&Plant::new(plant))
    };
    Ok(LaneRun {
        plant,
        feedback,
        controller,
        reference: &scenario.trajectory,
        initial: scenario.initial,
        events: &scenario.events,
        marks: &scenario.marks,
        config,
    })
}

/// `candidate` with the metrics of its scenario run.
fn scenario_candidate(setup: &Setup, mut candidate: Candidate, result: Result<SimSummary<4>, SimError>) -> Candidate {
    match result {
        Ok(summary) => {
            let mut totals = Totals::default();
            totals.add(&summary, &setup.arm.torque_limits());
            let place = summary.tip_error_at_marks.iter().fold(0.0f64, |a, b| a.max(*b));
            totals.fill(&mut candidate, place);
        }
        Err(error) => candidate.status = format!("failed: {error}"),
    }
    candidate
}

/// The scenario candidates `indices`, `lanes` runs side by side at SIMD level `level`, in order.
fn scenario_candidates(
    setup: &Setup,
    scenario: &ScenarioStudy,
    options: &CandidateOptions,
    settings: &[Setting],
    indices: &[usize],
    (lanes, level): (LaneCount, SimdLevel),
) -> Vec<Candidate> {
    let mut out: Vec<Option<Candidate>> = vec![None; indices.len()];
    let mut runs = Vec::with_capacity(indices.len());
    let mut slots = Vec::with_capacity(indices.len());
    for (slot, &index) in indices.iter().enumerate() {
        let blank = blank_candidate(index, &settings[index]);
        match scenario_run(setup, scenario, options, &settings[index]) {
            Ok(run) => {
                runs.push(run);
                slots.push((slot, blank));
            }
            Err(status) => out[slot] = Some(Candidate { status, ..blank }),
        }
    }
    for ((slot, blank), result) in slots.into_iter().zip(simulate_lanes(&mut runs, lanes, level)) {
        out[slot] = Some(scenario_candidate(setup, blank, result));
    }
    out.into_iter().map(|candidate| candidate.unwrap_or_else(|| unreachable!("every slot is filled"))).collect()
}

/// Settings every candidate shares.
#[derive(Debug, Clone)]
pub struct CandidateOptions {
    /// The game's tool pitch, rad, when the pre-flight accepted the board, found once for every
    /// candidate (see [`chessarm_chess::play::PlaySettings::checked_pitch`]).
    pub pitch: Option<f64>,
    pub controller_knows_payload: bool,
    /// How a game's pieces are put down.
    pub placement: Placement,
    /// Which controller the gains are for.
    pub kind: ControllerKind,
    /// Whether the controller compensates its model's friction.
    pub knows_friction: bool,
    /// Sensors, estimator, lag and the true arm (`None`: ideal, the setup's arm); every
    /// candidate runs the same trial (the same draws and sensor noise).
    pub trial: Option<Trial>,
    pub integrator: Integrator,
    /// Start of the tracking metrics, s (see [`SimConfig::tracking_from`]).
    pub tracking_from: f64,
    /// A game's pieces' largest mass errors for the tracking budget, per kind (see
    /// [`crate::app::setup::conditions::Study::tracking`]), kg.
    pub mass_error: [f64; 6],
    /// What the fine points' band can resolve: the sensors' and the servos' counts.
    pub resolution: crate::app::setup::conditions::Resolution,
    /// Each joint's servo's P register conversion ([`crate::app::setup::servos::p_register_conversions`]).
    pub p_conversions: [Option<f64>; 4],
}

/// What drives a candidate's joints: its controller (a torque controller with its gains, or
/// a servo host), the actuators the host knows and the true ones, and the control period.
struct Drive {
    kind: ControllerKind,
    gains: Gains<4>,
    actuators: chessarm_core::sim::actuator::Actuators<4>,
    true_actuators: chessarm_core::sim::actuator::Actuators<4>,
    control_period: f64,
}

impl Drive {
    fn of(setup: &Setup, options: &CandidateOptions, setting: &Setting) -> Self {
        let true_actuators = options.trial.as_ref().map_or(setup.actuators, |t| t.actuators);
        match setting {
            Setting::Torque(gains) => Self {
                kind: options.kind,
                gains: *gains,
                actuators: setup.actuators,
                true_actuators,
                control_period: 1e-3,
            },
            Setting::Servo { command, p_gain } => {
                let with_p = |a| crate::app::setup::servos::with_p_register(a, &options.p_conversions, *p_gain);
                Self {
                    kind: ControllerKind::ServoHost(*command),
                    // A host has no gains; the number is not used.
                    gains: Gains::uniform(1.0, 1.0, 0.0).unwrap_or_else(|_| unreachable!("positive gains")),
                    actuators: with_p(&setup.actuators),
                    true_actuators: with_p(&true_actuators),
                    control_period: 1.0 / setup.bus_rate,
                }
            }
        }
    }

    /// The tracking budget of a game's carried pieces for this drive.
    fn tracking(&self, setup: &Setup) -> chessarm_chess::tasks::Tracking {
        setup.motion.tracking.for_actuators(&self.gains, &self.actuators, &setup.arm)
    }
}

/// Most candidates one sweep may describe.
pub const MAX_CANDIDATES: usize = 10_000_000;

/// The kp and kd ranges of a torque controller's sweep.
fn torque_ranges(options: &TuneOptions) -> Result<(GainRange, GainRange)> {
    match (options.kp, options.kd) {
        (Some(kp), Some(kd)) => Ok((kp, kd)),
        _ => bail!("tune sweeps a torque controller's --kp and --kd ranges (or servos' --p-gain with --actuator)"),
    }
}

/// The gains of every candidate, in sweep order: kp outermost, then kd, then ki.
pub fn candidate_gains(options: &TuneOptions) -> Result<Vec<Gains<4>>> {
    let (kp_range, kd_range) = torque_ranges(options)?;
    let pid = options.controller == ControllerName::Pid;
    if !matches!(
        options.controller,
        ControllerName::Pd | ControllerName::Pid | ControllerName::Adaptive | ControllerName::Dob
    ) {
        bail!("tune sweeps one controller: pd, pid, adaptive or dob, not {}", options.controller.name());
    }
    if options.ki.is_some() && !pid {
        bail!("--ki given with --controller {}: only pid has an integral term", options.controller.name());
    }
    if kp_range.from <= 0.0 {
        bail!("kp range starts at {}: kp must be > 0", kp_range.from);
    }
    let ki_values = match (&options.ki, pid) {
        (Some(range), _) => range.values(),
        (None, true) => bail!("--controller pid needs a --ki range"),
        (None, false) => vec![0.0],
    };
    let count = kp_range.count as f64 * kd_range.count as f64 * ki_values.len() as f64;
    if count > MAX_CANDIDATES as f64 {
        bail!("the sweep has {count:e} candidates, more than {MAX_CANDIDATES}; split it with fewer values or --shard");
    }
    // Every candidate's gains, its row of results and its CSV line are held at once.
    let ranges = |flag: &str, range: &GainRange| format!("{flag} {}..{}:{}", range.from, range.to, range.count);
    let mut cause = format!("{} {}", ranges("--kp", &kp_range), ranges("--kd", &kd_range));
    if let Some(ki) = &options.ki {
        cause.push_str(&format!(" {}", ranges("--ki", ki)));
    }
    crate::app::resources::ensure_fits(
        &cause,
        "candidates",
        count,
        (std::mem::size_of::<Gains<4>>() + std::mem::size_of::<Candidate>() + 160) as f64,
    )?;
    let mut all = Vec::new();
    for kp in kp_range.values() {
        for kd in kd_range.values() {
            for &ki in &ki_values {
                all.push(Gains::uniform(kp, kd, ki)?);
            }
        }
    }
    Ok(all)
}

/// The study a sweep runs: the game if one is given, else the scenario (whose payload is
/// `trial`'s true pawn, if the sweep runs under realistic conditions).
pub fn study(setup: &Setup, options: &TuneOptions, trial: Option<&Trial>) -> Result<Study> {
    if let Some(record) = &options.game {
        if options.payload_mass > 0.0 || options.q0.is_some() {
            bail!("--payload-mass and --q0 go with a scenario; a game grips real pieces from its home position");
        }
        return Ok(Study::Game(record.clone()));
    }
    scenario_study(setup, options, trial).map(Study::Scenario)
}

/// The scenario study of a sweep.
fn scenario_study(setup: &Setup, options: &TuneOptions, trial: Option<&Trial>) -> Result<ScenarioStudy> {
    let plan = plan_scenario(setup, &options.scenario, 1e-3, "the sweep")?;
    ensure_tracked(options.tracking_from(), &plan)?;
    let events = pawn_events(setup, trial, &plan.path, options.payload_mass, options.controller_knows_payload);
    let marks = plan.path.events().iter().map(|e| e.time).collect();
    let initial = options.q0.map(|q| JointState::at_rest(JointVector::from(setup.convention.user(q))));
    Ok(ScenarioStudy { trajectory: plan.joint, events, marks, initial })
}

/// Runs the candidates `range` on `threads` worker threads (all cores when `None`).
#[allow(clippy::too_many_arguments)]
pub fn sweep(
    setup: &Setup,
    study: &Study,
    options: &CandidateOptions,
    settings: &[Setting],
    range: std::ops::Range<usize>,
    threads: Option<usize>,
    progress: Option<Progress<'_>>,
    stop: Stop<'_>,
) -> Result<Vec<Candidate>> {
    let threads = crate::app::resources::worker_threads(threads)?;
    let batching = crate::app::resources::batching()?;
    let pool =
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().context("cannot start the worker threads")?;
    let record = match study {
        Study::Game(record) => record,
        Study::Scenario(scenario) => {
            // A batch of candidates per task: the lanes of one batch simulator.
            let indices: Vec<usize> = range.collect();
            let batches: Result<Vec<Vec<Candidate>>> = pool.install(|| {
                indices
                    .par_chunks(crate::app::resources::per_task(indices.len(), threads, batching.0))
                    .map(|chunk| {
                        if stop() {
                            return Err(interrupted());
                        }
                        let candidates = scenario_candidates(setup, scenario, options, settings, chunk, batching);
                        if let Some(progress) = progress {
                            progress(chunk.len() as u64);
                        }
                        Ok(candidates)
                    })
                    .collect()
            });
            return Ok(batches?.into_iter().flatten().collect());
        }
    };
    pool.install(|| {
        range
            .into_par_iter()
            .map(|index| {
                if stop() {
                    return Err(interrupted());
                }
                let candidate = game_candidate(setup, record, options, index, &settings[index]);
                if let Some(progress) = progress {
                    progress(1);
                }
                Ok(candidate)
            })
            .collect()
    })
}

/// A warning when the best pick lies on the edge of the swept range of a gain (one swept over
/// more than one value): the optimum may lie beyond it.
pub fn edge_warning(options: &TuneOptions, best: Option<&Candidate>) -> Option<String> {
    let best = best?;
    if best.servo_command.is_some() {
        return servo_edge_warning(options, best);
    }
    let (kp_range, kd_range) = torque_ranges(options).ok()?;
    let per_cell = options.ki.map_or(1, |r| r.count);
    let kd_count = kd_range.count;
    let cell = best.index / per_cell;
    let axes = [
        ("kp", "--kp", cell / kd_count, kp_range.count),
        ("kd", "--kd", cell % kd_count, kd_count),
        ("ki", "--ki", best.index % per_cell, per_cell),
    ];
    let edges: Vec<String> = axes
        .iter()
        .filter(|(_, _, index, count)| *count > 1 && (*index == 0 || index + 1 == *count))
        .map(|(name, flag, index, _)| {
            format!("{name} at its {} ({flag})", if *index == 0 { "smallest" } else { "largest" })
        })
        .collect();
    (!edges.is_empty()).then(|| {
        format!(
            "the best pick (kp {}, kd {}{}) lies on the edge of the sweep: {}; widen the range",
            tick(best.kp),
            tick(best.kd),
            if per_cell > 1 { format!(", ki {}", tick(best.ki)) } else { String::new() },
            edges.join(", ")
        )
    })
}

/// A servo sweep's candidates: every host strategy of the setup's `servo_commands` (outer) at
/// every P register value of `p_gain` (inner). Every joint's servo must have a P register.
fn servo_settings(setup: &Setup, options: &TuneOptions) -> Result<Vec<Setting>> {
    if options.kp.is_some() || options.kd.is_some() || options.ki.is_some() {
        bail!("--kp, --kd and --ki are a torque controller's; with servos (--actuator) sweep --p-gain A..B:N");
    }
    let Some(range) = options.p_gain else {
        bail!("tune with servos sweeps their P register: give --p-gain A..B:N (e.g. 8..64:8)");
    };
    if range.from <= 0.0 {
        bail!("--p-gain range starts at {}: the P register must be > 0", range.from);
    }
    let conversions = crate::app::setup::servos::p_register_conversions(setup);
    if let Some(j) = conversions.iter().position(Option::is_none) {
        bail!(
            "--p-gain: joint {}'s actuator {} has no P register to sweep (a stepper, or an [actuators] table without `base`)",
            j + 1,
            setup.actuator_names[j]
        );
    }
    let count = range.count as f64 * setup.servo_commands.len() as f64;
    if count > MAX_CANDIDATES as f64 {
        bail!("the sweep has {count:e} candidates, more than {MAX_CANDIDATES}; split it with fewer values or --shard");
    }
    Ok(setup
        .servo_commands
        .iter()
        .flat_map(|command| range.values().into_iter().map(move |p_gain| Setting::Servo { command: *command, p_gain }))
        .collect())
}

/// A warning when a servo sweep's best pick has the smallest or largest P register swept.
fn servo_edge_warning(options: &TuneOptions, best: &Candidate) -> Option<String> {
    let range = options.p_gain?;
    let index = best.index % range.count;
    (range.count > 1 && (index == 0 || index + 1 == range.count)).then(|| {
        format!(
            "the best pick ({} at P {}) has the {} P register swept (--p-gain); widen the range",
            best.servo_command.map_or("?", |c| c.name()),
            tick(best.p_gain),
            if index == 0 { "smallest" } else { "largest" }
        )
    })
}
