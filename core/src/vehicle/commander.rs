//! The commander: the sans-IO state machine between the nets' `command`
//! effects and the autopilot. It learns the vehicle from its HEARTBEAT,
//! announces us, asks for telemetry, sends commands and mission uploads,
//! matches the answers, retries, and reports outcomes.

use std::collections::{BTreeSet, VecDeque};

use elaboration::Firmware;
// MISSION_SET_CURRENT and REQUEST_DATA_STREAM are superseded, and used on
// purpose: they are the fallbacks for autopilots without the newer commands.
#[allow(deprecated)]
use mavlink::dialects::ardupilotmega::{
    MavAutopilot, MavCmd, MavMessage, MavMissionType, MavModeFlag, MavResult, MavState, MavType,
    COMMAND_ACK_DATA, COMMAND_INT_DATA, COMMAND_LONG_DATA, HEARTBEAT_DATA,
    MISSION_SET_CURRENT_DATA, REQUEST_DATA_STREAM_DATA,
};
use mavlink::MavHeader;
use nets::{Micros, Outcome, Params, Value};

use super::config::VehicleConfig;
use super::mission::{build_items, Step, Upload};
use super::parameters::{ParameterCheck, Verdict};
use super::plan::{plan, CommandSpec, Context, Fallback, Plan};
use super::request::{parse, Request};
use super::streams::{data_streams, message_name, stream_of, streamable};

/// Resends of one SET_MESSAGE_INTERVAL before falling back.
const STREAM_RETRIES: u8 = 1;

/// Who asked for a command.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Origin {
    /// A net; the outcome goes back under this id.
    Net(u64),
    /// Our own telemetry request (SET_MESSAGE_INTERVAL for a message id).
    Stream { message: u32 },
}

#[derive(Debug, Clone, PartialEq)]
enum State {
    /// Not sent yet: no vehicle, or another command of the same MAV_CMD is
    /// in flight.
    Waiting,
    /// Sent; waiting for its COMMAND_ACK until `deadline`.
    Sent { deadline: Micros, in_progress: bool },
    /// TEMPORARILY_REJECTED: resend at `until`.
    Pausing { until: Micros },
    /// DO_SET_MISSION_CURRENT unsupported: MISSION_SET_CURRENT sent,
    /// waiting for MISSION_CURRENT to show `seq`.
    SetCurrent { seq: u16, deadline: Micros },
}

#[derive(Debug, Clone)]
struct Op {
    origin: Origin,
    request: Request,
    spec: Option<CommandSpec>,
    issued: Micros,
    state: State,
    /// Transmissions so far (the next confirmation is `sends`).
    sends: u8,
    /// Resends after a missing ack.
    timeouts: u8,
    rejected: u8,
    /// Switched between COMMAND_LONG and COMMAND_INT once already.
    switched: bool,
    /// Forgotten by the nets while in flight: it keeps its MAV_CMD busy
    /// until answered or timed out, and reports nothing.
    silent: bool,
    /// When it was first transmitted.
    first_sent: Option<Micros>,
}

impl Op {
    fn key(&self) -> Option<(MavCmd, u8)> {
        self.spec.as_ref().map(|s| (s.command, s.component))
    }

    fn in_flight(&self) -> bool {
        !matches!(self.state, State::Waiting)
    }
}

/// A queued or running mission upload.
struct MissionJob {
    id: u64,
    request: Request,
    upload: Option<Upload>,
    issued: Micros,
}

/// The system id the gateway announces itself under before it knows the
/// vehicle's (unless `[gateway] system` is configured): 1, ArduPilot's and
/// PX4's default `SYSID_THISMAV`/`MAV_SYS_ID`.
pub const ANNOUNCE_SYSTEM: u8 = 1;

/// The gateway's HEARTBEAT: a companion computer
/// (MAV_TYPE_ONBOARD_CONTROLLER, MAV_AUTOPILOT_INVALID), never a ground
/// station.
pub fn companion_heartbeat() -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_ONBOARD_CONTROLLER,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        base_mode: MavModeFlag::empty(),
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    })
}

