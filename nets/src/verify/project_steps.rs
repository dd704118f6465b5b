//! What one input did to a state, kept so that a state that differs only in
//! what the player cannot read need not run it again.
//!
//! A step of the project explorer runs the player on a concrete state (see
//! [`super::project`]). Its outcome depends on the marking, the active
//! nets, the lockouts, which timers run (each net's, with its duration and
//! category) and which results are pending (each net's, in the order they
//! were issued), and on the input. It does not depend on how the pending
//! calls of *different* nets interleave in issue order, nor on the start
//! order of timers other than the one expiring, nor on the ids the calls
//! hold: the player reads a call by its id only to answer it, and a timer
//! by its net and name. Abstract states keep those orders (the player's
//! later steps report them), so many states share one [`projection`]: about
//! one in seven on `examples/uav-flight-test`.
//!
//! A step's [`Delta`] says what the state became in those terms: the new
//! marking, active nets and lockouts whole; each timer and pending call
//! after the step either one of before (named by net and timer, or by net
//! and rank among the net's calls) or a new one (its id or start order
//! counted from the state's next). [`Delta::apply`] rebuilds, from another
//! concrete state with the same projection, exactly the state the player
//! would have left.
//!
//! Pure data: no player runs here. The explorer checks every cached outcome
//! against the player when asked ([`super::project::Options`]'s
//! `check_steps`, which the tests set).

use crate::model::{NetId, VehicleId};
use crate::player::{Pending, PendingKind, State, Timer};

/// The input of a step as the projection names it.
pub(super) enum Ident {
    /// External event number.
    Event(usize),
    /// The timer of this net and index.
    Timer(NetId, usize),
    /// The pending call with this id (named by its net and its rank among
    /// that net's calls), with the failure reason's number (`None`: done).
    Result { id: u64, reason: Option<usize> },
}

/// Writes the projection of the concrete state `s` for input `input` into
/// `out`: everything a step's outcome depends on, without the orders and
/// ids it does not (see the module's text). `None` when the input names a
/// call or timer `s` does not hold (not cached then).
pub(super) fn projection(input: &Ident, s: &State, out: &mut Vec<u8>) -> Option<()> {
    out.clear();
    let u32_ = |out: &mut Vec<u8>, v: usize| out.extend_from_slice(&(v as u32).to_le_bytes());
    match input {
        Ident::Event(i) => {
            out.push(0);
            u32_(out, *i);
        }
        Ident::Timer(net, timer) => {
            out.push(1);
            u32_(out, *net);
            u32_(out, *timer);
        }
        Ident::Result { id, reason } => {
            let p = s.pending.get(id)?;
            out.push(2);
            u32_(out, p.net);
            u32_(out, rank(s, *id, p.net));
            match reason {
                None => out.push(0),
                Some(r) => {
                    out.push(1);
                    u32_(out, *r);
                }
            }
        }
    }
    for w in &s.marking {
        out.extend_from_slice(&w.to_le_bytes());
    }
    out.extend(s.active.iter().map(|&a| u8::from(a)));
    out.push(u8::from(s.lockout));
    u32_(out, s.locked.len());
    for &v in &s.locked {
        u32_(out, v);
    }
    // Timers by net and index (unique: restarting replaces), with what the
    // player reads of them. The expiring one is the input's.
    let mut timers: smallvec::SmallVec<[&Timer; 16]> = s.timers.iter().collect();
    timers.sort_unstable_by_key(|t| (t.net, t.timer));
    u32_(out, timers.len());
    for t in timers {
        u32_(out, t.net);
        u32_(out, t.timer);
        out.extend_from_slice(&t.deadline.to_le_bytes());
        out.push(u8::from(t.catastrophic));
    }
    // Pending calls net by net, each net's in issue order.
    u32_(out, s.pending.len());
    let mut nets: smallvec::SmallVec<[NetId; 16]> = s.pending.values().map(|p| p.net).collect();
    nets.sort_unstable();
    nets.dedup();
    for n in nets {
        for p in s.pending.values().filter(|p| p.net == n) {
            write_pending(p, out);
        }
    }
    Some(())
}

/// The rank of call `id` among the calls of net `net` in `s` (issue order).
fn rank(s: &State, id: u64, net: NetId) -> usize {
    s.pending.range(..id).filter(|(_, p)| p.net == net).count()
}

