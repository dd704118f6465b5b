//! Profiles: TOML files of rules, loaded once into a compiled form. A
//! profile is read in layers (a built-in one, then a project's file): a
//! later layer's rule of the same name replaces the keys it gives (so a
//! project can change only a category), new names add rules, and
//! `enabled = false` removes one. Every problem of every layer is reported
//! at once, with file, line and column.

use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::ops::Range;

use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::Message;
use nets::Category;
use regex::Regex;
use toml::de::{DeTable, DeValue};
use toml::Spanned;

use crate::expr::{self, Compiled, ExprError, Resolver};
use crate::fields;

/// The built-in ArduPilot profile.
pub const ARDUPILOT: &str = include_str!("../profiles/ardupilot.toml");
/// The built-in PX4 profile.
pub const PX4: &str = include_str!("../profiles/px4.toml");

/// The text of a built-in profile by name (`ardupilot`, `px4`).
pub fn builtin(name: &str) -> Option<&'static str> {
    match name {
        "ardupilot" => Some(ARDUPILOT),
        "px4" => Some(PX4),
        _ => None,
    }
}

/// One problem in a profile.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Problem {
    pub file: String,
    pub line: usize,
    pub col: usize,
    /// Byte range in the file.
    pub span: Range<usize>,
    pub message: String,
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}:{}: {}",
            self.file, self.line, self.col, self.message
        )
    }
}

/// Every problem found while loading a profile.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub struct ProfileError {
    pub problems: Vec<Problem>,
}

impl fmt::Display for ProfileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} problem(s) in the profile", self.problems.len())?;
        for p in &self.problems {
            write!(f, "\n  {p}")?;
        }
        Ok(())
    }
}

/// Which senders a rule listens to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SourceFilter {
    /// The supervised vehicle's autopilot (the default).
    Autopilot,
    /// Any component of the supervised vehicle's system.
    Vehicle,
    /// Ground stations (HEARTBEAT type GCS), from any system.
    Gcs,
    /// Anyone.
    Any,
    /// Given ids (either may be left out).
    Ids {
        sysid: Option<u8>,
        compid: Option<u8>,
    },
}

/// A compiled rule.
#[derive(Debug, Clone)]
pub struct Rule {
    /// The rule's name in the profile (by default, its event's name).
    pub name: String,
    pub event: String,
    pub category: Category,
    pub(crate) when: Compiled,
    pub(crate) clear: Option<Compiled>,
    pub for_us: u64,
    pub clear_for_us: u64,
    pub cleared: Option<(String, Category)>,
    /// Fire when the condition already holds at its first evaluation.
    pub initial: bool,
    /// Fire on every triggering message where the condition holds, instead
    /// of once per false-to-true change.
    pub each: bool,
    /// (`each` rules) How many of the rule's last events (with distinct
    /// parameters) are remembered: a message whose event carries the same
    /// parameters as one of them is a repeat, not a new occurrence, until
    /// `clear` becomes true after having been false at the last event or
    /// since. 0: every message is
    /// an occurrence.
    pub distinct: usize,
    /// (`each` rules) The rule detects the autopilot's reboot: when it
    /// fires, what elaboration remembers of the sender's previous boot is
    /// forgotten (docs/events.md, "Autopilot reboot").
    pub reboot: bool,
    pub(crate) params: Vec<(String, Compiled)>,
    pub source: SourceFilter,
    /// (`on`) The only messages, by slot, on whose frames `when` is
    /// evaluated (and the rule can fire): not the others it reads, never
    /// on ticks. `None`: every message the condition reads, and ticks.
    pub(crate) on: Option<Vec<usize>>,
    /// Evaluated on ticks (reads `age()` or has a duration).
    pub(crate) timed: bool,
    /// Reads `age()`: evaluated on every tick, not only while a duration runs.
    pub(crate) ages: bool,
}

impl Rule {
    /// The names of the parameters the rule's event carries, in order.
    pub fn param_names(&self) -> impl Iterator<Item = &str> {
        self.params.iter().map(|(name, _)| name.as_str())
    }

    /// Whether a message in `slot` can fire the rule: one of its `on`
    /// messages, or without `on` one its condition reads (fields or age).
    /// A message read by `clear` only re-arms.
    pub(crate) fn fires_on(&self, slot: usize) -> bool {
        match &self.on {
            Some(on) => on.contains(&slot),
            None => self.when.reads.contains(&slot) || self.when.ages.contains(&slot),
        }
    }

    /// Whether `when` is evaluated on a message in `slot`: one of the `on`
    /// messages, or without `on` any message that evaluates the rule.
    pub(crate) fn when_on(&self, slot: usize) -> bool {
        self.on.as_ref().is_none_or(|on| on.contains(&slot))
    }

    /// Whether the rule reads fields of the message in `slot` (not only its
    /// age).
    pub(crate) fn reads_fields_of(&self, slot: usize) -> bool {
        self.when.reads.contains(&slot)
            || self.clear.as_ref().is_some_and(|c| c.reads.contains(&slot))
    }
}

/// A message the profile reads or times.
#[derive(Debug, Clone)]
pub(crate) struct Slot {
    pub id: u32,
    pub fields: Vec<String>,
    /// Some rule reads its fields, so frames of it are decoded.
    pub decode: bool,
}

/// The messages (ids) one rule depends on ([`Profile::event_needs`]).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Needs {
    /// Messages whose fields it reads, its `on` messages and those it asks
    /// `seen()` of: a receiver that does not get them now does not run the
    /// rule as one that does (`!seen(EXTENDED_SYS_STATE)` is the rule for
    /// a port without it, not for one with it).
    pub fields: Vec<u32>,
    /// Messages whose age only it reads (`age()`: a silence): a receiver
    /// must have heard them once; their silence it then observes.
    pub ages: Vec<u32>,
    /// How long its condition must hold before it fires (`for`, or
    /// `clear_for` for its `cleared` event), microseconds: the event's
    /// onset is that long before it.
    pub hold_us: u64,
}

