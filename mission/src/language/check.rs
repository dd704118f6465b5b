//! The mission loader: the file's text to a checked [`Mission`], every
//! problem collected at its `file:line:col`.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::ops::Range;

use nets::action::{self, ActionSyntax};
use nets::expr::{self, Context};
use nets::source::{Problem, SourceFile};
use nets::time::parse_duration;
use nets::Category;
use toml::Spanned;

use super::model::{
    End, Level, Limit, Mission, Procedure, Reaction, Rule, Said, Step, Target, CATEGORIES,
};
use super::steps::{sequence, Sequence};
use super::syntax::{self, in_order, Actions, RawStep, Text};

/// What the mission's project says about events, for checking the events
/// a mission waits for.
#[derive(Debug, Clone, Default)]
pub struct Known {
    /// Every event that may come from outside the mission (the project's
    /// `[events]`, the elaboration catalog, what other nets emit, the
    /// results of the project's program functions), when known: `None`
    /// leaves events unchecked, as `nets::load` does without a profile.
    pub events: Option<BTreeSet<String>>,
    /// Declared categories, by event.
    pub categories: BTreeMap<String, Category>,
    /// The project's global places and whether each starts marked.
    pub globals: BTreeMap<String, bool>,
}

/// Words a target may be besides a step's name, and names no step may take.
const TARGETS: [&str; 5] = ["next", "retry", "done", "abort", "land"];
pub(super) const RESERVED: [&str; 8] = [
    "next", "retry", "done", "abort", "land", "start", "aborted", "landing",
];