fn write_pending(p: &Pending, out: &mut Vec<u8>) {
    out.extend_from_slice(&(p.net as u32).to_le_bytes());
    out.push(u8::from(p.catastrophic));
    match &p.kind {
        PendingKind::Call { program, function } => {
            out.push(0);
            out.extend_from_slice(&(*program as u32).to_le_bytes());
            out.extend_from_slice(&(*function as u32).to_le_bytes());
        }
        PendingKind::Command { verb } => {
            out.push(1);
            out.extend_from_slice(&(verb.len() as u32).to_le_bytes());
            out.extend_from_slice(verb.as_bytes());
        }
        PendingKind::Question { ask } => {
            out.push(2);
            out.extend_from_slice(&(*ask as u32).to_le_bytes());
        }
    }
}

/// A timer after a step.
#[derive(Debug, Clone, PartialEq)]
enum TimerAfter {
    /// The one of this net and index before the step, unchanged.
    Old(NetId, usize),
    /// Started by the step: `seq` counts from the state's next start order.
    New(Timer),
}

/// A pending call after a step.
#[derive(Debug, Clone, PartialEq)]
enum PendingAfter {
    /// The net's call of this rank before the step.
    Old(NetId, usize),
    /// Issued by the step, with its id counted from the state's next.
    New(u64, Pending),
}

/// What a step made of a state, in the projection's terms.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Delta {
    marking: Vec<u64>,
    active: Vec<bool>,
    lockout: bool,
    locked: Vec<VehicleId>,
    timers: Vec<TimerAfter>,
    pending: Vec<PendingAfter>,
    next_id: u64,
    next_timer_seq: u64,
}

impl Delta {
    /// What the step from `before` to `after` did; `None` if it cannot be
    /// said in these terms (a timer or call of before changed in place).
    pub fn capture(before: &State, after: &State) -> Option<Delta> {
        let timers = after
            .timers
            .iter()
            .map(|t| {
                if t.seq < before.next_timer_seq {
                    let old = before
                        .timers
                        .iter()
                        .find(|o| o.net == t.net && o.timer == t.timer)?;
                    (old == t).then_some(TimerAfter::Old(t.net, t.timer))
                } else {
                    let mut t = t.clone();
                    t.seq -= before.next_timer_seq;
                    Some(TimerAfter::New(t))
                }
            })
            .collect::<Option<Vec<_>>>()?;
        let mut pending = after
            .pending
            .iter()
            .map(|(&id, p)| {
                if id < before.next_id {
                    let old = before.pending.get(&id)?;
                    (old == p).then(|| PendingAfter::Old(p.net, rank(before, id, p.net)))
                } else {
                    Some(PendingAfter::New(id - before.next_id, p.clone()))
                }
            })
            .collect::<Option<Vec<_>>>()?;
        // In an order of their own (the ids' order across nets is the
        // state's, not the step's).
        pending.sort_by_key(|p| match p {
            PendingAfter::Old(net, rank) => (0, *net, *rank as u64),
            PendingAfter::New(offset, _) => (1, 0, *offset),
        });
        Some(Delta {
            marking: after.marking.clone(),
            active: after.active.clone(),
            lockout: after.lockout,
            locked: after.locked.clone(),
            timers,
            pending,
            next_id: after.next_id.checked_sub(before.next_id)?,
            next_timer_seq: after.next_timer_seq.checked_sub(before.next_timer_seq)?,
        })
    }

    /// The state the step leaves when run on `before` (whose projection is
    /// the one this delta was captured on), written into `out`; `None` if
    /// `before` lacks a timer or call the delta keeps.
    pub fn apply(&self, before: &State, out: &mut State) -> Option<()> {
        out.now = before.now;
        out.marking.clone_from(&self.marking);
        out.active.clone_from(&self.active);
        out.lockout = self.lockout;
        out.locked.clone_from(&self.locked);
        out.queue
            .iter_mut()
            .for_each(std::collections::VecDeque::clear);
        out.timers.clear();
        for t in &self.timers {
            out.timers.push(match t {
                TimerAfter::Old(net, timer) => before
                    .timers
                    .iter()
                    .find(|o| o.net == *net && o.timer == *timer)?
                    .clone(),
                TimerAfter::New(t) => {
                    let mut t = t.clone();
                    t.seq += before.next_timer_seq;
                    t
                }
            });
        }
        out.pending.clear();
        for p in &self.pending {
            match p {
                PendingAfter::Old(net, rank) => {
                    let (id, p) = before
                        .pending
                        .iter()
                        .filter(|(_, p)| p.net == *net)
                        .nth(*rank)?;
                    out.pending.insert(*id, p.clone());
                }
                PendingAfter::New(offset, p) => {
                    out.pending.insert(before.next_id + offset, p.clone());
                }
            }
        }
        out.next_id = before.next_id + self.next_id;
        out.next_timer_seq = before.next_timer_seq + self.next_timer_seq;
        Some(())
    }

