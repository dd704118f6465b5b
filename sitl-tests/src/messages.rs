//! Messages received that are not commands: stream requests, the mission
//! protocol (upload, download, set current, clear), parameters, SET_MODE,
//! TIMESYNC.

// ArduPilot still speaks the deprecated messages (MISSION_REQUEST, MISSION_ITEM,
// SET_MODE, REQUEST_DATA_STREAM, MISSION_SET_CURRENT): so does the simulation.
#![allow(deprecated)]

use mavlink::dialects::ardupilotmega::*;

use crate::mission::{MissionItem, Reply};
use crate::streams::Group;
use crate::vehicle::Vehicle;

impl Vehicle {
    /// Whether a message addressed to `target` system is for us (0 = all).
    fn for_us(&self, target: u8) -> bool {
        target == 0 || target == self.cfg.system_id
    }

    /// Whether `component` is the autopilot (0 = all).
    fn for_autopilot(component: u8) -> bool {
        component == 0 || component == crate::vehicle::AUTOPILOT
    }

    /// A message from `from` (already known not to be our own).
    pub(crate) fn on_message(&mut self, from: (u8, u8), msg: &MavMessage) {
        match msg {
            MavMessage::COMMAND_LONG(c) if self.for_us(c.target_system) => {
                let p = [
                    c.param1, c.param2, c.param3, c.param4, c.param5, c.param6, c.param7,
                ];
                self.on_command(from, c.target_component, c.command as u32, p, None);
            }
            MavMessage::COMMAND_INT(c) if self.for_us(c.target_system) => {
                let p = [
                    c.param1, c.param2, c.param3, c.param4, c.x as f32, c.y as f32, c.z,
                ];
                let int = crate::commands::IntArgs {
                    frame: c.frame,
                    x: c.x,
                    y: c.y,
                    z: c.z,
                };
                self.on_command(from, c.target_component, c.command as u32, p, Some(int));
            }
            // ArduPilot acks SET_MODE with COMMAND_ACK command 11, which
            // rust-mavlink's MAV_CMD cannot carry: the mode changes, no ack.
            MavMessage::SET_MODE(m)
                if self.for_us(m.target_system)
                    && m.base_mode.bits() & 1 != 0
                    && self.ready()
                    && crate::modes::settable(m.custom_mode) =>
            {
                self.enter_mode(m.custom_mode);
            }
            MavMessage::REQUEST_DATA_STREAM(r)
                if self.for_us(r.target_system) && Self::for_autopilot(r.target_component) =>
            {
                let groups = self.streams.request_stream(
                    self.now,
                    r.req_stream_id as u8,
                    r.req_message_rate,
                    r.start_stop != 0,
                );
                let rate = if r.start_stop != 0 {
                    r.req_message_rate.min(50)
                } else {
                    0
                };
                for g in groups {
                    let name = Group::param(g);
                    self.params.set(name, rate as f32);
                    self.send_param(name);
                }
            }
            MavMessage::MISSION_COUNT(m)
                if self.for_us(m.target_system) && Self::for_autopilot(m.target_component) =>
            {
                if m.mission_type != MavMissionType::MAV_MISSION_TYPE_MISSION {
                    self.mission_ack(
                        from,
                        MavMissionResult::MAV_MISSION_UNSUPPORTED,
                        m.mission_type,
                    );
                    return;
                }
                let replies = self.uploads.count(self.now, from, m.count);
                for r in replies {
                    self.mission_reply(r);
                }
            }
            MavMessage::MISSION_ITEM_INT(m)
                if self.for_us(m.target_system) && Self::for_autopilot(m.target_component) =>
            {
                let replies = self.uploads.item(self.now, from, MissionItem::from_int(m));
                for r in replies {
                    self.mission_reply(r);
                }
            }
            MavMessage::MISSION_ITEM(m)
                if self.for_us(m.target_system) && Self::for_autopilot(m.target_component) =>
            {
                let replies = self
                    .uploads
                    .item(self.now, from, MissionItem::from_float(m));
                for r in replies {
                    self.mission_reply(r);
                }
            }
            MavMessage::MISSION_ACK(a)
                if self.for_us(a.target_system)
                    && a.mavtype != MavMissionResult::MAV_MISSION_ACCEPTED =>
            {
                self.uploads.cancel(from);
            }
            MavMessage::MISSION_REQUEST_LIST(m)
                if self.for_us(m.target_system) && Self::for_autopilot(m.target_component) =>
            {
                let count = if m.mission_type == MavMissionType::MAV_MISSION_TYPE_MISSION {
                    self.mission.len() as u16
                } else {
                    0
                };
                self.send(MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
                    count,
                    target_system: from.0,
                    target_component: from.1,
                    mission_type: m.mission_type,
                    opaque_id: 0,
                }));
            }
            MavMessage::MISSION_REQUEST_INT(r)
                if self.for_us(r.target_system) && Self::for_autopilot(r.target_component) =>
            {
                match self.mission.get(r.seq as usize) {
                    Some(it) => {
                        let m = it.to_int(from, r.seq == self.auto.current);
                        self.send(MavMessage::MISSION_ITEM_INT(m));
                    }
                    None => self.mission_ack(
                        from,
                        MavMissionResult::MAV_MISSION_INVALID_SEQUENCE,
                        r.mission_type,
                    ),
                }
            }
            MavMessage::MISSION_REQUEST(r)
                if self.for_us(r.target_system) && Self::for_autopilot(r.target_component) =>
            {
                match self.mission.get(r.seq as usize) {
                    Some(it) => {
                        let m = it.to_float(from, r.seq == self.auto.current);
                        self.send(MavMessage::MISSION_ITEM(m));
                    }
                    None => self.mission_ack(
                        from,
                        MavMissionResult::MAV_MISSION_INVALID_SEQUENCE,
                        r.mission_type,
                    ),
                }
            }
            MavMessage::MISSION_SET_CURRENT(m)
                if self.for_us(m.target_system)
                    && Self::for_autopilot(m.target_component)
                    && self.auto_set_current(m.seq) =>
            {
                let mc = self.mission_current();
                self.send(mc);
            }
            MavMessage::MISSION_CLEAR_ALL(m)
                if self.for_us(m.target_system) && Self::for_autopilot(m.target_component) =>
            {
                self.store_mission(Vec::new());
                self.mission_ack(from, MavMissionResult::MAV_MISSION_ACCEPTED, m.mission_type);
            }
            MavMessage::PARAM_REQUEST_LIST(m)
                if self.for_us(m.target_system) && Self::for_autopilot(m.target_component) =>
            {
                for i in 0..self.params.len() {
                    self.send_param_at(i);
                }
            }
            MavMessage::PARAM_REQUEST_READ(m)
                if self.for_us(m.target_system) && Self::for_autopilot(m.target_component) =>
            {
                let name = m.param_id.to_str().unwrap_or("").to_owned();
                if m.param_index >= 0 {
                    self.send_param_at(m.param_index as usize);
                } else {
                    self.send_param(&name);
                }
            }
            MavMessage::PARAM_SET(m)
                if self.for_us(m.target_system) && Self::for_autopilot(m.target_component) =>
            {
                let name = m.param_id.to_str().unwrap_or("").to_owned();
                if m.param_value.is_finite() && self.params.set(&name, m.param_value) {
                    self.send_param(&name);
                }
            }
            MavMessage::TIMESYNC(t) if t.tc1 == 0 => {
                let now_ns = (self.now * 1000) as i64;
                self.send(MavMessage::TIMESYNC(TIMESYNC_DATA {
                    tc1: now_ns,
                    ts1: t.ts1,
                    target_system: from.0,
                    target_component: from.1,
                }));
            }
            _ => {}
        }
    }

    fn mission_ack(&mut self, to: (u8, u8), result: MavMissionResult, kind: MavMissionType) {
        self.send(MavMessage::MISSION_ACK(MISSION_ACK_DATA {
            target_system: to.0,
            target_component: to.1,
            mavtype: result,
            mission_type: kind,
            opaque_id: 0,
        }));
    }

    /// Carries out what the upload asks.
    pub(crate) fn mission_reply(&mut self, r: Reply) {
        match r {
            Reply::Request { to, seq } => {
                // ArduPilot 4.7 asks with MISSION_REQUEST (the recording).
                self.send(MavMessage::MISSION_REQUEST(MISSION_REQUEST_DATA {
                    seq,
                    target_system: to.0,
                    target_component: to.1,
                    mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
                }));
            }
            Reply::Ack { to, result } => {
                self.mission_ack(to, result, MavMissionType::MAV_MISSION_TYPE_MISSION)
            }
            Reply::Stored(items) => {
                self.store_mission(items);
                self.info("Flight plan received");
            }
            Reply::Cleared => self.store_mission(Vec::new()),
        }
    }

    /// Replaces the mission (item 0 becomes home, whatever was sent).
    fn store_mission(&mut self, mut items: Vec<MissionItem>) {
        if items.is_empty() {
            items.push(self.home_item());
        } else {
            items[0] = self.home_item();
        }
        for (i, it) in items.iter_mut().enumerate() {
            it.seq = i as u16;
        }
        self.mission = items;
        self.params.set("MIS_TOTAL", self.mission.len() as f32);
        self.send_param("MIS_TOTAL");
        let len = self.mission.len() as u16;
        if self.auto.current >= len {
            self.auto.current = 0;
            self.auto.started = false;
        }
        self.auto.complete = false;
        if self.auto.running {
            // The current command reloads from the new mission.
            if len <= 1 {
                self.auto.running = false;
            } else {
                self.auto.started = false;
                if self.auto.current == 0 {
                    self.auto.current = 1;
                }
            }
        }
    }
}