/// Checks the mission file `name` holding `text`.
pub fn check(name: &str, text: &str, known: &Known) -> Result<Mission, Vec<Problem>> {
    let file = SourceFile::new(name, text);
    let mut c = Checker {
        file: file.clone(),
        problems: Vec::new(),
    };
    let raw = match syntax::parse(text) {
        Ok(raw) => raw,
        Err((span, message)) => return Err(vec![Problem::new(&file, span, message)]),
    };
    let net = match &raw.name {
        Some(n) => {
            c.name(n, "net");
            if let Some((_, word, _)) = CATEGORIES.iter().find(|(_, _, net)| net == n.get_ref()) {
                c.at(n.span(), format!("`{}` names the net of the {word} reactions: give the steps net another name", n.get_ref()));
            }
            n.get_ref().clone()
        }
        None => "MISSION".to_owned(),
    };
    let net_span = raw.name.as_ref().map_or(0..0, |n| n.span());

    let Sequence {
        mut steps,
        index,
        branch_of,
        first,
        raw: raw_steps,
    } = sequence(&mut c, &raw.steps, known, true, None);
    c.phases(&mut steps, &raw_steps, first, known);

    // Levels: sequences in nets of their own, run by the mission's steps.
    let tables = in_order(&raw.levels);
    let mut levels = Vec::new();
    for (key, table) in tables {
        c.name(key, "level");
        let clash = key.get_ref() == &net || CATEGORIES.iter().any(|(_, _, n)| n == key.get_ref());
        if clash {
            c.at(
                key.span(),
                format!(
                    "level `{}` takes the name of a net the mission compiles into: give it another",
                    key.get_ref()
                ),
            );
        }
        let seq = sequence(&mut c, table, known, false, Some(key));
        levels.push(Level {
            name: key.get_ref().clone(),
            span: key.span(),
            first: seq.first.unwrap_or(0),
            steps: seq.steps,
        });
    }
    for (i, (_, step)) in raw_steps.iter().enumerate() {
        let Some(run) = &step.get_ref().run else {
            continue;
        };
        match levels.iter().position(|l| &l.name == run.get_ref()) {
            Some(l) => steps[i].run = Some(l),
            None => {
                let meant =
                    nets::suggest::nearest(run.get_ref(), levels.iter().map(|l| l.name.as_str()));
                c.at(
                    run.span(),
                    format!(
                        "unknown level `{}`: declare it as [levels.{}]{}",
                        run.get_ref(),
                        run.get_ref(),
                        meant
                            .map(|m| format!("; did you mean `{m}`?"))
                            .unwrap_or_default()
                    ),
                );
            }
        }
    }
    for (l, level) in levels.iter().enumerate() {
        if !steps.iter().any(|s| s.run == Some(l)) {
            c.at(
                level.span.clone(),
                format!(
                    "level `{}` is run by no step: give a step `run = \"{}\"`",
                    level.name, level.name
                ),
            );
        }
    }

    // Rules.
    let raw_rules = in_order(&raw.rules);
    let mut rules = Vec::new();
    for (key, rule) in raw_rules {
        c.name(key, "rule");
        let r = rule.get_ref();
        let during: Vec<usize> = match &r.during {
            None => (0..steps.len())
                .filter(|&i| steps[i].branches.is_empty())
                .collect(),
            Some(list) if list.get_ref().is_empty() => {
                c.at(list.span(), format!("rule `{}` is scoped to no step: name the steps it watches in `during`, or leave `during` out to watch them all", key.get_ref()));
                Vec::new()
            }
            Some(list) => {
                let mut out = Vec::new();
                for name in list.get_ref() {
                    if let Some(i) = c.step(&index, name) {
                        if !steps[i].branches.is_empty() {
                            c.at(name.span(), format!("`{}` is a parallel step: name the steps of its branches a rule watches", name.get_ref()));
                        } else if out.contains(&i) {
                            c.at(
                                name.span(),
                                format!("step `{}` is named twice", name.get_ref()),
                            );
                        } else {
                            out.push(i);
                        }
                    }
                }
                out
            }
        };
        let on = match &r.on {
            Some(on) => c.event(on, known),
            None => c.event(key, known),
        };
        let lasting = r.lasting.as_ref().and_then(|l| c.duration(l));
        let resume_on = r.resume_on.as_ref().map(|e| c.event(e, known));
        let then = r.then.as_ref().map(|t| {
            let in_branch = during.iter().any(|&i| steps[i].branch_of.is_some());
            if in_branch {
                c.at(t.span(), "a rule watching a step of a parallel branch suspends and resumes it (`resume_on`): it cannot lead elsewhere");
            }
            let scope = Scope { step: usize::MAX, retries: 0, branch_of: None, next: Target::Done, index: &index, branch_of_all: &branch_of };
            match c.target(t, &scope) {
                Target::Retry => {
                    c.at(t.span(), "a rule leads to a step, `done`, `abort` or `land`, not `retry`");
                    Target::Abort
                }
                t => t,
            }
        });
        if r.lasting.is_some() && r.resume_on.is_none() {
            c.at(rule.span(), format!("rule `{}` has `for` but no `resume_on`: say which event ends the condition before it lasts", key.get_ref()));
        }
        if r.then.is_none() && r.resume_on.is_none() {
            c.at(key.span(), format!("rule `{}` leaves its steps with no way out: give it `resume_on` (suspend the step, then enter it again) or `then` (where to go)", key.get_ref()));
        }
        if r.then.is_some() && r.resume_on.is_some() && r.lasting.is_none() {
            c.at(rule.span(), format!("rule `{}` has both `then` and `resume_on`: `then` leaves the step for good, `resume_on` suspends it; `resume_on` with `then` is only the event that ends a `for`", key.get_ref()));
        }
        rules.push(Rule {
            name: key.get_ref().clone(),
            span: key.span(),
            during,
            on,
            when: c.guard(&r.when),
            lasting,
            actions: c.actions(&r.actions),
            resume_on,
            then,
        });
    }

    // Procedures: steps of a category's net.
    let mut procedures: Vec<(Category, Sequence)> = Vec::new();
    let tables = in_order(&raw.procedures);
    for (section, table) in tables {
        let Some((category, word)) = c.category(section, "procedures") else {
            continue;
        };
        if !raw.reactions.keys().any(|k| k.get_ref() == word) {
            c.at(
                section.span(),
                format!("procedure of {word} with no reaction to start it: add [reactions.{word}]"),
            );
        }
        let seq = sequence(&mut c, table, known, false, Some(section));
        for (key, _) in &seq.raw {
            if ["watching", "reacted"].contains(&key.get_ref().as_str()) {
                c.at(
                    key.span(),
                    format!(
                        "`{}` names a place of the {word} net: give the step another name",
                        key.get_ref()
                    ),
                );
            }
        }
        procedures.push((category, seq));
    }

    // Reactions, one net per category.
    let mut reactions = Vec::new();
    let sections = in_order(&raw.reactions);
    for (section, list) in sections {
        let Some((category, _)) = c.category(section, "reactions") else {
            continue;
        };
        let list = in_order(list);
        for (key, reaction) in list {
            c.name(key, "reaction");
            let r = reaction.get_ref();
            let on = match &r.on {
                Some(on) => c.event(on, known),
                None => c.event(key, known),
            };
            if let Some(&declared) = known.categories.get(&on.text) {
                if declared != category {
                    c.at(on.span.clone(), format!("event `{}` is declared {declared}: its reaction belongs in [reactions.{declared}]", on.text));
                }
            }
            let procedure = procedures
                .iter()
                .find(|(c, _)| *c == category)
                .map(|(_, seq)| seq);
            let end = match r.then.as_ref().map(|t| (t, t.get_ref().as_str())) {
                None if category == Category::Catastrophic => End::Abort,
                None => End::Stay,
                Some((_, "stay")) if category != Category::Catastrophic => End::Stay,
                Some((_, "abort")) => End::Abort,
                Some((_, "land")) => End::Land,
                Some((_, word)) if procedure.is_some_and(|p| p.index.contains_key(word)) => {
                    End::Procedure(
                        procedure
                            .and_then(|p| p.index.get(word).copied())
                            .unwrap_or(0),
                    )
                }
                Some((t, word)) => {
                    let also = if category == Category::Catastrophic {
                        ""
                    } else {
                        ", `stay` (the default)"
                    };
                    let steps: Vec<&str> = procedure
                        .map(|p| p.index.keys().copied().collect())
                        .unwrap_or_default();
                    let meant = nets::suggest::nearest(word, steps.iter().copied());
                    c.at(
                        t.span(),
                        format!(
                            "a {category} reaction ends with `abort`{}{also}, `land` or a step of [procedures.{}]{}",
                            if also.is_empty() { " (the default: a catastrophic event cannot be recovered)" } else { "" },
                            category,
                            meant.map(|m| format!("; did you mean `{m}`?")).unwrap_or_default()
                        ),
                    );
                    End::Stay
                }
            };
            let phases = match &r.phases {
                None => Vec::new(),
                Some(list) if list.get_ref().is_empty() => {
                    c.at(list.span(), format!("reaction `{}` in no phase: name its phases, or leave `phases` out to react in every one", key.get_ref()));
                    Vec::new()
                }
                Some(list) => list
                    .get_ref()
                    .iter()
                    .map(|p| {
                        c.global(p, known);
                        p.get_ref().clone()
                    })
                    .collect(),
            };
            reactions.push(Reaction {
                phases,
                name: key.get_ref().clone(),
                span: key.span(),
                category,
                on,
                when: c.guard(&r.when),
                actions: c.actions(&r.actions),
                end,
            });
        }
    }

    let done = c.actions(&raw.done);
    let abort = c.actions(&raw.abort);
    let land = match &raw.land {
        None => vec![Said {
            text: "command land".to_owned(),
            span: 0..0,
        }],
        some => c.actions(some),
    };
    let mission = Mission {
        file,
        net,
        net_span,
        steps,
        first: first.unwrap_or(0),
        rules,
        levels,
        procedures: procedures
            .into_iter()
            .map(|(category, seq)| Procedure {
                category,
                steps: seq.steps,
            })
            .collect(),
        reactions,
        done,
        abort,
        land,
    };
    if c.problems.is_empty() {
        c.reachable(&mission);
    }
    if c.problems.is_empty() {
        Ok(mission)
    } else {
        Err(c.problems)
    }
}