/// A compiled profile.
#[derive(Debug, Clone)]
pub struct Profile {
    pub(crate) rules: Vec<Rule>,
    pub(crate) slots: Vec<Slot>,
    /// Slot + 1 by message id (0: not read), for ids below 2^16; others
    /// (rare, and not in the dialect today) in `slot_of_big_id`.
    pub(crate) slot_of_id: Vec<u16>,
    pub(crate) slot_of_big_id: HashMap<u32, usize>,
    pub(crate) regexes: Vec<Regex>,
    pub(crate) memos: usize,
    /// Rules to evaluate on a message, by slot.
    pub(crate) by_slot: Vec<Vec<usize>>,
    pub(crate) timed: Vec<usize>,
}

/// Slot 0 is always HEARTBEAT: it classifies senders and names modes.
pub(crate) const HEARTBEAT_SLOT: usize = 0;

impl Profile {
    /// A built-in profile by name.
    pub fn builtin(name: &str) -> Result<Profile, ProfileError> {
        let text = builtin(name).ok_or_else(|| ProfileError {
            problems: vec![Problem {
                file: name.to_owned(),
                line: 0,
                col: 0,
                span: 0..0,
                message: format!("no built-in profile `{name}` (known: ardupilot, px4)"),
            }],
        })?;
        Profile::load(&[(&format!("{name}.toml"), text)])
    }

    /// Loads layers of profile text, each with the file name used in
    /// problems; later layers override earlier ones rule by rule.
    pub fn load(layers: &[(&str, &str)]) -> Result<Profile, ProfileError> {
        let mut problems = Vec::new();
        let mut specs: BTreeMap<String, RuleSpec> = BTreeMap::new();
        let mut order: Vec<String> = Vec::new();
        for (file_index, (file, text)) in layers.iter().enumerate() {
            let loc = Locator {
                file,
                text,
                file_index,
            };
            read_layer(&loc, &mut specs, &mut order, &mut problems);
        }
        let mut b = Builder::default();
        b.slot_for(
            MavMessage::message_id_from_name("HEARTBEAT").unwrap_or(0),
            true,
        );
        let locs: Vec<Locator> = layers
            .iter()
            .enumerate()
            .map(|(i, (file, text))| Locator {
                file,
                text,
                file_index: i,
            })
            .collect();
        let mut rules = Vec::new();
        // Rules run in the order they were first declared (layer, then
        // position in the file).
        order.sort_by_key(|k| specs.get(k).map(|s| s.first).unwrap_or((usize::MAX, 0)));
        for key in &order {
            let Some(spec) = specs.get(key) else { continue };
            if spec.enabled == Some(false) {
                continue;
            }
            if let Some(rule) = b.rule(key, spec, &locs, &mut problems) {
                rules.push(rule);
            }
        }
        if !problems.is_empty() {
            problems.sort_by(|a, b| (&a.file, a.span.start).cmp(&(&b.file, b.span.start)));
            return Err(ProfileError { problems });
        }
        let mut by_slot = vec![Vec::new(); b.slots.len()];
        let mut timed = Vec::new();
        for (i, r) in rules.iter().enumerate() {
            // With `on`, the condition is evaluated on those messages only;
            // an explicit `clear` is still watched on the messages it reads.
            let mut reads: Vec<usize> = match &r.on {
                Some(on) => on.clone(),
                None => {
                    let mut v = r.when.reads.clone();
                    v.extend(&r.when.ages);
                    v
                }
            };
            if let Some(c) = &r.clear {
                reads.extend(&c.reads);
                reads.extend(&c.ages);
            }
            reads.sort_unstable();
            reads.dedup();
            for s in reads {
                by_slot[s].push(i);
            }
            if r.timed {
                timed.push(i);
            }
        }
        Ok(Profile {
            rules,
            slot_of_id: {
                let mut t = vec![0u16; 1 << 16];
                for (i, s) in b.slots.iter().enumerate() {
                    if let Some(e) = t.get_mut(s.id as usize) {
                        *e = u16::try_from(i + 1).unwrap_or(0);
                    }
                }
                t
            },
            slot_of_big_id: b
                .slots
                .iter()
                .enumerate()
                .filter(|(_, s)| s.id >= 1 << 16)
                .map(|(i, s)| (s.id, i))
                .collect(),
            slots: b.slots,
            regexes: b.regexes,
            memos: b.memos,
            by_slot,
            timed,
        })
    }

    /// The rules, in the order declared.
    pub fn rules(&self) -> &[Rule] {
        &self.rules
    }

    /// The ids of the messages the profile reads or times, in order: the
    /// telemetry the gateway asks the autopilot for.
    pub fn messages(&self) -> Vec<u32> {
        self.slots.iter().map(|s| s.id).collect()
    }

    /// The ids of the messages to ask the autopilot for at a rate: those
    /// whose values the rules read as a state (conditions of rules without
    /// `each`, any `clear`, parameters) and the `on` messages of rules
    /// without `each` (the frames they are evaluated on). A message only
    /// an `each` rule's condition (or `on`) reads (STATUSTEXT, COMMAND_ACK,
    /// MISSION_ITEM_REACHED) is an event the autopilot sends on its own:
    /// requested as a stream, ArduPilot re-sends its last one every period.
    pub fn telemetry(&self) -> Vec<u32> {
        let mut state = vec![false; self.slots.len()];
        state[HEARTBEAT_SLOT] = true;
        let mut mark = |slots: &[usize]| {
            for &s in slots {
                if let Some(x) = state.get_mut(s) {
                    *x = true;
                }
            }
        };
        for r in &self.rules {
            if !r.each {
                mark(&r.when.reads);
                mark(&r.when.ages);
                mark(r.on.as_deref().unwrap_or_default());
            }
            // What an each rule's clear and parameters read of its own
            // triggering message is that event, not a state.
            let states = |slots: &[usize]| -> Vec<usize> {
                slots
                    .iter()
                    .copied()
                    .filter(|s| !(r.each && r.when.reads.contains(s)))
                    .collect()
            };
            if let Some(c) = &r.clear {
                mark(&states(&c.reads));
                mark(&c.ages);
            }
            for (_, p) in &r.params {
                mark(&states(&p.reads));
            }
        }
        self.slots
            .iter()
            .zip(state)
            .filter(|(_, state)| *state)
            .map(|(s, _)| s.id)
            .collect()
    }

