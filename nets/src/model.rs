//! The compiled form of a project: what the loader produces and the player
//! and verifier read. Names are resolved to indices; nothing here is
//! mutable at run time.

use std::collections::{BTreeMap, HashMap};

use crate::event::Category;
use crate::expr::Expr;
use crate::time::Micros;

/// Index of a net in [`Project::nets`] (project.toml order).
pub type NetId = usize;
/// Index of a transition within its net (file order).
pub type TransitionId = usize;
/// Index of a vehicle in [`Project::vehicles`] (project.toml order).
pub type VehicleId = usize;

/// The separator of a vehicle qualification: `engine_failure@R2`,
/// `MOVE@R1`.
pub const VEHICLE_MARK: char = '@';

/// Splits a vehicle-qualified name (`engine_failure@R2`) into its base and
/// vehicle; an unqualified name has no vehicle. Global places are written
/// with a leading `@` (`@bottleneck`): that is not a qualification.
pub fn split_vehicle(name: &str) -> (&str, Option<&str>) {
    match name.rsplit_once(VEHICLE_MARK) {
        Some((base, vehicle)) if !base.is_empty() => (base, Some(vehicle)),
        _ => (name, None),
    }
}

/// `NAME@VEHICLE`.
pub fn qualify(name: &str, vehicle: &str) -> String {
    format!("{name}{VEHICLE_MARK}{vehicle}")
}

/// A place an arc touches: one of the net's own, or a global place.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum PlaceRef {
    Local(usize),
    Global(usize),
}

/// A whole project.
#[derive(Debug, Clone)]
pub struct Project {
    pub name: String,
    pub description: String,
    pub nets: Vec<Net>,
    pub globals: Vec<Global>,
    pub programs: Vec<Program>,
    /// Declared events: category and parameters.
    pub events: BTreeMap<String, EventDecl>,
    /// Limits on one input's run to completion.
    pub limits: Limits,
    /// Event name → the transitions it triggers, in the order the player
    /// tries them: declaration order (nets in project order, transitions in
    /// file order), except that a transition comes after the siblings that
    /// outrank it (see [`Choice`]).
    pub triggers: HashMap<String, Vec<(NetId, TransitionId)>>,
    /// Flat place numbering: globals first, then each net's places.
    pub place_offsets: Vec<usize>,
    pub place_count: usize,
    /// The team (`[[vehicle]]` in project.toml); empty for a project that
    /// supervises one implicit vehicle.
    pub vehicles: Vec<Vehicle>,
    /// The shared resources whose mutual exclusion is declared
    /// (`[[exclusive]]`).
    pub exclusive: Vec<Exclusive>,
    /// How the state of a running earlier version maps onto this one
    /// (`[reload]`; [`crate::version`]).
    pub reload: Reload,
}

/// `[reload]` in project.toml: what a running earlier version's places
/// and timers are called in this one. Names are `NET.name` (a global place:
/// its name alone); a name not mapped keeps its name.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Reload {
    /// Old place → new place.
    pub places: BTreeMap<String, String>,
    /// Old timer → new timer (of the same net or another).
    pub timers: BTreeMap<String, String>,
    /// `lockout = "kept"`: this version keeps the catastrophic lockout's
    /// nets unchanged, so it may take over during the lockout (checked
    /// when it swaps: [`crate::version::map`]).
    pub lockout_kept: bool,
}

/// One vehicle of the team.
#[derive(Debug, Clone, PartialEq)]
pub struct Vehicle {
    pub name: String,
    /// Its MAVLink system id.
    pub system: u8,
    /// Its MAVLink component id (1, the autopilot, unless declared).
    pub component: u8,
    /// Its elaboration profile, as written: the gateway interprets it.
    pub profile: Option<String>,
    /// Its link, as written: the gateway interprets it.
    pub link: Option<String>,
}

/// A shared resource: places of vehicle instances that must never hold
/// tokens of two different vehicles at once.
#[derive(Debug, Clone, PartialEq)]
pub struct Exclusive {
    pub name: String,
    /// The places as declared (`TEMPLATE.place`).
    pub places: Vec<String>,
    /// For each vehicle holding some: the flat indices of its instances'
    /// places in the resource.
    pub held: Vec<(VehicleId, Vec<usize>)>,
}

impl Exclusive {
    /// The vehicles holding the resource in a marking (`marked(flat)`), in
    /// vehicle order: more than one is a violation.
    pub fn holders(&self, marked: impl Fn(usize) -> bool) -> Vec<VehicleId> {
        self.held
            .iter()
            .filter(|(_, places)| places.iter().any(|&p| marked(p)))
            .map(|(v, _)| *v)
            .collect()
    }
}

/// A global place, declared in project.toml and shared by every net.
#[derive(Debug, Clone)]
pub struct Global {
    pub name: String,
    pub initial: bool,
}

