//! The explorer's steps: each input a state allows (external events,
//! timer expiries, results, answers), run through the player on the
//! state's concrete form, the oracle's answer sequences enumerated, and the
//! successors and labels that come out, for [`levels`] to search
//! breadth-first on several threads.

use super::*;

impl levels::Explore for Explorer {
    type Worker = Worker;

    fn worker(&self) -> Worker {
        Worker {
            labels: Vec::new(),
            index: FastMap::default(),
            global: Vec::new(),
            scratch: Scratch::default(),
            next: Vec::new(),
            label_key: Vec::new(),
            this_input: Vec::new(),
            this_input_keys: Vec::new(),
            player: None,
            concrete: None,
            concrete_current: false,
            pending_number: 0,
            todo: Vec::new(),
            todo_bits: Vec::new(),
            answers: Vec::new(),
            used: Vec::new(),
            canon: Vec::new(),
            image: Vec::new(),
            capture: Capture::default(),
            reused: Vec::new(),
            parts: Parts::default(),
            projection: Vec::new(),
            entry: Vec::new(),
            log: Vec::new(),
        }
    }

    fn expand(&self, worker: &mut Worker, key: &[u8], out: &mut levels::Successors<'_>) {
        self.successors(worker, key, out);
    }

    fn label(&self, worker: &mut Worker, local: u32) -> u32 {
        if let Some(&g) = worker.global.get(local as usize) {
            if g != u32::MAX {
                return g;
            }
        }
        let (key, label) = {
            let registry = self.registry.lock().unwrap_or_else(|e| e.into_inner());
            match registry.labels.get(local as usize) {
                Some(entry) => entry.clone(),
                // Never: the workers' labels are all registered.
                None => return u32::MAX,
            }
        };
        let mut table = self.labels.lock().unwrap_or_else(|e| e.into_inner());
        let g = match table.index.get(&key) {
            Some(&g) => g,
            None => {
                let g = table.labels.len() as u32;
                table.labels.push(label);
                table.index.insert(key, g);
                g
            }
        };
        if worker.global.len() <= local as usize {
            worker.global.resize(local as usize + 1, u32::MAX);
        }
        worker.global[local as usize] = g;
        g
    }
}

impl Explorer {
    pub(super) fn new(
        project: Arc<Project>,
        symmetry: bool,
        partial_order: bool,
        steps: Steps,
    ) -> Explorer {
        let externals = external_events(&project)
            .into_iter()
            .map(|name| {
                let event = Event::new(name);
                let category = project
                    .declared_category(&event.name)
                    .unwrap_or(event.category);
                External {
                    waiting: project
                        .triggers
                        .get(&event.name)
                        .cloned()
                        .unwrap_or_default(),
                    catastrophic: category == crate::event::Category::Catastrophic,
                    vehicle: project.vehicle_event(&event.name).map(|(_, v)| v),
                    event,
                }
            })
            .collect();
        let calls = project
            .nets
            .iter()
            .map(|_| {
                project
                    .programs
                    .iter()
                    .map(|p| vec![None; p.functions.len()])
                    .collect()
            })
            .collect();
        let mut explorer = Explorer {
            codec: Codec::new(
                &project,
                (symmetry || partial_order) && !project.vehicles.is_empty(),
            ),
            project,
            externals,
            calls,
            commands: FastMap::default(),
            questions: Vec::new(),
            labels: Mutex::new(LabelTable::default()),
            symmetry: None,
            stubborn: None,
            broken: Mutex::new(None),
            steps,
            compared: Mutex::new((0, None)),
            kept: Kept::new(crate::verify::project_steps::BUDGET),
            registry: Mutex::new(Registry::default()),
            from: None,
        };
        // What is known of every result the nets' actions can await.
        let project = explorer.project.clone();
        explorer.questions = project
            .nets
            .iter()
            .enumerate()
            .map(|(n, net)| {
                (0..net.asks.len())
                    .map(|ask| {
                        explorer.compute_known(&crate::player::Pending {
                            net: n,
                            kind: PendingKind::Question { ask },
                            catastrophic: false,
                        })
                    })
                    .collect()
            })
            .collect();
        for (n, net) in project.nets.iter().enumerate() {
            for action in net.transitions.iter().flat_map(|t| &t.actions) {
                let kind = match action {
                    Action::Call {
                        program, function, ..
                    } => PendingKind::Call {
                        program: *program,
                        function: *function,
                    },
                    Action::Command { verb, .. } => PendingKind::Command { verb: verb.clone() },
                    _ => continue,
                };
                let pending = crate::player::Pending {
                    net: n,
                    kind,
                    catastrophic: false,
                };
                let known = explorer.compute_known(&pending);
                match pending.kind {
                    PendingKind::Call { program, function } => {
                        explorer.calls[n][program][function] = Some(known);
                    }
                    PendingKind::Question { .. } => {}
                    PendingKind::Command { verb } => {
                        let by_net = explorer.commands.entry(verb).or_default();
                        if !by_net.iter().any(|(m, _)| *m == n) {
                            by_net.push((n, known));
                        }
                    }
                }
            }
        }
        if symmetry {
            explorer.symmetry =
                Some(Symmetry::of(&project, explorer.codec.order_free())).filter(Symmetry::reduces);
        }
        if partial_order && !project.vehicles.is_empty() {
            let names: Vec<String> = explorer
                .externals
                .iter()
                .map(|x| x.event.name.clone())
                .collect();
            let stubborn = Stubborn::new(&project, &names);
            explorer.stubborn = Some(stubborn);
        }
        if explorer.symmetry.is_some() || explorer.stubborn.is_some() || explorer.codec.order_free()
        {
            explorer.steps = Steps::Run;
        }
        explorer
    }

