//! PNML (ISO/IEC 15909-2) for place/transition nets: a small document model
//! ([`Document`]), a reader ([`read_document`], [`read_ptnet`]) and a writer
//! ([`write_document`], [`write_ptnet`]).
//!
//! The document model keeps what the standard structures: nested pages,
//! reference places and transitions, arcs with weights, and `<toolspecific>`
//! payloads on every node (kept verbatim, so Petrel can carry its events and
//! actions through files other tools read). [`NetDoc::to_ptnet`] flattens a
//! net: pages dissolved, references resolved (chains too), arcs merged into
//! weighted pre/post sets. `<graphics>` and unknown elements are ignored.
//!
//! No file I/O: the reader takes the text, the writer returns it. Every error
//! carries the line and column where it was found; bad input never panics.

use std::collections::{HashMap, HashSet};
use std::fmt::Write as _;

use super::ptnet::{normalize_arcs, PtNet};

/// The PNML namespace written on `<pnml>`.
pub const PNML_NAMESPACE: &str = "http://www.pnml.org/version-2009/grammar/pnml";
/// The net type of P/T nets.
pub const PTNET_TYPE: &str = "http://www.pnml.org/version-2009/grammar/ptnet";

/// A position in the text (1-based); 0:0 for nodes built in memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Pos {
    pub line: u32,
    pub col: u32,
}

/// A `<toolspecific tool version>` payload: its inner XML, verbatim.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ToolSpecific {
    pub tool: String,
    pub version: String,
    /// The element's content as XML text (a well-formed fragment).
    pub content: String,
}

/// A `<place>`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct PlaceNode {
    pub id: String,
    pub name: Option<String>,
    pub initial_marking: u32,
    pub toolspecific: Vec<ToolSpecific>,
    pub pos: Pos,
}

/// A `<transition>`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct TransitionNode {
    pub id: String,
    pub name: Option<String>,
    pub toolspecific: Vec<ToolSpecific>,
    pub pos: Pos,
}

/// A `<referencePlace>` or `<referenceTransition>`: a node standing for the
/// node whose id is `reference` (possibly another reference).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ReferenceNode {
    pub id: String,
    pub name: Option<String>,
    pub reference: String,
    pub toolspecific: Vec<ToolSpecific>,
    pub pos: Pos,
}

/// An `<arc>` with its inscription as a weight (1 when absent).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ArcNode {
    pub id: String,
    pub source: String,
    pub target: String,
    pub weight: u32,
    pub toolspecific: Vec<ToolSpecific>,
    pub pos: Pos,
}

/// A `<page>`: nodes and nested pages.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Page {
    pub id: String,
    pub name: Option<String>,
    pub places: Vec<PlaceNode>,
    pub transitions: Vec<TransitionNode>,
    pub reference_places: Vec<ReferenceNode>,
    pub reference_transitions: Vec<ReferenceNode>,
    pub arcs: Vec<ArcNode>,
    pub pages: Vec<Page>,
    pub toolspecific: Vec<ToolSpecific>,
    pub pos: Pos,
}

/// A `<net>`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct NetDoc {
    pub id: String,
    pub net_type: String,
    pub name: Option<String>,
    pub pages: Vec<Page>,
    pub toolspecific: Vec<ToolSpecific>,
    pub pos: Pos,
}

/// A PNML document: one or more nets.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Document {
    pub nets: Vec<NetDoc>,
}

/// A PNML problem, with where it was found.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}:{}: {kind}", pos.line, pos.col)]
pub struct PnmlError {
    pub pos: Pos,
    pub kind: PnmlErrorKind,
}

