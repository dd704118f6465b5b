//! The writer thread: owns the MCAP file, turns entries into messages on
//! the channels of docs/recording.md, and closes a chunk (syncing the file)
//! at least every `flush_every`, so that a power loss costs at most that
//! much of the flight; when the handle goes, it writes the summary.

use std::collections::{BTreeMap, HashMap};
use std::io::{Seek, Write};
use std::sync::atomic::Ordering;
use std::sync::mpsc::{Receiver, TryRecvError};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How long the writer sleeps between two batches of entries.
const BATCH: Duration = Duration::from_millis(10);

use elaboration::Frame;
use mavlink::dialects::ardupilotmega::MavMessage;
use mcap::records::MessageHeader;
use nets::player::{effect_json, Digest};
use nets::{Effect, Event, Micros, Outcome, Project};
use serde_json::{json, Value as Json};

use super::decoded::{self, Decoder};
use super::layout::{self, Input};
use super::queue::{Dropped, Entry, Options, RecordError, Report};
use petrel_core::supervisor::Step;

/// Fixed channels, by topic.
struct Channels {
    raw: u16,
    sent: u16,
    inputs: u16,
    events: u16,
    effects: u16,
    digests: u16,
    commands: u16,
    programs: u16,
    recorder: u16,
    location: u16,
    log: u16,
}

/// What a pending id is, to route its result.
#[derive(Clone, Copy)]
enum Pending {
    Command,
    Call,
}

pub(super) struct Writer<W: Write + Seek> {
    mcap: mcap::Writer<W>,
    project: Arc<Project>,
    options: Options,
    dropped: Arc<Dropped>,
    channels: Channels,
    json_schemas: HashMap<&'static str, u16>,
    /// Decoded channels by (sent, system, component, message id).
    decoded: HashMap<(bool, u8, u8, u32), Option<u16>>,
    markings: HashMap<Option<usize>, u16>,
    /// The same channels by topic (a net keeps its channel across
    /// versions of the project).
    marking_topics: HashMap<String, u16>,
    /// The ground mirror's channels, by topic.
    mirror: HashMap<&'static str, u16>,
    /// Added to times (µs) to make log times: a mirror's replica steps
    /// are at the vehicle's time and logged at the ground's.
    shift: i64,
    decoder: Decoder,
    pending: HashMap<u64, Pending>,
    raw_index: u64,
    sent_index: u64,
    boot_ms: Option<u32>,
    steps: u64,
    messages: u64,
    dirty: bool,
    reported_dropped: u64,
    last_time: Micros,
    last_seq: Option<u64>,
}

fn add_json_channel<W: Write + Seek>(
    mcap: &mut mcap::Writer<W>,
    topic: &str,
    schema: (&str, &str),
) -> Result<u16, mcap::McapError> {
    let id = mcap.add_schema(schema.0, "jsonschema", schema.1.as_bytes())?;
    mcap.add_channel(id, topic, "json", &BTreeMap::new())
}

