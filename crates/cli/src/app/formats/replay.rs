//! `replay.html`: the simulated motion in 3D, one self-contained file that opens offline.
//!
//! The page embeds the vendored three.js ([`THREE_VERSION`], `assets/three/`), the viewer
//! (`assets/replay.html`) and the run's data as JSON. The data are for display: the joint
//! angles and rates every [`DISPLAY_PERIOD`] (at most 50 Hz), quantised to 10 µrad and
//! 100 µrad/s (the page interpolates between frames by cubic Hermite on both), the desired tool tip
//! to 10 µm, the tip error to 1 µm, times to 0.1 ms, each channel delta-encoded; exact values
//! stay in the CSVs. The page computes the arm's pose from the angles with the model's own DH
//! parameters, so the tool drawn is where forward kinematics puts it. A gripped piece moves
//! rigidly with the tool (its base at `standing + tip(t) − tip(grip)`), a released one stays
//! where the simulation put it down.

use crate::app::output::write_atomic;
use anyhow::Result;
use chessarm_chess::board::BoardGeometry;
use chessarm_chess::pieces::{PieceSet, role_name};
use chessarm_chess::play::Handling;
use chessarm_chess::shakmaty::{Color, Square};
use chessarm_chess::table::{Location, Table};
use chessarm_core::arm::bodies::{JOINT_LENGTH, JOINT_RADIUS, LINK_RADIUS, TOOL_RADIUS};
use chessarm_core::arm::model::ArmModel;
use chessarm_core::nalgebra::Vector3;
use chessarm_core::sim::StepRecord;
use serde_json::{Value, json};
use std::io::Write;
use std::path::Path;

/// The vendored three.js release (see `assets/three/README.md`).
pub const THREE_VERSION: &str = "0.185.1";
const THREE_CORE: &str = include_str!("../../../assets/three/three.core.min.js");
const THREE_MODULE: &str = include_str!("../../../assets/three/three.module.min.js");
const VIEWER: &str = include_str!("../../../assets/replay.html");

/// Time between displayed frames, s (50 Hz: every second record of `play`, every twentieth
/// of `simulate`).
pub const DISPLAY_PERIOD: f64 = 0.02;

/// Units of the quantised channels: time (s), angle (rad), position (m), tip error (m).
const TIME_UNIT: f64 = 1e-4;
const ANGLE_UNIT: f64 = 1e-5;
const RATE_UNIT: f64 = 1e-4;
const POSITION_UNIT: f64 = 1e-5;
const ERROR_UNIT: f64 = 1e-6;

/// What the phase labels of the timeline say, by code.
const PHASES: [&str; 10] = [
    "at rest",
    "travelling",
    "lowering",
    "raising",
    "gripping",
    "releasing",
    "carrying",
    "lowering the piece",
    "lifting the piece",
    "waiting to be in position",
];

/// One displayed instant: time in the run (s), joint angles (rad), desired tool tip (m) and
/// tip error (m).
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    pub t: f64,
    pub q: [f64; 4],
    pub qd: [f64; 4],
    pub tip_desired: Vector3<f64>,
    pub tip_error: f64,
}

impl Frame {
    /// The frame of a recorded step at run time `t`.
    pub fn of(t: f64, record: &StepRecord<4>) -> Self {
        Self {
            t,
            q: record.state.q.into(),
            qd: record.state.qd.into(),
            tip_desired: record.tip_desired,
            tip_error: (record.tip - record.tip_desired).norm(),
        }
    }
}

/// One move on the timeline.
#[derive(Debug, Clone)]
pub struct ReplayMove {
    pub ply: usize,
    /// The move number as notation writes it: `1.` for White's, `1...` for Black's.
    pub number: String,
    pub san: String,
    pub uci: String,
    /// `robot` or `hand`.
    pub by: &'static str,
    pub start: f64,
    pub end: f64,
    /// The move's closest approach of the arm to an obstacle, shown at its instant.
    pub closest: Option<ReplayClosest>,
}

