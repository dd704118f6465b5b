//! `run`'s loop: the gateway on board once everything is loaded — the
//! links read, the supervisor stepped, the commanders and programs carrying
//! out its effects, steps printed and recorded after the commands are out.

use std::io::Write;
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::MavMessage;
use nets::Micros;
use serde_json::json;
use tokio::sync::mpsc;

use super::autopilot::{adopt, identify};
use super::parameters::parameters_fit;
use super::reload::{Background, Reload};
use super::signals::{Hangup, Signals};
use super::timeline::Timeline;
use super::{elaboration_config, links, Setup, SILENCE_WARNING, TIMESTAMP_PERSIST, UPLOAD_GRACE};
use crate::cli::{Outcome, VerbResult};
use crate::clock::Clock;
use crate::link::{LinkWriter, Received};
use crate::programs::server::{Direction, ProgramInput, Programs};
use petrel_core::onboard::{DownlinkConfig, Input as OwnedInput, Onboard, Settled, Transmit};
use petrel_core::supervisor::Supervisor;
use petrel_core::vehicle::commander::Commander;
use petrel_record::recorder::{Options as RecordOptions, Recorder};

pub(super) struct Gateway {
    clock: Clock,
    /// Every decision: the supervisor, the commanders, the downlink.
    core: Onboard,
    programs: Option<Programs>,
    /// One writer per link (`team::links` order).
    writers: Vec<LinkWriter>,
    recorder: Option<Recorder>,
    /// The web monitor: fed in `settle`, served on its own thread.
    monitor: Option<(petrel_web::monitor::Feed, petrel_web::monitor::Server)>,
    out: Timeline<std::io::BufWriter<Box<dyn Write + Send>>>,
    /// New versions of the project (SIGHUP), read and proved off the loop.
    reload: Reload,
    dir: std::path::PathBuf,
    /// The version the last step printed ran in.
    shown: std::sync::Arc<nets::Project>,
}

impl Gateway {
    fn now(&self) -> Micros {
        self.clock.now()
    }

    /// The calls the core has for the programs.
    fn calls(&mut self) {
        while let Some(effect) = self.core.poll_call() {
            if let Some(p) = &self.programs {
                p.effect(&effect);
            }
        }
    }

    /// Prints and records the steps carried out since the last call, in
    /// order, and flushes the timeline.
    fn settle(&mut self) {
        self.core.settle();
        // Each step is said with the version it ran in: a version that
        // took over in this batch names the steps from its own on.
        let mut project = self.shown.clone();
        while let Some(Settled {
            input,
            step,
            digest,
        }) = self.core.poll_settled()
        {
            if let OwnedInput::Version(v) = &input {
                project = v.project.clone();
                let _ = self.out.input(
                    step.time,
                    "version",
                    json!({"version": v.number}),
                    &format!("VERSION {} takes over", v.number),
                );
            }
            if let OwnedInput::Event(event) = &input {
                let _ = self.out.event(&project, step.time, event, None);
            }
            let _ = self.out.effects(&project, &step.effects);
            for (event, effects) in &step.events {
                let _ = self.out.event(
                    &project,
                    event.time_us,
                    &event.event,
                    Some(json!({"sysid": event.sysid, "compid": event.compid})),
                );
                let _ = self.out.effects(&project, effects);
            }
            if let Some((feed, _)) = &self.monitor {
                feed.step(&input.as_supervisor(), &step, self.core.player());
                if let OwnedInput::Version(v) = &input {
                    feed.replace_page(petrel_web::monitor::page::page(
                        &v.project,
                        Some(&self.dir),
                        "live",
                    ));
                }
            }
            if let (Some(rec), Some(digest)) = (&self.recorder, digest) {
                // A team's frames say their link (one link: implied).
                let link = match &input {
                    OwnedInput::Frame(_, link) if self.writers.len() > 1 => Some(*link),
                    _ => None,
                };
                rec.record_on(&input.as_supervisor(), link, step, digest);
            }
        }
        self.shown = project;
        if let Some((feed, _)) = &self.monitor {
            feed.publish();
        }
        let _ = self.out.out.flush();
    }

    /// SIGHUP: the project folder is read again.
    fn hangup(&mut self) {
        say!(
            "SIGHUP: reading {} again for a new version of the project",
            self.dir.display()
        );
        self.reload.request();
    }

