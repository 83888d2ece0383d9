//! The person's side of the board: what they type, or what the board's sensors read, one line
//! at a time from standard input or a local socket.
//!
//! Typed: a move in SAN or UCI (`e4`, `Nf3`, `O-O`, `e7e8q`), or `undo` (take back your last
//! move and the arm's reply), `resign`, `draw` (offer one), `quit` (stop; the game is saved and
//! can be resumed). Occupancy: a reading of the board after the person's move
//! ([`chessarm_chess::occupancy`]), resolved against the legal moves; a promotion is asked
//! (`q`, `r`, `b` or `n` on the next line), and the typed words work there too. A line that
//! gives no move is answered with why and what was expected, and the next line is read:
//! nothing is played until a line gives a legal move.

use anyhow::{Context, Result};
use chessarm_chess::notation::parse_move;
use chessarm_chess::occupancy::{MoveReader, Resolved, parse_reading};
use chessarm_chess::shakmaty::{Chess, Move, Role};
use std::io::BufRead;

/// Longest line read, bytes (a reading is 64 characters; a FEN board field under 100). A
/// longer line is no person's move and no board's reading: the input ends with an error.
pub const MAX_LINE: usize = 4096;
/// Refused lines kept for the game's record (the first ones), and characters kept of each;
/// the rest are only counted.
pub const REFUSED_KEPT: usize = 100;
/// Lines refused in a row after which the input is taken for something else than a person's
/// moves or a board's readings (random bytes, a log): the game ends, saved. A person mistypes a
/// few times; a board's sensors, read after each move, a few more.
pub const REFUSED_IN_A_ROW: usize = 1000;
const REFUSED_CHARS: usize = 200;

pub use crate::cli::HumanInput;

/// What the person did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Action {
    Move(Move),
    Undo,
    Resign,
    /// Offered a draw.
    Draw,
    /// Stopped (or the input ended): the game is saved, resumable.
    Quit,
}

/// The words the person may type instead of a move, at every prompt.
fn word(line: &str) -> Option<Action> {
    match line.to_ascii_lowercase().as_str() {
        "undo" | "takeback" => Some(Action::Undo),
        "resign" => Some(Action::Resign),
        "draw" => Some(Action::Draw),
        "quit" | "exit" => Some(Action::Quit),
        _ => None,
    }
}

/// The lines refused, for the game's record: the first [`REFUSED_KEPT`] (each cut to 200
/// characters, control characters escaped), and how many there were and their bytes.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Refused {
    pub kept: Vec<String>,
    pub lines: usize,
    pub bytes: usize,
}

/// The person's input: a line source and how to read it.
pub struct Person {
    kind: HumanInput,
    lines: Box<dyn BufRead + Send>,
    reader: MoveReader,
    /// What was refused (for the game's record).
    pub refused: Refused,
    /// Lines refused since the person's last action.
    in_a_row: usize,
}

impl std::fmt::Debug for Person {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Person").field("kind", &self.kind).finish_non_exhaustive()
    }
}

impl Person {
    pub fn new(kind: HumanInput, lines: Box<dyn BufRead + Send>) -> Self {
        Self { kind, lines, reader: MoveReader::default(), refused: Refused::default(), in_a_row: 0 }
    }

    /// The next line (trimmed), `None` at the end of the input.
    ///
    /// # Errors
    ///
    /// The input cannot be read, or a line runs past [`MAX_LINE`] bytes without ending (a
    /// file of zeros, a device, a stream that is not lines of moves).
    fn line(&mut self) -> Result<Option<String>> {
        let mut buffer = Vec::new();
        let n = std::io::Read::take(&mut self.lines, MAX_LINE as u64 + 1)
            .read_until(b'\n', &mut buffer)
            .context("reading the person's input")?;
        if n == 0 {
            return Ok(None);
        }
        if n > MAX_LINE && buffer.last() != Some(&b'\n') {
            anyhow::bail!(
                "the person's input has a line of over {MAX_LINE} bytes without a line end (it starts '{}'): it is not moves typed or a board's readings; the game is saved",
                crate::app::text::escape_controls(&String::from_utf8_lossy(&buffer[..buffer.len().min(40)]))
            );
        }
        Ok(Some(String::from_utf8_lossy(&buffer).trim().to_string()))
    }

