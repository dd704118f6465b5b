//! The recorder's handle: what the gateway's loop calls, without ever
//! waiting, to hand entries to the writer thread (`writer.rs`) over a
//! bounded queue.
//!
//! Each call is one entry on the queue; when the queue is full the entry is
//! dropped whole and counted, and the writer records the count on
//! `/petrel/recorder` as soon as it catches up. `finish` waits for the
//! writer to write what is queued and the summary.

use std::fs::File;
use std::io::{self, Seek, Write};
use std::path::Path;
use std::sync::atomic::Ordering;
use std::sync::mpsc::{sync_channel, SyncSender, TrySendError};
use std::sync::Arc;
use std::thread::JoinHandle;

use nets::player::Digest;
use nets::{Micros, Player, Project};
use serde_json::Value as Json;

use super::file::RecordingFile;
use super::layout::{self, Input};
use super::queue::{Dropped, Entry};
pub use super::queue::{Level, Options, RecordError, Report};
use super::writer::Writer;
use petrel_core::supervisor::{self, Step, Supervisor};

/// Why the recording stopped in flight: printed at once for the crew.
struct Stopped {
    file: String,
    reason: String,
    steps: u64,
    /// The Supervisor time of the last step written (µs).
    at: Micros,
}

impl std::fmt::Display for Stopped {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "RECORDING STOPPED at t = {:.1} s: {} ({}); {} steps recorded, readable up to the last chunk closed before; \
             the flight goes on unrecorded, what is not recorded is counted",
            nets::time::seconds(self.at),
            self.file,
            self.reason,
            self.steps
        )
    }
}

/// The sink of a recording on the disk.
type Sink = RecordingFile;

/// The handle. Its methods never block and never fail the caller.
pub struct Recorder {
    tx: Option<SyncSender<Entry>>,
    /// The queue's capacity.
    capacity: u64,
    dropped: Arc<Dropped>,
    thread: Option<JoinHandle<Result<Report, RecordError>>>,
}

