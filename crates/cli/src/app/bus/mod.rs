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

pub mod arm;
pub mod driver;
pub mod dynamixel;
pub mod feetech;
pub mod mapping;
pub mod port;
pub mod simulator;

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
    /// Where the packet starts in the stream (after any noise), and the bytes the packet and
    /// anything before it took.
    pub start: usize,
    pub consumed: usize,
}

/// Which of the two protocols a bus speaks, and each one's registers for what the driver does:
/// torque on and off, the goal and the present position.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Protocol {
    /// Feetech SCS/STS (STS3215: the SO-101), 1 Mbaud.
    Feetech,
    /// Dynamixel Protocol 2.0 (XM430, XL430: OpenManipulator-X, Interbotix), 1 Mbaud here.
    Dynamixel,
}

/// Hardware error bits of a Dynamixel X series' `HARDWARE_ERROR_STATUS` (address 70).
pub const DYNAMIXEL_HARDWARE_BITS: [(u8, &str); 5] = [
    (0x01, "input voltage"),
    (0x04, "overheat"),
    (0x08, "motor encoder"),
    (0x10, "electrical shock"),
    (0x20, "overload"),
];

impl Protocol {
    pub fn name(self) -> &'static str {
        match self {
            Self::Feetech => "feetech",
            Self::Dynamixel => "dynamixel",
        }
    }

    /// The protocol of a built-in servo (`sts3215…` Feetech, `xl430`/`xm430` Dynamixel).
    pub fn of_servo(name: &str) -> Option<Self> {
        // (The SCS series is big-endian: not spoken here.)
        if name.starts_with("sts") {
            Some(Self::Feetech)
        } else if name.starts_with("xl") || name.starts_with("xm") || name.starts_with("xh") {
            Some(Self::Dynamixel)
        } else {
            None
        }
    }

    /// The broadcast ID (both: 0xFE).
    pub const BROADCAST: u8 = 0xFE;

    pub fn ping(self, id: u8) -> Vec<u8> {
        match self {
            Self::Feetech => feetech::instruction(id, feetech::PING, &[]),
            Self::Dynamixel => dynamixel::instruction(id, dynamixel::PING, &[]),
        }
    }

    pub fn write(self, id: u8, address: u16, data: &[u8]) -> Vec<u8> {
        match self {
            Self::Feetech => feetech::write(id, address as u8, data),
            Self::Dynamixel => dynamixel::write(id, address, data),
        }
    }

    pub fn read(self, id: u8, address: u16, length: u16) -> Vec<u8> {
        match self {
            Self::Feetech => feetech::read(id, address as u8, length as u8),
            Self::Dynamixel => dynamixel::read(id, address, length),
        }
    }

    pub fn sync_write(self, address: u16, data: &[(u8, &[u8])]) -> Vec<u8> {
        match self {
            Self::Feetech => feetech::sync_write(address as u8, data),
            Self::Dynamixel => dynamixel::sync_write(address, data),
        }
    }

    pub fn sync_read(self, address: u16, length: u16, ids: &[u8]) -> Vec<u8> {
        match self {
            Self::Feetech => feetech::sync_read(address as u8, length as u8, ids),
            Self::Dynamixel => dynamixel::sync_read(address, length, ids),
        }
    }

    /// A status packet from the front of `stream`.
    ///
    /// # Errors
    ///
    /// As the protocol's `parse_status`.
    pub fn parse_status(self, stream: &[u8]) -> Result<Status, PacketError> {
        match self {
            Self::Feetech => feetech::parse_status(stream),
            Self::Dynamixel => dynamixel::parse_status(stream),
        }
    }

    /// An instruction packet from the front of `stream` (`error` holds the instruction).
    ///
    /// # Errors
    ///
    /// As the protocol's `parse_packet`.
    pub fn parse_instruction(self, stream: &[u8]) -> Result<Status, PacketError> {
        match self {
            Self::Feetech => feetech::parse_packet(stream),
            Self::Dynamixel => dynamixel::parse_packet(stream),
        }
    }

    pub fn status(self, id: u8, error: u8, params: &[u8]) -> Vec<u8> {
        match self {
            Self::Feetech => feetech::status(id, error, params),
            Self::Dynamixel => dynamixel::status(id, error, params),
        }
    }

    pub fn torque_enable(self) -> u16 {
        match self {
            Self::Feetech => feetech::TORQUE_ENABLE.into(),
            Self::Dynamixel => dynamixel::TORQUE_ENABLE,
        }
    }

    pub fn goal_position(self) -> u16 {
        match self {
            Self::Feetech => feetech::GOAL_POSITION.into(),
            Self::Dynamixel => dynamixel::GOAL_POSITION,
        }
    }

    pub fn present_position(self) -> u16 {
        match self {
            Self::Feetech => feetech::PRESENT_POSITION.into(),
            Self::Dynamixel => dynamixel::PRESENT_POSITION,
        }
    }

    /// Bytes of a position register (STS: 2, Dynamixel X: 4).
    pub fn position_bytes(self) -> u16 {
        match self {
            Self::Feetech => 2,
            Self::Dynamixel => 4,
        }
    }

    /// A position in ticks as its register's bytes (little-endian; the STS's negative
    /// positions in sign-magnitude, bit 15).
    pub fn encode_position(self, ticks: i64) -> Vec<u8> {
        match self {
            Self::Feetech => {
                let magnitude = ticks.unsigned_abs().min(0x7FFF) as u16;
                let raw = if ticks < 0 { magnitude | 0x8000 } else { magnitude };
                raw.to_le_bytes().to_vec()
            }
            Self::Dynamixel => (ticks.clamp(i32::MIN.into(), i32::MAX.into()) as i32).to_le_bytes().to_vec(),
        }
    }

    /// A position register's bytes as ticks ([`Protocol::encode_position`]'s inverse); `None`
    /// for the wrong number of bytes.
    pub fn decode_position(self, bytes: &[u8]) -> Option<i64> {
        match self {
            Self::Feetech => {
                let raw = u16::from_le_bytes(bytes.try_into().ok()?);
                let magnitude = i64::from(raw & 0x7FFF);
                Some(if raw & 0x8000 != 0 { -magnitude } else { magnitude })
            }
            Self::Dynamixel => Some(i32::from_le_bytes(bytes.try_into().ok()?).into()),
        }
    }

    /// What a status's error byte reports that must stop the arm, in words (`None`: nothing).
    /// A Dynamixel's alert bit says only that a hardware error is set: the driver reads
    /// [`dynamixel::HARDWARE_ERROR_STATUS`] to name it ([`Protocol::hardware_error`]).
    pub fn fault(self, error: u8) -> Option<String> {
        match self {
            Self::Feetech => {
                let named: Vec<&str> =
                    feetech::ERROR_BITS.iter().filter(|(bit, _)| error & bit != 0).map(|(_, n)| *n).collect();
                (!named.is_empty()).then(|| named.join(", "))
            }
            Self::Dynamixel => {
                let mut named = Vec::new();
                if error & dynamixel::ALERT != 0 {
                    named.push("hardware error (alert)".to_string());
                }
                let number = error & 0x7F;
                if number != 0 {
                    let what = match number {
                        1 => "result fail",
                        2 => "instruction error",
                        3 => "CRC error",
                        4 => "data range error",
                        5 => "data length error",
                        6 => "data limit error",
                        7 => "access error",
                        _ => "unknown error",
                    };
                    named.push(format!("{what} ({number})"));
                }
                (!named.is_empty()).then(|| named.join(", "))
            }
        }
    }

    /// A Dynamixel's `HARDWARE_ERROR_STATUS` byte in words.
    pub fn hardware_error(status: u8) -> String {
        let named: Vec<&str> =
            DYNAMIXEL_HARDWARE_BITS.iter().filter(|(bit, _)| status & bit != 0).map(|(_, n)| *n).collect();
        if named.is_empty() { format!("hardware error status {status:#04x}") } else { named.join(", ") }
    }
}