/// What is wrong in a PNML text.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PnmlErrorKind {
    #[error("malformed XML: {0}")]
    Xml(String),
    #[error("the root element is <{0}>, expected <pnml>")]
    NotPnml(String),
    #[error("the document holds no <net>")]
    NoNet,
    #[error("the document holds {0} nets, expected one")]
    SeveralNets(usize),
    #[error("the net type is `{0}`, expected a P/T net ({PTNET_TYPE})")]
    NotPtNet(String),
    #[error("<{element}> has no `{attribute}` attribute")]
    MissingAttribute {
        element: String,
        attribute: &'static str,
    },
    #[error("id `{0}` is used twice")]
    DuplicateId(String),
    #[error("{what} `{text}` is not a natural number")]
    BadNumber { what: &'static str, text: String },
    #[error("arc `{0}` has weight 0")]
    ZeroWeight(String),
    #[error("arc `{arc}`: {end} `{node}` is not a node of the net")]
    DanglingArc {
        arc: String,
        end: &'static str,
        node: String,
    },
    #[error("arc `{0}` must join a place and a transition")]
    ArcSameKind(String),
    #[error("reference `{id}` points to `{target}`, which is not a {expected} of the net")]
    UnknownReference {
        id: String,
        target: String,
        expected: &'static str,
    },
    #[error("reference `{0}` is part of a cycle of references")]
    ReferenceCycle(String),
}

fn err(pos: Pos, kind: PnmlErrorKind) -> PnmlError {
    PnmlError { pos, kind }
}

// ---------------------------------------------------------------- reading

/// Reads a PNML text holding exactly one P/T net and flattens it.
pub fn read_ptnet(text: &str) -> Result<PtNet, PnmlError> {
    let doc = read_document(text)?;
    match doc.nets.len() {
        0 => Err(err(Pos { line: 1, col: 1 }, PnmlErrorKind::NoNet)),
        1 => doc.nets[0].to_ptnet(),
        n => Err(err(doc.nets[1].pos, PnmlErrorKind::SeveralNets(n))),
    }
}

/// Reads a PNML text into the document model (no flattening, no checks of
/// references or arcs; [`NetDoc::to_ptnet`] does those).
pub fn read_document(text: &str) -> Result<Document, PnmlError> {
    let xml = roxmltree::Document::parse(text).map_err(|e| {
        let p = e.pos();
        err(
            Pos {
                line: p.row,
                col: p.col,
            },
            PnmlErrorKind::Xml(xml_message(&e)),
        )
    })?;
    let line_starts = std::iter::once(0)
        .chain(text.match_indices('\n').map(|(i, _)| i + 1))
        .collect();
    let reader = Reader { text, line_starts };
    let root = xml.root_element();
    if root.tag_name().name() != "pnml" {
        return Err(err(
            reader.pos(root),
            PnmlErrorKind::NotPnml(root.tag_name().name().to_string()),
        ));
    }
    let mut doc = Document::default();
    for net in elements(root, "net") {
        doc.nets.push(reader.net(net)?);
    }
    Ok(doc)
}

/// roxmltree's message without its trailing " at L:C" (we print our own).
fn xml_message(e: &roxmltree::Error) -> String {
    let s = e.to_string();
    match s.rfind(" at ") {
        Some(i) if s[i + 4..].chars().all(|c| c.is_ascii_digit() || c == ':') => s[..i].to_string(),
        _ => s,
    }
}

fn elements<'a, 'i>(
    node: roxmltree::Node<'a, 'i>,
    name: &'static str,
) -> impl Iterator<Item = roxmltree::Node<'a, 'i>> {
    node.children()
        .filter(move |c| c.is_element() && c.tag_name().name() == name)
}

struct Reader<'i> {
    text: &'i str,
    /// Byte offset where each line starts.
    line_starts: Vec<usize>,
}

