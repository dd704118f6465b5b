//! The commanders of a team: one [`Commander`] per vehicle, each on its
//! vehicle's link, and the routing of the nets' command effects by their
//! `vehicle` (docs/multi-vehicle.md, "A team"). Without a team, one
//! member commands the one vehicle.
//!
//! Sans-IO like the commander: frames come in with the link they were read
//! on; what to send comes out with the link and the identity to send it as.
//! Outcomes come back by command id, which the player numbers across the
//! team, so each reaches the instance that commanded.

use std::collections::VecDeque;

use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::MavHeader;
use nets::{Micros, Outcome, Params};

use super::commander::Commander;
use super::parameters::Verdict;

/// One vehicle's commander and where it speaks.
pub struct Member {
    /// The vehicle's name (`None` without a team).
    pub name: Option<String>,
    /// The index of its link.
    pub link: usize,
    pub commander: Commander,
}

/// The team's commanders, in team order.
pub struct Crew {
    members: Vec<Member>,
    /// Outcomes of commands no member could take.
    refused: VecDeque<(u64, Outcome)>,
    /// The member polled first next time (fairness between vehicles).
    next: usize,
}

/// A frame to send: on `link`, as `from`.
#[derive(Debug)]
pub struct Transmit {
    pub link: usize,
    pub from: (u8, u8),
    pub message: MavMessage,
}

impl Crew {
    /// `members` in team order (at least one).
    pub fn new(members: Vec<Member>) -> Crew {
        Crew {
            members,
            refused: VecDeque::new(),
            next: 0,
        }
    }

    pub fn members(&self) -> &[Member] {
        &self.members
    }

    /// The first vehicle's commander: the one that identifies the gateway
    /// (the mirror's downlink, the scaled clock's autopilot time).
    pub fn first(&self) -> Option<&Commander> {
        self.members.first().map(|m| &m.commander)
    }

    /// A message read on `link`: to every commander on it (each follows
    /// its own autopilot only).
    pub fn message(&mut self, link: usize, now: Micros, header: &MavHeader, message: &MavMessage) {
        for m in self.members.iter_mut().filter(|m| m.link == link) {
            m.commander.message(now, header, message);
        }
    }

    /// A command effect: to the commander of `vehicle` (the one member
    /// without a team); a vehicle the crew does not have fails it.
    pub fn command(
        &mut self,
        id: u64,
        vehicle: Option<usize>,
        verb: &str,
        args: &Params,
        now: Micros,
    ) {
        match self.members.get_mut(vehicle.unwrap_or(0)) {
            Some(m) => m.commander.command(id, verb, args, now),
            None => self.refused.push_back((
                id,
                Outcome::Failed(format!("no vehicle {} in the team", vehicle.unwrap_or(0))),
            )),
        }
    }

    /// Forgets a command (its net was deactivated), whichever vehicle had it.
    pub fn forget(&mut self, id: u64) {
        for m in &mut self.members {
            m.commander.forget(id);
        }
    }

    pub fn tick(&mut self, now: Micros) {
        for m in &mut self.members {
            m.commander.tick(now);
        }
    }

    pub fn next_deadline(&self) -> Option<Micros> {
        self.members
            .iter()
            .filter_map(|m| m.commander.next_deadline())
            .min()
    }

    /// Whether any commander has work under way (a mission upload).
    pub fn busy(&self) -> bool {
        self.members.iter().any(|m| m.commander.busy())
    }

    /// The next frame to send, taking the vehicles in turn.
    pub fn poll_transmit(&mut self) -> Option<Transmit> {
        let n = self.members.len();
        for k in 0..n {
            let i = (self.next + k) % n;
            let m = &mut self.members[i];
            if let Some(message) = m.commander.poll_transmit() {
                self.next = (i + 1) % n;
                return Some(Transmit {
                    link: m.link,
                    from: m.commander.sender(),
                    message,
                });
            }
        }
        None
    }

    /// The next command outcome, for the player.
    pub fn poll_outcome(&mut self) -> Option<(u64, Outcome)> {
        if let Some(o) = self.refused.pop_front() {
            return Some(o);
        }
        self.members
            .iter_mut()
            .find_map(|m| m.commander.poll_outcome())
    }

