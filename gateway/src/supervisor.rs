//! The supervisor: elaboration and the player as one sans-IO state machine —
//! the unit `petrel run` drives from the live link and `petrel replay` from
//! a recording. Feed it timed inputs; each returns the step it caused.
//!
//! Frames go through the elaborator; the events it yields go to the player
//! in order, each at its frame's time; ticks let elaboration timeouts and
//! player timers fire when no frame arrives. Call and command results and
//! programs' own events go straight to the player.

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

/// Elaboration and the player.
pub struct Supervisor {
    elaborator: Elaborator,
    player: Player,
    seq: u64,
    elaborated: Vec<Elaborated>,
    /// Frames that failed their checksum or were cut.
    pub bad_frames: u64,
}

#[allow(dead_code)]
impl Supervisor {
    /// Starts the player at `now`; the start's effects are step 0.
    pub fn start(
        project: Arc<Project>,
        profile: Profile,
        config: Config,
        now: Micros,
    ) -> (Supervisor, Step) {
        let mut player = Player::start(project, now);
        let effects = player.effects().collect();
        let supervisor = Supervisor {
            elaborator: Elaborator::new(profile, config),
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

    pub fn elaborator(&self) -> &Elaborator {
        &self.elaborator
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
                    self.elaborator.tick(time);
                    self.elaborator.frame(time, &frame);
                    self.elaborator.drain_into(&mut self.elaborated);
                }
                Err(_) => self.bad_frames += 1,
            },
            Input::Tick => {
                self.elaborator.tick(time);
                self.elaborator.drain_into(&mut self.elaborated);
            }
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
