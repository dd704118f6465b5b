//! The onboard half of the ground mirror, sans-IO: fed the supervisor's
//! steps and the ground's requests, polled for downlink packets (TUNNEL
//! payloads). It numbers the step records, keeps the last ones in a ring to
//! send again on request, sends the step counter and digest every second,
//! and a snapshot of the player on request and every
//! [`Config::snapshot_every`]. Retransmissions and snapshots share a byte
//! budget per second so that a resync never floods the radio.
//!
//! It never decides anything for the player: it only reads it.

use std::collections::{BTreeSet, VecDeque};

use nets::binary::Writer;
use nets::player::{snapshot, Digest};
use nets::{Micros, Player};

use super::record::{
    self, Chunk, Fragment, Heartbeat, Input, Record, Snapshot, StepRecord, MAX_PACKET,
};

/// How the publisher paces itself.
#[derive(Debug, Clone)]
pub struct Config {
    /// Step records kept to answer retransmission requests.
    pub ring: usize,
    /// The heartbeat's period.
    pub heartbeat_every: Micros,
    /// A snapshot's period (besides those asked for).
    pub snapshot_every: Micros,
    /// Bytes per second that retransmissions and snapshots may use (a
    /// bucket holding one second's worth).
    pub resync_bytes_per_s: u64,
    /// Records sent again for one request, at most.
    pub resend_max: u64,
}

impl Default for Config {
    fn default() -> Config {
        Config {
            ring: 512,
            heartbeat_every: 1_000_000,
            snapshot_every: 60_000_000,
            resync_bytes_per_s: 1_000,
            resend_max: 32,
        }
    }
}

/// What the publisher counted.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Counts {
    pub records: u64,
    pub heartbeats: u64,
    pub snapshots: u64,
    pub resent: u64,
    /// Packets sent and their bytes (TUNNEL payloads).
    pub packets: u64,
    pub bytes: u64,
    /// Uplink packets that did not decode, or asked for another session.
    pub refused: u64,
}

/// Heartbeats asked for ahead (`8 heartbeat?`), kept at most: the ground
/// asks one per event it saw and the vehicle has not reported yet.
pub const HEARTBEATS_ASKED: usize = 16;
/// Heartbeats asked for are sent this far apart at least (vehicle time),
/// whoever asks and however often: four a second, 200 B/s at most.
pub const HEARTBEAT_ASKED_GAP: Micros = 250_000;

/// Lanes in one boot record at most (a team's in turn): a packet's worth
/// with its heartbeat.
pub const BOOT_LANES: usize = 12;

/// The onboard publisher.
pub struct Publisher {
    config: Config,
    session: u32,
    next: u64,
    ring: VecDeque<StepRecord>,
    /// Fresh records (sent at once).
    fresh: VecDeque<Record>,
    /// Retransmissions and snapshot chunks (paced).
    resync: VecDeque<Record>,
    tokens: u64,
    refilled: Micros,
    next_heartbeat: Micros,
    next_snapshot: Micros,
    snapshots: u64,
    /// The project's version the player runs (`None`: the one the run
    /// started with), said in each snapshot.
    version: Option<(u32, [u8; 32])>,
    /// A snapshot was asked for and not yet queued.
    snapshot_asked: bool,
    /// Vehicle times the ground asked a heartbeat at (at most
    /// [`HEARTBEATS_ASKED`], the earliest kept).
    heartbeats_asked: BTreeSet<Micros>,
    /// When the last heartbeat asked for went (vehicle time).
    asked_sent_at: Option<Micros>,
    /// Each lane's autopilot clock as far as read (`Record::Boot`), and
    /// where the next boot record starts among them (a team's lanes in
    /// turn, [`BOOT_LANES`] a heartbeat).
    boots: Vec<(u64, Micros)>,
    boots_from: usize,
    pub counts: Counts,
}

impl Publisher {
    /// A publisher for session `session` (a new number each time the
    /// gateway starts), at `now`.
    pub fn new(session: u32, config: Config, now: Micros) -> Publisher {
        Publisher {
            tokens: config.resync_bytes_per_s,
            next_snapshot: now.saturating_add(config.snapshot_every),
            config,
            session,
            next: 0,
            ring: VecDeque::new(),
            fresh: VecDeque::new(),
            resync: VecDeque::new(),
            refilled: now,
            next_heartbeat: now,
            snapshots: 0,
            version: None,
            snapshot_asked: false,
            heartbeats_asked: BTreeSet::new(),
            asked_sent_at: None,
            boots: Vec::new(),
            boots_from: 0,
            counts: Counts::default(),
        }
    }

