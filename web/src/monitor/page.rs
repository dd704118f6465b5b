//! The page's fixed part: the project as drawn — each net's SVG (Petrel's
//! own layout, `nets::svg`), its places and transitions with their
//! definitions (file:line, event, guard, actions), the global places, the
//! hierarchy (which net activates which, and each net's level), and the
//! team: its vehicles (name, system) and each net's vehicle (an instance's;
//! null for a team net and in a project without a team).

use std::collections::VecDeque;
use std::path::Path;

use nets::dot::Drawing;
use nets::model::{Action, PlaceRef};
use nets::Project;
use serde_json::{json, Value as Json};

/// The line (from 1) of the first line of `text` at or after `from` that
/// satisfies `hit`.
fn line_of(text: &str, from: usize, hit: impl Fn(&str) -> bool) -> Option<usize> {
    text.lines()
        .enumerate()
        .skip(from)
        .find(|(_, l)| hit(l))
        .map(|(i, _)| i + 1)
}

fn quoted(name: &str) -> String {
    format!("\"{name}\"")
}

/// The line declaring transition `name` in a net file: its `name = "…"`
/// after a `[[transition]]` header.
fn transition_line(text: &str, name: &str) -> Option<usize> {
    let mut in_transition = false;
    for (i, l) in text.lines().enumerate() {
        let t = l.trim();
        if t.starts_with('[') {
            in_transition = t == "[[transition]]";
        }
        if in_transition && t.starts_with("name") && t.contains(&quoted(name)) {
            return Some(i + 1);
        }
    }
    None
}

/// Each net's level: 0 for a net no other net activates, then one more
/// than the net that activates it (first found, breadth first).
fn levels(project: &Project, activates: &[Vec<usize>]) -> Vec<Option<usize>> {
    let n = project.nets.len();
    let mut level = vec![None; n];
    let mut queue = VecDeque::new();
    for (i, l) in level.iter_mut().enumerate() {
        if !activates
            .iter()
            .enumerate()
            .any(|(a, to)| a != i && to.contains(&i))
        {
            *l = Some(0);
            queue.push_back(i);
        }
    }
    while let Some(a) = queue.pop_front() {
        let next = level[a].map_or(0, |l| l + 1);
        for &b in &activates[a] {
            if level[b].is_none() {
                level[b] = Some(next);
                queue.push_back(b);
            }
        }
    }
    level
}

