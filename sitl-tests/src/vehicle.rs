//! The sans-IO simulated vehicle: ArduPlane and its camera as one state
//! machine. Fed `(now, header, message)` with [`Vehicle::handle`] and time
//! with [`Vehicle::advance`], polled with [`Vehicle::poll_transmit`] for
//! the `(header, message)` pairs to send. No sockets, no clock: `now` is
//! sim microseconds since boot, and the physics steps at a fixed sim `dt`.

use std::collections::VecDeque;

use mavlink::dialects::ardupilotmega::{MavMessage, MavResult, MavSeverity, STATUSTEXT_DATA};
use mavlink::MavHeader;

use crate::boot::{BootState, Phase};
use crate::camera::{self, Camera};
use crate::config::SimConfig;
use crate::faults::{Fault, FaultKind, Refusal, Trigger};
use crate::geo::{self, Home, V2};
use crate::mission::{MissionItem, Uploads};
use crate::model::{Aircraft, Airframe};
use crate::nav_state::{AutoState, Flight, RoverNav};
use crate::params::Params;
use crate::state::{Fix, SimState, Text};
use crate::streams::{id, Streams};

/// The autopilot's component id (MAV_COMP_ID_AUTOPILOT1).
pub const AUTOPILOT: u8 = 1;

/// A fault waiting for its time, or active until a time.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Pending {
    pub fault: Fault,
    pub when: Trigger,
    pub duration: Option<f64>,
}

/// The simulated vehicle.
#[derive(Debug, Clone)]
pub struct Vehicle {
    pub(crate) cfg: SimConfig,
    pub(crate) params: Params,
    pub(crate) af: Airframe,
    /// Sim time reached (µs since boot).
    pub(crate) now: u64,
    next_step: u64,
    pub(crate) ac: Aircraft,
    pub(crate) boot: BootState,
    pub(crate) fl: Flight,
    /// Home now (moves at arming and disarming, as on ArduPlane).
    pub(crate) home_pos: V2,
    pub(crate) home_set: bool,
    pub(crate) mission: Vec<MissionItem>,
    pub(crate) auto: AutoState,
    /// The rover's navigation (a plane does not use it).
    pub(crate) rv: RoverNav,
    pub(crate) uploads: Uploads,
    pub(crate) streams: Streams,
    pub(crate) camera: Camera,
    /// Faults scheduled, not yet started.
    pub(crate) scheduled: Vec<Pending>,
    /// Faults active, with the time they clear.
    pub(crate) active: Vec<(Fault, Option<u64>)>,
    out: VecDeque<(MavHeader, MavMessage)>,
    seq_autopilot: u8,
    seq_camera: u8,
    pub(crate) truth: SimState,
    /// Texts to send later: (time, severity, text).
    pub(crate) later: Vec<(u64, MavSeverity, String)>,
    /// Servo outputs 1..16 set by DO_SET_SERVO (0 = not driven).
    pub(crate) servos: [u16; 16],
    pub(crate) relays: [bool; 6],
    pub(crate) next_timesync: u64,
    pub(crate) next_stats: u64,
    pub(crate) next_prearm_report: u64,
    /// MSG_TERRAIN sends so far (every sixth carries a TERRAIN_REQUEST).
    pub(crate) next_terrain_request: u64,
    pub(crate) esc_count: u16,
    pub(crate) statustext_id: u16,
    /// The last MISSION_ITEM_REACHED (65535 before any), re-sent when
    /// streamed.
    pub(crate) last_reached: u16,
    /// HOME_POSITION to send at this time.
    pub(crate) home_due: Option<u64>,
    /// Messages held while a command is handled (they follow its ack).
    held: Option<Vec<(u8, MavMessage)>>,
    /// Frames dropped by a link loss.
    pub(crate) dropped: u64,
    /// Sim µs of the simulation when this boot began (0 until a reboot):
    /// `now` counts from it, the caller's clock from the first boot.
    epoch: u64,
    /// A reboot under way: the boot-time µs at which the autopilot starts
    /// again (silent until then).
    reboot_at: Option<u64>,
    /// This boot follows a watchdog reset in flight: the start-up restores
    /// the mode and arming instead of starting in MANUAL, disarmed.
    pub(crate) watchdog: bool,
    /// Link faults for the socket to apply (bytes of garbage due).
    garbage_due: usize,
}

/// The link faults the socket applies to what the vehicle sends
/// ([`Vehicle::take_wire_faults`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct WireFaults {
    /// Random bytes to write among the frames now.
    pub garbage: usize,
    /// Send every frame twice.
    pub duplicate: bool,
    /// Swap the frames two by two.
    pub reorder: bool,
}

impl Vehicle {
    /// A vehicle just powered on (sim time 0), parked at `cfg.home`.
    pub fn new(cfg: SimConfig) -> Vehicle {
        let mut params = Params::of(cfg.firmware);
        for (name, value) in &cfg.params {
            if !params.set(name, *value) {
                tracing::warn!(%name, "unknown parameter in SimConfig::params, ignored");
            }
        }
        params.set("SYSID_THISMAV", cfg.system_id as f32);
        let mut streams = Streams::default();
        for group in streams.request_stream(0, 0, cfg.stream_hz, cfg.stream_hz > 0) {
            params.set(group.param(), cfg.stream_hz.min(50) as f32);
        }
        params.set("BATT_CAPACITY", cfg.airframe.battery_capacity_mah as f32);
        let af = cfg.airframe.clone();
        let wind = V2::new(cfg.wind.0, cfg.wind.1);
        let ac = Aircraft::parked(cfg.home.heading.to_radians(), wind, cfg.home.alt_amsl, &af);
        let scheduled = cfg
            .faults
            .entries
            .iter()
            .map(|e| Pending {
                fault: e.fault.clone(),
                when: e.when,
                duration: e.duration,
            })
            .collect();
        let step = cfg.step_us.max(1_000);
        let mut v = Vehicle {
            params,
            af,
            now: 0,
            next_step: step,
            ac,
            boot: BootState::default(),
            fl: Flight::new(),
            home_pos: V2::ZERO,
            home_set: false,
            mission: Vec::new(),
            auto: Default::default(),
            rv: Default::default(),
            uploads: Uploads::default(),
            streams,
            camera: Camera::default(),
            scheduled,
            active: Vec::new(),
            out: VecDeque::new(),
            seq_autopilot: 0,
            seq_camera: 0,
            truth: SimState::default(),
            later: Vec::new(),
            servos: [0; 16],
            relays: [false; 6],
            next_timesync: 10_000_000,
            next_stats: 30_700_000,
            next_prearm_report: 30_000_000,
            next_terrain_request: 0,
            esc_count: 0,
            statustext_id: 0,
            last_reached: u16::MAX,
            home_due: None,
            held: None,
            dropped: 0,
            epoch: 0,
            reboot_at: None,
            watchdog: false,
            garbage_due: 0,
            cfg,
        };
        v.cfg.step_us = step;
        v.truth.link_up = true;
        v
    }

