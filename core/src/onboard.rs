//! The gateway's core on board: every decision `petrel run` takes once
//! everything is loaded, with no socket, thread or clock (as quinn-proto
//! is to quinn). Feed it the frames each link received, ticks when
//! [`Onboard::poll_timeout`] comes, the programs' outcomes and events,
//! each with its time; poll it for the frames to send
//! ([`Onboard::poll_transmit`]: the commanders' commands first, then the
//! downlink's records), the calls for the programs
//! ([`Onboard::poll_call`]) and the steps carried out, to print and
//! record ([`Onboard::poll_settled`]). `cli/run/gateway.rs` only moves
//! bytes, records and prints.
//!
//! The order is the one that keeps a command's latency short: after an
//! input, send what [`Onboard::poll_transmit`] gives (the commanders'
//! outcomes it meets are fed to the player meanwhile), then
//! [`Onboard::settle`] (the steps become records for the mirror and
//! settled steps for the driver), then [`Onboard::publish`] and send again.

use std::collections::VecDeque;
use std::sync::Arc;

use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::MavHeader;
use nets::player::Digest;
use nets::{Effect, Event, Micros, Outcome, Player, Project};

use crate::frame::Received;
use crate::mirror::dialog::AnswerGate;
use crate::mirror::publisher::{Config as PublisherConfig, Publisher};
use crate::mirror::tunnel::Tunnel;
use crate::mirror::upload::{Config as UploadConfig, Receiver};
use crate::mirror::Unread;
use crate::signing::Key;
use crate::supervisor::{self, Step, Supervisor};
use crate::vehicle::commander::Commander;
use crate::vehicle::crew::{self, Crew};
use crate::vehicle::parameters::Verdict;
use crate::version::{Files, Proof, Proved, Report, Version, Versions};

/// Elaboration timeouts and link loss are evaluated at least this often
/// when no frame arrives.
pub const TICK: Micros = 100_000;

/// Telemetry rate asked for every message a profile reads.
pub const TELEMETRY_HZ: f32 = 4.0;

/// One commander per vehicle of `project` (`base`: the `[gateway]`
/// settings), on its link (`link_of`, by vehicle; link 0 when not given),
/// asking its autopilot for what its lane's profile reads.
pub fn crew(
    project: &Project,
    base: &crate::vehicle::config::VehicleConfig,
    lanes: &[supervisor::Lane],
    link_of: &[usize],
) -> Crew {
    let members = crate::team::commanders(project, base)
        .into_iter()
        .zip(lanes)
        .enumerate()
        .map(|(v, (config, lane))| {
            let messages: Vec<(u32, f32)> = lane
                .profile
                .telemetry()
                .into_iter()
                .filter(|&id| id != 0) // HEARTBEAT always comes
                .map(|id| (id, TELEMETRY_HZ))
                .collect();
            let mut commander = Commander::new(config);
            commander.request_streams(&messages, 0);
            crew::Member {
                name: lane.vehicle.clone(),
                link: link_of.get(v).copied().unwrap_or(0),
                commander,
            }
        })
        .collect();
    Crew::new(members)
}

/// The mirror's downlink, when on.
pub struct DownlinkConfig {
    /// This run's session number (a mirror tells a restart from a gap).
    pub session: u32,
    /// The mirror's system id.
    pub mirror: u8,
    /// The events left out of the records when they change nothing.
    pub unread: Unread,
}

/// A supervisor input, owned: what a settled step was fed.
#[derive(Debug, Clone)]
pub enum Input {
    /// A frame and the link it came in on.
    Frame(Vec<u8>, usize),
    Tick,
    Result {
        id: u64,
        outcome: Outcome,
    },
    Event(Event),
    Answer {
        id: u64,
        choice: String,
    },
    /// A new version of the project takes over.
    Version(Arc<Version>),
}

impl Input {
    /// As the supervisor takes it.
    pub fn as_supervisor(&self) -> supervisor::Input<'_> {
        match self {
            Input::Frame(bytes, _) => supervisor::Input::Frame(bytes),
            Input::Tick => supervisor::Input::Tick,
            Input::Result { id, outcome } => supervisor::Input::Result {
                id: *id,
                outcome: outcome.clone(),
            },
            Input::Event(e) => supervisor::Input::Event(e.clone()),
            Input::Answer { id, choice } => supervisor::Input::Answer {
                id: *id,
                choice: choice.clone(),
            },
            Input::Version(v) => supervisor::Input::Version(v),
        }
    }
}