    /// What a background thread brought back: a version read (offered to
    /// the core), or a proof's answer (to the core, at this boundary).
    fn background(&mut self, back: Background) {
        let now = self.now();
        match back {
            Background::Loaded(Ok((project, files))) => {
                self.reload.loaded();
                self.core.offer_version(project, files);
            }
            Background::Loaded(Err(why)) => {
                self.reload.loaded();
                self.say_version(format!(
                    "the new version does not load, the running version goes on:\n{why}"
                ));
            }
            Background::Proved(proved) => self.core.handle_proved(now, *proved),
            Background::Uploaded(upload, Ok((project, files))) => {
                self.say_version(format!(
                    "a version sent up from the ground (upload {upload}) loads and holds its check"
                ));
                self.core.offer_uploaded(upload, project, files);
            }
            Background::Uploaded(upload, Err(why)) => {
                self.say_version(format!(
                    "the version sent up from the ground (upload {upload}) is refused, the running version goes on:\n{why}"
                ));
                let first = why.lines().next().unwrap_or("").to_owned();
                self.core.upload_refused(upload, &first);
            }
        }
    }

    /// The core's proofs started, what became of the versions said (and
    /// recorded).
    fn versions(&mut self) {
        while let Some((upload, bytes)) = self.core.poll_upload() {
            self.say_version(format!(
                "a version sent up from the ground arrived whole (upload {upload}, {} bytes): loading it",
                bytes.len()
            ));
            self.reload.uploaded(upload, bytes);
        }
        while let Some(proof) = self.core.poll_proof() {
            self.reload.prove(proof);
        }
        while let Some(report) = self.core.poll_version() {
            self.say_version(report.to_string());
        }
    }

