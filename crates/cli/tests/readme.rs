//! Every example command of the README and of the manual's pages in `docs/`, run as written
//! (`cargo run --release -- ARGS` is the binary with ARGS): each page's examples in order, in a
//! fresh folder of the page's own with a small `game.pgn` and the files the page shows (```toml
//! blocks headed `# NAME.toml`); each must succeed, and the promises the pages make about some
//! of them are checked. (The Python page's ```python blocks are run by `python_package.rs`.)
//!
//! Not run here: `cargo test` (this is it) and `cargo bench` (minutes of measurement; CI's
//! `clippy --all-targets` builds the benchmarks).

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

mod common;

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository's root.
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A page whose examples run: `README.md` or a page of `docs/`.
struct Page {
    /// The path from the repository's root, as the messages name it.
    name: String,
    text: String,
}

/// The README.
fn readme() -> Page {
    Page { name: "README.md".to_owned(), text: std::fs::read_to_string(root().join("README.md")).unwrap() }
}

/// Every page of `docs/`, by name.
fn docs_pages() -> Vec<Page> {
    let mut names = common::file_names(&root().join("docs"));
    names.retain(|name| name.ends_with(".md"));
    names
        .into_iter()
        .map(|name| {
            let text = std::fs::read_to_string(root().join("docs").join(&name)).unwrap();
            Page { name: format!("docs/{name}"), text }
        })
        .collect()
}

/// The README and every page of `docs/`.
fn all_pages() -> Vec<Page> {
    std::iter::once(readme()).chain(docs_pages()).collect()
}

/// A page's `cargo run --release …` lines of its `sh` blocks, comments removed.
fn commands_of(page: &Page) -> Vec<String> {
    let mut commands = Vec::new();
    let mut in_sh = false;
    for line in page.text.lines() {
        let trimmed = line.trim();
        if trimmed.starts_with("```") {
            in_sh = trimmed == "```sh";
            continue;
        }
        if in_sh && trimmed.starts_with("cargo run --release") {
            let command = trimmed.split(" #").next().unwrap().trim();
            commands.push(command.to_owned());
        }
    }
    commands
}

/// A page's ```toml blocks that start with a `# NAME.toml` line: files its examples read.
fn files_of(page: &Page) -> Vec<(String, String)> {
    let mut files = Vec::new();
    let mut current: Option<(String, String)> = None;
    let mut in_toml = false;
    for line in page.text.lines() {
        let trimmed = line.trim();
        if trimmed.starts_with("```") {
            if let Some(file) = current.take() {
                files.push(file);
            }
            in_toml = trimmed == "```toml";
            continue;
        }
        if in_toml {
            match &mut current {
                None => {
                    if let Some(name) = trimmed.strip_prefix("# ").filter(|n| n.ends_with(".toml")) {
                        current = Some((name.to_owned(), String::new()));
                    }
                    in_toml = current.is_some();
                }
                Some((_, text)) => {
                    text.push_str(line);
                    text.push('\n');
                }
            }
        }
    }
    files
}

/// Splits a command line as the shell would for these examples (double quotes group words).
fn words(command: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut current = String::new();
    let mut quoted = false;
    for c in command.chars() {
        match c {
            '"' => quoted = !quoted,
            ' ' if !quoted => {
                if !current.is_empty() {
                    words.push(std::mem::take(&mut current));
                }
            }
            c => current.push(c),
        }
    }
    if !current.is_empty() {
        words.push(current);
    }
    words
}

/// A small PGN of two short games for the examples that read `game.pgn`.
const GAME_PGN: &str = "[Event \"Scholar's mate\"]\n[Result \"1-0\"]\n\n1. e4 e5 2. Bc4 Nc6 3. Qh5 Nf6 4. Qxf7# 1-0\n\n\
[Event \"Fool's mate\"]\n[Result \"0-1\"]\n\n1. f3 e5 2. g4 Qh4# 0-1\n";

