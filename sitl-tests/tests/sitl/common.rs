//! Helpers shared by the end-to-end tests.

use std::path::{Path, PathBuf};

use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::{MavHeader, MavlinkVersion};
use sitl_tests::Vehicle;

/// `../shared` beside the workspace, or `None` (with the reason printed)
/// when it is absent; absent under CI=true is a failure.
pub fn shared_file(relative: &str) -> Option<PathBuf> {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared");
    let path = shared.join(relative);
    if path.is_file() {
        return Some(path);
    }
    let reason = format!(
        "{} not found (shared data beside the workspace)",
        path.display()
    );
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!("{reason}: required under CI=true");
    }
    println!("SKIPPED: {reason}");
    None
}

/// A frame the vehicle sent, as a client decodes it off the wire.
#[derive(Debug, Clone)]
pub struct Sent {
    /// Sim microseconds since boot.
    pub time_us: u64,
    pub header: MavHeader,
    pub msg: MavMessage,
    /// The frame's bytes.
    pub bytes: Vec<u8>,
}

/// Drains the vehicle's output through the wire format: each message is
/// serialized by rust-mavlink and decoded again with `elaboration::Frame`,
/// as the gateway reads it.
pub fn drain(v: &mut Vehicle, out: &mut Vec<Sent>) {
    while let Some((header, msg)) = v.poll_transmit() {
        let bytes = elaboration::frame::serialize(header, MavlinkVersion::V2, &msg);
        let frame = match elaboration::Frame::parse(&bytes) {
            Ok(f) => f,
            Err(e) => panic!("the vehicle sent an unparsable frame: {e} ({msg:?})"),
        };
        let decoded = match frame.decode() {
            Ok(m) => m,
            Err(e) => panic!("the vehicle sent an undecodable frame: {e:?} ({msg:?})"),
        };
        assert_eq!(frame.header(), header);
        out.push(Sent {
            time_us: v.now_us(),
            header,
            msg: decoded,
            bytes,
        });
    }
}

/// The message's name.
pub fn name(m: &MavMessage) -> &'static str {
    use mavlink::Message;
    m.message_name()
}
