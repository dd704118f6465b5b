//! The MCAP reader behind `petrel replay` (`petrel_record::read`) and
//! `petrel recover` (`petrel_record::recover`): any bytes as a recording.
#![no_main]

use libfuzzer_sys::fuzz_target;
use petrel_record::{layout, read, recover};

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