/// The vehicle side of the gateway, without I/O. See the module docs of
/// `vehicle` for the calling order.
pub struct Commander {
    config: VehicleConfig,
    /// The autopilot: system and component.
    target: Option<(u8, u8)>,
    firmware: Option<Firmware>,
    /// The firmware the target's first HEARTBEAT says it is.
    heard_firmware: Option<Firmware>,
    ops: Vec<Op>,
    missions: VecDeque<MissionJob>,
    transmit: VecDeque<MavMessage>,
    outcomes: VecDeque<(u64, Outcome)>,
    now: Micros,
    next_heartbeat: Option<Micros>,
    last_heard: Option<Micros>,
    link_lost: bool,
    /// The autopilot's last SYSTEM_TIME.time_boot_ms: when it goes back, the
    /// autopilot rebooted and forgot the message intervals it was asked.
    boot_ms: Option<u32>,
    streams: Vec<(u32, f32)>,
    /// Messages SET_MESSAGE_INTERVAL did not obtain.
    stream_fallback: BTreeSet<u32>,
    /// The autopilot does not do SET_MESSAGE_INTERVAL: use REQUEST_DATA_STREAM.
    interval_unsupported: bool,
    home: Option<(i32, i32, f32)>,
    home_amsl: Option<f32>,
    relative_alt: Option<f32>,
    /// The autopilot parameters the project needs, read at start.
    parameters: ParameterCheck,
    /// Armed, as the autopilot's last HEARTBEAT said.
    armed: Option<bool>,
}

fn result_name(result: MavResult) -> String {
    let name = format!("{result:?}");
    name.strip_prefix("MAV_RESULT_")
        .map(str::to_owned)
        .unwrap_or(name)
}

fn done(result: &str) -> Outcome {
    let mut params = Params::new();
    params.insert("result".into(), Value::Str(result.into()));
    Outcome::Done(params)
}

impl Commander {
    pub fn new(config: VehicleConfig) -> Commander {
        let target = match (config.system, config.autopilot_component) {
            (Some(s), Some(c)) => Some((s, c)),
            _ => None,
        };
        Commander {
            parameters: ParameterCheck::new(&config.parameters),
            armed: None,
            firmware: config.firmware,
            heard_firmware: None,
            config,
            target,
            ops: Vec::new(),
            missions: VecDeque::new(),
            transmit: VecDeque::new(),
            outcomes: VecDeque::new(),
            now: 0,
            next_heartbeat: None,
            last_heard: None,
            link_lost: false,
            boot_ms: None,
            streams: Vec::new(),
            stream_fallback: BTreeSet::new(),
            interval_unsupported: false,
            home: None,
            home_amsl: None,
            relative_alt: None,
        }
    }

    /// Who we speak as: the vehicle's system id and our component (191).
    /// `None` until the system id is configured or learned; nothing is
    /// transmitted before.
    pub fn identity(&self) -> Option<(u8, u8)> {
        self.config
            .system
            .or(self.target.map(|t| t.0))
            .map(|s| (s, self.config.own_component()))
    }

    /// Who we send as: our identity once known; before, the configured or
    /// default system id ([`ANNOUNCE_SYSTEM`]) — so that the gateway speaks
    /// first, behind endpoints that wait for their client to speak (a
    /// mavlink-router `Mode = Server` UDP endpoint, pymavlink's `udpin`).
    /// Only HEARTBEATs go out under it.
    pub fn sender(&self) -> (u8, u8) {
        self.identity()
            .unwrap_or((ANNOUNCE_SYSTEM, self.config.own_component()))
    }

    /// Whether a frame from the autopilot has been heard.
    pub fn heard(&self) -> bool {
        self.last_heard.is_some()
    }

    /// The autopilot we command (system, component), once known.
    pub fn target(&self) -> Option<(u8, u8)> {
        self.target
    }

    /// The firmware family, configured or learned.
    pub fn firmware(&self) -> Option<Firmware> {
        self.firmware
    }

    /// Whether the autopilot has been silent for longer than the link timeout.
    pub fn link_lost(&self) -> bool {
        self.link_lost
    }

    /// Whether a command or mission upload is waiting or in flight (nets'
    /// commands only; telemetry requests do not count). On shutdown, keep
    /// feeding messages and ticks until this is false so that no upload is
    /// left half done, or `forget` them.
    pub fn busy(&self) -> bool {
        self.ops
            .iter()
            .any(|o| matches!(o.origin, Origin::Net(_)) && !o.silent)
            || !self.missions.is_empty()
    }

    fn clock(&mut self, now: Micros) -> Micros {
        self.now = self.now.max(now);
        self.now
    }

    /// A net's `command` effect. The outcome comes back from `poll_outcome`
    /// with the same id.
    pub fn command(&mut self, id: u64, verb: &str, args: &Params, now: Micros) {
        let now = self.clock(now);
        if self.ops.iter().any(|o| o.origin == Origin::Net(id))
            || self.missions.iter().any(|m| m.id == id)
        {
            tracing::warn!(id, verb, "command id already pending: ignored");
            return;
        }
        let request = match parse(verb, args) {
            Ok(r) => r,
            Err(reason) => {
                self.outcomes.push_back((id, Outcome::Failed(reason)));
                return;
            }
        };
        if matches!(request, Request::UploadMission { .. }) {
            self.missions.push_back(MissionJob {
                id,
                request,
                upload: None,
                issued: now,
            });
        } else {
            self.ops.push(Op {
                origin: Origin::Net(id),
                request,
                spec: None,
                issued: now,
                state: State::Waiting,
                sends: 0,
                timeouts: 0,
                rejected: 0,
                switched: false,
                silent: false,
                first_sent: None,
            });
        }
        self.pump(now);
    }

