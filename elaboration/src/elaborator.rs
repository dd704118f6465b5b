//! The elaborator: a sans-IO state machine fed frames (or decoded messages)
//! with their receive times, and `tick`s between them; it queues events.
//!
//! Liveness (`age()`, `seen()`, `loss()`) counts CRC-valid frames per
//! sender, decoded or not; a frame is decoded only when a rule reads its
//! message's fields, and a decoding failure is counted per message id.

use std::collections::{BTreeMap, VecDeque};

use mavlink::dialects::ardupilotmega::{MavMessage, STATUSTEXT_DATA};
use mavlink::MavHeader;
use mavlink::Message;
use nets::{Event, Params};

use crate::constants::{mode_name, Firmware};
use crate::expr::{self, Context, Func, V};
use crate::fields::{self, Field};
use crate::frame::Frame;
use crate::profile::{Profile, Rule, SourceFilter, HEARTBEAT_SLOT};
use crate::statustext::{Joiner, Piece};

/// An event with its time and the sender it is about.
#[derive(Debug, Clone, PartialEq)]
pub struct Elaborated {
    /// Receive time of the frame (or tick) that fired it, microseconds.
    pub time_us: u64,
    /// The sender's own clock when it fired, microseconds since its boot:
    /// the last `time_boot_ms` it sent, up to and including the frame that
    /// fired it, plus the receive time since that frame. `None` while the
    /// sender has sent no message that carries one
    /// ([`crate::frame::boot_ms_offset`]). The time added is at most the
    /// sender's recent period between such messages: a computer that
    /// stalled reads the first frame after it long after the last, and
    /// that time is the stall's.
    pub boot_us: Option<u64>,
    pub event: Event,
    pub sysid: u8,
    pub compid: u8,
    /// The rule that fired it: its index in the profile
    /// ([`crate::Profile::rules_needs`] tells what it read); `None` when
    /// rebuilt from a record.
    pub rule: Option<usize>,
}

/// How the elaborator finds the vehicle and paces its timers.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Config {
    /// The supervised vehicle's system id; by default the first sender of
    /// an autopilot HEARTBEAT.
    pub sysid: Option<u8>,
    /// Its autopilot's component id; by default that sender's.
    pub compid: Option<u8>,
    /// Forces the firmware family used to name modes (a QuadPlane reporting
    /// a multicopter type, say).
    pub firmware: Option<Firmware>,
    /// Timed rules (`age()`, `for`) are evaluated on this grid, in
    /// microseconds: it bounds how late a timeout fires.
    pub tick_us: u64,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            sysid: None,
            compid: None,
            firmware: None,
            tick_us: 100_000,
        }
    }
}

/// Counts kept by the elaborator.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Stats {
    pub frames: u64,
    pub decoded: u64,
    /// Frames of a read message that rust-mavlink failed to decode, by id.
    pub decode_failures: BTreeMap<u32, u64>,
    /// Frames lost according to per-sender sequence numbers.
    pub sequence_lost: u64,
    /// Frames ignored because [`MAX_SOURCES`] senders were already followed.
    pub ignored_senders: u64,
    /// Reboots detected (`reboot` rules fired).
    pub reboots: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Unknown,
    Autopilot,
    Gcs,
    Other,
}

#[derive(Debug, Clone, Default)]
struct RuleState {
    initialized: bool,
    active: bool,
    /// The active state was announced by an event (not a silent start):
    /// only then does clearing announce its own event.
    announced: bool,
    pending_since: Option<u64>,
    clearing_since: Option<u64>,
    /// (`distinct` rules) The parameters of the last events (the most
    /// recent last), until re-armed.
    last_params: Vec<Params>,
    /// (`distinct` rules) `clear` was false at some evaluation since the
    /// last event: its becoming true re-arms the rule.
    clear_was_false: bool,
}