    /// Sim time reached (µs since the simulation started: a reboot does
    /// not reset it).
    pub fn now_us(&self) -> u64 {
        self.epoch + self.now
    }

    /// The vehicle's system id.
    pub fn system_id(&self) -> u8 {
        self.cfg.system_id
    }

    /// A message received at `now` (sim µs). Time advances to `now` first.
    pub fn handle(&mut self, now: u64, header: &MavHeader, msg: &MavMessage) {
        self.advance(now);
        if self.reboot_at.is_some() {
            return;
        }
        if self.link_lost() {
            return;
        }
        let Ok(sys) = u8::try_from(header.system_id) else {
            return;
        };
        let from = (sys, header.component_id);
        if sys == self.cfg.system_id
            && (header.component_id == AUTOPILOT || header.component_id == camera::COMPONENT)
        {
            return; // our own frames, echoed
        }
        self.on_message(from, msg);
    }

    /// Runs the simulation up to `now` (sim µs since the simulation
    /// started): physics steps, streams, heartbeats, timers. Time never
    /// goes back.
    pub fn advance(&mut self, now: u64) {
        loop {
            let now = now.saturating_sub(self.epoch);
            let step = self.next_step;
            let tele = self.next_telemetry();
            let t = step.min(tele);
            if let Some(at) = self.reboot_at.filter(|at| *at <= t.min(now)) {
                self.now = self.now.max(at);
                self.reboot();
                continue;
            }
            if t > now {
                break;
            }
            self.now = self.now.max(t);
            if t == step {
                self.step();
                self.next_step += self.cfg.step_us;
            } else {
                self.emit_telemetry(t);
            }
        }
        self.now = self.now.max(now.saturating_sub(self.epoch));
    }

    /// The next frame to send, with its header (sequence numbers per
    /// component, counted also for frames a link loss swallows).
    pub fn poll_transmit(&mut self) -> Option<(MavHeader, MavMessage)> {
        self.out.pop_front()
    }

    /// The next time (sim µs) something happens even if nothing arrives:
    /// the runner sleeps until then.
    pub fn next_deadline(&self) -> u64 {
        self.epoch + self.next_step.min(self.next_telemetry())
    }

    /// The link faults active now, and the garbage due (taken: the
    /// socket writes it once).
    pub fn take_wire_faults(&mut self) -> WireFaults {
        let silent = self.link_lost();
        WireFaults {
            garbage: if silent {
                0
            } else {
                std::mem::take(&mut self.garbage_due)
            },
            duplicate: self.has_fault(FaultKind::Duplicate),
            reorder: self.has_fault(FaultKind::Reorder),
        }
    }

    /// The result every command to the autopilot gets under
    /// [`Fault::RefuseCommands`], if active.
    pub(crate) fn refusal(&self) -> Option<MavResult> {
        self.active.iter().find_map(|(f, _)| match f {
            Fault::RefuseCommands(r) | Fault::RefuseCommand(r) => Some(match r {
                Refusal::Denied => MavResult::MAV_RESULT_DENIED,
                Refusal::Failed => MavResult::MAV_RESULT_FAILED,
                Refusal::TemporarilyRejected => MavResult::MAV_RESULT_TEMPORARILY_REJECTED,
            }),
            _ => None,
        })
    }

    /// The autopilot boots again (the end of [`Fault::Reboot`]'s silence):
    /// a fresh autopilot, from boot time 0, with what survives a reset.
    fn reboot(&mut self) {
        let boot = self.epoch + self.now;
        tracing::info!(t = self.t_s(), "autopilot reboots");
        let mut fresh = Vehicle::new(self.cfg.clone());
        fresh.epoch = boot;
        // EEPROM: the parameters, the mission.
        fresh.params = self.params.clone();
        fresh.mission = std::mem::take(&mut self.mission);
        // The world: the aircraft flies on.
        fresh.ac = self.ac.clone();
        // The watchdog's persistent data (a reset in flight): armed, the
        // mode, home, the mission's current item; the flight goes on.
        let in_flight = self.fl.armed;
        if in_flight {
            fresh.fl = std::mem::take(&mut self.fl);
            fresh.auto = std::mem::take(&mut self.auto);
            fresh.rv = std::mem::take(&mut self.rv);
            fresh.home_pos = self.home_pos;
            fresh.home_set = self.home_set;
            fresh.watchdog = true;
            fresh.last_reached = self.last_reached;
        }
        fresh.servos = self.servos;
        fresh.relays = self.relays;
        // The test's records and the faults under way go on.
        fresh.truth = std::mem::take(&mut self.truth);
        fresh.scheduled = std::mem::take(&mut self.scheduled);
        fresh.active = std::mem::take(&mut self.active)
            .into_iter()
            .filter(|(f, _)| f.kind() != FaultKind::Reboot)
            .collect();
        fresh.dropped = self.dropped;
        *self = fresh;
    }

    /// Injects a fault now; it stays until [`Vehicle::clear`].
    pub fn inject(&mut self, fault: Fault) {
        self.start_fault(fault, None);
    }

