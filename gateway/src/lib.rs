//! The gateway's library: the drivers, everything `petrel` does that
//! touches the world and is not a verb.
//!
//! The decisions are `petrel_core`'s (the onboard and ground cores, the
//! supervisor, the team, the commanders, the mirror): this crate moves
//! their bytes. It owns the MAVLink links ([`link`]: reading, writing,
//! signing on the wire, the mirror's uplink), the program server and the
//! started programs ([`programs`]), preflight, a version's files packed
//! for the uplink ([`upload`]), the clock and the threads'
//! scheduling (the recorder's and the web pages' threads too; the
//! recording itself is `petrel_record`'s, the pages `petrel_web`'s). The `petrel` binary's `cli/`
//! parses arguments and drives these; nothing here imports `cli/`, reads
//! arguments or decides an exit status.

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
pub mod link;
pub mod preflight;
pub mod programs;
pub mod scheduling;
pub mod upload;
