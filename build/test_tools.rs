// Shared by the build scripts of `crates/chess` and `crates/cli` (`include!`d): finds the
// outside tools some tests need and sets a `cfg` for each one present, so that a test whose
// tool is missing is `#[ignore]`d with the reason and counted as ignored by the test harness,
// not reported as passed. `cargo test -- --include-ignored` runs them anyway (and they fail
// without their tool). See docs/testing.md.

use std::path::{Path, PathBuf};

/// The folders of `PATH`, and `/usr/games` where Debian puts chess engines.
fn search_dirs() -> Vec<PathBuf> {
    let mut dirs: Vec<PathBuf> = std::env::var_os("PATH").map(|p| std::env::split_paths(&p).collect()).unwrap_or_default();
    dirs.push(PathBuf::from("/usr/games"));
    dirs
}

/// Whether `program` is an executable file in one of the search folders.
fn has_program(program: &str) -> bool {
    use std::os::unix::fs::PermissionsExt;
    search_dirs().iter().any(|dir| {
        std::fs::metadata(dir.join(program)).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
    })
}

/// Declares `name` as a cfg and sets it when `present`.
fn tool_cfg(name: &str, present: bool) {
    println!("cargo::rustc-check-cfg=cfg({name})");
    if present {
        println!("cargo::rustc-cfg={name}");
    }
}

/// Reruns the build script when a tool may have come or gone: `PATH` or a folder on it changed.
fn watch_search_dirs() {
    println!("cargo::rerun-if-env-changed=PATH");
    for dir in search_dirs() {
        if dir.is_dir() {
            println!("cargo::rerun-if-changed={}", dir.display());
        }
    }
}

#[allow(dead_code)] // each build script uses some of these
fn stockfish_cfg() {
    tool_cfg("tool_stockfish", has_program("stockfish"));
}

/// Chromium with Node.js and playwright-core installed by `npm ci` in `tests/browser`.
#[allow(dead_code)]
fn browser_cfg(browser_dir: &Path) {
    println!("cargo::rerun-if-changed={}", browser_dir.display());
    println!("cargo::rerun-if-env-changed=CHESSARM_CHROMIUM");
    let chromium = match std::env::var_os("CHESSARM_CHROMIUM") {
        Some(path) => Path::new(&path).is_file(),
        None => has_program("chromium"),
    };
    let present = chromium && has_program("node") && browser_dir.join("node_modules/playwright-core").is_dir();
    tool_cfg("tool_browser", present);
}

/// A Python named by `CHESSARM_PYTHON` (with the chessarm package, pytest and MuJoCo).
#[allow(dead_code)]
fn python_cfg() {
    println!("cargo::rerun-if-env-changed=CHESSARM_PYTHON");
    tool_cfg("tool_python", std::env::var_os("CHESSARM_PYTHON").is_some_and(|p| !p.is_empty()));
}
