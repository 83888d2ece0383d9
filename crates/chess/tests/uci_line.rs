//! Tests of the pure UCI line parser `chessarm_chess::opponent::parse_uci_line`.

use chessarm_chess::opponent::{UciLine, parse_uci_line};
use proptest::prelude::*;

fn best(mv: Option<&str>, ponder: Option<&str>) -> UciLine {
    UciLine::BestMove { mv: mv.map(str::to_owned), ponder: ponder.map(str::to_owned) }
}

#[test]
fn known_lines_parse() {
    assert_eq!(parse_uci_line("uciok"), UciLine::UciOk);
    assert_eq!(parse_uci_line("  readyok\r\n"), UciLine::ReadyOk);
    assert_eq!(parse_uci_line("uciok and junk"), UciLine::UciOk, "unknown trailing tokens are ignored");
    assert_eq!(parse_uci_line("id name Stockfish 16.1"), UciLine::IdName("Stockfish 16.1".to_owned()));
    assert_eq!(parse_uci_line("id\tname   Fake \t Engine "), UciLine::IdName("Fake Engine".to_owned()));
    assert_eq!(parse_uci_line("id name"), UciLine::IdName(String::new()));
    assert_eq!(
        parse_uci_line("id author The Stockfish developers"),
        UciLine::IdAuthor("The Stockfish developers".into())
    );
    assert_eq!(parse_uci_line("id"), UciLine::Other("id".to_owned()));
    assert_eq!(parse_uci_line("id version 3"), UciLine::Other("id version 3".to_owned()));
    assert_eq!(parse_uci_line("bestmove e2e4 ponder e7e5"), best(Some("e2e4"), Some("e7e5")));
    assert_eq!(parse_uci_line("bestmove\te2e4"), best(Some("e2e4"), None));
    assert_eq!(parse_uci_line("bestmove e2e4 ponder"), best(Some("e2e4"), None));
    assert_eq!(parse_uci_line("bestmove e2e4 junk e7e5"), best(Some("e2e4"), None));
    assert_eq!(parse_uci_line("bestmove"), best(None, None), "kept so that the client can report it");
    assert_eq!(parse_uci_line("bestmove (none)"), best(Some("(none)"), None));
    assert_eq!(parse_uci_line("info depth 1 score cp 20"), UciLine::Info("depth 1 score cp 20".to_owned()));
    assert_eq!(parse_uci_line("info"), UciLine::Info(String::new()));
    // Keywords are matched exactly and only as the first token.
    assert_eq!(parse_uci_line("Bestmove e2e4"), UciLine::Other("Bestmove e2e4".to_owned()));
    assert_eq!(parse_uci_line("info string bestmove a1a1"), UciLine::Info("string bestmove a1a1".to_owned()));
    assert_eq!(parse_uci_line("Fake engine for tests"), UciLine::Other("Fake engine for tests".to_owned()));
    assert_eq!(parse_uci_line(""), UciLine::Other(String::new()));
    assert_eq!(parse_uci_line(" \t\r\n"), UciLine::Other(String::new()));
    // Unicode whitespace separates tokens too; other control characters are part of tokens.
    assert_eq!(parse_uci_line("uciok\u{a0}x"), UciLine::UciOk);
    assert_eq!(parse_uci_line("bestmove\u{3000}e2e4\u{0}"), best(Some("e2e4\u{0}"), None));
}

#[test]
fn display_is_canonical() {
    let cases = [
        ("  id   name  A  B ", "id name A B"),
        ("id name", "id name"),
        ("bestmove  e2e4\tponder  e7e5 extra", "bestmove e2e4 ponder e7e5"),
        ("bestmove", "bestmove"),
        ("info  depth 3", "info depth 3"),
        ("readyok now", "readyok"),
        ("\t hello \t world ", "hello world"),
        ("", ""),
    ];
    for (line, canonical) in cases {
        assert_eq!(parse_uci_line(line).to_string(), canonical, "{line:?}");
    }
}

/// Separators including tabs, carriage returns, a vertical tab and Unicode spaces.
fn separator() -> impl Strategy<Value = String> {
    prop::collection::vec(prop::sample::select(vec![" ", "\t", "\r", "\n", "\u{b}", "\u{a0}", "\u{3000}"]), 1..3)
        .prop_map(|parts| parts.concat())
}

/// Lines built from UCI keywords and arbitrary tokens, so that every branch of the parser is reached
/// (arbitrary strings almost never start with a keyword).
fn keyword_line() -> impl Strategy<Value = String> {
    let token = prop_oneof![
        prop::sample::select(vec!["bestmove", "ponder", "id", "name", "author", "info", "uciok", "readyok", "e2e4"])
            .prop_map(str::to_owned),
        any::<String>(),
    ];
    prop::collection::vec((separator(), token), 0..6).prop_map(|parts| parts.into_iter().map(|(s, t)| s + &t).collect())
}

proptest! {
    /// The documented round trip: printing a parsed line and parsing it again gives the same value,
    /// for any input (control characters and any Unicode included).
    #[test]
    fn parse_display_round_trip(line in prop_oneof![any::<String>(), keyword_line()]) {
        let parsed = parse_uci_line(&line);
        let printed = parsed.to_string();
        prop_assert_eq!(parse_uci_line(&printed), parsed.clone(), "printed {:?}", printed);
        // The canonical text is its own canonical form.
        prop_assert_eq!(parsed.to_string(), printed);
    }
}