#[derive(Debug)]
struct Source {
    sysid: u8,
    compid: u8,
    kind: Kind,
    firmware: Firmware,
    custom_mode: Option<u32>,
    first_us: u64,
    last_seq: Option<u8>,
    /// Moving average of the lost-frame ratio (0..1).
    loss: f64,
    last_by_slot: Vec<Option<u64>>,
    values: Vec<Option<Vec<Field>>>,
    rules: Vec<RuleState>,
    memos: Vec<V<'static>>,
    /// Its long STATUSTEXT under way (chunks put back together).
    statustext: Joiner,
    /// Its last `time_boot_ms` (µs) and when it came (receive time).
    boot: Option<(u64, u64)>,
    /// The last gaps between its frames carrying `time_boot_ms`, on its
    /// own clock (µs): the most the receive time since the last one may
    /// add ([`Source::boot_at`]).
    boot_gaps: [u64; 8],
    boot_gap_at: usize,
}

/// Gaps of the sender's own clock longer than this are a silence or a
/// reboot, not its period.
const BOOT_GAP_MAX: u64 = 2_000_000;

impl Source {
    /// The sender's clock at receive time `now` (see [`Elaborated::boot_us`]):
    /// its last `time_boot_ms` plus the receive time since, at most its
    /// recent period. A computer that stalled reads the frames of the
    /// stall together, the first long after the last: that time is the
    /// stall's, not the autopilot's.
    fn boot_at(&self, now: u64) -> Option<u64> {
        let period = self.boot_gaps.iter().copied().max().unwrap_or(0);
        self.boot
            .map(|(boot, at)| boot.saturating_add(now.saturating_sub(at).min(period)))
    }

    fn boot_heard(&mut self, boot: u64, now: u64) {
        if let Some((last, _)) = self.boot {
            let gap = boot.saturating_sub(last);
            if gap <= BOOT_GAP_MAX {
                self.boot_gaps[self.boot_gap_at] = gap;
                self.boot_gap_at = (self.boot_gap_at + 1) % self.boot_gaps.len();
            }
        }
        self.boot = Some((boot, now));
    }
}

const LOSS_WEIGHT: f64 = 1.0 / 32.0;
/// Senders followed at most (a MAVLink network has a handful; a stream of
/// forged ids must not grow memory without bound). Frames from further
/// senders are counted and ignored, except the configured vehicle's.
pub const MAX_SOURCES: usize = 256;
/// At most this many tick steps are replayed for one time jump; beyond it
/// the timers jump straight to the new time.
const MAX_STEPS: u64 = 1200;

/// Elaboration of one vehicle's telemetry with one profile.
#[derive(Debug)]
pub struct Elaborator {
    profile: Profile,
    config: Config,
    vehicle: Option<(u8, u8)>,
    sources: Vec<Source>,
    now: u64,
    next_tick: Option<u64>,
    events: VecDeque<Elaborated>,
    stats: Stats,
    enum_names: fields::EnumNames,
    /// The frame being ingested: the frames its sequence number says were
    /// lost, and its sender's loss average before it (undone if the frame
    /// shows a reboot).
    this_frame: (u64, f64),
    /// Where STATUSTEXT's `text` is among its fields.
    statustext_text: Option<usize>,
}

impl Elaborator {
    pub fn new(profile: Profile, config: Config) -> Self {
        let vehicle = match (config.sysid, config.compid) {
            (Some(s), Some(c)) => Some((s, c)),
            _ => None,
        };
        Elaborator {
            profile,
            config,
            vehicle,
            sources: Vec::new(),
            now: 0,
            next_tick: None,
            events: VecDeque::new(),
            stats: Stats::default(),
            enum_names: fields::EnumNames::default(),
            this_frame: (0, 0.0),
            statustext_text: fields::schema(<STATUSTEXT_DATA as mavlink::MessageData>::ID)
                .and_then(|names| names.iter().position(|n| n == "text")),
        }
    }

    pub fn profile(&self) -> &Profile {
        &self.profile
    }

    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    /// The supervised vehicle's (system, autopilot component), once known.
    pub fn vehicle(&self) -> Option<(u8, u8)> {
        self.vehicle
    }

