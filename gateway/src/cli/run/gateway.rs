//! `run`'s loop: the gateway on board once everything is loaded — the
//! links read, the supervisor stepped, the commanders and programs carrying
//! out its effects, steps printed and recorded after the commands are out.

use std::io::Write;
use std::sync::Arc;
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::MavMessage;
use nets::{Effect, Micros, Project};
use serde_json::json;
use tokio::sync::mpsc;

use super::autopilot::{adopt, identify};
use super::parameters::parameters_fit;
use super::signals::Signals;
use super::timeline::Timeline;
use super::{
    elaboration_config, links, Setup, SILENCE_WARNING, TELEMETRY_HZ, TICK, TIMESTAMP_PERSIST,
    UPLOAD_GRACE,
};
use crate::cli::{Outcome, VerbResult};
use crate::clock::Clock;
use crate::link::{LinkWriter, Received};
use crate::mirror::dialog::AnswerGate;
use crate::mirror::publisher::{Config as PublisherConfig, Publisher};
use crate::mirror::tunnel::{Tunnel, PAYLOAD_TYPE};
use crate::programs::server::{Direction, ProgramInput, Programs};
use crate::record::recorder::{Options as RecordOptions, Recorder};
use crate::supervisor::{Input, Step, Supervisor};
use crate::vehicle::commander::Commander;
use crate::vehicle::crew::{Crew, Member};

pub(super) struct Gateway {
    clock: Clock,
    project: Arc<Project>,
    supervisor: Supervisor,
    /// One commander per vehicle, each on its link.
    crew: Crew,
    programs: Option<Programs>,
    /// One writer per link (`team::links` order).
    writers: Vec<LinkWriter>,
    recorder: Option<Recorder>,
    downlink: Option<Downlink>,
    /// Judges the operator's answers (`None`: no `--operator-key`, every
    /// answer rejected).
    answers: Option<AnswerGate>,
    /// The web monitor: fed in `settle`, served on its own thread.
    monitor: Option<(crate::monitor::Feed, crate::monitor::Server)>,
    /// Steps carried out but not yet printed and recorded (see `feed`).
    done: Vec<Done>,
    frames: u64,
    events: u64,
    out: Timeline<std::io::BufWriter<Box<dyn Write + Send>>>,
}

/// The mirror's downlink on board.
struct Downlink {
    publisher: Publisher,
    /// The events left out of the records when they change nothing.
    unread: crate::mirror::Unread,
    /// The mirror's system id.
    mirror: u8,
}

/// A step carried out, waiting to be printed and recorded.
struct Done {
    input: Owned,
    step: Step,
    /// The player's time before the step.
    before: Micros,
    /// The player's digest right after the step (when recording).
    digest: Option<nets::player::Digest>,
}

/// A Supervisor input, owned.
enum Owned {
    /// A frame and the link it came in on.
    Frame(Vec<u8>, usize),
    Tick,
    Result {
        id: u64,
        outcome: nets::Outcome,
    },
    Event(nets::Event),
    Answer {
        id: u64,
        choice: String,
    },
}

impl Owned {
    fn input(&self) -> Input<'_> {
        match self {
            Owned::Frame(bytes, _) => Input::Frame(bytes),
            Owned::Tick => Input::Tick,
            Owned::Result { id, outcome } => Input::Result {
                id: *id,
                outcome: outcome.clone(),
            },
            Owned::Event(e) => Input::Event(e.clone()),
            Owned::Answer { id, choice } => Input::Answer {
                id: *id,
                choice: choice.clone(),
            },
        }
    }
}

impl Gateway {
    fn now(&self) -> Micros {
        self.clock.now()
    }

