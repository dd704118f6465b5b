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
//!
//! ```
//! use elaboration::{Config, Elaborator, Profile, TlogReader};
//!
//! # fn main() -> Result<(), elaboration::ProfileError> {
//! let profile = Profile::builtin("ardupilot")?;
//! // Or a project's layer over it, each text with its file name for errors:
//! // Profile::load(&[("ardupilot.toml", elaboration::profile::ARDUPILOT), ("project.toml", &text)])?
//! let mut elaborator = Elaborator::new(profile, Config::default());
//! let tlog: Vec<u8> = Vec::new(); // the bytes of a .tlog
//! for record in TlogReader::new(&tlog) {
//!     elaborator.frame(record.time_us, &record.frame);
//!     while let Some(e) = elaborator.poll_event() {
//!         println!("{} {} {}", e.time_us, e.event.category, e.event);
//!     }
//! }
//! // On a live link, call `elaborator.tick(now_us)` regularly so that
//! // timeouts (link loss) fire while nothing arrives.
//! # Ok(())
//! # }
//! ```

pub mod constants;
pub mod elaborator;
pub mod expr;
pub mod fields;
pub mod frame;
pub mod profile;
pub mod statustext;
pub mod tlog;

pub use constants::Firmware;
pub use elaborator::{Config, Elaborated, Elaborator, Stats};
pub use frame::{Frame, FrameError};
pub use profile::{Needs, Problem, Profile, ProfileError, Rule, SourceFilter};
pub use tlog::{ReadStats, Record, TlogReader, TlogWriter};
