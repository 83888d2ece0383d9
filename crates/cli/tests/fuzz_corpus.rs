//! The fuzz corpora as ordinary tests: every input in `fuzz/corpus/<target>/` (minimised by
//! `fuzz/run.sh`) and in `fuzz/seeds/<target>/` (hand-made) goes through the same property check
//! as the cargo-fuzz target (`fuzz/src/checks.rs`, included by path).

use std::panic;
use std::path::{Path, PathBuf};

#[path = "../../../fuzz/src/checks.rs"]
mod checks;

#[path = "../../../fuzz/src/uci_check.rs"]
mod uci_check;

/// The files of `fuzz/<folder>/<target>/`, sorted; fails if the folder is missing or empty.
fn files_of(folder: &str, target: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz").join(folder).join(target);
    let entries = std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("cannot read {}: {e}", dir.display()));
    let mut inputs: Vec<PathBuf> = entries.map(|entry| entry.expect("corpus entry").path()).collect();
    inputs.sort();
    assert!(!inputs.is_empty(), "{} is empty", dir.display());
    inputs
}

/// Runs every file of the target's corpus and seeds through `check`; fails naming the inputs
/// that fail.
fn run_corpus(target: &str, check: fn(&[u8])) {
    let mut inputs = files_of("corpus", target);
    inputs.extend(files_of("seeds", target));
    let failed: Vec<&PathBuf> = inputs
        .iter()
        .filter(|path| {
            let data = std::fs::read(path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
            panic::catch_unwind(|| check(&data)).is_err()
        })
        .collect();
    assert!(failed.is_empty(), "{} of {} inputs of {target} fail: {failed:?}", failed.len(), inputs.len());
}

#[test]
fn pgn_corpus() {
    run_corpus("pgn", checks::check_pgn);
}

#[test]
fn move_list_corpus() {
    run_corpus("move_list", checks::check_move_list);
}

#[test]
fn fen_corpus() {
    run_corpus("fen", checks::check_fen);
}

#[test]
fn setup_toml_corpus() {
    run_corpus("setup_toml", checks::check_setup_toml);
}

#[test]
fn urdf_corpus() {
    run_corpus("urdf", checks::check_urdf);
}

#[test]
fn numbers_corpus() {
    run_corpus("numbers", checks::check_numbers);
}

#[test]
fn bus_feetech_corpus() {
    run_corpus("bus_feetech", checks::check_bus_feetech);
}

#[test]
fn bus_dynamixel_corpus() {
    run_corpus("bus_dynamixel", checks::check_bus_dynamixel);
}

#[test]
fn bus_simulator_corpus() {
    run_corpus("bus_simulator", checks::check_bus_simulator);
}

#[test]
fn occupancy_corpus() {
    run_corpus("occupancy", checks::check_occupancy);
}

#[test]
fn typed_move_corpus() {
    run_corpus("typed_move", checks::check_typed_move);
}

#[test]
fn live_request_corpus() {
    run_corpus("live_request", checks::check_live_request);
}

#[test]
fn uci_line_corpus() {
    run_corpus("uci_line", uci_check::check_uci_line);
}
