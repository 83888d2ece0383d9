//! Tests of the streaming PGN reader `read_game` against `parse_pgn` + `select_game`, its limits
//! (games, tags) and its reads.
#![allow(clippy::unwrap_used)]

use std::io::{self, Read};
use std::time::{Duration, Instant};

use chessarm_chess::notation::{
    GameRecord, MAX_PGN_GAME_BYTES, MAX_PGN_TAG_BYTES, NotationError, parse_pgn, read_game, read_game_with_limit,
    select_game,
};
use proptest::prelude::*;
use shakmaty::EnPassantMode;
use shakmaty::fen::Fen;

const OPERA: &str = include_str!("fixtures/opera_game.pgn");
const OPERA_SAN_START: &str = "e4 e5 Nf3 d6 d4 Bg4";

/// What is compared of a record: SAN moves, headers and start FEN.
type Summary = (Vec<String>, Vec<(String, String)>, String);

fn summary(record: &GameRecord) -> Summary {
    (record.san_moves(), record.headers.clone(), Fen::from_position(&record.start, EnPassantMode::Legal).to_string())
}

/// A result reduced to what is compared; errors by their message (which names every field).
fn outcome(result: Result<GameRecord, NotationError>) -> Result<Summary, String> {
    result.as_ref().map(summary).map_err(ToString::to_string)
}

/// The game a problem is in, if the error is about one game.
fn error_game(error: &NotationError) -> Option<usize> {
    match error {
        NotationError::MalformedPgn { game, .. }
        | NotationError::InvalidFenTag { game, .. }
        | NotationError::UnsupportedVariant { game, .. }
        | NotationError::PgnMove { game, .. }
        | NotationError::GameTooLong { game, .. }
        | NotationError::TagTooLong { game, .. } => Some(*game),
        _ => None,
    }
}

/// `parse_pgn` + `select_game`, except that a problem in a game after `number` is not seen (as
/// `read_game` never reads that far): then game `number` is taken from the longest prefix of the text
/// that parses, which holds every game before the broken one complete (O(n²), for small texts).
fn reference(text: &str, number: usize) -> Result<Summary, String> {
    match parse_pgn(text) {
        Ok(games) => outcome(select_game(games, number)),
        Err(error) if number >= 1 && error_game(&error).is_some_and(|game| game > number) => {
            let prefix = (0..text.len())
                .rev()
                .filter(|&end| text.is_char_boundary(end))
                .find_map(|end| parse_pgn(&text[..end]).ok())
                .unwrap_or_else(|| panic!("no prefix of the text parses, yet {error}"));
            outcome(select_game(prefix, number))
        }
        Err(error) => Err(error.to_string()),
    }
}

/// Hands out one byte per `read` call.
struct OneByte<R>(R);

impl<R: Read> Read for OneByte<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match buf.first_mut() {
            Some(first) => self.0.read(std::slice::from_mut(first)),
            None => Ok(0),
        }
    }
}

/// Counts the bytes read through it.
struct Counting<R> {
    inner: R,
    bytes: usize,
}

impl<R: Read> Read for Counting<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.bytes += n;
        Ok(n)
    }
}

/// Every `.pgn` file in `tests/fixtures`, by name.
fn fixtures() -> Vec<(String, String)> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures");
    let mut files: Vec<(String, String)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .filter(|path| path.extension().is_some_and(|ext| ext == "pgn"))
        .map(|path| (path.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read_to_string(&path).unwrap()))
        .collect();
    files.sort();
    assert!(files.len() >= 7, "{files:?}");
    files
}

/// Checks `read_game` (whole reads, one byte per read, and a small game limit that forces small
/// reads and games split across them) against the reference for games 0..=10 of `text`.
fn check_all_numbers(name: &str, text: &str) {
    // Larger than any game of the fixtures (the longest file is under 1 KB), small enough that reads
    // are cut mid-game.
    const SMALL_LIMIT: usize = 1200;
    for number in 0..=10 {
        let expected = reference(text, number);
        let whole = outcome(read_game(text.as_bytes(), number));
        assert_eq!(whole, expected, "{name}, game {number}");
        let bytewise = outcome(read_game(OneByte(text.as_bytes()), number));
        assert_eq!(bytewise, expected, "{name}, game {number}, one byte per read");
        let small = outcome(read_game_with_limit(OneByte(text.as_bytes()), number, SMALL_LIMIT));
        assert_eq!(small, expected, "{name}, game {number}, limit {SMALL_LIMIT}");
    }
    // Game 10 is past the end (or the file fails before): every game number was covered.
    assert!(reference(text, 10).is_err(), "{name}: has a game 10");
}

