//! The independent check, sans-IO: the events the ground elaborates from
//! its own telemetry (with the same profile) matched against the events the
//! vehicle published, by name, within a window of vehicle time. One seen on
//! one side only is a `mirror_disagreement`, with what each side saw.
//!
//! Link events (the communication category) are never compared: the
//! ground's `link_lost` is not the vehicle's. A side is judged only once its
//! view is complete past the window: the vehicle's once the replica holds
//! every record through that time (a record the radio lost is not a missing
//! event), the ground's once its elaboration has seen that time.
//!
//! The window is not the same both ways (docs/mirror.md, "The independent
//! check"): both sides run the same rules with the same debounces on the
//! same autopilot's messages, but the vehicle receives every message its
//! rules read at 4 Hz (the gateway asks them so) while the ground gets the
//! ground station's rates, 1 Hz or less for some. So the ground may see an
//! event up to a ground period after the vehicle ([`Window::ground_late`]),
//! and the vehicle after the ground only by a vehicle period, a tick of each
//! side's timers and the jitter of the radio ([`Window::vehicle_late`]).
//! The first bounds how soon "the ground saw none" is said, the second how
//! soon "the vehicle reported none": the mirror asks the vehicle for a
//! heartbeat at that time ([`Check::poll_heartbeat_wanted`]), whose
//! arrival proves the vehicle's records complete through it.
//!
//! Nothing is judged while the two views settle ([`SETTLE`]): rules
//! compare a reading with the one before (`changed`, `prev`), and the two
//! sides start reading at different moments, through different ports. The
//! ground may hear ArduPlane's INITIALISING heartbeat and then MANUAL (a
//! `mode_changed`) where the vehicle's first heartbeat was already MANUAL
//! (its first reading: no event). Both saw the truth; neither is a
//! disagreement an operator should be shown at boot.

use std::collections::VecDeque;

use nets::{Category, Event, Micros, Params};

/// How far apart in vehicle time the two sides may see one event.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Window {
    /// The vehicle may see an event this long after the ground: its
    /// telemetry period (4 Hz, 0.25 s), one tick of its timers (`for`,
    /// `age()`: 0.1 s), and the jitter of the radio and of the ground's
    /// time base (the rest).
    pub vehicle_late: Micros,
    /// The ground may see an event this long after the vehicle: a ground
    /// station's telemetry period (1 Hz, or 0.5 Hz for some groups) and the
    /// same tick and jitter.
    pub ground_late: Micros,
}

/// The window for every rule (docs/mirror.md, "The independent check").
pub const WINDOW: Window = Window {
    vehicle_late: 1_000_000,
    ground_late: 2_000_000,
};

/// A ground event within this after a [`HOLE`] in the ground's view may
/// come from the hole itself (rules on a component's silence wait up to
/// 15 s, the flight-test example's camera, and a debounce started before
/// may end after it): it is not judged.
pub const SILENCE: Micros = 20_000_000;

/// A loss leaves a hole in the ground's view when the autopilot's frames
/// it lost would have taken this long to send (as many frames as its
/// numbers skipped, at its rate on the ground's link): long enough for a
/// silence or a debounce the vehicle did not see. A frame lost here and there (the radio's usual
/// loss: the autopilot sends tens of frames a second) leaves no hole: the
/// ground's rules read the next frame a period later, which the window
/// covers. Shorter than any silence a compared rule waits for (5 s at
/// least in the ArduPilot and PX4 profiles).
pub const HOLE: Micros = 1_000_000;

/// Events of either side within this after the later of the two views'
/// starts (the vehicle's player, or the snapshot the replica was restored
/// from; the ground's first autopilot heartbeat) are not judged: by then
/// each side has read every stream its rules compare at least once (the
/// ground's slowest at 0.5 Hz) and a change one side sees is one the
/// other saw the start of.
pub const SETTLE: Micros = 2_000_000;

/// A ground event waits at most this long past its window (vehicle time)
/// for the vehicle's view of the autopilot's clock to pass it, and a
/// vehicle event for the ground's, before it is judged on vehicle time
/// alone: an autopilot that stops sending a message with `time_boot_ms`
/// does not hold the check for ever.
pub const STALE: Micros = 10_000_000;

/// A heartbeat asked for to judge a ground event on the autopilot's clock
/// is asked this much later than its window's end: the vehicle's last
/// `time_boot_ms` read is a telemetry period (4 Hz: 0.25 s) and its link's
/// delay behind the frames it elaborates (0.3 s left it short on real
/// ArduPlane SITL, the report waiting for the next periodic heartbeat).
pub const BOOT_MARGIN: Micros = 500_000;

/// Which side saw an event the other did not.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    Ground,
    Vehicle,
}

/// An event seen on one side only.
#[derive(Debug, Clone, PartialEq)]
pub struct Disagreement {
    pub event: String,
    pub seen_by: Side,
    /// When it was seen (vehicle time).
    pub time: Micros,
    /// Its parameters as that side elaborated them.
    pub params: Params,
    /// How long the other side was given to see it.
    pub window: Micros,
    /// The other side's nearest event of that name, if any: (time, params).
    pub other: Option<(Micros, Params)>,
}

