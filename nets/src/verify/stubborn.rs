//! Partial-order reduction of the project explorer: stubborn sets over the
//! inputs a state offers.
//!
//! Inputs come in *classes*: an external event, a timer of a net, the
//! result of a kind of call, command or question of a net. A step of a
//! class has a *footprint*: what it may read and write. The resources are
//! the places, each net's active flag, each timer, each kind of pending
//! result, and the catastrophic lockouts: one per vehicle and the team's
//! (the order in which timers start and results are awaited is not: a
//! team's reduced key keeps none the player cannot tell apart, see
//! `project_states`). A step fires the transitions its input triggers,
//! then the immediate transitions their outputs may enable, the
//! transitions the events they emit trigger, the nets they activate,
//! `net_fault`'s; its footprint is the union of theirs.
//!
//! Two footprints per class:
//! - the *static* one counts every transition that can fire in the step,
//!   in any state;
//! - the one *read in a state* counts only the transitions that can fire
//!   from that state: their net active (or activated earlier in the step)
//!   and every input place marked (or marked earlier in the step). Each
//!   transition left out lacks a condition — one input place unmarked or
//!   its net inactive — and the classes that may fulfil it (that may mark
//!   that place, activate that net) are its *enablers in the state*.
//!
//! The lockouts follow the player: an occurrence of vehicle V (an event
//! `E@V`, a timer or result of one of V's instances, their `net_fault`) is
//! dropped when V or the team is locked out, one of the team (a team
//! event, a team net's timer or result) when the team is. So a step reads
//! the team's lockout and that of the vehicle of every occurrence it may
//! handle that something waits for (an occurrence nothing waits for changes
//! nothing, dropped or not). A catastrophic occurrence that fires locks its
//! vehicle out (the team, for a team occurrence), and a catastrophic
//! reaction makes what it emits catastrophic: a step that may handle a
//! catastrophic occurrence writes the lockout of every occurrence it may
//! handle. A timer or result such a step may start is catastrophic in turn
//! (the player's taint, decided on the static footprints), and its class
//! gets the same footprint. Lockouts are never lifted. A locked-out
//! vehicle's events are no inputs; its timers and results still are, and
//! are dropped: the footprint over-approximates such a step (dropping only
//! takes effects away), so the reduction stays on once vehicles are
//! locked out.
//!
//! In a state, a stubborn set starts from one enabled class and is closed
//! under:
//! - an enabled member brings every class whose *static* footprint writes
//!   what the member's footprint in the state reads or writes, or reads
//!   what it writes; and the enablers in the state of every transition its
//!   step leaves out (so that no class outside the set can make the
//!   member's step larger than read in the state);
//! - a disabled external event brings, for each transition it triggers,
//!   the classes that may fulfil one condition that transition lacks in
//!   the state (its net active, else one unmarked input place: the one
//!   fewest classes mark), or nothing when none is lacking (then a lockout
//!   drops it, for good);
//! - any other disabled member brings every class that may write what
//!   enables it.
//!
//! Only the enabled members (the ample set) are explored, and only when
//! none is *visible* — its step in the state deactivates a net that is
//! active there and marks none of its final places (a net's own deadness
//! reads it) — unless they are all the enabled classes. A step that may
//! mark a place of an `[[exclusive]]` resource reads every place of it, so
//! that making a second holder is an outcome of the step. The cycle
//! proviso is the explorer's (see docs/verify.md for why all this
//! preserves every verdict).

use std::collections::HashMap;

use crate::event::Category;
use crate::model::{names, Action, NetId, Project, Transition, TransitionId, VehicleId};
use crate::player::{Pending, PendingKind};

/// A class of inputs (see the module doc).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub(super) enum Class {
    /// An external event, by its index in the explorer's list.
    Event(usize),
    Timer(NetId, usize),
    Call(NetId, usize, usize),
    Command(NetId, String),
    Question(NetId, usize),
}

/// The steps of every class, their static footprints, and what the stubborn
/// sets read of a state.
pub(super) struct Stubborn {
    index: HashMap<Class, u32>,
    /// The steps: what a footprint is computed from.
    steps: Steps,
    /// Per class: its inputs may be catastrophic (see the module doc).
    tainted: Vec<bool>,
    /// Per class: what its enabling reads besides its own resource (the
    /// timers started with it: they expire in their order).
    together: Vec<Bits>,
    /// Per resource: the classes whose static footprint reads or writes it.
    touching: Vec<Bits>,
    /// Per resource: the classes whose static footprint writes it.
    writing: Vec<Bits>,
    /// Per class: the classes that may write what enables it.
    enablers: Vec<Vec<u32>>,
    /// Per timer or pending class: the classes that may start that timer
    /// or issue that kind of call, command or question.
    starters: Vec<Vec<u32>>,
    /// Per class: its timer, for a timer's class.
    timer_of: Vec<Option<(NetId, usize)>>,
    /// Per net: its final places.
    finals: Vec<Vec<usize>>,
    /// Per external event's class: the net and input places of each
    /// transition it triggers (what enables it in a state).
    waiting: Vec<Vec<(NetId, Vec<usize>)>>,
    /// Per place: the classes that may mark it.
    producers: Vec<Vec<u32>>,
    /// Per net: the classes that may activate it.
    activators: Vec<Vec<u32>>,
    /// The static dependency relation, for the tests: per class, the
    /// classes whose static footprint meets its own.
    #[cfg(test)]
    dependent: Vec<Vec<u32>>,
}

/// What the stubborn sets read of a state: marked places, active nets,
/// running timers.
pub(super) trait Marking {
    fn marked(&self, place: usize) -> bool;
    fn active(&self, net: NetId) -> bool;
    fn running(&self, net: NetId, timer: usize) -> bool;
}

