//! Sets `cfg(tool_stockfish)` when Stockfish is installed (see build/test_tools.rs).

include!("../../build/test_tools.rs");

fn main() {
    watch_search_dirs();
    stockfish_cfg();
}
