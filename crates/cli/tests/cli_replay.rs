//! `replay.html` in a real browser: Debian's Chromium, headless, driven by playwright-core
//! (`tests/browser/probe.mjs`), the page opened from `file://`. Without Node.js, the npm
//! package or Chromium the test harness counts the browser tests as ignored (`cfg(tool_browser)`,
//! set by the build script); `--include-ignored` runs them, and they fail without their tools.

#![allow(clippy::unwrap_used)]

mod common;

use common::{chessarm, json_of};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn browser_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/browser")
}

/// Why the browser tests cannot run here, if they cannot.
fn missing_browser() -> Option<String> {
    let chromium = std::env::var("CHESSARM_CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into());
    if !Path::new(&chromium).exists() {
        return Some(format!("{chromium} is not installed"));
    }
    if Command::new("node").arg("--version").output().is_err() {
        return Some("node is not installed".into());
    }
    if !browser_dir().join("node_modules/playwright-core").exists() {
        return Some("playwright-core is not installed (npm ci in crates/cli/tests/browser)".into());
    }
    None
}

/// Fails a browser test that runs where its tools are missing (`--include-ignored`).
fn require_browser() {
    if let Some(reason) = missing_browser() {
        panic!("this test needs a browser: {reason} (see docs/testing.md)");
    }
}

/// Where a test keeps its screenshot, as a test artefact: `target/test-artifacts/`.
fn artefact(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/test-artifacts");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

use common::play_game as played;

/// Plays `args` into `out` and opens its replay.html in the browser (`screenshot`, `times`
/// and `shot_at` as for [`probe`]'s first run): the game.json and the page's report, whose
/// console is clean and whose final table is the game's.
fn replayed(out: &Path, args: &[&str], screenshot: &Path, times: &[f64], shot_at: f64) -> (Value, Value) {
    let game = played(out, args);
    let report = probe(&out.join("replay.html"), screenshot, 0, times, shot_at);
    assert_clean_console(&report);
    assert_final_table(&report, &game);
    (game, report)
}

/// Opens `html` in the browser: the page's report (see probe.mjs).
fn probe(html: &Path, screenshot: &Path, run: usize, times: &[f64], shot_at: f64) -> Value {
    let times: Vec<String> = times.iter().map(|t| format!("{t}")).collect();
    let output = Command::new("node")
        .current_dir(browser_dir())
        .arg("probe.mjs")
        .arg(html)
        .arg(screenshot)
        .args(["--run", &run.to_string(), "--times", &times.join(","), "--shot-at", &shot_at.to_string()])
        .output()
        .unwrap();
    assert!(output.status.success(), "probe failed: {}", String::from_utf8_lossy(&output.stderr));
    serde_json::from_slice(&output.stdout).unwrap()
}

/// Console errors, page errors and warnings, but not the software GL driver's notes on
/// reading pixels back for the screenshot (a performance hint, not a fault of the page).
fn assert_clean_console(report: &Value) {
    let problems: Vec<&str> = report["errors"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e.as_str().unwrap())
        .filter(|e| !(e.starts_with("warning:") && e.contains("GL Driver Message")))
        .collect();
    assert!(problems.is_empty(), "console: {problems:?}");
    assert_eq!(report["requests"].as_array().unwrap().len(), 0, "the page went to the network: {}", report["requests"]);
    assert_eq!(report["webgl"], true, "no WebGL: the 3D view was not drawn");
}

/// Rows of a CSV as maps from column name to value.
fn csv_rows(path: &Path) -> Vec<std::collections::HashMap<String, f64>> {
    let mut reader = csv::Reader::from_path(path).unwrap();
    let header: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
    reader
        .records()
        .map(|r| header.iter().cloned().zip(r.unwrap().iter().map(|v| v.parse::<f64>().unwrap())).collect())
        .collect()
}

/// Every `step`-th row of the CSVs: `(t, [x, y, z])` of the simulated tool tip.
fn tip_samples(csvs: &[PathBuf], step: usize, offset: usize) -> Vec<(f64, [f64; 3])> {
    csvs.iter()
        .flat_map(|csv| csv_rows(csv).into_iter().skip(offset).step_by(step).collect::<Vec<_>>())
        .map(|row| (row["t"], [row["x"], row["y"], row["z"]]))
        .collect()
}

/// Largest distance between the scene's tool and the CSV's tip at the probed instants, m.
fn worst_tool_error(report: &Value, samples: &[(f64, [f64; 3])]) -> (f64, f64) {
    let probed = report["samples"].as_array().unwrap();
    assert_eq!(probed.len(), samples.len());
    let mut worst = (0.0f64, 0.0);
    for (probe, (t, tip)) in probed.iter().zip(samples) {
        let tool = common::numbers(&probe["tool"]);
        let distance = ((tool[0] - tip[0]).powi(2) + (tool[1] - tip[1]).powi(2) + (tool[2] - tip[2]).powi(2)).sqrt();
        if distance > worst.0 {
            worst = (distance, *t);
        }
    }
    worst
}

/// An RGB pixel of a PNG screenshot, averaged over the 3×3 block around `(x, y)` (page pixels).
struct Picture {
    width: usize,
    height: usize,
    rgb: Vec<[f64; 3]>,
}

impl Picture {
    fn read(path: &Path) -> Self {
        let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
        let mut reader = decoder.read_info().unwrap();
        let mut buffer = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buffer).unwrap();
        let channels = info.color_type.samples();
        assert_eq!(info.bit_depth, png::BitDepth::Eight);
        let rgb = buffer[..info.buffer_size()]
            .chunks(channels)
            .map(|p| [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])])
            .collect();
        Self { width: info.width as usize, height: info.height as usize, rgb }
    }

    fn at(&self, point: &Value) -> [f64; 3] {
        let (x, y) = (point[0].as_f64().unwrap() as usize, point[1].as_f64().unwrap() as usize);
        let mut sum = [0.0; 3];
        for dy in 0..3 {
            for dx in 0..3 {
                let p = self.rgb[(y + dy - 1).min(self.height - 1) * self.width + (x + dx - 1).min(self.width - 1)];
                for k in 0..3 {
                    sum[k] += p[k] / 9.0;
                }
            }
        }
        sum
    }
}

