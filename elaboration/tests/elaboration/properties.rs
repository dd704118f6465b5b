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
