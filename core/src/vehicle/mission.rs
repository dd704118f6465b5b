//! Mission upload: MISSION_COUNT, then the vehicle asks for each item
//! (MISSION_REQUEST_INT, or the older MISSION_REQUEST) and we answer with
//! MISSION_ITEM_INT, until its MISSION_ACK. The vehicle leads: it may ask
//! for an item twice or out of order, and may send a failing MISSION_ACK
//! and keep asking.

use elaboration::Firmware;
use mavlink::dialects::ardupilotmega::{
    MavCmd, MavFrame, MavMessage, MavMissionResult, MavMissionType, MISSION_ACK_DATA,
    MISSION_COUNT_DATA, MISSION_ITEM_INT_DATA,
};
use nets::Micros;
use num_traits::FromPrimitive;

use super::plan::degrees_e7;
use super::request::{Item, ItemFrame};

/// The name of a mission result without its prefix (`ACCEPTED`, `NO_SPACE`…).
pub fn result_name(result: MavMissionResult) -> String {
    let name = format!("{result:?}");
    name.strip_prefix("MAV_MISSION_")
        .map(str::to_owned)
        .unwrap_or(name)
}

/// The items as sent: on ArduPilot, item 0 is home (the vehicle overwrites
/// it) and the nets' items follow from 1; on PX4 they start at 0.
pub fn build_items(
    items: &[Item],
    firmware: Firmware,
    home: Option<(i32, i32, f32)>,
    target: (u8, u8),
) -> Result<Vec<MISSION_ITEM_INT_DATA>, String> {
    let base = MISSION_ITEM_INT_DATA {
        target_system: target.0,
        target_component: target.1,
        autocontinue: 1,
        mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        ..MISSION_ITEM_INT_DATA::DEFAULT
    };
    let mut out = Vec::with_capacity(items.len() + 1);
    if firmware != Firmware::Px4 {
        let (x, y, z) = home.unwrap_or((0, 0, 0.0));
        out.push(MISSION_ITEM_INT_DATA {
            command: MavCmd::MAV_CMD_NAV_WAYPOINT,
            frame: MavFrame::MAV_FRAME_GLOBAL,
            x,
            y,
            z,
            ..base.clone()
        });
    }
    for (i, item) in items.iter().enumerate() {
        let command = MavCmd::from_u16(item.command).ok_or_else(|| {
            format!(
                "upload_mission: item {i}: command {} is not in the dialect",
                item.command
            )
        })?;
        out.push(MISSION_ITEM_INT_DATA {
            command,
            frame: match item.frame {
                ItemFrame::Relative => MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
                ItemFrame::Amsl => MavFrame::MAV_FRAME_GLOBAL,
                ItemFrame::Terrain => MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT,
            },
            param1: item.params[0],
            param2: item.params[1],
            param3: item.params[2],
            param4: item.params[3],
            x: degrees_e7(item.lat),
            y: degrees_e7(item.lon),
            z: item.alt,
            autocontinue: item.autocontinue as u8,
            ..base.clone()
        });
    }
    for (seq, item) in out.iter_mut().enumerate() {
        item.seq = seq as u16;
    }
    Ok(out)
}

/// What an upload asks of the commander.
#[derive(Debug, Clone, PartialEq)]
pub enum Step {
    /// Nothing to do.
    Wait,
    Send(MavMessage),
    /// Finished: done with this many items, or failed with a reason. The
    /// message, if any, goes to the vehicle first.
    Done {
        count: usize,
    },
    Failed {
        reason: String,
        send: Option<MavMessage>,
    },
}

/// One upload in progress.
#[derive(Debug, Clone)]
pub struct Upload {
    items: Vec<MISSION_ITEM_INT_DATA>,
    target: (u8, u8),
    deadline: Micros,
    /// Transmissions since the vehicle last moved the exchange on.
    sends: u8,
    last_sent: Option<u16>,
    /// A failing MISSION_ACK, final unless the vehicle asks again in time.
    error: Option<String>,
    timeout: Micros,
    retries: u8,
    /// PX4 checks an accepted mission afterwards and refuses MISSION_START
    /// until it has: the upload is done when MISSION_CURRENT shows the new
    /// mission (`total` items, a mission state past NO_MISSION).
    confirm: bool,
    /// Accepted, waiting for that MISSION_CURRENT until `deadline`.
    checking: bool,
    /// The last MISSION_CURRENT seen while checking: (total, mission_state).
    current: Option<(u16, u8)>,
}

/// MISSION_STATE_NOT_STARTED: a valid mission, not begun.
const MISSION_STATE_NOT_STARTED: u8 = 2;

