//! `play`: a game of chess with the simulated arm, every piece checked on its square.

use crate::app::formats::hardware::MoveLabel;
use crate::app::formats::pgn::PgnGame;
use crate::app::formats::plots::{Corner, Level, Panel, Series, Style, plot_panels, tick};
use crate::app::formats::replay::{Frame, Replay, ReplayMove, ReplayRun, thin, write_replay};
use crate::app::output::{
    ensure_dir, numbered, refuse_unlisted, remove_listed_in, remove_stale, write_csv, write_json,
};
use crate::app::setup::file::Setup;
use crate::app::studies::person::{PersonGame, side_name};
use crate::app::studies::play::{GameResult, PlayOptions, Played, Prepared, game_result, prepare};
use crate::cli::{PlayArgs, RobotSide};
use anyhow::{Context, Result, bail};
use chessarm_chess::notation::{GameRecord, parse_fen, parse_move_list};
use chessarm_chess::opponent::{BuiltinEngine, Opponent, UciEngine};
use chessarm_chess::play::{Game, MoveReport, Mover};
use chessarm_chess::shakmaty::{Chess, Color, Position};
use serde_json::{Value, json};
use std::path::Path;
use std::time::{Duration, Instant};

/// More plies than any game can have under the fifty-move rule (about 5 900).
const LONGEST_GAME_PLIES: usize = 6_000;

/// Memory one played ply keeps until the end, bytes: its replay frames (every 20 ms of up to
/// ~15 s of motion, captures and promotions being the longest), its plot points (every 10 ms)
/// and its report; its recorded steps go to its CSV and are dropped.
const BYTES_PER_PLY: f64 =
    (750 * std::mem::size_of::<Frame>() + 1_500 * 16 + std::mem::size_of::<MoveReport>() + 2_048) as f64;

/// Where the moves come from.
enum Source {
    Record(GameRecord),
    Engines { start: Chess, robot: Box<dyn Opponent>, opponent: Box<dyn Opponent> },
    Human(Box<HumanGame>),
}

/// A person against the arm (`--human`): who plays what, the person's input, the engine that
/// chooses the arm's moves, the game's PGN as it stands, and how it ended.
struct HumanGame {
    /// The game's turns, its record and how it ended.
    turns: PersonGame,
    input: crate::live::input::Person,
    engine: Box<dyn Opponent>,
    /// The socket the input comes from, removed at the end.
    _socket: Option<crate::live::input::SocketFile>,
    /// The live page, if served (`--live`).
    live: Option<crate::live::page::LivePage>,
    /// Per robot move: the engine's thinking and the time from the person's move to the arm
    /// starting less that thinking (planning, checking and simulating the move), s.
    timings: Vec<RobotTiming>,
}

/// A robot move's times in the live loop, s.
#[derive(Debug, Clone, Copy)]
struct RobotTiming {
    ply: usize,
    thinking: f64,
    latency: f64,
}

fn start_position(args: &PlayArgs) -> Result<Chess> {
    Ok(match &args.fen {
        Some(fen) => parse_fen(fen)?,
        None => Chess::default(),
    })
}

/// The built-in engine: to `--depth`, capped in time only with `--builtin-movetime`.
fn builtin(args: &PlayArgs) -> BuiltinEngine {
    BuiltinEngine::new(args.depth, args.builtin_movetime.map(Duration::from_millis))
}

/// Why this game's moves may differ between machines or runs (empty: they cannot).
fn machine_dependence(args: &PlayArgs) -> Vec<String> {
    let mut reasons = Vec::new();
    let engine_game = args.game_file.is_none() && args.moves.is_none();
    if !engine_game {
        return reasons;
    }
    let builtin_plays = args.engine == "builtin" || args.robot != RobotSide::Both;
    if builtin_plays && let Some(ms) = args.builtin_movetime {
        reasons.push(format!("--builtin-movetime {ms} stops the built-in engine's search on wall time"));
    }
    if args.engine != "builtin" {
        reasons
            .push(format!("the UCI engine {} searches for --movetime {} ms of wall time", args.engine, args.movetime));
    }
    reasons
}

fn opponent(args: &PlayArgs) -> Result<Box<dyn Opponent>> {
    if args.engine == "builtin" {
        return Ok(Box::new(builtin(args)));
    }
    let engine = UciEngine::spawn(Path::new(&args.engine), args.movetime, Duration::from_millis(args.engine_timeout))?;
    Ok(Box::new(engine))
}

fn source(args: &PlayArgs) -> Result<Source> {
    if let Some(side) = args.human {
        return human_source(args, side);
    }
    if let Some(path) = &args.game_file {
        if args.fen.is_some() {
            bail!("--fen goes with --moves or an engine game; a PGN file sets its own start ([FEN] tag)");
        }
        return Ok(Source::Record(crate::app::formats::pgn::read_pgn_game(path, args.game)?));
    }
    if let Some(moves) = &args.moves {
        return Ok(Source::Record(parse_move_list(moves, start_position(args)?)?));
    }
    let start = start_position(args)?;
    let opponent = opponent(args)?;
    // With --robot both every move comes from --engine; the robot's own engine is not asked.
    let robot: Box<dyn Opponent> = Box::new(builtin(args));
    Ok(Source::Engines { start, robot, opponent })
}

/// The person's game: a new one from --fen (or the initial position), or the one saved in
/// --out's game.pgn (`--resume`).
fn human_source(args: &PlayArgs, side: crate::cli::HumanSide) -> Result<Source> {
    let person = match side {
        crate::cli::HumanSide::White => Color::White,
        crate::cli::HumanSide::Black => Color::Black,
    };
    let pgn = if args.resume {
        if args.fen.is_some() {
            bail!("--fen starts a new game; --resume goes on with the one in game.pgn (its [FEN] tag gives its start)");
        }
        let path = args.out.join("game.pgn");
        // Saved over after every move: a game.pgn chessarm did not write is refused now, not
        // after the resumed moves have been replayed.
        crate::app::output::refuse_if_not_ours(&path, "--out").context("--resume")?;
        PgnGame::resume(&path, person)?
    } else {
        PgnGame { headers: Vec::new(), start: start_position(args)?, moves: Vec::new() }
    };
    let engine = opponent(args)?;
    let mut pgn = pgn;
    if !args.resume {
        let arm = format!("chessarm arm ({})", engine.name());
        let (white, black) = if person == Color::White { ("person", arm.as_str()) } else { (arm.as_str(), "person") };
        pgn.headers = vec![
            ("Event".into(), "chessarm: a person against the arm".into()),
            ("Site".into(), if args.port.is_some() { "the real arm".into() } else { "simulation".into() }),
            ("Date".into(), pgn_date(std::time::SystemTime::now())),
            ("Round".into(), "-".into()),
            ("White".into(), white.into()),
            ("Black".into(), black.into()),
        ];
    }
    let (lines, socket, live): (Box<dyn std::io::BufRead + Send>, _, _) = match args.live {
        Some(port) => {
            let (page, clicks) = crate::live::page::LivePage::serve(port)?;
            crate::tell(&format!("live page: {} (open it in a browser; your moves are clicked there)\n", page.url));
            (Box::new(clicks), None, Some(page))
        }
        None => {
            let (lines, socket) =
                crate::live::input::lines_from(args.input_socket.as_deref(), args.input_file.as_deref())?;
            (lines, socket, None)
        }
    };
    Ok(Source::Human(Box::new(HumanGame {
        turns: PersonGame::new(person, pgn),
        input: crate::live::input::Person::new(
            args.human_input.unwrap_or(crate::live::input::HumanInput::Typed),
            lines,
        ),
        engine,
        _socket: socket,
        live,
        timings: Vec::new(),
    })))
}

