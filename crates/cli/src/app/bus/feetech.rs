//! Feetech SCS/STS packets (the STS3215 of the SO-101).
//!
//! Instruction: `FF FF ID LEN INST P1…PN CHK` with `LEN = N + 2` and
//! `CHK = ¬(ID + LEN + INST + ΣP) mod 256`; status: `FF FF ID LEN ERR P1…PN CHK` with the
//! same length and checksum over `ERR` in place of `INST`. Multi-byte values of the STS series
//! are little-endian (the SCS series' are big-endian: not used here). ID 0xFE broadcasts.

use super::{PacketError, Status};

pub const PING: u8 = 0x01;
pub const READ: u8 = 0x02;
pub const WRITE: u8 = 0x03;
pub const SYNC_READ: u8 = 0x82;
pub const SYNC_WRITE: u8 = 0x83;
pub const BROADCAST: u8 = 0xFE;

/// STS3215 control table addresses.
pub const MODEL_NUMBER: u8 = 3;
pub const TORQUE_ENABLE: u8 = 40;
pub const GOAL_POSITION: u8 = 42;
pub const PRESENT_POSITION: u8 = 56;
/// Status error bits: input voltage, angle sensor, overheat, overcurrent, angle limit, overload.
pub const ERROR_BITS: [(u8, &str); 6] = [
    (0x01, "input voltage"),
    (0x02, "angle sensor"),
    (0x04, "overheat"),
    (0x08, "overcurrent"),
    (0x10, "angle limit"),
    (0x20, "overload"),
];

/// The complement of the byte sum, modulo 256.
pub fn checksum(bytes: &[u8]) -> u8 {
    !bytes.iter().fold(0u8, |sum, b| sum.wrapping_add(*b))
}

/// The instruction packet `instruction` with `params` to servo `id`.
///
/// # Panics
///
/// Never for the packets of this module: `params` longer than 253 bytes does not fit a packet
/// (`LEN` is one byte) and is refused by the callers' types.
pub fn instruction(id: u8, instruction: u8, params: &[u8]) -> Vec<u8> {
    let length = u8::try_from(params.len() + 2).unwrap_or_else(|_| unreachable!("at most 253 parameter bytes"));
    let mut packet = Vec::with_capacity(params.len() + 6);
    packet.extend([0xFF, 0xFF, id, length, instruction]);
    packet.extend_from_slice(params);
    packet.push(checksum(&packet[2..]));
    packet
}

/// `WRITE` of `data` at `address` of servo `id`.
pub fn write(id: u8, address: u8, data: &[u8]) -> Vec<u8> {
    let mut params = vec![address];
    params.extend_from_slice(data);
    instruction(id, WRITE, &params)
}

/// `READ` of `length` bytes at `address` of servo `id`.
pub fn read(id: u8, address: u8, length: u8) -> Vec<u8> {
    instruction(id, READ, &[address, length])
}

/// `SYNC_WRITE` (broadcast) of each servo's `data` (all the same length) at `address`.
pub fn sync_write(address: u8, goals: &[(u8, &[u8])]) -> Vec<u8> {
    let length = goals.first().map_or(0, |(_, d)| d.len());
    let mut params = vec![address, length as u8];
    for (id, data) in goals {
        params.push(*id);
        params.extend_from_slice(data);
    }
    instruction(BROADCAST, SYNC_WRITE, &params)
}

/// `SYNC_READ` (broadcast) of `length` bytes at `address` of each of `ids`: each answers in turn.
pub fn sync_read(address: u8, length: u8, ids: &[u8]) -> Vec<u8> {
    let mut params = vec![address, length];
    params.extend_from_slice(ids);
    instruction(BROADCAST, SYNC_READ, &params)
}

/// A status packet from the front of `stream` (noise before its header skipped).
///
/// # Errors
///
/// No header, a packet cut short, a length under 2, or a checksum that does not match.
pub fn parse_status(stream: &[u8]) -> Result<Status, PacketError> {
    parse_packet(stream)
}

/// Any packet from the front of `stream`: a status (`error` its error byte) or an instruction
/// (`error` its instruction byte: the two share one layout).
///
/// # Errors
///
/// As [`parse_status`].
pub fn parse_packet(stream: &[u8]) -> Result<Status, PacketError> {
    let start = stream.windows(2).position(|w| w == [0xFF, 0xFF]).ok_or(PacketError::NoHeader(stream.len()))?;
    // A run of FF: the header is the last two before the ID (an ID is never FF).
    let mut at = start;
    while stream.get(at + 2) == Some(&0xFF) {
        at += 1;
    }
    let head = &stream[at..];
    if head.len() < 4 {
        return Err(PacketError::Short { got: head.len(), needed: 6 });
    }
    let length = head[3] as usize;
    if length < 2 {
        return Err(PacketError::Malformed("length under 2"));
    }
    let total = 4 + length;
    if head.len() < total {
        return Err(PacketError::Short { got: head.len(), needed: total });
    }
    let expected = checksum(&head[2..total - 1]);
    if head[total - 1] != expected {
        return Err(PacketError::Checksum { got: head[total - 1].into(), expected: expected.into() });
    }
    Ok(Status { id: head[2], error: head[4], params: head[5..total - 1].to_vec(), start: at, consumed: at + total })
}

/// The status packet servo `id` answers with `error` and `params`.
pub fn status(id: u8, error: u8, params: &[u8]) -> Vec<u8> {
    instruction(id, error, params)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ping of servo 1 (the SDK's example) and a write of position 2048 (0x0800,
    /// little-endian) at address 42 of servo 1, checksums by hand: ¬(1 + 2 + 1) = 0xFB,
    /// ¬(1 + 5 + 3 + 0x2A + 0x00 + 0x08) = ¬0x3B = 0xC4.
    #[test]
    fn packets_checked_by_hand() {
        assert_eq!(instruction(1, PING, &[]), [0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB]);
        let packet = write(1, GOAL_POSITION, &2048u16.to_le_bytes());
        assert_eq!(packet, [0xFF, 0xFF, 0x01, 0x05, 0x03, 0x2A, 0x00, 0x08, 0xC4]);
    }

    /// A status packet reads back after noise; a flipped byte or a cut is an error.
    #[test]
    fn status_packets_read_back_and_damage_is_seen() {
        let reply = status(3, 0x20, &[0x00, 0x08]);
        let mut stream = vec![0x00, 0x13, 0xFF];
        stream.extend(&reply);
        let read = parse_status(&stream).unwrap();
        assert_eq!(
            (read.id, read.error, read.params.as_slice(), read.consumed),
            (3, 0x20, &[0x00, 0x08][..], stream.len())
        );
        let mut bad = reply.clone();
        bad[5] ^= 0x01;
        assert!(matches!(parse_status(&bad), Err(PacketError::Checksum { .. })));
        assert!(matches!(parse_status(&reply[..reply.len() - 1]), Err(PacketError::Short { .. })));
        assert_eq!(parse_status(&[1, 2, 3]), Err(PacketError::NoHeader(3)));
    }
}
