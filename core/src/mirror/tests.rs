//! The publisher and the replica together, on the flight-test example: the
//! real `Supervisor` on board, random traces of program events, results and
//! ticks, and a downlink and uplink that lose packets by a seeded rule.

use std::path::Path;
use std::sync::Arc;

use nets::{Event, Micros, Outcome, Params, Project, Value};
use proptest::prelude::*;

use super::publisher::{self, Publisher};
use super::record::{self, Record};
use super::replica::{self, Replica, Report};
use super::step_inputs;
use crate::supervisor::{Input, Supervisor};

pub(crate) fn example() -> (Arc<Project>, elaboration::Profile) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/uav-flight-test");
    let gateway = crate::project::gateway_table(&dir).expect("project.toml");
    let given = gateway.get("profile").and_then(|v| v.as_str());
    let layers =
        crate::profile::Layers::pick(None, Some((&dir, given)), "ardupilot").expect("profile");
    let profile = layers.load().expect("profile loads");
    let project =
        crate::project::load_with(&dir, &crate::project::catalog(&profile)).expect("project loads");
    (project, profile)
}

/// One input of a trace.
#[derive(Debug, Clone)]
enum Step {
    /// A declared event (by index), as a program would send it.
    Event { pick: usize, dt: Micros },
    /// The outcome of a pending call or command (by index).
    Reply { pick: usize, ok: bool, dt: Micros },
    /// Time passes: a tick.
    Tick { dt: Micros },
}

fn trace(len: usize) -> impl Strategy<Value = Vec<Step>> {
    prop::collection::vec(
        prop_oneof![
            3 => (0usize..64, 0u64..3_000_000).prop_map(|(pick, dt)| Step::Event { pick, dt }),
            3 => (0usize..4, any::<bool>(), 0u64..2_000_000).prop_map(|(pick, ok, dt)| Step::Reply { pick, ok, dt }),
            4 => (0u64..2_000_000).prop_map(|dt| Step::Tick { dt }),
        ],
        1..len,
    )
}

/// Drops packets: `rate` in a thousand at random (seeded), and everything
/// while a burst is on.
struct Loss {
    seed: u64,
    rate: u64,
    bursts: Vec<(Micros, Micros)>,
    dropped: u64,
}

impl Loss {
    fn none() -> Loss {
        Loss::random(0, 0)
    }

    fn random(seed: u64, rate: u64) -> Loss {
        Loss {
            seed: seed | 1,
            rate,
            bursts: Vec::new(),
            dropped: 0,
        }
    }

    fn drops(&mut self, now: Micros) -> bool {
        // xorshift64
        self.seed ^= self.seed << 13;
        self.seed ^= self.seed >> 7;
        self.seed ^= self.seed << 17;
        let drop = self.seed % 1000 < self.rate
            || self.bursts.iter().any(|(a, b)| (*a..*b).contains(&now));
        self.dropped += u64::from(drop);
        drop
    }
}

/// The vehicle's side, the link and the ground's side.
struct Flight {
    project: Arc<Project>,
    supervisor: Supervisor,
    publisher: Publisher,
    replica: Replica,
    now: Micros,
    down: Loss,
    up: Loss,
    reports: Vec<Report>,
    /// Inputs the vehicle plays without publishing them (a fault).
    hidden: Vec<Event>,
    /// The step at which a hidden input changed the vehicle's state.
    hidden_at: Option<u64>,
    uplink: Vec<Vec<u8>>,
    downlink_bytes: u64,
    /// The autopilot rebooted and forgot the route to the mirror: the
    /// downlink goes nowhere until the mirror sends something.
    route_lost: bool,
}

impl Flight {
    fn new(down: Loss, up: Loss, config: publisher::Config) -> Flight {
        let (project, profile) = example();
        let (supervisor, _) =
            Supervisor::start(project.clone(), profile, elaboration::Config::default(), 0);
        let mut f = Flight {
            replica: Replica::new(project.clone(), replica::Config::default()),
            project,
            supervisor,
            publisher: Publisher::new(7, config, 0),
            now: 0,
            down,
            up,
            reports: Vec::new(),
            hidden: Vec::new(),
            hidden_at: None,
            uplink: Vec::new(),
            downlink_bytes: 0,
            route_lost: false,
        };
        f.exchange();
        f
    }

