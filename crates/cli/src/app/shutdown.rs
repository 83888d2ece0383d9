//! The end of a run on a termination signal (SIGINT, SIGTERM, SIGHUP): one handler, and the
//! rooms that hold something to undo register what to do, each at its stage. This room imports
//! none of them.
//!
//! Stages run in order: [`Stage::Hardware`] first (the servos' torque off, nothing sent after
//! it), then [`Stage::Files`] (temporary files removed; their lock kept until the exit, so no
//! rename starts after them), then [`Stage::Processes`] (engines, which run in process groups of
//! their own that the terminal's Ctrl-C misses). The process then exits with
//! [`SIGNAL_EXIT_CODE`].

use anyhow::{Context, Result};
use std::sync::{Mutex, PoisonError};

/// Exit code after a termination signal (128 + SIGINT, the shell's convention for Ctrl-C).
pub const SIGNAL_EXIT_CODE: i32 = 130;

/// When an action runs on a signal, in this order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Stage {
    /// Hardware made safe: the servos' torque off.
    Hardware,
    /// Files this run must not leave behind.
    Files,
    /// Child processes stopped.
    Processes,
}

/// An action and the stage it runs at.
type Action = (Stage, fn());

static ACTIONS: Mutex<Vec<Action>> = Mutex::new(Vec::new());

/// Registers `action` to run at `stage` when a signal ends the program (once, however often
/// it is registered).
pub fn register(stage: Stage, action: fn()) {
    let mut actions = ACTIONS.lock().unwrap_or_else(PoisonError::into_inner);
    if !actions.iter().any(|(s, a)| *s == stage && std::ptr::fn_addr_eq(*a, action)) {
        actions.push((stage, action));
    }
}

/// Installs the handler: on a signal every registered action runs, stage by stage, then the
/// process exits with [`SIGNAL_EXIT_CODE`].
///
/// # Errors
///
/// When the handler cannot be installed.
pub fn install() -> Result<()> {
    ctrlc::set_handler(|| {
        let mut actions = ACTIONS.lock().unwrap_or_else(PoisonError::into_inner).clone();
        actions.sort_by_key(|(stage, _)| *stage);
        for (_, action) in actions {
            action();
        }
        // A test hook: `CHESSARM_TEST_SLOW_SIGNAL_MS` makes the handler wait that long before it
        // exits, so a test sees the main thread stay quiet while the engines it used are gone.
        if let Some(ms) = std::env::var("CHESSARM_TEST_SLOW_SIGNAL_MS").ok().and_then(|v| v.parse::<u64>().ok()) {
            std::thread::sleep(std::time::Duration::from_millis(ms));
        }
        std::process::exit(SIGNAL_EXIT_CODE);
    })
    .context("cannot install the signal handler")
}
