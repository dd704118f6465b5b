//! The tlog reader and the elaborator: any bytes as a telemetry log, each
//! frame elaborated with the built-in ArduPilot and PX4 profiles, ticks
//! between frames, every event drained.
#![no_main]

use std::sync::OnceLock;

use elaboration::{Config, Elaborator, Profile, TlogReader};
use libfuzzer_sys::fuzz_target;

/// The built-in profiles, compiled once (compiling them is not what is
/// fuzzed here, and would make each run take 40 ms).
fn profiles() -> &'static [Profile] {
    static PROFILES: OnceLock<Vec<Profile>> = OnceLock::new();
    PROFILES.get_or_init(|| {
        ["ardupilot", "px4"]
            .into_iter()
            .filter_map(|n| Profile::builtin(n).ok())
            .collect()
    })
}

fuzz_target!(|data: &[u8]| {
    for profile in profiles() {
        let profile = profile.clone();
        let mut e = Elaborator::new(profile, Config::default());
        let mut last = 0u64;
        for rec in TlogReader::new(data) {
            if rec.time_us > last {
                e.tick(rec.time_us);
            }
            last = last.max(rec.time_us);
            e.frame(rec.time_us, &rec.frame);
            while e.poll_event().is_some() {}
        }
        e.tick(last.saturating_add(60_000_000));
        while e.poll_event().is_some() {}
    }
});
