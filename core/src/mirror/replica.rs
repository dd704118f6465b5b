//! The ground half of the mirror, sans-IO: the replica of the vehicle's
//! player. Fed downlink packets (and the ground's own elaborated events,
//! for the provisional view) with the ground's time, polled for reports and
//! for uplink requests.
//!
//! It plays each step record exactly as the onboard supervisor played its
//! inputs — the player advanced to the time before the step, each input at
//! its own time, then advanced to the step's time — so that its digest
//! equals the vehicle's after every record and at every heartbeat. Records
//! are numbered: a gap is seen at the first record or heartbeat after it;
//! the replica asks for the missing records (while the vehicle's ring holds
//! them) or for a snapshot, restores, and reports `mirror_resynced`. A
//! digest that differs for the same step, or a gap not repaired in
//! [`Config::give_up_after`], is `mirror_diverged` naming the step; the
//! replica then asks for a snapshot and resyncs by itself.
//!
//! It has no way to command the vehicle or call a program: its only
//! output to the link is [`Uplink`], which holds resync requests.

use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;

use nets::player::snapshot;
use nets::{Effect, Event, Micros, Player, Project};

use super::call::{self, Call, Played};
use super::record::{self, Chunk, Fragment, Heartbeat, Input, Record, Snapshot, StepRecord};
use crate::version::Version;

/// How far back (ground time) the heartbeats that set the time base go.
pub const OFFSET_SPAN: Micros = 10_000_000;

/// How the replica waits and asks.
#[derive(Debug, Clone)]
pub struct Config {
    /// A request not answered within this (ground time) is sent again.
    pub retry_after: Micros,
    /// A gap still open after this many heartbeats heard since it opened
    /// (the link works, the records do not come) is a divergence. A link
    /// that is down brings no heartbeat: that is a loss, not a divergence.
    pub give_up_after: u32,
    /// While nothing is heard, a snapshot request this often; and while
    /// the downlink is silent after it was heard, a heartbeat request.
    pub hello_every: Micros,
    /// The downlink is silent when nothing came for this long (ground
    /// time): three heartbeats missed. An autopilot that rebooted has lost
    /// its routes, and forwards the records to the mirror again only once
    /// it hears the mirror (docs/mirror.md, "Addressing").
    pub silent_after: Micros,
    /// Records held while waiting for an earlier one, at most.
    pub hold_max: usize,
    /// Records asked for in one request, at most.
    pub resend_max: u64,
    /// Keep every call on the player for [`Replica::poll_played`] (the
    /// mirror's recording).
    pub record: bool,
}

impl Default for Config {
    fn default() -> Config {
        Config {
            retry_after: 1_500_000,
            give_up_after: 30,
            hello_every: 5_000_000,
            silent_after: 3_000_000,
            hold_max: 1024,
            resend_max: 32,
            record: false,
        }
    }
}

/// How the replica came back in step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Repair {
    /// The missing records were sent again.
    Retransmission,
    /// A snapshot was restored.
    Snapshot,
    /// The first records of a session (the player's start).
    Start,
}

impl Repair {
    pub fn name(self) -> &'static str {
        match self {
            Repair::Retransmission => "retransmission",
            Repair::Snapshot => "snapshot",
            Repair::Start => "start",
        }
    }
}

/// What the replica reports, in order.
#[derive(Debug, Clone, PartialEq)]
pub enum Report {
    /// A vehicle step played: its effects are what the vehicle did (its
    /// commands and calls, shown, never carried out).
    Step {
        number: u64,
        step: u64,
        time: Micros,
        inputs: Vec<Input>,
        effects: Vec<Effect>,
    },
    /// Time passed to a vehicle step that sent no record (checked at a
    /// heartbeat or snapshot): the effects of the timers that expired.
    Timers {
        step: u64,
        time: Micros,
        effects: Vec<Effect>,
    },
    /// The vehicle's digest at `step` equals the replica's.
    Agreed { step: u64 },
    /// Records are missing: the replica is provisional from `step`.
    Gap { from: u64, to: u64, step: u64 },
    /// Exact again at `step`, `after` the gap opened (ground time).
    Resynced {
        step: u64,
        how: Repair,
        after: Micros,
    },
    /// The replica's state differs from the vehicle's at `step` (the first
    /// step found to differ; `agreed` the last step found equal).
    Diverged {
        step: u64,
        agreed: Option<u64>,
        reason: String,
    },
    /// A new version of the project took over on board at `step`, and in
    /// the replica (what follows is of its project).
    Version {
        number: u32,
        version: Arc<Version>,
        step: u64,
    },
    /// The vehicle runs version `number` (its files' digest), which this
    /// replica does not have ([`Replica::know`]): it waits for it,
    /// inexact (said once per version).
    UnknownVersion { number: u32, digest: [u8; 32] },
}

