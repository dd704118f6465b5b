//! A team project (`[[vehicle]]`, docs/nets.md "Teams of vehicles") as
//! the gateway runs it: each vehicle's elaboration lane (its profile, its
//! `{sysid, compid}`), its commander's configuration, and the links the
//! team needs, each opened once however many vehicles share it.
//!
//! `run` and `replay` both build their lanes here, so that a replay
//! elaborates each vehicle as the flight did. A project without a team has
//! one lane, unqualified, and one link.

use std::path::Path;

use elaboration::{Config, Profile};
use nets::Project;

use crate::profile::Layers;
use crate::supervisor::Lane;
use crate::vehicle::config::VehicleConfig;

/// The built-in family of a profile's layers (`px4` or `ardupilot`): the
/// base a vehicle's profile file extends.
pub fn family(layers: &[(String, String)]) -> &'static str {
    match layers.first().map(|(n, _)| n.as_str()) {
        Some("px4.toml") => "px4",
        _ => "ardupilot",
    }
}

/// The elaboration lanes: without a team, one (`base` and `config`); a
/// team, one per vehicle in team order, with the vehicle's `profile`
/// (`ardupilot`, `px4` or a file beside project.toml extending the built-in
/// `family`) or else `base`, and the vehicle's system and component.
pub fn lanes(
    project: &Project,
    dir: &Path,
    base: &Profile,
    family: &str,
    config: &Config,
) -> Result<Vec<Lane>, miette::Report> {
    if project.vehicles.is_empty() {
        return Ok(vec![Lane {
            vehicle: None,
            profile: base.clone(),
            config: config.clone(),
        }]);
    }
    project
        .vehicles
        .iter()
        .map(|v| {
            let profile = match &v.profile {
                None => base.clone(),
                Some(choice) => Layers::choose(choice, Some(dir), family)
                    .map_err(|e| miette::miette!("vehicle {}: {e}", v.name))?
                    .load()
                    .map_err(|problems| {
                        miette::miette!(
                            "vehicle {}: its profile {choice} does not load:\n{problems}",
                            v.name
                        )
                    })?,
            };
            Ok(Lane {
                vehicle: Some(v.name.clone()),
                profile,
                config: Config {
                    sysid: Some(v.system),
                    compid: Some(v.component),
                    firmware: None,
                    tick_us: config.tick_us,
                },
            })
        })
        .collect()
}

/// The commander's configuration for each vehicle of the team (team
/// order): the `[gateway]` one (timing, payloads, parameters) with the
/// vehicle's system and autopilot component; without a team, `base`.
pub fn commanders(project: &Project, base: &VehicleConfig) -> Vec<VehicleConfig> {
    if project.vehicles.is_empty() {
        return vec![base.clone()];
    }
    project
        .vehicles
        .iter()
        .map(|v| {
            let firmware = match v.profile.as_deref() {
                Some("px4") => Some(elaboration::Firmware::Px4),
                _ => None,
            };
            VehicleConfig {
                system: Some(v.system),
                autopilot_component: Some(v.component),
                firmware: firmware.or(base.firmware),
                ..base.clone()
            }
        })
        .collect()
}

/// The links to open, each once: `(address, the vehicles on it)` in the
/// order first named. A vehicle without `link` is on `default` (the
/// command line's or `[gateway]`'s). Without a team: `default`, vehicle 0.
pub fn links(project: &Project, default: &str) -> Vec<(String, Vec<usize>)> {
    let mut links: Vec<(String, Vec<usize>)> = Vec::new();
    let count = project.vehicles.len().max(1);
    for v in 0..count {
        let address = project
            .vehicles
            .get(v)
            .and_then(|v| v.link.as_deref())
            .unwrap_or(default);
        match links.iter_mut().find(|(a, _)| a == address) {
            Some((_, on)) => on.push(v),
            None => links.push((address.to_owned(), vec![v])),
        }
    }
    links
}

#[cfg(test)]
mod tests {
    use super::*;

    fn team(vehicles: &str) -> Project {
        let files = [
            (
                "project.toml",
                format!(
                    "name = \"t\"\n{vehicles}\n[[net]]\nfile = \"m.toml\"\nactive = true\n"
                ),
            ),
            (
                "m.toml",
                "name = \"M\"\nvehicles = \"all\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\n\n[[transition]]\nname = \"go\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"armed\"\n"
                    .to_owned(),
            ),
        ];
        let sources: std::collections::BTreeMap<String, String> = files
            .iter()
            .map(|(n, t)| ((*n).to_owned(), t.clone()))
            .collect();
        nets::load::load(&sources).expect("the team loads")
    }

