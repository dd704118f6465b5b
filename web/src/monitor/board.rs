//! The board: what the page shows at one instant — each net's activity and
//! marking, the transitions enabled and how often each has fired, the
//! catastrophic lockout, the log (events with what they fired or why they
//! were dropped, commands, calls, results, faults, each with the vehicle it
//! is of in a team) and the vehicles. Fed the
//! supervisor's steps as the gateway (or a replay) makes them; it reads the
//! player's state and never calls into it.

use nets::value::params_json;
use std::collections::{HashMap, VecDeque};
use std::sync::Arc;

use nets::model::VehicleId;
use nets::{Effect, Event, Micros, Outcome, Player, Project};
use serde_json::{json, Value as Json};

use super::vehicle::Vehicles;
use petrel_core::supervisor::{Input, Step};

/// Requests (commands and calls) remembered to name their results; older
/// ones are forgotten first.
const REQUESTS: usize = 4096;
/// Track points kept by a live board.
const TRACK_LIVE: usize = 4000;

/// The marking part of the board: small, copied whole into the page's
/// frames and into a recording's index.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Marking {
    pub seq: u64,
    pub time: Micros,
    pub active: Vec<bool>,
    /// The flat marking bitset (the player's).
    pub marking: Vec<u64>,
    /// Enabled transitions, as flat transition indices.
    pub enabled: Vec<u32>,
    /// Firings so far, per flat transition index.
    pub fired: Vec<u32>,
    pub lockout: bool,
    /// The vehicles locked out one by one (a team's).
    pub locked: Vec<usize>,
}

impl Marking {
    pub fn marked(&self, flat: usize) -> bool {
        self.marking
            .get(flat / 64)
            .is_some_and(|w| w & (1 << (flat % 64)) != 0)
    }

    /// As the page reads it.
    pub fn json(&self, project: &Project, origin: Micros) -> Json {
        let marked: Vec<usize> = (0..project.place_count)
            .filter(|&p| self.marked(p))
            .collect();
        json!({
            "seq": self.seq,
            "time_us": self.time,
            "t": seconds(self.time, origin),
            "active": self.active,
            "marked": marked,
            "enabled": self.enabled,
            "fired": self.fired,
            "lockout": self.lockout,
            "locked": self
                .locked
                .iter()
                .filter_map(|&v| project.vehicles.get(v).map(|v| v.name.clone()))
                .collect::<Vec<_>>(),
        })
    }
}

pub fn seconds(time: Micros, origin: Micros) -> f64 {
    nets::time::seconds(time.saturating_sub(origin))
}

/// One line of the log, with its number (from 0, never reused).
#[derive(Debug, Clone)]
pub struct Entry {
    pub id: u64,
    pub time: Micros,
    /// The event's category (events only): the timeline marks it.
    pub category: Option<nets::Category>,
    pub json: Json,
}

/// The board.
pub struct Board {
    project: Arc<Project>,
    /// Transition offsets in the flat transition numbering, per net.
    offsets: Vec<usize>,
    pub origin: Micros,
    pub marking: Marking,
    /// Whether the last step changed the marking part.
    pub marking_changed: bool,
    log: VecDeque<Entry>,
    next_entry: u64,
    /// At most this many entries kept (`usize::MAX`: all, for a recording).
    log_cap: usize,
    /// Each request's name and the vehicle it is for.
    requests: HashMap<u64, (String, Option<VehicleId>)>,
    request_order: VecDeque<u64>,
    /// The vehicles' strips and tracks (a team's, or the one vehicle).
    pub vehicle: Vehicles,
    /// The mirror's panel (`petrel mirror` only).
    pub mirror: Option<super::mirror::Mirror>,
}