/// The step whose targets are being read.
pub(super) struct Scope<'a> {
    pub(super) step: usize,
    pub(super) retries: u32,
    pub(super) branch_of: Option<(usize, usize)>,
    pub(super) next: Target,
    pub(super) index: &'a BTreeMap<&'a str, usize>,
    pub(super) branch_of_all: &'a [Option<(usize, usize)>],
}

pub(super) struct Checker {
    pub(super) file: SourceFile,
    pub(super) problems: Vec<Problem>,
}

impl Checker {
    pub(super) fn at(&mut self, span: Range<usize>, message: impl Into<String>) {
        self.problems.push(Problem::new(&self.file, span, message));
    }

    pub(super) fn name(&mut self, name: &Text, what: &str) {
        let s = name.get_ref();
        let ok = nets::load::is_name(s);
        if !ok {
            self.at(name.span(), format!("invalid {what} name `{s}`: use letters, digits and `_`, starting with a letter or `_`"));
        }
    }

    pub(super) fn step(&mut self, index: &BTreeMap<&str, usize>, name: &Text) -> Option<usize> {
        let found = index.get(name.get_ref().as_str()).copied();
        if found.is_none() {
            let meant = nets::suggest::nearest(name.get_ref(), index.keys().copied());
            self.at(
                name.span(),
                format!(
                    "unknown step `{}`{}",
                    name.get_ref(),
                    meant
                        .map(|m| format!("; did you mean `{m}`?"))
                        .unwrap_or_default()
                ),
            );
        }
        found
    }

