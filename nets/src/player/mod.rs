//! The player: a pure, deterministic state machine that fires the
//! event-triggered transitions of a project's nets and produces effects.
//!
//! Feed it [`Player::handle`] (an event), [`Player::advance`] (time passing)
//! and [`Player::result`] (a call's or command's outcome); drain
//! [`Player::effects`] after each. It never reads a clock: the same inputs
//! give the same effects and the same [`Player::digest`], bit for bit.
//!
//! The rules it keeps are written in `docs/nets.md` ("How the player
//! plays"); each has a test in `nets/tests/it/player.rs`.

mod digest;
mod effect;
mod oracle;
mod render;
#[cfg(test)]
mod reset_tests;
pub mod snapshot;
mod state;
mod symbols;

use std::sync::Arc;

pub use digest::{canonical_bytes, Digest, DIGEST_ALGORITHM};
pub use effect::{AnswerRefusal, DropReason, Effect, Fault, Marked};
pub use oracle::{Oracle, Question};

pub use render::{effect_json, effect_text, marking_words};
pub use state::{Pending, PendingKind, Queued, State, Timer};

use crate::event::{Category, Event};
use crate::model::{names, Action, NetId, PlaceRef, Project, TransitionId, VehicleId};
use crate::time::Micros;
use crate::value::{Params, Value};
use symbols::{EventInfo, Symbols};

/// The outcome of a call or command, given back to the player. As JSON:
/// `{"done": {params}}` or `{"failed": "reason"}`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Outcome {
    /// Done, with the result's parameters.
    Done(Params),
    /// Failed, with a reason.
    Failed(String),
}

/// Why a snapshot cannot be restored on a project.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RestoreError {
    #[error("the snapshot does not fit this project: {0}")]
    Mismatch(String),
}

/// The player of one project.
#[derive(Debug, Clone)]
pub struct Player {
    project: Arc<Project>,
    /// The project's event names, worked out once.
    symbols: Arc<Symbols>,
    state: State,
    effects: Vec<Effect>,
    oracle: Option<Oracle>,
    /// Scratch space reused across inputs (never part of the state).
    candidates: Vec<(NetId, TransitionId)>,
    consumed: Vec<u64>,
    /// Something fired or was activated since the last immediate pass.
    changed: bool,
    /// `net_fault`s raised by rejected firings of the occurrence being
    /// handled, with whether the catastrophic reaction raised them; queued
    /// once the occurrence is over (see [`Player::queue_net_faults`]).
    net_faults: Vec<(Params, bool)>,
    /// Set by the verifier, which reads only firings and faults: no other
    /// effect is recorded (its millions of steps would build them for
    /// nothing). Never set in flight.
    firings_only: bool,
    /// For the verifier: the pending calls as its last restore put them
    /// (the caller's number for them, their count and the next id then):
    /// while the count and the next id are unchanged nothing was added or
    /// removed, and the same calls need not be copied again.
    pending_from: Option<(u64, usize, u64)>,
}

enum Firing {
    Fired,
    Rejected,
}

impl Player {
    /// Starts a project at `now`: global places get their initial marking,
    /// the nets marked `active` are activated, and immediate transitions
    /// fire.
    pub fn start(project: Arc<Project>, now: Micros) -> Player {
        let words = project.place_count.div_ceil(64).max(1);
        let state = State {
            now,
            marking: vec![0; words],
            active: vec![false; project.nets.len()],
            timers: Vec::new(),
            queue: Default::default(),
            lockout: false,
            locked: Vec::new(),
            pending: Default::default(),
            next_id: 1,
            next_timer_seq: 0,
        };
        let mut player = Player::with_state(project, state);
        let project = Arc::clone(&player.project);
        for (g, global) in project.globals.iter().enumerate() {
            player.state.set(g, global.initial);
        }
        if !project.globals.is_empty() {
            player.push_marking(now, None);
        }
        for (n, net) in project.nets.iter().enumerate() {
            if net.active_at_start {
                player.activate(&project, n, now);
            }
        }
        player.immediates(&project, now, false);
        player.run_queue(&project, now, 1);
        player
    }

    fn with_state(project: Arc<Project>, state: State) -> Player {
        let words = project.place_count.div_ceil(64).max(1);
        Player {
            symbols: Arc::new(Symbols::new(&project)),
            project,
            state,
            effects: Vec::new(),
            oracle: None,
            candidates: Vec::new(),
            consumed: vec![0; words],
            changed: false,
            net_faults: Vec::new(),
            firings_only: false,
            pending_from: None,
        }
    }

    /// Restores a snapshot taken from a player of the same project.
    pub fn restore(project: Arc<Project>, state: State) -> Result<Player, RestoreError> {
        let words = project.place_count.div_ceil(64).max(1);
        let mismatch = |m: String| Err(RestoreError::Mismatch(m));
        if state.marking.len() != words {
            return mismatch(format!(
                "{} marking words, the project needs {words}",
                state.marking.len()
            ));
        }
        if state.active.len() != project.nets.len() {
            return mismatch(format!(
                "{} nets, the project has {}",
                state.active.len(),
                project.nets.len()
            ));
        }
        let spare = project.place_count % 64;
        if spare != 0 && state.marking[words - 1] >> spare != 0 {
            return mismatch("tokens beyond the project's places".into());
        }
        for t in &state.timers {
            if t.net >= project.nets.len() || t.timer >= project.nets[t.net].timers.len() {
                return mismatch(format!("timer {} of net {} does not exist", t.timer, t.net));
            }
        }
        for (id, p) in &state.pending {
            let ok = p.net < project.nets.len()
                && match &p.kind {
                    PendingKind::Call { program, function } => project
                        .programs
                        .get(*program)
                        .is_some_and(|pr| *function < pr.functions.len()),
                    PendingKind::Command { .. } => true,
                    PendingKind::Question { ask } => {
                        p.net < project.nets.len() && *ask < project.nets[p.net].asks.len()
                    }
                };
            if !ok || *id >= state.next_id {
                return mismatch(format!("pending id {id} does not fit the project"));
            }
        }
        if state.locked.iter().any(|&v| v >= project.vehicles.len()) {
            return mismatch("a vehicle locked out that the project does not have".into());
        }
        if state
            .queue
            .iter()
            .flatten()
            .any(|q| q.target.is_some_and(|t| t >= project.nets.len()))
        {
            return mismatch("a queued event targets a net that does not exist".into());
        }
        Ok(Player::with_state(project, state))
    }

