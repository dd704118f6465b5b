//! The vehicle side over loopback UDP: the commander and the link against a
//! scripted autopilot (rust-mavlink) on 127.0.0.1. Short timeouts keep the
//! whole file to a few seconds.

#![allow(deprecated)] // REQUEST_DATA_STREAM, MISSION_REQUEST: the fallbacks under test

use gateway::link;
use petrel_core::vehicle;

mod driver;
use crate::peer;
mod recorded;

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use mavlink::dialects::ardupilotmega::*;
use nets::{Outcome, Params, Value};

use driver::{eventually, free_port, Gateway};
use peer::{ack, command_of, heartbeat, now, Peer, Reply};
use vehicle::config::{Payload, Timing, VehicleConfig};

const LIMIT: Duration = Duration::from_secs(5);

fn fast() -> VehicleConfig {
    let mut config = VehicleConfig {
        timing: Timing {
            ack_timeout: 150_000,
            retries: 3,
            rejected_retries: 3,
            in_progress_timeout: 1_000_000,
            mission_retries: 3,
            link_timeout: 400_000,
            heartbeat_period: 1_000_000,
        },
        ..VehicleConfig::default()
    };
    config
        .payloads
        .insert("camera".into(), Payload::Camera { component: 100 });
    config.payloads.insert(
        "sprayer".into(),
        Payload::Relay {
            instance: 1,
            start: 1,
            stop: 0,
        },
    );
    config
}

fn args(pairs: &[(&str, Value)]) -> Params {
    pairs
        .iter()
        .map(|(k, v)| (k.to_string(), v.clone()))
        .collect()
}

fn accepted() -> Outcome {
    Outcome::Done(args(&[("result", Value::Str("ACCEPTED".into()))]))
}

fn copter() -> MavMessage {
    heartbeat(
        MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        MavType::MAV_TYPE_QUADROTOR,
    )
}

/// Answers every command with `result`, from the component it was sent to.
fn always(result: MavResult) -> peer::Script {
    Box::new(move |_, m| match m {
        MavMessage::COMMAND_LONG(c) => vec![Reply {
            component: c.target_component,
            ..now(ack(c.command, result))
        }],
        MavMessage::COMMAND_INT(c) => vec![Reply {
            component: c.target_component,
            ..now(ack(c.command, result))
        }],
        _ => vec![],
    })
}

async fn pair(
    config: VehicleConfig,
    hb: MavMessage,
    telemetry: Vec<MavMessage>,
    script: peer::Script,
) -> (Gateway, Peer) {
    let port = free_port();
    let gateway = Gateway::start(port, config).await;
    let peer = Peer::start(&format!("udpout:127.0.0.1:{port}"), hb, telemetry, script).await;
    (gateway, peer)
}

#[tokio::test]
async fn heartbeat_identity_and_message_intervals() {
    let (gateway, peer) = pair(
        fast(),
        copter(),
        vec![],
        always(MavResult::MAV_RESULT_ACCEPTED),
    )
    .await;
    gateway.streams(&[(33, 4.0), (1, 2.0)]);
    let ours = |p: &Peer| {
        p.all()
            .into_iter()
            .filter(|s| matches!(s.message, MavMessage::HEARTBEAT(_)))
            .collect::<Vec<_>>()
    };
    assert!(
        eventually(LIMIT, || ours(&peer).len() >= 2).await,
        "two heartbeats"
    );
    let beats = ours(&peer);
    for b in &beats {
        assert_eq!((b.header.system_id, b.header.component_id), (1, 191));
        let MavMessage::HEARTBEAT(h) = &b.message else {
            unreachable!()
        };
        assert_eq!(h.mavtype, MavType::MAV_TYPE_ONBOARD_CONTROLLER);
        assert_eq!(h.autopilot, MavAutopilot::MAV_AUTOPILOT_INVALID);
    }
    let gap = beats[1].at - beats[0].at;
    assert!(
        gap >= Duration::from_millis(900) && gap <= Duration::from_millis(1300),
        "1 Hz: {gap:?}"
    );
    let seq: Vec<u8> = peer.all().iter().map(|s| s.header.sequence).collect();
    assert!(
        seq.windows(2).all(|w| w[1] == w[0].wrapping_add(1)),
        "sequence numbers count up: {seq:?}"
    );
    let intervals: Vec<(f32, f32)> = peer
        .commands(MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL)
        .iter()
        .map(|m| match m {
            MavMessage::COMMAND_LONG(c) => (c.param1, c.param2),
            _ => unreachable!(),
        })
        .collect();
    assert_eq!(intervals, vec![(33.0, 250_000.0), (1.0, 500_000.0)]);
    assert!(!peer
        .messages()
        .iter()
        .any(|m| matches!(m, MavMessage::REQUEST_DATA_STREAM(_))));
}

