//! PX4's own SITL (`../shared/px4-sitl`: PX4 v1.18's flight stack flying its
//! built-in SIH physics model, no Gazebo): found, started in a scratch folder
//! of its own on an instance number no other PX4 of this process holds, and
//! always killed and reaped (on drop, even when a test panics).
//!
//! Where the build is: `PX4_SITL` (the folder holding `px4`, `run-sih.sh`
//! and `etc/`), else `shared/px4-sitl/` beside the repository. [`require`]
//! is how a test asks for it: absent, it prints why and the test returns;
//! with `CI=true` it panics, so that CI never counts a skip as a pass.
//!
//! What the real SITL does that a harness must know:
//! - PX4 runs its modules through `px4-<module>` links beside the binary.
//!   A copy that lost its symbolic links (each `px4-*` a 3-byte file saying
//!   `px4`) cannot start; [`Px4::start`] therefore runs it from a folder of
//!   links it makes in the scratch folder (`bin/`), which works either way.
//! - MAVLink is UDP on 127.0.0.1: the onboard link (a companion computer
//!   such as Petrel) listens on 14580+I and sends to 14540+I; the ground
//!   station link listens on 18570+I and sends to 14550, the same port for
//!   every instance — a test listens on the onboard port, or speaks first to
//!   18570+I (PX4 answers where traffic comes from). MAV_SYS_ID is I+1.
//! - Its parameters, `dataman` (missions) and logs go to the working folder;
//!   a fresh folder is a fresh vehicle. Parameters are set at start with
//!   `PX4_PARAM_<NAME>=<value>`.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};

/// The airframe SIH flies (`run-sih.sh -m`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Model {
    /// 10040 sihsim_quadx.
    Quad,
    /// 10041 sihsim_airplane, with the corrections `run-sih.sh` applies.
    Plane,
    /// 10043 standard VTOL.
    Vtol,
}

impl Model {
    pub fn arg(self) -> &'static str {
        match self {
            Model::Quad => "quad",
            Model::Plane => "plane",
            Model::Vtol => "vtol",
        }
    }
}

/// The SITL build's folder.
#[derive(Clone, Debug)]
pub struct Located {
    pub dir: PathBuf,
}

/// Finds the build, or says why not.
pub fn locate() -> Result<Located, String> {
    let dir = match std::env::var_os("PX4_SITL") {
        Some(d) => PathBuf::from(d),
        None => crate::ardupilot::shared_dir().join("px4-sitl"),
    };
    for needed in ["px4", "run-sih.sh", "px4-alias.sh", "etc/init.d-posix/rcS"] {
        if !dir.join(needed).is_file() {
            return Err(format!(
                "{} is missing (set PX4_SITL, or put shared/px4-sitl beside the repository)",
                dir.join(needed).display()
            ));
        }
    }
    Ok(Located { dir })
}

/// The build, or `None` after printing why the test is skipped; panics when
/// `CI=true`.
pub fn require(test: &str) -> Option<Located> {
    match locate() {
        Ok(l) => Some(l),
        Err(why) if crate::ardupilot::in_ci() => {
            panic!("{test}: PX4 SITL is required in CI: {why}")
        }
        Err(why) => {
            crate::skip::skip(&format!("no PX4 SITL: {why}"));
            None
        }
    }
}

/// How to start one.
#[derive(Clone, Debug)]
pub struct Options {
    pub model: Model,
    /// `-s`: SIH in lockstep this many times faster than the wall clock
    /// (PX4 scales its loss timeouts itself).
    pub speed: u32,
    /// `PX4_PARAM_<NAME>=<value>`, applied after the airframe's.
    pub params: Vec<(String, f64)>,
    /// Write a ULog (about 9 MB per 40 s of flight).
    pub log: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            model: Model::Quad,
            speed: 10,
            params: Vec::new(),
            log: false,
        }
    }
}

/// Instance numbers this process may use (other PX4 users take others).
pub const INSTANCES: [u8; 4] = [0, 1, 2, 3];

static TAKEN: Mutex<[bool; 4]> = Mutex::new([false; 4]);
static FREED: Condvar = Condvar::new();

/// An instance number held while a PX4 runs, given back on drop.
#[derive(Debug)]
struct Instance(usize);

impl Instance {
    fn take() -> Instance {
        let mut taken = TAKEN.lock().unwrap_or_else(|e| e.into_inner());
        loop {
            if let Some(i) = taken.iter().position(|t| !t) {
                taken[i] = true;
                return Instance(i);
            }
            taken = FREED.wait(taken).unwrap_or_else(|e| e.into_inner());
        }
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        let mut taken = TAKEN.lock().unwrap_or_else(|e| e.into_inner());
        taken[self.0] = false;
        FREED.notify_all();
    }
}

/// A running PX4, killed and reaped on drop.
#[derive(Debug)]
pub struct Px4 {
    child: Option<Child>,
    // Dropped after `child` is reaped (field order), never before.
    instance: Instance,
    dir: PathBuf,
}