/// Resources, numbered: places, active flags, timers, pending kinds, then
/// the lockout.
struct Resources {
    places: usize,
    nets: usize,
    timer_offsets: Vec<usize>,
    timers: usize,
    pending: HashMap<Class, usize>,
    vehicles: usize,
}

impl Resources {
    fn active(&self, n: NetId) -> usize {
        self.places + n
    }
    fn timer(&self, n: NetId, t: usize) -> usize {
        self.places + self.nets + self.timer_offsets[n] + t
    }
    fn pending(&self, c: &Class) -> Option<usize> {
        self.pending
            .get(c)
            .map(|i| self.places + self.nets + self.timers + i)
    }
    /// The lockout of a vehicle, or the team's (`None`).
    fn lockout(&self, vehicle: Option<VehicleId>) -> usize {
        self.places + self.nets + self.timers + self.pending.len() + vehicle.map_or(0, |v| v + 1)
    }
    fn count(&self) -> usize {
        self.lockout(Some(self.vehicles))
    }
}

/// A set of resources, or of classes.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Bits(Vec<u64>);

impl Bits {
    fn new(n: usize) -> Bits {
        Bits(vec![0; n.div_ceil(64)])
    }
    fn set(&mut self, i: usize) {
        self.0[i / 64] |= 1 << (i % 64);
    }
    fn has(&self, i: usize) -> bool {
        self.0[i / 64] & (1 << (i % 64)) != 0
    }
    fn meets(&self, other: &Bits) -> bool {
        self.0.iter().zip(&other.0).any(|(a, b)| a & b != 0)
    }
    fn add(&mut self, other: &Bits) {
        for (a, b) in self.0.iter_mut().zip(&other.0) {
            *a |= b;
        }
    }
    /// The members, ascending.
    fn members(&self) -> impl Iterator<Item = usize> + '_ {
        self.0.iter().enumerate().flat_map(|(i, &w)| {
            let mut w = w;
            std::iter::from_fn(move || {
                (w != 0).then(|| {
                    let b = w.trailing_zeros() as usize;
                    w &= w - 1;
                    i * 64 + b
                })
            })
        })
    }
}

/// Reads and writes of a step of one class.
struct Footprint {
    reads: Bits,
    writes: Bits,
    /// A step of the class may handle a catastrophic occurrence (so what
    /// it starts may be catastrophic too).
    catastrophic: bool,
    /// The places it may mark and the nets it may activate (as
    /// `active`), what may enable a transition.
    marks: Bits,
    /// The timers it may start and the kinds of result it may await.
    starts: Bits,
    /// The nets it may deactivate.
    deactivates: Vec<NetId>,
}

/// One transition's own part in a step: what its firing (and its actions)
/// may read and write, and the transitions that may fire after it in the
/// same step.
struct Move {
    net: NetId,
    inputs: Vec<usize>,
    reads: Bits,
    writes: Bits,
    marks: Bits,
    starts: Bits,
    deactivates: Vec<NetId>,
    /// It waits for a catastrophic event or emits one.
    catastrophic: bool,
    /// The vehicles of the occurrences its firing may raise that something
    /// waits for (its emitted events, its `net_fault`).
    heard: Vec<Option<VehicleId>>,
    /// The transitions that may fire after it in the step: the immediate
    /// ones its outputs may enable, those of the nets it activates, those
    /// its emitted events trigger.
    next: Vec<u32>,
}

/// How a step of a class starts, before any transition fires.
struct Opening {
    reads: Bits,
    writes: Bits,
    /// What decides whether the class is enabled.
    enabling: Bits,
    /// The vehicle whose lockout drops its input (`None`: the team's only).
    vehicle: Option<VehicleId>,
    /// Its input is a catastrophic event.
    catastrophic: bool,
    /// The transitions its input may fire (moves), then `net_fault`'s when
    /// there is one.
    start: Vec<u32>,
}

/// Everything a footprint is computed from.
struct Steps {
    res: Resources,
    moves: Vec<Move>,
    openings: Vec<Opening>,
    /// The immediate transitions (moves): one enabled in a state was
    /// rejected there, and is tried again after any step.
    immediates: Vec<u32>,
    /// The places of each `[[exclusive]]` resource.
    held: Vec<Bits>,
}

/// The transitions a step read in a state leaves out.
#[derive(Default)]
struct Left {
    seen: Vec<bool>,
    work: Vec<u32>,
    deferred: Vec<u32>,
}

impl Steps {
    fn new(project: &Project, externals: &[String], classes: &[Class], res: Resources) -> Steps {
        let offsets: Vec<u32> = project
            .nets
            .iter()
            .scan(0u32, |acc, net| {
                let at = *acc;
                *acc += net.transitions.len() as u32;
                Some(at)
            })
            .collect();
        let id = |(n, t): (NetId, TransitionId)| offsets[n] + t as u32;
        let net_fault: Vec<u32> = project
            .triggers
            .get(names::NET_FAULT)
            .into_iter()
            .flatten()
            .map(|&x| id(x))
            .collect();
        let mut moves = Vec::new();
        for (n, net) in project.nets.iter().enumerate() {
            for tr in &net.transitions {
                moves.push(one_move(project, &res, n, tr, !net_fault.is_empty(), &id));
            }
        }
        let openings = classes
            .iter()
            .map(|c| {
                let mut o = opening(project, externals, &res, c, &id);
                if !o.start.is_empty() {
                    o.start.extend(&net_fault);
                }
                o
            })
            .collect();
        let held = project
            .exclusive
            .iter()
            .map(|resource| {
                let mut held = Bits::new(res.count());
                for &p in resource.held.iter().flat_map(|(_, places)| places) {
                    held.set(p);
                }
                held
            })
            .collect();
        let immediates = project
            .nets
            .iter()
            .enumerate()
            .flat_map(|(n, net)| net.immediate.iter().map(move |&t| (n, t)))
            .map(id)
            .collect();
        Steps {
            res,
            moves,
            openings,
            immediates,
            held,
        }
    }

