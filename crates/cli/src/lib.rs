//! The `chessarm` command-line program: commands, reports (CSV, JSON, plots) and progress.
//! This crate is the only place that touches files and the terminal.

pub mod args;
pub mod cli;
pub mod commands;
pub mod conditions;
pub mod config;
pub mod hardware;
pub mod output;
pub mod plots;
pub mod progress;
pub mod replay;
pub mod resources;
pub mod urdf;
pub mod urdf_import;

use anyhow::Result;
use cli::{Cli, Command};
use config::Setup;

/// Whether `--json` was given: results as JSON on stdout instead of a summary for people.
static JSON_OUTPUT: std::sync::OnceLock<bool> = std::sync::OnceLock::new();

/// Whether the result goes out as JSON (`--json`).
pub fn json_output() -> bool {
    JSON_OUTPUT.get().copied().unwrap_or(false)
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

/// Runs a parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    let _ = JSON_OUTPUT.set(cli.json);
    let mut setup = Setup::load(cli.arm.as_deref())?;
    if let Some(path) = &cli.urdf {
        (setup.arm, setup.joint_names) = urdf_import::load(path)?;
        setup.urdf_path = Some(path.clone());
    }
    match cli.command {
        None => commands::demo::run(&setup, &cli::DemoArgs { out: "out".into() }),
        Some(Command::Demo(args)) => commands::demo::run(&setup, &args),
        Some(Command::Dynamics(args)) => commands::simulate::dynamics(&setup, &args),
        Some(Command::Simulate(args)) => commands::simulate::run(&setup, &args),
        Some(Command::Gains(args)) => commands::gains::run(&setup, &args),
        Some(Command::Tune(mut args)) => {
            args.shard = args::resolve_shard(args.shard, &args.batch, |name| std::env::var(name).ok())
                .map_err(anyhow::Error::msg)?;
            commands::tune::run(&setup, &args)
        }
        Some(Command::Play(args)) => commands::play::run(&setup, &args),
        Some(Command::Robustness(mut args)) => {
            args.shard = args::resolve_shard(args.shard, &args.batch, |name| std::env::var(name).ok())
                .map_err(anyhow::Error::msg)?;
            commands::robustness::run(&setup, &args)
        }
        Some(Command::Arm) => print_text(&setup.to_toml()?),
        Some(Command::Fk(args)) => commands::kinematics::fk(&setup, &args),
        Some(Command::Ik(args)) => commands::kinematics::ik(&setup, &args),
        Some(Command::Urdf) => print_text(&urdf::to_urdf(&setup.arm, "chessarm", &setup.joint_names)),
        Some(Command::Plan(args)) => commands::plan::run(&setup, &args),
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
    let _ = write!(std::io::stderr(), "{text}");
}

/// The error and its causes on one line, each cause only if the message does not already
/// contain it (several errors quote their cause in their own message). Line breaks become
/// spaces and other control characters are escaped (see [`escape_controls`]), so that text an
/// engine or a file sent cannot split or overwrite the line.
pub fn one_line(error: &anyhow::Error) -> String {
    let mut message = error.to_string();
    for cause in error.chain().skip(1) {
        let text = cause.to_string();
        if !message.contains(&text) {
            message.push_str(": ");
            message.push_str(&text);
        }
    }
    shorten_long_words(&escape_controls(&message))
}

/// Longest run of non-blank characters an error line shows whole (a path, a FEN, a move).
const LONGEST_WORD: usize = 200;

/// `text` with each run of non-blank characters longer than [`LONGEST_WORD`] cut to its start
/// and the count of what was left out, so that a megabyte token quoted by a parser does not
/// become a megabyte error line.
pub fn shorten_long_words(text: &str) -> String {
    if text.len() <= LONGEST_WORD {
        return text.to_owned();
    }
    let mut shown = String::with_capacity(text.len().min(4096));
    for (i, word) in text.split(' ').enumerate() {
        if i > 0 {
            shown.push(' ');
        }
        if word.chars().count() <= LONGEST_WORD {
            shown.push_str(word);
        } else {
            let kept: String = word.chars().take(LONGEST_WORD / 2).collect();
            shown.push_str(&format!("{kept}…({} more bytes)", word.len() - kept.len()));
        }
    }
    shown
}

/// `text` on one line: `\n` becomes a space, every other control character (CR, VT, NUL, ESC,
/// DEL, …) is shown escaped (`\r`, `\t`, `\0`, `\u{b}`), everything else as it is.
pub fn escape_controls(text: &str) -> String {
    let mut shown = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '\n' => shown.push(' '),
            '\r' => shown.push_str("\\r"),
            '\t' => shown.push_str("\\t"),
            '\0' => shown.push_str("\\0"),
            c if c.is_control() => shown.push_str(&format!("\\u{{{:x}}}", u32::from(c))),
            c => shown.push(c),
        }
    }
    shown
}