#[test]
fn read_game_agrees_with_parse_pgn_on_every_fixture() {
    for (name, text) in fixtures() {
        check_all_numbers(&name, &text);
        check_all_numbers(&format!("{name} with CRLF"), &text.replace('\n', "\r\n"));
        check_all_numbers(&format!("{name} with a BOM"), &format!("\u{feff}{text}"));
    }
}

#[test]
fn read_game_agrees_on_edge_cases() {
    let texts = [
        "",
        " \n\n\t\n",
        "{ just a comment }\n",
        "\u{feff}",
        "\u{feff}1. e4 *",
        // A BOM between games is not skipped (by either).
        "1. e4 e5 1-0\n\u{feff}1. d4 d5 0-1",
        "1. e4 e5 1-0 1. d4 d5 0-1",
        "1. e4 e5 2. Qh9 Nc6 *",
        "[White \"A\"]\n\n1. e4 { never closed",
        "[Variant \"Chess960\"]\n\n1. e4 *\n",
        "1. e4 e5 *\n\n[Event \"x\"]\n\n1. e4 e4 *\n",
        "1. e4 e5 1-0",
        "1. e4 e5",
        "[Event \"no moves\"]",
        "[Event \"unterminated",
    ];
    for text in texts {
        check_all_numbers(&format!("{text:?}"), text);
    }
}

#[test]
fn a_bom_is_only_skipped_at_the_start_of_the_file() {
    let game = read_game("\u{feff}1. e4 *".as_bytes(), 1).unwrap();
    assert_eq!(game.san_moves(), ["e4"]);
    // Fed one byte at a time, the BOM's three bytes arrive in three reads.
    let game = read_game(OneByte("\u{feff}1. d4 *".as_bytes()), 1).unwrap();
    assert_eq!(game.san_moves(), ["d4"]);
    assert!(parse_pgn("1. e4 e5 1-0\n\u{feff}1. d4 d5 0-1").is_err());
    assert!(read_game("1. e4 e5 1-0\n\u{feff}1. d4 d5 0-1".as_bytes(), 2).is_err());
}

/// An endless supply of copies of one game (up to `total` bytes).
struct RepeatedGame {
    game: &'static [u8],
    offset: usize,
    left: usize,
}

impl Read for RepeatedGame {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let mut written = 0;
        while written < buf.len() && self.left > 0 {
            let part = &self.game[self.offset..];
            let n = part.len().min(buf.len() - written).min(self.left);
            buf[written..written + n].copy_from_slice(&part[..n]);
            written += n;
            self.left -= n;
            self.offset = (self.offset + n) % self.game.len();
        }
        Ok(written)
    }
}

#[test]
fn reading_one_game_of_a_huge_file_reads_only_a_prefix() {
    const TOTAL: usize = 50 * 1024 * 1024;
    let text = format!("{OPERA}\n");
    let game: &'static [u8] = Box::leak(text.into_bytes().into_boxed_slice());
    for number in [1, 3] {
        let mut reader = Counting { inner: RepeatedGame { game, offset: 0, left: TOTAL }, bytes: 0 };
        let record = read_game(&mut reader, number).unwrap();
        assert!(record.san_moves().join(" ").starts_with(OPERA_SAN_START));
        assert_eq!(record.moves.len(), 33);
        assert!(reader.bytes < 1024 * 1024, "read {} bytes of {TOTAL} for game {number}", reader.bytes);
    }
}