/// A step carried out, to print and record.
pub struct Settled {
    pub input: Input,
    pub step: Step,
    /// The player's digest right after the step (when recording or
    /// publishing).
    pub digest: Option<Digest>,
}

/// A step carried out, not yet settled.
struct Done {
    settled: Settled,
    /// The player's time before the step.
    before: Micros,
}

/// A frame to send.
#[derive(Debug)]
pub enum Transmit {
    /// A commander's message, from (`from`) on link `link`.
    Command(Box<crew::Transmit>),
    /// A downlink record for the mirror, from the gateway's identity on
    /// the first vehicle's link.
    Downlink {
        link: usize,
        from: (u8, u8),
        tunnel: Tunnel,
    },
}

struct Downlink {
    publisher: Publisher,
    unread: Unread,
    mirror: u8,
}

/// The gateway's state on board.
pub struct Onboard {
    supervisor: Supervisor,
    crew: Crew,
    downlink: Option<Downlink>,
    /// Judges the operator's answers (`None`: no operator key, every
    /// answer rejected).
    answers: Option<AnswerGate>,
    /// Every step's digest is wanted (a recording).
    digests: bool,
    next_tick: Micros,
    done: Vec<Done>,
    settled: VecDeque<Settled>,
    calls: VecDeque<Effect>,
    downlink_out: VecDeque<Transmit>,
    /// New versions of the project offered in flight.
    versions: Versions,
    /// Versions sent up from the ground (`mirror::upload`), and the
    /// upload each offered version came from.
    uploads: Receiver,
    uploaded: std::collections::BTreeMap<u32, u64>,
    said_no_key: bool,
    /// Frames received, events elaborated.
    pub frames: u64,
    pub events: u64,
}

impl Onboard {
    /// The core around a started supervisor and its crew. `digests`: every
    /// step's digest is wanted (a recording).
    pub fn new(
        supervisor: Supervisor,
        crew: Crew,
        downlink: Option<DownlinkConfig>,
        operator: Option<Key>,
        digests: bool,
    ) -> Onboard {
        Onboard {
            supervisor,
            crew,
            downlink: downlink.map(|d| Downlink {
                publisher: Publisher::new(d.session, PublisherConfig::default(), 0),
                unread: d.unread,
                mirror: d.mirror,
            }),
            answers: operator.map(AnswerGate::new),
            digests,
            next_tick: TICK,
            done: Vec::new(),
            settled: VecDeque::new(),
            calls: VecDeque::new(),
            downlink_out: VecDeque::new(),
            versions: Versions::default(),
            uploads: Receiver::new(UploadConfig::default()),
            uploaded: std::collections::BTreeMap::new(),
            said_no_key: false,
            frames: 0,
            events: 0,
        }
    }

    /// The start step's effects (commands to the crew, calls queued), at
    /// `now`.
    pub fn start(&mut self, now: Micros, start: &Step) {
        for e in &start.effects {
            self.effect(now, e);
        }
    }

    /// A frame received on link `link`, its step at its receive time, at
    /// `now` (`unix_us`: the wall clock's UNIX time, for the operator's
    /// signatures): to the commanders on that link, then to the
    /// supervisor.
    ///
    /// The frame is parsed once, by the link: its decoded message goes to
    /// the commanders and to elaboration as it is; only a frame the dialect
    /// did not decode is elaborated from its bytes (and a TUNNEL, whose
    /// payload type rust-mavlink's enum may refuse, read from them).
    pub fn handle_frame(&mut self, now: Micros, link: usize, rx: Received, unix_us: u64) {
        self.frames += 1;
        let tunnel = rx
            .message
            .as_ref()
            .is_none_or(|m| matches!(m, MavMessage::TUNNEL(_)));
        if tunnel && self.crew.members().first().map(|m| m.link) == Some(link) {
            self.uplink(now, &rx.bytes, unix_us);
        }
        if let Some(message) = &rx.message {
            self.crew.message(link, rx.time_us, &rx.header, message);
        }
        let decoded = rx.message.as_ref().map(|m| (&rx.header, m));
        let input = Input::Frame(rx.bytes, link);
        self.feed_heard(now, rx.time_us, input, decoded);
    }