    /// The supervised vehicle's last `time_boot_ms` heard, in µs (not
    /// extrapolated: how far its own clock the elaboration has read).
    pub fn vehicle_boot_us(&self) -> Option<u64> {
        let (sysid, compid) = self.vehicle?;
        self.sources
            .iter()
            .find(|s| s.sysid == sysid && s.compid == compid)?
            .boot
            .map(|(boot, _)| boot)
    }

    /// Whether the supervised vehicle is still in the state event `event`
    /// announced: a rule producing it (without `each`) is active and its
    /// condition has not turned false since. `true` for an occurrence (a
    /// rule with `each`), a `cleared` event, an event no rule produces, or
    /// before the vehicle is known.
    pub fn still_holds(&self, event: &str) -> bool {
        let Some(src) = self
            .vehicle
            .and_then(|(s, c)| self.sources.iter().find(|x| x.sysid == s && x.compid == c))
        else {
            return true;
        };
        let mut states = self
            .profile
            .rules
            .iter()
            .zip(&src.rules)
            .filter(|(r, _)| r.event == event)
            .peekable();
        if states.peek().is_none()
            || self.profile.rules.iter().any(|r| {
                r.cleared.as_ref().is_some_and(|c| c.0 == event) || (r.event == event && r.each)
            })
        {
            return true;
        }
        states.any(|(_, s)| s.active && s.clearing_since.is_none())
    }

    /// The next queued event.
    pub fn poll_event(&mut self) -> Option<Elaborated> {
        self.events.pop_front()
    }

    /// Moves all queued events into `out`.
    pub fn drain_into(&mut self, out: &mut Vec<Elaborated>) {
        out.extend(self.events.drain(..));
    }

    /// Feeds a CRC-checked frame received at `time_us`.
    pub fn frame(&mut self, time_us: u64, frame: &Frame) {
        self.ingest(
            time_us,
            frame.system_id(),
            frame.component_id(),
            frame.sequence(),
            frame.message_id(),
            Input::Frame(frame),
        );
    }

    /// Feeds a message already decoded by rust-mavlink (a live link).
    pub fn message(&mut self, time_us: u64, header: &MavHeader, message: &MavMessage) {
        let sysid = u8::try_from(header.system_id).unwrap_or(u8::MAX);
        self.ingest(
            time_us,
            sysid,
            header.component_id,
            header.sequence,
            message.message_id(),
            Input::Message(message),
        );
    }

    /// Lets time pass: timeouts (`age()`, `for`) fire up to `time_us`.
    pub fn tick(&mut self, time_us: u64) {
        let time_us = time_us.max(self.now);
        let step = self.config.tick_us.max(1);
        let mut next = match self.next_tick {
            Some(n) => n,
            None => {
                self.now = time_us;
                self.next_tick = Some(time_us.saturating_add(step));
                return;
            }
        };
        let mut steps = 0;
        while next <= time_us {
            if steps == MAX_STEPS {
                next = time_us;
            }
            self.now = next;
            self.run_timed();
            steps += 1;
            match next.checked_add(step) {
                Some(n) => next = n,
                None => {
                    next = u64::MAX;
                    break;
                }
            }
        }
        self.next_tick = Some(next);
        self.now = time_us;
    }

    fn run_timed(&mut self) {
        for ri in 0..self.profile.timed.len() {
            let r = self.profile.timed[ri];
            let (ages, source) = (self.profile.rules[r].ages, self.profile.rules[r].source);
            for si in 0..self.sources.len() {
                // A rule without age() only changes with time while one of
                // its durations runs.
                let state = &self.sources[si].rules[r];
                let running = state.pending_since.is_some() || state.clearing_since.is_some();
                if (ages || running) && self.matches(&source, si) {
                    self.evaluate(r, si, None);
                }
            }
        }
    }