    /// The player started at the exploration's instant (or restored to the
    /// state it starts from), answering guards through the oracle, and the
    /// key of its initial state.
    pub(super) fn start(&self) -> (Player, Vec<u8>) {
        let mut player = match &self.from {
            Some(from) => from.clone(),
            None => Player::start(self.project.clone(), T),
        };
        player.set_oracle(Some(Oracle::default()));
        let mut initial = Vec::new();
        self.codec.encode(
            player.state(),
            0,
            T,
            None,
            &|_, p| self.relevant(p),
            &mut Scratch::default(),
            &mut initial,
        );
        (player, initial)
    }

    pub(super) fn run(
        self,
        max_states: usize,
        threads: usize,
        proviso: Proviso,
        progress: Option<&dyn Fn(usize)>,
    ) -> Explored {
        let (mut player, initial) = self.start();
        let effects: Vec<Effect> = player.effects().collect();
        let initial_fired = fired_of(&effects);
        let mut tell = |expanded: usize| {
            if let Some(report) = progress {
                if expanded.is_multiple_of(PROGRESS_EVERY) {
                    report(expanded);
                }
            }
        };
        if let Some(sym) = &self.symmetry {
            // The start-up's immediate transitions, from the initial marking.
            let mut before = player.state().clone();
            before.marking.iter_mut().for_each(|w| *w = 0);
            for (i, g) in self.project.globals.iter().enumerate() {
                if g.initial {
                    before.marking[i / 64] |= 1 << (i % 64);
                }
            }
            for (n, net) in self.project.nets.iter().enumerate() {
                before.active[n] = net.active_at_start;
                if net.active_at_start {
                    for (i, p) in net.places.iter().enumerate() {
                        let f = self.project.place_offsets[n] + i;
                        if p.initial {
                            before.marking[f / 64] |= 1 << (f % 64);
                        }
                    }
                }
            }
            if let Some(why) = sym.order_decides(&self.project, &before, &effects) {
                self.note_broken(why);
            }
        }
        let space = levels::explore(&self, &initial, max_states, threads, proviso, &mut tell);
        let n = space.store.len();
        let reverse = reverse_of(&space.graph, n);
        let labels = self
            .labels
            .into_inner()
            .unwrap_or_else(|e| e.into_inner())
            .labels;
        let mut fired: HashSet<(NetId, TransitionId)> = initial_fired.into_iter().collect();
        for l in &labels {
            fired.extend(l.fired.iter().copied());
        }
        if let Some(sym) = &self.symmetry {
            // What fires in a representative fires in each of its images.
            let seen: Vec<(NetId, TransitionId)> = fired.iter().copied().collect();
            for g in &sym.perms {
                fired.extend(seen.iter().map(|&(n, t)| (g.nets[n], t)));
            }
        }
        Explored {
            project: self.project,
            codec: self.codec,
            space,
            labels,
            fired,
            reverse,
            symmetry: self.symmetry,
            partial_order: self.stubborn.is_some(),
            broken: self.broken.into_inner().unwrap_or_else(|e| e.into_inner()),
            compared: self
                .compared
                .into_inner()
                .unwrap_or_else(|e| e.into_inner()),
            statics: std::sync::OnceLock::new(),
        }
    }

