//! The flight-test example's project (examples/uav-flight-test), loaded
//! once, for the targets and seed generators that need a player.

use std::collections::BTreeMap;
use std::sync::{Arc, OnceLock};

use nets::Project;

pub fn project() -> Option<Arc<Project>> {
    static PROJECT: OnceLock<Option<Arc<Project>>> = OnceLock::new();
    PROJECT
        .get_or_init(|| {
            let files: BTreeMap<String, String> = [
                (
                    "project.toml",
                    include_str!("../../examples/uav-flight-test/project.toml"),
                ),
                (
                    "catastrophic.toml",
                    include_str!("../../examples/uav-flight-test/catastrophic.toml"),
                ),
                (
                    "safety.toml",
                    include_str!("../../examples/uav-flight-test/safety.toml"),
                ),
                (
                    "payload.toml",
                    include_str!("../../examples/uav-flight-test/payload.toml"),
                ),
                (
                    "communication.toml",
                    include_str!("../../examples/uav-flight-test/communication.toml"),
                ),
                (
                    "init.toml",
                    include_str!("../../examples/uav-flight-test/init.toml"),
                ),
                (
                    "mission-state.toml",
                    include_str!("../../examples/uav-flight-test/mission-state.toml"),
                ),
                (
                    "flight.toml",
                    include_str!("../../examples/uav-flight-test/flight.toml"),
                ),
                (
                    "operations.toml",
                    include_str!("../../examples/uav-flight-test/operations.toml"),
                ),
            ]
            .into_iter()
            .map(|(n, t)| (n.to_owned(), t.to_owned()))
            .collect();
            nets::load(&files).ok().map(Arc::new)
        })
        .clone()
}