    fn source_index(&mut self, sysid: u8, compid: u8, time_us: u64) -> Option<usize> {
        if let Some(i) = self
            .sources
            .iter()
            .position(|s| s.sysid == sysid && s.compid == compid)
        {
            return Some(i);
        }
        let configured =
            self.config.sysid == Some(sysid) && self.config.compid.is_none_or(|c| c == compid);
        if self.sources.len() >= MAX_SOURCES && !configured {
            return None;
        }
        let p = &self.profile;
        self.sources.push(Source {
            sysid,
            compid,
            kind: Kind::Unknown,
            firmware: self.config.firmware.unwrap_or(Firmware::Other),
            custom_mode: None,
            first_us: time_us,
            last_seq: None,
            loss: 0.0,
            last_by_slot: vec![None; p.slots.len()],
            values: vec![None; p.slots.len()],
            rules: vec![RuleState::default(); p.rules.len()],
            memos: vec![V::Missing; p.memos],
            statustext: Joiner::default(),
            boot: None,
            boot_gaps: [0; 8],
            boot_gap_at: 0,
        });
        Some(self.sources.len() - 1)
    }

    fn ingest(&mut self, time_us: u64, sysid: u8, compid: u8, seq: u8, msgid: u32, input: Input) {
        self.tick(time_us);
        let now = self.now;
        self.stats.frames += 1;
        let Some(si) = self.source_index(sysid, compid, now) else {
            self.stats.ignored_senders += 1;
            return;
        };
        let src = &mut self.sources[si];
        self.this_frame = (0, src.loss);
        if let Some(last) = src.last_seq {
            let lost = seq.wrapping_sub(last).wrapping_sub(1);
            // Large jumps are a restart or reordering, not losses.
            let lost = if lost < 128 { lost } else { 0 };
            self.stats.sequence_lost += lost as u64;
            self.this_frame.0 = lost as u64;
            for _ in 0..lost {
                src.loss += LOSS_WEIGHT * (1.0 - src.loss);
            }
            src.loss -= LOSS_WEIGHT * src.loss;
        }
        src.last_seq = Some(seq);
        let boot_ms = match &input {
            Input::Frame(f) => f.time_boot_ms(),
            Input::Message(m) => crate::frame::message_boot_ms(m),
        };
        if let Some(ms) = boot_ms {
            src.boot_heard(u64::from(ms) * 1000, now);
        }
        let slot = match self.profile.slot_of_id.get(msgid as usize) {
            Some(&0) => return,
            Some(&s) => s as usize - 1,
            None => match self.profile.slot_of_big_id.get(&msgid) {
                Some(&s) => s,
                None => return,
            },
        };
        src.last_by_slot[slot] = Some(now);
        // A frame that does not decode still proves its sender alive: the
        // rules that only time this message (`age(MSG)`, as link_lost) are
        // evaluated on it; those reading its fields are not (their values
        // would be the previous message's).
        let decoded = !self.profile.slots[slot].decode || self.decode_into(si, slot, msgid, input);
        for k in 0..self.profile.by_slot[slot].len() {
            let r = self.profile.by_slot[slot][k];
            let rule = &self.profile.rules[r];
            if (decoded || !rule.reads_fields_of(slot)) && self.matches(&rule.source, si) {
                self.evaluate(r, si, Some(slot));
            }
        }
    }

    /// Decodes a frame of a read message into its source's field values;
    /// false (counted) when rust-mavlink cannot decode it.
    fn decode_into(&mut self, si: usize, slot: usize, msgid: u32, input: Input) -> bool {
        let decoded;
        let msg = match input {
            Input::Message(m) => m,
            Input::Frame(f) => match f.decode() {
                Ok(m) => {
                    decoded = m;
                    &decoded
                }
                Err(_) => {
                    *self.stats.decode_failures.entry(msgid).or_default() += 1;
                    return false;
                }
            },
        };
        self.stats.decoded += 1;
        let values = self.sources[si].values[slot].get_or_insert_with(Vec::new);
        if !fields::extract(msg, values, &mut self.enum_names) {
            *self.stats.decode_failures.entry(msgid).or_default() += 1;
            return false;
        }
        if slot == HEARTBEAT_SLOT {
            self.classify(si, msg);
        }
        if let MavMessage::STATUSTEXT(st) = msg {
            return self.join_statustext(si, slot, st);
        }
        true
    }

