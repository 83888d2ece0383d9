//! Servo buses: the packets of the two protocols the makers' arms use, built and read here so
//! that the goal positions the simulation proved reach the servos byte for byte.
//!
//! - [`feetech`]: Feetech's SCS/STS protocol (the SO-101's STS3215): `FF FF ID LEN INST
//!   PARAMS… CHECKSUM`, the checksum the complement of the byte sum.
//! - [`dynamixel`]: ROBOTIS Dynamixel Protocol 2.0 (OpenManipulator-X's XM430, Interbotix's
//!   XL430): `FF FF FD 00 ID LEN_L LEN_H INST PARAMS… CRC_L CRC_H`, CRC-16 (polynomial 0x8005)
//!   and byte stuffing.
//!
//! Both read a status packet back from a byte stream that may hold noise before it; a packet
//! cut short, with a bad checksum or from another servo is an error that says so.

pub mod dynamixel;
pub mod feetech;

/// What went wrong reading a status packet.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PacketError {
    #[error("no reply (no packet header in {0} bytes)")]
    NoHeader(usize),
    #[error("the reply was cut short: {got} of {needed} bytes")]
    Short { got: usize, needed: usize },
    #[error("the reply's checksum is {got:#06x}, its bytes give {expected:#06x}")]
    Checksum { got: u16, expected: u16 },
    #[error("the reply is malformed: {0}")]
    Malformed(&'static str),
}

/// A servo's status packet: who answered, its error byte and the data.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Status {
    pub id: u8,
    pub error: u8,
    pub params: Vec<u8>,
    /// Bytes of the stream the packet and anything before it took.
    pub consumed: usize,
}