impl Px4 {
    /// Starts it in `dir` (created: `bin/` the links it runs from, `work/`
    /// its parameters, dataman and logs) on a free instance, and waits until
    /// its start-up script has finished (at most 60 s).
    pub fn start(located: &Located, options: &Options, dir: &Path) -> std::io::Result<Px4> {
        let bin = links(located, &dir.join("bin"))?;
        let work = dir.join("work");
        std::fs::create_dir_all(&work)?;
        let instance = Instance::take();
        let mut cmd = Command::new(bin.join("run-sih.sh"));
        cmd.arg(&work)
            .args(["-i", &INSTANCES[instance.0].to_string()])
            .args(["-m", options.model.arg()])
            .args(["-s", &options.speed.to_string()])
            .current_dir(dir)
            .stdin(Stdio::null())
            .stdout(Stdio::from(std::fs::File::create(dir.join("px4.out"))?))
            .stderr(Stdio::from(std::fs::File::create(dir.join("px4.err"))?));
        if !options.log {
            cmd.env("PX4_PARAM_SDLOG_MODE", "-1");
        }
        for (name, value) in &options.params {
            cmd.env(format!("PX4_PARAM_{name}"), value.to_string());
        }
        let child = cmd.spawn()?;
        let mut px4 = Px4 {
            child: Some(child),
            instance,
            dir: dir.to_owned(),
        };
        px4.wait_started(Duration::from_secs(60))?;
        Ok(px4)
    }

    /// Its instance number (MAV_SYS_ID is this + 1).
    pub fn instance(&self) -> u8 {
        INSTANCES[self.instance.0]
    }

    /// Its MAVLink system id.
    pub fn system_id(&self) -> u8 {
        self.instance() + 1
    }

    /// Where PX4 sends its onboard link (14540+I): a companion listens
    /// there (`udpin:127.0.0.1:PORT`) and PX4 answers where it speaks from.
    pub fn onboard_port(&self) -> u16 {
        14540 + u16::from(self.instance())
    }

    /// Where the onboard link listens (14580+I).
    pub fn onboard_listen_port(&self) -> u16 {
        14580 + u16::from(self.instance())
    }

    /// Where the ground station link listens (18570+I); it answers the
    /// first who speaks to it.
    pub fn gcs_port(&self) -> u16 {
        18570 + u16::from(self.instance())
    }

    /// Its scratch folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// What PX4 printed so far (its console), for failure messages.
    pub fn output(&self) -> String {
        let out = std::fs::read_to_string(self.dir.join("px4.out")).unwrap_or_default();
        let err = std::fs::read_to_string(self.dir.join("px4.err")).unwrap_or_default();
        format!("{out}{err}")
    }

    /// Whether the process is still running.
    pub fn running(&mut self) -> bool {
        self.child
            .as_mut()
            .is_some_and(|c| matches!(c.try_wait(), Ok(None)))
    }

    fn wait_started(&mut self, limit: Duration) -> std::io::Result<()> {
        let started = Instant::now();
        while started.elapsed() < limit {
            let out = self.output();
            if out.contains("Startup script returned successfully") {
                return Ok(());
            }
            if out.contains("Startup script returned with return value") || !self.running() {
                self.stop();
                return Err(std::io::Error::other(format!(
                    "PX4 SITL failed to start:\n{}",
                    self.output()
                )));
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        self.stop();
        Err(std::io::Error::new(
            std::io::ErrorKind::TimedOut,
            format!(
                "PX4 SITL did not finish starting within {limit:?}:\n{}",
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

impl Drop for Px4 {
    fn drop(&mut self) {
        self.stop();
    }
}

/// A folder of links that runs the build at `located`: `px4`, each
/// `px4-<module>` (a link to `px4`, whatever the copy holds), `px4-alias.sh`,
/// `etc`, `shim` and `run-sih.sh`. Returns the folder.
fn links(located: &Located, bin: &Path) -> std::io::Result<PathBuf> {
    std::fs::create_dir_all(bin)?;
    let source = located.dir.canonicalize()?;
    for entry in std::fs::read_dir(&source)? {
        let entry = entry?;
        let name = entry.file_name();
        let Some(text) = name.to_str() else { continue };
        let target = if text.starts_with("px4-") && text != "px4-alias.sh" {
            PathBuf::from("px4")
        } else if matches!(text, "px4" | "px4-alias.sh" | "etc" | "shim" | "run-sih.sh") {
            source.join(text)
        } else {
            continue;
        };
        let link = bin.join(text);
        if link.symlink_metadata().is_err() {
            std::os::unix::fs::symlink(&target, &link)?;
        }
    }
    Ok(bin.to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scratch::Scratch;

    #[test]
    fn instances_are_taken_once_and_given_back() {
        let all: Vec<Instance> = (0..INSTANCES.len()).map(|_| Instance::take()).collect();
        let mut numbers: Vec<usize> = all.iter().map(|i| i.0).collect();
        numbers.sort_unstable();
        assert_eq!(numbers, vec![0, 1, 2, 3]);
        drop(all);
        let again = Instance::take();
        assert!(again.0 < 4);
    }

    #[test]
    fn links_rebuild_a_copy_that_lost_its_symbolic_links() {
        let root = Scratch::new("px4-links");
        let build = root.join("build");
        std::fs::create_dir_all(build.join("etc")).expect("etc");
        for (name, text) in [
            ("px4", "ELF"),
            ("px4-param", "px4"),
            ("px4-alias.sh", "#"),
            ("run-sih.sh", "#"),
            ("README.md", "x"),
        ] {
            std::fs::write(build.join(name), text).expect("write");
        }
        let bin = links(&Located { dir: build.clone() }, &root.join("bin")).expect("links");
        let target = |n: &str| std::fs::read_link(bin.join(n)).expect(n);
        assert_eq!(target("px4-param"), PathBuf::from("px4"));
        let build = build.canonicalize().expect("canonical");
        assert_eq!(target("px4"), build.join("px4"));
        assert_eq!(target("etc"), build.join("etc"));
        assert_eq!(target("px4-alias.sh"), build.join("px4-alias.sh"));
        assert!(bin.join("README.md").symlink_metadata().is_err());
        // Again over the same folder: nothing to redo, no error.
        links(&Located { dir: build }, &bin).expect("links again");
    }
}
