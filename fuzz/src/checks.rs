//! The property checks of the fuzz targets, one `check_*` function per target.
//!
//! This file is also included by path in `crates/cli/tests/fuzz_corpus.rs`, which runs the
//! committed corpora as ordinary tests, so it uses only what that test crate has: the
//! `chessarm` library, `chessarm_chess` and the `shakmaty` it re-exports.
//!
//! Every check takes the raw input bytes. Bytes that are not UTF-8 are replaced by U+FFFD
//! (lossy conversion) rather than skipped, so that mutations that break UTF-8 still reach the
//! parsers. No input is skipped for its size: the parsers are meant to take time and memory
//! linear in their input, which the run script bounds with `-timeout` and `-malloc_limit_mb`.
//! A check returns when the input is rejected cleanly or every property holds, and panics
//! (failing the fuzz target or the test) when a property fails.

use std::borrow::Cow;

use chessarm::args;
use chessarm::config::Setup;
use chessarm_chess::notation::{self, GameRecord};
use chessarm_chess::shakmaty::fen::Fen;
use chessarm_chess::shakmaty::{CastlingMode, Chess, EnPassantMode};

fn text(data: &[u8]) -> Cow<'_, str> {
    String::from_utf8_lossy(data)
}

fn fen_of(pos: &Chess) -> String {
    Fen::from_position(pos, EnPassantMode::Legal).to_string()
}

fn has_line_break(text: &str) -> bool {
    text.contains('\n')
}

/// Error messages are one line; those that quote their input verbatim only when it is one line.
fn assert_one_line(message: &str, input: &str) {
    assert!(
        !has_line_break(message) || has_line_break(input),
        "error message of {input:?} is not one line: {message:?}"
    );
}

/// FEN: a parsed position printed as FEN parses back to the same FEN; errors are one line.
pub fn check_fen(data: &[u8]) {
    let input = text(data);
    match notation::parse_fen(&input) {
        Ok(pos) => {
            let fen = fen_of(&pos);
            let again = notation::parse_fen(&fen)
                .unwrap_or_else(|e| panic!("FEN {fen:?} printed from {input:?} does not parse: {e}"));
            assert_eq!(fen_of(&again), fen, "FEN round trip of {input:?}");
        }
        Err(e) => assert_one_line(&e.to_string(), &input),
    }
}

/// The moves of `record`, printed as SAN and as UCI, parse back to the same moves from its start.
fn assert_moves_round_trip(record: &GameRecord, input: &str) {
    let san = record.san_moves().join(" ");
    let again = notation::parse_move_list(&san, record.start.clone())
        .unwrap_or_else(|e| panic!("SAN {san:?} printed from {input:?} does not parse: {e}"));
    assert_eq!(again.moves, record.moves, "SAN round trip {san:?} of {input:?}");
    let uci: Vec<String> = record.moves.iter().map(|m| m.to_uci(CastlingMode::Standard).to_string()).collect();
    let uci = uci.join(",");
    let again = notation::parse_move_list(&uci, record.start.clone())
        .unwrap_or_else(|e| panic!("UCI {uci:?} printed from {input:?} does not parse: {e}"));
    assert_eq!(again.moves, record.moves, "UCI round trip {uci:?} of {input:?}");
}

/// Move list: the input is a move list from the standard start, or a FEN line followed by a
/// move list from that position. A parsed list printed as SAN (and as UCI) parses back to the
/// same moves; errors are one line when the list is.
pub fn check_move_list(data: &[u8]) {
    let input = text(data);
    let (start, list) = match input.split_once('\n') {
        Some((first, rest)) => match notation::parse_fen(first) {
            Ok(pos) => (pos, rest),
            Err(_) => (Chess::default(), &*input),
        },
        None => (Chess::default(), &*input),
    };
    match notation::parse_move_list(list, start.clone()) {
        Ok(record) => {
            assert!(record.headers.is_empty(), "move list {list:?} has headers");
            assert_eq!(fen_of(&record.start), fen_of(&start), "start of {list:?}");
            assert_moves_round_trip(&record, list);
        }
        Err(e) => assert_one_line(&e.to_string(), list),
    }
}

