//! The ground's own view of the vehicles it mirrors, sans-IO: the ground's
//! telemetry elaborated in the team's lanes exactly as `petrel run` does on
//! board (`supervisor::Lanes`, built by `team::lanes`: one per vehicle,
//! frames routed by system id, events qualified `EVENT@VEHICLE`), each
//! vehicle's frames counted and watched for losses (a gap in its sequence
//! numbers), its autopilot's heartbeat noted, and one independent check
//! (`check.rs`) per vehicle, so that a vehicle's events are judged against
//! that vehicle's, with that vehicle's losses and what the ground has heard
//! of it.
//!
//! Without a team there is one lane, unqualified, and "the vehicle" is the
//! system of the first autopilot heartbeat heard, as before teams. In a
//! team, a frame of a system that is no vehicle of the team (a ground
//! station, another aircraft) is not a vehicle's: not counted, not watched;
//! it is said once ([`Ground::poll_foreign`]) and, as on board, handed to
//! every lane, whose rules say whom they watch.

use std::collections::{BTreeMap, VecDeque};

use elaboration::{Elaborated, Frame, Needs};
use nets::{Event, Micros};

use super::check::{Check, Counts, Disagreement, Side, Window};
use crate::supervisor::{Lane, Lanes};

/// HEARTBEAT's message id, and its `autopilot` field's offset in the
/// payload (after `custom_mode` u32 and `type` u8).
const HEARTBEAT: u32 = 0;
const AUTOPILOT_AT: usize = 5;
/// `MAV_AUTOPILOT_INVALID`: a ground station's or a companion's heartbeat.
const AUTOPILOT_INVALID: u8 = 8;

/// What the ground knows of one vehicle (one lane).
#[derive(Debug, Clone, Default)]
pub struct Watch {
    /// The vehicle's name (`None` without a team).
    pub name: Option<String>,
    /// Its system: its lane's in a team; without one, the first autopilot
    /// heartbeat's.
    pub system: Option<u8>,
    /// Its autopilot's component (1 unless the team says otherwise).
    pub autopilot: u8,
    /// Frames of its system the ground received.
    pub frames: u64,
    /// Its autopilot's heartbeat was heard.
    pub heard: bool,
    /// When it was first heard (ground time): where the ground's view of
    /// the vehicle starts.
    first_heard: Option<Micros>,
    /// The autopilot's last sequence number and when it came (ground
    /// time), and the system's last (its components but the onboard
    /// gateway's).
    autopilot_seq: Option<(u8, Micros)>,
    system_seq: Option<u8>,
    /// The autopilot's frames since its first heard, lost ones included
    /// (by its numbers): with the time since, its period on this link.
    autopilot_sent: u64,
    /// The last autopilot frame heard (ground time): how far the ground's
    /// view of this vehicle reaches.
    last_autopilot: Option<Micros>,
    /// The autopilot's clock as far as the ground has read it: its last
    /// `time_boot_ms` (µs).
    last_boot: Option<Micros>,
    /// The messages heard from the vehicle's system (not its onboard
    /// gateway's), by component and id: first and last heard (ground
    /// time), how many. By component: the camera's HEARTBEAT, a second
    /// apart, must not hide a silence of the autopilot's (at 30 % loss,
    /// five of the autopilot's lost in a row and its `armed` heard 5 s
    /// late, judged as if on time: a false disagreement in CI).
    receiving: BTreeMap<(u8, u32), Stream>,
    /// The last frame's message, when it came after a silence of its
    /// stream longer than the check's window beyond its period (its
    /// earlier frames lost): what it says may have started that much
    /// earlier, so an event it makes has no onset the check can judge.
    late: Option<u32>,
}

/// A message not heard from the vehicle for this long, or three of its
/// usual periods if longer, is no longer received (a ground station's
/// slowest streams come every 2 s).
pub const QUIET: Micros = 5_000_000;

/// A sample at least this old (and two of its stream's periods) is stale:
/// a state the ground reads from it beside fresh ones may be one the
/// autopilot never was in.
pub const STALE: Micros = 1_000_000;

/// A message's stream from one component: first and last heard (ground
/// time), how many.
type Stream = (Micros, Micros, u64);