    /// The number the next record gets.
    #[cfg(test)]
    pub fn next_record(&self) -> u64 {
        self.next
    }

    /// How far each lane's autopilot clock the elaboration has read
    /// (`supervisor::Lanes::boots`): sent after each heartbeat, so that the
    /// ground judges on the autopilot's clock how complete the vehicle's
    /// events are (docs/mirror.md, "The independent check").
    pub fn autopilot_clocks(&mut self, boots: Vec<(u64, Micros)>) {
        self.boots = boots;
    }

    /// A step whose inputs reached the player: `before` is the player's time
    /// before it, `time` the step's, `after` the player's digest after it.
    pub fn step(
        &mut self,
        step: u64,
        before: Micros,
        time: Micros,
        inputs: Vec<Input>,
        after: &Digest,
    ) {
        let mut digest = [0u8; 8];
        digest.copy_from_slice(&after.0[..8]);
        let record = StepRecord {
            number: self.next,
            step,
            before,
            time,
            inputs,
            digest,
        };
        self.next += 1;
        self.counts.records += 1;
        self.queue_step(&record, false);
        self.ring.push_back(record);
        while self.ring.len() > self.config.ring {
            self.ring.pop_front();
        }
    }

    /// A step record as one record, or as fragments when it is too long.
    fn queue_step(&mut self, s: &StepRecord, resend: bool) {
        let whole = Record::Step(s.clone());
        let queue = if resend {
            &mut self.resync
        } else {
            &mut self.fresh
        };
        // The record and the packet's version byte.
        if record::size(&whole) < MAX_PACKET {
            queue.push_back(whole);
            return;
        }
        let mut w = Writer::new();
        record::step_body(s, &mut w);
        let header = {
            let mut h = Writer::new();
            h.uvarint(s.number);
            h.bytes.len()
        };
        match record::pieces(&w.bytes, header) {
            Some(pieces) => {
                let count = pieces.len() as u8;
                for (i, data) in pieces.into_iter().enumerate() {
                    queue.push_back(Record::Fragment(Fragment {
                        number: s.number,
                        index: i as u8,
                        count,
                        data,
                    }));
                }
            }
            None => tracing::warn!(
                "step record {} ({} bytes) too long for the downlink: the mirror will ask for a snapshot",
                s.number,
                w.bytes.len()
            ),
        }
    }

    /// An uplink packet from the ground; `step` and `player` are the
    /// supervisor's now, for a snapshot asked for.
    pub fn receive(&mut self, packet: &[u8]) {
        let Ok(records) = record::decode_packet(packet) else {
            self.counts.refused += 1;
            return;
        };
        for r in records {
            match r {
                Record::Resend { from, count } => {
                    let count = count.min(self.config.resend_max);
                    let first = self.ring.front().map_or(self.next, |r| r.number);
                    let wanted: Vec<StepRecord> = self
                        .ring
                        .iter()
                        .filter(|r| {
                            r.number >= from.max(first) && r.number < from.saturating_add(count)
                        })
                        .filter(|r| !self.queued_again(r.number))
                        .cloned()
                        .collect();
                    for s in wanted {
                        self.counts.resent += 1;
                        self.queue_step(&s, true);
                    }
                }
                Record::SendSnapshot { session } if session == self.session || session == 0 => {
                    self.snapshot_asked = true;
                }
                Record::SendHeartbeat { at } => {
                    self.heartbeats_asked.insert(at);
                    while self.heartbeats_asked.len() > HEARTBEATS_ASKED {
                        self.heartbeats_asked.pop_last();
                    }
                }
                _ => self.counts.refused += 1,
            }
        }
    }

    /// A record said down with the fresh ones (an upload's status or
    /// verdict: `mirror::upload`).
    pub fn say(&mut self, record: Record) {
        self.fresh.push_back(record);
    }

    fn queued_again(&self, number: u64) -> bool {
        self.resync.iter().any(|r| match r {
            Record::Step(s) => s.number == number,
            Record::Fragment(f) => f.number == number,
            _ => false,
        })
    }

