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
pub use super::project_report::{Exclusion, ProjectReport, Reduction, Report};
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

mod explorer;
mod verdict;

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

/// Checks `project` as a whole from `from`, a state of its player, instead
/// of from its start: what a running version's state mapped onto a new
/// version must pass before the new version takes over
/// ([`crate::version::swap`]). The state is explored as the check
/// explores the start (time abstracted, ids renumbered: a running timer
/// keeps the time it has left), without the team's symmetry (the state
/// need not be symmetric). `Err` when the state does not fit the project.
pub fn check_from(
    project: &Arc<Project>,
    from: &State,
    options: &Options,
) -> Result<Report, crate::player::RestoreError> {
    let mut start = from.clone();
    for timer in &mut start.timers {
        timer.deadline = timer.deadline.saturating_sub(start.now) + T;
    }
    start.now = T;
    let mut explorer = Explorer::new(project.clone(), false, options.partial_order, options.steps);
    explorer.from = Some(Player::restore(project.clone(), start)?);
    let explored = explorer.run(
        options.max_states,
        options.threads,
        options.proviso,
        options.progress,
    );
    let mut report = explored.verdict(None, true);
    report.reduction.partial_order = explored.partial_order;
    if explored.partial_order {
        Walker::new(project).shorten_report(project, &mut report);
    }
    Ok(report)
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
            in_project.relies.push(w.clone());
            whole.relies.push(w);
        }
        if let Some(w) = super::alone::incomplete(name, &a) {
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
        let (_, initial) = explorer.start();
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
    let finals = final_places(project, None);
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
    /// The player the exploration starts from instead of the project's
    /// start (a running version's state mapped onto this one), at [`T`].
    from: Option<Player>,
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

/// The final places of the project's nets (of `scope` alone, if given), as
/// indices among all places.
fn final_places(project: &Project, scope: Option<NetId>) -> Vec<usize> {
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