impl Watch {
    /// The stream of message `id` the rules read: the autopilot's, else
    /// the first component's heard sending it.
    fn stream(&self, id: u32) -> Option<&Stream> {
        self.receiving.get(&(self.autopilot, id)).or_else(|| {
            self.receiving
                .iter()
                .find(|((_, i), _)| *i == id)
                .map(|(_, s)| s)
        })
    }

    /// Whether the ground was receiving message `id` at ground time `now`:
    /// heard within [`QUIET`] or three of its periods.
    fn receiving(&self, id: u32, now: Micros) -> bool {
        self.stream(id).is_some_and(|&(first, last, n)| {
            let period = last.saturating_sub(first) / n.saturating_sub(1).max(1);
            last.saturating_add(QUIET.max(3 * period)) >= now
        })
    }

    /// Whether the ground's last sample of message `id` is stale at `now`
    /// for a condition that held since `onset` (`now` for one without a
    /// duration): older than two of its periods and a second (its last
    /// frames lost, or its stream slower here than on board), or from
    /// before the onset and overdue (no sample of it the whole time the
    /// condition held, though one was due: the condition rests on a
    /// sample from before what started it).
    pub(super) fn stale(&self, id: u32, now: Micros, onset: Micros) -> bool {
        self.stream(id).is_some_and(|&(first, last, n)| {
            let period = last.saturating_sub(first) / n.saturating_sub(1).max(1);
            let age = now.saturating_sub(last);
            n >= 2
                && (age > (2 * period).max(STALE) || (last < onset && onset < now && age > period))
        })
    }

    /// Whether the ground can observe a rule with `needs` at `now`: it
    /// receives every message whose fields the rule reads, and has heard
    /// every one whose age it reads.
    fn runs(&self, needs: &Needs, now: Micros) -> bool {
        needs.fields.iter().all(|id| self.receiving(*id, now))
            && needs.ages.iter().all(|id| self.stream(*id).is_some())
    }
}

/// The ground's view: lanes, watches, checks.
pub struct Ground {
    lanes: Lanes,
    watches: Vec<Watch>,
    /// One check per vehicle, in team order.
    pub(crate) checks: Vec<Check>,
    team: bool,
    /// Systems heard that are no vehicle of the team, with their frames.
    foreign: BTreeMap<u8, u64>,
    /// Those not said yet.
    unsaid: VecDeque<u8>,
    pub(super) elaborated: Vec<Elaborated>,
    /// Ground events elaborated before the vehicle's time base was known
    /// (before the downlink's first heartbeat): judged once it is, with
    /// their autopilot time and whether the ground could observe them.
    untimed: VecDeque<(Micros, Option<Micros>, bool, Event)>,
    /// Each lane's events and what each of their rules depends on
    /// (`Profile::event_needs`), by unqualified name.
    needs: Vec<Vec<(String, Vec<Needs>)>>,
    /// Each lane's rules, by index in its profile: what each of the
    /// events it produces depends on (`Profile::rules_needs`).
    rules: Vec<Vec<Vec<(String, Needs)>>>,
    /// Events the ground elaborated.
    pub events: u64,
    /// The check's window.
    window: Window,
}

/// Ground events kept waiting for the time base, at most.
const UNTIMED: usize = 256;

impl Ground {
    /// The ground's view of `lanes` (`team::lanes`), each vehicle checked
    /// with `window`.
    pub fn new(lanes: Vec<Lane>, window: Window) -> Ground {
        let team = lanes.iter().any(|l| l.vehicle.is_some());
        let watches = lanes
            .iter()
            .map(|l| Watch {
                name: l.vehicle.clone(),
                system: if team { l.config.sysid } else { None },
                autopilot: l.config.compid.unwrap_or(1),
                ..Watch::default()
            })
            .collect::<Vec<_>>();
        // Each vehicle's events elaborated only from frames addressed to
        // one link (the acknowledgements of the onboard gateway's own
        // commands): never compared.
        let checks = lanes
            .iter()
            .map(|l| Check::new(window).with_addressed(l.profile.addressed_events()))
            .collect();
        let rules: Vec<Vec<Vec<(String, Needs)>>> = lanes
            .iter()
            .map(|l| {
                l.profile
                    .rules_needs()
                    .into_iter()
                    .map(|events| {
                        events
                            .into_iter()
                            .map(|(name, needs)| (name.to_owned(), needs))
                            .collect()
                    })
                    .collect()
            })
            .collect();
        let needs = lanes
            .iter()
            .map(|l| {
                l.profile
                    .event_needs()
                    .into_iter()
                    .map(|(name, needs)| (name.to_owned(), needs))
                    .collect()
            })
            .collect();
        Ground {
            lanes: Lanes::new(lanes),
            watches,
            checks,
            team,
            foreign: BTreeMap::new(),
            unsaid: VecDeque::new(),
            elaborated: Vec::new(),
            untimed: VecDeque::new(),
            needs,
            rules,
            events: 0,
            window,
        }
    }