    pub(super) fn target(&mut self, t: &Text, scope: &Scope) -> Target {
        let target = match t.get_ref().as_str() {
            "next" => return scope.next,
            "retry" => {
                if scope.retries == 0 && scope.step != usize::MAX {
                    self.at(
                        t.span(),
                        "`retry` needs `retries` (how many times the step may be entered again)",
                    );
                }
                return Target::Retry;
            }
            "done" => Target::Done,
            "abort" => Target::Abort,
            "land" => Target::Land,
            word => match scope.index.get(word) {
                Some(&i) => Target::Step(i),
                None => {
                    let meant =
                        nets::suggest::nearest(word, scope.index.keys().copied().chain(TARGETS));
                    self.at(t.span(), format!("unknown step `{word}`: a target is a step, next, retry, done, abort or land{}", meant.map(|m| format!("; did you mean `{m}`?")).unwrap_or_default()));
                    return Target::Abort;
                }
            },
        };
        let within = match (scope.branch_of, target) {
            (None, Target::Step(i)) => scope.branch_of_all[i].is_none(),
            (None, _) => true,
            (Some(b), Target::Step(i)) => scope.branch_of_all[i] == Some(b),
            (Some(_), _) => false,
        };
        if !within {
            self.at(
                t.span(),
                match scope.branch_of {
                    None => format!("step `{}` is in a parallel branch: it is entered through its parallel step", t.get_ref()),
                    Some(_) => "a step of a parallel branch leads only within its branch (`next`, `retry`, a step of the branch)".to_owned(),
                },
            );
        }
        target
    }

    pub(super) fn event(&mut self, on: &Text, known: &Known) -> Said {
        let name = on.get_ref();
        let valid = nets::load::is_event_name(name);
        if !valid {
            self.at(on.span(), format!("invalid event name `{name}`"));
        } else if let Some(events) = &known.events {
            if !events.contains(name) {
                let meant = nets::suggest::nearest(name, events.iter().map(String::as_str));
                self.at(
                    on.span(),
                    format!(
                        "unknown event `{name}`: no elaboration rule, [events] declaration, net or mission action produces it{} (an event a program or another outside source sends is declared in project.toml's [events])",
                        meant.map(|m| format!("; did you mean `{m}`?")).unwrap_or_default()
                    ),
                );
            }
        }
        Said {
            text: name.clone(),
            span: on.span(),
        }
    }

    pub(super) fn guard(&mut self, when: &Option<Text>) -> Option<Said> {
        let when = when.as_ref()?;
        if let Err(e) = expr::parse(when.get_ref(), Context::Guard) {
            let at = self.file.inside_string(&when.span(), when.get_ref(), e.at);
            self.at(at..at + e.len, format!("guard: {}", e.message));
        }
        Some(Said {
            text: when.get_ref().clone(),
            span: when.span(),
        })
    }