#[tokio::test]
async fn stream_fallback_when_unsupported_or_unanswered() {
    for script in [
        always(MavResult::MAV_RESULT_UNSUPPORTED),
        Box::new(|_: &_, _: &_| vec![]) as peer::Script,
    ] {
        let (gateway, peer) = pair(fast(), copter(), vec![], script).await;
        gateway.streams(&[(33, 4.0), (30, 10.0)]);
        let requested = |p: &Peer| -> Vec<(MavDataStream, u16)> {
            p.messages()
                .iter()
                .filter_map(|m| match m {
                    MavMessage::REQUEST_DATA_STREAM(r) => {
                        Some((r.req_stream_id, r.req_message_rate))
                    }
                    _ => None,
                })
                .collect()
        };
        assert!(
            eventually(LIMIT, || requested(&peer).len() == 2).await,
            "{:?}",
            peer.messages()
        );
        assert_eq!(
            requested(&peer),
            vec![
                (MavDataStream::MAV_DATA_STREAM_POSITION, 4),
                (MavDataStream::MAV_DATA_STREAM_EXTRA1, 10)
            ]
        );
    }
}

#[tokio::test]
async fn every_verb_ardupilot_and_px4() {
    let position = MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
        lat: -353_632_610,
        lon: 1_491_652_300,
        alt: 500_000,
        relative_alt: 10_000,
        ..GLOBAL_POSITION_INT_DATA::DEFAULT
    });
    let px4 = heartbeat(MavAutopilot::MAV_AUTOPILOT_PX4, MavType::MAV_TYPE_QUADROTOR);
    let text = |s: &str| Value::Str(s.into());
    let wp = Value::Map(
        [
            ("lat".to_string(), Value::Float(-35.36)),
            ("lon".to_string(), Value::Float(149.16)),
            ("alt".to_string(), Value::Int(30)),
        ]
        .into(),
    );
    for (hb, mode, expected_mode) in [
        (copter(), "GUIDED", (4.0, 0.0)),
        (px4, "AUTO_MISSION", (4.0, 4.0)),
    ] {
        let mission_script: peer::Script = {
            let mut count = 0u16;
            let mut inner = always(MavResult::MAV_RESULT_ACCEPTED);
            Box::new(move |h, m| match m {
                MavMessage::MISSION_COUNT(c) => {
                    count = c.count;
                    vec![now(MavMessage::MISSION_REQUEST_INT(
                        MISSION_REQUEST_INT_DATA {
                            seq: 0,
                            target_system: 1,
                            target_component: 191,
                            ..Default::default()
                        },
                    ))]
                }
                MavMessage::MISSION_ITEM_INT(i) if i.seq + 1 < count => {
                    vec![now(MavMessage::MISSION_REQUEST_INT(
                        MISSION_REQUEST_INT_DATA {
                            seq: i.seq + 1,
                            target_system: 1,
                            target_component: 191,
                            ..Default::default()
                        },
                    ))]
                }
                MavMessage::MISSION_ITEM_INT(_) => {
                    vec![now(MavMessage::MISSION_ACK(MISSION_ACK_DATA {
                        target_system: 1,
                        target_component: 191,
                        ..Default::default()
                    }))]
                }
                other => inner(h, other),
            })
        };
        let (mut gateway, peer) = pair(fast(), hb, vec![position.clone()], mission_script).await;
        let verbs: Vec<(&str, Params, Option<MavCmd>)> = vec![
            ("arm", args(&[]), Some(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM)),
            (
                "mode",
                args(&[("mode", text(mode))]),
                Some(MavCmd::MAV_CMD_DO_SET_MODE),
            ),
            (
                "takeoff",
                args(&[("alt", Value::Int(20))]),
                Some(MavCmd::MAV_CMD_NAV_TAKEOFF),
            ),
            (
                "goto",
                args(&[
                    ("lat", Value::Float(-35.36)),
                    ("lon", Value::Float(149.16)),
                    ("alt", Value::Int(30)),
                ]),
                Some(MavCmd::MAV_CMD_DO_REPOSITION),
            ),
            (
                "set_speed",
                args(&[("speed", Value::Int(8))]),
                Some(MavCmd::MAV_CMD_DO_CHANGE_SPEED),
            ),
            (
                "upload_mission",
                args(&[("items", Value::List(vec![wp.clone(), wp.clone()]))]),
                None,
            ),
            (
                "start_mission",
                args(&[]),
                Some(MavCmd::MAV_CMD_MISSION_START),
            ),
            (
                "set_current",
                args(&[("seq", Value::Int(1))]),
                Some(MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT),
            ),
            (
                "payload_start",
                args(&[("payload", text("camera"))]),
                Some(MavCmd::MAV_CMD_IMAGE_START_CAPTURE),
            ),
            (
                "payload_stop",
                args(&[("payload", text("camera"))]),
                Some(MavCmd::MAV_CMD_IMAGE_STOP_CAPTURE),
            ),
            (
                "payload_start",
                args(&[("payload", text("sprayer"))]),
                Some(MavCmd::MAV_CMD_DO_SET_RELAY),
            ),
            ("rtl", args(&[]), Some(MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH)),
            ("land", args(&[]), Some(MavCmd::MAV_CMD_NAV_LAND)),
            (
                "disarm",
                args(&[]),
                Some(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM),
            ),
        ];
        // Wait until the gateway knows the vehicle and its position.
        assert!(
            eventually(LIMIT, || peer
                .all()
                .iter()
                .any(|s| matches!(s.message, MavMessage::HEARTBEAT(_))))
            .await
        );
        tokio::time::sleep(Duration::from_millis(150)).await;
        for (n, (verb, a, cmd)) in verbs.into_iter().enumerate() {
            let id = n as u64 + 1;
            gateway.command(id, verb, a);
            let (got, outcome) = gateway.outcome(LIMIT).await;
            assert_eq!(got, id);
            match cmd {
                Some(cmd) => {
                    assert_eq!(outcome, accepted(), "{verb}");
                    assert!(!peer.commands(cmd).is_empty(), "{verb}: {cmd:?} seen");
                }
                None => assert!(
                    matches!(outcome, Outcome::Done(ref p) if p.get("result") == Some(&text("ACCEPTED"))),
                    "{verb}: {outcome:?}"
                ),
            }
        }
        let modes: Vec<(f32, f32)> = peer
            .commands(MavCmd::MAV_CMD_DO_SET_MODE)
            .iter()
            .map(|m| match m {
                MavMessage::COMMAND_LONG(c) => (c.param2, c.param3),
                _ => unreachable!(),
            })
            .collect();
        assert_eq!(modes, vec![expected_mode]);
        for m in peer.commands(MavCmd::MAV_CMD_IMAGE_START_CAPTURE) {
            let MavMessage::COMMAND_LONG(c) = m else {
                unreachable!()
            };
            assert_eq!(c.target_component, 100);
        }
        assert!(peer
            .commands(MavCmd::MAV_CMD_DO_REPOSITION)
            .iter()
            .all(|m| matches!(m, MavMessage::COMMAND_INT(_))));
    }
}

