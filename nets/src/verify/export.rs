//! Petrel nets as PNML, and back.
//!
//! Each net is one PNML document that any P/T tool reads: a page `globals`
//! holds the project's global places (with their initial marking), a page
//! named after the net holds its places, its transitions, reference places
//! standing for the globals it uses, and the arcs. What a P/T net cannot say
//! travels in `<toolspecific tool="petrel" version="1">`: on the net, its
//! name and whether it starts active; on a place, whether it is final; on a
//! transition, its event, guard, `else` or priority and actions, as written
//! in the net file.
//! [`import_net`] reads such a document back into a net file.

use std::fmt::Write as _;

use super::pnml::{
    read_document, write_document, ArcNode, Document, NetDoc, Page, PlaceNode, PnmlError, Pos,
    ReferenceNode, ToolSpecific, TransitionNode, PTNET_TYPE,
};
use crate::model::{Choice, NetId, PlaceRef, Project};

/// The `tool` of Petrel's `<toolspecific>` elements.
pub const TOOL: &str = "petrel";
/// Their `version`.
pub const TOOL_VERSION: &str = "1";

fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}

fn petrel(content: String) -> Vec<ToolSpecific> {
    vec![ToolSpecific {
        tool: TOOL.to_owned(),
        version: TOOL_VERSION.to_owned(),
        content,
    }]
}

/// An XML id from a name (ids are NCNames: letters, digits, `_`, `-`, `.`).
fn xml_id(prefix: &str, parts: &[&str]) -> String {
    let mut id = prefix.to_owned();
    for p in parts {
        id.push('_');
        id.extend(p.chars().map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '-'
            }
        }));
    }
    id
}

/// One net of a project as a PNML document.
pub fn export_net(project: &Project, n: NetId) -> String {
    let net = &project.nets[n];
    let mut globals_page = Page {
        id: "globals".into(),
        name: Some("globals".into()),
        ..Page::default()
    };
    for g in &project.globals {
        globals_page.places.push(PlaceNode {
            id: xml_id("g", &[&g.name]),
            name: Some(g.name.clone()),
            initial_marking: u32::from(g.initial),
            toolspecific: Vec::new(),
            pos: Pos::default(),
        });
    }
    let mut page = Page {
        id: xml_id("page", &[&net.name]),
        name: Some(net.name.clone()),
        ..Page::default()
    };
    for p in &net.places {
        page.places.push(PlaceNode {
            id: xml_id("p", &[&net.name, &p.name]),
            name: Some(p.name.clone()),
            initial_marking: u32::from(p.initial),
            toolspecific: if p.is_final {
                petrel("<final/>".into())
            } else {
                Vec::new()
            },
            pos: Pos::default(),
        });
    }
    let mut used = vec![false; project.globals.len()];
    for t in &net.transitions {
        for p in t.inputs.iter().chain(&t.outputs) {
            if let PlaceRef::Global(g) = p {
                used[*g] = true;
            }
        }
    }
    for (g, global) in project.globals.iter().enumerate() {
        if used[g] {
            page.reference_places.push(ReferenceNode {
                id: xml_id("r", &[&net.name, &global.name]),
                name: Some(format!("@{}", global.name)),
                reference: xml_id("g", &[&global.name]),
                toolspecific: Vec::new(),
                pos: Pos::default(),
            });
        }
    }
    let place_id = |p: &PlaceRef| match p {
        PlaceRef::Local(l) => xml_id("p", &[&net.name, &net.places[*l].name]),
        PlaceRef::Global(g) => xml_id("r", &[&net.name, &project.globals[*g].name]),
    };
    let mut arc = 0usize;
    for t in &net.transitions {
        let tid = xml_id("t", &[&net.name, &t.name]);
        let mut content = String::new();
        if let Some(e) = &t.event {
            let _ = write!(content, "<event>{}</event>", escape(e));
        }
        if let Some(g) = &t.guard {
            let _ = write!(content, "<guard>{}</guard>", escape(&g.text));
        }
        match t.choice {
            Choice::Ordinary => {}
            Choice::Priority(p) => {
                let _ = write!(content, "<priority>{p}</priority>");
            }
            Choice::Else => content.push_str("<else/>"),
        }
        for a in &t.action_source {
            let _ = write!(content, "<action>{}</action>", escape(a));
        }
        page.transitions.push(TransitionNode {
            id: tid.clone(),
            name: Some(t.name.clone()),
            toolspecific: petrel(content),
            pos: Pos::default(),
        });
        for (from, to) in t
            .inputs
            .iter()
            .map(|p| (place_id(p), tid.clone()))
            .chain(t.outputs.iter().map(|p| (tid.clone(), place_id(p))))
        {
            arc += 1;
            page.arcs.push(ArcNode {
                id: format!("a{arc}"),
                source: from,
                target: to,
                weight: 1,
                toolspecific: Vec::new(),
                pos: Pos::default(),
            });
        }
    }
    let doc = Document {
        nets: vec![NetDoc {
            id: xml_id("net", &[&net.name]),
            net_type: PTNET_TYPE.to_owned(),
            name: Some(net.name.clone()),
            pages: vec![globals_page, page],
            toolspecific: petrel(format!(
                "<net name=\"{}\" active=\"{}\"/>",
                escape(&net.name),
                net.active_at_start
            )),
            pos: Pos::default(),
        }],
    };
    write_document(&doc)
}