    /// The names of the events this profile can produce.
    pub fn event_names(&self) -> Vec<&str> {
        let mut v: Vec<&str> = self
            .rules
            .iter()
            .flat_map(|r| {
                std::iter::once(r.event.as_str()).chain(r.cleared.as_ref().map(|c| c.0.as_str()))
            })
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    }

    /// What each event's rules depend on, for a receiver to tell whether it
    /// can observe the event at all: by event name (a rule's event, or its
    /// `cleared` event), one [`Needs`] per rule producing it. Only the
    /// messages the autopilot streams as a state ([`Profile::telemetry`])
    /// count: an event message (STATUSTEXT, COMMAND_ACK) comes to every
    /// link when it happens, its absence is no blindness.
    pub fn event_needs(&self) -> Vec<(&str, Vec<Needs>)> {
        let mut out: Vec<(&str, Vec<Needs>)> = Vec::new();
        for (name, needs) in self.rules_needs().into_iter().flatten() {
            match out.iter_mut().find(|(n, _)| *n == name) {
                Some((_, v)) => v.push(needs),
                None => out.push((name, vec![needs])),
            }
        }
        out
    }

    /// What each rule depends on, by its index in the profile (the index
    /// [`crate::Elaborated::rule`] gives), for each event it produces: its
    /// own, then its `cleared` event's.
    pub fn rules_needs(&self) -> Vec<Vec<(&str, Needs)>> {
        let state = self.telemetry();
        (0..self.rules.len())
            .map(|r| self.needs_of(r, &state))
            .collect()
    }

    fn needs_of(&self, index: usize, state: &[u32]) -> Vec<(&str, Needs)> {
        let ids = |slots: &[usize]| -> Vec<u32> {
            let mut v: Vec<u32> = slots
                .iter()
                .filter_map(|s| self.slots.get(*s))
                .map(|s| s.id)
                .filter(|id| state.contains(id))
                .collect();
            v.sort_unstable();
            v.dedup();
            v
        };
        let r = &self.rules[index];
        let when_fields = [
            r.when.reads.as_slice(),
            r.when.seen.as_slice(),
            r.on.as_deref().unwrap_or_default(),
        ]
        .concat();
        let rule = Needs {
            fields: ids(&when_fields),
            ages: ids(&r.when.ages)
                .into_iter()
                .filter(|id| !ids(&when_fields).contains(id))
                .collect(),
            hold_us: r.for_us,
        };
        let mut names = vec![(r.event.as_str(), rule.clone())];
        if let Some((cleared, _)) = &r.cleared {
            // Cleared by `clear` (or `when` turning false): both read.
            let mut fields = rule.fields.clone();
            let mut ages = rule.ages.clone();
            if let Some(c) = &r.clear {
                fields.extend(ids(&c.reads));
                fields.extend(ids(&c.seen));
                ages.extend(ids(&c.ages));
            }
            fields.sort_unstable();
            fields.dedup();
            ages.retain(|id| !fields.contains(id));
            ages.sort_unstable();
            ages.dedup();
            names.push((
                cleared.as_str(),
                Needs {
                    fields,
                    ages,
                    hold_us: r.clear_for_us,
                },
            ));
        }
        names
    }

    /// The events this profile elaborates only from frames addressed to one
    /// system and component: every rule producing one fires on frames of
    /// messages with `target_system` and `target_component` fields
    /// (COMMAND_ACK), never on ticks nor on another message. An autopilot
    /// sends those to the link of the one they answer, so two receivers on
    /// two links never see the same ones (the onboard gateway hears the
    /// acknowledgements of its own commands, a ground station its own): the
    /// ground mirror's independent check does not compare them.
    pub fn addressed_events(&self) -> Vec<&str> {
        let addressed = |slot: &usize| {
            self.slots.get(*slot).is_some_and(|s| {
                s.fields.iter().any(|f| f == "target_system")
                    && s.fields.iter().any(|f| f == "target_component")
            })
        };
        let only_addressed = |r: &Rule| {
            let mut triggers = match &r.on {
                Some(on) => on.clone(),
                None => [r.when.reads.as_slice(), r.when.ages.as_slice()].concat(),
            };
            triggers.dedup();
            r.each
                && !r.timed
                && r.for_us == 0
                && !r.when.timed
                && !triggers.is_empty()
                && triggers.iter().all(addressed)
        };
        let mut v: Vec<&str> = self
            .rules
            .iter()
            .filter(|r| only_addressed(r))
            .map(|r| r.event.as_str())
            .filter(|name| {
                self.rules.iter().all(|r| {
                    (r.event != *name || only_addressed(r))
                        && r.cleared.as_ref().is_none_or(|c| c.0 != *name)
                })
            })
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    }
}

// ------------------------------------------------------------ reading TOML

#[derive(Clone, Copy)]
struct Locator<'a> {
    file: &'a str,
    text: &'a str,
    file_index: usize,
}

impl Locator<'_> {
    fn problem(&self, span: Range<usize>, message: impl Into<String>) -> Problem {
        // A span the TOML parser gives may start inside a multi-byte
        // character: count from that character's first byte.
        let mut start = span.start.min(self.text.len());
        while !self.text.is_char_boundary(start) {
            start -= 1;
        }
        let before = &self.text[..start];
        let line = before.matches('\n').count() + 1;
        let col = before.rfind('\n').map(|i| start - i).unwrap_or(start + 1);
        Problem {
            file: self.file.to_owned(),
            line,
            col,
            span,
            message: message.into(),
        }
    }
}