#[tokio::test]
async fn retry_timeout_rejection_in_progress() {
    let mut count: HashMap<u32, u32> = HashMap::new();
    let script: peer::Script = Box::new(move |_, m| {
        let Some(cmd) = command_of(m) else {
            return vec![];
        };
        let n = count.entry(cmd as u32).or_default();
        *n += 1;
        match (cmd, *n) {
            // No answer twice, then accepted.
            (MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 1 | 2) => vec![],
            (MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, _) => {
                vec![now(ack(cmd, MavResult::MAV_RESULT_ACCEPTED))]
            }
            // IN_PROGRESS at once, ACCEPTED 400 ms later (past the ack timeout).
            (MavCmd::MAV_CMD_NAV_TAKEOFF, _) => vec![
                now(ack(cmd, MavResult::MAV_RESULT_IN_PROGRESS)),
                Reply {
                    after: Duration::from_millis(400),
                    ..now(ack(cmd, MavResult::MAV_RESULT_ACCEPTED))
                },
            ],
            (MavCmd::MAV_CMD_DO_SET_MODE, 1) => {
                vec![now(ack(cmd, MavResult::MAV_RESULT_TEMPORARILY_REJECTED))]
            }
            (MavCmd::MAV_CMD_DO_SET_MODE, _) => vec![now(ack(cmd, MavResult::MAV_RESULT_ACCEPTED))],
            (MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH, _) => {
                vec![now(ack(cmd, MavResult::MAV_RESULT_DENIED))]
            }
            _ => vec![], // land: never answered
        }
    });
    let (mut gateway, peer) = pair(fast(), copter(), vec![], script).await;
    assert!(eventually(LIMIT, || !peer.all().is_empty()).await);
    gateway.command(1, "arm", args(&[]));
    assert_eq!(gateway.outcome(LIMIT).await, (1, accepted()));
    let confirmations: Vec<u8> = peer
        .commands(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM)
        .iter()
        .map(|m| match m {
            MavMessage::COMMAND_LONG(c) => c.confirmation,
            _ => unreachable!(),
        })
        .collect();
    assert_eq!(confirmations, vec![0, 1, 2]);
    gateway.command(2, "takeoff", args(&[("alt", Value::Int(10))]));
    assert_eq!(gateway.outcome(LIMIT).await, (2, accepted()));
    assert_eq!(
        peer.commands(MavCmd::MAV_CMD_NAV_TAKEOFF).len(),
        1,
        "no resend while IN_PROGRESS"
    );
    gateway.command(3, "mode", args(&[("mode", Value::Str("AUTO".into()))]));
    assert_eq!(gateway.outcome(LIMIT).await, (3, accepted()));
    assert_eq!(peer.commands(MavCmd::MAV_CMD_DO_SET_MODE).len(), 2);
    gateway.command(4, "rtl", args(&[]));
    assert_eq!(
        gateway.outcome(LIMIT).await,
        (4, Outcome::Failed("DENIED".into()))
    );
    gateway.command(5, "land", args(&[]));
    assert_eq!(
        gateway.outcome(LIMIT).await,
        (5, Outcome::Failed("timeout".into()))
    );
    assert_eq!(
        peer.commands(MavCmd::MAV_CMD_NAV_LAND).len(),
        4,
        "first send and 3 retries"
    );
}

