//! The project-level verifier: explores what the *player* can reach, not a
//! translation of the nets into a plain token game.
//!
//! A state is what the player holds between two inputs (markings, active
//! nets, running timers, pending calls and commands, the lockout), with time
//! abstracted away: timers keep their duration and the step that started
//! them, ids are renumbered. A step is one input run to completion by the
//! same code that flies ([`crate::Player`]):
//!
//! - an external event (any event a net waits for that the nets do not only
//!   produce themselves), in any state;
//! - the expiry of a running timer — timers started in the same step expire
//!   in the order their durations fix, others in any order;
//! - the result of a pending call or command: done, or failed with each
//!   reason the guards awaiting the failure tell apart (every string they
//!   compare `reason` with, and one they do not);
//! - the operator's answer to a pending question, with each choice it
//!   offers (its timeout is its timer's expiry, above);
//!
//! Each net gets two verdicts of its own. The first is read off the same
//! exploration: the net *in its project*, under what the other nets really
//! do. Its states are its own markings (and whether it is active); it is
//! dead in a state where it is active, holds no final place and can never
//! fire again, even if other nets still can; it is unsafe if one of its
//! transitions attempts a double token. The second is the net *alone* (the
//! single-procedure level, [`super::alone`]): the same explorer on a copy of
//! the project where the other nets are absent and the events they emit may
//! come at any time; its figures are counted the same way. The project level
//! is authoritative: a violation found alone only is a warning (the net
//! relies on the other nets), one found in the project too is an error.
//!
//! Guards on parameters the verifier does not know are answered both ways
//! through the player's [`Oracle`]; guards it can evaluate (a command
//! result's `verb`, a failure's `reason` among the values above) are
//! evaluated. An action argument that reads a parameter of the external
//! event asks whether the event carries it: absent, the firing is rejected
//! as in flight (and a fallback declared after it takes the event); present,
//! the argument is left out. The answers agree within the step (see
//! [`Oracle`]); answer sequences that end alike (same state, same firings,
//! same faults) make one edge.
//!
//! Events take the category the project declares (with the elaboration
//! profile's catalog when the caller loaded it: `petrel check` does, as
//! `petrel run`), which decides priorities and the catastrophic lockout.

use std::collections::{BTreeSet, HashMap, HashSet, VecDeque};
use std::sync::{Arc, Mutex};

use super::graph::{self, Csr};
use super::levels;
pub use super::levels::Proviso;
use super::project_states::{Abs, Codec, Scratch};
pub use super::project_steps::Steps;
use super::project_steps::{Capture, Entry, Kept, Parts, Step};
use super::project_warnings::emitted_events;
pub use super::project_warnings::{static_warnings, token_game, Warning};
use super::stubborn::{Class, Stubborn};
use super::symmetry::Symmetry;
use crate::event::Event;
use crate::model::{names, Action, NetId, Project, TransitionId};
use crate::player::{Effect, Fault, Oracle, Outcome, PendingKind, Player, Question, State};
use crate::time::Micros;
use crate::value::Params;

/// The most states a check stores by default (the player's states take
/// about a kilobyte each). `petrel check` and `petrel run`'s own check
/// share it, so that `run` never refuses what `check` proves.
pub const MAX_STATES: usize = 1_000_000;

/// Limits of a check.
#[derive(Clone, Copy)]
pub struct Options<'a> {
    /// Stop exploring past this many states (the report says so).
    pub max_states: usize,
    /// Give each net its own verdict in its project as well as the whole
    /// project's.
    pub each_net: bool,
    /// With `each_net`, also explore each net alone (information and
    /// warnings only: `petrel run`, which needs only [`ProjectReport::holds`],
    /// leaves it out).
    pub alone: bool,
    /// Called now and then with the number of states explored so far.
    pub progress: Option<&'a dyn Fn(usize)>,
    /// Threads exploring (at least one); the report is the same whatever
    /// their number.
    pub threads: usize,
    /// Explore one representative per orbit of the team's symmetry group
    /// (vehicles the compiled project treats alike; see
    /// [`super::symmetry`]). No effect without interchangeable vehicles.
    pub symmetry: bool,
    /// Explore stubborn sets of inputs instead of every input (partial-order
    /// reduction, [`super::stubborn`]); teams only: a project without
    /// vehicles is explored whole, its figures unchanged.
    pub partial_order: bool,
    /// Also explore the whole project without reduction, for the
    /// unreduced number of states ([`Reduction::unreduced_states`]).
    pub compare_unreduced: bool,
    /// How a partial-order reduction keeps an input from being put off
    /// for ever around a cycle of reduced states (no effect without
    /// `partial_order`).
    pub proviso: Proviso,
    /// Whether a step's outcome is reused for states that differ only in
    /// orders the player cannot read (see [`Steps`]); the report is the
    /// same either way.
    pub steps: Steps,
}