impl Board {
    /// A board showing `player`'s state (its start), times counted from `origin`.
    pub fn new(project: Arc<Project>, player: &Player, origin: Micros, log_cap: usize) -> Board {
        let mut offsets = Vec::with_capacity(project.nets.len());
        let mut n = 0;
        for net in &project.nets {
            offsets.push(n);
            n += net.transitions.len();
        }
        let mut board = Board {
            project: project.clone(),
            offsets,
            origin,
            marking: Marking {
                fired: vec![0; n],
                ..Marking::default()
            },
            marking_changed: true,
            log: VecDeque::new(),
            next_entry: 0,
            log_cap,
            requests: HashMap::new(),
            request_order: VecDeque::new(),
            vehicle: Vehicles::new(
                &project,
                if log_cap == usize::MAX {
                    usize::MAX
                } else {
                    TRACK_LIVE
                },
            ),
            mirror: None,
        };
        board.read_marking(player, origin);
        board
    }

    pub fn project(&self) -> &Arc<Project> {
        &self.project
    }

    /// The log entries kept, oldest first.
    pub fn log(&self) -> &VecDeque<Entry> {
        &self.log
    }

    /// The number the next entry will get.
    pub fn next_entry(&self) -> u64 {
        self.next_entry
    }

    /// The start's effects (step 0).
    pub fn start(&mut self, step: &Step, player: &Player) {
        self.effects(&step.effects, None);
        self.read_marking(player, step.time);
    }

    /// One step of the supervisor, `player` as it stands right after it.
    pub fn step(&mut self, input: &Input, step: &Step, player: &Player) {
        self.vehicle.begin();
        if let Input::Frame(bytes) = input {
            self.vehicle.frame(step.time, bytes);
        }
        self.played(input, step, player);
        self.vehicle.now = step.time;
    }

    /// One step of a player, logged and its marking read; the vehicle
    /// strip untouched (the mirror feeds it the ground's own frames).
    pub fn played(&mut self, input: &Input, step: &Step, player: &Player) {
        self.marking_changed = false;
        match input {
            Input::Frame(_) | Input::Tick => {}
            Input::Result { id, outcome } => {
                let request = self.requests.remove(id);
                let (done, detail) = match outcome {
                    Outcome::Done(p) => (true, params_json(p)),
                    Outcome::Failed(r) => (false, json!(r)),
                };
                if let (true, Some((of, vehicle))) = (done, &request) {
                    self.vehicle.answer(*vehicle, of, &detail);
                }
                let vehicle = self.vehicle_name(request.as_ref().and_then(|r| r.1));
                let of = request.map(|r| r.0);
                let i = Some(self.push(
                    step.time,
                    None,
                    json!({"kind": "result", "id": id, "of": of, "ok": done, "detail": detail,
                           "vehicle": vehicle, "fired": []}),
                ));
                self.attach(i, &step.effects);
            }
            Input::Event(event) => {
                let i = self.event(step.time, event, "program");
                self.attach(i, &step.effects);
            }
            Input::Answer { id, choice } => {
                let i = Some(self.push(
                    step.time,
                    None,
                    json!({"kind": "answer", "id": id, "choice": choice, "fired": []}),
                ));
                self.attach(i, &step.effects);
            }
            Input::Version(version) => {
                self.take_version(player.project().clone());
                self.push(
                    step.time,
                    None,
                    json!({"kind": "version", "number": version.number, "seq": step.seq,
                           "text": format!("version {} took over", version.number)}),
                );
                // The marking's bits are numbered anew.
                self.read_marking(player, step.time);
                self.marking_changed = true;
            }
        }
        if !matches!(
            input,
            Input::Result { .. } | Input::Event(_) | Input::Answer { .. }
        ) {
            self.effects(&step.effects, None);
        }
        for (e, effects) in &step.events {
            let i = self.event(e.time_us, &e.event, "vehicle");
            self.attach(i, effects);
        }
        let touched = !step.effects.is_empty() || !step.events.is_empty();
        if touched {
            self.read_marking(player, step.time);
        }
        self.marking.seq = step.seq;
        self.marking.time = step.time;
    }

