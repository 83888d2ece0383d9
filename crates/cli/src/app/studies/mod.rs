//! The studies: each a library call with typed options and a typed result, nothing written.
pub mod board;
pub mod calibrate;
pub mod person;
pub mod placement;
pub mod plan;
pub mod play;
pub mod robustness;
pub mod simulate;
pub mod tune;

/// A count of work done, told as it passes (a progress bar's `inc`): simulated steps,
/// candidates, trials.
pub type Progress<'a> = &'a (dyn Fn(u64) + Sync);

/// Asked between pieces of work (candidates, trials, plies): `true` stops the study with
/// [`interrupted`] (the command line's Ctrl-C, Python's `KeyboardInterrupt`).
pub type Stop<'a> = &'a (dyn Fn() -> bool + Sync);

/// A study that was asked to stop.
pub fn interrupted() -> anyhow::Error {
    anyhow::anyhow!("interrupted")
}

/// Never stops: for a study run to its end.
pub fn never() -> bool {
    false
}
