//! The PNML reader: any text as a PNML document, then as a P/T net.
#![no_main]

use libfuzzer_sys::fuzz_target;
use nets::verify::pnml;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(doc) = pnml::read_document(text) {
        for net in &doc.nets {
            let _ = net.to_ptnet();
        }
        let _ = pnml::write_document(&doc);
    }
    if let Ok(net) = pnml::read_ptnet(text) {
        // What it reads, it writes back and reads again.
        let again = pnml::read_ptnet(&pnml::write_ptnet(&net));
        assert!(again.is_ok(), "a net read from PNML does not read back: {again:?}");
    }
});