    /// Whether `m` can fire in a step from `state` that has marked `marks`
    /// so far (`None`: any state).
    fn can_fire(&self, m: &Move, state: Option<&dyn Marking>, marks: &Bits) -> bool {
        let Some(s) = state else {
            return true;
        };
        (s.active(m.net) || marks.has(self.res.active(m.net)))
            && m.inputs.iter().all(|&p| s.marked(p) || marks.has(p))
    }

    /// The footprint of a step of class `c` (`tainted`: its input may be
    /// catastrophic) from `state`, or from any state (`None`). With a
    /// state, `left.deferred` ends with the transitions the step leaves
    /// out: they cannot fire in it.
    fn footprint(
        &self,
        c: usize,
        tainted: bool,
        state: Option<&dyn Marking>,
        left: &mut Left,
    ) -> Footprint {
        let o = &self.openings[c];
        let count = self.res.count();
        let mut reads = o.reads.clone();
        let mut writes = o.writes.clone();
        let mut marks = Bits::new(count);
        let mut starts = Bits::new(count);
        let mut deactivates = Vec::new();
        let mut catastrophic = tainted || o.catastrophic;
        let mut heard: Vec<Option<VehicleId>> = Vec::new();
        left.seen.clear();
        left.seen.resize(self.moves.len(), false);
        left.work.clear();
        left.deferred.clear();
        left.work.extend(o.start.iter().rev());
        // An immediate transition enabled in the state was rejected there
        // (else it would have fired): it is tried again after the step.
        if let Some(s) = state.filter(|_| !o.start.is_empty()) {
            for &u in &self.immediates {
                let m = &self.moves[u as usize];
                if s.active(m.net) && m.inputs.iter().all(|&p| s.marked(p)) {
                    left.work.push(u);
                }
            }
        }
        let mut fired = false;
        loop {
            while let Some(t) = left.work.pop() {
                if left.seen[t as usize] {
                    continue;
                }
                let m = &self.moves[t as usize];
                if !self.can_fire(m, state, &marks) {
                    left.deferred.push(t);
                    continue;
                }
                left.seen[t as usize] = true;
                fired = true;
                reads.add(&m.reads);
                writes.add(&m.writes);
                marks.add(&m.marks);
                starts.add(&m.starts);
                for &n in &m.deactivates {
                    if !deactivates.contains(&n) {
                        deactivates.push(n);
                    }
                }
                catastrophic |= m.catastrophic;
                heard.extend_from_slice(&m.heard);
                left.work.extend(m.next.iter().rev());
            }
            // What the step marked may let a transition left out fire.
            left.deferred.retain(|&t| !left.seen[t as usize]);
            left.deferred.sort_unstable();
            left.deferred.dedup();
            let ready: Vec<u32> = left
                .deferred
                .iter()
                .copied()
                .filter(|&t| self.can_fire(&self.moves[t as usize], state, &marks))
                .collect();
            if ready.is_empty() {
                break;
            }
            left.work.extend(ready);
        }
        // An occurrence of a vehicle locked out (or of any, the team's
        // lockout on) is dropped: the step reads those lockouts. A
        // catastrophic one that fires a transition locks its vehicle out
        // (the team, for a team event), and so may every occurrence a
        // catastrophic reaction handles (its emitted events and
        // `net_fault`s are catastrophic too).
        if fired {
            heard.push(o.vehicle);
        }
        heard.sort_unstable();
        heard.dedup();
        if !heard.is_empty() {
            reads.set(self.res.lockout(None));
        }
        for &v in &heard {
            reads.set(self.res.lockout(v));
            if catastrophic {
                writes.set(self.res.lockout(v));
            }
        }
        // A step that may mark a place of an `[[exclusive]]` resource
        // reads every place of it: whether the step makes a second holder
        // is then an outcome of the step, which the reduction preserves
        // like any other (see docs/verify.md).
        for held in &self.held {
            if marks.meets(held) {
                reads.add(held);
            }
        }
        Footprint {
            reads,
            writes,
            catastrophic,
            marks,
            starts,
            deactivates,
        }
    }
}