/// A move's closest approach, for showing: when (s, the run's time), how near (m), the arm's
/// part and the obstacle as people name them, the point on each (m), whether it is a contact,
/// and whether it is the simulated motion's (else the plan's, which the simulated arm follows
/// within its tracking error).
#[derive(Debug, Clone)]
pub struct ReplayClosest {
    pub t: f64,
    pub distance: f64,
    pub part: String,
    pub obstacle: String,
    pub points: [Vector3<f64>; 2],
    pub contact: bool,
    pub simulated: bool,
}

/// One simulated run (a controller, a game).
#[derive(Debug, Clone)]
pub struct ReplayRun {
    pub name: String,
    pub frames: Vec<Frame>,
    pub handled: Vec<Handling>,
    pub moves: Vec<ReplayMove>,
    /// The fine points' waits, `[start, end]` in the run's time (s): the phase shows them.
    pub waits: Vec<[f64; 2]>,
}

/// Everything a replay shows.
#[derive(Debug, Clone)]
pub struct Replay<'a> {
    pub title: String,
    pub arm: &'a ArmModel<4>,
    pub board: &'a BoardGeometry,
    pub pieces: &'a PieceSet,
    /// The table at the start (every piece, with its index as id).
    pub table: &'a Table,
    /// Placement tolerance, m: a piece put down farther from its place is shown misplaced.
    pub tolerance: f64,
    /// A note shown under the title (e.g. "payload 0 kg").
    pub note: String,
    pub runs: Vec<ReplayRun>,
}

/// Keeps the frames at least [`DISPLAY_PERIOD`] apart, and the last of `frames` (the end of a
/// move), dropping any not later than the one before.
pub fn thin(frames: impl IntoIterator<Item = Frame>, into: &mut Vec<Frame>) {
    let mut pending: Option<Frame> = None;
    for frame in frames {
        let last = into.last().map(|f| f.t);
        if last.is_none_or(|t| frame.t >= t + DISPLAY_PERIOD - 1e-9) {
            into.push(frame);
            pending = None;
        } else if last.is_some_and(|t| frame.t > t + 1e-9) {
            pending = Some(frame);
        }
    }
    into.extend(pending);
}

fn quantise(value: f64, unit: f64) -> i64 {
    (value / unit).round() as i64
}

/// Delta encoding: the first value, then each value's difference from the one before.
fn deltas(values: impl Iterator<Item = i64>) -> Vec<i64> {
    let mut last = 0;
    values
        .map(|v| {
            let d = v - last;
            last = v;
            d
        })
        .collect()
}

/// Rounds to 1 µm (positions in m) for the JSON; `+ 0.0` drops negative zeros.
fn micro(value: f64) -> f64 {
    (value * 1e6).round() / 1e6 + 0.0
}

/// The phase of each frame, run-length encoded as `[time, code]`: from the desired tool
/// velocity and whether a piece is gripped.
fn phases(run: &ReplayRun) -> Vec<[f64; 2]> {
    let mut out: Vec<[f64; 2]> = Vec::new();
    let robot = |h: &&Handling| h.grip_tip.is_some();
    for (i, frame) in run.frames.iter().enumerate() {
        let next = run.frames.get(i + 1).or_else(|| i.checked_sub(1).and_then(|p| run.frames.get(p)));
        let velocity = match next {
            Some(other) if (other.t - frame.t).abs() > 0.0 => {
                (other.tip_desired - frame.tip_desired) / (other.t - frame.t)
            }
            _ => Vector3::zeros(),
        };
        let t = frame.t;
        let waiting = run.waits.iter().any(|[start, end]| *start <= t && t < *end);
        let carrying = run.handled.iter().filter(robot).any(|h| h.grip_time <= t && t < h.release_time);
        let near = |at: f64| (at - t).abs() <= 0.6;
        let code = if waiting {
            9
        } else if velocity.norm() < 1e-3 {
            if run.handled.iter().filter(robot).any(|h| near(h.grip_time)) {
                4
            } else if run.handled.iter().filter(robot).any(|h| near(h.release_time)) {
                5
            } else {
                0
            }
        } else if velocity.xy().norm() < 0.1 * velocity.z.abs() {
            match (velocity.z < 0.0, carrying) {
                (true, false) => 2,
                (false, false) => 3,
                (true, true) => 7,
                (false, true) => 8,
            }
        } else if carrying {
            6
        } else {
            1
        };
        if out.last().is_none_or(|last| last[1] != code as f64) {
            out.push([micro(t), code as f64]);
        }
    }
    out
}