/// Why a PNML document is not a Petrel net.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ImportError {
    #[error(transparent)]
    Pnml(#[from] PnmlError),
    #[error("{0}")]
    Petrel(String),
}

/// An element of Petrel's toolspecific content: tag, attributes, text.
type Item = (String, Vec<(String, String)>, String);

fn petrel_fragment(ts: &[ToolSpecific]) -> Result<Option<Vec<Item>>, ImportError> {
    let Some(t) = ts.iter().find(|t| t.tool == TOOL) else {
        return Ok(None);
    };
    let wrapped = format!("<x>{}</x>", t.content);
    let doc = roxmltree::Document::parse(&wrapped)
        .map_err(|e| ImportError::Petrel(format!("petrel toolspecific content: {e}")))?;
    Ok(Some(
        doc.root_element()
            .children()
            .filter(|c| c.is_element())
            .map(|c| {
                let attrs = c
                    .attributes()
                    .map(|a| (a.name().to_owned(), a.value().to_owned()))
                    .collect();
                (
                    c.tag_name().name().to_owned(),
                    attrs,
                    c.text().unwrap_or("").to_owned(),
                )
            })
            .collect(),
    ))
}

fn toml_string(s: &str) -> String {
    toml::Value::String(s.to_owned()).to_string()
}

fn toml_list(items: &[String]) -> String {
    let inner: Vec<String> = items.iter().map(|s| toml_string(s)).collect();
    format!("[{}]", inner.join(", "))
}