impl Report {
    /// `mirror_resynced` / `mirror_diverged` as events for the ground's
    /// timeline, recording and nets.
    pub fn event(&self) -> Option<Event> {
        match self {
            Report::Resynced { step, how, after } => Some(
                Event::new("mirror_resynced")
                    .param("step", *step as i64)
                    .param("how", how.name())
                    .param("after_s", *after as f64 / 1e6),
            ),
            Report::Diverged {
                step,
                agreed,
                reason,
            } => {
                let mut e = Event::new("mirror_diverged")
                    .param("step", *step as i64)
                    .param("reason", reason.as_str());
                if let Some(a) = agreed {
                    e = e.param("agreed", *a as i64);
                }
                Some(e)
            }
            _ => None,
        }
    }
}

/// Bytes the mirror may send up: resync requests only (the only type the
/// mirror's link writer takes). Built by the replica, never by hand.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Uplink(Vec<u8>);

impl Uplink {
    pub fn bytes(&self) -> &[u8] {
        &self.0
    }
}

/// What the replica counted.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Counts {
    pub packets: u64,
    /// Packets that did not decode (counted, never applied).
    pub refused: u64,
    pub records: u64,
    pub duplicates: u64,
    pub agreed: u64,
    pub gaps: u64,
    pub resends_asked: u64,
    pub snapshots_asked: u64,
    /// Heartbeats asked for: by the independent check, and while the
    /// downlink was silent.
    pub heartbeats_asked: u64,
    pub snapshots_restored: u64,
    /// Snapshots that failed their digest or did not fit the project.
    pub snapshots_refused: u64,
    pub diverged: u64,
}

/// A snapshot being put together: (session, snapshot number, its pieces).
type Chunks = (u32, u64, Vec<Option<Vec<u8>>>);

/// Boot records kept (one a heartbeat: the last half minute).
const BOOTS: usize = 32;

/// The replica.
pub struct Replica {
    config: Config,
    project: Arc<Project>,
    /// The versions of the project this replica can take over (beside
    /// `project`, the one the vehicle started with), by files' digest.
    versions: Vec<Arc<Version>>,
    /// The version the vehicle runs and this replica lacks, once said.
    missing: Option<(u32, [u8; 32])>,
    session: Option<u32>,
    /// The exact replica, once in step with the vehicle.
    player: Option<Player>,
    /// The number of the next record to play.
    next: u64,
    /// The last vehicle step played or checked, and the last found equal.
    step: u64,
    agreed: Option<u64>,
    /// Records received after a gap, by number.
    held: BTreeMap<u64, StepRecord>,
    fragments: BTreeMap<u64, Vec<Option<Vec<u8>>>>,
    chunks: Option<Chunks>,
    /// The highest record number known to exist, plus one.
    known: u64,
    /// The oldest record the vehicle's ring holds (last heartbeat).
    oldest: u64,
    /// The last heartbeat, kept until the records before it are played.
    heartbeat: Option<Heartbeat>,
    /// When (ground time) the current gap opened, or sync was lost.
    gap_since: Option<Micros>,
    /// Heartbeats heard while the current gap is open.
    gap_heartbeats: u32,
    /// When the last snapshot request went up.
    asked_at: Option<Micros>,
    /// When each missing record was last asked for.
    asked: BTreeMap<u64, Micros>,
    /// Diverged and not yet resynced: reported once.
    diverged: bool,
    /// The replica advanced by the ground's own events while a gap is open.
    provisional: Option<Player>,
    /// Vehicle time minus ground time: the median of the recent
    /// heartbeats', kept with their ground time.
    offset: Option<i128>,
    offsets: VecDeque<(Micros, i128)>,
    /// The last boot records (`Record::Boot`): at a vehicle time, how far
    /// each lane's autopilot clock the onboard elaboration had read.
    boots: VecDeque<(Micros, Vec<(u64, Micros)>)>,
    /// When (ground time) the last downlink packet came, and the last
    /// request sent while it was silent.
    heard_at: Option<Micros>,
    hailed_at: Option<Micros>,
    now: Micros,
    reports: VecDeque<Report>,
    uplink: VecDeque<Uplink>,
    /// The calls on the player, when recording.
    played: VecDeque<Played>,
    /// The vehicle's word on uploads (`mirror::upload`), for the sender.
    uploads: VecDeque<Record>,
    pub counts: Counts,
}

