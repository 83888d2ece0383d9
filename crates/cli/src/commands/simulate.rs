//! `simulate` and `dynamics`: the report's closed-loop study and the dynamics terms.

use crate::app::formats::simulation::{comparison_table, files_of, write_study};
use crate::app::resources::{show, show_list};
use crate::app::setup::conditions::Study;
use crate::app::setup::file::Setup;
use crate::app::studies::simulate::{
    DefaultGains, RunOptions, controller_specs, gripped_pawn, simulate_scenario, study_steps,
};
use crate::cli::{DynamicsArgs, SimulateArgs};
use anyhow::{Result, bail};
use chessarm_core::arm::dynamics::{DynamicsTerms, coriolis_torques, gravity_torques};
use chessarm_core::arm::model::JointVector;
use serde_json::{Value, json};

pub fn options_from(setup: &Setup, args: &SimulateArgs) -> Result<RunOptions> {
    let control_period = 1.0 / args.control_rate;
    let study = Study::new(setup, &args.conditions.options(), control_period)?;
    let (trial, conditions) = if study.is_ideal(setup) {
        (None, Value::Null)
    } else {
        crate::tell(&study.note(args.conditions.options().run_seed()));
        (Some(study.trial(args.conditions.options().run_seed())?), study.describe())
    };
    Ok(RunOptions {
        dt: args.dt,
        integrator: args.integrator.integrator(),
        control_period: 1.0 / args.control_rate,
        q0: args.q0,
        payload_mass: args.payload_mass,
        controller_knows_payload: args.controller_knows_payload,
        tracking_from: args.tracking_from,
        rate_flags: format!("--dt {} with --control-rate {}", show(args.dt), show(args.control_rate)),
        trial,
        conditions,
    })
}

/// Checks `--dt` against `--control-rate` before anything runs, naming both flags as typed.
fn check_rates(args: &SimulateArgs) -> Result<()> {
    let (dt, rate) = (show(args.dt), show(args.control_rate));
    let period = 1.0 / args.control_rate;
    if !period.is_finite() {
        bail!("--control-rate {rate} Hz is too small: its sample period 1/{rate} s is not a finite number");
    }
    let ratio = period / args.dt;
    if ratio.round() < 1.0 || (ratio - ratio.round()).abs() > 1e-9 * ratio {
        bail!(
            "--control-rate {rate} Hz (a sample every {} s) must be a whole multiple of the time step --dt {dt} s: \
             the controller samples every k-th step (e.g. --control-rate {} for k = 1)",
            show(period),
            show(1.0 / args.dt)
        );
    }
    Ok(())
}

pub fn run(setup: &Setup, args: &SimulateArgs) -> Result<()> {
    check_rates(args)?;
    if let Some(q0) = &args.q0 {
        crate::warn_outside_limits(setup, "--q0", q0);
    }
    let mut specs = match crate::servo_hosts(setup) {
        Some(hosts) => hosts,
        None => controller_specs(&args.controller, &args.gains.given(), DefaultGains::Report)?,
    };
    for spec in &mut specs {
        spec.knows_friction = args.conditions.options().knows_friction(setup);
    }
    let options = options_from(setup, args)?;
    let total = study_steps(setup, &args.scenario, &options)?.saturating_mul(specs.len() as u64);
    let bar = crate::progress::bar(total, "simulating");
    let study = simulate_scenario(setup, &args.scenario, &specs, &options, Some(&|n| bar.inc(n)))?;
    let result = write_study(setup, &args.scenario, &study, &options, &args.out)?;
    bar.finish_and_clear();
    let runs = &study.runs;
    let mut human = String::new();
    crate::tell_or_keep(&comparison_table(runs, args.q0.is_some()), &mut human);
    human.push_str(&crate::files_text(&files_of(&result)));
    crate::emit(&human, &result)?;
    Ok(())
}

/// `dynamics`: `M(q)`, `C(q, q̇) q̇` and `g(q)` as JSON.
pub fn dynamics(setup: &Setup, args: &DynamicsArgs) -> Result<()> {
    let model = if args.payload_mass > 0.0 {
        setup.arm.with_payload(Some(gripped_pawn(setup, args.payload_mass)))?
    } else {
        setup.arm
    };
    // In the model's convention; the results back in the user's (a URDF's own sense):
    // `M → S M S`, torques `→ S τ` with `S` the joints' signs.
    let q = JointVector::<4>::from(setup.convention.user(args.q));
    let qd = JointVector::<4>::from(setup.convention.user(args.qd));
    crate::warn_outside_limits(setup, "--q", &args.q);
    let signs = setup.convention.signs;
    let mut terms = DynamicsTerms::new(&model, &q, &qd);
    terms.mass_matrix =
        chessarm_core::nalgebra::Matrix4::from_fn(|r, c| signs[r] * signs[c] * terms.mass_matrix[(r, c)]);
    let coriolis = JointVector::<4>::from(setup.convention.user(coriolis_torques(&model, &q, &qd)));
    let gravity = JointVector::<4>::from(setup.convention.user(gravity_torques(&model, &q)));
    // JSON has no infinity: an overflowed term would print as null with success.
    for (name, finite) in [
        ("M(q)", terms.mass_matrix.iter().all(|v| v.is_finite())),
        ("C(q, q̇)·q̇", coriolis.iter().all(|v| v.is_finite())),
        ("g(q)", gravity.iter().all(|v| v.is_finite())),
    ] {
        if !finite {
            bail!(
                "{name} overflows at --q {} --qd {}: the result is not a finite number; give smaller values",
                show_list(&args.q),
                show_list(&args.qd)
            );
        }
    }
    let rows: Vec<Vec<f64>> = (0..4).map(|r| (0..4).map(|c| terms.mass_matrix[(r, c)]).collect()).collect();
    let line = |values: &[f64]| values.iter().map(|v| format!("{:>12.6}", v + 0.0)).collect::<Vec<_>>().join(" ");
    let mut human = String::from("M(q) (kg·m²):\n");
    for row in &rows {
        human.push_str(&format!("  {}\n", line(row)));
    }
    human.push_str(&format!(
        "C(q, q̇)·q̇ (N·m):\n  {}\ng(q) (N·m):\n  {}\n",
        line(coriolis.as_slice()),
        line(gravity.as_slice())
    ));
    let human = human.replace("-0.000000", " 0.000000");
    crate::emit(&human, &json!({ "M": rows, "c": coriolis.as_slice(), "g": gravity.as_slice() }))?;
    Ok(())
}