    fn feed(&mut self, input: Input) {
        let before = self.supervisor.player().state().now;
        let step = self.supervisor.step(self.now, input.clone());
        if let Some(inputs) = step_inputs(&input, &step, &super::Unread::none()) {
            self.publisher.step(
                step.seq,
                before,
                step.time,
                inputs,
                &self.supervisor.player().digest(),
            );
        }
    }

    fn play(&mut self, s: &Step) {
        let names: Vec<&String> = self.project.events.keys().collect();
        match s {
            Step::Event { pick, dt } => {
                self.now += dt;
                let name = names[pick % names.len()].clone();
                let event = Event::new(name)
                    .param("alt", Value::Int(*pick as i64 * 7))
                    .param("finished", Value::Bool(pick % 2 == 0));
                self.feed(Input::Event(event));
            }
            Step::Reply { pick, ok, dt } => {
                self.now += dt;
                let ids: Vec<u64> = self
                    .supervisor
                    .player()
                    .state()
                    .pending
                    .keys()
                    .copied()
                    .collect();
                let id = ids.get(*pick).copied().unwrap_or(9_000 + *pick as u64);
                let outcome = if *ok {
                    Outcome::Done(Params::from([("index".to_owned(), Value::Int(2))]))
                } else {
                    Outcome::Failed("refused".into())
                };
                self.feed(Input::Result { id, outcome });
            }
            Step::Tick { dt } => {
                self.now += dt;
                self.feed(Input::Tick);
            }
        }
        if let Some(e) = self.hidden.pop() {
            // Played on board, never published.
            let mut shadow = self.supervisor.player().clone();
            self.supervisor.step(self.now, Input::Event(e));
            shadow.advance(self.now);
            let changed = self.supervisor.player().digest() != shadow.digest();
            if changed {
                self.hidden.clear();
                self.hidden_at = Some(self.supervisor.seq());
            }
        }
        self.exchange();
    }

    /// Heartbeats, snapshots and packets both ways, as a loop turn does.
    fn exchange(&mut self) {
        self.publisher
            .tick(self.now, self.supervisor.seq(), self.supervisor.player());
        while let Some(p) = self.publisher.poll_transmit() {
            self.downlink_bytes += p.len() as u64;
            if !self.down.drops(self.now) && !self.route_lost {
                self.replica.receive(self.now, &p);
            }
        }
        self.replica.tick(self.now);
        while let Some(u) = self.replica.poll_transmit() {
            self.uplink.push(u.bytes().to_vec());
            if !self.up.drops(self.now) {
                // Heard: the autopilot learns the way to the mirror.
                self.route_lost = false;
                self.publisher.receive(u.bytes());
            }
        }
        while let Some(r) = self.replica.poll_report() {
            self.reports.push(r);
        }
    }

    /// Quiet time with a clean link, so that every gap can be repaired.
    fn settle(&mut self, seconds: u64) {
        self.down.rate = 0;
        self.up.rate = 0;
        self.down.bursts.clear();
        self.up.bursts.clear();
        for _ in 0..seconds * 10 {
            self.now += 100_000;
            self.feed(Input::Tick);
            self.exchange();
        }
    }

    fn diverged(&self) -> Vec<&Report> {
        self.reports
            .iter()
            .filter(|r| matches!(r, Report::Diverged { .. }))
            .collect()
    }

    /// The replica is exact and equal to the vehicle.
    fn assert_equal(&self) {
        let Some(exact) = self.replica.exact() else {
            panic!(
                "the replica is not exact: {:?}\n{:?}\nreports {:?}",
                self.replica.counts,
                self.publisher.counts,
                self.reports
                    .iter()
                    .filter(|r| !matches!(
                        r,
                        Report::Step { .. } | Report::Agreed { .. } | Report::Timers { .. }
                    ))
                    .collect::<Vec<_>>()
            );
        };
        let vehicle = self.supervisor.player();
        assert_eq!(self.replica.next_record(), self.publisher.next_record());
        // The replica has heard the vehicle up to its last heartbeat: let
        // its time catch up.
        let mut exact = exact.clone();
        assert!(exact.state().now <= vehicle.state().now);
        exact.advance(vehicle.state().now);
        assert_eq!(exact.digest(), vehicle.digest());
    }
}