/// `time`'s date as PGN writes it (`2026.12.06`, UTC).
fn pgn_date(time: std::time::SystemTime) -> String {
    let days = time.duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs() / 86_400) as i64;
    // Days since 1970-01-01 to a civil date (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1_460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}.{month:02}.{day:02}")
}

/// Refuses the person's flags without a person: they would be ignored (and `--resume` would
/// keep an old game.pgn beside a new game.json).
fn refuse_person_flags_without_a_person(args: &PlayArgs) -> Result<()> {
    if args.human.is_some() {
        return Ok(());
    }
    let given = [
        ("--live", args.live.is_some()),
        ("--input-file", args.input_file.is_some()),
        ("--input-socket", args.input_socket.is_some()),
        ("--resume", args.resume),
        ("--human-input", args.human_input.is_some()),
    ];
    if let Some((flag, _)) = given.iter().find(|(_, given)| *given) {
        bail!("{flag} is for a person's game: give --human white or --human black with it");
    }
    Ok(())
}

pub fn run(setup: &Setup, args: &PlayArgs) -> Result<()> {
    refuse_person_flags_without_a_person(args)?;
    let setup = &args.motion.apply(setup)?;
    // With servos, their host replaces the torque controller: said before any other word.
    crate::servo_hosts(setup);
    let Prepared { settings, controller: settings_name, study, trial, ideal, notes, .. } =
        prepare(setup, &options(args))?;
    for note in notes {
        crate::tell(&note);
    }
    let mut source = source(args)?;
    // A person sits across from the arm: the board turned to face them, when it is served so.
    let seated;
    let setup = match &source {
        Source::Human(human) => {
            let (board, note) = crate::app::studies::person::seat(setup, human.turns.person);
            crate::tell(&note);
            seated = Setup { board, ..setup.clone() };
            &seated
        }
        _ => setup,
    };
    let start = match &source {
        Source::Record(record) => record.start.clone(),
        Source::Engines { start, .. } => start.clone(),
        Source::Human(human) => human.turns.pgn.start.clone(),
    };
    let total = match &source {
        Source::Record(record) => record.moves.len(),
        Source::Engines { .. } => args.plies,
        Source::Human(_) => LONGEST_GAME_PLIES,
    };
    // Each ply's recorded steps are kept for the plots: a bound before anything runs. An engine
    // game cannot last longer than the fifty-move rule allows (< 6000 plies).
    let (cause, plies) = match &source {
        Source::Record(_) => (
            match &args.game_file {
                Some(path) => format!("game {} of {}", args.game, path.display()),
                None => "--moves".to_owned(),
            },
            total as f64,
        ),
        Source::Engines { .. } => (format!("--plies {}", args.plies), args.plies.min(LONGEST_GAME_PLIES) as f64),
        // A person's game is bounded as an engine game is; its plies are kept as they come.
        Source::Human(_) => ("--human".to_owned(), 0.0),
    };
    crate::app::resources::ensure_fits(&cause, "plies", plies, BYTES_PER_PLY)?;
    ensure_dir(&args.out)?;
    let moves_dir = args.out.join("moves");
    let hardware_dir = args.out.join("hardware");
    // Results of an earlier game in the same folder must not pass for this one's; only files
    // an earlier chessarm run wrote (and listed) are removed.
    remove_stale(&[args.out.join("game.json")])?;
    if !args.resume {
        remove_stale(&[args.out.join("game.pgn"), args.out.join("bus.jsonl")])?;
    }
    remove_listed_in(&moves_dir)?;
    // Move CSVs are named NNN-<uci>.csv: any such file that is not chessarm's is refused now.
    let numbered_file = |name: &str, extensions: &[&str]| {
        extensions.iter().any(|e| name.ends_with(e))
            && name.len() > 4
            && name.as_bytes()[..3].iter().all(u8::is_ascii_digit)
    };
    refuse_unlisted(&moves_dir, |name| numbered_file(name, &[".csv"]))?;
    remove_listed_in(&hardware_dir)?;
    refuse_unlisted(&hardware_dir, |name| numbered_file(name, &[".csv", ".json"]))?;
    // An earlier game's stopped part-way trajectories do not belong to this one.
    remove_listed_in(&args.out.join("hardware-incomplete"))?;
    // The servos' bus, checked before anything runs: their goals go out in its ticks.
    let servo_bus =
        setup.actuators.take_positions().then(|| crate::app::setup::servos::ServoBus::of(setup)).transpose()?;
    let started = Instant::now();
    let first_number = (start.fullmoves().get(), start.turn());
    let mut game = Game::new(setup.arm, setup.board, start, settings)?;
    if game.pitch() != chessarm_core::arm::task::TOOL_DOWN {
        crate::tell(&format!(
            "tool: {} for every grip and release, the nearest straight down that serves this board ([motion] max_tilt)\n",
            chessarm_chess::clearance::columns::tilt_words(game.pitch())
        ));
    }
    let start_table = game.table().clone();
    let start_pose = Frame {
        t: 0.0,
        q: game.state().q.into(),
        qd: game.state().qd.into(),
        tip_desired: game.tool(),
        tip_error: 0.0,
    };
    // A person's game needs the terminal for the person: no progress bar.
    let bar = if matches!(source, Source::Human(_)) {
        indicatif::ProgressBar::hidden()
    } else {
        crate::progress::bar(total as u64, "playing")
    };
    let header = format!(
        "{:>4} {:>8} {:>6} {:<18} {:>8} {:>8} {:>12} {:>22} {:>9}  {}",
        "ply", "san", "by", "kind", "time s", "wait s", "max tip mm", "placement mm", "clear mm", "closest pair"
    );
    let mut kept = Kept {
        reports: Vec::new(),
        tip_errors: Vec::new(),
        replay: ReplayBuilder::new(first_number, start_pose),
        header,
        taken_back: Vec::new(),
    };
    // The real arm (or a dry run), opened before anything moves.
    let mut real_arm = (args.port.is_some() || args.dry_run)
        .then(|| {
            crate::app::bus::arm::RealArm::open(
                &crate::app::setup::servos::wiring(setup)?,
                crate::app::bus::arm::ArmOptions {
                    port: args.port.as_deref(),
                    dry_run: args.dry_run,
                    max_step: args.max_step_deg.to_radians(),
                    reply_timeout: Duration::from_millis(args.reply_timeout_ms),
                    log: Box::new(|| crate::app::output::create_log(&args.out.join("bus.jsonl"), args.resume)),
                },
            )
        })
        .transpose()?;
    let outputs = Outputs {
        setup,
        start_table: &start_table,
        controller: &settings_name,
        moves_dir: &moves_dir,
        hardware_dir: &hardware_dir,
        servo_bus: servo_bus.as_ref(),
        args,
    };
    let mut played = || -> Result<()> {
        if let Source::Human(human) = &mut source {
            return play_human(human, &mut game, &mut kept, &outputs, &bar, real_arm.as_mut());
        }
        for ply in 0..total {
            if crate::cancelled() {
                return Err(crate::interrupted());
            }
            // A given game is replayed whole; an engine game stops at its result.
            if matches!(source, Source::Engines { .. }) && game.outcome().is_some() {
                break;
            }
            let turn = game.position().turn();
            let mv = match &mut source {
                Source::Record(record) => record.moves[ply],
                Source::Engines { robot, opponent, .. } => {
                    let player = if args.robot.moves(turn) && args.robot != RobotSide::Both { robot } else { opponent };
                    player.choose_move(game.position()).with_context(|| format!("ply {}", ply + 1))?
                }
                Source::Human(_) => unreachable!("played above"),
            };
            let mover = if args.robot.moves(turn) { Mover::Robot } else { Mover::Opponent };
            let report = game.play(&mv, mover)?;
            if let Some(arm) = real_arm.as_mut() {
                send_to_arm(arm, &report)?;
            }
            kept.keep(report, &outputs, &bar)?;
        }
        Ok(())
    };
    let outcome = played();
    let Kept { reports, tip_errors, replay, taken_back, .. } = kept;
    if let Err(error) = outcome {
        bar.finish_and_clear();
        // A game that stops part-way for any reason leaves nothing that passes for a whole
        // game: game.json says where and why, and the hardware trajectories so far move to
        // hardware-incomplete/ (a driver reading hardware/ finds none).
        let record = json!({
            "complete": false,
            "failed_at_ply": reports.len() + 1,
            "plies_played": reports.len(),
            "error": crate::app::text::one_line(&error),
        });
        write_json(&args.out.join("game.json"), &record)?;
        if hardware_dir.is_dir() {
            let incomplete = args.out.join("hardware-incomplete");
            if incomplete.is_dir() {
                // An earlier stopped game's: its files, then chessarm's own list and lock.
                remove_listed_in(&incomplete)?;
                for own in [crate::app::output::WRITTEN_LIST, crate::app::output::folder_lock::LOCK_FILE] {
                    crate::app::output::remove_file_if_there(&incomplete.join(own))?;
                }
                std::fs::remove_dir(&incomplete).with_context(|| {
                    format!("cannot replace {}: it holds files chessarm did not write", incomplete.display())
                })?;
            }
            std::fs::rename(&hardware_dir, &incomplete)
                .with_context(|| format!("cannot move {} aside", hardware_dir.display()))?;
        }
        return Err(error.context(format!(
            "the game stopped at ply {} ({} played; {} says so)",
            reports.len() + 1,
            reports.len(),
            args.out.join("game.json").display()
        )));
    }
    bar.finish_and_clear();
    let wall_time_s = started.elapsed().as_secs_f64();
    let plot = args.out.join("tip_error.png");
    let placement_plot = args.out.join("placement.png");
    plot_game(&plot, &placement_plot, tip_errors, &reports, args.tolerance_mm)?;
    let dependence = machine_dependence(args);
    if !dependence.is_empty() {
        crate::tell(&format!("note: this game may differ on another machine: {}\n", dependence.join("; ")));
    }
    let result = result_of(&game, &source, args.plies, reports.len());
    let mut summary = game_json(&game, &reports, wall_time_s, &dependence, &result);
    summary["complete"] = json!(true);
    if let Source::Human(human) = &source {
        human.turns.pgn.save(&args.out.join("game.pgn"), &result.result)?;
        summary["human"] = human_json(human, args, &taken_back);
    }
    if let Some(arm) = &real_arm {
        summary["real_arm"] = real_arm_json(arm);
    }
    summary["controller"] = json!(settings_name);
    summary["conditions"] = if ideal { Value::Null } else { study.describe() };
    summary["dt_s"] = json!(args.dt);
    // Friction the plant has and the controller does not compensate, said in game.json too.
    summary["unmodelled_friction"] = json!(study.unmodelled_friction());
    summary["trial"] = if ideal { Value::Null } else { trial.describe() };
    let all_waits = chessarm_chess::play::WaitTotals::of(reports.iter().flat_map(|r| &r.waits));
    let game_json_path = args.out.join("game.json");
    write_json(&game_json_path, &summary)?;
    let replay_path = args.out.join("replay.html");
    let replay = Replay {
        title: format!("chessarm play: {} plies, {} controller", reports.len(), settings_name),
        arm: &setup.arm,
        board: &setup.board,
        pieces: &setup.pieces,
        table: &start_table,
        tolerance: args.tolerance_mm / 1e3,
        note: format!(
            "result {} ({}); robot time {:.1} s; {}; {} misplaced",
            result.result,
            result.reason,
            game.robot_time(),
            waits_text(game.in_position().is_some(), &all_waits),
            game.misplaced().len()
        ),
        runs: vec![replay.finish(&settings_name)],
    };
    write_replay(&replay_path, &replay)?;
    let mut human = String::new();
    if let Some(line) = clearance_text(&reports) {
        crate::tell_or_keep(&line, &mut human);
    }
    crate::tell_or_keep(
        &format!(
            "result {} ({}); {} plies, robot time {:.1} s ({}), wall time {:.2} s; physical board {} the rules' board; {} misplaced\n",
            result.result,
            result.reason,
            reports.len(),
            game.robot_time(),
            waits_text(game.in_position().is_some(), &all_waits),
            wall_time_s,
            if game.fen_physical() == game.fen_rules() { "equals" } else { "DIFFERS FROM" },
            game.misplaced().len()
        ),
        &mut human,
    );
    human.push_str(&format!("final position (FEN): {}\n", game.fen_physical()));
    human.push_str(&format!("Watch it: {} (open in a browser)\n", replay_path.display()));
    let mut written = vec![game_json_path, replay_path, plot, placement_plot];
    if matches!(source, Source::Human(_)) {
        written.push(args.out.join("game.pgn"));
    }
    // The folders only when there is something in them (a person's game may have no arm's move).
    if moves_dir.is_dir() {
        written.push(moves_dir);
    }
    if hardware_dir.is_dir() {
        written.push(hardware_dir);
    }
    let files: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
    human.push_str(&crate::files_text(&files));
    crate::emit(
        &human,
        &json!({
            "result": result.result,
            "result_reason": result.reason,
            "plies": reports.len(),
            "final_fen_rules": game.fen_rules(),
            "final_fen_physical": game.fen_physical(),
            "misplaced": game.misplaced().len(),
            "files": files,
        }),
    )?;
    Ok(())
}