/// A string value and where it is.
#[derive(Debug, Clone)]
struct Text {
    value: String,
    file: usize,
    span: Range<usize>,
}

#[derive(Debug, Clone, Default)]
struct RuleSpec {
    decl: Option<(usize, Range<usize>)>,
    /// Where the rule was first declared: (layer, byte offset).
    first: (usize, usize),
    event: Option<Text>,
    category: Option<Text>,
    when: Option<Text>,
    clear: Option<Text>,
    for_: Option<Text>,
    clear_for: Option<Text>,
    cleared: Option<Text>,
    cleared_category: Option<Text>,
    initial: Option<bool>,
    each: Option<bool>,
    distinct: Option<usize>,
    reboot: Option<bool>,
    enabled: Option<bool>,
    source: Option<(SourceFilter, usize, Range<usize>)>,
    /// `on`: message names (at least one; checked against the dialect when
    /// the rule is compiled).
    on: Option<Vec<Text>>,
    params: BTreeMap<String, Text>,
}

const RULE_KEYS: &str = "event, category, when, on, clear, for, clear_for, cleared, cleared_category, initial, each, distinct, reboot, enabled, source, params";

fn read_layer(
    loc: &Locator,
    specs: &mut BTreeMap<String, RuleSpec>,
    order: &mut Vec<String>,
    problems: &mut Vec<Problem>,
) {
    let (root, errors) = DeTable::parse_recoverable(loc.text);
    for e in errors {
        problems.push(loc.problem(e.span().unwrap_or(0..0), e.message().to_owned()));
    }
    for (key, value) in root.get_ref().iter() {
        if key.get_ref().as_ref() != "rules" {
            problems.push(loc.problem(
                key.span(),
                format!(
                    "unknown key `{}` (a profile holds [rules.NAME] tables)",
                    key.get_ref()
                ),
            ));
            continue;
        }
        let Some(rules) = value.get_ref().as_table() else {
            problems.push(loc.problem(value.span(), "`rules` must be a table of rules"));
            continue;
        };
        for (name, body) in rules.iter() {
            let name_str = name.get_ref().to_string();
            let Some(table) = body.get_ref().as_table() else {
                problems
                    .push(loc.problem(body.span(), format!("rule `{name_str}` must be a table")));
                continue;
            };
            if !specs.contains_key(&name_str) {
                order.push(name_str.clone());
                specs.insert(
                    name_str.clone(),
                    RuleSpec {
                        first: (loc.file_index, name.span().start),
                        ..RuleSpec::default()
                    },
                );
            }
            let spec = specs.entry(name_str).or_default();
            spec.decl = Some((loc.file_index, name.span()));
            read_rule(loc, table, spec, problems);
        }
    }
}

fn text_of(
    loc: &Locator,
    v: &Spanned<DeValue>,
    key: &str,
    problems: &mut Vec<Problem>,
) -> Option<Text> {
    match v.get_ref().as_str() {
        Some(s) => Some(Text {
            value: s.to_owned(),
            file: loc.file_index,
            span: v.span(),
        }),
        None => {
            problems.push(loc.problem(v.span(), format!("`{key}` must be a string")));
            None
        }
    }
}

fn bool_of(
    loc: &Locator,
    v: &Spanned<DeValue>,
    key: &str,
    problems: &mut Vec<Problem>,
) -> Option<bool> {
    let b = v.get_ref().as_bool();
    if b.is_none() {
        problems.push(loc.problem(v.span(), format!("`{key}` must be true or false")));
    }
    b
}

fn read_rule(loc: &Locator, table: &DeTable, spec: &mut RuleSpec, problems: &mut Vec<Problem>) {
    for (key, v) in table.iter() {
        let k = key.get_ref().as_ref();
        match k {
            "event" => spec.event = text_of(loc, v, k, problems),
            "category" => spec.category = text_of(loc, v, k, problems),
            "when" => spec.when = text_of(loc, v, k, problems),
            "on" => spec.on = on_of(loc, v, problems),
            "clear" => spec.clear = text_of(loc, v, k, problems),
            "for" => spec.for_ = text_of(loc, v, k, problems),
            "clear_for" => spec.clear_for = text_of(loc, v, k, problems),
            "cleared" => spec.cleared = text_of(loc, v, k, problems),
            "cleared_category" => spec.cleared_category = text_of(loc, v, k, problems),
            "initial" => spec.initial = bool_of(loc, v, k, problems),
            "each" => spec.each = bool_of(loc, v, k, problems),
            "distinct" => spec.distinct = distinct_of(loc, v, problems),
            "reboot" => spec.reboot = bool_of(loc, v, k, problems),
            "enabled" => spec.enabled = bool_of(loc, v, k, problems),
            "source" => {
                if let Some(s) = read_source(loc, v, problems) {
                    spec.source = Some((s, loc.file_index, v.span()));
                }
            }
            "params" => match v.get_ref().as_table() {
                Some(t) => {
                    for (pk, pv) in t.iter() {
                        if let Some(text) = text_of(loc, pv, pk.get_ref(), problems) {
                            spec.params.insert(pk.get_ref().to_string(), text);
                        }
                    }
                }
                None => {
                    problems.push(loc.problem(v.span(), "`params` must be a table of expressions"))
                }
            },
            other => problems.push(loc.problem(
                key.span(),
                format!("unknown rule key `{other}` (known: {RULE_KEYS})"),
            )),
        }
    }
}