/// Every uplink packet holds resync requests only.
fn only_requests(uplink: &[Vec<u8>]) {
    for p in uplink {
        let records = record::decode_packet(p).expect("uplink decodes");
        for r in records {
            assert!(
                matches!(
                    r,
                    Record::Resend { .. }
                        | Record::SendSnapshot { .. }
                        | Record::SendHeartbeat { .. }
                ),
                "{r:?}"
            );
        }
    }
}

fn fly(steps: &[Step], down: Loss, up: Loss) -> Flight {
    let mut f = Flight::new(down, up, publisher::Config::default());
    for s in steps {
        f.play(s);
    }
    f.settle(5);
    f
}

#[test]
fn a_lossless_downlink_agrees_at_every_record() {
    let steps: Vec<Step> = (0..400)
        .map(|i| match i % 5 {
            0 | 3 => Step::Event {
                pick: i * 7,
                dt: 300_000,
            },
            1 => Step::Reply {
                pick: 0,
                ok: i % 3 != 0,
                dt: 200_000,
            },
            _ => Step::Tick { dt: 150_000 },
        })
        .collect();
    let f = fly(&steps, Loss::none(), Loss::none());
    f.assert_equal();
    assert!(f.diverged().is_empty(), "{:?}", f.diverged());
    // Every record and every heartbeat checked, none asked again.
    assert_eq!(f.replica.counts.records, f.publisher.counts.records);
    assert!(
        f.replica.counts.agreed >= f.publisher.counts.records + f.publisher.counts.heartbeats - 1
    );
    assert_eq!(f.uplink.len(), 0);
    assert!(f.publisher.counts.records > 100, "{:?}", f.publisher.counts);
}

#[test]
fn losses_are_repaired_by_retransmission_and_never_called_divergence() {
    let steps: Vec<Step> = (0..600)
        .map(|i| match i % 4 {
            0 => Step::Event {
                pick: i * 5,
                dt: 250_000,
            },
            1 => Step::Reply {
                pick: i % 2,
                ok: true,
                dt: 100_000,
            },
            _ => Step::Tick { dt: 100_000 },
        })
        .collect();
    for rate in [10, 100, 300] {
        let f = fly(
            &steps,
            Loss::random(rate, rate),
            Loss::random(rate + 1, rate),
        );
        f.assert_equal();
        assert!(f.diverged().is_empty(), "{rate}‰: {:?}", f.diverged());
        assert!(f.down.dropped > 0);
        assert!(f.replica.counts.gaps > 0, "{rate}‰");
        let resynced = f
            .reports
            .iter()
            .filter(|r| matches!(r, Report::Resynced { .. }))
            .count();
        assert!(resynced as u64 >= f.replica.counts.gaps, "{rate}‰");
        only_requests(&f.uplink);
    }
}

#[test]
fn a_gap_older_than_the_ring_is_repaired_by_a_snapshot() {
    let config = publisher::Config {
        ring: 4,
        ..publisher::Config::default()
    };
    let mut down = Loss::none();
    // Ten seconds of silence on the downlink.
    down.bursts.push((5_000_000, 15_000_000));
    let mut f = Flight::new(down, Loss::none(), config);
    for i in 0..300 {
        f.play(&Step::Event {
            pick: i,
            dt: 100_000,
        });
    }
    f.settle(5);
    f.assert_equal();
    assert!(f.diverged().is_empty(), "{:?}", f.diverged());
    assert!(f.replica.counts.snapshots_restored >= 1);
    assert!(f.reports.iter().any(|r| matches!(
        r,
        Report::Resynced {
            how: replica::Repair::Snapshot,
            ..
        }
    )));
}