impl Replica {
    pub fn new(project: Arc<Project>, config: Config) -> Replica {
        Replica {
            config,
            project,
            versions: Vec::new(),
            missing: None,
            session: None,
            player: None,
            next: 0,
            step: 0,
            agreed: None,
            held: BTreeMap::new(),
            fragments: BTreeMap::new(),
            chunks: None,
            known: 0,
            oldest: 0,
            heartbeat: None,
            gap_since: Some(0),
            asked_at: None,
            gap_heartbeats: 0,
            asked: BTreeMap::new(),
            diverged: false,
            provisional: None,
            offset: None,
            offsets: VecDeque::new(),
            boots: VecDeque::new(),
            heard_at: None,
            hailed_at: None,
            now: 0,
            reports: VecDeque::new(),
            uplink: VecDeque::new(),
            played: VecDeque::new(),
            uploads: VecDeque::new(),
            counts: Counts::default(),
        }
    }

    /// The next word of the vehicle on an upload (`Record::Received`,
    /// `Record::Verdict`).
    pub fn poll_upload(&mut self) -> Option<Record> {
        self.uploads.pop_front()
    }

    /// A version of the project this replica may meet: the vehicle takes
    /// it over (a step record says so), or a snapshot is of it. A version
    /// the replica waited for resyncs it at the next snapshot.
    pub fn know(&mut self, version: Arc<Version>) {
        let digest = version.digest();
        if self.versions.iter().any(|v| v.digest() == digest) {
            return;
        }
        if self.missing.is_some_and(|(_, d)| d == digest) {
            self.missing = None;
            // Ask for a snapshot at once.
            self.asked_at = None;
        }
        self.versions.push(version);
    }

    /// The known version whose files' digest is `digest`.
    fn version(&self, digest: &[u8; 32]) -> Option<Arc<Version>> {
        self.versions
            .iter()
            .find(|v| &v.digest() == digest)
            .cloned()
    }

    /// The vehicle runs a version this replica lacks: said once, and the
    /// replica is inexact until it has it.
    fn lacks(&mut self, number: u32, digest: [u8; 32]) {
        if self.missing != Some((number, digest)) {
            self.missing = Some((number, digest));
            self.reports
                .push_back(Report::UnknownVersion { number, digest });
        }
    }

    /// The exact replica, when in step (not while a gap is open).
    #[cfg(test)]
    pub fn exact(&self) -> Option<&Player> {
        if self.gap_since.is_none() && !self.diverged {
            self.player.as_ref()
        } else {
            None
        }
    }

    /// The vehicle time through which the replica holds every record (its
    /// player's time), when it is exact.
    pub fn exact_time(&self) -> Option<Micros> {
        (self.gap_since.is_none() && !self.diverged)
            .then(|| self.player.as_ref().map(|p| p.state().now))
            .flatten()
    }

    /// How far lane `lane`'s autopilot clock (its `time_boot_ms`, in µs)
    /// the onboard elaboration had read by the time through which the
    /// replica holds every record ([`Replica::exact_time`]): every event the
    /// vehicle elaborated from frames up to it is known to the ground.
    pub fn exact_boot(&self, lane: usize) -> Option<Micros> {
        let known = self.exact_time()?;
        self.boots
            .iter()
            .rev()
            .filter(|(time, _)| *time <= known)
            .find_map(|(_, lanes)| lanes.iter().find(|(l, _)| *l == lane as u64))
            .map(|(_, boot)| *boot)
    }