/// A run's frames, channel by channel, quantised and delta-encoded; typed rather than a
/// `serde_json::Value` tree, which would take ~4× their memory when written (fields in
/// alphabetical order, as a `Value`'s are).
#[derive(Debug, serde::Serialize)]
struct FramesJson {
    q: Vec<Vec<i64>>,
    qd: Vec<Vec<i64>>,
    t: Vec<i64>,
    tip_desired: Vec<Vec<i64>>,
    tip_error: Vec<i64>,
}

/// A run as the replay's data holds it (fields in alphabetical order).
#[derive(Debug, serde::Serialize)]
struct RunJson {
    frames: FramesJson,
    handled: Vec<Value>,
    moves: Vec<Value>,
    name: String,
    phases: Vec<[f64; 2]>,
}

/// The replay's data: the scene, then its runs.
#[derive(Debug, serde::Serialize)]
pub struct ReplayData {
    #[serde(flatten)]
    scene: Value,
    runs: Vec<RunJson>,
}

fn run_json(run: &ReplayRun, table: &Table, tolerance: f64) -> RunJson {
    let frames = &run.frames;
    let channel = |get: &dyn Fn(&Frame) -> f64, unit: f64| deltas(frames.iter().map(|f| quantise(get(f), unit)));
    let q: Vec<Vec<i64>> = (0..4).map(|j| channel(&|f: &Frame| f.q[j], ANGLE_UNIT)).collect();
    let qd: Vec<Vec<i64>> = (0..4).map(|j| channel(&|f: &Frame| f.qd[j], RATE_UNIT)).collect();
    let tip: Vec<Vec<i64>> = (0..3).map(|k| channel(&|f: &Frame| f.tip_desired[k], POSITION_UNIT)).collect();
    let handled: Vec<Value> = run
        .handled
        .iter()
        .map(|h| {
            let target = table.nominal_position(h.to);
            let error = (h.placed - target).norm();
            json!({
                "piece": h.piece,
                "from": h.from.to_string(),
                "to": h.to.to_string(),
                "grip_t": micro(h.grip_time),
                "release_t": micro(h.release_time),
                "standing": [micro(h.standing.x), micro(h.standing.y)],
                "placed": [micro(h.placed.x), micro(h.placed.y)],
                "grip_tip": h.grip_tip.map(|p| [micro(p.x), micro(p.y), micro(p.z)]),
                "error_mm": (error * 1e6).round() / 1e3,
                "misplaced": error > tolerance,
            })
        })
        .collect();
    let moves: Vec<Value> = run
        .moves
        .iter()
        .map(|m| {
            let closest = m.closest.as_ref().map(|c| {
                json!({
                    "t": micro(c.t),
                    "distance_mm": (c.distance * 1e6).round() / 1e3,
                    "part": c.part,
                    "obstacle": c.obstacle,
                    "points": c.points.map(|p| [micro(p.x), micro(p.y), micro(p.z)]),
                    "contact": c.contact,
                    "simulated": c.simulated,
                })
            });
            json!({"ply": m.ply, "number": m.number, "san": m.san, "uci": m.uci, "by": m.by, "start": micro(m.start), "end": micro(m.end), "closest": closest})
        })
        .collect();
    RunJson {
        name: run.name.clone(),
        frames: FramesJson {
            t: channel(&|f: &Frame| f.t, TIME_UNIT),
            q,
            qd,
            tip_desired: tip,
            tip_error: frames.iter().map(|f| quantise(f.tip_error, ERROR_UNIT)).collect(),
        },
        handled,
        moves,
        phases: phases(run),
    }
}

fn side(color: Color) -> &'static str {
    if color == Color::White { "white" } else { "black" }
}

