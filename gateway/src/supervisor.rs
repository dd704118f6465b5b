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
use nets::{Effect, Event, Micros, Outcome, Player, Project};

/// One timed input. (`Result` and `Event` come from the vehicle link and the
/// programs in `petrel run`; `replay` of a telemetry log has neither.)
#[allow(dead_code)]
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
}

/// What one input caused.
#[allow(dead_code)]
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

/// Elaboration and the player.
pub struct Supervisor {
    /// One elaborator per lane, in team order.
    elaborators: Vec<Elaborator>,
    /// Each lane's vehicle name and `(sysid, compid)`.
    lanes: Vec<(Option<String>, Option<u8>, Option<u8>)>,
    player: Player,
    seq: u64,
    elaborated: Vec<Elaborated>,
    /// Frames that failed their checksum or were cut.
    pub bad_frames: u64,
}

#[allow(dead_code)]
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
        let ids = lanes
            .iter()
            .map(|l| (l.vehicle.clone(), l.config.sysid, l.config.compid))
            .collect();
        let elaborators = lanes
            .into_iter()
            .map(|l| Elaborator::new(l.profile, l.config))
            .collect();
        let supervisor = Supervisor {
            elaborators,
            lanes: ids,
            player,
            seq: 0,
            elaborated: Vec::new(),
            bad_frames: 0,
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
    pub fn elaborator(&self) -> &Elaborator {
        &self.elaborators[0]
    }

    /// The lanes a frame from (`system`, `component`) goes to: the lane of
    /// its vehicle (by system, then component when several vehicles share
    /// the system), else every lane.
    fn route(&self, system: u8, component: u8) -> std::ops::Range<usize> {
        let mine = |i: usize| self.lanes[i].1 == Some(system);
        let exact = |i: usize| mine(i) && self.lanes[i].2 == Some(component);
        let n = self.lanes.len();
        if n == 1 {
            return 0..1;
        }
        if let Some(i) = (0..n).find(|&i| exact(i)) {
            return i..i + 1;
        }
        match (0..n).find(|&i| mine(i)) {
            Some(i) => i..i + 1,
            None => 0..n,
        }
    }

    /// Ticks and drains lanes `range`, qualifying each event with its
    /// lane's vehicle.
    fn drain(&mut self, range: std::ops::Range<usize>, time: Micros, frame: Option<&Frame>) {
        let several = range.len() > 1;
        for i in range {
            let e = &mut self.elaborators[i];
            e.tick(time);
            if let Some(frame) = frame {
                e.frame(time, frame);
            }
            let from = self.elaborated.len();
            e.drain_into(&mut self.elaborated);
            if let Some(vehicle) = &self.lanes[i].0 {
                for e in &mut self.elaborated[from..] {
                    e.event.name = nets::model::qualify(&e.event.name, vehicle);
                }
            }
        }
        if several {
            // Several lanes' events in time order; a stable sort keeps
            // team order among events of one instant.
            self.elaborated.sort_by_key(|e| e.time_us);
        }
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
        let mut step = Step {
            seq: self.seq,
            time,
            ..Step::default()
        };
        match input {
            Input::Frame(bytes) => match Frame::parse(bytes) {
                Ok(frame) => {
                    let lanes = self.route(frame.system_id(), frame.component_id());
                    self.drain(lanes, time, Some(&frame));
                }
                Err(_) => self.bad_frames += 1,
            },
            Input::Tick => self.drain(0..self.elaborators.len(), time, None),
            Input::Result { id, outcome } => self.player.result(id, outcome, time),
            Input::Event(event) => self.player.handle(&event, time),
            Input::Answer { id, choice } => {
                let _ = self.player.answer(id, &choice, time);
            }
        }
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