    /// The vehicle's time at ground time `now`, estimated from the recent
    /// heartbeats: each one's time minus the ground's when it came is the
    /// clocks' difference less its delay on the way, and the median of the
    /// last [`OFFSET_SPAN`] is taken. The delay is kept in: the ground's
    /// telemetry comes the same way as the heartbeats (the autopilot's
    /// ground port, its queue, the radio), so a ground event maps to about
    /// when the vehicle heard the same frame. The median, not the last,
    /// so that one heartbeat held up (by the radio, by a busy ground) does
    /// not move the time base; not the least delayed, which would leave
    /// the ground port's usual queue in every ground event's time.
    pub fn vehicle_time(&self, now: Micros) -> Option<Micros> {
        self.offset.map(|o| (now as i128 + o).max(0) as Micros)
    }

    /// The replica as shown: exact, or provisional (advanced by the
    /// ground's own elaboration) while a gap is open; `true` when
    /// provisional.
    pub fn shown(&self) -> Option<(&Player, bool)> {
        match (&self.provisional, &self.player) {
            (Some(p), _) if self.gap_since.is_some() => Some((p, true)),
            (_, Some(p)) => Some((p, self.gap_since.is_some() || self.diverged)),
            _ => None,
        }
    }

    /// The number of the next record to play.
    #[cfg(test)]
    pub fn next_record(&self) -> u64 {
        self.next
    }

    /// The next report.
    pub fn poll_report(&mut self) -> Option<Report> {
        self.reports.pop_front()
    }

    /// The next call the exact replica made on its player (kept only
    /// with [`Config::record`]), in order.
    pub fn poll_played(&mut self) -> Option<Played> {
        self.played.pop_front()
    }

    /// Keeps a call for the recording.
    fn keep(&mut self, time: Micros, call: impl FnOnce() -> Call, effects: &[Effect]) {
        if !self.config.record {
            return;
        }
        let Some(p) = &self.player else { return };
        self.played.push_back(Played {
            time,
            call: call(),
            effects: effects.to_vec(),
            digest: p.digest(),
        });
    }

    /// The next request to send up.
    pub fn poll_transmit(&mut self) -> Option<Uplink> {
        self.uplink.pop_front()
    }

    /// Asks the vehicle for a heartbeat once its time reaches `at`: the
    /// independent check judges a ground event the vehicle did not report
    /// once the vehicle's records are known complete past it (without it,
    /// the periodic heartbeat comes up to a second later). Only while in
    /// step with a session heard.
    pub fn ask_heartbeat(&mut self, at: Micros) {
        if self.session.is_none() || self.gap_since.is_some() || self.diverged {
            return;
        }
        self.counts.heartbeats_asked += 1;
        self.uplink
            .push_back(Uplink(record::packet(&[Record::SendHeartbeat { at }])));
    }

    /// A downlink packet received at ground time `now`.
    pub fn receive(&mut self, now: Micros, packet: &[u8]) {
        self.now = self.now.max(now);
        self.counts.packets += 1;
        self.heard_at = Some(self.now);
        self.hailed_at = None;
        let records = match record::decode_packet(packet) {
            Ok(r) => r,
            Err(e) => {
                self.counts.refused += 1;
                tracing::debug!("downlink packet refused: {e}");
                return;
            }
        };
        for r in records {
            match r {
                Record::Heartbeat(h) => self.heartbeat(h),
                Record::Step(s) => {
                    self.record(s);
                    self.play_held();
                }
                Record::Fragment(f) => {
                    self.fragment(f);
                    self.play_held();
                }
                Record::Chunk(c) => self.chunk(c),
                Record::Boot { time, lanes } => {
                    self.boots.push_back((time, lanes));
                    while self.boots.len() > BOOTS {
                        self.boots.pop_front();
                    }
                }
                // The vehicle's word on an upload (`mirror::upload`).
                r @ (Record::Received { .. } | Record::Verdict { .. }) => self.uploads.push_back(r),
                // Uplink records heard back (a shared link): not ours.
                Record::Upload { .. }
                | Record::Piece { .. }
                | Record::Resend { .. }
                | Record::SendSnapshot { .. }
                | Record::SendHeartbeat { .. }
                | Record::Answer { .. } => {}
            }
        }
        self.play_held();
        self.check_heartbeat();
        self.ask();
    }