/// Where a game's per-move files go.
struct Outputs<'a> {
    setup: &'a Setup,
    /// The table at the start and the controller's name (for the live page's replay).
    start_table: &'a chessarm_chess::table::Table,
    controller: &'a str,
    moves_dir: &'a Path,
    hardware_dir: &'a Path,
    servo_bus: Option<&'a crate::app::setup::servos::ServoBus>,
    args: &'a PlayArgs,
}

/// What a game keeps of its moves until its end: their reports (without their recorded
/// steps), the tip errors for the plot, the replay's frames.
struct Kept {
    reports: Vec<MoveReport>,
    /// The tip error of every recorded step (robot time s, mm), for the game's plot.
    tip_errors: Vec<(f64, f64)>,
    replay: ReplayBuilder,
    header: String,
    /// The moves a person took back (ply, SAN, by whom), for game.json.
    taken_back: Vec<Value>,
}

impl Kept {
    /// A played move: its line in the table, its CSV and hardware files, its share of the
    /// plots and the replay.
    fn keep(&mut self, mut report: MoveReport, out: &Outputs<'_>, bar: &indicatif::ProgressBar) -> Result<()> {
        let setup = out.setup;
        if self.reports.is_empty() {
            say(bar, self.header.clone());
        }
        say(bar, move_line(&report));
        if report.mover == Mover::Robot {
            write_move_csv(out.moves_dir, &report, &setup.convention)?;
        }
        if let Some(hardware) = report.hardware.take() {
            ensure_dir(out.hardware_dir)?;
            let label = MoveLabel {
                ply: report.ply,
                san: &report.san,
                uci: &report.uci,
                grips: hardware.grips.clone(),
                fine_points: hardware.fine_points.clone(),
                in_position: hardware.in_position,
                finger_opening: report.opening,
                widths: hardware.widths.clone(),
            };
            crate::app::formats::hardware::write_move(
                out.hardware_dir,
                &format!("{:03}-{}", report.ply, report.uci),
                (&setup.base_link, &setup.joint_names, &setup.convention),
                &hardware.points,
                &hardware.commands,
                &label,
                out.args.export_rate,
            )?;
            if let Some(bus) = out.servo_bus {
                if !out.hardware_dir.join("servo_bus.json").is_file() {
                    crate::app::formats::hardware::write_servo_bus(out.hardware_dir, setup, bus)?;
                }
                crate::app::formats::hardware::write_servo_goals(
                    out.hardware_dir,
                    &format!("{:03}-{}", report.ply, report.uci),
                    &setup.convention,
                    bus,
                    &hardware.servo_goals,
                )?;
            }
        }
        bar.inc(1);
        // The recorded steps are in the move's CSV now: only the plot's and the replay's share
        // of them stays (16 of a step's 300-odd bytes, and the replay's frames), so that
        // memory does not grow with the records of every move.
        self.tip_errors
            .extend(report.records.iter().map(|r| (report.start_time + r.t, (r.tip - r.tip_desired).norm() * 1e3)));
        self.replay.add(&report);
        report.records = Vec::new();
        self.reports.push(report);
        Ok(())
    }
}

