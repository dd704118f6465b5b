//! Recording (MCAP): everything `petrel run` sees and decides, in one file
//! that Foxglove and PlotJuggler open and `petrel replay` replays exactly.
//! The layout (channels, encodings, times, the inputs log) is in
//! docs/recording.md.
//!
//! This crate owns the file: the typed records that the writer writes and
//! the reader reads ([`layout`], one type for both), the writer thread, and
//! reading back and recovering a cut file. It never decides anything (the
//! steps come from `petrel_core`'s supervisor), never opens a socket, and
//! never sets a thread's scheduling: the driver does, through
//! [`recorder::Options::writer_started`].
//!
//! - [`recorder`]: the [`recorder::Recorder`] handle, over a bounded queue
//!   to the writer thread (`writer.rs`, which owns the file): the caller
//!   never waits and never fails; what is dropped is counted and recorded.
//! - [`layout`]: topics, encodings, schemas, the JSON of inputs.
//! - [`decoded`]: MAVLink messages as flat JSON with a schema per type.
//! - [`read`]: a recording read back, tolerant of a cut file.
//! - [`check`]: a replayed step compared with the recorded one.
//!
//! # Using it from `petrel run`
//!
//! ```text
//! use record::recorder::{Options, Recorder};
//! let recorder = Recorder::create(path, project.clone(),
//!     Options { clock_offset_ns, profile: "ardupilot".into(), config: config.clone(), ..Default::default() })?;
//! let (mut sup, start) = Supervisor::start(project, profile, config, now);
//! recorder.start(&start, sup.player());
//! loop {
//!     let input = Input::Frame(&received.bytes);      // or Tick, Result, Event
//!     let step = recorder.feed(&mut sup, now, input);  // sup.step + recorder.step; never blocks
//!     // carry out the effects; every frame sent: recorder.sent(now, &bytes)
//!     // program traffic beyond calls/replies/events: recorder.program(now, name, kind, json)
//!     // lines for people (/log): recorder.log(now, Level::Warning, "link", text)
//! }
//! let report = recorder.finish()?;                    // on SIGINT/SIGTERM: the summary
//! ```

pub mod check;
pub mod decoded;
mod fields;
pub mod file;
pub mod layout;
mod queue;
pub mod read;
pub mod recorder;
pub mod recover;
mod writer;
