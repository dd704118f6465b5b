//! DEC as a program of the gateway: a blocking client of the program
//! protocol (docs/programs.md). It connects to the gateway's program
//! address (`tcp:HOST:PORT` or `unix:PATH`) — again and again, with a
//! growing delay, while the gateway is not there yet —, says hello with
//! every function it serves, and answers each call in order until the
//! gateway closes the connection or the stop flag is raised.

use std::io::{self, BufRead, BufReader, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
#[cfg(unix)]
use std::os::unix::net::UnixStream;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use crate::decision::{Dec, FUNCTIONS};
use crate::mission::{Mission, MissionError};
use crate::protocol::{self, BadLine, FromGateway};

/// The longest line read (the protocol's bound); longer ones are skipped.
pub const MAX_LINE: usize = 1 << 20;

/// How often a blocked read looks at the stop flag.
const POLL: Duration = Duration::from_millis(100);

/// Why DEC stopped serving.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("{0}")]
    Mission(#[from] MissionError),
    #[error("bad program address `{0}`: expected tcp:HOST:PORT or unix:PATH")]
    Address(String),
    #[error("no gateway at {address} after {attempts} attempts: {last}")]
    Unreachable {
        address: String,
        attempts: u32,
        last: io::Error,
    },
    #[error("the gateway refused DEC: {0}")]
    Refused(String),
    #[error("connection to the gateway: {0}")]
    Io(#[from] io::Error),
}

/// How DEC connects.
#[derive(Debug, Clone)]
pub struct Options {
    /// The program name in the hello (the project's `[programs.NAME]`).
    pub name: String,
    /// Connection attempts before giving up.
    pub attempts: u32,
    /// The delay after the first failed attempt; it doubles each time…
    pub first_delay: Duration,
    /// …up to this.
    pub max_delay: Duration,
}

impl Default for Options {
    fn default() -> Options {
        Options {
            name: "DEC".into(),
            attempts: 120,
            first_delay: Duration::from_millis(100),
            max_delay: Duration::from_secs(1),
        }
    }
}

/// How a session ended without error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ended {
    /// The gateway closed the connection after the welcome.
    Closed,
    /// The stop flag was raised.
    Stopped,
}

/// Serves the mission file at `mission` to the gateway at `address` until
/// the gateway closes the connection.
pub fn serve(address: &str, mission: &Path) -> Result<(), Error> {
    serve_until(address, mission, Arc::new(AtomicBool::new(false)))
}

/// As [`serve`], and returns as soon as `stop` is raised (within 0.1 s).
pub fn serve_until(address: &str, mission: &Path, stop: Arc<AtomicBool>) -> Result<(), Error> {
    let dec = Dec::new(Mission::load(mission)?);
    serve_with(address, dec, &Options::default(), &stop).map(|_| ())
}

/// Serves `dec` to the gateway at `address`.
pub fn serve_with(
    address: &str,
    mut dec: Dec,
    options: &Options,
    stop: &AtomicBool,
) -> Result<Ended, Error> {
    let Some(stream) = connect(address, options, stop)? else {
        return Ok(Ended::Stopped);
    };
    tracing::info!(address, "connected to the gateway");
    session(stream, &mut dec, options, stop)
}

enum Stream {
    Tcp(TcpStream),
    #[cfg(unix)]
    Unix(UnixStream),
}

impl Stream {
    fn set_read_timeout(&self, t: Option<Duration>) -> io::Result<()> {
        match self {
            Stream::Tcp(s) => s.set_read_timeout(t),
            #[cfg(unix)]
            Stream::Unix(s) => s.set_read_timeout(t),
        }
    }

    fn try_clone(&self) -> io::Result<Stream> {
        Ok(match self {
            Stream::Tcp(s) => Stream::Tcp(s.try_clone()?),
            #[cfg(unix)]
            Stream::Unix(s) => Stream::Unix(s.try_clone()?),
        })
    }
}

impl Read for Stream {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self {
            Stream::Tcp(s) => s.read(buf),
            #[cfg(unix)]
            Stream::Unix(s) => s.read(buf),
        }
    }
}

impl Write for Stream {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match self {
            Stream::Tcp(s) => s.write(buf),
            #[cfg(unix)]
            Stream::Unix(s) => s.write(buf),
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        match self {
            Stream::Tcp(s) => s.flush(),
            #[cfg(unix)]
            Stream::Unix(s) => s.flush(),
        }
    }
}