impl Kept {
    /// The person took back every move after the first `keep`: their reports and their files
    /// (the move CSVs, the hardware trajectories) go, so that the folder, game.json and
    /// game.pgn hold one game; the replay keeps them, as what the arm did before the take-back.
    fn take_back(&mut self, keep: usize, out: &Outputs<'_>) -> Result<()> {
        for report in self.reports.drain(keep.min(self.reports.len())..) {
            let stem = format!("{:03}-{}", report.ply, report.uci);
            crate::app::output::remove_file_if_there(&out.moves_dir.join(format!("{stem}.csv")))?;
            for suffix in [".csv", ".json", "-goals.csv"] {
                crate::app::output::remove_file_if_there(&out.hardware_dir.join(format!("{stem}{suffix}")))?;
            }
            self.taken_back.push(json!({"ply": report.ply, "san": report.san, "by": if report.mover == Mover::Robot { "robot" } else { "hand" }}));
        }
        Ok(())
    }
}

/// Sends a robot move to the real arm, only if the simulation proved it: no piece misplaced
/// and no contact in the simulated motion (else nothing is sent and the game stops, saved).
fn send_to_arm(arm: &mut crate::app::bus::arm::RealArm, report: &MoveReport) -> Result<()> {
    let Some(hardware) = report.hardware.as_ref() else { return Ok(()) };
    if let Some(misplaced) = report.new_misplaced.first() {
        bail!(
            "ply {} {}: not sent to the real arm: the simulated move misplaced a piece ({misplaced}); nothing was sent",
            report.ply,
            report.san
        );
    }
    if report.executed_clearance.as_ref().is_some_and(|e| e.is_contact()) {
        bail!(
            "ply {} {}: not sent to the real arm: the simulated arm touched (game.json's clearance says where); nothing was sent",
            report.ply,
            report.san
        );
    }
    arm.execute(&hardware.servo_goals, report.start_time, &report.handled, &crate::cancelled)
        .with_context(|| format!("ply {} {}: the real arm", report.ply, report.san))?;
    Ok(())
}

/// A person plays the arm: the person's moves from their input (played by hand), the arm's
/// from the engine (planned, checked, simulated, then sent to the real arm if there is one),
/// game.pgn saved after every ply, until the rules end the game, the person resigns, a draw is
/// agreed or the input ends.
fn play_human(
    human: &mut HumanGame,
    game: &mut Game,
    kept: &mut Kept,
    out: &Outputs<'_>,
    bar: &indicatif::ProgressBar,
    mut real_arm: Option<&mut crate::app::bus::arm::RealArm>,
) -> Result<()> {
    let pgn_path = out.args.out.join("game.pgn");
    // The resumed moves: the board shows them, so they are played by hand.
    for k in 0..human.turns.resumed {
        let report = human.turns.play_resumed(game, k)?;
        kept.keep(report, out, bar)?;
    }
    if human.turns.resumed > 0 {
        crate::tell(&format!("resumed {} after {} plies\n", pgn_path.display(), human.turns.resumed));
    }
    // When the person's last move was read (for the arm's latency).
    let mut person_moved = Instant::now();
    human.turns.pgn.save(&pgn_path, "*")?;
    publish(human, game, kept, out, "")?;
    loop {
        if crate::cancelled() {
            return Err(crate::interrupted());
        }
        if game.outcome().is_some() {
            return Ok(());
        }
        let position = game.position().clone();
        if position.turn() == human.turns.person {
            crate::tell(&format!("your move ({}):\n", side_name(human.turns.person)));
            match human.input.next(&position)? {
                crate::live::input::Action::Move(m) => {
                    person_moved = Instant::now();
                    let report = human.turns.person_moves(game, m)?;
                    kept.keep(report, out, bar)?;
                }
                crate::live::input::Action::Undo => {
                    let Some(taken) = human.turns.take_back(game)? else {
                        crate::tell("nothing to take back: you have not moved yet\n");
                        continue;
                    };
                    let put: Vec<String> = taken.handled.iter().map(|h| format!("{} to {}", h.from, h.to)).collect();
                    crate::tell(&format!("taken back {} plies: put back {}\n", taken.plies, put.join(", ")));
                    kept.replay.take_back(&taken.handled, taken.plies);
                    kept.take_back(taken.kept, out)?;
                    // The arm's taken-back replies leave its timings too.
                    human.timings.retain(|t| t.ply <= taken.kept);
                }
                crate::live::input::Action::Resign => {
                    human.turns.resign();
                    return Ok(());
                }
                crate::live::input::Action::Draw => match human.turns.offer_draw(&position) {
                    Ok(()) => return Ok(()),
                    Err(lead) => {
                        crate::tell(&format!("the arm declines the draw: it is ahead by {lead} in material\n"));
                    }
                },
                crate::live::input::Action::Quit => {
                    human.turns.stop(&out.args.out);
                    return Ok(());
                }
            }
        } else {
            let (report, thinking) = human.turns.arm_moves(game, human.engine.as_mut())?;
            // The arm starts now: the move is planned, checked and simulated.
            let latency = person_moved.elapsed().as_secs_f64() - thinking;
            if let Some(arm) = real_arm.as_deref_mut() {
                send_to_arm(arm, &report)?;
            }
            human.timings.push(RobotTiming { ply: report.ply, thinking, latency });
            kept.keep(report, out, bar)?;
        }
        human.turns.pgn.save(&pgn_path, "*")?;
        publish(human, game, kept, out, "")?;
    }
}