    fn say_version(&mut self, text: String) {
        // At the gateway's time, as the timeline counts it.
        say!("reload at {:.3} s: {text}", nets::time::seconds(self.now()));
        if let Some(rec) = &self.recorder {
            rec.log(
                self.clock.now(),
                petrel_record::recorder::Level::Info,
                "reload",
                text,
            );
        }
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
        let mut hangups = Hangup::new()?;
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
                        .unwrap_or(petrel_core::vehicle::commander::ANNOUNCE_SYSTEM),
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
        let lanes = petrel_core::team::lanes(
            &setup.project,
            &setup.dir,
            &setup.profile,
            petrel_core::team::family(&setup.layers.layers),
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
                    writer_started: crate::scheduling::recorder_thread,
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
        let crew = petrel_core::onboard::crew(&setup.project, &setup.vehicle, &lanes, &link_of);
        let unread = petrel_core::mirror::Unread::of(&lanes);
        let (supervisor, start) = Supervisor::start_lanes(setup.project.clone(), lanes, 0);
        let core = Onboard::new(
            supervisor,
            crew,
            setup.downlink.map(|mirror| DownlinkConfig {
                session: session(),
                mirror,
                unread,
            }),
            setup.operator.take(),
            recorder.is_some(),
        );
        // A new version is loaded with the profile the flight runs with
        // (the one adopted from the autopilot heard).
        let (reload, mut background) = Reload::new(
            setup.dir.clone(),
            petrel_core::project::catalog(&setup.profile),
            setup.layers.layers.clone(),
            !setup.unchecked,
        );
        let mut gw = Gateway {
            reload,
            dir: setup.dir.clone(),
            shown: setup.project.clone(),
            clock,
            core,
            programs,
            writers,
            recorder,
            monitor: None,
            out: Timeline {
                out: std::io::BufWriter::new(setup.out),
                json: setup.json,
                origin: 0,
            },
        };
        if let Some(rec) = &gw.recorder {
            rec.start(&start, gw.core.player());
        }
        if let Some(address) = setup.http {
            let (project, player) = (gw.core.project().clone(), gw.core.player());
            let monitor =
                petrel_web::monitor::start_live(address, project, &setup.dir, &start, player)
                    .map_err(|e| miette::miette!("cannot serve the monitor on {address}: {e}"))?;
            say!("monitor: http://{}/", monitor.1.address);
            gw.monitor = Some(monitor);
        }
        let now = gw.now();
        gw.core.start(now, &start);
        let _ = gw.out.effects(gw.core.project(), &start.effects);
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
        let mut refused = false;
        // Said once when the vehicle stays silent: nothing else tells a
        // user that the address, the router or the autopilot is wrong.
        let mut said_silent = vec![false; gw.core.crew().members().len()];
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
                if let Some(event) = reporter.poll(rejections, gw.core.project(), gw.now()) {
                    let now = gw.now();
                    gw.core.handle_event(now, event);
                }
            }
            if let Some(file) = &timestamp_file {
                if persisted_at.elapsed() >= TIMESTAMP_PERSIST {
                    persisted_at = Instant::now();
                    links::persist_timestamps(file, &gw.writers);
                }
            }
            if Instant::now() >= silent_until {
                for (said, m) in said_silent.iter_mut().zip(gw.core.crew().members()) {
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
            let deadline = gw.core.poll_timeout();
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
                    gw.core.handle_timeout(now);
                }
                _ = signals.recv() => break,
                _ = until_stop => break,
                _ = told_to_stop => break,
                _ = hangups.recv() => gw.hangup(),
                Some(back) = background.recv() => gw.background(back),
            }
            gw.pump().await;
            gw.settle();
            gw.publish().await;
            gw.versions();
            if let Some((v, verdict)) = gw.core.poll_parameters() {
                let member = &gw.core.crew().members()[v];
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
        while gw.core.busy() && Instant::now() < grace {
            tokio::select! {
                Some((link, rx)) = frames.recv() => {
                    if let Some(message) = &rx.message {
                        gw.core.handle_vehicle_message(link, rx.time_us, &rx.header, message);
                    }
                }
                _ = ticks.tick() => {
                    let now = gw.now();
                    gw.core.tick_commanders(now);
                }
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
        let counts = gw.core.upload_counts();
        if counts.offers > 0 {
            say!(
                "versions sent up: {} offers, {} pieces taken, {} whole, {} refused pieces, {} while another was received, {} altered",
                counts.offers,
                counts.pieces,
                counts.completed,
                counts.refused,
                counts.busy,
                counts.altered
            );
        }
        if let (version @ 1.., _) = gw.core.version() {
            say!("the project's version {version} ran at the end (docs/run.md \"A new version in flight\")");
        }
        if let Some(gate) = gw.core.answers() {
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
            core,
            mut out,
            recorder,
            ..
        } = gw;
        let (frames, events) = (core.frames, core.events);
        let supervisor = core.supervisor();
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

    /// A frame from link `link`: the scaled clock follows the autopilot's
    /// time, then the core takes it.
    fn frame(&mut self, link: usize, rx: Received) {
        if let Some(message) = &rx.message {
            self.follow_vehicle_time(&rx.header, message);
        }
        let now = self.now();
        self.core
            .handle_frame(now, link, rx, crate::link::unix_us());
        self.calls();
    }

    /// A scaled clock follows the simulated autopilot's own time
    /// (`clock::Clock::sync`); at scale 1 this does nothing.
    fn follow_vehicle_time(&self, header: &mavlink::MavHeader, message: &MavMessage) {
        if self.clock.scale() == 1.0
            || self.core.crew().first().and_then(Commander::target)
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

    /// Sends what the core has to send, each frame on its link (recorded
    /// as sent), until it has nothing more; then the calls it made
    /// meanwhile go to the programs.
    async fn pump(&mut self) {
        loop {
            let now = self.now();
            let Some(t) = self.core.poll_transmit(now) else {
                break;
            };
            let sent = match &t {
                Transmit::Command(t) => match self.writers.get(t.link) {
                    Some(writer) => writer.send(t.from, &t.message).await,
                    None => continue,
                },
                Transmit::Downlink { link, from, tunnel } => match self.writers.get(*link) {
                    Some(writer) => writer.send_data(*from, tunnel).await,
                    None => continue,
                },
            };
            match sent {
                Ok(bytes) => {
                    if let (Some(rec), false) = (&self.recorder, bytes.is_empty()) {
                        rec.sent(self.clock.now(), &bytes);
                    }
                }
                Err(e) if matches!(t, Transmit::Downlink { .. }) => {
                    // The rest of the downlink waits for the next turn.
                    tracing::warn!("downlink: {e}");
                    break;
                }
                Err(e) => {
                    // Never spin on a link that keeps failing.
                    tracing::warn!("{e}");
                    tokio::time::sleep(Duration::from_millis(200)).await;
                }
            }
        }
        self.calls();
    }

    /// The downlink's heartbeat, snapshots and records, sent.
    async fn publish(&mut self) {
        let now = self.now();
        self.core.publish(now);
        self.pump().await;
    }

    fn program_input(&mut self, input: ProgramInput) {
        let now = self.now();
        match input {
            ProgramInput::Outcome { id, outcome } => self.core.handle_result(now, id, outcome),
            ProgramInput::Event { event, .. } | ProgramInput::Lost { event, .. } => {
                self.core.handle_event(now, event)
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
        self.calls();
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
