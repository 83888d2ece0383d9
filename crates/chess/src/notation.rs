//! Chess notation: games given as PGN files, as move lists (SAN or UCI) or as a FEN start position.
//!
//! Everything here produces a [`GameRecord`]: a legal start position and a list of legal moves.
//! Parse problems are reported as [`NotationError`]s whose one-line messages name the offending
//! value and, for moves, the game, the move number and the position (as FEN) in which it failed.
//!
//! [`parse_pgn`] parses a whole PGN text; [`read_game`] reads one game of a PGN from any reader,
//! stopping after it and bounding the memory used (for large databases or input that is not PGN).
//!
//! PGN parsing is done with `pgn-reader`: tags are kept, comments, NAGs and variations are ignored
//! (only the main line is played), `[FEN "..."]` tags give the start position, and a result token
//! (`1-0`, `0-1`, `1/2-1/2`, `*`) ends a game. Because `pgn-reader` silently skips tokens that are
//! not SAN, the movetext is also scanned here so that such tokens are reported instead of dropped.

use std::fmt;
use std::io::{self, Read};
use std::ops::ControlFlow;

use pgn_reader::{Outcome, RawComment, RawTag, Reader, SanPlus, Skip, Visitor};
use shakmaty::fen::Fen;
use shakmaty::san::SanError;
use shakmaty::uci::UciMove;
use shakmaty::{CastlingMode, Chess, Color, EnPassantMode, Move, Position};

/// A game to play: the start position and the moves, all legal.
#[derive(Debug, Clone)]
pub struct GameRecord {
    /// PGN tag pairs in file order (e.g. `("White", "Kasparov, Garry")`); empty for move lists.
    pub headers: Vec<(String, String)>,
    /// The position before the first move.
    pub start: Chess,
    /// The moves, each legal in the position reached by the moves before it.
    pub moves: Vec<Move>,
    /// Per move, the PGN comment after it (`None`: none; several are joined by a space);
    /// empty for move lists.
    pub comments: Vec<Option<String>>,
}

impl GameRecord {
    /// Value of the first header called `name` (exact, case-sensitive match), if any.
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers.iter().find(|(key, _)| key == name).map(|(_, value)| value.as_str())
    }

    /// SAN of every move (with `+`/`#` suffixes), computed from the positions.
    pub fn san_moves(&self) -> Vec<String> {
        let mut pos = self.start.clone();
        self.moves.iter().map(|&m| SanPlus::from_move_and_play_unchecked(&mut pos, m).to_string()).collect()
    }

    /// The position after the last move.
    pub fn final_position(&self) -> Chess {
        let mut pos = self.start.clone();
        for &m in &self.moves {
            pos.play_unchecked(m);
        }
        pos
    }
}

/// Why a move token was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MoveProblem {
    /// The token is not syntactically valid SAN (PGN movetext).
    NotSan,
    /// The token is neither syntactically valid SAN nor UCI (move lists).
    NotSanOrUci,
    /// The token is well-formed but matches no legal move.
    Illegal,
    /// The SAN matches several legal moves (missing disambiguation).
    Ambiguous,
}

impl fmt::Display for MoveProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            MoveProblem::NotSan => "is not valid SAN",
            MoveProblem::NotSanOrUci => "is not valid SAN or UCI",
            MoveProblem::Illegal => "is illegal",
            MoveProblem::Ambiguous => "is ambiguous",
        })
    }
}

impl From<SanError> for MoveProblem {
    fn from(err: SanError) -> Self {
        match err {
            SanError::IllegalSan => MoveProblem::Illegal,
            SanError::AmbiguousSan => MoveProblem::Ambiguous,
        }
    }
}

