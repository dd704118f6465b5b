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

    /// Waits for an RTL COMMAND_LONG, acking every command on the way:
    /// when the harness read it, and when it reached the socket (the
    /// kernel's receive timestamp, UNIX ns; `None` where there is none).
    fn wait_rtl(&mut self, deadline: Instant) -> Option<(Instant, Option<u128>)> {
        let mut buf = [0u8; 2048];
        while Instant::now() < deadline {
            let Some((n, stamp)) = socket_stamp::recv(&self.socket, &mut buf) else {
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
                return Some((arrived, stamp));
            }
        }
        None
    }
}

pub struct Stats {
    pub name: &'static str,
    /// From the send to the harness reading the command (sorted): what the
    /// harness's own thread waited for a CPU is in it.
    pub micros: Vec<f64>,
    /// From the send to the command reaching the harness's socket (the
    /// kernel's receive timestamp; sorted; empty where there is none): the
    /// reactor's time alone.
    pub socket_micros: Vec<f64>,
    pub lost: usize,
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let i = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

impl Stats {
    pub fn pct(&self, p: f64) -> f64 {
        percentile(&self.micros, p)
    }

    /// [`Stats::pct`] of the times at the socket.
    #[allow(dead_code)]
    pub fn socket_pct(&self, p: f64) -> f64 {
        percentile(&self.socket_micros, p)
    }
}

/// Kernel receive timestamps on a UDP socket (SO_TIMESTAMPNS, Linux).
mod socket_stamp {
    use std::net::UdpSocket;

    /// Asks the kernel to stamp each datagram received on `socket`.
    #[cfg(target_os = "linux")]
    pub fn enable(socket: &UdpSocket) -> bool {
        use std::os::fd::AsRawFd;
        let on: libc::c_int = 1;
        // SAFETY: setsockopt reads one c_int from `on`, alive for the call.
        unsafe {
            libc::setsockopt(
                socket.as_raw_fd(),
                libc::SOL_SOCKET,
                libc::SO_TIMESTAMPNS,
                &on as *const libc::c_int as *const libc::c_void,
                std::mem::size_of::<libc::c_int>() as libc::socklen_t,
            ) == 0
        }
    }

    /// One datagram into `buf`: its length and the kernel's stamp (UNIX ns).
    #[cfg(target_os = "linux")]
    pub fn recv(socket: &UdpSocket, buf: &mut [u8]) -> Option<(usize, Option<u128>)> {
        use std::os::fd::AsRawFd;
        let mut iov = libc::iovec {
            iov_base: buf.as_mut_ptr() as *mut libc::c_void,
            iov_len: buf.len(),
        };
        let mut control = [0u64; 16];
        // SAFETY: msghdr is plain data; zeroed is a valid empty header.
        let mut msg: libc::msghdr = unsafe { std::mem::zeroed() };
        msg.msg_iov = &mut iov;
        msg.msg_iovlen = 1;
        msg.msg_control = control.as_mut_ptr() as *mut libc::c_void;
        msg.msg_controllen = std::mem::size_of_val(&control) as _;
        // SAFETY: recvmsg writes at most iov_len bytes into `buf` and at
        // most msg_controllen into `control`, both alive for the call.
        let n = unsafe { libc::recvmsg(socket.as_raw_fd(), &mut msg, 0) };
        if n < 0 {
            return None;
        }
        let mut stamp = None;
        // SAFETY: the CMSG macros walk the control buffer recvmsg filled,
        // within msg_controllen.
        unsafe {
            let mut c = libc::CMSG_FIRSTHDR(&msg);
            while !c.is_null() {
                if (*c).cmsg_level == libc::SOL_SOCKET && (*c).cmsg_type == libc::SCM_TIMESTAMPNS {
                    let ts = std::ptr::read_unaligned(libc::CMSG_DATA(c) as *const libc::timespec);
                    stamp = Some(ts.tv_sec as u128 * 1_000_000_000 + ts.tv_nsec as u128);
                }
                c = libc::CMSG_NXTHDR(&msg, c);
            }
        }
        Some((n as usize, stamp))
    }

    #[cfg(not(target_os = "linux"))]
    pub fn enable(_: &UdpSocket) -> bool {
        false
    }

    #[cfg(not(target_os = "linux"))]
    pub fn recv(socket: &UdpSocket, buf: &mut [u8]) -> Option<(usize, Option<u128>)> {
        socket.recv(buf).ok().map(|n| (n, None))
    }
}

/// Now, UNIX ns (the clock of the kernel's receive timestamps).
fn unix_ns() -> u128 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos())
}