    /// Roughly the bytes it holds.
    pub fn size(&self) -> usize {
        std::mem::size_of::<Delta>()
            + self.marking.len() * 8
            + self.active.len()
            + self.locked.len() * 8
            + self.timers.len() * std::mem::size_of::<TimerAfter>()
            + self.pending.len() * (std::mem::size_of::<PendingAfter>() + 16)
    }
}

/// Pending calls as a map, for tests.
#[cfg(test)]
fn calls(list: &[(u64, NetId, usize)]) -> std::collections::BTreeMap<u64, Pending> {
    list.iter()
        .map(|&(id, net, function)| {
            (
                id,
                Pending {
                    net,
                    kind: PendingKind::Call {
                        program: 0,
                        function,
                    },
                    catastrophic: false,
                },
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(pending: &[(u64, NetId, usize)], next_id: u64) -> State {
        State {
            now: 0,
            marking: vec![0b1010],
            active: vec![true, true],
            timers: vec![
                Timer {
                    net: 1,
                    timer: 0,
                    deadline: 7,
                    seq: 4,
                    catastrophic: false,
                },
                Timer {
                    net: 0,
                    timer: 2,
                    deadline: 9,
                    seq: 3,
                    catastrophic: false,
                },
            ],
            queue: Default::default(),
            lockout: false,
            locked: Vec::new(),
            pending: calls(pending),
            next_id,
            next_timer_seq: 5,
        }
    }

    #[test]
    fn calls_of_different_nets_in_another_order_share_a_projection() {
        // Net 0's call 0 then net 1's call 1, against net 1's first.
        let a = state(&[(0, 0, 0), (1, 1, 0)], 2);
        let b = state(&[(0, 1, 0), (1, 0, 0)], 2);
        let (mut pa, mut pb) = (Vec::new(), Vec::new());
        projection(&Ident::Event(3), &a, &mut pa).unwrap();
        projection(&Ident::Event(3), &b, &mut pb).unwrap();
        assert_eq!(pa, pb);
        // The same net's two calls in another order do not.
        let c = state(&[(0, 0, 0), (1, 0, 1)], 2);
        let d = state(&[(0, 0, 1), (1, 0, 0)], 2);
        let (mut pc, mut pd) = (Vec::new(), Vec::new());
        projection(&Ident::Event(3), &c, &mut pc).unwrap();
        projection(&Ident::Event(3), &d, &mut pd).unwrap();
        assert_ne!(pc, pd);
        // A result names its call by net and rank: net 1's only call is
        // id 1 in `a`, id 0 in `b`.
        projection(
            &Ident::Result {
                id: 1,
                reason: None,
            },
            &a,
            &mut pa,
        )
        .unwrap();
        projection(
            &Ident::Result {
                id: 0,
                reason: None,
            },
            &b,
            &mut pb,
        )
        .unwrap();
        assert_eq!(pa, pb);
        assert!(projection(
            &Ident::Result {
                id: 9,
                reason: None
            },
            &a,
            &mut pa
        )
        .is_none());
    }

    #[test]
    fn a_delta_rebuilds_the_step_on_a_state_with_the_same_projection() {
        let a = state(&[(0, 0, 0), (1, 1, 0)], 2);
        let b = state(&[(0, 1, 0), (1, 0, 0)], 2);
        // The step on `a`: net 1's call answered (removed), a new call of
        // net 0, net 0's timer restarted, a place marked.
        let mut after_a = a.clone();
        after_a.pending.remove(&1);
        after_a.pending.insert(2, calls(&[(2, 0, 3)])[&2].clone());
        after_a.next_id = 3;
        after_a.timers.retain(|t| t.net != 0);
        after_a.timers.push(Timer {
            net: 0,
            timer: 2,
            deadline: 20,
            seq: 5,
            catastrophic: false,
        });
        after_a.next_timer_seq = 6;
        after_a.marking[0] |= 1;
        let delta = Delta::capture(&a, &after_a).unwrap();
        // The same step on `b` answers net 1's call, which is id 0 there.
        let mut after_b = State {
            pending: Default::default(),
            ..a.clone()
        };
        delta.apply(&b, &mut after_b).unwrap();
        let mut want = b.clone();
        want.pending.remove(&0);
        want.pending.insert(2, calls(&[(2, 0, 3)])[&2].clone());
        want.next_id = 3;
        want.timers = after_a.timers.clone();
        want.next_timer_seq = 6;
        want.marking[0] |= 1;
        assert_eq!(after_b, want);
        // A timer changed in place cannot be said.
        let mut odd = a.clone();
        odd.timers[0].catastrophic = true;
        assert!(Delta::capture(&a, &odd).is_none());
    }
}