fn luminance(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

fn difference(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).abs()).sum()
}

/// The screenshot shows the board's light and dark squares and the arm where the scene puts
/// them, and is not one colour.
fn assert_picture_shows_the_scene(screenshot: &Path, report: &Value) {
    let picture = Picture::read(screenshot);
    let marks = &report["landmarks"];
    let background = picture.at(&marks["background"]);
    let first = |kind: &str| {
        let list = marks[kind].as_array().unwrap();
        assert!(!list.is_empty(), "no unobstructed {kind} landmark in view: {marks}");
        list.iter().map(|m| picture.at(&m["at"])).collect::<Vec<_>>()
    };
    let (light, dark, links) = (first("light"), first("dark"), first("links"));
    let mean = |colours: &[[f64; 3]]| colours.iter().map(|c| luminance(*c)).sum::<f64>() / colours.len() as f64;
    // Lit from above, the light squares (#e9d4aa) stay well brighter than the dark (#9a6a3f):
    // their luminances differ by 90 unlit; a third of that must survive the shading.
    assert!(mean(&light) > mean(&dark) + 30.0, "light {light:?} vs dark {dark:?} squares");
    for square in light.iter().chain(&dark) {
        assert!(difference(*square, background) > 60.0, "a square looks like the background: {square:?}");
    }
    // The arm's links (#c8ccd2) are grey, not the board's brown nor the background.
    for link in &links {
        assert!(difference(*link, background) > 60.0, "a link looks like the background: {link:?}");
        let spread = link.iter().cloned().fold(f64::MIN, f64::max) - link.iter().cloned().fold(f64::MAX, f64::min);
        assert!(spread < 40.0, "a link is not grey: {link:?}");
    }
    // Not blank: many distinct colours over the picture.
    let mut seen = std::collections::HashSet::new();
    for p in &picture.rgb {
        seen.insert((p[0] as u8 >> 3, p[1] as u8 >> 3, p[2] as u8 >> 3));
    }
    assert!(seen.len() > 200, "only {} colours in the screenshot", seen.len());
}

