//! The loader: a project folder's TOML files to a checked [`Project`].
//!
//! Every problem is collected and reported at once, each with its file,
//! line and column. No input makes it panic.

use std::collections::{BTreeMap, HashMap};
use std::ops::Range;

use serde::Deserialize;
use toml::Spanned;

use crate::action::{self, ActionSyntax};
use crate::choice;
use crate::event::Category;
use crate::expr::{self, Context, Expr};
use crate::model::{
    qualify, split_vehicle, Action, Args, Ask, Choice, EventDecl, Exclusive, Function, Global,
    Guard, Limits, Net, NetId, Place, PlaceRef, Program, Project, Reload, Transition, Vehicle,
    VehicleId, ASK_TIMEOUT,
};
use crate::source::{LoadError, Problem, SourceFile, Sources};
use crate::time::parse_duration;
use crate::verbs;

/// The project file every project folder holds.
pub const PROJECT_FILE: &str = "project.toml";

/// Events known from outside the project (an elaboration profile), with
/// their categories and parameters.
pub type Catalog = BTreeMap<String, EventDecl>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawProject {
    name: Option<Spanned<String>>,
    description: Option<String>,
    #[serde(default, rename = "net")]
    nets: Vec<RawNetEntry>,
    #[serde(default)]
    globals: BTreeMap<Spanned<String>, Spanned<toml::Value>>,
    #[serde(default)]
    programs: BTreeMap<Spanned<String>, RawProgram>,
    #[serde(default)]
    events: BTreeMap<Spanned<String>, Spanned<toml::Value>>,
    limits: Option<RawLimits>,
    /// The team: `[[vehicle]]`.
    #[serde(default, rename = "vehicle")]
    vehicles: Vec<RawVehicle>,
    /// Shared resources whose mutual exclusion is declared: `[[exclusive]]`.
    #[serde(default)]
    exclusive: Vec<RawExclusive>,
    /// Settings of the gateway (link, recording…): read by the gateway.
    #[allow(dead_code)]
    gateway: Option<toml::Table>,
    /// Renames for a swap from a running earlier version: `[reload]`.
    reload: Option<RawReload>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawReload {
    #[serde(default)]
    places: BTreeMap<Spanned<String>, Spanned<String>>,
    #[serde(default)]
    timers: BTreeMap<Spanned<String>, Spanned<String>>,
    lockout: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawVehicle {
    name: Spanned<String>,
    system: Spanned<i64>,
    component: Option<Spanned<i64>>,
    /// Its elaboration profile: interpreted by the gateway.
    profile: Option<String>,
    /// Its link: interpreted by the gateway.
    link: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawExclusive {
    name: Spanned<String>,
    places: Spanned<Vec<Spanned<String>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawNetEntry {
    file: Spanned<String>,
    #[serde(default)]
    active: bool,
}

#[derive(Deserialize)]
struct RawProgram {
    #[serde(default)]
    functions: BTreeMap<Spanned<String>, RawFunction>,
    /// How the gateway reaches or starts the program: read by the gateway.
    #[serde(flatten)]
    settings: BTreeMap<String, toml::Value>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFunction {
    #[serde(default)]
    args: Vec<Spanned<String>>,
    #[serde(default)]
    returns: Vec<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLimits {
    firings_per_step: Option<usize>,
    steps_per_input: Option<usize>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawNet {
    name: Spanned<String>,
    #[allow(dead_code)]
    description: Option<String>,
    #[serde(default)]
    places: Vec<Spanned<String>>,
    #[serde(default)]
    initial: Vec<Spanned<String>>,
    #[serde(default, rename = "final")]
    finals: Vec<Spanned<String>>,
    #[serde(default, rename = "transition")]
    transitions: Vec<RawTransition>,
    /// A template: one instance per vehicle named (`["R1", "R2"]`), or per
    /// vehicle of the team (`"all"`).
    vehicles: Option<Spanned<toml::Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTransition {
    name: Spanned<String>,
    #[allow(dead_code)]
    description: Option<String>,
    #[serde(default)]
    from: Vec<Spanned<String>>,
    #[serde(default)]
    to: Vec<Spanned<String>>,
    on: Option<Spanned<String>>,
    when: Option<Spanned<String>>,
    #[serde(default, rename = "do")]
    actions: Vec<Spanned<String>>,
    /// `else = true`: the fallback of its siblings.
    #[serde(rename = "else")]
    otherwise: Option<Spanned<bool>>,
    priority: Option<Spanned<i64>>,
}

/// Loads and checks a project, knowing nothing of what elaboration
/// produces: any event a transition waits for may come from outside (the
/// verifier explores it so), and `petrel check`'s static warnings say which
/// ones nothing in the project itself produces.
pub fn load(sources: &dyn Sources) -> Result<Project, LoadError> {
    load_as(sources, &Catalog::new(), false)
}

/// Loads and checks a project, knowing the events an elaboration profile
/// produces (their parameters and default categories): with the project's
/// `[events]`, the `catalog` is every event that may come from outside the
/// nets. A transition waiting for an event nothing produces — no rule of
/// the catalog, no `[events]` entry, no net's `emit`, no timer, answer or
/// result of its own net ([`crate::outside::produced`]) — can never fire:
/// a load error, with the nearest event that is produced when it looks
/// like a typo.
pub fn load_with(sources: &dyn Sources, catalog: &Catalog) -> Result<Project, LoadError> {
    load_as(sources, catalog, true)
}

fn load_as(
    sources: &dyn Sources,
    catalog: &Catalog,
    outside_known: bool,
) -> Result<Project, LoadError> {
    let mut loader = Loader {
        problems: Vec::new(),
    };
    let project = loader.project(sources, catalog, outside_known);
    if loader.problems.is_empty() {
        if let Some(project) = project {
            return Ok(project);
        }
    }
    Err(LoadError {
        problems: loader.problems,
    })
}

struct Loader {
    problems: Vec<Problem>,
}

/// A name of a net, place, transition, timer, program or function:
/// letters, digits and `_`, starting with a letter or `_`.
pub fn is_name(s: &str) -> bool {
    let mut chars = s.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// Event names may also hold dots (`DEC.replan.done`) and dashes.
pub fn is_event_name(s: &str) -> bool {
    !s.is_empty()
        && s.split('.').all(|part| {
            let mut chars = part.chars();
            chars
                .next()
                .is_some_and(|c| c.is_ascii_alphanumeric() || c == '_')
                && chars.all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        })
}

fn list(names: &[String]) -> String {
    if names.is_empty() {
        "none".to_owned()
    } else {
        names.join(", ")
    }
}

/// One net of the project before compiling: a net file, once, or a
/// template's instance for one vehicle.
struct Unit {
    /// Index in the parsed net files.
    raw: usize,
    vehicle: Option<VehicleId>,
    /// The first (or only) unit of its file: the one whose problems are
    /// reported.
    first: bool,
}

/// Context for checking one net.
struct NetScope<'a> {
    file: &'a SourceFile,
    net_names: &'a HashMap<String, NetId>,
    /// Each template's instances: (vehicle, net).
    templates: &'a HashMap<String, Vec<(VehicleId, NetId)>>,
    global_names: &'a HashMap<String, usize>,
    programs: &'a [Program],
    project: &'a Project,
    catalog: &'a Catalog,
}

impl Loader {
    fn problem(&mut self, file: &SourceFile, span: Range<usize>, message: impl Into<String>) {
        self.problems.push(Problem::new(file, span, message));
    }

    fn parse<T: for<'de> Deserialize<'de>>(&mut self, file: &SourceFile) -> Option<T> {
        match toml::from_str::<T>(&file.text) {
            Ok(t) => Some(t),
            Err(e) => {
                let span = e.span().unwrap_or(0..0);
                let mut message = e.message().trim().replace('\n', " ");
                // TOML says only "duplicate key": name it.
                if message == "duplicate key" {
                    if let Some(key) = file.text.get(span.clone()) {
                        let key = key.trim().trim_matches(|c| c == '"' || c == '\'');
                        if !key.is_empty() && !key.contains('\n') {
                            message = format!("duplicate key `{key}`: a name is declared once");
                        }
                    }
                }
                self.problem(file, span, message);
                None
            }
        }
    }

    fn name_check(&mut self, file: &SourceFile, name: &Spanned<String>, what: &str) {
        if !is_name(name.get_ref()) {
            self.problem(
                file,
                name.span(),
                format!(
                    "invalid {what} name `{}`: use letters, digits and `_`, starting with a letter or `_`",
                    name.get_ref()
                ),
            );
        }
    }

    fn project(
        &mut self,
        sources: &dyn Sources,
        catalog: &Catalog,
        outside_known: bool,
    ) -> Option<Project> {
        let text = match sources.read(PROJECT_FILE) {
            Ok(t) => t,
            Err(reason) => {
                let file = SourceFile::new(PROJECT_FILE, "");
                self.problem(&file, 0..0, format!("cannot read {PROJECT_FILE}: {reason}"));
                return None;
            }
        };
        let pfile = SourceFile::new(PROJECT_FILE, &text);
        let raw: RawProject = self.parse(&pfile)?;

        // Globals.
        let mut globals = Vec::new();
        for (name, initial) in &raw.globals {
            self.name_check(&pfile, name, "global place");
            let initial = match initial.get_ref() {
                toml::Value::Boolean(b) => *b,
                toml::Value::Integer(0) => false,
                toml::Value::Integer(1) => true,
                toml::Value::Integer(n) => {
                    self.problem(
                        &pfile,
                        initial.span(),
                        format!("global place `{}` starts with {n} tokens: nets are safe, write 0 or 1 (or false/true)", name.get_ref()),
                    );
                    false
                }
                other => {
                    self.problem(
                        &pfile,
                        initial.span(),
                        format!("global place `{}`: expected true or false (its initial marking), found a {}", name.get_ref(), other.type_str()),
                    );
                    false
                }
            };
            globals.push(Global {
                name: name.get_ref().clone(),
                initial,
            });
        }
        let global_names: HashMap<String, usize> = globals
            .iter()
            .enumerate()
            .map(|(i, g)| (g.name.clone(), i))
            .collect();

        let vehicles = self.vehicles(&pfile, &raw.vehicles);

        // Programs.
        let mut programs = Vec::new();
        for (name, raw_program) in &raw.programs {
            self.name_check(&pfile, name, "program");
            if name.get_ref() == "command" {
                self.problem(
                    &pfile,
                    name.span(),
                    "`command` is reserved for vehicle commands: choose another program name",
                );
            }
            let mut functions = Vec::new();
            for (fname, f) in &raw_program.functions {
                self.name_check(&pfile, fname, "function");
                for (what, names) in [("argument", &f.args), ("return", &f.returns)] {
                    let mut seen: Vec<&str> = Vec::new();
                    for n in names {
                        if seen.contains(&n.get_ref().as_str()) {
                            self.problem(
                                &pfile,
                                n.span(),
                                format!(
                                    "duplicate {what} `{}` of {}.{}",
                                    n.get_ref(),
                                    name.get_ref(),
                                    fname.get_ref()
                                ),
                            );
                        }
                        seen.push(n.get_ref());
                        self.name_check(&pfile, n, what);
                    }
                }
                functions.push(Function {
                    name: fname.get_ref().clone(),
                    args: f.args.iter().map(|a| a.get_ref().clone()).collect(),
                    returns: f.returns.iter().map(|a| a.get_ref().clone()).collect(),
                });
            }
            programs.push(Program {
                name: name.get_ref().clone(),
                functions,
                settings: raw_program.settings.clone(),
            });
        }

        // Events: the catalog first, then the project's declarations win.
        let mut events: BTreeMap<String, EventDecl> = catalog.clone();
        for (name, decl) in &raw.events {
            if !is_event_name(name.get_ref()) {
                self.problem(
                    &pfile,
                    name.span(),
                    format!("invalid event name `{}`", name.get_ref()),
                );
            }
            let entry = events.entry(name.get_ref().clone()).or_default();
            let span = decl.span();
            let (category, params) = match decl.get_ref() {
                toml::Value::String(c) => (Some(c.as_str()), None),
                toml::Value::Table(t) => {
                    let mut category = None;
                    let mut params = None;
                    for (key, value) in t {
                        match (key.as_str(), value) {
                            ("category", toml::Value::String(c)) => category = Some(c.as_str()),
                            ("params", toml::Value::Array(a)) => params = Some(a),
                            ("description", toml::Value::String(_)) => {}
                            ("category" | "params" | "description", v) => self.problem(&pfile, span.clone(), format!("event `{}`: `{key}` cannot be a {}", name.get_ref(), v.type_str())),
                            _ => self.problem(&pfile, span.clone(), format!("event `{}`: unknown key `{key}` (expected category, params, description)", name.get_ref())),
                        }
                    }
                    (category, params)
                }
                other => {
                    self.problem(&pfile, span.clone(), format!("event `{}`: expected a category or a table {{ category, params }}, found a {}", name.get_ref(), other.type_str()));
                    (None, None)
                }
            };
            if let Some(c) = category {
                match c.parse::<Category>() {
                    Ok(c) => entry.category = Some(c),
                    Err(e) => self.problem(&pfile, span.clone(), e.to_string()),
                }
            }
            if let Some(params) = params {
                let mut seen: Vec<String> = Vec::new();
                for p in params {
                    match p.as_str() {
                        Some(p) if is_name(p) && !seen.iter().any(|s| s == p) => seen.push(p.to_owned()),
                        Some(p) if is_name(p) => self.problem(&pfile, span.clone(), format!("duplicate parameter `{p}` of event `{}`", name.get_ref())),
                        _ => self.problem(&pfile, span.clone(), format!("event `{}`: parameter names are strings of letters, digits and `_`", name.get_ref())),
                    }
                }
                entry.params = Some(seen);
            }
        }

        let mut limits = Limits::default();
        if let Some(l) = &raw.limits {
            limits.firings_per_step = l.firings_per_step.unwrap_or(limits.firings_per_step).max(1);
            limits.steps_per_input = l.steps_per_input.unwrap_or(limits.steps_per_input).max(1);
        }

        // Net files.
        let mut raw_nets: Vec<(SourceFile, RawNet, bool)> = Vec::new();
        let mut nets_complete = true;
        for entry in &raw.nets {
            let path = entry.file.get_ref();
            match sources.read(path) {
                Ok(text) => {
                    let file = SourceFile::new(path, &text);
                    match self.parse::<RawNet>(&file) {
                        Some(net) => raw_nets.push((file, net, entry.active)),
                        None => nets_complete = false,
                    }
                }
                Err(reason) => {
                    nets_complete = false;
                    self.problem(
                        &pfile,
                        entry.file.span(),
                        format!("cannot read net file `{path}`: {reason}"),
                    );
                }
            }
        }
        if raw.nets.is_empty() {
            self.problem(
                &pfile,
                0..0,
                "the project has no nets: add [[net]] tables with file = \"NAME.toml\"",
            );
        }

        // A template becomes one instance per vehicle, `NAME@VEHICLE`.
        let mut units: Vec<Unit> = Vec::new();
        for (i, (file, net, _)) in raw_nets.iter().enumerate() {
            match &net.vehicles {
                None => units.push(Unit {
                    raw: i,
                    vehicle: None,
                    first: true,
                }),
                Some(list) => {
                    for (k, v) in self
                        .template_vehicles(file, list, &vehicles)
                        .into_iter()
                        .enumerate()
                    {
                        units.push(Unit {
                            raw: i,
                            vehicle: Some(v),
                            first: k == 0,
                        });
                    }
                }
            }
        }
        let mut templates: HashMap<String, Vec<(VehicleId, NetId)>> = HashMap::new();
        let mut net_names: HashMap<String, NetId> = HashMap::new();
        let mut first_seen: HashMap<String, usize> = HashMap::new();
        for (i, (file, net, _)) in raw_nets.iter().enumerate() {
            self.name_check(file, &net.name, "net");
            if let Some(&first) = first_seen.get(net.name.get_ref()) {
                let (ffile, fnet, _) = &raw_nets[first];
                let (l, c) = ffile.line_col(fnet.name.span().start);
                self.problem(
                    file,
                    net.name.span(),
                    format!(
                        "duplicate net `{}` (first declared at {}:{l}:{c})",
                        net.name.get_ref(),
                        ffile.name
                    ),
                );
            } else {
                first_seen.insert(net.name.get_ref().clone(), i);
            }
        }
        for (id, unit) in units.iter().enumerate() {
            let name = raw_nets[unit.raw].1.name.get_ref();
            if first_seen.get(name) != Some(&unit.raw) {
                continue;
            }
            match unit.vehicle {
                None => {
                    net_names.insert(name.clone(), id);
                }
                Some(v) => {
                    net_names.insert(qualify(name, &vehicles[v].name), id);
                    templates.entry(name.clone()).or_default().push((v, id));
                }
            }
        }

        // A first pass gives every net its places and timers, so that the
        // flat numbering exists before transitions are compiled.
        let mut project = Project {
            name: raw
                .name
                .as_ref()
                .map(|n| n.get_ref().clone())
                .unwrap_or_default(),
            description: raw.description.clone().unwrap_or_default(),
            nets: Vec::new(),
            globals,
            programs,
            events,
            limits,
            triggers: HashMap::new(),
            place_offsets: Vec::new(),
            place_count: 0,
            vehicles,
            exclusive: Vec::new(),
            reload: Reload::default(),
        };
        for unit in &units {
            let (file, raw_net, active) = &raw_nets[unit.raw];
            let before = self.problems.len();
            let mut net = self.net_shell(file, raw_net, *active);
            if !unit.first {
                // Its template's problems are reported once.
                self.problems.truncate(before);
            }
            if let Some(v) = unit.vehicle {
                net.name = qualify(&net.name, &project.vehicles[v].name);
                net.vehicle = Some(v);
            }
            project.nets.push(net);
        }
        let mut offset = project.globals.len();
        for net in &project.nets {
            project.place_offsets.push(offset);
            offset += net.places.len();
        }
        project.place_count = offset;

        let mut transitions = Vec::new();
        for (i, unit) in units.iter().enumerate() {
            let (file, raw_net, _) = &raw_nets[unit.raw];
            let scope = NetScope {
                file,
                net_names: &net_names,
                templates: &templates,
                global_names: &global_names,
                programs: &project.programs,
                project: &project,
                catalog,
            };
            let before = self.problems.len();
            transitions.push(self.transitions(&scope, i, raw_net));
            if !unit.first {
                self.problems.truncate(before);
            }
        }
        for (i, ts) in transitions.into_iter().enumerate() {
            project.nets[i].immediate = ts
                .iter()
                .enumerate()
                .filter(|(_, t)| t.event.is_none())
                .map(|(j, _)| j)
                .collect();
            project.nets[i].transitions = ts;
        }
        for (n, net) in project.nets.iter().enumerate() {
            for (t, tr) in net.transitions.iter().enumerate() {
                if let Some(e) = &tr.event {
                    project.triggers.entry(e.clone()).or_default().push((n, t));
                }
            }
        }
        let firsts: Vec<bool> = units.iter().map(|u| u.first).collect();
        let sources: Vec<(&SourceFile, &RawNet)> = units
            .iter()
            .map(|u| (&raw_nets[u.raw].0, &raw_nets[u.raw].1))
            .collect();
        self.choices(&project, &sources, &firsts);
        project.exclusive = self.exclusive(&pfile, &raw.exclusive, &project, &templates);
        if let Some(r) = &raw.reload {
            project.reload = self.reload(&pfile, r, &project);
        }
        for waiting in project.triggers.values_mut() {
            choice::order(&project.nets, waiting);
        }
        if !nets_complete {
            // References to nets that failed to parse would only add noise;
            // the parse problems are already reported.
            self.problems
                .retain(|p| !p.message.starts_with("unknown net "));
        }
        if outside_known && self.problems.is_empty() {
            // Only in a project otherwise sound: an action refused above
            // would make the event it emits look produced by nothing.
            self.unproduced(&project, &units, &raw_nets);
        }
        Some(project)
    }

    /// Every transition waiting for an event nothing produces
    /// ([`crate::outside::produced_by_nothing`]), reported at its `on`
    /// value once for a template's instances.
    fn unproduced(
        &mut self,
        project: &Project,
        units: &[Unit],
        raw_nets: &[(SourceFile, RawNet, bool)],
    ) {
        // (raw net, transition) → the first instance's text, the others'
        // names.
        let mut found: BTreeMap<(usize, usize), (String, Vec<String>)> = BTreeMap::new();
        for (n, unit) in units.iter().enumerate() {
            let Some(net) = project.nets.get(n) else {
                continue;
            };
            for (j, t) in net.transitions.iter().enumerate() {
                let Some(e) = &t.event else { continue };
                let Some(text) = crate::outside::produced_by_nothing(project, n, &t.name, e) else {
                    continue;
                };
                found
                    .entry((unit.raw, j))
                    .and_modify(|(_, others)| others.push(net.name.clone()))
                    .or_insert((text, Vec::new()));
            }
        }
        for ((raw, j), (mut text, others)) in found {
            let (file, net, _) = &raw_nets[raw];
            let Some(on) = net.transitions.get(j).and_then(|t| t.on.as_ref()) else {
                continue;
            };
            if !others.is_empty() {
                text.push_str(&format!("; so too in {}", others.join(", ")));
            }
            self.problem(file, on.span(), text);
        }
    }

    /// The team declared by `[[vehicle]]`: names and MAVLink ids unique.
    fn vehicles(&mut self, file: &SourceFile, raw: &[RawVehicle]) -> Vec<Vehicle> {
        let mut out: Vec<Vehicle> = Vec::new();
        let mut spans: Vec<Range<usize>> = Vec::new();
        for v in raw {
            self.name_check(file, &v.name, "vehicle");
            let id =
                |this: &mut Self, n: &Spanned<i64>, what: &str| match u8::try_from(*n.get_ref()) {
                    Ok(x) if x > 0 => x,
                    _ => {
                        this.problem(
                            file,
                            n.span(),
                            format!(
                                "vehicle `{}`: MAVLink {what} id {} is out of range (1 to 255)",
                                v.name.get_ref(),
                                n.get_ref()
                            ),
                        );
                        0
                    }
                };
            let system = id(self, &v.system, "system");
            let component = match &v.component {
                Some(c) => id(self, c, "component"),
                None => 1,
            };
            if let Some(k) = out.iter().position(|w| w.name == *v.name.get_ref()) {
                let (l, c) = file.line_col(spans[k].start);
                self.problem(
                    file,
                    v.name.span(),
                    format!(
                        "duplicate vehicle `{}` (first declared at {}:{l}:{c})",
                        v.name.get_ref(),
                        file.name
                    ),
                );
            } else if let Some(w) = out
                .iter()
                .find(|w| system != 0 && w.system == system && w.component == component)
            {
                self.problem(file, v.system.span(), format!("vehicle `{}` has the MAVLink system id {system} (component {component}) of vehicle `{}`: each vehicle needs its own", v.name.get_ref(), w.name));
            }
            spans.push(v.name.span());
            out.push(Vehicle {
                name: v.name.get_ref().clone(),
                system,
                component,
                profile: v.profile.clone(),
                link: v.link.clone(),
            });
        }
        out
    }

    /// The vehicles a template is instantiated for, in team order.
    fn template_vehicles(
        &mut self,
        file: &SourceFile,
        list: &Spanned<toml::Value>,
        vehicles: &[Vehicle],
    ) -> Vec<VehicleId> {
        let span = list.span();
        if vehicles.is_empty() {
            self.problem(file, span, "`vehicles`: the project declares no vehicle (add [[vehicle]] tables with name and system to project.toml)");
            return Vec::new();
        }
        let names: Vec<&str> = vehicles.iter().map(|v| v.name.as_str()).collect();
        match list.get_ref() {
            toml::Value::String(all) if all == "all" => (0..vehicles.len()).collect(),
            toml::Value::Array(items) => {
                let mut out: Vec<VehicleId> = Vec::new();
                for item in items {
                    let Some(name) = item.as_str() else {
                        self.problem(
                            file,
                            span.clone(),
                            "`vehicles`: expected vehicle names (strings)",
                        );
                        continue;
                    };
                    match names.iter().position(|n| *n == name) {
                        Some(v) if out.contains(&v) => self.problem(
                            file,
                            span.clone(),
                            format!("`vehicles` lists `{name}` twice"),
                        ),
                        Some(v) => out.push(v),
                        None => self.problem(
                            file,
                            span.clone(),
                            format!(
                                "unknown vehicle `{name}` in `vehicles` (the team: {})",
                                names.join(", ")
                            ),
                        ),
                    }
                }
                if items.is_empty() {
                    self.problem(
                        file,
                        span,
                        "`vehicles` is empty: name at least one vehicle, or write \"all\"",
                    );
                }
                out.sort_unstable();
                out
            }
            _ => {
                self.problem(
                    file,
                    span,
                    "`vehicles`: expected a list of vehicle names or \"all\"",
                );
                Vec::new()
            }
        }
    }

    /// `[reload]`: each new name must be a place (a timer) of this
    /// version; the old names belong to the running version and are
    /// checked when it swaps ([`crate::version`]).
    fn reload(&mut self, file: &SourceFile, raw: &RawReload, project: &Project) -> Reload {
        let mut out = Reload::default();
        type Found = fn(&Project, &str) -> bool;
        let place: Found = |p, n| crate::version::place_named(p, n).is_some();
        let timer: Found = |p, n| crate::version::timer_named(p, n).is_some();
        let kinds = [
            (
                &raw.places,
                &mut out.places,
                "place",
                place,
                "NET.place, or a global place's name",
            ),
            (&raw.timers, &mut out.timers, "timer", timer, "NET.timer"),
        ];
        for (renames, into, kind, exists, how) in kinds {
            for (old, new) in renames {
                let found = exists(project, new.get_ref());
                if !found {
                    self.problem(
                        file,
                        new.span(),
                        format!(
                            "[reload] {kind} `{}`: this version has no such {kind} (write {how})",
                            new.get_ref()
                        ),
                    );
                }
                into.insert(old.get_ref().clone(), new.get_ref().clone());
            }
        }
        if let Some(lockout) = &raw.lockout {
            if lockout.get_ref() == "kept" {
                out.lockout_kept = true;
            } else {
                self.problem(
                    file,
                    lockout.span(),
                    format!(
                        "[reload] lockout = {:?}: \"kept\" is its one value (this version keeps the catastrophic lockout's nets unchanged)",
                        lockout.get_ref()
                    ),
                );
            }
        }
        out
    }

    /// The shared resources of `[[exclusive]]`: places `TEMPLATE.place`
    /// of instances.
    fn exclusive(
        &mut self,
        file: &SourceFile,
        raw: &[RawExclusive],
        project: &Project,
        templates: &HashMap<String, Vec<(VehicleId, NetId)>>,
    ) -> Vec<Exclusive> {
        let mut out: Vec<Exclusive> = Vec::new();
        for r in raw {
            self.name_check(file, &r.name, "resource");
            if out.iter().any(|e| e.name == *r.name.get_ref()) {
                self.problem(
                    file,
                    r.name.span(),
                    format!("duplicate resource `{}`", r.name.get_ref()),
                );
            }
            if r.places.get_ref().is_empty() {
                self.problem(
                    file,
                    r.places.span(),
                    format!("resource `{}` has no places", r.name.get_ref()),
                );
            }
            let mut held: Vec<(VehicleId, Vec<usize>)> = Vec::new();
            for place in r.places.get_ref() {
                let Some((template, name)) = place.get_ref().split_once('.') else {
                    self.problem(file, place.span(), format!("resource place `{}`: write TEMPLATE.place, a place of a net instantiated per vehicle", place.get_ref()));
                    continue;
                };
                let Some(instances) = templates.get(template) else {
                    let hint = if project.net(template).is_some() {
                        " (it has no `vehicles`: a team net's places are no vehicle's)"
                    } else {
                        ""
                    };
                    self.problem(file, place.span(), format!("resource place `{}`: `{template}` is not a net instantiated per vehicle{hint}", place.get_ref()));
                    continue;
                };
                for &(v, n) in instances {
                    let Some(p) = project.nets[n].places.iter().position(|q| q.name == name) else {
                        self.problem(
                            file,
                            place.span(),
                            format!(
                                "resource place `{}`: net `{template}` has no place `{name}`",
                                place.get_ref()
                            ),
                        );
                        break;
                    };
                    let flat = project.flat(n, PlaceRef::Local(p));
                    match held.iter_mut().find(|(w, _)| *w == v) {
                        Some((_, places)) if !places.contains(&flat) => places.push(flat),
                        Some(_) => {}
                        None => held.push((v, vec![flat])),
                    }
                }
            }
            held.sort();
            out.push(Exclusive {
                name: r.name.get_ref().clone(),
                places: r
                    .places
                    .get_ref()
                    .iter()
                    .map(|p| p.get_ref().clone())
                    .collect(),
                held,
            });
        }
        out
    }

    /// The event a transition of net `net` waits for, as the player
    /// delivers it: in a template's instance, a vehicle event is that
    /// vehicle's (`E@VEHICLE`); the net's own timers, its questions'
    /// answers and the results of its calls and commands stay as written.
    /// In a team net, `E@VEHICLE` must name a vehicle of the team.
    fn vehicle_event(
        &mut self,
        scope: &NetScope,
        net: NetId,
        text: &str,
        span: Range<usize>,
        what: &str,
    ) -> Option<String> {
        let (base, vehicle) = split_vehicle(text);
        if !is_event_name(base) || vehicle.is_some_and(|v| !is_name(v)) {
            self.problem(scope.file, span, format!("invalid event name `{text}`"));
            return None;
        }
        let project = scope.project;
        match (project.nets[net].vehicle, vehicle) {
            (Some(_), Some(_)) => {
                self.problem(scope.file, span, format!("`{text}` in a net instantiated per vehicle: an instance's events are its own vehicle's, write `{base}` (only a team net, without `vehicles`, names a vehicle)"));
                None
            }
            (Some(v), None) => {
                let own = crate::outside::own_timer(project, net, text)
                    || project.nets[net].asks.iter().any(|a| {
                        text.split_once('.').is_some_and(|(q, c)| {
                            a.name == q && (c == ASK_TIMEOUT || a.choices.iter().any(|x| x == c))
                        })
                    })
                    || crate::outside::player_own(project, text).is_some();
                Some(if own && what == "on" {
                    text.to_owned()
                } else {
                    qualify(text, &project.vehicles[v].name)
                })
            }
            (None, Some(v)) if project.vehicle(v).is_none() => {
                let team: Vec<String> = project.vehicles.iter().map(|v| v.name.clone()).collect();
                self.problem(
                    scope.file,
                    span,
                    format!(
                        "`{text}`: `@{v}` names no vehicle (the team: {})",
                        list(&team)
                    ),
                );
                None
            }
            _ => Some(text.to_owned()),
        }
    }

    /// A transition's `else` or `priority`: only for one waiting for an
    /// event, not both.
    fn choice(&mut self, file: &SourceFile, t: &RawTransition, waits: bool) -> Choice {
        let choice = match (&t.otherwise, &t.priority) {
            (Some(e), Some(_)) if *e.get_ref() => {
                self.problem(file, e.span(), format!("transition `{}` has both `else` and `priority`: an `else` transition is tried after all its siblings, whatever their priority", t.name.get_ref()));
                return Choice::Ordinary;
            }
            (Some(e), _) if *e.get_ref() => (Choice::Else, e.span()),
            (_, Some(p)) => (Choice::Priority(*p.get_ref()), p.span()),
            _ => return Choice::Ordinary,
        };
        if !waits {
            self.problem(file, choice.1, format!("immediate transition `{}` cannot have `else` or `priority`: immediate transitions fire one at a time in declaration order (give it `on = \"EVENT\"`)", t.name.get_ref()));
            return Choice::Ordinary;
        }
        choice.0
    }

    /// Declarations of `else` and `priority` that decide nothing.
    fn choices(&mut self, project: &Project, nets: &[(&SourceFile, &RawNet)], firsts: &[bool]) {
        for (n, t, message) in choice::problems(project) {
            if !firsts[n] {
                continue;
            }
            let (file, raw) = nets[n];
            let raw = &raw.transitions[t];
            let span = match (&raw.otherwise, &raw.priority) {
                (Some(e), _) if *e.get_ref() => e.span(),
                (_, Some(p)) => p.span(),
                _ => raw.name.span(),
            };
            self.problem(file, span, message);
        }
    }

    fn net_shell(&mut self, file: &SourceFile, raw: &RawNet, active: bool) -> Net {
        let mut places: Vec<Place> = Vec::new();
        for p in &raw.places {
            if let Some(stripped) = p.get_ref().strip_prefix('@') {
                self.problem(file, p.span(), format!("`@{stripped}` is a global place: declare it in project.toml [globals], not in a net's places"));
                continue;
            }
            self.name_check(file, p, "place");
            if places.iter().any(|q| q.name == *p.get_ref()) {
                self.problem(file, p.span(), format!("duplicate place `{}`", p.get_ref()));
                continue;
            }
            places.push(Place {
                name: p.get_ref().clone(),
                initial: false,
                is_final: false,
            });
        }
        for (list, what) in [(&raw.initial, "initial"), (&raw.finals, "final")] {
            for p in list {
                match places.iter_mut().find(|q| q.name == *p.get_ref()) {
                    Some(place) => {
                        let flag = if what == "initial" {
                            &mut place.initial
                        } else {
                            &mut place.is_final
                        };
                        if *flag {
                            self.problem(
                                file,
                                p.span(),
                                format!("place `{}` is listed twice in `{what}`", p.get_ref()),
                            );
                        }
                        *flag = true;
                    }
                    None => self.problem(
                        file,
                        p.span(),
                        format!(
                            "unknown place `{}` in `{what}`: it is not in `places`",
                            p.get_ref()
                        ),
                    ),
                }
            }
        }
        let mut timers: Vec<String> = Vec::new();
        let mut asks: Vec<Ask> = Vec::new();
        for t in &raw.transitions {
            for a in &t.actions {
                match action::parse(a.get_ref()) {
                    Ok(ActionSyntax::Timer { name, .. }) if !timers.contains(&name.0) => {
                        timers.push(name.0);
                    }
                    Ok(ActionSyntax::Ask { name, choices, .. })
                        if asks.iter().all(|q| q.name != name.0) =>
                    {
                        timers.push(format!("{}.{ASK_TIMEOUT}", name.0));
                        asks.push(Ask {
                            name: name.0,
                            choices: choices.into_iter().map(|c| c.0).collect(),
                            timer: timers.len() - 1,
                        });
                    }
                    _ => {}
                }
            }
        }
        Net {
            name: raw.name.get_ref().clone(),
            file: file.name.clone(),
            places,
            transitions: Vec::new(),
            vehicle: None,
            active_at_start: active,
            timers,
            asks,
            immediate: Vec::new(),
        }
    }

    fn transitions(&mut self, scope: &NetScope, net: NetId, raw: &RawNet) -> Vec<Transition> {
        let file = scope.file;
        let mut out: Vec<Transition> = Vec::new();
        let mut seen: HashMap<String, usize> = HashMap::new();
        for t in &raw.transitions {
            self.name_check(file, &t.name, "transition");
            if let Some(&first) = seen.get(t.name.get_ref()) {
                let (l, c) = file.line_col(first);
                self.problem(
                    file,
                    t.name.span(),
                    format!(
                        "duplicate transition `{}` (first declared at {}:{l}:{c})",
                        t.name.get_ref(),
                        file.name
                    ),
                );
            } else {
                seen.insert(t.name.get_ref().clone(), t.name.span().start);
            }
            let inputs = self.arcs(scope, net, &t.from, "from");
            let outputs = self.arcs(scope, net, &t.to, "to");
            if t.from.is_empty() {
                self.problem(
                    file,
                    t.name.span(),
                    format!(
                        "transition `{}` has no input place: give it `from = [...]`",
                        t.name.get_ref()
                    ),
                );
            }
            let event = match &t.on {
                Some(on) => self.vehicle_event(scope, net, on.get_ref(), on.span(), "on"),
                None => None,
            };
            let known_params: Option<Vec<String>> = event.as_deref().and_then(|e| {
                if crate::outside::own_timer(scope.project, net, e)
                    && !scope.project.events.contains_key(e)
                {
                    Some(Vec::new())
                } else {
                    scope
                        .project
                        .event_params(e)
                        .or_else(|| scope.catalog.get(e).and_then(|d| d.params.clone()))
                }
            });
            let ctx = TriggerCtx {
                transition: t.name.get_ref(),
                event: event.as_deref(),
                params: known_params.as_deref(),
            };
            let guard = match &t.when {
                Some(when) if event.is_none() => {
                    self.problem(file, when.span(), format!("immediate transition `{}` cannot have a guard: there is no event to test (give it `on = \"EVENT\"`)", t.name.get_ref()));
                    None
                }
                Some(when) => match expr::parse(when.get_ref(), Context::Guard) {
                    Ok(e) => {
                        self.check_params(file, when, &e, &ctx);
                        Some(Guard {
                            text: when.get_ref().clone(),
                            expr: e,
                        })
                    }
                    Err(err) => {
                        let at = file.inside_string(&when.span(), when.get_ref(), err.at);
                        self.problem(file, at..at + 1, format!("in guard: {}", err.message));
                        None
                    }
                },
                None => None,
            };
            let mut actions = Vec::new();
            let mut action_source = Vec::new();
            for a in &t.actions {
                if let Some(action) = self.action(scope, net, a, &ctx) {
                    actions.push(action);
                    action_source.push(a.get_ref().trim().to_owned());
                }
            }
            let flat_inputs = inputs.iter().map(|p| scope.project.flat(net, *p)).collect();
            let flat_outputs = outputs
                .iter()
                .map(|p| scope.project.flat(net, *p))
                .collect();
            let choice = self.choice(file, t, event.is_some());
            out.push(Transition {
                choice,
                name: t.name.get_ref().clone(),
                inputs,
                outputs,
                event,
                guard,
                actions,
                action_source,
                flat_inputs,
                flat_outputs,
            });
        }
        out
    }

    fn arcs(
        &mut self,
        scope: &NetScope,
        net: NetId,
        names: &[Spanned<String>],
        side: &str,
    ) -> Vec<PlaceRef> {
        let file = scope.file;
        let mut out: Vec<PlaceRef> = Vec::new();
        for n in names {
            let place = if let Some(global) = n.get_ref().strip_prefix('@') {
                match scope.global_names.get(global) {
                    Some(&g) => PlaceRef::Global(g),
                    None => {
                        self.problem(file, n.span(), format!("undeclared global place `@{global}`: declare it in project.toml [globals]"));
                        continue;
                    }
                }
            } else {
                match scope.project.nets[net]
                    .places
                    .iter()
                    .position(|p| p.name == *n.get_ref())
                {
                    Some(p) => PlaceRef::Local(p),
                    None => {
                        let hint = if scope.global_names.contains_key(n.get_ref()) {
                            format!(" (the global place is written `@{}`)", n.get_ref())
                        } else {
                            String::new()
                        };
                        self.problem(
                            file,
                            n.span(),
                            format!(
                                "unknown place `{}` in `{side}` of net `{}`{hint}",
                                n.get_ref(),
                                scope.project.nets[net].name
                            ),
                        );
                        continue;
                    }
                }
            };
            if out.contains(&place) {
                self.problem(
                    file,
                    n.span(),
                    format!(
                        "place `{}` appears twice in `{side}`: arcs are unary",
                        n.get_ref()
                    ),
                );
                continue;
            }
            out.push(place);
        }
        out
    }

    fn check_params(
        &mut self,
        file: &SourceFile,
        text: &Spanned<String>,
        e: &Expr,
        ctx: &TriggerCtx,
    ) {
        let mut read = Vec::new();
        e.params(&mut read);
        self.check_param_list(file, text, &read, ctx, 0);
    }

    fn check_param_list(
        &mut self,
        file: &SourceFile,
        text: &Spanned<String>,
        read: &[(String, usize)],
        ctx: &TriggerCtx,
        base: usize,
    ) {
        for (name, at) in read {
            let at = file.inside_string(&text.span(), text.get_ref(), base + at);
            let message = match (ctx.event, ctx.params) {
                (None, _) => format!("`${name}`: immediate transition `{}` has no triggering event, so no parameters", ctx.transition),
                (Some(event), None) => format!("unknown parameter `{name}`: event `{event}` declares no parameters (declare them in project.toml: [events.\"{event}\"] params = [...])"),
                (Some(event), Some(params)) if !params.iter().any(|p| p == name) => format!("unknown parameter `{name}` of event `{event}` (it has: {})", list(params)),
                _ => continue,
            };
            self.problem(file, at..at + name.len() + 1, message);
        }
    }

    fn action(
        &mut self,
        scope: &NetScope,
        net: NetId,
        text: &Spanned<String>,
        ctx: &TriggerCtx,
    ) -> Option<Action> {
        let file = scope.file;
        let at = |i: usize| {
            let a = file.inside_string(&text.span(), text.get_ref(), i);
            a..a + 1
        };
        let name_span = |n: &(String, usize)| {
            let a = file.inside_string(&text.span(), text.get_ref(), n.1);
            a..a + n.0.len().max(1)
        };
        let syntax = match action::parse(text.get_ref()) {
            Ok(s) => s,
            Err(err) => {
                self.problem(file, at(err.at), format!("in action: {}", err.message));
                return None;
            }
        };
        let check_args = |this: &mut Self, args: &Args| {
            let mut read = Vec::new();
            for (_, e) in args {
                e.params(&mut read);
            }
            this.check_param_list(file, text, &read, ctx, 0);
        };
        Some(match syntax {
            ActionSyntax::Activate(n) | ActionSyntax::Deactivate(n) => {
                // In an instance, a template's name is its own vehicle's
                // instance; a team net names the instance (`MOVE@R1`).
                let own = scope.project.nets[net].vehicle.and_then(|v| {
                    scope
                        .templates
                        .get(&n.0)
                        .and_then(|i| i.iter().find(|(w, _)| *w == v).map(|(_, id)| *id))
                });
                let Some(id) = own.or_else(|| scope.net_names.get(&n.0).copied()) else {
                    let hint = if scope.templates.contains_key(&n.0) {
                        format!(
                            ": `{}` is instantiated per vehicle, name the instance (`{}@VEHICLE`)",
                            n.0, n.0
                        )
                    } else {
                        String::new()
                    };
                    self.problem(file, name_span(&n), format!("unknown net `{}`{hint}", n.0));
                    return None;
                };
                if text.get_ref().trim_start().starts_with("activate") {
                    Action::Activate(id)
                } else {
                    Action::Deactivate(id)
                }
            }
            ActionSyntax::Emit { event, args } => {
                let emitted =
                    self.vehicle_event(scope, net, &event.0, name_span(&event), "emit")?;
                if let Some(params) = scope
                    .project
                    .events
                    .get(split_vehicle(&event.0).0)
                    .and_then(|d| d.params.as_ref())
                {
                    for (k, _) in &args {
                        if !params.contains(k) {
                            self.problem(
                                file,
                                name_span(&event),
                                format!(
                                    "event `{}` has no parameter `{k}` (it has: {})",
                                    event.0,
                                    list(params)
                                ),
                            );
                        }
                    }
                }
                check_args(self, &args);
                Action::Emit {
                    event: emitted,
                    args,
                }
            }
            ActionSyntax::Timer { name, after } => {
                let micros = match parse_duration(&after.0) {
                    Ok(m) => m,
                    Err(e) => {
                        self.problem(file, name_span(&after), e.to_string());
                        return None;
                    }
                };
                let timer = scope.project.nets[net]
                    .timers
                    .iter()
                    .position(|t| *t == name.0)?;
                Action::Timer {
                    timer,
                    after: micros,
                }
            }
            ActionSyntax::Cancel(name) => {
                match scope.project.nets[net]
                    .timers
                    .iter()
                    .position(|t| *t == name.0)
                {
                    Some(timer) => Action::Cancel { timer },
                    None => {
                        self.problem(
                            file,
                            name_span(&name),
                            format!(
                                "unknown timer `{}`: net `{}` never starts it",
                                name.0, scope.project.nets[net].name
                            ),
                        );
                        return None;
                    }
                }
            }
            ActionSyntax::Call {
                program,
                function,
                args,
            } => {
                let Some(p) = scope.programs.iter().position(|p| p.name == program.0) else {
                    self.problem(
                        file,
                        name_span(&program),
                        format!(
                            "unknown program `{}`: declare it in project.toml [programs]",
                            program.0
                        ),
                    );
                    return None;
                };
                let prog = &scope.programs[p];
                let Some(f) = prog.functions.iter().position(|f| f.name == function.0) else {
                    let names: Vec<String> =
                        prog.functions.iter().map(|f| f.name.clone()).collect();
                    self.problem(
                        file,
                        name_span(&function),
                        format!(
                            "unknown function `{}` of program `{}` (it has: {})",
                            function.0,
                            program.0,
                            list(&names)
                        ),
                    );
                    return None;
                };
                let func = &prog.functions[f];
                for (k, _) in &args {
                    if !func.args.contains(k) {
                        self.problem(
                            file,
                            name_span(&function),
                            format!(
                                "{}.{} takes no argument `{k}` (it takes: {})",
                                program.0,
                                function.0,
                                list(&func.args)
                            ),
                        );
                    }
                }
                for k in &func.args {
                    if !args.iter().any(|(a, _)| a == k) {
                        self.problem(
                            file,
                            name_span(&function),
                            format!("{}.{} needs argument `{k}`", program.0, function.0),
                        );
                    }
                }
                check_args(self, &args);
                Action::Call {
                    program: p,
                    function: f,
                    args,
                }
            }
            ActionSyntax::Command {
                verb,
                args,
                vehicle,
            } => {
                let team: Vec<String> = scope
                    .project
                    .vehicles
                    .iter()
                    .map(|v| v.name.clone())
                    .collect();
                let vehicle = match (scope.project.nets[net].vehicle, vehicle) {
                    (Some(_), Some(named)) => {
                        self.problem(file, name_span(&named), format!("`@{}`: an instance commands its own vehicle only (a team net, without `vehicles`, commands a named one)", named.0));
                        return None;
                    }
                    (Some(own), None) => Some(own),
                    (None, Some(named)) => match scope.project.vehicle(&named.0) {
                        Some(v) => Some(v),
                        None => {
                            self.problem(
                                file,
                                name_span(&named),
                                format!(
                                    "`@{}` names no vehicle (the team: {})",
                                    named.0,
                                    list(&team)
                                ),
                            );
                            return None;
                        }
                    },
                    (None, None) if !team.is_empty() => {
                        self.problem(file, name_span(&verb), format!("command `{}` in a team net: name the vehicle (`command {} @{} ...`)", verb.0, verb.0, team[0]));
                        return None;
                    }
                    (None, None) => None,
                };
                let Some(v) = verbs::verb(&verb.0) else {
                    let names: Vec<String> =
                        verbs::VERBS.iter().map(|v| v.name.to_owned()).collect();
                    self.problem(
                        file,
                        name_span(&verb),
                        format!(
                            "unknown command verb `{}` (known: {})",
                            verb.0,
                            list(&names)
                        ),
                    );
                    return None;
                };
                for (k, _) in &args {
                    if !v.required.contains(&k.as_str()) && !v.optional.contains(&k.as_str()) {
                        let mut known: Vec<String> = v
                            .required
                            .iter()
                            .chain(v.optional)
                            .map(|s| s.to_string())
                            .collect();
                        known.sort();
                        self.problem(
                            file,
                            name_span(&verb),
                            format!(
                                "command `{}` takes no argument `{k}` (it takes: {})",
                                verb.0,
                                list(&known)
                            ),
                        );
                    }
                }
                for k in v.required {
                    if !args.iter().any(|(a, _)| a == k) {
                        self.problem(
                            file,
                            name_span(&verb),
                            format!("command `{}` needs argument `{k}`", verb.0),
                        );
                    }
                }
                check_args(self, &args);
                Action::Command {
                    verb: verb.0,
                    args,
                    vehicle,
                }
            }
            ActionSyntax::Ask {
                name,
                question,
                choices,
                timeout,
            } => {
                let micros = match parse_duration(&timeout.0) {
                    Ok(m) => m,
                    Err(e) => {
                        self.problem(file, name_span(&timeout), e.to_string());
                        return None;
                    }
                };
                let choices: Vec<String> = choices.into_iter().map(|c| c.0).collect();
                for (i, c) in choices.iter().enumerate() {
                    if c == ASK_TIMEOUT || choices[..i].contains(c) {
                        self.problem(
                            file,
                            name_span(&name),
                            format!(
                                "ask `{}`: choice `{c}` is {}",
                                name.0,
                                if c == ASK_TIMEOUT {
                                    "reserved for the ask's timeout event"
                                } else {
                                    "offered twice"
                                }
                            ),
                        );
                        return None;
                    }
                }
                let net_asks = &scope.project.nets[net].asks;
                let ask = net_asks.iter().position(|q| q.name == name.0)?;
                if net_asks[ask].choices != choices {
                    self.problem(
                        file,
                        name_span(&name),
                        format!(
                            "ask `{}` is asked elsewhere in net `{}` with other choices ({}): one name, one set of choices",
                            name.0,
                            scope.project.nets[net].name,
                            list(&net_asks[ask].choices)
                        ),
                    );
                    return None;
                }
                Action::Ask {
                    ask,
                    question,
                    after: micros,
                }
            }
        })
    }
}

struct TriggerCtx<'a> {
    transition: &'a str,
    event: Option<&'a str>,
    params: Option<&'a [String]>,
}
