//! What the recorder's handle (`recorder.rs`) and its writer thread
//! (`writer.rs`) share: the entries on the queue between them, what the
//! handle dropped, the options, the report and the errors.

use std::io;
use std::sync::atomic::AtomicU64;
use std::sync::Arc;
use std::time::Duration;

use nets::player::Digest;
use nets::{Micros, Project};
use serde_json::Value as Json;

use super::layout::Input;
use petrel_core::supervisor::Step;

/// How the recorder behaves.
#[derive(Debug, Clone)]
pub struct Options {
    /// Entries the queue holds before it drops.
    pub queue: usize,
    /// A chunk is closed (and the file synced) at least this often.
    pub flush_every: Duration,
    /// Added to Supervisor times (µs × 1000) to make MCAP log and publish
    /// times: `petrel run`, whose times count from its start, gives the
    /// UNIX time of its origin in ns; a replayed tlog's times are already
    /// UNIX µs (0).
    pub clock_offset_ns: u64,
    /// The elaboration profile's name (`ardupilot`, `px4` or the file
    /// given), recorded with the start; replay uses it unless told.
    pub profile: String,
    /// The profile's layers, `(file name, TOML text)`, base first, recorded
    /// with the start so that replay needs no profile file.
    pub profile_layers: Vec<(String, String)>,
    /// The elaboration config the Supervisor was started with, recorded
    /// with the start: replay elaborates with it.
    pub config: elaboration::Config,
    /// Called first on the writer thread, before it writes: the driver puts
    /// the thread in its scheduling policy there (`petrel run`: batch, so
    /// that the writer's wake-ups never preempt the loop).
    pub writer_started: fn(),
}

impl Default for Options {
    fn default() -> Self {
        Options {
            // About 8 s of a busy autopilot's frames at 10x (1.3 MB of entries):
            // a writer starved of CPU for seconds catches up without a drop.
            queue: 16384,
            // Under a second, so that what a kill loses (the chunk under
            // way, plus the writer's 10 ms batches) stays within one.
            flush_every: Duration::from_millis(900),
            clock_offset_ns: 0,
            profile: String::new(),
            profile_layers: Vec::new(),
            config: elaboration::Config::default(),
            writer_started: || {},
        }
    }
}

/// Why a recording could not be made.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error("cannot create the recording {path}: {source}")]
    Create { path: String, source: io::Error },
    #[error("cannot write the recording: {0}")]
    Write(String),
    #[error("the recorder's thread stopped unexpectedly")]
    Thread,
}

impl From<mcap::McapError> for RecordError {
    fn from(e: mcap::McapError) -> Self {
        if let mcap::McapError::Io(e) = &e {
            return RecordError::Write(e.to_string());
        }
        // The MCAP error's own text does not say which I/O error it was.
        let mut text = e.to_string();
        if let Some(source) = std::error::Error::source(&e) {
            text = format!("{text}: {source}");
        }
        RecordError::Write(text)
    }
}

/// What a finished recording holds.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Report {
    /// Steps written.
    pub steps: u64,
    /// Entries dropped because the queue was full.
    pub dropped: u64,
    /// Of which Supervisor steps (replay stops at the first).
    pub dropped_steps: u64,
    /// Messages written, all channels.
    pub messages: u64,
}

/// A step on the queue: its input, the frame's bytes, the step, the digest
/// after it, the frame's link.
pub(super) type StepEntry = (Input, Option<Vec<u8>>, Step, Digest, Option<usize>);

/// One entry on the queue.
pub(super) enum Entry {
    /// A step: its input (a frame's index is given by the writer), the
    /// frame's bytes, the step, the digest after it, the link the frame
    /// came in on (when told).
    Step(Box<StepEntry>),
    /// A step in which a new version of the project took over: the
    /// writer names what follows by it.
    Version(Box<(Arc<Project>, StepEntry)>),
    /// The ground mirror's replica took over a new version: the calls
    /// that follow are named by it.
    Project(Arc<Project>),
    Sent {
        time: Micros,
        bytes: Vec<u8>,
    },
    /// A frame received that is no Supervisor input (the ground mirror's).
    Received {
        time: Micros,
        bytes: Vec<u8>,
    },
    /// A step of the mirror's replica: the ground time it was played at,
    /// the call (`input: "replica"`), the step, the digest after it.
    Replica(Box<(Micros, Json, Step, Digest)>),
    /// A line on one of the mirror's own channels.
    Mirror {
        time: Micros,
        topic: &'static str,
        body: Json,
    },
    Program {
        time: Micros,
        program: String,
        kind: &'static str,
        body: Json,
    },
    Log {
        time: Micros,
        level: Level,
        name: &'static str,
        message: String,
    },
}

/// The level of a log line (`foxglove.Log`'s numbering).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    Debug = 1,
    Info = 2,
    Warning = 3,
    Error = 4,
    Fatal = 5,
}

/// What the handle dropped, shared with the writer.
#[derive(Debug, Default)]
pub(super) struct Dropped {
    pub(super) entries: AtomicU64,
    pub(super) steps: AtomicU64,
    /// Entries on the queue (the writer takes them off).
    pub(super) queued: AtomicU64,
}
