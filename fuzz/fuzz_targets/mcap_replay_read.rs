//! The MCAP reader behind `petrel replay` (gateway/src/record/read.rs) and
//! `petrel recover` (recover.rs), compiled from the gateway's sources: any
//! bytes as a recording.
#![no_main]

use libfuzzer_sys::fuzz_target;

// At the crate's root, as `super::` in them expects.
#[allow(dead_code)]
#[path = "../../gateway/src/record/fields.rs"]
mod fields;
#[allow(dead_code)]
#[path = "../../gateway/src/record/layout.rs"]
mod layout;
#[allow(dead_code)]
#[path = "../../gateway/src/record/read.rs"]
mod read;
#[allow(dead_code)]
#[path = "../../gateway/src/record/recover.rs"]
mod recover;

fuzz_target!(|data: &[u8]| {
    if let Ok(rec) = read::read(data, true) {
        // What replay asks of it.
        for (_, _, input) in &rec.inputs {
            if let layout::Input::Frame(i) = input {
                let _ = rec.frame(*i);
            }
        }
        let _ = rec.frame(u64::MAX);
    }
    let _ = recover::recover(data, std::io::Cursor::new(Vec::new()));
});