    /// What is known of a pending call or command's result: whether it is
    /// relevant, and the reasons its failure is explored with.
    fn known(&self, pending: &crate::player::Pending) -> std::borrow::Cow<'_, Known> {
        let found = match &pending.kind {
            PendingKind::Call { program, function } => self
                .calls
                .get(pending.net)
                .and_then(|by_program| by_program.get(*program))
                .and_then(|by_function| by_function.get(*function))
                .and_then(Option::as_ref),
            PendingKind::Command { verb } => self
                .commands
                .get(verb.as_str())
                .and_then(|by_net| by_net.iter().find(|(n, _)| *n == pending.net))
                .map(|(_, k)| k),
            PendingKind::Question { ask } => self
                .questions
                .get(pending.net)
                .and_then(|asks| asks.get(*ask)),
        };
        match found {
            Some(k) => std::borrow::Cow::Borrowed(k),
            // Not issued by an action of the project: worked out now.
            None => std::borrow::Cow::Owned(self.compute_known(pending)),
        }
    }

    fn compute_known(&self, pending: &crate::player::Pending) -> Known {
        // A question: always kept, answered with each of its choices.
        if let PendingKind::Question { ask } = pending.kind {
            let choices = &self.project.nets[pending.net].asks[ask].choices;
            return (true, choices.clone());
        }
        (
            self.compute_relevant(pending),
            self.compute_failure_reasons(pending),
        )
    }

    fn relevant(&self, pending: &crate::player::Pending) -> bool {
        self.known(pending).0
    }
    /// Whether the result of a pending call or command can ever fire a
    /// transition of the net that awaits it.
    fn compute_relevant(&self, pending: &crate::player::Pending) -> bool {
        let net = &self.project.nets[pending.net];
        net.transitions.iter().any(|t| {
            let Some(e) = &t.event else { return false };
            match &pending.kind {
                PendingKind::Call { program, function } => {
                    let p = &self.project.programs[*program];
                    let base = format!("{}.{}.", p.name, p.functions[*function].name);
                    e.strip_prefix(&base)
                        .is_some_and(|o| o == names::DONE || o == names::FAILED)
                }
                PendingKind::Question { .. } => true,
                PendingKind::Command { verb } => {
                    if e != names::COMMAND_OK && e != names::COMMAND_FAILED {
                        return false;
                    }
                    let params =
                        Params::from([("verb".to_owned(), crate::value::Value::Str(verb.clone()))]);
                    t.guard
                        .as_ref()
                        .is_none_or(|g| g.expr.holds(&params).unwrap_or(true))
                }
            }
        })
    }

    fn inputs(&self, abs: &Abs) -> Vec<Input> {
        let state = &abs.state;
        // An external event none of whose transitions is enabled by the
        // marking (or that the lockout drops) changes nothing: the player
        // would not even look at a guard. Not run.
        let mut inputs: Vec<Input> = (0..self.externals.len())
            .filter(|&i| {
                let x = &self.externals[i];
                (x.catastrophic || !state.locks(x.vehicle))
                    && x.waiting.iter().any(|&(n, t)| {
                        state.active[n]
                            && self.project.nets[n].transitions[t]
                                .flat_inputs
                                .iter()
                                .all(|&p| state.marked(p))
                    })
            })
            .map(Input::Event)
            .collect();
        let timers = &state.timers;
        for (i, t) in timers.iter().enumerate() {
            let blocked = timers.iter().enumerate().any(|(j, u)| {
                j != i
                    && abs.groups[j] == abs.groups[i]
                    && (u.deadline, u.seq) < (t.deadline, t.seq)
            });
            if !blocked {
                inputs.push(Input::Timer(i));
            }
        }
        for (id, pending) in &state.pending {
            // A question has no "done": its outcomes are its choices (the
            // reasons below) and its timeout (a timer, above).
            if !matches!(pending.kind, PendingKind::Question { .. }) {
                inputs.push(Input::Result {
                    id: *id,
                    reason: None,
                });
            }
            for reason in 0..self.known(pending).1.len() {
                inputs.push(Input::Result {
                    id: *id,
                    reason: Some(reason),
                });
            }
        }
        inputs
    }

    /// Records the first step found whose outcome the player's order of
    /// vehicles decided (the smallest text, whatever the threads).
    fn note_broken(&self, why: String) {
        let mut broken = self.broken.lock().unwrap_or_else(|e| e.into_inner());
        if broken.as_ref().is_none_or(|b| why < *b) {
            *broken = Some(why);
        }
    }

    /// The class of an input, for the stubborn sets.
    fn class_of(&self, stubborn: &Stubborn, abs: &Abs, input: &Input) -> Option<u32> {
        match input {
            Input::Event(i) => stubborn.class(&Class::Event(*i)),
            Input::Timer(i) => {
                let t = &abs.state.timers[*i];
                stubborn.class(&Class::Timer(t.net, t.timer))
            }
            Input::Result { id, .. } => abs
                .state
                .pending
                .get(id)
                .and_then(|p| stubborn.class_of_pending(p)),
        }
    }

    fn successors(&self, w: &mut Worker, key: &[u8], out: &mut levels::Successors<'_>) {
        if self.symmetry.is_some() && self.broken.lock().map_or(true, |b| b.is_some()) {
            return; // the exploration is given up: no need to go on
        }
        // A state whose projection was expanded before: its outcomes again,
        // without the player.
        let mut found = None;
        w.log.clear();
        let reuse = self.steps != Steps::Run && w.parts.read(&self.codec, key);
        let h = if reuse {
            crate::verify::project_steps::projection(key, &w.parts, &mut w.projection);
            let h = Kept::hash(&w.projection);
            found = self.kept.find(&w.projection, h);
            match &found {
                Some(entry) if self.steps == Steps::Reuse => {
                    Self::reuse(w, entry, key, &mut |label, next| {
                        out.push(label, next, 0);
                    });
                    return;
                }
                Some(_) => {}
                None if self.kept.full() => {}
                None => w.capture.begin(w.parts.pending()),
            }
            h
        } else {
            0
        };
        let abs = self.codec.decode(key);
        w.concrete_current = false;
        let inputs = self.inputs(&abs);
        // The ample sets, when the stubborn sets reduce in this state (and
        // the search does not ask for every input).
        let stubborn = self.stubborn.as_ref().filter(|_| !out.full());
        let ample = stubborn.map_or(Vec::new(), |stubborn| {
            let classes: Vec<Option<u32>> = inputs
                .iter()
                .map(|i| self.class_of(stubborn, &abs, i))
                .collect();
            stubborn.ample(&classes, &abs.state, AMPLE_TRIES)
        });
        // An ample set one of whose steps changes nothing is not taken,
        // nor under the levels' cycle proviso (see [`Proviso`]) one of
        // whose steps leads to a state numbered no higher than this one
        // (stored before it, or itself: every cycle has such a step); the
        // next is tried, and the state is expanded fully when none is left.
        for set in &ample {
            let mark = out.mark();
            let mut known = false;
            for (input, _) in inputs.iter().zip(set).filter(|(_, a)| **a) {
                known = self.input_successors(w, key, &abs, input, out);
                if known {
                    break;
                }
            }
            if !known {
                out.set_reduced();
                return;
            }
            out.undo(mark);
        }
        for input in &inputs {
            self.input_successors(w, key, &abs, input, out);
        }
        if let Some(entry) = found {
            self.compare(w, &entry, key);
        }
        if let Some(entry) = w.capture.finish() {
            self.kept.insert(&w.projection, h, entry);
        }
    }

    /// The registry's number of the label of key `key` (made by `make` if
    /// no worker made it before), and the label.
    fn register(&self, key: &[u8], make: impl FnOnce() -> Label) -> (u32, Label) {
        let mut registry = self.registry.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(&l) = registry.index.get(key) {
            return (l, registry.labels[l as usize].1.clone());
        }
        let label = make();
        let l = registry.labels.len() as u32;
        registry.labels.push((key.to_vec(), label.clone()));
        registry.index.insert(key.to_vec(), l);
        (l, label)
    }

    /// The text of the label numbered `l` in the registry.
    pub(super) fn label_text(&self, l: u32) -> String {
        let registry = self.registry.lock().unwrap_or_else(|e| e.into_inner());
        registry
            .labels
            .get(l as usize)
            .map_or_else(String::new, |(_, label)| label.text.clone())
    }

    /// The edges of the state `key` (read into `w.parts`) by the outcomes
    /// kept in `entry`, in the order the player's runs would give them.
    fn reuse(w: &mut Worker, entry: &Entry, key: &[u8], push: &mut dyn FnMut(u32, &[u8])) {
        entry.edges(
            key,
            &w.parts,
            &mut w.next,
            &mut w.reused,
            &mut w.this_input_keys,
            push,
        );
    }

    /// Compares the edges the player's runs gave (`w.log`) with what
    /// reusing `entry` gives ([`Steps::Compare`]).
    fn compare(&self, w: &mut Worker, entry: &Entry, key: &[u8]) {
        let mut reused: Vec<(u32, Vec<u8>)> = Vec::new();
        Self::reuse(w, entry, key, &mut |label, next| {
            reused.push((label, next.to_vec()))
        });
        let mut compared = self.compared.lock().unwrap_or_else(|e| e.into_inner());
        compared.0 += 1;
        // (Labels are the registry's numbers: equal when their keys are.)
        let same = reused == w.log;
        if !same && compared.1.is_none() {
            let text = |edges: &[(u32, Vec<u8>)]| -> Vec<String> {
                edges
                    .iter()
                    .map(|(l, k)| {
                        format!("{} → {:?}", self.label_text(*l), self.codec.decode(k).state)
                    })
                    .collect()
            };
            compared.1 = Some(format!(
                "state {:?}: the player gives {:#?}, reuse gives {:#?}",
                self.codec.decode(key).state,
                text(&w.log),
                text(&reused)
            ));
        }
    }

    /// The successors of the state `key` (decoded: `abs`) by one input;
    /// whether one of them was stored before it (or is it) or the input
    /// changed nothing.
    fn input_successors(
        &self,
        w: &mut Worker,
        key: &[u8],
        abs: &Abs,
        input: &Input,
        out: &mut levels::Successors<'_>,
    ) -> bool {
        let mut known = false;
        let mut pushed = false;
        {
            w.this_input.clear();
            w.this_input_keys.clear();
            let concrete = w.concrete.get_or_insert_with(|| abs.state.clone());
            let (seq_before, pending_changed) =
                set_concrete(abs, input, concrete, w.concrete_current);
            w.concrete_current = true;
            w.pending_number += u64::from(pending_changed);
            let concrete = &*concrete;
            if w.capture.active() {
                w.capture.input(match input {
                    Input::Result { id, .. } => 1 + w.parts.canon(id.wrapping_sub(1) as usize),
                    _ => 0,
                });
            }
            // Every sequence of oracle answers, depth first: a stack of
            // ranges of `todo_bits`.
            w.todo.clear();
            w.todo_bits.clear();
            w.todo.push(0..0);
            while let Some(range) = w.todo.pop() {
                w.answers.clear();
                w.answers.extend_from_slice(&w.todo_bits[range.clone()]);
                w.todo_bits.truncate(range.start);
                let answers = &w.answers;
                let Some(player) =
                    self.step(&mut w.player, concrete, w.pending_number, input, answers)
                else {
                    w.capture.abandon();
                    continue;
                };
                // Read where the player recorded them (its next restore
                // clears them).
                let effects: &[Effect] = player.recorded();
                let questions: &[Question] = player.oracle().map_or(&[], |o| &o.questions);
                let asked = questions.len();
                for k in answers.len()..asked {
                    let start = w.todo_bits.len();
                    w.todo_bits.extend_from_slice(answers);
                    w.todo_bits.resize(start + k, false);
                    w.todo_bits.push(true);
                    w.todo.push(start..w.todo_bits.len());
                }
                w.used.clear();
                w.used.extend_from_slice(answers);
                w.used.resize(asked, false);
                let used = &w.used;
                self.codec.encode(
                    player.state(),
                    seq_before,
                    T + 1,
                    Some(abs),
                    &|id, p| {
                        // The state's own pending calls are in its key, so
                        // relevant (relevance depends on a call's net and
                        // kind only; without symmetry, the key is the state
                        // encoded): only the step's new ones are looked up.
                        (id < abs.state.next_id && self.symmetry.is_none()) || self.relevant(p)
                    },
                    &mut w.scratch,
                    &mut w.next,
                );
                let mut unsafe_by = None;
                let mut livelock = None;
                let mut fires = false;
                for e in effects {
                    match e {
                        Effect::Fired { .. } => fires = true,
                        Effect::Fault {
                            fault: Fault::DoubleToken { net, .. },
                            ..
                        } => unsafe_by = unsafe_by.or(Some(*net)),
                        Effect::Fault {
                            fault: Fault::Livelock { net, .. },
                            ..
                        } => livelock = Some(Some(*net)),
                        Effect::Fault {
                            fault: Fault::Overflow { .. },
                            ..
                        } => livelock = livelock.or(Some(None)),
                        _ => {}
                    }
                }
                let flagged = fires || unsafe_by.is_some() || livelock.is_some();
                // Nothing happened: not an edge (but its outcome is captured,
                // below, since it may change another key of the projection).
                let nothing = !flagged && w.next == key;
                if nothing && !w.capture.active() {
                    continue;
                }
                // The step's label, known by what its text says.
                label_key(abs, input, questions, used, effects, &mut w.label_key);
                let local = match w.index.get(&w.label_key) {
                    Some(&l) => l,
                    None => {
                        let (l, label) = self.register(&w.label_key, || {
                            Label::new(
                                self.describe(abs, input, questions, used, effects),
                                fired_of(effects),
                                unsafe_by,
                                livelock,
                            )
                        });
                        if w.labels.len() <= l as usize {
                            w.labels.resize(l as usize + 1, None);
                        }
                        w.labels[l as usize] = Some(label);
                        w.index.insert(w.label_key.clone(), l);
                        l
                    }
                };
                if w.capture.active() {
                    let step = Step {
                        key,
                        parts: &w.parts,
                        after: player.state(),
                        seq_before,
                        next_id: abs.state.next_id,
                        step_time: T + 1,
                        next: &w.next,
                        relevant: &|p| self.relevant(p),
                    };
                    let labels = &w.labels;
                    let alike = |a: u32, b: u32| match (&labels[a as usize], &labels[b as usize]) {
                        (Some(a), Some(b)) => a.alike(b),
                        _ => false,
                    };
                    w.capture
                        .outcome(&self.codec, &step, local, flagged, &alike, &mut w.entry);
                    if nothing {
                        continue;
                    }
                }
                // Answers that end alike (an event lacking `lat` or `lon`
                // is rejected the same way) make one edge: the first.
                let labels = &w.labels;
                if w.this_input.iter().any(|(l, range)| {
                    w.this_input_keys[range.clone()] == w.next[..]
                        && match (&labels[*l as usize], &labels[local as usize]) {
                            (Some(a), Some(b)) => a.alike(b),
                            _ => false,
                        }
                }) {
                    continue;
                }
                let start = w.this_input_keys.len();
                w.this_input_keys.extend_from_slice(&w.next);
                w.this_input.push((local, start..w.this_input_keys.len()));
                pushed = true;
                if self.steps == Steps::Compare {
                    w.log.push((local, w.next.clone()));
                }
                match &self.symmetry {
                    None => known |= out.push(local, &w.next, 0),
                    Some(sym) => {
                        if let Some(why) = sym.order_decides(&self.project, &abs.state, effects) {
                            self.note_broken(why);
                        }
                        let perm = sym.canonical(&w.next, &mut w.canon, &mut w.image);
                        known |= out.push(local, &w.canon, perm);
                    }
                }
            }
        }
        w.capture.end_input();
        known || !pushed
    }

    /// Runs one input on `concrete` (see [`set_concrete`]) with the oracle's
    /// `answers`, in the worker's player: the player after it.
    /// `pending` numbers `concrete`'s pending calls (see
    /// [`Player::reset_for_verifier`]).
    fn step<'p>(
        &self,
        slot: &'p mut Option<Player>,
        concrete: &State,
        pending: u64,
        input: &Input,
        answers: &[bool],
    ) -> Option<&'p mut Player> {
        let player = match slot {
            Some(player) => {
                player.reset_for_verifier(concrete, pending, answers);
                player
            }
            None => {
                // A state the explorer built itself always fits its project.
                let mut player = Player::restore(self.project.clone(), concrete.clone()).ok()?;
                player.reset_for_verifier(concrete, pending, answers);
                slot.insert(player)
            }
        };
        match input {
            Input::Event(i) => player.handle(&self.externals[*i].event, T + 1),
            Input::Timer(_) => player.advance(T + 1),
            Input::Result { id, reason } => {
                let pending = concrete.pending.get(id);
                let question =
                    pending.is_some_and(|p| matches!(p.kind, PendingKind::Question { .. }));
                match self.reason(pending, *reason) {
                    Some(choice) if question => {
                        // Refusal cannot happen: the choice is offered.
                        let _ = player.answer(*id, &choice, T + 1);
                    }
                    None => player.result(*id, Outcome::Done(Params::new()), T + 1),
                    Some(r) => player.result(*id, Outcome::Failed(r.into_owned()), T + 1),
                }
            }
        }
        Some(player)
    }

    /// The text of reason number `reason` of a pending result (`None`:
    /// done, or a result that is not pending: its inputs are only listed
    /// from the pending results of a state).
    fn reason(
        &self,
        pending: Option<&crate::player::Pending>,
        reason: Option<usize>,
    ) -> Option<std::borrow::Cow<'_, str>> {
        let (pending, reason) = (pending?, reason?);
        match self.known(pending) {
            std::borrow::Cow::Borrowed(k) => k.1.get(reason).map(|r| r.as_str().into()),
            std::borrow::Cow::Owned(k) => k.1.get(reason).map(|r| r.clone().into()),
        }
    }

    /// The reasons a failed call or command is explored with: one per way
    /// the guards of the transitions awaiting the failure can read its
    /// `reason` (each string they compare it with, and one they do not),
    /// so that a guard on the reason is answered both ways, and answers
    /// that no reason could give together are never explored.
    fn compute_failure_reasons(&self, pending: &crate::player::Pending) -> Vec<String> {
        let (event, verb) = match &pending.kind {
            PendingKind::Call { program, function } => {
                let p = &self.project.programs[*program];
                (
                    format!(
                        "{}.{}.{}",
                        p.name,
                        p.functions[*function].name,
                        names::FAILED
                    ),
                    None,
                )
            }
            PendingKind::Command { verb } => (names::COMMAND_FAILED.to_owned(), Some(verb)),
            PendingKind::Question { .. } => return Vec::new(),
        };
        let guards: Vec<&crate::expr::Expr> = self.project.nets[pending.net]
            .transitions
            .iter()
            .filter(|t| t.event.as_deref() == Some(event.as_str()))
            .filter_map(|t| t.guard.as_ref().map(|g| &g.expr))
            .collect();
        let mut literals: BTreeSet<String> = BTreeSet::new();
        for g in &guards {
            reason_literals(g, &mut literals);
        }
        let other = ["failed", "other", "unknown"]
            .iter()
            .map(|s| (*s).to_owned())
            .chain((1..).map(|i| format!("failed {i}")))
            .find(|s| !literals.contains(s))
            .unwrap_or_default();
        // One reason per distinct reading of the guards, the other first.
        let mut seen: Vec<Vec<Option<bool>>> = Vec::new();
        let mut out = Vec::new();
        for reason in std::iter::once(other).chain(literals) {
            let mut params =
                Params::from([(REASON.to_owned(), crate::value::Value::Str(reason.clone()))]);
            if let Some(v) = verb {
                params.insert("verb".to_owned(), crate::value::Value::Str(v.clone()));
            }
            let reading: Vec<Option<bool>> = guards.iter().map(|g| g.holds(&params).ok()).collect();
            if !seen.contains(&reading) {
                seen.push(reading);
                out.push(reason);
            }
        }
        out
    }

    fn describe(
        &self,
        abs: &Abs,
        input: &Input,
        questions: &[Question],
        answers: &[bool],
        effects: &[Effect],
    ) -> String {
        let p = &self.project;
        let mut text = match input {
            Input::Event(i) => self.externals[*i].event.name.clone(),
            Input::Timer(i) => {
                let t = &abs.state.timers[*i];
                format!(
                    "timer {}.{}",
                    p.nets[t.net].name, p.nets[t.net].timers[t.timer]
                )
            }
            Input::Result { id, reason } => {
                let reason = self.reason(abs.state.pending.get(id), *reason);
                let done = reason.is_none();
                let outcome = if done { names::DONE } else { names::FAILED };
                let mut text = match abs.state.pending.get(id).map(|x| &x.kind) {
                    Some(PendingKind::Call { program, function }) => {
                        let prog = &p.programs[*program];
                        format!("{}.{}.{outcome}", prog.name, prog.functions[*function].name)
                    }
                    Some(PendingKind::Command { verb }) => {
                        format!("command.{} ({verb})", if done { "ok" } else { "failed" })
                    }
                    Some(PendingKind::Question { ask }) => {
                        let net = abs.state.pending.get(id).map_or(0, |x| x.net);
                        let a = &p.nets[net].asks[*ask];
                        let choice = reason.as_deref().unwrap_or_default();
                        // The choice is in the event's name: no reason below.
                        format!("{} (answer)", a.answer_event(choice))
                    }
                    None => format!("result #{id}"),
                };
                // The reason, when the guards tell reasons apart.
                if let Some(r) = reason {
                    let explored = abs
                        .state
                        .pending
                        .get(id)
                        .filter(|x| !matches!(x.kind, PendingKind::Question { .. }))
                        .map_or(1, |x| self.known(x).1.len());
                    if explored > 1 {
                        text.push_str(&format!(" [reason: {r:?}]"));
                    }
                }
                text
            }
        };
        // The external event's parameters, as the oracle said.
        let carried = |present: bool| -> Vec<&str> {
            questions
                .iter()
                .zip(answers)
                .filter_map(|(q, a)| match q {
                    Question::Carries(p) if *a == present => Some(&**p),
                    _ => None,
                })
                .collect()
        };
        let (with, without) = (carried(true), carried(false));
        if !with.is_empty() || !without.is_empty() {
            let mut parts = Vec::new();
            if !with.is_empty() {
                parts.push(format!("with {}", with.join(", ")));
            }
            if !without.is_empty() {
                parts.push(format!("without {}", without.join(", ")));
            }
            text.push_str(&format!(" [{}]", parts.join("; ")));
        }
        let guards: Vec<&str> = questions
            .iter()
            .zip(answers)
            .filter(|(q, _)| **q == Question::Guard)
            .map(|(_, b)| if *b { "yes" } else { "no" })
            .collect();
        if !guards.is_empty() {
            text.push_str(&format!(" [guards: {}]", guards.join(", ")));
        }
        let fired: Vec<String> = effects.iter().filter_map(|e| e.fired_label(p)).collect();
        if !fired.is_empty() {
            text.push_str(&format!(" → {}", fired.join(", ")));
        }
        for e in effects {
            if let Effect::Fault { fault, .. } = e {
                let what = match fault {
                    Fault::DoubleToken {
                        net,
                        transition,
                        place,
                    } => format!(
                        "{}.{} would put a second token in {}",
                        p.nets[*net].name,
                        p.nets[*net].transitions[*transition].name,
                        crate::player::flat_place_name(p, *place)
                    ),
                    Fault::Livelock { firings, .. } => {
                        format!("livelock: {firings} immediate firings")
                    }
                    Fault::Overflow { steps } => format!("livelock: {steps} emitted events"),
                    _ => continue,
                };
                text.push_str(&format!(" ✗ {what}"));
            }
        }
        text
    }
}

