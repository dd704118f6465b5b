//! The whole state of a player: what [`crate::Player::snapshot`] returns and
//! [`crate::Player::restore`] takes, and what the digest covers.

use std::collections::{BTreeMap, VecDeque};

use serde::{Deserialize, Serialize};

use crate::event::{Category, Event};
use crate::model::{NetId, VehicleId};
use crate::time::Micros;

/// Everything a player holds between two inputs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct State {
    /// The latest instant seen.
    pub now: Micros,
    /// Marked places, as a bitset over the flat numbering (globals first,
    /// then each net's places in project order).
    pub marking: Vec<u64>,
    /// Which nets are active, in project order.
    pub active: Vec<bool>,
    /// Running timers, ordered by deadline then start order.
    pub timers: Vec<Timer>,
    /// Queued events, one queue per category (highest priority first). Empty
    /// between inputs: every input runs to completion.
    pub queue: [VecDeque<Queued>; 5],
    /// The catastrophic lockout of the whole team (of the one vehicle of a
    /// project without `[[vehicle]]`).
    pub lockout: bool,
    /// The vehicles locked out one by one: a catastrophic event of theirs
    /// fired a transition (ascending, each once). Empty without a team.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub locked: Vec<VehicleId>,
    /// Calls, commands and questions awaiting their results, by id.
    pub pending: BTreeMap<u64, Pending>,
    /// The id the next call or command gets.
    pub next_id: u64,
    /// The start order the next timer gets.
    pub next_timer_seq: u64,
}

/// A running timer.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Timer {
    pub net: NetId,
    /// Index into the net's timer names.
    pub timer: usize,
    pub deadline: Micros,
    pub seq: u64,
    /// Started by the catastrophic reaction: its expiry is catastrophic.
    pub catastrophic: bool,
}

/// A queued event.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Queued {
    /// The event, with its effective category.
    pub event: Event,
    /// Delivered only to this net (results and timers).
    pub target: Option<NetId>,
}

/// A call or command awaiting its result.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Pending {
    pub net: NetId,
    pub kind: PendingKind,
    /// Issued by the catastrophic reaction: its result is catastrophic.
    pub catastrophic: bool,
}

/// What is pending.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum PendingKind {
    Call {
        program: usize,
        function: usize,
    },
    Command {
        verb: String,
    },
    /// A question to the operator: ask `ask` of the pending's net. Its
    /// answer comes back through [`crate::Player::answer`]; its timeout is
    /// the net's timer `NAME.timeout`.
    Question {
        ask: usize,
    },
}

impl State {
    /// Whether a non-catastrophic event of `vehicle` (`None`: no vehicle's,
    /// a team event) is dropped by a lockout: the team's, or its vehicle's.
    pub fn locks(&self, vehicle: Option<VehicleId>) -> bool {
        self.lockout || vehicle.is_some_and(|v| self.locked.binary_search(&v).is_ok())
    }

    /// Whether flat place `p` is marked.
    pub fn marked(&self, p: usize) -> bool {
        self.marking[p / 64] & (1 << (p % 64)) != 0
    }

    pub(crate) fn set(&mut self, p: usize, on: bool) {
        if on {
            self.marking[p / 64] |= 1 << (p % 64);
        } else {
            self.marking[p / 64] &= !(1 << (p % 64));
        }
    }

    pub(crate) fn push(&mut self, q: Queued) {
        self.queue[q.event.category.priority()].push_back(q);
    }

    pub(crate) fn pop(&mut self) -> Option<Queued> {
        self.queue.iter_mut().find_map(|q| q.pop_front())
    }

    /// Number of queued events.
    pub fn queued(&self) -> usize {
        self.queue.iter().map(VecDeque::len).sum()
    }

    /// The category of the highest-priority queued event.
    pub fn next_category(&self) -> Option<Category> {
        self.queue
            .iter()
            .position(|q| !q.is_empty())
            .map(|i| Category::ALL[i])
    }
}