    /// A line of the mirror's own on the log at the board's time (`kind`:
    /// `push`, what became of a version sent up).
    pub fn note(&mut self, kind: &str, text: &str) {
        let time = self.marking.time;
        self.push(time, None, json!({"kind": kind, "text": text}));
    }

    /// A new version of the project on the board: nets numbered anew,
    /// each transition's firings kept by its net's and its own name.
    fn take_version(&mut self, project: Arc<Project>) {
        let mut fired = HashMap::new();
        for (n, net) in self.project.nets.iter().enumerate() {
            for (t, tr) in net.transitions.iter().enumerate() {
                let count = self.marking.fired.get(self.offsets[n] + t).copied();
                fired.insert((net.name.as_str(), tr.name.as_str()), count.unwrap_or(0));
            }
        }
        let mut offsets = Vec::with_capacity(project.nets.len());
        let mut counts = Vec::new();
        for net in &project.nets {
            offsets.push(counts.len());
            for tr in &net.transitions {
                let count = fired.get(&(net.name.as_str(), tr.name.as_str()));
                counts.push(count.copied().unwrap_or(0));
            }
        }
        self.marking.fired = counts;
        self.offsets = offsets;
        self.project = project;
    }

    /// Shows `player` as it stands at `time` (the mirror's replica
    /// restored from a snapshot, or advanced provisionally).
    pub fn show(&mut self, player: &Player, time: Micros) {
        self.read_marking(player, time);
        self.marking.time = time;
    }

    fn event(&mut self, time: Micros, event: &Event, source: &str) -> Option<usize> {
        let category = self
            .project
            .declared_category(&event.name)
            .unwrap_or(event.category);
        let vehicle = self.event_vehicle(event);
        Some(self.push(
            time,
            Some(category),
            json!({"kind": "event", "name": event.name, "category": category.as_str(),
                   "params": params_json(&event.params), "source": source,
                   "vehicle": vehicle, "fired": [], "dropped": null}),
        ))
    }

    /// Effects caused by the entry at `entry` (its firings and drops noted
    /// on it), the others logged on their own.
    fn attach(&mut self, entry: Option<usize>, effects: &[Effect]) {
        self.effects(effects, entry);
    }

