//! MAVLink 2 message signing on the vehicle link, as ArduPilot and PX4 do it
//! (<https://mavlink.io/en/guide/message_signing.html>). The signer and the
//! verifier are sans-IO: the caller gives the time (microseconds since the
//! Unix epoch) and the frames; the signature itself is rust-mavlink's
//! (`calculate_signature`, SHA-256/48). Only the key and timestamp files are
//! read and written here.
//!
//! - [`Key`]: the 32-byte secret from a file, refused when others may read
//!   it.
//! - [`Signer`]: signs every frame sent with our link id and a timestamp
//!   (units of 10 µs since 2015-01-01) that only grows, also across restarts:
//!   the caller persists [`Signer::timestamp`] and gives it back at start.
//! - [`Verifier`]: judges every frame received — a valid signature is
//!   accepted once per (link id, system, component) stream and timestamp;
//!   a bad signature, a replayed or stale timestamp is always rejected;
//!   an unsigned frame only when signatures are required.

use std::collections::HashMap;
use std::path::Path;

use mavlink::consts::v2::{IFLAG_SIGNED, SIGNATURE_VALUE_SIZE};
use mavlink::{MAVLinkMessageRaw, MAVLinkV2MessageRaw};

/// The signing epoch, 2015-01-01T00:00:00Z, in seconds since the Unix epoch.
const EPOCH_UNIX_S: u64 = 1_420_070_400;

/// Timestamps advance in units of 10 µs.
const UNITS_PER_S: u64 = 100_000;

/// A timestamp given back after a restart may lag the last one used by up
/// to the interval at which it is persisted: this much is added to it.
pub const PERSIST_MARGIN: u64 = 60 * UNITS_PER_S;

/// A stream heard for the first time may be at most this much older than
/// the newest timestamp known (the MAVLink signing spec's one minute).
const NEW_STREAM_WINDOW: u64 = 60 * UNITS_PER_S;

/// The signing timestamp at `unix_us` microseconds since the Unix epoch.
pub fn timestamp_at(unix_us: u64) -> u64 {
    unix_us.saturating_sub(EPOCH_UNIX_S * 1_000_000) / 10
}

/// Why a key file is refused.
#[derive(Debug, thiserror::Error)]
pub enum KeyError {
    #[error("cannot read {path}: {source}")]
    Read {
        path: String,
        source: std::io::Error,
    },
    #[error(
        "{path} holds a secret but may be read by other users (mode {mode:o}): `chmod 600 {path}`"
    )]
    Readable { path: String, mode: u32 },
    #[error("the signing key {path} is neither 32 bytes nor 64 hexadecimal digits ({len} bytes)")]
    Format { path: String, len: usize },
}

/// Reads a file that holds a secret (a signing key, the programs' token):
/// on Unix, refused when group or others may read it.
pub fn read_private(path: &Path) -> Result<Vec<u8>, KeyError> {
    let read = |source| KeyError::Read {
        path: path.display().to_string(),
        source,
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(path).map_err(read)?.permissions().mode();
        if mode & 0o077 != 0 {
            return Err(KeyError::Readable {
                path: path.display().to_string(),
                mode: mode & 0o777,
            });
        }
    }
    std::fs::read(path).map_err(read)
}

/// A 32-byte signing secret, as `SETUP_SIGNING` gives it to the autopilot.
#[derive(Clone, PartialEq, Eq)]
pub struct Key([u8; 32]);

impl std::fmt::Debug for Key {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Key(…)")
    }
}

impl Key {
    pub fn new(secret: [u8; 32]) -> Key {
        Key(secret)
    }

    pub fn secret(&self) -> &[u8; 32] {
        &self.0
    }

    /// Reads a key file: the 32 bytes themselves, or 64 hexadecimal digits
    /// (surrounding whitespace ignored). On Unix, a file that group or
    /// others may read is refused.
    pub fn load(path: &Path) -> Result<Key, KeyError> {
        let bytes = read_private(path)?;
        Key::parse(&bytes).ok_or(KeyError::Format {
            path: path.display().to_string(),
            len: bytes.len(),
        })
    }

    /// The key from a file's bytes, if they are one.
    pub fn parse(bytes: &[u8]) -> Option<Key> {
        if let Ok(raw) = <[u8; 32]>::try_from(bytes) {
            // 32 bytes that read as hex digits would be a 16-byte key in hex:
            // not a format we take, so raw bytes win.
            return Some(Key(raw));
        }
        let text = std::str::from_utf8(bytes).ok()?.trim();
        if text.len() != 64 {
            return None;
        }
        let mut secret = [0u8; 32];
        for (i, pair) in text.as_bytes().chunks(2).enumerate() {
            let pair = std::str::from_utf8(pair).ok()?;
            secret[i] = u8::from_str_radix(pair, 16).ok()?;
        }
        Some(Key(secret))
    }
}

