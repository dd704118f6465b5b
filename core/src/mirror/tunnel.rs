//! The downlink's MAVLink carrier: TUNNEL (message 385) with Petrel's
//! payload type, [`PAYLOAD_TYPE`], from the range MAVLink leaves to local
//! use (32768–65535).
//!
//! rust-mavlink types `TUNNEL.payload_type` as the registered enum, which
//! has no value in the private range: it can neither build nor decode our
//! frames. [`Tunnel`] is TUNNEL with the type as a plain `u16`; it lets
//! rust-mavlink lay out and read every field but that one (serialised as
//! "unknown", 0) and only puts the `u16` in the first two payload bytes,
//! where MAVLink's field ordering (largest type first) places it. Framing,
//! checksum (with TUNNEL's CRC_EXTRA) and signing stay rust-mavlink's.
//!
//! Addressing (docs/mirror.md, "Addressing", checked against ArduPilot's
//! `libraries/GCS_MAVLink/MAVLink_routing.cpp`):
//! - downlink: from the gateway (vehicle system, component 191) to the
//!   mirror's system id, component 0. ArduPilot forwards a message whose
//!   target system is not its own on every link where it has seen that
//!   system (rule 2c), and nowhere else: so the mirror speaks first (its
//!   first snapshot request) and the records then reach its link only.
//! - uplink: from the mirror to (vehicle system, 191). The target is the
//!   autopilot's system but not its component: ArduPilot does not take it
//!   itself and forwards it where it has seen (system, 191), the
//!   companion's link (rule 2d).

use mavlink::dialects::ardupilotmega::{MavMessage, MavTunnelPayloadType, TUNNEL_DATA};
use mavlink::error::ParserError;
use mavlink::{MavlinkVersion, MessageData};

/// Petrel's TUNNEL payload type: the mirror's records ("PM", 0x504D, moved
/// into the private range).
pub const PAYLOAD_TYPE: u16 = 0xD04D;

/// TUNNEL with its payload type as a number.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Tunnel {
    pub payload_type: u16,
    pub target_system: u8,
    pub target_component: u8,
    /// At most 128 bytes.
    pub payload: Vec<u8>,
}

impl MessageData for Tunnel {
    type Message = MavMessage;
    const ID: u32 = TUNNEL_DATA::ID;
    const NAME: &'static str = TUNNEL_DATA::NAME;
    const EXTRA_CRC: u8 = TUNNEL_DATA::EXTRA_CRC;
    const ENCODED_LEN: usize = TUNNEL_DATA::ENCODED_LEN;

    fn ser(&self, version: MavlinkVersion, bytes: &mut [u8]) -> usize {
        let len = self.payload.len().min(128);
        let mut payload = [0u8; 128];
        payload[..len].copy_from_slice(&self.payload[..len]);
        let data = TUNNEL_DATA {
            payload_type: MavTunnelPayloadType::MAV_TUNNEL_PAYLOAD_TYPE_UNKNOWN,
            target_system: self.target_system,
            target_component: self.target_component,
            payload_length: len as u8,
            payload,
        };
        let n = data.ser(version, bytes);
        bytes[..2].copy_from_slice(&self.payload_type.to_le_bytes());
        // MAVLink 2 drops trailing zeros: keep the type's bytes.
        let typed = match self.payload_type {
            0 => 0,
            t if t > 0xff => 2,
            _ => 1,
        };
        n.max(typed)
    }

    fn deser(version: MavlinkVersion, payload: &[u8]) -> Result<Self, ParserError> {
        let mut bytes = [0u8; TUNNEL_DATA::ENCODED_LEN];
        let n = payload.len().min(bytes.len());
        bytes[..n].copy_from_slice(&payload[..n]);
        let payload_type = u16::from_le_bytes([bytes[0], bytes[1]]);
        bytes[0] = 0;
        bytes[1] = 0;
        let data = TUNNEL_DATA::deser(version, &bytes)?;
        let len = usize::from(data.payload_length).min(128);
        Ok(Tunnel {
            payload_type,
            target_system: data.target_system,
            target_component: data.target_component,
            payload: data.payload[..len].to_vec(),
        })
    }
}

impl Tunnel {
    /// Petrel's records `payload` for (`system`, `component`).
    pub fn petrel(to: (u8, u8), payload: Vec<u8>) -> Tunnel {
        Tunnel {
            payload_type: PAYLOAD_TYPE,
            target_system: to.0,
            target_component: to.1,
            payload,
        }
    }

    /// As an unsigned MAVLink 2 frame from (`system`, `component`), as a
    /// link writes it (the tests' radio).
    #[cfg(any(test, feature = "fixtures"))]
    pub fn unsigned_frame(&self, from: (u8, u8), sequence: u8) -> Vec<u8> {
        let header = mavlink::MavHeader {
            system_id: u32::from(from.0),
            component_id: from.1,
            sequence,
        };
        let mut raw = mavlink::MAVLinkV2MessageRaw::new();
        raw.serialize_message_data(header, self);
        raw.raw_bytes().to_vec()
    }

    /// A Petrel TUNNEL from a received frame: `None` for any other frame.
    pub fn from_frame(frame: &elaboration::Frame) -> Option<Tunnel> {
        if frame.message_id() != TUNNEL_DATA::ID {
            return None;
        }
        Tunnel::deser(frame.version(), frame.payload())
            .ok()
            .filter(|t| t.payload_type == PAYLOAD_TYPE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::{MAVLinkV2MessageRaw, MavHeader};

    #[test]
    fn a_petrel_tunnel_round_trips_through_rust_mavlink_framing() {
        for payload in [vec![1u8, 2, 3], vec![], vec![0xff; 128], vec![7, 0, 0, 0]] {
            let t = Tunnel {
                payload_type: PAYLOAD_TYPE,
                target_system: 245,
                target_component: 0,
                payload,
            };
            let mut raw = MAVLinkV2MessageRaw::new();
            raw.serialize_message_data(
                MavHeader {
                    system_id: 1,
                    component_id: 191,
                    sequence: 9,
                },
                &t,
            );
            let frame = elaboration::Frame::parse(raw.raw_bytes()).expect("a valid frame");
            assert_eq!(frame.message_id(), 385);
            assert_eq!((frame.system_id(), frame.component_id()), (1, 191));
            assert_eq!(Tunnel::from_frame(&frame), Some(t));
        }
    }

    #[test]
    fn other_tunnels_and_messages_are_not_ours() {
        let t = Tunnel {
            payload_type: 201,
            target_system: 1,
            target_component: 1,
            payload: vec![1],
        };
        let mut raw = MAVLinkV2MessageRaw::new();
        raw.serialize_message_data(MavHeader::default(), &t);
        let frame = elaboration::Frame::parse(raw.raw_bytes()).expect("a valid frame");
        assert_eq!(Tunnel::from_frame(&frame), None);
        // And rust-mavlink reads a registered type as TUNNEL itself.
        assert!(matches!(frame.decode(), Ok(MavMessage::TUNNEL(_))));
    }
}