    pub(super) fn actions(&mut self, actions: &Option<Spanned<Actions>>) -> Vec<Said> {
        let Some(actions) = actions else {
            return Vec::new();
        };
        let mut out = Vec::new();
        for a in actions.get_ref().spanned(actions.span()) {
            match action::parse(a.get_ref()) {
                Err(e) => {
                    let at = self.file.inside_string(&a.span(), a.get_ref(), e.at);
                    self.at(at..at + e.len, format!("action: {}", e.message));
                }
                Ok(
                    ActionSyntax::Timer { after, .. } | ActionSyntax::Ask { timeout: after, .. },
                ) => {
                    if let Err(e) = parse_duration(&after.0) {
                        let at = self.file.inside_string(&a.span(), a.get_ref(), after.1);
                        self.at(at..at + after.0.len(), e.to_string());
                    }
                }
                Ok(_) => {}
            }
            out.push(Said {
                text: a.get_ref().clone(),
                span: a.span(),
            });
        }
        out
    }

    pub(super) fn duration(&mut self, text: &Text) -> Option<Limit> {
        match parse_duration(text.get_ref()) {
            Ok(micros) => Some(Limit {
                said: Said {
                    text: text.get_ref().clone(),
                    span: text.span(),
                },
                micros,
            }),
            Err(e) => {
                self.at(text.span(), e.to_string());
                None
            }
        }
    }

    /// The category a `[reactions.WORD]` or `[procedures.WORD]` names.
    fn category(&mut self, section: &Text, what: &str) -> Option<(Category, &'static str)> {
        let found = CATEGORIES
            .iter()
            .find(|(_, word, _)| *word == section.get_ref());
        if found.is_none() {
            self.at(section.span(), format!("unknown category `{}`: {what} are catastrophic, safety, mission or communication", section.get_ref()));
        }
        found.map(|&(category, word, _)| (category, word))
    }

    /// A phase names a global place of the project.
    pub(super) fn global(&mut self, phase: &Text, known: &Known) {
        let name = phase.get_ref();
        if !known.globals.contains_key(name) {
            let meant = nets::suggest::nearest(name, known.globals.keys().map(String::as_str));
            self.at(
                phase.span(),
                format!(
                    "phase `{name}` is no global place of project.toml: declare it in [globals]{}",
                    meant
                        .map(|m| format!("; did you mean `{m}`?"))
                        .unwrap_or_default()
                ),
            );
        }
    }

    /// Once a step has a phase every step of the sequence has one, a
    /// branch's steps take their parallel step's, and the project starts
    /// with the first step's phase marked and no other.
    fn phases(
        &mut self,
        steps: &mut [Step],
        raw: &[(&Text, &Spanned<RawStep>)],
        first: Option<usize>,
        known: &Known,
    ) {
        let used: BTreeSet<String> = steps.iter().filter_map(|s| s.phase.clone()).collect();
        if used.is_empty() {
            return;
        }
        for s in steps
            .iter()
            .filter(|s| s.branch_of.is_none() && s.phase.is_none())
        {
            self.at(
                s.span.clone(),
                format!(
                    "step `{}` has no phase: once a step has one, every step says its phase",
                    s.name
                ),
            );
        }
        for i in 0..steps.len() {
            if let Some((p, _)) = steps[i].branch_of {
                steps[i].phase = steps[p].phase.clone();
            }
        }
        let Some(first) = first else { return };
        let Some(start) = steps[first].phase.clone() else {
            return;
        };
        let wrong: Vec<&str> = used
            .iter()
            .filter(|p| known.globals.get(*p).copied().unwrap_or(false) != (**p == start))
            .map(String::as_str)
            .collect();
        if !wrong.is_empty() {
            let span = raw[first]
                .1
                .get_ref()
                .phase
                .as_ref()
                .map_or(steps[first].span.clone(), |p| p.span());
            self.at(span, format!("the mission starts in phase `{start}`: project.toml's [globals] must start it true and every other phase false ({} {})", wrong.join(", "), if wrong.len() == 1 { "is not" } else { "are not" }));
        }
    }