/// `on = "MSG"` or `on = ["MSG", ...]`: at least one message name.
fn on_of(loc: &Locator, v: &Spanned<DeValue>, problems: &mut Vec<Problem>) -> Option<Vec<Text>> {
    if v.get_ref().as_str().is_some() {
        return text_of(loc, v, "on", problems).map(|t| vec![t]);
    }
    let Some(items) = v.get_ref().as_array() else {
        problems.push(loc.problem(
            v.span(),
            "`on` must be a message name or a list of them (on = \"MISSION_ITEM_REACHED\")",
        ));
        return None;
    };
    if items.is_empty() {
        problems.push(loc.problem(
            v.span(),
            "`on` lists no message: name at least one (leave `on` out to evaluate the rule on every message it reads)",
        ));
        return None;
    }
    // The names that are strings are checked even when another is not, so
    // that every problem comes at once.
    Some(
        items
            .iter()
            .filter_map(|item| text_of(loc, item, "on", problems))
            .collect(),
    )
}

/// `distinct = true` (the last event), `false`, or how many events (1-64).
fn distinct_of(loc: &Locator, v: &Spanned<DeValue>, problems: &mut Vec<Problem>) -> Option<usize> {
    if let Some(b) = v.get_ref().as_bool() {
        return Some(usize::from(b));
    }
    let n = v
        .get_ref()
        .as_integer()
        .and_then(|i| i64::from_str_radix(i.as_str(), i.radix()).ok())
        .and_then(|i| usize::try_from(i).ok())
        .filter(|n| (1..=MAX_DISTINCT).contains(n));
    if n.is_none() {
        problems.push(loc.problem(
            v.span(),
            format!("`distinct` must be true, false or how many events to remember (1 to {MAX_DISTINCT})"),
        ));
    }
    n
}

/// The most events a `distinct` rule remembers.
pub const MAX_DISTINCT: usize = 64;

fn read_source(
    loc: &Locator,
    v: &Spanned<DeValue>,
    problems: &mut Vec<Problem>,
) -> Option<SourceFilter> {
    if let Some(s) = v.get_ref().as_str() {
        let f = match s {
            "autopilot" => SourceFilter::Autopilot,
            "vehicle" => SourceFilter::Vehicle,
            "gcs" => SourceFilter::Gcs,
            "any" => SourceFilter::Any,
            _ => {
                problems.push(loc.problem(v.span(), format!("unknown source `{s}` (autopilot, vehicle, gcs, any, or {{ sysid = N, compid = M }})")));
                return None;
            }
        };
        return Some(f);
    }
    let Some(t) = v.get_ref().as_table() else {
        problems.push(loc.problem(
            v.span(),
            "`source` must be a name or { sysid = N, compid = M }",
        ));
        return None;
    };
    let mut ids = (None, None);
    for (k, val) in t.iter() {
        let n = val
            .get_ref()
            .as_integer()
            .and_then(|i| i64::from_str_radix(i.as_str(), i.radix()).ok())
            .and_then(|i| u8::try_from(i).ok());
        let Some(n) = n else {
            problems.push(loc.problem(val.span(), "an id must be an integer from 0 to 255"));
            continue;
        };
        match k.get_ref().as_ref() {
            "sysid" => ids.0 = Some(n),
            "compid" => ids.1 = Some(n),
            other => problems.push(loc.problem(
                k.span(),
                format!("unknown source key `{other}` (sysid, compid)"),
            )),
        }
    }
    Some(SourceFilter::Ids {
        sysid: ids.0,
        compid: ids.1,
    })
}

/// Parses `2s`, `500ms`, `1.5s`, `1min` into microseconds.
pub fn parse_duration(s: &str) -> Option<u64> {
    let s = s.trim();
    let split = s.find(|c: char| !(c.is_ascii_digit() || c == '.'))?;
    let (num, unit) = s.split_at(split);
    let n: f64 = num.parse().ok()?;
    let scale = match unit.trim() {
        "us" => 1.0,
        "ms" => 1e3,
        "s" => 1e6,
        "min" => 60e6,
        _ => return None,
    };
    let us = n * scale;
    (0.0..1e15).contains(&us).then_some(us as u64)
}

// ------------------------------------------------------------ compiling

#[derive(Default)]
struct Builder {
    slots: Vec<Slot>,
    regexes: Vec<Regex>,
    memos: usize,
}

impl Builder {
    fn slot_for(&mut self, id: u32, decode: bool) -> usize {
        if let Some(i) = self.slots.iter().position(|s| s.id == id) {
            self.slots[i].decode |= decode;
            return i;
        }
        self.slots.push(Slot {
            id,
            fields: fields::schema(id).unwrap_or_default(),
            decode,
        });
        self.slots.len() - 1
    }

    fn message_id(name: &str) -> Result<u32, String> {
        MavMessage::message_id_from_name(name)
            .ok_or_else(|| format!("unknown message `{name}` (not in the ardupilotmega dialect)"))
    }

    fn compile(
        &mut self,
        text: &Text,
        locs: &[Locator],
        problems: &mut Vec<Problem>,
    ) -> Option<Compiled> {
        match expr::compile(&text.value, self) {
            Ok(c) => Some(c),
            Err(ExprError {
                offset,
                len,
                message,
            }) => {
                let loc = &locs[text.file];
                let raw = &loc.text[text.span.start.min(loc.text.len())..];
                let open = if raw.starts_with("\"\"\"") || raw.starts_with("'''") {
                    3 + usize::from(raw[3..].starts_with('\n'))
                } else {
                    1
                };
                let start = text.span.start + open + offset;
                problems.push(loc.problem(start..start + len, message));
                None
            }
        }
    }