    /// A message for the commanders only (the upload grace at the end,
    /// when the supervisor is done).
    pub fn handle_vehicle_message(
        &mut self,
        link: usize,
        time: Micros,
        header: &MavHeader,
        message: &MavMessage,
    ) {
        self.crew.message(link, time, header, message);
    }

    /// When [`Self::handle_timeout`] is due: the next tick, the player's
    /// next timer, the commanders' next retry.
    pub fn poll_timeout(&self) -> Micros {
        [
            Some(self.next_tick),
            self.supervisor.next_deadline(),
            self.crew.next_deadline(),
        ]
        .into_iter()
        .flatten()
        .min()
        .unwrap_or(self.next_tick)
    }

    /// Time passes at `now`: the commanders' timers, then a tick of the
    /// supervisor.
    pub fn handle_timeout(&mut self, now: Micros) {
        self.crew.tick(now);
        self.uploads.tick(now);
        if now >= self.next_tick {
            self.next_tick = now - now % TICK + TICK;
        }
        self.feed(now, now, Input::Tick);
    }

    /// The commanders' timers alone (the upload grace at the end).
    pub fn tick_commanders(&mut self, now: Micros) {
        self.crew.tick(now);
    }

    /// A program's outcome of call `id`, at `now`.
    pub fn handle_result(&mut self, now: Micros, id: u64, outcome: Outcome) {
        self.feed(now, now, Input::Result { id, outcome });
    }

    /// An event from a program or the link (a program lost, signatures
    /// refused), at `now`.
    pub fn handle_event(&mut self, now: Micros, event: Event) {
        self.feed(now, now, Input::Event(event));
    }

    /// The next frame to send: the commanders' first; their outcomes met
    /// on the way are fed to the player (at `now`), which may command
    /// again; then the downlink's (after [`Self::publish`]).
    pub fn poll_transmit(&mut self, now: Micros) -> Option<Transmit> {
        loop {
            if let Some(t) = self.crew.poll_transmit() {
                return Some(Transmit::Command(Box::new(t)));
            }
            match self.crew.poll_outcome() {
                Some((id, outcome)) => self.feed(now, now, Input::Result { id, outcome }),
                None => return self.downlink_out.pop_front(),
            }
        }
    }

    /// The next call or forgotten call for the programs.
    pub fn poll_call(&mut self) -> Option<Effect> {
        self.calls.pop_front()
    }

    /// The steps carried out since the last call become records for the
    /// mirror and settled steps ([`Self::poll_settled`]), in order.
    pub fn settle(&mut self) {
        for Done { settled, before } in std::mem::take(&mut self.done) {
            if let (Some(d), Some(digest)) = (&mut self.downlink, &settled.digest) {
                if let Some(inputs) = crate::mirror::step_inputs(
                    &settled.input.as_supervisor(),
                    &settled.step,
                    &d.unread,
                ) {
                    d.publisher
                        .step(settled.step.seq, before, settled.step.time, inputs, digest);
                }
            }
            self.events += settled.step.events.len() as u64;
            self.settled.push_back(settled);
        }
    }

    /// The next step settled, to print and record.
    pub fn poll_settled(&mut self) -> Option<Settled> {
        self.settled.pop_front()
    }

    /// The downlink's heartbeat and snapshots when due at `now`, and every
    /// packet the publisher has, queued for [`Self::poll_transmit`].
    pub fn publish(&mut self, now: Micros) {
        let me = self.crew.first().and_then(Commander::identity);
        let link = self.crew.members().first().map_or(0, |m| m.link);
        let (Some(d), Some(me)) = (&mut self.downlink, me) else {
            return;
        };
        while let Some(record) = self.uploads.poll_downlink() {
            d.publisher.say(record);
        }
        d.publisher.autopilot_clocks(self.supervisor.boots());
        d.publisher
            .tick(now, self.supervisor.seq(), self.supervisor.player());
        while let Some(payload) = d.publisher.poll_transmit() {
            self.downlink_out.push_back(Transmit::Downlink {
                link,
                from: me,
                tunnel: Tunnel::petrel((d.mirror, 0), payload),
            });
        }
    }

