//! What the player needs to know of each event name its project can
//! produce or await, worked out once per project: its declared category,
//! whether only the player may produce it, its vehicle and the transitions
//! waiting for it. The per-input path then does one hash lookup per
//! occurrence instead of string comparisons and ordered-map searches, and
//! builds no result name with `format!`. Every entry is what the functions
//! it replaces (`Project::declared_category`, `outside::player_own`,
//! `event_vehicle`, `Project::triggers`, `outside::own_timer`) give for
//! that name; a name outside the table takes those functions themselves.

use std::collections::HashMap;

use crate::event::Category;
use crate::model::{names, Action, NetId, Project, TransitionId, VehicleId};

/// What is known of one event name.
#[derive(Debug)]
pub(super) struct EventInfo {
    /// Its name.
    pub name: String,
    /// The project's declared category (`Project::declared_category`).
    pub declared: Option<Category>,
    /// Only the player produces it (`outside::player_own`): a result,
    /// an answer, `net_fault`.
    pub own: bool,
    /// The vehicle its name carries (`EVENT@VEHICLE`) in a team, for an
    /// occurrence without a target; never used for `net_fault`, whose
    /// vehicle is its parameter's.
    pub vehicle: Option<VehicleId>,
    /// `Project::triggers`: the transitions waiting for it, each with
    /// whether the name is its net's own timer (which only that timer's
    /// expiry delivers).
    pub waiting: Option<Vec<(NetId, TransitionId, bool)>>,
}

/// Every event name of a project, numbered.
#[derive(Debug)]
pub(super) struct Symbols {
    ids: HashMap<String, u32, foldhash::fast::FixedState>,
    events: Vec<EventInfo>,
    /// Per net, per timer: its name's number.
    pub timers: Vec<Vec<u32>>,
    /// Per program, per function: the numbers of `P.F.done` and `P.F.failed`.
    pub results: Vec<Vec<(u32, u32)>>,
    pub command_ok: u32,
    pub command_failed: u32,
    pub net_fault: u32,
    /// Every immediate transition, in the order the player tries them
    /// (nets in project order, each net's in file order).
    pub immediates: Vec<Immediate>,
}

/// An immediate transition, with its input places as marking words and
/// the bits they must have.
#[derive(Debug)]
pub(super) struct Immediate {
    pub net: NetId,
    pub transition: TransitionId,
    pub inputs: smallvec::SmallVec<[(usize, u64); 2]>,
}

impl Immediate {
    /// Whether every input place is marked in `marking`.
    pub fn enabled(&self, marking: &[u64]) -> bool {
        self.inputs
            .iter()
            .all(|&(word, bits)| marking[word] & bits == bits)
    }
}

impl Symbols {
    pub fn new(project: &Project) -> Symbols {
        let mut symbols = Symbols {
            ids: HashMap::default(),
            events: Vec::new(),
            timers: Vec::new(),
            results: Vec::new(),
            command_ok: 0,
            command_failed: 0,
            net_fault: 0,
            immediates: Vec::new(),
        };
        for (n, net) in project.nets.iter().enumerate() {
            for &t in &net.immediate {
                let mut inputs: smallvec::SmallVec<[(usize, u64); 2]> = Default::default();
                for &p in &net.transitions[t].flat_inputs {
                    let (word, bit) = (p / 64, 1u64 << (p % 64));
                    match inputs.iter_mut().find(|(w, _)| *w == word) {
                        Some((_, bits)) => *bits |= bit,
                        None => inputs.push((word, bit)),
                    }
                }
                symbols.immediates.push(Immediate {
                    net: n,
                    transition: t,
                    inputs,
                });
            }
        }
        symbols.command_ok = symbols.add(project, names::COMMAND_OK);
        symbols.command_failed = symbols.add(project, names::COMMAND_FAILED);
        symbols.net_fault = symbols.add(project, names::NET_FAULT);
        symbols.timers = project
            .nets
            .iter()
            .map(|n| n.timers.iter().map(|t| symbols.add(project, t)).collect())
            .collect();
        symbols.results = project
            .programs
            .iter()
            .map(|p| {
                p.functions
                    .iter()
                    .map(|f| {
                        let base = format!("{}.{}", p.name, f.name);
                        (
                            symbols.add(project, &format!("{base}.{}", names::DONE)),
                            symbols.add(project, &format!("{base}.{}", names::FAILED)),
                        )
                    })
                    .collect()
            })
            .collect();
        let mut more: Vec<String> = project.triggers.keys().cloned().collect();
        more.extend(project.events.keys().cloned());
        for net in &project.nets {
            for ask in &net.asks {
                more.extend(ask.choices.iter().map(|c| ask.answer_event(c)));
                more.push(ask.answer_event(crate::model::ASK_TIMEOUT));
            }
            for action in net.transitions.iter().flat_map(|t| &t.actions) {
                if let Action::Emit { event, .. } = action {
                    more.push(event.clone());
                }
            }
        }
        more.sort();
        for name in more {
            symbols.add(project, &name);
        }
        symbols
    }