impl Disagreement {
    /// `mirror_disagreement` for the ground's timeline and nets.
    pub fn event(&self) -> Event {
        let (who, other) = match self.seen_by {
            Side::Ground => ("ground", "vehicle"),
            Side::Vehicle => ("vehicle", "ground"),
        };
        let mut e = Event::new("mirror_disagreement")
            .param("event", self.event.as_str())
            .param("seen_by", who)
            .param("t", self.time as f64 / 1e6)
            .param("window_s", self.window as f64 / 1e6)
            .param(who, nets::Value::Map(self.params.clone()));
        if let Some((t, p)) = &self.other {
            e = e
                // Not `ground_t`: `petrel mirror --json` gives the ground's
                // clock that name.
                .param(format!("{other}_event_t"), *t as f64 / 1e6)
                .param(other, nets::Value::Map(p.clone()));
        }
        e
    }
}

#[derive(Debug, Clone)]
struct Seen {
    name: String,
    time: Micros,
    /// The autopilot's clock when it was elaborated (`time_boot_ms`, µs).
    boot: Option<Micros>,
    /// The ground was not receiving a message every rule of the event
    /// depends on (`ground::Ground`'s judgement when it was seen).
    unobservable: bool,
    params: Params,
}

/// What the check counted.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Counts {
    pub matched: u64,
    pub ground_only: u64,
    pub vehicle_only: u64,
    /// Link events, not compared.
    pub skipped: u64,
    /// Events elaborated from frames addressed to one link alone (the
    /// acknowledgements of a side's own commands: `command_rejected`), not
    /// compared: the other side never receives them.
    pub addressed: u64,
    /// Events not judged: seen by the vehicle while the ground lost the
    /// autopilot's frames, by the ground within [`SILENCE`] after a
    /// [`HOLE`] or before the replica's snapshot, or by either while the
    /// two views settled ([`SETTLE`]).
    pub unjudged: u64,
    /// Events seen on one side only that the ground cannot observe: every
    /// rule producing them depends on a message the ground was not
    /// receiving from the vehicle (`EXTENDED_SYS_STATE` on a port that
    /// does not stream it), so the ground never runs the rule the vehicle
    /// ran. Never disagreements.
    pub unobservable: u64,
    /// The longest the vehicle saw a matched event after the ground, and
    /// the ground after the vehicle (vehicle time): the margins the window
    /// left.
    pub vehicle_late_max: Micros,
    pub ground_late_max: Micros,
}

/// The independent check.
#[derive(Debug)]
pub struct Check {
    window: Window,
    ground: VecDeque<Seen>,
    vehicle: VecDeque<Seen>,
    /// Every event seen on each side lately, matched or not, as evidence.
    recent: VecDeque<(Side, Seen)>,
    reports: VecDeque<Disagreement>,
    /// Spans of vehicle time in which the ground lost the autopilot's
    /// frames: from the last frame heard before a gap to the first after,
    /// and how long the frames lost would have taken to send (the hole
    /// they left in the ground's view).
    lost: VecDeque<(Micros, Micros, Micros)>,
    /// Event names (unqualified) elaborated only from frames addressed to
    /// one link ([`elaboration::Profile::addressed_events`]): not compared.
    addressed: Vec<String>,
    /// The vehicle's events before this time are unknown (the replica was
    /// restored from a snapshot taken then).
    known_from: Micros,
    /// The ground's first autopilot heartbeat (vehicle time): its view's
    /// start.
    ground_from: Option<Micros>,
    /// Ground events not matched when seen (their time and name): if still
    /// unmatched half a window later, a heartbeat is asked for at the end
    /// of their window.
    wanted: VecDeque<(Micros, String)>,
    pub counts: Counts,
}

impl Check {
    pub fn new(window: Window) -> Check {
        Check {
            window,
            ground: VecDeque::new(),
            vehicle: VecDeque::new(),
            recent: VecDeque::new(),
            reports: VecDeque::new(),
            lost: VecDeque::new(),
            addressed: Vec::new(),
            known_from: 0,
            ground_from: None,
            wanted: VecDeque::new(),
            counts: Counts::default(),
        }
    }

    /// The events (unqualified names) elaborated only from frames addressed
    /// to one link, which the other side never receives: not compared.
    pub fn with_addressed(mut self, names: impl IntoIterator<Item = impl Into<String>>) -> Check {
        self.addressed = names.into_iter().map(Into::into).collect();
        self
    }