    /// Whether the project is a team's.
    pub fn team(&self) -> bool {
        self.team
    }

    /// The vehicles, in team order (one without a team).
    pub fn watches(&self) -> &[Watch] {
        &self.watches
    }

    /// Each vehicle's check counts, in team order.
    pub fn counts(&self) -> impl Iterator<Item = &Counts> {
        self.checks.iter().map(|c| &c.counts)
    }

    /// The checks' counts summed over the team (the longest delays the
    /// longest of any vehicle's).
    pub fn total(&self) -> Counts {
        let mut t = Counts::default();
        for c in self.counts() {
            t.matched += c.matched;
            t.ground_only += c.ground_only;
            t.vehicle_only += c.vehicle_only;
            t.skipped += c.skipped;
            t.addressed += c.addressed;
            t.unjudged += c.unjudged;
            t.unobservable += c.unobservable;
            t.vehicle_late_max = t.vehicle_late_max.max(c.vehicle_late_max);
            t.ground_late_max = t.ground_late_max.max(c.ground_late_max);
        }
        t
    }

    /// Systems heard that are no vehicle of the team, with their frames.
    pub fn foreign(&self) -> &BTreeMap<u8, u64> {
        &self.foreign
    }

    /// A system newly heard that is no vehicle of the team (said once).
    pub fn poll_foreign(&mut self) -> Option<u8> {
        self.unsaid.pop_front()
    }

    /// Whose frame this is: the lane of a team vehicle, or (without a
    /// team) the vehicle once its autopilot was heard.
    fn whose(&mut self, frame: &Frame) -> Option<usize> {
        let (system, component) = (frame.system_id(), frame.component_id());
        if self.team {
            return self.lanes.lane_of(system, component);
        }
        let w = &mut self.watches[0];
        if w.system.is_none() && autopilot_heartbeat(frame) {
            w.system = Some(system);
        }
        (w.system == Some(system)).then_some(0)
    }

