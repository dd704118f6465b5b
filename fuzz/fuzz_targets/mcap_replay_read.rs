//! The MCAP reader behind `petrel replay` (gateway/src/record/read.rs) and
//! `petrel recover` (recover.rs), compiled from the gateway's sources: any
//! bytes as a recording.
#![no_main]

use libfuzzer_sys::fuzz_target;

#[allow(dead_code)]
mod record {
    #[path = "../../../gateway/src/record/layout.rs"]
    pub mod layout;
    #[path = "../../../gateway/src/record/read.rs"]
    pub mod read;
    #[path = "../../../gateway/src/record/recover.rs"]
    pub mod recover;
}

fuzz_target!(|data: &[u8]| {
    if let Ok(rec) = record::read::read(data, true) {
        // What replay asks of it.
        for (_, _, input) in &rec.inputs {
            if let record::layout::Input::Frame(i) = input {
                let _ = rec.frame(*i);
            }
        }
        let _ = rec.frame(u64::MAX);
    }
    let _ = record::recover::recover(data, std::io::Cursor::new(Vec::new()));
});
