//! The compiler: a checked [`Mission`] to ordinary net files, as TOML text
//! people can read and edit, with a map from each generated line back to
//! the mission line it comes from.

use std::fmt::Write as _;
use std::ops::Range;

use super::model::{End, Mission, Said, Step, Target, CATEGORIES};

/// One generated net file.
#[derive(Debug, Clone, PartialEq)]
pub struct NetFile {
    /// The net's name.
    pub net: String,
    /// Its path beside project.toml.
    pub path: String,
    /// Active from the start.
    pub active: bool,
    pub text: String,
    /// For each line of `text`, the span of the mission file it comes from.
    pub origins: Vec<Range<usize>>,
}

/// A transition before it is written.
struct Transition {
    name: String,
    /// What it is in the mission's words (`step transit: until mission_item_reached`).
    says: String,
    origin: Range<usize>,
    from: Vec<String>,
    to: Vec<String>,
    on: Option<String>,
    when: Option<Said>,
    actions: Vec<Said>,
    otherwise: bool,
    priority: Option<usize>,
}

/// A net being built: its places and transitions, names kept unique.
struct Net {
    name: String,
    places: Vec<String>,
    initial: Vec<String>,
    finals: Vec<String>,
    transitions: Vec<Transition>,
}

impl Net {
    fn new(name: &str) -> Self {
        Net {
            name: name.to_owned(),
            places: Vec::new(),
            initial: Vec::new(),
            finals: Vec::new(),
            transitions: Vec::new(),
        }
    }

    fn place(&mut self, name: &str) -> String {
        if !self.places.iter().any(|p| p == name) {
            self.places.push(name.to_owned());
        }
        name.to_owned()
    }

    /// A transition name not taken yet in this net, from `base`.
    fn fresh(&self, base: &str) -> String {
        let base: String = base
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '_' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        let taken = |n: &str| self.transitions.iter().any(|t| t.name == n);
        if !taken(&base) {
            return base;
        }
        (2..)
            .map(|k| format!("{base}_{k}"))
            .find(|n| !taken(n))
            .unwrap_or(base)
    }

    fn add(&mut self, mut t: Transition) {
        t.name = self.fresh(&t.name);
        self.transitions.push(t);
    }

    /// Transitions that wait for the same event and share an input place
    /// compete: rank them in the order the mission says them (the first
    /// said is tried first), so that `petrel check` reads an intended choice.
    fn rank(&mut self) {
        let n = self.transitions.len();
        for i in 0..n {
            let t = &self.transitions[i];
            if t.otherwise || t.on.is_none() {
                continue;
            }
            let siblings = self.transitions.iter().enumerate().any(|(j, u)| {
                j != i && !u.otherwise && u.on == t.on && u.from.iter().any(|p| t.from.contains(p))
            });
            if siblings {
                let later = self.transitions[i + 1..]
                    .iter()
                    .filter(|u| u.on == t.on)
                    .count();
                self.transitions[i].priority = Some(later + 1);
            }
        }
    }

    fn write(&self, mission: &Mission, path: &str, active: bool) -> NetFile {
        let mut out = Lines::default();
        let whole = if self.name == mission.net {
            mission.net_span.clone()
        } else {
            0..0
        };
        out.line(&format!("# Compiled from {} by `petrel compile`: edit the mission, or this file once compiled.", mission.file.name), &whole);
        out.line(&format!("name = {}", quote(&self.name)), &whole);
        out.line(&format!("places = {}", list(&self.places)), &whole);
        out.line(&format!("initial = {}", list(&self.initial)), &whole);
        out.line(&format!("final = {}", list(&self.finals)), &whole);
        for t in &self.transitions {
            let o = &t.origin;
            out.line("", o);
            let (line, _) = mission.file.line_col(o.start);
            out.line(&format!("# {}:{line}: {}", mission.file.name, t.says), o);
            out.line("[[transition]]", o);
            out.line(&format!("name = {}", quote(&t.name)), o);
            out.line(&format!("from = {}", list(&t.from)), o);
            out.line(&format!("to = {}", list(&t.to)), o);
            if let Some(on) = &t.on {
                out.line(&format!("on = {}", quote(on)), o);
            }
            if let Some(w) = &t.when {
                out.line(&format!("when = {}", quote(&w.text)), &w.span);
            }
            if t.otherwise {
                out.line("else = true", o);
            }
            if let Some(p) = t.priority {
                out.line(&format!("priority = {p}"), o);
            }
            match t.actions.as_slice() {
                [] => {}
                [one] => out.line(&format!("do = [{}]", quote(&one.text)), &one.span),
                many => {
                    out.line("do = [", o);
                    for a in many {
                        out.line(&format!("  {},", quote(&a.text)), &a.span);
                    }
                    out.line("]", o);
                }
            }
        }
        NetFile {
            net: self.name.clone(),
            path: path.to_owned(),
            active,
            text: out.text,
            origins: out.origins,
        }
    }
}

