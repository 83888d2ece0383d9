//! The `chessarm` command-line program: commands, reports (CSV, JSON, plots) and progress.
//! This crate is the only place that touches files and the terminal.

pub mod args;
pub mod cli;
pub mod commands;
pub mod config;
pub mod output;
pub mod plots;
pub mod progress;
pub mod urdf;

use anyhow::Result;
use cli::{Cli, Command};
use config::Setup;

/// Runs a parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    let setup = Setup::load(cli.arm.as_deref())?;
    match cli.command {
        None => commands::demo::run(&setup, &cli::DemoArgs { out: "out".into() }),
        Some(Command::Demo(args)) => commands::demo::run(&setup, &args),
        Some(Command::Dynamics(args)) => commands::simulate::dynamics(&setup, &args),
        Some(Command::Simulate(args)) => commands::simulate::run(&setup, &args),
        Some(Command::Gains(args)) => commands::gains::run(&setup, &args),
        Some(Command::Tune(args)) => commands::tune::run(&setup, &args),
        Some(Command::Play(args)) => commands::play::run(&setup, &args),
        Some(Command::Arm) => {
            print!("{}", setup.to_toml()?);
            Ok(())
        }
        Some(Command::Fk(args)) => commands::kinematics::fk(&setup, &args),
        Some(Command::Ik(args)) => commands::kinematics::ik(&setup, &args),
        Some(Command::Urdf) => {
            print!("{}", urdf::to_urdf(&setup.arm, "chessarm"));
            Ok(())
        }
        Some(Command::Plan(args)) => commands::plan::run(&setup, &args),
    }
}

/// Prints a JSON value to standard output on one line. A closed pipe (`| head`) is not an
/// error worth a panic: the output is simply dropped.
pub fn print_json(value: &serde_json::Value) {
    use std::io::Write;
    let _ = writeln!(std::io::stdout(), "{value}");
}

/// Writes text for the person at the terminal to standard error (dropped if it is closed).
pub fn tell(text: &str) {
    use std::io::Write;
    let _ = write!(std::io::stderr(), "{text}");
}

/// The error and its causes on one line, each cause only if the message does not already
/// contain it (several errors quote their cause in their own message).
pub fn one_line(error: &anyhow::Error) -> String {
    let mut message = error.to_string();
    for cause in error.chain().skip(1) {
        let text = cause.to_string();
        if !message.contains(&text) {
            message.push_str(": ");
            message.push_str(&text);
        }
    }
    message.replace('\n', " ")
}