    /// A vehicle time a heartbeat is wanted at, `now` being the vehicle's
    /// time: a ground event the vehicle has not reported is judged once a
    /// heartbeat past its window arrives (the periodic one comes up to a
    /// second later). Asked for only when the vehicle's event has not come
    /// half a window after the ground's (it usually comes at once), in
    /// time for the request to reach the vehicle before the window ends.
    pub fn poll_heartbeat_wanted(&mut self, now: Option<Micros>) -> Option<Micros> {
        let late = self.window.vehicle_late;
        let now = now?;
        while let Some((time, name)) = self.wanted.front() {
            if time.saturating_add(late / 2) > now {
                return None;
            }
            let (time, name) = (*time, name.clone());
            self.wanted.pop_front();
            if let Some(g) = self
                .ground
                .iter()
                .find(|g| g.time == time && g.name == name)
            {
                // On the autopilot's clock, the heartbeat must come once
                // the vehicle has read it past the window: a period later.
                let margin = if g.boot.is_some() { BOOT_MARGIN } else { 0 };
                return Some(time.saturating_add(late + margin) + 1);
            }
        }
        None
    }

    /// The ground lost autopilot frames (a gap in their sequence numbers)
    /// between vehicle times `from` and `to`, `hole` long at the
    /// autopilot's rate: what it elaborated around then may come late or
    /// not at all.
    pub fn lost(&mut self, from: Micros, to: Micros, hole: Micros) {
        self.lost.push_back((from, to, hole));
        while self.lost.len() > 1024 {
            self.lost.pop_front();
        }
    }

    /// The replica was restored from a snapshot at vehicle time `time`:
    /// the vehicle's events before it were never published to the ground,
    /// so the ground's events before it are not judged.
    pub fn unknown_before(&mut self, time: Micros) {
        self.known_from = self.known_from.max(time);
        let before = self.ground.len();
        self.ground.retain(|g| g.time >= time);
        self.counts.unjudged += (before - self.ground.len()) as u64;
    }

    /// The ground heard the vehicle's autopilot's first heartbeat at vehicle
    /// time `time` (the first call counts).
    pub fn ground_from(&mut self, time: Micros) {
        self.ground_from.get_or_insert(time);
    }

    /// Whether the ground's start is known yet ([`Check::ground_from`]).
    pub fn knows_ground_start(&self) -> bool {
        self.ground_from.is_some()
    }

    /// Whether an event seen on one side only at `time` falls while the two
    /// views settled: within [`SETTLE`] of the later start.
    fn settling(&self, time: Micros) -> bool {
        let start = self.known_from.max(self.ground_from.unwrap_or(0));
        time < start.saturating_add(SETTLE)
    }

    /// Whether the ground lost frames between `from` and `to`.
    fn losing(&self, from: Micros, to: Micros) -> bool {
        self.lost.iter().any(|(a, b, _)| *a <= to && *b >= from)
    }

    /// Whether a ground event at `time` may come from a hole in the
    /// ground's view: one at least [`HOLE`] long, ended [`SILENCE`] before
    /// at most. A frame lost here and there is no reason not to judge: the
    /// vehicle's engine failure is as visible at 10 % loss as at none.
    fn in_hole(&self, time: Micros) -> bool {
        self.lost
            .iter()
            .any(|(a, b, hole)| *hole >= HOLE && *a <= time && b.saturating_add(SILENCE) >= time)
    }

    /// How long, within `from..to` (vehicle time), a ground event would not
    /// have been judged for a hole in the ground's view ([`Check::in_hole`]):
    /// the check's blind time.
    pub fn blind(&self, from: Micros, to: Micros) -> Micros {
        let mut spans: Vec<(Micros, Micros)> = self
            .lost
            .iter()
            .filter(|(_, _, hole)| *hole >= HOLE)
            .map(|(a, b, _)| ((*a).max(from), b.saturating_add(SILENCE).min(to)))
            .filter(|(a, b)| a < b)
            .collect();
        spans.sort_unstable();
        let (mut total, mut reached) = (0, from);
        for (a, b) in spans {
            let a = a.max(reached);
            if b > a {
                total += b - a;
                reached = b;
            }
        }
        total
    }

    /// How far back a ground event seen at `time` may have happened: the
    /// start of the losses just before it.
    fn earliest(&self, time: Micros) -> Micros {
        let mut earliest = time;
        for (a, b, _) in self.lost.iter().rev() {
            if *b + self.window.ground_late >= earliest && *a < earliest {
                earliest = *a;
            }
        }
        earliest.saturating_sub(self.window.ground_late)
    }

    /// An event the vehicle published (elaborated on board), at its time
    /// and the autopilot's (`boot`, when known).
    pub fn vehicle(&mut self, time: Micros, boot: Option<Micros>, event: &Event) {
        self.seen(Side::Vehicle, time, boot, event, false);
    }

    /// An event the ground elaborated, at its vehicle time and the
    /// autopilot's.
    pub fn ground(&mut self, time: Micros, boot: Option<Micros>, event: &Event) {
        self.seen(Side::Ground, time, boot, event, false);
    }

    /// An event seen by `side` that the ground cannot observe (every rule
    /// producing it depends on a message it was not receiving): matched if
    /// the other side saw it, never a disagreement.
    pub fn unobservable(&mut self, side: Side, time: Micros, boot: Option<Micros>, event: &Event) {
        self.seen(side, time, boot, event, true);
    }

