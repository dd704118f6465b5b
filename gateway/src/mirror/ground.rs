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

use elaboration::{Elaborated, Frame};
use nets::{Event, Micros};

use super::check::{Check, Counts, Disagreement, Window};
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
    elaborated: Vec<Elaborated>,
    /// Ground events elaborated before the vehicle's time base was known
    /// (before the downlink's first heartbeat): judged once it is.
    untimed: VecDeque<(Micros, Event)>,
    /// Events the ground elaborated.
    pub events: u64,
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
        Ground {
            lanes: Lanes::new(lanes),
            watches,
            checks,
            team,
            foreign: BTreeMap::new(),
            unsaid: VecDeque::new(),
            elaborated: Vec::new(),
            untimed: VecDeque::new(),
            events: 0,
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
        while let Some(t) = self.untimed.front().and_then(|(at, _)| to_vehicle(*at)) {
            let Some((_, event)) = self.untimed.pop_front() else {
                break;
            };
            if t > 0 {
                let i = self.lane_of_event(&event);
                self.checks[i].ground(t, &event);
            }
        }
        let mut elaborated = std::mem::take(&mut self.elaborated);
        for e in elaborated.drain(..) {
            self.events += 1;
            seen(&e.event);
            match to_vehicle(e.time_us) {
                Some(t) => {
                    let i = self.lane_of_event(&e.event);
                    self.checks[i].ground(t, &e.event);
                }
                None => {
                    if self.untimed.len() == UNTIMED {
                        self.untimed.pop_front();
                    }
                    self.untimed.push_back((e.time_us, e.event));
                }
            }
        }
        self.elaborated = elaborated;
    }

    /// An event the vehicle published (elaborated on board), at its time.
    pub fn vehicle_event(&mut self, time: Micros, event: &Event) {
        let i = self.lane_of_event(event);
        self.checks[i].vehicle(time, event);
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
    pub fn advance(
        &mut self,
        vehicle_known: Option<Micros>,
        to_vehicle: impl Fn(Micros) -> Option<Micros>,
    ) {
        for (c, w) in self.checks.iter_mut().zip(&self.watches) {
            // Converted once: the first time it is known.
            if !c.knows_ground_start() {
                if let Some(t) = w.first_heard.and_then(&to_vehicle) {
                    c.ground_from(t);
                }
            }
            c.advance(vehicle_known, w.last_autopilot.and_then(&to_vehicle));
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