#[derive(Default)]
struct Lines {
    text: String,
    origins: Vec<Range<usize>>,
}

impl Lines {
    fn line(&mut self, s: &str, origin: &Range<usize>) {
        let _ = writeln!(self.text, "{s}");
        self.origins.push(origin.clone());
    }
}

fn quote(s: &str) -> String {
    toml::Value::String(s.to_owned()).to_string()
}

fn list(names: &[String]) -> String {
    format!(
        "[{}]",
        names
            .iter()
            .map(|n| quote(n))
            .collect::<Vec<_>>()
            .join(", ")
    )
}

fn said(text: String) -> Said {
    Said { text, span: 0..0 }
}

/// Where a transition goes and what it does on the way.
struct Lead {
    to: Vec<String>,
    actions: Vec<Said>,
    /// The phase of the step it leads into, if it is a step with one.
    phase: Option<String>,
    /// The level the step it leads into runs, if any.
    run: Option<usize>,
}

impl Lead {
    /// Into a place that is no step's.
    fn to_place(place: String, actions: Vec<Said>) -> Lead {
        Lead {
            to: vec![place],
            actions,
            phase: None,
            run: None,
        }
    }
}

/// A net of steps under construction: the mission's steps net, or a
/// category's net with its procedure.
struct Steps<'a> {
    m: &'a Mission,
    steps: &'a [Step],
    /// Where `done`, `abort` and `land` lead: a place, and the actions on
    /// the way in.
    ends: [(&'static str, Vec<Said>); 3],
    net: Net,
}

impl Steps<'_> {
    /// Step `i`'s place for attempt `k` (0: the first entry).
    fn attempt(&mut self, i: usize, k: u32) -> String {
        let name = self.attempt_name(i, k);
        self.net.place(&name)
    }

    fn attempt_name(&self, i: usize, k: u32) -> String {
        let name = &self.steps[i].name;
        if k == 0 {
            name.clone()
        } else {
            format!("{name}_retry{k}")
        }
    }

    fn limit_timer(&self, i: usize) -> String {
        format!("{}_limit", self.steps[i].name)
    }

    /// Entering step `i` at attempt `k`: its place, its actions, its limit.
    fn enter(&mut self, i: usize, k: u32) -> Lead {
        let s = &self.steps[i];
        if !s.branches.is_empty() {
            let mut lead = Lead {
                to: Vec::new(),
                actions: Vec::new(),
                phase: s.phase.clone(),
                run: None,
            };
            for branch in &s.branches {
                if let Some(&first) = branch.first() {
                    let l = self.enter(first, 0);
                    lead.to.extend(l.to);
                    lead.actions.extend(l.actions);
                }
            }
            return lead;
        }
        let mut actions = s.actions.clone();
        if let Some(level) = s.run.and_then(|l| self.m.levels.get(l)) {
            actions.push(Said {
                text: format!("activate {}", level.name),
                span: s.span.clone(),
            });
        }
        if let Some(limit) = &s.limit {
            actions.push(Said {
                text: format!(
                    "timer {} after {}",
                    self.limit_timer(i),
                    limit.said.text.trim()
                ),
                span: limit.said.span.clone(),
            });
        }
        Lead {
            to: vec![self.attempt(i, k)],
            actions,
            phase: s.phase.clone(),
            run: s.run,
        }
    }

    /// Where `target` leads from step `i` at attempt `k`.
    fn lead(&mut self, i: usize, k: u32, target: Target) -> Lead {
        match target {
            Target::Step(j) => self.enter(j, 0),
            Target::Retry if k < self.steps[i].retries => match &self.steps[i].retry_after {
                // Wait, then enter again (the transition `…_again`).
                Some(after) => Lead {
                    to: vec![self
                        .net
                        .place(&format!("{}_wait", self.attempt_name(i, k + 1)))],
                    actions: vec![Said {
                        text: format!(
                            "timer {}_retry after {}",
                            self.steps[i].name,
                            after.said.text.trim()
                        ),
                        span: after.said.span.clone(),
                    }],
                    phase: None,
                    run: None,
                },
                None => self.enter(i, k + 1),
            },
            Target::Retry => self.lead(i, k, self.steps[i].on_limit),
            Target::Join(p, b) => {
                let join = format!("{}_join{}", self.steps[p].name, b + 1);
                Lead::to_place(self.net.place(&join), Vec::new())
            }
            Target::Done => self.end(0),
            Target::Abort => self.end(1),
            Target::Land => self.end(2),
        }
    }

    /// Into `done`, `abort` or `land` (0, 1, 2 in `ends`).
    fn end(&mut self, e: usize) -> Lead {
        let (place, actions) = &self.ends[e];
        let actions = actions.clone();
        Lead::to_place(self.net.place(place), actions)
    }

    /// Actions leaving step `i` other than by its limit.
    fn leave(&self, i: usize) -> Vec<Said> {
        let mut out = self.stop_level(i);
        if let Some(limit) = &self.steps[i].limit {
            out.push(Said {
                text: format!("cancel {}", self.limit_timer(i)),
                span: limit.said.span.clone(),
            });
        }
        out
    }

    /// Leaving step `i` stops the level it runs.
    fn stop_level(&self, i: usize) -> Vec<Said> {
        let s = &self.steps[i];
        match s.run.and_then(|l| self.m.levels.get(l)) {
            Some(level) => vec![Said {
                text: format!("deactivate {}", level.name),
                span: s.span.clone(),
            }],
            None => Vec::new(),
        }
    }

    /// Adds a transition out of step `src` (`None`: out of no step) along
    /// `lead`; leaving one phase for another moves its global place's token.
    #[allow(clippy::too_many_arguments)]
    fn transition(
        &mut self,
        src: Option<usize>,
        name: String,
        says: String,
        origin: Range<usize>,
        mut from: Vec<String>,
        on: Option<String>,
        when: Option<Said>,
        mut actions: Vec<Said>,
        lead: Lead,
    ) {
        actions.extend(lead.actions);
        // From a step running a level into another running it (or the same
        // step again): the level goes on, neither stopped nor started.
        if let (Some(l), Some(level)) = (lead.run, lead.run.and_then(|l| self.m.levels.get(l))) {
            if src.is_some_and(|i| self.steps[i].run == Some(l)) {
                let (stop, start) = (
                    format!("deactivate {}", level.name),
                    format!("activate {}", level.name),
                );
                actions.retain(|a| a.text != stop && a.text != start);
            }
        }
        let mut to = lead.to;
        let old = src.and_then(|i| self.steps[i].phase.as_ref());
        if let (Some(old), Some(new)) = (old, &lead.phase) {
            if old != new {
                from.push(format!("@{old}"));
                to.push(format!("@{new}"));
            }
        }
        self.net.add(Transition {
            name,
            says,
            origin,
            from,
            to,
            on,
            when,
            actions,
            otherwise: false,
            priority: None,
        });
    }

    /// The whole net: `start`, then the steps from `first`, and `rules`.
    fn build(mut self, first: usize, rules: &[super::model::Rule], what: &str) -> Net {
        let start = self.net.place("start");
        self.net.initial.push(start.clone());
        let lead = self.enter(first, 0);
        let first = &self.steps[first];
        self.transition(
            None,
            "start".into(),
            format!("{what} starts with step {}", first.name),
            first.span.clone(),
            vec![start],
            None,
            None,
            Vec::new(),
            lead,
        );

        self.sequence();
        for r in rules {
            self.rule(r);
        }
        for end in ["done", "aborted", "landing"] {
            if self.net.places.iter().any(|p| p == end) {
                self.net.finals.push(end.to_owned());
            }
        }
        self.net.rank();
        self.net
    }

    /// Every step's transitions: exits, limits, joins.
    fn sequence(&mut self) {
        for (i, s) in self.steps.iter().enumerate() {
            if !s.branches.is_empty() {
                let from: Vec<String> = (0..s.branches.len())
                    .map(|b| self.net.place(&format!("{}_join{}", s.name, b + 1)))
                    .collect();
                let lead = self.lead(i, 0, s.next);
                self.transition(
                    Some(i),
                    format!("{}_join", s.name),
                    format!("parallel step {}: every branch is over", s.name),
                    s.span.clone(),
                    from,
                    None,
                    None,
                    Vec::new(),
                    lead,
                );
                continue;
            }
            for k in 0..=s.retries {
                let place = self.attempt(i, k);
                for e in &s.exits {
                    let mut actions = self.leave(i);
                    actions.extend(e.actions.iter().cloned());
                    let lead = self.lead(i, k, e.then);
                    let when = e
                        .when
                        .as_ref()
                        .map(|w| format!(" when {}", w.text))
                        .unwrap_or_default();
                    let (mut from, mut lead) = (vec![place.clone()], lead);
                    let (name, says, origin) = match (&e.on, &e.phase) {
                        (Some(on), _) => (
                            format!("{place}_{}", on.text),
                            format!("step {}: until {}{when}", s.name, on.text),
                            on.span.clone(),
                        ),
                        (None, Some(p)) => (
                            format!("{place}_{}", p.text),
                            format!("step {}: in phase {}", s.name, p.text),
                            p.span.clone(),
                        ),
                        (None, None) => (place.clone(), format!("step {}", s.name), s.span.clone()),
                    };
                    if let Some(p) = &e.phase {
                        from.push(format!("@{}", p.text));
                        lead.to.push(format!("@{}", p.text));
                    }
                    self.transition(
                        Some(i),
                        name,
                        says,
                        origin,
                        from,
                        e.on.as_ref().map(|on| on.text.clone()),
                        e.when.clone(),
                        actions,
                        lead,
                    );
                }
                if let (Some(after), true) = (&s.retry_after, k > 0) {
                    let lead = self.enter(i, k);
                    let wait = self.net.place(&format!("{place}_wait"));
                    self.transition(
                        None, // from the wait: the level, if any, starts again
                        format!("{place}_again"),
                        format!("step {}: retry after {}", s.name, after.said.text),
                        after.said.span.clone(),
                        vec![wait],
                        Some(format!("{}_retry", s.name)),
                        None,
                        Vec::new(),
                        lead,
                    );
                }
                if let Some(limit) = &s.limit {
                    let lead = self.lead(i, k, Target::Retry);
                    let what = if k < s.retries { "retry" } else { "give up" };
                    self.transition(
                        Some(i),
                        format!("{place}_limit"),
                        format!("step {}: limit {} ({what})", s.name, limit.said.text),
                        limit.said.span.clone(),
                        vec![place.clone()],
                        Some(self.limit_timer(i)),
                        None,
                        self.stop_level(i),
                        lead,
                    );
                }
            }
        }
    }

    fn rule(&mut self, r: &super::model::Rule) {
        let timer = format!("{}_for", r.name);
        let (idle, grace) = match &r.lasting {
            Some(_) => {
                let idle = self.net.place(&format!("{}_idle", r.name));
                let grace = self.net.place(&format!("{}_grace", r.name));
                self.net.initial.push(idle.clone());
                (Some(idle), Some(grace))
            }
            None => (None, None),
        };
        for &i in &r.during {
            let s = &self.steps[i];
            for k in 0..=s.retries {
                let place = self.attempt(i, k);
                let mut actions = self.leave(i);
                actions.extend(r.actions.iter().cloned());
                let lead = match r.then {
                    Some(t) => self.lead(i, k, t),
                    None => Lead {
                        to: vec![self.net.place(&format!("{place}__{}", r.name))],
                        actions: Vec::new(),
                        phase: None,
                        run: None,
                    },
                };
                let says = format!("rule {} during {}", r.name, s.name);
                if let (Some(idle), Some(grace), Some(lasting)) = (&idle, &grace, &r.lasting) {
                    let arm = Lead {
                        to: vec![grace.clone(), place.clone()],
                        actions: vec![Said {
                            text: format!("timer {timer} after {}", lasting.said.text.trim()),
                            span: lasting.said.span.clone(),
                        }],
                        phase: None,
                        run: None,
                    };
                    self.transition(
                        Some(i),
                        format!("{place}__{}_begins", r.name),
                        format!("{says}: on {} (for {})", r.on.text, lasting.said.text),
                        r.on.span.clone(),
                        vec![idle.clone(), place.clone()],
                        Some(r.on.text.clone()),
                        r.when.clone(),
                        Vec::new(),
                        arm,
                    );
                    let mut lead = lead;
                    lead.to.push(idle.clone());
                    self.transition(
                        Some(i),
                        format!("{place}__{}", r.name),
                        format!("{says}: {} lasted {}", r.on.text, lasting.said.text),
                        lasting.said.span.clone(),
                        vec![grace.clone(), place.clone()],
                        Some(timer.clone()),
                        None,
                        actions,
                        lead,
                    );
                } else {
                    self.transition(
                        Some(i),
                        format!("{place}__{}", r.name),
                        format!("{says}: on {}", r.on.text),
                        r.on.span.clone(),
                        vec![place.clone()],
                        Some(r.on.text.clone()),
                        r.when.clone(),
                        actions,
                        lead,
                    );
                }
                if let (None, Some(resume)) = (r.then, &r.resume_on) {
                    let suspended = format!("{place}__{}", r.name);
                    let lead = self.enter(i, k);
                    self.transition(
                        None, // from the suspension: the level, if any, starts again
                        format!("{suspended}_resume"),
                        format!("{says}: resume on {}", resume.text),
                        resume.span.clone(),
                        vec![suspended],
                        Some(resume.text.clone()),
                        None,
                        Vec::new(),
                        lead,
                    );
                }
            }
        }
        if let (Some(idle), Some(grace), Some(resume)) = (idle, grace, &r.resume_on) {
            self.net.add(Transition {
                name: format!("{}_clears", r.name),
                says: format!("rule {}: {} before it lasted", r.name, resume.text),
                origin: resume.span.clone(),
                from: vec![grace.clone()],
                to: vec![idle.clone()],
                on: Some(resume.text.clone()),
                when: None,
                actions: vec![said(format!("cancel {timer}"))],
                otherwise: false,
                priority: None,
            });
            self.net.add(Transition {
                name: format!("{}_lapses", r.name),
                says: format!("rule {}: lasted, but its steps are over", r.name),
                origin: r.span.clone(),
                from: vec![grace],
                to: vec![idle],
                on: Some(timer),
                when: None,
                actions: Vec::new(),
                otherwise: true,
                priority: None,
            });
        }
    }
}

