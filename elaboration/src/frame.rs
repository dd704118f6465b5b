//! One MAVLink frame as bytes: its header fields, its payload, and its
//! checksum checked by rust-mavlink. Framing (where a frame starts and how
//! long it is) is read from the header; the CRC and the decoding are
//! rust-mavlink's.

use std::sync::OnceLock;

use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::error::ParserError;
use mavlink::{MavHeader, MavlinkVersion, Message};

/// First byte of a MAVLink 1 frame.
pub const STX_V1: u8 = mavlink::MAV_STX;
/// First byte of a MAVLink 2 frame.
pub const STX_V2: u8 = mavlink::MAV_STX_V2;

const V1_HEADER: usize = 6; // stx, len, seq, sys, comp, msgid
const V2_HEADER: usize = 10; // stx, len, incompat, compat, seq, sys, comp, msgid(3)
const CHECKSUM: usize = 2;
const SIGNATURE: usize = 13;
const IFLAG_SIGNED: u8 = 0x01;
/// The shortest possible frame (MAVLink 1, empty payload).
pub const MIN_FRAME_LEN: usize = V1_HEADER + CHECKSUM;

/// A frame whose checksum rust-mavlink accepted, borrowed from the bytes it
/// was read from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame<'a> {
    bytes: &'a [u8],
}

/// Why bytes are not a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// The first byte is not a MAVLink start marker.
    #[error("no MAVLink start marker")]
    NoStartMarker,
    /// The header announces more bytes than there are.
    #[error("truncated frame: {needed} bytes announced, {available} available")]
    Truncated { needed: usize, available: usize },
    /// The message id is not in the dialect, so its checksum cannot be checked.
    #[error("unknown message id {id}")]
    UnknownMessage { id: u32, len: usize },
    /// The checksum does not match.
    #[error("bad checksum on message id {id}")]
    BadCrc { id: u32, len: usize },
    /// A MAVLink 2 frame with incompatibility flags this library does not
    /// know (only signing is defined): the spec says to drop it.
    #[error("unknown MAVLink 2 incompatibility flags {flags:#04x} on message id {id}")]
    IncompatibleFlags { flags: u8, id: u32, len: usize },
}

impl FrameError {
    /// The length the header announced, when the header could be read.
    pub fn announced_len(&self) -> Option<usize> {
        match *self {
            FrameError::UnknownMessage { len, .. }
            | FrameError::BadCrc { len, .. }
            | FrameError::IncompatibleFlags { len, .. } => Some(len),
            FrameError::Truncated { needed, .. } => Some(needed),
            FrameError::NoStartMarker => None,
        }
    }
}

/// The length a frame starting at `bytes[0]` announces in its header, if the
/// header is there.
pub fn announced_len(bytes: &[u8]) -> Option<usize> {
    match *bytes.first()? {
        STX_V1 => Some(V1_HEADER + *bytes.get(1)? as usize + CHECKSUM),
        STX_V2 => {
            let len = *bytes.get(1)? as usize;
            let signed = *bytes.get(2)? & IFLAG_SIGNED != 0;
            Some(V2_HEADER + len + CHECKSUM + if signed { SIGNATURE } else { 0 })
        }
        _ => None,
    }
}

struct Dialect {
    /// For every message id below 2^16: 0 unknown, else extra CRC + 1.
    extra: Vec<u16>,
}

fn dialect() -> &'static Dialect {
    static DIALECT: OnceLock<Dialect> = OnceLock::new();
    DIALECT.get_or_init(|| {
        let mut extra = vec![0u16; 1 << 16];
        for (id, slot) in extra.iter_mut().enumerate() {
            let id = id as u32;
            if MavMessage::default_message_from_id(id).is_some() {
                *slot = MavMessage::extra_crc(id) as u16 + 1;
            }
        }
        Dialect { extra }
    })
}

/// The CRC extra byte of a message id of the ardupilotmega dialect, or `None`
/// when the id is not in it.
pub fn extra_crc(id: u32) -> Option<u8> {
    let e = *dialect().extra.get(id as usize)?;
    (e != 0).then(|| (e - 1) as u8)
}

