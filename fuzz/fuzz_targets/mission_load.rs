//! The mission loader and compiler (`petrel-mission`): any text as a
//! project's mission file. It loads or is refused; never a panic, and
//! every problem points at the project's own files, never only at text
//! the compiler generated.
#![no_main]

use std::collections::BTreeMap;

use libfuzzer_sys::fuzz_target;

const PROJECT: &str = r#"name = "fuzz"
mission = "steps.toml"

[globals]
on_ground = true
airborne = false
down = false

[events]
ready_for_takeoff = "nominal"
altitude_reached = { category = "nominal", params = ["alt"] }
landed = "nominal"
link_lost = "communication"
link_restored = "communication"
engine_failure = "catastrophic"
battery_low = "safety"

[programs.DEC.functions]
replan = { args = ["failed"], returns = ["waypoints"] }
"#;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let files = BTreeMap::from([
        ("project.toml".to_owned(), PROJECT.to_owned()),
        ("steps.toml".to_owned(), text.to_owned()),
    ]);
    for catalog in [None, Some(&nets::load::Catalog::new())] {
        if let Err(e) = petrel_mission::load(&files, catalog) {
            assert!(!e.problems.is_empty());
            for p in &e.problems {
                assert!(
                    p.file.name == "steps.toml" || p.file.name == "project.toml",
                    "a problem only in generated text: {p}"
                );
            }
        }
    }
});