#[test]
fn non_pgn_input_is_too_long_fast() {
    for byte in [0u8, b'a', b' ', b'['] {
        let start = Instant::now();
        let mut reader = Counting { inner: io::repeat(byte), bytes: 0 };
        let err = read_game(&mut reader, 1).unwrap_err();
        assert_eq!(err, NotationError::GameTooLong { game: 1, max_bytes: MAX_PGN_GAME_BYTES }, "byte {byte}");
        assert_eq!(err.to_string(), "game 1 is longer than 4 MiB (is this a PGN file?)");
        // Never more than the limit and a byte are held (reads stop there).
        assert!(reader.bytes <= MAX_PGN_GAME_BYTES + 1, "read {} bytes", reader.bytes);
        // Scanning ~8 MB in total takes well under a second even unoptimised; 5 s for a loaded machine.
        assert!(start.elapsed() < Duration::from_secs(5), "byte {byte}: took {:?}", start.elapsed());
    }
    let err = read_game_with_limit(io::repeat(b'a'), 1, 1000).unwrap_err();
    assert_eq!(err.to_string(), "game 1 is longer than 1000 bytes (is this a PGN file?)");
}

#[test]
fn a_game_too_long_after_good_games() {
    let text = format!("{OPERA}\n{OPERA}\n{{{}}}\n1. e4 *\n", "x".repeat(5000));
    assert_eq!(read_game_with_limit(text.as_bytes(), 2, 2000).unwrap().moves.len(), 33);
    let err = read_game_with_limit(text.as_bytes(), 3, 2000).unwrap_err();
    assert_eq!(err, NotationError::GameTooLong { game: 3, max_bytes: 2000 });
    let err = read_game_with_limit(OneByte(text.as_bytes()), 3, 2000).unwrap_err();
    assert_eq!(err, NotationError::GameTooLong { game: 3, max_bytes: 2000 });
    // Within the default limit the long comment is fine.
    assert_eq!(read_game(text.as_bytes(), 3).unwrap().san_moves(), ["e4"]);
}

/// Gives `data`, then fails.
struct FailingAfter(&'static [u8]);

impl Read for FailingAfter {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.0.is_empty() {
            return Err(io::Error::other("disk on fire"));
        }
        let n = self.0.read(buf)?;
        Ok(n)
    }
}

#[test]
fn read_errors_are_reported() {
    let err = read_game(FailingAfter(b"1. e4 e5 2. Nf3"), 1).unwrap_err();
    assert_eq!(err, NotationError::Io { kind: io::ErrorKind::Other, reason: "disk on fire".to_owned() });
    assert_eq!(err.to_string(), "cannot read the PGN: disk on fire");
    // A game complete before the failure is returned (the rest is not needed). With whole reads the
    // failure comes with the read that would fill the buffer, so one byte per read is what shows this.
    let game = read_game(OneByte(FailingAfter(b"1. e4 e5 1-0 1. d4")), 1).unwrap();
    assert_eq!(game.san_moves(), ["e4", "e5"]);
}

// ---------------------------------------------------------------------------------------------------
// Tags too long for pgn-reader
// ---------------------------------------------------------------------------------------------------

#[test]
fn a_huge_tag_value_is_named_not_unterminated() {
    let text = format!("[Event \"{}\"]\n[White \"A\"]\n\n1. e4 *\n", "v".repeat(1_000_000));
    let expected = NotationError::TagTooLong { game: 1, tag: "Event".to_owned(), max_bytes: MAX_PGN_TAG_BYTES };
    assert_eq!(parse_pgn(&text).unwrap_err(), expected);
    assert_eq!(read_game(text.as_bytes(), 1).unwrap_err(), expected);
    assert_eq!(expected.to_string(), "game 1: tag [Event] is longer than 8192 bytes");

    // In the second game, and without a closing quote (the line ends the value).
    let text = format!("{OPERA}\n[Annotator \"{}\n[White \"A\"]\n\n1. e4 *\n", "v".repeat(20_000));
    let err = parse_pgn(&text).unwrap_err();
    assert_eq!(err.to_string(), "game 2: tag [Annotator] is longer than 8192 bytes");
    assert_eq!(read_game(text.as_bytes(), 1).unwrap().moves.len(), 33);
    assert_eq!(read_game(text.as_bytes(), 2).unwrap_err(), err);

    // A huge name is cut.
    let text = format!("[{} \"x\"]\n\n1. e4 *\n", "N".repeat(1_000_000));
    let err = parse_pgn(&text).unwrap_err();
    assert_eq!(err.to_string(), format!("game 1: tag [{}…] is longer than 8192 bytes", "N".repeat(40)));
}