/// The scripted autopilot's socket, connected to a reactor on `port`.
pub fn connect(port: u16) -> Option<Autopilot> {
    let socket = UdpSocket::bind("127.0.0.1:0").ok()?;
    socket.connect(("127.0.0.1", port)).ok()?;
    socket
        .set_read_timeout(Some(Duration::from_millis(50)))
        .ok()?;
    if !socket_stamp::enable(&socket) {
        eprintln!("no kernel receive timestamps: latencies at the socket not measured");
    }
    Some(Autopilot {
        socket,
        seq: Arc::new(AtomicU8::new(0)),
    })
}

/// Runs at most `n` trials, for at most `limit`, against a reactor on `port`.
#[allow(dead_code)]
pub fn trials(name: &'static str, port: u16, n: usize, limit: Duration) -> Option<Stats> {
    let ap = connect(port)?;
    trials_on(name, ap, n, limit)
}

/// [`trials`] on an autopilot socket already made.
#[allow(dead_code)]
pub fn trials_on(name: &'static str, ap: Autopilot, n: usize, limit: Duration) -> Option<Stats> {
    interleaved(vec![(name, ap)], n, limit).pop().flatten()
}

/// Reads what is waiting, without waiting for more.
fn drain_for(ap: &mut Autopilot, buf: &mut [u8], t: Duration) {
    let until = Instant::now() + t;
    let _ = ap.socket.set_nonblocking(true);
    while Instant::now() < until && ap.socket.recv(buf).is_ok() {}
    let _ = ap.socket.set_nonblocking(false);
}

/// Several reactors, each on its autopilot socket, given their trials in
/// turn (one of each, then the next round): they all meet the machine's
/// load as it comes and goes, which trials run one reactor after the other
/// would not. At most `n` trials each, for at most `limit` in all.
pub fn interleaved(
    mut reactors: Vec<(&'static str, Autopilot)>,
    n: usize,
    limit: Duration,
) -> Vec<Option<Stats>> {
    // Let each reactor hear its autopilot (and take its identity) first.
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(3) {
        for (_, ap) in &mut reactors {
            ap.send(&heartbeat());
            ap.send(&sys_status(90));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let mut drain = [0u8; 2048];
    for (_, ap) in &mut reactors {
        drain_for(ap, &mut drain, Duration::from_millis(100));
    }
    let give_up = Instant::now() + limit;
    let mut micros = vec![Vec::with_capacity(n.min(1 << 20)); reactors.len()];
    let mut socket_micros = vec![Vec::with_capacity(n.min(1 << 20)); reactors.len()];
    let mut lost = vec![0; reactors.len()];
    let mut last_hb = Instant::now();
    'trials: for trial in 0..n {
        if trial % 1000 == 0 {
            for ((name, _), lost) in reactors.iter().zip(&lost) {
                eprintln!("{name}: trial {trial}, {lost} lost");
            }
        }
        let heartbeat_due = last_hb.elapsed() > Duration::from_millis(500);
        if heartbeat_due {
            last_hb = Instant::now();
        }
        for (r, (name, ap)) in reactors.iter_mut().enumerate() {
            if heartbeat_due {
                ap.send(&heartbeat());
            }
            let sent_unix = unix_ns();
            let sent = Instant::now();
            ap.send(&sys_status(20));
            match ap.wait_rtl(sent + Duration::from_secs(1)) {
                Some((arrived, stamp)) => {
                    micros[r].push((arrived - sent).as_secs_f64() * 1e6);
                    if let Some(at) = stamp {
                        socket_micros[r].push(at.saturating_sub(sent_unix) as f64 / 1e3);
                    }
                }
                None => lost[r] += 1,
            }
            // Re-arm the rule.
            ap.send(&sys_status(90));
            std::thread::sleep(Duration::from_micros(300));
            drain_for(ap, &mut drain, Duration::from_millis(2));
            if lost[r] > 20 {
                eprintln!("{name}: more than 20 trials lost; stopping");
                break 'trials;
            }
            if Instant::now() > give_up {
                eprintln!("{name}: out of time after {trial} trials; stopping");
                break 'trials;
            }
        }
    }
    reactors
        .iter()
        .zip(micros.into_iter().zip(socket_micros).zip(lost))
        .map(|((name, _), ((mut micros, mut socket_micros), lost))| {
            micros.sort_by(f64::total_cmp);
            socket_micros.sort_by(f64::total_cmp);
            (!micros.is_empty()).then_some(Stats {
                name,
                micros,
                socket_micros,
                lost,
            })
        })
        .collect()
}