/// The engine an example plays against with `--engine /PATH`, if it names one by its path.
fn engine_of(command: &str) -> Option<String> {
    let args: Vec<String> = words(command);
    args.iter().skip_while(|a| *a != "--engine").nth(1).filter(|engine| engine.starts_with('/')).cloned()
}

/// A folder with what a page's examples read: its files, the game, `examples/`.
fn example_folder(page: &Page) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("game.pgn"), GAME_PGN).unwrap();
    // The files a page shows from examples/ are shipped there (a comment line or two above what
    // it shows); others are written for the examples of the page that read them.
    let root = root();
    for (name, text) in &files_of(page) {
        if name.starts_with("examples/") {
            let shipped = std::fs::read_to_string(root.join(name)).unwrap();
            let page = &page.name;
            assert!(shipped.ends_with(text.as_str()), "{name} differs from {page}'s:\n{shipped}\n---\n{text}");
        } else {
            std::fs::write(dir.path().join(name), text).unwrap();
        }
    }
    // The makers' URDFs the examples name, at the same path.
    let real_arms = Path::new("crates/cli/tests/fixtures/real-arms");
    common::copy_files(&root.join(real_arms), &dir.path().join(real_arms));
    // The needle fingers the real arms' examples give.
    let needle = Path::new("crates/cli/tests/fixtures/needle_fingers.toml");
    std::fs::copy(root.join(needle), dir.path().join(needle)).unwrap();
    // The repository's examples/ folder, which the examples name.
    common::copy_examples(dir.path());
    dir
}

/// Runs one example of `page` in `dir` and checks what its page promises of it.
fn run_example(page: &str, dir: &Path, command: &str) {
    let args: Vec<String> = words(command).into_iter().skip(3).skip_while(|w| w == "--").collect();
    let output = Command::new(env!("CARGO_BIN_EXE_chessarm")).args(&args).current_dir(dir).output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{page}: {command}: {stderr}");
    let stdout = String::from_utf8_lossy(&output.stdout);
    // With --json the result is one JSON value; without, a summary for people.
    let json = if args.iter().any(|a| a == "--json") {
        serde_json::from_slice(&output.stdout).unwrap_or_else(|e| panic!("{command}: stdout {e}"))
    } else {
        assert!(!stdout.trim().is_empty(), "{command}: nothing on stdout");
        assert!(serde_json::from_slice::<Value>(&output.stdout).is_err(), "{command}: JSON without --json");
        Value::Null
    };
    check_promises(&args, &json, &format!("{stdout}{stderr}"), dir);
}

/// Runs a page's examples in order in a folder of its own, but those that play an installed
/// engine: they have a test of their own, which the harness counts as ignored where the engine
/// is not installed. Returns how many ran.
fn run_page(page: &Page) -> usize {
    let commands: Vec<String> = commands_of(page).into_iter().filter(|c| engine_of(c).is_none()).collect();
    if commands.is_empty() {
        return 0;
    }
    let dir = example_folder(page);
    for command in &commands {
        run_example(&page.name, dir.path(), command);
    }
    commands.len()
}

#[test]
fn every_readme_example_runs_and_keeps_its_promises() {
    let page = readme();
    let commands = commands_of(&page);
    assert!(commands.len() >= 3, "README examples not found: {commands:?}");
    run_page(&page);
}

/// The manual's pages (`docs/*.md`) that show example commands; each must still have some.
const PAGES_WITH_EXAMPLES: [&str; 6] = [
    "docs/live.md",
    "docs/playing.md",
    "docs/real-arms.md",
    "docs/realistic-robot.md",
    "docs/replay.md",
    "docs/study.md",
];

