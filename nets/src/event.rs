//! Events: what the player reacts to. Elaboration, programs, timers, command
//! results and the nets themselves all produce this one shape.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::value::{fmt_params, Params, Value};

/// The category of an event: the paper's four disruptive categories, plus
/// nominal. The declaration order is the processing priority: queued events
/// of an earlier category are handled first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Category {
    Catastrophic,
    Safety,
    Communication,
    Mission,
    Nominal,
}

impl Category {
    /// Every category, highest priority first.
    pub const ALL: [Category; 5] = [
        Category::Catastrophic,
        Category::Safety,
        Category::Communication,
        Category::Mission,
        Category::Nominal,
    ];

    /// The lowercase name used in files and output.
    pub fn as_str(self) -> &'static str {
        match self {
            Category::Catastrophic => "catastrophic",
            Category::Safety => "safety",
            Category::Communication => "communication",
            Category::Mission => "mission",
            Category::Nominal => "nominal",
        }
    }

    /// Priority index: 0 for catastrophic up to 4 for nominal.
    pub fn priority(self) -> usize {
        self as usize
    }
}

impl fmt::Display for Category {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Error for a category name that is not one of the five.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "unknown category `{0}` (expected catastrophic, safety, communication, mission or nominal)"
)]
pub struct UnknownCategory(pub String);

impl FromStr for Category {
    type Err = UnknownCategory;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s {
            "catastrophic" => Category::Catastrophic,
            "safety" => Category::Safety,
            "communication" => Category::Communication,
            "mission" => Category::Mission,
            "nominal" => Category::Nominal,
            _ => return Err(UnknownCategory(s.to_owned())),
        })
    }
}

/// One occurrence of an event: a name, a category and parameters. Its time is
/// passed beside it (`Player::handle(event, now)`), so the same event value
/// can be reused.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Event {
    pub name: String,
    pub category: Category,
    #[serde(default)]
    pub params: Params,
}

impl Event {
    /// A nominal event with no parameters.
    pub fn new(name: impl Into<String>) -> Self {
        Event {
            name: name.into(),
            category: Category::Nominal,
            params: Params::new(),
        }
    }

    /// Sets the category.
    pub fn category(mut self, category: Category) -> Self {
        self.category = category;
        self
    }

    /// Adds a parameter.
    pub fn param(mut self, name: impl Into<String>, value: impl Into<Value>) -> Self {
        self.params.insert(name.into(), value.into());
        self
    }
}

impl fmt::Display for Event {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name)?;
        if !self.params.is_empty() {
            f.write_str(" ")?;
            fmt_params(f, &self.params)?;
        }
        Ok(())
    }
}