    /// A STATUSTEXT chunk (MAVLink 2's `id`, `chunk_seq`): the rules read
    /// the whole text on its last chunk, and nothing before (false: the
    /// rules reading it are not evaluated, the frame still counts as heard).
    fn join_statustext(&mut self, si: usize, slot: usize, st: &STATUSTEXT_DATA) -> bool {
        let text = String::from_utf8_lossy(&st.text[..]);
        let (text, last) = match text.find('\0') {
            Some(end) => (&text[..end], true),
            None => (&text[..], false),
        };
        match self.sources[si]
            .statustext
            .push(st.id, st.chunk_seq, text, last)
        {
            Piece::Whole => true,
            Piece::Pending => false,
            Piece::Joined(whole) => {
                if let (Some(at), Some(values)) =
                    (self.statustext_text, self.sources[si].values[slot].as_mut())
                {
                    if let Some(field) = values.get_mut(at) {
                        *field = Field::Str(whole);
                    }
                }
                true
            }
        }
    }

    fn classify(&mut self, si: usize, msg: &MavMessage) {
        let MavMessage::HEARTBEAT(hb) = msg else {
            return;
        };
        let autopilot = hb.autopilot as i64;
        let mav_type = hb.mavtype as i64;
        const INVALID: i64 =
            mavlink::dialects::ardupilotmega::MavAutopilot::MAV_AUTOPILOT_INVALID as i64;
        const GCS: i64 = mavlink::dialects::ardupilotmega::MavType::MAV_TYPE_GCS as i64;
        let forced = self.config.firmware;
        let src = &mut self.sources[si];
        src.custom_mode = Some(hb.custom_mode);
        src.firmware = forced.unwrap_or_else(|| Firmware::from_heartbeat(autopilot, mav_type));
        src.kind = if mav_type == GCS {
            Kind::Gcs
        } else if autopilot != INVALID {
            Kind::Autopilot
        } else {
            Kind::Other
        };
        if self.vehicle.is_none() && src.kind == Kind::Autopilot {
            let sys_ok = self.config.sysid.is_none_or(|s| s == src.sysid);
            let comp_ok = self.config.compid.is_none_or(|c| c == src.compid);
            if sys_ok && comp_ok {
                self.vehicle = Some((src.sysid, src.compid));
            }
        }
    }

    fn matches(&self, filter: &SourceFilter, si: usize) -> bool {
        let s = &self.sources[si];
        match *filter {
            SourceFilter::Autopilot => self.vehicle == Some((s.sysid, s.compid)),
            SourceFilter::Vehicle => self.vehicle.is_some_and(|(sys, _)| sys == s.sysid),
            SourceFilter::Gcs => s.kind == Kind::Gcs,
            SourceFilter::Any => true,
            SourceFilter::Ids { sysid, compid } => {
                sysid.is_none_or(|x| x == s.sysid) && compid.is_none_or(|x| x == s.compid)
            }
        }
    }

    /// Evaluates rule `r` for source `si`, on a message of `trigger`'s slot
    /// or (`None`) on a tick.
    fn evaluate(&mut self, r: usize, si: usize, trigger: Option<usize>) {
        let profile = &self.profile;
        let rule = &profile.rules[r];
        let now = self.now;
        let Some(slot) = trigger.filter(|_| rule.each) else {
            if !rule.each {
                self.evaluate_state(r, si, trigger);
            }
            return;
        };
        let src = &mut self.sources[si];
        let mut cx = Cx { src, profile, now };
        // Re-armed when `clear` becomes true after having been false at or
        // since the last event.
        let mut clear_now = None;
        if let (true, Some(clear)) = (rule.distinct > 0, &rule.clear) {
            clear_now = expr::eval(&clear.node, &mut cx).truth();
            let state = &mut cx.src.rules[r];
            match clear_now {
                Some(false) => state.clear_was_false = true,
                Some(true) if state.clear_was_false => {
                    state.last_params.clear();
                    state.clear_was_false = false;
                }
                _ => {}
            }
        }
        // An each rule fires on the messages its condition reads; one that
        // only `clear` reads re-arms it, nothing more.
        if !rule.fires_on(slot) {
            return;
        }
        if expr::eval(&rule.when.node, &mut cx).truth() != Some(true) {
            return;
        }
        let params = params(rule, &mut cx);
        if rule.distinct > 0 {
            let state = &mut cx.src.rules[r];
            if state.last_params.contains(&params) {
                return;
            }
            if state.last_params.len() >= rule.distinct {
                state.last_params.remove(0);
            }
            state.last_params.push(params.clone());
            // `clear` false at this very message counts as "since".
            state.clear_was_false = clear_now == Some(false);
        }
        let (sysid, compid, boot_us) = (cx.src.sysid, cx.src.compid, cx.src.boot_at(now));
        let reboot = rule.reboot;
        self.events.push_back(Elaborated {
            time_us: now,
            event: Event {
                name: rule.event.clone(),
                category: rule.category,
                params,
            },
            sysid,
            compid,
            boot_us,
            rule: Some(r),
        });
        if reboot {
            self.forget_boot(si, slot);
        }
    }

