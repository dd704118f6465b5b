//! A check's verdicts, read off its exploration: for the project and for
//! each net in it, dead and unsafe states with the shortest paths to them,
//! conflicts that never arise, and loops with a cycle each.

use super::*;

/// Breadth-first searches allowed for listing loops, per report.
const LOOP_SEARCHES: usize = 500;

impl Explored {
    /// The step that showed the player breaking the symmetry, if one did
    /// (then the exploration stopped early and proves nothing).
    pub(super) fn symmetry_broken(&self) -> Option<&str> {
        self.broken.as_deref()
    }

    /// Whether the exploration proves that a conflict never arises: it is
    /// complete and not reduced by partial order (which skips states), no
    /// net emits the event (so it only ever arrives as an input, in an
    /// explored state) and no explored state (nor, with symmetry, its
    /// images) marks the input places of both transitions with both nets
    /// active.
    fn never_together(&self, w: &Warning) -> bool {
        let Some((event, pair)) = &w.conflict else {
            return false;
        };
        if !self.space.complete
            || self.partial_order
            || event == names::NET_FAULT
            || emitted_events(&self.project).contains(event)
        {
            return false;
        }
        let enabled = |st: &[u8], (n, t): (NetId, TransitionId)| {
            self.codec.active(st, n)
                && self.project.nets[n].transitions[t]
                    .flat_inputs
                    .iter()
                    .all(|&p| self.codec.marked(st, p))
        };
        let images: Vec<[(NetId, TransitionId); 2]> = match &self.symmetry {
            None => vec![*pair],
            Some(sym) => sym
                .perms
                .iter()
                .map(|g| {
                    [
                        (g.nets[pair[0].0], pair[0].1),
                        (g.nets[pair[1].0], pair[1].1),
                    ]
                })
                .collect(),
        };
        !(0..self.space.store.len() as u32).any(|s| {
            let st = self.space.store.get(s);
            images
                .iter()
                .any(|pair| enabled(st, pair[0]) && enabled(st, pair[1]))
        })
    }

    /// The symmetry element (index) that maps the representatives' names to
    /// the real ones at each step of the path to state `s`, and at its end.
    fn path_perms(&self, s: u32) -> (Vec<(u32, u8)>, u8) {
        let steps = self.space.path_with_perms(s);
        let Some(sym) = &self.symmetry else {
            return (steps.into_iter().map(|(l, _)| (l, 0)).collect(), 0);
        };
        let mut sigma = 0u8;
        let mut out = Vec::with_capacity(steps.len());
        for (l, perm) in steps {
            out.push((l, sigma));
            sigma = sym.compose(sigma, sym.inverse[perm as usize]);
        }
        (out, sigma)
    }

    /// A real path to state `s` (its steps' texts), followed by `last` if
    /// given; renamed so that the net `m` of the representative is `x`
    /// (`rename: Some((m, x))`).
    fn real_path(&self, s: u32, last: Option<u32>, rename: Option<(NetId, NetId)>) -> Vec<String> {
        let (steps, end) = self.path_perms(s);
        let text = |l: u32| &self.labels[l as usize].text;
        let Some(sym) = &self.symmetry else {
            let mut out: Vec<String> = steps.iter().map(|(l, _)| text(*l).clone()).collect();
            out.extend(last.map(|l| text(l).clone()));
            return out;
        };
        // Then a last element `h` so that the named net ends where asked.
        let h = rename
            .and_then(|(m, x)| {
                let real = sym.perms[end as usize].nets[m];
                (0..sym.perms.len()).find(|&h| sym.perms[h].nets[real] == x)
            })
            .unwrap_or(0) as u8;
        let mut out: Vec<String> = steps
            .iter()
            .map(|(l, sigma)| sym.rename(sym.compose(h, *sigma), text(*l)))
            .collect();
        if let Some(l) = last {
            out.push(sym.rename(sym.compose(h, end), text(l)));
        }
        out
    }