#[test]
fn a_real_divergence_names_its_step_then_resyncs_by_itself() {
    let mut f = Flight::new(Loss::none(), Loss::none(), publisher::Config::default());
    for _ in 0..20 {
        f.play(&Step::Tick { dt: 200_000 });
    }
    assert!(f.diverged().is_empty());
    // The vehicle plays an input it does not publish: the replica's state
    // differs from the next check on.
    let names: Vec<String> = f.project.events.keys().cloned().collect();
    for n in &names {
        f.hidden.push(Event::new(n.clone()).param("alt", 100));
    }
    for i in 0..names.len() + 30 {
        f.play(&Step::Tick {
            dt: 100_000 + i as u64,
        });
    }
    f.settle(5);
    let diverged = f.diverged();
    assert!(
        !diverged.is_empty(),
        "{:?} {:?}",
        f.hidden_at,
        f.replica.counts
    );
    let Report::Diverged { step, agreed, .. } = diverged[0] else {
        unreachable!()
    };
    let hidden_at = f.hidden_at.expect("a hidden input changed the vehicle");
    // Named at the first check after the hidden input: the next record or
    // heartbeat, within a second.
    assert!(*step >= hidden_at, "{step} < {hidden_at}");
    assert!(agreed.is_some_and(|a| a < hidden_at), "{agreed:?}");
    assert_eq!(diverged.len(), 1, "{diverged:?}");
    // Resynced by a snapshot, and equal at the end.
    assert!(f.replica.counts.snapshots_restored >= 1);
    f.assert_equal();
}

#[test]
fn a_mirror_started_late_asks_for_a_snapshot() {
    let mut f = Flight::new(Loss::none(), Loss::none(), publisher::Config::default());
    for i in 0..50 {
        f.play(&Step::Event {
            pick: i,
            dt: 300_000,
        });
    }
    // A new ground station, mid-flight.
    f.replica = Replica::new(f.project.clone(), replica::Config::default());
    f.reports.clear();
    for i in 0..30 {
        f.play(&Step::Event {
            pick: i,
            dt: 300_000,
        });
    }
    f.settle(5);
    f.assert_equal();
    assert!(f.diverged().is_empty(), "{:?}", f.diverged());
    assert_eq!(f.replica.counts.snapshots_restored, 1);
}

#[test]
fn corrupt_packets_are_counted_and_ignored() {
    let mut f = Flight::new(Loss::none(), Loss::none(), publisher::Config::default());
    f.replica.receive(1, &[]);
    f.replica.receive(1, &[9, 1, 2]);
    f.replica.receive(1, &[1, 1, 0xff]);
    assert_eq!(f.replica.counts.refused, 3);
    for i in 0..10 {
        f.play(&Step::Event {
            pick: i,
            dt: 300_000,
        });
    }
    f.publisher.receive(&[1, 77]);
    assert_eq!(f.publisher.counts.refused, 1);
    f.settle(2);
    f.assert_equal();
}

#[test]
fn the_downlink_stays_small_when_nothing_happens() {
    let mut f = Flight::new(Loss::none(), Loss::none(), publisher::Config::default());
    f.settle(120);
    // Heartbeats (one a second) and two snapshots in two minutes.
    let per_s = f.downlink_bytes as f64 / 120.0;
    assert!(per_s < 60.0, "{per_s} B/s");
    f.assert_equal();
}