#[test]
#[cfg_attr(not(tool_browser), ignore = "needs Chromium, Node.js and playwright-core; see docs/testing.md")]
fn the_readme_game_replays_in_a_browser_where_the_simulation_put_everything() {
    require_browser();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let game = played(&out, &["--moves", "e4 e5 Nf3 Nc6 Bb5"]);
    let mut csvs: Vec<PathBuf> = std::fs::read_dir(out.join("moves"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "csv"))
        .collect();
    csvs.sort();
    // Every row (10 ms): instants on the display frames (every 20 ms) and between them.
    let samples = tip_samples(&csvs, 1, 0);
    assert!(samples.len() > 100);
    let times: Vec<f64> = samples.iter().map(|s| s.0).collect();
    let screenshot = artefact("replay-play.png");
    let report = probe(&out.join("replay.html"), &screenshot, 0, &times, 7.777);
    assert_clean_console(&report);
    // The drawn tool is where the simulation's CSV puts the tip: display sampling (50 Hz,
    // cubic interpolation) and quantisation (10 µrad) cost less than 0.5 mm.
    let (worst, at) = worst_tool_error(&report, &samples);
    assert!(worst < 0.5e-3, "tool {:.3} mm from the CSV's tip at t = {at} s", worst * 1e3);
    eprintln!("replay: worst tool-vs-CSV distance {:.4} mm at t = {at} s", worst * 1e3);
    // One entry per ply, in order, with the game's SAN.
    let moves = report["moves"].as_array().unwrap();
    let plies = game["moves"].as_array().unwrap();
    assert_eq!(moves.len(), plies.len());
    for (shown, played) in moves.iter().zip(plies) {
        assert_eq!(shown["san"], played["san"]);
        assert_eq!(shown["ply"], played["ply"]);
    }
    // At the end every piece stands where game.json's final table says (to the µm the
    // replay's data are rounded to).
    assert_final_table(&report, &game);
    assert_handlings_and_steps(&report);
    assert_picture_shows_the_scene(&screenshot, &report);
    assert!(report["samples"].as_array().unwrap().iter().any(|s| s["phase"] == "carrying"));
    assert_closest_pairs(&report, &game);
}

/// Every robot move's closest pair is game.json's (part, obstacle, distance to the µm the
/// replay rounds to), shown at its instant as a line between its two points (as long as the
/// distance: the points are rounded to 1 µm, so 5 µm) with the readout naming both, and gone
/// a second later.
fn assert_closest_pairs(report: &Value, game: &Value) {
    let shown = report["closest"].as_array().unwrap();
    let plies = game["moves"].as_array().unwrap();
    assert_eq!(shown.len(), plies.len());
    let mut seen = 0;
    for (entry, played) in shown.iter().zip(plies) {
        let Some(clearance) = played["clearance"].as_object() else {
            assert!(entry.is_null(), "{entry}");
            continue;
        };
        seen += 1;
        let c = &entry["closest"];
        let simulated = &clearance["executed"]["smallest_mm"];
        let expected = if simulated.is_number() { simulated } else { &clearance["smallest_mm"] };
        assert!((c["distance_mm"].as_f64().unwrap() - expected.as_f64().unwrap()).abs() < 1e-3, "{c} vs {played}");
        assert_eq!(c["simulated"].as_bool().unwrap(), simulated.is_number());
        let part = if simulated.is_number() { &clearance["executed"]["part"] } else { &clearance["part"] };
        assert_eq!(&c["part"], part);
        let line = common::numbers(&entry["at"]["line"]);
        let length = ((line[0] - line[3]).powi(2) + (line[1] - line[4]).powi(2) + (line[2] - line[5]).powi(2)).sqrt();
        assert!((length * 1e3 - c["distance_mm"].as_f64().unwrap()).abs() < 5e-3, "{entry}");
        assert_eq!(entry["at"]["visible"], true, "{entry}");
        assert_eq!(entry["after"]["visible"], false, "{entry}");
        let text = entry["at"]["text"].as_str().unwrap();
        for needle in [c["part"].as_str().unwrap(), c["obstacle"].as_str().unwrap(), " mm at "] {
            assert!(text.contains(needle), "{needle}: {text}");
        }
    }
    assert!(seen >= 3, "{shown:?}");
}

fn assert_final_table(report: &Value, game: &Value) {
    let pieces = report["pieces"].as_array().unwrap();
    let table = game["final_table"].as_array().unwrap();
    assert_eq!(pieces.len(), table.len());
    for (shown, truth) in pieces.iter().zip(table) {
        let p = common::numbers(&shown["position"]);
        let (x, y) = (truth["x_m"].as_f64().unwrap(), truth["y_m"].as_f64().unwrap());
        let off = ((p[0] - x).powi(2) + (p[1] - y).powi(2)).sqrt();
        assert!(off < 1e-6, "{} at {} is drawn {:.4} mm away", truth["piece"], truth["location"], off * 1e3);
        assert!(p[2].abs() < 1e-12, "{} is not standing on the table: z = {}", truth["piece"], p[2]);
        let name = format!("{} {}", shown["color"].as_str().unwrap(), shown["role"].as_str().unwrap());
        assert_eq!(name, truth["piece"].as_str().unwrap());
    }
}

