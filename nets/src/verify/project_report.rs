//! What a project's check found: the report of one exploration (the whole
//! project's, a net's in it, a net's alone), the reductions it ran, and
//! the project's report gathering them.

/// What one exploration found.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// Reachable states.
    pub states: usize,
    /// Steps (state, input) that lead somewhere: something fired, a fault
    /// was found, or the state changed.
    pub edges: usize,
    /// Reachable states from which nothing can ever fire again and that hold
    /// no final place.
    pub dead_markings: usize,
    /// No reachable step attempts to put a second token in a place.
    pub safe: bool,
    /// The most tokens a place in scope ever holds (for a net: its own
    /// places and the global places it uses); the player never lets it
    /// exceed 1.
    pub max_tokens: u32,
    /// A shortest sequence of steps to a dead marking.
    pub deadlock_example: Option<Vec<String>>,
    /// A shortest sequence of steps whose last one attempts a double token.
    pub unsafe_example: Option<Vec<String>>,
    /// Livelocks: a step in which immediate transitions or internally emitted
    /// events kept firing past the player's bounds (errors).
    pub livelocks: Vec<Vec<String>>,
    /// Other cycles of firing steps (information: a waypoint loop).
    pub loops: Vec<Vec<String>>,
    /// What a net alone shows that it does not show in its project: it
    /// relies on the other nets (information, as a design usually
    /// intends: a net waiting for a global place another fills is dead
    /// alone). The whole project's report lists every net's.
    pub relies: Vec<String>,
    pub warnings: Vec<String>,
    /// False when the state limit stopped the exploration.
    pub complete: bool,
    /// Declared shared resources (`[[exclusive]]`) held by two vehicles
    /// at once in a reachable state (the whole project's report only).
    pub exclusion: Vec<Exclusion>,
    /// The reductions the exploration ran (the whole project's report
    /// only).
    pub reduction: Reduction,
}

/// Which reductions an exploration ran, and what they saved.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Reduction {
    /// The classes of interchangeable vehicles explored one representative
    /// per orbit (empty: no symmetry used).
    pub symmetry: Vec<Vec<String>>,
    /// The order of the symmetry group (1: none).
    pub group: usize,
    /// Partial-order reduction (stubborn sets) ran.
    pub partial_order: bool,
    /// States were kept without the orders the player cannot tell apart
    /// (a timer's start order beside timers of other steps, the issue order
    /// of pending calls): on for a team whenever a reduction is asked for,
    /// since the others need it.
    pub order_free: bool,
    /// Why a reduction asked for did not run.
    pub notes: Vec<String>,
    /// States of the same project explored without reduction, when asked
    /// ([`super::project::Options::compare_unreduced`]).
    pub unreduced_states: Option<usize>,
}

/// A shared resource held by several vehicles at once, and a shortest
/// sequence of steps there (each names its vehicle: `at_gate@R1`, a timer
/// of `MOVE@R2`…).
#[derive(Debug, Clone, PartialEq)]
pub struct Exclusion {
    pub resource: String,
    pub vehicles: Vec<String>,
    pub example: Vec<String>,
}

impl Report {
    /// Whether every property holds (warnings and loops aside).
    pub fn holds(&self) -> bool {
        self.safe
            && self.dead_markings == 0
            && self.livelocks.is_empty()
            && self.complete
            && self.exclusion.is_empty()
    }
}

/// The whole project's report, each net's in its project, and each net's
/// alone.
#[derive(Debug, Clone, PartialEq)]
pub struct ProjectReport {
    pub project: Report,
    /// Each net in its project, in project order.
    pub nets: Vec<(String, Report)>,
    /// Each net alone (same order as `nets`): information and warnings,
    /// never part of [`ProjectReport::holds`].
    pub alone: Vec<Report>,
}

impl ProjectReport {
    /// Whether every property holds at the project level (the whole
    /// project and each net in it); a net's verdict alone does not count.
    pub fn holds(&self) -> bool {
        self.project.holds() && self.nets.iter().all(|(_, r)| r.holds())
    }
}