/// The live page's view of the game now (if it is served): the board, the moves, whose turn,
/// the legal moves, the built-in engine's evaluation, and the replay of the game so far.
fn publish(human: &HumanGame, game: &Game, kept: &Kept, out: &Outputs<'_>, status: &str) -> Result<()> {
    use chessarm_chess::shakmaty::{CastlingMode, EnPassantMode, fen::Fen};
    let Some(page) = &human.live else { return Ok(()) };
    let position = game.position();
    let over = game.outcome().is_some() || human.turns.ended.is_some();
    let your_turn = !over && position.turn() == human.turns.person;
    let evaluation = if game.outcome().is_some() {
        None
    } else {
        let score =
            BuiltinEngine::new(2, None).search(position).ok().map(|s| f64::from(s.score.clamp(-9_900, 9_900)) / 100.0);
        score.map(|s| if position.turn() == Color::White { s } else { -s })
    };
    let mut list = String::new();
    let mut replayed = human.turns.pgn.start.clone();
    for (k, (m, _)) in human.turns.pgn.moves.iter().enumerate() {
        if replayed.turn() == Color::White || k == 0 {
            let dots = if replayed.turn() == Color::White { "." } else { "..." };
            list.push_str(&format!("{}{dots} ", replayed.fullmoves()));
        }
        let san = chessarm_chess::shakmaty::san::SanPlus::from_move_and_play_unchecked(&mut replayed, *m);
        list.push_str(&format!("{san} "));
        if replayed.turn() == Color::White {
            list.push('\n');
        }
    }
    let status = if !status.is_empty() {
        status.to_string()
    } else if let Some((result, reason)) = &human.turns.ended {
        format!("{result}: {reason}")
    } else if let Some(outcome) = game.outcome() {
        format!("{}: {}", outcome.result, outcome.reason)
    } else if your_turn {
        "your move: click a piece, then its square".to_string()
    } else {
        "the arm is moving".to_string()
    };
    let state = json!({
        "fen": Fen::from_position(position, EnPassantMode::Legal).to_string(),
        "person": if human.turns.person == Color::White { "white" } else { "black" },
        "your_turn": your_turn,
        "legal": if your_turn { position.legal_moves().iter().map(|m| m.to_uci(CastlingMode::Standard).to_string()).collect::<Vec<_>>() } else { Vec::new() },
        "last_uci": human.turns.pgn.moves.last().map(|(m, _)| m.to_uci(CastlingMode::Standard).to_string()),
        "last_robot_ply": kept.reports.iter().rev().find(|r| r.mover == Mover::Robot).map(|r| r.ply),
        "plies": human.turns.pgn.moves.len(),
        "move_list": list.trim_end(),
        "evaluation": evaluation,
        "status": status,
        "over": over,
        "replay_version": kept.reports.len(),
    });
    let replay = Replay {
        title: format!("chessarm: a person against the arm, {} plies", human.turns.pgn.moves.len()),
        arm: &out.setup.arm,
        board: &out.setup.board,
        pieces: &out.setup.pieces,
        table: out.start_table,
        tolerance: out.args.tolerance_mm / 1e3,
        note: String::new(),
        runs: vec![kept.replay.clone().finish(out.controller)],
    };
    let mut html = Vec::new();
    crate::app::formats::replay::write_replay_html(&mut html, &replay)?;
    page.show(state, html);
    Ok(())
}

/// The person's game in game.json: sides, input, what was refused, and per robot move the
/// engine's thinking and the latency from the person's move to the arm starting (s).
fn human_json(human: &HumanGame, args: &PlayArgs, taken_back: &[Value]) -> Value {
    let latencies: Vec<f64> = human.timings.iter().map(|t| t.latency).collect();
    json!({
        "person": if human.turns.person == Color::White { "white" } else { "black" },
        "input": match args.human_input.unwrap_or(crate::live::input::HumanInput::Typed) {
            crate::live::input::HumanInput::Typed => "typed",
            crate::live::input::HumanInput::Occupancy => "occupancy",
        },
        "engine": human.engine.name(),
        "resumed_plies": human.turns.resumed,
        // The first refused lines (bounded), and how many there were in all.
        "refused_input": human.input.refused.kept,
        "refused_lines": human.input.refused.lines,
        "refused_bytes": human.input.refused.bytes,
        "taken_back": taken_back,
        "robot_moves": human.timings.iter().map(|t| json!({
            "ply": t.ply,
            "thinking_s": t.thinking,
            "latency_s": t.latency,
        })).collect::<Vec<_>>(),
        "largest_latency_s": latencies.iter().copied().reduce(f64::max),
    })
}

/// The real arm's record in game.json: packets sent and, over the moves, the largest lead of
/// a goal over the present position and change between goals (ticks), and how far a move's
/// stream slid behind its clock when the machine was late (s).
fn real_arm_json(arm: &crate::app::bus::arm::RealArm) -> Value {
    let lead: [i64; 4] = std::array::from_fn(|j| arm.followed.iter().map(|f| f.largest_lead[j]).max().unwrap_or(0));
    let change: [i64; 4] = std::array::from_fn(|j| arm.followed.iter().map(|f| f.largest_change[j]).max().unwrap_or(0));
    json!({
        "dry_run": arm.is_dry_run(),
        "moves": arm.followed.len(),
        "periods": arm.followed.iter().map(|f| f.periods).sum::<usize>(),
        "packets_sent": arm.packets_sent(),
        "ramp_periods": arm.ramp_periods(),
        "largest_lead_ticks": lead,
        "largest_change_ticks": change,
        "largest_slide_s": arm.followed.iter().map(|f| f.slid).fold(0.0, f64::max),
    })
}