    /// The verdict for the whole project (`None`) or one net in it, with
    /// the warnings found without exploring if `statics`.
    ///
    /// With symmetry, a net's verdict reads every net of its orbit in each
    /// representative (nodes `state × orbit member`): the net in the real
    /// state `g·s` is the member `g⁻¹(net)` in `s`.
    pub(super) fn verdict(&self, net: Option<NetId>, statics: bool) -> Report {
        let space = &self.space;
        let labels = &self.labels;
        let n = space.store.len();
        let codec = &self.codec;
        let key = |s: u32| space.store.get(s);
        let project = &self.project;

        // The nets the verdict is about, per node, and the product graph.
        let orbit: Vec<Option<NetId>> = match (net, &self.symmetry) {
            (None, _) => vec![None],
            (Some(x), None) => vec![Some(x)],
            (Some(x), Some(sym)) => {
                let mut members: Vec<NetId> = vec![x];
                for g in &sym.perms {
                    if !members.contains(&g.nets[x]) {
                        members.push(g.nets[x]);
                    }
                }
                members.into_iter().map(Some).collect()
            }
        };
        let k = orbit.len();
        let nodes = n * k;
        let state_of = |u: u32| u / k as u32;
        let net_of = |u: u32| orbit[u as usize % k];
        let (graph, perms) = if k == 1 {
            (
                std::borrow::Cow::Borrowed(&space.graph),
                std::borrow::Cow::Borrowed(&space.perms[..]),
            )
        } else {
            let sym = self.symmetry.as_ref();
            let mut g = Csr::default();
            let mut perms = Vec::new();
            for s in 0..n as u32 {
                let first = space.graph.first_edge(s);
                for i in 0..k {
                    let mut edges = Vec::new();
                    for (e, (l, t)) in space.graph.edges(s).enumerate() {
                        let perm = space.perms[first + e];
                        let image =
                            orbit[i].map(|m| sym.map_or(m, |y| y.perms[perm as usize].nets[m]));
                        let j = orbit.iter().position(|o| *o == image).unwrap_or(i);
                        edges.push((*l, t * k as u32 + j as u32));
                        perms.push(perm);
                    }
                    g.push_node(edges);
                }
            }
            (std::borrow::Cow::Owned(g), std::borrow::Cow::Owned(perms))
        };
        let g: &Csr<u32> = &graph;
        let reverse = if k == 1 {
            std::borrow::Cow::Borrowed(&self.reverse)
        } else {
            std::borrow::Cow::Owned(reverse_of(g, nodes))
        };
        let in_scope_at = |u: u32, m: NetId| net_of(u).is_none_or(|x| x == m);

        // Live nodes: those from which a firing step (of the node's net) is
        // reachable. Also the first unsafe step and the livelocks, in
        // breadth-first order, so their examples are shortest.
        let mut live = vec![false; nodes];
        let mut queue = VecDeque::new();
        let mut first_unsafe: Option<(u32, u32)> = None;
        let mut livelocks: Vec<(u32, u32)> = Vec::new();
        for u in 0..nodes as u32 {
            for (l, _) in g.edges(u) {
                let label = &labels[*l as usize];
                if label.fires(net_of(u)) && !live[u as usize] {
                    live[u as usize] = true;
                    queue.push_back(u);
                }
                if first_unsafe.is_none() && label.unsafe_by.is_some_and(|m| in_scope_at(u, m)) {
                    first_unsafe = Some((u, *l));
                }
                if let Some(by) = label.livelock {
                    if by.is_none_or(|m| in_scope_at(u, m)) && livelocks.len() < 10 {
                        livelocks.push((u, *l));
                    }
                }
            }
        }
        while let Some(u) = queue.pop_front() {
            for (_, p) in reverse.edges(u) {
                if !live[p as usize] {
                    live[p as usize] = true;
                    queue.push_back(p);
                }
            }
        }
        let finals: Vec<Vec<usize>> = orbit.iter().map(|&m| final_places(project, m)).collect();
        let dead: Vec<u32> = (0..nodes as u32)
            .filter(|&u| {
                let st = key(state_of(u));
                !live[u as usize]
                    && net_of(u).is_none_or(|x| codec.active(st, x))
                    && !finals[u as usize % k].iter().any(|&p| codec.marked(st, p))
            })
            .collect();

        // A net's own view: whether it is active and its marking, numbered
        // in order of first appearance.
        let (states, edges, dead_markings) = match net {
            None => (n, g.edge_count(), dead.len()),
            Some(x) => {
                let places = project.nets[x].places.len();
                let mut ids: HashMap<Vec<u8>, u32> = HashMap::new();
                let mut buf: Vec<u8> = Vec::with_capacity(places + 1);
                let view: Vec<u32> = (0..nodes as u32)
                    .map(|u| {
                        let st = key(state_of(u));
                        let m = net_of(u).unwrap_or(x);
                        let offset = project.place_offsets[m];
                        buf.clear();
                        buf.push(u8::from(codec.active(st, m)));
                        buf.extend((0..places).map(|i| u8::from(codec.marked(st, offset + i))));
                        if let Some(&id) = ids.get(&buf) {
                            return id;
                        }
                        let next = ids.len() as u32;
                        ids.insert(buf.clone(), next);
                        next
                    })
                    .collect();
                let mut moves: Vec<u64> = Vec::new();
                for u in 0..nodes as u32 {
                    for (l, t) in g.edges(u) {
                        if labels[*l as usize].fires(net_of(u)) {
                            moves.push(
                                u64::from(view[u as usize]) << 32 | u64::from(view[t as usize]),
                            );
                        }
                    }
                }
                moves.sort_unstable();
                moves.dedup();
                let dead_views: HashSet<u32> = dead.iter().map(|&u| view[u as usize]).collect();
                (ids.len(), moves.len(), dead_views.len())
            }
        };

        // Loops of firing steps, each listed once: the firing edges (with
        // their symmetry elements), their components, a shortest cycle.
        let mut firing = Csr::default();
        let mut firing_perms: Vec<u8> = Vec::new();
        for u in 0..nodes as u32 {
            let first = g.first_edge(u);
            let mut out = Vec::new();
            for (e, (l, t)) in g.edges(u).enumerate() {
                if labels[*l as usize].fires(net_of(u)) {
                    out.push((*l, t));
                    firing_perms.push(perms.get(first + e).copied().unwrap_or(0));
                }
            }
            firing.push_node(out);
        }
        let sccs = graph::strongly_connected_components(&firing);
        let mut loops = Vec::new();
        let mut loop_keys: HashSet<Vec<String>> = HashSet::new();
        let mut searches = 0;
        for u in 0..nodes as u32 {
            let c = sccs.component[u as usize];
            if !sccs.cyclic[c as usize] || searches >= LOOP_SEARCHES || loops.len() >= MAX_LOOPS {
                continue;
            }
            searches += 1;
            if let Some(cycle) =
                graph::shortest_cycle(&firing, u, |v| sccs.component[v as usize] == c)
            {
                let texts = self.cycle_labels(&firing, &firing_perms, &cycle);
                let mut sorted = texts.clone();
                sorted.sort();
                if loop_keys.insert(sorted) {
                    loops.push(texts);
                }
            }
        }

        let fired = &self.fired;
        let statics: &[Warning] = if statics {
            self.statics.get_or_init(|| {
                let mut found = static_warnings(project);
                found.retain(|w| !self.never_together(w));
                found
            })
        } else {
            &[]
        };
        let mut warnings: Vec<String> = statics
            .iter()
            .filter(|w| net.is_none_or(|x| w.nets.contains(&x)))
            .map(|w| w.text.clone())
            .collect();
        for (ni, nt) in project
            .nets
            .iter()
            .enumerate()
            .filter(|(ni, _)| net.is_none_or(|x| x == *ni))
        {
            for (ti, t) in nt.transitions.iter().enumerate() {
                if !fired.contains(&(ni, ti)) && space.complete {
                    warnings.push(format!("transition {}.{} can never fire", nt.name, t.name));
                }
            }
        }
        if !space.complete {
            warnings.push(format!(
                "state limit reached after {n} states: the exploration is incomplete"
            ));
        }
        // The places in scope: every place, or the net's own (each member of
        // its orbit's) and the global places its transitions use.
        let scope: Vec<usize> = match net {
            None => (0..project.place_count).collect(),
            Some(_) => {
                let mut places: BTreeSet<usize> = BTreeSet::new();
                for x in orbit.iter().flatten() {
                    let offset = project.place_offsets[*x];
                    places.extend(offset..offset + project.nets[*x].places.len());
                    for t in &project.nets[*x].transitions {
                        places.extend(t.flat_inputs.iter().chain(&t.flat_outputs));
                    }
                }
                places.into_iter().collect()
            }
        };
        let any_tokens = (0..n as u32).any(|s| scope.iter().any(|&p| codec.marked(key(s), p)));
        let rename_for = |u: u32| net.zip(net_of(u)).map(|(x, m)| (m, x));
        let with_step = |(u, l): (u32, u32)| self.real_path(state_of(u), Some(l), rename_for(u));
        // Each declared resource: the first state (breadth-first, so the
        // shortest example) where two vehicles hold it.
        let exclusion = if net.is_none() {
            project
                .exclusive
                .iter()
                .filter_map(|r| {
                    (0..n as u32).find_map(|s| {
                        let holders = r.holders(|p| codec.marked(key(s), p));
                        (holders.len() > 1).then(|| {
                            let (_, end) = self.path_perms(s);
                            let mut real: Vec<usize> = holders
                                .iter()
                                .map(|&v| {
                                    self.symmetry.as_ref().map_or(v, |sym| sym.vehicle(end, v))
                                })
                                .collect();
                            real.sort_unstable();
                            Exclusion {
                                resource: r.name.clone(),
                                vehicles: real
                                    .iter()
                                    .map(|&v| project.vehicles[v].name.clone())
                                    .collect(),
                                example: self.real_path(s, None, None),
                            }
                        })
                    })
                })
                .collect()
        } else {
            Vec::new()
        };
        Report {
            exclusion,
            states,
            edges,
            dead_markings,
            safe: first_unsafe.is_none(),
            max_tokens: u32::from(any_tokens),
            deadlock_example: dead
                .first()
                .map(|&u| self.real_path(state_of(u), None, rename_for(u))),
            unsafe_example: first_unsafe.map(with_step),
            livelocks: livelocks.into_iter().map(with_step).collect(),
            loops,
            relies: Vec::new(),
            warnings,
            complete: space.complete,
            reduction: Reduction::default(),
        }
    }

    /// The texts of a cycle's steps (a real path from the cycle's first
    /// state: with symmetry, each step renamed by the elements before it).
    fn cycle_labels(&self, firing: &Csr<u32>, perms: &[u8], cycle: &[u32]) -> Vec<String> {
        let mut out = Vec::new();
        let mut sigma = 0u8;
        for (i, &s) in cycle.iter().enumerate() {
            let next = cycle[(i + 1) % cycle.len()];
            let first = firing.first_edge(s);
            if let Some((e, (l, _))) = firing.edges(s).enumerate().find(|(_, (_, t))| *t == next) {
                let text = &self.labels[*l as usize].text;
                match &self.symmetry {
                    None => out.push(text.clone()),
                    Some(sym) => {
                        out.push(sym.rename(sigma, text));
                        let perm = perms.get(first + e).copied().unwrap_or(0);
                        sigma = sym.compose(sigma, sym.inverse[perm as usize]);
                    }
                }
            }
        }
        out
    }
}
