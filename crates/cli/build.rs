//! Sets `cfg(tool_stockfish)`, `cfg(tool_browser)` and `cfg(tool_python)` when the tools that
//! some tests need are there (see build/test_tools.rs).

include!("../../build/test_tools.rs");

fn main() {
    watch_search_dirs();
    stockfish_cfg();
    browser_cfg(&Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/browser"));
    python_cfg();
}