/// The project as the page draws it. `dir` is the project folder, read for
/// the definitions' line numbers (none without it).
pub fn page(project: &Project, dir: Option<&Path>, mode: &str) -> Json {
    let read = |file: &str| dir.and_then(|d| std::fs::read_to_string(d.join(file)).ok());
    let activates: Vec<Vec<usize>> = project
        .nets
        .iter()
        .map(|net| {
            let mut to: Vec<usize> = net
                .transitions
                .iter()
                .flat_map(|t| &t.actions)
                .filter_map(|a| match a {
                    Action::Activate(n) => Some(*n),
                    _ => None,
                })
                .collect();
            to.sort_unstable();
            to.dedup();
            to
        })
        .collect();
    let level = levels(project, &activates);
    let project_text = read("project.toml");
    let globals: Vec<Json> = project
        .globals
        .iter()
        .enumerate()
        .map(|(g, global)| {
            let line = project_text.as_deref().and_then(|t| {
                line_of(t, 0, |l| {
                    l.trim_start().starts_with(&format!("{} ", global.name))
                })
            });
            let users: Vec<&str> = project
                .nets
                .iter()
                .filter(|net| {
                    net.transitions.iter().any(|t| {
                        t.inputs
                            .iter()
                            .chain(&t.outputs)
                            .any(|p| *p == PlaceRef::Global(g))
                    })
                })
                .map(|net| net.name.as_str())
                .collect();
            json!({"name": global.name, "flat": g, "initial": global.initial,
                   "file": "project.toml", "line": line, "nets": users})
        })
        .collect();
    let mut flat_transition = 0;
    let nets: Vec<Json> = project
        .nets
        .iter()
        .enumerate()
        .map(|(n, net)| {
            let text = read(&net.file);
            let net_id = nets::svg::id(&net.name);
            let place_name = |p: &PlaceRef| match p {
                PlaceRef::Local(i) => net.places[*i].name.clone(),
                PlaceRef::Global(g) => format!("@{}", project.globals[*g].name),
            };
            let mut places: Vec<Json> = net
                .places
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let line = text.as_deref().and_then(|t| {
                        line_of(t, 0, |l| {
                            l.trim_start().starts_with("places") && l.contains(&quoted(&p.name))
                        })
                        .or_else(|| line_of(t, 0, |l| l.contains(&quoted(&p.name))))
                    });
                    json!({"id": format!("p-{net_id}-{}", nets::svg::id(&p.name)), "name": p.name,
                           "flat": project.flat(n, PlaceRef::Local(i)), "global": false,
                           "initial": p.initial, "final": p.is_final, "file": net.file, "line": line})
                })
                .collect();
            // The global places it uses, once each.
            let mut used: Vec<usize> = net
                .transitions
                .iter()
                .flat_map(|t| t.inputs.iter().chain(&t.outputs))
                .filter_map(|p| match p {
                    PlaceRef::Global(g) => Some(*g),
                    PlaceRef::Local(_) => None,
                })
                .collect();
            used.sort_unstable();
            used.dedup();
            for g in used {
                let name = format!("@{}", project.globals[g].name);
                places.push(json!({"id": format!("p-{net_id}-{}", nets::svg::id(&name)), "name": name,
                                   "flat": g, "global": true, "file": "project.toml",
                                   "line": globals[g]["line"]}));
            }
            let transitions: Vec<Json> = net
                .transitions
                .iter()
                .map(|t| {
                    let line = text.as_deref().and_then(|x| transition_line(x, &t.name));
                    let v = json!({"id": format!("t-{net_id}-{}", nets::svg::id(&t.name)),
                           "name": t.name, "flat": flat_transition, "event": t.event,
                           "guard": t.guard.as_ref().map(|g| g.text.clone()),
                           "actions": t.action_source,
                           "inputs": t.inputs.iter().map(place_name).collect::<Vec<_>>(),
                           "outputs": t.outputs.iter().map(place_name).collect::<Vec<_>>(),
                           "file": net.file, "line": line});
                    flat_transition += 1;
                    v
                })
                .collect();
            let svg = nets::svg::svg(
                project,
                &Drawing {
                    net: Some(n),
                    marking: None,
                },
            );
            let vehicle = net
                .vehicle
                .and_then(|v| project.vehicles.get(v))
                .map(|v| v.name.as_str());
            json!({"name": net.name, "vehicle": vehicle, "file": net.file, "active_at_start": net.active_at_start,
                   "level": level[n], "activates": activates[n].iter().map(|&a| &project.nets[a].name).collect::<Vec<_>>(),
                   "places": places, "transitions": transitions, "svg": svg})
        })
        .collect();
    let vehicles: Vec<Json> = project
        .vehicles
        .iter()
        .map(|v| json!({"name": v.name, "system": v.system, "component": v.component}))
        .collect();
    json!({"mode": mode, "name": project.name, "description": project.description,
           "vehicles": vehicles, "globals": globals, "nets": nets, "place_count": project.place_count,
           "transition_count": flat_transition, "petrel": env!("CARGO_PKG_VERSION")})
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn definitions_are_found_and_levels_follow_activation() {
        let net_a = "name = \"A\"\nplaces = [\"idle\", \"on\"]\ninitial = [\"idle\"]\n\n[[transition]]\nname = \"go\"\nfrom = [\"idle\"]\nto = [\"on\"]\non = \"x\"\ndo = [\"activate B\"]\n";
        let net_b = "name = \"B\"\nplaces = [\"s\"]\ninitial = [\"s\"]\n";
        let files = [
            ("project.toml", "[[net]]\nfile = \"a.toml\"\nactive = true\n[[net]]\nfile = \"b.toml\"\n[events]\nx = {}\n"),
            ("a.toml", net_a),
            ("b.toml", net_b),
        ];
        let project = nets::load(&files).unwrap_or_else(|e| panic!("{e}"));
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        for (name, text) in files {
            std::fs::write(dir.path().join(name), text).unwrap_or_else(|e| panic!("{e}"));
        }
        let p = page(&project, Some(dir.path()), "live");
        assert_eq!(p["nets"][0]["level"], 0);
        assert_eq!(p["nets"][1]["level"], 1);
        assert_eq!(p["nets"][0]["activates"], json!(["B"]));
        let go = &p["nets"][0]["transitions"][0];
        assert_eq!(go["line"], 6, "{go}: its `name = \"go\"` line");
        assert_eq!(go["id"], "t-A-go");
        assert_eq!(go["actions"], json!(["activate B"]));
        assert_eq!(p["nets"][0]["places"][1]["line"], 2);
        let svg = p["nets"][0]["svg"].as_str().unwrap_or("");
        for id in ["t-A-go", "p-A-idle", "p-A-on"] {
            assert!(svg.contains(&format!("id=\"{id}\"")), "{id} not in {svg}");
        }
    }

    #[test]
    fn the_team_and_each_nets_vehicle_are_said() {
        let files = [
            (
                "project.toml",
                "[[vehicle]]\nname = \"R1\"\nsystem = 1\n[[vehicle]]\nname = \"R2\"\nsystem = 2\ncomponent = 3\n\
                 [[net]]\nfile = \"t.toml\"\nactive = true\n[[net]]\nfile = \"a.toml\"\nactive = true\n[events]\nx = {}\n",
            ),
            ("t.toml", "name = \"T\"\nplaces = [\"s\"]\ninitial = [\"s\"]\n"),
            (
                "a.toml",
                "name = \"A\"\nvehicles = \"all\"\nplaces = [\"s\"]\ninitial = [\"s\"]\n",
            ),
        ];
        let project = nets::load(&files).unwrap_or_else(|e| panic!("{e}"));
        let p = page(&project, None, "live");
        assert_eq!(
            p["vehicles"],
            json!([{"name": "R1", "system": 1, "component": 1},
                   {"name": "R2", "system": 2, "component": 3}])
        );
        let nets: Vec<(Json, Json)> = p["nets"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|n| (n["name"].clone(), n["vehicle"].clone()))
            .collect();
        assert_eq!(
            nets,
            vec![
                (json!("T"), Json::Null),
                (json!("A@R1"), json!("R1")),
                (json!("A@R2"), json!("R2")),
            ]
        );
        // Without a team: no vehicles, no net's vehicle.
        let one = page(&super::super::board::tests::project(), None, "live");
        assert_eq!(one["vehicles"], json!([]));
        assert_eq!(one["nets"][0]["vehicle"], Json::Null);
    }
}