    /// A frame the ground received at `now` (ground time): counted for its
    /// vehicle, watched for losses (`to_vehicle` turns ground time into the
    /// vehicle's, when known). Every frame, downlink TUNNELs included.
    pub fn heard(
        &mut self,
        now: Micros,
        frame: &Frame,
        to_vehicle: impl Fn(Micros) -> Option<Micros>,
    ) {
        let Some(i) = self.whose(frame) else {
            if self.team {
                let n = self.foreign.entry(frame.system_id()).or_default();
                if *n == 0 {
                    self.unsaid.push_back(frame.system_id());
                }
                *n += 1;
            }
            return;
        };
        let w = &mut self.watches[i];
        w.frames += 1;
        let component = frame.component_id();
        w.late = None;
        if component != crate::mirror::COMPANION {
            let r = w
                .receiving
                .entry((component, frame.message_id()))
                .or_insert((now, now, 0));
            let period = r.1.saturating_sub(r.0) / r.2.saturating_sub(1).max(1);
            if r.2 >= 2 && now.saturating_sub(r.1).saturating_sub(period) > self.window.ground_late
            {
                w.late = Some(frame.message_id());
            }
            r.1 = now;
            r.2 += 1;
        }
        if component == w.autopilot {
            if let Some(ms) = frame.time_boot_ms() {
                w.last_boot = Some(Micros::from(ms) * 1000);
            }
        }
        if component == w.autopilot && autopilot_heartbeat(frame) {
            w.heard = true;
            w.first_heard.get_or_insert(now);
        }
        // The onboard gateway (vehicle, 191) numbers everything it sends
        // with one counter, and most of it never reaches the ground: its
        // commands, mission items and parameter reads go to the autopilot,
        // which keeps them. Its numbers say nothing of the radio (they
        // left a gap at every command: the check was blind most of the
        // flight). The downlink's own losses are the replica's, by record
        // number: the check judges the vehicle's side only once the
        // replica holds every record.
        if component == crate::mirror::COMPANION {
            return;
        }
        // The frames the radio lost: a gap in the autopilot's sequence
        // numbers, which it sends whole to the ground's link (its own
        // stream on that port: what it addresses to another link is
        // numbered on that link). And a gap in the system's too, for
        // vehicles whose components share one counter (the simulator)
        // rather than one each (ArduPilot and its camera). Another
        // component's own numbers are not read: a camera answering the
        // companion alone would leave gaps the radio did not.
        let seq = frame.sequence();
        let system_gap = w.system_seq.is_some_and(|s| seq != s.wrapping_add(1));
        w.system_seq = Some(seq);
        if component != w.autopilot {
            return;
        }
        if let Some((last, at)) = w.autopilot_seq {
            let missing = seq.wrapping_sub(last).wrapping_sub(1);
            w.autopilot_sent += u64::from(missing) + 1;
            if missing > 0 && system_gap {
                if let (Some(a), Some(b)) = (to_vehicle(at), to_vehicle(now)) {
                    // How long the ground's view went without the
                    // autopilot: the frames missing at its period here,
                    // not the time between the frames heard, which batches
                    // of frames (a serial port read, a simulator at 10x)
                    // stretch to a second around one lost frame. A silence
                    // longer than the numbers wrap (256 frames) is the
                    // time between.
                    let period = w
                        .first_heard
                        .map_or(0, |first| now.saturating_sub(first))
                        .checked_div(w.autopilot_sent)
                        .unwrap_or(0);
                    let span = b.saturating_sub(a);
                    let hole = if span > 256 * period {
                        span
                    } else {
                        u64::from(missing) * period
                    };
                    self.checks[i].lost(a, b, hole);
                }
            }
        }
        w.autopilot_seq = Some((seq, now));
        w.last_autopilot = Some(now);
    }

    /// A telemetry frame (not a downlink TUNNEL) to elaborate, at `now`.
    pub fn elaborate(&mut self, now: Micros, frame: &Frame) {
        self.lanes.frame(now, frame, &mut self.elaborated);
    }

    /// Time passes with nothing received.
    pub fn tick(&mut self, now: Micros) {
        self.lanes.tick(now, &mut self.elaborated);
    }

    /// The events elaborated since the last call, each handed to `seen`
    /// and to its vehicle's check (at its vehicle time, when known).
    pub fn drain(
        &mut self,
        to_vehicle: impl Fn(Micros) -> Option<Micros>,
        mut seen: impl FnMut(&Event),
    ) {
        // Those that came before the time base, once it is known; those
        // from before the vehicle's player started (vehicle time 0, where
        // `to_vehicle` stops) the vehicle never elaborated: not judged.
        while let Some(t) = self.untimed.front().and_then(|(at, ..)| to_vehicle(*at)) {
            let Some((_, boot, observable, event)) = self.untimed.pop_front() else {
                break;
            };
            if t > 0 {
                self.judge_later(Side::Ground, t, boot, observable, &event);
            }
        }
        let mut elaborated = std::mem::take(&mut self.elaborated);
        for e in elaborated.drain(..) {
            self.events += 1;
            seen(&e.event);
            let observable =
                self.observable(e.time_us, &e.event) && !self.late(&e.event) && !self.stale(&e);
            match to_vehicle(e.time_us) {
                Some(t) => self.judge_later(Side::Ground, t, e.boot_us, observable, &e.event),
                None => {
                    if self.untimed.len() == UNTIMED {
                        self.untimed.pop_front();
                    }
                    self.untimed
                        .push_back((e.time_us, e.boot_us, observable, e.event));
                }
            }
        }
        self.elaborated = elaborated;
        for w in &mut self.watches {
            w.late = None;
        }
    }