impl<W: Write + Seek> Writer<W> {
    pub(super) fn new(
        mut mcap: mcap::Writer<W>,
        project: Arc<Project>,
        options: Options,
        dropped: Arc<Dropped>,
    ) -> Result<Self, mcap::McapError> {
        let frame_schema = mcap.add_schema(
            layout::FRAME_SCHEMA,
            layout::FRAME_SCHEMA_ENCODING,
            layout::FRAME_SCHEMA_TEXT.as_bytes(),
        )?;
        let none = BTreeMap::new();
        let json =
            |mcap: &mut mcap::Writer<W>, t| add_json_channel(mcap, t, layout::petrel_schema(t));
        let channels = Channels {
            inputs: json(&mut mcap, layout::INPUTS)?,
            events: json(&mut mcap, layout::EVENTS)?,
            effects: json(&mut mcap, layout::EFFECTS)?,
            digests: json(&mut mcap, layout::DIGESTS)?,
            commands: json(&mut mcap, layout::COMMANDS)?,
            programs: json(&mut mcap, layout::PROGRAMS)?,
            recorder: json(&mut mcap, layout::RECORDER)?,
            location: add_json_channel(
                &mut mcap,
                layout::LOCATION,
                ("foxglove.LocationFix", decoded::LOCATION_FIX_SCHEMA),
            )?,
            log: add_json_channel(&mut mcap, layout::LOG, ("foxglove.Log", layout::LOG_SCHEMA))?,
            raw: mcap.add_channel(frame_schema, layout::RAW, layout::FRAME_ENCODING, &none)?,
            sent: mcap.add_channel(frame_schema, layout::SENT, layout::FRAME_ENCODING, &none)?,
        };
        let metadata = [
            ("layout".to_owned(), layout::LAYOUT_VERSION.to_owned()),
            ("project".to_owned(), project.name.clone()),
            ("profile".to_owned(), options.profile.clone()),
            ("petrel".to_owned(), env!("CARGO_PKG_VERSION").to_owned()),
            (
                "clock_offset_ns".to_owned(),
                options.clock_offset_ns.to_string(),
            ),
        ];
        mcap.write_metadata(&mcap::records::Metadata {
            name: "petrel".into(),
            metadata: metadata.into_iter().collect(),
        })?;
        // The file is a valid MCAP from the start (file.rs).
        mcap.flush()?;
        Ok(Writer {
            mcap,
            project,
            options,
            dropped,
            channels,
            json_schemas: HashMap::new(),
            decoded: HashMap::new(),
            markings: HashMap::new(),
            marking_topics: HashMap::new(),
            mirror: HashMap::new(),
            shift: 0,
            decoder: Decoder::default(),
            pending: HashMap::new(),
            raw_index: 0,
            sent_index: 0,
            boot_ms: None,
            steps: 0,
            messages: 0,
            dirty: true,
            reported_dropped: 0,
            last_time: 0,
            last_seq: None,
        })
    }