impl Default for Options<'_> {
    fn default() -> Self {
        Options {
            max_states: MAX_STATES,
            each_net: true,
            alone: true,
            progress: None,
            threads: 1,
            symmetry: true,
            partial_order: true,
            compare_unreduced: false,
            proviso: Proviso::default(),
            steps: Steps::default(),
        }
    }
}

/// States explored between two calls of [`Options::progress`].
const PROGRESS_EVERY: usize = 256;

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
    /// ([`Options::compare_unreduced`]).
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

/// Checks a project as a whole and, if asked, each net in it and alone.
pub fn check(project: &Arc<Project>, options: &Options) -> ProjectReport {
    let (explored, reduction) = explore_reduced(project, options);
    // The whole project's verdict, then each net's (on the threads asked
    // for: each verdict reads the exploration only).
    let scopes: Vec<Option<NetId>> = if options.each_net {
        std::iter::once(None)
            .chain((0..project.nets.len()).map(Some))
            .collect()
    } else {
        vec![None]
    };
    let mut verdicts = verdicts(&explored, &scopes, options.threads).into_iter();
    let mut whole = verdicts
        .next()
        .unwrap_or_else(|| explored.verdict(None, true));
    whole.reduction = reduction;
    let mut walker = explored.partial_order.then(|| Walker::new(project));
    if let Some(walker) = &mut walker {
        walker.shorten_report(project, &mut whole);
    }
    if options.compare_unreduced && (whole.reduction.group > 1 || whole.reduction.partial_order) {
        let plain = Explorer::new(project.clone(), false, false, options.steps).run(
            options.max_states,
            options.threads,
            options.proviso,
            None,
        );
        whole.reduction.unreduced_states = Some(plain.space.store.len());
    } else if options.compare_unreduced {
        whole.reduction.unreduced_states = Some(whole.states);
    }
    if !options.each_net {
        return ProjectReport {
            project: whole,
            nets: Vec::new(),
            alone: Vec::new(),
        };
    }
    let mut nets: Vec<(String, Report)> = (0..project.nets.len())
        .map(|n| {
            let mut r = verdicts
                .next()
                .unwrap_or_else(|| explored.verdict(Some(n), true));
            if let Some(walker) = &mut walker {
                walker.shorten_report(project, &mut r);
            }
            (project.nets[n].name.clone(), r)
        })
        .collect();
    if !options.alone {
        return ProjectReport {
            project: whole,
            nets,
            alone: Vec::new(),
        };
    }
    // The progress meter keeps counting through the nets alone.
    let mut done = explored.space.store.len();
    drop(explored);
    let mut alone = Vec::with_capacity(nets.len());
    for (n, (name, in_project)) in nets.iter_mut().enumerate() {
        let copy = Arc::new(super::alone::project_alone(project, n));
        let offset = done;
        let progress = |k: usize| {
            if let Some(report) = options.progress {
                report(offset + k);
            }
        };
        let explored = Explorer::new(copy, options.symmetry, options.partial_order, options.steps)
            .run(
                options.max_states,
                options.threads,
                options.proviso,
                options.progress.map(|_| &progress as &dyn Fn(usize)),
            );
        let explored = match explored.symmetry_broken() {
            // The copy's symmetry does not hold for the player: whole.
            Some(_) => Explorer::new(
                explored.project.clone(),
                false,
                options.partial_order,
                options.steps,
            )
            .run(options.max_states, options.threads, options.proviso, None),
            None => explored,
        };
        done += explored.space.store.len();
        // Static warnings of the copy (events the absent nets emit look
        // produced by nothing) say nothing of the net: left out.
        let a = explored.verdict(Some(n), false);
        for w in super::alone::relies(name, &a, in_project) {
            in_project.warnings.push(w.clone());
            whole.warnings.push(w);
        }
        alone.push(a);
    }
    ProjectReport {
        project: whole,
        nets,
        alone,
    }
}

