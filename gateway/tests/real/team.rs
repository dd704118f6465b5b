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

use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::MavCmd;

use crate::team_run::{fixture, petrel, replay_agrees, Timeline};
use harness::{free_udp_port, mavproxy_log, route, two_copters, Router};
use scratch::Scratch;

/// SITL's --speedup, and the gateway's --time-scale.
const SPEEDUP: u32 = 5;
/// Wall-clock bound on the flight (boot, EKF, both takeoffs, RTL).
const LIMIT: Duration = Duration::from_secs(180);

#[test]
fn two_real_copters_take_off_under_one_petrel_and_r2_alone_is_sent_home() {
    // A turn to fly (real/main.rs: at most two flights at once, each on
    // instances of its own).
    let turn = crate::sitl_turn();
    let test = "two_real_copters_take_off_under_one_petrel_and_r2_alone_is_sent_home";
    let started = Instant::now();
    let tmp = Scratch::new("team");
    let dir = tmp.path();
    let Some((mavproxy, sitl1, sitl2)) = two_copters(test, turn.instance(15), SPEEDUP, dir) else {
        return;
    };
    let project = fixture("team-copters");
    let port = free_udp_port();
    let mut gw = petrel(
        &project,
        &format!("udpin:127.0.0.1:{port}"),
        dir,
        SPEEDUP,
        LIMIT,
    );
    let router_log = dir.join("router.tlog");
    let mut router = route(&mavproxy, [&sitl1, &sitl2], &[port], dir);
    let flew = loop {
        if Timeline::read(dir).fired("TEAM", "r2_going_home") {
            // Time for RTL to show in the router's log.
            std::thread::sleep(Duration::from_secs(2));
            break true;
        }
        if started.elapsed() > LIMIT || !gw.running() || !router.running() {
            break false;
        }
        std::thread::sleep(Duration::from_millis(200));
    };
    gw.stop();
    router.stop();
    drop((sitl1, sitl2));
    let t = Timeline::read(dir);
    let routed = Router::read(&router_log);
    eprintln!(
        "{test}: {:.1} s of wall time; climbed to {:.1} m (R1) and {:.1} m (R2); {} commands through the router",
        started.elapsed().as_secs_f64(),
        routed.max_alt[1],
        routed.max_alt[2],
        routed.commands.len()
    );
    assert!(
        flew,
        "the team never got both airborne and R2 home within {LIMIT:?}\n{}\nMAVProxy:\n{}",
        t.decisions(),
        mavproxy_log(dir)
    );
    t.tagged_by_vehicle();
    for net in ["TAKEOFF@R1", "TAKEOFF@R2"] {
        assert!(
            t.fired(net, "airborne") || t.fired(net, "airborne_late"),
            "{net}"
        );
    }
    // The router's view: every command Petrel sent (component 191) went to
    // the system it speaks as; both were told to arm and armed after it;
    // RTL (NAV_RETURN_TO_LAUNCH) went to vehicle 2 only.
    let ours: Vec<_> = routed.commands.iter().filter(|c| c.2 == 191).collect();
    for c in &ours {
        assert_eq!(
            c.1, c.3,
            "Petrel commanded another vehicle as this one: {c:?}"
        );
    }
    for v in [1u8, 2] {
        let arm = ours
            .iter()
            .find(|c| c.3 == v && c.4 == MavCmd::MAV_CMD_COMPONENT_ARM_DISARM && c.5 == 1.0)
            .unwrap_or_else(|| panic!("no arm command to vehicle {v}"));
        let armed = routed.first_armed[usize::from(v)].expect("armed");
        assert!(armed > arm.0, "vehicle {v} armed before it was told to");
        assert!(routed.max_alt[usize::from(v)] > 3.0, "vehicle {v} climbed");
    }
    let rtl: Vec<_> = t
        .commands()
        .into_iter()
        .filter(|(verb, _)| verb == "rtl")
        .collect();
    assert_eq!(rtl, [("rtl".to_owned(), "R2".to_owned())]);
    let home: Vec<u8> = ours
        .iter()
        .filter(|c| c.4 == MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH)
        .map(|c| c.3)
        .collect();
    assert!(
        !home.is_empty() && home.iter().all(|&v| v == 2),
        "RTL to R2 only: {ours:?}"
    );
    let replayed = replay_agrees(dir, &project);
    replayed.tagged_by_vehicle();
}
