//! The program protocol's line parser (gateway/src/programs/protocol.rs,
//! compiled from the gateway's sources): any line a program may send.
#![no_main]

use libfuzzer_sys::fuzz_target;

#[allow(dead_code)]
#[path = "../../gateway/src/programs/protocol.rs"]
mod protocol;

fuzz_target!(|data: &[u8]| {
    let Ok(line) = std::str::from_utf8(data) else {
        return;
    };
    if line.len() <= protocol::MAX_LINE {
        let _ = protocol::parse(line);
    }
});