/// A minimal PGN of `record`: its tags (escaped) and its SAN moves, ended by `*`.
fn pgn_of(record: &GameRecord) -> String {
    let mut pgn = String::new();
    for (name, value) in &record.headers {
        let value = value.replace('\\', "\\\\").replace('"', "\\\"");
        pgn.push_str(&format!("[{name} \"{value}\"]\n"));
    }
    if !record.headers.is_empty() {
        pgn.push('\n');
    }
    for san in record.san_moves() {
        pgn.push_str(&san);
        pgn.push(' ');
    }
    pgn.push_str("*\n");
    pgn
}

/// PGN: every game's moves round-trip as a move list; a game rebuilt as a minimal PGN (tags,
/// SAN, `*`) parses back to one game with the same tags, start position and moves (skipped for
/// games with a line break in a tag, which a PGN tag line cannot hold); errors are one line.
pub fn check_pgn(data: &[u8]) {
    let input = text(data);
    let records = match notation::parse_pgn(&input) {
        Ok(records) => records,
        Err(e) => {
            // A tag value can hold a line break escaped by a backslash (`[FEN "\<LF>1`); the
            // messages quote such values escaped, so they stay one line too.
            let message = e.to_string();
            assert!(!has_line_break(&message), "PGN error message is not one line: {message:?}");
            return;
        }
    };
    assert!(!records.is_empty(), "parse_pgn returned no game and no error");
    for record in &records {
        assert_moves_round_trip(record, &input);
        if record.headers.iter().any(|(name, value)| has_line_break(name) || value.contains('\n')) {
            continue;
        }
        let pgn = pgn_of(record);
        let again = notation::parse_pgn(&pgn)
            .unwrap_or_else(|e| panic!("PGN {pgn:?} rebuilt from {input:?} does not parse: {e}"));
        assert_eq!(again.len(), 1, "PGN {pgn:?} rebuilt from {input:?} holds {} games", again.len());
        assert_eq!(again[0].headers, record.headers, "tags of {pgn:?} rebuilt from {input:?}");
        assert_eq!(fen_of(&again[0].start), fen_of(&record.start), "start of {pgn:?} rebuilt from {input:?}");
        assert_eq!(again[0].moves, record.moves, "moves of {pgn:?} rebuilt from {input:?}");
    }
}

/// Setup TOML: a parsed setup's `to_toml` parses again, and `to_toml` of that is the same text
/// (a fixed point); errors (with their context chain) are one line.
///
/// A tensor rotated by a non-zero `inertia_rpy` can print a `-0.0`; `inertia_rpy = [0, 0, 0]`
/// leaves the tensor exactly as written, so that too is a fixed point at the first reprint.
pub fn check_setup_toml(data: &[u8]) {
    let input = text(data);
    let parse_and_print = |toml: &str, what: &str| {
        let setup = Setup::parse(toml).unwrap_or_else(|e| panic!("{what} does not parse: {e:#}\n{toml}"));
        setup.to_toml().unwrap_or_else(|e| panic!("to_toml of {what} failed: {e:#}\n{toml}"))
    };
    match Setup::parse(&input) {
        Ok(setup) => {
            let printed = setup.to_toml().unwrap_or_else(|e| panic!("to_toml of {input:?} failed: {e:#}"));
            let reprinted = parse_and_print(&printed, "the first print");
            assert_eq!(reprinted, printed, "to_toml is not a fixed point for {input:?}");
        }
        Err(e) => {
            let message = format!("{e:#}");
            assert!(!has_line_break(&message), "setup error message is not one line: {message:?}");
        }
    }
}