#[test]
fn every_docs_page_example_runs_and_keeps_its_promises() {
    let mut ran = Vec::new();
    for page in docs_pages() {
        if run_page(&page) > 0 {
            ran.push(page.name);
        }
    }
    for name in PAGES_WITH_EXAMPLES {
        assert!(ran.iter().any(|r| r == name), "no examples ran from {name}: {ran:?}");
    }
    // The pages' files: the uncertainty file the Monte Carlo examples read among them.
    let files: Vec<String> = docs_pages().iter().flat_map(files_of).map(|(name, _)| name).collect();
    assert!(files.iter().any(|name| name == "examples/uncertainty.toml"), "the pages' files not found: {files:?}");
}

#[test]
#[cfg_attr(not(tool_stockfish), ignore = "needs Stockfish (apt install stockfish); see docs/testing.md")]
fn the_examples_against_an_installed_engine_run() {
    let mut ran = 0;
    for page in all_pages() {
        let commands: Vec<String> = commands_of(&page).into_iter().filter(|c| engine_of(c).is_some()).collect();
        if commands.is_empty() {
            continue;
        }
        let dir = example_folder(&page);
        for command in &commands {
            run_against_installed_engine(&page.name, dir.path(), command);
            ran += 1;
        }
    }
    assert!(ran > 0, "no page has an example against Stockfish");
}

/// Runs an example of `page` that plays the engine it names by its path, with the engine where
/// this system has it.
fn run_against_installed_engine(page: &str, dir: &Path, command: &str) {
    let engine = engine_of(command).unwrap();
    // Where this system has the engine, if not where the page (Debian) says.
    let installed = if Path::new(&engine).exists() {
        engine.clone()
    } else {
        let name = Path::new(&engine).file_name().unwrap();
        std::env::var_os("PATH")
            .and_then(|paths| std::env::split_paths(&paths).map(|dir| dir.join(name)).find(|p| p.is_file()))
            .unwrap_or_else(|| panic!("{engine} is not installed, for {page}'s: {command}"))
            .to_string_lossy()
            .into_owned()
    };
    run_example(page, dir, &command.replace(&engine, &installed));
}

