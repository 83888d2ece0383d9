//! The `chessarm` binary. Errors are one line on standard error with exit code 2.

use clap::Parser;
use clap::error::ErrorKind;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = match chessarm::cli::Cli::try_parse() {
        Ok(cli) => cli,
        Err(error) => {
            return match error.kind() {
                ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
                    let _ = error.print();
                    ExitCode::SUCCESS
                }
                _ => {
                    let rendered = error.render().to_string();
                    let first = rendered.lines().find(|l| !l.trim().is_empty()).unwrap_or("error: bad arguments");
                    eprintln!("{first}");
                    ExitCode::from(2)
                }
            };
        }
    };
    match chessarm::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {}", format!("{error:#}").replace('\n', " "));
            ExitCode::from(2)
        }
    }
}
