//! The net and project loader (TOML): the input is a project folder as
//! `name\0text\0name\0text…`, `project.toml` among them; the loader must
//! load it or say why, never panic or hang.
#![no_main]

use std::collections::BTreeMap;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let mut files = BTreeMap::new();
    let mut parts = text.split('\0');
    while let (Some(name), Some(body)) = (parts.next(), parts.next()) {
        files.insert(name.to_owned(), body.to_owned());
    }
    if let Ok(project) = nets::load(&files) {
        // A project that loads starts.
        let mut player = nets::Player::start(std::sync::Arc::new(project), 0);
        let _ = player.effects().count();
    }
    // With the ArduPilot profile's catalog, as `petrel run` loads it
    // (compiled once).
    static CATALOG: std::sync::OnceLock<Option<nets::load::Catalog>> = std::sync::OnceLock::new();
    let catalog = CATALOG.get_or_init(|| {
        elaboration::Profile::builtin("ardupilot")
            .ok()
            .map(|p| p.catalog())
    });
    if let Some(catalog) = catalog {
        let _ = nets::load_with(&files, catalog);
    }
});
