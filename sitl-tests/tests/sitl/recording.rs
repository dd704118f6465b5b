//! The simulation against ArduPilot's own SITL: the recorded client's
//! messages are replayed to the simulated vehicle at the same times (in
//! sim time since boot; the mission items answered as the vehicle asks for
//! them, as that client did), and what the simulation sends is compared
//! with what ArduPlane 4.7 sent: message set, stream rates, start-up
//! order, COMMAND_ACK results, the mission exchange, the arming refusal,
//! the STATUSTEXTs, the flight's timeline, the events Petrel's elaboration
//! derives, and the kinematics.

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use elaboration::{Config, Elaborator, Frame, Profile, TlogReader};
use mavlink::dialects::ardupilotmega::*;
use mavlink::MavHeader;
use regex::Regex;
use sitl_tests::{SimConfig, Vehicle};

use super::common::{drain, name, shared_file, Sent};

const TLOG: &str = "telemetry/SITL_arduplane-4.7.0dev_auto_mission_land.tlog";

/// Message types the simulation sends that the recorded plane does not,
/// and why.
const SIM_ONLY: &[(&str, &str)] = &[(
    "EFI_STATUS",
    "the simulated engine is a combustion engine with an EFI; the recorded SITL plane is electric",
)];

/// Recorded STATUSTEXTs the simulation does not say, and why.
const TEXTS_NOT_SIMULATED: &[(&str, &str)] = &[
    (
        "EKF2 IMUN is using GPS",
        "EKF2 runs beside EKF3 in SITL and starts using the GPS in flight; only EKF3's is simulated",
    ),
    (
        "EKF2 IMUN is using GPS",
        "(IMU1 of the same)",
    ),
];

/// A decoded record: time since boot (µs), sender, message.
struct Rec {
    time_us: u64,
    header: MavHeader,
    msg: MavMessage,
    bytes: Vec<u8>,
}

struct Recording {
    /// Frames of the autopilot (system 1, component 1).
    vehicle: Vec<Rec>,
    /// Frames of the client (system 255).
    client: Vec<Rec>,
    /// Boot time of the first record (µs).
    offset_us: u64,
}

fn read(bytes: &[u8]) -> Recording {
    let mut raw = Vec::new();
    let mut t0 = None;
    for r in TlogReader::new(bytes) {
        let t = *t0.get_or_insert(r.time_us);
        let Ok(msg) = r.frame.decode() else { continue };
        raw.push((
            r.time_us - t,
            r.frame.header(),
            msg,
            r.frame.bytes().to_vec(),
        ));
    }
    // Boot time = log time + offset: the least-delayed time-stamped frame
    // gives the offset.
    let offset_us = raw
        .iter()
        .filter_map(|(t, _, m, _)| {
            let boot_ms = match m {
                MavMessage::SYSTEM_TIME(s) => s.time_boot_ms,
                MavMessage::ATTITUDE(a) => a.time_boot_ms,
                _ => return None,
            };
            (boot_ms as u64 * 1000).checked_sub(*t)
        })
        .max()
        .unwrap_or(0);
    let mut vehicle = Vec::new();
    let mut client = Vec::new();
    for (t, header, msg, bytes) in raw {
        let rec = Rec {
            time_us: t + offset_us,
            header,
            msg,
            bytes,
        };
        match (header.system_id, header.component_id) {
            (1, 1) => vehicle.push(rec),
            (255, _) => client.push(rec),
            _ => {}
        }
    }
    Recording {
        vehicle,
        client,
        offset_us,
    }
}

