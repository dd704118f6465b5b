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
//! of pending result, and the catastrophic lockouts: one per vehicle and
//! the team's (the order in which timers start and results are awaited is
//! not: a team's reduced key keeps none the player cannot tell apart, see
//! `project_states`). Two classes are dependent when one writes what the
//! other reads or writes.
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
//! (the player's taint), and its class gets the same footprint. Lockouts
//! are never lifted. A locked-out vehicle's events are no inputs; its
//! timers and results still are, and are dropped: the static footprint
//! over-approximates such a step (dropping only takes effects away), so the
//! reduction stays on once vehicles are locked out.
//!
//! In a state, a stubborn set starts from one enabled class and is closed
//! under: an enabled member brings every class dependent on it; a disabled
//! external event brings, for each transition it triggers, the classes
//! that may fulfil one condition that transition lacks in the state (its
//! net active, else one unmarked input place: the one fewest classes
//! mark), or nothing when none is lacking (then a lockout drops it, for
//! good); any other disabled member brings every class that may write what
//! enables it. Only the enabled members (the ample set) are explored, and
//! only when none is *visible* — may deactivate a net that is active and
//! marks none of its final places in the state (a net's own deadness reads
//! it) — unless they are all the enabled classes. A step that may mark a
//! place of an `[[exclusive]]` resource reads every place of it, so that
//! making a second holder is an outcome of the step. The cycle proviso is
//! the explorer's: an ample set is not taken when one of its steps leads to
//! a state numbered no higher than the state expanded, or changes nothing;
//! the next smallest is tried, and the state is expanded fully when none
//! is left (see docs/verify.md for why this preserves every verdict).

use std::collections::HashMap;

use crate::event::Category;
use crate::model::{names, Action, NetId, Project, TransitionId, VehicleId};
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
    /// Per class: the nets it may deactivate (what a net's own deadness
    /// reads; see [`Stubborn::visible`]).
    deactivates: Vec<Vec<NetId>>,
    /// Per net: its final places.
    finals: Vec<Vec<usize>>,
    /// Per external event's class: the net and input places of each
    /// transition it triggers (what enables it in a state).
    waiting: Vec<Vec<(NetId, Vec<usize>)>>,
    /// Per place: the classes that may mark it.
    producers: Vec<Vec<u32>>,
    /// Per net: the classes that may activate it.
    activators: Vec<Vec<u32>>,
}

