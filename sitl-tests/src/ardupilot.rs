//! ArduPilot's own SITL (`../shared/ardupilot-sitl`: the real ArduPlane and
//! ArduCopter flight code on a built-in physics model): found, started in a
//! scratch folder of its own, and always reaped (on drop, even when a test
//! panics).
//!
//! Where the binaries are: `ARDUPILOT_SITL`/`ARDUPILOT_DEFAULTS` (a binary
//! and its parameter file; `ARDUPILOT_COPTER_SITL`/`ARDUPILOT_COPTER_DEFAULTS`
//! for the copter), else `shared/ardupilot-sitl/` beside the repository.
//! [`require`] is how a test asks for them: absent, it prints why and the
//! test returns; with `CI=true` it panics, so that CI never counts a skip
//! as a pass.
//!
//! What the real SITL does that a harness must know:
//! - SERIAL0 is TCP `5760 + 10 × instance`, SERIAL1 `+2`, SERIAL2 `+3`;
//!   the simulation does not start until a client has connected to
//!   SERIAL0 ("Waiting for connection"), and each serial port takes one
//!   client.
//! - it writes `eeprom.bin` and `logs/` in its working directory;
//!   [`Sitl::start`] always wipes them (`--wipe`) for a fresh vehicle.
//! - extra parameters go in a file of their own after the standard
//!   defaults (`--defaults std,extra`), as ArduPilot's autotest does.

use std::io::Write;
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Which ArduPilot vehicle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Firmware {
    Plane,
    Copter,
}

impl Firmware {
    fn binary(self) -> &'static str {
        match self {
            Firmware::Plane => "arduplane",
            Firmware::Copter => "arducopter",
        }
    }

    fn parm(self) -> &'static str {
        match self {
            Firmware::Plane => "plane.parm",
            Firmware::Copter => "copter.parm",
        }
    }

    /// The physics model SITL flies (`--model`).
    pub fn model(self) -> &'static str {
        match self {
            Firmware::Plane => "plane",
            Firmware::Copter => "quad",
        }
    }

    fn env(self) -> (&'static str, &'static str) {
        match self {
            Firmware::Plane => ("ARDUPILOT_SITL", "ARDUPILOT_DEFAULTS"),
            Firmware::Copter => ("ARDUPILOT_COPTER_SITL", "ARDUPILOT_COPTER_DEFAULTS"),
        }
    }
}

/// A SITL binary and its standard parameter file.
#[derive(Clone, Debug)]
pub struct Located {
    pub firmware: Firmware,
    pub binary: PathBuf,
    pub defaults: PathBuf,
}

/// `shared/` beside the repository (the workspace's parent folder), or
/// `PETREL_SHARED`.
pub fn shared_dir() -> PathBuf {
    crate::skip::shared_dir()
}

/// Finds the binary and its defaults, or says why not.
pub fn locate(firmware: Firmware) -> Result<Located, String> {
    let (bin_var, defaults_var) = firmware.env();
    let (binary, defaults) = match (std::env::var_os(bin_var), std::env::var_os(defaults_var)) {
        (Some(b), Some(d)) => (PathBuf::from(b), PathBuf::from(d)),
        (Some(_), None) | (None, Some(_)) => {
            return Err(format!("{bin_var} and {defaults_var} must be set together"))
        }
        (None, None) => {
            let dir = shared_dir().join("ardupilot-sitl");
            (dir.join(firmware.binary()), dir.join(firmware.parm()))
        }
    };
    for path in [&binary, &defaults] {
        if !path.is_file() {
            return Err(format!(
                "{} is missing (set {bin_var}/{defaults_var}, or put shared/ardupilot-sitl beside the repository)",
                path.display()
            ));
        }
    }
    Ok(Located {
        firmware,
        binary,
        defaults,
    })
}

/// True when a missing peer must fail the test rather than skip it.
pub fn in_ci() -> bool {
    crate::skip::in_ci()
}

/// The SITL binary for `firmware`, or `None` after printing why the test
/// is skipped; panics when `CI=true`.
pub fn require(firmware: Firmware, test: &str) -> Option<Located> {
    match locate(firmware) {
        Ok(l) => Some(l),
        Err(why) if in_ci() => panic!("{test}: ArduPilot SITL is required in CI: {why}"),
        Err(why) => {
            crate::skip::skip(&format!("no ArduPilot SITL: {why}"));
            None
        }
    }
}

/// How to start one SITL.
#[derive(Clone, Debug)]
pub struct Options {
    /// `-I`: ports 5760 + 10 × instance; distinct per SITL running at once.
    /// The gateway's real-firmware tests number theirs in
    /// `gateway/tests/real/main.rs` (two flights at once, on instances 0-16
    /// and 20-36); this crate's own `tests/sitl.rs` flies 8.
    pub instance: u8,
    /// `--speedup`.
    pub speedup: u32,
    /// `--sysid` (MAV_SYSID), when not the default 1.
    pub sysid: Option<u8>,
    /// `--home lat,lon,alt,heading`.
    pub home: (f64, f64, f64, f64),
    /// Parameters set at boot, after the standard defaults.
    pub params: Vec<(String, f64)>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            instance: 0,
            speedup: 5,
            sysid: None,
            home: (-35.363261, 149.165230, 584.0, 353.0),
            params: Vec::new(),
        }
    }
}

