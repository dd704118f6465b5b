//! What the multi-vehicle tests share (`multi_vehicle.rs`: a gateway per
//! vehicle; `team.rs`: one gateway for the team): MAVProxy as the router
//! and what its tlog saw, child processes reaped even when a test fails,
//! free loopback ports, scripted frames. A module of the `it` binary (the
//! scripted vehicles) and of `real` (the SITL copters), each using a part.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use elaboration::TlogReader;
use mavlink::dialects::ardupilotmega::{
    MavAutopilot, MavCmd, MavMessage, MavModeFlag, MavState, MavType, HEARTBEAT_DATA,
};
use mavlink::{MavHeader, MavlinkVersion};
use sitl_tests::ardupilot;

/// `mavproxy.py` on the PATH, or why not (a failure under CI=true).
pub fn mavproxy(test: &str) -> Option<PathBuf> {
    let found = std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|p| p.join("mavproxy.py"))
            .find(|p| p.is_file())
    });
    match found {
        Some(p) => Some(p),
        None if ardupilot::in_ci() => panic!("{test}: MAVProxy (mavproxy.py) is required in CI"),
        None => {
            sitl_tests::skip::skip("mavproxy.py is not on the PATH (pip install MAVProxy)");
            None
        }
    }
}

/// Two real ArduCopter SITLs side by side, SITL instances `first` and
/// `first + 1`, system ids 1 and 2, homes 0.001° of longitude apart (about
/// 90 m), at `speedup`, with MAVProxy to route them: `None` (the test is
/// skipped, saying why; a failure under CI=true) when either is missing.
pub fn two_copters(
    test: &str,
    first: u8,
    speedup: u32,
    dir: &Path,
) -> Option<(PathBuf, ardupilot::Sitl, ardupilot::Sitl)> {
    let copter = ardupilot::require(ardupilot::Firmware::Copter, test)?;
    let mavproxy = mavproxy(test)?;
    let options = |instance, sysid, east: f64| ardupilot::Options {
        instance,
        speedup,
        sysid: Some(sysid),
        home: (-35.363261, 149.165230 + east, 584.0, 353.0),
        ..ardupilot::Options::default()
    };
    let start = |instance, sysid, east, name: &str| {
        ardupilot::Sitl::start(&copter, &options(instance, sysid, east), &dir.join(name))
            .unwrap_or_else(|e| panic!("{test}: cannot start {name}: {e}"))
    };
    let sitl1 = start(first, 1, 0.0, "sitl1");
    let sitl2 = start(first + 1, 2, 0.001, "sitl2");
    Some((mavproxy, sitl1, sitl2))
}

/// MAVProxy routing both SITLs' SERIAL0 to UDP `outs` on 127.0.0.1, its
/// tlog at `dir/router.tlog`, its output in `dir/mavproxy.{out,err}`;
/// the gateways behind it ask for their own telemetry.
pub fn route(mavproxy: &Path, sitls: [&ardupilot::Sitl; 2], outs: &[u16], dir: &Path) -> Process {
    let mut command = Command::new(mavproxy);
    for sitl in sitls {
        command.arg(format!("--master=tcp:127.0.0.1:{}", sitl.port(0)));
    }
    for port in outs {
        command.arg(format!("--out=udp:127.0.0.1:{port}"));
    }
    let log = |name: &str| std::fs::File::create(dir.join(name)).expect("log file");
    Process::spawn(
        "MAVProxy",
        command
            .args(["--streamrate=-1", "--daemon", "--non-interactive"])
            .arg("--state-basedir")
            .arg(dir.join("mavproxy"))
            .arg("--logfile")
            .arg(dir.join("router.tlog"))
            .stdout(log("mavproxy.out"))
            .stderr(log("mavproxy.err")),
    )
}

/// What MAVProxy printed, for failure messages.
pub fn mavproxy_log(dir: &Path) -> String {
    let read = |f: &str| std::fs::read_to_string(dir.join(f)).unwrap_or_default();
    format!("{}{}", read("mavproxy.out"), read("mavproxy.err"))
}

/// A free UDP port on 127.0.0.1 (bound to port 0, then released).
pub fn free_udp_port() -> u16 {
    let socket = std::net::UdpSocket::bind("127.0.0.1:0").expect("bind a UDP port");
    socket.local_addr().expect("its address").port()
}