impl<'a> Frame<'a> {
    /// Reads the frame at the start of `bytes` (extra bytes after it are
    /// ignored) and checks its checksum with rust-mavlink.
    pub fn parse(bytes: &'a [u8]) -> Result<Frame<'a>, FrameError> {
        let len = match announced_len(bytes) {
            Some(len) => len,
            None if bytes.first().is_some_and(|&b| b == STX_V1 || b == STX_V2) => {
                return Err(FrameError::Truncated {
                    needed: V2_HEADER,
                    available: bytes.len(),
                })
            }
            None => return Err(FrameError::NoStartMarker),
        };
        if bytes.len() < len {
            return Err(FrameError::Truncated {
                needed: len,
                available: bytes.len(),
            });
        }
        let frame = Frame {
            bytes: &bytes[..len],
        };
        let id = frame.message_id();
        if frame.is_v2() && bytes[2] & !IFLAG_SIGNED != 0 {
            return Err(FrameError::IncompatibleFlags {
                flags: bytes[2],
                id,
                len,
            });
        }
        let Some(extra) = extra_crc(id) else {
            return Err(FrameError::UnknownMessage { id, len });
        };
        let crc_end = frame.header_len() + frame.payload_len();
        let crc = u16::from_le_bytes([bytes[crc_end], bytes[crc_end + 1]]);
        if mavlink::calculate_crc(&bytes[1..crc_end], extra) != crc {
            return Err(FrameError::BadCrc { id, len });
        }
        Ok(frame)
    }

    /// The frame's bytes, exactly as on the wire.
    pub fn bytes(&self) -> &'a [u8] {
        self.bytes
    }

    /// MAVLink 1 or 2.
    pub fn version(&self) -> MavlinkVersion {
        if self.bytes[0] == STX_V2 {
            MavlinkVersion::V2
        } else {
            MavlinkVersion::V1
        }
    }

    fn is_v2(&self) -> bool {
        self.bytes[0] == STX_V2
    }

    fn header_len(&self) -> usize {
        if self.is_v2() {
            V2_HEADER
        } else {
            V1_HEADER
        }
    }

    fn payload_len(&self) -> usize {
        self.bytes[1] as usize
    }

    /// The sender's sequence number.
    pub fn sequence(&self) -> u8 {
        self.bytes[if self.is_v2() { 4 } else { 2 }]
    }

    /// The sender's system id.
    pub fn system_id(&self) -> u8 {
        self.bytes[if self.is_v2() { 5 } else { 3 }]
    }

    /// The sender's component id.
    pub fn component_id(&self) -> u8 {
        self.bytes[if self.is_v2() { 6 } else { 4 }]
    }

    /// The message id.
    pub fn message_id(&self) -> u32 {
        if self.is_v2() {
            u32::from_le_bytes([self.bytes[7], self.bytes[8], self.bytes[9], 0])
        } else {
            self.bytes[5] as u32
        }
    }

    /// The payload (MAVLink 2 payloads come without their trailing zeros).
    pub fn payload(&self) -> &'a [u8] {
        let start = self.header_len();
        &self.bytes[start..start + self.payload_len()]
    }

    /// The autopilot's own clock in this frame: its `time_boot_ms`, for the
    /// messages that carry one ([`boot_ms_offset`]); `None` otherwise.
    pub fn time_boot_ms(&self) -> Option<u32> {
        let at = boot_ms_offset(self.message_id())?;
        // MAVLink 2 cuts a payload's trailing zeros: a missing byte is 0.
        let mut b = [0u8; 4];
        for (i, x) in b.iter_mut().enumerate() {
            *x = self.payload().get(at + i).copied().unwrap_or(0);
        }
        Some(u32::from_le_bytes(b))
    }

    /// The header as rust-mavlink's type.
    pub fn header(&self) -> MavHeader {
        MavHeader {
            system_id: self.system_id() as u32,
            component_id: self.component_id(),
            sequence: self.sequence(),
        }
    }

    /// Decodes the message with rust-mavlink.
    pub fn decode(&self) -> Result<MavMessage, ParserError> {
        MavMessage::parse(self.version(), self.message_id(), self.payload())
    }
}

/// Serializes a message into frame bytes with rust-mavlink (for tests, the
/// simulated vehicle and the tlog writer).
pub fn serialize(header: MavHeader, version: MavlinkVersion, message: &MavMessage) -> Vec<u8> {
    let mut out = Vec::with_capacity(64);
    // Writing into a Vec cannot fail; a message id above 255 cannot go
    // into MAVLink 1, in which case nothing is written.
    let _ = mavlink::write_versioned_msg(&mut out, version, header, message);
    out
}

/// Where a message's `time_boot_ms` (u32) sits in its payload, for the
/// messages of the autopilot's usual telemetry that carry one (MAVLink
/// orders fields by size: after SYSTEM_TIME's u64, first in the others).
pub fn boot_ms_offset(id: u32) -> Option<usize> {
    match id {
        2 => Some(8),                                 // SYSTEM_TIME
        29 | 30 | 31 | 32 | 33 | 65 | 251 => Some(0), // SCALED_PRESSURE, ATTITUDE, ATTITUDE_QUATERNION,
        // LOCAL_POSITION_NED, GLOBAL_POSITION_INT, RC_CHANNELS, NAMED_VALUE_FLOAT
        _ => None,
    }
}