    fn rule(
        &mut self,
        key: &str,
        spec: &RuleSpec,
        locs: &[Locator],
        problems: &mut Vec<Problem>,
    ) -> Option<Rule> {
        let (decl_file, decl_span) = spec.decl.clone().unwrap_or((0, 0..0));
        let decl = locs[decl_file];
        let before = problems.len();
        let category = |t: &Option<Text>,
                        what: &str,
                        problems: &mut Vec<Problem>|
         -> Option<Category> {
            match t {
                Some(t) => match t.value.parse::<Category>() {
                    Ok(c) => Some(c),
                    Err(e) => {
                        problems.push(locs[t.file].problem(t.span.clone(), e.to_string()));
                        None
                    }
                },
                None => {
                    problems.push(
                        decl.problem(decl_span.clone(), format!("rule `{key}` has no `{what}`")),
                    );
                    None
                }
            }
        };
        let cat = category(&spec.category, "category", problems);
        let when = match &spec.when {
            Some(t) => self.compile(t, locs, problems),
            None => {
                problems.push(decl.problem(
                    decl_span.clone(),
                    format!("rule `{key}` has no `when` condition"),
                ));
                None
            }
        };
        let clear = spec
            .clear
            .as_ref()
            .and_then(|t| self.compile(t, locs, problems));
        let duration = |t: &Option<Text>, problems: &mut Vec<Problem>| -> u64 {
            match t {
                Some(t) => parse_duration(&t.value).unwrap_or_else(|| {
                    problems.push(locs[t.file].problem(
                        t.span.clone(),
                        format!(
                            "bad duration `{}` (as in \"2s\", \"500ms\", \"1min\")",
                            t.value
                        ),
                    ));
                    0
                }),
                None => 0,
            }
        };
        let for_us = duration(&spec.for_, problems);
        let clear_for_us = duration(&spec.clear_for, problems);
        let mut params = Vec::new();
        for (name, t) in &spec.params {
            if let Some(c) = self.compile(t, locs, problems) {
                params.push((name.clone(), c));
            }
        }
        let cleared = match &spec.cleared {
            Some(t) => {
                let c = match &spec.cleared_category {
                    Some(_) => category(&spec.cleared_category, "cleared_category", problems),
                    None => cat,
                };
                c.map(|c| (t.value.clone(), c))
            }
            None => None,
        };
        let event = spec
            .event
            .as_ref()
            .map(|t| t.value.clone())
            .unwrap_or_else(|| key.to_owned());
        for (name, t) in std::iter::once((&event, spec.event.as_ref()))
            .chain(cleared.as_ref().map(|c| (&c.0, spec.cleared.as_ref())))
        {
            if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                let (loc, span) = match t {
                    Some(t) => (locs[t.file], t.span.clone()),
                    None => (decl, decl_span.clone()),
                };
                problems.push(loc.problem(
                    span,
                    format!("bad event name `{name}` (letters, digits and _)"),
                ));
            }
        }
        let each = spec.each.unwrap_or(false);
        let distinct = spec.distinct.unwrap_or(0);
        if distinct > 0 && !each {
            problems.push(decl.problem(
                decl_span.clone(),
                format!("rule `{key}`: `distinct` applies to `each` rules only (a rule without `each` fires once until `clear` anyway)"),
            ));
        }
        let reboot = spec.reboot.unwrap_or(false);
        if reboot && !each {
            problems.push(decl.problem(
                decl_span.clone(),
                format!("rule `{key}`: `reboot` applies to `each` rules only (a reboot is an occurrence, seen on the message that shows it)"),
            ));
        }
        if each && distinct == 0 && spec.clear.is_some() {
            problems.push(decl.problem(
                decl_span.clone(),
                format!("rule `{key}`: `clear` on an `each` rule needs `distinct = true` (it re-arms a distinct rule)"),
            ));
        }
        let on = spec.on.as_ref().map(|names| {
            let mut slots = Vec::new();
            for t in names {
                match Builder::message_id(&t.value) {
                    Ok(id) => slots.push(self.slot_for(id, false)),
                    Err(e) => problems.push(locs[t.file].problem(t.span.clone(), e)),
                }
            }
            slots.sort_unstable();
            slots.dedup();
            slots
        });
        if problems.len() > before {
            return None;
        }
        let (when, category) = (when?, cat?);
        // A rule with `on` is evaluated on frames of those messages only,
        // never on ticks: `age()` and `loss()` are read there, `for` and
        // `clear_for` measured there.
        let ages = on.is_none() && (when.timed || clear.as_ref().is_some_and(|c| c.timed));
        let timed = on.is_none()
            && (when.timed
                || clear.as_ref().is_some_and(|c| c.timed)
                || for_us > 0
                || clear_for_us > 0);
        Some(Rule {
            name: key.to_owned(),
            event,
            category,
            when,
            clear,
            for_us,
            clear_for_us,
            cleared,
            initial: spec.initial.unwrap_or(true),
            each,
            distinct,
            reboot,
            params,
            source: spec
                .source
                .as_ref()
                .map(|s| s.0)
                .unwrap_or(SourceFilter::Autopilot),
            on,
            timed,
            ages,
        })
    }
}

impl Resolver for Builder {
    fn field(&mut self, message: &str, field: &str) -> Result<(usize, usize), String> {
        let id = Builder::message_id(message)?;
        let slot = self.slot_for(id, true);
        let fields = &self.slots[slot].fields;
        fields
            .iter()
            .position(|f| f == field)
            .map(|i| (slot, i))
            .ok_or_else(|| {
                format!(
                    "`{message}` has no field `{field}` (fields: {})",
                    fields.join(", ")
                )
            })
    }

    fn timed_message(&mut self, message: &str) -> Result<usize, String> {
        let id = Builder::message_id(message)?;
        Ok(self.slot_for(id, false))
    }

    fn constant(&self, name: &str) -> Option<i64> {
        crate::constants::value(name)
    }

    fn regex(&mut self, regex: Regex) -> usize {
        self.regexes.push(regex);
        self.regexes.len() - 1
    }

    fn memo(&mut self) -> usize {
        self.memos += 1;
        self.memos - 1
    }
}

