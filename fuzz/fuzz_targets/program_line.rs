//! The program protocol's line parser (`petrel_core::programs::protocol`):
//! any line a program may send.
#![no_main]

use libfuzzer_sys::fuzz_target;

use petrel_core::programs::protocol;

fuzz_target!(|data: &[u8]| {
    let Ok(line) = std::str::from_utf8(data) else {
        return;
    };
    if line.len() <= protocol::MAX_LINE {
        let _ = protocol::parse(line);
    }
});