    /// The number of `name`, added if new.
    fn add(&mut self, project: &Project, name: &str) -> u32 {
        if let Some(&id) = self.ids.get(name) {
            return id;
        }
        let id = self.events.len() as u32;
        let waiting = project.triggers.get(name).map(|list| {
            list.iter()
                .map(|&(n, t)| (n, t, crate::outside::own_timer(project, n, name)))
                .collect()
        });
        self.events.push(EventInfo {
            name: name.to_owned(),
            declared: project.declared_category(name),
            own: crate::outside::player_own(project, name).is_some(),
            vehicle: if project.vehicles.is_empty() {
                None
            } else {
                project.vehicle_event(name).map(|(_, v)| v)
            },
            waiting,
        });
        self.ids.insert(name.to_owned(), id);
        id
    }

    /// What is known of `name`, if the project knows it.
    pub fn get(&self, name: &str) -> Option<&EventInfo> {
        self.ids.get(name).map(|&id| &self.events[id as usize])
    }

    /// The name numbered `id`.
    pub fn info(&self, id: u32) -> &EventInfo {
        &self.events[id as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    #[test]
    fn every_entry_is_what_the_functions_it_replaces_give() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples");
        for example in ["uav-flight-test", "uav-survey", "ugv-bottleneck"] {
            let mut files = BTreeMap::new();
            let folder = dir.join(example);
            for entry in std::fs::read_dir(&folder).expect("example").flatten() {
                let name = entry.file_name().to_string_lossy().into_owned();
                if name.ends_with(".toml") {
                    let text = std::fs::read_to_string(entry.path()).expect("file");
                    files.insert(name, text);
                }
            }
            let project = crate::load(&files).expect("loads");
            let symbols = Symbols::new(&project);
            assert!(symbols.events.len() > 10, "{example}");
            for (id, info) in symbols.events.iter().enumerate() {
                let name = info.name.as_str();
                assert_eq!(symbols.get(name).map(|i| i.name.as_str()), Some(name));
                assert_eq!(symbols.info(id as u32).name, name);
                assert_eq!(info.declared, project.declared_category(name), "{name}");
                assert_eq!(
                    info.own,
                    crate::outside::player_own(&project, name).is_some(),
                    "{name}"
                );
                let params = crate::value::Params::new();
                if name != names::NET_FAULT {
                    assert_eq!(
                        info.vehicle,
                        super::super::event_vehicle(&project, name, &params, None),
                        "{name}"
                    );
                }
                let waiting: Option<Vec<(NetId, TransitionId)>> = info
                    .waiting
                    .as_ref()
                    .map(|w| w.iter().map(|&(n, t, _)| (n, t)).collect());
                assert_eq!(waiting.as_ref(), project.triggers.get(name), "{name}");
            }
            assert!(symbols.get("no such event").is_none());
            for (n, timers) in symbols.timers.iter().enumerate() {
                for (i, &id) in timers.iter().enumerate() {
                    assert_eq!(symbols.info(id).name, project.nets[n].timers[i]);
                }
            }
        }
    }
}
