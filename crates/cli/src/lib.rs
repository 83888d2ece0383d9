//! The `chessarm` command-line program: commands, reports (CSV, JSON, plots) and progress.
//! This crate is the only place that touches files and the terminal.

pub mod app;
pub mod args;
pub mod cli;
pub mod commands;
pub mod live;
pub mod progress;

use anyhow::Result;
use app::setup::file::Setup;
use cli::{Cli, Command};

/// Whether `--json` was given: results as JSON on stdout instead of a summary for people.
static JSON_OUTPUT: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// What a command run by [`run_captured`] printed, kept instead of printed.
#[derive(Debug, Default, Clone)]
pub struct Captured {
    /// Standard output (the result's one line of JSON, or text such as `arm`'s TOML).
    pub stdout: String,
    /// What went to standard error: warnings and notes for the person at the terminal.
    pub stderr: String,
}

/// While [`run_captured`] runs a command: where its output goes instead of the terminal.
static CAPTURE: std::sync::Mutex<Option<Captured>> = std::sync::Mutex::new(None);

/// Numbers of the in-process runs ([`run_id`]); 0 is no run.
static NEXT_RUN: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
/// The run executing now (0: none, e.g. the binary's own).
static CURRENT_RUN: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
/// The run [`cancel`] was asked to stop.
static CANCELLED_RUN: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// A fresh number for a [`run_captured`] call, so that [`cancel`] stops that run and no other.
pub fn run_id() -> u64 {
    NEXT_RUN.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

/// Asks run `id` to stop (Python's Ctrl-C), whether it is running or still waiting its turn:
/// sweeps, campaigns and games fail with "interrupted" at their next candidate, trial or ply.
pub fn cancel(id: u64) {
    CANCELLED_RUN.store(id, std::sync::atomic::Ordering::SeqCst);
}

/// Whether the running command was asked to stop.
pub fn cancelled() -> bool {
    let current = CURRENT_RUN.load(std::sync::atomic::Ordering::SeqCst);
    current != 0 && CANCELLED_RUN.load(std::sync::atomic::Ordering::SeqCst) == current
}

/// The error of a command stopped by [`cancel`].
pub fn interrupted() -> anyhow::Error {
    app::studies::interrupted()
}

/// One command at a time runs captured (the capture is the process's).
static CAPTURED_RUN: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Appends to the capture when one is on; `false` when the text should go to the terminal.
fn captured(text: &str, stdout: bool) -> bool {
    let mut capture = CAPTURE.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    match capture.as_mut() {
        Some(kept) => {
            if stdout { &mut kept.stdout } else { &mut kept.stderr }.push_str(text);
            true
        }
        None => false,
    }
}

/// Why [`run_captured`] did not run or finish a command.
#[derive(Debug)]
pub enum RunError {
    /// The arguments: clap's message (naming the flag and the value as typed) on one line.
    Usage(String),
    /// The command failed: the error, as the CLI prints it on one line, and what it had said
    /// on standard error before.
    Failed { message: String, stderr: String },
}

/// Runs `chessarm ARGS --json` in this process, for the Python bindings: what it would print is
/// returned instead (the result's JSON is `stdout`). Files are written as the command writes them.
/// `id` (from [`run_id`]) names the run for [`cancel`].
///
/// # Errors
///
/// As [`RunError`]: bad arguments, or the command's own error.
pub fn run_captured(args: &[String], id: u64) -> Result<Captured, RunError> {
    use clap::Parser;
    let _one_at_a_time = CAPTURED_RUN.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let words = std::iter::once("chessarm".to_string()).chain(args.iter().cloned()).chain(["--json".to_string()]);
    let cli = Cli::try_parse_from(words).map_err(|error| RunError::Usage(usage_message(&error)))?;
    *CAPTURE.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = Some(Captured::default());
    CURRENT_RUN.store(id, std::sync::atomic::Ordering::SeqCst);
    // The folders' lists are read afresh: between two runs in one process the user may have
    // removed or changed a folder.
    app::output::forget_listed();
    let result = run(cli);
    CURRENT_RUN.store(0, std::sync::atomic::Ordering::SeqCst);
    let kept = CAPTURE.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take().unwrap_or_default();
    result
        .map(|()| kept.clone())
        .map_err(|error| RunError::Failed { message: app::text::one_line(&error), stderr: kept.stderr })
}

/// clap's message for bad arguments on one line, without its usage and help hints.
pub fn usage_message(error: &clap::Error) -> String {
    let rendered = error.render().to_string();
    let message: Vec<&str> = rendered
        .lines()
        .take_while(|line| !line.starts_with("Usage:") && !line.starts_with("For more information"))
        .map(str::trim)
        .filter(|line| !line.is_empty())
        .collect();
    app::text::shorten_long_words(&app::text::escape_controls(&message.join(" ")))
}

/// Whether the result goes out as JSON (`--json`).
pub fn json_output() -> bool {
    JSON_OUTPUT.load(std::sync::atomic::Ordering::Relaxed)
}

/// Prints a command's result: `json` with `--json`, else `human` (a summary for people, which
/// ends with a newline).
///
/// # Errors
///
/// As [`print_json`].
pub fn emit(human: &str, json: &serde_json::Value) -> Result<()> {
    if json_output() { print_json(json) } else { print_text(human) }
}

/// Text for the terminal that goes with the result: on stdout with the human summary, on
/// stderr with `--json` (so that stdout stays one JSON value).
pub fn tell_or_keep(text: &str, summary: &mut String) {
    if json_output() {
        tell(text);
    } else {
        summary.push_str(text);
    }
}

/// "files:" and one indented line per file, for the human summaries.
pub fn files_text(files: &[String]) -> String {
    let mut text = String::from("files:\n");
    for file in files {
        text.push_str(&format!("  {file}\n"));
    }
    text
}

/// Warns (on stderr) about each angle of `flag` outside its joint's limits: most often an
/// angle typed in degrees where radians are read.
pub fn warn_outside_limits(setup: &Setup, flag: &str, q: &[f64; 4]) {
    for (j, value) in q.iter().enumerate() {
        let (lower, upper) = setup.user_limits(j);
        if !(lower..=upper).contains(value) {
            crate::tell(&format!(
                "warning: {flag} joint {} = {} rad is outside its limits [{lower:.4}, {upper:.4}] rad; angles are \
                 read in radians (if {} was meant in degrees, that is {:.4} rad)\n",
                j + 1,
                crate::app::resources::show(*value),
                crate::app::resources::show(*value),
                value.to_radians()
            ));
        }
    }
}

/// With servos, the hosts that drive them (see [`app::setup::servos::servo_hosts`]), the note
/// that they replace the torque controllers told to the person (not with `--json`).
pub fn servo_hosts(setup: &Setup) -> Option<Vec<chessarm_core::control::choice::ControllerSpec>> {
    let (hosts, note) = app::setup::servos::servo_hosts(setup)?;
    if !json_output() {
        tell(&note);
    }
    Some(hosts)
}

/// Runs a parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    JSON_OUTPUT.store(cli.json, std::sync::atomic::Ordering::Relaxed);
    let options = app::setup::SetupOptions {
        arm: cli.arm.clone(),
        urdf: cli.urdf.clone(),
        lock: cli.lock.clone().map(|locks| locks.0).unwrap_or_default(),
        tool: cli.tool.clone(),
        tool_offset: cli.tool_offset,
        actuator: cli.actuator.clone(),
        servo_command: cli.servo_command.clone(),
        bus_rate: cli.bus_rate,
    };
    let resolved = app::setup::resolve(&options)?;
    for note in &resolved.notes {
        tell(&format!("{note}\n"));
    }
    let mut setup = resolved.setup;
    if cli.servo_command.is_none() && matches!(cli.command, Some(Command::Tune(_))) {
        // A sweep compares every host strategy unless told which.
        setup.servo_commands = chessarm_core::control::servo_host::ServoCommand::ALL.to_vec();
    }
    if setup.actuators.take_positions() && matches!(cli.command, Some(Command::Demo(_)) | None) {
        anyhow::bail!(
            "the report's study (demo) runs torque motors only so far; servos and steppers (--actuator {}) work with simulate, play, tune, robustness and board",
            setup.actuator_names.join(",")
        );
    }
    // The bus's period against the simulation's time step, before any work.
    let (dt, dt_flag) = match &cli.command {
        Some(Command::Play(args)) => (args.dt, " --dt"),
        Some(Command::Simulate(args)) => (args.dt, " --dt"),
        _ => (chessarm_chess::play::PlaySettings::DEFAULT_DT, ""),
    };
    app::setup::servos::check_bus_period(&setup, dt, dt_flag)?;
    let default_out = std::path::PathBuf::from("out");
    let out = match &cli.command {
        None => Some(&default_out),
        Some(Command::Demo(args)) => Some(&args.out),
        Some(Command::Simulate(args)) => Some(&args.out),
        Some(Command::Tune(args)) => Some(&args.out),
        Some(Command::Play(args)) => Some(&args.out),
        Some(Command::Robustness(args)) => Some(&args.out),
        Some(Command::Plan(args)) => Some(&args.out),
        Some(Command::Calibrate(args)) => Some(&args.out),
        Some(
            Command::Dynamics(_)
            | Command::Gains(_)
            | Command::Arm
            | Command::Fk(_)
            | Command::Ik(_)
            | Command::Urdf
            | Command::Board(_)
            | Command::BusSim(_),
        ) => None,
    };
    let folder = out.map(|dir| app::output::folder_lock::RunFolder::take(dir)).transpose()?;
    let result = out.map_or(Ok(()), |dir| app::output::check_list(dir)).and_then(|()| dispatch(&setup, cli.command));
    if let Some(folder) = folder {
        folder.end(result.is_ok());
    }
    result
}

