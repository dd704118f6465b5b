//! Partial-order reduction of the project explorer: stubborn sets over the
//! inputs a state offers.
//!
//! Inputs come in *classes*: an external event, a timer of a net, the
//! result of a kind of call, command or question of a net. Each class has a
//! static footprint: what a step it starts may read and write, over every
//! transition that can fire in that step (those its event triggers, then
//! the immediate transitions its outputs may enable, the transitions the
//! events it emits trigger, the nets it activates, `net_fault`'s). The
//! resources are the places, each net's active flag, each timer, each kind
//! of pending result and the catastrophic lockout (the order in which
//! timers start and results are awaited is not: a team's reduced key keeps
//! none the player cannot tell apart, see `project_states`). Two
//! classes are dependent when one writes what the other reads or writes.
//!
//! In a state, a stubborn set starts from one enabled class and is closed
//! under: an enabled member brings every class dependent on it; a disabled
//! member brings every class that may write what enables it. Only the
//! enabled members (the ample set) are explored, and only when they are
//! invisible — they write no place of an `[[exclusive]]` resource and no
//! net's active flag — unless they are all the enabled classes. The cycle
//! proviso is the explorer's: a state is expanded fully when a step of its
//! ample set leads to a state already stored, or changes nothing
//! (see docs/verify.md for why this preserves every verdict).

use std::collections::HashMap;

use crate::event::Category;
use crate::model::{names, Action, NetId, Project, TransitionId};
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

/// The footprints of every class and the dependencies between them.
pub(super) struct Stubborn {
    index: HashMap<Class, u32>,
    /// Per class: the classes dependent on it.
    dependent: Vec<Vec<u32>>,
    /// Per class: the classes that may write what enables it.
    enablers: Vec<Vec<u32>>,
    /// Per class: it writes what a verdict reads (an exclusive place, an
    /// active flag).
    visible: Vec<bool>,
}

/// Resources, numbered: places, active flags, timers, pending kinds, then
/// the lockout.
struct Resources {
    places: usize,
    nets: usize,
    timer_offsets: Vec<usize>,
    timers: usize,
    pending: HashMap<Class, usize>,
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
    fn lockout(&self) -> usize {
        self.places + self.nets + self.timers + self.pending.len()
    }
    fn count(&self) -> usize {
        self.lockout() + 1
    }
}

/// A set of resources.
#[derive(Clone)]
struct Bits(Vec<u64>);

impl Bits {
    fn new(n: usize) -> Bits {
        Bits(vec![0; n.div_ceil(64)])
    }
    fn set(&mut self, i: usize) {
        self.0[i / 64] |= 1 << (i % 64);
    }
    fn meets(&self, other: &Bits) -> bool {
        self.0.iter().zip(&other.0).any(|(a, b)| a & b != 0)
    }
}

