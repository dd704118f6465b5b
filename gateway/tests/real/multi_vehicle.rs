//! Two real ArduCopters on one link, each supervised by its own `petrel
//! run` (docs/multi-vehicle.md).
//!
//! ArduPilot's own SITL flies vehicle 1 (`-I6 --sysid 1`) and vehicle 2
//! (`-I7 --sysid 2`). MAVProxy routes both onto one link, with one `--out`
//! per gateway:
//!
//! ```text
//! copter sysid 1 ─SERIAL0─┐                 ┌─udp─▶ petrel A  system_id = 2: GUIDED, arm, takeoff 10 m
//!                         ├─ MAVProxy ──────┤
//! copter sysid 2 ─SERIAL0─┘                 └─udp─▶ petrel B  system_id = 1: watches, commands nothing
//!               └─SERIAL1──── its own link ───────▶ petrel C  no system_id: locks on the first autopilot
//! ```
//!
//! Only A commands. Asserted: each gateway's events name only its own
//! vehicle; A and B each report the other vehicle ignored, once; C says
//! it locked on vehicle 2; from the router's own log (MAVProxy's tlog),
//! every command a gateway sent targets its own vehicle, vehicle 2 armed
//! only after A's arm command and climbed, vehicle 1 was never armed nor
//! commanded to. A's recording replays with `--check-against`.
//!
//! A second test needs nothing: two scripted vehicles (HEARTBEATs and
//! COMMAND_ACKs from one UDP socket, as a router would) and two gateways,
//! one configured for vehicle 2, one locking on the first autopilot heard.
//!
//! The first needs the SITL binaries (`../shared/ardupilot-sitl`) and MAVProxy
//! (`mavproxy.py`, pip): without them it prints why and passes, except
//! with `CI=true`, where it fails.

use crate::scratch;

use crate::harness;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use crate::gateways::{fixture, petrel_with, Gateway};
use harness::{free_udp_port, mavproxy_log, route, two_copters, Process, Router};
use scratch::Scratch;

/// SITL's --speedup, and the gateways' --time-scale.
const SPEEDUP: u32 = 5;
/// Wall-clock bound on the flight (boot, EKF, takeoff).
const LIMIT: Duration = Duration::from_secs(150);
/// After A's nets see the takeoff, the climb to 10 m goes on for this long.
const CLIMB: Duration = Duration::from_secs(4);

/// `petrel run PROJECT --mavlink ADDRESS`, timeline to `dir/NAME.jsonl`,
/// log to `dir/NAME.err`, recording to `dir/NAME.mcap`.
fn petrel(name: &'static str, project: &Path, address: &str, dir: &Path) -> Process {
    petrel_with(name, project, address, dir, SPEEDUP, LIMIT)
}