    /// Lets ground time pass: requests retried, a gap too long reported,
    /// a silent downlink hailed.
    pub fn tick(&mut self, now: Micros) {
        self.now = self.now.max(now);
        self.ask();
        self.hail();
    }

    /// The downlink heard once and silent since `silent_after`: the
    /// vehicle's gateway stopped, the radio is down, or the autopilot
    /// rebooted and forgot the route to the mirror, which it learns again
    /// from any frame the mirror sends. So the mirror speaks: a heartbeat
    /// request (cheap; what is missing is asked for when the records come
    /// back), every `hello_every` while the silence lasts.
    fn hail(&mut self) {
        let Some(heard) = self.heard_at else { return };
        if self.now.saturating_sub(heard) < self.config.silent_after {
            return;
        }
        if self
            .hailed_at
            .is_some_and(|t| self.now.saturating_sub(t) < self.config.hello_every)
        {
            return;
        }
        self.hailed_at = Some(self.now);
        self.counts.heartbeats_asked += 1;
        tracing::debug!(
            now = self.now,
            "the downlink is silent: hailing the vehicle"
        );
        self.uplink
            .push_back(Uplink(record::packet(&[Record::SendHeartbeat { at: 0 }])));
    }

    /// An event the ground's own elaboration produced: it advances the
    /// provisional replica while a gap is open (never the exact one).
    pub fn ground_event(&mut self, now: Micros, event: &Event) {
        self.now = self.now.max(now);
        if self.gap_since.is_none() {
            return;
        }
        let Some(offset) = self.offset else { return };
        let vehicle = (now as i128 + offset).max(0) as Micros;
        if self.provisional.is_none() {
            self.provisional = self.player.clone();
        }
        if let Some(p) = &mut self.provisional {
            p.handle(event, vehicle);
            let _ = p.effects().count();
        }
    }

    fn heartbeat(&mut self, h: Heartbeat) {
        if self.session.is_none() {
            // The first heartbeat heard: records heard before it are kept.
            self.session = Some(h.session);
            if h.next == 0 || self.held.contains_key(&0) {
                self.start();
            }
        } else if self.session != Some(h.session) {
            self.new_session(h.session, h.next == 0);
        }
        let offset = h.time as i128 - self.now as i128;
        let now = self.now;
        self.offsets
            .retain(|(at, _)| now.saturating_sub(*at) < OFFSET_SPAN);
        self.offsets.push_back((now, offset));
        let mut recent: Vec<i128> = self.offsets.iter().map(|(_, o)| *o).collect();
        recent.sort_unstable();
        self.offset = recent.get(recent.len() / 2).copied();
        self.known = self.known.max(h.next);
        self.oldest = h.oldest;
        // The records that came before this heartbeat, in its packet
        // (the session's first records, held until the session was
        // known), are played before it is judged: none is missing.
        self.play_held();
        if self.player.is_some() && self.next < h.next {
            self.open_gap();
        }
        if self.gap_since.is_some() {
            self.gap_heartbeats += 1;
        }
        self.heartbeat = Some(h);
    }

    /// Another run of the onboard gateway: start over. When it has sent no
    /// record yet, its player is at its start, which the replica can build.
    fn new_session(&mut self, session: u32, from_start: bool) {
        self.session = Some(session);
        // Another run: another clock.
        self.offsets.clear();
        self.boots.clear();
        self.held.clear();
        self.fragments.clear();
        self.chunks = None;
        self.heartbeat = None;
        self.provisional = None;
        self.next = 0;
        self.known = 0;
        self.step = 0;
        self.agreed = None;
        self.diverged = false;
        self.player = None;
        if from_start {
            self.start();
        } else if self.gap_since.is_none() {
            self.gap_since = Some(self.now);
        }
    }

    fn start(&mut self) {
        let mut p = call::start(self.project.clone(), 0);
        let effects: Vec<Effect> = p.effects().collect();
        self.player = Some(p);
        self.keep(0, || Call::Restart, &effects);
        self.gap_heartbeats = 0;
        if let Some(since) = self.gap_since.take() {
            self.reports.push_back(Report::Resynced {
                step: 0,
                how: Repair::Start,
                after: self.now.saturating_sub(since),
            });
        }
    }