/// Reads and writes of one class.
struct Footprint {
    reads: Bits,
    writes: Bits,
    /// What decides whether the class is enabled.
    enabling: Bits,
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
        };
        let footprints: Vec<Footprint> = classes
            .iter()
            .map(|c| footprint(project, externals, &res, c))
            .collect();
        // Timers started in one step expire in their order: a timer's
        // enabling reads every timer a class may start with it.
        let mut footprints = footprints;
        let starts: Vec<Vec<usize>> = (0..classes.len())
            .map(|i| {
                (0..classes.len())
                    .filter(|&j| {
                        matches!(classes[j], Class::Timer(..))
                            && class_resource(&res, &classes[j]).is_some_and(|r| {
                                footprints[i].writes.0[r / 64] & (1 << (r % 64)) != 0
                            })
                    })
                    .collect()
            })
            .collect();
        for together in &starts {
            for &a in together {
                for &b in together {
                    if let Some(r) = class_resource(&res, &classes[b]) {
                        footprints[a].enabling.set(r);
                        footprints[a].reads.set(r);
                    }
                }
            }
        }
        let exclusive_places: Vec<usize> = project
            .exclusive
            .iter()
            .flat_map(|r| r.held.iter().flat_map(|(_, p)| p.iter().copied()))
            .collect();
        let mut visible_bits = Bits::new(res.count());
        for &p in &exclusive_places {
            visible_bits.set(p);
        }
        for n in 0..project.nets.len() {
            visible_bits.set(res.active(n));
        }
        let k = classes.len();
        let mut dependent = vec![Vec::new(); k];
        let mut enablers = vec![Vec::new(); k];
        for a in 0..k {
            for b in 0..k {
                let (fa, fb) = (&footprints[a], &footprints[b]);
                if a == b
                    || fa.writes.meets(&fb.reads)
                    || fa.writes.meets(&fb.writes)
                    || fb.writes.meets(&fa.reads)
                {
                    dependent[a].push(b as u32);
                }
                if fb.writes.meets(&fa.enabling) {
                    enablers[a].push(b as u32);
                }
            }
        }
        Stubborn {
            index: classes
                .into_iter()
                .enumerate()
                .map(|(i, c)| (c, i as u32))
                .collect(),
            dependent,
            enablers,
            visible: footprints
                .iter()
                .map(|f| f.writes.meets(&visible_bits))
                .collect(),
        }
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

    /// The ample set among the enabled classes `enabled` (each input's
    /// class, `None` when it has none): which of them to explore, or
    /// `None` to explore every one.
    pub fn ample(&self, enabled: &[Option<u32>]) -> Option<Vec<bool>> {
        if enabled.iter().any(Option::is_none) {
            return None;
        }
        let classes = self.dependent.len();
        let mut is_enabled = vec![false; classes];
        for c in enabled.iter().flatten() {
            is_enabled[*c as usize] = true;
        }
        let distinct = is_enabled.iter().filter(|e| **e).count();
        let mut best: Option<(usize, Vec<bool>)> = None;
        let mut seeds: Vec<u32> = enabled.iter().flatten().copied().collect();
        seeds.sort_unstable();
        seeds.dedup();
        for seed in seeds {
            if self.visible[seed as usize] {
                continue;
            }
            let mut member = vec![false; classes];
            member[seed as usize] = true;
            let mut work = vec![seed];
            let mut size = 1;
            let mut visible = false;
            while let Some(c) = work.pop() {
                let c = c as usize;
                let next = if is_enabled[c] {
                    visible |= self.visible[c];
                    &self.dependent[c]
                } else {
                    &self.enablers[c]
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
                if visible || size >= distinct || best.as_ref().is_some_and(|(s, _)| size >= *s) {
                    break;
                }
            }
            if visible || size >= distinct || best.as_ref().is_some_and(|(s, _)| size >= *s) {
                continue;
            }
            best = Some((size, member));
        }
        let (_, member) = best?;
        Some(
            enabled
                .iter()
                .map(|c| c.is_some_and(|c| member[c as usize]))
                .collect(),
        )
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

/// What a step of class `c` may read and write.
fn footprint(project: &Project, externals: &[String], res: &Resources, c: &Class) -> Footprint {
    let mut reads = Bits::new(res.count());
    let mut writes = Bits::new(res.count());
    let mut enabling = Bits::new(res.count());
    // Every input reads the lockout (it drops other events).
    reads.set(res.lockout());
    enabling.set(res.lockout());
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
            if category(project, event) == Category::Catastrophic {
                writes.set(res.lockout());
            }
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
    // A catastrophic timer or result (started by the catastrophic reaction)
    // only exists once the lockout is set: the explorer expands such
    // states fully.
    // The transitions that may fire in the step.
    let mut seen: std::collections::HashSet<(NetId, TransitionId)> = Default::default();
    let mut work = start;
    if !work.is_empty() {
        work.extend(
            project
                .triggers
                .get(names::NET_FAULT)
                .cloned()
                .unwrap_or_default(),
        );
    }
    while let Some((n, t)) = work.pop() {
        if !seen.insert((n, t)) {
            continue;
        }
        let tr = &project.nets[n].transitions[t];
        reads.set(res.active(n));
        for &p in &tr.flat_inputs {
            reads.set(p);
            writes.set(p);
        }
        for &p in &tr.flat_outputs {
            reads.set(p); // a double token is found by reading it
            writes.set(p);
        }
        if tr
            .event
            .as_deref()
            .is_some_and(|e| category(project, e) == Category::Catastrophic)
        {
            writes.set(res.lockout());
        }
        // Immediate transitions the outputs may enable.
        for (m, net) in project.nets.iter().enumerate() {
            for &u in &net.immediate {
                if net.transitions[u]
                    .flat_inputs
                    .iter()
                    .any(|p| tr.flat_outputs.contains(p))
                {
                    work.push((m, u));
                }
            }
        }
        for a in &tr.actions {
            match a {
                Action::Activate(m) | Action::Deactivate(m) => {
                    let m = *m;
                    writes.set(res.active(m));
                    let offset = project.place_offsets[m];
                    for i in 0..project.nets[m].places.len() {
                        writes.set(offset + i);
                        reads.set(offset + i);
                    }
                    for i in 0..project.nets[m].timers.len() {
                        writes.set(res.timer(m, i));
                    }
                    for (class, _) in res.pending.iter() {
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
                        work.push((m, u));
                    }
                }
                Action::Emit { event, .. } => {
                    if category(project, event) == Category::Catastrophic {
                        writes.set(res.lockout());
                    }
                    work.extend(project.triggers.get(event).cloned().unwrap_or_default());
                }
                Action::Timer { timer, .. } => {
                    writes.set(res.timer(n, *timer));
                }
                Action::Cancel { timer } => writes.set(res.timer(n, *timer)),
                Action::Call {
                    program, function, ..
                } => {
                    issue(res, &mut writes, Class::Call(n, *program, *function));
                }
                Action::Command { verb, .. } => {
                    issue(res, &mut writes, Class::Command(n, verb.clone()));
                }
                Action::Ask { ask, .. } => {
                    let timer = project.nets[n].asks[*ask].timer;
                    writes.set(res.timer(n, timer));
                    issue(res, &mut writes, Class::Question(n, *ask));
                }
            }
        }
    }
    Footprint {
        reads,
        writes,
        enabling,
    }
}

/// A call, command or question issued: its kind is written (the order of
/// pending results is not part of a team's reduced key).
fn issue(res: &Resources, writes: &mut Bits, class: Class) {
    if let Some(r) = res.pending(&class) {
        writes.set(r);
    }
}