/// Errors of the notation parsers. Messages are one line and name the problem and the value.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NotationError {
    /// A FEN string given directly is malformed or describes an illegal position.
    #[error("invalid FEN '{fen}': {reason}")]
    InvalidFen {
        /// The FEN as given.
        fen: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The PGN text contains no game.
    #[error("no games in the PGN")]
    NoGames,
    /// [`select_game`] was asked for a game number outside `1..=count`.
    #[error("game {requested} requested but the file has {count} game{}", plural_s(.count))]
    NoSuchGame {
        /// The requested 1-based game number.
        requested: usize,
        /// The number of games available.
        count: usize,
    },
    /// The PGN is structurally broken (e.g. an unterminated comment or tag).
    #[error("game {game}: malformed PGN: {reason}")]
    MalformedPgn {
        /// 1-based game number.
        game: usize,
        /// What the PGN reader reported.
        reason: String,
    },
    /// The `[FEN]` tag of a game is malformed or describes an illegal position.
    #[error("game {game}: invalid FEN tag '{}': {reason}", .fen.escape_debug())]
    InvalidFenTag {
        /// 1-based game number.
        game: usize,
        /// The FEN tag value.
        fen: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The `[Variant]` tag names something other than standard chess.
    #[error("game {game}: variant '{}' is not supported (standard chess only)", .variant.escape_debug())]
    UnsupportedVariant {
        /// 1-based game number.
        game: usize,
        /// The variant tag value.
        variant: String,
    },
    /// A main-line move of a PGN game is not valid SAN, illegal or ambiguous.
    #[error("game {game}, move {}: '{san}' {problem} in {fen}", move_label(.number, .color))]
    PgnMove {
        /// 1-based game number.
        game: usize,
        /// Full-move number of the move.
        number: u32,
        /// Side to move.
        color: Color,
        /// The move text as written.
        san: String,
        /// What is wrong with it.
        problem: MoveProblem,
        /// The position before the move.
        fen: String,
    },
    /// The text of one game (from the end of the previous one) is longer than the limit of
    /// [`read_game_with_limit`] ([`MAX_PGN_GAME_BYTES`] for [`read_game`]).
    #[error("game {game} is longer than {} (is this a PGN file?)", byte_size(.max_bytes))]
    GameTooLong {
        /// 1-based number the game would have.
        game: usize,
        /// The limit, in bytes.
        max_bytes: usize,
    },
    /// A tag pair, from its `[` to its closing quote, is longer than [`MAX_PGN_TAG_BYTES`].
    #[error("game {game}: tag [{tag}] is longer than {max_bytes} bytes")]
    TagTooLong {
        /// 1-based game number.
        game: usize,
        /// The tag name as typed (whitespace trimmed; cut after 40 characters, marked with `…`).
        tag: String,
        /// The limit, [`MAX_PGN_TAG_BYTES`].
        max_bytes: usize,
    },
    /// Reading the PGN failed.
    #[error("cannot read the PGN: {reason}")]
    Io {
        /// The kind of the I/O error.
        kind: io::ErrorKind,
        /// The I/O error's message.
        reason: String,
    },
    /// An entry of a move list is not valid SAN/UCI, illegal or ambiguous.
    #[error("move {index} '{token}' (game move {}) {problem} in {fen}", move_short(.number, .color))]
    ListMove {
        /// 1-based index of the move in the list (move numbers and results not counted).
        index: usize,
        /// Full-move number of the move in the game.
        number: u32,
        /// Side to move.
        color: Color,
        /// The token as written.
        token: String,
        /// What is wrong with it.
        problem: MoveProblem,
        /// The position before the move.
        fen: String,
    },
}

/// `"14. (white)"` or `"14... (black)"`.
fn move_label(number: &u32, color: &Color) -> String {
    let dots = if color.is_white() { "." } else { "..." };
    format!("{number}{dots} ({color})")
}

/// `"14. white"` or `"14... black"`.
fn move_short(number: &u32, color: &Color) -> String {
    let dots = if color.is_white() { "." } else { "..." };
    format!("{number}{dots} {color}")
}

/// `"4 MiB"`, `"64 KiB"` or `"1000 bytes"`.
fn byte_size(bytes: &usize) -> String {
    const KIB: usize = 1024;
    const MIB: usize = 1024 * 1024;
    match *bytes {
        0 => "0 bytes".to_owned(),
        b if b.is_multiple_of(MIB) => format!("{} MiB", b / MIB),
        b if b.is_multiple_of(KIB) => format!("{} KiB", b / KIB),
        b => format!("{b} byte{}", plural_s(&b)),
    }
}

fn plural_s(count: &usize) -> &'static str {
    if *count == 1 { "" } else { "s" }
}

fn fen_of(pos: &Chess) -> String {
    Fen::from_position(pos, EnPassantMode::Legal).to_string()
}

/// Parses a FEN of a legal standard-chess position (castling rights in standard mode).
///
/// Leading and trailing whitespace is ignored.
pub fn parse_fen(fen: &str) -> Result<Chess, NotationError> {
    fen_to_position(fen.trim()).map_err(|reason| NotationError::InvalidFen { fen: fen.trim().to_owned(), reason })
}

fn fen_to_position(fen: &str) -> Result<Chess, String> {
    let parsed = Fen::from_ascii(fen.as_bytes()).map_err(|e| e.to_string())?;
    parsed.into_position(CastlingMode::Standard).map_err(|e| e.to_string())
}

/// Picks game `number` (1-based) out of `games`.
pub fn select_game(games: Vec<GameRecord>, number: usize) -> Result<GameRecord, NotationError> {
    let count = games.len();
    number
        .checked_sub(1)
        .and_then(|index| games.into_iter().nth(index))
        .ok_or(NotationError::NoSuchGame { requested: number, count })
}