/// Signs the frames we send.
#[derive(Debug)]
pub struct Signer {
    key: Key,
    link_id: u8,
    /// The last timestamp used (0: none yet).
    last: u64,
}

impl Signer {
    /// `persisted`: the timestamp persisted by an earlier run, if any.
    pub fn new(key: Key, link_id: u8, persisted: Option<u64>) -> Signer {
        Signer {
            key,
            link_id,
            last: persisted.map_or(0, |t| t.saturating_add(PERSIST_MARGIN)),
        }
    }

    /// Serializes `message` under `header`, signed, at `unix_us`.
    pub fn sign<M: mavlink::Message>(
        &mut self,
        header: mavlink::MavHeader,
        message: &M,
        unix_us: u64,
    ) -> MAVLinkV2MessageRaw {
        let mut raw = MAVLinkV2MessageRaw::new();
        raw.serialize_message_for_signing(header, message);
        self.fill_signature(&mut raw, unix_us);
        raw
    }

    /// Puts our link id, the next timestamp and the signature (rust-mavlink's
    /// `calculate_signature`) in a frame serialised for signing.
    fn fill_signature(&mut self, raw: &mut MAVLinkV2MessageRaw, unix_us: u64) {
        let timestamp = timestamp_at(unix_us).max(self.last + 1);
        self.last = timestamp;
        *raw.signature_link_id_mut() = self.link_id;
        raw.signature_timestamp_bytes_mut()
            .copy_from_slice(&timestamp.to_le_bytes()[..6]);
        let mut signature = [0u8; SIGNATURE_VALUE_SIZE];
        raw.calculate_signature(self.key.secret(), &mut signature);
        raw.signature_value_mut().copy_from_slice(&signature);
    }

    /// Like [`Signer::sign`], for a message the dialect's types cannot hold
    /// (the mirror's TUNNEL with a private payload type): rust-mavlink frames
    /// it with the signed flag set first, so that the header and checksum
    /// carry it, and computes the signature.
    pub fn sign_data<D: mavlink::MessageData>(
        &mut self,
        header: mavlink::MavHeader,
        data: &D,
        unix_us: u64,
    ) -> MAVLinkV2MessageRaw {
        let mut raw = MAVLinkV2MessageRaw::new();
        *raw.incompatibility_flags_mut() = IFLAG_SIGNED;
        raw.serialize_message_data(header, data);
        self.fill_signature(&mut raw, unix_us);
        raw
    }

    /// The last timestamp used, to persist.
    pub fn timestamp(&self) -> u64 {
        self.last
    }
}

/// The timestamp persisted in `path` by an earlier run (`None` when there
/// is none or it does not read as one: the signer then starts from the
/// clock).
pub fn read_timestamp(path: &Path) -> Option<u64> {
    std::fs::read_to_string(path).ok()?.trim().parse().ok()
}

/// Persists `timestamp` in `path`, atomically (a temporary file renamed).
pub fn write_timestamp(path: &Path, timestamp: u64) -> std::io::Result<()> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    std::fs::write(&tmp, format!("{timestamp}\n"))?;
    std::fs::rename(&tmp, path)
}

/// Signing on a link, as `run` was asked for it.
#[derive(Debug, Clone)]
pub struct Setup {
    pub key: Key,
    /// Our link id in the signatures (`--signing-link-id`).
    pub link_id: u8,
    /// Unsigned frames from the vehicle are rejected too.
    pub require: bool,
    /// Where the signing timestamp persists across restarts.
    pub timestamp_file: std::path::PathBuf,
}

/// The whole MAVLink 2 frame in `bytes` as rust-mavlink's raw frame, to
/// verify; `None` for a MAVLink 1 frame or bytes that are no whole frame.
pub fn raw_frame(bytes: &[u8]) -> Option<MAVLinkMessageRaw> {
    use mavlink::consts::v2::SIGNATURE_SIZE;
    const HEADER: usize = 9;
    let (&stx, rest) = bytes.split_first()?;
    let (&len, rest) = rest.split_first()?;
    let &flags = rest.first()?;
    if stx != mavlink::MAV_STX_V2 {
        return None;
    }
    let signature = if flags & IFLAG_SIGNED != 0 {
        SIGNATURE_SIZE
    } else {
        0
    };
    let whole = 1 + HEADER + usize::from(len) + 2 + signature;
    let mut raw = MAVLinkV2MessageRaw::new();
    let buffer = raw.as_mut_slice();
    if bytes.len() < whole || whole > buffer.len() {
        return None;
    }
    buffer[..whole].copy_from_slice(&bytes[..whole]);
    Some(MAVLinkMessageRaw::V2(raw))
}