/// The verdicts of `explored` for each of `scopes` (see
/// [`Explored::verdict`]), in order, worked out on up to `threads` threads.
fn verdicts(explored: &Explored, scopes: &[Option<NetId>], threads: usize) -> Vec<Report> {
    let threads = threads.clamp(1, scopes.len().max(1));
    if threads == 1 {
        return scopes.iter().map(|&s| explored.verdict(s, true)).collect();
    }
    let next = std::sync::atomic::AtomicUsize::new(0);
    let done: Mutex<Vec<(usize, Report)>> = Mutex::new(Vec::with_capacity(scopes.len()));
    std::thread::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(&s) = scopes.get(i) else { break };
                let report = explored.verdict(s, true);
                if let Ok(mut d) = done.lock() {
                    d.push((i, report));
                }
            });
        }
    });
    let mut done = done.into_inner().unwrap_or_else(|e| e.into_inner());
    done.sort_by_key(|(i, _)| *i);
    done.into_iter().map(|(_, r)| r).collect()
}

/// Replays a counterexample (the texts of its steps, as a report gives
/// them) on the unreduced explorer, from the initial state: each step must
/// be one the player really takes from a state the previous steps reach.
/// Returns the marked flat places of each state the whole sequence reaches,
/// or the first step that does not replay.
pub fn replay(project: &Arc<Project>, steps: &[String]) -> Result<Vec<Vec<usize>>, String> {
    let mut walker = Walker::new(project);
    let frontier = walker.walk(steps)?;
    Ok(frontier
        .iter()
        .map(|key| {
            (0..project.place_count)
                .filter(|&p| walker.explorer.codec.marked(key, p))
                .collect()
        })
        .collect())
}

/// Walks sequences of step texts on the unreduced explorer.
struct Walker {
    explorer: Explorer,
    worker: Worker,
    initial: Vec<u8>,
}

impl Walker {
    fn new(project: &Arc<Project>) -> Walker {
        let explorer = Explorer::new(project.clone(), false, false, Steps::Run);
        let mut player = Player::start(project.clone(), T);
        player.set_oracle(Some(Oracle::default()));
        let mut initial = Vec::new();
        explorer.codec.encode(
            player.state(),
            0,
            T,
            None,
            &|_, p| explorer.relevant(p),
            &mut Scratch::default(),
            &mut initial,
        );
        let worker = levels::Explore::worker(&explorer);
        Walker {
            explorer,
            worker,
            initial,
        }
    }

    /// The keys of the states `steps` reach from the initial state, or the
    /// first step that does not replay.
    fn walk(&mut self, steps: &[String]) -> Result<Vec<Vec<u8>>, String> {
        let mut frontier: Vec<Vec<u8>> = vec![self.initial.clone()];
        for (i, step) in steps.iter().enumerate() {
            let mut next: Vec<Vec<u8>> = Vec::new();
            for key in &frontier {
                for (local, target) in levels::expand_one(&self.explorer, &mut self.worker, key) {
                    if self.explorer.label_text(local) == *step && !next.contains(&target) {
                        next.push(target);
                    }
                }
            }
            if next.is_empty() {
                return Err(format!("step {} does not replay: {step}", i + 1));
            }
            frontier = next;
        }
        Ok(frontier)
    }

    /// `path` with steps left out, one at a time from the first, as long
    /// as what is left still replays and `keeps` its end states.
    fn shorten(&mut self, path: &mut Vec<String>, keeps: &dyn Fn(&Codec, &[Vec<u8>]) -> bool) {
        if path.len() > MAX_SHORTENED {
            return;
        }
        let mut i = 0;
        while i < path.len() {
            let mut shorter = path.clone();
            shorter.remove(i);
            match self.walk(&shorter) {
                Ok(ends) if keeps(&self.explorer.codec, &ends) => *path = shorter,
                _ => i += 1,
            }
        }
    }