/// Parses a move list played from `start`.
///
/// Tokens are separated by whitespace and/or commas. Each token is a move in SAN (`e4`, `Nf3`,
/// `O-O`, `0-0-0`, `exd6`, `e8=Q+`, `Qxf7#`, trailing `!`/`?` allowed) or UCI (`e2e4`, `e7e8q`,
/// `e1g1`). Move numbers (`1.`, `1...`, `12.`, also glued as in `1.e4`) and result tokens (`1-0`,
/// `0-1`, `1/2-1/2`, `*`) are skipped. The record has no headers.
pub fn parse_move_list(text: &str, start: Chess) -> Result<GameRecord, NotationError> {
    let mut pos = start.clone();
    let mut moves = Vec::new();
    for raw in text.split(|c: char| c.is_whitespace() || c == ',').filter(|t| !t.is_empty()) {
        let Some(token) = strip_move_number(raw) else { continue };
        if is_result(token) {
            continue;
        }
        match list_token_to_move(token, &pos) {
            Ok(m) => {
                pos.play_unchecked(m);
                moves.push(m);
            }
            Err(problem) => {
                return Err(NotationError::ListMove {
                    index: moves.len() + 1,
                    number: pos.fullmoves().get(),
                    color: pos.turn(),
                    token: token.to_owned(),
                    problem,
                    fen: fen_of(&pos),
                });
            }
        }
    }
    Ok(GameRecord { headers: Vec::new(), start, moves, comments: Vec::new() })
}

/// Removes a leading move number (`12.`, `12...`); `None` if nothing is left.
/// Tokens starting with digits but without a dot (e.g. `0-0`, `1-0`, `12`) are returned unchanged.
fn strip_move_number(token: &str) -> Option<&str> {
    let after_digits = token.trim_start_matches(|c: char| c.is_ascii_digit());
    if after_digits.len() == token.len() || !after_digits.starts_with('.') {
        return Some(token);
    }
    let rest = after_digits.trim_start_matches('.');
    if rest.is_empty() { None } else { Some(rest) }
}

fn is_result(token: &str) -> bool {
    matches!(token, "1-0" | "0-1" | "1/2-1/2" | "½-½" | "*")
}

/// One move typed in SAN (`Nf3`, `O-O`, `0-0`, `e8=Q`, trailing `+`/`#`/`!`/`?` allowed) or
/// UCI (`g1f3`, `e7e8q`), legal in `pos`.
///
/// # Errors
///
/// The token is neither, matches no legal move, or is ambiguous.
pub fn parse_move(token: &str, pos: &Chess) -> Result<Move, MoveProblem> {
    list_token_to_move(token.trim(), pos)
}

