//! Simulating a scenario: each controller along the scenario's planned trajectory, in the
//! plant of the setup (or of a trial's drawn arm), through the trial's sensors and estimator,
//! the gripped piece carried from each grip to its release; metrics and every step kept.

use crate::app::resources::show;
use crate::app::setup::conditions::Trial;
use crate::app::setup::file::Setup;
use crate::app::studies::plan::{Plan, plan_scenario};
use anyhow::{Context, Result, bail};
use chessarm_chess::pieces::PieceDimensions;
use chessarm_core::arm::model::{JointVector, Payload};
use chessarm_core::control::JointState;
use chessarm_core::control::choice::{ControllerKind, ControllerSpec};
use chessarm_core::control::gains::{GAME_PD, Gains, REPORT_PD, REPORT_PID};
use chessarm_core::plan::path::{CartesianPath, GripperAction};
use chessarm_core::sim::{
    Integrator, Observer, PayloadEvent, Plant, SimConfig, SimSummary, StepRecord, simulate_sensed,
};
use serde_json::Value;
use std::time::Instant;

/// A controller of `simulate` and `robustness`, in a comma-separated list.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ControllerName {
    /// Computed torque with a PD outer loop (report: kp = 400, kd = 20).
    Pd,
    /// Computed torque with a PID outer loop and anti-windup (report: kp = 600, kd = 25, ki = 75).
    Pid,
    /// The report's PID as it was, without anti-windup (its start-up wind-up spoils the grip).
    PidPlain,
    /// Computed torque that estimates the gripped piece's mass online (PD gains).
    Adaptive,
    /// Computed torque with a disturbance observer (PD gains).
    Dob,
    /// pd and pid.
    Both,
}

impl ControllerName {
    pub fn name(self) -> &'static str {
        match self {
            ControllerName::Pd => "pd",
            ControllerName::Pid => "pid",
            ControllerName::PidPlain => "pid-plain",
            ControllerName::Adaptive => "adaptive",
            ControllerName::Dob => "dob",
            ControllerName::Both => "both",
        }
    }
}

/// Outer-loop gains the user gave, each one value per joint; the defaults fill what is left out.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GivenGains {
    /// Proportional gain, 1/s².
    pub kp: Option<[f64; 4]>,
    /// Derivative gain, 1/s.
    pub kd: Option<[f64; 4]>,
    /// Integral gain, 1/s³ (PID only).
    pub ki: Option<[f64; 4]>,
}

/// A count of simulated steps, told as they pass.
pub use crate::app::studies::Progress;

/// The piece gripped in the report's scenario: the setup's pawn with the given mass (kg).
pub fn gripped_pawn(setup: &Setup, mass: f64) -> Payload {
    PieceDimensions { mass, ..setup.pieces.pawn }.payload()
}

/// The true mass of a pawn the controller believes weighs `mass` kg: scaled as the trial's
/// pawn is to the setup's.
pub fn true_pawn_mass(setup: &Setup, trial: Option<&Trial>, mass: f64) -> f64 {
    trial.map_or(mass, |t| mass * t.pieces.pawn.mass / setup.pieces.pawn.mass)
}

/// Payload events of a path: the trial's true pawn, gripped at every grip mark and released
/// at every release mark (none when the mass is 0). `mass` is the pawn's nominal mass, kg (the
/// controller's belief); the true one is scaled as the trial's pawn is to the setup's.
pub fn pawn_events(
    setup: &Setup,
    trial: Option<&Trial>,
    path: &CartesianPath,
    mass: f64,
    controller_knows: bool,
) -> Vec<PayloadEvent> {
    if mass <= 0.0 {
        return Vec::new();
    }
    let pawn = trial.map_or(setup.pieces.pawn, |t| t.pieces.pawn);
    let payload = PieceDimensions { mass: true_pawn_mass(setup, trial, mass), ..pawn }.payload();
    path.events()
        .iter()
        .map(|event| {
            PayloadEvent::new(event.time, (event.action == GripperAction::Grip).then_some(payload), controller_knows)
        })
        .collect()
}

/// Simulation settings shared by the controllers of one study.
#[derive(Debug, Clone)]
pub struct RunOptions {
    pub dt: f64,
    pub integrator: Integrator,
    pub control_period: f64,
    pub q0: Option<[f64; 4]>,
    pub payload_mass: f64,
    pub controller_knows_payload: bool,
    /// Start of the tracking metrics, s.
    pub tracking_from: f64,
    /// The flags that set the time step and rate, as typed, for error messages.
    pub rate_flags: String,
    /// Sensors, estimator, lag and the true arm (ideal: the setup's arm, exact state).
    pub trial: Option<Trial>,
    /// The study's conditions, for summary.json (null when ideal).
    pub conditions: Value,
}

