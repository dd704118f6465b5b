//! The scripted autopilot of the latency benchmarks (`latency.rs`,
//! `monitor_load.rs`): it sends a low-battery SYS_STATUS to a reactor over
//! UDP on 127.0.0.1 and times the RTL COMMAND_LONG coming back, acking
//! every command on the way.

use std::net::UdpSocket;
use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use elaboration::Frame;
use mavlink::dialects::ardupilotmega::*;
use mavlink::{MavHeader, MavlinkVersion};

const AUTOPILOT: MavHeader = MavHeader {
    system_id: 1,
    component_id: 1,
    sequence: 0,
};

pub fn encode(seq: u8, message: &MavMessage) -> Vec<u8> {
    let mut out = Vec::new();
    let header = MavHeader {
        sequence: seq,
        ..AUTOPILOT
    };
    if let Err(e) = mavlink::write_versioned_msg(&mut out, MavlinkVersion::V2, header, message) {
        panic!("cannot encode {message:?}: {e}");
    }
    out
}

pub fn heartbeat() -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 4,
        mavtype: MavType::MAV_TYPE_QUADROTOR,
        autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED,
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    })
}

pub fn sys_status(remaining: i8) -> MavMessage {
    MavMessage::SYS_STATUS(SYS_STATUS_DATA {
        battery_remaining: remaining,
        voltage_battery: 11_800,
        ..SYS_STATUS_DATA::default()
    })
}

/// The scripted autopilot's side of one reactor (petrel or the script).
pub struct Autopilot {
    pub socket: UdpSocket,
    /// Shared with a feeder sending on the same socket (one sequence).
    pub seq: Arc<AtomicU8>,
}

impl Autopilot {
    pub fn send(&mut self, message: &MavMessage) {
        let seq = self.seq.fetch_add(1, Ordering::Relaxed).wrapping_add(1);
        let bytes = encode(seq, message);
        let _ = self.socket.send(&bytes);
    }

    /// Waits for an RTL COMMAND_LONG, acking every command on the way.
    fn wait_rtl(&mut self, deadline: Instant) -> Option<Instant> {
        let mut buf = [0u8; 2048];
        while Instant::now() < deadline {
            let Ok(n) = self.socket.recv(&mut buf) else {
                continue;
            };
            let arrived = Instant::now();
            let mut at = 0;
            let mut rtl = false;
            while at < n {
                let Ok(frame) = Frame::parse(&buf[at..n]) else {
                    break;
                };
                at += frame.bytes().len();
                if let Ok(MavMessage::COMMAND_LONG(c)) = frame.decode() {
                    self.send(&MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
                        command: c.command,
                        result: MavResult::MAV_RESULT_ACCEPTED,
                        progress: 0,
                        result_param2: 0,
                        target_system: frame.system_id(),
                        target_component: frame.component_id(),
                    }));
                    rtl |= c.command == MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH;
                }
            }
            if rtl {
                return Some(arrived);
            }
        }
        None
    }
}

pub struct Stats {
    pub name: &'static str,
    pub micros: Vec<f64>,
    pub lost: usize,
}

impl Stats {
    pub fn pct(&self, p: f64) -> f64 {
        let i = ((self.micros.len() as f64 - 1.0) * p).round() as usize;
        self.micros[i.min(self.micros.len() - 1)]
    }
}

/// The scripted autopilot's socket, connected to a reactor on `port`.
pub fn connect(port: u16) -> Option<Autopilot> {
    let socket = UdpSocket::bind("127.0.0.1:0").ok()?;
    socket.connect(("127.0.0.1", port)).ok()?;
    socket
        .set_read_timeout(Some(Duration::from_millis(50)))
        .ok()?;
    Some(Autopilot {
        socket,
        seq: Arc::new(AtomicU8::new(0)),
    })
}

/// Runs at most `n` trials, for at most `limit`, against a reactor on `port`.
pub fn trials(name: &'static str, port: u16, n: usize, limit: Duration) -> Option<Stats> {
    let ap = connect(port)?;
    trials_on(name, ap, n, limit)
}

/// [`trials`] on an autopilot socket already made.
pub fn trials_on(
    name: &'static str,
    mut ap: Autopilot,
    n: usize,
    limit: Duration,
) -> Option<Stats> {
    // Let the reactor hear the autopilot (and take its identity) first.
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(3) {
        ap.send(&heartbeat());
        ap.send(&sys_status(90));
        std::thread::sleep(Duration::from_millis(50));
    }
    let mut drain = [0u8; 2048];
    // Reads what is waiting, without waiting for more.
    let drain_for = |ap: &mut Autopilot, buf: &mut [u8], t: Duration| {
        let until = Instant::now() + t;
        let _ = ap.socket.set_nonblocking(true);
        while Instant::now() < until && ap.socket.recv(buf).is_ok() {}
        let _ = ap.socket.set_nonblocking(false);
    };
    drain_for(&mut ap, &mut drain, Duration::from_millis(100));
    // Each reactor gets at most this long, whatever happens.
    let give_up = Instant::now() + limit;
    let mut micros = Vec::with_capacity(n.min(1 << 20));
    let mut lost = 0;
    let mut last_hb = Instant::now();
    for trial in 0..n {
        if trial % 1000 == 0 {
            eprintln!("{name}: trial {trial}, {lost} lost");
        }
        if last_hb.elapsed() > Duration::from_millis(500) {
            ap.send(&heartbeat());
            last_hb = Instant::now();
        }
        let sent = Instant::now();
        ap.send(&sys_status(20));
        match ap.wait_rtl(sent + Duration::from_secs(1)) {
            Some(arrived) => micros.push((arrived - sent).as_secs_f64() * 1e6),
            None => lost += 1,
        }
        // Re-arm the rule.
        ap.send(&sys_status(90));
        std::thread::sleep(Duration::from_micros(300));
        drain_for(&mut ap, &mut drain, Duration::from_millis(2));
        if lost > 20 {
            eprintln!("{name}: more than 20 trials lost; stopping");
            break;
        }
        if Instant::now() > give_up {
            eprintln!("{name}: out of time after {trial} trials; stopping");
            break;
        }
    }
    micros.sort_by(f64::total_cmp);
    (!micros.is_empty()).then_some(Stats { name, micros, lost })
}