    /// A new version of the project, loaded (and checked from its own
    /// start) by the driver: its proof from the running state is queued
    /// for [`Self::poll_proof`]; a version still being proved is given up
    /// for it. What became of it comes out of [`Self::poll_version`].
    pub fn offer_version(&mut self, project: Arc<Project>, files: Files) {
        self.versions
            .offer(project, files, self.supervisor.player());
    }

    /// The next proof for the driver to run beside the supervision
    /// ([`Proof::run`]; it may take seconds) and hand back to
    /// [`Self::handle_proved`].
    pub fn poll_proof(&mut self) -> Option<Proof> {
        self.versions.poll_proof()
    }

    /// A proof's answer, at `now`: the version takes over in a step of its
    /// own if it holds for the state the player is in now, else it is
    /// proved again (from the state as it is) or refused.
    pub fn handle_proved(&mut self, now: Micros, proved: Proved) {
        let Some(version) = self.versions.proved(proved, self.supervisor.player()) else {
            return;
        };
        self.feed(now, now, Input::Version(version.clone()));
        let refused = std::mem::take(&mut self.supervisor.version_refused);
        if let (Some(d), true) = (&mut self.downlink, refused.is_empty()) {
            d.publisher.version(version.number, version.digest());
        }
        self.versions
            .took_over(&version, self.supervisor.seq(), refused);
    }

    /// What became of the versions offered, in order (a version sent up
    /// from the ground has its verdict said down too).
    pub fn poll_version(&mut self) -> Option<Report> {
        let report = self.versions.poll_report()?;
        let settled = match &report {
            Report::Swapped { number, .. }
            | Report::Refused { number, .. }
            | Report::Superseded { number, .. } => Some(*number),
            _ => None,
        };
        if let Some(upload) = settled.and_then(|n| self.uploaded.remove(&n)) {
            self.uploads.verdict(upload, &report.to_string());
        }
        Some(report)
    }

    /// The next version sent up whole from the ground, its bytes' digest
    /// checked: `(upload, bytes)`, for the driver to load and check off
    /// the loop, then [`Self::offer_uploaded`] or [`Self::upload_refused`].
    pub fn poll_upload(&mut self) -> Option<(u64, Vec<u8>)> {
        self.uploads.poll_complete()
    }

    /// Upload `upload` loaded and checked: offered as a new version, whose
    /// verdict goes down to the ground.
    pub fn offer_uploaded(&mut self, upload: u64, project: Arc<Project>, files: Files) {
        self.uploaded.insert(self.versions.next_number(), upload);
        self.offer_version(project, files);
    }

    /// Upload `upload` does not load or fails its check: why, said down.
    pub fn upload_refused(&mut self, upload: u64, why: &str) {
        self.uploads.verdict(upload, &format!("refused: {why}"));
    }

    /// What the upload receiver counted.
    pub fn upload_counts(&self) -> &crate::mirror::upload::Counts {
        &self.uploads.counts
    }

    /// The running version's number (0: the one the run started with) and
    /// whether another is being proved.
    pub fn version(&self) -> (u32, bool) {
        (self.versions.current(), self.versions.pending())
    }

    /// A vehicle's parameters judged (`[gateway.parameters]`): its index
    /// in the crew and the verdict.
    pub fn poll_parameters(&mut self) -> Option<(usize, Verdict)> {
        self.crew.poll_parameters()
    }

    /// A mission upload or another exchange is under way.
    pub fn busy(&self) -> bool {
        self.crew.busy()
    }

    pub fn crew(&self) -> &Crew {
        &self.crew
    }

    pub fn supervisor(&self) -> &Supervisor {
        &self.supervisor
    }

    pub fn player(&self) -> &Player {
        self.supervisor.player()
    }

    pub fn project(&self) -> &Arc<Project> {
        self.supervisor.player().project()
    }

    pub fn answers(&self) -> Option<&AnswerGate> {
        self.answers.as_ref()
    }

    /// Steps the supervisor at `time` and carries out the step's effects
    /// at `now`: commands go to the commanders (sent by the next
    /// `poll_transmit`), calls to the queue; the digest is taken now, as
    /// it must be.
    fn feed(&mut self, now: Micros, time: Micros, input: Input) {
        self.feed_heard(now, time, input, None);
    }

