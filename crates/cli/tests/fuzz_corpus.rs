//! The fuzz corpora as ordinary tests: every input in `fuzz/corpus/<target>/` goes through the
//! same property check as the cargo-fuzz target (`fuzz/src/checks.rs`, included by path).

use std::panic;
use std::path::{Path, PathBuf};

#[path = "../../../fuzz/src/checks.rs"]
mod checks;

// The UCI line check needs `chessarm_chess::opponent::parse_uci_line`. Once it exists, turn
// `any()` into `all()` here and on `uci_line_corpus` below.
#[cfg(any())]
#[path = "../../../fuzz/src/uci_check.rs"]
mod uci_check;

/// Runs every file of the target's corpus through `check`; fails naming the inputs that fail,
/// or if the corpus is missing or empty.
fn run_corpus(target: &str, check: fn(&[u8])) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus").join(target);
    let entries = std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("cannot read corpus {}: {e}", dir.display()));
    let mut inputs: Vec<PathBuf> = entries.map(|entry| entry.expect("corpus entry").path()).collect();
    inputs.sort();
    assert!(!inputs.is_empty(), "the corpus {} is empty", dir.display());
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
fn numbers_corpus() {
    run_corpus("numbers", checks::check_numbers);
}

#[cfg(any())]
#[test]
fn uci_line_corpus() {
    run_corpus("uci_line", uci_check::check_uci_line);
}