    /// Every step is reached: the mission's from its first, a procedure's
    /// from the reactions leading into it.
    fn reachable(&mut self, m: &Mission) {
        self.reached(&m.steps, &[m.first], &m.rules);
        for l in &m.levels {
            self.reached(&l.steps, &[l.first], &[]);
        }
        for p in &m.procedures {
            let starts: Vec<usize> = m
                .reactions
                .iter()
                .filter(|r| r.category == p.category)
                .filter_map(|r| match r.end {
                    End::Procedure(j) => Some(j),
                    _ => None,
                })
                .collect();
            self.reached(&p.steps, &starts, &[]);
        }
    }

    fn reached(&mut self, steps: &[Step], starts: &[usize], rules: &[Rule]) {
        let mut seen = vec![false; steps.len()];
        let mut queue: VecDeque<usize> = starts.iter().copied().collect();
        while let Some(i) = queue.pop_front() {
            if i >= seen.len() || std::mem::replace(&mut seen[i], true) {
                continue;
            }
            let s = &steps[i];
            let mut targets: Vec<Target> = s.exits.iter().map(|e| e.then).collect();
            if !s.branches.is_empty() {
                targets.push(s.next);
            }
            if s.limit.is_some() {
                targets.push(s.on_limit);
            }
            targets.extend(
                rules
                    .iter()
                    .filter(|r| r.during.contains(&i))
                    .filter_map(|r| r.then),
            );
            for branch in &s.branches {
                queue.extend(branch.first());
            }
            for t in targets {
                match t {
                    Target::Step(j) => queue.push_back(j),
                    Target::Join(p, _) => queue.push_back(steps[p].next_step().unwrap_or(p)),
                    _ => {}
                }
            }
        }
        for (i, s) in steps.iter().enumerate() {
            if !seen[i] {
                self.at(s.span.clone(), format!("step `{}` is unreachable: no step, exit, limit, rule or reaction leads to it from the first step", s.name));
            }
        }
    }
}

impl Step {
    /// The step `next` leads to, if it is one.
    fn next_step(&self) -> Option<usize> {
        match self.next {
            Target::Step(i) => Some(i),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn problems(text: &str) -> Vec<String> {
        match check("m.toml", text, &Known::default()) {
            Ok(_) => Vec::new(),
            Err(p) => p.iter().map(ToString::to_string).collect(),
        }
    }

    #[test]
    fn a_plain_sequence_checks() {
        let m = check(
            "m.toml",
            "[steps]\na = { do = \"command arm\", until = \"command.ok\" }\nb = { until = \"landed\", limit = \"3min\", on_limit = \"land\" }\n",
            &Known::default(),
        )
        .expect("checks");
        assert_eq!(m.steps[0].exits[0].then, Target::Step(1));
        assert_eq!(m.steps[1].exits[0].then, Target::Done);
        assert_eq!(
            m.steps[1].limit.as_ref().map(|l| l.micros),
            Some(180_000_000)
        );
        assert_eq!(m.steps[1].on_limit, Target::Land);
    }

    #[test]
    fn each_mistake_is_reported_where_it_is() {
        let text = "[steps]\na = { until = \"x\", then = \"c\" }\nb = { do = \"comand rtl\" }\nc = { until = \"y\", limit = \"3 parsecs\" }\n[rules]\nr = { during = [], resume_on = \"z\" }\n";
        let p = problems(text);
        assert_eq!(
            p,
            [
                "m.toml:3:1: step `b` has no way out: give it `until` (the event that ends it), `exits` or a `limit`",
                "m.toml:3:13: action: unknown action `comand`: expected activate, deactivate, emit, timer, cancel, call, command or ask",
                "m.toml:4:28: malformed duration `3 parsecs`: expected a number and a unit, as in `30s`, `500ms`, `1.5s`, `2min` or `1h`",
                "m.toml:6:16: rule `r` is scoped to no step: name the steps it watches in `during`, or leave `during` out to watch them all",
            ],
            "{p:#?}"
        );
    }
}