/// A line above the progress bar, or plainly on stderr when there is no terminal to draw on.
fn say(bar: &indicatif::ProgressBar, line: String) {
    if bar.is_hidden() { crate::tell(&format!("{line}\n")) } else { bar.println(line) }
}

fn move_line(report: &MoveReport) -> String {
    let by = if report.mover == Mover::Robot { "robot" } else { "hand" };
    let tip = report.max_tip_error.map_or("-".to_string(), |e| format!("{:.4}", e * 1e3));
    let place = report.place_errors.iter().map(|e| format!("{:.3}", e * 1e3)).collect::<Vec<_>>().join(" ");
    let waits = report.wait_totals();
    let wait = if report.mover == Mover::Robot { format!("{:.2}", waits.total) } else { "-".to_string() };
    let (clear, pair) = match &report.clearance {
        Some(c) => (format!("{:.1}", c.distance * 1e3), format!("{} – {}", c.part, c.obstacle_name)),
        None => ("-".to_string(), String::new()),
    };
    let mut line = format!(
        "{:>4} {:>8} {:>6} {:<18} {:>8.2} {:>8} {:>12} {:>22} {:>9}  {}",
        report.ply,
        report.san,
        by,
        report.kind.name(),
        report.duration,
        wait,
        tip,
        place,
        clear,
        pair
    );
    for adjustment in &report.adjustments {
        line.push_str(&format!("\n     CLEARANCE: {adjustment}"));
    }
    if report.executed_clearance.as_ref().is_some_and(|e| e.is_contact()) {
        line.push_str("\n     CONTACT: the simulated arm touched (see game.json's clearance)");
    }
    if waits.timed_out > 0 {
        line.push_str(&format!(
            "\n     NOT IN POSITION: {} gripper command(s) went ahead after the timeout",
            waits.timed_out
        ));
    }
    for misplaced in &report.new_misplaced {
        line.push_str(&format!("\n     MISPLACED: {misplaced}"));
    }
    line
}

/// The game's result: a person's game as it ended (a resignation, a draw agreed), else as
/// the rules or the record say ([`game_result`]); an engine game stops after `limit` plies.
fn result_of(game: &Game, source: &Source, limit: usize, plies: usize) -> GameResult {
    match source {
        Source::Human(human) => match &human.turns.ended {
            Some((result, reason)) => GameResult { result: result.clone(), reason: reason.clone() },
            None => game_result(game, Played::Person, plies),
        },
        Source::Record(record) => game_result(game, Played::Record(record), plies),
        Source::Engines { .. } => game_result(game, Played::Engines { plies: limit }, plies),
    }
}

/// The options of the game the flags describe (SI: the flags' mm converted here).
fn options(args: &PlayArgs) -> PlayOptions {
    PlayOptions {
        controller: args.controller.into(),
        gains: args.gains.given(),
        conditions: args.conditions.options(),
        placement: args.placement.options(),
        tolerance: args.tolerance_mm / 1e3,
        dt: args.dt,
        integrator: args.integrator.integrator(),
        export_rate: args.export_rate,
        controller_knows_payload: args.controller_knows_payload,
        keep_pace: args.keep_pace,
    }
}

/// The fine points' waits in words: "12 in-position waits, 1.30 s, longest 0.25 s, 0 timed out".
fn waits_text(fine_points: bool, totals: &chessarm_chess::play::WaitTotals) -> String {
    if !fine_points {
        return "gripper by the clock".to_string();
    }
    format!(
        "{} in-position waits, {:.2} s, longest {:.2} s, {} timed out",
        totals.count, totals.total, totals.longest, totals.timed_out
    )
}

/// The move's closest pair for the replay: the simulated motion's where it was measured, else
/// the plan's, at the run's time.
fn replay_closest(report: &chessarm_chess::play::MoveReport) -> Option<crate::app::formats::replay::ReplayClosest> {
    use chessarm_chess::play::Executed;
    let (clearance, simulated) = match (&report.executed_clearance, &report.clearance) {
        (Some(Executed::Measured(m)), _) => (m, true),
        (_, Some(planned)) => (planned, false),
        _ => return None,
    };
    Some(crate::app::formats::replay::ReplayClosest {
        t: report.start_time + clearance.time,
        distance: clearance.distance,
        part: clearance.part.to_string(),
        obstacle: clearance.obstacle_name.clone(),
        points: clearance.points?,
        contact: clearance.is_contact(),
        simulated,
    })
}

/// A move's closest approach as JSON (mm, s from the move's start): the plan's nearest pair
/// (the arm's part and the obstacle), the fingers' smallest gap to the piece they open around,
/// and the simulated motion's clearance, a lower bound or measured.
fn clearance_json(
    planned: &chessarm_chess::clearance::moves::MoveClearance,
    executed: Option<&chessarm_chess::play::Executed>,
) -> Value {
    use chessarm_chess::play::Executed;
    let (kind, piece) = match planned.obstacle {
        chessarm_chess::clearance::Obstacle::Piece(_) => ("piece", planned.piece),
        chessarm_chess::clearance::Obstacle::Table => ("table", None),
        chessarm_chess::clearance::Obstacle::Arm(_) => ("arm", None),
    };
    json!({
        "smallest_mm": planned.distance * 1e3,
        "time_s": planned.time,
        "part": planned.part.to_string(),
        "obstacle": planned.obstacle_name,
        "obstacle_kind": kind,
        "piece_index": piece,
        "fingers_to_gripped_piece_mm": planned.gripped.map(|g| g * 1e3),
        "checks": planned.checks,
        "resolution_mm": planned.resolution * 1e3,
        "executed": executed.map(|e| match e {
            Executed::AtLeast(d) => json!({"at_least_mm": d * 1e3, "contact": false}),
            Executed::Measured(m) => json!({
                "smallest_mm": m.distance * 1e3,
                "time_s": m.time,
                "part": m.part.to_string(),
                "obstacle": m.obstacle_name,
                "fingers_to_gripped_piece_mm": m.gripped.map(|g| g * 1e3),
                "resolution_mm": m.resolution * 1e3,
                "contact": m.is_contact(),
            }),
        }),
    })
}

