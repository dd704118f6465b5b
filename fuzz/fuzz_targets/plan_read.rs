//! The plan readers (`petrel-mission`): any text as a QGroundControl
//! `.plan` and as a `QGC WPL` file. Either reads or is refused; every item
//! read has its sequence.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    for plan in [
        petrel_mission::read("f.plan", text),
        petrel_mission::qgc::read("f.plan", text),
        petrel_mission::wpl::read("f.txt", text),
    ]
    .into_iter()
    .flatten()
    {
        for (k, item) in plan.items.iter().enumerate() {
            assert_eq!(usize::from(item.seq), k + 1);
        }
    }
});