/// Runs `command` (the demo when there is none).
fn dispatch(setup: &Setup, command: Option<Command>) -> Result<()> {
    match command {
        None => commands::demo::run(setup, &cli::DemoArgs { out: "out".into() }),
        Some(Command::Demo(args)) => commands::demo::run(setup, &args),
        Some(Command::Dynamics(args)) => commands::simulate::dynamics(setup, &args),
        Some(Command::Simulate(args)) => commands::simulate::run(setup, &args),
        Some(Command::Gains(args)) => commands::gains::run(setup, &args),
        Some(Command::Tune(mut args)) => {
            args.shard = args::resolve_shard(args.shard, (args.batch.shard_from_env, args.batch.shards), |name| {
                std::env::var(name).ok()
            })
            .map_err(anyhow::Error::msg)?;
            commands::tune::run(setup, &args)
        }
        Some(Command::Play(args)) => commands::play::run(setup, &args),
        Some(Command::BusSim(args)) => commands::bus_sim::run(setup, &args),
        Some(Command::Calibrate(args)) => commands::calibrate::run(setup, &args),
        Some(Command::Robustness(mut args)) => {
            args.shard = args::resolve_shard(args.shard, (args.batch.shard_from_env, args.batch.shards), |name| {
                std::env::var(name).ok()
            })
            .map_err(anyhow::Error::msg)?;
            commands::robustness::run(setup, &args)
        }
        Some(Command::Arm) => {
            // Standard DH turns every joint about its +z: a joint the file turns the other way
            // (a base yaw about −z) has its angles negated in this file.
            for (name, sign) in setup.joint_names.iter().zip(setup.convention.signs) {
                if sign < 0.0 {
                    tell(&format!(
                        "warning: joint '{name}' turns about the other sense in the URDF: in this setup file (standard \
                         DH) its angles are the URDF's negated\n"
                    ));
                }
            }
            print_text(&setup.to_toml()?)
        }
        Some(Command::Fk(args)) => commands::kinematics::fk(setup, &args),
        Some(Command::Ik(args)) => commands::kinematics::ik(setup, &args),
        Some(Command::Urdf) => print_text(&app::formats::urdf::to_urdf(
            &setup.arm,
            "chessarm",
            &setup.joint_names,
            &setup.convention.signs,
            setup.clearance.gripper.palm_depth(),
        )),
        Some(Command::Plan(args)) => commands::plan::run(setup, &args),
        Some(Command::Board(args)) => commands::board::run(setup, &args),
    }
}

