//! Play scripts (`petrel play --events`): any text as a script, parsed,
//! then played on the uav-survey example's player line by line.
#![no_main]

use std::collections::BTreeMap;
use std::sync::{Arc, OnceLock};

use libfuzzer_sys::fuzz_target;
use nets::{Player, Project};

fn project() -> Option<Arc<Project>> {
    static PROJECT: OnceLock<Option<Arc<Project>>> = OnceLock::new();
    PROJECT
        .get_or_init(|| {
            let files: BTreeMap<String, String> = [
                ("project.toml", include_str!("../../examples/uav-survey/project.toml")),
                ("mission.toml", include_str!("../../examples/uav-survey/mission.toml")),
                ("events.toml", include_str!("../../examples/uav-survey/events.toml")),
            ]
            .into_iter()
            .map(|(n, t)| (n.to_owned(), t.to_owned()))
            .collect();
            nets::load(&files).ok().map(Arc::new)
        })
        .clone()
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(lines) = nets::script::parse(text) else {
        return;
    };
    let Some(project) = project() else {
        return;
    };
    let mut player = Player::start(project, 0);
    for line in &lines {
        let _ = nets::script::play_line(&mut player, line);
        let _ = player.effects().count();
    }
});