/// The robot moves' smallest clearances (m) by move kind, in the order of their first move.
fn clearances_by_kind(reports: &[MoveReport]) -> Vec<(&'static str, Vec<f64>)> {
    let mut kinds: Vec<(&'static str, Vec<f64>)> = Vec::new();
    for r in reports {
        if let Some(c) = &r.clearance {
            match kinds.iter_mut().find(|(k, _)| *k == r.kind.name()) {
                Some((_, all)) => all.push(c.distance),
                None => kinds.push((r.kind.name(), vec![c.distance])),
            }
        }
    }
    for (_, all) in &mut kinds {
        all.sort_by(f64::total_cmp);
    }
    kinds
}

/// The game's clearances as JSON (mm): the smallest and where, the simulated contacts, and per
/// move kind the smallest, median and largest of its moves' smallest clearances.
fn clearance_summary(reports: &[MoveReport]) -> Option<Value> {
    let nearest = reports
        .iter()
        .filter_map(|r| r.clearance.as_ref().map(|c| (r, c)))
        .min_by(|a, b| a.1.distance.total_cmp(&b.1.distance))?;
    let contacts = reports.iter().filter(|r| r.executed_clearance.as_ref().is_some_and(|e| e.is_contact())).count();
    let by_kind: serde_json::Map<String, Value> = clearances_by_kind(reports)
        .into_iter()
        .map(|(kind, all)| {
            (
                kind.to_string(),
                json!({
                    "moves": all.len(),
                    "smallest_mm": all[0] * 1e3,
                    "median_mm": all[all.len() / 2] * 1e3,
                    "largest_mm": all[all.len() - 1] * 1e3,
                }),
            )
        })
        .collect();
    Some(json!({
        "smallest_mm": nearest.1.distance * 1e3,
        "ply": nearest.0.ply,
        "san": nearest.0.san,
        "part": nearest.1.part.to_string(),
        "obstacle": nearest.1.obstacle_name,
        "contacts": contacts,
        "adjusted_moves": reports.iter().filter(|r| !r.adjustments.is_empty()).count(),
        // Moves run again slower because the simulated motion came nearer than the margin.
        "slowed_moves": reports.iter().filter(|r| r.mover == Mover::Robot && r.pace < 1.0).count(),
        "slowest_pace": reports.iter().filter(|r| r.mover == Mover::Robot).map(|r| r.pace).fold(1.0, f64::min),
        "by_kind": by_kind,
    }))
}

/// The game's clearances for people: the smallest and where, the contacts, the moves changed.
fn clearance_text(reports: &[MoveReport]) -> Option<String> {
    let summary = clearance_summary(reports)?;
    Some(format!(
        "smallest clearance {:.1} mm (ply {} {}: {} – {}); {} contact(s) in the simulated motion; {} move(s) changed to keep clear{}\n",
        summary["smallest_mm"].as_f64().unwrap_or(f64::NAN),
        summary["ply"],
        summary["san"].as_str().unwrap_or(""),
        summary["part"].as_str().unwrap_or(""),
        summary["obstacle"].as_str().unwrap_or(""),
        summary["contacts"],
        summary["adjusted_moves"],
        match summary["slowed_moves"].as_u64() {
            Some(0) | None => String::new(),
            Some(n) => format!(
                ", {n} slowed (down to {:.2} of the pace) where the simulated motion came nearer than the margin",
                summary["slowest_pace"].as_f64().unwrap_or(1.0)
            ),
        },
    ))
}

/// A wait total as JSON (s).
fn totals_json(totals: &chessarm_chess::play::WaitTotals) -> Value {
    json!({
        "count": totals.count,
        "total_s": totals.total,
        "longest_s": totals.longest,
        "timed_out": totals.timed_out,
    })
}

/// A move's fine-point waits: their totals and, per gripper command in order, when the plan
/// reached it (s from the move's start), how long it waited (s), whether it timed out, and the
/// estimated tip error (mm) and speed (mm/s) when it went ahead.
fn waits_json(waits: &[chessarm_core::plan::fine_point::Wait]) -> Value {
    let mut value = totals_json(&chessarm_chess::play::WaitTotals::of(waits));
    value["commands"] = waits
        .iter()
        .map(|w| {
            json!({
                "command": if w.event % 2 == 0 { "close" } else { "open" },
                "reached_s": w.reached,
                "wait_s": w.duration,
                "timed_out": w.timed_out,
                "estimated_tip_error_mm": w.check.tip_error * 1e3,
                "estimated_tip_speed_mm_per_s": w.check.tip_speed * 1e3,
            })
        })
        .collect();
    value
}

/// The robot time of the arm's moves (their simulated durations), s per move; `None` without.
fn robot_time_per_move(reports: &[MoveReport]) -> Option<f64> {
    let robot: Vec<f64> = reports.iter().filter(|r| r.mover == Mover::Robot).map(|r| r.duration).collect();
    (!robot.is_empty()).then(|| robot.iter().sum::<f64>() / robot.len() as f64)
}

fn game_json(
    game: &Game,
    reports: &[MoveReport],
    wall_time_s: f64,
    machine_dependence: &[String],
    result: &GameResult,
) -> Value {
    let moves: Vec<Value> = reports
        .iter()
        .map(|r| {
            json!({
                "ply": r.ply,
                "san": r.san,
                "uci": r.uci,
                "kind": r.kind.name(),
                "by": if r.mover == Mover::Robot { "robot" } else { "hand" },
                "tasks": r.tasks,
                "duration_s": r.duration,
                "planned_duration_s": r.planned_duration,
                "phases_s": (r.mover == Mover::Robot).then(|| json!({
                    "travel": r.phases.travel,
                    "vertical": r.phases.vertical,
                    "grip": r.phases.grip,
                    "pause": r.phases.pause,
                })),
                "longest_limit": r.longest_limit.as_ref().map(|(name, time)| json!({"limit": name, "time_s": time})),
                "lspb_slowdowns": r.slowdowns,
                "saturated_samples": r.summary.as_ref().map(|s| s.saturated_samples),
                "lost_steps": r.summary.as_ref().map(|s| s.lost_steps),
                "peak_torque_nm": r.summary.as_ref().map(|s| s.peak_torque.as_slice().to_vec()),
                "max_tip_error_mm": r.max_tip_error.map(|e| e * 1e3),
                "place_errors_mm": r.place_errors.iter().map(|e| e * 1e3).collect::<Vec<_>>(),
                "in_position_waits": (r.mover == Mover::Robot).then(|| waits_json(&r.waits)),
                "clearance": r.clearance.as_ref().map(|c| clearance_json(c, r.executed_clearance.as_ref())),
                "clearance_adjustments": r.adjustments,
                "finger_opening_mm": r.opening.map(|o| o * 1e3),
                // The pace it ran at (a fraction of the limits'), and the simulated clearance of
                // each try that came nearer than the margin before it (mm, 0: a contact).
                "pace": (r.mover == Mover::Robot).then_some(r.pace),
                "too_near_tries_mm": r.too_near_at.iter().map(|d| d * 1e3).collect::<Vec<_>>(),
            })
        })
        .collect();
    let all_waits = chessarm_chess::play::WaitTotals::of(reports.iter().flat_map(|r| &r.waits));
    let misplaced: Vec<Value> = game
        .misplaced()
        .iter()
        .map(|(ply, san, m)| {
            json!({
                "ply": ply, "san": san, "square": m.square.map(|s| s.to_string()),
                "offset_mm": m.offset_m * 1e3, "reason": m.reason,
            })
        })
        .collect();
    json!({
        "result": result.result,
        "result_reason": result.reason,
        "moves": moves,
        "final_fen_rules": game.fen_rules(),
        "final_fen_physical": game.fen_physical(),
        "misplaced": misplaced,
        "clearance": clearance_summary(reports),
        // Every piece on the table at the end, in the order of the start's table (the replay's
        // piece ids): where it is meant to stand and where it stands (m).
        "final_table": game.table().pieces().iter().map(|p| json!({
            "piece": chessarm_chess::pieces::piece_name(p.piece),
            "location": p.location.to_string(),
            "x_m": p.position.x,
            "y_m": p.position.y,
        })).collect::<Vec<_>>(),
        "total_robot_time_s": game.robot_time(),
        "robot_time_per_robot_move_s": robot_time_per_move(reports),
        // The tool's pitch for every grip, carry and release, and the board it was played on
        // (turned to face a person, where one plays).
        "tool_pitch_rad": game.pitch(),
        "board": json!({
            "square_size_m": game.board().square_size,
            "center_m": [game.board().center.x, game.board().center.y],
            "yaw_rad": game.board().yaw,
            "squares_turned": game.board().squares_turned,
        }),
        "in_position": game.in_position().map(|gate| json!({
            "tip_band_mm": gate.tip_band * 1e3,
            "speed_band_mm_per_s": gate.speed_band * 1e3,
            "timeout_s": gate.timeout,
            "waits": totals_json(&all_waits),
        })),
        "wall_time_s": wall_time_s,
        // Whether the same command plays the same moves on any machine, and if not why.
        "deterministic": machine_dependence.is_empty(),
        "machine_dependent_because": machine_dependence,
    })
}

/// The game as the replay shows it, built move by move: the arm at rest at its home pose at
/// t = 0, then every robot move's recorded steps at the display rate and its simulated end
/// state at its end, every piece moved, every move on the timeline.
#[derive(Clone)]
struct ReplayBuilder {
    frames: Vec<Frame>,
    moves: Vec<ReplayMove>,
    handled: Vec<chessarm_chess::play::Handling>,
    /// The fine points' waits that took time, `[start, end]` in the game's robot time (s).
    waits: Vec<[f64; 2]>,
    /// The next move's number and side to move.
    number: u32,
    turn: Color,
}

impl ReplayBuilder {
    /// `first` is the start position's move number and side to move.
    fn new((number, turn): (u32, Color), start: Frame) -> Self {
        Self { frames: vec![start], moves: Vec::new(), handled: Vec::new(), waits: Vec::new(), number, turn }
    }

    fn add(&mut self, report: &MoveReport) {
        let end = report.summary.as_ref().zip(report.records.last()).map(|(summary, last)| Frame {
            t: report.start_time + summary.duration,
            q: summary.final_state.q.into(),
            qd: summary.final_state.qd.into(),
            ..Frame::of(report.start_time + summary.duration, last)
        });
        thin(report.records.iter().map(|r| Frame::of(report.start_time + r.t, r)).chain(end), &mut self.frames);
        self.moves.push(ReplayMove {
            ply: report.ply,
            number: format!("{}{}", self.number, if self.turn == Color::White { "." } else { "..." }),
            san: report.san.clone(),
            uci: report.uci.clone(),
            by: if report.mover == Mover::Robot { "robot" } else { "hand" },
            start: report.start_time,
            end: report.start_time + report.duration,
            closest: replay_closest(report),
        });
        if self.turn == Color::Black {
            self.number += 1;
        }
        self.turn = !self.turn;
        self.handled.extend(report.handled.iter().copied());
        let start = report.start_time;
        self.waits.extend(
            report
                .waits
                .iter()
                .filter(|w| w.duration > 0.0)
                .map(|w| [start + w.reached, start + w.reached + w.duration]),
        );
    }

    /// The person took back `plies` moves, putting pieces back by hand (`handled`): the moves
    /// leave the move list (their plies are played again), the arm's motion stays on the
    /// timeline as what it did.
    fn take_back(&mut self, handled: &[chessarm_chess::play::Handling], plies: usize) {
        self.handled.extend_from_slice(handled);
        self.moves.truncate(self.moves.len().saturating_sub(plies));
        for _ in 0..plies {
            self.turn = !self.turn;
            if self.turn == Color::Black {
                self.number -= 1;
            }
        }
    }

    fn finish(self, name: &str) -> ReplayRun {
        ReplayRun {
            name: name.to_string(),
            frames: self.frames,
            handled: self.handled,
            moves: self.moves,
            waits: self.waits,
        }
    }
}

fn write_move_csv(
    dir: &Path,
    report: &MoveReport,
    convention: &crate::app::setup::file::JointConvention,
) -> Result<()> {
    let mut header = vec!["t".to_string()];
    header.extend(numbered("q", 4).chain(numbered("q_des", 4)));
    header.extend(["x", "y", "z", "x_des", "y_des", "z_des", "tip_error_mm"].map(String::from));
    if report.records.first().is_some_and(|r| r.servo.is_some()) {
        header.extend(crate::app::setup::servos::servo_columns());
    }
    let path = dir.join(format!("{:03}-{}.csv", report.ply, report.uci));
    write_csv(
        &path,
        &header,
        report.records.iter().map(|r| {
            let mut row = vec![report.start_time + r.t];
            row.extend(convention.user(r.state.q).into_iter().chain(convention.user(r.reference.q)));
            row.extend(r.tip.iter().chain(r.tip_desired.iter()));
            row.push((r.tip - r.tip_desired).norm() * 1e3);
            crate::app::setup::servos::push_servo_values(&mut row, r, convention);
            row
        }),
    )
}

fn plot_game(
    path: &Path,
    placement_path: &Path,
    tip_errors: Vec<(f64, f64)>,
    reports: &[MoveReport],
    tolerance_mm: f64,
) -> Result<()> {
    // Displayed in mm; game.json and the CSVs say mm too.
    let tip = Panel {
        title: "tool-tip tracking error over the game (robot time; log scale)".into(),
        y_label: "tip error (mm)".into(),
        series: vec![Series {
            label: "|tip − desired tip|".into(), points: tip_errors, color: 2, style: Style::Line
        }],
        log_y: true,
        ..Panel::default()
    };
    let placement = Panel {
        title: format!(
            "distance of each placed piece from its target: a point per robot move (its worst task), dashed the {} mm tolerance",
            tick(tolerance_mm)
        ),
        y_label: "placement error (mm)".into(),
        series: vec![Series {
            label: "worst task of the robot's move".into(),
            points: reports
                .iter()
                .filter(|r| r.mover == Mover::Robot)
                .map(|r| (r.ply as f64, r.place_errors.iter().fold(0.0f64, |a, b| a.max(*b)) * 1e3))
                .collect(),
            color: 0,
            style: Style::Points,
        }],
        levels: vec![Level { value: tolerance_mm, label: format!("tolerance {} mm", tick(tolerance_mm)), color: 3 }],
        integer_x: true,
        legend: Corner::Hidden,
        ..Panel::default()
    };
    plot_panels(path, "Game: tool-tip tracking", "robot time (s)", &[tip])?;
    plot_panels(placement_path, "Game: piece placement", "ply", &[placement])
}
