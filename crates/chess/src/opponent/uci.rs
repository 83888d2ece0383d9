//! A client for external chess engines speaking the UCI protocol (Stockfish and friends), over plain
//! `std::process` pipes.
//!
//! The engine's standard output is read by a dedicated thread that forwards lines over a channel, so
//! every wait has a timeout: a hung engine is killed and reported as [`OpponentError::EngineTimeout`],
//! a crashed one as [`OpponentError::EngineDied`]. A line longer than [`MAX_UCI_LINE_BYTES`] is
//! [`OpponentError::LineTooLong`]: the reader never buffers more than that. Every line is parsed by
//! [`parse_uci_line`]. Dropping a [`UciEngine`] sends `quit` and kills the process after a short grace
//! period, so no zombie or hang remains.
//!
//! On Linux the engine runs in a process group of its own, and the whole group is killed whenever the
//! engine is (timeout, death, line too long, drop), so helper processes it started go too (unless they
//! left the group themselves). A consequence: a Ctrl-C in the terminal does not reach the engine
//! directly; it sees its standard input close when this process exits, on which UCI engines quit. On
//! other systems only the engine process itself is killed.

use std::io::{self, BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, ExitStatus, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender, TryRecvError};
use std::sync::{Mutex, MutexGuard, PoisonError};
use std::thread;
use std::time::{Duration, Instant};

use shakmaty::fen::Fen;
use shakmaty::uci::UciMove;
use shakmaty::{Chess, EnPassantMode, Move, Position};

use super::uci_line::{UciLine, parse_uci_line};
use super::{Opponent, OpponentError};

/// Longest line (in bytes, without its `\n`) accepted from an engine. Real engines' longest lines are
/// `info ... pv` lines of a few kilobytes; this bounds what the reader thread buffers per line.
pub const MAX_UCI_LINE_BYTES: usize = 64 * 1024;

/// How long a process gets to exit by itself (after `quit`, or after closing its output) before it is
/// killed.
const EXIT_GRACE: Duration = Duration::from_millis(200);
/// Polling interval while waiting for a process to exit.
const EXIT_POLL: Duration = Duration::from_millis(5);
/// While waiting for a reply, how often we look whether the engine process has exited (an exited
/// engine whose output pipe is still held open by a child of its own would otherwise look hung until
/// the timeout).
const WAIT_SLICE: Duration = Duration::from_millis(25);
/// After the engine has exited, how long lines it wrote before exiting are still collected (the
/// reader thread may not have forwarded them yet) before the engine is reported dead.
const DRAIN_GRACE: Duration = Duration::from_millis(100);

/// What the reader thread forwards.
#[derive(Debug)]
enum Output {
    /// One line, without its terminator and trailing whitespace.
    Line(String),
    /// The engine sent more than [`MAX_UCI_LINE_BYTES`] bytes without a newline; the thread stopped.
    TooLong,
}

/// A running UCI engine process.
#[derive(Debug)]
pub struct UciEngine {
    path: PathBuf,
    id_name: Option<String>,
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Receiver<Output>,
    movetime_ms: u64,
    timeout: Duration,
    /// Why the engine is no longer usable, once it has died or been killed.
    dead: Option<String>,
    /// The exit status, once the process has been reaped (after which its process group is not
    /// signalled any more: its id could name another group).
    status: Option<ExitStatus>,
}