/// A game as PGN text: the Seven Tag Roster first (`?` where `headers` does not give one; the
/// `Result` tag is `result`), then the other `headers`, `SetUp`/`FEN` when `start` is not the
/// initial position; the moves in SAN, each followed by its comment if it has one (`}` in a
/// comment is replaced, as PGN comments cannot hold it), lines under 80 characters, the result
/// last.
pub fn write_pgn(
    headers: &[(String, String)],
    start: &Chess,
    moves: &[(Move, Option<String>)],
    result: &str,
) -> String {
    let escape = |v: &str| v.replace('\\', "\\\\").replace('"', "\\\"");
    let mut out = String::new();
    let given = |name: &str| headers.iter().find(|(k, _)| k == name).map(|(_, v)| v.as_str());
    for name in ["Event", "Site", "Date", "Round", "White", "Black"] {
        out.push_str(&format!("[{name} \"{}\"]\n", escape(given(name).unwrap_or("?"))));
    }
    out.push_str(&format!("[Result \"{result}\"]\n"));
    let initial = Chess::default();
    let custom_start = fen_of(start) != fen_of(&initial);
    for (name, value) in headers {
        let roster = ["Event", "Site", "Date", "Round", "White", "Black", "Result", "SetUp", "FEN"];
        if !roster.contains(&name.as_str()) {
            out.push_str(&format!("[{name} \"{}\"]\n", escape(value)));
        }
    }
    if custom_start {
        out.push_str("[SetUp \"1\"]\n");
        out.push_str(&format!("[FEN \"{}\"]\n", fen_of(start)));
    }
    out.push('\n');
    let mut tokens = Vec::new();
    let mut pos = start.clone();
    let mut after_comment = false;
    for (m, comment) in moves {
        let number = pos.fullmoves().get();
        if pos.turn() == Color::White {
            tokens.push(format!("{number}."));
        } else if after_comment || tokens.is_empty() {
            tokens.push(format!("{number}..."));
        }
        tokens.push(SanPlus::from_move_and_play_unchecked(&mut pos, *m).to_string());
        after_comment = false;
        if let Some(comment) = comment {
            tokens.push(format!("{{{}}}", comment.replace('}', ")")));
            after_comment = true;
        }
    }
    tokens.push(result.to_string());
    let mut line = String::new();
    for token in tokens {
        if !line.is_empty() && line.len() + 1 + token.len() > 79 {
            out.push_str(&line);
            out.push('\n');
            line.clear();
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(&token);
    }
    out.push_str(&line);
    out.push('\n');
    out
}

fn list_token_to_move(token: &str, pos: &Chess) -> Result<Move, MoveProblem> {
    let trimmed = token.trim_end_matches(['!', '?']);
    if let Ok(uci) = UciMove::from_ascii(trimmed.as_bytes()) {
        return uci.to_move(pos).map_err(|_| MoveProblem::Illegal);
    }
    // Castling written with zeros, as some sources do.
    let normalized;
    let san_text = if trimmed.starts_with("0-0") {
        normalized = trimmed.replace('0', "O");
        normalized.as_str()
    } else {
        trimmed
    };
    let san = SanPlus::from_ascii(san_text.as_bytes()).map_err(|_| MoveProblem::NotSanOrUci)?;
    san.san.to_move(pos).map_err(MoveProblem::from)
}

/// Largest accepted tag pair, in bytes from its `[` to its closing quote (or the end of its line).
/// The PGN standard limits lines to 255 bytes; real files exceed that now and then (long `Annotator`
/// or `Event` values). `pgn-reader` is configured to support tags this long everywhere (its buffer
/// stays at its default 16 KiB for this value), and longer ones are reported as
/// [`NotationError::TagTooLong`] instead of a confusing "unterminated tag".
pub const MAX_PGN_TAG_BYTES: usize = 8 * 1024;

/// Largest game [`read_game`] accepts, in bytes (its text from the end of the previous game). The
/// longest real games are a few tens of kilobytes with heavy annotation; this bounds the memory used
/// for a file that is not PGN at all (e.g. `/dev/zero`) while leaving ample room.
pub const MAX_PGN_GAME_BYTES: usize = 4 * 1024 * 1024;

/// Smallest read from the underlying reader; reads grow with the pending text.
const MIN_READ: usize = 64 * 1024;

/// Parses all games of a PGN file.
///
/// Headers are kept; comments, NAGs and variations are ignored (only the main line is played).
/// A `[FEN]` tag gives the start position (a `[Variant]` tag other than standard chess is
/// rejected). A result token ends a game. Fails on the first problem, naming the game, or with
/// [`NotationError::NoGames`] if the text holds no game. See [`read_game`] to read one game of a
/// large file without holding the file.
pub fn parse_pgn(text: &str) -> Result<Vec<GameRecord>, NotationError> {
    let bytes = text.as_bytes();
    let mut records = Vec::new();
    let mut games = 0;
    let mut at = bom_len(bytes);
    while at < bytes.len() {
        let chunk = scan_chunk(bytes, at);
        at = chunk.end;
        if chunk.has_content {
            parse_chunk(&chunk, &mut games, |_, record| {
                records.push(record);
                ControlFlow::Continue(())
            })?;
        }
    }
    if records.is_empty() { Err(NotationError::NoGames) } else { Ok(records) }
}

/// Reads game `number` (1-based) of a PGN from `reader`, without holding more than that game.
///
/// The same as [`parse_pgn`] followed by [`select_game`] on the same text (same numbering, records
/// and errors; [`NotationError::NoSuchGame`] with the true count when the file ends early,
/// [`NotationError::NoGames`] when it has none), except that:
/// - reading stops as soon as game `number` is complete, so problems in later games are not
///   reported (they are never read); for `number == 0` the whole input is read, as the count needs it;
/// - a game longer than [`MAX_PGN_GAME_BYTES`] is [`NotationError::GameTooLong`], so that
///   non-PGN input (`/dev/zero`) fails fast with bounded memory;
/// - the input is bytes: text that is not UTF-8 is decoded lossily (tags) or rejected as moves;
/// - read errors are [`NotationError::Io`] (unless the game was complete in what came before).
///
/// The input is read in blocks of at least 64 KiB (growing with a long game), each until it is full
/// or the input ends: on a pipe, reading waits for a block or the end of the input.
///
/// # Errors
///
/// Any [`NotationError`] of [`parse_pgn`] and [`select_game`], [`NotationError::GameTooLong`] and
/// [`NotationError::Io`].
pub fn read_game<R: io::Read>(reader: R, number: usize) -> Result<GameRecord, NotationError> {
    read_game_with_limit(reader, number, MAX_PGN_GAME_BYTES)
}

/// [`read_game`] with a limit of `max_game_bytes` per game instead of [`MAX_PGN_GAME_BYTES`].
///
/// The limit applies to the text of a game from the end of the previous one (leading whitespace
/// and comments included); the result does not depend on how the reader splits its data.
///
/// # Errors
///
/// As [`read_game`], with [`NotationError::GameTooLong`] naming `max_game_bytes`.
pub fn read_game_with_limit<R: io::Read>(
    mut reader: R,
    number: usize,
    max_game_bytes: usize,
) -> Result<GameRecord, NotationError> {
    // Text not yet consumed: it starts at a game boundary (or at the start of the file).
    let mut pending: Vec<u8> = Vec::new();
    let mut at_file_start = true;
    let mut eof = false;
    // A read error, reported once the text read before it has been used.
    let mut failure = None;
    let mut games = 0;
    loop {
        // A BOM is only looked for at the start of the file, once its first 3 bytes are there.
        let mut at = 0;
        let ready = !at_file_start || eof || pending.len() >= 3;
        if ready && at_file_start {
            at = bom_len(&pending);
            at_file_start = false;
        }
        while ready && at < pending.len() {
            let chunk = scan_chunk(&pending, at);
            let complete = eof || chunk.end < pending.len();
            // An incomplete chunk is at least as long as what is there of it.
            if chunk.end - at > max_game_bytes {
                return Err(NotationError::GameTooLong { game: games + 1, max_bytes: max_game_bytes });
            }
            if !complete {
                break;
            }
            at = chunk.end;
            if chunk.has_content {
                let mut found = None;
                parse_chunk(&chunk, &mut games, |game, record| {
                    if game == number {
                        found = Some(record);
                        ControlFlow::Break(())
                    } else {
                        ControlFlow::Continue(())
                    }
                })?;
                if let Some(record) = found {
                    return Ok(record);
                }
            }
        }
        pending.drain(..at);
        if eof {
            return Err(if games == 0 {
                NotationError::NoGames
            } else {
                NotationError::NoSuchGame { requested: number, count: games }
            });
        }
        if let Some(failure) = failure {
            return Err(failure);
        }
        // Reads grow with the pending text, so that rescanning an incomplete game stays amortised
        // (each rescan follows a doubling), and stop one byte past the limit.
        let room = (max_game_bytes + 1).saturating_sub(pending.len()).max(1);
        let want = pending.len().max(MIN_READ).min(room);
        let before = pending.len();
        let limit = u64::try_from(want).unwrap_or(u64::MAX);
        // On an error, what was read before it is in `pending` and is scanned first.
        match (&mut reader).take(limit).read_to_end(&mut pending) {
            Ok(_) => eof = pending.len() - before < want,
            Err(error) => failure = Some(NotationError::Io { kind: error.kind(), reason: error.to_string() }),
        }
    }
}

/// Length of a UTF-8 byte-order mark at the start of `bytes` (0 or 3).
fn bom_len(bytes: &[u8]) -> usize {
    if bytes.starts_with(b"\xef\xbb\xbf") { 3 } else { 0 }
}

/// Parses the games of one chunk, numbering them on from `games` (which counts them), and hands each
/// record with its number to `take` until it breaks. Fails on the chunk's first problem.
fn parse_chunk(
    chunk: &GameChunk<'_>,
    games: &mut usize,
    mut take: impl FnMut(usize, GameRecord) -> ControlFlow<()>,
) -> Result<(), NotationError> {
    if let Some(tag) = &chunk.long_tag {
        return Err(NotationError::TagTooLong { game: *games + 1, tag: tag.clone(), max_bytes: MAX_PGN_TAG_BYTES });
    }
    if let Some(reason) = &chunk.unbalanced {
        return Err(NotationError::MalformedPgn { game: *games + 1, reason: reason.clone() });
    }
    let mut reader = Reader::build(chunk.text).set_supported_tag_line_length(MAX_PGN_TAG_BYTES).finish();
    let mut visitor = GameVisitor;
    let mut first_of_chunk = true;
    loop {
        let game = *games + 1;
        let parsed = match reader.read_game(&mut visitor) {
            Ok(Some(parsed)) => parsed,
            Ok(None) => return Ok(()),
            Err(err) => return Err(malformed(game, &err)),
        };
        let bad_token = if first_of_chunk { chunk.bad_token.as_ref() } else { None };
        first_of_chunk = false;
        let record = finish_game(game, parsed, bad_token)?;
        *games = game;
        if take(game, record).is_break() {
            return Ok(());
        }
    }
}

fn malformed(game: usize, err: &io::Error) -> NotationError {
    NotationError::MalformedPgn { game, reason: err.to_string() }
}

/// Turns the visitor output into a record, or into the first error of the game.
fn finish_game(game: usize, parsed: ParsedGame, bad_token: Option<&BadToken>) -> Result<GameRecord, NotationError> {
    let ParsedGame { headers, start, moves, mut comments, failure } = parsed;
    comments.resize(moves.len(), None);
    let failed_at = match failure {
        Some(Failure::FenTag { fen, reason }) => return Err(NotationError::InvalidFenTag { game, fen, reason }),
        Some(Failure::Variant(variant)) => return Err(NotationError::UnsupportedVariant { game, variant }),
        Some(Failure::Move { ply, san, problem }) => Some((ply, san, problem)),
        None => None,
    };
    // Report whichever problem comes first in the main line: a token that is not SAN (which
    // pgn-reader skipped) or an illegal/ambiguous move.
    let (ply, san, problem) = match (bad_token, failed_at) {
        (Some(bad), failed) if bad.ply <= moves.len() && failed.as_ref().is_none_or(|(ply, ..)| bad.ply <= *ply) => {
            (bad.ply, bad.token.clone(), MoveProblem::NotSan)
        }
        (_, Some(failed)) => failed,
        (_, None) => return Ok(GameRecord { headers, start, moves, comments }),
    };
    let mut pos = start;
    for &m in moves.iter().take(ply) {
        pos.play_unchecked(m);
    }
    Err(move_error(game, &pos, san, problem))
}

fn move_error(game: usize, pos: &Chess, san: String, problem: MoveProblem) -> NotationError {
    NotationError::PgnMove { game, number: pos.fullmoves().get(), color: pos.turn(), san, problem, fen: fen_of(pos) }
}

/// What went wrong while visiting one game.
#[derive(Debug)]
enum Failure {
    FenTag { fen: String, reason: String },
    Variant(String),
    Move { ply: usize, san: String, problem: MoveProblem },
}

/// One game as produced by [`GameVisitor`]: the moves up to the first failure, if any.
#[derive(Debug, Default)]
struct ParsedGame {
    headers: Vec<(String, String)>,
    start: Chess,
    moves: Vec<Move>,
    comments: Vec<Option<String>>,
    failure: Option<Failure>,
}

/// Movetext state: the game so far and the current position.
#[derive(Debug, Default)]
struct Movetext {
    game: ParsedGame,
    pos: Chess,
}

/// `pgn-reader` visitor that plays the main line.
#[derive(Debug)]
struct GameVisitor;

impl Visitor for GameVisitor {
    type Tags = Vec<(String, String)>;
    type Movetext = Movetext;
    type Output = ParsedGame;

    fn begin_tags(&mut self) -> ControlFlow<Self::Output, Self::Tags> {
        ControlFlow::Continue(Vec::new())
    }

    fn tag(&mut self, tags: &mut Self::Tags, name: &[u8], value: RawTag<'_>) -> ControlFlow<Self::Output> {
        tags.push((String::from_utf8_lossy(name).into_owned(), value.decode_utf8_lossy().into_owned()));
        ControlFlow::Continue(())
    }

    fn begin_movetext(&mut self, tags: Self::Tags) -> ControlFlow<Self::Output, Self::Movetext> {
        let tag = |name: &str| tags.iter().find(|(k, _)| k.eq_ignore_ascii_case(name)).map(|(_, v)| v.trim());
        let start = if let Some(variant) = tag("Variant").filter(|v| !is_standard_variant(v)) {
            Err(Failure::Variant(variant.to_owned()))
        } else if let Some(fen) = tag("FEN") {
            fen_to_position(fen).map_err(|reason| Failure::FenTag { fen: fen.to_owned(), reason })
        } else {
            Ok(Chess::default())
        };
        match start {
            Ok(start) => ControlFlow::Continue(Movetext {
                game: ParsedGame {
                    headers: tags,
                    start: start.clone(),
                    moves: Vec::new(),
                    comments: Vec::new(),
                    failure: None,
                },
                pos: start,
            }),
            Err(failure) => ControlFlow::Break(ParsedGame {
                headers: tags,
                start: Chess::default(),
                moves: Vec::new(),
                comments: Vec::new(),
                failure: Some(failure),
            }),
        }
    }

    fn comment(&mut self, movetext: &mut Self::Movetext, comment: RawComment<'_>) -> ControlFlow<Self::Output> {
        let moves = movetext.game.moves.len();
        if moves > 0 {
            let text = String::from_utf8_lossy(comment.as_bytes()).trim().to_string();
            movetext.game.comments.resize(moves, None);
            let slot = &mut movetext.game.comments[moves - 1];
            *slot = Some(match slot.take() {
                Some(earlier) => format!("{earlier} {text}"),
                None => text,
            });
        }
        ControlFlow::Continue(())
    }

    fn san(&mut self, movetext: &mut Self::Movetext, san_plus: SanPlus) -> ControlFlow<Self::Output> {
        match san_plus.san.to_move(&movetext.pos) {
            Ok(m) => {
                movetext.pos.play_unchecked(m);
                movetext.game.moves.push(m);
                ControlFlow::Continue(())
            }
            Err(err) => {
                let mut game = std::mem::take(&mut movetext.game);
                game.failure =
                    Some(Failure::Move { ply: game.moves.len(), san: san_plus.to_string(), problem: err.into() });
                ControlFlow::Break(game)
            }
        }
    }

    fn begin_variation(&mut self, _movetext: &mut Self::Movetext) -> ControlFlow<Self::Output, Skip> {
        ControlFlow::Continue(Skip(true))
    }

    fn outcome(&mut self, movetext: &mut Self::Movetext, _outcome: Outcome) -> ControlFlow<Self::Output> {
        // The result token ends the game.
        ControlFlow::Break(std::mem::take(&mut movetext.game))
    }

    fn end_game(&mut self, movetext: Self::Movetext) -> Self::Output {
        movetext.game
    }
}

fn is_standard_variant(variant: &str) -> bool {
    ["standard", "chess", "normal", "from position", "fromposition"].iter().any(|v| variant.eq_ignore_ascii_case(v))
}

/// A main-line token that `pgn-reader` would skip silently because it is not SAN.
#[derive(Debug, Clone)]
struct BadToken {
    /// Number of valid main-line SAN tokens before it.
    ply: usize,
    token: String,
}

/// One game's text as cut by [`scan_chunk`], with what the scan noticed in it.
#[derive(Debug)]
struct GameChunk<'a> {
    text: &'a [u8],
    /// Index just after the chunk in the scanned bytes. If it is the end of the bytes, the chunk may
    /// go on in text not scanned yet (a boundary lies strictly inside the bytes).
    end: usize,
    /// Whether the chunk has tags, moves or a result (otherwise it is skipped).
    has_content: bool,
    /// The first main-line token that is not SAN.
    bad_token: Option<BadToken>,
    /// The name of the first tag longer than [`MAX_PGN_TAG_BYTES`].
    long_tag: Option<String>,
    /// What is wrong with the game's parentheses, if anything: a `)` that closes no variation, or
    /// a `(` never closed (which would swallow the rest of the game silently).
    unbalanced: Option<String>,
}