impl<'a, 'i> Reader<'i> {
    /// The line and column (in characters) of `node`'s start.
    fn pos(&self, node: roxmltree::Node) -> Pos {
        let at = node.range().start;
        let line = self
            .line_starts
            .partition_point(|&start| start <= at)
            .max(1);
        let start = self.line_starts[line - 1];
        let col = self.text.get(start..at).map_or(0, |s| s.chars().count()) + 1;
        Pos {
            line: line as u32,
            col: col as u32,
        }
    }

    fn attr(&self, node: roxmltree::Node, attribute: &'static str) -> Result<String, PnmlError> {
        node.attribute(attribute)
            .map(str::to_string)
            .ok_or_else(|| {
                err(
                    self.pos(node),
                    PnmlErrorKind::MissingAttribute {
                        element: node.tag_name().name().to_string(),
                        attribute,
                    },
                )
            })
    }

    /// The text of `<child><text>…</text></child>`, trimmed, with its position.
    fn labelled_text(
        &self,
        node: roxmltree::Node<'a, 'i>,
        child: &'static str,
    ) -> Option<(String, Pos)> {
        let c = elements(node, child).next()?;
        let t = elements(c, "text").next()?;
        Some((t.text().unwrap_or("").trim().to_string(), self.pos(t)))
    }

    fn name(&self, node: roxmltree::Node<'a, 'i>) -> Option<String> {
        self.labelled_text(node, "name").map(|(s, _)| s)
    }

    fn number(
        &self,
        node: roxmltree::Node<'a, 'i>,
        child: &'static str,
        what: &'static str,
    ) -> Result<Option<u32>, PnmlError> {
        match self.labelled_text(node, child) {
            None => Ok(None),
            Some((s, pos)) => s
                .parse::<u32>()
                .map(Some)
                .map_err(|_| err(pos, PnmlErrorKind::BadNumber { what, text: s })),
        }
    }

    fn toolspecific(&self, node: roxmltree::Node<'a, 'i>) -> Result<Vec<ToolSpecific>, PnmlError> {
        elements(node, "toolspecific")
            .map(|ts| {
                let content = match (ts.first_child(), ts.last_child()) {
                    (Some(first), Some(last)) => {
                        self.text[first.range().start..last.range().end].to_string()
                    }
                    _ => String::new(),
                };
                Ok(ToolSpecific {
                    tool: self.attr(ts, "tool")?,
                    version: self.attr(ts, "version")?,
                    content,
                })
            })
            .collect()
    }

    fn net(&self, node: roxmltree::Node<'a, 'i>) -> Result<NetDoc, PnmlError> {
        let mut pages = Vec::new();
        for p in elements(node, "page") {
            pages.push(self.page(p)?);
        }
        Ok(NetDoc {
            id: self.attr(node, "id")?,
            net_type: self.attr(node, "type")?,
            name: self.name(node),
            pages,
            toolspecific: self.toolspecific(node)?,
            pos: self.pos(node),
        })
    }

    fn reference(&self, c: roxmltree::Node<'a, 'i>) -> Result<ReferenceNode, PnmlError> {
        Ok(ReferenceNode {
            id: self.attr(c, "id")?,
            name: self.name(c),
            reference: self.attr(c, "ref")?,
            toolspecific: self.toolspecific(c)?,
            pos: self.pos(c),
        })
    }

    fn page(&self, node: roxmltree::Node<'a, 'i>) -> Result<Page, PnmlError> {
        let mut page = Page {
            id: self.attr(node, "id")?,
            name: self.name(node),
            toolspecific: self.toolspecific(node)?,
            pos: self.pos(node),
            ..Page::default()
        };
        for c in node.children().filter(|c| c.is_element()) {
            match c.tag_name().name() {
                "place" => page.places.push(PlaceNode {
                    id: self.attr(c, "id")?,
                    name: self.name(c),
                    initial_marking: self
                        .number(c, "initialMarking", "initial marking")?
                        .unwrap_or(0),
                    toolspecific: self.toolspecific(c)?,
                    pos: self.pos(c),
                }),
                "transition" => page.transitions.push(TransitionNode {
                    id: self.attr(c, "id")?,
                    name: self.name(c),
                    toolspecific: self.toolspecific(c)?,
                    pos: self.pos(c),
                }),
                "referencePlace" => page.reference_places.push(self.reference(c)?),
                "referenceTransition" => page.reference_transitions.push(self.reference(c)?),
                "arc" => {
                    let id = self.attr(c, "id")?;
                    let weight = self
                        .number(c, "inscription", "arc inscription")?
                        .unwrap_or(1);
                    if weight == 0 {
                        return Err(err(self.pos(c), PnmlErrorKind::ZeroWeight(id)));
                    }
                    page.arcs.push(ArcNode {
                        id,
                        source: self.attr(c, "source")?,
                        target: self.attr(c, "target")?,
                        weight,
                        toolspecific: self.toolspecific(c)?,
                        pos: self.pos(c),
                    });
                }
                "page" => page.pages.push(self.page(c)?),
                _ => {}
            }
        }
        Ok(page)
    }
}

