//! SVG drawings of nets laid out by [`crate::layout`], without Graphviz:
//! places as circles (a dot per token, marked places in red as EdiPet did),
//! transitions as bars labelled with their event and guard, arcs with
//! arrowheads, global places as double circles named `@name`. Each net is a
//! `<g class="net" data-net="NAME">` with ids on its places (`p-NET-place`)
//! and transitions (`t-NET-transition`), so that a page can restyle them.

use std::fmt::Write as _;

use crate::dot::Drawing;
use crate::layout::{layout, Node};
use crate::model::{PlaceRef, Project};

const RADIUS: f64 = 14.0;
const BAR: (f64, f64) = (8.0, 34.0);
/// The longest transition label drawn, in characters.
const LABEL: usize = 40;
/// Room for a net's title above its drawing.
const TITLE: f64 = 28.0;

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// An id fragment: letters, digits, `_` and `-` kept, anything else `_`.
pub fn id(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Draws the nets (all, or `drawing.net`) one below the other.
pub fn svg(project: &Project, drawing: &Drawing) -> String {
    let nets: Vec<usize> = match drawing.net {
        Some(n) => vec![n],
        None => (0..project.nets.len()).collect(),
    };
    let marked = |flat: usize| drawing.marked(project, flat);
    let layouts: Vec<_> = nets.iter().map(|&n| (n, layout(project, n))).collect();
    let width = layouts.iter().map(|(_, l)| l.width).fold(200.0, f64::max);
    let height: f64 = layouts.iter().map(|(_, l)| l.height + TITLE).sum();
    let mut out = String::new();
    let _ = writeln!(
        out,
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}" font-family="Helvetica, Arial, sans-serif" font-size="10">"##
    );
    out.push_str(
        r##"<defs><marker id="arrow" viewBox="0 0 10 10" refX="10" refY="5" markerWidth="7" markerHeight="7" orient="auto-start-reverse"><path d="M 0 0 L 10 5 L 0 10 z" fill="#444"/></marker></defs>
"##,
    );
    let mut top = 0.0;
    for (n, l) in &layouts {
        let net = &project.nets[*n];
        let _ = writeln!(
            out,
            r##"<g class="net" data-net="{}" transform="translate(0 {top:.1})"><text x="8" y="18" font-size="13" font-weight="bold">{}</text><g transform="translate(0 {TITLE})">"##,
            escape(&net.name),
            escape(&net.name)
        );
        // Arcs first, under the nodes, trimmed to the nodes' edges.
        for a in &l.arcs {
            let mut pts = a.points.clone();
            let trim = |from: (f64, f64), to: (f64, f64), node: Node| -> (f64, f64) {
                let (dx, dy) = (to.0 - from.0, to.1 - from.1);
                let len = (dx * dx + dy * dy).sqrt().max(1e-9);
                let r = match node {
                    Node::Place(_) => RADIUS + 1.0,
                    Node::Transition(_) => BAR.0 / 2.0 + 1.0,
                    Node::Bend => 0.0,
                };
                (to.0 - dx / len * r, to.1 - dy / len * r)
            };
            let k = pts.len();
            if k >= 2 {
                pts[k - 1] = trim(pts[k - 2], pts[k - 1], l.nodes[a.to].node);
                pts[0] = trim(pts[1], pts[0], l.nodes[a.from].node);
            }
            let d: Vec<String> = pts.iter().map(|(x, y)| format!("{x:.1},{y:.1}")).collect();
            let _ = writeln!(
                out,
                r##"<polyline class="arc{}" points="{}" fill="none" stroke="#444" marker-end="url(#arrow)"/>"##,
                if a.back { " back" } else { "" },
                d.join(" ")
            );
        }
        for p in &l.nodes {
            match p.node {
                Node::Bend => {}
                Node::Place(place) => {
                    let flat = project.flat(*n, place);
                    let (name, global, is_final) = match place {
                        PlaceRef::Local(i) => {
                            (net.places[i].name.clone(), false, net.places[i].is_final)
                        }
                        PlaceRef::Global(g) => {
                            (format!("@{}", project.globals[g].name), true, false)
                        }
                    };
                    let on = marked(flat);
                    let stroke = if on { "#c00" } else { "#222" };
                    let _ = write!(
                        out,
                        r##"<g class="place{}" id="p-{}-{}"><circle cx="{:.1}" cy="{:.1}" r="{RADIUS}" fill="{}" stroke="{stroke}" stroke-width="{}"/>"##,
                        if on { " marked" } else { "" },
                        id(&net.name),
                        id(&name),
                        p.x,
                        p.y,
                        if on { "#fdd" } else { "#fff" },
                        if is_final { 3 } else { 1 }
                    );
                    if global {
                        let _ = write!(
                            out,
                            r##"<circle cx="{:.1}" cy="{:.1}" r="{}" fill="none" stroke="{stroke}"/>"##,
                            p.x,
                            p.y,
                            RADIUS - 3.0
                        );
                    }
                    if on {
                        let _ = write!(
                            out,
                            r##"<circle class="token" cx="{:.1}" cy="{:.1}" r="4" fill="#c00"/>"##,
                            p.x, p.y
                        );
                    }
                    let _ = writeln!(
                        out,
                        r##"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text></g>"##,
                        p.x,
                        p.y + RADIUS + 12.0,
                        escape(&name)
                    );
                }
                Node::Transition(t) => {
                    let tr = &net.transitions[t];
                    let mut full = tr.event.clone().unwrap_or_else(|| "(immediate)".into());
                    if let Some(g) = &tr.guard {
                        full.push_str(&format!(" [{}]", g.text));
                    }
                    // Long guards are cut on the drawing; the whole text is
                    // the bar's title (shown on hover).
                    let label: String = if full.chars().count() > LABEL {
                        full.chars().take(LABEL - 1).chain(['…']).collect()
                    } else {
                        full.clone()
                    };
                    let _ = writeln!(
                        out,
                        r##"<g class="transition" id="t-{}-{}"><title>{}.{}: {}</title><rect x="{:.1}" y="{:.1}" width="{}" height="{}" fill="#222"/><text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text></g>"##,
                        id(&net.name),
                        id(&tr.name),
                        escape(&net.name),
                        escape(&tr.name),
                        escape(&full),
                        p.x - BAR.0 / 2.0,
                        p.y - BAR.1 / 2.0,
                        BAR.0,
                        BAR.1,
                        p.x,
                        p.y - BAR.1 / 2.0 - 4.0,
                        escape(&label)
                    );
                }
            }
        }
        out.push_str("</g></g>\n");
        top += l.height + TITLE;
    }
    out.push_str("</svg>\n");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_place_transition_and_arc_is_drawn_in_well_formed_svg() {
        let p = crate::load(&[
            (
                "project.toml",
                "[[net]]\nfile = \"n.toml\"\nactive = true\n[globals]\nbusy = false\n[events]\nx = { params = [\"alt\"] }\n",
            ),
            (
                "n.toml",
                "name = \"N1\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\nfinal = [\"b\"]\n\
                 [[transition]]\nname = \"go\"\nfrom = [\"a\"]\nto = [\"b\", \"@busy\"]\non = \"x\"\nwhen = 'alt < 3 && \"a\" == \"a\"'\n",
            ),
        ]);
        let p = match p {
            Ok(p) => p,
            Err(e) => panic!("{e}"),
        };
        let text = svg(&p, &Drawing::default());
        let doc = roxmltree::Document::parse(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
        let class = |c: &str| {
            doc.descendants()
                .filter(|n| {
                    n.attribute("class")
                        .is_some_and(|k| k.split(' ').any(|w| w == c))
                })
                .count()
        };
        assert_eq!(class("net"), 1);
        assert_eq!(class("place"), 3, "a, b and @busy");
        assert_eq!(class("transition"), 1);
        assert_eq!(class("arc"), 3);
        assert_eq!(class("marked"), 1, "the initial marking: a");
        assert!(text.contains("N1") && text.contains("@busy"));
        assert!(
            text.contains("x [alt &lt; 3 &amp;&amp; &quot;a&quot; == &quot;a&quot;]"),
            "{text}"
        );
    }
}