impl Recorder {
    /// Creates `path` and starts recording into it.
    pub fn create(
        path: &Path,
        project: Arc<Project>,
        options: Options,
    ) -> Result<Recorder, RecordError> {
        let create = |source| RecordError::Create {
            path: path.display().to_string(),
            source,
        };
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(create)?;
        }
        let file = File::create(path).map_err(create)?;
        Recorder::spawn(
            RecordingFile::new(file),
            Sink::seal,
            path.display().to_string(),
            project,
            options,
        )
    }

    /// Records into any seekable sink (tests inject slow or in-memory ones).
    pub fn with_sink<W: Write + Seek + Send + 'static>(
        sink: W,
        project: Arc<Project>,
        options: Options,
    ) -> Result<Recorder, RecordError> {
        Recorder::spawn(
            sink,
            |mut w: W| w.flush(),
            "the recording".into(),
            project,
            options,
        )
    }

    /// The writer's thread over `sink`; `seal` ends the sink once the
    /// writer has finished the file.
    fn spawn<W: Write + Seek + Send + 'static>(
        sink: W,
        seal: fn(W) -> io::Result<()>,
        name: String,
        project: Arc<Project>,
        options: Options,
    ) -> Result<Recorder, RecordError> {
        // Chunks are compressed in memory and handed whole to the sink
        // (`disable_seeking`): no placeholder length ever reaches the file.
        let mcap = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            .compression_threads(0)
            .chunk_size(None)
            .disable_seeking(true)
            .profile(layout::PROFILE)
            .create(sink)?;
        let dropped = Arc::new(Dropped::default());
        let (tx, rx) = sync_channel(options.queue.max(1));
        let capacity = options.queue.max(1) as u64;
        let writer_started = options.writer_started;
        let mut writer = Writer::new(mcap, project, options, Arc::clone(&dropped))?;
        let thread = std::thread::Builder::new()
            .name("petrel-recorder".into())
            .spawn(move || {
                // The writer's work can wait: the driver's policy for it.
                writer_started();
                let result = writer.run(rx);
                let (written, at) = (writer.steps(), writer.last_time());
                let result = result.and_then(|report| {
                    seal(writer.into_sink())
                        .map_err(|e| RecordError::Write(format!("cannot end the file: {e}")))?;
                    Ok(report)
                });
                if let Err(e) = &result {
                    // The queue's receiver goes with this thread: from now
                    // on every entry is counted as dropped, and the flight
                    // goes on.
                    let stopped = Stopped {
                        file: name,
                        reason: e.to_string(),
                        steps: written,
                        at,
                    };
                    tracing::error!("{stopped}");
                }
                result
            })
            .map_err(|_| RecordError::Thread)?;
        Ok(Recorder {
            tx: Some(tx),
            capacity,
            dropped,
            thread: Some(thread),
        })
    }

    fn send(&self, entry: Entry) {
        let Some(tx) = &self.tx else { return };
        match tx.try_send(entry) {
            Ok(()) => {
                self.dropped.queued.fetch_add(1, Ordering::Relaxed);
            }
            Err(TrySendError::Full(e)) | Err(TrySendError::Disconnected(e)) => {
                if matches!(e, Entry::Step(_) | Entry::Replica(_) | Entry::Version(_)) {
                    self.dropped.steps.fetch_add(1, Ordering::Relaxed);
                }
                self.dropped.entries.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    /// Step 0: the player's start, as `Supervisor::start` returned it.
    pub fn start(&self, step: &Step, player: &Player) {
        self.send(Entry::Step(Box::new((
            Input::Start,
            None,
            step.clone(),
            player.digest(),
            None,
        ))));
    }

    /// One Supervisor step: the input it was fed, the step it returned and
    /// the player after it (for the digest). Call it right after each
    /// `Supervisor::step`, in order.
    pub fn step(&self, input: &supervisor::Input, step: &Step, player: &Player) {
        let (input, frame) = Self::split(input);
        self.send(Entry::Step(Box::new((
            input,
            frame,
            step.clone(),
            player.digest(),
            None,
        ))));
    }

    /// One Supervisor step, taken by value, with the digest of the player
    /// right after it: for a caller that carries a step out before it
    /// records it (`petrel run`). Call it for each step, in order.
    pub fn record(&self, input: &supervisor::Input, step: Step, digest: Digest) {
        self.record_on(input, None, step, digest);
    }

    /// [`Recorder::record`], with the link a frame came in on (a team's
    /// links, in the order first named): recorded as the input's `link`.
    pub fn record_on(
        &self,
        input: &supervisor::Input,
        link: Option<usize>,
        step: Step,
        digest: Digest,
    ) {
        let (split, frame) = Self::split(input);
        let link = link.filter(|_| frame.is_some());
        let entry = (split, frame, step, digest, link);
        match input {
            supervisor::Input::Version(v) => {
                // Never dropped: what follows is named by this version.
                // The queue drains in microseconds; a version comes once.
                if let Some(tx) = &self.tx {
                    let version = Entry::Version(Box::new((v.project.clone(), entry)));
                    if tx.send(version).is_ok() {
                        self.dropped.queued.fetch_add(1, Ordering::Relaxed);
                    } else {
                        self.dropped.steps.fetch_add(1, Ordering::Relaxed);
                        self.dropped.entries.fetch_add(1, Ordering::Relaxed);
                    }
                }
            }
            _ => self.send(Entry::Step(Box::new(entry))),
        }
    }

    fn split(input: &supervisor::Input) -> (Input, Option<Vec<u8>>) {
        match input {
            supervisor::Input::Frame(bytes) => (Input::Frame(0), Some(bytes.to_vec())),
            supervisor::Input::Tick => (Input::Tick, None),
            supervisor::Input::Result { id, outcome } => (
                Input::Result {
                    id: *id,
                    outcome: outcome.clone(),
                },
                None,
            ),
            supervisor::Input::Event(e) => (Input::Event(e.clone()), None),
            supervisor::Input::Answer { id, choice } => (
                Input::Answer {
                    id: *id,
                    choice: choice.clone(),
                },
                None,
            ),
            supervisor::Input::Version(v) => (
                Input::Version {
                    number: v.number,
                    files: v.files.clone(),
                },
                None,
            ),
        }
    }

    /// Feeds `sup` one input and records the step: `Supervisor::step` and
    /// [`Recorder::step`] in one call, so that no step goes unrecorded.
    pub fn feed(&self, sup: &mut Supervisor, time: Micros, input: supervisor::Input) -> Step {
        let step = sup.step(time, input.clone());
        self.step(&input, &step, sup.player());
        step
    }

    /// A frame the gateway sent to the vehicle, at `time`.
    pub fn sent(&self, time: Micros, bytes: &[u8]) {
        self.send(Entry::Sent {
            time,
            bytes: bytes.to_vec(),
        });
    }

    /// A frame received at `time` that feeds no Supervisor (the ground
    /// mirror's telemetry): on `/mavlink/raw`, referred to by no input.
    /// When the queue is three quarters full these are dropped (counted)
    /// first, keeping the rest of it for the replica's steps.
    pub fn received(&self, time: Micros, bytes: &[u8]) {
        if self.dropped.queued.load(Ordering::Relaxed) >= self.capacity / 4 * 3 {
            self.dropped.entries.fetch_add(1, Ordering::Relaxed);
            return;
        }
        self.send(Entry::Received {
            time,
            bytes: bytes.to_vec(),
        });
    }

    /// A step of the ground mirror's replica (numbered from 1, in order,
    /// at the vehicle's time), whose input is `call`
    /// (`mirror::call::call_json`), played at ground time `at`.
    pub fn replica(&self, at: Micros, call: Json, step: Step, digest: Digest) {
        self.send(Entry::Replica(Box::new((at, call, step, digest))));
    }

    /// The ground mirror's replica took over a new version of the
    /// project: its calls from now on are named by `project`. Never
    /// dropped (a version comes once).
    pub fn replica_version(&self, project: Arc<Project>) {
        if let Some(tx) = &self.tx {
            if tx.send(Entry::Project(project)).is_ok() {
                self.dropped.queued.fetch_add(1, Ordering::Relaxed);
            } else {
                self.dropped.entries.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    /// A line on the ground mirror's channel `topic` (`layout::MIRROR_*`).
    pub fn mirror(&self, time: Micros, topic: &'static str, body: Json) {
        self.send(Entry::Mirror { time, topic, body });
    }

    /// Program traffic not already in the steps (calls are effects, replies
    /// and events are inputs): connections, protocol lines, errors. `kind`
    /// names it (`hello`, `line_in`, `line_out`, `lost`…); `body` is any JSON.
    pub fn program(&self, time: Micros, program: &str, kind: &'static str, body: Json) {
        self.send(Entry::Program {
            time,
            program: program.to_owned(),
            kind,
            body,
        });
    }

    /// A line for people (`/log`, `foxglove.Log`): what the gateway warns
    /// about in flight, `name` saying which part of it (`link`, `vehicle`…).
    pub fn log(&self, time: Micros, level: Level, name: &'static str, message: String) {
        self.send(Entry::Log {
            time,
            level,
            name,
            message,
        });
    }

    /// Entries dropped so far because the queue was full.
    pub fn dropped(&self) -> u64 {
        self.dropped.entries.load(Ordering::Relaxed)
    }

    /// Writes what is queued, then the summary, and closes the file.
    pub fn finish(mut self) -> Result<Report, RecordError> {
        self.tx = None;
        match self.thread.take().map(JoinHandle::join) {
            Some(Ok(result)) => result,
            _ => Err(RecordError::Thread),
        }
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        self.tx = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
