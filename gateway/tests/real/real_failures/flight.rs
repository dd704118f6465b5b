//! A ground station's link to ArduPilot's own SITL, in this test process:
//! raw frames read from SERIAL0 and recorded in a tlog stamped with the
//! vehicle's own (simulated) clock, commands and PARAM_SETs sent, and a
//! link hole made by dropping everything for a while. Every wait is
//! bounded in simulated time and in wall time.

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::time::{Duration, Instant};

use elaboration::frame::{announced_len, serialize};
use elaboration::{Frame, TlogWriter};
use mavlink::dialects::ardupilotmega::*;
use mavlink::{MavHeader, MavlinkVersion};
use sitl_tests::ardupilot::{self, Sitl};

/// Microseconds since the UNIX epoch of the vehicle's boot in the tlog
/// (any fixed base: `petrel events` reads times relative to the first frame).
const EPOCH_US: u64 = 1_800_000_000_000_000;
const S: u64 = 1_000_000;

/// What the vehicle said, as the test needs it.
#[derive(Debug, Default)]
pub struct Said {
    pub armed: bool,
    pub custom_mode: u32,
    pub system_status: u8,
    /// Metres above home.
    pub altitude: f64,
    pub fix_type: u8,
    /// (vehicle time µs, text) of every STATUSTEXT, a long text's chunks
    /// put back together as the elaboration does.
    pub texts: Vec<(u64, String)>,
    chunks: elaboration::statustext::Joiner,
    /// (vehicle time µs, custom_mode) of every mode change.
    pub modes: Vec<(u64, u32)>,
    pub params: HashMap<String, f32>,
    /// (command, result) of every COMMAND_ACK.
    pub acks: Vec<(MavCmd, MavResult)>,
    /// The mission items the vehicle asked for, in order.
    pub mission_requests: Vec<u16>,
    pub mission_ack: Option<MavMissionResult>,
    /// MISSION_ITEM_REACHED frames received (repeats included).
    pub reached_frames: u64,
    /// The seq of every MISSION_ITEM_REACHED frame, changes only.
    pub reached: Vec<u16>,
}

pub struct Link {
    stream: TcpStream,
    buf: Vec<u8>,
    tlog: TlogWriter<BufWriter<File>>,
    /// The vehicle's clock (µs since boot, from its messages' time_boot_ms)
    /// and when it was last read.
    boot_us: u64,
    boot_read: Instant,
    speedup: f64,
    seq: u8,
    /// Dropping every frame both ways (a link hole).
    hole: bool,
    next_heartbeat_us: u64,
    /// The last tlog stamp (stamps never go backwards).
    stamp_us: u64,
    /// Frames recorded.
    pub recorded: u64,
    pub said: Said,
}

fn mode_of(hb: &HEARTBEAT_DATA) -> (bool, u32, u8) {
    (
        hb.base_mode
            .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED),
        hb.custom_mode,
        hb.system_status as u8,
    )
}