/// The replay's data, to be written as JSON.
pub fn replay_json(replay: &Replay<'_>) -> ReplayData {
    let board = replay.board;
    let dh: Vec<[f64; 4]> =
        replay.arm.links().iter().map(|l| [l.dh.a, l.dh.alpha, l.dh.d, l.dh.theta_offset].map(|v| v + 0.0)).collect();
    let base = [replay.arm.base().x, replay.arm.base().y, replay.arm.base().z].map(|v| v + 0.0);
    let squares: Vec<Value> = Square::ALL
        .iter()
        .map(|&s| {
            let c = board.square_center(s);
            json!([s.to_string(), micro(c.x), micro(c.y)])
        })
        .collect();
    let slots: Vec<Value> = Location::off_board()
        .map(|l| {
            let p = replay.table.nominal_position(l);
            json!([l.to_string(), micro(p.x), micro(p.y)])
        })
        .collect();
    let pieces: serde_json::Map<String, Value> = replay
        .pieces
        .all()
        .iter()
        .map(|(role, d)| {
            (
                role_name(*role).to_string(),
                json!({"height": d.height, "base_diameter": d.base_diameter, "grip_height": d.grip_height}),
            )
        })
        .collect();
    let table: Vec<Value> = replay
        .table
        .pieces()
        .iter()
        .map(|p| {
            json!({
                "color": side(p.piece.color),
                "role": role_name(p.piece.role),
                "location": p.location.to_string(),
                "xy": [micro(p.position.x), micro(p.position.y)],
            })
        })
        .collect();
    let scene = json!({
        "format": "chessarm-replay",
        "version": 1,
        "three": THREE_VERSION,
        "title": replay.title,
        "note": replay.note,
        "units": {"time": TIME_UNIT, "angle": ANGLE_UNIT, "rate": RATE_UNIT, "position": POSITION_UNIT, "tip_error": ERROR_UNIT},
        "phase_names": PHASES,
        "arm": {
            "dh": dh,
            "base": base,
            "link_radius": LINK_RADIUS,
            "joint_radius": JOINT_RADIUS,
            "joint_length": JOINT_LENGTH,
            "tool_radius": TOOL_RADIUS,
        },
        "board": {
            "square_size": board.square_size,
            "center": [board.center.x, board.center.y],
            "yaw": board.yaw,
            "surface_height": board.surface_height,
            "squares": squares,
            "slots": slots,
        },
        "pieces": pieces,
        "table": table,
        "tolerance_mm": replay.tolerance * 1e3,
    });
    ReplayData { scene, runs: replay.runs.iter().map(|r| run_json(r, replay.table, replay.tolerance)).collect() }
}

/// What fills one of the viewer's slots.
#[derive(Debug, Clone, Copy)]
enum Slot {
    Title,
    ThreeCore,
    ThreeModule,
    Data,
}

/// The viewer's slots and their markers, in the order they appear in `assets/replay.html`
/// (each once; tested).
const SLOTS: [(Slot, &str); 4] = [
    (Slot::Title, "<!--TITLE-->"),
    (Slot::ThreeCore, "/*THREE_CORE*/"),
    (Slot::ThreeModule, "/*THREE_MODULE*/"),
    (Slot::Data, "/*CHESSARM_DATA*/"),
];

/// Writes the whole page to `out`: the viewer with the title, three.js and the data filled in,
/// streamed (the data's JSON is never held as text, nor the page).
///
/// In a `<script>` element only `</script` (and `<!--`) can end or disturb the text: the data's
/// every `<` is written as `\u003c` (JSON's escape for it); the three.js files hold neither
/// (tested).
pub fn write_replay_html(out: &mut dyn Write, replay: &Replay<'_>) -> Result<()> {
    let mut rest = VIEWER;
    for (slot, marker) in SLOTS {
        let (before, after) =
            rest.split_once(marker).unwrap_or_else(|| unreachable!("the viewer has its slots in order (tested)"));
        out.write_all(before.as_bytes())?;
        match slot {
            Slot::Title => out.write_all(html_escape(&replay.title).as_bytes())?,
            Slot::ThreeCore => out.write_all(THREE_CORE.as_bytes())?,
            Slot::ThreeModule => out.write_all(THREE_MODULE.as_bytes())?,
            Slot::Data => serde_json::to_writer(EscapeLessThan(&mut *out), &replay_json(replay))?,
        }
        rest = after;
    }
    out.write_all(rest.as_bytes())?;
    Ok(())
}