/// The reactions of one category, as its net, with its procedure.
fn reactions(m: &Mission, category: nets::Category, name: &str) -> Option<Net> {
    let list: Vec<_> = m
        .reactions
        .iter()
        .filter(|r| r.category == category)
        .collect();
    if list.is_empty() {
        return None;
    }
    let procedure = m
        .procedures
        .iter()
        .find(|p| p.category == category)
        .map_or(&[][..], |p| &p.steps[..]);
    let catastrophic = category == nets::Category::Catastrophic;
    // Abort and land stop the mission's steps; a catastrophic reaction
    // has stopped them, and every other reaction's procedure, already.
    let stop = |then: &[Said]| {
        let mut actions = Vec::new();
        if !catastrophic {
            actions.push(said(format!("deactivate {}", m.net)));
        }
        actions.extend(then.iter().cloned());
        actions
    };
    let mut others: Vec<String> = CATEGORIES
        .iter()
        .filter(|(c, _, _)| *c != category && m.reactions.iter().any(|r| r.category == *c))
        .map(|(_, _, net)| format!("deactivate {net}"))
        .collect();
    others.insert(0, format!("deactivate {}", m.net));
    let mut net = Steps {
        m,
        steps: procedure,
        ends: [
            (
                if catastrophic { "reacted" } else { "watching" },
                Vec::new(),
            ),
            ("reacted", stop(&m.abort)),
            ("reacted", stop(&m.land)),
        ],
        net: Net::new(name),
    };
    let watching = net.net.place("watching");
    net.net.initial.push(watching.clone());
    net.net.finals.push(watching.clone());
    for r in list {
        let mut actions = r.actions.clone();
        // A catastrophic event ends the mission's steps, and the other
        // reactions' procedures, whatever follows (the paper's §3.2.3).
        if catastrophic {
            actions.extend(others.iter().cloned().map(said));
        }
        let lead = match r.end {
            End::Stay => Lead {
                to: vec![watching.clone()],
                actions: Vec::new(),
                phase: None,
                run: None,
            },
            End::Abort => net.lead(0, 0, Target::Abort),
            End::Land => net.lead(0, 0, Target::Land),
            End::Procedure(j) => net.enter(j, 0),
        };
        let end = match r.end {
            End::Stay => "the mission goes on".to_owned(),
            End::Abort => "abort".to_owned(),
            End::Land => "land".to_owned(),
            End::Procedure(j) => format!("procedure step {}", procedure[j].name),
        };
        let phases: Vec<Option<&String>> = if r.phases.is_empty() {
            vec![None]
        } else {
            r.phases.iter().map(Some).collect()
        };
        for phase in phases {
            let (mut from, mut to) = (vec![watching.clone()], lead.to.clone());
            let (name, also) = match phase {
                Some(p) => {
                    from.push(format!("@{p}"));
                    to.push(format!("@{p}"));
                    (format!("{}_{p}", r.name), format!(" (in phase {p})"))
                }
                None => (r.name.clone(), String::new()),
            };
            let mut all = actions.clone();
            all.extend(lead.actions.iter().cloned());
            net.net.add(Transition {
                name,
                says: format!("{category} reaction {}{also}: {end}", r.name),
                origin: r.span.clone(),
                from,
                to,
                on: Some(r.on.text.clone()),
                when: r.when.clone(),
                actions: all,
                otherwise: false,
                priority: None,
            });
        }
    }
    net.sequence();
    let mut net = net.net;
    if net.places.iter().any(|p| p == "reacted") {
        net.finals.push("reacted".to_owned());
    }
    net.rank();
    Some(net)
}