impl Link {
    /// Connects to SERIAL0 (which starts the simulation) and records to
    /// `tlog`.
    pub fn open(sitl: &Sitl, speedup: u32, tlog: &Path) -> Result<Link, String> {
        let stream = ardupilot::connect(sitl.port(0), Duration::from_secs(10))
            .map_err(|e| format!("connecting to SITL: {e}"))?;
        stream
            .set_read_timeout(Some(Duration::from_millis(5)))
            .map_err(|e| e.to_string())?;
        let file = File::create(tlog).map_err(|e| format!("{}: {e}", tlog.display()))?;
        let mut link = Link {
            stream,
            buf: Vec::with_capacity(1 << 16),
            tlog: TlogWriter::new(BufWriter::new(file)),
            boot_us: 0,
            boot_read: Instant::now(),
            speedup: f64::from(speedup),
            seq: 0,
            hole: false,
            next_heartbeat_us: 0,
            stamp_us: 0,
            recorded: 0,
            said: Said::default(),
        };
        link.wait("the first heartbeat", 30.0, |s| s.system_status != 0)?;
        // Every stream group at 4 Hz (SYS_STATUS, GPS_RAW_INT,
        // SERVO_OUTPUT_RAW, BATTERY_STATUS, EKF_STATUS_REPORT, ESC telemetry...),
        // as ground stations ask ArduPilot (its SRn_ groups).
        #[allow(deprecated)]
        let request = MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
            req_message_rate: 4,
            target_system: 1,
            target_component: 1,
            req_stream_id: MavDataStream::MAV_DATA_STREAM_ALL,
            start_stop: 1,
        });
        link.send(request)?;
        Ok(link)
    }

    /// The vehicle's time now, µs since its boot: its last time_boot_ms
    /// plus the wall time since, at the speed-up (at most 300 ms more).
    pub fn now_us(&self) -> u64 {
        let extra = self.boot_read.elapsed().as_secs_f64() * self.speedup * 1e6;
        self.boot_us + (extra as u64).min(300_000)
    }

    /// The tlog time of a vehicle time.
    pub fn tlog_us(at_us: u64) -> u64 {
        EPOCH_US + at_us
    }

    pub fn send(&mut self, msg: MavMessage) -> Result<(), String> {
        if self.hole {
            return Ok(());
        }
        let header = MavHeader {
            system_id: 255,
            component_id: 190,
            sequence: self.seq,
        };
        self.seq = self.seq.wrapping_add(1);
        self.stream
            .write_all(&serialize(header, MavlinkVersion::V2, &msg))
            .map_err(|e| format!("sending to SITL: {e}"))
    }

    /// Reads what arrived; records and reads each frame.
    fn pump(&mut self) -> Result<(), String> {
        if self.now_us() >= self.next_heartbeat_us {
            self.next_heartbeat_us = self.now_us() + S;
            self.send(MavMessage::HEARTBEAT(HEARTBEAT_DATA {
                custom_mode: 0,
                mavtype: MavType::MAV_TYPE_GCS,
                autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
                base_mode: MavModeFlag::empty(),
                system_status: MavState::MAV_STATE_ACTIVE,
                mavlink_version: 3,
            }))?;
        }
        let mut chunk = [0u8; 8192];
        match self.stream.read(&mut chunk) {
            Ok(0) => return Err("SITL closed the link".into()),
            Ok(n) => self.buf.extend_from_slice(&chunk[..n]),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) => {}
            Err(e) => return Err(format!("reading from SITL: {e}")),
        }
        let mut at = 0;
        while at < self.buf.len() {
            let rest = &self.buf[at..];
            if rest[0] != elaboration::frame::STX_V2 && rest[0] != elaboration::frame::STX_V1 {
                at += 1;
                continue;
            }
            let Some(len) = announced_len(rest) else {
                break;
            };
            if rest.len() < len {
                break;
            }
            let bytes = rest[..len].to_vec();
            match Frame::parse(&bytes) {
                Ok(frame) => {
                    self.read_frame(&frame)?;
                    at += len;
                }
                Err(_) => at += 1,
            }
        }
        self.buf.drain(..at);
        Ok(())
    }

    fn read_frame(&mut self, frame: &Frame) -> Result<(), String> {
        let Ok(msg) = frame.decode() else {
            return Ok(());
        };
        let boot_ms = match &msg {
            MavMessage::ATTITUDE(d) => Some(d.time_boot_ms),
            MavMessage::GLOBAL_POSITION_INT(d) => Some(d.time_boot_ms),
            MavMessage::SYSTEM_TIME(d) => Some(d.time_boot_ms),
            _ => None,
        };
        if let Some(ms) = boot_ms {
            let us = u64::from(ms) * 1000;
            if us > self.boot_us {
                self.boot_us = us;
                self.boot_read = Instant::now();
            }
        }
        if self.hole {
            return Ok(());
        }
        let now = self.now_us().max(self.stamp_us);
        self.stamp_us = now;
        self.tlog
            .write_frame(Self::tlog_us(now), frame.bytes())
            .map_err(|e| format!("writing the tlog: {e}"))?;
        self.recorded += 1;
        let (sys, comp) = (frame.system_id(), frame.component_id());
        let said = &mut self.said;
        match msg {
            MavMessage::HEARTBEAT(hb) if (sys, comp) == (1, 1) => {
                let (armed, mode, status) = mode_of(&hb);
                if mode != said.custom_mode || said.modes.is_empty() {
                    said.modes.push((now, mode));
                }
                (said.armed, said.custom_mode, said.system_status) = (armed, mode, status);
            }
            MavMessage::GLOBAL_POSITION_INT(d) => {
                said.altitude = f64::from(d.relative_alt) / 1000.0;
            }
            MavMessage::GPS_RAW_INT(d) => said.fix_type = d.fix_type as u8,
            MavMessage::STATUSTEXT(d) => {
                if let Some(text) = joined_text(&mut said.chunks, &d) {
                    said.texts.push((now, text));
                }
            }
            MavMessage::PARAM_VALUE(d) => {
                let name = String::from_utf8_lossy(d.param_id.as_slice())
                    .trim_end_matches('\0')
                    .to_owned();
                said.params.insert(name, d.param_value);
            }
            MavMessage::COMMAND_ACK(d) => said.acks.push((d.command, d.result)),
            MavMessage::MISSION_REQUEST_INT(d) => said.mission_requests.push(d.seq),
            #[allow(deprecated)]
            MavMessage::MISSION_REQUEST(d) => said.mission_requests.push(d.seq),
            MavMessage::MISSION_ACK(d) => said.mission_ack = Some(d.mavtype),
            MavMessage::MISSION_ITEM_REACHED(d) => {
                said.reached_frames += 1;
                if said.reached.last() != Some(&d.seq) {
                    said.reached.push(d.seq);
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// Runs the link until `done` holds, at most `limit_s` of vehicle time
    /// (and a wall-time bound derived from it).
    pub fn wait(
        &mut self,
        what: &str,
        limit_s: f64,
        mut done: impl FnMut(&Said) -> bool,
    ) -> Result<(), String> {
        let start = self.now_us();
        let wall = Instant::now();
        let wall_limit = Duration::from_secs_f64(limit_s / self.speedup * 4.0 + 20.0);
        loop {
            self.pump()?;
            if done(&self.said) {
                return Ok(());
            }
            let sim_s = (self.now_us().saturating_sub(start)) as f64 / 1e6;
            if sim_s > limit_s || wall.elapsed() > wall_limit {
                return Err(format!(
                    "{what}: not within {limit_s} s of vehicle time ({sim_s:.1} s, {:.1} s wall); last texts: {:?}",
                    wall.elapsed().as_secs_f64(),
                    self.said.texts.iter().rev().take(5).collect::<Vec<_>>()
                ));
            }
        }
    }

    /// Lets `s` seconds of vehicle time pass.
    pub fn hold(&mut self, s: f64) -> Result<(), String> {
        self.hold_exactly(s)
    }

    /// Drops everything both ways for `s` seconds of vehicle time.
    pub fn hole(&mut self, s: f64) -> Result<(), String> {
        self.hole = true;
        let r = self.hold_exactly(s);
        self.hole = false;
        r
    }

    /// Lets exactly `s` seconds of vehicle time pass.
    pub fn hold_exactly(&mut self, s: f64) -> Result<(), String> {
        let until = self.now_us() + (s * 1e6) as u64;
        let wall = Instant::now();
        let wall_limit = Duration::from_secs_f64(s / self.speedup * 4.0 + 20.0);
        while self.now_us() < until {
            self.pump()?;
            if wall.elapsed() > wall_limit {
                return Err(format!("holding {s} s: the vehicle's clock stalled"));
            }
        }
        Ok(())
    }

    /// PARAM_SET, confirmed by the PARAM_VALUE that echoes it.
    pub fn param(&mut self, name: &str, value: f32) -> Result<(), String> {
        let mut id = [0u8; 16];
        id[..name.len()].copy_from_slice(name.as_bytes());
        for _ in 0..3 {
            self.said.params.remove(name);
            self.send(MavMessage::PARAM_SET(PARAM_SET_DATA {
                param_value: value,
                target_system: 1,
                target_component: 1,
                param_id: mavlink::types::CharArray::new(id),
                param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
            }))?;
            let key = name.to_owned();
            if self
                .wait(&format!("{name} = {value}"), 3.0, |s| {
                    s.params.get(&key).is_some_and(|v| (v - value).abs() < 1e-3)
                })
                .is_ok()
            {
                return Ok(());
            }
        }
        Err(format!("{name} = {value} not confirmed"))
    }

    /// COMMAND_LONG, and its COMMAND_ACK's result.
    pub fn command(&mut self, command: MavCmd, p: [f32; 7]) -> Result<MavResult, String> {
        let before = self.said.acks.len();
        self.send(sitl_tests::wire::command_long((1, 1), command, p))?;
        self.wait(&format!("{command:?} acknowledged"), 5.0, |s| {
            s.acks[before..].iter().any(|(c, _)| *c == command)
        })?;
        Ok(self.said.acks[before..]
            .iter()
            .rev()
            .find(|(c, _)| *c == command)
            .map(|(_, r)| *r)
            .unwrap_or(MavResult::MAV_RESULT_FAILED))
    }

    /// Sets a flight mode by number and waits for the heartbeat to say it.
    pub fn mode(&mut self, custom_mode: u32) -> Result<(), String> {
        for _ in 0..5 {
            let p = [1.0, custom_mode as f32, 0.0, 0.0, 0.0, 0.0, 0.0];
            self.command(MavCmd::MAV_CMD_DO_SET_MODE, p)?;
            if self
                .wait(&format!("mode {custom_mode}"), 2.0, |s| {
                    s.custom_mode == custom_mode
                })
                .is_ok()
            {
                return Ok(());
            }
        }
        Err(format!("mode {custom_mode} refused"))
    }

    /// Arms in `custom_mode`, retrying while ArduPilot refuses (EKF and GPS
    /// settling; the first refusal is common), within `limit_s`; then
    /// `after` at once (a copter disarms within seconds if it does not
    /// take off).
    pub fn arm(
        &mut self,
        custom_mode: u32,
        limit_s: f64,
        after: impl FnOnce(&mut Link) -> Result<(), String>,
    ) -> Result<(), String> {
        let start = self.now_us();
        while !self.said.armed {
            if self.now_us() - start > (limit_s * 1e6) as u64 {
                return Err(format!(
                    "not armed within {limit_s} s; texts: {:?}",
                    self.said.texts
                ));
            }
            if self.said.custom_mode != custom_mode {
                let p = [1.0, custom_mode as f32, 0.0, 0.0, 0.0, 0.0, 0.0];
                self.command(MavCmd::MAV_CMD_DO_SET_MODE, p)?;
            }
            let arm = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
            if self.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, arm)?
                == MavResult::MAV_RESULT_ACCEPTED
            {
                self.wait("armed", 3.0, |s| s.armed)?;
                break;
            }
            self.hold(2.0)?;
        }
        after(self)
    }

    /// Uploads a mission (item 0 is home) and waits for its MISSION_ACK.
    pub fn upload_mission(&mut self, items: &[MISSION_ITEM_INT_DATA]) -> Result<(), String> {
        self.said.mission_requests.clear();
        self.said.mission_ack = None;
        self.send(MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
            count: items.len() as u16,
            target_system: 1,
            target_component: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            opaque_id: 0,
        }))?;
        let mut sent = 0;
        while self.said.mission_ack.is_none() {
            self.wait("a mission request or ack", 10.0, |s| {
                s.mission_requests.len() > sent || s.mission_ack.is_some()
            })?;
            while sent < self.said.mission_requests.len() {
                let seq = usize::from(self.said.mission_requests[sent]);
                sent += 1;
                let item = items
                    .get(seq)
                    .ok_or_else(|| format!("the vehicle asked for mission item {seq}"))?;
                let mut item = item.clone();
                item.seq = seq as u16;
                self.send(MavMessage::MISSION_ITEM_INT(item))?;
            }
        }
        match self.said.mission_ack {
            Some(MavMissionResult::MAV_MISSION_ACCEPTED) => Ok(()),
            other => Err(format!("mission refused: {other:?}")),
        }
    }

    /// The texts the vehicle said between two vehicle times.
    pub fn texts_between(&self, from_us: u64, to_us: u64) -> Vec<&str> {
        self.said
            .texts
            .iter()
            .filter(|(t, _)| (from_us..=to_us).contains(t))
            .map(|(_, s)| s.as_str())
            .collect()
    }

    /// Flushes the tlog.
    pub fn finish(self) -> Result<(), String> {
        self.tlog
            .into_inner()
            .and_then(|mut w| w.flush())
            .map_err(|e| format!("writing the tlog: {e}"))
    }
}

/// A STATUSTEXT chunk put together with those before it (ArduPilot sends a
/// text longer than 50 bytes in chunks of one `id`): the whole text when
/// this chunk ends it, None while it is under way.
pub fn joined_text(
    chunks: &mut elaboration::statustext::Joiner,
    d: &STATUSTEXT_DATA,
) -> Option<String> {
    use elaboration::statustext::Piece;
    let raw = String::from_utf8_lossy(d.text.as_slice());
    let (part, last) = match raw.find('\0') {
        Some(end) => (&raw[..end], true),
        None => (&raw[..], false),
    };
    match chunks.push(d.id, d.chunk_seq, part, last) {
        Piece::Whole => Some(part.to_owned()),
        Piece::Joined(whole) => Some(whole),
        Piece::Pending => None,
    }
}