    /// Puts the verifier's oracle in charge of guards and arguments that
    /// read parameters the verifier does not know (see [`Oracle`]); `None`
    /// restores evaluation.
    pub fn set_oracle(&mut self, oracle: Option<Oracle>) {
        self.oracle = oracle;
    }

    /// The verifier's restore: puts `state` (built by the verifier for
    /// this project, so not checked again) in place of the player's own and
    /// an oracle giving `answers`, keeping the buffers of both, so that
    /// millions of steps allocate little. From then on only firings and
    /// faults are recorded.
    /// `pending` numbers `state`'s pending calls: the same number twice
    /// means the same calls (the copy is then skipped when the player has
    /// not changed its own since).
    pub(crate) fn reset_for_verifier(&mut self, state: &State, pending: u64, answers: &[bool]) {
        let s = &mut self.state;
        s.now = state.now;
        s.marking.clone_from(&state.marking);
        s.active.clone_from(&state.active);
        s.timers.clone_from(&state.timers);
        for (q, from) in s.queue.iter_mut().zip(&state.queue) {
            // Empty between inputs, both: nothing to do then.
            if !q.is_empty() || !from.is_empty() {
                q.clear();
                q.extend(from.iter().cloned());
            }
        }
        s.lockout = state.lockout;
        s.locked.clone_from(&state.locked);
        match self.pending_from {
            // The same calls as the last restore's: as the steps since left
            // them. A step never changes an entry: it adds calls (ids from
            // `next_id` on) and removes some. Put back only what changed.
            Some((p, len, next)) if p == pending => {
                if len != s.pending.len() || next != s.next_id {
                    if next != s.next_id {
                        drop(s.pending.split_off(&next));
                    }
                    if s.pending.len() != state.pending.len() {
                        for (id, p) in &state.pending {
                            s.pending.entry(*id).or_insert_with(|| p.clone());
                        }
                    }
                }
            }
            _ => {
                if s.pending != state.pending {
                    s.pending.clone_from(&state.pending);
                }
            }
        }
        self.pending_from = Some((pending, state.pending.len(), state.next_id));
        s.next_id = state.next_id;
        s.next_timer_seq = state.next_timer_seq;
        self.effects.clear();
        self.changed = false;
        self.firings_only = true;
        match &mut self.oracle {
            Some(o) => {
                o.answers.clear();
                o.answers.extend_from_slice(answers);
                o.asked = 0;
                o.questions.clear();
                o.open(false);
            }
            None => self.oracle = Some(Oracle::new(answers.to_vec())),
        }
    }

    /// Whether effects other than firings and faults are recorded.
    fn records(&self) -> bool {
        !self.firings_only
    }

    /// An outside event dropped, with the category it was handled under
    /// (recorded unless only firings are).
    fn drop_outside(&mut self, now: Micros, event: &Event, category: Category, reason: DropReason) {
        if self.records() {
            self.effects.push(Effect::Dropped {
                time: now,
                event: Event {
                    name: event.name.clone(),
                    category,
                    params: event.params.clone(),
                },
                reason,
            });
        }
    }

    /// The oracle, with the questions it was asked.
    pub fn oracle(&self) -> Option<&Oracle> {
        self.oracle.as_ref()
    }

    /// The project played.
    pub fn project(&self) -> &Arc<Project> {
        &self.project
    }

    /// A copy of the whole state.
    pub fn snapshot(&self) -> State {
        self.state.clone()
    }

    /// The state, borrowed.
    pub fn state(&self) -> &State {
        &self.state
    }

    /// The digest of the whole state (see [`Digest`]).
    pub fn digest(&self) -> Digest {
        digest::digest(&self.state)
    }