/// A transition's own part in a step (see [`Move`]); `net_fault`: some
/// transition waits for `net_fault` (a rejected firing raises it).
fn one_move(
    project: &Project,
    res: &Resources,
    n: NetId,
    tr: &Transition,
    net_fault: bool,
    id: &dyn Fn((NetId, TransitionId)) -> u32,
) -> Move {
    let count = res.count();
    let mut reads = Bits::new(count);
    let mut writes = Bits::new(count);
    let mut marks = Bits::new(count);
    let mut starts = Bits::new(count);
    let mut deactivates = Vec::new();
    let mut heard = Vec::new();
    let mut next = Vec::new();
    reads.set(res.active(n));
    for &p in &tr.flat_inputs {
        reads.set(p);
        writes.set(p);
    }
    for &p in &tr.flat_outputs {
        reads.set(p); // a double token is found by reading it
        writes.set(p);
        marks.set(p);
    }
    let mut catastrophic = tr
        .event
        .as_deref()
        .is_some_and(|e| category(project, e) == Category::Catastrophic);
    // A rejected firing raises the net's `net_fault`.
    if net_fault {
        heard.push(project.nets[n].vehicle);
    }
    // Immediate transitions the outputs may enable.
    for (m, net) in project.nets.iter().enumerate() {
        for &u in &net.immediate {
            if net.transitions[u]
                .flat_inputs
                .iter()
                .any(|p| tr.flat_outputs.contains(p))
            {
                next.push(id((m, u)));
            }
        }
    }
    for a in &tr.actions {
        match a {
            Action::Activate(m) | Action::Deactivate(m) => {
                let m = *m;
                writes.set(res.active(m));
                if matches!(a, Action::Deactivate(_)) && !deactivates.contains(&m) {
                    deactivates.push(m);
                }
                if matches!(a, Action::Activate(_)) {
                    marks.set(res.active(m));
                    let offset = project.place_offsets[m];
                    for (i, place) in project.nets[m].places.iter().enumerate() {
                        if place.initial {
                            marks.set(offset + i);
                        }
                    }
                }
                let offset = project.place_offsets[m];
                for i in 0..project.nets[m].places.len() {
                    writes.set(offset + i);
                    reads.set(offset + i);
                }
                for i in 0..project.nets[m].timers.len() {
                    writes.set(res.timer(m, i));
                }
                for class in res.pending.keys() {
                    let net = match class {
                        Class::Call(x, ..) | Class::Command(x, _) | Class::Question(x, _) => *x,
                        _ => continue,
                    };
                    if net == m {
                        if let Some(r) = res.pending(class) {
                            writes.set(r);
                        }
                    }
                }
                for &u in &project.nets[m].immediate {
                    next.push(id((m, u)));
                }
            }
            Action::Emit { event, .. } => {
                catastrophic |= category(project, event) == Category::Catastrophic;
                if let Some(waiting) = project.triggers.get(event) {
                    heard.push(project.vehicle_event(event).map(|(_, v)| v));
                    next.extend(waiting.iter().map(|&x| id(x)));
                }
            }
            Action::Timer { timer, .. } => {
                writes.set(res.timer(n, *timer));
                starts.set(res.timer(n, *timer));
            }
            Action::Cancel { timer } => writes.set(res.timer(n, *timer)),
            Action::Call {
                program, function, ..
            } => issue(
                res,
                &mut writes,
                &mut starts,
                Class::Call(n, *program, *function),
            ),
            Action::Command { verb, .. } => issue(
                res,
                &mut writes,
                &mut starts,
                Class::Command(n, verb.clone()),
            ),
            Action::Ask { ask, .. } => {
                let timer = project.nets[n].asks[*ask].timer;
                writes.set(res.timer(n, timer));
                starts.set(res.timer(n, timer));
                issue(res, &mut writes, &mut starts, Class::Question(n, *ask));
            }
        }
    }
    Move {
        net: n,
        inputs: tr.flat_inputs.clone(),
        reads,
        writes,
        marks,
        starts,
        deactivates,
        catastrophic,
        heard,
        next,
    }
}

/// How a step of class `c` starts (see [`Opening`]).
fn opening(
    project: &Project,
    externals: &[String],
    res: &Resources,
    c: &Class,
    id: &dyn Fn((NetId, TransitionId)) -> u32,
) -> Opening {
    let count = res.count();
    let mut reads = Bits::new(count);
    let mut writes = Bits::new(count);
    let mut enabling = Bits::new(count);
    let mut catastrophic = false;
    let waiting_for = |net: NetId, event: &str| -> Vec<(NetId, TransitionId)> {
        project.nets[net]
            .transitions
            .iter()
            .enumerate()
            .filter(|(_, t)| t.event.as_deref() == Some(event))
            .map(|(i, _)| (net, i))
            .collect()
    };
    let mut start: Vec<(NetId, TransitionId)> = Vec::new();
    match c {
        Class::Event(i) => {
            let event = &externals[*i];
            start = project.triggers.get(event).cloned().unwrap_or_default();
            for &(n, t) in &start {
                enabling.set(res.active(n));
                for &p in &project.nets[n].transitions[t].flat_inputs {
                    enabling.set(p);
                }
            }
            catastrophic = category(project, event) == Category::Catastrophic;
        }
        Class::Timer(n, t) => {
            let r = res.timer(*n, *t);
            enabling.set(r);
            reads.set(r);
            writes.set(r);
            start = waiting_for(*n, &project.nets[*n].timers[*t]);
            // A question's timeout ends the question.
            for (a, ask) in project.nets[*n].asks.iter().enumerate() {
                if ask.timer == *t {
                    if let Some(q) = res.pending(&Class::Question(*n, a)) {
                        writes.set(q);
                    }
                }
            }
        }
        other => {
            if let Some(r) = res.pending(other) {
                enabling.set(r);
                reads.set(r);
                writes.set(r);
            }
            match other {
                Class::Call(n, program, function) => {
                    let p = &project.programs[*program];
                    let base = format!("{}.{}", p.name, p.functions[*function].name);
                    start = waiting_for(*n, &format!("{base}.{}", names::DONE));
                    start.extend(waiting_for(*n, &format!("{base}.{}", names::FAILED)));
                }
                Class::Command(n, _) => {
                    start = waiting_for(*n, names::COMMAND_OK);
                    start.extend(waiting_for(*n, names::COMMAND_FAILED));
                }
                Class::Question(n, a) => {
                    let ask = &project.nets[*n].asks[*a];
                    for choice in &ask.choices {
                        start.extend(waiting_for(*n, &ask.answer_event(choice)));
                    }
                    writes.set(res.timer(*n, ask.timer));
                }
                _ => {}
            }
        }
    }
    let vehicle = input_vehicle(project, externals, c);
    // The lockouts that drop the input (the team's, its vehicle's): they
    // decide whether an external event is an input at all, and whether a
    // timer or result fires what awaits it.
    if matches!(c, Class::Event(_)) {
        enabling.set(res.lockout(None));
        enabling.set(res.lockout(vehicle));
    }
    Opening {
        reads,
        writes,
        enabling,
        vehicle,
        catastrophic,
        start: start.into_iter().map(id).collect(),
    }
}