    fn effects(&mut self, effects: &[Effect], entry: Option<usize>) {
        let project = self.project.clone();
        for effect in effects {
            let time = effect.time();
            match effect {
                Effect::Fired {
                    net, transition, ..
                } => {
                    let flat = self.offsets[*net] + transition;
                    self.marking_changed = true;
                    if let Some(c) = self.marking.fired.get_mut(flat) {
                        *c = c.saturating_add(1);
                    }
                    let label = effect.fired_label(&project).unwrap_or_default();
                    match entry.and_then(|i| self.entry_mut(i)) {
                        Some(e) => {
                            if let Some(a) = e.json["fired"].as_array_mut() {
                                a.push(json!(label));
                            }
                        }
                        None => {
                            self.push(time, None, json!({"kind": "fired", "name": label}));
                        }
                    }
                }
                Effect::Dropped { event, reason, .. } => {
                    let reason = reason.as_str();
                    let same = entry
                        .and_then(|i| self.entry_mut(i))
                        .filter(|e| e.json["name"] == event.name.as_str());
                    match same {
                        Some(e) => e.json["dropped"] = json!(reason),
                        None => {
                            let category = project
                                .declared_category(&event.name)
                                .unwrap_or(event.category);
                            let vehicle = self.event_vehicle(event);
                            self.push(
                                time,
                                Some(category),
                                json!({"kind": "event", "name": event.name, "category": category.as_str(),
                                       "params": params_json(&event.params), "source": "nets",
                                       "vehicle": vehicle, "fired": [], "dropped": reason}),
                            );
                        }
                    }
                }
                Effect::Command {
                    id,
                    net,
                    verb,
                    args,
                    vehicle,
                    ..
                } => {
                    self.remember(*id, verb.clone(), *vehicle);
                    let name = self.vehicle_name(*vehicle);
                    self.push(
                        time,
                        None,
                        json!({"kind": "command", "id": id, "net": project.nets[*net].name,
                               "name": verb, "params": params_json(args), "vehicle": name}),
                    );
                }
                Effect::Call {
                    id,
                    net,
                    program,
                    function,
                    args,
                    vehicle,
                    ..
                } => {
                    let p = &project.programs[*program];
                    let name = format!("{}.{}", p.name, p.functions[*function].name);
                    self.remember(*id, name.clone(), *vehicle);
                    let vehicle = self.vehicle_name(*vehicle);
                    self.push(
                        time,
                        None,
                        json!({"kind": "call", "id": id, "net": project.nets[*net].name,
                               "name": name, "params": params_json(args), "vehicle": vehicle}),
                    );
                }
                Effect::Ask {
                    id,
                    net,
                    ask,
                    question,
                    choices,
                    deadline,
                    ..
                } => {
                    let n = &project.nets[*net];
                    let name = n.asks.get(*ask).map(|a| a.name.as_str()).unwrap_or("?");
                    let vehicle = self.vehicle_name(n.vehicle);
                    self.push(
                        time,
                        None,
                        json!({"kind": "question", "id": id, "net": n.name,
                               "name": format!("{}.{name}", n.name), "question": question,
                               "choices": choices, "deadline": *deadline as f64 / 1e6,
                               "vehicle": vehicle}),
                    );
                }
                Effect::Fault { .. }
                | Effect::Lockout { .. }
                | Effect::LateResult { .. }
                | Effect::AnswerRefused { .. }
                | Effect::Unanswered { .. } => {
                    let mut v = nets::player::effect_json(&project, effect);
                    let kind = v["effect"].as_str().unwrap_or("fault").to_owned();
                    v["kind"] = json!(kind);
                    v["text"] = json!(nets::player::effect_text(&project, effect));
                    self.push(time, None, v);
                }
                Effect::TimerExpired { net, timer, .. } => {
                    let net = &project.nets[*net];
                    self.push(
                        time,
                        None,
                        json!({"kind": "timer", "name": format!("{}.{}", net.name, net.timers[*timer])}),
                    );
                }
                Effect::Activated { net, .. } | Effect::Deactivated { net, .. } => {
                    let what = if matches!(effect, Effect::Activated { .. }) {
                        "activated"
                    } else {
                        "deactivated"
                    };
                    self.push(
                        time,
                        None,
                        json!({"kind": "net", "name": project.nets[*net].name, "what": what}),
                    );
                }
                _ => {}
            }
            self.vehicle.effect(effect);
        }
    }

    /// A vehicle's name, as the page reads it (null: none, or a project
    /// without a team).
    fn vehicle_name(&self, vehicle: Option<VehicleId>) -> Json {
        json!(vehicle
            .and_then(|v| self.project.vehicles.get(v))
            .map(|v| v.name.as_str()))
    }

    /// The vehicle of a team's vehicle event (`engine_failure@R2`).
    fn event_vehicle(&self, event: &Event) -> Json {
        self.vehicle_name(self.project.vehicle_event(&event.name).map(|(_, v)| v))
    }

    fn remember(&mut self, id: u64, what: String, vehicle: Option<VehicleId>) {
        if self.request_order.len() >= REQUESTS {
            if let Some(old) = self.request_order.pop_front() {
                self.requests.remove(&old);
            }
        }
        self.requests.insert(id, (what, vehicle));
        self.request_order.push_back(id);
    }

    /// The entry numbered `id`, if still kept.
    fn entry_mut(&mut self, id: usize) -> Option<&mut Entry> {
        let first = self.log.front()?.id as usize;
        self.log.get_mut(id.checked_sub(first)?)
    }