    /// Whether `event`, elaborated from the last frame, may read a message
    /// that came after its stream went silent longer than the window (its
    /// frames lost on the radio): the ground saw it late by an unknown
    /// amount (at 30 % loss, `armed` 5 s after the vehicle), so it is
    /// judged as one the ground cannot observe — matched if the vehicle
    /// saw it, never reported if not.
    fn late(&self, event: &Event) -> bool {
        let i = self.lane_of_event(event);
        let Some(id) = self.watches[i].late else {
            return false;
        };
        let name = nets::model::split_vehicle(&event.name).0;
        self.needs[i]
            .iter()
            .find(|(n, _)| n == name)
            .is_some_and(|(_, rules)| rules.iter().any(|r| r.fields.contains(&id)))
    }

    /// Whether the rule that produced `e` read a stale sample when it
    /// fired (`Watch::stale`, from the condition's onset for a rule with a
    /// duration): the ground's state was a mix of old and new samples
    /// (ArduPlane's ESC telemetry from before a throttle step, beside the
    /// throttle after it, held 2 s while the ESC frames were lost: an
    /// `engine_failure` the vehicle never had), judged as one the ground
    /// cannot observe. Without the rule (an event rebuilt from a record),
    /// whether every rule producing its event read one.
    pub(super) fn stale(&self, e: &Elaborated) -> bool {
        let now = e.time_us;
        let i = self.lane_of_event(&e.event);
        let name = nets::model::split_vehicle(&e.event.name).0;
        let w = &self.watches[i];
        let read_stale = |r: &Needs| {
            let onset = now.saturating_sub(r.hold_us);
            r.fields.iter().any(|id| w.stale(*id, now, onset))
        };
        let fired = e
            .rule
            .and_then(|r| self.rules[i].get(r))
            .and_then(|events| events.iter().find(|(n, _)| n == name));
        match fired {
            Some((_, needs)) => read_stale(needs),
            None => self.needs[i]
                .iter()
                .find(|(n, _)| n == name)
                .is_some_and(|(_, rules)| !rules.is_empty() && rules.iter().all(read_stale)),
        }
    }

    /// An event the vehicle published (elaborated on board), at its time
    /// and its autopilot's (`boot`), heard at ground time `now`.
    pub fn vehicle_event(
        &mut self,
        now: Micros,
        time: Micros,
        boot: Option<Micros>,
        event: &Event,
    ) {
        let observable = self.observable(now, event);
        self.judge_later(Side::Vehicle, time, boot, observable, event);
    }

    fn judge_later(
        &mut self,
        side: Side,
        time: Micros,
        boot: Option<Micros>,
        observable: bool,
        event: &Event,
    ) {
        let i = self.lane_of_event(event);
        let c = &mut self.checks[i];
        match (side, observable) {
            (Side::Ground, true) => c.ground(time, boot, event),
            (Side::Vehicle, true) => c.vehicle(time, boot, event),
            (side, false) => c.unobservable(side, time, boot, event),
        }
    }

    /// Whether the ground can observe `event` at ground time `now`: some
    /// rule producing it depends only on messages the ground is receiving
    /// from its vehicle (`Watch::runs`). An event no rule produces (none
    /// of the profile's) is observable.
    fn observable(&self, now: Micros, event: &Event) -> bool {
        let i = self.lane_of_event(event);
        let name = nets::model::split_vehicle(&event.name).0;
        match self.needs[i].iter().find(|(n, _)| n == name) {
            Some((_, rules)) => rules.iter().any(|r| self.watches[i].runs(r, now)),
            None => true,
        }
    }

    /// The check of an event's vehicle (`EVENT@VEHICLE`); the first
    /// without a team, or for an event of no vehicle.
    fn lane_of_event(&self, event: &Event) -> usize {
        match nets::model::split_vehicle(&event.name).1 {
            Some(v) if self.team => (0..self.lanes.count())
                .find(|&i| self.lanes.vehicle(i) == Some(v))
                .unwrap_or(0),
            _ => 0,
        }
    }

    /// The replica was restored from a snapshot at vehicle time `time`.
    pub fn unknown_before(&mut self, time: Micros) {
        for c in &mut self.checks {
            c.unknown_before(time);
        }
    }