/// Every moved piece stood where it was before its grip and where it was put down after its
/// release, seeking forwards and backwards; shift+arrows step through every ply in order.
fn assert_handlings_and_steps(report: &Value) {
    let handled = report["handled"].as_array().unwrap();
    assert!(!handled.is_empty());
    for pass in ["forwards", "backwards"] {
        for (seen, h) in report[pass].as_array().unwrap().iter().zip(handled) {
            // (A hand move at t = 0 has no "before" on the timeline.)
            let checks: &[(&str, &str)] = if h["grip_t"].as_f64().unwrap() < 1e-3 {
                &[("after", "placed")]
            } else {
                &[("before", "standing"), ("after", "placed")]
            };
            for &(when, key) in checks {
                let p = common::numbers(&seen[when]);
                let q = common::numbers(&h[key]);
                let off = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt();
                assert!(
                    off < 1e-9 && p[2].abs() < 1e-12,
                    "{pass}: piece {} {when} {}: {p:?} vs {q:?}",
                    h["piece"],
                    h["to"]
                );
            }
        }
    }
    let plies: Vec<i64> = report["moves"].as_array().unwrap().iter().map(|m| m["ply"].as_i64().unwrap()).collect();
    let down: Vec<i64> = report["down"].as_array().unwrap().iter().filter_map(Value::as_i64).collect();
    let last = *plies.last().unwrap();
    // At t = 0 the current move is the last one that starts then (a hand move at t = 0 is
    // done: the arm's move after it is under way).
    let moves = report["moves"].as_array().unwrap();
    let start = moves[0]["start"].as_f64().unwrap();
    let first = moves.iter().filter(|m| m["start"].as_f64().unwrap() <= start + 1e-9).count() - 1;
    let expected: Vec<i64> = plies[first..].iter().copied().chain([last, last]).chain(vec![last; first]).collect();
    assert_eq!(down, expected, "the current move at t = 0, then shift+→ past the last");
    let up: Vec<i64> = report["up"].as_array().unwrap().iter().filter_map(Value::as_i64).collect();
    let mut back: Vec<i64> = plies.iter().rev().skip(1).copied().collect();
    back.push(plies[0]);
    back.push(plies[0]);
    assert_eq!(up, back, "shift+← from the last move");
}

#[test]
#[cfg_attr(not(tool_browser), ignore = "needs Chromium, Node.js and playwright-core; see docs/testing.md")]
fn captures_castling_and_promotions_end_with_every_piece_in_its_place() {
    require_browser();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let pgn = common::chess_fixture("special_moves.pgn");
    let (game, report) = replayed(&out, &[&pgn], &artefact("replay-special-moves.png"), &[], 1.0);
    assert_handlings_and_steps(&report);
    let table = game["final_table"].as_array().unwrap();
    assert!(table.iter().any(|p| p["location"].as_str().unwrap().contains("graveyard")), "nothing was captured");
    assert_eq!(report["moves"].as_array().unwrap().len(), game["moves"].as_array().unwrap().len());
}

#[test]
#[cfg_attr(not(tool_browser), ignore = "needs Chromium, Node.js and playwright-core; see docs/testing.md")]
fn the_demo_replays_each_controller_where_its_csv_puts_the_tool() {
    require_browser();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    json_of(&chessarm(&["demo", "--out", out.to_str().unwrap()]));
    let simulate = out.join("simulate");
    for (run, name) in ["pd", "pid-plain", "pid"].iter().enumerate() {
        // Every third row (1 ms steps): instants on and between the display frames.
        let samples = tip_samples(&[simulate.join(format!("{name}.csv"))], 3, 1);
        let times: Vec<f64> = samples.iter().map(|s| s.0).collect();
        let report =
            probe(&simulate.join("replay.html"), &artefact(&format!("replay-demo-{name}.png")), run, &times, 5.8);
        assert_clean_console(&report);
        assert_eq!(report["runs"].as_array().unwrap().len(), 3);
        // The start-up jump from q = 0 included, the fastest motion of all (joint 3 turns
        // 2.5 rad in a fraction of a second): the frames carry the rates as well as the angles.
        let (worst, at) = worst_tool_error(&report, &samples);
        assert!(worst < 0.5e-3, "{name}: tool {:.3} mm from the CSV's tip at t = {at} s", worst * 1e3);
        eprintln!("demo replay {name}: worst tool-vs-CSV {:.4} mm (t = {at} s)", worst * 1e3);
        let pawn = report["pieces"].as_array().unwrap().iter().find(|p| {
            p["role"] == "pawn" && {
                let p = common::numbers(&p["position"]);
                (p[0] + 0.03).abs() < 0.01 && (p[1] - 0.30).abs() < 0.01
            }
        });
        assert!(pawn.is_some(), "{name}: no pawn on d4 at the end: {}", report["pieces"]);
    }
}