    /// Injects a fault now for `duration_s` sim seconds.
    pub fn inject_for(&mut self, fault: Fault, duration_s: f64) {
        let until = self.run_us() + (duration_s.max(0.0) * 1e6) as u64;
        self.start_fault(fault, Some(until));
    }

    /// Ends the active faults of a kind.
    pub fn clear(&mut self, kind: FaultKind) {
        let ended: Vec<Fault> = self
            .active
            .iter()
            .filter(|(f, _)| f.kind() == kind)
            .map(|(f, _)| f.clone())
            .collect();
        self.active.retain(|(f, _)| f.kind() != kind);
        for f in ended {
            self.end_fault(f);
        }
    }

    /// A snapshot of the simulated truth.
    pub fn state(&self) -> SimState {
        let mut s = self.truth.clone();
        let (lat, lon) = geo::location(&self.cfg.home, self.ac.pos);
        s.time_s = self.t_s();
        s.armed = self.fl.armed;
        s.custom_mode = self.fl.mode;
        s.mode = self.mode_name();
        s.system_status = self.system_status() as u8;
        s.lat = lat;
        s.lon = lon;
        s.alt = self.ac.alt;
        s.north = self.ac.pos.n;
        s.east = self.ac.pos.e;
        s.airspeed = self.ac.indicated_airspeed();
        s.groundspeed = self.ac.groundspeed();
        s.climb = self.ac.climb;
        s.heading = self.ac.heading.to_degrees();
        s.bank = self.ac.bank.to_degrees();
        s.pitch = self.ac.pitch.to_degrees();
        s.max_bank = self.fl.max_bank.to_degrees();
        s.throttle = self.ac.throttle * 100.0;
        s.on_ground = self.ac.on_ground;
        s.flying = self.is_flying();
        s.landed = self.fl.landed;
        s.crashed = self.fl.crashed;
        s.engine_running = self.ac.engine.working && self.ac.engine.rpm > 0.0;
        s.engine_rpm = self.ac.engine.rpm;
        s.battery_remaining = self.battery_remaining();
        s.battery_voltage = self.ac.battery.voltage;
        s.gps_fix = self.gps_fix();
        s.satellites = if s.gps_fix >= 3 { 10 } else { 0 };
        s.link_up = !self.link_lost();
        s.mission = self.mission.clone();
        s.mission_current = self.auto.current;
        s
    }

    // ----- helpers shared by the other modules -----

    /// Sim seconds since the simulation started (for the test's records
    /// and the fault schedule; a reboot does not reset them).
    pub(crate) fn t_s(&self) -> f64 {
        (self.epoch + self.now) as f64 / 1e6
    }

    /// Sim seconds since this boot (the start-up sequence's clock).
    pub(crate) fn boot_s(&self) -> f64 {
        self.now as f64 / 1e6
    }

    /// Sim µs since the simulation started (faults' end times).
    fn run_us(&self) -> u64 {
        self.epoch + self.now
    }

    pub(crate) fn fix(&self) -> Fix {
        let (lat, lon) = geo::location(&self.cfg.home, self.ac.pos);
        Fix {
            time_s: self.t_s(),
            lat,
            lon,
            alt: self.ac.alt,
        }
    }

    /// The boot home (the EKF origin and the frame of `Aircraft::pos`).
    pub(crate) fn origin(&self) -> &Home {
        &self.cfg.home
    }

    pub(crate) fn ready(&self) -> bool {
        self.boot.has(Phase::Ready)
    }

    pub(crate) fn has_fault(&self, kind: FaultKind) -> bool {
        self.active.iter().any(|(f, _)| f.kind() == kind)
    }

    pub(crate) fn link_lost(&self) -> bool {
        self.has_fault(FaultKind::LinkLoss) || self.reboot_at.is_some()
    }

    pub(crate) fn battery_remaining(&self) -> f64 {
        self.ac.battery.remaining(self.af.battery_capacity_mah)
    }

    /// Holds what is sent from now on until [`Vehicle::release`].
    pub(crate) fn hold(&mut self) {
        self.held = Some(Vec::new());
    }

    /// Ends holding; returns what was held.
    pub(crate) fn release(&mut self) -> Vec<(u8, MavMessage)> {
        self.held.take().unwrap_or_default()
    }

    /// Queues a message from a component.
    pub(crate) fn send_from(&mut self, component: u8, msg: MavMessage) {
        if let Some(held) = self.held.as_mut() {
            held.push((component, msg));
            return;
        }
        let seq = if component == camera::COMPONENT {
            &mut self.seq_camera
        } else {
            &mut self.seq_autopilot
        };
        let header = MavHeader {
            system_id: self.cfg.system_id as u32,
            component_id: component,
            sequence: *seq,
        };
        *seq = seq.wrapping_add(1);
        if self.link_lost() {
            self.dropped += 1;
            return;
        }
        self.out.push_back((header, msg));
    }

    /// Queues a message from the autopilot.
    pub(crate) fn send(&mut self, msg: MavMessage) {
        self.send_from(AUTOPILOT, msg);
    }

    /// Sends a STATUSTEXT (in 50-character chunks when longer, as ArduPilot).
    pub(crate) fn text(&mut self, severity: MavSeverity, text: impl Into<String>) {
        let text: String = text.into();
        tracing::debug!(t = self.t_s(), %text, "STATUSTEXT");
        self.truth.statustexts.push(Text {
            time_s: self.t_s(),
            severity: severity as u8,
            text: text.clone(),
        });
        let bytes = text.as_bytes();
        if bytes.len() <= 50 {
            self.send(MavMessage::STATUSTEXT(STATUSTEXT_DATA {
                severity,
                text: text.as_str().into(),
                id: 0,
                chunk_seq: 0,
            }));
            return;
        }
        self.statustext_id = self.statustext_id.wrapping_add(1).max(1);
        let id = self.statustext_id;
        for (i, chunk) in bytes.chunks(50).enumerate() {
            let mut data = [0u8; 50];
            data[..chunk.len()].copy_from_slice(chunk);
            self.send(MavMessage::STATUSTEXT(STATUSTEXT_DATA {
                severity,
                text: data.into(),
                id,
                chunk_seq: i as u8,
            }));
        }
    }