/// Reads a PNML document written by [`export_net`] back into the text of a
/// net file, and whether the net starts active.
pub fn import_net(text: &str) -> Result<(String, bool), ImportError> {
    let doc = read_document(text)?;
    let [net] = doc.nets.as_slice() else {
        return Err(ImportError::Petrel(format!(
            "expected one net, found {}",
            doc.nets.len()
        )));
    };
    let mut name = net.name.clone().unwrap_or_else(|| net.id.clone());
    let mut active = false;
    if let Some(items) = petrel_fragment(&net.toolspecific)? {
        for (tag, attrs, _) in items {
            if tag == "net" {
                for (k, v) in attrs {
                    match k.as_str() {
                        "name" => name = v,
                        "active" => active = v == "true",
                        _ => {}
                    }
                }
            }
        }
    }
    // Every page: globals are the places of the `globals` page; the rest
    // belong to the net.
    let mut globals: Vec<(String, String)> = Vec::new(); // (id, name)
    let mut places: Vec<(String, String, u32, bool)> = Vec::new(); // id, name, initial, final
    let mut refs: Vec<(String, String)> = Vec::new(); // id, referenced id
    let mut transitions: Vec<&TransitionNode> = Vec::new();
    let mut arcs: Vec<&ArcNode> = Vec::new();
    fn walk<'a>(
        page: &'a Page,
        globals: &mut Vec<(String, String)>,
        places: &mut Vec<(String, String, u32, bool)>,
        refs: &mut Vec<(String, String)>,
        transitions: &mut Vec<&'a TransitionNode>,
        arcs: &mut Vec<&'a ArcNode>,
    ) -> Result<(), ImportError> {
        for p in &page.places {
            let pname = p.name.clone().unwrap_or_else(|| p.id.clone());
            if page.id == "globals" {
                globals.push((p.id.clone(), pname));
            } else {
                let is_final = petrel_fragment(&p.toolspecific)?
                    .is_some_and(|items| items.iter().any(|(t, _, _)| t == "final"));
                places.push((p.id.clone(), pname, p.initial_marking, is_final));
            }
        }
        refs.extend(
            page.reference_places
                .iter()
                .map(|r| (r.id.clone(), r.reference.clone())),
        );
        transitions.extend(&page.transitions);
        arcs.extend(&page.arcs);
        for sub in &page.pages {
            walk(sub, globals, places, refs, transitions, arcs)?;
        }
        Ok(())
    }
    for page in &net.pages {
        walk(
            page,
            &mut globals,
            &mut places,
            &mut refs,
            &mut transitions,
            &mut arcs,
        )?;
    }
    // A place id as written in a net file: a local name, or `@global`.
    let resolve = |id: &str| -> Result<String, ImportError> {
        let mut id = id.to_owned();
        for _ in 0..=refs.len() {
            if let Some((_, target)) = refs.iter().find(|(r, _)| *r == id) {
                id = target.clone();
                continue;
            }
            if let Some((_, g)) = globals.iter().find(|(gid, _)| *gid == id) {
                return Ok(format!("@{g}"));
            }
            if let Some((_, n, _, _)) = places.iter().find(|(pid, ..)| *pid == id) {
                return Ok(n.clone());
            }
            break;
        }
        Err(ImportError::Petrel(format!(
            "arc end `{id}` is not a place"
        )))
    };
    let mut out = String::new();
    let _ = writeln!(out, "name = {}", toml_string(&name));
    let names: Vec<String> = places.iter().map(|p| p.1.clone()).collect();
    let initial: Vec<String> = places
        .iter()
        .filter(|p| p.2 > 0)
        .map(|p| p.1.clone())
        .collect();
    let finals: Vec<String> = places.iter().filter(|p| p.3).map(|p| p.1.clone()).collect();
    let _ = writeln!(out, "places = {}", toml_list(&names));
    let _ = writeln!(out, "initial = {}", toml_list(&initial));
    if !finals.is_empty() {
        let _ = writeln!(out, "final = {}", toml_list(&finals));
    }
    for t in transitions {
        let tname = t.name.clone().unwrap_or_else(|| t.id.clone());
        let mut from = Vec::new();
        let mut to = Vec::new();
        for a in &arcs {
            if a.target == t.id {
                from.push(resolve(&a.source)?);
            } else if a.source == t.id {
                to.push(resolve(&a.target)?);
            }
        }
        let _ = writeln!(out, "\n[[transition]]\nname = {}", toml_string(&tname));
        let _ = writeln!(out, "from = {}\nto = {}", toml_list(&from), toml_list(&to));
        let mut actions = Vec::new();
        if let Some(items) = petrel_fragment(&t.toolspecific)? {
            for (tag, _, text) in items {
                match tag.as_str() {
                    "event" => {
                        let _ = writeln!(out, "on = {}", toml_string(&text));
                    }
                    "guard" => {
                        let _ = writeln!(out, "when = {}", toml_string(&text));
                    }
                    "else" => {
                        let _ = writeln!(out, "else = true");
                    }
                    // A number as it is; anything else as a string, which
                    // the loader reports.
                    "priority" => match text.trim().parse::<i64>() {
                        Ok(p) => {
                            let _ = writeln!(out, "priority = {p}");
                        }
                        Err(_) => {
                            let _ = writeln!(out, "priority = {}", toml_string(&text));
                        }
                    },
                    "action" => actions.push(text),
                    _ => {}
                }
            }
        }
        if !actions.is_empty() {
            let _ = writeln!(out, "do = {}", toml_list(&actions));
        }
    }
    Ok((out, active))
}
