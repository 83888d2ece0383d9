//! ROBOTIS Dynamixel Protocol 2.0 packets (XM430, XL430).
//!
//! Instruction: `FF FF FD 00 ID LEN_L LEN_H INST P1…PN CRC_L CRC_H`, `LEN` = N + 3 (the
//! instruction, the parameters and the CRC, after stuffing); status: the same with `INST =
//! 0x55` followed by the error byte. The CRC is CRC-16 with polynomial 0x8005, initial value 0,
//! unreflected, over every byte from the header to the last parameter. Byte stuffing: wherever
//! `FF FF FD` appears from the instruction on, a `FD` is added after it (and taken out on
//! reading). Multi-byte values are little-endian. ID 0xFE broadcasts.

use super::{PacketError, Status};

pub const PING: u8 = 0x01;
pub const READ: u8 = 0x02;
pub const WRITE: u8 = 0x03;
pub const SYNC_READ: u8 = 0x82;
pub const SYNC_WRITE: u8 = 0x83;
pub const STATUS: u8 = 0x55;
pub const BROADCAST: u8 = 0xFE;

/// XM430/XL430 control table addresses.
pub const MODEL_NUMBER: u16 = 0;
pub const FIRMWARE_VERSION: u16 = 6;
pub const TORQUE_ENABLE: u16 = 64;
pub const HARDWARE_ERROR_STATUS: u16 = 70;
pub const GOAL_POSITION: u16 = 116;
pub const PRESENT_POSITION: u16 = 132;
/// The status error byte's alert bit: the servo has a hardware error (read
/// [`HARDWARE_ERROR_STATUS`]).
pub const ALERT: u8 = 0x80;

const HEADER: [u8; 4] = [0xFF, 0xFF, 0xFD, 0x00];

/// CRC-16, polynomial 0x8005 (x¹⁶ + x¹⁵ + x² + 1), initial 0, most significant bit first.
pub fn crc16(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0;
    for &byte in bytes {
        crc ^= u16::from(byte) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 { (crc << 1) ^ 0x8005 } else { crc << 1 };
        }
    }
    crc
}

/// `body` with an `FD` after every `FF FF FD` (the header's pattern).
pub fn stuff(body: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(body.len() + body.len() / 3);
    for (i, &b) in body.iter().enumerate() {
        out.push(b);
        if b == 0xFD && i >= 2 && body[i - 1] == 0xFF && body[i - 2] == 0xFF {
            out.push(0xFD);
        }
    }
    out
}

/// `stuffed` with the `FD` after each `FF FF FD` taken out ([`stuff`]'s inverse).
pub fn unstuff(stuffed: &[u8]) -> Vec<u8> {
    let mut body = Vec::with_capacity(stuffed.len());
    let mut i = 0;
    while i < stuffed.len() {
        body.push(stuffed[i]);
        // Only the stuffed `FD` after `FF FF FD` goes; any other byte there is the sender's
        // own (a sender that does not stuff), kept.
        if stuffed[i] == 0xFD
            && body.len() >= 3
            && body[body.len() - 2] == 0xFF
            && body[body.len() - 3] == 0xFF
            && stuffed.get(i + 1) == Some(&0xFD)
        {
            i += 1;
        }
        i += 1;
    }
    body
}

/// A packet to or from servo `id`: `kind` (the instruction, or [`STATUS`]) then `params`.
fn packet(id: u8, kind: u8, params: &[u8]) -> Vec<u8> {
    let mut body = vec![kind];
    body.extend_from_slice(params);
    let body = stuff(&body);
    let length = (body.len() + 2) as u16;
    let mut out = Vec::with_capacity(body.len() + 9);
    out.extend(HEADER);
    out.push(id);
    out.extend(length.to_le_bytes());
    out.extend(&body);
    let crc = crc16(&out);
    out.extend(crc.to_le_bytes());
    out
}

/// The instruction packet `instruction` with `params` to servo `id`.
pub fn instruction(id: u8, instruction: u8, params: &[u8]) -> Vec<u8> {
    packet(id, instruction, params)
}

/// `WRITE` of `data` at `address` of servo `id`.
pub fn write(id: u8, address: u16, data: &[u8]) -> Vec<u8> {
    let mut params = address.to_le_bytes().to_vec();
    params.extend_from_slice(data);
    instruction(id, WRITE, &params)
}

/// `READ` of `length` bytes at `address` of servo `id`.
pub fn read(id: u8, address: u16, length: u16) -> Vec<u8> {
    let mut params = address.to_le_bytes().to_vec();
    params.extend(length.to_le_bytes());
    instruction(id, READ, &params)
}

/// `SYNC_WRITE` (broadcast) of each servo's `data` (all the same length) at `address`.
pub fn sync_write(address: u16, goals: &[(u8, &[u8])]) -> Vec<u8> {
    let length = goals.first().map_or(0, |(_, d)| d.len()) as u16;
    let mut params = address.to_le_bytes().to_vec();
    params.extend(length.to_le_bytes());
    for (id, data) in goals {
        params.push(*id);
        params.extend_from_slice(data);
    }
    instruction(BROADCAST, SYNC_WRITE, &params)
}

