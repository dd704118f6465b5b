//! One `petrel run` supervising a team of vehicles (docs/multi-vehicle.md,
//! "A team"; docs/nets.md, "Teams of vehicles").
//!
//! The scripted tests need nothing: copters scripted on loopback UDP
//! (HEARTBEATs changing mode after 1.5 s, armed once told to, every
//! COMMAND_LONG answered by the vehicle it targets), first both behind one
//! link (a router) with a third vehicle that is no vehicle of the team,
//! then each on its own link. The project (`fixtures/team-scripted`): an
//! ARM template arms each vehicle when it changes mode; a team net lands
//! R2, and only R2, once both are armed. Asserted: every event is tagged
//! with the vehicle whose system sent it, the outsider's frames are
//! dropped and told once, every command went to the vehicle it names on
//! that vehicle's link as that vehicle's component 191, the land command
//! only after both armed, the commands' effects name their vehicle, and
//! the recording replays with `--check-against`, its events qualified.
//!
//! The real test flies two ArduCopter SITLs behind MAVProxy (one link):
//! a TAKEOFF template guides, arms and takes off each; once both are
//! airborne the team net sends R2 home (RTL). It needs the SITL binaries
//! (`../shared/ardupilot-sitl`) and `mavproxy.py`: without them it prints
//! why and passes, except under `CI=true`, where it fails.

use crate::scratch;

use crate::harness;

use std::net::{SocketAddr, UdpSocket};
use std::path::Path;
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::{MavCmd, MavMessage, MavResult, COMMAND_ACK_DATA};

use crate::team_run::{fixture, petrel, replay_agrees, Timeline};
use harness::{copter_heartbeat, frame, free_udp_port};
use scratch::Scratch;

/// A command the scripted vehicles received.
#[derive(Debug, Clone, Copy)]
struct Received {
    /// The scripted link it came in on.
    link: usize,
    at: Instant,
    sender: (u8, u8),
    target: u8,
    command: MavCmd,
    param1: f32,
}

/// One scripted link: a socket speaking for `systems` to the gateway's
/// `to`. A system on several links is one vehicle heard on each.
struct ScriptedLink {
    socket: UdpSocket,
    to: SocketAddr,
    systems: Vec<u8>,
}

/// Flies the scripted vehicles until `done` or `limit`: HEARTBEATs at
/// 10 Hz (STABILIZE, then after 1.5 s AUTO for vehicles 1 and 3, LOITER
/// for 2), armed once an arm command reached them; each COMMAND_LONG
/// answered ACCEPTED by its target, on the link it came in on, when that
/// link carries the target.
fn fly(links: &[ScriptedLink], limit: Duration, mut done: impl FnMut() -> bool) -> Vec<Received> {
    let started = Instant::now();
    for l in links {
        l.socket
            .set_read_timeout(Some(Duration::from_millis(5)))
            .expect("timeout");
    }
    let mut received = Vec::new();
    let mut seq = [0u8; 256];
    let mut armed = [false; 256];
    let mut next_heartbeat = Instant::now();
    let mut next_check = Instant::now();
    let mut buf = [0u8; 600];
    while started.elapsed() < limit {
        if Instant::now() >= next_check {
            next_check += Duration::from_millis(250);
            if done() {
                break;
            }
        }
        if Instant::now() >= next_heartbeat {
            next_heartbeat += Duration::from_millis(100);
            let later = started.elapsed() > Duration::from_millis(1500);
            for l in links {
                for &system in &l.systems {
                    let mode = match (later, system) {
                        (false, _) => 0,
                        (true, 2) => 5,
                        (true, _) => 3,
                    };
                    let s = usize::from(system);
                    seq[s] = seq[s].wrapping_add(1);
                    let hb = copter_heartbeat(mode, armed[s]);
                    let _ = l.socket.send_to(&frame(system, 1, seq[s], &hb), l.to);
                }
            }
        }
        for (i, l) in links.iter().enumerate() {
            let Ok((n, from)) = l.socket.recv_from(&mut buf) else {
                continue;
            };
            let Ok(f) = elaboration::Frame::parse(&buf[..n]) else {
                continue;
            };
            let sender = (f.system_id(), f.component_id());
            let Ok(MavMessage::COMMAND_LONG(c)) = f.decode() else {
                continue;
            };
            received.push(Received {
                link: i,
                at: Instant::now(),
                sender,
                target: c.target_system,
                command: c.command,
                param1: c.param1,
            });
            if !l.systems.contains(&c.target_system) {
                continue;
            }
            let t = usize::from(c.target_system);
            if c.command == MavCmd::MAV_CMD_COMPONENT_ARM_DISARM {
                armed[t] = c.param1 == 1.0;
            }
            seq[t] = seq[t].wrapping_add(1);
            let ack = MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
                command: c.command,
                result: MavResult::MAV_RESULT_ACCEPTED,
                progress: 0,
                result_param2: 0,
                target_system: sender.0,
                target_component: sender.1,
            });
            let _ = l
                .socket
                .send_to(&frame(c.target_system, 1, seq[t], &ack), from);
        }
    }
    received
}