/// What the pages say of particular examples.
fn check_promises(args: &[String], json: &Value, terminal: &str, dir: &Path) {
    let first = args.first().map(String::as_str);
    match first {
        // `cargo run --release`: the demo into out/.
        None => {
            assert!(terminal.contains("the report's conclusion holds"), "{terminal}");
            assert!(terminal.contains("out/simulate/replay.html"), "{terminal}");
            assert!(terminal.lines().count() < 20, "not a short summary: {terminal}");
            assert!(dir.join("out/simulate/summary.json").exists() && dir.join("out/plan/joint.csv").exists());
            assert!(dir.join("out/simulate/replay.html").exists());
            // The files the study's page lists for the demo, one set per controller it names.
            for controller in ["pd", "pid-plain", "pid"] {
                for suffix in [".csv", "_joints.png", "_torques.png"] {
                    let name = format!("{controller}{suffix}");
                    assert!(dir.join("out/simulate").join(&name).exists(), "{name}");
                }
            }
            let study = std::fs::read_to_string(root().join("docs/study.md")).unwrap();
            assert!(study.contains("- `pd.csv`, `pid-plain.csv`, `pid.csv`:"), "docs/study.md's demo files");
        }
        Some("plan") if args.iter().any(|a| a == "--export-rate") => {
            for stem in ["001-e2e4", "002-d7d5", "003-e4d5"] {
                assert!(dir.join(format!("out/plan/hardware/{stem}.json")).exists(), "{stem}");
                assert!(dir.join(format!("out/plan/hardware/{stem}.csv")).exists(), "{stem}");
            }
        }
        Some("plan") if args.iter().any(|a| a == "--xlsx") => {
            let out = args.iter().skip_while(|a| *a != "--out").nth(1).map_or("out/plan", String::as_str);
            assert!(dir.join(out).join("joint.xlsx").exists(), "{out}/joint.xlsx");
        }
        Some("--urdf") if args.get(2).map(String::as_str) == Some("arm") => {
            assert!(terminal.contains("alpha = -1.5707963267948966"), "{terminal}");
        }
        Some("tune") if args.iter().any(|a| a == "--q0") => {
            // The start-up jump no longer makes every candidate score the same.
            let csv = std::fs::read_to_string(dir.join("out/tune/tune.csv")).unwrap();
            let mut values: Vec<f64> = csv
                .lines()
                .skip(1)
                .filter(|line| line.split(',').nth(4) == Some("ok"))
                .map(|line| line.split(',').nth(5).unwrap().parse().unwrap())
                .collect();
            values.sort_by(f64::total_cmp);
            values.dedup();
            assert!(values.len() > 100, "only {} distinct max tip errors", values.len());
            assert!(values[0] < 0.1, "best max tip error {} mm", values[0]);
            assert!(terminal.contains("tracking metrics from t = 1 s on"), "{terminal}");
        }
        // The replay of one trial: the one robustness.json says is PD's worst (its page says
        // so), to the same placement error.
        Some("simulate") if args.iter().any(|a| a == "--trial-seed") => {
            let study: Value =
                serde_json::from_slice(&std::fs::read(dir.join("out/robustness/robustness.json")).unwrap()).unwrap();
            let pd = &study["controllers"].as_array().unwrap().iter().find(|c| c["controller"] == "pd").unwrap();
            let typed: Vec<&str> = args.iter().map(String::as_str).filter(|a| *a != "--json").collect();
            assert_eq!(pd["replay_worst_trial"].as_str().unwrap(), format!("chessarm {}", typed.join(" ")));
            assert_eq!(json["summary"]["controllers"][0]["placement_error_mm"], pd["place_error_mm"]["max"]);
        }
        Some("play") if args.iter().any(|a| a == "--game") => {
            assert_eq!(json["result"].as_str(), Some("0-1"), "game 2 is the fool's mate: {json}");
            assert!(dir.join("out/play/replay.html").exists());
        }
        Some("calibrate") => {
            // The page's figures: the board found moved 8 mm and turned 2°.
            let result: Value =
                serde_json::from_slice(&std::fs::read(dir.join("calibration/calibration.json")).unwrap()).unwrap();
            assert!((result["moved_mm"].as_f64().unwrap() - 8.0).abs() < 0.2, "{result}");
            assert!((result["turned_deg"].as_f64().unwrap() - 2.0).abs() < 0.02, "{result}");
            assert!(result["largest_residual_mm"].as_f64().unwrap() < 0.21, "{result}");
            assert!(dir.join("calibration/setup.toml").is_file() && dir.join("calibration/residuals.png").is_file());
        }
        _ if args.iter().any(|a| a == "--human") => {
            // The person's game is saved as PGN; resumed, it goes on; a dry run logs packets.
            let out = args.iter().skip_while(|a| *a != "--out").nth(1).unwrap();
            let pgn = std::fs::read_to_string(dir.join(out).join("game.pgn")).unwrap();
            assert!(pgn.contains("1. Nc3"), "{pgn}");
            if args.iter().any(|a| a == "--resume") {
                assert!(pgn.contains("Bd3"), "{pgn}");
            }
            if args.iter().any(|a| a == "--dry-run") {
                let log = std::fs::read_to_string(dir.join(out).join("bus.jsonl")).unwrap();
                assert!(log.lines().count() > 100, "{log}");
            }
            if !args.iter().any(|a| a == "--resume") {
                assert!(terminal.contains("not played"), "the example's inputs hold a refused line: {terminal}");
            }
        }
        Some("play") if args.iter().any(|a| a == "--moves") => {
            assert!(terminal.contains("replay.html"), "{terminal}");
        }
        _ => {}
    }
}

/// One `<!-- monte-carlo: ARGS -->` table: its ARGS and, per row, the fixture and its figures.
type MonteCarloTable = (String, Vec<(String, Vec<f64>)>);

