//! Tests of the opponents: the built-in engine, the UCI client against fake engines written as shell
//! scripts, and (when installed) a short game against Stockfish.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

use std::path::PathBuf;
use std::time::{Duration, Instant};

use chessarm_chess::opponent::{BuiltinEngine, MAX_UCI_LINE_BYTES, Opponent, OpponentError, UciEngine};
use shakmaty::fen::Fen;
use shakmaty::{CastlingMode, Chess, EnPassantMode, Move, Position, Role, Square};

fn position(fen: &str) -> Chess {
    fen.parse::<Fen>().expect("valid FEN").into_position(CastlingMode::Standard).expect("legal position")
}

fn fen_of(position: &Chess) -> String {
    Fen::from_position(position, EnPassantMode::Legal).to_string()
}

fn play(position: &Chess, m: Move) -> Chess {
    assert!(position.is_legal(m), "illegal move {m} in {}", fen_of(position));
    position.clone().play(m).expect("legal move")
}

// ---------------------------------------------------------------------------------------------------
// Built-in engine
// ---------------------------------------------------------------------------------------------------

#[test]
fn builtin_finds_back_rank_mate_in_one() {
    let pos = position("6k1/5ppp/8/8/8/8/5PPP/R5K1 w - - 0 1");
    let mut engine = BuiltinEngine::new(3, None);
    let m = engine.choose_move(&pos).expect("a move");
    let after = play(&pos, m);
    assert!(after.is_checkmate(), "expected Ra8#, got {m}");
    let summary = engine.search(&pos).expect("a move");
    assert_eq!(summary.mate_in_plies(), Some(1), "{summary:?}");
}

#[test]
fn builtin_prefers_the_faster_mate() {
    // Qg7# mates at once; other moves mate later or not at all.
    let pos = position("7k/8/5KQ1/8/8/8/8/8 w - - 0 1");
    let summary = BuiltinEngine::new(4, None).search(&pos).expect("a move");
    assert!(play(&pos, summary.best_move).is_checkmate(), "{summary:?}");
    assert_eq!(summary.mate_in_plies(), Some(1));
}

#[test]
fn builtin_defends_against_a_back_rank_mate() {
    // Black to move must make luft (or otherwise parry Ra8#).
    let pos = position("6k1/5ppp/8/8/8/8/5PPP/R5K1 b - - 0 1");
    let summary = BuiltinEngine::new(3, None).search(&pos).expect("a move");
    assert!(summary.mate_in_plies().is_none(), "{summary:?}");
    let after = play(&pos, summary.best_move);
    for reply in after.legal_moves() {
        assert!(!play(&after, reply).is_checkmate(), "{} allows {reply}", summary.best_move);
    }
}

#[test]
fn builtin_takes_a_hanging_queen() {
    // 2... Qh4?? leaves the queen en prise to the knight on f3.
    let pos = position("rnb1kbnr/pppp1ppp/8/4p3/4P2q/5N2/PPPP1PPP/RNBQKB1R w KQkq - 2 3");
    let m = BuiltinEngine::new(3, None).choose_move(&pos).expect("a move");
    assert_eq!(m.to(), Square::H4, "expected Nxh4, got {m}");
    assert_eq!(m.capture(), Some(Role::Queen), "expected Nxh4, got {m}");
}

#[test]
fn builtin_takes_a_free_rook() {
    // The bishop on c3 takes the undefended rook on h8 along the long diagonal.
    let pos = position("4k2r/8/8/8/8/2B5/8/4K3 w - - 0 1");
    let m = BuiltinEngine::new(3, None).choose_move(&pos).expect("a move");
    assert_eq!(m.to(), Square::H8, "expected Bxh8, got {m}");
}

#[test]
fn builtin_plays_legal_moves_in_self_play() {
    let mut engine = BuiltinEngine::new(3, None);
    let mut pos = Chess::default();
    for ply in 0..20 {
        let m = engine.choose_move(&pos).unwrap_or_else(|e| panic!("ply {ply} in {}: {e}", fen_of(&pos)));
        pos = play(&pos, m);
    }
}