    /// Refuses `line` (said on standard error with why, control characters escaped) and keeps
    /// it for the record, within bounds.
    ///
    /// # Errors
    ///
    /// [`REFUSED_IN_A_ROW`] lines in a row were refused.
    fn refuse(&mut self, line: &str, why: &str) -> Result<()> {
        self.in_a_row += 1;
        if self.in_a_row > REFUSED_IN_A_ROW {
            anyhow::bail!(
                "the person's input gave no move in {REFUSED_IN_A_ROW} lines in a row (the last: '{}'): it is not moves typed or a board's readings; the game is saved",
                crate::app::text::escape_controls(&line.chars().take(40).collect::<String>())
            );
        }
        let why = crate::app::text::escape_controls(why);
        crate::tell(&format!("not played: {why}\n"));
        self.refused.lines += 1;
        self.refused.bytes += line.len();
        if self.refused.kept.len() < REFUSED_KEPT {
            let entry = format!("{}: {why}", crate::app::text::escape_controls(line));
            self.refused.kept.push(entry.chars().take(REFUSED_CHARS).collect());
        }
        Ok(())
    }

    /// The person's next action in `position`; lines that give none are refused (said on
    /// standard error) and the next one read.
    ///
    /// # Errors
    ///
    /// The input could not be read, or is not lines (see [`Person::line`]).
    pub fn next(&mut self, position: &Chess) -> Result<Action> {
        // A new move: what the sensors saw before (the arm's own move) is not part of it.
        self.reader.reset();
        self.in_a_row = 0;
        loop {
            let Some(line) = self.line()? else { return Ok(Action::Quit) };
            // Blank lines and comments (a recorded session's notes).
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            if let Some(action) = word(&line) {
                return Ok(action);
            }
            let shown = crate::app::text::escape_controls(&line);
            match self.kind {
                HumanInput::Typed => match parse_move(&line, position) {
                    Ok(m) => return Ok(Action::Move(m)),
                    Err(problem) => {
                        let why = format!(
                            "'{shown}' {problem} in this position (type a move in SAN or UCI, undo, resign, draw or quit)"
                        );
                        self.refuse(&line, &why)?;
                    }
                },
                HumanInput::Occupancy => {
                    let resolved = parse_reading(&line).and_then(|reading| self.reader.read(position, &reading));
                    let chosen = match resolved {
                        Ok(Resolved::Unchanged | Resolved::InProgress) => continue,
                        Ok(Resolved::Move(m)) => Action::Move(m),
                        Ok(Resolved::Promotion(choices)) => self.promotion(&choices)?,
                        Ok(Resolved::Choice(choices)) => self.which(position, &choices)?,
                        Err(error) => {
                            self.refuse(&line, &error.to_string())?;
                            continue;
                        }
                    };
                    self.reader.reset();
                    return Ok(chosen);
                }
            }
        }
    }

    /// Asks which of several captures that read alike was made: the move typed (SAN or UCI) on
    /// the next line, or one of the typed words; [`Action::Quit`] if the input ends.
    fn which(&mut self, position: &Chess, choices: &[Move]) -> Result<Action> {
        let names: Vec<String> =
            choices.iter().map(|m| chessarm_chess::shakmaty::san::San::from_move(position, *m).to_string()).collect();
        loop {
            crate::tell(&format!(
                "the board reads alike after {}: which was it? (type it, or undo, resign, draw or quit; lift the taken piece first next time)\n",
                names.join(", ")
            ));
            let Some(line) = self.line()? else { return Ok(Action::Quit) };
            if let Some(action) = word(&line) {
                return Ok(action);
            }
            match parse_move(&line, position) {
                Ok(m) if choices.contains(&m) => return Ok(Action::Move(m)),
                _ => {
                    let why =
                        format!("'{}' is not one of {}", crate::app::text::escape_controls(&line), names.join(", "));
                    self.refuse(&line, &why)?;
                }
            }
        }
    }

