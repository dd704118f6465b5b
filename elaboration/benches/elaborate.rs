//! Frames per second through the tlog reader and the elaborator with the
//! full ArduPilot profile, beside rust-mavlink's bare typed parse of the same
//! frames, on the largest shared tlog held in memory.
//!
//! `cargo bench -p elaboration --bench elaborate`

use std::path::Path;
use std::sync::OnceLock;

use divan::counter::ItemsCount;
use divan::Bencher;
use elaboration::{Config, Elaborator, Profile, TlogReader};
use mavlink::dialects::ardupilotmega::MavMessage;

const LOG: &str = "ardusub_2023-04-18_sub_qgc_baddata.tlog";

struct Input {
    /// The tlog as recorded (timestamps, and 1967 bad-CRC records).
    tlog: Vec<u8>,
    /// The same valid frames back to back, without timestamps.
    frames: Vec<u8>,
    count: usize,
}

fn input() -> Option<&'static Input> {
    static INPUT: OnceLock<Option<Input>> = OnceLock::new();
    INPUT
        .get_or_init(|| {
            let path = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../shared/telemetry")
                .join(LOG);
            let tlog = match std::fs::read(&path) {
                Ok(b) => b,
                Err(e) => {
                    eprintln!("skipped: {}: {e}", path.display());
                    return None;
                }
            };
            let mut frames = Vec::with_capacity(tlog.len());
            let mut count = 0;
            for rec in TlogReader::new(&tlog) {
                frames.extend_from_slice(rec.frame.bytes());
                count += 1;
            }
            Some(Input {
                tlog,
                frames,
                count,
            })
        })
        .as_ref()
}

fn main() {
    divan::main();
}

/// Baseline: rust-mavlink's `MavlinkReader::read_any_message` decoding every
/// frame (MAVLink 1 and 2) of the same bytes.
#[divan::bench]
fn bare_rust_mavlink_parse(bencher: Bencher) {
    let Some(input) = input() else { return };
    bencher.counter(ItemsCount::new(input.count)).bench(|| {
        let mut reader = mavlink::MavlinkReader::new(&input.frames[..]);
        let mut n = 0usize;
        while let Ok((_, msg)) = reader.read_any_message::<MavMessage>() {
            divan::black_box(&msg);
            n += 1;
        }
        assert_eq!(n, input.count);
    });
}

/// Reading the tlog (timestamps, framing, CRC) and elaborating every frame
/// with the built-in ArduPilot profile.
#[divan::bench]
fn tlog_and_elaboration(bencher: Bencher) {
    let Some(input) = input() else { return };
    let profile = Profile::builtin("ardupilot").expect("built-in profile");
    bencher
        .counter(ItemsCount::new(input.count))
        .with_inputs(|| Elaborator::new(profile.clone(), Config::default()))
        .bench_local_values(|mut elab| {
            let mut events = 0usize;
            for rec in TlogReader::new(&input.tlog) {
                elab.frame(rec.time_us, &rec.frame);
                while elab.poll_event().is_some() {
                    events += 1;
                }
            }
            divan::black_box(events);
            elab
        });
}

/// Reading the tlog alone (timestamps, framing, CRC), for the share of the
/// elaborator in the figure above.
#[divan::bench]
fn tlog_read_only(bencher: Bencher) {
    let Some(input) = input() else { return };
    bencher.counter(ItemsCount::new(input.count)).bench(|| {
        let mut n = 0usize;
        for rec in TlogReader::new(&input.tlog) {
            divan::black_box(&rec);
            n += 1;
        }
        assert_eq!(n, input.count);
    });
}