#[test]
fn two_copters_on_one_router_each_supervised_and_commanded_by_its_own_gateway() {
    // A turn to fly (real/main.rs: at most two flights at once, each on
    // instances of its own).
    let turn = crate::sitl_turn();
    let test = "two_copters_on_one_router_each_supervised_and_commanded_by_its_own_gateway";
    let started = Instant::now();
    let tmp = Scratch::new("multi-vehicle");
    let dir = tmp.path();
    let Some((mavproxy, sitl1, mut sitl2)) = two_copters(test, turn.instance(6), SPEEDUP, dir)
    else {
        return;
    };

    // The gateways behind the router listen first; MAVProxy's connection
    // to both SERIAL0 starts the simulations.
    let (port_a, port_b) = (free_udp_port(), free_udp_port());
    let mut a = petrel(
        "a",
        &fixture("copter2_takeoff"),
        &format!("udpin:127.0.0.1:{port_a}"),
        dir,
    );
    let mut b = petrel(
        "b",
        &fixture("copter1_watch"),
        &format!("udpin:127.0.0.1:{port_b}"),
        dir,
    );
    let router_log = dir.join("router.tlog");
    let mut router = route(&mavproxy, [&sitl1, &sitl2], &[port_a, port_b], dir);
    // Vehicle 2's own link: SERIAL1 listens once the simulation runs.
    let serial1 = format!("SERIAL1 on TCP port {}", sitl2.port(1));
    while !sitl2.output().contains(&serial1) {
        assert!(
            started.elapsed() < Duration::from_secs(30) && sitl2.running(),
            "SITL 2 never opened SERIAL1 (is MAVProxy connected?):\n{}\nMAVProxy:\n{}",
            sitl2.output(),
            mavproxy_log(dir)
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    let mut c = petrel("c", &fixture("first_heard_watch"), &sitl2.address(1), dir);

    // Fly until A's nets have seen vehicle 2 take off, and a little more.
    let flew = loop {
        if Gateway::read("a", dir).fired("airborne") {
            std::thread::sleep(CLIMB);
            break true;
        }
        if started.elapsed() > LIMIT || !(a.running() && b.running() && c.running()) {
            break false;
        }
        if !router.running() {
            break false;
        }
        std::thread::sleep(Duration::from_millis(200));
    };
    for p in [&mut a, &mut b, &mut c, &mut router] {
        p.stop();
    }
    drop((sitl1, sitl2));
    let flight = started.elapsed();
    let (a, b, c) = (
        Gateway::read("a", dir),
        Gateway::read("b", dir),
        Gateway::read("c", dir),
    );
    let routed = Router::read(&router_log);
    eprintln!(
        "{test}: flown in {:.1} s of wall time; vehicle 2 climbed to {:.1} m, vehicle 1 to {:.1} m; {} commands through the router",
        flight.as_secs_f64(),
        routed.max_alt[2],
        routed.max_alt[1],
        routed.commands.len()
    );
    for gw in [&a, &b, &c] {
        let summary = gw.log.lines().find(|l| l.starts_with("stopped after"));
        eprintln!("{test}: {}: {}", gw.name, summary.unwrap_or("no summary"));
    }
    assert!(
        flew,
        "vehicle 2 never took off within {LIMIT:?}\nA:\n{}{}\nB:\n{}\nC:\n{}\nMAVProxy:\n{}",
        a.decisions(),
        a.log,
        b.log,
        c.log,
        mavproxy_log(dir)
    );

    // Each gateway heard only its own vehicle, and said whom it ignored.
    a.only_from(2);
    b.only_from(1);
    c.only_from(2);
    assert_eq!(a.told("ignoring vehicle 1 ("), 1, "A's log:\n{}", a.log);
    assert_eq!(a.told("supervising vehicle 2 ("), 1, "A's log:\n{}", a.log);
    assert_eq!(b.told("ignoring vehicle 2 ("), 1, "B's log:\n{}", b.log);
    assert_eq!(b.told("supervising vehicle 1 ("), 1, "B's log:\n{}", b.log);
    assert_eq!(
        c.told("supervising vehicle 2 (ARDUPILOTMEGA QUADROTOR, autopilot component 1): the first autopilot heard"),
        1,
        "C's log:\n{}",
        c.log
    );
    // A commanded its vehicle, which armed and took off; B and C heard
    // theirs ready; B's vehicle never left the ground, C's (vehicle 2) did.
    for (event, gw) in [("armed", &a), ("takeoff", &a), ("ready_for_takeoff", &b)] {
        assert!(gw.heard(event), "{}: no {event}", gw.name);
    }
    assert!(a.fired("airborne") && c.fired("airborne") && b.fired("ready"));
    assert!(!b.heard("armed") && !b.heard("takeoff") && !b.fired("airborne"));
    assert_eq!((b.commands(), c.commands()), (0, 0));
    assert!(a.commands() >= 3, "GUIDED, arm, takeoff");

    // The router's view: every command a gateway (component 191) sent
    // targets its own system; vehicle 1 was never told to arm, and never
    // armed; vehicle 2 armed after A's arm command, and climbed.
    assert!(routed.heartbeats[1] > 10 && routed.heartbeats[2] > 10);
    let gateway_commands: Vec<_> = routed.commands.iter().filter(|c| c.2 == 191).collect();
    assert!(!gateway_commands.is_empty());
    for c in &gateway_commands {
        assert_eq!(c.1, c.3, "a gateway commanded another vehicle: {c:?}");
    }
    assert!(routed.arms_to(1).is_empty(), "{:?}", routed.arms_to(1));
    assert_eq!(routed.first_armed[1], None, "vehicle 1 armed");
    let arms = routed.arms_to(2);
    let first_arm = arms.first().expect("an arm command to vehicle 2");
    assert_eq!((first_arm.1, first_arm.2), (2, 191), "A sent it");
    let armed = routed.first_armed[2].expect("vehicle 2 armed");
    assert!(armed > first_arm.0, "vehicle 2 armed before it was told to");
    assert!(routed.max_alt[2] > 5.0, "vehicle 2 climbed");
    assert!(routed.max_alt[1] < 1.0, "vehicle 1 stayed down");

    // A's recording replays to the same decisions.
    let replay = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .arg("replay")
        .arg(dir.join("a.mcap"))
        .arg(fixture("copter2_takeoff"))
        .arg("--check-against")
        .output()
        .expect("petrel replay");
    assert!(
        replay.status.success(),
        "A's recording does not replay:\n{}{}",
        String::from_utf8_lossy(&replay.stdout),
        String::from_utf8_lossy(&replay.stderr)
    );
    eprintln!(
        "{test}: {:.1} s of wall time in all",
        started.elapsed().as_secs_f64()
    );
}
