//! A MAVLink frame as the driver received it: parsed once, by rust-mavlink,
//! and handed to the cores with its raw bytes (for elaboration, the
//! recording and the downlink) and its receive time.

use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::{MavHeader, MavlinkVersion};

/// One frame as received.
#[derive(Debug, Clone)]
pub struct Received {
    /// Microseconds on the clock given to the link's open (the driver's monotonic clock).
    pub time_us: u64,
    /// The frame's bytes exactly as on the wire (checksum already checked
    /// by rust-mavlink).
    pub bytes: Vec<u8>,
    pub version: MavlinkVersion,
    pub header: MavHeader,
    /// The message, when the dialect decodes it (an unknown enum value, for
    /// instance, fails the decoding: the bytes are still delivered).
    pub message: Option<MavMessage>,
}
