//! The point-mass model as a client sees it in the telemetry (the core
//! driven in simulated time): the glide with the engine off at the
//! configured glide ratio, the cruise airspeed, the bank limit in turns,
//! the climb, the wind.

use mavlink::dialects::ardupilotmega::*;
use sitl_tests::{Airframe, BootTimeline, Fault, SimConfig};

use super::common::{mission_item, Client};

fn quick(cfg: SimConfig) -> SimConfig {
    SimConfig {
        boot: BootTimeline::quick(),
        first_arm_refused: false,
        ..cfg
    }
}

/// Boots, takes off in TAKEOFF mode, streams everything at 4 Hz.
fn airborne(cfg: SimConfig) -> Client {
    let mut c = Client::new(quick(cfg));
    c.run_to(3.5);
    c.streams(4);
    assert_eq!(
        c.command(
            MavCmd::MAV_CMD_DO_SET_MODE,
            [1.0, 13.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        ),
        Some(MavResult::MAV_RESULT_ACCEPTED)
    );
    assert_eq!(
        c.command(
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        ),
        Some(MavResult::MAV_RESULT_ACCEPTED)
    );
    assert!(c.run_until(60.0, |s| s.texts_with("Takeoff complete").len() == 1));
    c
}

/// Track length (m) and height lost (m) from GLOBAL_POSITION_INT.
fn track(c: &Client, from: usize) -> (f64, f64, f64) {
    let pos: Vec<(f64, f64, f64)> = c
        .since(from, "GLOBAL_POSITION_INT")
        .into_iter()
        .filter_map(|s| match &s.msg {
            MavMessage::GLOBAL_POSITION_INT(g) => Some((
                g.lat as f64 / 1e7 * 111_319.5,
                g.lon as f64 / 1e7 * 111_319.5 * (-35.363261f64).to_radians().cos(),
                g.relative_alt as f64 / 1000.0,
            )),
            _ => None,
        })
        .collect();
    let mut dist = 0.0;
    for w in pos.windows(2) {
        dist += (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1);
    }
    (dist, pos[0].2, pos[pos.len() - 1].2)
}

#[test]
fn the_glide_with_the_engine_failed_follows_its_glide_ratio() {
    for ratio in [4.3, 10.0] {
        let mut c = airborne(SimConfig {
            airframe: Airframe {
                failed_engine_glide_ratio: ratio,
                ..Airframe::default()
            },
            ..SimConfig::default()
        });
        // Wings nearly level: a wide loiter far away, high.
        let home = sitl_tests::Home::default();
        assert_eq!(
            c.reposition(home.lat + 0.05, home.lon, 150.0, 1500.0),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        let t = c.v.state().time_s;
        assert!(c.run_until(t + 120.0, |s| s.alt > 145.0));
        c.v.inject(Fault::EngineFailure);
        // After the propeller has stopped and the speed settled.
        let t = c.v.state().time_s;
        c.run_to(t + 10.0);
        let from = c.got.len();
        assert!(c.run_until(t + 400.0, |s| s.alt < 20.0));
        let (dist, top, bottom) = track(&c, from);
        let measured = dist / (top - bottom);
        println!(
            "glide ratio {ratio}: {measured:.2} ({dist:.0} m for {:.0} m of height)",
            top - bottom
        );
        assert!(
            (measured / ratio - 1.0).abs() < 0.1,
            "glide ratio {measured} for {ratio}"
        );
    }
}

#[test]
fn cruise_bank_limit_and_climb_as_configured() {
    let mut c = airborne(SimConfig {
        params: vec![
            ("AIRSPEED_CRUISE".into(), 18.0),
            ("ROLL_LIMIT_DEG".into(), 30.0),
        ],
        ..SimConfig::default()
    });
    let home = sitl_tests::Home::default();
    let box_ = [(600.0, 0.0), (600.0, 600.0), (0.0, 600.0), (0.0, 0.0)];
    let items: Vec<_> = box_
        .iter()
        .map(|(n, e)| mission_item(&home, MavCmd::MAV_CMD_NAV_WAYPOINT, *n, *e, 60.0))
        .collect();
    assert_eq!(
        c.upload(&items),
        Some(MavMissionResult::MAV_MISSION_ACCEPTED)
    );
    let from = c.got.len();
    assert_eq!(
        c.command(MavCmd::MAV_CMD_MISSION_START, [0.0; 7]),
        Some(MavResult::MAV_RESULT_ACCEPTED)
    );
    assert!(c.run_until(400.0, |s| s.reached.len() == 4));
    let roll = c
        .since(from, "ATTITUDE")
        .into_iter()
        .filter_map(|s| match &s.msg {
            MavMessage::ATTITUDE(a) => Some((a.roll as f64).abs().to_degrees()),
            _ => None,
        })
        .fold(0.0, f64::max);
    assert!(roll <= 30.0 + 1e-3 && roll > 25.0, "largest bank {roll}°");
    let hud: Vec<(f32, f32, f32)> = c
        .since(0, "VFR_HUD")
        .into_iter()
        .filter_map(|s| match &s.msg {
            MavMessage::VFR_HUD(h) => Some((h.airspeed, h.climb, h.groundspeed)),
            _ => None,
        })
        .collect();
    let max_climb = hud.iter().map(|h| h.1).fold(0.0, f32::max);
    assert!(
        (8.0..=13.0).contains(&max_climb),
        "take-off climb {max_climb} m/s"
    );
    // Straight and level on the last leg: the cruise airspeed.
    let tail = &hud[hud.len() - 20..];
    let aspd = tail.iter().map(|h| h.0).sum::<f32>() / tail.len() as f32;
    assert!((aspd - 18.0).abs() < 0.5, "cruise airspeed {aspd}");
    // True airspeed is above the indicated one at 640 m AMSL.
    let gs = tail.iter().map(|h| h.2).sum::<f32>() / tail.len() as f32;
    assert!(gs > aspd, "ground speed {gs} (no wind)");
    println!("bank ≤ {roll:.1}° (limit 30), climb {max_climb:.1} m/s, cruise {aspd:.1} m/s EAS, {gs:.1} m/s over the ground");
}

#[test]
fn the_wind_drifts_the_aircraft_and_the_autopilot_corrects() {
    // 8 m/s toward the east (from the west).
    let mut c = airborne(SimConfig {
        wind: (0.0, 8.0),
        ..SimConfig::default()
    });
    let home = sitl_tests::Home::default();
    let items = vec![
        mission_item(&home, MavCmd::MAV_CMD_NAV_WAYPOINT, 1500.0, 0.0, 60.0),
        mission_item(&home, MavCmd::MAV_CMD_NAV_LOITER_UNLIM, 1500.0, 0.0, 60.0),
    ];
    assert_eq!(
        c.upload(&items),
        Some(MavMissionResult::MAV_MISSION_ACCEPTED)
    );
    assert_eq!(
        c.command(MavCmd::MAV_CMD_MISSION_START, [0.0; 7]),
        Some(MavResult::MAV_RESULT_ACCEPTED)
    );
    let from = c.got.len();
    assert!(c.run_until(300.0, |s| s.reached.iter().any(|r| r.seq == 1)));
    let s = c.v.state();
    // On the leg: flown north, crabbing into the wind, the track held.
    assert!(
        (s.north - 1450.0).abs() < 100.0 && s.east.abs() < 60.0,
        "{} {}",
        s.north,
        s.east
    );
    let wind = c.since(from, "WIND");
    assert!(matches!(&wind[0].msg, MavMessage::WIND(w)
        if (w.speed - 8.0).abs() < 0.01 && (w.direction + 90.0).abs() < 0.01));
}