/// One controller's run: metrics and the time series.
#[derive(Debug)]
pub struct ControllerRun {
    pub spec: ControllerSpec,
    pub summary: SimSummary<4>,
    pub records: Vec<StepRecord<4>>,
    pub wall_time_s: f64,
}

/// Which gains a controller takes when none are given.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DefaultGains {
    /// The report's: PID's for pid and pid-plain, PD's for the others (scenarios, the study).
    Report,
    /// Whole games': [`GAME_PD`] for every controller, PID with the report's `ki`.
    Game,
}

/// The controllers `names` asks for (in order, each once; `both` is pd and pid), with the
/// `defaults` gains unless overridden.
pub fn controller_specs(
    names: &[ControllerName],
    given: &GivenGains,
    defaults: DefaultGains,
) -> Result<Vec<ControllerSpec>> {
    let GivenGains { kp, kd, ki } = *given;
    let make = |name: &str, kind: ControllerKind, (default_kp, default_kd, default_ki): (f64, f64, f64)| {
        let pick = |given: Option<[f64; 4]>, default: f64| JointVector::<4>::from(given.unwrap_or([default; 4]));
        let ki = if name.starts_with("pid") { pick(ki, default_ki) } else { JointVector::zeros() };
        let gains = Gains::per_joint(pick(kp, default_kp), pick(kd, default_kd), ki)?;
        Ok::<_, anyhow::Error>(ControllerSpec { name: name.to_string(), kind, gains, knows_friction: false })
    };
    let mut wanted: Vec<ControllerName> = Vec::new();
    for name in names {
        let expanded: &[ControllerName] = if *name == ControllerName::Both {
            &[ControllerName::Pd, ControllerName::Pid]
        } else {
            std::slice::from_ref(name)
        };
        for name in expanded {
            if !wanted.contains(name) {
                wanted.push(*name);
            }
        }
    }
    if ki.is_some() && !wanted.iter().any(|n| matches!(n, ControllerName::Pid | ControllerName::PidPlain)) {
        let list: Vec<&str> = wanted.iter().map(|n| n.name()).collect();
        bail!("--ki given with --controller {}: only pid and pid-plain have an integral term", list.join(","));
    }
    let (pd, pid) = match defaults {
        DefaultGains::Report => ((REPORT_PD.0, REPORT_PD.1, 0.0), REPORT_PID),
        DefaultGains::Game => ((GAME_PD.0, GAME_PD.1, 0.0), (GAME_PD.0, GAME_PD.1, REPORT_PID.2)),
    };
    wanted
        .iter()
        .map(|name| match name {
            ControllerName::Pd | ControllerName::Both => make("pd", ControllerKind::ComputedTorque, pd),
            ControllerName::Pid => make("pid", ControllerKind::AntiWindupPid, pid),
            ControllerName::PidPlain => make("pid-plain", ControllerKind::ComputedTorque, pid),
            ControllerName::Adaptive => make("adaptive", ControllerKind::Adaptive, pd),
            ControllerName::Dob => make("dob", ControllerKind::DisturbanceObserver, pd),
        })
        .collect()
}

/// Keeps every step and moves a progress bar.
struct Recorder<'a> {
    records: Vec<StepRecord<4>>,
    progress: Option<Progress<'a>>,
}

impl Observer<4> for Recorder<'_> {
    fn observe(&mut self, record: &StepRecord<4>) {
        self.records.push(*record);
        if let Some(tell) = self.progress
            && self.records.len().is_multiple_of(500)
        {
            tell(500);
        }
    }
}

/// Simulates one controller along `plan` (whose trajectory must be sampled at the control
/// period). The gripped piece is carried from each grip to the next release.
pub fn run_controller(
    setup: &Setup,
    plan: &Plan,
    spec: &ControllerSpec,
    options: &RunOptions,
    progress: Option<Progress<'_>>,
) -> Result<ControllerRun> {
    let trial = options.trial.as_ref();
    // Servos' gears are part of the plant (armature, friction, back-EMF).
    let actuators = trial.map_or(setup.actuators, |t| t.actuators);
    let plant_model = actuators.plant_model(&trial.map_or(setup.arm, |t| t.plant))?;
    let mut plant = Plant::new(plant_model);
    let mut controller =
        spec.build_for(setup.arm, &setup.actuators).with_context(|| format!("controller {}", spec.name))?;
    let conditions = trial.map_or_else(chessarm_core::sense::Conditions::ideal, |t| t.conditions.clone());
    // A servo host samples at the bus rate.
    let control_period = crate::app::setup::servos::control_period(setup, options.control_period);
    let mut feedback = conditions.feedback(control_period)?;
    let config = SimConfig {
        dt: options.dt,
        control_period,
        actuators,
        integrator: options.integrator,
        tracking_from: options.tracking_from,
        torque_lag: conditions.torque_lag,
        ..SimConfig::new(&plant)
    };
    let events = pawn_events(setup, trial, &plan.path, options.payload_mass, options.controller_knows_payload);
    let marks: Vec<f64> = plan.path.events().iter().map(|e| e.time).collect();
    // --q0 is in the user's convention (a URDF's own sense), the model's from here.
    let initial = options.q0.map(|q0| JointState::at_rest(JointVector::from(setup.convention.user(q0))));
    let mut recorder = Recorder { records: Vec::with_capacity(plan.joint.samples().len() + 1), progress };
    let started = Instant::now();
    let summary = simulate_sensed(
        &mut plant,
        &mut feedback,
        controller.as_mut(),
        &plan.joint,
        initial,
        &events,
        &marks,
        &config,
        &mut recorder,
    )
    .with_context(|| format!("controller {}", spec.name))?;
    let wall_time_s = started.elapsed().as_secs_f64();
    Ok(ControllerRun { spec: spec.clone(), summary, records: recorder.records, wall_time_s })
}