    /// A report's examples shortened (a reduced search may take
    /// independent steps first): each still replays and shows the same
    /// violation — the same dead state, the same last step, two holders of
    /// the same resource.
    fn shorten_report(&mut self, project: &Project, r: &mut Report) {
        if let Some(path) = &mut r.deadlock_example {
            if let Ok(dead) = self.walk(path) {
                self.shorten(path, &|_, ends| ends.iter().any(|e| dead.contains(e)));
            }
        }
        let replays = |_: &Codec, _: &[Vec<u8>]| true;
        if let Some(path) = &mut r.unsafe_example {
            self.shorten(path, &replays);
        }
        for path in &mut r.livelocks {
            self.shorten(path, &replays);
        }
        for x in &mut r.exclusion {
            let Some(resource) = project.exclusive.iter().find(|e| e.name == x.resource) else {
                continue;
            };
            self.shorten(&mut x.example, &|codec, ends| {
                ends.iter()
                    .any(|e| resource.holders(|p| codec.marked(e, p)).len() > 1)
            });
        }
    }
}

/// The longest example [`Walker::shorten`] tries to shorten (each try
/// replays the whole example).
const MAX_SHORTENED: usize = 64;

/// The dead states of the whole project's exploration with `options`
/// (with symmetry, one per orbit), each as its marked flat places: what
/// [`Report::dead_markings`] counts.
pub fn dead_markings(project: &Arc<Project>, options: &Options) -> Vec<Vec<usize>> {
    let (explored, _) = explore_reduced(project, options);
    let n = explored.space.store.len();
    let labels = &explored.labels;
    let mut live = vec![false; n];
    let mut queue = VecDeque::new();
    for s in 0..n as u32 {
        if explored
            .space
            .graph
            .edges(s)
            .any(|(l, _)| labels[*l as usize].fires(None))
        {
            live[s as usize] = true;
            queue.push_back(s);
        }
    }
    while let Some(s) = queue.pop_front() {
        for (_, p) in explored.reverse.edges(s) {
            if !live[p as usize] {
                live[p as usize] = true;
                queue.push_back(p);
            }
        }
    }
    let finals: Vec<usize> = project
        .nets
        .iter()
        .enumerate()
        .flat_map(|(ni, nt)| {
            let offset = project.place_offsets[ni];
            nt.places
                .iter()
                .enumerate()
                .filter(|(_, p)| p.is_final)
                .map(move |(i, _)| offset + i)
        })
        .collect();
    let codec = &explored.codec;
    (0..n as u32)
        .filter(|&s| {
            let key = explored.space.store.get(s);
            !live[s as usize] && !finals.iter().any(|&p| codec.marked(key, p))
        })
        .map(|s| {
            let key = explored.space.store.get(s);
            (0..project.place_count)
                .filter(|&p| codec.marked(key, p))
                .collect()
        })
        .collect()
}

/// Explores `project` with the reductions `options` asks for; when the
/// player breaks the symmetry the model has, explores again without it.
fn explore_reduced(project: &Arc<Project>, options: &Options) -> (Explored, Reduction) {
    let explored = Explorer::new(
        project.clone(),
        options.symmetry,
        options.partial_order,
        options.steps,
    )
    .run(
        options.max_states,
        options.threads,
        options.proviso,
        options.progress,
    );
    let mut notes = Vec::new();
    let explored = match explored.symmetry_broken() {
        Some(why) => {
            notes.push(format!(
                "symmetry not used: the player's order of vehicles decides a step ({why})"
            ));
            Explorer::new(project.clone(), false, options.partial_order, options.steps).run(
                options.max_states,
                options.threads,
                options.proviso,
                options.progress,
            )
        }
        None => explored,
    };
    let reduction = Reduction {
        symmetry: explored.symmetry.as_ref().map_or_else(Vec::new, |sym| {
            sym.classes
                .iter()
                .map(|c| {
                    c.iter()
                        .map(|&v| project.vehicles[v].name.clone())
                        .collect()
                })
                .collect()
        }),
        group: explored.symmetry.as_ref().map_or(1, |sym| sym.perms.len()),
        partial_order: explored.partial_order,
        order_free: explored.codec.order_free(),
        notes,
        unreduced_states: None,
    };
    (explored, reduction)
}