/// The data embedded in a replay page.
fn replay_data(html: &Path) -> Value {
    let page = std::fs::read_to_string(html).unwrap();
    let start = page.find(r#"<script type="application/json" id="chessarm-data">"#).unwrap();
    let text = &page[start..];
    let text = &text[text.find('>').unwrap() + 1..text.find("</script>").unwrap()];
    serde_json::from_str(text).unwrap()
}

#[test]
fn a_whole_game_s_replay_stays_small_and_at_most_50_hz() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let pgn = common::chess_fixture("kasparov_topalov_1999.pgn");
    let game = json_of(&chessarm(&["play", &pgn, "--out", out.to_str().unwrap()]));
    assert_eq!(game["plies"], 87);
    let html = out.join("replay.html");
    let size = std::fs::metadata(&html).unwrap().len();
    // The issue's budget: an 80-ply game in at most 3 MB, three.js (751 kB) included.
    assert!(size < 3_000_000, "replay.html of 87 plies is {size} bytes");
    eprintln!("replay.html of 87 plies: {size} bytes");
    let data = replay_data(&html);
    let run = &data["runs"][0];
    let unit = data["units"]["time"].as_f64().unwrap();
    let mut t = 0i64;
    let times: Vec<f64> = run["frames"]["t"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| {
            t += d.as_i64().unwrap();
            t as f64 * unit
        })
        .collect();
    let moves = run["moves"].as_array().unwrap();
    assert_eq!(moves.len(), 87);
    let ends: Vec<f64> = moves.iter().map(|m| m["end"].as_f64().unwrap()).collect();
    // Frames 20 ms apart at least, but where a move ends: its last record (within one record
    // period, 10 ms, of its end) is kept.
    for pair in times.windows(2) {
        let gap = pair[1] - pair[0];
        let at_an_end = ends.iter().any(|e| (e - pair[1]).abs() < 0.011 || (e - pair[0]).abs() < 0.011);
        assert!(gap > 0.0 && (gap >= 0.02 - 1e-3 || at_an_end), "frames {pair:?} {gap} s apart");
    }
    // Every channel has one value per frame.
    for channel in ["q", "qd", "tip_desired"] {
        for values in run["frames"][channel].as_array().unwrap() {
            assert_eq!(values.as_array().unwrap().len(), times.len(), "{channel}");
        }
    }
    assert_eq!(run["frames"]["tip_error"].as_array().unwrap().len(), times.len());
    // The last frame is the end of the game's robot time.
    let total = std::fs::read_to_string(out.join("game.json")).unwrap();
    let total: Value = serde_json::from_str(&total).unwrap();
    assert!((times.last().unwrap() - total["total_robot_time_s"].as_f64().unwrap()).abs() < 1e-3);
}

#[test]
#[cfg_attr(not(tool_browser), ignore = "needs Chromium, Node.js and playwright-core; see docs/testing.md")]
fn the_opponent_s_hand_moves_count_to_the_last_ply_and_a_page_without_robot_moves_shows_the_arm() {
    require_browser();
    let dir = tempfile::tempdir().unwrap();
    // The arm plays black: the last ply, White's, is the hand's, after the last robot frame.
    let out = dir.path().join("black");
    let pgn = common::chess_fixture("special_moves.pgn");
    let (_, report) = replayed(&out, &[&pgn, "--robot", "black"], &artefact("replay-robot-black.png"), &[], 3.0);
    assert_handlings_and_steps(&report);
    // A FEN start with Black to move, one move by the hand: no robot frame but the home pose.
    let out = dir.path().join("hand");
    let fen = "rnbqkbnr/pppppppp/8/8/4P3/8/PPPP1PPP/RNBQKBNR b KQkq - 0 1";
    let (_, report) = replayed(
        &out,
        &["--moves", "e5", "--fen", fen, "--robot", "white"],
        &artefact("replay-hand-only.png"),
        &[0.0],
        0.0,
    );
    let tool = common::numbers(&report["samples"][0]["tool"]);
    assert!(tool.iter().all(|v| v.is_finite()) && tool[2] > 0.1, "no arm drawn: {tool:?}");
    assert_eq!(report["moves"][0]["ply"], 1);
    let html = std::fs::read_to_string(out.join("replay.html")).unwrap();
    assert!(html.contains(r#""number":"1...""#), "Black's first move is numbered 1...");
    assert_picture_shows_the_scene(&artefact("replay-hand-only.png"), &report);
}