/// The start-up span after a start at rest off the trajectory (`--q0`), s: the demo's table
/// shows the tip error after it, and `tune` starts its tracking metrics there by default.
pub const TRANSIENT_S: f64 = 1.0;

/// Refuses a start of the tracking metrics at or past the end of the plan (`--tracking-from`).
pub fn ensure_tracked(tracking_from: f64, plan: &Plan) -> Result<()> {
    if tracking_from >= plan.path.duration() {
        bail!(
            "--tracking-from {} s is at or past the end of the {:.0} s scenario: no step would be measured",
            show(tracking_from),
            plan.path.duration()
        );
    }
    Ok(())
}

/// Largest tool-tip error of a recorded run from `from` s on, m.
pub fn max_tip_error_from(run: &ControllerRun, from: f64) -> f64 {
    run.records.iter().filter(|r| r.t >= from).map(|r| (r.tip - r.tip_desired).norm()).fold(0.0, f64::max)
}

/// Steps one study takes per controller, for progress bars.
pub fn study_steps(setup: &Setup, scenario: &str, options: &RunOptions) -> Result<u64> {
    let path = chessarm_chess::scenario::scenario(scenario, &setup.board)
        .map(|s| s.path(&setup.board))
        .transpose()?
        .map_or(0.0, |p| p.duration());
    // In floating point and capped (at the core's largest run), so absurd --dt values cannot
    // overflow the count before the memory estimate refuses them.
    Ok(((path / options.dt).round().min(chessarm_core::plan::path::MAX_SAMPLES as f64) as u64).saturating_add(1))
}

/// Distance of the scenario's piece from its target square's centre where the simulated tool
/// released it, m (`None` without a grip and a release).
pub fn placement_error(plan: &Plan, summary: &SimSummary<4>) -> Option<f64> {
    let (grip, release) = (summary.tip_at_marks.first()?, summary.tip_at_marks.get(1)?);
    let (standing, target) = plan.placement?;
    Some((chessarm_chess::play::placed_position(&plan.base, grip, release, &standing) - target).norm())
}

/// A scenario simulated with every controller of a study: its plan and one run per controller.
#[derive(Debug)]
pub struct ScenarioRuns {
    pub plan: Plan,
    pub runs: Vec<ControllerRun>,
}

/// Simulates `scenario` with each controller of `specs` (the plan sampled at the control
/// period, the tracking metrics from `options.tracking_from`), every step kept.
///
/// # Errors
///
/// An unknown scenario, a plan that does not fit in memory, a tracking start past the end, a
/// controller that cannot be built for the arm or a simulation that fails.
pub fn simulate_scenario(
    setup: &Setup,
    scenario: &str,
    specs: &[ControllerSpec],
    options: &RunOptions,
    progress: Option<Progress<'_>>,
) -> Result<ScenarioRuns> {
    let cause = options.rate_flags.as_str();
    let plan = plan_scenario(setup, scenario, options.control_period, cause)?;
    ensure_tracked(options.tracking_from, &plan)?;
    // Every step of every controller is kept, with the points of its plots.
    let steps = (plan.path.duration() / options.dt).ceil() + 1.0;
    crate::app::resources::ensure_fits(
        cause,
        "recorded steps",
        steps * specs.len() as f64,
        (std::mem::size_of::<StepRecord<4>>() + 17 * std::mem::size_of::<(f64, f64)>()) as f64,
    )?;
    let runs = specs.iter().map(|spec| run_controller(setup, &plan, spec, options, progress)).collect::<Result<_>>()?;
    Ok(ScenarioRuns { plan, runs })
}