/// Explores `project` (without reductions) running the player for every
/// step, and working out besides what reusing the outcomes kept for states
/// with the same projection gives ([`Steps::Compare`]): the number of
/// states compared, or the first difference found.
pub fn compare_steps(project: &Arc<Project>, threads: usize) -> Result<usize, String> {
    let explored = Explorer::new(project.clone(), false, false, Steps::Compare).run(
        MAX_STATES,
        threads,
        Proviso::default(),
        None,
    );
    match explored.compared {
        (n, None) => Ok(n),
        (_, Some(difference)) => Err(difference),
    }
}

/// Loops listed in a report, at most (the same loop seen from different
/// states is listed once).
const MAX_LOOPS: usize = 20;

/// The parameter a failed call or command carries its reason in.
const REASON: &str = "reason";

/// The instant every step runs at (any fixed value would do).
const T: Micros = 1_000_000_000;

#[derive(Debug, Clone)]
enum Input {
    /// An external event: its index in [`Explorer::externals`].
    Event(usize),
    Timer(usize),
    /// `reason`: `None` for done, otherwise the failure's reason (a
    /// question's choice): its index in what is known of the result
    /// ([`Explorer::known`]).
    Result {
        id: u64,
        reason: Option<usize>,
    },
}

/// What happened in one step.
#[derive(Debug, Clone)]
struct Label {
    text: String,
    fired: Vec<(NetId, TransitionId)>,
    /// The nets numbered below 64 among `fired`, as bits (what
    /// [`Label::fires`] reads for them).
    fired_nets: u64,
    /// The net whose transition attempted a double token.
    unsafe_by: Option<NetId>,
    /// The livelock's net (the transition the bound stopped at), or `None`
    /// for an overflow of emitted events.
    livelock: Option<Option<NetId>>,
}

impl Label {
    fn new(
        text: String,
        fired: Vec<(NetId, TransitionId)>,
        unsafe_by: Option<NetId>,
        livelock: Option<Option<NetId>>,
    ) -> Label {
        let fired_nets = fired
            .iter()
            .filter(|(n, _)| *n < 64)
            .fold(0u64, |bits, (n, _)| bits | 1 << n);
        Label {
            text,
            fired,
            fired_nets,
            unsafe_by,
            livelock,
        }
    }

    fn fires(&self, net: Option<NetId>) -> bool {
        match net {
            None => !self.fired.is_empty(),
            Some(n) if n < 64 => self.fired_nets & 1 << n != 0,
            Some(n) => self.fired.iter().any(|(m, _)| *m == n),
        }
    }

    /// Whether two steps end alike (with the same target).
    fn alike(&self, other: &Label) -> bool {
        self.fired == other.fired
            && self.unsafe_by == other.unsafe_by
            && self.livelock == other.livelock
    }
}

/// An external event, ready to send, with what decides whether it can do
/// anything in a state.
struct External {
    event: Event,
    /// The transitions it triggers.
    waiting: Vec<(NetId, TransitionId)>,
    /// Its category is catastrophic (the lockout does not drop it).
    catastrophic: bool,
    /// Its vehicle (`EVENT@VEHICLE`), whose own lockout drops it.
    vehicle: Option<crate::model::VehicleId>,
}

/// How many ample sets a state tries (smallest first) before it is
/// expanded fully (see [`Explorer::successors`]).
const AMPLE_TRIES: usize = 4;

/// A hash map with a fast fixed hash (what it holds never comes from
/// outside a check).
type FastMap<K, V> = HashMap<K, V, foldhash::fast::FixedState>;

/// What is known of a pending result: whether it is relevant, and the
/// reasons its failure is explored with.
type Known = (bool, Vec<String>);