#[test]
fn after_an_autopilot_reboot_the_mirror_speaks_when_the_downlink_falls_silent() {
    let mut f = Flight::new(Loss::none(), Loss::none(), publisher::Config::default());
    f.settle(10);
    // In step, nothing to ask: the mirror says nothing.
    assert!(f.uplink.is_empty(), "{:?}", f.uplink);
    // The autopilot reboots: its routes are gone, the records go nowhere.
    f.route_lost = true;
    let lost_at = f.now;
    for i in 0..60 {
        f.play(&Step::Event {
            pick: i,
            dt: 100_000,
        });
        if !f.route_lost {
            break;
        }
    }
    assert!(
        !f.route_lost,
        "the mirror never spoke: the route stays lost"
    );
    let silent = f.now - lost_at;
    let config = replica::Config::default();
    assert!(
        silent >= config.silent_after && silent <= config.silent_after + 200_000,
        "spoke after {silent} µs of silence"
    );
    // One heartbeat request, and the records flow again.
    assert_eq!(f.uplink.len(), 1, "{:?}", f.uplink);
    assert_eq!(
        record::decode_packet(&f.uplink[0]),
        Ok(vec![Record::SendHeartbeat { at: 0 }])
    );
    f.settle(5);
    f.assert_equal();
    assert!(f.diverged().is_empty(), "{:?}", f.diverged());
    only_requests(&f.uplink);
}

#[test]
fn a_silent_downlink_is_hailed_every_few_seconds_never_more() {
    let mut f = Flight::new(Loss::none(), Loss::none(), publisher::Config::default());
    f.settle(3);
    // The radio is down both ways for a minute.
    f.down.bursts.push((f.now, f.now + 60_000_000));
    f.up.bursts.push((f.now, f.now + 60_000_000));
    for _ in 0..600 {
        f.now += 100_000;
        f.feed(Input::Tick);
        f.exchange();
    }
    // A request after 3 s of silence, then one every 5 s.
    let config = replica::Config::default();
    let expected = (60_000_000 - config.silent_after) / config.hello_every + 1;
    assert_eq!(f.uplink.len() as u64, expected, "{:?}", f.uplink);
    f.settle(5);
    f.assert_equal();
}

#[test]
fn a_heartbeat_asked_for_comes_when_the_vehicles_time_reaches_it() {
    let mut f = Flight::new(Loss::none(), Loss::none(), publisher::Config::default());
    f.settle(2);
    let heartbeats = f.publisher.counts.heartbeats;
    // Between two periodic heartbeats (every second, the last at 2.0 s).
    let at = f.now + 400_000;
    f.replica.ask_heartbeat(at);
    while f.now < at {
        f.exchange();
        assert!(f.replica.exact_time() < Some(at));
        f.now += 100_000;
        f.feed(Input::Tick);
    }
    f.exchange();
    assert_eq!(f.publisher.counts.heartbeats, heartbeats + 1);
    assert_eq!(f.replica.exact_time(), Some(at));
    assert_eq!(f.replica.counts.heartbeats_asked, 1);
    f.settle(2);
    f.assert_equal();
    only_requests(&f.uplink);
}

#[test]
fn heartbeats_asked_for_are_paced_however_often_the_ground_asks() {
    let mut f = Flight::new(Loss::none(), Loss::none(), publisher::Config::default());
    f.settle(2);
    let heartbeats = f.publisher.counts.heartbeats;
    // A ground asking for a heartbeat at once, at every tick for 2 s.
    let ask = record::packet(&[Record::SendHeartbeat { at: 0 }]);
    for _ in 0..20 {
        f.publisher.receive(&ask);
        f.now += 100_000;
        f.feed(Input::Tick);
        f.exchange();
    }
    // Two periodic ones, and the asked ones 250 ms apart at least.
    let sent = f.publisher.counts.heartbeats - heartbeats;
    let most = 2 + 2_000_000 / publisher::HEARTBEAT_ASKED_GAP;
    assert!((3..=most).contains(&sent), "{sent} heartbeats in 2 s");
    f.settle(2);
    f.assert_equal();
}