/// The concrete state an input runs on: `abs` at instant `T`, every timer
/// due after the step's instant, except the one the input expires (due at
/// it); and the start order the step's first new timer gets, and whether
/// the pending calls changed. `current`: `concrete` already holds `abs`'s
/// pending calls (set for an earlier input of the same state; only this
/// function changes `concrete`).
fn set_concrete(abs: &Abs, input: &Input, concrete: &mut State, current: bool) -> (u64, bool) {
    let expire = match input {
        Input::Timer(i) => Some(*i),
        _ => None,
    };
    let from = &abs.state;
    concrete.marking.clone_from(&from.marking);
    concrete.active.clone_from(&from.active);
    concrete.timers.clone_from(&from.timers);
    concrete
        .queue
        .iter_mut()
        .for_each(std::collections::VecDeque::clear);
    concrete.lockout = from.lockout;
    concrete.locked.clone_from(&from.locked);
    let pending_changed = !current && concrete.pending != from.pending;
    if pending_changed {
        concrete.pending.clone_from(&from.pending);
    }
    concrete.next_id = from.next_id;
    concrete.next_timer_seq = from.next_timer_seq;
    concrete.now = T;
    for (i, t) in concrete.timers.iter_mut().enumerate() {
        t.deadline = if Some(i) == expire {
            T + 1
        } else {
            T + 2 + t.deadline
        };
    }
    concrete.timers.sort_by_key(|t| (t.deadline, t.seq));
    (concrete.next_timer_seq, pending_changed)
}