    /// The effects produced since the last drain, in order.
    #[must_use = "effects are what the player asks the world to do"]
    pub fn effects(&mut self) -> std::vec::Drain<'_, Effect> {
        self.effects.drain(..)
    }

    /// The effects recorded since the verifier's last restore, in place.
    pub(crate) fn recorded(&self) -> &[Effect] {
        &self.effects
    }

    /// The earliest timer deadline, if a timer runs: call [`Player::advance`]
    /// then.
    pub fn next_deadline(&self) -> Option<Micros> {
        self.state.timers.first().map(|t| t.deadline)
    }

    /// Whether the catastrophic lockout of the whole team (of the one
    /// vehicle, without `[[vehicle]]`) is on.
    pub fn locked_out(&self) -> bool {
        self.state.lockout
    }

    /// Whether a vehicle's events are locked out: the team's lockout, or
    /// one its own catastrophic event started.
    pub fn vehicle_locked_out(&self, vehicle: VehicleId) -> bool {
        self.state.locks(Some(vehicle))
    }

    /// Whether a net is active.
    pub fn is_active(&self, net: NetId) -> bool {
        self.state.active[net]
    }

    /// Whether a place of a net is marked.
    pub fn is_marked(&self, net: NetId, place: PlaceRef) -> bool {
        self.state.marked(self.project.flat(net, place))
    }

    /// Lets time pass to `now`: every timer whose deadline is ≤ now fires, in
    /// deadline order (ties in start order), each handled at its deadline.
    pub fn advance(&mut self, now: Micros) {
        let project = Arc::clone(&self.project);
        self.expire_timers(&project, now);
        self.state.now = self.state.now.max(now);
    }

    /// Handles one occurrence of an event at `now` (after the timers due by
    /// then), and runs the consequences to completion. The project's declared
    /// category for the event, if any, replaces the event's own.
    pub fn handle(&mut self, event: &Event, now: Micros) {
        let project = Arc::clone(&self.project);
        let symbols = Arc::clone(&self.symbols);
        self.expire_timers(&project, now);
        let now = self.state.now.max(now);
        self.state.now = now;
        let info = symbols.get(&event.name);
        let category = match info {
            Some(info) => info.declared,
            None => project.declared_category(&event.name),
        }
        .unwrap_or(event.category);
        // A result or `net_fault` from outside would stand for one the
        // player never produced: dropped, recorded.
        let own = match info {
            Some(info) => info.own,
            None => crate::outside::player_own(&project, &event.name).is_some(),
        };
        if own {
            self.drop_outside(now, event, category, DropReason::Reserved);
            return;
        }
        // The verifier does not know an external event's parameters.
        if let Some(oracle) = &mut self.oracle {
            oracle.open(true);
        }
        let occurred = self.occur(
            &project,
            info,
            &event.name,
            category,
            &event.params,
            None,
            now,
        );
        if let Some(oracle) = &mut self.oracle {
            oracle.open(false);
        }
        if let Err(reason) = occurred {
            self.drop_outside(now, event, category, reason);
        }
        let tainted = category == Category::Catastrophic;
        self.immediates(&project, now, tainted);
        self.run_queue(&project, now, 1);
    }

    /// Gives back the outcome of call or command `id` at `now`. It becomes
    /// an event for the net that issued it: `PROGRAM.FUNCTION.done {…}` /
    /// `PROGRAM.FUNCTION.failed {reason}`, `command.ok {verb}` /
    /// `command.failed {verb, reason}`.
    pub fn result(&mut self, id: u64, outcome: Outcome, now: Micros) {
        let project = Arc::clone(&self.project);
        self.expire_timers(&project, now);
        let now = self.state.now.max(now);
        self.state.now = now;
        // A question is answered through `answer`, never by a result.
        let pending = match self.state.pending.get(&id) {
            Some(p) if !matches!(p.kind, PendingKind::Question { .. }) => {
                self.state.pending.remove(&id)
            }
            _ => None,
        };
        let Some(pending) = pending else {
            if self.records() {
                self.effects.push(Effect::LateResult { time: now, id });
            }
            return;
        };
        let symbols = Arc::clone(&self.symbols);
        let (id, params) = match (&pending.kind, outcome) {
            (PendingKind::Call { program, function }, outcome) => {
                let (done, failed) = symbols.results[*program][*function];
                match outcome {
                    Outcome::Done(params) => (done, params),
                    Outcome::Failed(reason) => (
                        failed,
                        Params::from([("reason".to_owned(), Value::Str(reason))]),
                    ),
                }
            }
            (PendingKind::Command { verb }, Outcome::Done(mut params)) => {
                params.insert("verb".into(), Value::Str(verb.clone()));
                (symbols.command_ok, params)
            }
            (PendingKind::Question { .. }, _) => {
                unreachable!("questions are answered, not resulted")
            }
            (PendingKind::Command { verb }, Outcome::Failed(reason)) => (
                symbols.command_failed,
                Params::from([
                    ("reason".to_owned(), Value::Str(reason)),
                    ("verb".to_owned(), Value::Str(verb.clone())),
                ]),
            ),
        };
        let info = symbols.info(id);
        self.push_result(
            pending.net,
            info.name.clone(),
            info.declared,
            params,
            pending.catastrophic,
        );
        self.run_queue(&project, now, 0);
    }

    /// Gives the operator's answer `choice` to question `id` at `now` (after
    /// the timers due by then: an answer at or after the question's deadline
    /// is late). If the question is pending and offers `choice`, the event
    /// `NAME.CHOICE {choice}` goes to the asking net and the timeout is
    /// cancelled; otherwise nothing is delivered and the refusal is
    /// recorded ([`Effect::AnswerRefused`]) and returned.
    pub fn answer(&mut self, id: u64, choice: &str, now: Micros) -> Result<(), AnswerRefusal> {
        let project = Arc::clone(&self.project);
        self.expire_timers(&project, now);
        let now = self.state.now.max(now);
        self.state.now = now;
        let refused = |this: &mut Self, reason| {
            if this.records() {
                this.effects.push(Effect::AnswerRefused {
                    time: now,
                    id,
                    choice: choice.to_owned(),
                    reason,
                });
            }
            Err(reason)
        };
        let Some(Pending {
            net,
            kind: PendingKind::Question { ask },
            catastrophic,
        }) = self.state.pending.get(&id).cloned()
        else {
            return refused(self, AnswerRefusal::NotPending);
        };
        let spec = &project.nets[net].asks[ask];
        if !spec.choices.iter().any(|c| c == choice) {
            return refused(self, AnswerRefusal::NotOffered);
        }
        self.state.pending.remove(&id);
        let before = self.state.timers.len();
        self.state
            .timers
            .retain(|x| !(x.net == net && x.timer == spec.timer));
        if self.state.timers.len() != before && self.records() {
            self.effects.push(Effect::TimerCancelled {
                time: now,
                net,
                timer: spec.timer,
            });
        }
        if self.records() {
            self.effects.push(Effect::Answered {
                time: now,
                id,
                net,
                choice: choice.to_owned(),
            });
        }
        let params = Params::from([("choice".to_owned(), Value::Str(choice.to_owned()))]);
        let name = spec.answer_event(choice);
        let declared = match self.symbols.get(&name) {
            Some(info) => info.declared,
            None => project.declared_category(&name),
        };
        self.push_result(net, name, declared, params, catastrophic);
        self.run_queue(&project, now, 0);
        Ok(())
    }

    /// Queues a result (a call's, a command's, an answer) for net `net`:
    /// catastrophic if the catastrophic reaction issued it, else the
    /// declared category or nominal.
    /// `declared`: the project's declared category for `name`.
    fn push_result(
        &mut self,
        net: NetId,
        name: String,
        declared: Option<Category>,
        params: Params,
        catastrophic: bool,
    ) {
        let category = if catastrophic {
            Category::Catastrophic
        } else {
            declared.unwrap_or(Category::Nominal)
        };
        self.state.push(Queued {
            event: Event {
                name,
                category,
                params,
            },
            target: Some(net),
        });
    }

    /// The questions pending, in id order: (id, net, ask).
    pub fn questions(&self) -> impl Iterator<Item = (u64, NetId, usize)> + '_ {
        self.state
            .pending
            .iter()
            .filter_map(|(id, p)| match p.kind {
                PendingKind::Question { ask } => Some((*id, p.net, ask)),
                _ => None,
            })
    }

    /// Marks or empties global place `global` from outside the nets, then
    /// runs immediate transitions. The verifier uses it to stand for the
    /// other nets when it checks one net alone.
    pub fn set_global(&mut self, global: usize, marked: bool, now: Micros) {
        let project = Arc::clone(&self.project);
        self.expire_timers(&project, now);
        let now = self.state.now.max(now);
        self.state.now = now;
        if global < project.globals.len() && self.state.marked(global) != marked {
            self.state.set(global, marked);
            self.push_marking(now, None);
            self.changed = true;
            self.immediates(&project, now, false);
            self.run_queue(&project, now, 0);
        }
    }

    /// Fires the timers due by `now`, each at its own deadline. A timer that
    /// its own expiry restarts with a zero duration would expire again and
    /// again at one instant: more than `steps_per_input` expiries at one
    /// instant is an overflow fault, and the timers still due then are
    /// dropped, recorded.
    fn expire_timers(&mut self, project: &Project, now: Micros) {
        let mut instant = None;
        let mut expiries = 0usize;
        while let Some(first) = self.state.timers.first() {
            if first.deadline > now {
                break;
            }
            let timer = self.state.timers.remove(0);
            let time = self.state.now.max(timer.deadline);
            self.state.now = time;
            if instant == Some(time) {
                expiries += 1;
            } else {
                instant = Some(time);
                expiries = 1;
            }
            if expiries > project.limits.steps_per_input {
                self.effects.push(Effect::Fault {
                    time,
                    fault: Fault::Overflow {
                        steps: expiries - 1,
                    },
                });
                let mut due = vec![timer];
                while self
                    .state
                    .timers
                    .first()
                    .is_some_and(|t| t.deadline <= time)
                {
                    due.push(self.state.timers.remove(0));
                }
                for t in &due {
                    if self.records() {
                        self.effects.push(Effect::Dropped {
                            time,
                            event: timer_event(&self.symbols, t),
                            reason: DropReason::Overflow,
                        });
                    }
                }
                continue;
            }
            if self.records() {
                self.effects.push(Effect::TimerExpired {
                    time,
                    net: timer.net,
                    timer: timer.timer,
                });
            }
            self.question_timed_out(project, timer.net, timer.timer, time);
            self.state.push(Queued {
                event: timer_event(&self.symbols, &timer),
                target: Some(timer.net),
            });
            self.run_queue(project, time, 0);
        }
    }

    /// Handles queued events, highest category first, FIFO within one.
    fn run_queue(&mut self, project: &Project, now: Micros, mut steps: usize) {
        while let Some(q) = self.state.pop() {
            steps += 1;
            if steps > project.limits.steps_per_input {
                self.effects.push(Effect::Fault {
                    time: now,
                    fault: Fault::Overflow { steps: steps - 1 },
                });
                if self.records() {
                    self.effects.push(Effect::Dropped {
                        time: now,
                        event: q.event,
                        reason: DropReason::Overflow,
                    });
                }
                while let Some(q) = self.state.pop() {
                    if self.records() {
                        self.effects.push(Effect::Dropped {
                            time: now,
                            event: q.event,
                            reason: DropReason::Overflow,
                        });
                    }
                }
                return;
            }
            let category = q.event.category;
            let symbols = Arc::clone(&self.symbols);
            if let Err(reason) = self.occur(
                project,
                symbols.get(&q.event.name),
                &q.event.name,
                category,
                &q.event.params,
                q.target,
                now,
            ) {
                if self.records() {
                    self.effects.push(Effect::Dropped {
                        time: now,
                        event: q.event,
                        reason,
                    });
                }
            }
            self.immediates(project, now, category == Category::Catastrophic);
        }
    }

    fn drop_reason(
        &self,
        category: Category,
        target: Option<NetId>,
        vehicle: Option<VehicleId>,
    ) -> Option<DropReason> {
        if category != Category::Catastrophic && self.state.locks(vehicle) {
            Some(DropReason::Lockout)
        } else if target.is_some_and(|t| !self.state.active[t]) {
            Some(DropReason::NetInactive)
        } else {
            None
        }
    }

    /// One occurrence of an event: fires every waiting transition enabled at
    /// its arrival, each at most once, first declared first; or says why the
    /// event is dropped.
    /// `info`: what the project's symbols know of `name` (`None`: a name
    /// the project does not know, which no transition waits for).
    #[allow(clippy::too_many_arguments)]
    fn occur(
        &mut self,
        project: &Project,
        info: Option<&EventInfo>,
        name: &str,
        category: Category,
        params: &Params,
        target: Option<NetId>,
        now: Micros,
    ) -> Result<(), DropReason> {
        let vehicle = match info {
            Some(info) if target.is_none() && name != names::NET_FAULT => info.vehicle,
            _ => event_vehicle(project, name, params, target),
        };
        if let Some(reason) = self.drop_reason(category, target, vehicle) {
            return Err(reason);
        }
        let Some(waiting) = info.and_then(|i| i.waiting.as_ref()) else {
            return Ok(());
        };
        let mut candidates = std::mem::take(&mut self.candidates);
        candidates.clear();
        for &(n, t, own_timer) in waiting {
            if target.is_some_and(|x| x != n) || !self.state.active[n] {
                continue;
            }
            // A net's own timer is heard from that timer only, never from
            // an event that bears its name.
            if target.is_none() && own_timer {
                continue;
            }
            let tr = &project.nets[n].transitions[t];
            if !tr.flat_inputs.iter().all(|&p| self.state.marked(p)) {
                continue;
            }
            if let Some(guard) = &tr.guard {
                let verdict = match guard.expr.holds(params) {
                    Err(crate::expr::EvalError::MissingParam(_)) if self.oracle.is_some() => {
                        match self.oracle.as_mut().map(|o| o.guard(&guard.expr, params)) {
                            Some(oracle::GuardAnswer::Holds) => Ok(true),
                            // As in flight: the guard cannot be evaluated.
                            Some(oracle::GuardAnswer::Missing(p)) => {
                                Err(crate::expr::EvalError::MissingParam(p))
                            }
                            _ => Ok(false),
                        }
                    }
                    verdict => verdict,
                };
                match verdict {
                    Ok(true) => {}
                    Ok(false) => continue,
                    Err(e) => {
                        self.effects.push(Effect::Fault {
                            time: now,
                            fault: Fault::Guard {
                                net: n,
                                transition: t,
                                message: e.to_string(),
                            },
                        });
                        continue;
                    }
                }
            }
            candidates.push((n, t));
        }
        if !candidates.is_empty() {
            self.consumed.iter_mut().for_each(|w| *w = 0);
            let tainted = category == Category::Catastrophic;
            for &(n, t) in &candidates {
                let tr = &project.nets[n].transitions[t];
                let still = self.state.active[n]
                    && tr.flat_inputs.iter().all(|&p| {
                        self.state.marked(p) && self.consumed[p / 64] & (1 << (p % 64)) == 0
                    });
                if still {
                    if let Firing::Fired = self.fire(project, n, t, params, now, tainted) {
                        if tainted && !self.state.locks(vehicle) {
                            match vehicle {
                                None => self.state.lockout = true,
                                Some(v) => {
                                    let at = self.state.locked.partition_point(|&x| x < v);
                                    self.state.locked.insert(at, v);
                                }
                            }
                            if self.records() {
                                self.effects.push(Effect::Lockout {
                                    time: now,
                                    event: name.to_owned(),
                                    net: n,
                                    transition: t,
                                    vehicle,
                                });
                            }
                        }
                        self.run_actions(project, n, t, params, now, tainted);
                    }
                }
            }
            self.queue_net_faults(project);
        }
        self.candidates = candidates;
        Ok(())
    }

    /// Fires a transition's token game (not its actions), or rejects it
    /// whole.
    fn fire(
        &mut self,
        project: &Project,
        n: NetId,
        t: TransitionId,
        params: &Params,
        now: Micros,
        tainted: bool,
    ) -> Firing {
        let tr = &project.nets[n].transitions[t];
        // Arguments are evaluated before anything changes, so a bad one
        // rejects the firing whole.
        for action in &tr.actions {
            let args = match action {
                Action::Emit { args, .. }
                | Action::Call { args, .. }
                | Action::Command { args, .. } => args,
                _ => continue,
            };
            for (key, e) in args {
                // The common argument `$p`: checked without a copy of its
                // value (what evaluating it comes to, below).
                let fast = match e {
                    crate::expr::Expr::Param { name, .. } => {
                        match (params.get(name.as_str()), &mut self.oracle) {
                            (Some(v), _) if v.is_finite() => Some(None),
                            (None, Some(oracle)) => Some(
                                oracle
                                    .argument(e, params)
                                    .map(crate::expr::EvalError::MissingParam),
                            ),
                            _ => None,
                        }
                    }
                    _ => None,
                };
                let err = match fast {
                    Some(None) => continue,
                    Some(Some(err)) => err,
                    None => match (e.eval(params), &mut self.oracle) {
                        (Ok(_), _) => continue,
                        // The verifier does not know the parameter: if the
                        // external event is said to lack it, the firing is
                        // rejected as in flight; else the argument is left out.
                        (Err(crate::expr::EvalError::MissingParam(_)), Some(oracle)) => {
                            match oracle.argument(e, params) {
                                Some(p) => crate::expr::EvalError::MissingParam(p),
                                None => continue,
                            }
                        }
                        (Err(err), _) => err,
                    },
                };
                let message = format!("argument `{key}`: {err}");
                self.effects.push(Effect::Fault {
                    time: now,
                    fault: Fault::BadArgument {
                        net: n,
                        transition: t,
                        message: message.clone(),
                    },
                });
                self.net_fault(project, n, t, None, &message, now, tainted);
                return Firing::Rejected;
            }
        }
        if let Some(&p) = tr
            .flat_outputs
            .iter()
            .find(|&&p| self.state.marked(p) && !tr.flat_inputs.contains(&p))
        {
            self.effects.push(Effect::Fault {
                time: now,
                fault: Fault::DoubleToken {
                    net: n,
                    transition: t,
                    place: p,
                },
            });
            self.net_fault(project, n, t, Some(p), "double token", now, tainted);
            return Firing::Rejected;
        }
        let mut globals = false;
        for (&p, r) in tr.flat_inputs.iter().zip(&tr.inputs) {
            self.state.set(p, false);
            self.consumed[p / 64] |= 1 << (p % 64);
            globals |= matches!(r, PlaceRef::Global(_));
        }
        for (&p, r) in tr.flat_outputs.iter().zip(&tr.outputs) {
            self.state.set(p, true);
            globals |= matches!(r, PlaceRef::Global(_));
        }
        self.changed = true;
        self.effects.push(Effect::Fired {
            time: now,
            net: n,
            transition: t,
        });
        self.push_marking(now, Some(n));
        if globals {
            self.push_marking(now, None);
        }
        Firing::Fired
    }

    #[allow(clippy::too_many_arguments)]
    fn net_fault(
        &mut self,
        project: &Project,
        n: NetId,
        t: TransitionId,
        place: Option<usize>,
        reason: &str,
        _now: Micros,
        tainted: bool,
    ) {
        let net = &project.nets[n];
        let mut params = Params::from([
            ("net".to_owned(), Value::Str(net.name.clone())),
            (
                "transition".to_owned(),
                Value::Str(net.transitions[t].name.clone()),
            ),
            ("reason".to_owned(), Value::Str(reason.to_owned())),
        ]);
        if let Some(p) = place {
            params.insert("place".into(), Value::Str(flat_place_name(project, p)));
        }
        self.net_faults.push((params, tainted));
    }

    /// Queues the `net_fault`s of the occurrence just handled. One raised
    /// while a catastrophic event was being handled is catastrophic only if
    /// the catastrophic reaction is running (a catastrophic transition fired,
    /// so the lockout is on: the team's, or that of the faulty net's
    /// vehicle, whose event the `net_fault` then is): a rejected firing alone is not a catastrophic
    /// reaction and must not start the lockout through a net that hears
    /// `net_fault`. Otherwise it has its declared category (safety by
    /// default).
    fn queue_net_faults(&mut self, project: &Project) {
        for (params, tainted) in std::mem::take(&mut self.net_faults) {
            // The faulty net's vehicle (or the team): its lockout is the
            // reaction running.
            let vehicle = event_vehicle(project, names::NET_FAULT, &params, None);
            let category = if tainted && self.state.locks(vehicle) {
                Category::Catastrophic
            } else {
                self.symbols
                    .info(self.symbols.net_fault)
                    .declared
                    .unwrap_or(Category::Safety)
            };
            self.state.push(Queued {
                event: Event {
                    name: names::NET_FAULT.to_owned(),
                    category,
                    params,
                },
                target: None,
            });
        }
    }

    fn run_actions(
        &mut self,
        project: &Project,
        n: NetId,
        t: TransitionId,
        params: &Params,
        now: Micros,
        tainted: bool,
    ) {
        let eval = |args: &[(String, crate::expr::Expr)]| -> Params {
            // Already checked in `fire`: evaluation cannot fail here.
            args.iter()
                .filter(|(_, e)| match e {
                    // Left out, as its evaluation's error would be (without
                    // building the error).
                    crate::expr::Expr::Param { name, .. } => params.contains_key(name.as_str()),
                    _ => true,
                })
                .filter_map(|(k, e)| e.eval(params).ok().map(|v| (k.clone(), v)))
                .collect()
        };
        for action in &project.nets[n].transitions[t].actions {
            match action {
                Action::Activate(m) => {
                    if self.state.active[*m] {
                        if self.records() {
                            self.effects.push(Effect::Ignored {
                                time: now,
                                net: *m,
                                action: "activate",
                                by: n,
                            });
                        }
                    } else {
                        self.activate(project, *m, now);
                    }
                }
                Action::Deactivate(m) => {
                    if self.state.active[*m] {
                        self.deactivate(project, *m, now);
                    } else {
                        if self.records() {
                            self.effects.push(Effect::Ignored {
                                time: now,
                                net: *m,
                                action: "deactivate",
                                by: n,
                            });
                        }
                    }
                }
                Action::Emit { event, args } => {
                    let category = if tainted {
                        Category::Catastrophic
                    } else {
                        match self.symbols.get(event) {
                            Some(info) => info.declared,
                            None => project.declared_category(event),
                        }
                        .unwrap_or(Category::Nominal)
                    };
                    let event = Event {
                        name: event.clone(),
                        category,
                        params: eval(args),
                    };
                    if self.records() {
                        self.effects.push(Effect::Emitted {
                            time: now,
                            net: n,
                            event: event.clone(),
                        });
                    }
                    self.state.push(Queued {
                        event,
                        target: None,
                    });
                }
                Action::Timer { timer, after } => {
                    self.start_timer(n, *timer, *after, now, tainted);
                }
                Action::Cancel { timer } => {
                    let before = self.state.timers.len();
                    self.state
                        .timers
                        .retain(|x| !(x.net == n && x.timer == *timer));
                    if self.state.timers.len() != before && self.records() {
                        self.effects.push(Effect::TimerCancelled {
                            time: now,
                            net: n,
                            timer: *timer,
                        });
                    }
                }
                Action::Call {
                    program,
                    function,
                    args,
                } => {
                    let id = self.take_id();
                    self.state.pending.insert(
                        id,
                        Pending {
                            net: n,
                            kind: PendingKind::Call {
                                program: *program,
                                function: *function,
                            },
                            catastrophic: tainted,
                        },
                    );
                    if self.records() {
                        self.effects.push(Effect::Call {
                            time: now,
                            id,
                            net: n,
                            program: *program,
                            function: *function,
                            args: eval(args),
                            vehicle: project.nets[n].vehicle,
                        });
                    }
                }
                Action::Ask {
                    ask,
                    question,
                    after,
                } => self.ask(project, n, *ask, question, *after, now, tainted),
                Action::Command {
                    verb,
                    args,
                    vehicle,
                } => {
                    let id = self.take_id();
                    self.state.pending.insert(
                        id,
                        Pending {
                            net: n,
                            kind: PendingKind::Command { verb: verb.clone() },
                            catastrophic: tainted,
                        },
                    );
                    if self.records() {
                        self.effects.push(Effect::Command {
                            time: now,
                            id,
                            net: n,
                            verb: verb.clone(),
                            args: eval(args),
                            vehicle: *vehicle,
                        });
                    }
                }
            }
        }
    }

    /// Starts (or restarts) timer `timer` of net `n`.
    fn start_timer(&mut self, n: NetId, timer: usize, after: Micros, now: Micros, tainted: bool) {
        let before = self.state.timers.len();
        self.state
            .timers
            .retain(|x| !(x.net == n && x.timer == timer));
        let restarted = self.state.timers.len() != before;
        let deadline = now.saturating_add(after);
        let seq = self.state.next_timer_seq;
        self.state.next_timer_seq += 1;
        let at = self
            .state
            .timers
            .partition_point(|x| (x.deadline, x.seq) <= (deadline, seq));
        self.state.timers.insert(
            at,
            Timer {
                net: n,
                timer,
                deadline,
                seq,
                catastrophic: tainted,
            },
        );
        if self.records() {
            self.effects.push(Effect::TimerStarted {
                time: now,
                net: n,
                timer,
                deadline,
                restarted,
            });
        }
    }

    #[allow(clippy::too_many_arguments)]
    /// Asks question `ask` of net `n`: a question of that name still
    /// pending is forgotten (its answer will be refused), the new one is
    /// pending and its timeout timer (re)started.
    fn ask(
        &mut self,
        project: &Project,
        n: NetId,
        ask: usize,
        question: &str,
        after: Micros,
        now: Micros,
        tainted: bool,
    ) {
        let asked = |p: &Pending| p.net == n && p.kind == PendingKind::Question { ask };
        if let Some(old) = self
            .state
            .pending
            .iter()
            .find(|(_, p)| asked(p))
            .map(|(id, _)| *id)
        {
            self.state.pending.remove(&old);
            if self.records() {
                self.effects.push(Effect::Forgotten {
                    time: now,
                    id: old,
                    net: n,
                });
            }
        }
        let id = self.take_id();
        self.state.pending.insert(
            id,
            Pending {
                net: n,
                kind: PendingKind::Question { ask },
                catastrophic: tainted,
            },
        );
        let spec = &project.nets[n].asks[ask];
        if self.records() {
            self.effects.push(Effect::Ask {
                time: now,
                id,
                net: n,
                ask,
                question: question.to_owned(),
                choices: spec.choices.clone(),
                deadline: now.saturating_add(after),
            });
        }
        self.start_timer(n, spec.timer, after, now, tainted);
    }

    /// The question of net `net` whose timeout timer is `timer`, if one is
    /// pending: it is over, unanswered.
    fn question_timed_out(&mut self, project: &Project, net: NetId, timer: usize, time: Micros) {
        let id = self.state.pending.iter().find_map(|(id, p)| match p.kind {
            PendingKind::Question { ask }
                if p.net == net && project.nets[net].asks[ask].timer == timer =>
            {
                Some(*id)
            }
            _ => None,
        });
        if let Some(id) = id {
            self.state.pending.remove(&id);
            if self.records() {
                self.effects.push(Effect::Unanswered { time, id, net });
            }
        }
    }

    fn take_id(&mut self) -> u64 {
        let id = self.state.next_id;
        self.state.next_id += 1;
        id
    }

    fn activate(&mut self, project: &Project, m: NetId, now: Micros) {
        // A net can leave work behind while inactive: actions that follow
        // its own `deactivate` in one firing. The new activation starts
        // clean, inheriting none of it.
        self.forget_work(m, now);
        self.state.active[m] = true;
        let offset = project.place_offsets[m];
        for (i, place) in project.nets[m].places.iter().enumerate() {
            self.state.set(offset + i, place.initial);
        }
        self.changed = true;
        if self.records() {
            self.effects.push(Effect::Activated { time: now, net: m });
        }
        self.push_marking(now, Some(m));
    }

    fn deactivate(&mut self, project: &Project, m: NetId, now: Micros) {
        self.state.active[m] = false;
        let offset = project.place_offsets[m];
        for i in 0..project.nets[m].places.len() {
            let p = offset + i;
            self.state.set(p, false);
            self.consumed[p / 64] |= 1 << (p % 64);
        }
        self.forget_work(m, now);
        self.changed = true;
        if self.records() {
            self.effects.push(Effect::Deactivated { time: now, net: m });
        }
        self.push_marking(now, Some(m));
    }

    /// Cancels net `m`'s timers, forgets its pending calls and commands, and
    /// drops the results and expiries already queued for it.
    fn forget_work(&mut self, m: NetId, now: Micros) {
        // In place, in timer then id order (no list of what goes per call).
        let records = self.records();
        let effects = &mut self.effects;
        self.state.timers.retain(|x| {
            if x.net != m {
                return true;
            }
            if records {
                effects.push(Effect::TimerCancelled {
                    time: now,
                    net: m,
                    timer: x.timer,
                });
            }
            false
        });
        if self.state.pending.values().any(|p| p.net == m) {
            self.state.pending.retain(|&id, p| {
                if p.net != m {
                    return true;
                }
                if records {
                    effects.push(Effect::Forgotten {
                        time: now,
                        id,
                        net: m,
                    });
                }
                false
            });
        }
        // Results and timer expiries already queued for it are dropped now,
        // so that a later activation does not receive them.
        for queue in self.state.queue.iter_mut() {
            if !queue.iter().any(|q| q.target == Some(m)) {
                continue;
            }
            let mut kept = std::collections::VecDeque::with_capacity(queue.len());
            for q in queue.drain(..) {
                if q.target == Some(m) {
                    if records {
                        self.effects.push(Effect::Dropped {
                            time: now,
                            event: q.event,
                            reason: DropReason::NetInactive,
                        });
                    }
                } else {
                    kept.push_back(q);
                }
            }
            *queue = kept;
        }
    }

    /// Fires immediate transitions, first declared first, until none is
    /// enabled or the bound on firings per step is reached.
    fn immediates(&mut self, project: &Project, now: Micros, tainted: bool) {
        if !std::mem::take(&mut self.changed) {
            return;
        }
        let mut firings = 0usize;
        let mut rejected: Vec<(NetId, TransitionId)> = Vec::new();
        let symbols = Arc::clone(&self.symbols);
        'scan: loop {
            for immediate in &symbols.immediates {
                let (n, t) = (immediate.net, immediate.transition);
                if !self.state.active[n]
                    || !immediate.enabled(&self.state.marking)
                    || rejected.contains(&(n, t))
                {
                    continue;
                }
                firings += 1;
                if firings > project.limits.firings_per_step {
                    self.effects.push(Effect::Fault {
                        time: now,
                        fault: Fault::Livelock {
                            net: n,
                            transition: t,
                            firings: firings - 1,
                        },
                    });
                    self.changed = false;
                    return;
                }
                match self.fire(project, n, t, &Params::new(), now, tainted) {
                    Firing::Fired => {
                        rejected.clear();
                        self.run_actions(project, n, t, &Params::new(), now, tainted);
                        continue 'scan;
                    }
                    Firing::Rejected => {
                        self.queue_net_faults(project);
                        rejected.push((n, t));
                    }
                }
            }
            break;
        }
        self.changed = false;
    }

    fn push_marking(&mut self, now: Micros, net: Option<NetId>) {
        if !self.records() {
            return;
        }
        let (offset, len) = match net {
            Some(n) => (
                self.project.place_offsets[n],
                self.project.nets[n].places.len(),
            ),
            None => (0, self.project.globals.len()),
        };
        let marked: Marked = (0..len)
            .filter(|i| self.state.marked(offset + i))
            .map(|i| i as u16)
            .collect();
        let active = net.is_none_or(|n| self.state.active[n]);
        self.effects.push(Effect::Marking {
            time: now,
            net,
            marked,
            active,
        });
    }
}

