//! `gains`: outer-loop gains from response specs, verified by simulating the scenario.

use crate::app::resources::show;
use crate::app::setup::conditions::Study;
use crate::app::setup::file::Setup;
use crate::app::studies::plan::plan_scenario;
use crate::app::studies::simulate::{RunOptions, run_controller};
use crate::app::text::one_line;
use crate::cli::{ControllerChoice, GainsArgs};
use anyhow::{Result, bail};
use chessarm_core::control::choice::{ControllerKind, ControllerSpec};
use chessarm_core::control::gains::{Gains, ResponseShape, design_from_specs};
use chessarm_core::sim::Integrator;
use chessarm_core::sim::metrics::error_response;
use serde_json::{Value, json};

/// Integral pole ratio α for `--wn/--zeta` PID designs when none is given.
const DEFAULT_INTEGRAL_POLE_RATIO: f64 = 0.2;

/// The gains of one controller from the arguments, with ωn (rad/s) and ζ. A design that fails
/// is reported with the flags as typed (the derived value that failed follows).
fn design(args: &GainsArgs, pid: bool) -> Result<(Gains<4>, f64, f64, f64)> {
    design_unnamed(args, pid).map_err(|error| {
        let flags = match (args.settling_time, args.wn, args.zeta) {
            (Some(settling_time), ..) => {
                format!("--settling-time {} --overshoot {}", show(settling_time), show(args.overshoot))
            }
            (None, Some(wn), Some(zeta)) => format!("--wn {} --zeta {}", show(wn), show(zeta)),
            _ => String::new(),
        };
        let ratio = args.integral_pole_ratio.map(|r| format!(" --integral-pole-ratio {}", show(r))).unwrap_or_default();
        anyhow::anyhow!("{flags}{ratio}: no usable {} design ({})", if pid { "PID" } else { "PD" }, one_line(&error))
    })
}

fn design_unnamed(args: &GainsArgs, pid: bool) -> Result<(Gains<4>, f64, f64, f64)> {
    match (args.settling_time, args.wn, args.zeta) {
        (Some(settling_time), None, _) => {
            Ok(design_from_specs(settling_time, args.overshoot, pid.then_some(args.integral_pole_ratio))?)
        }
        (None, Some(wn), Some(zeta)) => {
            if !pid {
                return Ok((Gains::pd_from_natural_frequency(wn, zeta)?, wn, zeta, 0.0));
            }
            let ratio = args.integral_pole_ratio.unwrap_or(DEFAULT_INTEGRAL_POLE_RATIO);
            Ok((Gains::pid_from_poles(wn, zeta, ratio)?, wn, zeta, ratio))
        }
        _ => bail!("give --settling-time [--overshoot] or --wn with --zeta"),
    }
}

pub fn run(setup: &Setup, args: &GainsArgs) -> Result<()> {
    let controllers: &[(&str, bool)] = match args.controller {
        ControllerChoice::Pd => &[("pd", false)],
        ControllerChoice::Pid => &[("pid", true)],
        ControllerChoice::Both => &[("pd", false), ("pid", true)],
    };
    let mut designs = Vec::new();
    let mut human = String::new();
    for &(name, pid) in controllers {
        let (gains, wn, zeta, ratio) = design(args, pid)?;
        let spec = ControllerSpec {
            name: name.into(),
            kind: ControllerKind::ComputedTorque,
            gains,
            knows_friction: args.conditions.options().knows_friction(setup),
        };
        // What the design promises: the exact response of the error dynamics.
        let shape = ResponseShape::of(zeta, ratio);
        let poles: Vec<[f64; 2]> = gains.closed_loop_poles(0).iter().map(|p| [p.re, p.im]).collect();
        let measured = if args.no_verify { Value::Null } else { verify(setup, args, &spec)? };
        human.push_str(&design_table(name, &gains, (wn, zeta, ratio, pid), &shape, args, &measured));
        designs.push(json!({
            "controller": name,
            "wn_rad_s": wn,
            "zeta": zeta,
            "integral_pole_ratio": pid.then_some(ratio),
            "kp": gains.kp.as_slice(), "kd": gains.kd.as_slice(), "ki": gains.ki.as_slice(),
            "closed_loop_poles": poles,
            "requested": {
                "settling_time_s": args.settling_time,
                "overshoot_percent": args.settling_time.map(|_| args.overshoot),
            },
            "designed": { "settling_time_s": shape.settling / wn, "overshoot_percent": shape.overshoot_percent },
            "measured": measured,
        }));
    }
    crate::emit(&human, &json!({ "designs": designs }))?;
    Ok(())
}

