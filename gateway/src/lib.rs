//! The gateway's library: everything `petrel` does that is not a verb.
//!
//! It owns the supervisor (elaboration and the player as one sans-IO state
//! machine), the team, the vehicle commander and crew, the program
//! protocol and its server, the MAVLink links and signing, the recording
//! (MCAP), the ground mirror (record codec, publisher, replica, check,
//! dialog), the web pages (monitor, view, editor), preflight and the
//! project's loading. The `petrel` binary's `cli/` parses arguments and
//! drives these; nothing here imports `cli/`, reads arguments or decides
//! an exit status.
//!
//! Modules that do no I/O: [`supervisor`], [`team`], [`vehicle`],
//! [`programs::session`], [`mirror`]'s record, replica, check and dialog,
//! [`edit`]'s draft. Those that touch the world: [`link`], [`record`]'s
//! writer, [`programs`]' server, [`monitor`], [`clock`].

/// `eprintln!` that never panics: a message for people is lost, not the
/// process, when stderr cannot be written (`2>/dev/full`, a closed pipe).
#[macro_export]
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

/// `eprint!` that never panics (see `say!`).
#[macro_export]
macro_rules! say_part {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let mut err = std::io::stderr();
        let _ = write!(err, $($arg)*);
        let _ = err.flush();
    }};
}

/// `println!` that never panics: a reader that stopped reading (`| head`)
/// or a full disk loses the lines, not the process (a flight under way
/// goes on, and its recording is finished).
#[macro_export]
macro_rules! show {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

pub mod clock;
pub mod edit;
pub mod link;
pub mod mirror;
pub mod monitor;
pub mod onboard;
pub mod preflight;
pub mod profile;
pub mod programs;
pub mod project;
pub mod record;
pub mod scheduling;
pub mod supervisor;
pub mod team;
pub mod vehicle;