    #[test]
    fn vehicles_sharing_a_link_open_it_once() {
        let p = team(
            "[[vehicle]]\nname = \"R1\"\nsystem = 1\n\n[[vehicle]]\nname = \"R2\"\nsystem = 2\nlink = \"udpin:0.0.0.0:14560\"\n\n[[vehicle]]\nname = \"R3\"\nsystem = 3\n",
        );
        assert_eq!(
            links(&p, "udpin:0.0.0.0:14550"),
            [
                ("udpin:0.0.0.0:14550".to_owned(), vec![0, 2]),
                ("udpin:0.0.0.0:14560".to_owned(), vec![1]),
            ]
        );
        let base = VehicleConfig {
            quadplane: true,
            ..VehicleConfig::default()
        };
        let configs = commanders(&p, &base);
        let ids: Vec<_> = configs
            .iter()
            .map(|c| (c.system, c.autopilot_component, c.quadplane))
            .collect();
        assert_eq!(
            ids,
            [
                (Some(1), Some(1), true),
                (Some(2), Some(1), true),
                (Some(3), Some(1), true)
            ]
        );
    }

    #[test]
    fn each_vehicle_elaborates_with_its_profile_and_ids() {
        let p = team(
            "[[vehicle]]\nname = \"R1\"\nsystem = 4\ncomponent = 2\n\n[[vehicle]]\nname = \"R2\"\nsystem = 5\nprofile = \"px4\"\n",
        );
        let layers = Layers::builtin("ardupilot");
        let base = layers.load().expect("the built-in profile loads");
        let config = Config {
            tick_us: 50_000,
            ..Config::default()
        };
        let lanes =
            lanes(&p, Path::new("."), &base, family(&layers.layers), &config).expect("lanes");
        let got: Vec<_> = lanes
            .iter()
            .map(|l| {
                (
                    l.vehicle.clone(),
                    l.config.sysid,
                    l.config.compid,
                    l.config.tick_us,
                )
            })
            .collect();
        assert_eq!(
            got,
            [
                (Some("R1".to_owned()), Some(4), Some(2), 50_000),
                (Some("R2".to_owned()), Some(5), Some(1), 50_000)
            ]
        );
        // R2's profile is PX4's: it reads PX4's event catalog.
        let px4 = Layers::builtin("px4").load().expect("px4 loads");
        assert_eq!(
            lanes[1].profile.catalog().keys().collect::<Vec<_>>(),
            px4.catalog().keys().collect::<Vec<_>>()
        );
        // A profile file that is not there is a clear error naming the vehicle.
        let p = team("[[vehicle]]\nname = \"R1\"\nsystem = 1\nprofile = \"missing.toml\"\n");
        let e = super::lanes(&p, Path::new("/nonexistent"), &base, "ardupilot", &config)
            .expect_err("refused");
        assert!(
            e.to_string()
                .starts_with("vehicle R1: cannot read the profile"),
            "{e}"
        );
        assert!(e.to_string().contains("missing.toml"), "{e}");
        // Without a team: one unqualified lane with the given config.
        let single = super::lanes(&team_free(), Path::new("."), &base, "ardupilot", &config)
            .expect("one lane");
        assert_eq!(single.len(), 1);
        assert_eq!(single[0].vehicle, None);
        assert_eq!(single[0].config, config);
    }

    fn team_free() -> Project {
        let sources: std::collections::BTreeMap<String, String> = [
            (
                "project.toml",
                "name = \"s\"\n[[net]]\nfile = \"m.toml\"\nactive = true\n",
            ),
            (
                "m.toml",
                "name = \"M\"\nplaces = [\"a\"]\ninitial = [\"a\"]\n",
            ),
        ]
        .iter()
        .map(|(n, t)| ((*n).to_owned(), (*t).to_owned()))
        .collect();
        nets::load::load(&sources).expect("loads")
    }
}

/// Projects for tests, here and in other crates (the `fixtures` feature).
#[cfg(any(test, feature = "fixtures"))]
pub mod fixtures {
    use nets::Project;
    use std::sync::Arc;

    /// A team of two (R1 system 1, R2 system 2), each instance of `M`
    /// firing `go` on its vehicle's `armed` and then commanding it.
    pub fn team() -> Arc<Project> {
        let sources = [
            (
                "project.toml",
                "name = \"t\"\n[[vehicle]]\nname = \"R1\"\nsystem = 1\n\n[[vehicle]]\nname = \"R2\"\nsystem = 2\n\n[[net]]\nfile = \"m.toml\"\nactive = true\n",
            ),
            (
                "m.toml",
                "name = \"M\"\nvehicles = \"all\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\n\n[[transition]]\nname = \"go\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"armed\"\ndo = [\"command takeoff {alt: 10}\"]\n",
            ),
        ];
        let profile = crate::profile::Layers::builtin("ardupilot")
            .load()
            .expect("profile");
        Arc::new(
            nets::load::load_with(&sources, &crate::project::catalog(&profile))
                .expect("the team loads"),
        )
    }
}

