//! The property check of the UCI line parser target, apart from `checks.rs` because
//! `chessarm_chess::opponent::parse_uci_line` is new: this file is compiled only with the fuzz
//! crate's `uci` feature, and included by `crates/cli/tests/fuzz_corpus.rs` once switched on there.

use chessarm_chess::opponent::parse_uci_line;

/// UCI line parser: the input is an engine's output, read line by line (split at `\n`, so a
/// line may end in `\r`). Every line parses (to something), its printed form is one line, and
/// it parses back to the same value. Bytes that are not UTF-8 are replaced (lossy).
pub fn check_uci_line(data: &[u8]) {
    let input = String::from_utf8_lossy(data);
    for line in input.split('\n') {
        let parsed = parse_uci_line(line);
        let printed = parsed.to_string();
        assert!(!printed.contains('\n'), "UCI line {line:?} printed on several lines: {printed:?}");
        let again = parse_uci_line(&printed);
        assert!(again == parsed, "UCI line {line:?} printed as {printed:?} parses to {again:?}, not {parsed:?}");
    }
}