impl Upload {
    /// Starts: returns the upload and its MISSION_COUNT.
    pub fn start(
        items: Vec<MISSION_ITEM_INT_DATA>,
        target: (u8, u8),
        now: Micros,
        timeout: Micros,
        retries: u8,
    ) -> (Upload, MavMessage) {
        let upload = Upload {
            items,
            target,
            deadline: now + timeout,
            sends: 1,
            last_sent: None,
            error: None,
            timeout,
            retries,
            confirm: false,
            checking: false,
            current: None,
        };
        let count = upload.count();
        (upload, count)
    }

    fn count(&self) -> MavMessage {
        MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
            count: self.items.len() as u16,
            target_system: self.target.0,
            target_component: self.target.1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            opaque_id: 0,
        })
    }

    pub fn deadline(&self) -> Micros {
        self.deadline
    }

    /// The MISSION_ACK that tells the vehicle we gave up.
    pub fn cancel(&self) -> MavMessage {
        MavMessage::MISSION_ACK(MISSION_ACK_DATA {
            target_system: self.target.0,
            target_component: self.target.1,
            mavtype: MavMissionResult::MAV_MISSION_OPERATION_CANCELLED,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            opaque_id: 0,
        })
    }

    /// The vehicle asks for item `seq` (MISSION_REQUEST_INT or MISSION_REQUEST).
    pub fn request(&mut self, seq: u16, now: Micros) -> Step {
        let Some(item) = self.items.get(seq as usize) else {
            tracing::warn!(
                seq,
                count = self.items.len(),
                "vehicle asked for a mission item beyond the count"
            );
            return Step::Wait;
        };
        self.error = None;
        self.last_sent = Some(seq);
        self.sends = 1;
        self.deadline = now + self.timeout;
        Step::Send(MavMessage::MISSION_ITEM_INT(item.clone()))
    }

    /// Waits, after the vehicle's ACCEPTED, for MISSION_CURRENT to show the
    /// mission checked (PX4), at most `timeout × (retries + 1)`.
    pub fn confirmed_by_mission_current(mut self) -> Upload {
        self.confirm = true;
        self
    }

    /// The vehicle's MISSION_ACK.
    pub fn ack(&mut self, result: MavMissionResult, now: Micros) -> Step {
        if result == MavMissionResult::MAV_MISSION_ACCEPTED {
            if self.checking {
                return Step::Wait;
            }
            if self.confirm {
                self.checking = true;
                self.error = None;
                self.deadline = now + self.timeout * (u64::from(self.retries) + 1);
                return Step::Wait;
            }
            return Step::Done {
                count: self.items.len(),
            };
        }
        let name = result_name(result);
        tracing::warn!(result = %name, "mission upload: failing MISSION_ACK");
        self.error = Some(name);
        self.deadline = now + self.timeout;
        Step::Wait
    }

    /// MISSION_CURRENT while checking: done once it shows this mission
    /// valid (`total` items, NOT_STARTED or later).
    pub fn current(&mut self, total: u16, mission_state: u8) -> Step {
        if !self.checking {
            return Step::Wait;
        }
        self.current = Some((total, mission_state));
        if usize::from(total) == self.items.len() && mission_state >= MISSION_STATE_NOT_STARTED {
            return Step::Done {
                count: self.items.len(),
            };
        }
        Step::Wait
    }

    /// Time passed: resend, or give up.
    pub fn tick(&mut self, now: Micros) -> Step {
        if now < self.deadline {
            return Step::Wait;
        }
        if self.checking {
            // Accepted but never shown valid: PX4 found it infeasible (its
            // reason is in its events and console), or never said.
            return match self.current {
                Some((total, state))
                    if usize::from(total) == self.items.len()
                        || state < MISSION_STATE_NOT_STARTED =>
                {
                    Step::Failed {
                        reason: "INVALID".into(),
                        send: None,
                    }
                }
                _ => {
                    tracing::warn!("mission upload accepted; the vehicle never showed it checked");
                    Step::Done {
                        count: self.items.len(),
                    }
                }
            };
        }
        if let Some(reason) = self.error.take() {
            return Step::Failed { reason, send: None };
        }
        if self.sends > self.retries {
            return Step::Failed {
                reason: "timeout".into(),
                send: Some(self.cancel()),
            };
        }
        self.sends += 1;
        self.deadline = now + self.timeout;
        Step::Send(match self.last_sent {
            None => self.count(),
            Some(seq) => MavMessage::MISSION_ITEM_INT(self.items[seq as usize].clone()),
        })
    }
}