enum Target {
    Tcp(String),
    #[cfg(unix)]
    Unix(std::path::PathBuf),
}

fn target(address: &str) -> Result<Target, Error> {
    if let Some(rest) = address.strip_prefix("tcp:") {
        // HOST:PORT, checked now so that a typo is not retried for minutes.
        let ok = rest
            .rsplit_once(':')
            .is_some_and(|(host, port)| !host.is_empty() && port.parse::<u16>().is_ok());
        if ok {
            return Ok(Target::Tcp(rest.to_owned()));
        }
    }
    #[cfg(unix)]
    if let Some(path) = address.strip_prefix("unix:") {
        if !path.is_empty() {
            return Ok(Target::Unix(path.into()));
        }
    }
    Err(Error::Address(address.to_owned()))
}

fn open(target: &Target) -> io::Result<Stream> {
    match target {
        Target::Tcp(hostport) => {
            let mut last = io::Error::new(io::ErrorKind::NotFound, "no address");
            for addr in hostport.to_socket_addrs()? {
                match TcpStream::connect_timeout(&addr, Duration::from_secs(2)) {
                    Ok(s) => {
                        s.set_nodelay(true)?;
                        return Ok(Stream::Tcp(s));
                    }
                    Err(e) => last = e,
                }
            }
            Err(last)
        }
        #[cfg(unix)]
        Target::Unix(path) => UnixStream::connect(path).map(Stream::Unix),
    }
}

/// Connects, retrying with a doubling delay; `None` when stopped.
fn connect(address: &str, options: &Options, stop: &AtomicBool) -> Result<Option<Stream>, Error> {
    let target = target(address)?;
    let mut delay = options.first_delay;
    let mut attempt = 0;
    loop {
        if stop.load(Ordering::Relaxed) {
            return Ok(None);
        }
        attempt += 1;
        match open(&target) {
            Ok(s) => return Ok(Some(s)),
            Err(e) if attempt >= options.attempts.max(1) => {
                return Err(Error::Unreachable {
                    address: address.to_owned(),
                    attempts: attempt,
                    last: e,
                })
            }
            Err(e) => {
                tracing::debug!(address, attempt, error = %e, "no gateway yet");
            }
        }
        // Sleep in slices, so that a stop is seen at once.
        let mut left = delay;
        while !left.is_zero() {
            if stop.load(Ordering::Relaxed) {
                return Ok(None);
            }
            let slice = left.min(POLL);
            std::thread::sleep(slice);
            left -= slice;
        }
        delay = (delay * 2).min(options.max_delay);
    }
}

enum Line {
    Complete(Vec<u8>),
    TooLong,
    Eof,
    Stopped,
}

/// Reads one line (without its `\n`, a `\r` before it dropped), keeping a
/// partial line across read timeouts.
fn read_line(reader: &mut BufReader<Stream>, stop: &AtomicBool) -> io::Result<Line> {
    let mut line = Vec::new();
    let mut too_long = false;
    loop {
        if stop.load(Ordering::Relaxed) {
            return Ok(Line::Stopped);
        }
        let (done, used) = match reader.fill_buf() {
            Ok([]) => return Ok(Line::Eof),
            Ok(buf) => match buf.iter().position(|&b| b == b'\n') {
                Some(i) => {
                    if !too_long {
                        line.extend_from_slice(&buf[..i]);
                    }
                    (true, i + 1)
                }
                None => {
                    if !too_long {
                        line.extend_from_slice(buf);
                    }
                    (false, buf.len())
                }
            },
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock
                        | io::ErrorKind::TimedOut
                        | io::ErrorKind::Interrupted
                ) =>
            {
                continue
            }
            Err(e) => return Err(e),
        };
        reader.consume(used);
        if line.len() > MAX_LINE {
            too_long = true;
            line = Vec::new();
        }
        if done {
            if too_long {
                return Ok(Line::TooLong);
            }
            if line.last() == Some(&b'\r') {
                line.pop();
            }
            return Ok(Line::Complete(line));
        }
    }
}