fn request(seq: u16) -> Reply {
    now(MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
        seq,
        target_system: 1,
        target_component: 191,
        ..Default::default()
    }))
}

#[tokio::test]
async fn mission_upload_twice_asked_out_of_order_and_refused() {
    // Asks 0, 1, 1 again, 3 before 2, then accepts; a second upload is refused.
    let uploads = Arc::new(Mutex::new(0));
    let counter = uploads.clone();
    let mut asked_twice = false;
    let script: peer::Script = Box::new(move |_, m| match m {
        MavMessage::MISSION_COUNT(_) => {
            let mut n = counter.lock().expect("count");
            *n += 1;
            if *n == 1 {
                vec![request(0)]
            } else {
                vec![now(MavMessage::MISSION_ACK(MISSION_ACK_DATA {
                    target_system: 1,
                    target_component: 191,
                    mavtype: MavMissionResult::MAV_MISSION_NO_SPACE,
                    ..Default::default()
                }))]
            }
        }
        MavMessage::MISSION_ITEM_INT(i) => match i.seq {
            0 => vec![request(1)],
            1 if !asked_twice => {
                asked_twice = true;
                vec![request(1)]
            }
            1 => vec![request(3)],
            3 => vec![request(2)],
            _ => vec![now(MavMessage::MISSION_ACK(MISSION_ACK_DATA {
                target_system: 1,
                target_component: 191,
                ..Default::default()
            }))],
        },
        _ => vec![],
    });
    let (mut gateway, peer) = pair(fast(), copter(), vec![], script).await;
    assert!(eventually(LIMIT, || !peer.all().is_empty()).await);
    let wp = |lat: f64| {
        Value::Map(
            [
                ("lat".to_string(), Value::Float(lat)),
                ("lon".to_string(), Value::Float(1.0)),
                ("alt".to_string(), Value::Int(50)),
            ]
            .into(),
        )
    };
    gateway.command(
        1,
        "upload_mission",
        args(&[("items", Value::List(vec![wp(43.0), wp(43.1), wp(43.2)]))]),
    );
    let (id, outcome) = gateway.outcome(LIMIT).await;
    assert_eq!(id, 1);
    assert!(
        matches!(&outcome, Outcome::Done(p) if p.get("count") == Some(&Value::Int(4))),
        "{outcome:?}"
    );
    let items: Vec<(u16, i32)> = peer
        .messages()
        .iter()
        .filter_map(|m| match m {
            MavMessage::MISSION_ITEM_INT(i) => Some((i.seq, i.x)),
            _ => None,
        })
        .collect();
    assert_eq!(
        items,
        vec![
            (0, 0),
            (1, 430_000_000),
            (1, 430_000_000),
            (3, 432_000_000),
            (2, 431_000_000)
        ]
    );
    gateway.command(
        2,
        "upload_mission",
        args(&[("items", Value::List(vec![wp(43.0)]))]),
    );
    assert_eq!(
        gateway.outcome(LIMIT).await,
        (2, Outcome::Failed("NO_SPACE".into()))
    );
}