/// Bytes that end a movetext token, as in `pgn-reader`.
fn is_token_end(byte: u8) -> bool {
    matches!(byte, b' ' | b'\t' | b'\n' | b'\r' | b'{' | b'}' | b'(' | b')' | b'!' | b'?' | b'$' | b';' | b'.' | b'*')
}

/// Cuts the game starting at `start` out of `bytes`, following `pgn-reader`'s rules (a game's
/// movetext ends at a blank line or a line starting with `[`) and additionally ending a game after
/// its result token. Also records the first main-line token of the game that is not SAN, and the
/// first tag that is too long. Chunks without tags, moves or result (e.g. trailing whitespace or a
/// lone comment) have `has_content == false`.
///
/// Every decision that looks at the end of `bytes` (an unclosed comment, a token or line running to
/// the end, a newline as the last byte) leads to `end == bytes.len()`, and each chunk ends either
/// there or at a boundary strictly inside `bytes`. So a chunk with `end < bytes.len()` is the same
/// whatever follows, which is what lets [`read_game`] scan a growing buffer.
fn scan_chunk(bytes: &[u8], start: usize) -> GameChunk<'_> {
    let mut i = start;
    let mut has_content = false;
    let mut long_tag = None;

    // Tag section (and whitespace / escape lines before it).
    let mut line_start = true;
    while i < bytes.len() {
        match bytes[i] {
            b'\n' => {
                line_start = true;
                i += 1;
            }
            b' ' | b'\t' | b'\r' => i += 1,
            b'%' if line_start => i = line_end(bytes, i),
            b'[' => {
                has_content = true;
                let (next, too_long) = skip_tag(bytes, i);
                i = next;
                if long_tag.is_none() {
                    long_tag = too_long;
                }
                line_start = false;
            }
            _ => break,
        }
    }

    // Movetext.
    let mut depth = 0usize;
    let mut ply = 0usize;
    let mut bad_token = None;
    let mut unbalanced = None;
    let mut opened_after = 0usize;
    while i < bytes.len() {
        match bytes[i] {
            b'{' => i = bytes[i..].iter().position(|&b| b == b'}').map_or(bytes.len(), |p| i + p + 1),
            b';' => i = line_end(bytes, i),
            b'\n' => {
                i += 1;
                match bytes.get(i) {
                    Some(b'%') => i = line_end(bytes, i),
                    Some(b'[' | b'\n') => break,
                    Some(b'\r') if bytes.get(i + 1) == Some(&b'\n') => break,
                    _ => {}
                }
            }
            b'(' => {
                if depth == 0 {
                    opened_after = ply;
                }
                depth += 1;
                i += 1;
            }
            b')' => {
                if depth == 0 && unbalanced.is_none() {
                    unbalanced = Some(format!("a ')' after ply {ply} closes no variation"));
                }
                depth = depth.saturating_sub(1);
                i += 1;
            }
            b' ' | b'\t' | b'\r' | b'.' | b'!' | b'?' => i += 1,
            _ if depth > 0 => i += 1,
            b'$' => i = token_end(bytes, i + 1),
            _ => {
                // At least one byte, like pgn-reader (which skips a stray `}` as a bad token too).
                let end = token_end(bytes, i + 1);
                let token = String::from_utf8_lossy(&bytes[i..end]);
                i = end;
                if token == "*" || is_result(&token) {
                    has_content = true;
                    break;
                }
                // `pgn-reader` reads a leading move number (digits; the dots are separate tokens).
                let rest = if token.starts_with(|c: char| c.is_ascii_digit() && c != '0') {
                    token.trim_start_matches(|c: char| c.is_ascii_digit())
                } else {
                    &token
                };
                if rest.is_empty() {
                    continue;
                }
                has_content = true;
                let is_san = if rest.starts_with('0') {
                    // Castling written with zeros, read by pgn-reader itself.
                    matches!(rest, "0-0" | "0-0+" | "0-0#" | "0-0-0" | "0-0-0+" | "0-0-0#")
                } else {
                    matches!(SanPlus::from_ascii_prefix(rest.as_bytes()), Ok((_, len)) if len == rest.len())
                };
                if is_san {
                    ply += 1;
                } else if bad_token.is_none() {
                    bad_token = Some(BadToken { ply, token: token.into_owned() });
                }
            }
        }
    }
    if depth > 0 && unbalanced.is_none() {
        unbalanced = Some(format!(
            "a variation '(' opened after ply {opened_after} is never closed with ')' (the rest of the game would be skipped)"
        ));
    }
    GameChunk { text: &bytes[start..i], end: i, has_content, bad_token, long_tag, unbalanced }
}

