//! The `chessarm` binary. Errors are one line on standard error with exit code 2.

use clap::Parser;
use clap::error::ErrorKind;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = match chessarm::cli::Cli::try_parse() {
        Ok(cli) => cli,
        Err(error) => {
            return match error.kind() {
                ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => match error.print() {
                    Ok(()) => ExitCode::SUCCESS,
                    Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
                    Err(e) => {
                        chessarm::tell(&format!("error: cannot write to standard output: {e}\n"));
                        ExitCode::from(2)
                    }
                },
                _ => {
                    chessarm::tell(&format!("{}\n", chessarm::usage_message(&error)));
                    ExitCode::from(2)
                }
            };
        }
    };
    // What a signal must undo, stage by stage: the servos' torque, the files, the engines.
    use chessarm::app::shutdown::{Stage, register};
    register(Stage::Hardware, chessarm::app::bus::driver::torque_off_before_exit);
    register(Stage::Files, chessarm::app::output::remove_on_signal);
    register(Stage::Processes, chessarm_chess::opponent::kill_all_engines);
    if let Err(error) = chessarm::app::shutdown::install() {
        chessarm::tell(&format!("warning: {}\n", chessarm::app::text::one_line(&error)));
    }
    let result = chessarm::run(cli);
    chessarm::app::output::await_signal_handler();
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of our standard output has gone (`| head`): nothing more to say to anyone.
        Err(error) if chessarm::is_closed_pipe(&error) => ExitCode::SUCCESS,
        Err(error) => {
            chessarm::tell(&format!("error: {}\n", chessarm::app::text::one_line(&error)));
            ExitCode::from(2)
        }
    }
}
