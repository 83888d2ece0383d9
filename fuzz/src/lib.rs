//! Property checks for the cargo-fuzz targets in `fuzz_targets/` (see README.md).
//!
//! The checks live in `checks.rs` (and `uci_check.rs`), which `crates/cli/tests/fuzz_corpus.rs`
//! includes by path to run the committed corpora under `cargo test`.

#![forbid(unsafe_code)]

mod checks;
pub use checks::{
    check_bus_dynamixel, check_bus_feetech, check_bus_simulator, check_fen, check_live_request, check_move_list, check_numbers,
    check_occupancy, check_pgn, check_setup_toml, check_typed_move, check_urdf,
};

#[cfg(feature = "uci")]
mod uci_check;
#[cfg(feature = "uci")]
pub use uci_check::check_uci_line;