    pub(crate) fn info(&mut self, text: impl Into<String>) {
        self.text(MavSeverity::MAV_SEVERITY_INFO, text);
    }

    /// Sends a text `delay_s` later.
    pub(crate) fn info_later(&mut self, delay_s: f64, text: impl Into<String>) {
        let at = self.now + (delay_s * 1e6) as u64;
        self.later
            .push((at, MavSeverity::MAV_SEVERITY_INFO, text.into()));
    }

    // ----- time -----

    fn next_telemetry(&self) -> u64 {
        let mut t = self.streams.next_due().unwrap_or(u64::MAX);
        if self.cfg.camera {
            t = t.min(self.camera.next_deadline());
        }
        t
    }

    /// One physics step at `self.now`.
    fn step(&mut self) {
        self.boot_tick();
        self.fault_tick();
        self.timers_tick();
        if self.is_rover() {
            self.rover_step();
            for r in self.uploads.tick(self.now) {
                self.mission_reply(r);
            }
            return;
        }
        let ctrl = self.control();
        let dt = self.cfg.step_us as f64 / 1e6;
        let limit = self.roll_limit();
        let armed = self.fl.armed;
        let contact = self.ac.step(dt, &ctrl, armed, &self.af, limit);
        self.after_step(contact);
        for r in self.uploads.tick(self.now) {
            self.mission_reply(r);
        }
    }

    /// Delayed texts, TIMESYNC, statistics, the periodic PreArm report.
    fn timers_tick(&mut self) {
        let now = self.now;
        let due: Vec<(u64, MavSeverity, String)> = {
            let (due, keep): (Vec<_>, Vec<_>) =
                self.later.drain(..).partition(|(t, _, _)| *t <= now);
            self.later = keep;
            due
        };
        for (_, sev, text) in due {
            self.text(sev, text);
        }
        if self.home_due.is_some_and(|t| t <= now) {
            self.home_due = None;
            self.send_home();
        }
        if now >= self.next_timesync {
            self.next_timesync += 10_000_000;
            self.send_timesync();
        }
        if now >= self.next_stats {
            self.next_stats += 30_000_000;
            self.send_stats();
        }
        if now >= self.next_prearm_report {
            self.next_prearm_report += 30_000_000;
            self.prearm_report();
        }
    }

    /// Emits the streams and camera outputs due at `t`.
    fn emit_telemetry(&mut self, t: u64) {
        if self.cfg.camera && self.camera.next_deadline() <= t {
            for o in self.camera.tick(t) {
                self.camera_output(o);
            }
        }
        if self.streams.next_due().is_some_and(|d| d <= t) {
            for m in self.streams.take_due(t) {
                if m == id::HEARTBEAT {
                    self.send_heartbeat();
                } else if self.ready() {
                    self.send_stream(m);
                }
            }
        }
    }

    // ----- faults -----

    fn fault_tick(&mut self) {
        let t = self.t_s();
        let due: Vec<Pending> = {
            let (due, keep): (Vec<_>, Vec<_>) = self
                .scheduled
                .drain(..)
                .partition(|p| matches!(p.when, Trigger::At(at) if at <= t));
            self.scheduled = keep;
            due
        };
        for p in due {
            let until = p.duration.map(|d| self.run_us() + (d * 1e6) as u64);
            self.start_fault(p.fault, until);
        }
        let now = self.run_us();
        let ended: Vec<Fault> = self
            .active
            .iter()
            .filter(|(_, until)| until.is_some_and(|u| u <= now))
            .map(|(f, _)| f.clone())
            .collect();
        self.active
            .retain(|(_, until)| !until.is_some_and(|u| u <= now));
        for f in ended {
            self.end_fault(f);
        }
    }

    /// Faults scheduled on a mission item being reached.
    pub(crate) fn faults_on_reached(&mut self, seq: u16) {
        let due: Vec<Pending> = {
            let (due, keep): (Vec<_>, Vec<_>) = self
                .scheduled
                .drain(..)
                .partition(|p| p.when == Trigger::Reached(seq));
            self.scheduled = keep;
            due
        };
        for p in due {
            let until = p.duration.map(|d| self.run_us() + (d * 1e6) as u64);
            self.start_fault(p.fault, until);
        }
    }

    fn start_fault(&mut self, fault: Fault, until: Option<u64>) {
        tracing::info!(t = self.t_s(), %fault, "fault injected");
        self.truth.faults.push(crate::state::FaultEvent {
            time_s: self.t_s(),
            fault: fault.clone(),
            cleared: false,
        });
        match &fault {
            Fault::EngineFailure => self.ac.engine.working = false,
            Fault::PayloadFailure(kind) => self.camera.set_failure(Some(*kind)),
            Fault::GpsLoss => {}
            Fault::BatteryDrain { factor } => self.ac.battery.drain_factor = *factor,
            Fault::BatteryRemaining { percent } => {
                let cap = self.af.battery_capacity_mah;
                self.ac.battery.consumed_mah = cap * (1.0 - percent / 100.0);
                // Instantaneous: nothing stays active.
                return;
            }
            Fault::LinkLoss => {}
            Fault::Emergency { text } => {
                let text = text.clone();
                self.text(MavSeverity::MAV_SEVERITY_EMERGENCY, text);
            }
            Fault::Reboot { silence_s } => {
                // Instantaneous: silent now, boots after the silence.
                self.reboot_at = Some(self.now + (silence_s * 1e6) as u64);
                return;
            }
            Fault::Garbage { bytes } => {
                self.garbage_due += bytes;
                return;
            }
            Fault::RefuseCommands(_)
            | Fault::RefuseCommand(_)
            | Fault::Duplicate
            | Fault::Reorder
            | Fault::Stuck => {}
        }
        self.active.retain(|(f, _)| f.kind() != fault.kind());
        self.active.push((fault, until));
    }