#[test]
fn builtin_is_deterministic() {
    let pos = position("r1bqkb1r/pppp1ppp/2n2n2/4p2Q/2B1P3/8/PPPP1PPP/RNB1K1NR w KQkq - 4 4");
    let first = BuiltinEngine::new(3, None).search(&pos).expect("a move");
    let second = BuiltinEngine::new(3, None).search(&pos).expect("a move");
    assert_eq!(first, second);
    // Qxf7# is on the board.
    assert!(play(&pos, first.best_move).is_checkmate(), "{first:?}");
}

#[test]
fn builtin_without_a_time_budget_is_a_pure_function_of_position_and_depth() {
    use std::sync::atomic::{AtomicBool, Ordering};

    let positions = [
        Chess::default(),
        position("r1bq1rk1/pp2bppp/2n1pn2/2pp4/3P4/2PBPN2/PP1N1PPP/R2QK2R w KQ - 0 8"),
        position("8/5pk1/6p1/3R4/8/6P1/5PKP/2r5 b - - 3 40"),
    ];
    let search = |pos: &Chess| BuiltinEngine::new(3, None).search(pos).expect("a move");
    for pos in &positions {
        let reference = search(pos);
        assert_eq!(reference.depth, 3, "{reference:?}");
        for _ in 0..2 {
            assert_eq!(search(pos), reference, "repeated call in {}", fen_of(pos));
        }
        // Two searches at once while a third thread keeps a core busy: neither load nor concurrency
        // may change the result.
        // The burner is stopped before anything is asserted, so that a failure cannot hang the scope.
        let stop = AtomicBool::new(false);
        let results = std::thread::scope(|scope| {
            scope.spawn(|| {
                let mut x = 0u64;
                while !stop.load(Ordering::Relaxed) {
                    x = std::hint::black_box(x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1));
                }
            });
            let searches: Vec<_> = (0..2).map(|_| scope.spawn(|| search(pos))).collect();
            let results: Vec<_> = searches.into_iter().map(|handle| handle.join()).collect();
            stop.store(true, Ordering::Relaxed);
            results
        });
        for result in results {
            assert_eq!(result.expect("search thread"), reference, "threaded search in {}", fen_of(pos));
        }
    }
}

#[test]
fn builtin_reports_no_legal_moves_when_mated_or_stalemated() {
    let fools_mate = position("rnb1kbnr/pppp1ppp/8/4p3/6Pq/5P2/PPPPP2P/RNBQKBNR w KQkq - 1 3");
    let stalemate = position("7k/5Q2/6K1/8/8/8/8/8 b - - 0 1");
    for pos in [fools_mate, stalemate] {
        let err = BuiltinEngine::default().choose_move(&pos).expect_err("game is over");
        assert!(matches!(err, OpponentError::NoLegalMoves), "{err:?}");
        assert!(!err.to_string().contains('\n'));
    }
}

#[test]
fn builtin_respects_the_time_budget() {
    let pos = position("r1bq1rk1/pp2bppp/2n1pn2/2pp4/3P4/2PBPN2/PP1N1PPP/R2QK2R w KQ - 0 8");
    let engine = BuiltinEngine::new(64, Some(Duration::from_millis(200)));
    let start = Instant::now();
    let summary = engine.search(&pos).expect("a move");
    let elapsed = start.elapsed();
    assert!(elapsed < Duration::from_secs(2), "took {elapsed:?}");
    assert!(summary.depth >= 1, "{summary:?}");
    assert!(pos.is_legal(summary.best_move));
    assert_eq!(engine.name(), "builtin (depth 64, 200 ms)");
    assert_eq!(BuiltinEngine::default().name(), "builtin (depth 3)");
}

#[test]
fn opponents_work_as_trait_objects() {
    let mut opponents: Vec<Box<dyn Opponent>> = vec![Box::new(BuiltinEngine::new(1, None))];
    let pos = Chess::default();
    for opponent in &mut opponents {
        let m = opponent.choose_move(&pos).expect("a move");
        assert!(pos.is_legal(m), "{} played {m}", opponent.name());
    }
}