/// URDF: an imported arm's URDF (`chessarm urdf`) imports again to the same arm — joint names,
/// and every DH parameter, mass, centre of mass, inertia, limit and friction within 1e-9 of its
/// scale (the export writes shortest round-trip decimals and the import fits DH parameters by
/// `atan2` and `acos`, so the last bits may move; a wrong sign, axis or frame moves far more);
/// errors (with their context chain) are one line.
pub fn check_urdf(data: &[u8]) {
    let input = text(data);
    match chessarm::urdf_import::from_urdf(&input, &chessarm::urdf_import::ImportOptions::default()) {
        Ok(imported) => {
            let palm = chessarm_core::arm::bodies::Gripper::default().palm_depth();
            let printed =
                chessarm::urdf::to_urdf(&imported.model, "chessarm", &imported.joint_names, &imported.signs, palm);
            let again = chessarm::urdf_import::from_urdf(&printed, &chessarm::urdf_import::ImportOptions::default())
                .unwrap_or_else(|e| panic!("the export of {input:?} does not import: {e:#}\n{printed}"));
            assert_eq!(again.joint_names, imported.joint_names, "joint names of the export of {input:?}");
            assert_eq!(again.signs, imported.signs, "joint senses of the export of {input:?}");
            let close = |what: &str, a: &[f64], b: &[f64]| {
                let scale = a.iter().chain(b).fold(0.0_f64, |m, v| m.max(v.abs()));
                let far = a.iter().zip(b).any(|(x, y)| (x - y).abs() > 1e-9 * scale);
                assert!(!far, "{what} of the re-imported export of {input:?}: {a:?} vs {b:?}");
            };
            close("base", imported.model.base().as_slice(), again.model.base().as_slice());
            for (k, (one, two)) in imported.model.links().iter().zip(again.model.links()).enumerate() {
                let angles = |l: &chessarm_core::arm::model::Link| {
                    let (a, t) = (l.dh.alpha, l.dh.theta_offset);
                    [a.sin(), a.cos(), t.sin(), t.cos()]
                };
                close(&format!("link {k} DH angles"), &angles(one), &angles(two));
                close(&format!("link {k} DH lengths"), &[one.dh.a, one.dh.d], &[two.dh.a, two.dh.d]);
                close(&format!("link {k} mass"), &[one.inertial.mass], &[two.inertial.mass]);
                close(&format!("link {k} com"), one.inertial.com.as_slice(), two.inertial.com.as_slice());
                close(&format!("link {k} inertia"), one.inertial.inertia.as_slice(), two.inertial.inertia.as_slice());
                let limits = |l: &chessarm_core::arm::model::Link| {
                    [
                        l.limits.lower,
                        l.limits.upper,
                        l.limits.velocity,
                        l.limits.torque,
                        l.friction.viscous,
                        l.friction.coulomb,
                    ]
                };
                close(&format!("link {k} limits and friction"), &limits(one), &limits(two));
            }
        }
        Err(e) => {
            let message = format!("{e:#}");
            assert!(!has_line_break(&message), "URDF error message is not one line: {message:?}");
        }
    }
}

fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

fn join(values: &[f64]) -> String {
    values.iter().map(|v| format!("{v:?}")).collect::<Vec<_>>().join(",")
}

/// A list parser: finite values that `{:?}`, joined by commas, parse back bit for bit.
fn check_list<const N: usize>(input: &str, parse: fn(&str) -> Result<[f64; N], String>, valid: fn(f64) -> bool) {
    match parse(input) {
        Ok(values) => {
            assert!(values.iter().all(|&v| v.is_finite() && valid(v)), "{input:?} gave {values:?}");
            let printed = join(&values);
            let again = parse(&printed).unwrap_or_else(|e| panic!("{printed:?} printed from {input:?}: {e}"));
            assert!(same_bits(&again, &values), "{printed:?} printed from {input:?} gives {again:?}, not {values:?}");
        }
        Err(message) => assert_one_line(&message, input),
    }
}

