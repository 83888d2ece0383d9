//! The Python package (`crates/python`, installed with `pip install ./crates/python`): its
//! pytest suite, run against this build of the `chessarm` binary (`CHESSARM_BIN`), so the
//! Python numbers are checked against the CLI's; and the examples of its page,
//! `docs/python.md`, run as written. CI installs the package into its virtual environment
//! (`CHESSARM_PYTHON`); without it the test harness counts these tests as ignored.

#![allow(clippy::unwrap_used)]

mod common;

use std::path::Path;
use std::process::Command;

/// The Python that has the `chessarm` package and pytest (CI's `CHESSARM_PYTHON`).
fn python_with_chessarm() -> Option<String> {
    common::python_with("chessarm, pytest")
}

#[test]
#[cfg_attr(not(tool_python), ignore = "needs CHESSARM_PYTHON, a Python with the chessarm package; see docs/testing.md")]
fn the_python_packages_tests_pass_against_this_cli() {
    let python = python_with_chessarm().expect("CHESSARM_PYTHON (or python3) with the chessarm package and pytest");
    let tests = Path::new(env!("CARGO_MANIFEST_DIR")).join("../python/tests");
    let output = Command::new(&python)
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider", "-rs"])
        .arg(&tests)
        .env("CHESSARM_BIN", env!("CARGO_BIN_EXE_chessarm"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "pytest failed:\n{stdout}\n{}", String::from_utf8_lossy(&output.stderr));
    // Every test ran: none skipped (CHESSARM_BIN is set here).
    assert!(!stdout.contains("skipped"), "{stdout}");
    assert!(stdout.contains(" passed"), "{stdout}");
}

/// The ```python blocks of `docs/python.md`, in order.
fn python_page_blocks() -> Vec<String> {
    let page = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/python.md")).unwrap();
    let mut blocks = Vec::new();
    let mut current: Option<String> = None;
    for line in page.lines() {
        let trimmed = line.trim();
        if trimmed.starts_with("```") {
            if let Some(block) = current.take() {
                blocks.push(block);
            } else if trimmed == "```python" {
                current = Some(String::new());
            }
            continue;
        }
        if let Some(block) = &mut current {
            block.push_str(line);
            block.push('\n');
        }
    }
    blocks
}

/// Runs the blocks named on its command line in order, in one namespace, then checks what the
/// page promises: the plan's tool path is the forward kinematics of its joints, your own
/// controller's loop ran along the whole plan, and the kinematics section's shapes and inverse
/// pair aba ∘ rnea = identity (its names are the last to be bound).
const RUN_BLOCKS: &str = r#"
import sys
import numpy as np
namespace = {}
for path in sys.argv[1:]:
    with open(path, encoding="utf-8") as f:
        exec(compile(f.read(), path, "exec"), namespace)
plan = namespace["plan"]
assert plan.q.shape == (len(plan), 4) and plan.tool.shape == (len(plan), 3)
assert np.allclose(namespace["tips"], plan.tool, rtol=0.0, atol=1e-9)
assert namespace["mine"].t > 12.9
assert namespace["M"].shape == (4, 4) and namespace["J"].shape == (6, 4)
assert namespace["tau"].shape == (1000, 4)
assert np.allclose(namespace["arm"].aba(namespace["q"], namespace["v"], namespace["tau"][0]), 0.0, atol=1e-9)
"#;

#[test]
#[cfg_attr(not(tool_python), ignore = "needs CHESSARM_PYTHON, a Python with the chessarm package; see docs/testing.md")]
fn the_python_pages_examples_run_as_written() {
    let python = python_with_chessarm().expect("CHESSARM_PYTHON (or python3) with the chessarm package and pytest");
    // The Dask example needs a cluster's scheduler at its address: test_distributed.py runs the
    // same calls on a LocalCluster.
    let blocks: Vec<String> = python_page_blocks().into_iter().filter(|b| !b.contains("tcp://scheduler")).collect();
    assert!(blocks.len() >= 2, "docs/python.md's examples not found: {blocks:?}");
    // A fresh folder with the repository's examples/, which the examples name.
    let dir = tempfile::tempdir().unwrap();
    common::copy_examples(dir.path());
    let mut paths = Vec::new();
    for (i, block) in blocks.iter().enumerate() {
        // Named so that a traceback says where the block comes from.
        let name = format!("docs-python.md-block-{}.py", i + 1);
        std::fs::write(dir.path().join(&name), block).unwrap();
        paths.push(name);
    }
    let output = Command::new(&python)
        .arg("-c")
        .arg(RUN_BLOCKS)
        .args(&paths)
        .current_dir(dir.path())
        .env("CHESSARM_BIN", env!("CARGO_BIN_EXE_chessarm"))
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "docs/python.md's examples failed:\n{}\n{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
}