/// A writer that passes its bytes on with every `<` as `\u003c`. `<` is ASCII, so it is never
/// part of a longer UTF-8 sequence, and inside the JSON text it can only be in a string, where
/// the escape means the same character.
struct EscapeLessThan<'w>(&'w mut dyn Write);

impl Write for EscapeLessThan<'_> {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        for (k, part) in bytes.split(|b| *b == b'<').enumerate() {
            if k > 0 {
                self.0.write_all(b"\\u003c")?;
            }
            self.0.write_all(part)?;
        }
        Ok(bytes.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}

fn html_escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// Writes `replay.html` at `path` (temporary file, then rename).
pub fn write_replay(path: &Path, replay: &Replay<'_>) -> Result<()> {
    write_atomic(path, |out| write_replay_html(out, replay))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_vendored_three_js_cannot_end_its_script_element() {
        for (name, text) in [("core", THREE_CORE), ("module", THREE_MODULE)] {
            let lower = text.to_ascii_lowercase();
            assert!(!lower.contains("</script") && !lower.contains("<!--"), "three.{name} would break the page");
        }
        assert!(THREE_MODULE.contains("\"./three.core.min.js\""), "the module imports the core by this name");
    }

    #[test]
    fn the_vendored_three_js_is_the_release_its_readme_names() {
        // The hashes in assets/three/README.md, recomputed (coreutils' sha256sum).
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/three");
        let readme = std::fs::read_to_string(dir.join("README.md")).unwrap_or_default();
        assert!(readme.contains(&format!("**{THREE_VERSION}**")), "README names another version");
        for file in ["three.core.min.js", "three.module.min.js", "LICENSE"] {
            let output = std::process::Command::new("sha256sum").arg(dir.join(file)).output();
            let Ok(output) = output else { panic!("sha256sum is part of coreutils") };
            let text = String::from_utf8_lossy(&output.stdout);
            let hash = text.split_whitespace().next().unwrap_or_default();
            assert!(hash.len() == 64 && readme.contains(&format!("| `{file}` | `{hash}` |")), "{file}: {hash}");
        }
        let revision = THREE_VERSION.split('.').nth(1).unwrap_or_default();
        // Minified: `const t="185"` … `t as REVISION`.
        assert!(
            THREE_CORE.contains(&format!("const t=\"{revision}\"")) && THREE_CORE.contains("t as REVISION"),
            "three.core is not r{revision}"
        );
    }

    /// The streamed page equals the page filled in as text (the viewer's slots replaced one by
    /// one, the data's `<` escaped afterwards), for a title and names with `<`, `&` and `>`.
    #[test]
    fn the_streamed_page_is_the_viewer_with_its_slots_filled_in() {
        let mut at = 0;
        for (_, slot) in SLOTS {
            assert_eq!(VIEWER.matches(slot).count(), 1, "{slot} once in the viewer");
            let found = VIEWER.find(slot).unwrap_or_default();
            assert!(found >= at, "{slot} after the slot before it");
            at = found;
        }
        let arm = chessarm_core::arm::preset::report_arm();
        let board = BoardGeometry::default();
        let pieces = PieceSet::default();
        let table = Table::from_position(board, &chessarm_chess::shakmaty::Chess::default());
        let frame = |k: usize| Frame {
            t: k as f64 * 0.02,
            q: [0.1 * k as f64, -0.2, 0.3, 1e-6 * k as f64],
            qd: [0.5, -0.25, 0.0, 2.0],
            tip_desired: Vector3::new(0.2, -0.1, 0.05 + 1e-3 * k as f64),
            tip_error: 1e-4 * k as f64,
        };
        let moves = vec![ReplayMove {
            ply: 1,
            number: "1.".into(),
            san: "e4 <b>&</b>".into(),
            uci: "e2e4".into(),
            by: "robot",
            start: 0.0,
            end: 0.2,
            closest: None,
        }];
        let replay = Replay {
            title: "a <title> & more".into(),
            arm: &arm,
            board: &board,
            pieces: &pieces,
            table: &table,
            tolerance: 0.005,
            note: "</script><!-- note".into(),
            runs: vec![ReplayRun {
                name: "pd </script>".into(),
                frames: (0..11).map(frame).collect(),
                handled: Vec::new(),
                moves,
                waits: vec![[0.02, 0.05]],
            }],
        };
        let data = serde_json::to_string(&replay_json(&replay)).unwrap_or_default().replace('<', "\\u003c");
        let expected = VIEWER
            .replacen("/*THREE_CORE*/", THREE_CORE, 1)
            .replacen("/*THREE_MODULE*/", THREE_MODULE, 1)
            .replacen("/*CHESSARM_DATA*/", &data, 1)
            .replacen("<!--TITLE-->", &html_escape(&replay.title), 1);
        let mut page = Vec::new();
        assert!(write_replay_html(&mut page, &replay).is_ok());
        assert!(page == expected.as_bytes(), "streamed page differs from the filled-in one");
        let text = String::from_utf8(page).unwrap_or_default();
        assert_eq!(text.matches("</script").count(), VIEWER.matches("</script").count(), "the data end no script");
        assert!(text.contains("a &lt;title&gt; &amp; more"), "the title is escaped");
        assert!(text.contains("pd \\u003c/script>"), "the data's < is escaped");

        // A write that fails once, anywhere in the page (in the title, in three.js, in the
        // data, in the viewer's tail), fails the page: no error is swallowed, so no truncated
        // page is written as if complete (the writer takes every later write, so a page whose
        // error was dropped would come back Ok).
        let data_at = expected.find(&data).unwrap_or_default();
        let title_at = expected.find("a &lt;title").unwrap_or_default();
        for fail_at in [0, title_at + 2, title_at + 400, data_at + 1, data_at + data.len() / 2, expected.len() - 1] {
            let mut flaky = FailsOnce { written: 0, fail_at, failed: false };
            assert!(write_replay_html(&mut flaky, &replay).is_err(), "a failed write at byte {fail_at} was swallowed");
            assert!(flaky.failed, "byte {fail_at} reached");
        }
    }

    /// A writer whose one write that would reach byte `fail_at` fails; every other write is taken.
    struct FailsOnce {
        written: usize,
        fail_at: usize,
        failed: bool,
    }

    impl Write for FailsOnce {
        fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
            if !self.failed && self.written + bytes.len() > self.fail_at {
                self.failed = true;
                return Err(std::io::Error::other("disk full"));
            }
            self.written += bytes.len();
            Ok(bytes.len())
        }

        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn thinning_keeps_the_display_rate_and_each_move_end() {
        let frame = |t: f64| Frame { t, q: [t; 4], qd: [1.0; 4], tip_desired: Vector3::zeros(), tip_error: 0.0 };
        let mut out = Vec::new();
        thin((0..=105).map(|k| frame(k as f64 * 0.01)), &mut out);
        // Every second of 10 ms records, and the last (1.05 s) though only 10 ms after 1.04.
        assert_eq!(out.len(), 54);
        assert!(out.windows(2).all(|w| w[1].t > w[0].t));
        assert!((out.last().unwrap().t - 1.05).abs() < 1e-12);
        // The next move starts where this one ended: its first record (same time) is dropped.
        thin((0..=4).map(|k| frame(1.05 + k as f64 * 0.01)), &mut out);
        assert!(out.windows(2).all(|w| w[1].t - w[0].t > 1e-9));
        assert!((out.last().unwrap().t - 1.09).abs() < 1e-12);
    }

    #[test]
    fn deltas_invert_by_a_running_sum() {
        let values = [5, 7, 7, -3, 10];
        let d = deltas(values.into_iter());
        let mut sum = 0;
        let back: Vec<i64> = d
            .iter()
            .map(|x| {
                sum += x;
                sum
            })
            .collect();
        assert_eq!(back, values);
    }
}
