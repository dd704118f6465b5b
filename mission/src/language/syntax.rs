//! The mission file as written: TOML read with its spans, nothing checked
//! beyond the shape of each value.

use std::collections::BTreeMap;
use std::fmt;
use std::ops::Range;

use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::Deserialize;
use toml::Spanned;

/// A string and where it is written.
pub type Text = Spanned<String>;

/// The whole mission file.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawMission {
    /// The steps net's name (default `MISSION`).
    pub name: Option<Text>,
    pub description: Option<String>,
    /// Actions when a step leads to `done`, `abort`, `land`.
    pub done: Option<Spanned<Actions>>,
    pub abort: Option<Spanned<Actions>>,
    pub land: Option<Spanned<Actions>>,
    #[serde(default)]
    pub steps: BTreeMap<Text, Spanned<RawStep>>,
    #[serde(default)]
    pub rules: BTreeMap<Text, Spanned<RawRule>>,
    #[serde(default)]
    pub reactions: BTreeMap<Text, BTreeMap<Text, Spanned<RawReaction>>>,
    /// `[procedures.CATEGORY]`: steps a reaction of the category leads into.
    #[serde(default)]
    pub procedures: BTreeMap<Text, BTreeMap<Text, Spanned<RawStep>>>,
    /// `[levels.NAME]`: a sequence of steps in a net of its own, run by a
    /// step of the mission (the paper's level 3).
    #[serde(default)]
    pub levels: BTreeMap<Text, BTreeMap<Text, Spanned<RawStep>>>,
}

/// `[steps] NAME = { … }`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawStep {
    #[serde(rename = "do")]
    pub actions: Option<Spanned<Actions>>,
    /// The first exit, in short: its event, guard, target and actions.
    pub until: Option<Text>,
    pub when: Option<Text>,
    pub then: Option<Text>,
    #[serde(default)]
    pub exits: Vec<Spanned<RawExit>>,
    pub limit: Option<Text>,
    pub retries: Option<Spanned<i64>>,
    /// How long to wait before each retry (default: none).
    pub retry_after: Option<Text>,
    pub on_limit: Option<Text>,
    /// A parallel step: each branch a list of step names.
    pub branches: Option<Spanned<Vec<Vec<Text>>>>,
    /// The phase of the mission this step is in: a global place of
    /// project.toml, marked while the mission is in the step.
    pub phase: Option<Text>,
    /// A level of its own (`[levels.NAME]`) the step runs: activated on
    /// entering the step, deactivated on leaving it.
    pub run: Option<Text>,
}

/// One more way out of a step.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawExit {
    /// The event; none: an immediate exit on `phase`.
    pub on: Option<Text>,
    /// Only in this phase of the mission (a global place): a procedure's
    /// or a level's way to decide by the phase.
    pub phase: Option<Text>,
    pub when: Option<Text>,
    pub then: Option<Text>,
    #[serde(rename = "do")]
    pub actions: Option<Spanned<Actions>>,
}

/// `[rules] NAME = { … }`: an interrupt during some steps.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawRule {
    pub during: Option<Spanned<Vec<Text>>>,
    pub on: Option<Text>,
    pub when: Option<Text>,
    #[serde(rename = "for")]
    pub lasting: Option<Text>,
    #[serde(rename = "do")]
    pub actions: Option<Spanned<Actions>>,
    pub resume_on: Option<Text>,
    pub then: Option<Text>,
}

/// `[reactions.CATEGORY] EVENT = { … }`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawReaction {
    pub on: Option<Text>,
    pub when: Option<Text>,
    #[serde(rename = "do")]
    pub actions: Option<Spanned<Actions>>,
    pub then: Option<Text>,
    /// Only in these phases of the mission (global places).
    pub phases: Option<Spanned<Vec<Text>>>,
}

/// One action (`do = "command rtl"`) or a list of them. A lone string's
/// span is the surrounding `Spanned`'s: [`Actions::spanned`].
pub struct Actions(Vec<(String, Option<Range<usize>>)>);

impl Actions {
    /// Each action with its span (`whole` for a lone string).
    pub fn spanned(&self, whole: Range<usize>) -> Vec<Text> {
        self.0
            .iter()
            .map(|(text, span)| Spanned::new(span.clone().unwrap_or(whole.clone()), text.clone()))
            .collect()
    }
}

impl<'de> Deserialize<'de> for Actions {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct OneOrMany;
        impl<'de> Visitor<'de> for OneOrMany {
            type Value = Actions;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an action or a list of actions")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Actions, E> {
                Ok(Actions(vec![(v.to_owned(), None)]))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Actions, A::Error> {
                let mut out = Vec::new();
                while let Some(item) = seq.next_element::<Text>()? {
                    let span = item.span();
                    out.push((item.into_inner(), Some(span)));
                }
                Ok(Actions(out))
            }
        }
        deserializer.deserialize_any(OneOrMany)
    }
}

/// The entries of a table in the order the file writes them (a TOML table
/// deserialises in key order).
pub fn in_order<T>(table: &BTreeMap<Text, T>) -> Vec<(&Text, &T)> {
    let mut entries: Vec<(&Text, &T)> = table.iter().collect();
    entries.sort_by_key(|(k, _)| k.span().start);
    entries
}

/// Reads the mission file's text; a TOML or shape error at its span.
pub fn parse(text: &str) -> Result<RawMission, (Range<usize>, String)> {
    toml::from_str(text).map_err(|e| {
        (
            e.span().unwrap_or(0..0),
            e.message().trim().replace('\n', " "),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_action_alone_or_in_a_list_keeps_its_span() {
        let text =
            "[steps]\na = { do = \"command rtl\" }\nb = { do = [\"command arm\", \"emit x\"] }\n";
        let raw = parse(text).expect("parses");
        let steps = in_order(&raw.steps);
        let a = steps[0].1.get_ref().actions.as_ref().expect("a's do");
        let a = a.get_ref().spanned(a.span());
        assert_eq!(&text[a[0].span()], "\"command rtl\"");
        let b = steps[1].1.get_ref().actions.as_ref().expect("b's do");
        let b = b.get_ref().spanned(b.span());
        assert_eq!(&text[b[1].span()], "\"emit x\"");
    }

    #[test]
    fn an_unknown_key_is_refused_at_it() {
        let text = "[steps]\na = { dx = 1 }\n";
        let (span, message) = parse(text).err().expect("refused");
        assert!(message.contains("unknown field"), "{message}");
        assert!(span.start > 8, "{span:?}");
    }
}