/// One design as a table for people: the gains and closed-loop poles of each joint, and the
/// settling time and overshoot asked for, designed and measured in simulation.
fn design_table(
    name: &str,
    gains: &Gains<4>,
    (wn, zeta, ratio, pid): (f64, f64, f64, bool),
    shape: &ResponseShape,
    args: &GainsArgs,
    measured: &Value,
) -> String {
    let integral = if pid { format!(", integral pole at {} × ζωn", show(ratio)) } else { String::new() };
    let mut text = format!("{}: ωn = {wn:.4} rad/s, ζ = {zeta:.4}{integral}\n", name.to_uppercase());
    let requested = match args.settling_time {
        Some(t) => format!("{} s / {} %", show(t), show(args.overshoot)),
        None => "-".into(),
    };
    text.push_str(&format!(
        "{:>5} {:>10} {:>10} {:>10}  {:<40} {:>22} {:>22}\n",
        "joint", "kp", "kd", "ki", "closed-loop poles (1/s)", "settling s asked/des./sim.", "overshoot % des./sim."
    ));
    let number = |v: &Value| v.as_f64().map_or("-".to_string(), |x| format!("{x:.3}"));
    for j in 0..4 {
        let poles: Vec<String> = gains
            .closed_loop_poles(j)
            .iter()
            .map(|p| {
                let (re, im) = (p.re + 0.0, p.im + 0.0);
                if im.abs() < 1e-9 { format!("{re:.3}") } else { format!("{re:.3}{:+.3}i", im) }
            })
            .collect();
        let asked = args.settling_time.map_or("-".to_string(), |t| format!("{t:.3}"));
        text.push_str(&format!(
            "{:>5} {:>10.3} {:>10.3} {:>10.3}  {:<40} {:>22} {:>22}\n",
            j + 1,
            gains.kp[j],
            gains.kd[j],
            gains.ki[j],
            poles.join(", "),
            format!("{asked} / {:.3} / {}", shape.settling / wn, number(&measured["settling_time_s"][j])),
            format!("{:.2} / {}", shape.overshoot_percent, number(&measured["overshoot_percent"][j])),
        ));
    }
    if measured.is_null() {
        text.push_str("(not simulated: --no-verify)\n");
    } else {
        text.push_str(&format!(
            "asked {requested}; simulated from a {} rad error on every joint: worst settling {} s, worst overshoot {} %, {} saturated samples\n",
            show(args.initial_error),
            number(&measured["worst_settling_time_s"]),
            number(&measured["worst_overshoot_percent"]),
            measured["saturation_count"]
        ));
    }
    text.push('\n');
    text
}

/// Simulates the scenario from an initial error on every joint and measures each joint's
/// error response (2 % settling time, overshoot). With an exact model the error dynamics are
/// linear, so the transient is the run from the offset minus the run from the trajectory's
/// start: that removes the small forced error of the 1 kHz hold, which is of the order of the
/// 2 % band itself.
fn verify(setup: &Setup, args: &GainsArgs, spec: &ControllerSpec) -> Result<Value> {
    let plan = plan_scenario(setup, &args.scenario, 1e-3, "the verification run")?;
    let start = plan.joint.first().q;
    let q0: [f64; 4] = std::array::from_fn(|j| start[j] - args.initial_error);
    let study = Study::new(setup, &args.conditions.options(), 1e-3)?;
    let (trial, conditions) = if study.is_ideal(setup) {
        (None, Value::Null)
    } else {
        (Some(study.trial(args.conditions.options().run_seed())?), study.describe())
    };
    let options = RunOptions {
        dt: 1e-3,
        integrator: Integrator::default(),
        control_period: 1e-3,
        q0: Some(q0),
        payload_mass: 0.0,
        controller_knows_payload: false,
        tracking_from: 0.0,
        rate_flags: "the verification run".into(),
        trial,
        conditions: conditions.clone(),
    };
    let run = run_controller(setup, &plan, spec, &options, None)?;
    let trial_json = options.trial.as_ref().map(crate::app::setup::conditions::Trial::describe);
    let forced = run_controller(setup, &plan, spec, &RunOptions { q0: None, ..options }, None)?;
    let mut settling = Vec::new();
    let mut overshoot = Vec::new();
    for j in 0..4 {
        let error = |r: &chessarm_core::sim::StepRecord<4>| r.reference.q[j] - r.state.q[j];
        let samples: Vec<(f64, f64)> =
            run.records.iter().zip(&forced.records).map(|(r, f)| (r.t, error(r) - error(f))).collect();
        if let Some(response) = error_response(&samples, 0.02) {
            settling.push(response.settling_time);
            overshoot.push(response.overshoot_percent);
        }
    }
    let worst = |values: &[f64]| values.iter().copied().fold(0.0, f64::max);
    Ok(json!({
        "initial_error_rad": args.initial_error,
        "settling_time_s": settling,
        "overshoot_percent": overshoot,
        "worst_settling_time_s": worst(&settling),
        "worst_overshoot_percent": worst(&overshoot),
        "saturation_count": run.summary.saturated_samples,
        "conditions": conditions,
        "trial": trial_json,
    }))
}