// ---------------------------------------------------------------------------------------------------
// UCI client against fake engines
// ---------------------------------------------------------------------------------------------------

#[cfg(unix)]
mod fake_engines {
    use std::os::unix::fs::PermissionsExt;
    use std::path::Path;

    use super::*;

    /// A temporary directory removed on drop.
    struct TempDir(PathBuf);

    impl TempDir {
        fn new(name: &str) -> Self {
            let nanos =
                std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.subsec_nanos());
            let dir = std::env::temp_dir().join(format!("chessarm-opponent-{name}-{}-{nanos}", std::process::id()));
            std::fs::create_dir_all(&dir).expect("create temp dir");
            Self(dir)
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    /// Writes an executable `#!/bin/sh` fake engine whose reaction to `go` is `on_go` (shell code).
    fn write_fake_engine(dir: &TempDir, on_go: &str, on_quit: &str, after_loop: &str) -> PathBuf {
        write_fake_engine_with_prelude(dir, "", on_go, on_quit, after_loop)
    }

    /// Like [`write_fake_engine`], running `prelude` (shell code) first. `$DIR` is the temp dir.
    fn write_fake_engine_with_prelude(
        dir: &TempDir,
        prelude: &str,
        on_go: &str,
        on_quit: &str,
        after_loop: &str,
    ) -> PathBuf {
        let script = format!(
            r#"#!/bin/sh
    DIR='{dir}'
    {prelude}
    while read -r line; do
      case "$line" in
        uci) echo "Fake engine for tests"; echo "id name FakeEngine 1.0"; echo "id author nobody"; echo "uciok" ;;
        isready) echo "readyok" ;;
        go*) {on_go} ;;
        quit) {on_quit} ;;
      esac
    done
    {after_loop}
    "#,
            dir = dir.0.display()
        );
        let path = dir.0.join("engine.sh");
        std::fs::write(&path, script).expect("write fake engine");
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).expect("chmod fake engine");
        path
    }

    /// Spawns, retrying while another test's concurrent fork still holds the freshly written script open
    /// for writing (ETXTBSY, "text file busy").
    fn spawn(path: &Path, movetime_ms: u64, timeout: Duration) -> Result<UciEngine, OpponentError> {
        const ETXTBSY: i32 = 26;
        let mut attempts = 0;
        loop {
            match UciEngine::spawn(path, movetime_ms, timeout) {
                Err(OpponentError::EngineSpawn { cause, .. })
                    if cause.raw_os_error() == Some(ETXTBSY) && attempts < 50 =>
                {
                    attempts += 1;
                    std::thread::sleep(Duration::from_millis(20));
                }
                result => return result,
            }
        }
    }

    #[test]
    fn fake_engine_well_behaved() {
        let dir = TempDir::new("good");
        let path = write_fake_engine(
            &dir,
            r#"echo "info depth 1 score cp 20"; echo "bestmove e2e4 ponder e7e5""#,
            "exit 0",
            "",
        );
        let mut engine = spawn(&path, 10, Duration::from_secs(5)).expect("engine starts");
        assert_eq!(engine.name(), "FakeEngine 1.0");
        assert_eq!(engine.id_name(), Some("FakeEngine 1.0"));
        let pos = Chess::default();
        for _ in 0..3 {
            let m = engine.choose_move(&pos).expect("a move");
            assert_eq!(m.to_uci(CastlingMode::Standard).to_string(), "e2e4");
        }
        let err = engine.choose_move(&position("7k/5Q2/6K1/8/8/8/8/8 b - - 0 1")).expect_err("stalemate");
        assert!(matches!(err, OpponentError::NoLegalMoves), "{err:?}");
        let start = Instant::now();
        drop(engine);
        assert!(start.elapsed() < Duration::from_secs(2), "drop took {:?}", start.elapsed());
    }

    #[test]
    fn fake_engine_hanging_after_go_times_out() {
        let dir = TempDir::new("hang");
        let path = write_fake_engine(&dir, "exec sleep 30", "exit 0", "");
        let mut engine = spawn(&path, 50, Duration::from_millis(500)).expect("engine starts");
        let start = Instant::now();
        let err = engine.choose_move(&Chess::default()).expect_err("engine hangs");
        let elapsed = start.elapsed();
        assert!(elapsed >= Duration::from_millis(500), "gave up too early: {elapsed:?}");
        assert!(elapsed < Duration::from_secs(5), "took {elapsed:?}");
        match &err {
            OpponentError::EngineTimeout { engine: name, waited_ms, waiting_for } => {
                assert_eq!(*waited_ms, 550);
                assert_eq!(*waiting_for, "bestmove");
                assert!(name.contains("FakeEngine 1.0") && name.contains("engine.sh"), "{name}");
            }
            other => panic!("expected EngineTimeout, got {other:?}"),
        }
        let message = err.to_string();
        assert!(message.contains("550 ms") && !message.contains('\n'), "{message}");
        // The engine was killed: later calls fail at once, and drop does not hang.
        let start = Instant::now();
        let err = engine.choose_move(&Chess::default()).expect_err("engine is dead");
        assert!(matches!(err, OpponentError::EngineDied { .. }), "{err:?}");
        drop(engine);
        assert!(start.elapsed() < Duration::from_secs(2), "took {:?}", start.elapsed());
    }

    #[test]
    fn fake_engine_hanging_in_handshake_times_out() {
        let dir = TempDir::new("mute");
        let path = dir.0.join("mute.sh");
        {
            std::fs::write(&path, "#!/bin/sh\nexec sleep 30\n").expect("write fake engine");
            std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).expect("chmod");
        }
        let start = Instant::now();
        let err = spawn(&path, 50, Duration::from_millis(300)).expect_err("no uciok");
        assert!(start.elapsed() < Duration::from_secs(5), "took {:?}", start.elapsed());
        assert!(matches!(err, OpponentError::EngineTimeout { waiting_for: "uciok", waited_ms: 300, .. }), "{err:?}");
    }

    #[test]
    fn fake_engine_exiting_on_go_died() {
        let dir = TempDir::new("exit");
        let path = write_fake_engine(&dir, "exit 3", "exit 0", "");
        let mut engine = spawn(&path, 50, Duration::from_secs(5)).expect("engine starts");
        let start = Instant::now();
        let err = engine.choose_move(&Chess::default()).expect_err("engine exits");
        assert!(start.elapsed() < Duration::from_secs(4), "took {:?}", start.elapsed());
        match &err {
            OpponentError::EngineDied { engine: name, detail } => {
                assert!(name.contains("engine.sh"), "{name}");
                assert!(detail.contains("exit status: 3"), "{detail}");
            }
            other => panic!("expected EngineDied, got {other:?}"),
        }
        assert!(!err.to_string().contains('\n'));
        // Writing to the dead engine is an error, not a panic.
        let err = engine.choose_move(&Chess::default()).expect_err("engine is dead");
        assert!(matches!(err, OpponentError::EngineDied { .. }), "{err:?}");
    }

    #[test]
    fn fake_engine_playing_an_illegal_move() {
        let dir = TempDir::new("illegal");
        let path = write_fake_engine(&dir, r#"echo "bestmove e2e5""#, "exit 0", "");
        let mut engine = spawn(&path, 10, Duration::from_secs(5)).expect("engine starts");
        let pos = Chess::default();
        let err = engine.choose_move(&pos).expect_err("illegal move");
        match &err {
            OpponentError::IllegalMove { uci, fen, .. } => {
                assert_eq!(uci, "e2e5");
                assert_eq!(fen, &fen_of(&pos));
            }
            other => panic!("expected IllegalMove, got {other:?}"),
        }
        let message = err.to_string();
        assert!(message.contains("e2e5") && message.contains(&fen_of(&pos)), "{message}");
    }

    #[test]
    fn fake_engine_sending_garbage_moves_or_lines() {
        let dir = TempDir::new("garbage");
        let path = write_fake_engine(&dir, r#"echo "bestmove""#, "exit 0", "");
        let mut engine = spawn(&path, 10, Duration::from_secs(5)).expect("engine starts");
        let err = engine.choose_move(&Chess::default()).expect_err("no move text");
        assert!(matches!(&err, OpponentError::Protocol { line, .. } if line == "bestmove"), "{err:?}");

        let dir = TempDir::new("nonsense");
        let path = write_fake_engine(&dir, r#"echo "bestmove banana""#, "exit 0", "");
        let mut engine = spawn(&path, 10, Duration::from_secs(5)).expect("engine starts");
        let err = engine.choose_move(&Chess::default()).expect_err("unparsable move");
        assert!(matches!(&err, OpponentError::IllegalMove { uci, .. } if uci == "banana"), "{err:?}");
    }

    #[test]
    fn fake_engine_ignoring_quit_is_killed_on_drop() {
        let dir = TempDir::new("stubborn");
        let path = write_fake_engine(&dir, r#"echo "bestmove e2e4""#, ":", "exec sleep 30");
        let engine = spawn(&path, 10, Duration::from_secs(5)).expect("engine starts");
        let start = Instant::now();
        drop(engine);
        assert!(start.elapsed() < Duration::from_secs(2), "drop took {:?}", start.elapsed());
    }

    #[test]
    fn fake_engine_sending_an_endless_line_is_cut_off() {
        let dir = TempDir::new("endless");
        // 10 MB without a newline: the client must stop reading after 64 KiB + 1 bytes.
        let path = write_fake_engine(&dir, r#"head -c 10000000 /dev/zero | tr '\0' a"#, "exit 0", "");
        let mut engine = spawn(&path, 10, Duration::from_secs(10)).expect("engine starts");
        let start = Instant::now();
        let err = engine.choose_move(&Chess::default()).expect_err("line too long");
        // Reading 64 KiB and killing the engine takes milliseconds; 5 s (half the engine timeout, so a
        // timeout cannot pass for this error) leaves room for a loaded machine.
        assert!(start.elapsed() < Duration::from_secs(5), "took {:?}", start.elapsed());
        match &err {
            OpponentError::LineTooLong { engine: name, max_bytes } => {
                assert_eq!(*max_bytes, MAX_UCI_LINE_BYTES);
                assert!(name.contains("FakeEngine 1.0"), "{name}");
            }
            other => panic!("expected LineTooLong, got {other:?}"),
        }
        let message = err.to_string();
        assert!(message.contains("sent a line longer than 65536 bytes") && !message.contains('\n'), "{message}");
        // The engine was killed.
        let err = engine.choose_move(&Chess::default()).expect_err("engine is dead");
        assert!(matches!(err, OpponentError::EngineDied { .. }), "{err:?}");
        let start = Instant::now();
        drop(engine);
        assert!(start.elapsed() < Duration::from_secs(2), "drop took {:?}", start.elapsed());
    }

    #[test]
    fn fake_engine_line_of_exactly_the_limit_is_accepted() {
        let dir = TempDir::new("longline");
        let line = |bytes: usize| format!(r#"head -c {bytes} /dev/zero | tr '\0' a; echo"#);
        let on_go = format!(r#"{}; echo "bestmove e2e4""#, line(MAX_UCI_LINE_BYTES));
        let path = write_fake_engine(&dir, &on_go, "exit 0", "");
        let mut engine = spawn(&path, 10, Duration::from_secs(10)).expect("engine starts");
        let m = engine.choose_move(&Chess::default()).expect("a 65536-byte line is fine");
        assert_eq!(m.to_uci(CastlingMode::Standard).to_string(), "e2e4");

        let dir = TempDir::new("longerline");
        let on_go = format!(r#"{}; echo "bestmove e2e4""#, line(MAX_UCI_LINE_BYTES + 1));
        let path = write_fake_engine(&dir, &on_go, "exit 0", "");
        let mut engine = spawn(&path, 10, Duration::from_secs(10)).expect("engine starts");
        let err = engine.choose_move(&Chess::default()).expect_err("one byte too many");
        assert!(matches!(err, OpponentError::LineTooLong { .. }), "{err:?}");
    }

    /// The process id written by a fake engine to `file`.
    fn read_pid(file: &Path) -> u32 {
        let text = std::fs::read_to_string(file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        text.trim().parse().unwrap_or_else(|e| panic!("pid {text:?}: {e}"))
    }

    /// State letter and start time (clock ticks since boot) from `/proc/<pid>/stat`, `None` if there
    /// is no such process. The command name (field 2) may contain spaces and parentheses, so fields
    /// are counted after its closing parenthesis: state is field 3, start time field 22.
    #[cfg(target_os = "linux")]
    fn proc_state(pid: u32) -> Option<(char, u64)> {
        let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
        let after_name = &stat[stat.rfind(')')? + 1..];
        let fields: Vec<&str> = after_name.split_whitespace().collect();
        Some((fields.first()?.chars().next()?, fields.get(19)?.parse().ok()?))
    }

    /// Waits up to 2 s for process `pid` (alive now) to be gone. A zombie (`Z`) counts as gone: it has
    /// been killed, and as an orphan it is reaped by init (or whichever process adopts it), which
    /// this test does not control. If the pid is reused meanwhile (a different start time), the
    /// original process is gone too. 2 s: a killed process disappears within milliseconds; this
    /// leaves room for a loaded machine without making the test slow.
    #[cfg(target_os = "linux")]
    fn assert_gone_soon(pid: u32, what: &str) {
        let Some((_, started)) = proc_state(pid) else { return };
        let deadline = Instant::now() + Duration::from_secs(2);
        loop {
            match proc_state(pid) {
                None => return,
                Some(('Z', _)) => return,
                Some((_, start)) if start != started => return,
                Some((state, _)) if Instant::now() >= deadline => {
                    panic!("{what} (pid {pid}) still there in state {state} after 2 s")
                }
                Some(_) => std::thread::sleep(Duration::from_millis(10)),
            }
        }
    }

    /// A grandchild that is still running now.
    #[cfg(target_os = "linux")]
    fn running_grandchild(dir: &TempDir) -> u32 {
        let pid = read_pid(&dir.0.join("grandchild.pid"));
        let state = proc_state(pid).map(|(state, _)| state);
        assert!(matches!(state, Some('S' | 'R')), "grandchild {pid} not running: {state:?}");
        pid
    }

    /// Starts `sleep 1000` in the background (output away from the engine's pipe, so only the process
    /// group ties it to the engine) and records its pid.
    const START_GRANDCHILD: &str = r#"sleep 1000 >/dev/null 2>&1 &
    echo $! > "$DIR/grandchild.pid""#;

    #[test]
    #[cfg(target_os = "linux")]
    fn grandchild_is_killed_with_a_timed_out_engine() {
        let dir = TempDir::new("grandchild-timeout");
        let path = write_fake_engine_with_prelude(&dir, START_GRANDCHILD, "sleep 30", "exit 0", "");
        let mut engine = spawn(&path, 10, Duration::from_millis(300)).expect("engine starts");
        let grandchild = running_grandchild(&dir);
        let err = engine.choose_move(&Chess::default()).expect_err("engine hangs");
        assert!(matches!(err, OpponentError::EngineTimeout { .. }), "{err:?}");
        assert_gone_soon(grandchild, "grandchild after the timeout");
        drop(engine);
        assert_gone_soon(grandchild, "grandchild after drop");
    }

    #[test]
    #[cfg(target_os = "linux")]
    fn grandchild_is_killed_when_the_engine_is_dropped() {
        let dir = TempDir::new("grandchild-drop");
        let path = write_fake_engine_with_prelude(&dir, START_GRANDCHILD, r#"echo "bestmove e2e4""#, "exit 0", "");
        let mut engine = spawn(&path, 10, Duration::from_secs(5)).expect("engine starts");
        let grandchild = running_grandchild(&dir);
        engine.choose_move(&Chess::default()).expect("a move");
        // The engine exits on `quit`; its helper must not outlive it.
        drop(engine);
        assert_gone_soon(grandchild, "grandchild after drop");
    }

    #[test]
    #[cfg(target_os = "linux")]
    fn engine_exiting_while_its_child_holds_the_output_is_reported_dead_at_once() {
        let dir = TempDir::new("exit-held");
        // The background `sleep` inherits the engine's stdout, so the pipe stays open after `exit 3`.
        let on_go = r#"sleep 30 & echo $! > "$DIR/grandchild.pid"; exit 3"#;
        let path = write_fake_engine(&dir, on_go, "exit 0", "");
        let mut engine = spawn(&path, 10, Duration::from_secs(10)).expect("engine starts");
        let start = Instant::now();
        let err = engine.choose_move(&Chess::default()).expect_err("engine exits");
        let elapsed = start.elapsed();
        // Noticed within one 25 ms polling slice plus 100 ms for late lines; 2 s leaves room for a
        // loaded machine and is far below the 10 s timeout this used to end in.
        assert!(elapsed < Duration::from_secs(2), "took {elapsed:?}");
        match &err {
            OpponentError::EngineDied { detail, .. } => {
                assert_eq!(detail, "the process exited (exit status: 3) while we waited for `bestmove`");
            }
            other => panic!("expected EngineDied, got {other:?}"),
        }
        assert_gone_soon(read_pid(&dir.0.join("grandchild.pid")), "the child holding the output");
    }

    #[test]
    fn engine_answering_and_then_exiting_still_delivers_its_move() {
        let dir = TempDir::new("answer-exit");
        let on_go = r#"sleep 30 & echo "bestmove e2e4"; exit 0"#;
        let path = write_fake_engine(&dir, on_go, "exit 0", "");
        let mut engine = spawn(&path, 10, Duration::from_secs(10)).expect("engine starts");
        let m = engine.choose_move(&Chess::default()).expect("the move sent before exiting");
        assert_eq!(m.to_uci(CastlingMode::Standard).to_string(), "e2e4");
        let err = engine.choose_move(&Chess::default()).expect_err("engine is gone");
        assert!(matches!(err, OpponentError::EngineDied { .. }), "{err:?}");
    }
}

#[test]
fn missing_engine_is_a_spawn_error() {
    let path = std::env::temp_dir().join("chessarm-no-such-engine/definitely-not-stockfish");
    let err = UciEngine::spawn(&path, 50, Duration::from_secs(1)).expect_err("no such file");
    match &err {
        OpponentError::EngineSpawn { path: reported, .. } => assert_eq!(reported, &path),
        other => panic!("expected EngineSpawn, got {other:?}"),
    }
    let message = err.to_string();
    assert!(message.contains("definitely-not-stockfish") && !message.contains('\n'), "{message}");
}

// ---------------------------------------------------------------------------------------------------
// Real Stockfish
// ---------------------------------------------------------------------------------------------------

fn find_stockfish() -> Option<PathBuf> {
    let on_path = std::env::var_os("PATH")
        .map(|paths| std::env::split_paths(&paths).map(|dir| dir.join("stockfish")).collect::<Vec<_>>())
        .unwrap_or_default();
    on_path
        .into_iter()
        .chain([PathBuf::from("/usr/games/stockfish"), PathBuf::from("/usr/bin/stockfish")])
        .find(|candidate| candidate.is_file())
}

#[test]
#[cfg_attr(not(tool_stockfish), ignore = "needs Stockfish (apt install stockfish); see docs/testing.md")]
fn builtin_against_stockfish() {
    let path = find_stockfish().expect("stockfish on PATH, in /usr/games or /usr/bin");
    let mut stockfish = UciEngine::spawn(&path, 50, Duration::from_secs(10)).expect("stockfish starts");
    assert!(stockfish.name().to_lowercase().contains("stockfish"), "{}", stockfish.name());
    let mut builtin = BuiltinEngine::new(3, None);
    let mut pos = Chess::default();
    for ply in 0..10 {
        if pos.is_game_over() {
            break;
        }
        let player: &mut dyn Opponent = if ply % 2 == 0 { &mut builtin } else { &mut stockfish };
        let m = player.choose_move(&pos).unwrap_or_else(|e| panic!("{} failed at ply {ply}: {e}", player.name()));
        pos = play(&pos, m);
    }
}