#[test]
fn the_time_base_is_the_median_of_the_recent_heartbeats() {
    let (project, _) = example();
    let mut r = Replica::new(project, replica::Config::default());
    let heartbeat = |time: Micros| {
        record::packet(&[Record::Heartbeat(record::Heartbeat {
            session: 1,
            step: 0,
            time,
            next: 0,
            oldest: 0,
            digest: [0; 16],
        })])
    };
    // Vehicle time 10, 11, 12 s at ground time 4.1, 5.1, 6.1 s (0.1 s on
    // the way); the next one held up 0.7 s by a busy radio: the time base
    // does not move.
    for i in 0..3 {
        r.receive(
            4_100_000 + i * 1_000_000,
            &heartbeat(10_000_000 + i * 1_000_000),
        );
    }
    r.receive(7_800_000, &heartbeat(13_000_000));
    assert_eq!(r.vehicle_time(8_100_000), Some(14_000_000));
    // The way gets slower for good (a queue on the ground's port): the
    // time base follows once most of the last 10 s say so.
    for i in 0..8 {
        r.receive(
            8_600_000 + i * 1_000_000,
            &heartbeat(14_000_000 + i * 1_000_000),
        );
    }
    assert_eq!(r.vehicle_time(16_600_000), Some(22_000_000));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Random traces, random loss both ways: the replica ends equal, and
    /// never reports a divergence that is not there.
    #[test]
    fn random_traces_at_random_loss_end_equal(
        steps in trace(300),
        seed in any::<u64>(),
        rate in 0u64..400,
        burst in prop::option::of((0u64..60_000_000, 0u64..8_000_000)),
    ) {
        let mut down = Loss::random(seed, rate);
        if let Some((at, len)) = burst {
            down.bursts.push((at, at + len));
        }
        let f = fly(&steps, down, Loss::random(seed.rotate_left(7), rate));
        f.assert_equal();
        prop_assert!(f.diverged().is_empty(), "{:?}", f.diverged());
        only_requests(&f.uplink);
    }
}

#[test]
fn a_snapshot_of_the_example_fits_in_a_few_packets() {
    let mut f = Flight::new(Loss::none(), Loss::none(), publisher::Config::default());
    for i in 0..200 {
        f.play(&Step::Event {
            pick: i * 3,
            dt: 200_000,
        });
    }
    let bytes = nets::player::snapshot::encode(f.supervisor.player().state());
    eprintln!("snapshot of the flight-test example: {} bytes", bytes.len());
    assert!(bytes.len() < 512, "{} bytes", bytes.len());
}

#[test]
fn while_a_gap_is_open_the_replica_is_shown_provisional_then_exact_again() {
    let mut down = Loss::none();
    down.bursts.push((2_000_000, 4_000_000));
    let mut f = Flight::new(down, Loss::none(), publisher::Config::default());
    let names: Vec<String> = f.project.events.keys().cloned().collect();
    let mut provisional_seen = false;
    for i in 0..80 {
        f.play(&Step::Event {
            pick: i,
            dt: 100_000,
        });
        if let Some((_, true)) = f.replica.shown() {
            provisional_seen = true;
            // The ground's own events advance the provisional view only.
            let before = f.replica.exact_time();
            f.replica
                .ground_event(f.now, &Event::new(names[i % names.len()].clone()));
            assert_eq!(f.replica.exact_time(), before);
            assert!(f.replica.exact().is_none());
        }
    }
    f.settle(5);
    assert!(provisional_seen, "no gap was open: {:?}", f.replica.counts);
    assert!(matches!(f.replica.shown(), Some((_, false))));
    f.assert_equal();
}

/// Replays the calls the replica kept (through their recorded JSON) on a
/// fresh player, as `petrel replay` does a mirror's recording: every
/// call's effects and digest are the replica's. Returns how many calls of
/// each kind (restart, record, advance, restore).
fn replay_kept_calls(f: &mut Flight) -> [usize; 5] {
    use crate::mirror::call::{self, Call};
    let mut player = nets::Player::start(f.project.clone(), 0);
    let _ = player.effects().count();
    let mut kinds = [0; 5];
    let mut seq = 0;
    while let Some(played) = f.replica.poll_played() {
        seq += 1;
        // Through the call's text, as the mirror's recording keeps it.
        let line = call::call_json(&played.call).to_string();
        let time = played.time;
        let Ok(json) = serde_json::from_str::<serde_json::Value>(&line) else {
            panic!("call {seq} did not read back: {line}");
        };
        let c = call::call_from(&json).expect("a call");
        assert_eq!(c, played.call, "{line}");
        kinds[match c {
            Call::Restart => 0,
            Call::Record { .. } => 1,
            Call::Advance => 2,
            Call::Restore(_) => 3,
            Call::Version(_) => 4,
        }] += 1;
        let effects = call::apply(&mut player, time, &c).expect("the call plays");
        assert_eq!(effects, played.effects, "call {seq}: {c:?}");
        assert_eq!(player.digest(), played.digest, "call {seq}: {c:?}");
    }
    kinds
}