    fn record(&mut self, s: StepRecord) {
        self.counts.records += 1;
        if s.number < self.next && self.player.is_some() {
            self.counts.duplicates += 1;
            return;
        }
        self.known = self.known.max(s.number + 1);
        if self.held.len() < self.config.hold_max || s.number < self.next + 1 {
            self.held.insert(s.number, s);
        }
        // Record 0 follows the player's start: the replica can build it.
        if self.player.is_none() && self.session.is_some() && self.held.contains_key(&0) {
            self.next = 0;
            self.start();
        }
    }

    fn fragment(&mut self, f: Fragment) {
        if f.number < self.next && self.player.is_some() {
            self.counts.duplicates += 1;
            return;
        }
        let slots = self
            .fragments
            .entry(f.number)
            .or_insert_with(|| vec![None; usize::from(f.count)]);
        if slots.len() != usize::from(f.count) {
            *slots = vec![None; usize::from(f.count)];
        }
        slots[usize::from(f.index)] = Some(f.data);
        if slots.iter().all(Option::is_some) {
            let bytes: Vec<u8> = slots.iter().flatten().flatten().copied().collect();
            self.fragments.remove(&f.number);
            let mut r = nets::binary::Reader::new(&bytes);
            match record::decode_step(&mut r).and_then(|s| r.finish().map(|()| s)) {
                Ok(s) if s.number == f.number => self.record(s),
                _ => self.counts.refused += 1,
            }
        }
    }

    fn chunk(&mut self, c: Chunk) {
        if Some(c.session) != self.session {
            return;
        }
        let fresh = !matches!(&self.chunks, Some((s, n, slots)) if *s == c.session && *n == c.snapshot && slots.len() == usize::from(c.count));
        if fresh {
            self.chunks = Some((c.session, c.snapshot, vec![None; usize::from(c.count)]));
        }
        let Some((_, _, slots)) = &mut self.chunks else {
            return;
        };
        slots[usize::from(c.index)] = Some(c.data);
        if !slots.iter().all(Option::is_some) {
            return;
        }
        let bytes: Vec<u8> = slots.iter().flatten().flatten().copied().collect();
        self.chunks = None;
        self.snapshot(&bytes, c.versioned);
    }

    fn snapshot(&mut self, bytes: &[u8], versioned: bool) {
        let restored = Snapshot::decode(bytes, versioned)
            .map_err(|e| e.to_string())
            .and_then(|s| {
                let state = snapshot::decode(&s.state).map_err(|e| e.to_string())?;
                if snapshot::digest(&state).0 != s.digest {
                    return Err("its digest does not match its state".into());
                }
                let project = match s.version {
                    None => self.project.clone(),
                    Some((number, digest)) => match self.version(&digest) {
                        Some(v) => v.project.clone(),
                        None => {
                            // Said once (`Report::UnknownVersion`).
                            self.lacks(number, digest);
                            return Err(String::new());
                        }
                    },
                };
                let player = Player::restore(project, state).map_err(|e| e.to_string())?;
                Ok((s, player))
            });
        let (s, player) = match restored {
            Ok(x) => x,
            Err(e) => {
                self.counts.snapshots_refused += 1;
                if !e.is_empty() {
                    tracing::warn!("a snapshot from the vehicle was refused: {e}");
                }
                return;
            }
        };
        let in_step = self.player.is_some() && self.gap_since.is_none() && !self.diverged;
        if in_step {
            // A periodic snapshot of a step the replica has played: a full
            // check of the state.
            let time = player.state().now;
            if s.next == self.next && s.step >= self.step {
                if let Some(p) = &mut self.player {
                    p.advance(time);
                    let effects: Vec<Effect> = p.effects().collect();
                    let same = p.digest().0 == s.digest;
                    self.keep(time, || Call::Advance, &effects);
                    self.timers(s.step, time, effects);
                    if same {
                        self.agree(s.step);
                    } else {
                        self.diverge(s.step, "the snapshot's state differs".into());
                        self.adopt(s, player);
                    }
                }
            }
            return;
        }
        if s.next < self.next && self.player.is_some() && !self.diverged {
            return;
        }
        self.adopt(s, player);
    }

