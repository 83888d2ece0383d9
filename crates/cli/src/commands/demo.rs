//! `demo` (and `chessarm` with no command): the report's study end to end.

use crate::app::formats::plan::write_plan;
use crate::app::formats::simulation::{comparison_table, write_study};
use crate::app::setup::file::Setup;
use crate::app::studies::plan::plan_scenario;
use crate::app::studies::simulate::{
    ControllerName, ControllerRun, DefaultGains, GivenGains, RunOptions, TRANSIENT_S, controller_specs,
    max_tip_error_from, simulate_scenario, study_steps,
};
use crate::cli::DemoArgs;
use anyhow::Result;
use chessarm_core::sim::Integrator;
use serde_json::json;

const SCENARIO: &str = "queens-gambit";

pub fn run(setup: &Setup, args: &DemoArgs) -> Result<()> {
    // The report's Simulink run started at rest at q = 0 ("the joints jumping to their starting
    // position"), so the study does too: the start-up transient is part of the comparison.
    let options = RunOptions {
        dt: 1e-3,
        integrator: Integrator::default(),
        control_period: 1e-3,
        q0: Some([0.0; 4]),
        payload_mass: 0.0,
        controller_knows_payload: false,
        tracking_from: 0.0,
        rate_flags: "the demo".into(),
        trial: None,
        conditions: serde_json::Value::Null,
    };
    // The report's two controllers, and its PID with anti-windup.
    let specs = controller_specs(
        &[ControllerName::Pd, ControllerName::PidPlain, ControllerName::Pid],
        &GivenGains::default(),
        DefaultGains::Report,
    )?;
    let steps = study_steps(setup, SCENARIO, &options)?;
    let bar = crate::progress::bar(steps * specs.len() as u64 + steps / 10, "demo");
    bar.set_message("planning");
    let plan = plan_scenario(setup, SCENARIO, 0.005, "the demo")?;
    let plan_files = write_plan(&plan, &args.out.join("plan"), cfg!(feature = "xlsx"), &setup.convention)?;
    bar.inc(steps / 10);
    bar.set_message("simulating");
    let simulated = simulate_scenario(setup, SCENARIO, &specs, &options, Some(&|n| bar.inc(n)))?;
    let study = write_study(setup, SCENARIO, &simulated, &options, &args.out.join("simulate"))?;
    bar.finish_and_clear();
    let runs = simulated.runs;
    let heading = format!(
        "The report's study: {SCENARIO} (d2→d4), computed torque, plant = model, 1 kHz, start at rest at q = 0.\n"
    );
    let out = args.out.display();
    let conclusion = format!("{}\n", conclusion(&runs));
    if crate::json_output() {
        // Scripts get the JSON; the full comparison stays on the terminal.
        crate::tell(&heading);
        crate::tell(&comparison_table(&runs, true));
        crate::tell(&conclusion);
        crate::tell(&format!("Plots and CSVs: {out}/plan and {out}/simulate\n"));
    }
    let human = format!(
        "{heading}{}{conclusion}\nWatch it:     {out}/simulate/replay.html (open in a browser; pick the controller under run)\n\
         Plots:        {out}/simulate/tip_error.png, tracking_error.png, <controller>_joints.png, _torques.png; {out}/plan/*.png\n\
         Numbers:      {out}/simulate/summary.json and <controller>.csv; {out}/plan/joint.csv\n\
         (--json prints all of it as JSON)\n",
        short_table(&runs)
    );
    crate::emit(&human, &json!({ "plan_files": plan_files, "simulate": study }))?;
    Ok(())
}

/// A length in mm with four decimals, and "< 0.0001" for what they would show as zero.
fn millimetres(metres: f64) -> String {
    if metres > 0.0 && metres < 0.5e-7 { "< 0.0001".into() } else { format!("{:.4}", metres * 1e3) }
}

/// The study at a glance: per controller the tool's error at the grip and release instants,
/// its largest error after the start-up, and how often a motor saturated.
fn short_table(runs: &[ControllerRun]) -> String {
    let mut table = format!(
        "{:<10} {:>14} {:>17} {:>20} {:>10}\n",
        "control",
        "at grip mm",
        "at release mm",
        format!("max after {TRANSIENT_S} s mm"),
        "saturated"
    );
    for run in runs {
        let at = |i: usize| run.summary.tip_error_at_marks.get(i).map_or("-".to_string(), |e| millimetres(*e));
        table.push_str(&format!(
            "{:<10} {:>14} {:>17} {:>20.4} {:>10}\n",
            run.spec.name,
            at(0),
            at(1),
            max_tip_error_from(run, TRANSIENT_S) * 1e3,
            run.summary.saturated_samples
        ));
    }
    table
}

/// Says, from the numbers, whether the report's conclusion (PD places pieces more precisely
/// than PID) holds: compares the worst tip error at the grip and release instants.
fn conclusion(runs: &[ControllerRun]) -> String {
    let at_events = |name: &str| {
        runs.iter()
            .find(|run| run.spec.name == name)
            .map(|run| run.summary.tip_error_at_marks.iter().fold(0.0f64, |a, b| a.max(*b)) * 1e3)
    };
    // The study grips nothing (payload 0 kg): what it measures is where the tool is at the
    // grip and release instants, the report's measure of placement precision.
    let fixed = at_events("pid").map_or(String::new(), |pid| {
        format!(" With anti-windup (clamping, `--controller pid`) the same PID is within {pid:.4} mm.")
    });
    match (at_events("pd"), at_events("pid-plain")) {
        (Some(pd), Some(pid)) if pd < pid => format!(
            "At the grip and release instants PD puts the tool within {pd:.4} mm of its target, the report's PID within {pid:.4} mm \
             (no piece is carried: payload 0 kg): the report's conclusion holds. The PID's integral pole sits at \
             {:.3} 1/s, so the wind-up of the start-up transient decays over ~{:.0} s.{fixed}",
            slowest_pole(runs, "pid-plain"),
            -1.0 / slowest_pole(runs, "pid-plain")
        ),
        (Some(pd), Some(pid)) => format!(
            "At the grip and release instants PD puts the tool within {pd:.4} mm of its target, the report's PID within {pid:.4} mm \
             (no piece is carried): the report's conclusion does not hold here.{fixed}"
        ),
        _ => String::new(),
    }
}

fn slowest_pole(runs: &[ControllerRun], name: &str) -> f64 {
    runs.iter()
        .find(|run| run.spec.name == name)
        .map(|run| run.spec.gains.closed_loop_poles(0).iter().map(|p| p.re).fold(f64::NEG_INFINITY, f64::max))
        .unwrap_or(f64::NAN)
}