/// Why a received frame is rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Rejection {
    /// Not signed (MAVLink 1, or MAVLink 2 without a signature) while
    /// signatures are required.
    Unsigned,
    /// Signed, but not with our key (or altered).
    BadSignature,
    /// A timestamp not newer than the last one of its stream: a replay.
    Replayed,
    /// A new stream whose timestamp is more than a minute old.
    Stale,
}

impl Rejection {
    pub fn as_str(self) -> &'static str {
        match self {
            Rejection::Unsigned => "unsigned",
            Rejection::BadSignature => "bad signature",
            Rejection::Replayed => "replayed",
            Rejection::Stale => "stale",
        }
    }
}

impl std::fmt::Display for Rejection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Judges the frames we receive.
#[derive(Debug)]
pub struct Verifier {
    key: Key,
    require: bool,
    /// The last accepted timestamp of each (link id, system, component).
    streams: HashMap<(u8, u32, u8), u64>,
    /// The newest timestamp known: our clock's, or a frame's.
    newest: u64,
}

impl Verifier {
    /// `require`: unsigned frames are rejected too.
    pub fn new(key: Key, require: bool) -> Verifier {
        Verifier {
            key,
            require,
            streams: HashMap::new(),
            newest: 0,
        }
    }

    /// Accepts or rejects a frame received at `unix_us`.
    pub fn check(&mut self, frame: &MAVLinkMessageRaw, unix_us: u64) -> Result<(), Rejection> {
        let raw = match frame {
            MAVLinkMessageRaw::V2(raw) if raw.incompatibility_flags() & IFLAG_SIGNED != 0 => raw,
            _ if self.require => return Err(Rejection::Unsigned),
            _ => return Ok(()),
        };
        self.newest = self.newest.max(timestamp_at(unix_us));
        let mut signature = [0u8; SIGNATURE_VALUE_SIZE];
        raw.calculate_signature(self.key.secret(), &mut signature);
        if signature != raw.signature_value() {
            return Err(Rejection::BadSignature);
        }
        let timestamp = raw.signature_timestamp();
        let stream = (raw.signature_link_id(), raw.system_id(), raw.component_id());
        match self.streams.get(&stream) {
            Some(&last) if timestamp <= last => return Err(Rejection::Replayed),
            None if timestamp.saturating_add(NEW_STREAM_WINDOW) < self.newest => {
                return Err(Rejection::Stale)
            }
            _ => {}
        }
        self.streams.insert(stream, timestamp);
        self.newest = self.newest.max(timestamp);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::ardupilotmega::MavMessage;
    use mavlink::MavHeader;

    const NOW: u64 = 1_780_000_000_000_000; // 2026, in µs since the Unix epoch

    fn key(b: u8) -> Key {
        Key::new([b; 32])
    }

    fn heartbeat() -> MavMessage {
        MavMessage::HEARTBEAT(Default::default())
    }

    fn header(system: u32) -> MavHeader {
        MavHeader {
            system_id: system,
            component_id: 1,
            sequence: 0,
        }
    }

    fn signed(signer: &mut Signer, system: u32, at: u64) -> MAVLinkMessageRaw {
        MAVLinkMessageRaw::V2(signer.sign(header(system), &heartbeat(), at))
    }

    #[test]
    fn a_signed_frame_is_accepted_once_and_an_altered_or_foreign_one_never() {
        let mut signer = Signer::new(key(7), 3, None);
        let mut verifier = Verifier::new(key(7), true);
        let frame = signed(&mut signer, 1, NOW);
        assert_eq!(verifier.check(&frame, NOW), Ok(()));
        assert_eq!(verifier.check(&frame, NOW), Err(Rejection::Replayed));
        assert_eq!(verifier.check(&signed(&mut signer, 1, NOW), NOW), Ok(()));
        // Another key.
        let mut stranger = Signer::new(key(8), 3, None);
        assert_eq!(
            verifier.check(&signed(&mut stranger, 1, NOW), NOW),
            Err(Rejection::BadSignature)
        );
        // Its timestamp moved forward without the key: the signature no
        // longer matches.
        let MAVLinkMessageRaw::V2(mut raw) = signed(&mut signer, 1, NOW) else {
            unreachable!()
        };
        raw.signature_timestamp_bytes_mut()[0] ^= 0x40;
        assert_eq!(
            verifier.check(&MAVLinkMessageRaw::V2(raw), NOW),
            Err(Rejection::BadSignature)
        );
    }

    #[test]
    fn unsigned_frames_are_rejected_only_when_signatures_are_required() {
        let mut raw = MAVLinkV2MessageRaw::new();
        raw.serialize_message(header(1), &heartbeat());
        let unsigned = MAVLinkMessageRaw::V2(raw);
        assert_eq!(
            Verifier::new(key(1), true).check(&unsigned, NOW),
            Err(Rejection::Unsigned)
        );
        assert_eq!(Verifier::new(key(1), false).check(&unsigned, NOW), Ok(()));
        // A wrongly signed frame is rejected even when unsigned ones pass.
        let mut stranger = Signer::new(key(2), 0, None);
        assert_eq!(
            Verifier::new(key(1), false).check(&signed(&mut stranger, 1, NOW), NOW),
            Err(Rejection::BadSignature)
        );
    }

    #[test]
    fn a_new_stream_more_than_a_minute_old_is_stale() {
        let mut signer = Signer::new(key(7), 0, None);
        let old = signed(&mut signer, 1, NOW - 61_000_000);
        let mut verifier = Verifier::new(key(7), true);
        assert_eq!(verifier.check(&old, NOW), Err(Rejection::Stale));
        let mut signer = Signer::new(key(7), 0, None);
        let recent = signed(&mut signer, 1, NOW - 59_000_000);
        assert_eq!(verifier.check(&recent, NOW), Ok(()));
    }

    #[test]
    fn timestamps_only_grow_within_a_run_and_across_restarts() {
        let mut signer = Signer::new(key(7), 0, None);
        let a = signed(&mut signer, 1, NOW);
        let b = signed(&mut signer, 1, NOW); // same instant
        let c = signed(&mut signer, 1, NOW - 5_000_000); // the clock stepped back
        let ts = |f: &MAVLinkMessageRaw| match f {
            MAVLinkMessageRaw::V2(r) => r.signature_timestamp(),
            MAVLinkMessageRaw::V1(_) => 0,
        };
        assert!(
            ts(&a) < ts(&b) && ts(&b) < ts(&c),
            "{} {} {}",
            ts(&a),
            ts(&b),
            ts(&c)
        );
        assert_eq!(ts(&a), timestamp_at(NOW));
        // A restart on a computer without a real-time clock (its time is
        // far behind): the persisted timestamp keeps the order.
        let persisted = signer.timestamp();
        let mut again = Signer::new(key(7), 0, Some(persisted));
        let d = signed(&mut again, 1, 0);
        assert!(ts(&d) > persisted + PERSIST_MARGIN - 1);
        let mut verifier = Verifier::new(key(7), true);
        assert_eq!(verifier.check(&c, NOW), Ok(()));
        assert_eq!(verifier.check(&d, NOW), Ok(()));
    }

    #[test]
    fn key_files_raw_or_hex_and_never_readable_by_others() {
        let dir = std::env::temp_dir().join(format!("petrel-key-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let write = |name: &str, bytes: &[u8], mode: u32| {
            let path = dir.join(name);
            std::fs::write(&path, bytes).expect("write");
            #[cfg(unix)]
            {
                use std::os::unix::fs::PermissionsExt;
                std::fs::set_permissions(&path, std::fs::Permissions::from_mode(mode))
                    .expect("chmod");
            }
            path
        };
        let hex = "00112233445566778899aabbccddeeff00112233445566778899AABBCCDDEEFF\n";
        let k = Key::load(&write("hex", hex.as_bytes(), 0o600)).expect("hex key");
        assert_eq!(k.secret()[1], 0x11);
        assert_eq!(k.secret()[31], 0xff);
        let k = Key::load(&write("raw", &[9u8; 32], 0o400)).expect("raw key");
        assert_eq!(k, key(9));
        let e = Key::load(&write("short", b"abc", 0o600)).expect_err("short");
        assert!(e.to_string().contains("neither 32 bytes nor 64"), "{e}");
        #[cfg(unix)]
        {
            let e = Key::load(&write("open", hex.as_bytes(), 0o644)).expect_err("readable");
            assert!(e.to_string().contains("chmod 600"), "{e}");
        }
        let e = Key::load(&dir.join("missing")).expect_err("missing");
        assert!(e.to_string().contains("cannot read"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