    fn adopt(&mut self, s: Snapshot, mut player: Player) {
        let effects: Vec<Effect> = player.effects().collect();
        self.counts.snapshots_restored += 1;
        let time = player.state().now;
        self.player = Some(player);
        let state = &s.state;
        self.keep(time, || Call::Restore(state.clone()), &effects);
        self.next = s.next;
        self.step = s.step;
        self.agreed = Some(s.step);
        self.held = self.held.split_off(&s.next);
        self.diverged = false;
        self.provisional = None;
        let after = self.gap_since.map(|g| self.now.saturating_sub(g));
        self.gap_since = None;
        self.gap_heartbeats = 0;
        self.reports.push_back(Report::Resynced {
            step: s.step,
            how: Repair::Snapshot,
            after: after.unwrap_or(0),
        });
        self.play_held();
        self.check_heartbeat();
    }

    fn open_gap(&mut self) {
        if self.gap_since.is_none() {
            self.gap_since = Some(self.now);
            self.counts.gaps += 1;
            self.reports.push_back(Report::Gap {
                from: self.next,
                to: self.known,
                step: self.step,
            });
        }
    }

    /// Plays the held records that follow without a gap.
    fn play_held(&mut self) {
        if self.player.is_none() {
            return;
        }
        while let Some(s) = self.held.remove(&self.next) {
            self.play(s);
        }
        if let Some((&first, _)) = self.held.iter().next() {
            if first > self.next {
                self.open_gap();
            }
        }
        if self.held.is_empty() && self.next >= self.known {
            if let Some(since) = self.gap_since {
                if self.player.is_some() && !self.diverged {
                    self.gap_since = None;
                    self.gap_heartbeats = 0;
                    self.provisional = None;
                    self.reports.push_back(Report::Resynced {
                        step: self.step,
                        how: Repair::Retransmission,
                        after: self.now.saturating_sub(since),
                    });
                }
            }
        }
    }

    fn play(&mut self, s: StepRecord) {
        if self.player.is_none() {
            return;
        }
        let taken = s.inputs.iter().find_map(|i| match i {
            Input::Version { number, digest, .. } => Some((*number, *digest)),
            _ => None,
        });
        if let Some((number, digest)) = taken {
            if !self.take_over(s.step, s.time, number, digest) {
                // Inexact until it has the version: a snapshot of it will
                // resync it (`know`).
                self.next = s.number + 1;
                self.step = s.step;
                return;
            }
        }
        let Some(p) = &mut self.player else { return };
        let effects = call::play(p, s.before, &s.inputs, s.time);
        let same = p.digest().0[..8] == s.digest;
        let (before, inputs) = (s.before, &s.inputs);
        self.keep(
            s.time,
            || Call::Record {
                before,
                inputs: inputs.clone(),
            },
            &effects,
        );
        self.next = s.number + 1;
        self.step = s.step;
        self.reports.push_back(Report::Step {
            number: s.number,
            step: s.step,
            time: s.time,
            inputs: s.inputs,
            effects,
        });
        if same {
            self.agree(s.step);
        } else if !self.diverged {
            self.diverge(s.step, "the digest after the step differs".into());
        }
    }

    /// The vehicle's new version `number` takes over in the replica at
    /// `step`, if the replica has it: whether it did.
    fn take_over(&mut self, step: u64, time: Micros, number: u32, digest: [u8; 32]) -> bool {
        let Some(version) = self.version(&digest) else {
            self.lacks(number, digest);
            if !self.diverged {
                self.diverge(
                    step,
                    format!(
                        "the vehicle took over version {number}, which this mirror does not have"
                    ),
                );
            }
            return false;
        };
        let Some(p) = &mut self.player else {
            return false;
        };
        match call::take_over(p, &version) {
            Ok(player) => {
                *p = player;
                self.keep(time, || Call::Version(version.clone()), &[]);
                self.reports.push_back(Report::Version {
                    number,
                    version: version.clone(),
                    step,
                });
                true
            }
            Err(e) => {
                if !self.diverged {
                    self.diverge(step, e.to_string());
                }
                false
            }
        }
    }