/// The event a timer's expiry delivers to its net: its name, no parameters,
/// catastrophic if the catastrophic reaction started it, else the declared
/// category or nominal.
fn timer_event(symbols: &Symbols, timer: &Timer) -> Event {
    let info = symbols.info(symbols.timers[timer.net][timer.timer]);
    let category = if timer.catastrophic {
        Category::Catastrophic
    } else {
        info.declared.unwrap_or(Category::Nominal)
    };
    Event {
        name: info.name.clone(),
        category,
        params: Params::new(),
    }
}

/// The name of a flat place index: `@global` or `NET.place`.
pub fn flat_place_name(project: &Project, p: usize) -> String {
    if p < project.globals.len() {
        return format!("@{}", project.globals[p].name);
    }
    let n = project.place_offsets.partition_point(|&o| o <= p) - 1;
    format!(
        "{}.{}",
        project.nets[n].name,
        project.nets[n].places[p - project.place_offsets[n]].name
    )
}

/// The vehicle an occurrence belongs to, whose lockout drops it: a result's
/// or timer's net's vehicle (`target`), a `net_fault`'s faulty net's, or the
/// vehicle its name carries (`EVENT@VEHICLE`); `None` for a team event and
/// in a project without `[[vehicle]]`.
pub(crate) fn event_vehicle(
    project: &Project,
    name: &str,
    params: &Params,
    target: Option<NetId>,
) -> Option<VehicleId> {
    if project.vehicles.is_empty() {
        return None;
    }
    if let Some(t) = target {
        return project.nets[t].vehicle;
    }
    if name == names::NET_FAULT {
        return match params.get("net") {
            Some(Value::Str(net)) => project.vehicle_event(net).map(|(_, v)| v),
            _ => None,
        };
    }
    project.vehicle_event(name).map(|(_, v)| v)
}
