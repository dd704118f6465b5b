//! The supervisor: elaboration and the player as one sans-IO state machine —
//! the unit `petrel run` drives from the live link and `petrel replay` from
//! a recording. Feed it timed inputs; each returns the step it caused.
//!
//! Frames go through the elaborator; the events it yields go to the player
//! in order, each at its frame's time; ticks let elaboration timeouts and
//! player timers fire when no frame arrives. Call and command results and
//! programs' own events go straight to the player.
//!
//! A team (`[[vehicle]]`, docs/nets.md "Teams of vehicles") has one
//! elaborator per vehicle, each a [`Lane`] with its vehicle's profile and
//! `{sysid, compid}`: a frame goes to the lane of its system (a frame of a
//! system that is no vehicle of the team, a ground station's, to every
//! lane, whose rules tell whom they watch), and each event a lane yields
//! reaches the player as `EVENT@VEHICLE`. Ticks reach every lane, in team
//! order. One player for the team.

use std::sync::Arc;

use elaboration::{Config, Elaborated, Elaborator, Frame, Profile};
use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::MavHeader;
use nets::{Effect, Event, Micros, Outcome, Player, Project};

use crate::version::Version;

/// One timed input. (`Result` and `Event` come from the vehicle link and the
/// programs in `petrel run`; `replay` of a telemetry log has neither.)
#[derive(Debug, Clone)]
pub enum Input<'a> {
    /// A MAVLink frame as received (bytes on the wire).
    Frame(&'a [u8]),
    /// Time passes with nothing received.
    Tick,
    /// A call's or command's outcome.
    Result { id: u64, outcome: Outcome },
    /// An event from a software program.
    Event(Event),
    /// The operator's answer to question `id` (its signature checked by
    /// `mirror::dialog::AnswerGate`); the player refuses it if late.
    Answer { id: u64, choice: String },
    /// A new version of the project takes over, the state kept
    /// (`crate::version`: proved before it is fed).
    Version(&'a Arc<Version>),
}

/// What one input caused.
#[derive(Debug, Clone, Default)]
pub struct Step {
    /// Steps are numbered from 1 (0 is the start).
    pub seq: u64,
    pub time: Micros,
    /// Events elaborated from the input, in the order handed to the player,
    /// each with the effects it caused.
    pub events: Vec<(Elaborated, Vec<Effect>)>,
    /// The player's other effects: those of a result, a program's event, or
    /// timers expiring.
    pub effects: Vec<Effect>,
}

/// One vehicle's elaboration: its profile, its `{sysid, compid}`, and the
/// vehicle name its events are qualified with (`None`: a project without a
/// team, events unqualified).
#[derive(Debug, Clone)]
pub struct Lane {
    pub vehicle: Option<String>,
    pub profile: Profile,
    pub config: Config,
}

/// The team's elaboration: one elaborator per lane, frames routed by
/// system id, events qualified with their lane's vehicle. The supervisor
/// feeds its player from it; the ground mirror (`petrel mirror`)
/// elaborates the ground's own telemetry with the same lanes, so that both
/// sides name a vehicle's events alike.
pub struct Lanes {
    /// One elaborator per lane, in team order.
    elaborators: Vec<Elaborator>,
    /// Each lane's vehicle name and `(sysid, compid)`.
    ids: Vec<(Option<String>, Option<u8>, Option<u8>)>,
    /// By system id: the lanes of that system, in team order (a frame's
    /// lane is found without a scan of the team).
    by_system: Vec<Vec<usize>>,
}

impl Lanes {
    pub fn new(lanes: Vec<Lane>) -> Lanes {
        let ids = lanes
            .iter()
            .map(|l| (l.vehicle.clone(), l.config.sysid, l.config.compid))
            .collect::<Vec<_>>();
        let mut by_system = vec![Vec::new(); 256];
        for (i, (_, system, _)) in ids.iter().enumerate() {
            if let Some(system) = system {
                by_system[usize::from(*system)].push(i);
            }
        }
        let elaborators = lanes
            .into_iter()
            .map(|l| Elaborator::new(l.profile, l.config))
            .collect();
        Lanes {
            elaborators,
            ids,
            by_system,
        }
    }

    /// How many lanes (1 without a team).
    pub fn count(&self) -> usize {
        self.elaborators.len()
    }

    /// Lane `i`'s vehicle name (`None` without a team).
    pub fn vehicle(&self, i: usize) -> Option<&str> {
        self.ids.get(i).and_then(|l| l.0.as_deref())
    }

    /// The lane of a team vehicle of system `system` (by system, then
    /// component when several vehicles share the system); `None` for a
    /// system that is no vehicle of the team, and always without a team.
    pub fn lane_of(&self, system: u8, component: u8) -> Option<usize> {
        let mine = self.by_system.get(usize::from(system))?;
        mine.iter()
            .copied()
            .find(|&i| self.ids[i].2 == Some(component))
            .or_else(|| mine.first().copied())
    }

    /// The lanes a frame from (`system`, `component`) goes to: the lane of
    /// its vehicle, else every lane.
    pub fn route(&self, system: u8, component: u8) -> std::ops::Range<usize> {
        let n = self.ids.len();
        if n == 1 {
            return 0..1;
        }
        match self.lane_of(system, component) {
            Some(i) => i..i + 1,
            None => 0..n,
        }
    }

    /// Each lane's vehicle's autopilot clock as far as its elaboration
    /// has read it (`Elaborator::vehicle_boot_us`): (lane, µs), the lanes
    /// that heard one.
    pub fn boots(&self) -> Vec<(u64, Micros)> {
        self.elaborators
            .iter()
            .enumerate()
            .filter_map(|(i, e)| Some((i as u64, e.vehicle_boot_us()?)))
            .collect()
    }

    /// Lane `i`'s elaborator.
    pub fn elaborator(&self, i: usize) -> &Elaborator {
        &self.elaborators[i]
    }

    /// The first lane's elaborator (the only one without a team).
    pub fn first(&self) -> &Elaborator {
        &self.elaborators[0]
    }

    /// Feeds what was heard (or only time, `None`) at `time` to lanes
    /// `range` and drains what they elaborate into `out`, each event
    /// qualified with its lane's vehicle; several lanes' events in time
    /// order (a stable sort keeps team order among events of one instant).
    fn feed(
        &mut self,
        range: std::ops::Range<usize>,
        time: Micros,
        heard: Option<Heard>,
        out: &mut Vec<Elaborated>,
    ) {
        let several = range.len() > 1;
        let start = out.len();
        for i in range {
            let e = &mut self.elaborators[i];
            e.tick(time);
            match heard {
                Some(Heard::Frame(frame)) => e.frame(time, frame),
                Some(Heard::Message(header, message)) => e.message(time, header, message),
                None => {}
            }
            let from = out.len();
            e.drain_into(out);
            if let Some(vehicle) = &self.ids[i].0 {
                for e in &mut out[from..] {
                    e.event.name = nets::model::qualify(&e.event.name, vehicle);
                }
            }
        }
        if several {
            out[start..].sort_by_key(|e| e.time_us);
        }
    }

    /// A frame at `time` to the lanes of its system ([`Lanes::route`]).
    pub fn frame(&mut self, time: Micros, frame: &Frame, out: &mut Vec<Elaborated>) {
        let lanes = self.route(frame.system_id(), frame.component_id());
        self.feed(lanes, time, Some(Heard::Frame(frame)), out);
    }

    /// A message rust-mavlink already decoded (a live link's frame), at
    /// `time`, to the lanes of its system: the same events as
    /// [`Lanes::frame`] of its bytes, without parsing them again.
    pub fn message(
        &mut self,
        time: Micros,
        header: &MavHeader,
        message: &MavMessage,
        out: &mut Vec<Elaborated>,
    ) {
        let system = u8::try_from(header.system_id).unwrap_or(u8::MAX);
        let lanes = self.route(system, header.component_id);
        self.feed(lanes, time, Some(Heard::Message(header, message)), out);
    }

    /// Time passes: every lane ticks, in team order.
    pub fn tick(&mut self, time: Micros, out: &mut Vec<Elaborated>) {
        self.feed(0..self.count(), time, None, out);
    }
}

/// What a lane hears: a frame's bytes, or the message rust-mavlink decoded.
#[derive(Clone, Copy)]
enum Heard<'a, 'b> {
    Frame(&'a Frame<'b>),
    Message(&'a MavHeader, &'a MavMessage),
}

/// Elaboration and the player.
pub struct Supervisor {
    lanes: Lanes,
    player: Player,
    seq: u64,
    elaborated: Vec<Elaborated>,
    /// Frames that failed their checksum or were cut.
    pub bad_frames: u64,
    /// Why the last [`Input::Version`] could not take over (empty: it did,
    /// or none came).
    pub version_refused: Vec<String>,
}

impl Supervisor {
    /// Starts the player at `now` with one elaborator (a project without a
    /// team); the start's effects are step 0.
    pub fn start(
        project: Arc<Project>,
        profile: Profile,
        config: Config,
        now: Micros,
    ) -> (Supervisor, Step) {
        let lane = Lane {
            vehicle: None,
            profile,
            config,
        };
        Supervisor::start_lanes(project, vec![lane], now)
    }

    /// Starts the player at `now` with one elaborator per lane (a team: one
    /// per vehicle, `team::lanes`); the start's effects are step 0.
    pub fn start_lanes(project: Arc<Project>, lanes: Vec<Lane>, now: Micros) -> (Supervisor, Step) {
        let mut player = Player::start(project, now);
        let effects = player.effects().collect();
        let supervisor = Supervisor {
            lanes: Lanes::new(lanes),
            player,
            seq: 0,
            elaborated: Vec::new(),
            bad_frames: 0,
            version_refused: Vec::new(),
        };
        (
            supervisor,
            Step {
                seq: 0,
                time: now,
                events: Vec::new(),
                effects,
            },
        )
    }

    pub fn player(&self) -> &Player {
        &self.player
    }

    /// The first lane's elaborator (the only one without a team).
    /// Each lane's autopilot clock as far as read ([`Lanes::boots`]).
    pub fn boots(&self) -> Vec<(u64, Micros)> {
        self.lanes.boots()
    }

    pub fn elaborator(&self) -> &Elaborator {
        self.lanes.first()
    }

    /// The number of the last step.
    pub fn seq(&self) -> u64 {
        self.seq
    }

    /// When to tick next if nothing arrives: the player's next timer.
    pub fn next_deadline(&self) -> Option<Micros> {
        self.player.next_deadline()
    }

    /// A step of the player alone, no elaboration: `play` calls it and
    /// returns the effects (replaying a ground mirror's recording, whose
    /// steps are the replica's calls on its player).
    pub fn play_with<E>(
        &mut self,
        time: Micros,
        play: impl FnOnce(&mut Player) -> Result<Vec<Effect>, E>,
    ) -> Result<Step, E> {
        let effects = play(&mut self.player)?;
        self.seq += 1;
        Ok(Step {
            seq: self.seq,
            time,
            events: Vec::new(),
            effects,
        })
    }

    /// Feeds one input at `time`.
    pub fn step(&mut self, time: Micros, input: Input) -> Step {
        self.seq += 1;
        match input {
            Input::Frame(bytes) => match Frame::parse(bytes) {
                Ok(frame) => self.lanes.frame(time, &frame, &mut self.elaborated),
                Err(_) => self.bad_frames += 1,
            },
            Input::Tick => self.lanes.tick(time, &mut self.elaborated),
            Input::Result { id, outcome } => self.player.result(id, outcome, time),
            Input::Event(event) => self.player.handle(&event, time),
            Input::Answer { id, choice } => {
                let _ = self.player.answer(id, &choice, time);
            }
            Input::Version(version) => {
                self.version_refused = self.take_over(version).err().unwrap_or_default();
                if !self.version_refused.is_empty() {
                    tracing::warn!(
                        "version {} could not take over: {}",
                        version.number,
                        self.version_refused.join("; ")
                    );
                }
            }
        }
        self.settle(time)
    }

    /// `version` takes over, its state mapped from the running one by
    /// name; the player unchanged when it cannot, with why.
    fn take_over(&mut self, version: &Version) -> Result<(), Vec<String>> {
        let text = |why: Vec<nets::version::Refusal>| -> Vec<String> {
            why.iter().map(ToString::to_string).collect()
        };
        let old = self.player.project();
        let state = nets::version::map(old, self.player.state(), &version.project).map_err(text)?;
        self.player = Player::restore(version.project.clone(), state).map_err(|e| {
            vec![format!(
                "the mapped state does not fit the new version: {e}"
            )]
        })?;
        Ok(())
    }

    /// Feeds at `time` a frame that rust-mavlink already decoded on a live
    /// link: the step [`Self::step`] of `Input::Frame` of its bytes gives,
    /// without parsing the frame again (its bytes are recorded as that
    /// input; replay parses them, with the same events).
    pub fn step_message(&mut self, time: Micros, header: &MavHeader, message: &MavMessage) -> Step {
        self.seq += 1;
        self.lanes
            .message(time, header, message, &mut self.elaborated);
        self.settle(time)
    }

    /// The step an input just fed causes: the effects so far, each
    /// elaborated event handed to the player with its own, then time
    /// advanced to `time`.
    fn settle(&mut self, time: Micros) -> Step {
        let mut step = Step {
            seq: self.seq,
            time,
            ..Step::default()
        };
        step.effects.extend(self.player.effects());
        for e in self.elaborated.drain(..) {
            self.player.handle(&e.event, e.time_us);
            let effects = self.player.effects().collect();
            step.events.push((e, effects));
        }
        self.player.advance(time);
        step.effects.extend(self.player.effects());
        step
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lanes(ids: &[(&str, Option<u8>, Option<u8>)]) -> Lanes {
        let lanes = ids
            .iter()
            .map(|&(name, sysid, compid)| Lane {
                vehicle: Some(name.to_owned()),
                profile: Profile::builtin("ardupilot").unwrap(),
                config: Config {
                    sysid,
                    compid,
                    ..Config::default()
                },
            })
            .collect();
        Lanes::new(lanes)
    }

    #[test]
    fn a_frame_finds_its_lane_by_system_then_component() {
        // R1 and R2 share system 1 (components 1 and 2); R3 is system 3
        // with any component; R4 has no system id.
        let l = lanes(&[
            ("R1", Some(1), Some(1)),
            ("R2", Some(1), Some(2)),
            ("R3", Some(3), None),
            ("R4", None, None),
        ]);
        assert_eq!(l.lane_of(1, 1), Some(0));
        assert_eq!(l.lane_of(1, 2), Some(1));
        // Another component of system 1: its first lane.
        assert_eq!(l.lane_of(1, 9), Some(0));
        assert_eq!(l.lane_of(3, 200), Some(2));
        assert_eq!(l.lane_of(2, 1), None);
        assert_eq!(l.route(3, 1), 2..3);
        // No vehicle of the team: every lane.
        assert_eq!(l.route(255, 190), 0..4);
        // The same system declared twice with its component: in team order.
        let l = lanes(&[("A", Some(7), Some(4)), ("B", Some(7), Some(4))]);
        assert_eq!(l.lane_of(7, 4), Some(0));
    }
}
