//! A draft as the editing page draws it: each net's places, transitions
//! and arcs with their positions — the stored one (`layout.toml`) for a
//! node a person moved, the automatic layout (`nets::layout`) for the
//! others — read from the TOML documents, so that a net is drawn while it
//! does not load. Pure.

use nets::layout::{layout_shape, Node, Shape, MARGIN};
use nets::model::PlaceRef;
use nets::svg::id;
use serde_json::{json, Value as Json};
use toml_edit::Item;

use super::draft::{strings, transitions, Draft};
use super::op::Kind;

/// The page's element id of a place or transition (as `nets::svg` names
/// them, so that the monitor's styles apply).
pub fn element_id(net: &str, kind: Kind, name: &str) -> String {
    let k = match kind {
        Kind::Place => "p",
        Kind::Transition => "t",
    };
    format!("{k}-{}-{}", id(net), id(name))
}

/// The drawing of net `n` of the draft.
pub fn sketch(draft: &Draft, n: usize) -> Json {
    let net = &draft.nets[n];
    let name = net.name();
    let root = net.doc.as_table();
    let mut places: Vec<String> = Vec::new();
    for p in strings(root, "places") {
        if !places.contains(&p) {
            places.push(p);
        }
    }
    let initial = strings(root, "initial");
    let finals = strings(root, "final");
    let ts = transitions(&net.doc);
    // Globals in first use order.
    let mut globals: Vec<String> = Vec::new();
    let place_ref = |p: &str, globals: &mut Vec<String>| -> Option<PlaceRef> {
        if let Some(g) = p.strip_prefix('@') {
            let i = globals.iter().position(|x| x == g).unwrap_or_else(|| {
                globals.push(g.to_owned());
                globals.len() - 1
            });
            Some(PlaceRef::Global(i))
        } else {
            places.iter().position(|x| x == p).map(PlaceRef::Local)
        }
    };
    let mut shape = Shape {
        initial: Vec::new(),
        transitions: Vec::new(),
    };
    for t in &ts {
        let inputs = strings(t, "from")
            .iter()
            .filter_map(|p| place_ref(p, &mut globals))
            .collect();
        let outputs = strings(t, "to")
            .iter()
            .filter_map(|p| place_ref(p, &mut globals))
            .collect();
        shape.transitions.push((inputs, outputs));
    }
    shape.initial = places.iter().map(|p| initial.contains(p)).collect();
    let l = layout_shape(&shape);
    let place_name = |r: PlaceRef| match r {
        PlaceRef::Local(i) => places[i].clone(),
        PlaceRef::Global(g) => format!("@{}", globals[g]),
    };
    let transition_name = |i: usize| {
        ts[i]
            .get("name")
            .and_then(Item::as_str)
            .unwrap_or("")
            .to_owned()
    };
    // Each node: where it is drawn, and whether a person put it there.
    let at: Vec<((f64, f64), bool)> = l
        .nodes
        .iter()
        .map(|p| {
            let stored = match p.node {
                Node::Place(r) => draft.positions.get(name, Kind::Place, &place_name(r)),
                Node::Transition(t) => {
                    draft
                        .positions
                        .get(name, Kind::Transition, &transition_name(t))
                }
                Node::Bend => None,
            };
            (stored.unwrap_or((p.x, p.y)), stored.is_some())
        })
        .collect();
    let mut place_nodes = Vec::new();
    let mut transition_nodes = Vec::new();
    for (v, p) in l.nodes.iter().enumerate() {
        let ((x, y), pinned) = at[v];
        match p.node {
            Node::Place(r) => {
                let pn = place_name(r);
                let global = matches!(r, PlaceRef::Global(_));
                place_nodes.push(json!({
                    "name": pn, "id": element_id(name, Kind::Place, &pn), "global": global,
                    "declared": !global || draft.globals.iter().any(|g| pn[1..] == *g),
                    "initial": initial.contains(&pn), "final": finals.contains(&pn),
                    "x": x, "y": y, "pinned": pinned,
                }));
            }
            Node::Transition(i) => {
                let t = ts[i];
                let tn = transition_name(i);
                let text = |k: &str| t.get(k).and_then(Item::as_str).unwrap_or("").to_owned();
                transition_nodes.push(json!({
                    "name": tn, "id": element_id(name, Kind::Transition, &tn),
                    "on": text("on"), "when": text("when"), "do": strings(t, "do"),
                    "from": strings(t, "from"), "to": strings(t, "to"),
                    "x": x, "y": y, "pinned": pinned,
                }));
            }
            Node::Bend => {}
        }
    }
    let arcs: Vec<Json> = l
        .arcs
        .iter()
        .map(|a| {
            let (place, transition) = if a.input {
                (a.from, a.to)
            } else {
                (a.to, a.from)
            };
            let (Node::Place(pr), Node::Transition(ti)) =
                (l.nodes[place].node, l.nodes[transition].node)
            else {
                return Json::Null;
            };
            let moved = at[a.from].1 || at[a.to].1;
            let points: Vec<(f64, f64)> = if moved {
                vec![at[a.from].0, at[a.to].0]
            } else {
                a.points.clone()
            };
            json!({"transition": transition_name(ti), "place": place_name(pr), "input": a.input,
                   "points": points})
        })
        .filter(|a| !a.is_null())
        .collect();
    let (mut width, mut height) = (l.width, l.height);
    for ((x, y), _) in &at {
        width = width.max(x + MARGIN);
        height = height.max(y + MARGIN);
    }
    json!({"name": name, "file": net.file, "active": draft.net_active(n), "width": width.max(200.0), "height": height.max(120.0),
           "places": place_nodes, "transitions": transition_nodes, "arcs": arcs})
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edit::op::Op;

    #[test]
    fn a_draft_is_drawn_with_stored_positions_winning_and_while_it_does_not_load() {
        let project = "[[net]]\nfile = \"a.toml\"\nactive = true\n[globals]\ng = false\n";
        let a = "name = \"A\"\nplaces = [\"idle\", \"busy\"]\ninitial = [\"idle\"]\n[[transition]]\nname = \"go\"\nfrom = [\"idle\"]\nto = [\"busy\", \"@g\"]\n";
        let mut d = Draft::parse(project, &[("a.toml".into(), a.into())], "")
            .unwrap_or_else(|e| panic!("{e}"));
        let s = sketch(&d, 0);
        assert_eq!(s["places"].as_array().map(Vec::len), Some(3), "{s}");
        assert_eq!(s["places"][2]["name"], "@g");
        assert_eq!(s["places"][2]["id"], "p-A-_g");
        assert_eq!(s["transitions"][0]["id"], "t-A-go");
        assert_eq!(s["arcs"].as_array().map(Vec::len), Some(3));
        assert_eq!(s["places"][0]["pinned"], false);
        // A transition without input (the loader refuses it) is drawn.
        d.apply(&Op::AddTransition {
            net: "A".into(),
            name: "loose".into(),
            at: Some((500.0, 300.0)),
        })
        .unwrap_or_else(|e| panic!("{e}"));
        let s = sketch(&d, 0);
        let loose = &s["transitions"][1];
        assert_eq!(
            (loose["x"].as_f64(), loose["y"].as_f64()),
            (Some(500.0), Some(300.0))
        );
        assert_eq!(loose["pinned"], true);
        assert!(s["width"].as_f64().unwrap_or(0.0) >= 540.0);
        // A moved node's arcs are straight to it.
        d.apply(&Op::Move {
            net: "A".into(),
            kind: Kind::Place,
            name: "busy".into(),
            x: 7.0,
            y: 9.0,
        })
        .unwrap_or_else(|e| panic!("{e}"));
        let s = sketch(&d, 0);
        let arc = s["arcs"]
            .as_array()
            .and_then(|a| a.iter().find(|a| a["place"] == "busy"))
            .cloned()
            .unwrap_or_default();
        assert_eq!(arc["points"].as_array().map(Vec::len), Some(2));
        assert_eq!(arc["points"][1], json!([7.0, 9.0]));
    }
}
