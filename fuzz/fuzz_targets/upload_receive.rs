//! A version sent up from the ground (`petrel_core::mirror::upload`), on
//! the vehicle's end: any bytes cut into packets of upload records (as the
//! operator's gate lets signed ones through) fed to the receiver over
//! time, then whatever it completes read as a version's files. Memory
//! stays bounded, nothing panics, and only bytes that hash to their
//! offer's digest come out.
#![no_main]

use libfuzzer_sys::fuzz_target;
use petrel_core::mirror::record;
use petrel_core::mirror::upload::{files_from, Config, Receiver};

fuzz_target!(|data: &[u8]| {
    let mut receiver = Receiver::new(Config::default());
    let mut t = 0u64;
    // Each packet: one length byte, then that many bytes.
    let mut rest = data;
    while let Some((&n, tail)) = rest.split_first() {
        let n = usize::from(n).min(tail.len());
        let (packet, tail) = tail.split_at(n);
        rest = tail;
        t += 10_000;
        if let Ok(records) = record::decode_packet(packet) {
            for r in records {
                receiver.handle(t, r);
            }
        }
        receiver.tick(t);
        while receiver.poll_downlink().is_some() {}
        while let Some((upload, bytes)) = receiver.poll_complete() {
            let _ = files_from(&bytes);
            receiver.verdict(upload, "refused: fuzzed");
        }
    }
    // The files' own encoding, on any bytes.
    if let Ok(files) = files_from(data) {
        assert!(files.iter().all(|(p, _)| !p.starts_with('/') && !p.contains("..")));
    }
});