/// One net.
#[derive(Debug, Clone)]
pub struct Net {
    /// Its name: the file's `name`, and for an instance of a template
    /// `NAME@VEHICLE`.
    pub name: String,
    /// For an instance of a template: its vehicle. `None` for a team net
    /// (or in a project without vehicles).
    pub vehicle: Option<VehicleId>,
    /// The file it came from, relative to the project folder.
    pub file: String,
    pub places: Vec<Place>,
    pub transitions: Vec<Transition>,
    /// Whether the net is active when the project starts.
    pub active_at_start: bool,
    /// Timer names this net starts (its timer namespace). Each question the
    /// net asks has one too, `NAME.timeout`.
    pub timers: Vec<String>,
    /// The questions this net asks the operator, by name.
    pub asks: Vec<Ask>,
    /// Indices of its immediate transitions, in file order.
    pub immediate: Vec<TransitionId>,
}

/// A question a net asks the operator (`ask NAME "QUESTION" {choices: [..]}
/// timeout DURATION`). Its answer is the event `NAME.CHOICE {choice}`, its
/// timeout `NAME.timeout`, both delivered to the asking net only.
#[derive(Debug, Clone, PartialEq)]
pub struct Ask {
    pub name: String,
    pub choices: Vec<String>,
    /// Index of `NAME.timeout` in the net's timers.
    pub timer: usize,
}

impl Ask {
    /// The event an answer delivers: `NAME.CHOICE`.
    pub fn answer_event(&self, choice: &str) -> String {
        format!("{}.{choice}", self.name)
    }
}

/// The suffix of an ask's timeout event.
pub const ASK_TIMEOUT: &str = "timeout";

/// A place of a net.
#[derive(Debug, Clone)]
pub struct Place {
    pub name: String,
    /// Marked in the net's initial marking.
    pub initial: bool,
    /// Declared final: a marking that holds it is not a deadlock.
    pub is_final: bool,
}

/// A transition.
#[derive(Debug, Clone)]
pub struct Transition {
    pub name: String,
    pub inputs: Vec<PlaceRef>,
    pub outputs: Vec<PlaceRef>,
    /// The triggering event; `None` for an immediate transition.
    pub event: Option<String>,
    pub guard: Option<Guard>,
    pub actions: Vec<Action>,
    /// The actions as written in the net file (same order as `actions`).
    pub action_source: Vec<String>,
    /// Flat place indices (see [`Project::place_offsets`]).
    pub flat_inputs: Vec<usize>,
    pub flat_outputs: Vec<usize>,
    /// Its rank in a choice with its siblings: the transitions waiting for
    /// the same event that share an input place with it.
    pub choice: Choice,
}

/// How a transition ranks among its siblings (the transitions waiting for
/// the same event that share an input place with it): the player tries a
/// higher rank first, equal ranks in declaration order, and `petrel check`
/// takes two siblings of different ranks for an intended choice.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Choice {
    /// No declaration: priority 0.
    #[default]
    Ordinary,
    /// `priority = N`: tried before its siblings of lower priority.
    Priority(i64),
    /// `else = true`: tried after all its siblings, so it takes the event
    /// only when none of them does.
    Else,
}

impl Choice {
    /// Higher is tried first.
    pub fn rank(self) -> (bool, i64) {
        match self {
            Choice::Ordinary => (true, 0),
            Choice::Priority(p) => (true, p),
            Choice::Else => (false, 0),
        }
    }
}

impl Transition {
    /// Whether `other` waits for the same event and shares an input place.
    pub fn sibling_of(&self, other: &Transition) -> bool {
        self.event.is_some()
            && self.event == other.event
            && self
                .flat_inputs
                .iter()
                .any(|p| other.flat_inputs.contains(p))
    }
}

/// A guard and its source text.
#[derive(Debug, Clone)]
pub struct Guard {
    pub text: String,
    pub expr: Expr,
}

/// An action of a transition, run in order when it fires.
#[derive(Debug, Clone)]
pub enum Action {
    Activate(NetId),
    Deactivate(NetId),
    Emit {
        event: String,
        args: Args,
    },
    Timer {
        timer: usize,
        after: Micros,
    },
    Cancel {
        timer: usize,
    },
    Call {
        program: usize,
        function: usize,
        args: Args,
    },
    Command {
        verb: String,
        args: Args,
        /// The vehicle commanded: an instance's own, or the one a team net
        /// names (`command rtl @R2`); `None` in a project without vehicles.
        vehicle: Option<VehicleId>,
    },
    /// Ask the operator question `ask` of the net (index into
    /// [`Net::asks`]), with `question` shown, answered within `after`.
    Ask {
        ask: usize,
        question: String,
        after: Micros,
    },
}