    fn seen(
        &mut self,
        side: Side,
        time: Micros,
        boot: Option<Micros>,
        event: &Event,
        unobservable: bool,
    ) {
        if event.category == Category::Communication {
            self.counts.skipped += 1;
            return;
        }
        let unqualified = nets::model::split_vehicle(&event.name).0;
        if self.addressed.iter().any(|a| a == unqualified) {
            self.counts.addressed += 1;
            return;
        }
        if side == Side::Ground && time < self.known_from {
            self.counts.unjudged += 1;
            return;
        }
        let seen = Seen {
            name: event.name.clone(),
            time,
            boot,
            unobservable,
            params: event.params.clone(),
        };
        self.recent.push_back((side, seen.clone()));
        while self.recent.len() > 256 {
            self.recent.pop_front();
        }
        let late = self.window.vehicle_late;
        // On the autopilot's clock where both sides have it (the frames
        // both heard carry it: a busy computer that stamps its frames late
        // moves neither), else on vehicle time (the receive times). A
        // ground event is seen late when the frames before it were lost:
        // it matches a vehicle event from the start of those losses on
        // (`back`: how far before it, window included).
        let matches = |g: &Seen, v: &Seen, back: Micros| match (g.boot, v.boot) {
            (Some(gb), Some(vb)) => vb <= gb.saturating_add(late) && vb >= gb.saturating_sub(back),
            _ => v.time <= g.time.saturating_add(late) && v.time >= g.time.saturating_sub(back),
        };
        let back_here = time.saturating_sub(self.earliest(time));
        let back: Vec<Micros> = match side {
            Side::Vehicle => self
                .ground
                .iter()
                .map(|g| g.time.saturating_sub(self.earliest(g.time)))
                .collect(),
            Side::Ground => Vec::new(),
        };
        let other = match side {
            Side::Ground => &mut self.vehicle,
            Side::Vehicle => &mut self.ground,
        };
        let found = other.iter().enumerate().position(|(i, o)| {
            o.name == seen.name
                && match side {
                    Side::Ground => matches(&seen, o, back_here),
                    Side::Vehicle => matches(o, &seen, back[i]),
                }
        });
        if let Some(i) = found {
            let o = other.remove(i).expect("found");
            self.counts.matched += 1;
            let (g, v) = match side {
                Side::Ground => (&seen, &o),
                Side::Vehicle => (&o, &seen),
            };
            let (ground, vehicle) = match (g.boot, v.boot) {
                (Some(gb), Some(vb)) => (gb, vb),
                _ => (g.time, v.time),
            };
            let c = &mut self.counts;
            c.vehicle_late_max = c.vehicle_late_max.max(vehicle.saturating_sub(ground));
            c.ground_late_max = c.ground_late_max.max(ground.saturating_sub(vehicle));
            return;
        }
        match side {
            Side::Ground => {
                // Judged once the vehicle's records are known complete
                // past the window: a heartbeat asked for then.
                self.wanted.push_back((time, seen.name.clone()));
                while self.wanted.len() > 64 {
                    self.wanted.pop_front();
                }
                self.ground.push_back(seen);
            }
            Side::Vehicle => self.vehicle.push_back(seen),
        }
    }

    /// Judges what can be judged: `vehicle_known` is the vehicle time
    /// through which the replica holds every record, `ground_known` the
    /// vehicle time the ground's elaboration has reached; `vehicle_boot`
    /// and `ground_boot` how far each side has read the autopilot's clock
    /// by then (its `time_boot_ms`, µs), when known. An event with the
    /// autopilot's time is judged once the other side has read past it
    /// (and its window) on that clock; one without, or when the other side
    /// has none, on vehicle time.
    #[cfg(test)]
    pub fn advance(
        &mut self,
        vehicle_known: Option<Micros>,
        vehicle_boot: Option<Micros>,
        ground_known: Option<Micros>,
        ground_boot: Option<Micros>,
    ) {
        self.advance_holding(
            vehicle_known,
            vehicle_boot,
            ground_known,
            ground_boot,
            |_| true,
        );
    }