/// The bytes that tell one step's label from another's: the input, the
/// oracle's answers, what fired and the faults its text names (the label is
/// a function of them).
fn label_key(
    abs: &Abs,
    input: &Input,
    questions: &[Question],
    answers: &[bool],
    effects: &[Effect],
    out: &mut Vec<u8>,
) {
    out.clear();
    let u32_ = |out: &mut Vec<u8>, v: usize| out.extend_from_slice(&(v as u32).to_le_bytes());
    let str_ = |out: &mut Vec<u8>, s: &str| {
        out.extend_from_slice(&(s.len() as u32).to_le_bytes());
        out.extend_from_slice(s.as_bytes());
    };
    match input {
        Input::Event(i) => {
            out.push(0);
            u32_(out, *i);
        }
        Input::Timer(i) => {
            let t = &abs.state.timers[*i];
            out.push(1);
            u32_(out, t.net);
            u32_(out, t.timer);
        }
        Input::Result { id, reason } => {
            out.push(2);
            match abs.state.pending.get(id) {
                Some(p) => {
                    out.push(1);
                    u32_(out, p.net);
                    match &p.kind {
                        PendingKind::Call { program, function } => {
                            out.push(0);
                            u32_(out, *program);
                            u32_(out, *function);
                        }
                        PendingKind::Command { verb } => {
                            out.push(1);
                            str_(out, verb);
                        }
                        PendingKind::Question { ask } => {
                            out.push(2);
                            u32_(out, *ask);
                        }
                    }
                }
                None => {
                    out.push(0);
                    out.extend_from_slice(&id.to_le_bytes());
                }
            }
            // The reason's index: what is known of a result depends on
            // its net and kind only, written above.
            match reason {
                None => out.push(0),
                Some(r) => {
                    out.push(1);
                    u32_(out, *r);
                }
            }
        }
    }
    u32_(out, questions.len());
    for (q, a) in questions.iter().zip(answers) {
        match q {
            Question::Guard => out.push(u8::from(*a)),
            Question::Carries(p) => {
                out.push(2 + u8::from(*a));
                str_(out, p);
            }
        }
    }
    for e in effects {
        match e {
            Effect::Fired {
                net, transition, ..
            } => {
                out.push(b'F');
                u32_(out, *net);
                u32_(out, *transition);
            }
            Effect::Fault { fault, .. } => match fault {
                Fault::DoubleToken {
                    net,
                    transition,
                    place,
                } => {
                    out.push(b'D');
                    u32_(out, *net);
                    u32_(out, *transition);
                    u32_(out, *place);
                }
                Fault::Livelock {
                    net,
                    transition,
                    firings,
                } => {
                    out.push(b'L');
                    u32_(out, *net);
                    u32_(out, *transition);
                    u32_(out, *firings);
                }
                Fault::Overflow { steps } => {
                    out.push(b'O');
                    u32_(out, *steps);
                }
                _ => {}
            },
            _ => {}
        }
    }
}