impl UciEngine {
    /// Starts the engine at `path` and performs the UCI handshake (`uci`/`uciok`, `isready`/`readyok`).
    ///
    /// Each move is searched with `go movetime <movetime_ms>`. `timeout` bounds every wait for the
    /// engine: the handshake replies, and the `bestmove` reply on top of the move time.
    ///
    /// # Errors
    ///
    /// [`OpponentError::EngineSpawn`] if the program cannot be started; [`OpponentError::EngineTimeout`],
    /// [`OpponentError::EngineDied`] or [`OpponentError::LineTooLong`] if it does not complete the
    /// handshake.
    pub fn spawn(path: &Path, movetime_ms: u64, timeout: Duration) -> Result<Self, OpponentError> {
        let mut command = Command::new(path);
        command.stdin(Stdio::piped()).stdout(Stdio::piped()).stderr(Stdio::null());
        process::own_group(&mut command);
        let mut child =
            command.spawn().map_err(|cause| OpponentError::EngineSpawn { path: path.to_path_buf(), cause })?;
        live_groups().push(child.id());
        let stdin = child.stdin.take();
        let stdout = child.stdout.take();
        // Bounded: an engine that floods its output blocks on its own pipe instead of filling memory.
        let (sender, lines) = mpsc::sync_channel(LINE_BUFFER);
        // From here on, dropping `engine` (also on the error paths below) cleans up the process.
        let mut engine = Self {
            path: path.to_path_buf(),
            id_name: None,
            child,
            stdin,
            lines,
            movetime_ms,
            timeout,
            dead: None,
            status: None,
        };
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
        self.wait_for("uciok", self.timeout, |_, line| match line {
            UciLine::IdName(name) => {
                id_name = Some(name);
                None
            }
            UciLine::UciOk => Some(()),
            _ => None,
        })?;
        self.id_name = id_name.filter(|name| !name.is_empty());
        self.send("isready")?;
        self.wait_for("readyok", self.timeout, |_, line| (line == UciLine::ReadyOk).then_some(()))
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

    /// Reads lines until `accept` (given the line as sent and parsed) returns `Some`, for at most
    /// `timeout`. Every [`WAIT_SLICE`] without a line, looks whether the engine has exited.
    fn wait_for<T>(
        &mut self,
        waiting_for: &'static str,
        timeout: Duration,
        mut accept: impl FnMut(&str, UciLine) -> Option<T>,
    ) -> Result<T, OpponentError> {
        let deadline = Instant::now().checked_add(timeout);
        loop {
            // Checked before every line: a chatty engine must not keep a missed deadline alive.
            // `None`: a timeout too large to represent, wait without one.
            let remaining = deadline.map(|deadline| deadline.saturating_duration_since(Instant::now()));
            if remaining == Some(Duration::ZERO) {
                let waited_ms = u64::try_from(timeout.as_millis()).unwrap_or(u64::MAX);
                self.kill(format!("it was killed after not sending `{waiting_for}` within {waited_ms} ms"));
                return Err(OpponentError::EngineTimeout { engine: self.label(), waited_ms, waiting_for });
            }
            match self.lines.recv_timeout(remaining.map_or(WAIT_SLICE, |remaining| remaining.min(WAIT_SLICE))) {
                Ok(Output::Line(line)) => {
                    if let Some(value) = accept(&line, parse_uci_line(&line)) {
                        return Ok(value);
                    }
                }
                Ok(Output::TooLong) => return Err(self.line_too_long()),
                Err(RecvTimeoutError::Timeout) => {
                    if process::has_exited(&mut self.child) {
                        return self.exited_while_waiting(waiting_for, &mut accept);
                    }
                }
                Err(RecvTimeoutError::Disconnected) => {
                    let status = self.reap();
                    return Err(self.died(format!("{status} while we waited for `{waiting_for}`")));
                }
            }
        }
    }

    /// The engine process has exited while its output is still open (a child of its own holds it):
    /// takes the lines it wrote before exiting, then kills what is left of its process group.
    fn exited_while_waiting<T>(
        &mut self,
        waiting_for: &'static str,
        accept: &mut impl FnMut(&str, UciLine) -> Option<T>,
    ) -> Result<T, OpponentError> {
        let drain_until = Instant::now() + DRAIN_GRACE;
        loop {
            match self.lines.recv_timeout(drain_until.saturating_duration_since(Instant::now())) {
                Ok(Output::Line(line)) => {
                    if let Some(value) = accept(&line, parse_uci_line(&line)) {
                        return Ok(value);
                    }
                }
                Ok(Output::TooLong) => return Err(self.line_too_long()),
                Err(_) => break,
            }
        }
        let status = self.terminate().map_or_else(|| "the process exited".to_owned(), describe_exit);
        Err(self.died(format!("{status} while we waited for `{waiting_for}`")))
    }

    /// Kills the engine after an over-long line and builds the error.
    fn line_too_long(&mut self) -> OpponentError {
        self.kill(format!("it was killed after sending a line longer than {MAX_UCI_LINE_BYTES} bytes"));
        OpponentError::LineTooLong { engine: self.label(), max_bytes: MAX_UCI_LINE_BYTES }
    }

    /// Marks the engine dead and builds the matching error.
    fn died(&mut self, detail: String) -> OpponentError {
        self.dead.get_or_insert_with(|| detail.clone());
        OpponentError::EngineDied { engine: self.label(), detail }
    }

    /// Kills the process group (if still running) and waits for the process.
    fn kill(&mut self, reason: String) {
        self.terminate();
        self.dead.get_or_insert(reason);
    }

    /// Closes the engine's input, kills its process group and the process itself (no-ops for what has
    /// exited already), and reaps the process. Returns its exit status.
    fn terminate(&mut self) -> Option<ExitStatus> {
        self.stdin = None;
        if self.status.is_none() {
            // Not reaped yet, so the engine's process id still names its group, even if it has exited.
            process::kill_group(&self.child);
            let _ = self.child.kill();
            // Forgotten only after the kill and before the reaping, so `kill_all_engines` never
            // signals a reused id and never misses a live group.
            live_groups().retain(|&id| id != self.child.id());
            self.status = self.child.wait().ok();
        }
        self.status
    }

    /// The engine closed its output or input: give it a moment to exit, kill it otherwise, and describe
    /// what happened.
    fn reap(&mut self) -> String {
        self.stdin = None;
        let exited = self.wait_exit(EXIT_GRACE);
        let status = self.terminate();
        match status {
            Some(status) if exited => describe_exit(status),
            _ => "the process closed its pipes without exiting and was killed".to_owned(),
        }
    }

    /// Polls for the process to exit for at most `grace` (without reaping it).
    fn wait_exit(&mut self, grace: Duration) -> bool {
        let deadline = Instant::now() + grace;
        loop {
            if process::has_exited(&mut self.child) {
                return true;
            }
            if Instant::now() >= deadline {
                return false;
            }
            thread::sleep(EXIT_POLL);
        }
    }
}

/// "the process exited (exit status: 3)".
fn describe_exit(status: ExitStatus) -> String {
    format!("the process exited ({status})")
}

impl Opponent for UciEngine {
    fn choose_move(&mut self, position: &Chess) -> Result<Move, OpponentError> {
        if position.legal_moves().is_empty() {
            return Err(OpponentError::NoLegalMoves);
        }
        let fen = Fen::from_position(position, EnPassantMode::Legal).to_string();
        // Discard anything left over from earlier commands (late `info` lines and the like).
        for _ in 0..LINE_BUFFER {
            match self.lines.try_recv() {
                Ok(Output::Line(_)) => {}
                Ok(Output::TooLong) => return Err(self.line_too_long()),
                Err(TryRecvError::Empty | TryRecvError::Disconnected) => break,
            }
        }
        self.send(&format!("position fen {fen}"))?;
        self.send(&format!("go movetime {}", self.movetime_ms))?;
        let wait = Duration::from_millis(self.movetime_ms).saturating_add(self.timeout);
        let (line, mv) = self.wait_for("bestmove", wait, |line, parsed| match parsed {
            UciLine::BestMove { mv, .. } => Some((line.to_owned(), mv)),
            _ => None,
        })?;
        let Some(text) = mv else {
            return Err(OpponentError::Protocol { engine: self.label(), line });
        };
        text.parse::<UciMove>()
            .ok()
            .and_then(|uci| uci.to_move(position).ok())
            .ok_or_else(|| OpponentError::IllegalMove { engine: self.label(), uci: text, fen })
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
        // Whether or not it exits by itself, the rest of its process group is killed.
        self.wait_exit(EXIT_GRACE);
        self.terminate();
    }
}

/// Whether a write error means the engine is no longer reading its input.
fn is_pipe_closed(error: &io::Error) -> bool {
    matches!(error.kind(), io::ErrorKind::BrokenPipe | io::ErrorKind::ConnectionReset | io::ErrorKind::UnexpectedEof)
}

/// Lines buffered between the engine's output thread and the client.
const LINE_BUFFER: usize = 1024;

/// Forwards the engine's output line by line until it closes (or the receiver is gone). Never holds
/// more than [`MAX_UCI_LINE_BYTES`] + 1 bytes of one line: a longer line is reported as
/// [`Output::TooLong`] and ends the thread.
fn forward_lines(stdout: ChildStdout, lines: &SyncSender<Output>) {
    let mut reader = BufReader::new(stdout);
    let mut buffer = Vec::new();
    let limit = u64::try_from(MAX_UCI_LINE_BYTES).map_or(u64::MAX, |max| max.saturating_add(1));
    loop {
        buffer.clear();
        match (&mut reader).take(limit).read_until(b'\n', &mut buffer) {
            Ok(0) | Err(_) => return,
            Ok(_) => {
                // Without a newline, the line either hit the limit or is the last one before EOF.
                let text = match buffer.strip_suffix(b"\n") {
                    None if buffer.len() > MAX_UCI_LINE_BYTES => {
                        let _ = lines.send(Output::TooLong);
                        return;
                    }
                    Some(text) => text,
                    None => &buffer[..],
                };
                let line = String::from_utf8_lossy(text).trim_end().to_owned();
                if lines.send(Output::Line(line)).is_err() {
                    return;
                }
            }
        }
    }
}

/// Process control: on Linux, the engine leads a process group of its own, which is killed as a
/// whole; exits are detected without reaping the process, so that its id keeps naming the group until
/// the group has been killed.
#[cfg(target_os = "linux")]
mod process {
    use std::os::unix::process::CommandExt;
    use std::process::{Child, Command};