/// The pages' Monte Carlo tables: each `<!-- monte-carlo: ARGS -->` line is followed by a
/// table whose rows name a fixture (`` `NAME.pgn` ``) and give the success rate, the median,
/// p95 and largest placement error and the robot seconds per ply that `chessarm ARGS` (with
/// `GAME` the fixture) prints for its first controller, to the digits shown.
fn monte_carlo_tables(page: &Page) -> Vec<MonteCarloTable> {
    let mut tables: Vec<MonteCarloTable> = Vec::new();
    let mut in_table = false;
    for line in page.text.lines() {
        if let Some(args) = line.trim().strip_prefix("<!-- monte-carlo:").and_then(|l| l.strip_suffix("-->")) {
            tables.push((args.trim().to_owned(), Vec::new()));
            in_table = true;
            continue;
        }
        if !in_table {
            continue;
        }
        if !line.starts_with('|') {
            if !line.trim().is_empty() || tables.last().is_some_and(|t| !t.1.is_empty()) {
                in_table = false;
            }
            continue;
        }
        let cells: Vec<&str> = line.split('|').map(str::trim).filter(|c| !c.is_empty()).collect();
        let Some(game) = cells.first().and_then(|c| c.strip_prefix('`')).and_then(|c| c.strip_suffix('`')) else {
            continue;
        };
        let numbers: Vec<f64> = cells[1..]
            .iter()
            .filter_map(|c| c.trim_end_matches(|ch: char| !ch.is_ascii_digit()).trim().parse().ok())
            .collect();
        tables.last_mut().unwrap().1.push((game.to_owned(), numbers));
    }
    tables
}

#[test]
fn the_pages_monte_carlo_figures_are_what_their_command_prints() {
    let tables: Vec<MonteCarloTable> = all_pages().iter().flat_map(monte_carlo_tables).collect();
    assert!(tables.len() >= 2 && tables.iter().all(|t| t.1.len() == 2), "the pages' Monte Carlo tables: {tables:?}");
    let dir = tempfile::tempdir().unwrap();
    common::copy_examples(dir.path());
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../chess/tests/fixtures");
    for (template, rows) in &tables {
        for (game, figures) in rows {
            let path = fixtures.join(game);
            let args: Vec<String> = words(template)
                .into_iter()
                .map(|w| if w == "GAME" { path.display().to_string() } else { w })
                .chain(["--json".to_owned(), "--out".to_owned(), "out".to_owned()])
                .collect();
            let output =
                Command::new(env!("CARGO_BIN_EXE_chessarm")).args(&args).current_dir(dir.path()).output().unwrap();
            assert!(output.status.success(), "{template}: {}", String::from_utf8_lossy(&output.stderr));
            let json: Value = serde_json::from_slice(&output.stdout).unwrap();
            let stats = &json["summary"]["controllers"][0];
            let number = |v: &Value| v.as_f64().unwrap();
            let measured = [
                100.0 * number(&stats["success_rate"]),
                number(&stats["place_error_mm"]["median"]),
                number(&stats["place_error_mm"]["p95"]),
                number(&stats["place_error_mm"]["max"]),
                number(&stats["seconds_per_ply"]),
            ];
            // The figures as the page prints them: the rate in whole percent, the rest to two
            // decimals.
            assert_eq!(figures.len(), 5, "{game}: {figures:?}");
            let shown: Vec<String> = measured
                .iter()
                .enumerate()
                .map(|(i, v)| if i == 0 { format!("{v:.0}") } else { format!("{v:.2}") })
                .collect();
            let written: Vec<String> = figures
                .iter()
                .enumerate()
                .map(|(i, v)| if i == 0 { format!("{v:.0}") } else { format!("{v:.2}") })
                .collect();
            assert_eq!(written, shown, "{template} on {game}: the page {figures:?}, measured {measured:?}");
        }
    }
}
