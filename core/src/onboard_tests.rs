//! The onboard core and the ground's station in one process, in simulated
//! time, against the simulated ArduPlane's core (`sitl_tests::Vehicle`):
//! no socket, no thread, no clock. The nets arm the vehicle and take off;
//! the downlink goes to a station beside it, which hears the same
//! telemetry.

use std::path::Path;

use mavlink::{MavHeader, MavlinkVersion};

use super::*;
use crate::mirror::station::{Config as StationConfig, Output, Station};
use crate::mirror::MIRROR_SYSTEM;
use crate::vehicle::config::VehicleConfig;

const UNIX: u64 = 1_780_000_000_000_000;

/// Arm when ready, take off, and say so.
const NET: &str = r#"name = "FLIGHT"
places = ["ground", "arming", "rolling", "up"]
initial = ["ground"]
final = ["up"]

[[transition]]
name = "arm"
from = ["ground"]
to = ["arming"]
on = "ready_for_takeoff"
do = ["command arm"]

[[transition]]
name = "arm_refused"
from = ["arming"]
to = ["ground"]
on = "command.failed"

[[transition]]
name = "roll"
from = ["arming"]
to = ["rolling"]
on = "command.ok"
when = 'verb == "arm"'
do = ["command takeoff {alt: 60}"]

[[transition]]
name = "takeoff"
from = ["rolling"]
to = ["up"]
on = "takeoff"
"#;

fn project(dir: &Path) -> (Arc<Project>, Vec<supervisor::Lane>) {
    std::fs::write(
        dir.join("project.toml"),
        "[[net]]\nfile = \"flight.toml\"\nactive = true\n",
    )
    .expect("write");
    std::fs::write(dir.join("flight.toml"), NET).expect("write");
    let layers = crate::profile::Layers::builtin("ardupilot");
    let profile = layers.load().expect("the built-in profile");
    let project =
        crate::project::load_with(dir, &crate::project::catalog(&profile)).expect("it loads");
    let lanes = crate::team::lanes(
        &project,
        dir,
        &profile,
        crate::team::family(&layers.layers),
        &elaboration::Config::default(),
    )
    .expect("lanes");
    (project, lanes)
}

#[test]
fn a_flight_in_simulated_time_takes_off_and_the_station_follows_it_exactly() {
    let dir = tempfile::tempdir().expect("a folder");
    let (project, lanes) = project(dir.path());
    let unread = Unread::of(&lanes);
    let crew = crew(&project, &VehicleConfig::default(), &lanes, &[]);
    let ground_lanes = lanes.clone();
    let (supervisor, start) = Supervisor::start_lanes(project.clone(), lanes, 0);
    let mut core = Onboard::new(
        supervisor,
        crew,
        Some(DownlinkConfig {
            session: 1,
            mirror: MIRROR_SYSTEM,
            unread,
        }),
        None,
        false,
    );
    core.start(0, &start);
    let mut station = Station::new(StationConfig {
        project: project.clone(),
        system: MIRROR_SYSTEM,
        identity: (MIRROR_SYSTEM, 190),
        lanes: ground_lanes,
        signing: None,
        dialog: false,
        record: false,
    });
    let mut sim = sitl_tests::Vehicle::new(sitl_tests::SimConfig {
        boot: sitl_tests::BootTimeline::quick(),
        first_arm_refused: false,
        ..sitl_tests::SimConfig::default()
    });
    let mut fired: Vec<(Micros, String)> = Vec::new();
    let mut disagreements = Vec::new();
    let mut t: Micros = 0;
    let mut up_at = None;
    // Two minutes at most, in steps of 10 ms; 10 s more once up.
    while t < 120_000_000 && up_at.is_none_or(|u| t < u + 10_000_000) {
        t += 10_000;
        sim.advance(t);
        while let Some((header, message)) = sim.poll_transmit() {
            let bytes = elaboration::frame::serialize(header, MavlinkVersion::V2, &message);
            station.handle_frame(t, &bytes, UNIX + t);
            let rx = Received {
                time_us: t,
                bytes,
                version: MavlinkVersion::V2,
                header,
                message: Some(message),
            };
            core.handle_frame(t, 0, rx, UNIX + t);
        }
        if t >= core.poll_timeout() {
            core.handle_timeout(t);
        }
        if t.is_multiple_of(100_000) {
            station.handle_tick(t);
        }
        // What goes up from the ground: to the onboard gateway's link.
        while let Some((to, request)) = station.poll_transmit() {
            let bytes = Tunnel::petrel(to, request.bytes().to_vec())
                .unsigned_frame((MIRROR_SYSTEM, 190), 0);
            let header = MavHeader {
                system_id: u32::from(MIRROR_SYSTEM),
                component_id: 190,
                sequence: 0,
            };
            let rx = Received {
                time_us: t,
                bytes,
                version: MavlinkVersion::V2,
                header,
                message: None,
            };
            core.handle_frame(t, 0, rx, UNIX + t);
        }
        let mut send = |core: &mut Onboard, station: &mut Station| {
            while let Some(tx) = core.poll_transmit(t) {
                match tx {
                    Transmit::Command(c) => {
                        let header = MavHeader {
                            system_id: u32::from(c.from.0),
                            component_id: c.from.1,
                            sequence: 0,
                        };
                        sim.handle(t, &header, &c.message);
                    }
                    Transmit::Downlink { from, tunnel, .. } => {
                        station.handle_frame(t, &tunnel.unsigned_frame(from, 0), UNIX + t);
                    }
                }
            }
        };
        send(&mut core, &mut station);
        assert!(core.poll_call().is_none(), "the net calls no program");
        core.settle();
        while let Some(s) = core.poll_settled() {
            for f in s
                .step
                .effects
                .iter()
                .chain(s.step.events.iter().flat_map(|(_, e)| e))
            {
                if let Effect::Fired {
                    net, transition, ..
                } = f
                {
                    let name = project.nets[*net].transitions[*transition].name.clone();
                    fired.push((s.step.time, name.clone()));
                    if name == "takeoff" {
                        up_at = Some(t);
                    }
                }
            }
        }
        core.publish(t);
        send(&mut core, &mut station);
        while let Some(o) = station.poll_output() {
            if let Output::Disagreement(d) = o {
                disagreements.push(d);
            }
        }
    }
    let names: Vec<&str> = fired.iter().map(|(_, n)| n.as_str()).collect();
    assert!(
        up_at.is_some(),
        "never took off in {} s of simulated time: fired {names:?}, vehicle {:?}",
        t / 1_000_000,
        sim.state().mode
    );
    assert_eq!(names, ["arm", "roll", "takeoff"]);
    // Ten seconds after the takeoff: armed, in TAKEOFF, climbing away.
    let state = sim.state();
    assert!(
        state.armed && state.mode == "TAKEOFF" && state.alt > 10.0,
        "{state:?}"
    );
    // The station's replica is the vehicle's player, exactly.
    let exact = station.replica().exact().expect("the replica is exact");
    let mut exact = exact.clone();
    exact.advance(core.player().state().now);
    assert_eq!(exact.digest(), core.player().digest());
    // The ground, hearing the same telemetry, saw the same events.
    let total = station.ground().total();
    assert!(
        disagreements.is_empty() && total.matched >= 2,
        "{disagreements:?} {total:?}"
    );
}