    fn push(&mut self, time: Micros, category: Option<nets::Category>, mut json: Json) -> usize {
        let id = self.next_entry;
        self.next_entry += 1;
        json["t"] = json!(seconds(time, self.origin));
        json["n"] = json!(id);
        if self.log.len() >= self.log_cap {
            self.log.pop_front();
        }
        self.log.push_back(Entry {
            id,
            time,
            category,
            json,
        });
        id as usize
    }

    fn read_marking(&mut self, player: &Player, time: Micros) {
        let state = player.state();
        let project = &self.project;
        let mut enabled = Vec::new();
        for (n, net) in project.nets.iter().enumerate() {
            if !state.active.get(n).copied().unwrap_or(false) {
                continue;
            }
            for (t, tr) in net.transitions.iter().enumerate() {
                // Bounds-checked: within a turn of the mirror's page, the
                // board may still draw the version before the player's.
                let marked = |p: usize| {
                    state
                        .marking
                        .get(p / 64)
                        .is_some_and(|w| w & (1 << (p % 64)) != 0)
                };
                if tr.flat_inputs.iter().all(|&p| marked(p)) {
                    enabled.push((self.offsets[n] + t) as u32);
                }
            }
        }
        let changed = self.marking.marking != state.marking
            || self.marking.active != state.active
            || self.marking.enabled != enabled
            || self.marking.lockout != state.lockout
            || self.marking.locked != state.locked;
        self.marking_changed |= changed;
        self.marking.marking.clone_from(&state.marking);
        self.marking.active.clone_from(&state.active);
        self.marking.enabled = enabled;
        self.marking.lockout = state.lockout;
        self.marking.locked.clone_from(&state.locked);
        self.marking.time = time;
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A net that goes `idle` → `on` on `x` (commanding `arm`) and back on `y`.
    pub(crate) fn project() -> Arc<Project> {
        let files = [
            (
                "project.toml",
                "[[net]]\nfile = \"a.toml\"\nactive = true\n[events]\nx = {}\ny = {}\n",
            ),
            (
                "a.toml",
                "name = \"A\"\nplaces = [\"idle\", \"on\"]\ninitial = [\"idle\"]\n\
                 [[transition]]\nname = \"go\"\nfrom = [\"idle\"]\nto = [\"on\"]\non = \"x\"\ndo = [\"command arm\"]\n\
                 [[transition]]\nname = \"back\"\nfrom = [\"on\"]\nto = [\"idle\"]\non = \"y\"\n",
            ),
        ];
        Arc::new(nets::load(&files).unwrap_or_else(|e| panic!("{e}")))
    }

    /// Feeds `input` to the player as the supervisor would: the step.
    /// Steps `player` on `input`, shows the step on `board`, and returns
    /// the board's last log entry.
    fn feed(board: &mut Board, player: &mut Player, seq: u64, time: Micros, input: &Input) -> Json {
        let s = step(player, seq, time, input);
        board.step(input, &s, player);
        board
            .log()
            .back()
            .map(|e| e.json.clone())
            .unwrap_or_default()
    }

    pub(crate) fn step(player: &mut Player, seq: u64, time: Micros, input: &Input) -> Step {
        match input {
            Input::Event(e) => player.handle(e, time),
            Input::Result { id, outcome } => player.result(*id, outcome.clone(), time),
            Input::Answer { id, choice } => {
                let _ = player.answer(*id, choice, time);
            }
            Input::Frame(_) | Input::Tick => player.advance(time),
            Input::Version(v) => {
                let state = nets::version::map(player.project(), player.state(), &v.project)
                    .unwrap_or_else(|e| panic!("{e:?}"));
                *player =
                    Player::restore(v.project.clone(), state).unwrap_or_else(|e| panic!("{e}"));
            }
        }
        Step {
            seq,
            time,
            events: Vec::new(),
            effects: player.effects().collect(),
        }
    }

    #[test]
    fn a_new_version_is_drawn_with_the_firings_kept_by_name() {
        let project = project();
        let mut player = Player::start(project.clone(), 0);
        let _ = player.effects().count();
        let mut board = Board::new(project.clone(), &player, 0, 100);
        feed(
            &mut board,
            &mut player,
            1,
            1_000_000,
            &Input::Event(Event::new("x")),
        );
        // Version 1: a net before A, and A's `back` renamed `home`.
        let files = [
            (
                "project.toml",
                "[[net]]\nfile = \"b.toml\"\nactive = true\n[[net]]\nfile = \"a.toml\"\nactive = true\n[events]\nx = {}\ny = {}\n",
            ),
            (
                "b.toml",
                "name = \"B\"\nplaces = [\"p\", \"q\"]\ninitial = [\"p\"]\nfinal = [\"q\"]\n\
                 [[transition]]\nname = \"t\"\nfrom = [\"p\"]\nto = [\"q\"]\non = \"y\"\n",
            ),
            (
                "a.toml",
                "name = \"A\"\nplaces = [\"idle\", \"on\"]\ninitial = [\"idle\"]\n\
                 [[transition]]\nname = \"go\"\nfrom = [\"idle\"]\nto = [\"on\"]\non = \"x\"\ndo = [\"command arm\"]\n\
                 [[transition]]\nname = \"home\"\nfrom = [\"on\"]\nto = [\"idle\"]\non = \"y\"\n",
            ),
        ];
        let new = Arc::new(nets::load(&files).unwrap_or_else(|e| panic!("{e}")));
        let version = Arc::new(petrel_core::version::Version {
            number: 1,
            project: new.clone(),
            files: Vec::new(),
        });
        let entry = feed(
            &mut board,
            &mut player,
            2,
            2_000_000,
            &Input::Version(&version),
        );
        assert_eq!(entry["kind"], "version");
        assert_eq!(entry["number"], 1);
        assert!(Arc::ptr_eq(board.project(), &new));
        // B's transition first, then A's: `go` fired once, `home` never.
        assert_eq!(board.marking.fired, vec![0, 1, 0]);
        let on = new.flat(1, nets::model::PlaceRef::Local(1));
        assert!(board.marking.marked(on), "A is still on");
        feed(
            &mut board,
            &mut player,
            3,
            3_000_000,
            &Input::Event(Event::new("y")),
        );
        assert_eq!(board.marking.fired, vec![1, 1, 1]);
    }

    #[test]
    fn a_step_marks_fires_and_logs_with_its_outcome() {
        let project = project();
        let mut player = Player::start(project.clone(), 0);
        let _ = player.effects().count();
        let mut board = Board::new(project.clone(), &player, 0, 100);
        let (idle, on) = (
            project.flat(0, nets::model::PlaceRef::Local(0)),
            project.flat(0, nets::model::PlaceRef::Local(1)),
        );
        assert!(board.marking.marked(idle) && !board.marking.marked(on));
        assert_eq!(board.marking.enabled, vec![0], "go waits for x");
        let x = Input::Event(Event::new("x"));
        let s = step(&mut player, 1, 1_000_000, &x);
        board.step(&x, &s, &player);
        assert!(board.marking_changed);
        assert!(!board.marking.marked(idle) && board.marking.marked(on));
        assert_eq!(board.marking.fired, vec![1, 0]);
        assert_eq!(board.marking.enabled, vec![1]);
        let log: Vec<&Json> = board.log().iter().map(|e| &e.json).collect();
        assert_eq!(log[0]["kind"], "event");
        assert_eq!(log[0]["fired"], json!(["A.go"]));
        assert_eq!(log[0]["t"], 1.0);
        assert_eq!(log[1]["kind"], "command");
        assert_eq!(log[1]["name"], "arm");
        let id = log[1]["id"].as_u64().unwrap_or(0);
        let done = Input::Result {
            id,
            outcome: Outcome::Done(nets::Params::new()),
        };
        let last = feed(&mut board, &mut player, 2, 1_500_000, &done);
        assert_eq!(last["kind"], "result");
        assert_eq!(last["of"], "arm");
        assert_eq!(last["ok"], true);
        // An event nothing waits for is logged as such.
        let x = Input::Event(Event::new("x"));
        let last = feed(&mut board, &mut player, 3, 2_000_000, &x);
        assert_eq!(last["name"], "x");
        assert_eq!(last["fired"], json!([]));
        assert!(!board.marking_changed);
    }

    /// A team of two, R1 and R2, each with an instance of A (`x` commands
    /// `arm`, the catastrophic `boom` stops it) and a team net T.
    pub(crate) fn team() -> Arc<Project> {
        let files = [
            (
                "project.toml",
                "[[vehicle]]\nname = \"R1\"\nsystem = 1\n[[vehicle]]\nname = \"R2\"\nsystem = 2\n\
                 [[net]]\nfile = \"t.toml\"\nactive = true\n[[net]]\nfile = \"a.toml\"\nactive = true\n\
                 [events]\nx = {}\nboom = \"catastrophic\"\n",
            ),
            ("t.toml", "name = \"T\"\nplaces = [\"s\"]\ninitial = [\"s\"]\n"),
            (
                "a.toml",
                "name = \"A\"\nvehicles = \"all\"\nplaces = [\"idle\", \"on\", \"stopped\"]\ninitial = [\"idle\"]\n\
                 [[transition]]\nname = \"go\"\nfrom = [\"idle\"]\nto = [\"on\"]\non = \"x\"\ndo = [\"command arm\"]\n\
                 [[transition]]\nname = \"stop\"\nfrom = [\"on\"]\nto = [\"stopped\"]\non = \"boom\"\n",
            ),
        ];
        Arc::new(nets::load(&files).unwrap_or_else(|e| panic!("{e}")))
    }

    #[test]
    fn a_teams_log_says_each_entrys_vehicle_and_the_lockout_names_it() {
        let project = team();
        let mut player = Player::start(project.clone(), 0);
        let _ = player.effects().count();
        let mut board = Board::new(project.clone(), &player, 0, 100);
        let x = Input::Event(Event::new("x@R2"));
        let s = step(&mut player, 1, 1_000_000, &x);
        board.step(&x, &s, &player);
        let log: Vec<Json> = board.log().iter().map(|e| e.json.clone()).collect();
        assert_eq!(log[0]["kind"], "event");
        assert_eq!(log[0]["vehicle"], "R2");
        assert_eq!(log[0]["fired"], json!(["A@R2.go"]));
        assert_eq!(log[1]["kind"], "command");
        assert_eq!(log[1]["net"], "A@R2");
        assert_eq!(log[1]["vehicle"], "R2");
        let id = log[1]["id"].as_u64().unwrap_or(0);
        let done = Input::Result {
            id,
            outcome: Outcome::Done(nets::Params::new()),
        };
        let last = feed(&mut board, &mut player, 2, 1_500_000, &done);
        assert_eq!(
            (&last["of"], &last["vehicle"]),
            (&json!("arm"), &json!("R2"))
        );
        // R2's catastrophic event locks out R2 alone.
        let boom = Input::Event(Event::new("boom@R2"));
        let s = step(&mut player, 3, 2_000_000, &boom);
        board.step(&boom, &s, &player);
        let frame = board.marking.json(&project, 0);
        assert_eq!(frame["locked"], json!(["R2"]));
        assert_eq!(frame["lockout"], false);
        // An event of no vehicle (a program's, to the team) has none.
        let y = Input::Event(Event::new("x"));
        let last = feed(&mut board, &mut player, 4, 2_500_000, &y);
        assert_eq!(
            (&last["name"], &last["vehicle"]),
            (&json!("x"), &Json::Null)
        );
    }
}