impl Stubborn {
    /// The classes of `project`: `externals` are the explorer's external
    /// events.
    pub fn new(project: &Project, externals: &[String]) -> Stubborn {
        // Every class.
        let mut classes: Vec<Class> = (0..externals.len()).map(Class::Event).collect();
        let mut timer_offsets = Vec::with_capacity(project.nets.len());
        let mut timers = 0;
        for (n, net) in project.nets.iter().enumerate() {
            timer_offsets.push(timers);
            timers += net.timers.len();
            for t in 0..net.timers.len() {
                classes.push(Class::Timer(n, t));
            }
            for (a, _) in net.asks.iter().enumerate() {
                classes.push(Class::Question(n, a));
            }
            for action in net.transitions.iter().flat_map(|t| &t.actions) {
                let c = match action {
                    Action::Call {
                        program, function, ..
                    } => Class::Call(n, *program, *function),
                    Action::Command { verb, .. } => Class::Command(n, verb.clone()),
                    _ => continue,
                };
                if !classes.contains(&c) {
                    classes.push(c);
                }
            }
        }
        let pending: HashMap<Class, usize> = classes
            .iter()
            .filter(|c| !matches!(c, Class::Event(_) | Class::Timer(..)))
            .cloned()
            .enumerate()
            .map(|(i, c)| (c, i))
            .collect();
        let res = Resources {
            places: project.place_count,
            nets: project.nets.len(),
            timer_offsets,
            timers,
            pending,
            vehicles: project.vehicles.len(),
        };
        let steps = Steps::new(project, externals, &classes, res);
        let res = &steps.res;
        let k = classes.len();
        let mut left = Left::default();
        let mut footprints: Vec<Footprint> = (0..k)
            .map(|c| steps.footprint(c, false, None, &mut left))
            .collect();
        // A timer or result a catastrophic reaction starts is catastrophic
        // (the player's `tainted`): its class gets a catastrophic step's
        // footprint, and so on for what that step starts.
        let mut tainted = vec![false; k];
        loop {
            let mut more = false;
            for i in 0..k {
                let Some(r) = class_resource(res, &classes[i]) else {
                    continue;
                };
                if tainted[i] {
                    continue;
                }
                if footprints.iter().any(|f| f.catastrophic && f.starts.has(r)) {
                    tainted[i] = true;
                    footprints[i] = steps.footprint(i, true, None, &mut left);
                    more = true;
                }
            }
            if !more {
                break;
            }
        }
        // Timers started in one step expire in their order: a timer's
        // enabling reads every timer a class may start with it.
        let mut together: Vec<Bits> = vec![Bits::new(res.count()); k];
        for f in &footprints {
            let started: Vec<usize> = (0..k)
                .filter(|&j| {
                    matches!(classes[j], Class::Timer(..))
                        && class_resource(res, &classes[j]).is_some_and(|r| f.starts.has(r))
                })
                .collect();
            for &a in &started {
                for &b in &started {
                    if let Some(r) = class_resource(res, &classes[b]) {
                        together[a].set(r);
                    }
                }
            }
        }
        let mut enabling: Vec<Bits> = steps.openings.iter().map(|o| o.enabling.clone()).collect();
        for c in 0..k {
            footprints[c].reads.add(&together[c]);
            enabling[c].add(&together[c]);
        }
        let mut enablers = vec![Vec::new(); k];
        for a in 0..k {
            for (b, fb) in footprints.iter().enumerate() {
                if fb.writes.meets(&enabling[a]) {
                    enablers[a].push(b as u32);
                }
            }
        }
        let starters = classes
            .iter()
            .map(|c| match class_resource(res, c) {
                Some(r) => (0..k)
                    .filter(|&b| footprints[b].starts.has(r))
                    .map(|b| b as u32)
                    .collect(),
                None => Vec::new(),
            })
            .collect();
        let timer_of = classes
            .iter()
            .map(|c| match c {
                Class::Timer(n, t) => Some((*n, *t)),
                _ => None,
            })
            .collect();
        let mut touching = vec![Bits::new(k); res.count()];
        let mut writing = vec![Bits::new(k); res.count()];
        for (c, f) in footprints.iter().enumerate() {
            for r in f.reads.members() {
                touching[r].set(c);
            }
            for r in f.writes.members() {
                touching[r].set(c);
                writing[r].set(c);
            }
        }
        let waiting = classes
            .iter()
            .map(|c| match c {
                Class::Event(i) => project
                    .triggers
                    .get(&externals[*i])
                    .map(|list| {
                        list.iter()
                            .map(|&(n, t)| (n, project.nets[n].transitions[t].flat_inputs.clone()))
                            .collect()
                    })
                    .unwrap_or_default(),
                _ => Vec::new(),
            })
            .collect();
        let who = |r: usize| -> Vec<u32> {
            (0..k)
                .filter(|&b| footprints[b].marks.has(r))
                .map(|b| b as u32)
                .collect()
        };
        #[cfg(test)]
        let dependent = (0..k)
            .map(|a| {
                (0..k)
                    .filter(|&b| {
                        let (fa, fb) = (&footprints[a], &footprints[b]);
                        a == b
                            || fa.writes.meets(&fb.reads)
                            || fa.writes.meets(&fb.writes)
                            || fb.writes.meets(&fa.reads)
                    })
                    .map(|b| b as u32)
                    .collect()
            })
            .collect();
        Stubborn {
            index: classes
                .into_iter()
                .enumerate()
                .map(|(i, c)| (c, i as u32))
                .collect(),
            tainted,
            together,
            touching,
            writing,
            enablers,
            starters,
            timer_of,
            finals: project
                .nets
                .iter()
                .enumerate()
                .map(|(n, net)| {
                    net.places
                        .iter()
                        .enumerate()
                        .filter(|(_, p)| p.is_final)
                        .map(|(i, _)| project.place_offsets[n] + i)
                        .collect()
                })
                .collect(),
            waiting,
            producers: (0..res.places).map(who).collect(),
            activators: (0..res.nets).map(|n| who(res.active(n))).collect(),
            #[cfg(test)]
            dependent,
            steps,
        }
    }