#[tokio::test]
async fn link_loss_and_return_mid_command() {
    let mut config = fast();
    config.timing.ack_timeout = 200_000;
    let down_at_first_arm = Arc::new(Mutex::new(None::<Arc<std::sync::atomic::AtomicBool>>));
    let switch = down_at_first_arm.clone();
    let mut arms = 0;
    let script: peer::Script = Box::new(move |_, m| match command_of(m) {
        Some(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM) => {
            arms += 1;
            if arms == 1 {
                if let Some(down) = switch.lock().expect("switch").as_ref() {
                    down.store(true, std::sync::atomic::Ordering::SeqCst);
                }
                vec![]
            } else {
                vec![now(ack(
                    MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                    MavResult::MAV_RESULT_ACCEPTED,
                ))]
            }
        }
        Some(cmd) => vec![now(ack(cmd, MavResult::MAV_RESULT_ACCEPTED))],
        None => vec![],
    });
    let (mut gateway, peer) = pair(config, copter(), vec![], script).await;
    *down_at_first_arm.lock().expect("switch") = Some(peer.down.clone());
    gateway.streams(&[(33, 4.0)]);
    assert!(
        eventually(LIMIT, || peer
            .commands(MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL)
            .len()
            == 1)
        .await
    );
    gateway.command(1, "arm", args(&[]));
    assert!(
        eventually(LIMIT, || peer
            .down
            .load(std::sync::atomic::Ordering::SeqCst))
        .await,
        "link cut at the first arm"
    );
    tokio::time::sleep(Duration::from_millis(500)).await;
    peer.set_down(false);
    assert_eq!(gateway.outcome(LIMIT).await, (1, accepted()));
    let confirmations: Vec<u8> = peer
        .commands(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM)
        .iter()
        .map(|m| match m {
            MavMessage::COMMAND_LONG(c) => c.confirmation,
            _ => unreachable!(),
        })
        .collect();
    assert_eq!(
        confirmations.len(),
        2,
        "the first, then one resend after the link came back: {confirmations:?}"
    );
    assert_eq!(confirmations[0], 0);
    assert!(
        confirmations[1] >= 2 && confirmations[1] <= 3,
        "{confirmations:?}"
    );
    assert!(
        eventually(LIMIT, || peer
            .commands(MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL)
            .len()
            == 2)
        .await,
        "telemetry asked for again after the link came back"
    );
}