    /// `Check::advance` (a test's shorthand), where `holds` says whether the ground is still
    /// in the state a ground event announced (`Elaborator::still_holds`):
    /// one it left again before it was judged (a second or two later) is
    /// not judged. The ground samples some streams once a second or less:
    /// a stale sample of one with a fresh one of another makes a state the
    /// autopilot may never have been in (ArduPlane's SYS_STATUS still
    /// "pre-arm healthy" from before its disarm, with the heartbeat that
    /// disarms: a `ready_for_takeoff` for one second), which the vehicle,
    /// sampling every stream at 4 Hz, does not see.
    pub fn advance_holding(
        &mut self,
        vehicle_known: Option<Micros>,
        vehicle_boot: Option<Micros>,
        ground_known: Option<Micros>,
        ground_boot: Option<Micros>,
        holds: impl Fn(&str) -> bool,
    ) {
        let Window {
            vehicle_late,
            ground_late,
        } = self.window;
        // Past the other side's view: on the autopilot's clock when both
        // have it (and not STALE on vehicle time), else on vehicle time.
        let past = |seen: &Seen, late: Micros, known: Micros, boot: Option<Micros>| match (
            seen.boot, boot,
        ) {
            (Some(sb), Some(b)) => {
                sb.saturating_add(late) < b || seen.time.saturating_add(late + STALE) < known
            }
            _ => seen.time.saturating_add(late) < known,
        };
        if let Some(v) = vehicle_known {
            while self
                .ground
                .front()
                .is_some_and(|g| past(g, vehicle_late, v, vehicle_boot))
            {
                let g = self.ground.pop_front().expect("checked");
                if self.in_hole(g.time) || self.settling(g.time) || !holds(&g.name) {
                    self.counts.unjudged += 1;
                    continue;
                }
                if g.unobservable {
                    self.counts.unobservable += 1;
                    continue;
                }
                self.counts.ground_only += 1;
                let other = self.nearest(Side::Vehicle, &g);
                self.reports.push_back(Disagreement {
                    event: g.name,
                    seen_by: Side::Ground,
                    time: g.time,
                    params: g.params,
                    window: vehicle_late,
                    other,
                });
            }
        }
        if let Some(gk) = ground_known {
            while self
                .vehicle
                .front()
                .is_some_and(|v| past(v, ground_late, gk, ground_boot))
            {
                let v = self.vehicle.pop_front().expect("checked");
                if self.settling(v.time)
                    || self.losing(
                        v.time.saturating_sub(ground_late),
                        v.time.saturating_add(ground_late),
                    )
                {
                    self.counts.unjudged += 1;
                    continue;
                }
                if v.unobservable {
                    self.counts.unobservable += 1;
                    continue;
                }
                self.counts.vehicle_only += 1;
                let other = self.nearest(Side::Ground, &v);
                self.reports.push_back(Disagreement {
                    event: v.name,
                    seen_by: Side::Vehicle,
                    time: v.time,
                    params: v.params,
                    window: ground_late,
                    other,
                });
            }
        }
    }

    fn nearest(&self, side: Side, seen: &Seen) -> Option<(Micros, Params)> {
        self.recent
            .iter()
            .filter(|(s, o)| *s == side && o.name == seen.name)
            .min_by_key(|(_, o)| o.time.abs_diff(seen.time))
            .map(|(_, o)| (o.time, o.params.clone()))
    }

    /// Whether a disagreement waits to be polled.
    pub fn has_report(&self) -> bool {
        !self.reports.is_empty()
    }