/// Prints a JSON value to standard output on one line.
///
/// # Errors
///
/// A write or flush error (a full disk, `> /dev/full`); a closed pipe (`| head`) is one too,
/// which `main` turns into a quiet exit (see [`is_closed_pipe`]).
pub fn print_json(value: &serde_json::Value) -> Result<()> {
    print_text(&format!("{value}\n"))
}

/// Writes `text` to standard output and flushes it, so that every write error is reported.
///
/// # Errors
///
/// As [`print_json`].
pub fn print_text(text: &str) -> Result<()> {
    use std::io::Write;
    if captured(text, true) {
        return Ok(());
    }
    let mut stdout = std::io::stdout().lock();
    stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
        .map_err(|error| anyhow::Error::new(error).context("cannot write to standard output"))
}

/// Whether `error` is, at its root, a write to a pipe whose reader has gone (`chessarm urdf |
/// head -1`): not a failure of chessarm, so the program ends quietly.
pub fn is_closed_pipe(error: &anyhow::Error) -> bool {
    error
        .chain()
        .any(|cause| cause.downcast_ref::<std::io::Error>().is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe))
}

/// Writes text for the person at the terminal to standard error (dropped if it is closed).
pub fn tell(text: &str) {
    use std::io::Write;
    if captured(text, false) {
        return;
    }
    let _ = write!(std::io::stderr(), "{text}");
}