/// A frame elaborated from the message the link decoded gives the step its
/// bytes give (what `petrel replay` parses from the recording): two cores
/// fly one simulated take-off, one handed each frame's decoded message,
/// the other its bytes alone; their commands, steps and digests are the
/// same, frame after frame.
#[test]
fn a_decoded_frame_steps_as_its_bytes_do() {
    let dir = tempfile::tempdir().expect("a folder");
    let (project, lanes) = project(dir.path());
    let core = || {
        let crew = crew(&project, &VehicleConfig::default(), &lanes, &[]);
        let (supervisor, start) = Supervisor::start_lanes(project.clone(), lanes.clone(), 0);
        let mut core = Onboard::new(supervisor, crew, None, None, true);
        core.start(0, &start);
        core
    };
    let (mut decoded, mut from_bytes) = (core(), core());
    let mut sim = sitl_tests::Vehicle::new(sitl_tests::SimConfig {
        boot: sitl_tests::BootTimeline::quick(),
        first_arm_refused: false,
        ..sitl_tests::SimConfig::default()
    });
    let (mut frames, mut steps, mut fired) = (0, 0, Vec::new());
    let mut t: Micros = 0;
    while t < 90_000_000 {
        t += 10_000;
        sim.advance(t);
        while let Some((header, message)) = sim.poll_transmit() {
            let bytes = elaboration::frame::serialize(header, MavlinkVersion::V2, &message);
            let rx = |message| Received {
                time_us: t,
                bytes: bytes.clone(),
                version: MavlinkVersion::V2,
                header,
                message,
            };
            decoded.handle_frame(t, 0, rx(Some(message.clone())), UNIX + t);
            // Without its message, a core elaborates the frame's bytes (its
            // commanders do not hear it: they are given it alone).
            from_bytes.handle_vehicle_message(0, t, &header, &message);
            from_bytes.handle_frame(t, 0, rx(None), UNIX + t);
            frames += 1;
        }
        for core in [&mut decoded, &mut from_bytes] {
            if t >= core.poll_timeout() {
                core.handle_timeout(t);
            }
        }
        loop {
            let (a, b) = (decoded.poll_transmit(t), from_bytes.poll_transmit(t));
            assert_eq!(format!("{a:?}"), format!("{b:?}"), "at {t} µs");
            let Some(Transmit::Command(c)) = a else {
                break;
            };
            let header = MavHeader {
                system_id: u32::from(c.from.0),
                component_id: c.from.1,
                sequence: 0,
            };
            sim.handle(t, &header, &c.message);
        }
        decoded.settle();
        from_bytes.settle();
        loop {
            let (a, b) = (decoded.poll_settled(), from_bytes.poll_settled());
            let (Some(a), Some(b)) = (a, b) else {
                assert!(decoded.poll_settled().is_none() && from_bytes.poll_settled().is_none());
                break;
            };
            assert_eq!(
                format!("{:?}", a.step),
                format!("{:?}", b.step),
                "at {t} µs"
            );
            assert_eq!(a.digest, b.digest, "at {t} µs");
            steps += 1;
            for (_, effects) in &a.step.events {
                for e in effects {
                    if let Effect::Fired { transition, .. } = e {
                        fired.push(*transition);
                    }
                }
            }
        }
    }
    assert!(frames > 1_000, "{frames} frames");
    assert!(steps > 1_000, "{steps} steps");
    // The flight was flown: arm, roll, take-off all fired on events.
    assert!(fired.len() >= 2, "fired {fired:?}");
}