fn session(
    stream: Stream,
    dec: &mut Dec,
    options: &Options,
    stop: &AtomicBool,
) -> Result<Ended, Error> {
    stream.set_read_timeout(Some(POLL))?;
    let mut writer = stream.try_clone()?;
    let mut reader = BufReader::new(stream);
    writer.write_all(protocol::hello(&options.name, FUNCTIONS).as_bytes())?;
    writer.flush()?;
    let mut welcomed = false;
    loop {
        let line = match read_line(&mut reader, stop) {
            Ok(Line::Complete(line)) => line,
            Ok(Line::TooLong) => {
                tracing::warn!("skipped a line longer than {MAX_LINE} bytes from the gateway");
                continue;
            }
            Ok(Line::Stopped) => return Ok(Ended::Stopped),
            Ok(Line::Eof) if welcomed => {
                tracing::info!("the gateway closed the connection");
                return Ok(Ended::Closed);
            }
            Ok(Line::Eof) => {
                return Err(Error::Refused(
                    "the connection closed before the welcome".into(),
                ))
            }
            Err(e) if welcomed && is_disconnect(&e) => return Ok(Ended::Closed),
            Err(e) => return Err(e.into()),
        };
        if line.iter().all(u8::is_ascii_whitespace) {
            continue;
        }
        let reply = match protocol::parse(&line) {
            Ok(FromGateway::Welcome {
                functions,
                answered,
            }) => {
                welcomed = true;
                tracing::info!(?functions, "welcomed by the gateway");
                // A new process after a restart: what the one before
                // answered rebuilds the state (a reconnection of this
                // process keeps its own).
                if dec.calls() == 0 && !answered.is_empty() {
                    dec.resume(&answered);
                    tracing::info!(calls = answered.len(), "resumed the flight's decisions");
                }
                continue;
            }
            Ok(FromGateway::Error { message, line }) if !welcomed => {
                return Err(Error::Refused(match line {
                    Some(n) => format!("{message} (line {n})"),
                    None => message,
                }));
            }
            Ok(FromGateway::Error { message, line }) => {
                tracing::warn!(line, "the gateway could not take a line of ours: {message}");
                continue;
            }
            Ok(FromGateway::Call { id, function, args }) => {
                let answer = dec.call(&function, &args);
                match &answer {
                    Ok(p) => {
                        tracing::info!(id, function, ?args, params = %serde_json::Value::Object(p.clone()), "done")
                    }
                    Err(reason) => tracing::warn!(id, function, ?args, reason, "failed"),
                }
                match answer {
                    Ok(p) => protocol::done(id, p),
                    Err(reason) => protocol::failed(id, &reason),
                }
            }
            Err(BadLine::Call { id, reason }) => {
                tracing::warn!(id, reason, "malformed call");
                protocol::failed(id, &format!("malformed call: {reason}"))
            }
            Err(e) => {
                tracing::warn!("a line from the gateway was not understood: {e}");
                continue;
            }
        };
        match writer
            .write_all(reply.as_bytes())
            .and_then(|()| writer.flush())
        {
            Ok(()) => {}
            Err(e) if welcomed && is_disconnect(&e) => return Ok(Ended::Closed),
            Err(e) => return Err(e.into()),
        }
    }
}

fn is_disconnect(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::BrokenPipe
            | io::ErrorKind::ConnectionReset
            | io::ErrorKind::ConnectionAborted
            | io::ErrorKind::UnexpectedEof
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses() {
        assert!(
            matches!(target("tcp:127.0.0.1:5790"), Ok(Target::Tcp(a)) if a == "127.0.0.1:5790")
        );
        assert!(matches!(target("tcp:localhost:1"), Ok(Target::Tcp(_))));
        #[cfg(unix)]
        assert!(matches!(
            target("unix:/run/petrel.sock"),
            Ok(Target::Unix(_))
        ));
        for bad in [
            "127.0.0.1:5790",
            "tcp:127.0.0.1",
            "tcp::80",
            "tcp:h:99999",
            "unix:",
            "udp:x:1",
        ] {
            assert!(matches!(target(bad), Err(Error::Address(_))), "{bad}");
        }
    }

    #[test]
    fn a_stop_ends_the_wait_for_a_gateway() {
        let stop = AtomicBool::new(true);
        let dec = Dec::new(crate::mission::tests::example());
        let ended = serve_with("tcp:127.0.0.1:9", dec, &Options::default(), &stop);
        assert!(matches!(ended, Ok(Ended::Stopped)));
    }
}