/// The supervisor running a team: each vehicle's frames through its own
/// lane, its events qualified, commands addressed to it.
#[cfg(test)]
mod supervised {
    use crate::supervisor::{Input, Step, Supervisor};
    use elaboration::Config;
    use mavlink::dialects::ardupilotmega::{
        MavAutopilot, MavMessage, MavModeFlag, MavState, MavType, HEARTBEAT_DATA,
    };
    use mavlink::{MavHeader, MavlinkVersion};
    use nets::{Effect, Project};
    use std::sync::Arc;

    use super::fixtures::team;

    fn heartbeat(system: u8, armed: bool) -> Vec<u8> {
        let header = MavHeader {
            system_id: u32::from(system),
            component_id: 1,
            sequence: 0,
        };
        let mut base_mode = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
        if armed {
            base_mode |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
        }
        let hb = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: 4,
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode,
            system_status: MavState::MAV_STATE_STANDBY,
            mavlink_version: 3,
        });
        elaboration::frame::serialize(header, MavlinkVersion::V2, &hb)
    }

    fn start(project: &Arc<Project>) -> Supervisor {
        let layers = crate::profile::Layers::builtin("ardupilot");
        let profile = layers.load().expect("profile");
        let lanes = super::lanes(
            project,
            std::path::Path::new("."),
            &profile,
            super::family(&layers.layers),
            &Config::default(),
        )
        .expect("lanes");
        Supervisor::start_lanes(project.clone(), lanes, 0).0
    }

    fn names(step: &Step) -> Vec<String> {
        step.events
            .iter()
            .map(|(e, _)| e.event.name.clone())
            .filter(|n| n.starts_with("armed") || n.starts_with("disarmed"))
            .collect()
    }

    fn commanded(step: &Step) -> Vec<Option<nets::model::VehicleId>> {
        step.events
            .iter()
            .flat_map(|(_, effects)| effects)
            .filter_map(|e| match e {
                Effect::Command { vehicle, .. } => Some(*vehicle),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn each_vehicles_events_reach_its_own_instance_qualified() {
        let project = team();
        let mut sup = start(&project);
        let mut t = 0;
        let mut feed = |sup: &mut Supervisor, bytes: &[u8]| {
            t += 100_000;
            sup.step(t, Input::Frame(bytes))
        };
        // Both vehicles heard disarmed: nothing fires.
        assert!(commanded(&feed(&mut sup, &heartbeat(1, false))).is_empty());
        assert!(commanded(&feed(&mut sup, &heartbeat(2, false))).is_empty());
        // Vehicle 2 arms: `armed@R2`, and M@R2 (only) commands R2.
        let step = feed(&mut sup, &heartbeat(2, true));
        assert_eq!(names(&step), ["armed@R2"]);
        assert!(step.events.iter().all(|(e, _)| e.sysid == 2));
        assert_eq!(commanded(&step), [Some(1)]);
        assert!(in_b(&sup, &project, "M@R2") && !in_b(&sup, &project, "M@R1"));
        // A system that is no vehicle of the team arming (it reaches every
        // lane): no lane follows it, no event.
        let step = feed(&mut sup, &heartbeat(9, true));
        assert!(step.events.is_empty(), "{:?}", step.events);
        // Vehicle 1 arms: `armed@R1`, M@R1 commands R1.
        let step = feed(&mut sup, &heartbeat(1, true));
        assert_eq!(names(&step), ["armed@R1"]);
        assert_eq!(commanded(&step), [Some(0)]);
        assert!(in_b(&sup, &project, "M@R1") && in_b(&sup, &project, "M@R2"));
    }

    /// Whether instance `net` has its token in `b`.
    fn in_b(sup: &Supervisor, project: &Project, net: &str) -> bool {
        let n = project
            .nets
            .iter()
            .position(|x| x.name == net)
            .expect("net");
        sup.player().is_marked(n, nets::model::PlaceRef::Local(1))
    }

    #[test]
    fn a_team_replays_bit_for_bit() {
        let project = team();
        let frames = [
            heartbeat(1, false),
            heartbeat(2, false),
            heartbeat(2, true),
            heartbeat(1, true),
        ];
        let run = || {
            let mut sup = start(&project);
            for (i, f) in frames.iter().enumerate() {
                sup.step((i as u64 + 1) * 100_000, Input::Frame(f));
                sup.step((i as u64 + 1) * 100_000 + 50_000, Input::Tick);
            }
            sup.player().digest()
        };
        assert_eq!(run(), run());
    }
}