    /// The net that issued `id` was deactivated: stop retrying, report
    /// nothing. A mission upload in progress is cancelled on the vehicle.
    pub fn forget(&mut self, id: u64) {
        self.missions.retain(|m| {
            if m.id != id {
                return true;
            }
            if let Some(upload) = &m.upload {
                self.transmit.push_back(upload.cancel());
            }
            false
        });
        let mut i = 0;
        while i < self.ops.len() {
            if self.ops[i].origin == Origin::Net(id) {
                if self.ops[i].in_flight() {
                    self.ops[i].silent = true;
                    i += 1;
                } else {
                    self.ops.remove(i);
                }
            } else {
                i += 1;
            }
        }
        self.outcomes.retain(|(o, _)| *o != id);
        let now = self.now;
        self.pump(now);
    }

    /// The telemetry to ask for: (message id, rate in Hz; 0 stops it). Sent
    /// when the vehicle is known, and again whenever the link comes back.
    /// Messages that are events, or that the autopilot only relays, are
    /// left out (`streams::NEVER_STREAMED`): they come by themselves.
    pub fn request_streams(&mut self, messages: &[(u32, f32)], now: Micros) {
        let now = self.clock(now);
        let (wanted, left): (Vec<_>, Vec<_>) = messages.iter().partition(|(id, _)| streamable(*id));
        if !left.is_empty() {
            let names: Vec<String> = left.iter().map(|(id, _)| message_name(*id)).collect();
            tracing::info!(
                "not asked for at an interval (events, or relayed from another component): {}",
                names.join(", ")
            );
        }
        self.streams = wanted;
        self.restart_streams();
        self.pump(now);
    }

    fn restart_streams(&mut self) {
        if self.target.is_none() || self.streams.is_empty() {
            return;
        }
        self.ops
            .retain(|o| !matches!(o.origin, Origin::Stream { .. }) || o.in_flight());
        self.stream_fallback.clear();
        if self.interval_unsupported {
            self.stream_fallback
                .extend(self.streams.iter().map(|(id, _)| *id));
            self.send_data_streams();
            return;
        }
        let now = self.now;
        for &(message, rate) in &self.streams {
            let interval = if rate > 0.0 && rate.is_finite() {
                1e6 / rate
            } else {
                -1.0
            };
            self.ops.push(Op {
                origin: Origin::Stream { message },
                request: Request::Rtl, // unused: the spec is given
                spec: Some(CommandSpec {
                    command: MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
                    params: [message as f32, interval, 0.0, 0.0, 0.0, 0.0, 0.0],
                    int: None,
                    component: self.target.map_or(1, |t| t.1),
                    fallback: Fallback::None,
                }),
                issued: now,
                state: State::Waiting,
                sends: 0,
                timeouts: 0,
                rejected: 0,
                switched: false,
                silent: false,
                first_sent: None,
            });
        }
    }

