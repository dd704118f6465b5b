//! Elaboration: MAVLink telemetry in, supervision events out.
//!
//! It owns the tlog format (reader and writer over bytes), the framing of
//! MAVLink frames (checksums and decoding are rust-mavlink's), the rule
//! language of profiles (TOML, compiled once), the built-in ArduPilot and
//! PX4 profiles, and the [`Elaborator`]: a sans-IO state machine fed
//! `(time, frame)` and `tick(time)`, polled for [`Elaborated`] events.
//!
//! It never does I/O, never reads a clock (time is the frame's receive time
//! in microseconds), and never panics on input: bad frames, unknown ids and
//! undecodable messages are counted.

pub mod constants;
pub mod elaborator;
pub mod expr;
pub mod fields;
pub mod frame;
pub mod profile;
pub mod tlog;

pub use constants::Firmware;
pub use elaborator::{Config, Elaborated, Elaborator, Stats};
pub use frame::{Frame, FrameError};
pub use profile::{Problem, Profile, ProfileError, Rule, SourceFilter};
pub use tlog::{ReadStats, Record, TlogReader, TlogWriter};