    /// Judges what can be judged: `vehicle_known` is the vehicle time
    /// through which the replica holds every record; each vehicle's
    /// ground view reaches its last autopilot frame (not the clock: during
    /// a radio outage it does not advance).
    /// `vehicle_boot` gives, by lane, how far the onboard elaboration had
    /// read its autopilot's clock by `vehicle_known`
    /// (`Replica::exact_boot`); the ground's is its last autopilot frame's.
    pub fn advance(
        &mut self,
        vehicle_known: Option<Micros>,
        vehicle_boot: impl Fn(usize) -> Option<Micros>,
        to_vehicle: impl Fn(Micros) -> Option<Micros>,
    ) {
        for (i, (c, w)) in self.checks.iter_mut().zip(&self.watches).enumerate() {
            // Converted once: the first time it is known.
            if !c.knows_ground_start() {
                if let Some(t) = w.first_heard.and_then(&to_vehicle) {
                    c.ground_from(t);
                }
            }
            let elaborator = self.lanes.elaborator(i);
            c.advance_holding(
                vehicle_known,
                vehicle_boot(i),
                w.last_autopilot.and_then(&to_vehicle),
                w.last_boot,
                |name| elaborator.still_holds(nets::model::split_vehicle(name).0),
            );
        }
    }

    /// Each vehicle's ground view, followed and blind: the vehicle time
    /// from its autopilot's first frame heard to its last, and how much of
    /// it a ground event would not have been judged for a hole in the
    /// ground's view (`Check::blind`), in team order.
    pub fn blind(&self, to_vehicle: impl Fn(Micros) -> Option<Micros>) -> Vec<(Micros, Micros)> {
        self.checks
            .iter()
            .zip(&self.watches)
            .map(|(c, w)| {
                let from = w.first_heard.and_then(&to_vehicle);
                let to = w.last_autopilot.and_then(&to_vehicle);
                match (from, to) {
                    (Some(from), Some(to)) if to > from => (to - from, c.blind(from, to)),
                    _ => (0, 0),
                }
            })
            .collect()
    }

    /// A disagreement, with its vehicle's name (`None` without a team).
    pub fn poll_disagreement(&mut self) -> Option<(Option<&str>, Disagreement)> {
        let i = (0..self.checks.len()).find(|&i| self.checks[i].has_report())?;
        let d = self.checks[i].poll()?;
        Some((self.watches[i].name.as_deref(), d))
    }

    /// A vehicle time a heartbeat is wanted at (`Check::poll_heartbeat_wanted`),
    /// any vehicle's; `now` is the vehicle's time.
    pub fn poll_heartbeat_wanted(&mut self, now: Option<Micros>) -> Option<Micros> {
        self.checks
            .iter_mut()
            .find_map(|c| c.poll_heartbeat_wanted(now))
    }

    /// Who to send requests to before the onboard gateway's first record:
    /// its companion on the vehicle it runs beside — in a team the first
    /// vehicle (the onboard gateway speaks as the first vehicle's
    /// companion), once heard; without one, the vehicle heard.
    pub fn companion(&self) -> Option<(u8, u8)> {
        let w = self.watches.first()?;
        let system = w.system.filter(|_| w.heard || !self.team)?;
        Some((system, crate::mirror::COMPANION))
    }

    /// A vehicle heard whose downlink is awaited: its system.
    pub fn some_heard(&self) -> Option<u8> {
        self.watches
            .iter()
            .find(|w| w.heard || (!self.team && w.system.is_some()))
            .and_then(|w| w.system)
    }
}

/// Whether `frame` is an autopilot's HEARTBEAT (not a ground station's or
/// a companion's, whose `autopilot` is `MAV_AUTOPILOT_INVALID`).
fn autopilot_heartbeat(frame: &Frame) -> bool {
    frame.message_id() == HEARTBEAT
        // MAVLink 2 cuts trailing zeros: a missing byte is 0, GENERIC.
        && frame.payload().get(AUTOPILOT_AT).copied().unwrap_or(0) != AUTOPILOT_INVALID
}

// Its tests are `mirror::ground_tests` (ground/tests.rs), declared in
// mirror/mod.rs: benches/mirror_ground.rs compiles this file alone.