    /// Asks which piece a pawn becomes: `q`, `r`, `b` or `n` (or the piece's name) on the next
    /// line, or one of the typed words; [`Action::Quit`] if the input ends.
    fn promotion(&mut self, choices: &[Move]) -> Result<Action> {
        loop {
            crate::tell("promotion: which piece does the pawn become (q, r, b, n; or undo, resign, draw, quit)?\n");
            let Some(line) = self.line()? else { return Ok(Action::Quit) };
            if let Some(action) = word(&line) {
                return Ok(action);
            }
            let role = match line.to_ascii_lowercase().as_str() {
                "q" | "queen" => Some(Role::Queen),
                "r" | "rook" => Some(Role::Rook),
                "b" | "bishop" => Some(Role::Bishop),
                "n" | "knight" => Some(Role::Knight),
                _ => None,
            };
            match role.and_then(|r| choices.iter().find(|m| m.promotion() == Some(r))) {
                Some(m) => return Ok(Action::Move(*m)),
                None => {
                    let why = format!("'{}' is not q, r, b or n", crate::app::text::escape_controls(&line));
                    self.refuse(&line, &why)?;
                }
            }
        }
    }
}

/// The person's lines: standard input, a file (or named pipe) at `file`, or a Unix socket at
/// `socket` that chessarm creates,
/// listens on (one client at a time: a reader program connects and writes lines) and removes
/// when the game ends. An existing file at `path` is refused, not replaced.
///
/// # Errors
///
/// The socket cannot be made.
pub fn lines_from(
    socket: Option<&std::path::Path>,
    file: Option<&std::path::Path>,
) -> Result<(Box<dyn BufRead + Send>, Option<SocketFile>)> {
    if let Some(path) = file {
        let opened =
            std::fs::File::open(path).with_context(|| format!("--input-file {}: cannot read it", path.display()))?;
        return Ok((Box::new(std::io::BufReader::new(opened)), None));
    }
    let Some(path) = socket else {
        return Ok((Box::new(std::io::BufReader::new(std::io::stdin())), None));
    };
    if stale_socket(path) {
        // Left by a run that a signal no program can catch ended (SIGKILL, SIGQUIT): a socket
        // nobody listens on is nobody's, and is replaced.
        crate::tell(&format!("--input-socket {}: replacing a socket nobody listens on\n", path.display()));
        std::fs::remove_file(path)
            .with_context(|| format!("--input-socket {}: cannot remove the old socket", path.display()))?;
    }
    if path.exists() || path.is_symlink() {
        anyhow::bail!(
            "--input-socket {}: a file is there; give a path where chessarm may create its socket",
            path.display()
        );
    }
    let listener = std::os::unix::net::UnixListener::bind(path)
        .with_context(|| format!("--input-socket {}: cannot create the socket", path.display()))?;
    crate::app::output::remove_at_exit(path);
    let file = SocketFile(path.to_path_buf());
    crate::tell(&format!("waiting for the board's reader to connect to {}\n", path.display()));
    let (stream, _) = listener.accept().with_context(|| format!("--input-socket {}", path.display()))?;
    Ok((Box::new(std::io::BufReader::new(stream)), Some(file)))
}

/// Whether `path` is a Unix socket (not a link, not a file) that no program has open: the
/// kernel's list of bound sockets (`/proc/net/unix`) does not name it. (Connecting to find out
/// would be taken by a live run as its board's reader.) Unknown, when the list cannot be read:
/// not stale.
fn stale_socket(path: &std::path::Path) -> bool {
    use std::os::unix::fs::FileTypeExt;
    let is_socket = std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_socket());
    if !is_socket {
        return false;
    }
    let (Ok(bound), Ok(absolute)) = (std::fs::read_to_string("/proc/net/unix"), std::path::absolute(path)) else {
        return false;
    };
    let canonical = std::fs::canonicalize(path).unwrap_or_else(|_| absolute.clone());
    let names = [absolute.to_string_lossy().into_owned(), canonical.to_string_lossy().into_owned()];
    // Each line ends with the socket's path, when it has one; a path bound relative to a
    // process's folder is listed as given, so any line ending in the file's name counts as live.
    let file_name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    !bound.lines().skip(1).any(|line| {
        let listed = line.split_whitespace().nth(7).unwrap_or("");
        names.iter().any(|n| n == listed) || (!file_name.is_empty() && listed.ends_with(file_name.as_str()))
    })
}

/// The socket file chessarm made; removed when dropped (and by the signal handler on Ctrl-C
/// or a termination signal).
#[derive(Debug)]
pub struct SocketFile(std::path::PathBuf);

impl Drop for SocketFile {
    fn drop(&mut self) {
        crate::app::output::remove_now(&self.0);
    }
}