    /// What may enable the disabled class `c` in a state: for an external
    /// event, one condition each of its transitions lacks (its net active,
    /// else one input place marked: the one fewest classes mark) and the
    /// classes that may fulfil it; an event none of whose transitions
    /// lacks anything is disabled by a lockout, which nothing lifts. For a
    /// timer that runs (another one started with it expires first), every
    /// class that may write what enables it; for a timer that does not
    /// run, or a kind of result not awaited, the classes that may start it
    /// (nothing else makes it run or awaited: a cancel, a deactivation
    /// only stops it).
    fn enablers_in<'a>(
        &'a self,
        c: usize,
        state: &dyn Marking,
        out: &'a mut Vec<u32>,
    ) -> &'a [u32] {
        if self.waiting[c].is_empty() {
            return match self.timer_of[c] {
                Some((n, t)) if state.running(n, t) => &self.enablers[c],
                _ => &self.starters[c],
            };
        }
        out.clear();
        for (n, inputs) in &self.waiting[c] {
            let lacking = if !state.active(*n) {
                &self.activators[*n]
            } else {
                match inputs
                    .iter()
                    .filter(|&&p| !state.marked(p))
                    .min_by_key(|&&p| self.producers[p].len())
                {
                    Some(&p) => &self.producers[p],
                    None => continue,
                }
            };
            out.extend_from_slice(lacking);
        }
        out
    }

    /// What the enabled class `c` brings into a stubborn set in `state`,
    /// and whether it is visible there (its step deactivates a net that is
    /// active and marks none of its final places: a net that may be dead,
    /// the reduction must not take the deactivation first). It brings
    /// itself, every class whose static footprint writes what its step in
    /// the state reads or writes or reads what it writes, and for each
    /// transition its step leaves out the classes that may fulfil one
    /// condition it lacks (its net active, else one input place the step
    /// does not mark either: the one fewest classes mark).
    fn brings(&self, c: usize, state: &dyn Marking, left: &mut Left) -> (Bits, bool) {
        let f = self.steps.footprint(c, self.tainted[c], Some(state), left);
        let mut out = Bits::new(self.enablers.len());
        out.set(c);
        for r in f.writes.members() {
            out.add(&self.touching[r]);
        }
        for r in f.reads.members().chain(self.together[c].members()) {
            out.add(&self.writing[r]);
        }
        let res = &self.steps.res;
        for &t in &left.deferred {
            let m = &self.steps.moves[t as usize];
            let lacking = if !(state.active(m.net) || f.marks.has(res.active(m.net))) {
                &self.activators[m.net]
            } else {
                match m
                    .inputs
                    .iter()
                    .filter(|&&p| !(state.marked(p) || f.marks.has(p)))
                    .min_by_key(|&&p| self.producers[p].len())
                {
                    Some(&p) => &self.producers[p],
                    // Not reached: a transition left out lacks something.
                    None => continue,
                }
            };
            for &b in lacking {
                out.set(b as usize);
            }
        }
        let visible = f
            .deactivates
            .iter()
            .any(|&n| state.active(n) && !self.finals[n].iter().any(|&p| state.marked(p)));
        (out, visible)
    }

    /// The class of a pending result.
    pub fn class_of_pending(&self, pending: &Pending) -> Option<u32> {
        let c = match &pending.kind {
            PendingKind::Call { program, function } => {
                Class::Call(pending.net, *program, *function)
            }
            PendingKind::Command { verb } => Class::Command(pending.net, verb.clone()),
            PendingKind::Question { ask } => Class::Question(pending.net, *ask),
        };
        self.index.get(&c).copied()
    }

    /// The class of a timer or an external event.
    pub fn class(&self, c: &Class) -> Option<u32> {
        self.index.get(c).copied()
    }

    /// The ample sets among the enabled classes `enabled` (each input's
    /// class, `None` when it has none) in a state: for each, which inputs
    /// to explore; smallest first, at most `most`, none when no stubborn
    /// set reduces (then every input is explored).
    pub fn ample(
        &self,
        enabled: &[Option<u32>],
        state: &dyn Marking,
        most: usize,
    ) -> Vec<Vec<bool>> {
        if enabled.iter().any(Option::is_none) {
            return Vec::new();
        }
        let classes = self.enablers.len();
        let mut is_enabled = vec![false; classes];
        for c in enabled.iter().flatten() {
            is_enabled[*c as usize] = true;
        }
        let distinct = is_enabled.iter().filter(|e| **e).count();
        // What each enabled class brings, read in the state once.
        let mut brought: Vec<Option<(Vec<u32>, bool)>> = vec![None; classes];
        let mut left = Left::default();
        let mut found: Vec<(usize, Vec<bool>)> = Vec::new();
        let mut lacking = Vec::new();
        let mut seeds: Vec<u32> = enabled.iter().flatten().copied().collect();
        seeds.sort_unstable();
        seeds.dedup();
        let mut member = vec![false; classes];
        let mut work = Vec::new();
        for seed in seeds {
            member.iter_mut().for_each(|m| *m = false);
            member[seed as usize] = true;
            work.clear();
            work.push(seed);
            let mut size = 1;
            let mut visible = false;
            while let Some(c) = work.pop() {
                let c = c as usize;
                let next: &[u32] = if is_enabled[c] {
                    let (next, v) = brought[c].get_or_insert_with(|| {
                        let (set, v) = self.brings(c, state, &mut left);
                        (set.members().map(|b| b as u32).collect(), v)
                    });
                    visible |= *v;
                    next
                } else {
                    self.enablers_in(c, state, &mut lacking)
                };
                for &d in next {
                    if !member[d as usize] {
                        member[d as usize] = true;
                        if is_enabled[d as usize] {
                            size += 1;
                        }
                        work.push(d);
                    }
                }
                if visible || size >= distinct {
                    break;
                }
            }
            if visible || size >= distinct {
                continue;
            }
            let set: Vec<bool> = enabled
                .iter()
                .map(|c| c.is_some_and(|c| member[c as usize]))
                .collect();
            if !found.iter().any(|(_, s)| *s == set) {
                found.push((size, set));
            }
        }
        found.sort_by_key(|(size, _)| *size);
        found.truncate(most);
        found.into_iter().map(|(_, set)| set).collect()
    }
}