/// `SYNC_READ` (broadcast) of `length` bytes at `address` of each of `ids`: each answers in turn.
pub fn sync_read(address: u16, length: u16, ids: &[u8]) -> Vec<u8> {
    let mut params = address.to_le_bytes().to_vec();
    params.extend(length.to_le_bytes());
    params.extend_from_slice(ids);
    instruction(BROADCAST, SYNC_READ, &params)
}

/// The status packet servo `id` answers with `error` and `params`.
pub fn status(id: u8, error: u8, params: &[u8]) -> Vec<u8> {
    let mut all = vec![error];
    all.extend_from_slice(params);
    packet(id, STATUS, &all)
}

/// A status packet from the front of `stream` (noise before its header skipped).
///
/// # Errors
///
/// No header, a packet cut short, a length too small for a status, an instruction byte that is
/// not a status's, or a CRC that does not match.
pub fn parse_status(stream: &[u8]) -> Result<Status, PacketError> {
    let packet = parse_packet(stream)?;
    if packet.error != STATUS || packet.params.is_empty() {
        return Err(PacketError::Malformed("not a status packet (instruction 0x55 and an error byte)"));
    }
    Ok(Status {
        id: packet.id,
        error: packet.params[0],
        params: packet.params[1..].to_vec(),
        start: packet.start,
        consumed: packet.consumed,
    })
}

/// Any packet from the front of `stream`, unstuffed: `error` holds its instruction byte (0x55
/// for a status) and `params` everything after it.
///
/// # Errors
///
/// No header, a packet cut short, a length under 3, or a CRC that does not match.
pub fn parse_packet(stream: &[u8]) -> Result<Status, PacketError> {
    let at = stream.windows(4).position(|w| w == HEADER).ok_or(PacketError::NoHeader(stream.len()))?;
    let head = &stream[at..];
    if head.len() < 7 {
        return Err(PacketError::Short { got: head.len(), needed: 10 });
    }
    let length = u16::from_le_bytes([head[5], head[6]]) as usize;
    if length < 3 {
        return Err(PacketError::Malformed("length under 3"));
    }
    let total = 7 + length;
    if head.len() < total {
        return Err(PacketError::Short { got: head.len(), needed: total });
    }
    let got = u16::from_le_bytes([head[total - 2], head[total - 1]]);
    let expected = crc16(&head[..total - 2]);
    if got != expected {
        return Err(PacketError::Checksum { got, expected });
    }
    let body = unstuff(&head[7..total - 2]);
    Ok(Status { id: head[4], error: body[0], params: body[1..].to_vec(), start: at, consumed: at + total })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Only the stuffed `FD` is taken out: a byte after an unstuffed `FF FF FD` (a sender that
    /// does not stuff) stays.
    #[test]
    fn unstuffing_takes_out_only_the_stuffed_byte() {
        assert_eq!(unstuff(&[0xFF, 0xFF, 0xFD, 0xFD, 0x01]), [0xFF, 0xFF, 0xFD, 0x01]);
        assert_eq!(unstuff(&[0xFF, 0xFF, 0xFD, 0x01, 0x02]), [0xFF, 0xFF, 0xFD, 0x01, 0x02]);
        let body = [0x55, 0xFF, 0xFF, 0xFD, 0xFD, 0xFF, 0xFF, 0xFD];
        assert_eq!(unstuff(&stuff(&body)), body);
    }

    /// The packets of ROBOTIS's Protocol 2.0 manual: a ping of ID 1 (CRC 0x4E19) and a write of
    /// 512 to Goal Position (116) of ID 1 (CRC 0x89CA).
    #[test]
    fn the_manuals_packets() {
        assert_eq!(instruction(1, PING, &[]), [0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x03, 0x00, 0x01, 0x19, 0x4E]);
        assert_eq!(
            write(1, GOAL_POSITION, &512u32.to_le_bytes()),
            [0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x09, 0x00, 0x03, 0x74, 0x00, 0x00, 0x02, 0x00, 0x00, 0xCA, 0x89]
        );
    }

    /// A parameter run `FF FF FD` is stuffed on writing and unstuffed on reading; damage is seen.
    #[test]
    fn stuffing_round_trips_and_damage_is_seen() {
        let data = [0xFF, 0xFF, 0xFD, 0x01, 0xFF, 0xFF, 0xFD];
        let reply = status(7, 0x00, &data);
        // 0x55, the error byte, 7 data bytes, 2 stuffed and the CRC's 2.
        assert_eq!(reply[5], 13, "length counts the two stuffed bytes: {reply:02X?}");
        let read = parse_status(&[&[0x00, 0xFF][..], &reply].concat()).unwrap();
        assert_eq!((read.id, read.error, read.params.as_slice()), (7, 0, &data[..]));
        let mut bad = reply.clone();
        bad[9] ^= 0x10;
        assert!(matches!(parse_status(&bad), Err(PacketError::Checksum { .. })));
        assert!(matches!(parse_status(&reply[..8]), Err(PacketError::Short { .. })));
        assert!(matches!(parse_status(&instruction(1, PING, &[])), Err(PacketError::Malformed(_))));
    }
}
