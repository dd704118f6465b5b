//! The elaboration profile loader: a user's profile (TOML) over the
//! built-in ArduPilot one, and alone.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let base = elaboration::profile::builtin("ardupilot").unwrap_or("");
    let _ = elaboration::Profile::load(&[("ardupilot.toml", base), ("fuzz.toml", text)]);
    if let Ok(p) = elaboration::Profile::load(&[("fuzz.toml", text)]) {
        let _ = p.catalog();
        let _ = p.telemetry();
    }
});
