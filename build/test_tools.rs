// Shared by the build scripts of `crates/chess` and `crates/cli` (`include!`d): finds the
// outside tools some tests need and sets a `cfg` for each one present, so that a test whose
// tool is missing is `#[ignore]`d with the reason and counted as ignored by the test harness,
// not reported as passed. `cargo test -- --include-ignored` runs them anyway (and they fail
// without their tool). See docs/testing.md.

use std::path::{Path, PathBuf};

/// Where packages install programs (`/usr/games`: Debian's chess engines). These folders are
/// watched: the build script runs again when a program comes or goes there.
const INSTALL_DIRS: [&str; 5] = ["/usr/games", "/usr/bin", "/usr/local/bin", "/snap/bin", "/opt/homebrew/bin"];

/// The folders of `PATH`, then the install folders.
fn search_dirs() -> Vec<PathBuf> {
    let mut dirs: Vec<PathBuf> = std::env::var_os("PATH").map(|p| std::env::split_paths(&p).collect()).unwrap_or_default();
    dirs.extend(INSTALL_DIRS.iter().map(PathBuf::from));
    dirs
}

/// Whether `path` is an executable file.
fn is_program(path: &Path) -> bool {
    use std::os::unix::fs::PermissionsExt;
    std::fs::metadata(path).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
}

/// Whether `program` is an executable file in one of the search folders (the one it is found
/// in is watched too).
fn has_program(program: &str) -> bool {
    match search_dirs().into_iter().find(|dir| is_program(&dir.join(program))) {
        Some(dir) => {
            println!("cargo::rerun-if-changed={}", dir.join(program).display());
            true
        }
        None => false,
    }
}

/// Declares `name` as a cfg and sets it when `present`.
fn tool_cfg(name: &str, present: bool) {
    println!("cargo::rustc-check-cfg=cfg({name})");
    if present {
        println!("cargo::rustc-cfg={name}");
    }
}

/// Reruns the build script when a tool may have come or gone from the install folders. `PATH`
/// itself is not watched: it differs between a terminal, an editor and `pip`'s build, and each
/// difference would rebuild the crates; a tool installed elsewhere later is found after
/// `touch build/test_tools.rs`.
fn watch_search_dirs() {
    for dir in INSTALL_DIRS {
        if Path::new(dir).is_dir() {
            println!("cargo::rerun-if-changed={dir}");
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
    // Where the browser tests look for it (crates/cli/tests/cli_replay.rs).
    let chromium = std::env::var_os("CHESSARM_CHROMIUM").map_or_else(|| PathBuf::from("/usr/bin/chromium"), PathBuf::from);
    let present = is_program(&chromium) && has_program("node") && browser_dir.join("node_modules/playwright-core").is_dir();
    tool_cfg("tool_browser", present);
}

/// A Python named by `CHESSARM_PYTHON` (with the chessarm package, pytest and MuJoCo).
#[allow(dead_code)]
fn python_cfg() {
    println!("cargo::rerun-if-env-changed=CHESSARM_PYTHON");
    tool_cfg("tool_python", std::env::var_os("CHESSARM_PYTHON").is_some_and(|p| !p.is_empty()));
}