fn recording_flight(down: Loss, config: publisher::Config) -> Flight {
    let mut f = Flight::new(down, Loss::none(), config);
    f.replica = Replica::new(
        f.project.clone(),
        replica::Config {
            record: true,
            ..replica::Config::default()
        },
    );
    f
}

#[test]
fn the_replicas_calls_replay_to_its_digests_across_retransmissions_and_snapshots() {
    let config = publisher::Config {
        ring: 4,
        ..publisher::Config::default()
    };
    let mut down = Loss::random(3, 100);
    // Ten seconds of silence on the downlink: a snapshot restores.
    down.bursts.push((5_000_000, 15_000_000));
    let mut f = recording_flight(down, config);
    for i in 0..300 {
        f.play(&Step::Event {
            pick: i,
            dt: 100_000,
        });
    }
    f.settle(5);
    f.assert_equal();
    let kinds = replay_kept_calls(&mut f);
    // The start, records, heartbeats, and the snapshot restored.
    assert_eq!(kinds[0], 1, "{kinds:?}");
    assert!(kinds[1] > 100, "{kinds:?}");
    assert!(kinds[2] > 10, "{kinds:?}");
    assert!(kinds[3] >= 1, "{kinds:?}");
}

#[test]
fn a_replica_that_started_with_the_vehicle_records_its_restart() {
    let mut f = recording_flight(Loss::none(), publisher::Config::default());
    for i in 0..50 {
        f.play(&Step::Event {
            pick: i,
            dt: 300_000,
        });
    }
    f.settle(2);
    f.assert_equal();
    let kinds = replay_kept_calls(&mut f);
    assert_eq!(kinds[0], 1, "{kinds:?}");
    assert_eq!(kinds[3], 0, "{kinds:?}");
}

#[test]
fn without_recording_the_replica_keeps_no_calls() {
    let mut f = fly(
        &(0..20)
            .map(|i| Step::Event {
                pick: i,
                dt: 300_000,
            })
            .collect::<Vec<_>>(),
        Loss::none(),
        Loss::none(),
    );
    assert!(f.replica.poll_played().is_none());
}

#[test]
fn a_sessions_first_packet_is_played_without_a_gap() {
    // As in `petrel run`: the first turn of the loop steps the player
    // before the publisher's first tick, so the first packet holds record
    // 0 and then the first heartbeat (next: 1).
    let (project, profile) = example();
    let (mut supervisor, _) =
        Supervisor::start(project.clone(), profile, elaboration::Config::default(), 0);
    let mut publisher = Publisher::new(3, publisher::Config::default(), 0);
    let mut replica = Replica::new(project.clone(), replica::Config::default());
    let name = project.events.keys().next().expect("an event").clone();
    let input = Input::Event(Event::new(name));
    let step = supervisor.step(200_000, input.clone());
    let inputs =
        step_inputs(&input, &step, &super::Unread::none()).expect("a program's event is published");
    publisher.step(
        step.seq,
        0,
        step.time,
        inputs,
        &supervisor.player().digest(),
    );
    publisher.tick(200_000, supervisor.seq(), supervisor.player());
    let packet = publisher.poll_transmit().expect("a packet");
    let records = record::decode_packet(&packet).expect("decodes");
    assert!(
        matches!(records.as_slice(), [Record::Step(s), Record::Heartbeat(h)] if s.number == 0 && h.next == 1),
        "{records:?}"
    );
    replica.receive(1_000, &packet);
    let reports: Vec<Report> = std::iter::from_fn(|| replica.poll_report()).collect();
    let named: Vec<String> = reports
        .iter()
        .map(|r| match r {
            Report::Resynced { how, .. } => format!("resynced {}", how.name()),
            Report::Gap { from, to, .. } => format!("gap {from}..{to}"),
            Report::Step { number, .. } => format!("record {number}"),
            Report::Agreed { step } => format!("agreed {step}"),
            Report::Timers { .. } => "timers".into(),
            Report::Diverged { .. } => "diverged".into(),
            Report::Version { number, .. } => format!("version {number}"),
            Report::UnknownVersion { number, .. } => format!("unknown version {number}"),
        })
        .collect();
    assert_eq!(
        named,
        ["resynced start", "record 0", "agreed 1", "agreed 1"],
        "{reports:?}"
    );
    assert_eq!(replica.counts.gaps, 0);
    assert!(replica.poll_transmit().is_none(), "nothing asked");
    assert_eq!(
        replica.exact().map(|p| p.digest()),
        Some(supervisor.player().digest())
    );
}