/// The resource a timer or pending class stands for.
fn class_resource(res: &Resources, c: &Class) -> Option<usize> {
    match c {
        Class::Timer(n, t) => Some(res.timer(*n, *t)),
        Class::Event(_) => None,
        other => res.pending(other),
    }
}

fn category(project: &Project, event: &str) -> Category {
    project
        .declared_category(event)
        .unwrap_or_else(|| crate::event::Event::new(event).category)
}

/// The vehicle whose lockout drops an input of class `c` (`None`: only
/// the team's lockout drops it).
fn input_vehicle(project: &Project, externals: &[String], c: &Class) -> Option<VehicleId> {
    match c {
        Class::Event(i) => project.vehicle_event(&externals[*i]).map(|(_, v)| v),
        Class::Timer(n, _) | Class::Call(n, ..) | Class::Command(n, _) | Class::Question(n, _) => {
            project.nets[*n].vehicle
        }
    }
}

/// A call, command or question issued: its kind is written (the order of
/// pending results is not part of a team's reduced key).
fn issue(res: &Resources, writes: &mut Bits, starts: &mut Bits, class: Class) {
    if let Some(r) = res.pending(&class) {
        writes.set(r);
        starts.set(r);
    }
}

impl Marking for crate::player::State {
    fn marked(&self, place: usize) -> bool {
        crate::player::State::marked(self, place)
    }
    fn active(&self, net: NetId) -> bool {
        self.active[net]
    }
    fn running(&self, net: NetId, timer: usize) -> bool {
        self.timers.iter().any(|t| t.net == net && t.timer == timer)
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;

    /// Two robots, each moving on `go` or failing (catastrophic) on
    /// `engine_failure`; a team net hearing a team-wide catastrophic
    /// `alarm`.
    fn team() -> (Project, Vec<String>) {
        let files: BTreeMap<String, String> = [
            (
                "project.toml",
                "[events]\ngo = \"nominal\"\nengine_failure = \"catastrophic\"\nalarm = \"catastrophic\"\n\n[[vehicle]]\nname = \"R1\"\nsystem = 1\n\n[[vehicle]]\nname = \"R2\"\nsystem = 2\n\n[[net]]\nfile = \"move.toml\"\nactive = true\n\n[[net]]\nfile = \"team.toml\"\nactive = true\n",
            ),
            (
                "move.toml",
                "name = \"MOVE\"\nvehicles = \"all\"\nplaces = [\"a\", \"b\", \"down\"]\ninitial = [\"a\"]\nfinal = [\"b\", \"down\"]\n\n[[transition]]\nname = \"go\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"go\"\n\n[[transition]]\nname = \"fail\"\nfrom = [\"b\"]\nto = [\"down\"]\non = \"engine_failure\"\n",
            ),
            (
                "team.toml",
                "name = \"TEAM\"\nplaces = [\"on\", \"off\"]\ninitial = [\"on\"]\nfinal = [\"on\", \"off\"]\n\n[[transition]]\nname = \"alarm\"\nfrom = [\"on\"]\nto = [\"off\"]\non = \"alarm\"\n",
            ),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_owned(), v.to_owned()))
        .collect();
        let project = crate::load::load(&files).unwrap_or_else(|e| panic!("{e:?}"));
        let externals = [
            "alarm",
            "engine_failure@R1",
            "engine_failure@R2",
            "go@R1",
            "go@R2",
        ]
        .map(str::to_owned)
        .to_vec();
        (project, externals)
    }

    fn depends(s: &Stubborn, externals: &[String], a: &str, b: &str) -> bool {
        let class = |name: &str| {
            let i = externals.iter().position(|x| x == name).expect(name);
            s.index[&Class::Event(i)]
        };
        s.dependent[class(a) as usize].contains(&class(b))
    }

    #[test]
    fn a_vehicle_s_catastrophic_event_depends_on_its_own_inputs_only() {
        let (project, externals) = team();
        let s = Stubborn::new(&project, &externals);
        let d = |a, b| depends(&s, &externals, a, b);
        // R1's failure locks R1 out: R1's `go` is dropped after it, R2's
        // is not.
        assert!(d("engine_failure@R1", "go@R1"));
        assert!(d("go@R1", "engine_failure@R1"));
        assert!(!d("engine_failure@R1", "go@R2"));
        assert!(!d("engine_failure@R1", "engine_failure@R2"));
        assert!(!d("go@R1", "go@R2"));
        // A team-wide catastrophic event locks the whole team out.
        for other in ["go@R1", "go@R2", "engine_failure@R1", "engine_failure@R2"] {
            assert!(d("alarm", other), "{other}");
        }
    }

    /// A state of the team: `marked` places (flat numbers), every net
    /// active.
    struct At(Vec<usize>);

    impl Marking for At {
        fn marked(&self, place: usize) -> bool {
            self.0.contains(&place)
        }
        fn active(&self, _: NetId) -> bool {
            true
        }
        fn running(&self, _: NetId, _: usize) -> bool {
            false
        }
    }