#[test]
fn tags_up_to_the_limit_parse_wherever_they_are() {
    // `[Event "` is 8 bytes and the closing quote 1: a value of limit - 9 bytes makes a tag of exactly
    // the limit.
    let value = |bytes: usize| "v".repeat(bytes);
    // ~10 KB of tags first, so that the long one starts deep into pgn-reader's 16 KiB buffer and
    // runs past its end: pgn-reader refills only when fewer than its guaranteed tag length is left
    // (255 bytes by default, which made this tag "unterminated").
    let filler: String = (0..90).map(|i| format!("[Tag{i} \"{}\"]\n", value(100))).collect();
    assert!((9_000..12_000).contains(&filler.len()), "{}", filler.len());
    let exact = format!("{filler}[Event \"{}\"]\n\n1. e4 *\n", value(MAX_PGN_TAG_BYTES - 9));
    let game = parse_pgn(&exact).unwrap().remove(0);
    assert_eq!(game.header("Event").map(str::len), Some(MAX_PGN_TAG_BYTES - 9));
    assert_eq!(read_game(exact.as_bytes(), 1).unwrap().headers.len(), 91);
    let over = format!("{filler}[Event \"{}\"]\n\n1. e4 *\n", value(MAX_PGN_TAG_BYTES - 8));
    assert!(matches!(parse_pgn(&over).unwrap_err(), NotationError::TagTooLong { ref tag, .. } if tag == "Event"));
}

// ---------------------------------------------------------------------------------------------------
// Random files made of fixture games
// ---------------------------------------------------------------------------------------------------

/// The single games of all fixtures (files are cut before every tag section after a blank line).
fn fixture_games() -> Vec<String> {
    let mut games = Vec::new();
    for (_, text) in fixtures() {
        for (index, piece) in text.split("\n\n[").enumerate() {
            let piece = if index == 0 { piece.to_owned() } else { format!("[{piece}") };
            if parse_pgn(&piece).is_ok() || piece.contains("Illegal") {
                games.push(piece.trim().to_owned());
            }
        }
    }
    assert!(games.len() >= 10, "{games:?}");
    games
}

/// Whitespace and comments between games; ends with a newline so that tags start a line.
fn separator() -> impl Strategy<Value = String> {
    let part = prop::sample::select(vec![" ", "\t", "\n", "\r\n", "\n\n", "{ a comment [Event \"no\"] }", "; rest\n"]);
    prop::collection::vec(part, 0..5).prop_map(|parts| parts.concat() + "\n")
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Random concatenations of fixture games, with random whitespace and comments between them:
    /// `read_game` equals `parse_pgn` + `select_game` for every game number, with whole reads and
    /// one byte per read, and with a random small game limit (reads cut mid-game).
    #[test]
    fn random_files_of_fixture_games(
        picks in prop::collection::vec((any::<prop::sample::Index>(), separator()), 0..7),
        bom in any::<bool>(),
        limit in 1000usize..3000,
    ) {
        let games = fixture_games();
        let chosen: Vec<(&String, String)> = picks.iter().map(|(index, sep)| (index.get(&games), sep.clone())).collect();
        let text: String = (if bom { "\u{feff}" } else { "" }).to_owned()
            + &chosen.iter().map(|(game, sep)| format!("{sep}{game}")).collect::<String>();
        let whole = parse_pgn(&text);
        for number in 0..=chosen.len() + 1 {
            // Game n is the n-th piece; if a later piece is broken, the reference is the file cut
            // after piece n (cheaper than the longest parsing prefix, and the same).
            let expected = match &whole {
                Err(error) if number >= 1 && error_game(error).is_some_and(|game| game > number) => {
                    let prefix: String = chosen[..number].iter().map(|(game, sep)| format!("{sep}{game}")).collect();
                    outcome(select_game(parse_pgn(&prefix).unwrap(), number))
                }
                Ok(records) => outcome(select_game(records.clone(), number)),
                Err(error) => Err(error.to_string()),
            };
            prop_assert_eq!(&outcome(read_game(text.as_bytes(), number)), &expected, "game {}", number);
            prop_assert_eq!(&outcome(read_game(OneByte(text.as_bytes()), number)), &expected, "game {}", number);
            let small = outcome(read_game_with_limit(text.as_bytes(), number, limit));
            prop_assert_eq!(&small, &expected, "game {}, limit {}", number, limit);
        }
    }
}
