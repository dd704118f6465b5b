//! A mission once checked: steps, rules and reactions with every name
//! resolved, every duration read and every span kept, ready to compile.

use std::ops::Range;

use nets::source::SourceFile;
use nets::{Category, Micros};

/// A piece of text of the mission file (an action, a guard, an event
/// name) and where it is written.
#[derive(Debug, Clone, PartialEq)]
pub struct Said {
    pub text: String,
    pub span: Range<usize>,
}

/// Where an outcome leads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// A step, by index.
    Step(usize),
    /// The same step again, while retries are left; then its `on_limit`.
    Retry,
    /// The end of a parallel step's branch: (parallel step, branch).
    Join(usize, usize),
    /// The mission is over.
    Done,
    Abort,
    Land,
}

/// A way out of a step: an event (with a guard), where it leads, and the
/// actions taken on the way.
#[derive(Debug, Clone, PartialEq)]
pub struct Exit {
    /// The event; `None`: immediate (an exit on a phase).
    pub on: Option<Said>,
    pub when: Option<Said>,
    /// Taken only in this phase (a procedure's or a level's step).
    pub phase: Option<Said>,
    pub then: Target,
    pub actions: Vec<Said>,
}

/// A time limit: as written, and read.
#[derive(Debug, Clone, PartialEq)]
pub struct Limit {
    pub said: Said,
    pub micros: Micros,
}

/// One step of the mission.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    pub name: String,
    /// Its key in `[steps]`.
    pub span: Range<usize>,
    /// Run on entering it (each retry too).
    pub actions: Vec<Said>,
    pub exits: Vec<Exit>,
    pub limit: Option<Limit>,
    /// Times the step is entered again (`then = "retry"`, or its limit)
    /// before `on_limit`.
    pub retries: u32,
    /// The wait before each retry, if any.
    pub retry_after: Option<Limit>,
    /// Where the limit leads once no retry is left (default: abort).
    pub on_limit: Target,
    /// A parallel step: its branches, each a sequence of steps.
    pub branches: Vec<Vec<usize>>,
    /// A step of a parallel step's branch: (parallel step, branch).
    pub branch_of: Option<(usize, usize)>,
    /// Where `next` leads from this step.
    pub next: Target,
    /// Its phase (a global place), a branch's step its parallel step's.
    pub phase: Option<String>,
    /// The level it runs, by index in [`Mission::levels`].
    pub run: Option<usize>,
}

/// A sequence of steps in a net of its own, inactive until a step of the
/// mission runs it (the paper's level 3): `done` ends it.
#[derive(Debug, Clone, PartialEq)]
pub struct Level {
    /// Its net's name.
    pub name: String,
    pub span: Range<usize>,
    pub steps: Vec<Step>,
    pub first: usize,
}

/// An interrupt during some steps.
#[derive(Debug, Clone, PartialEq)]
pub struct Rule {
    pub name: String,
    pub span: Range<usize>,
    /// The steps it watches, by index.
    pub during: Vec<usize>,
    pub on: Said,
    pub when: Option<Said>,
    /// `for`: the condition must last this long (ended by `resume_on`).
    pub lasting: Option<Limit>,
    pub actions: Vec<Said>,
    /// The step is suspended until this event, then entered again.
    pub resume_on: Option<Said>,
    /// Or the step is left for good, to this target.
    pub then: Option<Target>,
}

/// What a reaction does to the steps once it has run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum End {
    /// The mission goes on as planned.
    Stay,
    /// The steps stop; the mission's `abort` actions run.
    Abort,
    /// The steps stop; the mission's `land` actions run.
    Land,
    /// Into a step of its category's procedure, by index.
    Procedure(usize),
}

/// The steps a category's reactions lead into, run in its net: `done`
/// goes back to watching (for catastrophic: the reaction is over), `abort`
/// and `land` stop the mission's steps.
#[derive(Debug, Clone, PartialEq)]
pub struct Procedure {
    pub category: Category,
    pub steps: Vec<Step>,
}

/// A reaction to a disruptive event, in its category's net.
#[derive(Debug, Clone, PartialEq)]
pub struct Reaction {
    pub name: String,
    pub span: Range<usize>,
    pub category: Category,
    pub on: Said,
    pub when: Option<Said>,
    pub actions: Vec<Said>,
    pub end: End,
    /// Only in these phases (global places); empty: in any.
    pub phases: Vec<String>,
}

/// A checked mission.
#[derive(Debug, Clone)]
pub struct Mission {
    pub file: SourceFile,
    /// The steps net's name, and its `name` in the file (empty: the
    /// default).
    pub net: String,
    pub net_span: Range<usize>,
    pub steps: Vec<Step>,
    /// The step the mission starts with.
    pub first: usize,
    pub rules: Vec<Rule>,
    pub reactions: Vec<Reaction>,
    pub procedures: Vec<Procedure>,
    pub levels: Vec<Level>,
    pub done: Vec<Said>,
    pub abort: Vec<Said>,
    pub land: Vec<Said>,
}

impl Mission {
    /// The steps of the main sequence (not in a branch), in order.
    pub fn sequence(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.steps.len()).filter(|&i| self.steps[i].branch_of.is_none())
    }
}

/// The disruptive categories, in the paper's priority order, with the name
/// of the net each one's reactions compile into.
pub const CATEGORIES: [(Category, &str, &str); 4] = [
    (Category::Catastrophic, "catastrophic", "CATASTROPHIC"),
    (Category::Safety, "safety", "SAFETY"),
    (Category::Mission, "mission", "MISSION_RELATED"),
    (Category::Communication, "communication", "COMMUNICATION"),
];