    /// Steps the supervisor and carries out the step's effects: commands go
    /// to the commander (sent by the next `pump`), calls to the programs.
    /// Printing and recording wait for `settle`, off the path from a frame
    /// to the command it causes; the digest is taken now, as it must be.
    fn feed(&mut self, time: Micros, input: Owned) {
        let before = self.supervisor.player().state().now;
        let step = self.supervisor.step(time, input.input());
        for e in &step.effects {
            self.effect(e);
        }
        for (_, effects) in &step.events {
            for e in effects {
                self.effect(e);
            }
        }
        let published = self.downlink.is_some()
            && (!step.events.is_empty()
                || matches!(
                    input,
                    Owned::Result { .. } | Owned::Event(_) | Owned::Answer { .. }
                ));
        let digest =
            (self.recorder.is_some() || published).then(|| self.supervisor.player().digest());
        self.done.push(Done {
            input,
            step,
            before,
            digest,
        });
    }

    /// Prints and records the steps carried out since the last call, in
    /// order, and flushes the timeline.
    fn settle(&mut self) {
        for Done {
            input,
            step,
            before,
            digest,
        } in std::mem::take(&mut self.done)
        {
            if let (Some(d), Some(digest)) = (&mut self.downlink, &digest) {
                if let Some(inputs) = crate::mirror::step_inputs(&input.input(), &step, &d.unread) {
                    d.publisher
                        .step(step.seq, before, step.time, inputs, digest);
                }
            }
            if let Owned::Event(event) = &input {
                let _ = self.out.event(&self.project, step.time, event, None);
            }
            let _ = self.out.effects(&self.project, &step.effects);
            for (event, effects) in &step.events {
                self.events += 1;
                let _ = self.out.event(
                    &self.project,
                    event.time_us,
                    &event.event,
                    Some(json!({"sysid": event.sysid, "compid": event.compid})),
                );
                let _ = self.out.effects(&self.project, effects);
            }
            if let Some((feed, _)) = &self.monitor {
                feed.step(&input.input(), &step, self.supervisor.player());
            }
            if let (Some(rec), Some(digest)) = (&self.recorder, digest) {
                // A team's frames say their link (one link: implied).
                let link = match &input {
                    Owned::Frame(_, link) if self.writers.len() > 1 => Some(*link),
                    _ => None,
                };
                rec.record_on(&input.input(), link, step, digest);
            }
        }
        if let Some((feed, _)) = &self.monitor {
            feed.publish();
        }
        let _ = self.out.out.flush();
    }