    /// [`Self::feed`], a frame's message elaborated as decoded when given.
    fn feed_heard(
        &mut self,
        now: Micros,
        time: Micros,
        input: Input,
        decoded: Option<(&MavHeader, &MavMessage)>,
    ) {
        let before = self.supervisor.player().state().now;
        let step = match decoded {
            Some((header, message)) => self.supervisor.step_message(time, header, message),
            None => self.supervisor.step(time, input.as_supervisor()),
        };
        for e in &step.effects {
            self.effect(now, e);
        }
        for (_, effects) in &step.events {
            for e in effects {
                self.effect(now, e);
            }
        }
        let published = self.downlink.is_some()
            && (!step.events.is_empty()
                || matches!(
                    input,
                    Input::Result { .. }
                        | Input::Event(_)
                        | Input::Answer { .. }
                        | Input::Version(_)
                ));
        let digest = (self.digests || published).then(|| self.supervisor.player().digest());
        self.done.push(Done {
            settled: Settled {
                input,
                step,
                digest,
            },
            before,
        });
    }

    fn effect(&mut self, now: Micros, effect: &Effect) {
        match effect {
            Effect::Command {
                id,
                verb,
                args,
                vehicle,
                ..
            } => self.crew.command(*id, *vehicle, verb, args, now),
            Effect::Forgotten { id, .. } => {
                self.crew.forget(*id);
                self.calls.push_back(effect.clone());
            }
            Effect::Call { .. } => self.calls.push_back(effect.clone()),
            _ => {}
        }
    }

    /// A frame from the mirror: a resync request to the publisher, or an
    /// operator's answer.
    fn uplink(&mut self, now: Micros, bytes: &[u8], unix_us: u64) {
        let me = self.crew.first().and_then(Commander::identity);
        let (Some(d), Some(me)) = (&mut self.downlink, me) else {
            return;
        };
        let Ok(frame) = elaboration::Frame::parse(bytes) else {
            return;
        };
        if let Some(t) = Tunnel::from_frame(&frame) {
            if (t.target_system, t.target_component) == me {
                if crate::mirror::dialog::is_answer(&t.payload) {
                    self.answer(now, bytes, unix_us);
                } else if crate::mirror::dialog::is_upload(&t.payload) {
                    self.upload(now, bytes, unix_us);
                } else {
                    d.publisher.receive(&t.payload);
                }
            }
        }
    }

    /// A piece of a version sent up from the ground (`mirror::upload`):
    /// judged by the operator's gate, as an answer is, then to the
    /// receiver.
    fn upload(&mut self, now: Micros, bytes: &[u8], unix_us: u64) {
        let Some(gate) = &mut self.answers else {
            if !std::mem::replace(&mut self.said_no_key, true) {
                tracing::warn!("an upload from the ground rejected: no --operator-key (said once)");
            }
            return;
        };
        match gate.judge_upload(bytes, unix_us) {
            Ok(records) => {
                for r in records {
                    self.uploads.handle(now, r);
                }
            }
            Err(why) => tracing::warn!("an upload from the ground rejected: {}", why.as_str()),
        }
    }

    /// An operator's answer (mirror::dialog): judged by the gate, then, if
    /// let through, an input of the player like any other (published down).
    fn answer(&mut self, now: Micros, bytes: &[u8], unix_us: u64) {
        let Some(gate) = &mut self.answers else {
            tracing::warn!("an operator's answer rejected: no --operator-key");
            return;
        };
        let (id, choice) = match gate.judge_bytes(bytes, unix_us) {
            Ok(answer) => answer,
            Err(why) => {
                tracing::warn!("an operator's answer rejected: {}", why.as_str());
                return;
            }
        };
        self.feed(now, now, Input::Answer { id, choice });
        let verdict = self
            .done
            .last()
            .and_then(|d| crate::mirror::dialog::verdict(&d.settled.step.effects, id));
        if let (Some(gate), Some(v)) = (&mut self.answers, verdict) {
            gate.delivered(v);
            if let Err(why) = v {
                tracing::warn!("the operator's answer to #{id} refused: {}", why.as_str());
            }
        }
    }
}

#[cfg(test)]
#[path = "onboard_tests.rs"]
mod tests;