/// The same from a decoded message.
pub fn message_boot_ms(message: &mavlink::dialects::ardupilotmega::MavMessage) -> Option<u32> {
    use mavlink::dialects::ardupilotmega::MavMessage as M;
    Some(match message {
        M::SYSTEM_TIME(m) => m.time_boot_ms,
        M::SCALED_PRESSURE(m) => m.time_boot_ms,
        M::ATTITUDE(m) => m.time_boot_ms,
        M::ATTITUDE_QUATERNION(m) => m.time_boot_ms,
        M::LOCAL_POSITION_NED(m) => m.time_boot_ms,
        M::GLOBAL_POSITION_INT(m) => m.time_boot_ms,
        M::RC_CHANNELS(m) => m.time_boot_ms,
        M::NAMED_VALUE_FLOAT(m) => m.time_boot_ms,
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::ardupilotmega::{MavModeFlag, HEARTBEAT_DATA};

    #[test]
    fn the_autopilots_clock_is_read_where_a_message_carries_it() {
        use mavlink::dialects::ardupilotmega::{GLOBAL_POSITION_INT_DATA, SYSTEM_TIME_DATA};
        let header = MavHeader::default();
        let messages = [
            MavMessage::SYSTEM_TIME(SYSTEM_TIME_DATA {
                time_unix_usec: u64::MAX,
                time_boot_ms: 123_456,
            }),
            MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
                time_boot_ms: 123_456,
                lat: -1,
                ..Default::default()
            }),
        ];
        for m in &messages {
            for v in [MavlinkVersion::V1, MavlinkVersion::V2] {
                let bytes = serialize(header, v, m);
                let f = Frame::parse(&bytes).expect("frame");
                assert_eq!(f.time_boot_ms(), Some(123_456), "{m:?}");
                assert_eq!(message_boot_ms(m), Some(123_456));
            }
        }
        // A small time, its high bytes cut by MAVLink 2: read as zeros.
        let m = MavMessage::SYSTEM_TIME(SYSTEM_TIME_DATA {
            time_unix_usec: 0,
            time_boot_ms: 7,
        });
        let bytes = serialize(header, MavlinkVersion::V2, &m);
        assert_eq!(Frame::parse(&bytes).expect("frame").time_boot_ms(), Some(7));
        let bytes = heartbeat(MavlinkVersion::V2);
        assert_eq!(Frame::parse(&bytes).expect("frame").time_boot_ms(), None);
    }

    fn heartbeat(version: MavlinkVersion) -> Vec<u8> {
        let msg = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: 5,
            base_mode: MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED,
            ..HEARTBEAT_DATA::DEFAULT
        });
        let header = MavHeader {
            system_id: 7,
            component_id: 1,
            sequence: 42,
        };
        serialize(header, version, &msg)
    }

    #[test]
    fn reads_both_versions() {
        for v in [MavlinkVersion::V1, MavlinkVersion::V2] {
            let bytes = heartbeat(v);
            let f = Frame::parse(&bytes).expect("valid frame");
            assert_eq!(f.version(), v);
            assert_eq!((f.system_id(), f.component_id(), f.sequence()), (7, 1, 42));
            assert_eq!(f.message_id(), 0);
            assert_eq!(f.bytes().len(), bytes.len());
            match f.decode() {
                Ok(MavMessage::HEARTBEAT(h)) => assert_eq!(h.custom_mode, 5),
                other => panic!("unexpected {other:?}"),
            }
        }
    }

    #[test]
    fn rejects_bad_crc_and_truncation() {
        let mut bytes = heartbeat(MavlinkVersion::V2);
        let n = bytes.len();
        assert!(matches!(
            Frame::parse(&bytes[..n - 1]),
            Err(FrameError::Truncated { .. })
        ));
        bytes[n - 1] ^= 0xff;
        assert!(matches!(
            Frame::parse(&bytes),
            Err(FrameError::BadCrc { id: 0, .. })
        ));
        assert_eq!(Frame::parse(&[0x00, 1, 2]), Err(FrameError::NoStartMarker));
        assert!(Frame::parse(&[]).is_err());
    }

    #[test]
    fn unknown_incompatibility_flags_are_refused() {
        let mut bytes = heartbeat(MavlinkVersion::V2);
        bytes[2] = 0x02;
        assert!(matches!(
            Frame::parse(&bytes),
            Err(FrameError::IncompatibleFlags {
                flags: 0x02,
                id: 0,
                ..
            })
        ));
    }

    #[test]
    fn unknown_id_is_reported() {
        // A MAVLink 2 frame with message id 0xFFFFFF, empty payload.
        let bytes = [STX_V2, 0, 0, 0, 0, 1, 1, 0xff, 0xff, 0xff, 0, 0];
        assert!(matches!(
            Frame::parse(&bytes),
            Err(FrameError::UnknownMessage {
                id: 0xFF_FFFF,
                len: 12
            })
        ));
    }
}
