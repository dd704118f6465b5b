//! The downlink's signatures, on the ground (docs/mirror.md, "A signed
//! downlink"): with the vehicle's signing key (`petrel mirror
//! --signing-key`, the file `petrel run --signing-key` reads), every
//! downlink record must come in a TUNNEL frame MAVLink 2 signed with it —
//! `petrel run` signs every frame it sends on a signed link, and the
//! autopilot routes them unchanged. A radio anyone can transmit on could
//! otherwise feed the mirror records of a vehicle state that is not the
//! vehicle's. Unsigned, wrongly signed (altered, or another key), replayed
//! and stale frames are refused before the replica sees them, and counted
//! by reason, as ArduPilot does on its own signed links.
//!
//! Sans-IO: the caller gives the frame's bytes and the wall time
//! (microseconds since the Unix epoch, for the signing spec's one-minute
//! window); the judgement is `link::signing::Verifier`'s, requiring
//! signatures.

use serde::Serialize;

use crate::signing::{raw_frame, Key, Rejection, Verifier};

/// Downlink frames refused for their signature, by reason.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Refusals {
    /// Whether the mirror requires signatures at all (it has the key).
    pub required: bool,
    /// Downlink frames whose signature verified.
    pub accepted: u64,
    pub unsigned: u64,
    pub bad_signature: u64,
    pub replayed: u64,
    pub stale: u64,
}

impl Refusals {
    /// Every frame refused.
    pub fn total(&self) -> u64 {
        self.unsigned + self.bad_signature + self.replayed + self.stale
    }

    /// `3 refused (2 unsigned, 1 replayed)`, for a person.
    pub fn words(&self) -> String {
        let parts: Vec<String> = [
            (self.unsigned, "unsigned"),
            (self.bad_signature, "bad signature"),
            (self.replayed, "replayed"),
            (self.stale, "stale"),
        ]
        .iter()
        .filter(|(n, _)| *n > 0)
        .map(|(n, what)| format!("{n} {what}"))
        .collect();
        if parts.is_empty() {
            "none refused".into()
        } else {
            format!("{} refused ({})", self.total(), parts.join(", "))
        }
    }
}

/// The downlink's judge.
#[derive(Debug)]
pub struct SignedDownlink {
    verifier: Verifier,
    refusals: Refusals,
}

impl SignedDownlink {
    /// Requires every downlink frame signed with `key`.
    pub fn new(key: Key) -> SignedDownlink {
        SignedDownlink {
            verifier: Verifier::new(key, true),
            refusals: Refusals {
                required: true,
                ..Refusals::default()
            },
        }
    }

    /// Whether the downlink frame `bytes` (a whole MAVLink frame) received
    /// at `unix_us` may reach the replica; a refusal is counted.
    pub fn admit(&mut self, bytes: &[u8], unix_us: u64) -> Result<(), Rejection> {
        let judged = match raw_frame(bytes) {
            Some(raw) => self.verifier.check(&raw, unix_us),
            None => Err(Rejection::Unsigned),
        };
        let r = &mut self.refusals;
        match judged {
            Ok(()) => r.accepted += 1,
            Err(Rejection::Unsigned) => r.unsigned += 1,
            Err(Rejection::BadSignature) => r.bad_signature += 1,
            Err(Rejection::Replayed) => r.replayed += 1,
            Err(Rejection::Stale) => r.stale += 1,
        }
        judged
    }

    pub fn refusals(&self) -> Refusals {
        self.refusals
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signing::Signer;
    use mavlink::dialects::ardupilotmega::{MavMessage, TUNNEL_DATA};
    use mavlink::{MavHeader, MavlinkVersion};

    const NOW: u64 = 1_780_000_000_000_000;

    fn tunnel(seq: u8) -> (MavHeader, MavMessage) {
        let header = MavHeader {
            system_id: 1,
            component_id: 191,
            sequence: seq,
        };
        let mut data = TUNNEL_DATA {
            target_system: 245,
            payload_length: 3,
            ..Default::default()
        };
        data.payload[..3].copy_from_slice(b"rec");
        (header, MavMessage::TUNNEL(data))
    }

    fn signed(signer: &mut Signer, seq: u8, at: u64) -> Vec<u8> {
        let (header, message) = tunnel(seq);
        signer.sign(header, &message, at).raw_bytes().to_vec()
    }

    /// The record unsigned; as MAVLink 1 (which cannot carry a TUNNEL),
    /// a heartbeat from the companion.
    fn unsigned(seq: u8, version: MavlinkVersion) -> Vec<u8> {
        let (header, mut message) = tunnel(seq);
        if version == MavlinkVersion::V1 {
            message = MavMessage::HEARTBEAT(Default::default());
        }
        let mut out = Vec::new();
        match version {
            MavlinkVersion::V2 => mavlink::write_v2_msg(&mut out, header, &message),
            MavlinkVersion::V1 => mavlink::write_v1_msg(&mut out, header, &message),
        }
        .unwrap_or_else(|e| panic!("{e}"));
        out
    }

    #[test]
    fn only_fresh_records_signed_with_the_key_reach_the_replica() {
        let key = Key::new([9; 32]);
        let mut signer = Signer::new(key.clone(), 0, None);
        let mut ground = SignedDownlink::new(key);
        let first = signed(&mut signer, 0, NOW);
        assert_eq!(ground.admit(&first, NOW), Ok(()));
        let second = signed(&mut signer, 1, NOW + 1_000);
        assert_eq!(ground.admit(&second, NOW + 1_000), Ok(()));
        // Heard again: a replay, whatever its arrival time.
        assert_eq!(ground.admit(&first, NOW + 2_000), Err(Rejection::Replayed));
        assert_eq!(ground.admit(&second, NOW + 2_000), Err(Rejection::Replayed));
        // The same record unsigned, as MAVLink 2 or 1.
        for version in [MavlinkVersion::V2, MavlinkVersion::V1] {
            assert_eq!(
                ground.admit(&unsigned(2, version), NOW),
                Err(Rejection::Unsigned)
            );
        }
        // Altered after signing (the record's byte), or another key's.
        let mut altered = signed(&mut signer, 3, NOW + 3_000);
        altered[10 + 4] ^= 0x01;
        assert_eq!(
            ground.admit(&altered, NOW + 3_000),
            Err(Rejection::BadSignature)
        );
        let mut other = Signer::new(Key::new([8; 32]), 0, None);
        assert_eq!(
            ground.admit(&signed(&mut other, 4, NOW), NOW),
            Err(Rejection::BadSignature)
        );
        // Garbage is no signed frame.
        assert_eq!(ground.admit(b"\xfd\x01", NOW), Err(Rejection::Unsigned));
        assert_eq!(ground.admit(&[], NOW), Err(Rejection::Unsigned));
        let r = ground.refusals();
        assert_eq!(
            (r.accepted, r.replayed, r.unsigned, r.bad_signature),
            (2, 2, 4, 2)
        );
        assert_eq!(
            r.words(),
            "8 refused (4 unsigned, 2 bad signature, 2 replayed)"
        );
        // A new stream an hour old: stale.
        let mut late = SignedDownlink::new(Key::new([7; 32]));
        let mut old = Signer::new(Key::new([7; 32]), 0, None);
        let hour = 3_600_000_000;
        assert_eq!(
            late.admit(&signed(&mut old, 0, NOW - hour), NOW),
            Err(Rejection::Stale)
        );
    }
}