    #[test]
    fn a_disabled_event_brings_only_what_may_enable_it_in_the_state() {
        let (project, externals) = team();
        let s = Stubborn::new(&project, &externals);
        let place = |net: &str, name: &str| {
            let n = project.nets.iter().position(|x| x.name == net).expect(net);
            let i = project.nets[n].places.iter().position(|p| p.name == name);
            project.place_offsets[n] + i.expect(name)
        };
        let class = |name: &str| {
            let i = externals.iter().position(|x| x == name).expect(name);
            Some(s.index[&Class::Event(i)])
        };
        // Both robots at `a`, the alarm heard already: each one's `go` is
        // an ample set of its own (its disabled failure needs `b`, which
        // only its own `go` marks; nothing brings the alarm back).
        let quiet = At(vec![
            place("MOVE@R1", "a"),
            place("MOVE@R2", "a"),
            place("TEAM", "off"),
        ]);
        let sets = s.ample(&[class("go@R1"), class("go@R2")], &quiet, 4);
        assert_eq!(sets, [vec![true, false], vec![false, true]]);
        // The alarm still to come may lock the whole team out: it depends
        // on every input, so no set leaves one out.
        let alert = At(vec![
            place("MOVE@R1", "a"),
            place("MOVE@R2", "a"),
            place("TEAM", "on"),
        ]);
        let enabled = [class("alarm"), class("go@R1"), class("go@R2")];
        assert!(s.ample(&enabled, &alert, 4).is_empty());
    }

    /// Two robots: `go` (a to b), `arrived` (b back to a, or out of the
    /// bottleneck: inside to out, giving `@free` back), `enter` (a and
    /// `@free` to inside).
    fn corridor() -> (Project, Vec<String>) {
        let files: BTreeMap<String, String> = [
            (
                "project.toml",
                "[events]\ngo = \"nominal\"\narrived = \"nominal\"\nenter = \"nominal\"\n\n[globals]\nfree = true\n\n[[vehicle]]\nname = \"R1\"\nsystem = 1\n\n[[vehicle]]\nname = \"R2\"\nsystem = 2\n\n[[net]]\nfile = \"move.toml\"\nactive = true\n",
            ),
            (
                "move.toml",
                "name = \"MOVE\"\nvehicles = \"all\"\nplaces = [\"a\", \"b\", \"inside\", \"out\"]\ninitial = [\"a\"]\nfinal = [\"out\"]\n\n[[transition]]\nname = \"go\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"go\"\n\n[[transition]]\nname = \"back\"\nfrom = [\"b\"]\nto = [\"a\"]\non = \"arrived\"\n\n[[transition]]\nname = \"leave\"\nfrom = [\"inside\"]\nto = [\"out\", \"@free\"]\non = \"arrived\"\n\n[[transition]]\nname = \"enter\"\nfrom = [\"a\", \"@free\"]\nto = [\"inside\"]\non = \"enter\"\n",
            ),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_owned(), v.to_owned()))
        .collect();
        let project = crate::load::load(&files).unwrap_or_else(|e| panic!("{e:?}"));
        let externals = [
            "arrived@R1",
            "arrived@R2",
            "enter@R1",
            "enter@R2",
            "go@R1",
            "go@R2",
        ]
        .map(str::to_owned)
        .to_vec();
        (project, externals)
    }

    #[test]
    fn a_step_read_in_the_state_counts_only_the_transitions_that_can_fire() {
        let (project, externals) = corridor();
        let s = Stubborn::new(&project, &externals);
        let place = |net: &str, name: &str| {
            let n = project.nets.iter().position(|x| x.name == net).expect(net);
            let i = project.nets[n].places.iter().position(|p| p.name == name);
            project.place_offsets[n] + i.expect(name)
        };
        // Globals come first.
        let global = 0;
        let class = |name: &str| {
            let i = externals.iter().position(|x| x == name).expect(name);
            Some(s.index[&Class::Event(i)])
        };
        // Statically, `arrived@R1` may fire `leave`, which gives `@free`
        // back: it depends on R2's `enter`, which takes it.
        assert!(depends(&s, &externals, "arrived@R1", "enter@R2"));
        // R1 at b (not inside), R2 at a, the bottleneck free: R1's
        // `arrived` can only fire `back`; `leave` needs `inside`, which
        // only R1's own `enter` marks (disabled: it needs a, which only
        // R1's `back` marks). So `arrived@R1` alone is an ample set.
        let at_b = At(vec![place("MOVE@R1", "b"), place("MOVE@R2", "a"), global]);
        let enabled = [class("arrived@R1"), class("enter@R2"), class("go@R2")];
        let sets = s.ample(&enabled, &at_b, 4);
        assert!(sets.contains(&vec![true, false, false]), "{sets:?}");
        // R1 inside instead: its `arrived` fires `leave` and gives `@free`
        // back, so R2's `enter` (disabled: it lacks `@free`) is in every
        // set holding it, and with it what may give `@free` back: R2's
        // `arrived`, which needs R2's `go` first. No set reduces.
        let inside = At(vec![place("MOVE@R1", "inside"), place("MOVE@R2", "a")]);
        let enabled = [class("arrived@R1"), class("go@R2")];
        assert!(s.ample(&enabled, &inside, 4).is_empty());
        let mut left = Left::default();
        let leaving = s.steps.footprint(
            s.index[&Class::Event(0)] as usize,
            false,
            Some(&inside),
            &mut left,
        );
        assert!(leaving.writes.has(global));
        let backing = s.steps.footprint(
            s.index[&Class::Event(0)] as usize,
            false,
            Some(&at_b),
            &mut left,
        );
        assert!(!backing.writes.has(global) && !backing.reads.has(global));
        // `leave` was left out: it lacks `inside`.
        assert_eq!(left.deferred.len(), 1);
    }
}