    fn end_fault(&mut self, fault: Fault) {
        tracing::info!(t = self.t_s(), %fault, "fault cleared");
        self.truth.faults.push(crate::state::FaultEvent {
            time_s: self.t_s(),
            fault: fault.clone(),
            cleared: true,
        });
        match fault {
            Fault::EngineFailure => self.ac.engine.working = true,
            Fault::PayloadFailure(_) => self.camera.set_failure(None),
            Fault::BatteryDrain { .. } => self.ac.battery.drain_factor = 1.0,
            Fault::GpsLoss
            | Fault::BatteryRemaining { .. }
            | Fault::LinkLoss
            | Fault::Emergency { .. }
            | Fault::Reboot { .. }
            | Fault::RefuseCommands(_)
            | Fault::RefuseCommand(_)
            | Fault::Garbage { .. }
            | Fault::Duplicate
            | Fault::Reorder
            | Fault::Stuck => {}
        }
    }
}

#[cfg(test)]
#[allow(deprecated, dead_code)]
pub(crate) mod testing {
    //! Helpers for the unit tests: a vehicle driven on simulated time.

    use super::*;
    use mavlink::dialects::ardupilotmega::*;

    pub const GCS: (u8, u8) = (255, 190);

    pub fn quick() -> SimConfig {
        SimConfig {
            boot: crate::boot::BootTimeline::quick(),
            first_arm_refused: false,
            ..SimConfig::default()
        }
    }

    /// A vehicle with its frames collected.
    pub struct Bench {
        pub v: Vehicle,
        pub got: Vec<(u64, MavHeader, MavMessage)>,
    }

    impl Bench {
        pub fn new(cfg: SimConfig) -> Bench {
            Bench {
                v: Vehicle::new(cfg),
                got: Vec::new(),
            }
        }

        fn drain(&mut self) {
            while let Some((h, m)) = self.v.poll_transmit() {
                self.got.push((self.v.now_us(), h, m));
            }
        }

        /// Collects what the vehicle sent after a direct call.
        pub fn drain_for_tests(&mut self) {
            self.drain();
        }

        /// Runs until `t` seconds.
        pub fn run_to(&mut self, t: f64) {
            let end = (t * 1e6) as u64;
            while self.v.now_us() < end {
                let next = (self.v.now_us() + 20_000).min(end);
                self.v.advance(next);
                self.drain();
            }
        }

        /// Runs until `cond` holds or `limit` seconds; returns whether it held.
        pub fn run_until(&mut self, limit: f64, cond: impl Fn(&Vehicle) -> bool) -> bool {
            let end = (limit * 1e6) as u64;
            while self.v.now_us() < end {
                if cond(&self.v) {
                    return true;
                }
                let next = self.v.now_us() + 20_000;
                self.v.advance(next);
                self.drain();
            }
            cond(&self.v)
        }

        pub fn send(&mut self, msg: MavMessage) {
            let header = MavHeader {
                system_id: GCS.0 as u32,
                component_id: GCS.1,
                sequence: 0,
            };
            let now = self.v.now_us();
            self.v.handle(now, &header, &msg);
            self.drain();
        }

        pub fn command(&mut self, command: MavCmd, p: [f32; 7]) -> Option<MavResult> {
            self.command_to(AUTOPILOT, command, p)
        }

        pub fn command_to(&mut self, comp: u8, command: MavCmd, p: [f32; 7]) -> Option<MavResult> {
            let before = self.got.len();
            self.send(crate::wire::command_long((1, comp), command, p));
            self.got[before..].iter().find_map(|(_, _, m)| match m {
                MavMessage::COMMAND_ACK(a) if a.command == command => Some(a.result),
                _ => None,
            })
        }

        /// A COMMAND_INT to the autopilot; the result of its ack.
        pub fn command_int(
            &mut self,
            command: MavCmd,
            frame: MavFrame,
            p: [f32; 4],
            x: i32,
            y: i32,
            z: f32,
        ) -> Option<MavResult> {
            let before = self.got.len();
            self.send(MavMessage::COMMAND_INT(COMMAND_INT_DATA {
                param1: p[0],
                param2: p[1],
                param3: p[2],
                param4: p[3],
                x,
                y,
                z,
                command,
                target_system: 1,
                target_component: AUTOPILOT,
                frame,
                current: 0,
                autocontinue: 0,
            }));
            self.got[before..].iter().find_map(|(_, _, m)| match m {
                MavMessage::COMMAND_ACK(a) if a.command == command => Some(a.result),
                _ => None,
            })
        }

        /// Quick boot, TAKEOFF mode, armed, climbed to TKOFF_ALT and loitering.
        pub fn airborne(cfg: SimConfig) -> Bench {
            let mut b = Bench::new(cfg);
            b.run_to(4.0);
            assert_eq!(
                b.set_mode(crate::modes::TAKEOFF),
                Some(MavResult::MAV_RESULT_ACCEPTED)
            );
            assert_eq!(b.arm(), Some(MavResult::MAV_RESULT_ACCEPTED));
            let done = b.run_until(60.0, |v| {
                v.truth
                    .statustexts
                    .iter()
                    .any(|t| t.text.starts_with("Takeoff complete"))
            });
            assert!(done, "no take-off: {:?}", b.texts());
            b
        }

        /// Messages of a type sent after index `from` of `got`.
        pub fn since(&self, from: usize, name: &str) -> Vec<(u64, MavHeader, MavMessage)> {
            use mavlink::Message;
            self.got[from..]
                .iter()
                .filter(|(_, _, m)| m.message_name() == name)
                .cloned()
                .collect()
        }

        pub fn set_mode(&mut self, mode: u32) -> Option<MavResult> {
            self.command(
                MavCmd::MAV_CMD_DO_SET_MODE,
                [1.0, mode as f32, 0.0, 0.0, 0.0, 0.0, 0.0],
            )
        }

        pub fn arm(&mut self) -> Option<MavResult> {
            self.command(
                MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            )
        }