/// Flies the simulation as the recorded client flew ArduPlane.
fn simulate(rec: &Recording, end_us: u64) -> Vec<Sent> {
    let mut v = Vehicle::new(SimConfig::default());
    let items: BTreeMap<u16, &Rec> = rec
        .client
        .iter()
        .filter_map(|r| match &r.msg {
            MavMessage::MISSION_ITEM_INT(i) => Some((i.seq, r)),
            _ => None,
        })
        .collect();
    let script: Vec<&Rec> = rec
        .client
        .iter()
        .filter(|r| !matches!(r.msg, MavMessage::MISSION_ITEM_INT(_)))
        .collect();
    let mut out: Vec<Sent> = Vec::new();
    let mut scanned = 0;
    let mut pending: VecDeque<(u64, u16)> = VecDeque::new();
    let mut next = 0;
    let mut t = 0;
    while t < end_us {
        t += 5_000;
        v.advance(t);
        drain(&mut v, &mut out);
        while next < script.len() && script[next].time_us <= t {
            let r = script[next];
            v.handle(t, &r.header, &r.msg);
            drain(&mut v, &mut out);
            next += 1;
        }
        // The client answers each item request 17 ms later, as recorded.
        for s in &out[scanned..] {
            #[allow(deprecated)]
            if let MavMessage::MISSION_REQUEST(m) = &s.msg {
                pending.push_back((s.time_us + 17_000, m.seq));
            }
            if let MavMessage::MISSION_REQUEST_INT(m) = &s.msg {
                pending.push_back((s.time_us + 17_000, m.seq));
            }
        }
        scanned = out.len();
        while pending.front().is_some_and(|(at, _)| *at <= t) {
            let Some((_, seq)) = pending.pop_front() else {
                break;
            };
            if let Some(r) = items.get(&seq) {
                v.handle(t, &r.header, &r.msg);
                drain(&mut v, &mut out);
            }
        }
    }
    out
}

/// Replaces the numbers of a STATUSTEXT by N, keeping mission sequence
/// numbers ("Mission: 2 WP", "Reached waypoint #2").
fn normalize(text: &str) -> String {
    let keep = Regex::new(r"^(Mission: \d+|Reached waypoint #\d+|Passed waypoint #\d+)").unwrap();
    let num = Regex::new(r"-?\d+(\.\d+)?").unwrap();
    match keep.find(text) {
        Some(m) => format!("{}{}", m.as_str(), num.replace_all(&text[m.end()..], "N")),
        None => num.replace_all(text, "N").into_owned(),
    }
}

/// Whether `needle` is a subsequence of `hay`.
fn missing_from(needle: &[String], hay: &[String]) -> Vec<String> {
    let mut missing = Vec::new();
    let mut i = 0;
    for n in needle {
        match hay[i..].iter().position(|h| h == n) {
            Some(p) => i += p + 1,
            None => missing.push(n.clone()),
        }
    }
    missing
}

/// Rate (Hz) of a message type after the start-up, over its own span.
fn rate(times: &[u64]) -> Option<f64> {
    let t: Vec<u64> = times.iter().copied().filter(|&t| t >= 5_000_000).collect();
    if t.len() < 20 {
        return None;
    }
    let span = (t[t.len() - 1] - t[0]) as f64 / 1e6;
    Some((t.len() - 1) as f64 / span)
}

fn events(frames: &[(u64, Vec<u8>)]) -> Vec<(u64, String)> {
    let profile = Profile::builtin("ardupilot").expect("the built-in profile loads");
    let mut e = Elaborator::new(profile, Config::default());
    let mut out = Vec::new();
    for (t, bytes) in frames {
        if let Ok(f) = Frame::parse(bytes) {
            e.frame(*t, &f);
        }
        while let Some(ev) = e.poll_event() {
            out.push((ev.time_us, ev.event.name.clone()));
        }
    }
    out
}

struct Report {
    lines: Vec<String>,
    failures: Vec<String>,
}

impl Report {
    fn line(&mut self, s: String) {
        self.lines.push(s);
    }
    fn check(&mut self, ok: bool, what: String) {
        self.lines
            .push(format!("{} {what}", if ok { "ok  " } else { "FAIL" }));
        if !ok {
            self.failures.push(what);
        }
    }
}

fn secs(us: u64) -> f64 {
    us as f64 / 1e6
}