    /// The sender rebooted (a `reboot` rule fired on a message of `slot`):
    /// what elaboration remembers of its previous boot is no baseline for
    /// the new one. Forgotten: the sequence number (its restart is no
    /// loss), the last values of every other message (a rule waits for
    /// fresh ones rather than judge the new boot by the old one's GPS fix
    /// or battery), the holds under way (`for`, `clear_for`) and the
    /// repeats `distinct` rules remember (a pre-arm failure after a reboot
    /// is news). Kept: liveness (the sender never stopped talking: no link
    /// loss is invented), and each rule's state, so that a real change
    /// across the reboot (armed before, disarmed after) is announced as
    /// the change it is.
    fn forget_boot(&mut self, si: usize, slot: usize) {
        let src = &mut self.sources[si];
        // The frame that shows the reboot restarted the sequence numbers:
        // the gap it seemed to leave is no loss either.
        let (lost, loss_before) = self.this_frame;
        self.stats.sequence_lost = self.stats.sequence_lost.saturating_sub(lost);
        src.loss = loss_before;
        for (i, values) in src.values.iter_mut().enumerate() {
            if i != slot {
                *values = None;
            }
        }
        for state in &mut src.rules {
            state.pending_since = None;
            state.clearing_since = None;
            state.last_params.clear();
            state.clear_was_false = false;
        }
        self.stats.reboots += 1;
    }

    /// Evaluates a rule that is not `each`: edges, durations, clearing; on
    /// a message of `trigger`'s slot or (`None`) on a tick. A rule with
    /// `on` evaluates `when` on its `on` messages only: on another message
    /// (one its `clear` reads) only an active rule's explicit `clear` is.
    fn evaluate_state(&mut self, r: usize, si: usize, trigger: Option<usize>) {
        let profile = &self.profile;
        let rule = &profile.rules[r];
        let now = self.now;
        let src = &mut self.sources[si];
        let mut cx = Cx { src, profile, now };
        let cond = if trigger.is_none_or(|slot| rule.when_on(slot)) {
            match expr::eval(&rule.when.node, &mut cx).truth() {
                Some(c) => Some(c),
                None => return,
            }
        } else {
            let state = &cx.src.rules[r];
            if !(state.initialized && state.active && rule.clear.is_some()) {
                return;
            }
            None
        };
        let state = &mut cx.src.rules[r];
        let mut fire = false;
        let mut clear_fire = false;
        if let (false, Some(cond)) = (state.initialized, cond) {
            state.initialized = true;
            if cond && !rule.initial {
                state.active = true;
                state.announced = false;
            } else if cond {
                fire = rule.for_us == 0;
                state.pending_since = (rule.for_us > 0).then_some(now);
            }
        } else if let (false, Some(cond)) = (state.active, cond) {
            if cond {
                let since = *state.pending_since.get_or_insert(now);
                fire = now.saturating_sub(since) >= rule.for_us;
            } else {
                state.pending_since = None;
            }
        } else {
            let cleared = match &rule.clear {
                Some(c) => {
                    let v = expr::eval(&c.node, &mut cx).truth();
                    match v {
                        Some(v) => v,
                        None => return,
                    }
                }
                None => match cond {
                    Some(cond) => !cond,
                    None => return,
                },
            };
            let state = &mut cx.src.rules[r];
            if cleared {
                let since = *state.clearing_since.get_or_insert(now);
                if now.saturating_sub(since) >= rule.clear_for_us {
                    state.active = false;
                    state.pending_since = None;
                    state.clearing_since = None;
                    clear_fire = rule.cleared.is_some() && state.announced;
                }
            } else {
                state.clearing_since = None;
            }
        }
        if fire {
            let state = &mut cx.src.rules[r];
            state.active = true;
            state.announced = true;
            state.pending_since = None;
            state.clearing_since = None;
            let params = params(rule, &mut cx);
            let (sysid, compid, boot_us) = (cx.src.sysid, cx.src.compid, cx.src.boot_at(now));
            self.events.push_back(Elaborated {
                time_us: now,
                event: Event {
                    name: rule.event.clone(),
                    category: rule.category,
                    params,
                },
                sysid,
                compid,
                boot_us,
                rule: Some(r),
            });
        }
        if clear_fire {
            if let Some((name, category)) = &rule.cleared {
                let (sysid, compid, boot_us) = (cx.src.sysid, cx.src.compid, cx.src.boot_at(now));
                let params = Params::new();
                self.events.push_back(Elaborated {
                    time_us: now,
                    event: Event {
                        name: name.clone(),
                        category: *category,
                        params,
                    },
                    sysid,
                    compid,
                    boot_us,
                    rule: Some(r),
                });
            }
        }
    }
}