/// A child process stopped with SIGTERM (then killed) and reaped on drop,
/// even when the test panics.
pub struct Process {
    name: &'static str,
    child: Option<Child>,
}

impl Process {
    pub fn spawn(name: &'static str, command: &mut Command) -> Process {
        let child = command
            .stdin(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {name}: {e}"));
        Process {
            name,
            child: Some(child),
        }
    }

    pub fn running(&mut self) -> bool {
        self.child
            .as_mut()
            .is_some_and(|c| matches!(c.try_wait(), Ok(None)))
    }

    /// SIGTERM, up to 5 s to exit, then SIGKILL; always reaped.
    pub fn stop(&mut self) {
        let Some(mut child) = self.child.take() else {
            return;
        };
        if let Ok(pid) = i32::try_from(child.id()) {
            // SAFETY: a signal to our own child, not yet reaped.
            unsafe { libc::kill(pid, libc::SIGTERM) };
        }
        let until = Instant::now() + Duration::from_secs(5);
        while Instant::now() < until {
            if !matches!(child.try_wait(), Ok(None)) {
                return;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        eprintln!("{} ignored SIGTERM: killed", self.name);
        let _ = child.kill();
        let _ = child.wait();
    }
}

impl Drop for Process {
    fn drop(&mut self) {
        self.stop();
    }
}

/// What the router saw, from MAVProxy's tlog (both vehicles' telemetry and
/// everything the gateways sent, on MAVProxy's one clock).
#[derive(Default)]
pub struct Router {
    /// (time µs, sender system, sender component, target system, command, param1)
    pub commands: Vec<(u64, u8, u8, u8, MavCmd, f32)>,
    /// First HEARTBEAT with the armed flag, per vehicle (index = sysid).
    pub first_armed: [Option<u64>; 3],
    /// Highest relative altitude (m), per vehicle.
    pub max_alt: [f32; 3],
    pub heartbeats: [u64; 3],
}

impl Router {
    pub fn read(path: &Path) -> Router {
        let bytes = std::fs::read(path).unwrap_or_default();
        let mut r = Router::default();
        for record in TlogReader::new(&bytes) {
            let (sys, comp) = (record.frame.system_id(), record.frame.component_id());
            let Ok(message) = record.frame.decode() else {
                continue;
            };
            let t = record.time_us;
            match message {
                MavMessage::COMMAND_LONG(c) => {
                    r.commands
                        .push((t, sys, comp, c.target_system, c.command, c.param1))
                }
                MavMessage::COMMAND_INT(c) => {
                    r.commands
                        .push((t, sys, comp, c.target_system, c.command, c.param1))
                }
                MavMessage::HEARTBEAT(hb) if comp == 1 && (1..=2).contains(&sys) => {
                    let v = sys as usize;
                    r.heartbeats[v] += 1;
                    if hb
                        .base_mode
                        .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED)
                        && r.first_armed[v].is_none()
                    {
                        r.first_armed[v] = Some(t);
                    }
                }
                MavMessage::GLOBAL_POSITION_INT(p) if comp == 1 && (1..=2).contains(&sys) => {
                    let v = sys as usize;
                    r.max_alt[v] = r.max_alt[v].max(p.relative_alt as f32 / 1000.0);
                }
                _ => {}
            }
        }
        r
    }

    /// Arm commands (COMPONENT_ARM_DISARM with param1 = 1) to `sysid`.
    pub fn arms_to(&self, sysid: u8) -> Vec<&(u64, u8, u8, u8, MavCmd, f32)> {
        self.commands
            .iter()
            .filter(|c| c.3 == sysid && c.4 == MavCmd::MAV_CMD_COMPONENT_ARM_DISARM && c.5 == 1.0)
            .collect()
    }
}

/// A frame from (`system`, `component`).
pub fn frame(system: u8, component: u8, sequence: u8, message: &MavMessage) -> Vec<u8> {
    let header = MavHeader {
        system_id: u32::from(system),
        component_id: component,
        sequence,
    };
    elaboration::frame::serialize(header, MavlinkVersion::V2, message)
}

/// A copter autopilot's HEARTBEAT in ArduCopter mode `custom_mode`.
pub fn copter_heartbeat(custom_mode: u32, armed: bool) -> MavMessage {
    let mut base_mode = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
    if armed {
        base_mode |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
    }
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode,
        mavtype: MavType::MAV_TYPE_QUADROTOR,
        autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode,
        system_status: MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
    })
}