#[test]
fn the_simulation_speaks_as_arduplane_sitl_recorded() {
    let Some(path) = shared_file(TLOG) else {
        return;
    };
    let bytes = match std::fs::read(&path) {
        Ok(b) => b,
        Err(e) => panic!("{}: {e}", path.display()),
    };
    let rec = read(&bytes);
    // The recording ends right after the automatic disarm; the simulated
    // client stays 30 s longer, for a simulation a little behind.
    let rec_end = rec.vehicle.last().map_or(0, |r| r.time_us);
    let end = rec_end + 30_000_000;
    let sim = simulate(&rec, end);
    let sim_ap: Vec<&Sent> = sim.iter().filter(|s| s.header.component_id == 1).collect();
    let mut r = Report {
        lines: Vec::new(),
        failures: Vec::new(),
    };
    r.line(format!(
        "recording: {} autopilot frames, {} client frames, boot offset {:.3} s, {:.1} s; simulation: {} autopilot frames, {} camera frames",
        rec.vehicle.len(),
        rec.client.len(),
        secs(rec.offset_us),
        secs(rec_end),
        sim_ap.len(),
        sim.len() - sim_ap.len()
    ));

    // --- Message set.
    let rec_types: BTreeSet<&str> = rec.vehicle.iter().map(|x| name(&x.msg)).collect();
    let sim_types: BTreeSet<&str> = sim_ap.iter().map(|x| name(&x.msg)).collect();
    let only_rec: Vec<&&str> = rec_types.difference(&sim_types).collect();
    let only_sim: Vec<&&str> = sim_types
        .difference(&rec_types)
        .filter(|t| !SIM_ONLY.iter().any(|(n, _)| n == *t))
        .collect();
    r.check(
        only_rec.is_empty(),
        format!(
            "every one of the {} message types ArduPlane sent is sent: missing {only_rec:?}",
            rec_types.len()
        ),
    );
    r.check(
        only_sim.is_empty(),
        format!("no message type ArduPlane never sent, but {SIM_ONLY:?}: unexpected {only_sim:?}"),
    );
    let camera: BTreeSet<&str> = sim
        .iter()
        .filter(|s| s.header.component_id == 100)
        .map(|s| name(&s.msg))
        .collect();
    r.check(
        camera.iter().eq(["HEARTBEAT"].iter()),
        format!("the camera (component 100) sends only its HEARTBEAT here: {camera:?}"),
    );

    // --- Rates.
    let mut by_type_rec: BTreeMap<&str, Vec<u64>> = BTreeMap::new();
    for x in &rec.vehicle {
        by_type_rec.entry(name(&x.msg)).or_default().push(x.time_us);
    }
    let mut by_type_sim: BTreeMap<&str, Vec<u64>> = BTreeMap::new();
    for x in &sim_ap {
        by_type_sim.entry(name(&x.msg)).or_default().push(x.time_us);
    }
    let mut worst: f64 = 0.0;
    for (t, times) in &by_type_rec {
        // Streams (and TERRAIN_REQUEST, which rides on one); event-driven
        // messages are counted below.
        let Some(rr) = rate(times).filter(|r| *r >= 0.5) else {
            continue;
        };
        let sr = by_type_sim.get(t).and_then(|s| rate(s));
        match sr {
            Some(sr) => {
                let dev = sr / rr - 1.0;
                worst = worst.max(dev.abs());
                r.check(
                    dev.abs() <= 0.2,
                    format!(
                        "{t:<28} rate {sr:6.2} Hz, recorded {rr:6.2} Hz ({:+.1} %)",
                        dev * 100.0
                    ),
                );
            }
            None => r.check(false, format!("{t}: recorded at {rr:.2} Hz, not streamed")),
        }
    }
    r.line(format!("largest rate deviation {:.1} %", worst * 100.0));
    for t in [
        "STATUSTEXT",
        "PARAM_VALUE",
        "TIMESYNC",
        "HOME_POSITION",
        "GPS_GLOBAL_ORIGIN",
        "COMMAND_ACK",
        "MISSION_ITEM_REACHED",
    ] {
        let count = |m: &BTreeMap<&str, Vec<u64>>| {
            m.get(t)
                .map_or(0, |v| v.iter().filter(|&&x| x <= rec_end).count())
        };
        r.line(format!(
            "     {t:<28} {:4} sent by {:.1} s, recorded {:4}",
            count(&by_type_sim),
            secs(rec_end),
            count(&by_type_rec)
        ));
    }
    // When each stream starts (the start-up sequence).
    for (t, times) in &by_type_rec {
        if times.len() < 20 || times[0] < 2_500_000 {
            continue;
        }
        let Some(s) = by_type_sim.get(t) else {
            continue;
        };
        let d = secs(s[0]) - secs(times[0]);
        r.check(
            d.abs() <= 1.5,
            format!(
                "{t:<28} first at {:6.2} s, recorded {:6.2} s",
                secs(s[0]),
                secs(times[0])
            ),
        );
    }

    // --- COMMAND_ACK results, in order.
    let acks = |it: &mut dyn Iterator<Item = &MavMessage>| -> Vec<(u32, u8)> {
        it.filter_map(|m| match m {
            MavMessage::COMMAND_ACK(a) => Some((a.command as u32, a.result as u8)),
            _ => None,
        })
        .collect()
    };
    let rec_acks = acks(&mut rec.vehicle.iter().map(|x| &x.msg));
    let sim_acks = acks(&mut sim_ap.iter().map(|x| &x.msg));
    r.check(
        rec_acks == sim_acks,
        format!("COMMAND_ACK (command, result) {sim_acks:?}, recorded {rec_acks:?}"),
    );

    // --- The mission exchange.
    #[allow(deprecated)]
    let exchange = |it: &mut dyn Iterator<Item = &MavMessage>| -> Vec<String> {
        it.filter_map(|m| match m {
            MavMessage::MISSION_REQUEST(x) => Some(format!("MISSION_REQUEST {}", x.seq)),
            MavMessage::MISSION_REQUEST_INT(x) => Some(format!("MISSION_REQUEST_INT {}", x.seq)),
            MavMessage::MISSION_ACK(x) => Some(format!("MISSION_ACK {:?}", x.mavtype)),
            MavMessage::MISSION_COUNT(x) => Some(format!("MISSION_COUNT {}", x.count)),
            _ => None,
        })
        .collect()
    };
    let rec_ex = exchange(&mut rec.vehicle.iter().map(|x| &x.msg));
    let sim_ex = exchange(&mut sim_ap.iter().map(|x| &x.msg));
    r.check(
        rec_ex == sim_ex,
        format!("mission exchange {sim_ex:?}, recorded {rec_ex:?}"),
    );

    // --- STATUSTEXTs.
    let texts = |it: &mut dyn Iterator<Item = (u64, &MavMessage)>| -> Vec<(u64, u8, String)> {
        it.filter_map(|(t, m)| match m {
            MavMessage::STATUSTEXT(s) => Some((
                t,
                s.severity as u8,
                s.text.to_str().unwrap_or("").to_owned(),
            )),
            _ => None,
        })
        .collect()
    };
    let rec_texts = texts(&mut rec.vehicle.iter().map(|x| (x.time_us, &x.msg)));
    let sim_texts = texts(&mut sim_ap.iter().map(|x| (x.time_us, &x.msg)));
    // The arming refusal: after the FAILED ack, before the accepted arming.
    let refusal = |texts: &[(u64, u8, String)]| {
        texts
            .iter()
            .find(|(_, _, t)| t.starts_with("Arm: "))
            .map(|(t, s, x)| (*t, *s, x.clone()))
    };
    let sim_refusal = refusal(&sim_texts);
    let rec_refusal = refusal(&rec_texts);
    r.check(
        sim_refusal.as_ref().map(|x| (x.1, x.2.as_str()))
            == rec_refusal.as_ref().map(|x| (x.1, x.2.as_str())),
        format!("arming refusal {sim_refusal:?}, recorded {rec_refusal:?}"),
    );
    let ack_time = |v: &[&Sent], result: MavResult| {
        v.iter().find_map(|s| match &s.msg {
            MavMessage::COMMAND_ACK(a)
                if a.command == MavCmd::MAV_CMD_COMPONENT_ARM_DISARM && a.result == result =>
            {
                Some(s.time_us)
            }
            _ => None,
        })
    };
    let failed_at = ack_time(&sim_ap, MavResult::MAV_RESULT_FAILED);
    let armed_at = ack_time(&sim_ap, MavResult::MAV_RESULT_ACCEPTED);
    r.check(
        match (failed_at, sim_refusal.as_ref(), armed_at) {
            (Some(f), Some((t, _, _)), Some(a)) => f <= *t && *t < a,
            _ => false,
        },
        format!(
            "\"Arm: …\" follows the FAILED ack ({:?} µs) and precedes the accepted arming ({:?} µs)",
            failed_at, armed_at
        ),
    );
    let rec_norm: Vec<String> = rec_texts.iter().map(|x| normalize(&x.2)).collect();
    let sim_norm: Vec<String> = sim_texts.iter().map(|x| normalize(&x.2)).collect();
    let mut missing = missing_from(&rec_norm, &sim_norm);
    for (t, _) in TEXTS_NOT_SIMULATED {
        if let Some(p) = missing.iter().position(|m| m == &normalize(t)) {
            missing.remove(p);
        }
    }
    r.check(
        missing.is_empty(),
        format!(
            "every recorded STATUSTEXT is said, in the recorded order (numbers aside; {} justified exceptions): missing {missing:?}",
            TEXTS_NOT_SIMULATED.len()
        ),
    );
    let extra: Vec<&String> = sim_norm.iter().filter(|t| !rec_norm.contains(t)).collect();
    r.check(
        extra.is_empty(),
        format!("no STATUSTEXT ArduPlane did not say: {extra:?}"),
    );

    // --- The flight's timeline.
    let when = |texts: &[(u64, u8, String)], prefix: &str| {
        texts
            .iter()
            .find(|(_, _, t)| t.starts_with(prefix))
            .map(|(t, _, _)| secs(*t))
    };
    let reached = |v: &mut dyn Iterator<Item = (u64, &MavMessage)>| -> Vec<(u16, f64)> {
        v.filter_map(|(t, m)| match m {
            MavMessage::MISSION_ITEM_REACHED(x) => Some((x.seq, secs(t))),
            _ => None,
        })
        .collect()
    };
    let rec_reached = reached(&mut rec.vehicle.iter().map(|x| (x.time_us, &x.msg)));
    let sim_reached = reached(&mut sim_ap.iter().map(|x| (x.time_us, &x.msg)));
    r.check(
        rec_reached
            .iter()
            .map(|x| x.0)
            .eq(sim_reached.iter().map(|x| x.0)),
        format!(
            "MISSION_ITEM_REACHED {:?}, recorded {:?}",
            sim_reached.iter().map(|x| x.0).collect::<Vec<_>>(),
            rec_reached.iter().map(|x| x.0).collect::<Vec<_>>()
        ),
    );
    let milestones = [
        "Triggered AUTO",
        "Takeoff complete",
        "Landing approach start",
        "Flare",
        "SIM Hit ground",
        "Auto disarmed",
    ];
    let mut rec_marks: Vec<(String, f64)> = Vec::new();
    let mut sim_marks: Vec<(String, f64)> = Vec::new();
    for m in milestones {
        if let (Some(a), Some(b)) = (when(&rec_texts, m), when(&sim_texts, m)) {
            rec_marks.push((m.to_owned(), a));
            sim_marks.push((m.to_owned(), b));
        }
    }
    for ((s, _), (rt, st)) in rec_reached
        .iter()
        .zip(sim_reached.iter())
        .map(|(a, b)| ((a.0, b.0), (a.1, b.1)))
    {
        rec_marks.push((format!("reached {s}"), rt));
        sim_marks.push((format!("reached {s}"), st));
    }
    // In time order; events of the same instant in the mission's order.
    let order = |marks: &mut Vec<(String, f64)>| {
        marks.sort_by(|a, b| {
            ((a.1 * 10.0).round() as i64)
                .cmp(&((b.1 * 10.0).round() as i64))
                .then(a.0.cmp(&b.0))
        })
    };
    order(&mut rec_marks);
    order(&mut sim_marks);
    r.check(
        rec_marks
            .iter()
            .map(|x| &x.0)
            .eq(sim_marks.iter().map(|x| &x.0)),
        format!(
            "milestones in the recorded order: {:?}",
            sim_marks.iter().map(|x| &x.0).collect::<Vec<_>>()
        ),
    );
    let at = |marks: &[(String, f64)], k: &str| marks.iter().find(|x| x.0 == k).map(|x| x.1);
    for (from, to, tol) in [
        ("Triggered AUTO", "Takeoff complete", 0.5),
        ("reached 1", "reached 2", 0.25),
        ("reached 2", "reached 3", 0.25),
        ("reached 3", "reached 4", 0.25),
        ("reached 4", "reached 5", 0.25),
        ("reached 5", "reached 6", 0.25),
        ("Landing approach start", "SIM Hit ground", 0.35),
        ("SIM Hit ground", "Auto disarmed", 0.25),
    ] {
        let d = |m: &[(String, f64)]| Some(at(m, to)? - at(m, from)?);
        match (d(&rec_marks), d(&sim_marks)) {
            (Some(rd), Some(sd)) => r.check(
                (sd / rd - 1.0).abs() <= tol,
                format!(
                    "{from} → {to}: {sd:5.1} s, recorded {rd:5.1} s ({:+.0} %, tolerance ±{:.0} %)",
                    (sd / rd - 1.0) * 100.0,
                    tol * 100.0
                ),
            ),
            _ => r.check(false, format!("{from} → {to}: missing")),
        }
    }

    // --- Petrel's elaboration sees the same events.
    let rec_frames: Vec<(u64, Vec<u8>)> = rec
        .vehicle
        .iter()
        .map(|x| (x.time_us, x.bytes.clone()))
        .collect();
    let sim_frames: Vec<(u64, Vec<u8>)> = sim_ap
        .iter()
        .map(|x| (x.time_us, x.bytes.clone()))
        .collect();
    // Up to the automatic disarm (where the recording ends).
    let until_disarmed = |mut e: Vec<(u64, String)>| {
        if let Some(p) = e.iter().position(|x| x.1 == "disarmed") {
            e.truncate(p + 1);
        }
        e
    };
    let rec_events = until_disarmed(events(&rec_frames));
    let sim_events = until_disarmed(events(&sim_frames));
    let names = |e: &[(u64, String)]| e.iter().map(|x| x.1.clone()).collect::<Vec<_>>();
    r.check(
        names(&rec_events) == names(&sim_events),
        format!(
            "elaborated events {:?}, recorded {:?}",
            names(&sim_events),
            names(&rec_events)
        ),
    );
    for ((rt, rn), (st, _)) in rec_events.iter().zip(sim_events.iter()) {
        r.line(format!(
            "     event {rn:<22} at {:6.1} s, recorded {:6.1} s",
            secs(*st),
            secs(*rt)
        ));
    }

    // --- Kinematics as a client sees them.
    let stats = |frames: &mut dyn Iterator<Item = (u64, &MavMessage)>, from: f64, to: f64| {
        let (mut n, mut aspd, mut max_climb, mut max_roll, mut max_alt) =
            (0.0, 0.0, 0.0f64, 0.0f64, 0.0f64);
        let mut bat = (None, None);
        for (t, m) in frames {
            let t = secs(t);
            match m {
                MavMessage::VFR_HUD(v) => {
                    max_climb = max_climb.max(v.climb as f64);
                    if t >= from && t <= to {
                        n += 1.0;
                        aspd += v.airspeed as f64;
                    }
                }
                MavMessage::ATTITUDE(a) => {
                    max_roll = max_roll.max((a.roll as f64).abs().to_degrees())
                }
                MavMessage::GLOBAL_POSITION_INT(g) => {
                    max_alt = max_alt.max(g.relative_alt as f64 / 1000.0)
                }
                MavMessage::SYS_STATUS(s) => {
                    if bat.0.is_none() && s.battery_remaining >= 0 {
                        bat.0 = Some(s.battery_remaining);
                    }
                    bat.1 = Some(s.battery_remaining);
                }
                _ => {}
            }
        }
        (aspd / f64::max(n, 1.0), max_climb, max_roll, max_alt, bat)
    };
    let span = |reached: &[(u16, f64)]| {
        (
            reached.iter().find(|x| x.0 == 2).map_or(0.0, |x| x.1),
            reached.iter().find(|x| x.0 == 5).map_or(0.0, |x| x.1),
        )
    };
    let (rf, rt) = span(&rec_reached);
    let (sf, st) = span(&sim_reached);
    let (r_aspd, r_climb, r_roll, r_alt, r_bat) =
        stats(&mut rec.vehicle.iter().map(|x| (x.time_us, &x.msg)), rf, rt);
    let (s_aspd, s_climb, s_roll, s_alt, s_bat) =
        stats(&mut sim_ap.iter().map(|x| (x.time_us, &x.msg)), sf, st);
    r.check(
        (s_aspd / r_aspd - 1.0).abs() <= 0.1,
        format!("cruise airspeed (waypoints 2 to 5) {s_aspd:.1} m/s, recorded {r_aspd:.1} m/s"),
    );
    r.check(
        (s_climb / r_climb - 1.0).abs() <= 0.3,
        format!("largest climb rate {s_climb:.1} m/s, recorded {r_climb:.1} m/s"),
    );
    r.check(
        s_roll <= 45.0 + 0.5,
        format!("largest bank {s_roll:.1}°, within ROLL_LIMIT_DEG 45 (recorded {r_roll:.1}°: ArduPlane overshoots its limit)"),
    );
    r.check(
        (s_alt - r_alt).abs() <= 10.0,
        format!("highest point {s_alt:.1} m above home, recorded {r_alt:.1} m"),
    );
    let used = |b: (Option<i8>, Option<i8>)| b.0.zip(b.1).map(|(a, b)| (a - b) as f64);
    let (ru, su) = (used(r_bat), used(s_bat));
    r.check(
        matches!((ru, su), (Some(a), Some(b)) if (a - b).abs() <= 5.0),
        format!("battery used {su:?} %, recorded {ru:?} %"),
    );
    let sim_land = sim_ap.iter().rev().find_map(|s| match &s.msg {
        MavMessage::GLOBAL_POSITION_INT(g) => Some(g),
        _ => None,
    });
    let rec_land = rec.vehicle.iter().rev().find_map(|s| match &s.msg {
        MavMessage::GLOBAL_POSITION_INT(g) => Some(g),
        _ => None,
    });
    if let (Some(s), Some(rl)) = (sim_land, rec_land) {
        let north = |g: &GLOBAL_POSITION_INT_DATA| (g.lat as f64 / 1e7 - -35.363261) * 111_319.5;
        r.line(format!(
            "     stopped {:.0} m north of home, recorded {:.0} m (the land point is 100 m north)",
            north(s),
            north(rl)
        ));
    }

    println!("{}", r.lines.join("\n"));
    assert!(
        r.failures.is_empty(),
        "{} differences from ArduPlane SITL:\n{}",
        r.failures.len(),
        r.failures.join("\n")
    );
}

#[test]
fn normalize_keeps_sequence_numbers() {
    assert_eq!(
        normalize("Reached waypoint #2 dist 49m"),
        "Reached waypoint #2 dist Nm"
    );
    assert_eq!(normalize("Mission: 7 Land"), "Mission: 7 Land");
    assert_eq!(
        normalize("Takeoff complete at 50.42m"),
        "Takeoff complete at Nm"
    );
    assert_eq!(
        normalize("EKF3 IMU1 is using GPS"),
        "EKFN IMUN is using GPS"
    );
    assert_eq!(
        missing_from(
            &["a".into(), "c".into()],
            &["a".into(), "b".into(), "c".into()]
        ),
        Vec::<String>::new()
    );
    assert_eq!(
        missing_from(&["c".into(), "a".into()], &["a".into(), "c".into()]),
        vec!["a".to_owned()]
    );
}