fn is_arm(r: &Received) -> bool {
    r.command == MavCmd::MAV_CMD_COMPONENT_ARM_DISARM && r.param1 == 1.0
}

/// What both scripted cases assert of the commands the vehicles received:
/// each armed once, by its own gateway identity, on its own link, and asked
/// for its telemetry; the land command to R2 only, after both armed;
/// nothing to anyone else.
fn commands_routed(received: &[Received], link_of: impl Fn(u8) -> usize) {
    assert!(!received.is_empty(), "no command reached the vehicles");
    for r in received {
        assert_eq!(r.sender, (r.target, 191), "as its own vehicle: {r:?}");
        assert!(matches!(r.target, 1 | 2), "a command to an outsider: {r:?}");
        assert_eq!(r.link, link_of(r.target), "on its vehicle's link: {r:?}");
    }
    let arms = |t: u8| {
        received
            .iter()
            .filter(|r| is_arm(r) && r.target == t)
            .count()
    };
    assert_eq!((arms(1), arms(2)), (1, 1), "{received:?}");
    let landing: Vec<_> = received
        .iter()
        .filter(|r| r.command == MavCmd::MAV_CMD_NAV_LAND)
        .collect();
    // Each commander asked its own autopilot for the telemetry it reads.
    for t in [1, 2] {
        assert!(
            received
                .iter()
                .any(|r| r.target == t && r.command == MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL),
            "no telemetry request to vehicle {t}: {received:?}"
        );
    }
    assert!(!landing.is_empty(), "no land command: {received:?}");
    let last_arm = received
        .iter()
        .filter(|r| is_arm(r))
        .map(|r| r.at)
        .max()
        .expect("arms");
    for r in &landing {
        assert_eq!(r.target, 2, "only R2 is told to land: {r:?}");
        assert!(r.at > last_arm, "land before both armed: {r:?}");
    }
}

/// The gateway's own view: instances armed their vehicles, the team net
/// landed R2, the effects name their vehicle; the recording agrees.
fn supervised(dir: &Path, project: &Path) -> Timeline {
    let t = Timeline::read(dir);
    t.tagged_by_vehicle();
    for net in ["ARM@R1", "ARM@R2"] {
        assert!(t.fired(net, "arm_ok"), "{net}:\n{}", t.decisions());
    }
    assert!(t.fired("TEAM", "land_r2") && t.fired("TEAM", "r2_landing"));
    let commands = t.commands();
    assert_eq!(
        commands,
        [
            ("arm".to_owned(), "R1".to_owned()),
            ("arm".to_owned(), "R2".to_owned()),
            ("land".to_owned(), "R2".to_owned())
        ],
        "{}",
        t.decisions()
    );
    let replayed = replay_agrees(dir, project);
    replayed.tagged_by_vehicle();
    assert_eq!(replayed.events().len(), t.events().len());
    t
}

