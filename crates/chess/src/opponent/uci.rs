//! A client for external chess engines speaking the UCI protocol (Stockfish and friends), over plain
//! `std::process` pipes.
//!
//! The engine's standard output is read by a dedicated thread that forwards lines over a channel, so
//! every wait has a timeout: a hung engine is killed and reported as [`OpponentError::EngineTimeout`],
//! a crashed one as [`OpponentError::EngineDied`]. Dropping a [`UciEngine`] sends `quit` and kills the
//! process after a short grace period, so no zombie or hang remains.

use std::io::{self, BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender};
use std::thread;
use std::time::{Duration, Instant};

use shakmaty::fen::Fen;
use shakmaty::uci::UciMove;
use shakmaty::{Chess, EnPassantMode, Move, Position};

use super::{Opponent, OpponentError};

/// How long a process gets to exit by itself (after `quit`, or after closing its output) before it is
/// killed.
const EXIT_GRACE: Duration = Duration::from_millis(200);
/// Polling interval while waiting for a process to exit.
const EXIT_POLL: Duration = Duration::from_millis(5);

/// A running UCI engine process.
#[derive(Debug)]
pub struct UciEngine {
    path: PathBuf,
    id_name: Option<String>,
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Receiver<String>,
    movetime_ms: u64,
    timeout: Duration,
    /// Why the engine is no longer usable, once it has died or been killed.
    dead: Option<String>,
}

impl UciEngine {
    /// Starts the engine at `path` and performs the UCI handshake (`uci`/`uciok`, `isready`/`readyok`).
    ///
    /// Each move is searched with `go movetime <movetime_ms>`. `timeout` bounds every wait for the
    /// engine: the handshake replies, and the `bestmove` reply on top of the move time.
    ///
    /// # Errors
    ///
    /// [`OpponentError::EngineSpawn`] if the program cannot be started; [`OpponentError::EngineTimeout`]
    /// or [`OpponentError::EngineDied`] if it does not complete the handshake.
    pub fn spawn(path: &Path, movetime_ms: u64, timeout: Duration) -> Result<Self, OpponentError> {
        let mut child = Command::new(path)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .map_err(|cause| OpponentError::EngineSpawn { path: path.to_path_buf(), cause })?;
        let stdin = child.stdin.take();
        let stdout = child.stdout.take();
        // Bounded: an engine that floods its output blocks on its own pipe instead of filling memory.
        let (sender, lines) = mpsc::sync_channel(LINE_BUFFER);
        // From here on, dropping `engine` (also on the error paths below) cleans up the process.
        let mut engine =
            Self { path: path.to_path_buf(), id_name: None, child, stdin, lines, movetime_ms, timeout, dead: None };
        let Some(stdout) = stdout else {
            return Err(engine.died("its standard output could not be captured".to_owned()));
        };
        thread::Builder::new().name("uci-engine-stdout".to_owned()).spawn(move || forward_lines(stdout, &sender))?;
        engine.handshake()?;
        Ok(engine)
    }

    /// The path the engine was started from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The name the engine reported with `id name`, if any.
    pub fn id_name(&self) -> Option<&str> {
        self.id_name.as_deref()
    }

    /// The move time per move, in milliseconds.
    pub fn movetime_ms(&self) -> u64 {
        self.movetime_ms
    }

    fn handshake(&mut self) -> Result<(), OpponentError> {
        self.send("uci")?;
        let mut id_name = None;
        self.wait_for("uciok", self.timeout, |line| {
            if let Some(name) = line.strip_prefix("id name ") {
                id_name = Some(name.trim().to_owned());
            }
            (line == "uciok").then_some(())
        })?;
        self.id_name = id_name.filter(|name| !name.is_empty());
        self.send("isready")?;
        self.wait_for("readyok", self.timeout, |line| (line == "readyok").then_some(()))
    }

    /// Engine name and path, for error messages.
    fn label(&self) -> String {
        match &self.id_name {
            Some(name) => format!("{name} ({})", self.path.display()),
            None => self.path.display().to_string(),
        }
    }

    /// Sends one command line.
    fn send(&mut self, command: &str) -> Result<(), OpponentError> {
        if let Some(reason) = &self.dead {
            return Err(OpponentError::EngineDied { engine: self.label(), detail: reason.clone() });
        }
        let Some(stdin) = self.stdin.as_mut() else {
            return Err(self.died("its standard input is closed".to_owned()));
        };
        let result =
            stdin.write_all(command.as_bytes()).and_then(|()| stdin.write_all(b"\n")).and_then(|()| stdin.flush());
        match result {
            Ok(()) => Ok(()),
            Err(error) if is_pipe_closed(&error) => {
                let status = self.reap();
                Err(self.died(format!("{status}; sending `{command}` failed: {error}")))
            }
            Err(error) => Err(OpponentError::Io(error)),
        }
    }