// ---------------------------------------------------------------- flattening

#[derive(Clone, Copy)]
enum Node<'d> {
    Place(usize),
    Transition(usize),
    RefPlace(&'d ReferenceNode),
    RefTransition(&'d ReferenceNode),
    Arc,
    Page,
}

fn claim<'d>(
    ids: &mut HashMap<&'d str, Node<'d>>,
    id: &'d str,
    pos: Pos,
    node: Node<'d>,
) -> Result<(), PnmlError> {
    match ids.insert(id, node) {
        Some(_) => Err(err(pos, PnmlErrorKind::DuplicateId(id.to_string()))),
        None => Ok(()),
    }
}

/// Follows a chain of references to the place or transition it stands for.
fn resolve<'d>(ids: &HashMap<&'d str, Node<'d>>, start: Node<'d>) -> Result<Node<'d>, PnmlError> {
    let mut node = start;
    let mut steps = 0usize;
    loop {
        let (r, expected) = match node {
            Node::RefPlace(r) => (r, "place"),
            Node::RefTransition(r) => (r, "transition"),
            other => return Ok(other),
        };
        steps += 1;
        if steps > ids.len() {
            let first = match start {
                Node::RefPlace(s) | Node::RefTransition(s) => s,
                _ => r,
            };
            return Err(err(
                first.pos,
                PnmlErrorKind::ReferenceCycle(first.id.clone()),
            ));
        }
        node = match (ids.get(r.reference.as_str()).copied(), expected) {
            (Some(n @ (Node::Place(_) | Node::RefPlace(_))), "place") => n,
            (Some(n @ (Node::Transition(_) | Node::RefTransition(_))), "transition") => n,
            _ => {
                return Err(err(
                    r.pos,
                    PnmlErrorKind::UnknownReference {
                        id: r.id.clone(),
                        target: r.reference.clone(),
                        expected,
                    },
                ))
            }
        };
    }
}

