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
                if self.is_rover()
                    && self.for_us(m.target_system)
                    && m.base_mode.bits() & 1 != 0 =>
            {
                self.rover_set_mode(m.custom_mode);
            }
            // Rover: a position target in GUIDED (no ack, as ArduPilot).
            MavMessage::SET_POSITION_TARGET_GLOBAL_INT(t)
                if self.is_rover()
                    && self.for_us(t.target_system)
                    && Self::for_autopilot(t.target_component)
                    && self.fl.mode == crate::modes::rover::GUIDED
                    && t.type_mask.bits() & 0b111 == 0
                    && !(t.lat_int == 0 && t.lon_int == 0) =>
            {
                let to = crate::geo::offset(
                    self.origin(),
                    t.lat_int as f64 / 1e7,
                    t.lon_int as f64 / 1e7,
                );
                self.rover_goto(to);
            }
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
                if self.is_rover()
                    && self.for_us(m.target_system)
                    && Self::for_autopilot(m.target_component)
                    && self.rover_set_current(m.seq) =>
            {
                let mc = self.mission_current();
                self.send(mc);
            }
            MavMessage::MISSION_SET_CURRENT(m)
                if !self.is_rover()
                    && self.for_us(m.target_system)
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
        if self.auto.running && self.is_rover() {
            // Rover restarts the current command from the new mission.
            self.text(
                MavSeverity::MAV_SEVERITY_CRITICAL,
                "Auto mission changed, restarted command",
            );
            let at = self.auto.current.max(1);
            self.rover_restart_at(at);
        } else if self.auto.running {
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

#[cfg(test)]
mod tests {
    use crate::mission::cmd;
    use crate::vehicle::testing::*;
    use mavlink::dialects::ardupilotmega::*;

    fn requests(b: &Bench, from: usize) -> Vec<(u64, u16)> {
        b.since(from, "MISSION_REQUEST")
            .into_iter()
            .map(|(t, _, m)| match m {
                MavMessage::MISSION_REQUEST(r) => (t, r.seq),
                _ => unreachable!(),
            })
            .collect()
    }

    fn acks(b: &Bench, from: usize) -> Vec<MavMissionResult> {
        b.since(from, "MISSION_ACK")
            .into_iter()
            .map(|(_, _, m)| match m {
                MavMessage::MISSION_ACK(a) => a.mavtype,
                _ => unreachable!(),
            })
            .collect()
    }

    #[test]
    fn upload_survives_a_lost_item_and_a_duplicate() {
        let mut b = Bench::new(quick());
        b.run_to(3.0);
        let items: Vec<_> = [(0.0, 0.0), (300.0, 0.0), (300.0, 300.0)]
            .iter()
            .enumerate()
            .map(|(i, (n, e))| {
                let mut it = item(&b.v, cmd::NAV_WAYPOINT, *n, *e, 60.0);
                it.seq = i as u16;
                it.to_int((1, 1), false)
            })
            .collect();
        let start = b.got.len();
        b.send(MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
            count: 3,
            target_system: 1,
            target_component: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            opaque_id: 0,
        }));
        b.send(MavMessage::MISSION_ITEM_INT(items[0].clone()));
        // Item 1 is lost: the vehicle asks for it again a second later.
        b.run_to(5.1);
        let asked: Vec<u16> = requests(&b, start).iter().map(|x| x.1).collect();
        assert_eq!(asked, vec![0, 1, 1, 1]);
        let times: Vec<u64> = requests(&b, start).iter().map(|x| x.0).collect();
        assert!(
            (990_000..=1_030_000).contains(&(times[2] - times[1])),
            "{times:?}"
        );
        // Item 0 sent again (a duplicate): INVALID_SEQUENCE, the upload goes on.
        b.send(MavMessage::MISSION_ITEM_INT(items[0].clone()));
        assert_eq!(
            acks(&b, start),
            vec![MavMissionResult::MAV_MISSION_INVALID_SEQUENCE]
        );
        b.send(MavMessage::MISSION_ITEM_INT(items[1].clone()));
        b.send(MavMessage::MISSION_ITEM_INT(items[2].clone()));
        assert_eq!(
            acks(&b, start),
            vec![
                MavMissionResult::MAV_MISSION_INVALID_SEQUENCE,
                MavMissionResult::MAV_MISSION_ACCEPTED
            ]
        );
        assert_eq!(b.texts().last().unwrap(), "Flight plan received");
        let m = b.v.state().mission;
        assert_eq!(m.len(), 3);
        // Item 0 is home whatever was sent; the others as sent.
        assert_eq!(m[0].frame, MavFrame::MAV_FRAME_GLOBAL);
        assert_eq!((m[2].x, m[2].y), (items[2].x, items[2].y));

        // Download: MISSION_COUNT, then each item asked for.
        let from = b.got.len();
        b.send(MavMessage::MISSION_REQUEST_LIST(
            MISSION_REQUEST_LIST_DATA {
                target_system: 1,
                target_component: 1,
                mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            },
        ));
        b.send(MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
            seq: 2,
            target_system: 1,
            target_component: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        }));
        b.send(MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
            seq: 9,
            target_system: 1,
            target_component: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        }));
        let count = b.since(from, "MISSION_COUNT");
        assert!(matches!(&count[0].2, MavMessage::MISSION_COUNT(c) if c.count == 3));
        let item2 = b.since(from, "MISSION_ITEM_INT");
        assert!(matches!(&item2[0].2, MavMessage::MISSION_ITEM_INT(i)
            if i.seq == 2 && i.x == items[2].x && i.target_system == 255));
        assert_eq!(
            acks(&b, from),
            vec![MavMissionResult::MAV_MISSION_INVALID_SEQUENCE]
        );

        // MISSION_SET_CURRENT answers MISSION_CURRENT.
        let from = b.got.len();
        b.send(MavMessage::MISSION_SET_CURRENT(MISSION_SET_CURRENT_DATA {
            seq: 2,
            target_system: 1,
            target_component: 1,
        }));
        let mc = b.since(from, "MISSION_CURRENT");
        assert!(matches!(&mc[0].2, MavMessage::MISSION_CURRENT(c)
            if c.seq == 2 && c.total == 2 && c.mission_state == MissionState::MISSION_STATE_PAUSED));
        assert_eq!(
            b.command(
                MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT,
                [7.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
            ),
            Some(MavResult::MAV_RESULT_DENIED)
        );
        // An upload abandoned: cancelled after 8 s of silence.
        let from = b.got.len();
        b.send(MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
            count: 5,
            target_system: 1,
            target_component: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            opaque_id: 0,
        }));
        b.run_to(b.v.state().time_s + 9.0);
        assert_eq!(
            acks(&b, from),
            vec![MavMissionResult::MAV_MISSION_OPERATION_CANCELLED]
        );
        assert_eq!(requests(&b, from).len(), 8); // at once, then every second
        assert_eq!(b.v.state().mission.len(), 3, "the stored mission is kept");
    }
}