/// What a profile says of the events it produces: category and parameter
/// names (a cleared event carries none). The project loader checks guards
/// and `$params` against it (`nets::load_with`).
impl Profile {
    pub fn catalog(&self) -> nets::load::Catalog {
        let mut out = nets::load::Catalog::new();
        for r in &self.rules {
            let entry = out.entry(r.event.clone()).or_default();
            entry.category.get_or_insert(r.category);
            let params = entry.params.get_or_insert_with(Vec::new);
            for (name, _) in &r.params {
                if !params.contains(name) {
                    params.push(name.clone());
                }
            }
            if let Some((cleared, category)) = &r.cleared {
                let e = out.entry(cleared.clone()).or_default();
                e.category.get_or_insert(*category);
                e.params.get_or_insert_with(Vec::new);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations() {
        assert_eq!(parse_duration("2s"), Some(2_000_000));
        assert_eq!(parse_duration("500ms"), Some(500_000));
        assert_eq!(parse_duration("1.5s"), Some(1_500_000));
        assert_eq!(parse_duration("1min"), Some(60_000_000));
        assert_eq!(parse_duration("2 parsecs"), None);
        assert_eq!(parse_duration("s"), None);
    }

    #[test]
    fn builtin_profiles_compile() {
        for name in ["ardupilot", "px4"] {
            let p = Profile::builtin(name).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(p.rules().len() > 20, "{name} has {} rules", p.rules().len());
        }
    }

    #[test]
    fn all_problems_at_once_with_positions() {
        let text = "[rules.a]\ncategory = \"safety\"\nwhen = \"SYS_STATUS.battery_remainin < 5\"\n\n[rules.b]\ncategory = \"bogus\"\nwhen = \"NOPE.x > 1\"\nfor = \"2 parsecs\"\ncolour = 3\n";
        let err = Profile::load(&[("my.toml", text)]).expect_err("invalid");
        let lines: Vec<(usize, usize)> = err.problems.iter().map(|p| (p.line, p.col)).collect();
        assert_eq!(err.problems.len(), 5, "{err}");
        assert!(err.problems.iter().all(|p| p.file == "my.toml"));
        // `SYS_STATUS.battery_remainin` starts at column 9 of line 3.
        assert_eq!(lines[0], (3, 9));
        assert!(
            err.problems[0].message.contains("battery_remaining"),
            "{}",
            err.problems[0].message
        );
        assert_eq!(lines[1], (6, 12));
        assert_eq!(lines[2], (7, 9));
        assert_eq!(lines[3], (8, 7));
        assert_eq!(lines[4], (9, 1));
    }

    #[test]
    fn problems_of_every_layer_come_together_each_with_its_file() {
        let base = "[rules.a]\ncategory = \"safety\"\nwhen = \"HEARTBEAT.nope == 1\"\n";
        let user = "[rules.a]\ncategory = \"fatal\"\n\n[rules.b]\ncategory = \"mission\"\nwhen = \"age(NOT_A_MESSAGE) > 2\"\nfor = \"soon\"\n";
        let err = Profile::load(&[("base.toml", base), ("user.toml", user)]).expect_err("invalid");
        let got: Vec<String> = err
            .problems
            .iter()
            .map(|p| format!("{}:{}:{}", p.file, p.line, p.col))
            .collect();
        assert_eq!(
            got,
            [
                "base.toml:3:9",
                "user.toml:2:12",
                "user.toml:6:13",
                "user.toml:7:7"
            ],
            "{err}"
        );
    }

    #[test]
    fn distinct_needs_each_and_clear_on_each_needs_distinct() {
        let text = "[rules.a]\ncategory = \"nominal\"\nwhen = \"true\"\ndistinct = true\n\n[rules.b]\ncategory = \"nominal\"\neach = true\nwhen = \"true\"\nclear = \"false\"\n\n[rules.c]\ncategory = \"nominal\"\neach = true\nwhen = \"true\"\ndistinct = 65\n";
        let err = Profile::load(&[("x.toml", text)]).expect_err("invalid");
        let lines: Vec<usize> = err.problems.iter().map(|p| p.line).collect();
        assert_eq!(lines, [1, 6, 16], "{err}");
        assert!(err.problems[2].message.contains("1 to 64"), "{err}");
        let ok = "[rules.c]\ncategory = \"nominal\"\neach = true\nwhen = \"true\"\ndistinct = 16\n";
        let p = Profile::load(&[("x.toml", ok)]).expect("valid");
        assert_eq!(p.rules()[0].distinct, 16);
        assert!(
            err.problems[0].message.contains("`each` rules only"),
            "{err}"
        );
        assert!(
            err.problems[1].message.contains("needs `distinct = true`"),
            "{err}"
        );
    }

    #[test]
    fn only_acknowledgements_are_addressed_events() {
        // COMMAND_ACK has target fields: its acknowledgements go to the
        // link of the command's sender alone. STATUSTEXT and
        // MISSION_ITEM_REACHED go to every link; state rules tick.
        for name in ["ardupilot", "px4"] {
            let p = Profile::builtin(name).expect("builtin");
            assert_eq!(p.addressed_events(), ["command_rejected"], "{name}");
        }
    }

    #[test]
    fn telemetry_leaves_out_the_messages_that_are_events() {
        for name in ["ardupilot", "px4"] {
            let p = Profile::builtin(name).expect("profile");
            let telemetry = p.telemetry();
            // STATUSTEXT, COMMAND_ACK, MISSION_ITEM_REACHED: read, not streamed.
            for event in [253, 77, 46] {
                assert!(p.messages().contains(&event), "{name} reads {event}");
                assert!(!telemetry.contains(&event), "{name} streams {event}");
            }
            // HEARTBEAT, SYS_STATUS, GPS_RAW_INT, MISSION_CURRENT, BATTERY_STATUS.
            for state in [0, 1, 24, 42, 147] {
                assert!(telemetry.contains(&state), "{name} does not stream {state}");
            }
        }
        let p = Profile::builtin("ardupilot").expect("profile");
        // SERVO_OUTPUT_RAW (motor_imbalance), FENCE_STATUS (geofence_breach),
        // ATTITUDE (loss_of_control's `on`) and NAV_CONTROLLER_OUTPUT (its
        // attitude target).
        for id in [36, 162, 30, 62] {
            assert!(p.telemetry().contains(&id), "{id}");
        }
    }

    #[test]
    fn on_names_messages_of_the_dialect_and_its_problems_are_located() {
        let text = r#"[rules.a]
category = "nominal"
when = "true"
on = "NOT_A_MESSAGE"

[rules.b]
category = "nominal"
when = "true"
on = []

[rules.c]
category = "nominal"
when = "true"
on = 3

[rules.d]
category = "nominal"
when = "true"
on = ["HEARTBEAT", 4, "NOPE"]
"#;
        let err = Profile::load(&[("on.toml", text)]).expect_err("invalid");
        let got: Vec<(usize, usize)> = err.problems.iter().map(|p| (p.line, p.col)).collect();
        assert_eq!(got, [(4, 6), (9, 6), (14, 6), (19, 20), (19, 23)], "{err}");
        assert!(err.problems[0]
            .message
            .contains("unknown message `NOT_A_MESSAGE`"));
        assert!(
            err.problems[1].message.contains("lists no message"),
            "{err}"
        );
        assert!(
            err.problems[2].message.contains("message name or a list"),
            "{err}"
        );
        assert!(
            err.problems[3].message.contains("must be a string"),
            "{err}"
        );
        assert!(
            err.problems[4].message.contains("unknown message `NOPE`"),
            "{err}"
        );

        let ok = "[rules.a]\ncategory = \"nominal\"\neach = true\nwhen = 'mode() == \"GUIDED\"'\non = [\"MISSION_ITEM_REACHED\", \"STATUSTEXT\", \"STATUSTEXT\"]\n";
        let p = Profile::load(&[("ok.toml", ok)]).expect("valid");
        let slot = |name: &str| {
            let id = MavMessage::message_id_from_name(name).expect("in the dialect");
            p.slots.iter().position(|s| s.id == id)
        };
        let (hb, reached, text) = (
            slot("HEARTBEAT").expect("read"),
            slot("MISSION_ITEM_REACHED").expect("listed"),
            slot("STATUSTEXT").expect("listed"),
        );
        let rule = &p.rules()[0];
        assert_eq!(rule.on, Some(vec![reached, text]));
        assert!(rule.fires_on(reached) && rule.fires_on(text) && !rule.fires_on(hb));
        // Evaluated on those only (not on the HEARTBEAT mode() reads);
        // the listed messages are not decoded for it, nothing reads them.
        assert!(p.by_slot[hb].is_empty());
        assert_eq!(
            (&p.by_slot[reached], &p.by_slot[text]),
            (&vec![0], &vec![0])
        );
        assert!(!p.slots[reached].decode && !p.slots[text].decode);
    }

    #[test]
    fn on_overrides_by_layer_and_takes_the_rule_off_the_ticks() {
        let base = "[rules.a]\ncategory = \"safety\"\nwhen = \"age(GPS_RAW_INT) > 2\"\n";
        let p = Profile::load(&[("base.toml", base)]).expect("valid");
        assert_eq!((p.timed.len(), p.rules()[0].on.clone()), (1, None));
        let user = "[rules.a]\non = \"SYSTEM_TIME\"\n";
        let p = Profile::load(&[("base.toml", base), ("user.toml", user)]).expect("valid");
        assert!(p.timed.is_empty());
        let on = p.rules()[0].on.clone().expect("on");
        assert_eq!(on.len(), 1);
        assert_eq!(p.slots[on[0]].id, 2, "SYSTEM_TIME");
        let again = "[rules.a]\non = \"SYSTEM_TYME\"\n";
        let err = Profile::load(&[
            ("base.toml", base),
            ("user.toml", user),
            ("again.toml", again),
        ])
        .expect_err("invalid");
        // A state rule evaluated on SYSTEM_TIME only needs it streamed; an
        // each rule's `on` message is an event, not asked for.
        assert!(p.telemetry().contains(&2));
        let each = "[rules.b]\ncategory = \"nominal\"\neach = true\non = \"STATUSTEXT\"\nwhen = \"true\"\n";
        let p = Profile::load(&[("each.toml", each)]).expect("valid");
        assert!(p.messages().contains(&253) && !p.telemetry().contains(&253));
        let got: Vec<String> = err.problems.iter().map(ToString::to_string).collect();
        assert_eq!(got.len(), 1, "{err}");
        assert!(
            got[0].starts_with("again.toml:2:6: unknown message `SYSTEM_TYME`"),
            "{err}"
        );
    }

    #[test]
    fn syntax_errors_are_located() {
        let err = Profile::load(&[("x.toml", "[rules.a\ncategory = 1")]).expect_err("invalid");
        assert!(!err.problems.is_empty());
        assert_eq!(err.problems[0].line, 1);
    }

    #[test]
    fn layers_override_by_rule_name() {
        let base = "[rules.a]\ncategory = \"safety\"\nwhen = \"SYS_STATUS.battery_remaining < 5\"\n[rules.b]\ncategory = \"nominal\"\nwhen = \"true\"\n";
        let user = "[rules.a]\ncategory = \"catastrophic\"\n[rules.b]\nenabled = false\n[rules.c]\ncategory = \"mission\"\nwhen = \"GPS_RAW_INT.satellites_visible < 4\"\n";
        let p = Profile::load(&[("base.toml", base), ("user.toml", user)]).expect("valid");
        let names: Vec<(&str, Category)> = p
            .rules()
            .iter()
            .map(|r| (r.event.as_str(), r.category))
            .collect();
        assert_eq!(
            names,
            vec![("a", Category::Catastrophic), ("c", Category::Mission)]
        );
    }
}