        /// Uploads items 1.. (item 0 home added) answering every request.
        pub fn upload(&mut self, items: &[MissionItem]) -> MavMissionResult {
            let mut all = vec![MissionItem::home(0.0, 0.0, 0.0)];
            all.extend(items.iter().cloned());
            for (i, it) in all.iter_mut().enumerate() {
                it.seq = i as u16;
            }
            self.send(MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
                count: all.len() as u16,
                target_system: 1,
                target_component: 1,
                mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
                opaque_id: 0,
            }));
            for _ in 0..(all.len() * 3) {
                let last = self.got.iter().rev().find_map(|(_, _, m)| match m {
                    MavMessage::MISSION_REQUEST(r) => Some(Err(r.seq)),
                    MavMessage::MISSION_ACK(a) => Some(Ok(a.mavtype)),
                    _ => None,
                });
                match last {
                    Some(Ok(r)) => return r,
                    Some(Err(seq)) => {
                        let it = all[seq as usize].to_int((1, 1), false);
                        self.send(MavMessage::MISSION_ITEM_INT(it));
                    }
                    None => self.run_to(self.v.t_s() + 0.1),
                }
            }
            MavMissionResult::MAV_MISSION_ERROR
        }

        /// The messages of a type received so far.
        pub fn of(&self, name: &str) -> Vec<&MavMessage> {
            use mavlink::Message;
            self.got
                .iter()
                .filter(|(_, _, m)| m.message_name() == name)
                .map(|(_, _, m)| m)
                .collect()
        }

        pub fn texts(&self) -> Vec<String> {
            self.v
                .truth
                .statustexts
                .iter()
                .map(|t| t.text.clone())
                .collect()
        }
    }

    /// A mission item at `(north, east)` metres from home, `alt` m above home.
    pub fn item(v: &Vehicle, command: u32, north: f64, east: f64, alt: f32) -> MissionItem {
        let (lat, lon) = crate::geo::location(&v.cfg.home, V2::new(north, east));
        let mut it = MissionItem::home(lat, lon, alt as f64);
        it.command = command;
        it.frame = MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT;
        it
    }
}

#[cfg(test)]
#[allow(deprecated)] // REQUEST_DATA_STREAM, as ArduPilot's clients still send it
mod tests {
    use super::testing::*;
    use crate::faults::{Fault, FaultKind, PayloadFailure, Schedule};
    use mavlink::dialects::ardupilotmega::*;