/// What the stubborn sets read of a state: marked places, active nets.
pub(super) trait Marking {
    fn marked(&self, place: usize) -> bool;
    fn active(&self, net: NetId) -> bool;
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
    fn has(&self, i: usize) -> bool {
        self.0[i / 64] & (1 << (i % 64)) != 0
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
        let mut footprints: Vec<Footprint> = classes
            .iter()
            .map(|c| footprint(project, externals, &res, c, false))
            .collect();
        // A timer or result a catastrophic reaction starts is catastrophic
        // (the player's `tainted`): its class gets a catastrophic step's
        // footprint, and so on for what that step starts.
        let mut tainted = vec![false; classes.len()];
        loop {
            let mut more = false;
            for i in 0..classes.len() {
                let Some(r) = class_resource(&res, &classes[i]) else {
                    continue;
                };
                if tainted[i] {
                    continue;
                }
                if footprints.iter().any(|f| f.catastrophic && f.starts.has(r)) {
                    tainted[i] = true;
                    footprints[i] = footprint(project, externals, &res, &classes[i], true);
                    more = true;
                }
            }
            if !more {
                break;
            }
        }
        // Timers started in one step expire in their order: a timer's
        // enabling reads every timer a class may start with it.
        let starts: Vec<Vec<usize>> = (0..classes.len())
            .map(|i| {
                (0..classes.len())
                    .filter(|&j| {
                        matches!(classes[j], Class::Timer(..))
                            && class_resource(&res, &classes[j])
                                .is_some_and(|r| footprints[i].starts.has(r))
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
        // A step that may mark a place of an `[[exclusive]]` resource reads
        // every place of it: whether the step makes a second holder is then
        // an outcome of the step, which the reduction preserves like any
        // other (see docs/verify.md).
        for resource in &project.exclusive {
            let mut held = Bits::new(res.count());
            for (_, places) in &resource.held {
                for &p in places {
                    held.set(p);
                }
            }
            for f in &mut footprints {
                if f.marks.meets(&held) {
                    for (r, w) in f.reads.0.iter_mut().zip(&held.0) {
                        *r |= w;
                    }
                }
            }
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
        Stubborn {
            index: classes
                .into_iter()
                .enumerate()
                .map(|(i, c)| (c, i as u32))
                .collect(),
            dependent,
            enablers,
            deactivates: footprints.iter().map(|f| f.deactivates.clone()).collect(),
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
        }
    }

    /// What may enable the disabled class `c` in a state: for an external
    /// event, one condition each of its transitions lacks (its net active,
    /// else one input place marked: the one fewest classes mark) and the
    /// classes that may fulfil it; an event none of whose transitions
    /// lacks anything is disabled by a lockout, which nothing lifts. For
    /// any other class, every class that may write what enables it.
    fn enablers_in<'a>(
        &'a self,
        c: usize,
        state: &dyn Marking,
        out: &'a mut Vec<u32>,
    ) -> &'a [u32] {
        if self.waiting[c].is_empty() {
            return &self.enablers[c];
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

    /// Whether class `c` is visible in a state: it may deactivate a net
    /// that is active there and marks none of its final places (a net that
    /// may be dead: the reduction must not take the deactivation first).
    fn visible(&self, c: usize, state: &dyn Marking) -> bool {
        self.deactivates[c]
            .iter()
            .any(|&n| state.active(n) && !self.finals[n].iter().any(|&p| state.marked(p)))
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
        let classes = self.dependent.len();
        let mut is_enabled = vec![false; classes];
        for c in enabled.iter().flatten() {
            is_enabled[*c as usize] = true;
        }
        let distinct = is_enabled.iter().filter(|e| **e).count();
        let mut found: Vec<(usize, Vec<bool>)> = Vec::new();
        let mut lacking = Vec::new();
        let mut seeds: Vec<u32> = enabled.iter().flatten().copied().collect();
        seeds.sort_unstable();
        seeds.dedup();
        let mut member = vec![false; classes];
        let mut work = Vec::new();
        for seed in seeds {
            if self.visible(seed as usize, state) {
                continue;
            }
            member.iter_mut().for_each(|m| *m = false);
            member[seed as usize] = true;
            work.clear();
            work.push(seed);
            let mut size = 1;
            let mut visible = false;
            while let Some(c) = work.pop() {
                let c = c as usize;
                let next = if is_enabled[c] {
                    visible |= self.visible(c, state);
                    &self.dependent[c]
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

/// What a step of class `c` may read and write; `tainted`: the input may
/// be catastrophic (a catastrophic event, or a timer or result a
/// catastrophic reaction may have started).
fn footprint(
    project: &Project,
    externals: &[String],
    res: &Resources,
    c: &Class,
    tainted: bool,
) -> Footprint {
    let mut reads = Bits::new(res.count());
    let mut writes = Bits::new(res.count());
    let mut enabling = Bits::new(res.count());
    let mut marks = Bits::new(res.count());
    let mut starts = Bits::new(res.count());
    let mut deactivates = Vec::new();
    let vehicle = input_vehicle(project, externals, c);
    // The vehicles of the occurrences the step may handle that something
    // hears (an occurrence nothing waits for changes nothing, dropped or
    // not), and whether one may be catastrophic.
    let mut heard: Vec<Option<VehicleId>> = Vec::new();
    let mut catastrophic = tainted;
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
            catastrophic |= category(project, event) == Category::Catastrophic;
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
    // The transitions that may fire in the step.
    let mut seen: std::collections::HashSet<(NetId, TransitionId)> = Default::default();
    // The lockouts that drop the input (the team's, its vehicle's): they
    // decide whether an external event is an input at all, and whether a
    // timer or result fires what awaits it.
    if matches!(c, Class::Event(_)) {
        enabling.set(res.lockout(None));
        enabling.set(res.lockout(vehicle));
    }
    if !start.is_empty() {
        heard.push(vehicle);
    }
    let mut work = start;
    let net_fault = project
        .triggers
        .get(names::NET_FAULT)
        .cloned()
        .unwrap_or_default();
    if !work.is_empty() {
        work.extend(net_fault.iter().copied());
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
            marks.set(p);
        }
        if tr
            .event
            .as_deref()
            .is_some_and(|e| category(project, e) == Category::Catastrophic)
        {
            catastrophic = true;
        }
        // A rejected firing raises the net's `net_fault`.
        if !net_fault.is_empty() {
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
                    work.push((m, u));
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
                    catastrophic |= category(project, event) == Category::Catastrophic;
                    if let Some(waiting) = project.triggers.get(event) {
                        heard.push(project.vehicle_event(event).map(|(_, v)| v));
                        work.extend(waiting.iter().copied());
                    }
                }
                Action::Timer { timer, .. } => {
                    writes.set(res.timer(n, *timer));
                    starts.set(res.timer(n, *timer));
                }
                Action::Cancel { timer } => writes.set(res.timer(n, *timer)),
                Action::Call {
                    program, function, ..
                } => {
                    issue(
                        res,
                        &mut writes,
                        &mut starts,
                        Class::Call(n, *program, *function),
                    );
                }
                Action::Command { verb, .. } => {
                    issue(
                        res,
                        &mut writes,
                        &mut starts,
                        Class::Command(n, verb.clone()),
                    );
                }
                Action::Ask { ask, .. } => {
                    let timer = project.nets[n].asks[*ask].timer;
                    writes.set(res.timer(n, timer));
                    starts.set(res.timer(n, timer));
                    issue(res, &mut writes, &mut starts, Class::Question(n, *ask));
                }
            }
        }
    }
    // An occurrence of a vehicle locked out (or of any, the team's lockout
    // on) is dropped: the step reads those lockouts. A catastrophic one that
    // fires a transition locks its vehicle out (the team, for a team
    // event), and so may every occurrence a catastrophic reaction handles
    // (its emitted events and `net_fault`s are catastrophic too).
    heard.sort_unstable();
    heard.dedup();
    if !heard.is_empty() {
        reads.set(res.lockout(None));
    }
    for &v in &heard {
        reads.set(res.lockout(v));
        if catastrophic {
            writes.set(res.lockout(v));
        }
    }
    Footprint {
        reads,
        writes,
        enabling,
        catastrophic,
        marks,
        starts,
        deactivates,
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
}
