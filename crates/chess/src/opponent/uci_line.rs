//! A pure parser for the lines a UCI engine sends, shared by the client and the fuzz targets.
//!
//! Tokens are separated by any amount of whitespace (`char::is_whitespace`, so also tabs, carriage
//! returns and Unicode spaces), as the UCI protocol allows. The first token decides what the line is;
//! keywords are matched exactly (UCI keywords are lower case). Tokens after what a command defines are
//! ignored (`uciok junk` is `uciok`), as the protocol asks of unknown tokens.

use std::fmt;

/// One line from a UCI engine, parsed by [`parse_uci_line`].
///
/// Every string held here is canonical: whitespace-free tokens joined by single spaces (possibly
/// empty). Printing a parsed value ([`fmt::Display`]) gives a canonical line that parses back to the
/// same value: for every string `s`, `parse_uci_line(&parse_uci_line(s).to_string()) == parse_uci_line(s)`.
/// (Values built by hand with non-canonical strings, e.g. `Other("uciok")`, need not round-trip.)
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum UciLine {
    /// `id name <name>`: the tokens after `name` (empty if there are none).
    IdName(String),
    /// `id author <author>`: the tokens after `author` (empty if there are none).
    IdAuthor(String),
    /// `uciok`: the engine has sent all its `id` and `option` lines.
    UciOk,
    /// `readyok`: the answer to `isready`.
    ReadyOk,
    /// `bestmove [<move> [ponder <move>]]`. `mv` is `None` when the line has no move (a protocol
    /// violation the client reports); `ponder` is the token after a `ponder` keyword in third place.
    BestMove {
        /// The move token as sent (not checked here: the client checks it against the position).
        mv: Option<String>,
        /// The expected reply, if the engine named one.
        ponder: Option<String>,
    },
    /// `info ...`: the tokens after `info`.
    Info(String),
    /// Any other line (including an empty one): all its tokens.
    Other(String),
}

/// Parses one line sent by a UCI engine (without or with its line terminator). Never fails: lines
/// that are no known command are [`UciLine::Other`].
pub fn parse_uci_line(line: &str) -> UciLine {
    let mut tokens = line.split_whitespace();
    let rest = |tokens: std::str::SplitWhitespace<'_>| tokens.collect::<Vec<_>>().join(" ");
    match tokens.next() {
        Some("uciok") => UciLine::UciOk,
        Some("readyok") => UciLine::ReadyOk,
        Some("info") => UciLine::Info(rest(tokens)),
        Some("bestmove") => {
            let mv = tokens.next().map(str::to_owned);
            let ponder = match (tokens.next(), tokens.next()) {
                (Some("ponder"), Some(ponder)) if mv.is_some() => Some(ponder.to_owned()),
                _ => None,
            };
            UciLine::BestMove { mv, ponder }
        }
        Some("id") => {
            let mut after = tokens.clone();
            match after.next() {
                Some("name") => UciLine::IdName(rest(after)),
                Some("author") => UciLine::IdAuthor(rest(after)),
                _ => UciLine::Other(rest(line.split_whitespace())),
            }
        }
        _ => UciLine::Other(rest(line.split_whitespace())),
    }
}

/// Writes `keyword`, then ` rest` unless `rest` is empty.
fn keyword_and_rest(f: &mut fmt::Formatter<'_>, keyword: &str, rest: &str) -> fmt::Result {
    f.write_str(keyword)?;
    if rest.is_empty() { Ok(()) } else { write!(f, " {rest}") }
}

impl fmt::Display for UciLine {
    /// The canonical line: tokens separated by single spaces, no line terminator.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            UciLine::IdName(name) => keyword_and_rest(f, "id name", name),
            UciLine::IdAuthor(author) => keyword_and_rest(f, "id author", author),
            UciLine::UciOk => f.write_str("uciok"),
            UciLine::ReadyOk => f.write_str("readyok"),
            UciLine::BestMove { mv, ponder } => {
                f.write_str("bestmove")?;
                if let Some(mv) = mv {
                    write!(f, " {mv}")?;
                    if let Some(ponder) = ponder {
                        write!(f, " ponder {ponder}")?;
                    }
                }
                Ok(())
            }
            UciLine::Info(rest) => keyword_and_rest(f, "info", rest),
            UciLine::Other(text) => f.write_str(text),
        }
    }
}