    pub(super) fn run(&mut self, rx: Receiver<Entry>) -> Result<Report, RecordError> {
        // The writer takes what is queued in batches, sleeping in between,
        // rather than waiting on the queue: a waiting receiver would make
        // every entry the gateway's loop queues a wake-up (a system call on
        // the loop's path, and a thread scheduled against it).
        let mut deadline = Instant::now() + self.options.flush_every;
        'run: loop {
            loop {
                match rx.try_recv() {
                    Ok(entry) => {
                        self.dropped.queued.fetch_sub(1, Ordering::Relaxed);
                        self.entry(entry)?
                    }
                    Err(TryRecvError::Empty) => break,
                    Err(TryRecvError::Disconnected) => break 'run,
                }
                // A chunk is closed on time even when the queue never empties.
                if Instant::now() >= deadline {
                    self.close_chunk()?;
                    deadline = Instant::now() + self.options.flush_every;
                }
            }
            if Instant::now() >= deadline {
                self.close_chunk()?;
                deadline = Instant::now() + self.options.flush_every;
            }
            let wait = deadline.saturating_duration_since(Instant::now());
            std::thread::sleep(wait.min(BATCH));
        }
        self.status(true)?;
        self.mcap.finish()?;
        Ok(Report {
            steps: self.steps,
            dropped: self.dropped.entries.load(Ordering::Relaxed),
            dropped_steps: self.dropped.steps.load(Ordering::Relaxed),
            messages: self.messages,
        })
    }

    /// Steps written so far.
    pub(super) fn steps(&self) -> u64 {
        self.steps
    }

    /// The Supervisor time of the last step written.
    pub(super) fn last_time(&self) -> Micros {
        self.last_time
    }

    /// The sink, once the file is finished.
    pub(super) fn into_sink(self) -> W {
        self.mcap.into_inner()
    }

    /// Writes the recorder's status and closes the chunk (the file is
    /// synced), if anything was written since the last one.
    fn close_chunk(&mut self) -> Result<(), RecordError> {
        self.status(false)?;
        if self.dirty {
            self.mcap.flush()?;
            self.dirty = false;
        }
        Ok(())
    }

    /// The log time of a Supervisor time.
    fn time_ns(&self, time: Micros) -> u64 {
        (time as i64)
            .saturating_add(self.shift)
            .max(0)
            .unsigned_abs()
            .saturating_mul(1000)
            .saturating_add(self.options.clock_offset_ns)
    }

    fn write(&mut self, channel: u16, seq: u64, time: Micros, data: &[u8]) -> mcap::McapResult<()> {
        let t = self.time_ns(time);
        self.messages += 1;
        self.dirty = true;
        self.mcap.write_to_known_channel(
            &MessageHeader {
                channel_id: channel,
                sequence: seq as u32,
                log_time: t,
                publish_time: t,
            },
            data,
        )
    }

    fn write_json(
        &mut self,
        channel: u16,
        seq: u64,
        time: Micros,
        v: &Json,
    ) -> mcap::McapResult<()> {
        let bytes = serde_json::to_vec(v).unwrap_or_default();
        self.write(channel, seq, time, &bytes)
    }

    /// Records the drop count when it changed (and at the end).
    fn status(&mut self, always: bool) -> mcap::McapResult<()> {
        let dropped = self.dropped.entries.load(Ordering::Relaxed);
        if !always && dropped == self.reported_dropped {
            return Ok(());
        }
        self.reported_dropped = dropped;
        let steps = self.dropped.steps.load(Ordering::Relaxed);
        let v = json!({"time_us": self.last_time, "written_steps": self.steps, "last_seq": self.last_seq, "dropped": dropped, "dropped_steps": steps});
        self.write_json(self.channels.recorder, self.steps, self.last_time, &v)
    }

    fn entry(&mut self, entry: Entry) -> mcap::McapResult<()> {
        match entry {
            Entry::Step(b) => {
                let (input, frame, step, digest, link) = *b;
                self.step(input, frame, &step, digest, link)
            }
            Entry::Version(b) => {
                let (project, (input, frame, step, digest, link)) = *b;
                self.take_version(project);
                self.attach_version(&input, step.time)?;
                self.step(input, frame, &step, digest, link)
            }
            Entry::Project(project) => {
                self.take_version(project);
                Ok(())
            }
            Entry::Sent { time, bytes } => self.frame(time, &bytes, true),
            Entry::Received { time, bytes } => self.frame(time, &bytes, false),
            Entry::Replica(b) => {
                let (at, call, step, digest) = *b;
                // Logged when the ground played it.
                self.shift = at as i64 - step.time as i64;
                let written = self.step(Input::Replica(call), None, &step, digest, None);
                self.shift = 0;
                written
            }
            Entry::Mirror { time, topic, body } => {
                let channel = match self.mirror.get(topic) {
                    Some(c) => *c,
                    None => {
                        let c =
                            add_json_channel(&mut self.mcap, topic, layout::petrel_schema(topic))?;
                        self.mirror.insert(topic, c);
                        c
                    }
                };
                self.write_json(channel, 0, time, &body)
            }
            Entry::Program {
                time,
                program,
                kind,
                body,
            } => {
                let v = json!({"time_us": time, "program": program, "kind": kind, "body": body});
                self.write_json(self.channels.programs, 0, time, &v)
            }
            Entry::Log {
                time,
                level,
                name,
                message,
            } => {
                let ns = self.time_ns(time);
                let v = json!({
                    "timestamp": {"sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000},
                    "level": level as u8,
                    "message": message,
                    "name": name,
                    "file": "",
                    "line": 0,
                });
                self.write_json(self.channels.log, 0, time, &v)
            }
        }
    }

    /// A version's files as MCAP attachments too, `version-N/PATH`
    /// (`mcap list attachments`, Foxglove's attachments panel), beside
    /// the input that replay reads them from.
    fn attach_version(&mut self, input: &Input, time: Micros) -> mcap::McapResult<()> {
        let Input::Version { number, files } = input else {
            return Ok(());
        };
        let t = self.time_ns(time);
        for (path, text) in files {
            self.mcap.attach(&mcap::Attachment {
                log_time: t,
                create_time: t,
                name: format!("version-{number}/{path}"),
                media_type: "application/toml".into(),
                data: std::borrow::Cow::Borrowed(text.as_bytes()),
            })?;
        }
        Ok(())
    }

    /// What follows is of `project`, a new version: its nets are numbered
    /// anew, their marking channels found again by topic.
    fn take_version(&mut self, project: Arc<Project>) {
        self.project = project;
        self.markings.clear();
    }

    fn step(
        &mut self,
        mut input: Input,
        frame: Option<Vec<u8>>,
        step: &Step,
        digest: Digest,
        link: Option<usize>,
    ) -> mcap::McapResult<()> {
        let (seq, time) = (step.seq, step.time);
        self.last_time = time;
        self.last_seq = Some(seq);
        if let Some(bytes) = frame {
            input = Input::Frame(self.raw_index);
            self.frame(time, &bytes, false)?;
        }
        let mut v = layout::input_json(seq, time, &input);
        if let Some(link) = link {
            v["link"] = json!(link);
        }
        if input == Input::Start {
            v["setup"] = layout::setup_json(&layout::Setup {
                config: self.options.config.clone(),
                profile: self.options.profile.clone(),
                layers: self.options.profile_layers.clone(),
            });
        }
        self.write_json(self.channels.inputs, seq, time, &v)?;
        match &input {
            Input::Result { id, outcome } => self.result(seq, time, *id, outcome)?,
            Input::Event(e) => self.program_event(seq, time, e)?,
            _ => {}
        }
        let mut count = 0;
        for effect in &step.effects {
            self.effect(seq, effect)?;
            count += 1;
        }
        for (e, effects) in &step.events {
            let v = json!({
                "seq": seq, "time_us": e.time_us, "event": e.event.name,
                "category": self.project.declared_category(&e.event.name).unwrap_or(e.event.category).as_str(),
                "params": layout::event_json(&e.event)["params"],
                "sysid": e.sysid, "compid": e.compid,
            });
            self.write_json(self.channels.events, seq, e.time_us, &v)?;
            for effect in effects {
                self.effect(seq, effect)?;
                count += 1;
            }
        }
        let v = json!({"seq": seq, "time_us": time, "digest": digest.to_string(), "boot_ms": self.boot_ms, "effects": count});
        self.write_json(self.channels.digests, seq, time, &v)?;
        self.steps += 1;
        Ok(())
    }

    /// A frame received (`sent` false: a Supervisor input, the next index
    /// on `/mavlink/raw`) or sent, raw then decoded.
    fn frame(&mut self, time: Micros, bytes: &[u8], sent: bool) -> mcap::McapResult<()> {
        let index = if sent {
            self.sent_index += 1;
            self.sent_index - 1
        } else {
            self.raw_index += 1;
            self.raw_index - 1
        };
        let raw = if sent {
            self.channels.sent
        } else {
            self.channels.raw
        };
        self.write(raw, index, time, &tlog_record(time, bytes))?;
        let Ok(frame) = Frame::parse(bytes) else {
            return Ok(());
        };
        let Ok(msg) = frame.decode() else {
            return Ok(());
        };
        if !sent {
            if let MavMessage::SYSTEM_TIME(t) = &msg {
                self.boot_ms = Some(t.time_boot_ms);
            }
            let t_ns = self.time_ns(time);
            if let Some(fix) = decoded::location_fix(&msg, t_ns) {
                self.write_json(self.channels.location, index, time, &fix)?;
            }
        }
        let key = (
            sent,
            frame.system_id(),
            frame.component_id(),
            frame.message_id(),
        );
        let Some((kind, v)) = self.decoder.decode(&msg) else {
            return Ok(());
        };
        let channel = match self.decoded.get(&key) {
            Some(c) => *c,
            None => {
                let schema = match self.json_schemas.get(kind.name) {
                    Some(s) => Some(*s),
                    None => {
                        let name = format!("mavlink.{}", kind.name);
                        let s =
                            self.mcap
                                .add_schema(&name, "jsonschema", kind.schema.as_bytes())?;
                        self.json_schemas.insert(kind.name, s);
                        Some(s)
                    }
                };
                let prefix = if sent { "/mavlink/sent" } else { "/mavlink" };
                let topic = format!("{prefix}/{}/{}/{}", key.1, key.2, kind.name);
                let c = match schema {
                    Some(s) => Some(self.mcap.add_channel(s, &topic, "json", &BTreeMap::new())?),
                    None => None,
                };
                self.decoded.insert(key, c);
                c
            }
        };
        if let Some(c) = channel {
            self.write_json(c, index, time, &v)?;
        }
        Ok(())
    }

    fn effect(&mut self, seq: u64, effect: &Effect) -> mcap::McapResult<()> {
        let time = effect.time();
        let mut v = effect_json(&self.project, effect);
        v["seq"] = json!(seq);
        self.write_json(self.channels.effects, seq, time, &v)?;
        match effect {
            Effect::Marking { net, marked, .. } => {
                let channel = match self.markings.get(net) {
                    Some(c) => *c,
                    None => {
                        let name = match net {
                            Some(n) => self.project.nets[*n].name.clone(),
                            None => "@globals".to_owned(),
                        };
                        let topic = format!("{}{name}", layout::MARKING_PREFIX);
                        let c = match self.marking_topics.get(&topic) {
                            Some(c) => *c,
                            None => {
                                let c = add_json_channel(
                                    &mut self.mcap,
                                    &topic,
                                    layout::petrel_schema(&topic),
                                )?;
                                self.marking_topics.insert(topic, c);
                                c
                            }
                        };
                        self.markings.insert(*net, c);
                        c
                    }
                };
                let mut m = json!({"seq": seq, "time_us": time, "marked": v["marked"], "tokens": marked.len()});
                if let Some(active) = v.get("active") {
                    m["active"] = active.clone();
                }
                self.write_json(channel, seq, time, &m)?;
            }
            Effect::Command { id, .. } => {
                self.pending.insert(*id, Pending::Command);
                self.write_json(self.channels.commands, seq, time, &v)?;
            }
            Effect::Call { id, .. } => {
                self.pending.insert(*id, Pending::Call);
                self.write_json(self.channels.programs, seq, time, &v)?;
            }
            _ => {}
        }
        Ok(())
    }

    fn result(
        &mut self,
        seq: u64,
        time: Micros,
        id: u64,
        outcome: &Outcome,
    ) -> mcap::McapResult<()> {
        let v = json!({"seq": seq, "time_us": time, "kind": "result", "id": id, "outcome": layout::outcome_json(outcome)});
        match self.pending.remove(&id) {
            Some(Pending::Command) => self.write_json(self.channels.commands, seq, time, &v),
            _ => self.write_json(self.channels.programs, seq, time, &v),
        }
    }

    fn program_event(&mut self, seq: u64, time: Micros, e: &Event) -> mcap::McapResult<()> {
        let v =
            json!({"seq": seq, "time_us": time, "kind": "event", "event": layout::event_json(e)});
        self.write_json(self.channels.programs, seq, time, &v)
    }
}

/// A tlog record: the time (µs, big-endian) then the frame.
fn tlog_record(time: Micros, bytes: &[u8]) -> Vec<u8> {
    let mut rec = Vec::with_capacity(8 + bytes.len());
    rec.extend_from_slice(&time.to_be_bytes());
    rec.extend_from_slice(bytes);
    rec
}