/// The strings a guard compares its `reason` parameter with.
fn reason_literals(expr: &crate::expr::Expr, out: &mut BTreeSet<String>) {
    use crate::expr::Expr;
    use crate::value::Value;
    match expr {
        Expr::Binary(_, a, b) => {
            match (a.as_ref(), b.as_ref()) {
                (Expr::Param { name, .. }, Expr::Lit(Value::Str(s)))
                | (Expr::Lit(Value::Str(s)), Expr::Param { name, .. })
                    if name == REASON =>
                {
                    out.insert(s.clone());
                }
                _ => {}
            }
            reason_literals(a, out);
            reason_literals(b, out);
        }
        Expr::Not(e) | Expr::Neg(e) | Expr::BitNot(e) => reason_literals(e, out),
        Expr::List(items) => items.iter().for_each(|e| reason_literals(e, out)),
        Expr::Map(items) => items.iter().for_each(|(_, e)| reason_literals(e, out)),
        Expr::Lit(_) | Expr::Param { .. } => {}
    }
}

fn fired_of(effects: &[Effect]) -> Vec<(NetId, TransitionId)> {
    effects
        .iter()
        .filter_map(|e| match e {
            Effect::Fired {
                net, transition, ..
            } => Some((*net, *transition)),
            _ => None,
        })
        .collect()
}