    pub(super) async fn run(mut setup: Setup) -> VerbResult {
        let origin = Instant::now();
        let clock = Clock::new(origin, setup.time_scale);
        if clock.scale() != 1.0 {
            say!(
                "the gateway's clock runs {}× faster than the wall (--time-scale)",
                clock.scale()
            );
        }
        // The recording's times count from the gateway's origin.
        let unix_ns = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as u64);
        // Said once if the vehicle stays silent this long after the link
        // opens (below).
        let silent_until = Instant::now() + SILENCE_WARNING;
        // Signals are watched from here on: a stop (systemd's SIGTERM)
        // while a `tcpin:` link waits for its client, or during the wait
        // for the autopilot, still ends cleanly.
        let mut signals = Signals::new()?;
        // Each link once, however many vehicles share it; a `tcpin:` link
        // waits for its client, within `--duration`.
        let opened = signals
            .or_stop(
                links::open(&setup, &clock),
                setup.duration.map(|d| origin + d),
            )
            .await;
        let opened = match opened {
            Ok(opened) => opened?,
            Err(stopped) => {
                say!(
                    "{}",
                    stopped.before_the_link("run", &setup.address, origin.elapsed())
                );
                return Ok(Outcome::Success);
            }
        };
        let links::Opened {
            addresses,
            link_of,
            mut readers,
            writers,
            rejections,
        } = opened;
        // Which autopilot, when the profile follows it: the frames read
        // meanwhile are fed once the supervisor runs, none lost.
        let mut told_early = false;
        let early = match setup.detect.take() {
            None => Vec::new(),
            Some(choice) => {
                // Within `--duration`: a run of 0.3 s is not held 3 s
                // waiting for an autopilot that is not there.
                let limit = clock
                    .wall(setup.vehicle.timing.link_timeout)
                    .max(Duration::from_secs(1));
                let limit = setup.duration.map_or(limit, |d| limit.min(d));
                let announce = (
                    setup
                        .project
                        .vehicles
                        .first()
                        .map(|v| v.system)
                        .or(setup.vehicle.system)
                        .unwrap_or(crate::vehicle::commander::ANNOUNCE_SYSTEM),
                    setup.vehicle.own_component(),
                );
                // The first link: the first vehicle's (all of them, but one
                // vehicle's own profile set, follow the autopilot heard).
                let (early, heard, stopped) =
                    identify(&mut readers[0], &writers[0], announce, limit, &mut signals).await;
                told_early |= stopped;
                adopt(&mut setup, &choice, heard)?;
                early
            }
        };
        // The program server listens only for a project that has programs.
        let (programs, mut inputs) = if setup.project.programs.is_empty() {
            (None, mpsc::channel(1).1)
        } else {
            let (p, i) = Programs::start(setup.project.clone(), &setup.dir, setup.programs)
                .await
                .map_err(|e| miette::miette!("{e}"))?;
            (Some(p), i)
        };
        // Each vehicle's elaboration: its profile and ids (one lane without
        // a team).
        let lanes = crate::team::lanes(
            &setup.project,
            &setup.dir,
            &setup.profile,
            crate::team::family(&setup.layers.layers),
            &elaboration_config(&setup.vehicle),
        )?;
        // The recording is created once the link and the program server
        // are open: a start that fails leaves no empty recording behind.
        let recorder = match &setup.record {
            None => None,
            Some(path) => {
                let options = RecordOptions {
                    clock_offset_ns: unix_ns,
                    profile: setup.layers.name.clone(),
                    profile_layers: setup.layers.layers.clone(),
                    config: lanes[0].config.clone(),
                    ..RecordOptions::default()
                };
                let rec = Recorder::create(path, setup.project.clone(), options)
                    .map_err(|e| miette::miette!("cannot record to {}: {e}", path.display()))?;
                say!("recording to {}", path.display());
                Some(rec)
            }
        };
        // One commander per vehicle, on its link, asking its autopilot for
        // what its profile reads.
        let configs = crate::team::commanders(&setup.project, &setup.vehicle);
        let members = configs
            .into_iter()
            .zip(&lanes)
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
                let link = link_of.get(v).copied().unwrap_or(0);
                Member {
                    name: lane.vehicle.clone(),
                    link,
                    commander,
                }
            })
            .collect();
        let unread = crate::mirror::Unread::of(&lanes);
        let (supervisor, start) = Supervisor::start_lanes(setup.project.clone(), lanes, 0);
        let mut gw = Gateway {
            clock,
            project: setup.project,
            supervisor,
            crew: Crew::new(members),
            programs,
            writers,
            recorder,
            downlink: setup.downlink.map(|mirror| Downlink {
                publisher: Publisher::new(session(), PublisherConfig::default(), 0),
                unread,
                mirror,
            }),
            answers: setup.operator.take().map(AnswerGate::new),
            monitor: None,
            done: Vec::new(),
            frames: 0,
            events: 0,
            out: Timeline {
                out: std::io::BufWriter::new(setup.out),
                json: setup.json,
                origin: 0,
            },
        };
        if let Some(rec) = &gw.recorder {
            rec.start(&start, gw.supervisor.player());
        }
        if let Some(address) = setup.http {
            let (project, player) = (gw.project.clone(), gw.supervisor.player());
            let monitor = crate::monitor::start_live(address, project, &setup.dir, &start, player)
                .map_err(|e| miette::miette!("cannot serve the monitor on {address}: {e}"))?;
            say!("monitor: http://{}/", monitor.1.address);
            gw.monitor = Some(monitor);
        }
        for e in &start.effects {
            gw.effect(e);
        }
        let _ = gw.out.effects(&gw.project, &start.effects);
        gw.pump().await;
        gw.settle();
        for rx in early {
            gw.frame(0, rx);
            gw.pump().await;
            gw.settle();
        }
        let stop_at = setup.duration.map(|d| origin + d);
        let stop = setup.stop.clone();
        let several = readers.len() > 1;
        let (mut frames, reader_tasks) = links::read(readers, &addresses);
        let mut next_tick = TICK;
        let mut refused = false;
        // Said once when the vehicle stays silent: nothing else tells a
        // user that the address, the router or the autopilot is wrong.
        let mut said_silent = vec![false; gw.crew.members().len()];
        let mut reporters: Vec<_> = rejections
            .iter()
            .map(|_| crate::link::rejections::Reporter::default())
            .collect();
        let timestamp_file = setup.signing.as_ref().map(|s| s.timestamp_file.clone());
        let mut persisted_at = Instant::now();
        loop {
            if told_early {
                break;
            }
            // Frames the signature checks dropped reach the nets as an event.
            for (reporter, rejections) in reporters.iter_mut().zip(&rejections) {
                if let Some(event) = reporter.poll(rejections, &gw.project, gw.now()) {
                    let now = gw.now();
                    gw.feed(now, Owned::Event(event));
                }
            }
            if let Some(file) = &timestamp_file {
                if persisted_at.elapsed() >= TIMESTAMP_PERSIST {
                    persisted_at = Instant::now();
                    links::persist_timestamps(file, &gw.writers);
                }
            }
            if Instant::now() >= silent_until {
                for (said, m) in said_silent.iter_mut().zip(gw.crew.members()) {
                    if *said || m.commander.heard() {
                        continue;
                    }
                    *said = true;
                    let (system, component) = m.commander.sender();
                    let vehicle = match &m.name {
                        Some(name) => format!("vehicle {name} not"),
                        None => "no vehicle".to_owned(),
                    };
                    say!(
                        "petrel: {vehicle} heard on {} after {} s; petrel sends its HEARTBEAT there as system {system}, component {component}. Check the address, that the router or autopilot sends telemetry to it, and the vehicle's system id.",
                        addresses[m.link],
                        SILENCE_WARNING.as_secs()
                    );
                }
            }
            let now = gw.now();
            let deadline = [
                Some(next_tick),
                gw.supervisor.next_deadline(),
                gw.crew.next_deadline(),
            ]
            .into_iter()
            .flatten()
            .min()
            .unwrap_or(next_tick);
            let sleep = tokio::time::sleep(gw.clock.wall(deadline.saturating_sub(now)));
            let until_stop = async {
                match stop_at {
                    Some(t) => tokio::time::sleep_until(t.into()).await,
                    None => std::future::pending().await,
                }
            };
            let told_to_stop = async {
                match &stop {
                    Some(n) => n.notified().await,
                    None => std::future::pending().await,
                }
            };
            tokio::select! {
                Some((link, rx)) = frames.recv() => gw.frame(link, rx),
                Some(input) = inputs.recv() => gw.program_input(input),
                _ = sleep => {
                    let now = gw.now();
                    gw.crew.tick(now);
                    if now >= next_tick {
                        next_tick = now - now % TICK + TICK;
                    }
                    gw.feed(now, Owned::Tick);
                }
                _ = signals.recv() => break,
                _ = until_stop => break,
                _ = told_to_stop => break,
            }
            gw.pump().await;
            gw.settle();
            gw.publish().await;
            if let Some((v, verdict)) = gw.crew.poll_parameters() {
                let member = &gw.crew.members()[v];
                let prefix = member
                    .name
                    .as_ref()
                    .map(|n| format!("vehicle {n}: "))
                    .unwrap_or_default();
                if !parameters_fit(&prefix, &verdict, member.commander.armed()) {
                    refused = true;
                    break;
                }
            }
        }
        // A mission upload under way gets a bounded time to finish.
        let grace = Instant::now() + UPLOAD_GRACE;
        // An interval, not a sleep made anew per turn: frames every few ms
        // would starve the commander's retries and timeouts.
        let mut ticks = tokio::time::interval(Duration::from_millis(20));
        ticks.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        while gw.crew.busy() && Instant::now() < grace {
            tokio::select! {
                Some((link, rx)) = frames.recv() => {
                    if let Some(message) = &rx.message {
                        gw.crew.message(link, rx.time_us, &rx.header, message);
                    }
                }
                _ = ticks.tick() => gw.crew.tick(gw.now()),
            }
            gw.pump().await;
            gw.settle();
        }
        for task in reader_tasks {
            task.abort();
        }
        if let Some(file) = &timestamp_file {
            links::persist_timestamps(file, &gw.writers);
        }
        for (rejections, address) in rejections.iter().zip(&addresses) {
            if let Some(summary) = rejections.summary() {
                if several {
                    say!("signatures on {address}: {summary}");
                } else {
                    say!("signatures: {summary}");
                }
            }
        }
        if let Some(gate) = &gw.answers {
            let rejected: Vec<String> = gate
                .rejected()
                .iter()
                .map(|(why, n)| format!("{n} {}", why.as_str()))
                .collect();
            say!(
                "operator answers: {} delivered, rejected: {}",
                gate.delivered_count(),
                if rejected.is_empty() {
                    "none".to_owned()
                } else {
                    rejected.join(", ")
                }
            );
        }
        let Gateway {
            programs,
            supervisor,
            mut out,
            frames,
            events,
            recorder,
            ..
        } = gw;
        if let Some(programs) = programs {
            programs.shutdown().await;
        }
        if let Some(rec) = recorder {
            let dropped = rec.dropped();
            match rec.finish() {
                Ok(report) if report.dropped > 0 => say!(
                    "recorded {} steps; the recorder fell behind and dropped {} entries ({} steps): replay stops at the first",
                    report.steps, report.dropped, report.dropped_steps
                ),
                Ok(report) => say!(
                    "recorded {} steps, {} messages",
                    report.steps, report.messages
                ),
                Err(e) => say!(
                    "the recording stopped in flight ({e}); {dropped} entries were not recorded"
                ),
            }
        }
        let player = supervisor.player();
        say!(
            "stopped after {:.1} s: {frames} frames, {events} events, {} bad frames, {} calls and commands unanswered",
            origin.elapsed().as_secs_f64(),
            supervisor.bad_frames,
            player.state().pending.len()
        );
        let _ = out.end(player.state().now, player);
        let _ = out.out.flush();
        Ok(if refused {
            Outcome::Failed
        } else {
            Outcome::Success
        })
    }

    /// A frame from link `link`: to the commanders on that link, then to
    /// the supervisor.
    fn frame(&mut self, link: usize, rx: Received) {
        self.frames += 1;
        if self.crew.members().first().map(|m| m.link) == Some(link) {
            self.uplink(&rx.bytes);
        }
        if let Some(message) = &rx.message {
            self.follow_vehicle_time(&rx.header, message);
            self.crew.message(link, rx.time_us, &rx.header, message);
        }
        self.feed(rx.time_us, Owned::Frame(rx.bytes, link));
    }

    /// A scaled clock follows the simulated autopilot's own time
    /// (`clock::Clock::sync`); at scale 1 this does nothing.
    fn follow_vehicle_time(&self, header: &mavlink::MavHeader, message: &MavMessage) {
        if self.clock.scale() == 1.0
            || self.crew.first().and_then(Commander::target)
                != Some((header.system_id as u8, header.component_id))
        {
            return;
        }
        let boot_ms = match message {
            MavMessage::SYSTEM_TIME(m) => m.time_boot_ms,
            MavMessage::GLOBAL_POSITION_INT(m) => m.time_boot_ms,
            MavMessage::ATTITUDE(m) => m.time_boot_ms,
            _ => return,
        };
        self.clock.sync(Micros::from(boot_ms) * 1000);
    }

    fn effect(&mut self, effect: &Effect) {
        let now = self.now();
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
                if let Some(p) = &self.programs {
                    p.effect(effect);
                }
            }
            Effect::Call { .. } => {
                if let Some(p) = &self.programs {
                    p.effect(effect);
                }
            }
            _ => {}
        }
    }

    /// Sends what the commanders have to send, each on its vehicle's link
    /// (each frame recorded as sent), and hands their outcomes to the
    /// player, until they have nothing more.
    async fn pump(&mut self) {
        loop {
            let mut busy = false;
            while let Some(t) = self.crew.poll_transmit() {
                busy = true;
                let Some(writer) = self.writers.get(t.link) else {
                    continue;
                };
                match writer.send(t.from, &t.message).await {
                    Ok(bytes) => {
                        if let (Some(rec), false) = (&self.recorder, bytes.is_empty()) {
                            rec.sent(self.clock.now(), &bytes);
                        }
                    }
                    Err(e) => {
                        // Never spin on a link that keeps failing.
                        tracing::warn!("{e}");
                        tokio::time::sleep(Duration::from_millis(200)).await;
                    }
                }
            }
            if let Some((id, outcome)) = self.crew.poll_outcome() {
                busy = true;
                let now = self.now();
                self.feed(now, Owned::Result { id, outcome });
            }
            if !busy {
                break;
            }
        }
    }

    /// A frame from the mirror (a resync request) goes to the publisher.
    fn uplink(&mut self, bytes: &[u8]) {
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
                    self.answer(bytes);
                } else {
                    d.publisher.receive(&t.payload);
                }
            }
        }
    }

    /// An operator's answer (mirror::dialog): judged by the gate, then, if
    /// let through, an input of the player like any other (published down).
    fn answer(&mut self, bytes: &[u8]) {
        let Some(gate) = &mut self.answers else {
            tracing::warn!("an operator's answer rejected: no --operator-key");
            return;
        };
        let (id, choice) = match gate.judge_bytes(bytes, crate::link::unix_us()) {
            Ok(answer) => answer,
            Err(why) => {
                tracing::warn!("an operator's answer rejected: {}", why.as_str());
                return;
            }
        };
        let now = self.now();
        self.feed(now, Owned::Answer { id, choice });
        let verdict = self
            .done
            .last()
            .and_then(|d| crate::mirror::dialog::verdict(&d.step.effects, id));
        if let (Some(gate), Some(v)) = (&mut self.answers, verdict) {
            gate.delivered(v);
            if let Err(why) = v {
                tracing::warn!("the operator's answer to #{id} refused: {}", why.as_str());
            }
        }
    }

    /// The downlink's heartbeat and snapshots when due, and every packet
    /// the publisher has, sent (and recorded as sent).
    async fn publish(&mut self) {
        let now = self.now();
        let me = self.crew.first().and_then(Commander::identity);
        let link = self.crew.members().first().map_or(0, |m| m.link);
        let (Some(d), Some(me), Some(writer)) = (&mut self.downlink, me, self.writers.get(link))
        else {
            return;
        };
        d.publisher.autopilot_clocks(self.supervisor.boots());
        d.publisher
            .tick(now, self.supervisor.seq(), self.supervisor.player());
        while let Some(payload) = d.publisher.poll_transmit() {
            let tunnel = Tunnel {
                payload_type: PAYLOAD_TYPE,
                target_system: d.mirror,
                target_component: 0,
                payload,
            };
            match writer.send_data(me, &tunnel).await {
                Ok(bytes) => {
                    if let (Some(rec), false) = (&self.recorder, bytes.is_empty()) {
                        rec.sent(self.clock.now(), &bytes);
                    }
                }
                Err(e) => {
                    tracing::warn!("downlink: {e}");
                    break;
                }
            }
        }
    }

    fn program_input(&mut self, input: ProgramInput) {
        let now = self.now();
        match input {
            ProgramInput::Outcome { id, outcome } => self.feed(now, Owned::Result { id, outcome }),
            ProgramInput::Event { event, .. } | ProgramInput::Lost { event, .. } => {
                self.feed(now, Owned::Event(event))
            }
            ProgramInput::Traffic(t) => {
                if let Some(rec) = &self.recorder {
                    let kind = match t.direction {
                        Direction::In => "in",
                        Direction::Out => "out",
                    };
                    let body = serde_json::from_str(&t.line)
                        .unwrap_or_else(|_| serde_json::Value::String(t.line.clone()));
                    rec.program(now, t.program.as_deref().unwrap_or("?"), kind, body);
                }
            }
        }
    }
}

/// A number for this run of the gateway, so that a mirror tells a restart
/// from a gap: the low bits of the UNIX time in milliseconds.
fn session() -> u32 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(1, |d| d.as_millis() as u32)
        .max(1)
}