    /// The next parameter check's verdict: the member it is about, and it.
    pub fn poll_parameters(&mut self) -> Option<(usize, Verdict)> {
        self.members
            .iter_mut()
            .enumerate()
            .find_map(|(i, m)| m.commander.poll_parameters().map(|v| (i, v)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vehicle::config::VehicleConfig;
    use mavlink::dialects::ardupilotmega::{
        MavAutopilot, MavCmd, MavModeFlag, MavResult, MavState, MavType, COMMAND_ACK_DATA,
        HEARTBEAT_DATA,
    };

    fn member(name: &str, system: u8, link: usize) -> Member {
        Member {
            name: Some(name.to_owned()),
            link,
            commander: Commander::new(VehicleConfig {
                system: Some(system),
                autopilot_component: Some(1),
                ..VehicleConfig::default()
            }),
        }
    }

    fn header(system: u8) -> MavHeader {
        MavHeader {
            system_id: u32::from(system),
            component_id: 1,
            sequence: 0,
        }
    }

    fn heartbeat() -> MavMessage {
        MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: 0,
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
            system_status: MavState::MAV_STATE_STANDBY,
            mavlink_version: 3,
        })
    }

    /// Everything to send now, HEARTBEATs aside.
    fn sent(crew: &mut Crew) -> Vec<Transmit> {
        std::iter::from_fn(|| crew.poll_transmit())
            .filter(|t| !matches!(t.message, MavMessage::HEARTBEAT(_)))
            .collect()
    }

    fn target(m: &MavMessage) -> Option<(u8, MavCmd)> {
        match m {
            MavMessage::COMMAND_LONG(c) => Some((c.target_system, c.command)),
            _ => None,
        }
    }

    #[test]
    fn commands_go_to_their_vehicle_on_its_link_and_outcomes_come_back() {
        // R1 and R2 share link 0; R3 has link 1.
        let mut crew = Crew::new(vec![
            member("R1", 1, 0),
            member("R2", 2, 0),
            member("R3", 3, 1),
        ]);
        let mut now = 0;
        // Each autopilot heard on its link (R3 also heard on link 0 by a
        // router: R3's commander follows link 1 only).
        for (link, system) in [(0, 1), (0, 2), (1, 3), (0, 3)] {
            crew.message(link, now, &header(system), &heartbeat());
        }
        let _ = sent(&mut crew); // telemetry and parameter requests, if any
        now += 1_000;
        crew.command(7, Some(1), "arm", &Params::new(), now);
        crew.command(8, Some(2), "rtl", &Params::new(), now);
        crew.command(9, Some(0), "land", &Params::new(), now);
        let out = sent(&mut crew);
        let routed: Vec<_> = out
            .iter()
            .filter_map(|t| target(&t.message).map(|(sys, cmd)| (t.link, t.from, sys, cmd)))
            .collect();
        assert!(
            routed.contains(&(0, (2, 191), 2, MavCmd::MAV_CMD_COMPONENT_ARM_DISARM)),
            "{routed:?}"
        );
        assert!(routed
            .iter()
            .any(|&(link, from, sys, _)| (link, from, sys) == (1, (3, 191), 3)));
        assert!(routed
            .iter()
            .any(|&(link, from, sys, _)| (link, from, sys) == (0, (1, 191), 1)));
        assert_eq!(routed.len(), 3, "one command each: {routed:?}");
        assert!(
            routed.iter().all(|&(_, from, sys, _)| from.0 == sys),
            "every command speaks as its own vehicle: {routed:?}"
        );
        // R2 accepts the arm: the outcome is command 7's. An ACK from R2
        // read on R3's link reaches no one.
        let ack = MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
            command: MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            result: MavResult::MAV_RESULT_ACCEPTED,
            progress: 0,
            result_param2: 0,
            target_system: 2,
            target_component: 191,
        });
        crew.message(1, now + 10, &header(2), &ack);
        assert_eq!(crew.poll_outcome(), None);
        crew.message(0, now + 10, &header(2), &ack);
        assert!(matches!(crew.poll_outcome(), Some((7, Outcome::Done(_)))));
        assert_eq!(crew.poll_outcome(), None);
        // A vehicle the crew does not have: the command fails at once.
        crew.command(10, Some(5), "land", &Params::new(), now);
        assert!(
            matches!(crew.poll_outcome(), Some((10, Outcome::Failed(r))) if r.contains("no vehicle"))
        );
        // Forgetting finds the command whichever vehicle holds it: no
        // outcome ever comes for 8 and 9, long after their timeouts.
        crew.forget(8);
        crew.forget(9);
        for s in 1..=120 {
            crew.tick(now + s * 1_000_000);
            let _ = sent(&mut crew);
        }
        assert_eq!(crew.poll_outcome(), None);
    }
}