    use rustix::process::{Pid, Signal, WaitId, WaitIdOptions, kill_process_group, waitid};

    /// Starts the process as the leader of a new process group.
    pub(super) fn own_group(command: &mut Command) {
        command.process_group(0);
    }

    /// Whether the (not yet reaped) process has exited; it is left as a zombie for `Child::wait`.
    pub(super) fn has_exited(child: &mut Child) -> bool {
        let options = WaitIdOptions::EXITED | WaitIdOptions::NOHANG | WaitIdOptions::NOWAIT;
        // An error (no such child) means there is nothing left to wait for.
        waitid(WaitId::Pid(Pid::from_child(child)), options).map_or(true, |status| status.is_some())
    }

    /// Sends SIGKILL to the process group led by `child`. Must only be called before `child` is
    /// reaped: until then its id cannot be reused, so the group is the engine's.
    pub(super) fn kill_group(child: &Child) {
        // ESRCH (nobody left in the group) is the normal case after a clean exit.
        let _ = kill_process_group(Pid::from_child(child), Signal::KILL);
    }

    /// Sends SIGKILL to process group `id` (an engine not yet reaped, see `kill_group`).
    pub(super) fn kill_group_id(id: u32) {
        if let Some(pid) = i32::try_from(id).ok().and_then(Pid::from_raw) {
            let _ = kill_process_group(pid, Signal::KILL);
        }
    }
}

/// Process ids (= process-group ids) of the engines this process has started and not reaped.
static LIVE_GROUPS: Mutex<Vec<u32>> = Mutex::new(Vec::new());

fn live_groups() -> MutexGuard<'static, Vec<u32>> {
    LIVE_GROUPS.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Kills the process group of every engine still running, for a program that is about to exit
/// without dropping its [`UciEngine`]s (e.g. from a SIGINT/SIGTERM handler that calls
/// `std::process::exit`): an engine runs in its own process group, so a terminal's Ctrl-C does
/// not reach it, and its helpers would otherwise outlive the program. The engines are not
/// reaped; the exiting program's end does that.
pub fn kill_all_engines() {
    for &id in live_groups().iter() {
        process::kill_group_id(id);
    }
}

/// Process control elsewhere: only the engine process itself is watched and killed.
#[cfg(not(target_os = "linux"))]
mod process {
    use std::process::{Child, Command};

    pub(super) fn own_group(_command: &mut Command) {}

    /// Whether the process has exited (it is reaped; `Child::wait` then returns the saved status).
    pub(super) fn has_exited(child: &mut Child) -> bool {
        child.try_wait().map_or(true, |status| status.is_some())
    }

    pub(super) fn kill_group(_child: &Child) {}

    pub(super) fn kill_group_id(_id: u32) {}
}
