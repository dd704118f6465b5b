//! Arbitrary bytes never panic the reader, the frame parser, the
//! elaborator or the profile loader.

use elaboration::{Config, Elaborator, Frame, Profile, TlogReader};
use proptest::prelude::*;

fn valid_log() -> Vec<u8> {
    use elaboration::frame::serialize;
    use mavlink::dialects::ardupilotmega::*;
    let mut w = elaboration::TlogWriter::new(Vec::new());
    for i in 0..40u8 {
        let msg = match i % 3 {
            0 => MavMessage::HEARTBEAT(HEARTBEAT_DATA::DEFAULT),
            1 => MavMessage::SYS_STATUS(SYS_STATUS_DATA::DEFAULT),
            _ => MavMessage::GPS_RAW_INT(GPS_RAW_INT_DATA::DEFAULT),
        };
        let h = mavlink::MavHeader {
            system_id: 1,
            component_id: 1,
            sequence: i,
        };
        let v = if i % 2 == 0 {
            mavlink::MavlinkVersion::V2
        } else {
            mavlink::MavlinkVersion::V1
        };
        let _ = w.write_frame(i as u64 * 250_000, &serialize(h, v, &msg));
    }
    w.into_inner().unwrap_or_default()
}

fn run(bytes: &[u8], elab: &mut Elaborator) -> u64 {
    let mut reader = TlogReader::new(bytes);
    let mut n = 0;
    for rec in reader.by_ref() {
        elab.frame(rec.time_us, &rec.frame);
        while elab.poll_event().is_some() {}
        n += 1;
    }
    assert_eq!(reader.stats().frames, n);
    n
}

/// A frame with a valid checksum (rust-mavlink's CRC and the dialect's CRC
/// extra) around arbitrary payload bytes: what a buggy or hostile sender
/// can put on a link, and what random bytes almost never reach.
fn frame_around(v2: bool, id: u32, seq: u8, sysid: u8, compid: u8, payload: &[u8]) -> Vec<u8> {
    let extra = elaboration::frame::extra_crc(id).unwrap_or(0);
    let mut bytes = if v2 {
        let id = id.to_le_bytes();
        vec![
            0xFD,
            payload.len() as u8,
            0,
            0,
            seq,
            sysid,
            compid,
            id[0],
            id[1],
            id[2],
        ]
    } else {
        vec![0xFE, payload.len() as u8, seq, sysid, compid, id as u8]
    };
    bytes.extend_from_slice(payload);
    let crc = mavlink::calculate_crc(&bytes[1..], extra);
    bytes.extend_from_slice(&crc.to_le_bytes());
    bytes
}

/// Message ids the built-in profiles read, and a few others.
const IDS: [u32; 16] = [
    0, 1, 24, 42, 46, 109, 147, 166, 193, 230, 245, 253, 290, 11030, 225, 30,
];

fn arbitrary_frame() -> impl Strategy<Value = (u64, Vec<u8>)> {
    (
        0u64..200_000_000,
        any::<bool>(),
        prop::sample::select(IDS.to_vec()),
        any::<u8>(),
        prop::sample::select(vec![1u8, 2, 51, 255]),
        prop::sample::select(vec![1u8, 68, 100, 154, 190]),
        proptest::collection::vec(any::<u8>(), 0..=255),
    )
        .prop_map(|(t, v2, id, seq, sysid, compid, payload)| {
            // MAVLink 1 carries ids below 256 only.
            let v2 = v2 || id > 255;
            (t, frame_around(v2, id, seq, sysid, compid, &payload))
        })
}

proptest! {
    // Each case is up to 200 frames through a freshly compiled profile.
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Frames with valid checksums and arbitrary contents (enum values out
    /// of range, truncated MAVLink 2 payloads, times going backwards) from
    /// the vehicle, its components, a ground station and others, after a
    /// real autopilot HEARTBEAT: every frame is read and counted, and the
    /// elaborator never panics.
    #[test]
    fn frames_with_valid_checksums_and_arbitrary_contents_never_panic(
        frames in proptest::collection::vec(arbitrary_frame(), 0..200),
        profile in prop::sample::select(vec!["ardupilot", "px4"]),
    ) {
        use elaboration::frame::serialize;
        use mavlink::dialects::ardupilotmega::*;
        let hb = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            ..HEARTBEAT_DATA::DEFAULT
        });
        let h = mavlink::MavHeader { system_id: 1, component_id: 1, sequence: 0 };
        let mut w = elaboration::TlogWriter::new(Vec::new());
        let _ = w.write_frame(0, &serialize(h, mavlink::MavlinkVersion::V2, &hb));
        for (t, bytes) in &frames {
            let _ = w.write_frame(*t, bytes);
        }
        let log = w.into_inner().unwrap_or_default();
        let mut elab = Elaborator::new(Profile::builtin(profile).expect("profile"), Config::default());
        let n = run(&log, &mut elab);
        prop_assert_eq!(n, frames.len() as u64 + 1);
        let stats = elab.stats();
        prop_assert_eq!(stats.frames, n);
        elab.tick(u64::MAX);
        while elab.poll_event().is_some() {}
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..4096)) {
        let _ = Frame::parse(&bytes);
        let mut elab = Elaborator::new(Profile::builtin("ardupilot").expect("profile"), Config::default());
        run(&bytes, &mut elab);
        elab.tick(u64::MAX);
    }

    #[test]
    fn corrupted_logs_never_panic(
        flips in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..64),
        cut in any::<prop::sample::Index>(),
    ) {
        let mut bytes = valid_log();
        for (at, b) in flips {
            let i = at.index(bytes.len());
            bytes[i] = b;
        }
        let end = cut.index(bytes.len() + 1);
        let mut elab = Elaborator::new(Profile::builtin("px4").expect("profile"), Config::default());
        run(&bytes[..end], &mut elab);
    }

    #[test]
    fn arbitrary_profile_text_never_panics(text in "\\PC{0,300}") {
        let _ = Profile::load(&[("fuzz.toml", &text)]);
        let rule = format!("[rules.x]\ncategory = \"safety\"\nwhen = \"{}\"\n", text.replace(['"', '\\', '\n'], ""));
        let _ = Profile::load(&[("fuzz.toml", &rule)]);
    }
}

#[test]
fn a_clean_log_reads_whole() {
    let bytes = valid_log();
    let mut elab = Elaborator::new(
        Profile::builtin("ardupilot").expect("profile"),
        Config::default(),
    );
    assert_eq!(run(&bytes, &mut elab), 40);
}

/// Found by `cargo fuzz` (profile_load): a problem whose span starts inside
/// a multi-byte character panicked while it was placed at line:col.
#[test]
fn a_problem_inside_a_multibyte_character_is_placed_without_a_panic() {
    let text = std::fs::read(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fixtures/fuzz-profile-span-in-a-char.toml"),
    )
    .expect("the fixture");
    let text = String::from_utf8_lossy(&text);
    let base = elaboration::profile::builtin("ardupilot").unwrap_or("");
    let loaded = elaboration::Profile::load(&[("ardupilot.toml", base), ("fuzz.toml", &text)]);
    let alone = elaboration::Profile::load(&[("fuzz.toml", &text)]);
    assert!(
        loaded.is_err() || alone.is_err(),
        "the fixture is a broken profile"
    );
}