    /// Compares the last heartbeat once every record before it is played.
    fn check_heartbeat(&mut self) {
        let Some(h) = &self.heartbeat else { return };
        let Some(p) = &mut self.player else { return };
        if self.next != h.next || self.diverged {
            return;
        }
        let h = self.heartbeat.take().expect("checked above");
        // A heartbeat older than what was played (reordered) says nothing.
        if h.step < self.step || h.time < p.state().now {
            return;
        }
        p.advance(h.time);
        let effects: Vec<Effect> = p.effects().collect();
        let same = p.digest().0[..16] == h.digest;
        self.keep(h.time, || Call::Advance, &effects);
        self.timers(h.step, h.time, effects);
        if same {
            self.agree(h.step);
        } else {
            self.diverge(h.step, "the heartbeat's digest differs".into());
        }
    }

    /// Time passed to a vehicle step with no record: what the timers did.
    fn timers(&mut self, step: u64, time: Micros, effects: Vec<Effect>) {
        self.step = step;
        if !effects.is_empty() {
            self.reports.push_back(Report::Timers {
                step,
                time,
                effects,
            });
        }
    }

    fn agree(&mut self, step: u64) {
        self.agreed = Some(step);
        self.counts.agreed += 1;
        self.reports.push_back(Report::Agreed { step });
    }

    fn diverge(&mut self, step: u64, reason: String) {
        self.diverged = true;
        self.counts.diverged += 1;
        if self.gap_since.is_none() {
            self.gap_since = Some(self.now);
        }
        self.reports.push_back(Report::Diverged {
            step,
            agreed: self.agreed,
            reason,
        });
        // Ask at once.
        self.asked_at = None;
    }

    /// Asks for what is missing: the records while the vehicle's ring
    /// holds them, else a snapshot; again after `retry_after`.
    fn ask(&mut self) {
        if self.gap_since.is_none() {
            return;
        }
        let session = self.session.unwrap_or(0);
        if self.player.is_some()
            && !self.diverged
            && self.gap_heartbeats >= self.config.give_up_after
        {
            self.diverge(self.step + 1, "records lost and not repaired".into());
        }
        let recent = |t: Micros, now: Micros, retry: Micros| now.saturating_sub(t) < retry;
        if self.player.is_some() && !self.diverged && self.next >= self.oldest {
            // Every missing record not asked for lately, in ranges.
            let (now, retry) = (self.now, self.config.retry_after);
            self.asked
                .retain(|n, t| *n >= self.next && recent(*t, now, retry));
            let mut requests = Vec::new();
            let mut total = 0;
            let mut n = self.next;
            while n < self.known && total < self.config.resend_max && requests.len() < 16 {
                if self.held.contains_key(&n) || self.asked.contains_key(&n) {
                    n += 1;
                    continue;
                }
                let from = n;
                while n < self.known
                    && !self.held.contains_key(&n)
                    && !self.asked.contains_key(&n)
                    && total < self.config.resend_max
                {
                    self.asked.insert(n, now);
                    n += 1;
                    total += 1;
                }
                requests.push(Record::Resend {
                    from,
                    count: n - from,
                });
            }
            if !requests.is_empty() {
                self.counts.resends_asked += 1;
                self.uplink.push_back(Uplink(record::packet(&requests)));
            }
            return;
        }
        if self
            .asked_at
            .is_some_and(|t| recent(t, self.now, self.config.retry_after))
            || self.missing.is_some()
        {
            // (A snapshot of a version this replica lacks could not be
            // restored: it waits for `know`.)
            return;
        }
        if self.session.is_none()
            && self
                .asked_at
                .is_some_and(|t| recent(t, self.now, self.config.hello_every))
        {
            // Nothing heard yet: the request is also how the autopilot
            // learns the way to this mirror (docs/mirror.md, "Addressing"),
            // so it goes up now and then until the vehicle answers.
            return;
        }
        self.counts.snapshots_asked += 1;
        tracing::debug!(session, now = self.now, "asking for a snapshot");
        self.asked_at = Some(self.now);
        self.uplink
            .push_back(Uplink(record::packet(&[Record::SendSnapshot { session }])));
    }
}