    fn all_streams(b: &mut Bench) {
        b.send(MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
            req_message_rate: 4,
            target_system: 1,
            target_component: 1,
            req_stream_id: MavDataStream::MAV_DATA_STREAM_ALL,
            start_stop: 1,
        }));
    }

    #[test]
    fn a_reboot_in_flight_is_silent_then_boots_from_zero_and_flies_on() {
        let mut b = Bench::airborne(quick());
        all_streams(&mut b);
        b.set_mode(crate::modes::LOITER);
        b.run_to(b.v.t_s() + 5.0);
        assert!(b.v.params.set("RTL_AUTOLAND", 2.0));
        let before = b.v.state();
        let at = before.time_s;
        b.v.inject(Fault::Reboot { silence_s: 2.0 });
        let from = b.got.len();
        // Silent, and deaf: a command during the silence is not heard.
        assert_eq!(b.set_mode(crate::modes::RTL), None);
        b.run_to(at + 1.9);
        assert_eq!(b.got.len(), from, "frames sent while rebooting");
        b.run_to(at + 8.0);
        let s = b.v.state();
        // The first frames of the new boot: sequence 0, and every
        // time_boot_ms from the new boot.
        let (_, h, _) = b.got[from..]
            .iter()
            .find(|(_, h, _)| h.component_id == crate::AUTOPILOT)
            .expect("frames after the reboot");
        assert_eq!(h.sequence, 0);
        let boot_ms: Vec<u32> = b
            .since(from, "SYSTEM_TIME")
            .iter()
            .filter_map(|(_, _, m)| match m {
                MavMessage::SYSTEM_TIME(t) => Some(t.time_boot_ms),
                _ => None,
            })
            .collect();
        assert!(!boot_ms.is_empty(), "no SYSTEM_TIME after the reboot");
        // The first at the stream's first second of the new boot.
        assert!(
            boot_ms[0] <= 1_000 && (boot_ms[0] as f64) < at * 1e3 - 10_000.0,
            "{boot_ms:?} after {at} s"
        );
        assert!(b.since(from, "HEARTBEAT").len() > 3);
        // The simulation's clock goes on; the flight goes on, armed, in
        // its mode, with its parameters and mission.
        assert!((s.time_s - (at + 8.0)).abs() < 0.01, "{}", s.time_s);
        assert!(
            s.armed && s.flying && !s.crashed && s.mode == "LOITER",
            "{s:?}"
        );
        assert_eq!(b.v.params.get("RTL_AUTOLAND"), 2.0);
        assert_eq!(s.mission, before.mission);
        assert_eq!(
            s.faults.last().map(|f| f.fault.kind()),
            Some(FaultKind::Reboot)
        );
        // Commands are heard again.
        assert_eq!(
            b.set_mode(crate::modes::RTL),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
    }

    #[test]
    fn refused_commands_are_answered_and_do_nothing() {
        let mut b = Bench::new(quick());
        b.run_to(4.0);
        b.v.inject_for(Fault::RefuseCommands(crate::faults::Refusal::Denied), 5.0);
        assert_eq!(
            b.set_mode(crate::modes::FBWA),
            Some(MavResult::MAV_RESULT_DENIED)
        );
        assert_eq!(b.arm(), Some(MavResult::MAV_RESULT_DENIED));
        let s = b.v.state();
        assert!(s.mode == "MANUAL" && !s.armed, "{s:?}");
        b.run_to(9.5);
        assert_eq!(
            b.set_mode(crate::modes::FBWA),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        assert_eq!(b.v.state().mode, "FLY_BY_WIRE_A");
        // One command refused, then the fault clears by itself.
        b.v.inject(Fault::RefuseCommand(
            crate::faults::Refusal::TemporarilyRejected,
        ));
        assert_eq!(
            b.set_mode(crate::modes::MANUAL),
            Some(MavResult::MAV_RESULT_TEMPORARILY_REJECTED)
        );
        assert_eq!(
            b.set_mode(crate::modes::MANUAL),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        let f = &b.v.state().faults;
        assert!(f
            .last()
            .is_some_and(|f| f.cleared && f.fault.kind() == FaultKind::RefuseCommand));
    }

    #[test]
    fn link_faults_are_handed_to_the_socket() {
        let mut b = Bench::new(quick());
        b.run_to(1.0);
        assert_eq!(b.v.take_wire_faults(), crate::WireFaults::default());
        b.v.inject(Fault::Garbage { bytes: 300 });
        b.v.inject_for(Fault::Duplicate, 2.0);
        b.v.inject_for(Fault::Reorder, 4.0);
        let w = b.v.take_wire_faults();
        assert_eq!((w.garbage, w.duplicate, w.reorder), (300, true, true));
        // The garbage once; each fault until it clears.
        assert_eq!(b.v.take_wire_faults().garbage, 0);
        b.run_to(3.5);
        let w = b.v.take_wire_faults();
        assert_eq!((w.duplicate, w.reorder), (false, true));
        b.run_to(5.5);
        assert_eq!(b.v.take_wire_faults(), crate::WireFaults::default());
    }

    #[test]
    fn a_link_loss_is_silent_both_ways() {
        let mut b = Bench::new(quick());
        b.run_to(4.0);
        all_streams(&mut b);
        b.run_to(5.0);
        let last_seq = b
            .got
            .iter()
            .rev()
            .find(|(_, h, _)| h.component_id == 1)
            .map(|x| x.1.sequence)
            .unwrap();
        b.v.inject_for(Fault::LinkLoss, 10.0);
        let from = b.got.len();
        // Nothing heard: the mode change is not received.
        assert_eq!(b.set_mode(crate::modes::FBWA), None);
        b.run_to(14.9);
        assert_eq!(b.got.len(), from, "frames sent during the link loss");
        assert!(!b.v.state().link_up);
        b.run_to(16.0);
        let s = b.v.state();
        assert!(s.link_up);
        assert_eq!(s.mode, "MANUAL");
        assert!(
            s.commands.is_empty(),
            "a command heard during the loss: {:?}",
            s.commands
        );
        // Frames flow again, their sequence numbers showing the loss.
        let (_, h, _) = b.got[from..]
            .iter()
            .find(|(_, h, _)| h.component_id == 1)
            .unwrap();
        assert!(
            h.sequence.wrapping_sub(last_seq) > 100,
            "{} after {}",
            h.sequence,
            last_seq
        );
        assert_eq!(
            b.set_mode(crate::modes::FBWA),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        let f = &s.faults;
        assert_eq!((f.len(), f[0].cleared, f[1].cleared), (2, false, true));
        assert!((f[1].time_s - f[0].time_s - 10.0).abs() < 0.05);
    }

    #[test]
    fn scheduled_faults_start_and_end_on_time() {
        let mut b = Bench::new(crate::SimConfig {
            faults: Schedule::parse(&[
                "gps_loss@5s:3s",
                "battery=20@6s",
                "emergency=Fire on board@7s:2s",
                "payload_failure=critical@9s:3s",
                "battery_drain=50@10s",
            ])
            .unwrap(),
            ..quick()
        });
        b.run_to(3.0);
        all_streams(&mut b);
        let fix = |b: &Bench| match b.of("GPS_RAW_INT").last() {
            Some(MavMessage::GPS_RAW_INT(g)) => (g.fix_type as u8, g.satellites_visible),
            _ => unreachable!(),
        };
        let ekf = |b: &Bench| match b.of("EKF_STATUS_REPORT").last() {
            Some(MavMessage::EKF_STATUS_REPORT(e)) => e.flags.bits(),
            _ => unreachable!(),
        };
        let status = |b: &Bench| match b
            .got
            .iter()
            .rev()
            .find(|(_, h, m)| h.component_id == 1 && matches!(m, MavMessage::HEARTBEAT(_)))
        {
            Some((_, _, MavMessage::HEARTBEAT(h))) => h.system_status,
            _ => unreachable!(),
        };
        b.run_to(4.9);
        assert_eq!((fix(&b), ekf(&b)), ((6, 10), 0x33f));
        b.run_to(6.5);
        assert_eq!((fix(&b), ekf(&b)), ((1, 0), 0x25));
        assert!((b.v.state().battery_remaining - 20.0).abs() < 0.1);
        b.run_to(8.5);
        assert_eq!(fix(&b), (6, 10));
        assert_eq!(status(&b), MavState::MAV_STATE_EMERGENCY);
        assert!(b.texts().contains(&"Fire on board".to_owned()));
        b.run_to(11.6);
        assert_eq!(status(&b), MavState::MAV_STATE_STANDBY);
        let cam = |b: &Bench| {
            b.got.iter().rev().find_map(|(_, h, m)| match m {
                MavMessage::HEARTBEAT(x) if h.component_id == 100 => Some(x.system_status),
                _ => None,
            })
        };
        assert_eq!(cam(&b), Some(MavState::MAV_STATE_CRITICAL));
        b.run_to(13.0);
        assert_eq!(cam(&b), Some(MavState::MAV_STATE_ACTIVE));
        let kinds: Vec<(FaultKind, bool)> =
            b.v.state()
                .faults
                .iter()
                .map(|f| (f.fault.kind(), f.cleared))
                .collect();
        assert_eq!(
            kinds,
            vec![
                (FaultKind::GpsLoss, false),
                (FaultKind::BatteryRemaining, false),
                (FaultKind::Emergency, false),
                (FaultKind::GpsLoss, true),
                (FaultKind::PayloadFailure, false),
                (FaultKind::Emergency, true),
                (FaultKind::BatteryDrain, false),
                (FaultKind::PayloadFailure, true),
            ]
        );
        // Injected from the API, cleared by kind.
        b.v.inject(Fault::PayloadFailure(PayloadFailure::Silent));
        b.run_to(16.0);
        assert_eq!(
            cam(&b),
            Some(MavState::MAV_STATE_ACTIVE),
            "the last heartbeat was before"
        );
        let from = b.got.len();
        b.run_to(18.0);
        assert!(!b.got[from..].iter().any(|(_, h, _)| h.component_id == 100));
        b.v.clear(FaultKind::PayloadFailure);
        b.run_to(19.0);
        assert!(b.got[from..].iter().any(|(_, h, _)| h.component_id == 100));
    }

    #[test]
    fn battery_failsafe_when_configured() {
        let mut b = Bench::airborne(crate::SimConfig {
            params: vec![
                ("BATT_LOW_MAH".into(), 1000.0),
                ("BATT_FS_LOW_ACT".into(), 1.0),
            ],
            ..quick()
        });
        b.v.inject(Fault::BatteryRemaining { percent: 31.0 });
        b.v.inject(Fault::BatteryDrain { factor: 20.0 });
        assert!(b.run_until(b.v.state().time_s + 60.0, |v| v.fl.battery_failsafe > 0));
        let s = b.v.state();
        assert_eq!(s.mode, "RTL");
        assert_eq!(s.system_status, MavState::MAV_STATE_CRITICAL as u8);
        assert!(b.texts().iter().any(|t| t.starts_with("Battery 1 is low")));
    }

    use proptest::prelude::*;

    fn float() -> impl Strategy<Value = f32> {
        prop_oneof![
            Just(f32::NAN),
            Just(f32::INFINITY),
            Just(-1.0f32),
            Just(0.0f32),
            Just(1.0f32),
            Just(21196.0f32),
            any::<f32>(),
            -100.0f32..3000.0,
        ]
    }

    fn command() -> impl Strategy<Value = u32> {
        prop_oneof![
            prop::sample::select(vec![
                16u32, 17, 20, 21, 22, 176, 177, 178, 179, 181, 183, 189, 191, 192, 224, 300, 400,
                410, 510, 511, 512, 520, 2000, 2001,
            ]),
            any::<u32>(),
        ]
    }

    /// Any message the vehicle reads, with hostile fields.
    fn message() -> impl Strategy<Value = (MavMessage, u8)> {
        let p7 = || proptest::collection::vec(float(), 7);
        prop_oneof![
            (command(), p7(), prop::sample::select(vec![0u8, 1, 100, 7])).prop_map(
                |(c, p, comp)| {
                    (
                        MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
                            param1: p[0],
                            param2: p[1],
                            param3: p[2],
                            param4: p[3],
                            param5: p[4],
                            param6: p[5],
                            param7: p[6],
                            command: num_traits::FromPrimitive::from_u32(c).unwrap_or_default(),
                            target_system: 1,
                            target_component: comp,
                            confirmation: 0,
                        }),
                        comp,
                    )
                }
            ),
            (command(), p7(), any::<i32>(), any::<i32>(), 0u8..12).prop_map(|(c, p, x, y, f)| {
                (
                    MavMessage::COMMAND_INT(COMMAND_INT_DATA {
                        param1: p[0],
                        param2: p[1],
                        param3: p[2],
                        param4: p[3],
                        x,
                        y,
                        z: p[6],
                        command: num_traits::FromPrimitive::from_u32(c).unwrap_or_default(),
                        target_system: 1,
                        target_component: 1,
                        frame: num_traits::FromPrimitive::from_u8(f).unwrap_or_default(),
                        current: 0,
                        autocontinue: 0,
                    }),
                    1,
                )
            }),
            (0u16..1200).prop_map(|count| {
                (
                    MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
                        count,
                        target_system: 1,
                        target_component: 1,
                        mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
                        opaque_id: 0,
                    }),
                    1,
                )
            }),
            (
                0u16..8,
                command(),
                p7(),
                any::<i32>(),
                any::<i32>(),
                0u8..12
            )
                .prop_map(|(seq, c, p, x, y, f)| {
                    (
                        MavMessage::MISSION_ITEM_INT(MISSION_ITEM_INT_DATA {
                            param1: p[0],
                            param2: p[1],
                            param3: p[2],
                            param4: p[3],
                            x,
                            y,
                            z: p[6],
                            seq,
                            command: num_traits::FromPrimitive::from_u32(c).unwrap_or_default(),
                            target_system: 1,
                            target_component: 1,
                            frame: num_traits::FromPrimitive::from_u8(f).unwrap_or_default(),
                            current: 0,
                            autocontinue: 1,
                            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
                        }),
                        1,
                    )
                }),
            (any::<u16>(), any::<u16>()).prop_map(|(seq, rate)| {
                (
                    MavMessage::MISSION_SET_CURRENT(MISSION_SET_CURRENT_DATA {
                        seq,
                        target_system: 1,
                        target_component: 1,
                    }),
                    (rate % 2) as u8,
                )
            }),
            (any::<u8>(), any::<u16>(), any::<bool>()).prop_map(|(s, rate, on)| {
                (
                    MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
                        req_message_rate: rate,
                        target_system: 1,
                        target_component: 1,
                        req_stream_id: num_traits::FromPrimitive::from_u8(s % 13)
                            .unwrap_or_default(),
                        start_stop: on as u8,
                    }),
                    1,
                )
            }),
            (any::<i16>(), float()).prop_map(|(i, v)| {
                (
                    MavMessage::PARAM_SET(PARAM_SET_DATA {
                        param_value: v,
                        target_system: 1,
                        target_component: 1,
                        param_id: if i % 2 == 0 {
                            "TKOFF_ALT"
                        } else {
                            "ROLL_LIMIT_DEG"
                        }
                        .into(),
                        param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
                    }),
                    1,
                )
            }),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

        /// Whatever arrives, the vehicle neither panics nor stops talking.
        #[test]
        fn hostile_input_never_stops_the_vehicle(
            msgs in proptest::collection::vec((message(), 0u64..3_000_000), 1..40)
        ) {
            let mut b = Bench::new(quick());
            b.run_to(2.5);
            for ((m, _), dt) in msgs {
                let t = b.v.now_us() + dt;
                b.v.advance(t);
                b.send(m);
            }
            let from = b.got.len();
            let t = b.v.state().time_s + 3.0;
            b.run_to(t);
            prop_assert!(b.since(from, "HEARTBEAT").len() >= 2);
        }
    }
}