fn params(rule: &Rule, cx: &mut Cx) -> Params {
    let mut out = Params::new();
    expr::captures(&rule.when.node, cx, &mut out);
    for (name, c) in &rule.params {
        if let Some(v) = expr::eval(&c.node, cx).to_value() {
            out.insert(name.clone(), v);
        }
    }
    out
}

enum Input<'a, 'b> {
    Frame(&'a Frame<'b>),
    Message(&'a MavMessage),
}

struct Cx<'a> {
    src: &'a mut Source,
    profile: &'a Profile,
    now: u64,
}

impl Context for Cx<'_> {
    fn field(&self, slot: usize, field: usize, index: Option<usize>) -> V<'_> {
        let Some(values) = &self.src.values[slot] else {
            return V::Missing;
        };
        match (values.get(field), index) {
            (Some(Field::Int(i)), None) => V::Int(*i),
            (Some(Field::Float(f)), None) => V::Float(*f),
            (Some(Field::Str(s)), None) => V::Str(s.as_str().into()),
            (Some(Field::List(l)), Some(i)) => match l.get(i) {
                Some(x) if x.fract() == 0.0 && x.abs() < 9e15 => V::Int(*x as i64),
                Some(x) => V::Float(*x),
                None => V::Missing,
            },
            (Some(Field::Str(s)), Some(i)) => s
                .chars()
                .nth(i)
                .map(|c| V::Int(c as i64))
                .unwrap_or(V::Missing),
            _ => V::Missing,
        }
    }

    fn age(&self, slot: usize) -> f64 {
        let last = self.src.last_by_slot[slot].unwrap_or(self.src.first_us);
        self.now.saturating_sub(last) as f64 / 1e6
    }

    fn seen(&self, slot: usize) -> bool {
        self.src.last_by_slot[slot].is_some()
    }

    fn call(&self, func: Func) -> V<'static> {
        match func {
            Func::Mode => match self.src.custom_mode {
                Some(m) => V::Str(mode_name(self.src.firmware, m).into()),
                None => V::Missing,
            },
            Func::Firmware => match self.src.custom_mode {
                Some(_) => V::Str(self.src.firmware.as_str().into()),
                None => V::Missing,
            },
            Func::Loss => V::Float((self.src.loss * 1000.0).round() / 10.0),
            Func::SysId => V::Int(self.src.sysid as i64),
            Func::CompId => V::Int(self.src.compid as i64),
        }
    }

    fn regex(&self, regex: usize) -> &regex::Regex {
        &self.profile.regexes[regex]
    }

    fn memo(&mut self, memo: usize) -> &mut V<'static> {
        &mut self.src.memos[memo]
    }
}