struct Explorer {
    project: Arc<Project>,
    codec: Codec,
    externals: Vec<External>,
    /// Per call (net, program, function) and command (net, verb) the
    /// project's actions make: what is known of its result; calls by net,
    /// then program, then function.
    calls: Vec<Vec<Vec<Option<Known>>>>,
    /// By verb, then net.
    commands: FastMap<String, Vec<(NetId, Known)>>,
    /// Per net, per question it asks.
    questions: Vec<Vec<Known>>,
    /// The search's labels, numbered in merge order, and their keys.
    labels: Mutex<LabelTable>,
    /// The team's symmetry, when it reduces and is asked for.
    symmetry: Option<Symmetry>,
    /// Stubborn sets, when asked for (teams only).
    stubborn: Option<Stubborn>,
    /// A step whose outcome the player's order of vehicles decided (the
    /// first found): the symmetry does not hold, the exploration stops.
    broken: Mutex<Option<String>>,
    /// How steps run: [`Steps::Run`] under symmetry or stubborn sets, and
    /// whenever the keys keep none of the orders a projection leaves out
    /// (a team's reduced exploration): reuse needs them.
    steps: Steps,
    /// With [`Steps::Compare`]: the states compared, and the first
    /// difference found.
    compared: Mutex<(usize, Option<String>)>,
    /// The steps' outcomes kept for reuse, for every worker.
    kept: Kept,
    /// Every label the workers made, by the number they give it.
    registry: Mutex<Registry>,
}

#[derive(Default)]
struct LabelTable {
    labels: Vec<Label>,
    index: HashMap<Vec<u8>, u32>,
}

/// Labels numbered as the workers make them (so that an outcome kept by
/// one worker names its label for all), with their keys; the search
/// numbers them again in merge order ([`LabelTable`]).
#[derive(Default)]
struct Registry {
    labels: Vec<(Vec<u8>, Label)>,
    index: FastMap<Vec<u8>, u32>,
}

/// One worker's buffers and labels (see [`levels::Explore`]).
struct Worker {
    /// The labels the worker made, by their number in the registry, and
    /// the numbers of their keys.
    labels: Vec<Option<Label>>,
    index: FastMap<Vec<u8>, u32>,
    /// The search's number of each label (by its registry number), once
    /// known.
    global: Vec<u32>,
    scratch: Scratch,
    next: Vec<u8>,
    label_key: Vec<u8>,
    /// The edges of the input being explored: label and target key.
    this_input: Vec<(u32, std::ops::Range<usize>)>,
    this_input_keys: Vec<u8>,
    /// The player every step of the worker runs in, and the state an
    /// input starts from.
    player: Option<Player>,
    concrete: Option<State>,
    /// `concrete` holds the pending calls of the state being expanded
    /// (set by its first input: the later ones skip comparing them).
    concrete_current: bool,
    /// Numbers the pending calls `concrete` holds: one more each time
    /// they change (see [`Player::reset_for_verifier`]).
    pending_number: u64,
    /// The answer sequences still to run for an input (ranges of
    /// `todo_bits`), the one running, and it padded to the questions asked.
    todo: Vec<std::ops::Range<usize>>,
    todo_bits: Vec<bool>,
    answers: Vec<bool>,
    used: Vec<bool>,
    /// The canonical key of a successor, and a buffer for its images.
    canon: Vec<u8>,
    image: Vec<u8>,
    /// The outcomes of the state being captured for reuse, the edges of
    /// the input being reused (outcome and target key), the state's key
    /// read, its projection and a buffer.
    capture: Capture,
    reused: Vec<(usize, std::ops::Range<usize>)>,
    parts: Parts,
    projection: Vec<u8>,
    entry: Vec<u8>,
    /// With [`Steps::Compare`]: the edges the player's runs gave.
    log: Vec<(u32, Vec<u8>)>,
}