    pub fn poll(&mut self) -> Option<Disagreement> {
        self.reports.pop_front()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(name: &str, category: Category) -> Event {
        Event {
            name: name.into(),
            category,
            params: Params::new(),
        }
    }

    #[test]
    fn events_within_the_window_match_either_way() {
        let mut c = Check::new(WINDOW);
        c.vehicle(10_000_000, None, &ev("takeoff", Category::Mission));
        c.ground(11_500_000, None, &ev("takeoff", Category::Mission));
        c.ground(20_000_000, None, &ev("landed", Category::Mission));
        c.vehicle(19_000_000, None, &ev("landed", Category::Mission));
        c.advance(Some(60_000_000), None, Some(60_000_000), None);
        assert_eq!(c.poll(), None);
        assert_eq!(c.counts.matched, 2);
    }

    #[test]
    fn an_engine_failure_the_vehicle_missed_is_reported_once_its_records_are_complete() {
        let mut c = Check::new(WINDOW);
        c.ground(
            52_900_000,
            None,
            &ev("engine_failure", Category::Catastrophic),
        );
        // Still unmatched half a window later: a heartbeat is wanted just
        // past the vehicle's window.
        assert_eq!(c.poll_heartbeat_wanted(Some(53_300_000)), None);
        assert_eq!(c.poll_heartbeat_wanted(Some(53_400_000)), Some(53_900_001));
        assert_eq!(c.poll_heartbeat_wanted(Some(53_400_000)), None);
        // The replica's records only reach 53.9 s: not yet judged.
        c.advance(Some(53_900_000), None, Some(55_000_000), None);
        assert_eq!(c.poll(), None);
        c.advance(Some(53_900_001), None, Some(55_000_000), None);
        let d = c.poll().expect("a disagreement");
        assert_eq!(d.seen_by, Side::Ground);
        assert_eq!(d.event, "engine_failure");
        assert_eq!(d.time, 52_900_000);
        assert_eq!(d.window, WINDOW.vehicle_late);
        let e = d.event();
        assert_eq!(e.name, "mirror_disagreement");
        assert_eq!(e.params["seen_by"], nets::Value::Str("ground".into()));
        assert_eq!(c.poll(), None);
    }

    #[test]
    fn the_window_is_longer_for_the_ground_than_for_the_vehicle() {
        // The ground 1.8 s after the vehicle (a slow ground stream): one
        // event, and no heartbeat wanted (the vehicle's came first).
        let mut c = Check::new(WINDOW);
        c.vehicle(10_000_000, None, &ev("disarmed", Category::Nominal));
        c.ground(11_800_000, None, &ev("disarmed", Category::Nominal));
        assert_eq!(c.poll_heartbeat_wanted(Some(20_000_000)), None);
        c.advance(Some(30_000_000), None, Some(30_000_000), None);
        assert_eq!(c.poll(), None);
        assert_eq!(c.counts.ground_late_max, 1_800_000);
        // The vehicle 0.9 s after the ground: one event.
        c.ground(40_000_000, None, &ev("takeoff", Category::Mission));
        c.vehicle(40_300_000, None, &ev("takeoff", Category::Mission));
        // Matched before half the window: no heartbeat asked for.
        assert_eq!(c.poll_heartbeat_wanted(Some(41_000_000)), None);
        c.ground(40_000_000, None, &ev("takeoff", Category::Mission));
        c.vehicle(40_900_000, None, &ev("takeoff", Category::Mission));
        c.advance(Some(60_000_000), None, Some(60_000_000), None);
        assert_eq!(c.poll(), None);
        assert_eq!(c.counts.vehicle_late_max, 900_000);
        assert_eq!(c.counts.matched, 3);
        // The vehicle 1.5 s after the ground: two events, one each side.
        c.ground(70_000_000, None, &ev("landed", Category::Mission));
        c.vehicle(71_500_000, None, &ev("landed", Category::Mission));
        c.advance(Some(90_000_000), None, Some(90_000_000), None);
        let sides: Vec<Side> = std::iter::from_fn(|| c.poll()).map(|d| d.seen_by).collect();
        assert_eq!(sides, [Side::Ground, Side::Vehicle]);
    }

    #[test]
    fn the_reverse_is_reported_with_the_grounds_nearest_evidence() {
        let mut c = Check::new(WINDOW);
        c.ground(3_000_000, None, &ev("battery_low", Category::Safety));
        c.advance(Some(3_000_000), None, Some(3_000_000), None);
        c.vehicle(40_000_000, None, &ev("battery_low", Category::Safety));
        c.advance(Some(43_000_000), None, Some(43_000_000), None);
        let reports: Vec<Disagreement> = std::iter::from_fn(|| c.poll()).collect();
        assert_eq!(reports.len(), 2, "{reports:?}");
        let v = reports
            .iter()
            .find(|d| d.seen_by == Side::Vehicle)
            .expect("vehicle only");
        assert_eq!(v.other.as_ref().map(|o| o.0), Some(3_000_000));
        assert_eq!(v.event().params["ground_event_t"], nets::Value::Float(3.0));
    }

    #[test]
    fn losses_on_the_ground_excuse_late_or_missing_ground_events() {
        let mut c = Check::new(WINDOW);
        // The ground lost the autopilot's frames from 40 to 45 s: the
        // vehicle's `disarmed` at 41 s reaches the ground at 45.5 s, and
        // its `mission_item_reached` at 43 s never does.
        c.vehicle(41_000_000, None, &ev("disarmed", Category::Nominal));
        c.vehicle(
            43_000_000,
            None,
            &ev("mission_item_reached", Category::Mission),
        );
        c.lost(40_000_000, 45_000_000, 5_000_000);
        c.ground(45_500_000, None, &ev("disarmed", Category::Nominal));
        c.advance(Some(60_000_000), None, Some(60_000_000), None);
        assert_eq!(c.poll(), None);
        assert_eq!(c.counts.matched, 1);
        assert_eq!(c.counts.unjudged, 1);
        // Without losses, the same late event is a disagreement both ways.
        let mut c = Check::new(WINDOW);
        c.vehicle(41_000_000, None, &ev("disarmed", Category::Nominal));
        c.ground(45_500_000, None, &ev("disarmed", Category::Nominal));
        c.advance(Some(60_000_000), None, Some(60_000_000), None);
        assert_eq!(std::iter::from_fn(|| c.poll()).count(), 2);
    }

    #[test]
    fn a_silence_the_radio_caused_and_events_before_a_snapshot_are_not_judged() {
        let mut c = Check::new(WINDOW);
        // The camera's frames lost from 30 to 40 s: the ground hears its
        // silence as a payload failure at 45 s; the vehicle heard it.
        c.lost(30_000_000, 40_000_000, 10_000_000);
        c.ground(45_000_000, None, &ev("payload_failure", Category::Mission));
        // Before the snapshot the replica restored at 10 s.
        c.ground(9_000_000, None, &ev("takeoff", Category::Mission));
        c.unknown_before(10_000_000);
        c.ground(
            9_500_000,
            None,
            &ev("mission_item_reached", Category::Mission),
        );
        c.advance(Some(90_000_000), None, Some(90_000_000), None);
        assert_eq!(c.poll(), None);
        assert_eq!(c.counts.unjudged, 3);
    }

    #[test]
    fn a_frame_lost_here_and_there_leaves_the_check_judging() {
        // 10 % loss: a frame of the autopilot's lost every 0.2 s, 30 ms
        // without it each time. Before, each loss hid every ground event
        // for 20 s: an engine failure the vehicle missed went unreported.
        let mut c = Check::new(WINDOW);
        for i in 0..200u64 {
            c.lost(i * 200_000, i * 200_000 + 30_000, 30_000);
        }
        c.ground(
            30_010_000,
            None,
            &ev("engine_failure", Category::Catastrophic),
        );
        c.advance(Some(40_000_000), None, Some(40_000_000), None);
        let d = c.poll().expect("reported");
        assert_eq!(
            (d.event.as_str(), d.seen_by),
            ("engine_failure", Side::Ground)
        );
        assert_eq!(c.blind(0, 40_000_000), 0);
        // A vehicle event during those losses is still not judged: the
        // one frame it came from may be the one the radio lost.
        c.vehicle(
            20_000_000,
            None,
            &ev("mission_item_reached", Category::Mission),
        );
        c.advance(Some(40_000_000), None, Some(40_000_000), None);
        assert_eq!(c.poll(), None);
        assert_eq!(c.counts.unjudged, 1);
        // A hole of a second or more hides the ground's events for 20 s
        // after it, and the check says how long it was blind.
        c.lost(50_000_000, 51_000_000, 1_000_000);
        c.ground(
            70_000_000,
            None,
            &ev("engine_failure", Category::Catastrophic),
        );
        c.ground(71_500_000, None, &ev("payload_failure", Category::Mission));
        c.advance(Some(80_000_000), None, Some(80_000_000), None);
        let d = c.poll().expect("the second, after the hole's 20 s");
        assert_eq!(d.event, "payload_failure");
        assert_eq!(c.counts.unjudged, 2);
        assert_eq!(c.blind(0, 80_000_000), 21_000_000);
        assert_eq!(c.blind(60_000_000, 65_000_000), 5_000_000);
    }

    #[test]
    fn events_from_frames_addressed_to_one_link_are_never_compared() {
        // ArduPilot acknowledges the onboard gateway's commands to it
        // alone, and a ground station's to the ground's link alone.
        let mut c = Check::new(WINDOW).with_addressed(["command_rejected"]);
        c.vehicle(10_000_000, None, &ev("command_rejected", Category::Mission));
        c.ground(
            20_000_000,
            None,
            &ev("command_rejected@R1", Category::Mission),
        );
        c.advance(Some(60_000_000), None, Some(60_000_000), None);
        assert_eq!(c.poll(), None);
        assert_eq!((c.counts.addressed, c.counts.unjudged), (2, 0));
    }

    #[test]
    fn nothing_is_judged_while_the_two_views_settle() {
        // The vehicle's player started at 0; the ground heard ArduPlane's
        // INITIALISING heartbeat at 0.15 s and MANUAL at 1.15 s (a change),
        // where the vehicle's first heartbeat was already MANUAL.
        let mut c = Check::new(WINDOW);
        c.ground_from(150_000);
        c.ground(1_150_000, None, &ev("mode_changed", Category::Nominal));
        // A real one later, on the ground only, is reported.
        c.ground(2_200_000, None, &ev("mode_changed", Category::Nominal));
        c.advance(Some(10_000_000), None, Some(10_000_000), None);
        let d = c.poll().expect("the later one");
        assert_eq!((d.time, d.seen_by), (2_200_000, Side::Ground));
        assert_eq!(c.poll(), None);
        assert_eq!((c.counts.unjudged, c.counts.ground_only), (1, 1));

        // The ground started listening 100 s into the vehicle's flight:
        // what the vehicle saw in the ground's first 2 s is not judged,
        // what it saw after is.
        let mut c = Check::new(WINDOW);
        c.ground_from(100_000_000);
        c.vehicle(101_000_000, None, &ev("mode_changed", Category::Nominal));
        c.vehicle(102_500_000, None, &ev("armed", Category::Nominal));
        c.advance(Some(110_000_000), None, Some(110_000_000), None);
        let d = c.poll().expect("the later one");
        assert_eq!((d.event.as_str(), d.seen_by), ("armed", Side::Vehicle));
        assert_eq!(c.poll(), None);
        assert_eq!((c.counts.unjudged, c.counts.vehicle_only), (1, 1));

        // The first call counts: a later heartbeat does not move the start.
        c.ground_from(200_000_000);
        c.ground(200_500_000, None, &ev("disarmed", Category::Nominal));
        c.advance(Some(210_000_000), None, Some(210_000_000), None);
        assert_eq!(c.poll().map(|d| d.time), Some(200_500_000));
    }

    #[test]
    fn on_the_autopilots_clock_a_side_that_stamps_late_raises_no_disagreement() {
        // The ground's computer starved 3.3 s: its events come 3.3 s late
        // in vehicle time, at the autopilot's same `time_boot_ms`.
        let mut c = Check::new(WINDOW);
        c.vehicle(
            10_000_000,
            Some(110_000_000),
            &ev("armed", Category::Nominal),
        );
        c.ground(
            13_300_000,
            Some(110_050_000),
            &ev("armed", Category::Nominal),
        );
        // The onboard gateway starved: its `takeoff` comes 3.3 s late in
        // vehicle time. The replica's records reach 21.2 s (past the
        // ground's event and its window in vehicle time) but the vehicle
        // had read its autopilot's clock only to 110.5 s: not judged yet.
        c.ground(
            20_000_000,
            Some(120_000_000),
            &ev("takeoff", Category::Mission),
        );
        c.advance(
            Some(21_200_000),
            Some(110_500_000),
            Some(21_000_000),
            Some(121_000_000),
        );
        assert_eq!(c.poll(), None);
        c.vehicle(
            23_300_000,
            Some(120_100_000),
            &ev("takeoff", Category::Mission),
        );
        c.advance(
            Some(40_000_000),
            Some(140_000_000),
            Some(40_000_000),
            Some(140_000_000),
        );
        assert_eq!(c.poll(), None);
        assert_eq!(c.counts.matched, 2);
        assert_eq!(c.counts.ground_late_max, 50_000);
        assert_eq!(c.counts.vehicle_late_max, 100_000);
    }

    #[test]
    fn on_the_autopilots_clock_a_real_miss_is_still_reported_both_ways() {
        let mut c = Check::new(WINDOW);
        c.ground(
            30_000_000,
            Some(130_000_000),
            &ev("engine_failure", Category::Catastrophic),
        );
        c.vehicle(
            35_000_000,
            Some(135_000_000),
            &ev("battery_low", Category::Safety),
        );
        // Asked for half a window past its end: the vehicle reads the
        // autopilot's clock a period behind.
        assert_eq!(
            c.poll_heartbeat_wanted(Some(30_500_000)),
            Some(31_000_000 + BOOT_MARGIN + 1)
        );
        // The vehicle has read its clock to 131.1 s, the ground to 137.1 s.
        c.advance(
            Some(31_400_000),
            Some(131_100_000),
            Some(37_100_000),
            Some(137_100_000),
        );
        let seen: Vec<(Side, String)> = std::iter::from_fn(|| c.poll())
            .map(|d| (d.seen_by, d.event))
            .collect();
        assert_eq!(
            seen,
            [
                (Side::Ground, "engine_failure".to_owned()),
                (Side::Vehicle, "battery_low".to_owned())
            ]
        );
        // A side that stops reading the autopilot's clock is judged on
        // vehicle time once STALE past the window.
        c.ground(
            50_000_000,
            Some(150_000_000),
            &ev("engine_failure", Category::Catastrophic),
        );
        c.advance(
            Some(60_000_000),
            Some(140_000_000),
            Some(60_000_000),
            Some(160_000_000),
        );
        assert_eq!(c.poll(), None);
        c.advance(
            Some(61_000_001),
            Some(140_000_000),
            Some(61_000_001),
            Some(160_000_000),
        );
        assert_eq!(c.poll().map(|d| d.time), Some(50_000_000));
    }

    #[test]
    fn unobservable_events_are_matched_or_counted_never_reported() {
        let mut c = Check::new(WINDOW);
        c.unobservable(
            Side::Vehicle,
            10_000_000,
            None,
            &ev("landed", Category::Mission),
        );
        c.unobservable(
            Side::Ground,
            20_000_000,
            None,
            &ev("takeoff", Category::Mission),
        );
        c.vehicle(20_100_000, None, &ev("takeoff", Category::Mission));
        c.advance(Some(60_000_000), None, Some(60_000_000), None);
        assert_eq!(c.poll(), None);
        assert_eq!((c.counts.unobservable, c.counts.matched), (1, 1));
    }

    #[test]
    fn a_state_the_ground_left_again_before_it_was_judged_is_not_judged() {
        // ArduPlane disarmed after its landing: the ground's 1 Hz SYS_STATUS
        // still said "pre-arm healthy" (from while armed) with the heartbeat
        // that disarmed, a second later not; the vehicle, at 4 Hz, never saw
        // both together.
        let mut c = Check::new(WINDOW);
        c.ground(
            122_000_000,
            None,
            &ev("ready_for_takeoff", Category::Nominal),
        );
        c.ground(
            130_000_000,
            None,
            &ev("ready_for_takeoff", Category::Nominal),
        );
        let mut left = true;
        c.advance_holding(Some(124_000_000), None, Some(124_000_000), None, |n| {
            n != "ready_for_takeoff" || !left
        });
        assert_eq!(c.poll(), None);
        assert_eq!(c.counts.unjudged, 1);
        // One the ground is still in when judged is reported.
        left = false;
        c.advance_holding(Some(132_000_000), None, Some(132_000_000), None, |n| {
            n != "ready_for_takeoff" || !left
        });
        assert_eq!(c.poll().map(|d| d.time), Some(130_000_000));
    }

    #[test]
    fn link_events_are_never_compared() {
        let mut c = Check::new(WINDOW);
        c.ground(1_000_000, None, &ev("link_lost", Category::Communication));
        c.advance(Some(100_000_000), None, Some(100_000_000), None);
        assert_eq!(c.poll(), None);
        assert_eq!(c.counts.skipped, 1);
    }
}
