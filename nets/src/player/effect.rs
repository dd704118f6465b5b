//! What the player asks the world to do, and what it records: the outputs
//! the caller drains after each input.

use smallvec::SmallVec;

use crate::event::Event;
use crate::model::{NetId, TransitionId, VehicleId};
use crate::time::Micros;
use crate::value::Params;

/// The places marked in a net (or, for `net: None`, the global places), by
/// index.
pub type Marked = SmallVec<[u16; 8]>;

/// One output of the player. Every effect carries the instant it happened
/// at: the input's time, or a timer's own deadline.
#[derive(Debug, Clone, PartialEq)]
pub enum Effect {
    /// A transition fired.
    Fired {
        time: Micros,
        net: NetId,
        transition: TransitionId,
    },
    /// The marking of a net (`Some`) or of the global places (`None`)
    /// changed; this is the new one.
    Marking {
        time: Micros,
        net: Option<NetId>,
        marked: Marked,
        /// False when the net was just deactivated (its marking is then
        /// empty): what tells a deactivation from an active net left
        /// without a token. Always true for the global places.
        active: bool,
    },
    /// A net was activated: it received its initial marking.
    Activated { time: Micros, net: NetId },
    /// A net was deactivated: its tokens, timers and pending calls are gone.
    Deactivated { time: Micros, net: NetId },
    /// `activate` of an active net, or `deactivate` of an inactive one: the
    /// player does nothing and records it.
    Ignored {
        time: Micros,
        net: NetId,
        /// `activate` or `deactivate`.
        action: &'static str,
        by: NetId,
    },
    /// An action emitted an event; it is queued.
    Emitted {
        time: Micros,
        net: NetId,
        event: Event,
    },
    /// A timer was started (or restarted, if it was running).
    TimerStarted {
        time: Micros,
        net: NetId,
        timer: usize,
        deadline: Micros,
        restarted: bool,
    },
    /// A running timer was cancelled (`cancel`, or its net deactivated).
    TimerCancelled {
        time: Micros,
        net: NetId,
        timer: usize,
    },
    /// A timer expired; its event is handled next.
    TimerExpired {
        time: Micros,
        net: NetId,
        timer: usize,
    },
    /// Call a software program's function. Its result comes back through
    /// [`crate::Player::result`] with the same id.
    Call {
        time: Micros,
        id: u64,
        net: NetId,
        program: usize,
        function: usize,
        args: Params,
        /// The vehicle the call is for: the calling instance's (`None` for
        /// a team net or a project without vehicles).
        vehicle: Option<VehicleId>,
    },
    /// Command the vehicle. Its result comes back through
    /// [`crate::Player::result`] with the same id.
    Command {
        time: Micros,
        id: u64,
        net: NetId,
        verb: String,
        args: Params,
        /// The vehicle commanded: the commanding instance's, or the one a
        /// team net names (`command rtl @R2`); `None` in a project without
        /// vehicles (its one implicit vehicle).
        vehicle: Option<VehicleId>,
    },
    /// Ask the operator a question. The answer comes back through
    /// [`crate::Player::answer`] with the same id before `deadline`, or the
    /// ask's timeout event fires at `deadline`.
    Ask {
        time: Micros,
        id: u64,
        net: NetId,
        /// Index into the net's asks.
        ask: usize,
        question: String,
        choices: Vec<String>,
        deadline: Micros,
    },
    /// The operator answered question `id` in time: `NAME.CHOICE` is queued
    /// for the asking net.
    Answered {
        time: Micros,
        id: u64,
        net: NetId,
        choice: String,
    },
    /// An answer was refused: nothing was delivered.
    AnswerRefused {
        time: Micros,
        id: u64,
        choice: String,
        reason: AnswerRefusal,
    },
    /// Question `id` timed out unanswered (its timeout event follows).
    Unanswered { time: Micros, id: u64, net: NetId },
    /// A pending call, command or question was forgotten because its net was
    /// deactivated; a late result will be dropped.
    Forgotten { time: Micros, id: u64, net: NetId },
    /// An event was not handled.
    Dropped {
        time: Micros,
        event: Event,
        reason: DropReason,
    },
    /// A result arrived for an id that is not pending (forgotten, or never
    /// issued): recorded and dropped.
    LateResult { time: Micros, id: u64 },
    /// A catastrophic event fired a transition: from now on only
    /// catastrophic events are handled — of that event's vehicle
    /// (`vehicle`), or of the whole team (`None`: an event of no vehicle,
    /// and always in a project without `[[vehicle]]`).
    Lockout {
        time: Micros,
        event: String,
        net: NetId,
        transition: TransitionId,
        vehicle: Option<VehicleId>,
    },
    /// Something went wrong in the nets; the player carried on.
    Fault { time: Micros, fault: Fault },
}