/// The recorded answers of ArduPilot SITL, replayed by the peer; the
/// gateway must send what the recording's client sent.
async fn replay_recording(
    name: &str,
    hb: MavMessage,
    telemetry: Vec<MavMessage>,
    verbs: Vec<(&str, Params)>,
    expected: Vec<Outcome>,
) {
    let Some(path) = recorded::telemetry(name) else {
        return;
    };
    let exchanges = recorded::exchanges(&path);
    assert!(!exchanges.is_empty(), "{name} holds exchanges");
    let queue = Arc::new(Mutex::new(
        exchanges
            .into_iter()
            .collect::<std::collections::VecDeque<_>>(),
    ));
    let mismatches = Arc::new(Mutex::new(Vec::<String>::new()));
    let (q, bad) = (queue.clone(), mismatches.clone());
    let script: peer::Script = Box::new(move |_, m| {
        if !matches!(
            m,
            MavMessage::COMMAND_LONG(_)
                | MavMessage::COMMAND_INT(_)
                | MavMessage::MISSION_COUNT(_)
                | MavMessage::MISSION_ITEM_INT(_)
        ) {
            return vec![];
        }
        let Some(next) = q.lock().expect("queue").pop_front() else {
            bad.lock().expect("log").push(format!("unexpected {m:?}"));
            return vec![];
        };
        if let Err(e) = recorded::same_request(m, &next.request) {
            bad.lock().expect("log").push(e);
        }
        next.replies
            .iter()
            .map(|r| now(recorded::readdress(r)))
            .collect()
    });
    let (mut gateway, peer) = pair(fast(), hb, telemetry, script).await;
    assert!(eventually(LIMIT, || !peer.all().is_empty()).await);
    tokio::time::sleep(Duration::from_millis(150)).await;
    for (n, ((verb, a), want)) in verbs.into_iter().zip(expected).enumerate() {
        let id = n as u64 + 1;
        gateway.command(id, verb, a);
        let (got, outcome) = gateway.outcome(LIMIT).await;
        assert_eq!(got, id);
        match (&outcome, &want) {
            (Outcome::Done(p), Outcome::Done(w)) => {
                assert_eq!(p.get("result"), w.get("result"), "{verb}")
            }
            _ => assert_eq!(outcome, want, "{verb}"),
        }
    }
    assert!(
        mismatches.lock().expect("log").is_empty(),
        "{:?}",
        mismatches.lock().expect("log")
    );
    assert!(
        queue.lock().expect("queue").is_empty(),
        "every recorded exchange replayed"
    );
}

#[tokio::test]
async fn arduplane_sitl_mission_upload_mode_and_refused_first_arm() {
    let Some(path) = recorded::telemetry("SITL_arduplane-4.7.0dev_auto_mission_land.tlog") else {
        return;
    };
    // The nets' items, from the recorded upload (item 0 is home).
    let items: Vec<Value> = recorded::exchanges(&path)
        .iter()
        .filter_map(|e| match &e.request {
            MavMessage::MISSION_ITEM_INT(i) if i.seq > 0 => Some(Value::Map(
                [
                    ("command".to_string(), Value::Int(i.command as i64)),
                    ("lat".to_string(), Value::Float(i.x as f64 / 1e7)),
                    ("lon".to_string(), Value::Float(i.y as f64 / 1e7)),
                    ("alt".to_string(), Value::Float(i.z as f64)),
                    ("p1".to_string(), Value::Float(i.param1 as f64)),
                ]
                .into(),
            )),
            _ => None,
        })
        .collect();
    assert_eq!(items.len(), 7);
    let home = MavMessage::HOME_POSITION(HOME_POSITION_DATA {
        latitude: -353_632_610,
        longitude: 1_491_652_300,
        altitude: 584_000,
        ..HOME_POSITION_DATA::DEFAULT
    });
    let plane = heartbeat(
        MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        MavType::MAV_TYPE_FIXED_WING,
    );
    let mut mission_done = Params::new();
    mission_done.insert("result".into(), Value::Str("ACCEPTED".into()));
    replay_recording(
        "SITL_arduplane-4.7.0dev_auto_mission_land.tlog",
        plane,
        vec![home],
        vec![
            ("upload_mission", args(&[("items", Value::List(items))])),
            ("mode", args(&[("mode", Value::Str("AUTO".into()))])),
            ("arm", args(&[])),
            ("arm", args(&[])),
        ],
        vec![
            Outcome::Done(mission_done),
            accepted(),
            Outcome::Failed("FAILED".into()),
            accepted(),
        ],
    )
    .await;
}