    #[allow(deprecated)] // REQUEST_DATA_STREAM is the fallback
    fn send_data_streams(&mut self) {
        let Some((system, component)) = self.target else {
            return;
        };
        let wanted: Vec<(u32, f32)> = self
            .streams
            .iter()
            .filter(|(id, _)| self.stream_fallback.contains(id))
            .copied()
            .collect();
        for (stream, rate) in data_streams(&wanted) {
            tracing::info!(?stream, rate, "REQUEST_DATA_STREAM");
            self.transmit
                .push_back(MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
                    req_message_rate: rate,
                    target_system: system,
                    target_component: component,
                    req_stream_id: stream,
                    start_stop: 1,
                }));
        }
    }

    /// A message received from the link (any sender).
    #[allow(deprecated)] // MISSION_REQUEST: older autopilots still send it
    pub fn message(&mut self, now: Micros, header: &MavHeader, message: &MavMessage) {
        let now = self.clock(now);
        let sender = (header.system_id as u8, header.component_id);
        if header.system_id > 255 {
            return;
        }
        if self.target.is_none() {
            if let MavMessage::HEARTBEAT(hb) = message {
                self.learn(sender, hb);
            }
        }
        let Some(target) = self.target else {
            return;
        };
        if sender.0 != target.0 {
            return;
        }
        if sender.1 == target.1 {
            self.parameters.start(target, now);
            match message {
                MavMessage::HEARTBEAT(hb) => {
                    self.armed = Some(
                        hb.base_mode
                            .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED),
                    );
                    let heard = *self.heard_firmware.get_or_insert_with(|| {
                        Firmware::from_heartbeat(hb.autopilot as i64, hb.mavtype as i64)
                    });
                    // Target configured, firmware not: learn it here.
                    self.firmware.get_or_insert(heard);
                }
                MavMessage::PARAM_VALUE(v) => self.parameters.value(v),
                MavMessage::SYSTEM_TIME(t) => {
                    // Back by more than 2 s, as elaboration's reboot rule.
                    let rebooted = self
                        .boot_ms
                        .is_some_and(|b| t.time_boot_ms.saturating_add(2_000) < b);
                    self.boot_ms = Some(t.time_boot_ms);
                    if rebooted {
                        tracing::info!("the autopilot rebooted: asking for telemetry again");
                        self.restart_streams();
                    }
                }
                _ => {}
            }
            self.last_heard = Some(now);
            if self.link_lost {
                tracing::info!("link back: asking for telemetry again");
                self.link_lost = false;
                self.restart_streams();
            }
        }
        match message {
            MavMessage::COMMAND_ACK(ack) => self.on_ack(sender, ack, now),
            MavMessage::MISSION_REQUEST_INT(r) => {
                self.on_mission_request(r.seq, r.target_system, r.mission_type, now)
            }
            MavMessage::MISSION_REQUEST(r) => {
                self.on_mission_request(r.seq, r.target_system, r.mission_type, now)
            }
            MavMessage::MISSION_ACK(a)
                if self.for_us(a.target_system, a.target_component)
                    && a.mission_type == MavMissionType::MAV_MISSION_TYPE_MISSION =>
            {
                if let Some(upload) = self.missions.front_mut().and_then(|j| j.upload.as_mut()) {
                    let step = upload.ack(a.mavtype, now);
                    self.mission_step(step);
                }
            }
            MavMessage::MISSION_CURRENT(c) => {
                self.on_mission_current(c.seq);
                if sender.1 == target.1 {
                    if let Some(upload) = self.missions.front_mut().and_then(|j| j.upload.as_mut())
                    {
                        let step = upload.current(c.total, c.mission_state as u8);
                        self.mission_step(step);
                    }
                }
            }
            // 0, 0 is what autopilots report before they have a position.
            MavMessage::GLOBAL_POSITION_INT(p)
                if sender.1 == target.1 && (p.lat, p.lon) != (0, 0) =>
            {
                self.home_amsl = Some((p.alt as i64 - p.relative_alt as i64) as f32 / 1000.0);
                self.relative_alt = Some(p.relative_alt as f32 / 1000.0);
            }
            MavMessage::HOME_POSITION(h) if sender.1 == target.1 => {
                self.home = Some((h.latitude, h.longitude, h.altitude as f32 / 1000.0));
            }
            _ => {}
        }
        self.pump(now);
    }

    fn learn(&mut self, sender: (u8, u8), hb: &HEARTBEAT_DATA) {
        if hb.autopilot == MavAutopilot::MAV_AUTOPILOT_INVALID
            || matches!(
                hb.mavtype,
                MavType::MAV_TYPE_GCS | MavType::MAV_TYPE_ONBOARD_CONTROLLER
            )
            || self.config.system.is_some_and(|s| s != sender.0)
            || self
                .config
                .autopilot_component
                .is_some_and(|c| c != sender.1)
        {
            return;
        }
        self.target = Some(sender);
        if self.firmware.is_none() {
            let fw = Firmware::from_heartbeat(hb.autopilot as i64, hb.mavtype as i64);
            self.firmware = Some(fw);
        }
        tracing::info!(system = sender.0, component = sender.1, firmware = ?self.firmware, "autopilot found");
        self.restart_streams();
    }

    /// PX4 publishes each failing arming check through its events protocol
    /// when the check changes, and says only "Arming denied: Resolve system
    /// health failures first" when an arming is refused: after a refusal,
    /// MAV_CMD_RUN_PREARM_CHECKS makes it publish every failing check again
    /// (elaboration turns them into `prearm_failed {text}`). Silent: its
    /// answer goes nowhere; one at a time.
    fn ask_prearm_report(&mut self) {
        let Some(target) = self.target else { return };
        if self.firmware != Some(Firmware::Px4)
            || self.ops.iter().any(|o| {
                o.spec
                    .as_ref()
                    .is_some_and(|s| s.command == MavCmd::MAV_CMD_RUN_PREARM_CHECKS)
            })
        {
            return;
        }
        self.ops.push(Op {
            origin: Origin::Net(u64::MAX),
            request: Request::Rtl, // unused: the spec is given
            spec: Some(CommandSpec {
                command: MavCmd::MAV_CMD_RUN_PREARM_CHECKS,
                params: [0.0; 7],
                int: None,
                component: target.1,
                fallback: Fallback::None,
            }),
            issued: self.now,
            state: State::Waiting,
            sends: 0,
            timeouts: 0,
            rejected: 0,
            switched: false,
            silent: true,
            first_sent: None,
        });
    }

    fn for_us(&self, system: u8, component: u8) -> bool {
        let Some((own_sys, own_comp)) = self.identity() else {
            return false;
        };
        (system == 0 || system == own_sys) && (component == 0 || component == own_comp)
    }

    fn on_ack(&mut self, sender: (u8, u8), ack: &COMMAND_ACK_DATA, now: Micros) {
        // Without the extension fields they read 0: then the command id alone matches.
        if !self.for_us(ack.target_system, ack.target_component) {
            return;
        }
        let Some(i) = self.ops.iter().position(|o| {
            o.in_flight()
                && o.spec.as_ref().is_some_and(|s| {
                    s.command == ack.command && (s.component == 0 || s.component == sender.1)
                })
        }) else {
            tracing::debug!(command = ?ack.command, result = ?ack.result, "COMMAND_ACK matches no command in flight");
            return;
        };
        if matches!(self.ops[i].request, Request::Arm { arm: true, .. })
            && !matches!(
                ack.result,
                MavResult::MAV_RESULT_ACCEPTED | MavResult::MAV_RESULT_IN_PROGRESS
            )
        {
            self.ask_prearm_report();
        }
        let timing = self.config.timing;
        let px4 = self.firmware == Some(Firmware::Px4);
        let op = &mut self.ops[i];
        if matches!(op.state, State::SetCurrent { .. }) {
            return;
        }
        if op.silent {
            if ack.result != MavResult::MAV_RESULT_IN_PROGRESS {
                self.ops.remove(i);
            }
            return;
        }
        match ack.result {
            MavResult::MAV_RESULT_ACCEPTED => self.finish(i, Ok("ACCEPTED")),
            MavResult::MAV_RESULT_IN_PROGRESS => {
                op.state = State::Sent {
                    deadline: now + timing.in_progress_timeout,
                    in_progress: true,
                };
            }
            MavResult::MAV_RESULT_TEMPORARILY_REJECTED if op.rejected < timing.rejected_retries => {
                op.rejected += 1;
                op.state = State::Pausing {
                    until: now + timing.ack_timeout,
                };
            }
            // PX4 v1.18 may deny a MISSION_START for a moment after its
            // upload showed checked ("Mission start denied! No valid
            // mission", about one start in five): a DENIED start is tried
            // again like a TEMPORARILY_REJECTED one, after 1, 2, 3…
            // ack_timeouts, `rejected_retries` times (docs/vehicle.md).
            MavResult::MAV_RESULT_DENIED
                if px4
                    && matches!(op.request, Request::StartMission { .. })
                    && op.rejected < timing.rejected_retries =>
            {
                op.rejected += 1;
                let wait = timing.ack_timeout * u64::from(op.rejected);
                tracing::info!(
                    "MISSION_START DENIED by PX4: trying again in {:.1} s",
                    wait as f64 / 1e6
                );
                op.state = State::Pausing { until: now + wait };
            }
            MavResult::MAV_RESULT_UNSUPPORTED
                if matches!(
                    op.spec.as_ref().map(|s| s.fallback),
                    Some(Fallback::MissionSetCurrent(_))
                ) =>
            {
                let Some(Fallback::MissionSetCurrent(seq)) = op.spec.as_ref().map(|s| s.fallback)
                else {
                    return;
                };
                op.sends = 1;
                op.timeouts = 0;
                op.state = State::SetCurrent {
                    seq,
                    deadline: now + timing.ack_timeout,
                };
                self.send_set_current(seq);
            }
            MavResult::MAV_RESULT_COMMAND_INT_ONLY | MavResult::MAV_RESULT_COMMAND_LONG_ONLY
                if !op.switched =>
            {
                op.switched = true;
                if let Some(spec) = op.spec.as_mut() {
                    spec.int = match spec.int {
                        Some(_) => None,
                        None => Some(super::plan::IntPosition {
                            frame: mavlink::dialects::ardupilotmega::MavFrame::MAV_FRAME_GLOBAL,
                            x: (spec.params[4] * 1e7) as i32,
                            y: (spec.params[5] * 1e7) as i32,
                        }),
                    };
                }
                self.transmit_op(i, now);
            }
            other => self.finish(i, Err(result_name(other))),
        }
    }

    #[allow(deprecated)] // MISSION_SET_CURRENT is the fallback
    fn send_set_current(&mut self, seq: u16) {
        if let Some((system, component)) = self.target {
            self.transmit
                .push_back(MavMessage::MISSION_SET_CURRENT(MISSION_SET_CURRENT_DATA {
                    seq,
                    target_system: system,
                    target_component: component,
                }));
        }
    }

    fn on_mission_current(&mut self, current: u16) {
        if let Some(i) = self
            .ops
            .iter()
            .position(|o| matches!(o.state, State::SetCurrent { seq, .. } if seq == current))
        {
            self.finish(i, Ok("MISSION_CURRENT"));
        }
    }

    fn on_mission_request(&mut self, seq: u16, to: u8, kind: MavMissionType, now: Micros) {
        if kind != MavMissionType::MAV_MISSION_TYPE_MISSION || !self.for_us(to, 0) {
            return;
        }
        if let Some(upload) = self.missions.front_mut().and_then(|j| j.upload.as_mut()) {
            let step = upload.request(seq, now);
            self.mission_step(step);
        }
    }

    fn mission_step(&mut self, step: Step) {
        match step {
            Step::Wait => {}
            Step::Send(m) => self.transmit.push_back(m),
            Step::Done { count } => {
                if let Some(job) = self.missions.pop_front() {
                    let mut params = Params::new();
                    params.insert("result".into(), Value::Str("ACCEPTED".into()));
                    params.insert("count".into(), Value::Int(count as i64));
                    self.outcomes.push_back((job.id, Outcome::Done(params)));
                }
            }
            Step::Failed { reason, send } => {
                if let Some(m) = send {
                    self.transmit.push_back(m);
                }
                if let Some(job) = self.missions.pop_front() {
                    self.outcomes.push_back((job.id, Outcome::Failed(reason)));
                }
            }
        }
    }

    /// Ends op `i`: reports it (nets) or records it (streams).
    fn finish(&mut self, i: usize, result: Result<&str, String>) {
        let op = self.ops.remove(i);
        match op.origin {
            Origin::Net(id) => {
                if !op.silent {
                    let outcome = match result {
                        Ok(r) => done(r),
                        Err(reason) => Outcome::Failed(reason),
                    };
                    self.outcomes.push_back((id, outcome));
                }
            }
            Origin::Stream { message } => {
                if let Err(reason) = result {
                    let name = message_name(message);
                    if stream_of(message).is_some() {
                        tracing::info!("SET_MESSAGE_INTERVAL {reason} for {name}: asking with REQUEST_DATA_STREAM instead");
                        self.stream_fallback.insert(message);
                    } else {
                        // In no stream group: REQUEST_DATA_STREAM would
                        // have to ask for every stream to get it.
                        tracing::warn!("SET_MESSAGE_INTERVAL {reason} for {name}: the autopilot will not stream it; the rules reading it see it only when the autopilot sends it by itself");
                    }
                    if reason != "FAILED" && reason != "DENIED" {
                        // UNSUPPORTED, or no answer: the autopilot does not
                        // do it at all. (ArduPilot answers DENIED for a
                        // message it cannot stream, e.g. RADIO_STATUS, and
                        // FAILED when it cannot set the rate: that message
                        // only.)
                        self.interval_unsupported = true;
                        let rest: Vec<u32> = self
                            .ops
                            .iter()
                            .filter_map(|o| match o.origin {
                                Origin::Stream { message } if !o.in_flight() => Some(message),
                                _ => None,
                            })
                            .collect();
                        self.stream_fallback.extend(rest);
                        self.ops.retain(|o| {
                            !matches!(o.origin, Origin::Stream { .. }) || o.in_flight()
                        });
                    }
                }
                let streams_left = self
                    .ops
                    .iter()
                    .any(|o| matches!(o.origin, Origin::Stream { .. }));
                if !streams_left && !self.stream_fallback.is_empty() {
                    self.send_data_streams();
                }
            }
        }
    }

    fn transmit_op(&mut self, i: usize, now: Micros) {
        let timing = self.config.timing;
        let Some((system, _)) = self.target else {
            return;
        };
        let op = &mut self.ops[i];
        let Some(spec) = op.spec.as_ref() else {
            return;
        };
        let confirmation = op.sends;
        let p = spec.params;
        let message = match spec.int {
            None => MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
                param1: p[0],
                param2: p[1],
                param3: p[2],
                param4: p[3],
                param5: p[4],
                param6: p[5],
                param7: p[6],
                command: spec.command,
                target_system: system,
                target_component: spec.component,
                confirmation,
            }),
            Some(pos) => MavMessage::COMMAND_INT(COMMAND_INT_DATA {
                param1: p[0],
                param2: p[1],
                param3: p[2],
                param4: p[3],
                x: pos.x,
                y: pos.y,
                z: p[6],
                command: spec.command,
                target_system: system,
                target_component: spec.component,
                frame: pos.frame,
                current: 0,
                autocontinue: 0,
            }),
        };
        op.sends = op.sends.saturating_add(1);
        op.first_sent.get_or_insert(now);
        op.state = State::Sent {
            deadline: now + timing.ack_timeout,
            in_progress: false,
        };
        self.transmit.push_back(message);
    }

    /// Time passes: heartbeats, retries, timeouts, link loss.
    pub fn tick(&mut self, now: Micros) {
        let now = self.clock(now);
        self.pump(now);
    }

    fn pump(&mut self, now: Micros) {
        let timing = self.config.timing;
        if self.identity().is_some() {
            let transmit = &mut self.transmit;
            self.parameters.poll(now, &mut |m| transmit.push_back(m));
        }
        // Heartbeat, from the start: under the vehicle's system id once
        // known, the announcing one before (`sender`).
        {
            let due = *self.next_heartbeat.get_or_insert(now);
            if now >= due {
                self.transmit.push_back(companion_heartbeat());
                let next = due + timing.heartbeat_period;
                self.next_heartbeat = Some(if next <= now {
                    now + timing.heartbeat_period
                } else {
                    next
                });
            }
        }
        // Link loss.
        if let Some(heard) = self.last_heard {
            if !self.link_lost && now >= heard + timing.link_timeout {
                tracing::warn!("autopilot silent: link lost");
                self.link_lost = true;
                // The streams are asked again when the link is back; a
                // reboot during the silence needs nothing more.
                self.boot_ms = None;
            }
        }
        // Deadlines of commands in flight.
        let mut i = 0;
        while i < self.ops.len() {
            let retries = match self.ops[i].origin {
                Origin::Net(_) => timing.retries,
                Origin::Stream { .. } => STREAM_RETRIES,
            };
            let op = &mut self.ops[i];
            match op.state {
                State::Sent {
                    deadline,
                    in_progress,
                } if now >= deadline => {
                    if op.silent {
                        self.ops.remove(i);
                        continue;
                    }
                    let heard_since = match (self.last_heard, op.first_sent) {
                        (Some(heard), Some(sent)) => heard >= sent,
                        _ => false,
                    };
                    if matches!(op.origin, Origin::Stream { .. })
                        && op.timeouts >= retries
                        && !heard_since
                    {
                        // The autopilot said nothing at all: the link, not
                        // SET_MESSAGE_INTERVAL, is the problem. Ask again later.
                        op.state = State::Waiting;
                        op.sends = 0;
                        op.timeouts = 0;
                        op.first_sent = None;
                        i += 1;
                        continue;
                    }
                    if in_progress || op.timeouts >= retries {
                        self.finish(i, Err("timeout".into()));
                        continue;
                    }
                    op.timeouts += 1;
                    self.transmit_op(i, now);
                }
                State::Pausing { until } if now >= until => {
                    if op.silent {
                        self.ops.remove(i);
                        continue;
                    }
                    self.transmit_op(i, now);
                }
                State::SetCurrent { seq, deadline } if now >= deadline => {
                    if op.silent {
                        self.ops.remove(i);
                        continue;
                    }
                    if op.timeouts >= retries {
                        self.finish(i, Err("timeout".into()));
                        continue;
                    }
                    op.timeouts += 1;
                    op.state = State::SetCurrent {
                        seq,
                        deadline: now + timing.ack_timeout,
                    };
                    self.send_set_current(seq);
                }
                _ => {}
            }
            i += 1;
        }
        // Commands waiting for the vehicle or for their MAV_CMD to be free.
        let budget = timing.ack_timeout * (timing.retries as u64 + 1);
        let mut i = 0;
        while i < self.ops.len() {
            if self.ops[i].in_flight() {
                i += 1;
                continue;
            }
            // The nets' commands wait for the verdict on the vehicle's
            // parameters (bounded: parameters::ATTEMPTS × PATIENCE).
            if matches!(self.ops[i].origin, Origin::Net(_))
                && self.target.is_some()
                && !self.parameters.settled()
            {
                i += 1;
                continue;
            }
            let (Some(target), Some(firmware)) = (self.target, self.firmware) else {
                if now >= self.ops[i].issued + budget {
                    self.finish(i, Err("no_vehicle".into()));
                    continue;
                }
                i += 1;
                continue;
            };
            if self.ops[i].spec.is_none() {
                let ctx = Context {
                    firmware,
                    autopilot: target.1,
                    payloads: &self.config.payloads,
                    // HOME_POSITION is the true home; GLOBAL_POSITION_INT's
                    // alt − relative_alt stands in until it comes.
                    home_amsl: self.home.map(|h| h.2).or(self.home_amsl),
                    relative_alt: self.relative_alt,
                    quadplane: self.config.quadplane,
                };
                let planned = match plan(&self.ops[i].request, &ctx) {
                    Ok(Plan::Command(spec)) => Ok(spec),
                    // Uploads go to `missions` in `command`; never here.
                    Ok(Plan::Mission) => Err("upload_mission is not a command".to_owned()),
                    Err(reason) => Err(reason),
                };
                match planned {
                    Ok(spec) => self.ops[i].spec = Some(spec),
                    Err(reason) => {
                        self.finish(i, Err(reason));
                        continue;
                    }
                }
            }
            let key = self.ops[i].key();
            let busy = self.ops.iter().any(|o| o.in_flight() && o.key() == key);
            if !busy {
                self.transmit_op(i, now);
            }
            i += 1;
        }
        // Mission uploads, one at a time (none before the vehicle's
        // parameters are judged).
        while let Some(job) = self.missions.front_mut() {
            if !self.parameters.settled() && job.upload.is_none() {
                break;
            }
            if let Some(upload) = job.upload.as_mut() {
                let step = upload.tick(now);
                let finished = matches!(step, Step::Done { .. } | Step::Failed { .. });
                self.mission_step(step);
                if finished {
                    continue;
                }
                break;
            }
            let (Some(target), Some(firmware)) = (self.target, self.firmware) else {
                if now >= job.issued + budget {
                    let id = job.id;
                    self.missions.pop_front();
                    self.outcomes
                        .push_back((id, Outcome::Failed("no_vehicle".into())));
                    continue;
                }
                break;
            };
            let Request::UploadMission { items } = &job.request else {
                self.missions.pop_front();
                continue;
            };
            match build_items(items, firmware, self.home, target) {
                Ok(items) => {
                    let (mut upload, count) = Upload::start(
                        items,
                        target,
                        now,
                        timing.ack_timeout,
                        timing.mission_retries,
                    );
                    if firmware == Firmware::Px4 {
                        upload = upload.confirmed_by_mission_current();
                    }
                    job.upload = Some(upload);
                    self.transmit.push_back(count);
                    break;
                }
                Err(reason) => {
                    let id = job.id;
                    self.missions.pop_front();
                    self.outcomes.push_back((id, Outcome::Failed(reason)));
                }
            }
        }
    }

    /// The next message to send to the vehicle, under `identity()`.
    pub fn poll_transmit(&mut self) -> Option<MavMessage> {
        self.transmit.pop_front()
    }

    /// The verdict on the project's autopilot parameters
    /// (`[gateway.parameters]`), once, when every one is read or given up
    /// on; never when the project names none.
    pub fn poll_parameters(&mut self) -> Option<Verdict> {
        // What the vehicle says it is, whatever the project configured:
        // the words are for a crew that brought the wrong project.
        self.parameters
            .poll_verdict(self.heard_firmware.or(self.firmware))
    }

    /// Whether the autopilot says it is armed (`None` before its first
    /// HEARTBEAT).
    pub fn armed(&self) -> Option<bool> {
        self.armed
    }

    /// The next outcome for the nets: `(command id, Done | Failed)`.
    pub fn poll_outcome(&mut self) -> Option<(u64, Outcome)> {
        self.outcomes.pop_front()
    }

    /// When `tick` must be called next at the latest.
    pub fn next_deadline(&self) -> Option<Micros> {
        let timing = self.config.timing;
        let budget = timing.ack_timeout * (timing.retries as u64 + 1);
        let mut next: Option<Micros> = None;
        let mut at = |t: Micros| next = Some(next.map_or(t, |n: Micros| n.min(t)));
        if self.identity().is_some() {
            at(self.next_heartbeat.unwrap_or(self.now));
        }
        if let (Some(heard), false) = (self.last_heard, self.link_lost) {
            at(heard + timing.link_timeout);
        }
        if let Some(t) = self.parameters.next_deadline() {
            at(t);
        }
        for op in &self.ops {
            match op.state {
                State::Sent { deadline, .. } | State::SetCurrent { deadline, .. } => at(deadline),
                State::Pausing { until } => at(until),
                State::Waiting if self.target.is_none() => at(op.issued + budget),
                State::Waiting => {}
            }
        }
        if let Some(job) = self.missions.front() {
            match &job.upload {
                Some(u) => at(u.deadline()),
                None if self.target.is_none() => at(job.issued + budget),
                None => at(self.now),
            }
        }
        next
    }
}
