//! MAVLink frames on a byte stream, checksummed and parsed by rust-mavlink
//! through `elaboration::Frame` (never by hand): what the simulated vehicle,
//! the camera on its own and the tests' clients read and write.

use elaboration::{Frame, FrameError};
use mavlink::dialects::ardupilotmega::{MavCmd, MavMessage, COMMAND_LONG_DATA};
use mavlink::{MavHeader, MavlinkVersion};

/// Takes the whole frames at the start of `buf`; garbage is skipped, a
/// frame cut short waits for the rest (it stays in `buf`). Frames that do
/// not decode (unknown ids, bad enum values) are dropped.
pub fn parse_frames(buf: &mut Vec<u8>, out: &mut Vec<(MavHeader, MavMessage)>) {
    let mut pos = 0;
    while pos < buf.len() {
        match Frame::parse(&buf[pos..]) {
            Ok(frame) => {
                pos += frame.bytes().len();
                if let Ok(msg) = frame.decode() {
                    out.push((frame.header(), msg));
                }
            }
            Err(FrameError::Truncated { .. }) => break,
            Err(_) => {
                // Resync on the next start marker.
                pos += 1;
                while pos < buf.len() && buf[pos] != 0xFD && buf[pos] != 0xFE {
                    pos += 1;
                }
            }
        }
    }
    buf.drain(..pos);
}

/// One MAVLink 2 frame.
pub fn frame(header: MavHeader, msg: &MavMessage) -> Vec<u8> {
    elaboration::frame::serialize(header, MavlinkVersion::V2, msg)
}

/// A COMMAND_LONG to `(system, component)` with its seven parameters, as
/// the simulator's and the tests' clients send one.
pub fn command_long(target: (u8, u8), command: MavCmd, p: [f32; 7]) -> MavMessage {
    MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
        param1: p[0],
        param2: p[1],
        param3: p[2],
        param4: p[3],
        param5: p[4],
        param6: p[5],
        param7: p[6],
        command,
        target_system: target.0,
        target_component: target.1,
        confirmation: 0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::ardupilotmega::HEARTBEAT_DATA;

    #[test]
    fn frames_survive_garbage_and_cuts() {
        let msg = MavMessage::HEARTBEAT(HEARTBEAT_DATA::default());
        let h = MavHeader {
            system_id: 255,
            component_id: 190,
            sequence: 7,
        };
        let frame = frame(h, &msg);
        let mut buf = vec![0x00, 0x42, 0x13];
        buf.extend_from_slice(&frame);
        buf.extend_from_slice(&frame[..5]);
        let mut out = Vec::new();
        parse_frames(&mut buf, &mut out);
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].0.sequence, 7);
        // The cut frame waits for its end.
        assert_eq!(buf.len(), 5);
        buf.extend_from_slice(&frame[5..]);
        parse_frames(&mut buf, &mut out);
        assert_eq!(out.len(), 2);
        assert!(buf.is_empty());
    }
}