/// Index of the `\n` ending the line containing `i` (or the end of the text).
fn line_end(bytes: &[u8], i: usize) -> usize {
    bytes[i..].iter().position(|&b| b == b'\n').map_or(bytes.len(), |p| i + p)
}

/// Index just after the token starting at `i`.
fn token_end(bytes: &[u8], i: usize) -> usize {
    bytes[i..].iter().position(|&b| is_token_end(b)).map_or(bytes.len(), |p| i + p)
}

/// Index after the tag pair starting with `[` at `i`: after its closing quote and `]`. Also the tag's
/// name if the tag is longer than [`MAX_PGN_TAG_BYTES`] up to its closing quote (or the end of its
/// line, or of the text), the part `pgn-reader` must see at once.
fn skip_tag(bytes: &[u8], i: usize) -> (usize, Option<String>) {
    let too_long = |terminator: usize, name_end: usize| {
        (terminator.saturating_add(1).min(bytes.len()) - i > MAX_PGN_TAG_BYTES)
            .then(|| tag_name(bytes, i + 1, name_end))
    };
    let mut j = i + 1;
    // Up to the opening quote; a line without one is skipped like pgn-reader does.
    while j < bytes.len() && !matches!(bytes[j], b'"' | b'\n' | b']') {
        j += 1;
    }
    let name_end = j;
    if j >= bytes.len() || bytes[j] != b'"' {
        return ((j + 1).min(bytes.len()), too_long(j, name_end));
    }
    j += 1;
    let terminator = loop {
        match bytes.get(j) {
            None => break bytes.len(),
            Some(b'\\') => j += 2,
            Some(b'"') => {
                j += 1;
                break j - 1;
            }
            Some(b'\n') => break j,
            Some(_) => j += 1,
        }
    };
    let long = too_long(terminator, name_end);
    let j = j.min(bytes.len());
    let after_spaces = j + bytes[j..].iter().take_while(|&&b| b == b' ' || b == b'\t').count();
    (if bytes.get(after_spaces) == Some(&b']') { after_spaces + 1 } else { j }, long)
}