/// Why an answer was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AnswerRefusal {
    /// No question with that id is pending: never asked, already answered,
    /// timed out (a late answer) or forgotten with its net.
    NotPending,
    /// The choice is not one the question offers.
    NotOffered,
}

impl AnswerRefusal {
    pub fn as_str(self) -> &'static str {
        match self {
            AnswerRefusal::NotPending => "not pending",
            AnswerRefusal::NotOffered => "not offered",
        }
    }
}

/// Why an event was dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DropReason {
    /// The catastrophic lockout (the team's or the event's vehicle's) is on
    /// and the event is not catastrophic.
    Lockout,
    /// A result or timer for a net that is no longer active.
    NetInactive,
    /// The run to completion exceeded its step bound.
    Overflow,
    /// An outside event bearing a name the player alone produces (a result,
    /// `net_fault`): see [`crate::outside`].
    Reserved,
}

impl DropReason {
    pub fn as_str(self) -> &'static str {
        match self {
            DropReason::Lockout => "lockout",
            DropReason::NetInactive => "net inactive",
            DropReason::Overflow => "overflow",
            DropReason::Reserved => "reserved",
        }
    }
}

/// A fault in the nets, found while playing them.
#[derive(Debug, Clone, PartialEq)]
pub enum Fault {
    /// A firing would have put a second token in a place: rejected whole.
    DoubleToken {
        net: NetId,
        transition: TransitionId,
        /// Flat place index (globals first).
        place: usize,
    },
    /// An action's argument could not be evaluated: the firing was rejected.
    BadArgument {
        net: NetId,
        transition: TransitionId,
        message: String,
    },
    /// A guard could not be evaluated (missing parameter, wrong type): it
    /// counted as false.
    Guard {
        net: NetId,
        transition: TransitionId,
        message: String,
    },
    /// Immediate transitions kept firing past the bound on firings per step.
    Livelock {
        net: NetId,
        transition: TransitionId,
        firings: usize,
    },
    /// One input caused more steps than the bound; the rest of the queue was
    /// dropped.
    Overflow { steps: usize },
}

impl Effect {
    /// The instant of the effect.
    pub fn time(&self) -> Micros {
        match self {
            Effect::Fired { time, .. }
            | Effect::Marking { time, .. }
            | Effect::Activated { time, .. }
            | Effect::Deactivated { time, .. }
            | Effect::Ignored { time, .. }
            | Effect::Emitted { time, .. }
            | Effect::TimerStarted { time, .. }
            | Effect::TimerCancelled { time, .. }
            | Effect::TimerExpired { time, .. }
            | Effect::Call { time, .. }
            | Effect::Command { time, .. }
            | Effect::Ask { time, .. }
            | Effect::Answered { time, .. }
            | Effect::AnswerRefused { time, .. }
            | Effect::Unanswered { time, .. }
            | Effect::Forgotten { time, .. }
            | Effect::Dropped { time, .. }
            | Effect::LateResult { time, .. }
            | Effect::Lockout { time, .. }
            | Effect::Fault { time, .. } => *time,
        }
    }

    /// For a firing, the transition as `NET.transition`.
    pub fn fired_label(&self, project: &crate::model::Project) -> Option<String> {
        match self {
            Effect::Fired {
                net, transition, ..
            } => {
                let net = &project.nets[*net];
                Some(format!(
                    "{}.{}",
                    net.name, net.transitions[*transition].name
                ))
            }
            _ => None,
        }
    }
}