#[test]
fn a_team_on_one_link_each_vehicle_hears_and_is_commanded_alone() {
    let started = Instant::now();
    let tmp = Scratch::new("team");
    let dir = tmp.path();
    let project = fixture("team-scripted");
    let port = free_udp_port();
    let limit = Duration::from_secs(20);
    let mut gw = petrel(&project, &format!("udpin:127.0.0.1:{port}"), dir, 1, limit);
    std::thread::sleep(Duration::from_millis(300));
    // The "router": one socket for R1, R2 and vehicle 3, no vehicle of the team.
    let links = [ScriptedLink {
        socket: UdpSocket::bind("127.0.0.1:0").expect("bind"),
        to: SocketAddr::from(([127, 0, 0, 1], port)),
        systems: vec![1, 2, 3],
    }];
    let received = fly(&links, limit, || {
        Timeline::read(dir).fired("TEAM", "r2_landing")
    });
    gw.stop();
    eprintln!(
        "one link: {:.1} s of wall time, {} commands",
        started.elapsed().as_secs_f64(),
        received.len()
    );
    let t = supervised(dir, &project);
    commands_routed(&received, |_| 0);
    assert_eq!(t.told("supervising vehicle 1 ("), 1, "{}", t.log);
    assert_eq!(t.told("supervising vehicle 2 ("), 1, "{}", t.log);
    assert_eq!(
        t.told("ignoring vehicle 3 (ARDUPILOTMEGA QUADROTOR, autopilot component 1): no vehicle of the team"),
        1,
        "{}",
        t.log
    );
}

#[test]
fn a_team_on_two_links_each_vehicle_is_commanded_on_its_own() {
    let started = Instant::now();
    let tmp = Scratch::new("team");
    let dir = tmp.path();
    let (port_a, port_b) = (free_udp_port(), free_udp_port());
    // The fixture with R2 on a link of its own.
    let project = dir.join("project");
    std::fs::create_dir(&project).expect("project folder");
    for file in ["arm.toml", "team.toml"] {
        std::fs::copy(fixture("team-scripted").join(file), project.join(file)).expect("copied");
    }
    let text = std::fs::read_to_string(fixture("team-scripted/project.toml")).expect("project");
    let text = text.replace(
        "system = 2\n",
        &format!("system = 2\nlink = \"udpin:127.0.0.1:{port_b}\"\n"),
    );
    std::fs::write(project.join("project.toml"), text).expect("written");
    let limit = Duration::from_secs(20);
    let mut gw = petrel(
        &project,
        &format!("udpin:127.0.0.1:{port_a}"),
        dir,
        1,
        limit,
    );
    std::thread::sleep(Duration::from_millis(300));
    // R2 is heard on link A too (a radio both hear): there it is dropped.
    let links = [
        ScriptedLink {
            socket: UdpSocket::bind("127.0.0.1:0").expect("bind"),
            to: SocketAddr::from(([127, 0, 0, 1], port_a)),
            systems: vec![1, 2],
        },
        ScriptedLink {
            socket: UdpSocket::bind("127.0.0.1:0").expect("bind"),
            to: SocketAddr::from(([127, 0, 0, 1], port_b)),
            systems: vec![2],
        },
    ];
    let received = fly(&links, limit, || {
        Timeline::read(dir).fired("TEAM", "r2_landing")
    });
    gw.stop();
    eprintln!(
        "two links: {:.1} s of wall time, {} commands",
        started.elapsed().as_secs_f64(),
        received.len()
    );
    let t = supervised(dir, &project);
    commands_routed(&received, |system| usize::from(system == 2));
    assert_eq!(
        t.told(&format!(
            "udpin:127.0.0.1:{port_a}: ignoring vehicle 2 (ARDUPILOTMEGA QUADROTOR, autopilot component 1): no vehicle of the team on this link"
        )),
        1,
        "{}",
        t.log
    );
    assert_eq!(
        t.told(&format!(
            "udpin:127.0.0.1:{port_b}: supervising vehicle 2 ("
        )),
        1,
        "{}",
        t.log
    );
}