/// Named arguments: literal values or the triggering event's parameters.
pub type Args = Vec<(String, Expr)>;

/// A software program and the functions the nets may call.
#[derive(Debug, Clone)]
pub struct Program {
    pub name: String,
    pub functions: Vec<Function>,
    /// The program's other settings in project.toml (how the gateway starts
    /// or reaches it); the nets crate does not read them.
    pub settings: std::collections::BTreeMap<String, toml::Value>,
}

/// A function a program serves.
#[derive(Debug, Clone)]
pub struct Function {
    pub name: String,
    pub args: Vec<String>,
    /// Parameters of its `PROGRAM.FUNCTION.done` event.
    pub returns: Vec<String>,
}

/// What the project says of an event.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EventDecl {
    pub category: Option<Category>,
    /// Its parameters, when declared.
    pub params: Option<Vec<String>>,
}

/// Bounds that turn a runaway into a reported fault.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Firings (of immediate transitions) after one handled event.
    pub firings_per_step: usize,
    /// Events handled in one run to completion; also timer expiries at
    /// one instant.
    pub steps_per_input: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            firings_per_step: 1000,
            steps_per_input: 1000,
        }
    }
}

/// Names of the events the player itself produces.
pub mod names {
    /// Emitted when a firing is rejected (double token, bad argument).
    pub const NET_FAULT: &str = "net_fault";
    pub const COMMAND_OK: &str = "command.ok";
    pub const COMMAND_FAILED: &str = "command.failed";
    pub const DONE: &str = "done";
    pub const FAILED: &str = "failed";
}

impl Project {
    /// The net of that name.
    pub fn net(&self, name: &str) -> Option<NetId> {
        self.nets.iter().position(|n| n.name == name)
    }

    /// The flat index of a place of a net.
    pub fn flat(&self, net: NetId, place: PlaceRef) -> usize {
        match place {
            PlaceRef::Global(g) => g,
            PlaceRef::Local(p) => self.place_offsets[net] + p,
        }
    }

    /// A place's name as written in a net file (`@name` for a global).
    pub fn place_name(&self, net: NetId, place: PlaceRef) -> String {
        match place {
            PlaceRef::Global(g) => format!("@{}", self.globals[g].name),
            PlaceRef::Local(p) => self.nets[net].places[p].name.clone(),
        }
    }

    /// The category the project gives an event, if it declares one. A
    /// vehicle's event (`engine_failure@R2`) has its base event's.
    pub fn declared_category(&self, event: &str) -> Option<Category> {
        self.events
            .get(event)
            .or_else(|| self.events.get(self.vehicle_event(event)?.0))
            .and_then(|d| d.category)
    }

    /// The vehicle named so.
    pub fn vehicle(&self, name: &str) -> Option<VehicleId> {
        self.vehicles.iter().position(|v| v.name == name)
    }

    /// A vehicle's event `BASE@VEHICLE` of a vehicle of the team: its base
    /// and vehicle.
    pub fn vehicle_event<'a>(&self, event: &'a str) -> Option<(&'a str, VehicleId)> {
        match split_vehicle(event) {
            (base, Some(v)) => Some((base, self.vehicle(v)?)),
            _ => None,
        }
    }

    /// The parameters an event is known to carry, if known.
    pub fn event_params(&self, event: &str) -> Option<Vec<String>> {
        if let Some(params) = self.events.get(event).and_then(|d| d.params.clone()) {
            return Some(params);
        }
        if let Some((base, _)) = self.vehicle_event(event) {
            return self.event_params(base);
        }
        match event {
            names::COMMAND_OK => return Some(vec!["verb".into()]),
            names::COMMAND_FAILED => return Some(vec!["reason".into(), "verb".into()]),
            names::NET_FAULT => {
                return Some(vec![
                    "net".into(),
                    "place".into(),
                    "reason".into(),
                    "transition".into(),
                ])
            }
            _ => {}
        }
        let (head, outcome) = event.rsplit_once('.')?;
        let (program, function) = head.split_once('.')?;
        let function = self
            .programs
            .iter()
            .find(|p| p.name == program)?
            .functions
            .iter()
            .find(|f| f.name == function)?;
        match outcome {
            names::DONE => Some(function.returns.clone()),
            names::FAILED => Some(vec!["reason".into()]),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_qualification_is_the_last_at_after_a_name() {
        assert_eq!(
            split_vehicle("engine_failure@R2"),
            ("engine_failure", Some("R2"))
        );
        assert_eq!(split_vehicle("DEC.replan.done"), ("DEC.replan.done", None));
        // A global place is written `@name`: not a qualification.
        assert_eq!(split_vehicle("@bottleneck"), ("@bottleneck", None));
        assert_eq!(qualify("MOVE", "R1"), "MOVE@R1");
    }
}