    /// Lets time pass: the heartbeat and the periodic snapshot when due.
    /// `step` is the supervisor's last step, `player` the player after it.
    pub fn tick(&mut self, now: Micros, step: u64, player: &Player) {
        // A heartbeat the ground asked for, once the player's time reaches
        // it: the ground then knows every record before that time.
        let time = player.state().now;
        let due = now >= self.next_heartbeat;
        let asked = self.heartbeats_asked.first().is_some_and(|at| *at <= time)
            && self
                .asked_sent_at
                .is_none_or(|t| time.saturating_sub(t) >= HEARTBEAT_ASKED_GAP);
        if due || asked {
            // Whichever heartbeat goes answers every request up to now.
            self.heartbeats_asked.retain(|at| *at > time);
            if due {
                self.next_heartbeat = now.saturating_add(self.config.heartbeat_every);
            } else {
                self.asked_sent_at = Some(time);
            }
            let mut digest = [0u8; 16];
            digest.copy_from_slice(&player.digest().0[..16]);
            self.fresh.push_back(Record::Heartbeat(Heartbeat {
                session: self.session,
                step,
                time: player.state().now,
                next: self.next,
                oldest: self.ring.front().map_or(self.next, |r| r.number),
                digest,
            }));
            self.counts.heartbeats += 1;
            if !self.boots.is_empty() {
                let from = self.boots_from % self.boots.len();
                let lanes: Vec<(u64, Micros)> = self
                    .boots
                    .iter()
                    .cycle()
                    .skip(from)
                    .take(self.boots.len().min(BOOT_LANES))
                    .copied()
                    .collect();
                self.boots_from = from + lanes.len();
                self.fresh.push_back(Record::Boot { time, lanes });
            }
        }
        let snapshot_queued = self.resync.iter().any(|r| matches!(r, Record::Chunk(_)));
        if (now >= self.next_snapshot || self.snapshot_asked) && !snapshot_queued {
            self.next_snapshot = now.saturating_add(self.config.snapshot_every);
            self.snapshot_asked = false;
            self.queue_snapshot(step, player);
        }
        let elapsed = now.saturating_sub(self.refilled);
        let add = elapsed.saturating_mul(self.config.resync_bytes_per_s) / 1_000_000;
        if add > 0 {
            self.tokens = (self.tokens + add).min(self.config.resync_bytes_per_s);
            self.refilled = now;
        }
    }

    /// A new version of the project took over (its number and files'
    /// digest): the snapshots from now on are of its state.
    pub fn version(&mut self, number: u32, digest: [u8; 32]) {
        self.version = Some((number, digest));
    }

    fn queue_snapshot(&mut self, step: u64, player: &Player) {
        let s = Snapshot {
            step,
            next: self.next,
            version: self.version,
            digest: player.digest().0,
            state: snapshot::encode(player.state()),
        };
        let bytes = s.encode();
        let header = {
            let mut h = Writer::new();
            h.raw(&[0; 4]);
            h.uvarint(self.snapshots);
            h.bytes.len()
        };
        let Some(pieces) = record::pieces(&bytes, header) else {
            tracing::warn!(
                "the player's snapshot ({} bytes) is too long for the downlink",
                bytes.len()
            );
            return;
        };
        let count = pieces.len() as u8;
        for (i, data) in pieces.into_iter().enumerate() {
            self.resync.push_back(Record::Chunk(Chunk {
                session: self.session,
                snapshot: self.snapshots,
                index: i as u8,
                count,
                data,
                versioned: s.version.is_some(),
            }));
        }
        self.snapshots += 1;
        self.counts.snapshots += 1;
    }

    /// The next downlink packet: fresh records first, packed together;
    /// then retransmissions and snapshot chunks while the budget allows.
    pub fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        let mut records = Vec::new();
        let mut size = 1;
        while let Some(r) = self.fresh.front() {
            let n = record::size(r);
            if size + n > MAX_PACKET {
                break;
            }
            size += n;
            records.extend(self.fresh.pop_front());
        }
        while let Some(r) = self.resync.front() {
            let n = record::size(r) as u64;
            if size as u64 + n > MAX_PACKET as u64 || self.tokens < n {
                break;
            }
            self.tokens -= n;
            size += n as usize;
            records.extend(self.resync.pop_front());
        }
        if records.is_empty() {
            return None;
        }
        let packet = record::packet(&records);
        self.counts.packets += 1;
        self.counts.bytes += packet.len() as u64;
        Some(packet)
    }
}
