//! Graphviz DOT drawings of nets: places as circles (a ● per token),
//! transitions as boxes labelled with their event, guard and actions, global
//! places shared between the nets that use them. Optionally with a marking,
//! coloured as EdiPet did (marked places in red).

use std::fmt::Write as _;

use crate::model::{NetId, PlaceRef, Project};

/// What to draw.
#[derive(Clone, Copy, Default)]
pub struct Drawing<'a> {
    /// Only this net (with the global places it touches); all nets if `None`.
    pub net: Option<NetId>,
    /// Marked places by flat index (see `Project::place_offsets`); the
    /// initial marking if `None`.
    pub marking: Option<&'a dyn Fn(usize) -> bool>,
}

impl Drawing<'_> {
    /// Whether flat place `flat` is marked in the drawing: by its marking,
    /// else in the project's initial marking.
    pub fn marked(&self, project: &Project, flat: usize) -> bool {
        match self.marking {
            Some(f) => f(flat),
            None => {
                if flat < project.globals.len() {
                    project.globals[flat].initial
                } else {
                    let n = project.place_offsets.partition_point(|&o| o <= flat) - 1;
                    let net = &project.nets[n];
                    net.active_at_start && net.places[flat - project.place_offsets[n]].initial
                }
            }
        }
    }
}

fn quote(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// Draws nets as one DOT digraph.
pub fn dot(project: &Project, drawing: &Drawing) -> String {
    let mut out = String::new();
    let title = match drawing.net {
        Some(n) => project.nets[n].name.clone(),
        None => project.name.clone(),
    };
    let _ = writeln!(out, "digraph {} {{", quote(&title));
    let _ = writeln!(out, "  rankdir=LR;");
    let _ = writeln!(out, "  node [fontname=\"Helvetica\", fontsize=10];");
    let marked = |flat: usize| drawing.marked(project, flat);
    let place_node =
        |out: &mut String, id: &str, name: &str, flat: usize, global: bool, is_final: bool| {
            let m = marked(flat);
            let label = if m {
                format!("{name}\n●")
            } else {
                name.to_owned()
            };
            let _ = writeln!(
                out,
                "  {} [shape={}, fixedsize=false, width=0.6, label={}{}{}];",
                quote(id),
                if is_final { "doublecircle" } else { "circle" },
                quote(&label),
                if global { ", style=dashed" } else { "" },
                if m { ", color=red, fontcolor=red" } else { "" },
            );
        };
    // Global places used by the drawn nets.
    let drawn: Vec<NetId> = match drawing.net {
        Some(n) => vec![n],
        None => (0..project.nets.len()).collect(),
    };
    let mut globals_used = vec![false; project.globals.len()];
    for &n in &drawn {
        for t in &project.nets[n].transitions {
            for p in t.inputs.iter().chain(&t.outputs) {
                if let PlaceRef::Global(g) = p {
                    globals_used[*g] = true;
                }
            }
        }
    }
    for (g, global) in project.globals.iter().enumerate() {
        if globals_used[g] {
            place_node(
                &mut out,
                &format!("@{}", global.name),
                &format!("@{}", global.name),
                g,
                true,
                false,
            );
        }
    }
    for &n in &drawn {
        let net = &project.nets[n];
        let _ = writeln!(
            out,
            "  subgraph {} {{",
            quote(&format!("cluster_{}", net.name))
        );
        let _ = writeln!(out, "    label={};", quote(&net.name));
        for (i, p) in net.places.iter().enumerate() {
            place_node(
                &mut out,
                &format!("{}.{}", net.name, p.name),
                &p.name,
                project.place_offsets[n] + i,
                false,
                p.is_final,
            );
        }
        for t in &net.transitions {
            let mut label = t.name.clone();
            match &t.event {
                Some(e) => label.push_str(&format!("\non {e}")),
                None => label.push_str("\n(immediate)"),
            }
            if let Some(g) = &t.guard {
                label.push_str(&format!("\nwhen {}", g.text));
            }
            for a in &t.action_source {
                label.push('\n');
                label.push_str(a);
            }
            let _ = writeln!(
                out,
                "    {} [shape=box, label={}];",
                quote(&format!("{}:{}", net.name, t.name)),
                quote(&label)
            );
        }
        let _ = writeln!(out, "  }}");
        let id = |p: &PlaceRef| match p {
            PlaceRef::Global(g) => format!("@{}", project.globals[*g].name),
            PlaceRef::Local(l) => format!("{}.{}", net.name, net.places[*l].name),
        };
        for t in &net.transitions {
            let tid = format!("{}:{}", net.name, t.name);
            for p in &t.inputs {
                let _ = writeln!(out, "  {} -> {};", quote(&id(p)), quote(&tid));
            }
            for p in &t.outputs {
                let _ = writeln!(out, "  {} -> {};", quote(&tid), quote(&id(p)));
            }
        }
    }
    out.push_str("}\n");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_places_tokens_transitions_and_arcs() {
        let files = [
            ("project.toml", "[events.e]\nparams = [\"mode\"]\n[globals]\nready = true\n[[net]]\nfile = \"n.toml\"\nactive = true\n"),
            (
                "n.toml",
                "name = \"N\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\nfinal = [\"b\"]\n[[transition]]\nname = \"go\"\nfrom = [\"a\", \"@ready\"]\nto = [\"b\"]\non = \"e\"\nwhen = 'mode == \"AUTO\"'\ndo = [\"timer w after 90s\", \"command takeoff {alt: 30}\"]\n",
            ),
        ];
        let project = crate::load(&files).expect("loads");
        let text = dot(&project, &Drawing::default());
        assert!(text.starts_with("digraph \"\" {\n  rankdir=LR;"), "{text}");
        assert!(text.contains("\"N.a\" [shape=circle, fixedsize=false, width=0.6, label=\"a\\n●\", color=red, fontcolor=red];"), "{text}");
        assert!(text.contains("\"N.b\" [shape=doublecircle"), "{text}");
        assert!(text.contains("\"@ready\" [shape=circle, fixedsize=false, width=0.6, label=\"@ready\\n●\", style=dashed, color=red, fontcolor=red];"), "{text}");
        assert!(text.contains("label=\"go\\non e\\nwhen mode == \\\"AUTO\\\"\\ntimer w after 90s\\ncommand takeoff {alt: 30}\""), "{text}");
        assert!(
            text.contains(
                "\"N.a\" -> \"N:go\";\n  \"@ready\" -> \"N:go\";\n  \"N:go\" -> \"N.b\";"
            ),
            "{text}"
        );
        // With another marking.
        let empty = |_: usize| false;
        let text = dot(
            &project,
            &Drawing {
                net: Some(0),
                marking: Some(&empty),
            },
        );
        assert!(!text.contains('●'));
    }
}