#[test]
fn a_refused_command_the_nets_do_not_await_costs_no_record_and_the_replica_stays_exact() {
    // ArduPlane refuses the onboard gateway's IMAGE_START_CAPTURE once a
    // second: `command_rejected`, which the ground never compares (the
    // acknowledgement goes to the onboard gateway alone) and no
    // transition of the example awaits, changes nothing but the clock.
    use mavlink::dialects::ardupilotmega::{
        MavAutopilot, MavCmd, MavMessage, MavModeFlag, MavResult, MavState, MavType,
        COMMAND_ACK_DATA, HEARTBEAT_DATA,
    };
    let frame = |component: u8, seq: u8, message: &MavMessage| {
        let header = mavlink::MavHeader {
            system_id: 1,
            component_id: component,
            sequence: seq,
        };
        elaboration::frame::serialize(header, mavlink::MavlinkVersion::V2, message)
    };
    let heartbeat = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_FIXED_WING,
        autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
        system_status: MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
    });
    let refused = MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
        command: MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
        result: MavResult::MAV_RESULT_DENIED,
        target_system: 1,
        target_component: 191,
        ..Default::default()
    });
    let (project, profile) = example();
    let config = elaboration::Config::default();
    let unread = super::Unread::of(&[crate::supervisor::Lane {
        vehicle: None,
        profile: profile.clone(),
        config: config.clone(),
    }]);
    let (mut supervisor, _) = Supervisor::start(project.clone(), profile, config, 0);
    let mut publisher = Publisher::new(5, publisher::Config::default(), 0);
    let mut replica = Replica::new(project.clone(), replica::Config::default());
    let (mut left_out, mut now) = (0, 0);
    for i in 0..40u8 {
        now += 250_000;
        let bytes = if i % 4 == 3 {
            frame(1, i, &refused)
        } else {
            frame(1, i, &heartbeat)
        };
        let before = supervisor.player().state().now;
        let input = Input::Frame(&bytes);
        let step = supervisor.step(now, input.clone());
        let rejected = step
            .events
            .iter()
            .any(|(e, _)| e.event.name == "command_rejected");
        if rejected {
            assert!(step_inputs(&input, &step, &super::Unread::none()).is_some());
        }
        match step_inputs(&input, &step, &unread) {
            Some(inputs) => publisher.step(
                step.seq,
                before,
                step.time,
                inputs,
                &supervisor.player().digest(),
            ),
            None => left_out += u64::from(rejected),
        }
        publisher.tick(now, supervisor.seq(), supervisor.player());
        while let Some(p) = publisher.poll_transmit() {
            replica.receive(now, &p);
        }
    }
    assert_eq!(left_out, 10, "every refusal left out");
    let reports: Vec<Report> = std::iter::from_fn(|| replica.poll_report()).collect();
    assert!(
        !reports
            .iter()
            .any(|r| matches!(r, Report::Diverged { .. } | Report::Gap { .. })),
        "{reports:?}"
    );
    let mut exact = replica.exact().expect("exact").clone();
    exact.advance(supervisor.player().state().now);
    assert_eq!(exact.digest(), supervisor.player().digest());
}
