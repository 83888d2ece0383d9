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

use chessarm::app::setup::file::Setup;
use chessarm::args;
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
    match chessarm::app::setup::urdf_import::from_urdf(
        &input,
        &chessarm::app::setup::urdf_import::ImportOptions::default(),
    ) {
        Ok(imported) => {
            let palm = chessarm_core::arm::bodies::Gripper::default().palm_depth();
            let printed = chessarm::app::formats::urdf::to_urdf(
                &imported.model,
                "chessarm",
                &imported.joint_names,
                &imported.signs,
                palm,
            );
            let again = chessarm::app::setup::urdf_import::from_urdf(
                &printed,
                &chessarm::app::setup::urdf_import::ImportOptions::default(),
            )
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
                let angles = |l: &chessarm_core::arm::link::Link| {
                    let (a, t) = (l.dh.alpha, l.dh.theta_offset);
                    [a.sin(), a.cos(), t.sin(), t.cos()]
                };
                close(&format!("link {k} DH angles"), &angles(one), &angles(two));
                close(&format!("link {k} DH lengths"), &[one.dh.a, one.dh.d], &[two.dh.a, two.dh.d]);
                close(&format!("link {k} mass"), &[one.inertial.mass], &[two.inertial.mass]);
                close(&format!("link {k} com"), one.inertial.com.as_slice(), two.inertial.com.as_slice());
                close(&format!("link {k} inertia"), one.inertial.inertia.as_slice(), two.inertial.inertia.as_slice());
                let limits = |l: &chessarm_core::arm::link::Link| {
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

/// The common properties of a packet read from the front of `data` by one protocol's parser:
/// where it starts and ends lies inside `data`; an error says why with figures that fit.
fn check_packet_bounds(data: &[u8], parsed: &Result<chessarm::app::bus::Status, chessarm::app::bus::PacketError>) {
    use chessarm::app::bus::PacketError;
    match parsed {
        Ok(packet) => assert!(packet.start < packet.consumed && packet.consumed <= data.len(), "{packet:?}"),
        Err(PacketError::NoHeader(n)) => assert_eq!(*n, data.len()),
        Err(PacketError::Short { got, needed }) => assert!(got < needed && *got <= data.len(), "{got} of {needed}"),
        Err(PacketError::Checksum { got, expected }) => assert_ne!(got, expected),
        Err(PacketError::Malformed(_)) => {}
    }
    if let Err(e) = parsed {
        assert!(!has_line_break(&e.to_string()), "{e}");
    }
}

/// `parse` on `data` within its bounds ([`check_packet_bounds`]), and what it reads, built again
/// by `build` from its ID, error byte and parameters, read back the same by `parse`. Returns
/// what it read and the bytes built.
fn check_rebuilt(
    data: &[u8],
    parse: fn(&[u8]) -> Result<chessarm::app::bus::Status, chessarm::app::bus::PacketError>,
    build: fn(u8, u8, &[u8]) -> Vec<u8>,
) -> Option<(chessarm::app::bus::Status, Vec<u8>)> {
    let parsed = parse(data);
    check_packet_bounds(data, &parsed);
    let read = parsed.ok()?;
    let built = build(read.id, read.error, &read.params);
    let back = parse(&built).unwrap_or_else(|e| panic!("{built:02X?} does not read back: {e}"));
    assert_eq!((back.id, back.error, &back.params), (read.id, read.error, &read.params));
    Some((read, built))
}

/// Feetech STS packets: whatever the bytes, the parser does not panic; a packet read (status
/// or instruction: one layout) is built again byte for byte from its ID, error (instruction)
/// byte and parameters; a packet built from the input's first bytes (ID, instruction, up to 253
/// parameters) reads back whole.
pub fn check_bus_feetech(data: &[u8]) {
    use chessarm::app::bus::feetech;
    let parsed = feetech::parse_packet(data);
    check_packet_bounds(data, &parsed);
    if let Ok(packet) = &parsed {
        assert_eq!(
            feetech::instruction(packet.id, packet.error, &packet.params),
            &data[packet.start..packet.consumed],
            "{packet:?}"
        );
        assert_eq!(feetech::parse_status(data), parsed, "a status reads as a packet does");
    }
    if let [id, instruction, params @ ..] = data
        && *id != 0xFF
    {
        let params = &params[..params.len().min(253)];
        let built = feetech::instruction(*id, *instruction, params);
        let back = feetech::parse_packet(&built).unwrap_or_else(|e| panic!("{built:02X?} does not read back: {e}"));
        assert_eq!(
            (back.id, back.error, back.params.as_slice(), back.start, back.consumed),
            (*id, *instruction, params, 0, built.len())
        );
    }
}

/// Dynamixel Protocol 2.0 packets: no panic; stuffing round-trips (`unstuff(stuff(x)) == x`,
/// and a stuffed body holds no `FF FF FD` but as `FF FF FD FD`); a packet read is built again
/// from its ID, instruction and parameters to bytes that read back the same, and to the very
/// bytes read when those were stuffed as the protocol stuffs (a sender that does not stuff is
/// read too, as the vendor's own SDK sends); a status read is rebuilt the same way; a packet
/// built from the input's first bytes (ID, instruction, parameters) reads back whole.
pub fn check_bus_dynamixel(data: &[u8]) {
    use chessarm::app::bus::dynamixel;
    let stuffed = dynamixel::stuff(data);
    assert_eq!(dynamixel::unstuff(&stuffed), data, "stuffing round trip");
    for (i, w) in stuffed.windows(3).enumerate() {
        if w == [0xFF, 0xFF, 0xFD] {
            assert_eq!(stuffed.get(i + 3), Some(&0xFD), "unstuffed header pattern at {i} in {stuffed:02X?}");
        }
    }
    if let Some((packet, built)) = check_rebuilt(data, dynamixel::parse_packet, dynamixel::instruction) {
        let body = &data[packet.start + 7..packet.consumed - 2];
        if dynamixel::stuff(&dynamixel::unstuff(body)) == body {
            assert_eq!(built, &data[packet.start..packet.consumed], "{packet:?}");
        }
    }
    check_rebuilt(data, dynamixel::parse_status, dynamixel::status);
    if let [id, instruction, params @ ..] = data {
        let built = dynamixel::instruction(*id, *instruction, params);
        let back = dynamixel::parse_packet(&built).unwrap_or_else(|e| panic!("{built:02X?} does not read back: {e}"));
        assert_eq!(
            (back.id, back.error, back.params.as_slice(), back.start, back.consumed),
            (*id, *instruction, params, 0, built.len())
        );
    }
}

/// The default setup's arm on STS3215 (Feetech) or XM430 (Dynamixel) servos, resting where a
/// game starts, built once: what [`check_bus_simulator`] puts on its bus.
struct SimulatedArm {
    arm: chessarm_core::arm::model::ArmModel<4>,
    actuators: chessarm_core::sim::actuator::Actuators<4>,
    bus: chessarm::app::setup::servos::ServoBus,
    signs: [f64; 4],
    q: chessarm_core::arm::model::JointVector<4>,
}

fn simulated_arm(actuator: &str) -> SimulatedArm {
    let mut setup = Setup::load(None).expect("the default setup");
    setup.actuators =
        chessarm::app::setup::actuators::resolve(&[actuator.to_string()], &setup.actuator_tables, "--actuator")
            .expect("a built-in servo");
    setup.actuator_names = std::array::from_fn(|_| actuator.to_string());
    let bus = chessarm::app::setup::servos::ServoBus::of(&setup).expect("the default bus");
    let motion = setup.motion.validated().expect("the default motion");
    let q = chessarm_chess::play::home_pose(&setup.arm, &setup.board, &setup.pieces, &motion).expect("a home pose");
    SimulatedArm { arm: setup.arm, actuators: setup.actuators, bus, signs: setup.convention.signs, q }
}

/// The simulated bus: the first byte chooses the protocol (bit 0: Dynamixel), a gripper servo
/// (bit 1, ID 6), a servo 2 that stops answering after its second goal packet (bit 2) and a
/// servo 3 that reports an overload at the first (bit 3). The rest is chunks, each a gap byte
/// `g` (the line silent before it: `g` × 10 µs for `g` < 240; 10 ms × (`g` − 239) above, up to
/// 160 ms; 100 s for 255, a long think), a length byte and that many bytes received at once.
/// Properties: no panic (dynamics included); what the bus sends back is whole status packets of
/// servos on the bus, each carrying at most 250 bytes of data, at most one per servo per
/// packet received (so at most 5 per 6 bytes received, a Feetech packet's least).
pub fn check_bus_simulator(data: &[u8]) {
    use chessarm::app::bus::Protocol;
    use chessarm::app::bus::simulator::{Fault, Faults, SimulatedBus};
    use std::sync::OnceLock;
    static STS: OnceLock<SimulatedArm> = OnceLock::new();
    static XM: OnceLock<SimulatedArm> = OnceLock::new();
    let Some((&flags, mut rest)) = data.split_first() else { return };
    let (protocol, arm) = if flags & 1 == 0 {
        (Protocol::Feetech, STS.get_or_init(|| simulated_arm("sts3215")))
    } else {
        (Protocol::Dynamixel, XM.get_or_init(|| simulated_arm("xm430")))
    };
    let gripper = (flags & 2 != 0).then_some((6, 2048));
    let faults = Faults {
        lose_reply: (flags & 4 != 0).then_some(Fault { id: 2, after: 2 }),
        overload: (flags & 8 != 0).then_some(Fault { id: 3, after: 1 }),
    };
    let sim = SimulatedBus::new(protocol, &arm.arm, &arm.actuators, arm.bus, arm.signs, arm.q, gripper)
        .expect("the simulated bus")
        .with_faults(faults);
    // The packets the bus took, counted by its log's lines.
    let packets = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let mut sim = sim.with_log(Box::new(LineCount(packets.clone())));
    let on_bus: Vec<u8> = arm.bus.ids.iter().copied().chain(gripper.map(|g| g.0)).collect();
    let mut at = 0.0;
    let mut output = Vec::new();
    while let [gap, length, tail @ ..] = rest {
        let (bytes, next) = tail.split_at((*length as usize).min(tail.len()));
        rest = next;
        at += match gap {
            0..240 => f64::from(*gap) * 1e-5,
            240..255 => f64::from(gap - 239) * 1e-2,
            255 => 100.0,
        };
        if *gap > 0 {
            // The line was silent for the gap.
            if let Some(dropped) = sim.expire(at) {
                assert!(!dropped.is_empty());
            }
        }
        output.clear();
        let before = packets.load(std::sync::atomic::Ordering::Relaxed);
        sim.receive(at, bytes, &mut output).expect("the simulated arm's dynamics");
        let taken = packets.load(std::sync::atomic::Ordering::Relaxed) - before;
        let mut replies = 0;
        let mut from = 0;
        while from < output.len() {
            let status = protocol
                .parse_status(&output[from..])
                .unwrap_or_else(|e| panic!("the bus sent {:02X?}: {e}", &output[from..]));
            assert_eq!(status.start, 0, "bytes before a reply in {output:02X?}");
            assert!(on_bus.contains(&status.id), "servo {} is not on the bus", status.id);
            assert!(status.params.len() <= 250, "{} bytes of data", status.params.len());
            from += status.consumed;
            replies += 1;
        }
        assert!(replies <= on_bus.len() * taken, "{replies} replies to {taken} packets");
    }
}

/// A log that counts its lines.
struct LineCount(std::sync::Arc<std::sync::atomic::AtomicUsize>);

impl std::io::Write for LineCount {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let lines = buf.iter().filter(|b| **b == b'\n').count();
        self.0.fetch_add(lines, std::sync::atomic::Ordering::Relaxed);
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Positions the board readings and typed moves are tried in: the start, both sides able to
/// castle both ways with an en passant capture, a knight with three captures that read alike,
/// promotions with and without a capture.
const POSITIONS: [&str; 5] = [
    "rnbqkbnr/pppppppp/8/8/8/8/PPPPPPPP/RNBQKBNR w KQkq - 0 1",
    "r3k2r/ppp2ppp/8/3pP3/8/8/PPP2PPP/R3K2R w KQkq d6 0 1",
    "4k3/8/2p1p3/3p4/4N3/8/8/4K3 w - - 0 1",
    "1n2k3/P7/8/8/8/8/7p/4K1N1 w - - 0 1",
    "1n2k3/P7/8/8/8/8/7p/4K1N1 b - - 0 1",
];

/// The position the first byte chooses, and the rest of the input as text.
fn position_and_text(data: &[u8]) -> Option<(Chess, Cow<'_, str>)> {
    let (&which, rest) = data.split_first()?;
    let pos = notation::parse_fen(POSITIONS[which as usize % POSITIONS.len()]).expect("a test position");
    Some((pos, text(rest)))
}

/// Whether the board after `m` in `pos` reads as `reading`.
fn reads_as(pos: &Chess, m: &chessarm_chess::shakmaty::Move, reading: &chessarm_chess::occupancy::Reading) -> bool {
    use chessarm_chess::occupancy::Reading;
    use chessarm_chess::shakmaty::Position;
    let mut after = pos.clone();
    after.play_unchecked(*m);
    match reading {
        Reading::Occupied(bits) => after.board().occupied() == *bits,
        Reading::Pieces(board) => after.board() == board,
    }
}

/// Board readings: the first byte chooses a position, then each line is a reading given to one
/// `MoveReader` in turn (a move it returns is played and the reader reset). Properties: no
/// panic; errors one line; a move returned is legal and leaves the board as read; a promotion's
/// or a capture's choice is of two or more legal moves that all do; "unchanged" only for the
/// position's own board.
pub fn check_occupancy(data: &[u8]) {
    use chessarm_chess::occupancy::{MoveReader, Resolved, parse_reading};
    use chessarm_chess::shakmaty::Position;
    let Some((mut pos, input)) = position_and_text(data) else { return };
    let mut reader = MoveReader::default();
    for line in input.lines() {
        let reading = match parse_reading(line) {
            Ok(reading) => reading,
            Err(e) => {
                assert_one_line(&e.to_string(), line);
                continue;
            }
        };
        let legal = pos.legal_moves();
        match reader.read(&pos, &reading) {
            Ok(Resolved::Move(m)) => {
                assert!(legal.contains(&m), "{m:?} is not legal in {}", fen_of(&pos));
                assert!(reads_as(&pos, &m, &reading), "{m:?} does not leave {line:?} in {}", fen_of(&pos));
                pos.play_unchecked(m);
                reader.reset();
            }
            Ok(Resolved::Promotion(moves) | Resolved::Choice(moves)) => {
                assert!(moves.len() >= 2, "a choice of {moves:?}");
                for m in &moves {
                    assert!(legal.contains(m), "{m:?} is not legal in {}", fen_of(&pos));
                    assert!(reads_as(&pos, m, &reading), "{m:?} does not leave {line:?}");
                }
            }
            Ok(Resolved::Unchanged) => assert_eq!(reading.occupied(), pos.board().occupied(), "{line:?}"),
            Ok(Resolved::InProgress) => {}
            Err(e) => assert_one_line(&e.to_string(), line),
        }
    }
}

/// Typed moves: the first byte chooses a position, then each line is a move typed in it (a
/// move parsed is played). Properties: no panic; a move returned is legal in the position, and
/// its SAN and UCI typed again give the same move; errors one line.
pub fn check_typed_move(data: &[u8]) {
    use chessarm_chess::shakmaty::Position;
    use chessarm_chess::shakmaty::san::San;
    let Some((mut pos, input)) = position_and_text(data) else { return };
    for line in input.lines() {
        match notation::parse_move(line, &pos) {
            Ok(m) => {
                assert!(pos.legal_moves().contains(&m), "{line:?} gave {m:?}, not legal in {}", fen_of(&pos));
                let san = San::from_move(&pos, m).to_string();
                let uci = m.to_uci(CastlingMode::Standard).to_string();
                for again in [&san, &uci] {
                    assert_eq!(notation::parse_move(again, &pos), Ok(m), "{again:?} (from {line:?})");
                }
                pos.play_unchecked(m);
            }
            Err(e) => assert_one_line(&e.to_string(), line),
        }
    }
}

/// The live page's request reader and gate: whatever the bytes, no panic; a head read is
/// within the bounds (head, body length), its path absolute; and the gate lets through only a
/// request for the page's own address that carries the token (but the icon), and a POST only
/// when it names its origin — the page's own.
pub fn check_live_request(data: &[u8]) {
    use chessarm::live::page::{MAX_BODY, MAX_HEAD, authorize, head_end, parse_head};
    const TOKEN: &str = "0123456789abcdef0123456789abcdef";
    let end = head_end(data).unwrap_or(data.len());
    let Ok((request, length)) = parse_head(&data[..end]) else { return };
    assert!(end <= MAX_HEAD && length <= MAX_BODY, "{end} {length}");
    assert!(request.path.starts_with('/'), "{request:?}");
    if authorize(&request, 8080, TOKEN).is_err() {
        return;
    }
    let host = request.header("host").map(str::to_ascii_lowercase);
    assert!(matches!(host.as_deref(), Some("127.0.0.1:8080" | "localhost:8080")), "{request:?}");
    let open = request.method == "GET" && request.path == "/favicon.ico";
    let carried = request.header("x-chessarm-token") == Some(TOKEN) || request.query.contains(TOKEN);
    assert!(open || carried, "{request:?}");
    if let Some(origin) = request.header("origin") {
        assert!(matches!(origin.to_ascii_lowercase().as_str(), "http://127.0.0.1:8080" | "http://localhost:8080"));
    }
    if request.method == "POST" {
        assert!(request.header("origin").is_some() || request.header("referer").is_some(), "{request:?}");
    }
}