#[tokio::test]
async fn arducopter_sitl_guided_takeoff_and_land() {
    replay_recording(
        "SITL_arducopter-4.7.0dev_guided_takeoff_land.tlog",
        copter(),
        vec![],
        vec![
            ("mode", args(&[("mode", Value::Str("GUIDED".into()))])),
            ("arm", args(&[])),
            ("takeoff", args(&[("alt", Value::Int(20))])),
            ("mode", args(&[("mode", Value::Str("LAND".into()))])),
        ],
        vec![accepted(), accepted(), accepted(), accepted()],
    )
    .await;
}

fn free_tcp_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free loopback port")
}

#[tokio::test]
async fn tcp_link_raw_frames_both_versions_and_reopen() {
    use mavlink::{AsyncMavConnection, MavHeader, MavlinkVersion};
    let port = free_tcp_port();
    let address = format!("tcpin:127.0.0.1:{port}");
    let from_autopilot = MavHeader {
        system_id: 1,
        component_id: 1,
        sequence: 7,
    };
    // The autopilot listens (as SITL does on 5760); the gateway connects out.
    let listen = {
        let address = address.clone();
        tokio::spawn(async move { mavlink::connect_async::<MavMessage>(&address).await })
    };
    tokio::time::sleep(Duration::from_millis(50)).await;
    let origin = std::time::Instant::now();
    let (mut reader, writer) = link::Link::open(&format!("tcpout:127.0.0.1:{port}"), origin)
        .await
        .expect("gateway connects");
    let mut autopilot = listen
        .await
        .expect("listener task")
        .expect("autopilot accepts");
    let hb = copter();
    for version in [MavlinkVersion::V1, MavlinkVersion::V2] {
        autopilot.set_protocol_version(version);
        autopilot
            .send(&from_autopilot, &hb)
            .await
            .expect("autopilot sends");
        let got = tokio::time::timeout(LIMIT, reader.recv())
            .await
            .expect("a frame in time")
            .expect("frame");
        assert_eq!(got.version, version);
        assert_eq!(
            got.bytes,
            elaboration::frame::serialize(
                MavHeader {
                    sequence: got.header.sequence,
                    ..from_autopilot
                },
                version,
                &hb
            ),
            "raw bytes as on the wire"
        );
        assert_eq!((got.header.system_id, got.header.component_id), (1, 1));
        assert_eq!(got.message, Some(hb.clone()));
        assert!(got.time_us > 0 && got.time_us < origin.elapsed().as_micros() as u64 + 1);
    }
    autopilot.set_protocol_version(MavlinkVersion::V2);
    writer.send((1, 191), &hb).await.expect("gateway sends");
    let (h, m) = tokio::time::timeout(LIMIT, autopilot.recv())
        .await
        .expect("in time")
        .expect("frame");
    assert_eq!((h.system_id, h.component_id), (1, 191));
    assert_eq!(m, hb);
    // The autopilot goes away and comes back on the same port.
    drop(autopilot);
    let reading = tokio::spawn(async move {
        let r = reader.recv().await;
        (reader, r)
    });
    tokio::time::sleep(Duration::from_millis(200)).await;
    let back = tokio::time::timeout(LIMIT, mavlink::connect_async::<MavMessage>(&address))
        .await
        .expect("the gateway reconnects in time")
        .expect("autopilot accepts again");
    back.send(&from_autopilot, &hb)
        .await
        .expect("autopilot sends again");
    let (_reader, r) = tokio::time::timeout(LIMIT, reading)
        .await
        .expect("in time")
        .expect("task");
    assert_eq!(r.expect("frame after reopening").message, Some(hb.clone()));
    writer
        .send((1, 191), &hb)
        .await
        .expect("the writer uses the new connection");
    let (h, _) = tokio::time::timeout(LIMIT, back.recv())
        .await
        .expect("in time")
        .expect("frame");
    assert_eq!(h.component_id, 191);
}