impl NetDoc {
    /// Flattens the net into a [`PtNet`]: pages dissolved, references resolved.
    pub fn to_ptnet(&self) -> Result<PtNet, PnmlError> {
        if !self.net_type.ends_with("ptnet") {
            return Err(err(
                self.pos,
                PnmlErrorKind::NotPtNet(self.net_type.clone()),
            ));
        }
        let mut net = PtNet::new(self.id.clone());
        if let Some(n) = &self.name {
            net.name = n.clone();
        }
        let mut pages: Vec<&Page> = Vec::new();
        let mut stack: Vec<&Page> = self.pages.iter().rev().collect();
        while let Some(page) = stack.pop() {
            pages.push(page);
            stack.extend(page.pages.iter().rev());
        }
        let mut ids: HashMap<&str, Node> = HashMap::new();
        let mut arcs: Vec<&ArcNode> = Vec::new();
        for page in &pages {
            claim(&mut ids, &page.id, page.pos, Node::Page)?;
            for p in &page.places {
                let i = net.add_place(p.id.clone(), p.initial_marking);
                if let Some(n) = &p.name {
                    net.places[i].name = n.clone();
                }
                claim(&mut ids, &p.id, p.pos, Node::Place(i))?;
            }
            for t in &page.transitions {
                let i = net.add_transition(t.id.clone(), &[], &[]);
                if let Some(n) = &t.name {
                    net.transitions[i].name = n.clone();
                }
                claim(&mut ids, &t.id, t.pos, Node::Transition(i))?;
            }
            for r in &page.reference_places {
                claim(&mut ids, &r.id, r.pos, Node::RefPlace(r))?;
            }
            for r in &page.reference_transitions {
                claim(&mut ids, &r.id, r.pos, Node::RefTransition(r))?;
            }
            for a in &page.arcs {
                claim(&mut ids, &a.id, a.pos, Node::Arc)?;
                arcs.push(a);
            }
        }
        // Check every reference, even those no arc uses.
        for page in &pages {
            for r in &page.reference_places {
                resolve(&ids, Node::RefPlace(r))?;
            }
            for r in &page.reference_transitions {
                resolve(&ids, Node::RefTransition(r))?;
            }
        }
        let mut pre: Vec<Vec<(usize, u32)>> = vec![Vec::new(); net.transitions.len()];
        let mut post: Vec<Vec<(usize, u32)>> = vec![Vec::new(); net.transitions.len()];
        for a in arcs {
            let end = |id: &str, end: &'static str| -> Result<Node, PnmlError> {
                match ids.get(id) {
                    Some(
                        n @ (Node::Place(_)
                        | Node::Transition(_)
                        | Node::RefPlace(_)
                        | Node::RefTransition(_)),
                    ) => resolve(&ids, *n),
                    _ => Err(err(
                        a.pos,
                        PnmlErrorKind::DanglingArc {
                            arc: a.id.clone(),
                            end,
                            node: id.to_string(),
                        },
                    )),
                }
            };
            match (end(&a.source, "source")?, end(&a.target, "target")?) {
                (Node::Place(p), Node::Transition(t)) => pre[t].push((p, a.weight)),
                (Node::Transition(t), Node::Place(p)) => post[t].push((p, a.weight)),
                _ => return Err(err(a.pos, PnmlErrorKind::ArcSameKind(a.id.clone()))),
            }
        }
        for (t, tr) in net.transitions.iter_mut().enumerate() {
            tr.pre = normalize_arcs(&pre[t]);
            tr.post = normalize_arcs(&post[t]);
        }
        Ok(net)
    }
}

// ---------------------------------------------------------------- writing

impl Document {
    /// A document holding `net` on one page, with names and weights.
    pub fn from_ptnet(net: &PtNet) -> Document {
        let mut used: HashSet<String> = net
            .places
            .iter()
            .map(|p| p.id.clone())
            .chain(net.transitions.iter().map(|t| t.id.clone()))
            .collect();
        let mut fresh = |base: String| -> String {
            let mut id = base.clone();
            let mut n = 1;
            while !used.insert(id.clone()) {
                n += 1;
                id = format!("{base}~{n}");
            }
            id
        };
        let mut page = Page {
            id: fresh(format!("{}-page", net.id)),
            ..Page::default()
        };
        for p in &net.places {
            page.places.push(PlaceNode {
                id: p.id.clone(),
                name: Some(p.name.clone()),
                initial_marking: p.initial,
                ..PlaceNode::default()
            });
        }
        for t in &net.transitions {
            page.transitions.push(TransitionNode {
                id: t.id.clone(),
                name: Some(t.name.clone()),
                ..TransitionNode::default()
            });
        }
        for t in &net.transitions {
            for &(p, w) in &t.pre {
                let place = &net.places[p].id;
                page.arcs.push(ArcNode {
                    id: fresh(format!("{place}-{}", t.id)),
                    source: place.clone(),
                    target: t.id.clone(),
                    weight: w,
                    ..ArcNode::default()
                });
            }
            for &(p, w) in &t.post {
                let place = &net.places[p].id;
                page.arcs.push(ArcNode {
                    id: fresh(format!("{}-{place}", t.id)),
                    source: t.id.clone(),
                    target: place.clone(),
                    weight: w,
                    ..ArcNode::default()
                });
            }
        }
        Document {
            nets: vec![NetDoc {
                id: net.id.clone(),
                net_type: PTNET_TYPE.to_string(),
                name: Some(net.name.clone()),
                pages: vec![page],
                ..NetDoc::default()
            }],
        }
    }
}