/// An exploration, ready for verdicts.
struct Explored {
    project: Arc<Project>,
    codec: Codec,
    space: levels::Space,
    labels: Vec<Label>,
    /// Transitions fired at start-up or in a step.
    fired: HashSet<(NetId, TransitionId)>,
    /// Each state's predecessors.
    reverse: Csr<()>,
    symmetry: Option<Symmetry>,
    partial_order: bool,
    broken: Option<String>,
    /// With [`Steps::Compare`]: the states compared, and the first
    /// difference.
    compared: (usize, Option<String>),
    /// The warnings found without exploring that the exploration does not
    /// disprove, worked out for the first verdict that asks.
    statics: std::sync::OnceLock<Vec<Warning>>,
}

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
    fn new(project: Arc<Project>, symmetry: bool, partial_order: bool, steps: Steps) -> Explorer {
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
            kept: Kept::new(super::project_steps::BUDGET),
            registry: Mutex::new(Registry::default()),
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

    fn run(
        self,
        max_states: usize,
        threads: usize,
        proviso: Proviso,
        progress: Option<&dyn Fn(usize)>,
    ) -> Explored {
        let mut player = Player::start(self.project.clone(), T);
        player.set_oracle(Some(Oracle::default()));
        let effects: Vec<Effect> = player.effects().collect();
        let initial_fired = fired_of(&effects);
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
            super::project_steps::projection(key, &w.parts, &mut w.projection);
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
    fn label_text(&self, l: u32) -> String {
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
        Expr::Not(e) | Expr::Neg(e) => reason_literals(e, out),
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

/// Breadth-first searches allowed for listing loops, per report.
const LOOP_SEARCHES: usize = 500;

impl Explored {
    /// The step that showed the player breaking the symmetry, if one did
    /// (then the exploration stopped early and proves nothing).
    fn symmetry_broken(&self) -> Option<&str> {
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
    fn verdict(&self, net: Option<NetId>, statics: bool) -> Report {
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
        let finals_of = |scope: Option<NetId>| -> Vec<usize> {
            project
                .nets
                .iter()
                .enumerate()
                .filter(|(ni, _)| scope.is_none_or(|x| x == *ni))
                .flat_map(|(ni, nt)| {
                    let offset = project.place_offsets[ni];
                    nt.places
                        .iter()
                        .enumerate()
                        .filter(|(_, p)| p.is_final)
                        .map(move |(i, _)| offset + i)
                })
                .collect()
        };
        let finals: Vec<Vec<usize>> = orbit.iter().map(|m| finals_of(*m)).collect();
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

/// The predecessors of each of the `n` nodes of `g`.
fn reverse_of(g: &Csr<u32>, n: usize) -> Csr<()> {
    let mut reverse_edges: Vec<(u32, u32)> = Vec::with_capacity(g.edge_count());
    for s in 0..n as u32 {
        for (_, t) in g.edges(s) {
            reverse_edges.push((t, s));
        }
    }
    reverse_edges.sort_unstable();
    let mut reverse = Csr::default();
    let mut at = 0;
    for t in 0..n as u32 {
        let start = at;
        while at < reverse_edges.len() && reverse_edges[at].0 == t {
            at += 1;
        }
        reverse.push_node(reverse_edges[start..at].iter().map(|&(_, s)| ((), s)));
    }
    reverse
}

/// Events that may come from outside: every event a transition waits for,
/// except those only the nets and the player produce (see
/// [`crate::outside`]): a net's own timers, results, `net_fault`, and the
/// events the nets emit that the project does not declare. An event the
/// project declares in `[events]` is external even if a net emits it too.
fn external_events(project: &Project) -> Vec<String> {
    let mut out: BTreeSet<String> = BTreeSet::new();
    for (ni, net) in project.nets.iter().enumerate() {
        for t in &net.transitions {
            let Some(e) = &t.event else { continue };
            let internal = crate::outside::own_timer(project, ni, e)
                || crate::outside::refusal(project, e).is_some();
            if !internal {
                out.insert(e.clone());
            }
        }
    }
    out.into_iter().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The example the reuse of steps is measured on, without a profile.
    fn flight_test() -> Arc<Project> {
        let dir =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/uav-flight-test");
        let mut files = std::collections::BTreeMap::new();
        for entry in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            if name.ends_with(".toml") {
                let text = std::fs::read_to_string(entry.path()).unwrap_or_default();
                files.insert(name, text);
            }
        }
        Arc::new(crate::load(&files).unwrap_or_else(|e| panic!("{e}")))
    }

    #[test]
    fn past_the_budget_the_player_expands_new_projections_and_the_report_is_the_same() {
        let project = flight_test();
        let explore = |steps, budget| {
            let mut explorer = Explorer::new(project.clone(), false, false, steps);
            explorer.kept = Kept::new(budget);
            explorer.run(MAX_STATES, 1, Proviso::default(), None)
        };
        let run = explore(Steps::Run, 0);
        // A megabyte keeps the outcomes of a few hundred projections of
        // the 8,791 the example has.
        let small = explore(Steps::Reuse, 1 << 20);
        assert_eq!(small.space.store.len(), run.space.store.len());
        assert_eq!(small.verdict(None, true), run.verdict(None, true));
    }
}