/// The nets a mission compiles into, in priority order: one per category
/// of disruptive event that has reactions (catastrophic, safety, mission,
/// communication: the paper's §3.2.3), then the steps. Files are named
/// `STEM.NET.toml` after the mission file `STEM.toml`.
pub fn compile(m: &Mission) -> Vec<NetFile> {
    let stem = m.file.name.strip_suffix(".toml").unwrap_or(&m.file.name);
    let path = |net: &str| format!("{stem}.{}.toml", net.to_ascii_lowercase());
    let mut out = Vec::new();
    for (category, _, name) in CATEGORIES {
        if let Some(net) = reactions(m, category, name) {
            out.push(net.write(m, &path(name), true));
        }
    }
    let steps = Steps {
        m,
        steps: &m.steps,
        ends: [
            ("done", m.done.clone()),
            ("aborted", m.abort.clone()),
            ("landing", m.land.clone()),
        ],
        net: Net::new(&m.net),
    }
    .build(m.first, &m.rules, "the mission");
    out.push(steps.write(m, &path(&m.net), true));
    for level in &m.levels {
        let net = Steps {
            m,
            steps: &level.steps,
            ends: [
                ("done", Vec::new()),
                ("aborted", m.abort.clone()),
                ("landing", m.land.clone()),
            ],
            net: Net::new(&level.name),
        }
        .build(level.first, &[], &format!("level {}", level.name));
        out.push(net.write(m, &path(&level.name), false));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::{Net, Transition};

    fn waiting(name: &str, from: &str, on: &str, otherwise: bool) -> Transition {
        Transition {
            name: name.to_owned(),
            says: String::new(),
            origin: 0..0,
            from: vec![from.to_owned()],
            to: vec![from.to_owned()],
            on: Some(on.to_owned()),
            when: None,
            actions: Vec::new(),
            otherwise,
            priority: None,
        }
    }

    #[test]
    fn names_stay_unique_and_siblings_are_ranked_in_the_order_said() {
        let mut net = Net::new("N");
        for t in [
            waiting("a", "p", "e", false),
            waiting("a", "p", "e", false),
            waiting("b", "q", "e", false),
            waiting("c", "p", "f", false),
            waiting("d", "p", "f", true),
        ] {
            net.add(t);
        }
        net.rank();
        let ranks: Vec<(&str, Option<usize>)> = net
            .transitions
            .iter()
            .map(|t| (t.name.as_str(), t.priority))
            .collect();
        // `b` shares no place with the others on `e`; `c`'s only sibling
        // is the fallback `d`: neither needs a rank.
        assert_eq!(
            ranks,
            [
                ("a", Some(3)),
                ("a_2", Some(2)),
                ("b", None),
                ("c", None),
                ("d", None)
            ]
        );
    }
}