/// A scalar parser: a valid value that `{:?}` parses back bit for bit.
fn check_scalar(input: &str, parse: fn(&str) -> Result<f64, String>, valid: fn(f64) -> bool) {
    match parse(input) {
        Ok(value) => {
            assert!(value.is_finite() && valid(value), "{input:?} gave {value:?}");
            let printed = format!("{value:?}");
            let again = parse(&printed).unwrap_or_else(|e| panic!("{printed:?} printed from {input:?}: {e}"));
            assert_eq!(again.to_bits(), value.to_bits(), "{printed:?} printed from {input:?}");
        }
        Err(message) => assert_one_line(&message, input),
    }
}

/// Gain ranges with at most this many values are also expanded (the parser allows 10⁶; the
/// bound keeps the executions fast).
const EXPANDED_RANGE: usize = 4096;

/// Numeric list arguments: the input goes through every parser of `chessarm::args`. Accepted
/// values are in their documented domain and print back (`{:?}` joined by commas, `A..B:N`,
/// `K/N`) to the same values; errors are one line when the argument is.
pub fn check_numbers(data: &[u8]) {
    let input = text(data);
    let input = &*input;
    let any = |_: f64| true;
    check_list::<1>(input, args::parse_numbers::<1>, any);
    check_list::<2>(input, args::parse_numbers::<2>, any);
    check_list::<3>(input, args::three, any);
    check_list::<4>(input, args::four, any);
    check_list::<4>(input, args::gain, |v| v >= 0.0);
    if let Ok([a, b, c, d]) = args::gain(input)
        && [b, c, d].iter().all(|v| v.to_bits() == a.to_bits())
    {
        let printed = format!("{a:?}");
        let again = args::gain(&printed).unwrap_or_else(|e| panic!("{printed:?} printed from {input:?}: {e}"));
        assert!(same_bits(&again, &[a; 4]), "{printed:?} printed from {input:?} gives {again:?}");
    }
    check_scalar(input, args::finite, any);
    check_scalar(input, args::non_negative, |v| v >= 0.0);
    check_scalar(input, args::positive, |v| v > 0.0);

    match args::range(input) {
        Ok(range) => {
            let args::GainRange { from, to, count } = range;
            assert!(from.is_finite() && to.is_finite() && 0.0 <= from && from <= to, "{input:?} gave {range:?}");
            assert!((1..=1_000_000).contains(&count), "{input:?} gave {range:?}");
            let printed = format!("{from:?}..{to:?}:{count}");
            let again = args::range(&printed).unwrap_or_else(|e| panic!("{printed:?} printed from {input:?}: {e}"));
            assert!(
                same_bits(&[again.from, again.to], &[from, to]) && again.count == count,
                "{printed:?} printed from {input:?} gives {again:?}, not {range:?}"
            );
            if count <= EXPANDED_RANGE {
                let values = range.values();
                assert_eq!(values.len(), count, "values of {range:?}");
                // Numerically: a `from` of -0.0 comes out as 0.0 (-0.0 + 0.0 · step).
                assert_eq!(values.first(), Some(&from), "first value of {range:?}");
                assert_eq!(values.last(), Some(if count == 1 { &from } else { &to }), "last value of {range:?}");
                assert!(values.windows(2).all(|w| w[0] <= w[1]), "values of {range:?} decrease: {values:?}");
                assert!(values.iter().all(|v| (from..=to).contains(v)), "values of {range:?} leave it: {values:?}");
            }
        }
        Err(message) => assert_one_line(&message, input),
    }

    match args::shard(input) {
        Ok((k, n)) => {
            assert!(1 <= k && k <= n, "{input:?} gave {k}/{n}");
            let printed = format!("{k}/{n}");
            assert_eq!(args::shard(&printed), Ok((k, n)), "{printed:?} printed from {input:?}");
        }
        Err(message) => assert_one_line(&message, input),
    }
}