    /// Reads lines until `accept` returns `Some`, for at most `timeout`.
    fn wait_for<T>(
        &mut self,
        waiting_for: &'static str,
        timeout: Duration,
        mut accept: impl FnMut(&str) -> Option<T>,
    ) -> Result<T, OpponentError> {
        let deadline = Instant::now().checked_add(timeout);
        loop {
            // Checked before every line: a chatty engine must not keep a missed deadline alive.
            let expired = deadline.is_some_and(|deadline| Instant::now() >= deadline);
            let received = match deadline {
                _ if expired => Err(RecvTimeoutError::Timeout),
                Some(deadline) => self.lines.recv_timeout(deadline.saturating_duration_since(Instant::now())),
                // A timeout too large to represent: wait without one.
                None => self.lines.recv().map_err(|_| RecvTimeoutError::Disconnected),
            };
            match received {
                Ok(line) => {
                    if let Some(value) = accept(line.trim()) {
                        return Ok(value);
                    }
                }
                Err(RecvTimeoutError::Timeout) => {
                    let waited_ms = u64::try_from(timeout.as_millis()).unwrap_or(u64::MAX);
                    self.kill(format!("it was killed after not sending `{waiting_for}` within {waited_ms} ms"));
                    return Err(OpponentError::EngineTimeout { engine: self.label(), waited_ms, waiting_for });
                }
                Err(RecvTimeoutError::Disconnected) => {
                    let status = self.reap();
                    return Err(self.died(format!("{status} while we waited for `{waiting_for}`")));
                }
            }
        }
    }

    /// Marks the engine dead and builds the matching error.
    fn died(&mut self, detail: String) -> OpponentError {
        self.dead.get_or_insert_with(|| detail.clone());
        OpponentError::EngineDied { engine: self.label(), detail }
    }

    /// Kills the process (if still running) and waits for it.
    fn kill(&mut self, reason: String) {
        self.stdin = None;
        let _ = self.child.kill();
        let _ = self.child.wait();
        self.dead.get_or_insert(reason);
    }

    /// The engine closed its output or input: give it a moment to exit, kill it otherwise, and describe
    /// what happened.
    fn reap(&mut self) -> String {
        self.stdin = None;
        if let Some(status) = self.wait_exit(EXIT_GRACE) {
            return format!("the process exited ({status})");
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
        "the process closed its pipes without exiting and was killed".to_owned()
    }

    /// Polls for the process to exit for at most `grace`.
    fn wait_exit(&mut self, grace: Duration) -> Option<std::process::ExitStatus> {
        let deadline = Instant::now() + grace;
        loop {
            match self.child.try_wait() {
                Ok(Some(status)) => return Some(status),
                Ok(None) if Instant::now() < deadline => thread::sleep(EXIT_POLL),
                Ok(None) | Err(_) => return None,
            }
        }
    }
}

impl Opponent for UciEngine {
    fn choose_move(&mut self, position: &Chess) -> Result<Move, OpponentError> {
        if position.legal_moves().is_empty() {
            return Err(OpponentError::NoLegalMoves);
        }
        let fen = Fen::from_position(position, EnPassantMode::Legal).to_string();
        // Discard anything left over from earlier commands (late `info` lines and the like).
        for _ in 0..LINE_BUFFER {
            if self.lines.try_recv().is_err() {
                break;
            }
        }
        self.send(&format!("position fen {fen}"))?;
        self.send(&format!("go movetime {}", self.movetime_ms))?;
        let wait = Duration::from_millis(self.movetime_ms).saturating_add(self.timeout);
        let line = self.wait_for("bestmove", wait, |line| {
            (line.split_whitespace().next() == Some("bestmove")).then(|| line.to_owned())
        })?;
        let Some(text) = line.split_whitespace().nth(1) else {
            return Err(OpponentError::Protocol { engine: self.label(), line });
        };
        text.parse::<UciMove>()
            .ok()
            .and_then(|uci| uci.to_move(position).ok())
            .ok_or_else(|| OpponentError::IllegalMove { engine: self.label(), uci: text.to_owned(), fen })
    }

    fn name(&self) -> String {
        self.id_name.clone().unwrap_or_else(|| self.path.display().to_string())
    }
}

impl Drop for UciEngine {
    fn drop(&mut self) {
        if self.dead.is_none() {
            let _ = self.send("quit");
        }
        // Closing stdin also tells engines that ignore `quit` that we are gone.
        self.stdin = None;
        if self.wait_exit(EXIT_GRACE).is_none() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// Whether a write error means the engine is no longer reading its input.
fn is_pipe_closed(error: &io::Error) -> bool {
    matches!(error.kind(), io::ErrorKind::BrokenPipe | io::ErrorKind::ConnectionReset | io::ErrorKind::UnexpectedEof)
}

/// Forwards the engine's output line by line until it closes (or the receiver is gone).
/// Lines buffered between the engine's output thread and the client.
const LINE_BUFFER: usize = 1024;

fn forward_lines(stdout: ChildStdout, lines: &SyncSender<String>) {
    let mut reader = BufReader::new(stdout);
    let mut buffer = Vec::new();
    loop {
        buffer.clear();
        match reader.read_until(b'\n', &mut buffer) {
            Ok(0) | Err(_) => return,
            Ok(_) => {
                let line = String::from_utf8_lossy(&buffer).trim_end().to_owned();
                if lines.send(line).is_err() {
                    return;
                }
            }
        }
    }
}