/// The tag name between `start` and `end`, whitespace trimmed, cut after 40 characters.
fn tag_name(bytes: &[u8], start: usize, end: usize) -> String {
    const MAX_CHARS: usize = 40;
    // Enough bytes for 40 characters of up to 4 bytes, and more, so that the cut cannot split one.
    let shown = &bytes[start..end.min(start + 8 * MAX_CHARS)];
    let name = String::from_utf8_lossy(shown);
    let name = name.trim();
    if name.chars().count() > MAX_CHARS || end > start + 8 * MAX_CHARS {
        name.chars().take(MAX_CHARS).collect::<String>() + "…"
    } else {
        name.to_owned()
    }
}

#[cfg(test)]
mod pgn_writing {
    use super::*;

    /// A written game reads back: headers, a custom start, moves and their comments; a comment
    /// on White's move is followed by Black's number (`3...`).
    #[test]
    fn written_games_read_back() {
        let start = parse_fen("r1bqkbnr/pppp1ppp/2n5/4p3/4P3/5N2/PPPP1PPP/RNBQKB1R w KQkq - 2 3").unwrap();
        let record = parse_move_list("Bb5 a6 Ba4 Nf6 O-O Be7 Re1 b5 Bb3 d6 c3 O-O h3", start.clone()).unwrap();
        let moves: Vec<(Move, Option<String>)> = record
            .moves
            .iter()
            .enumerate()
            .map(|(i, m)| (*m, (i % 2 == 0).then(|| format!("robot {i}.25 s, clear {i} mm {{x}}"))))
            .collect();
        let headers = vec![
            ("White".to_string(), "A \"quoted\" person".to_string()),
            ("Annotator".to_string(), "chessarm".to_string()),
        ];
        let text = write_pgn(&headers, &start, &moves, "*");
        assert!(text.contains("3. Bb5 {robot 0.25 s, clear 0 mm {x)} 3... a6 4. Ba4"), "{text}");
        assert!(text.lines().all(|l| l.len() < 80), "{text}");
        let back = parse_pgn(&text).unwrap().remove(0);
        assert_eq!(back.moves, record.moves);
        assert_eq!(fen_of(&back.start), fen_of(&start));
        assert_eq!(back.header("White"), Some("A \"quoted\" person"));
        assert_eq!(back.header("Annotator"), Some("chessarm"));
        assert_eq!(back.header("Result"), Some("*"));
        let comments: Vec<Option<String>> =
            moves.iter().map(|(_, c)| c.as_ref().map(|c| c.replace('}', ")"))).collect();
        assert_eq!(back.comments, comments);
    }
}