/// A running SITL process, killed and reaped on drop.
#[derive(Debug)]
pub struct Sitl {
    child: Option<Child>,
    instance: u8,
    dir: PathBuf,
}

impl Sitl {
    /// Starts it in `dir` (created; its eeprom wiped) and waits until
    /// SERIAL0 listens (at most 20 s). It does not connect: the first
    /// client of SERIAL0 starts the simulation.
    pub fn start(located: &Located, options: &Options, dir: &Path) -> std::io::Result<Sitl> {
        std::fs::create_dir_all(dir)?;
        let mut defaults = located.defaults.clone().into_os_string();
        if !options.params.is_empty() {
            let extra = dir.join("extra.parm");
            let mut f = std::fs::File::create(&extra)?;
            for (name, value) in &options.params {
                writeln!(f, "{name} {value}")?;
            }
            defaults.push(",");
            defaults.push(extra.as_os_str());
        }
        let (lat, lon, alt, heading) = options.home;
        let mut cmd = Command::new(&located.binary);
        cmd.current_dir(dir)
            .args(["--model", located.firmware.model()])
            .args(["--speedup", &options.speedup.to_string()])
            .arg(format!("-I{}", options.instance))
            .arg("--wipe")
            .arg("--defaults")
            .arg(defaults)
            .args(["--home", &format!("{lat},{lon},{alt},{heading}")])
            .stdin(Stdio::null())
            .stdout(Stdio::from(std::fs::File::create(dir.join("sitl.out"))?))
            .stderr(Stdio::from(std::fs::File::create(dir.join("sitl.err"))?));
        if let Some(sysid) = options.sysid {
            cmd.args(["--sysid", &sysid.to_string()]);
        }
        let child = cmd.spawn()?;
        let mut sitl = Sitl {
            child: Some(child),
            instance: options.instance,
            dir: dir.to_owned(),
        };
        sitl.wait_listening(Duration::from_secs(20))?;
        Ok(sitl)
    }

    /// TCP port of SERIALn (0, 1 or 2).
    pub fn port(&self, serial: u8) -> u16 {
        let base = 5760 + 10 * u16::from(self.instance);
        match serial {
            0 => base,
            1 => base + 2,
            _ => base + 3,
        }
    }

    /// `tcpout:127.0.0.1:PORT` of SERIALn, for `petrel run --mavlink`.
    pub fn address(&self, serial: u8) -> String {
        format!("tcpout:127.0.0.1:{}", self.port(serial))
    }

    /// The folder it runs in (its `sitl.out`, `sitl.err`, `logs/`).
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// What SITL printed so far, for failure messages.
    pub fn output(&self) -> String {
        let out = std::fs::read_to_string(self.dir.join("sitl.out")).unwrap_or_default();
        let err = std::fs::read_to_string(self.dir.join("sitl.err")).unwrap_or_default();
        format!("{out}{err}")
    }

    /// Whether the process is still running.
    pub fn running(&mut self) -> bool {
        self.child
            .as_mut()
            .is_some_and(|c| matches!(c.try_wait(), Ok(None)))
    }

    /// SITL announces "SERIAL0 on TCP port N" once it listens; connecting
    /// to probe would take SERIAL0's one client slot, so its output is
    /// read instead.
    fn wait_listening(&mut self, limit: Duration) -> std::io::Result<()> {
        let started = Instant::now();
        let needle = format!("SERIAL0 on TCP port {}", self.port(0));
        while started.elapsed() < limit {
            if self.output().contains(&needle) {
                return Ok(());
            }
            if !self.running() {
                return Err(std::io::Error::other(format!(
                    "SITL exited at start:\n{}",
                    self.output()
                )));
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        Err(std::io::Error::new(
            std::io::ErrorKind::TimedOut,
            format!(
                "SITL did not listen on {} within {limit:?}:\n{}",
                self.port(0),
                self.output()
            ),
        ))
    }

    /// Kills and reaps it now (also on drop).
    pub fn stop(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

impl Drop for Sitl {
    fn drop(&mut self) {
        self.stop();
    }
}

/// Connects to a SITL serial port that already listens, within `limit`.
pub fn connect(port: u16, limit: Duration) -> std::io::Result<TcpStream> {
    let started = Instant::now();
    loop {
        match TcpStream::connect(("127.0.0.1", port)) {
            Ok(s) => return Ok(s),
            Err(e) if started.elapsed() > limit => return Err(e),
            Err(_) => std::thread::sleep(Duration::from_millis(100)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ports_follow_the_instance() {
        assert_eq!(Firmware::Plane.model(), "plane");
        assert_eq!(Firmware::Copter.model(), "quad");
        let sitl = Sitl {
            child: None,
            instance: 3,
            dir: PathBuf::from("/tmp"),
        };
        assert_eq!(
            (sitl.port(0), sitl.port(1), sitl.port(2)),
            (5790, 5792, 5793)
        );
        assert_eq!(sitl.address(1), "tcpout:127.0.0.1:5792");
    }
}