/// Writes `net` as a PNML text.
pub fn write_ptnet(net: &PtNet) -> String {
    write_document(&Document::from_ptnet(net))
}

/// Writes a document as a PNML text (UTF-8, indented; `<toolspecific>`
/// contents verbatim).
pub fn write_document(doc: &Document) -> String {
    let mut w = Writer {
        out: String::new(),
        depth: 0,
    };
    w.out
        .push_str("<?xml version=\"1.0\" encoding=\"utf-8\"?>\n");
    w.open("pnml", &[("xmlns", PNML_NAMESPACE)]);
    for net in &doc.nets {
        w.open("net", &[("id", &net.id), ("type", &net.net_type)]);
        w.name(&net.name);
        w.toolspecific(&net.toolspecific);
        for page in &net.pages {
            w.page(page);
        }
        w.close("net");
    }
    w.close("pnml");
    w.out
}

struct Writer {
    out: String,
    depth: usize,
}

fn escape(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&apos;"),
            c => o.push(c),
        }
    }
    o
}

impl Writer {
    fn indent(&mut self) {
        for _ in 0..self.depth {
            self.out.push_str("  ");
        }
    }

    fn open(&mut self, name: &str, attrs: &[(&str, &str)]) {
        self.indent();
        let _ = write!(self.out, "<{name}");
        for (k, v) in attrs {
            let _ = write!(self.out, " {k}=\"{}\"", escape(v));
        }
        self.out.push_str(">\n");
        self.depth += 1;
    }

    fn close(&mut self, name: &str) {
        self.depth -= 1;
        self.indent();
        let _ = writeln!(self.out, "</{name}>");
    }

    fn labelled(&mut self, label: &str, text: &str) {
        self.indent();
        let _ = writeln!(self.out, "<{label}><text>{}</text></{label}>", escape(text));
    }

    fn name(&mut self, name: &Option<String>) {
        if let Some(n) = name {
            self.labelled("name", n);
        }
    }

    fn toolspecific(&mut self, ts: &[ToolSpecific]) {
        for t in ts {
            self.indent();
            let _ = writeln!(
                self.out,
                "<toolspecific tool=\"{}\" version=\"{}\">{}</toolspecific>",
                escape(&t.tool),
                escape(&t.version),
                t.content
            );
        }
    }

    fn page(&mut self, page: &Page) {
        self.open("page", &[("id", &page.id)]);
        self.name(&page.name);
        self.toolspecific(&page.toolspecific);
        for p in &page.places {
            self.open("place", &[("id", &p.id)]);
            self.name(&p.name);
            if p.initial_marking > 0 {
                self.labelled("initialMarking", &p.initial_marking.to_string());
            }
            self.toolspecific(&p.toolspecific);
            self.close("place");
        }
        for t in &page.transitions {
            self.open("transition", &[("id", &t.id)]);
            self.name(&t.name);
            self.toolspecific(&t.toolspecific);
            self.close("transition");
        }
        for (kind, refs) in [
            ("referencePlace", &page.reference_places),
            ("referenceTransition", &page.reference_transitions),
        ] {
            for r in refs {
                self.open(kind, &[("id", &r.id), ("ref", &r.reference)]);
                self.name(&r.name);
                self.toolspecific(&r.toolspecific);
                self.close(kind);
            }
        }
        for a in &page.arcs {
            self.open(
                "arc",
                &[("id", &a.id), ("source", &a.source), ("target", &a.target)],
            );
            if a.weight != 1 {
                self.labelled("inscription", &a.weight.to_string());
            }
            self.toolspecific(&a.toolspecific);
            self.close("arc");
        }
        for p in &page.pages {
            self.page(p);
        }
        self.close("page");
    }
}

#[cfg(test)]
mod tests;
