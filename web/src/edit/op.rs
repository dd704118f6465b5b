//! The edits the page asks for, and why one is refused.

use serde::Deserialize;

/// A node of a net: a place or a transition.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    Place,
    Transition,
}

impl Kind {
    pub fn word(self) -> &'static str {
        match self {
            Kind::Place => "place",
            Kind::Transition => "transition",
        }
    }
}

/// One edit of a project, as the page sends it (`{"op": "add_place", …}`).
/// Nets are named by their `name`; places and transitions by theirs
/// (global places as `@name`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case", deny_unknown_fields)]
pub enum Op {
    /// A new place, drawn at `at` if given (else laid out automatically).
    AddPlace {
        net: String,
        name: String,
        #[serde(default)]
        at: Option<(f64, f64)>,
    },
    RenamePlace {
        net: String,
        name: String,
        to: String,
    },
    /// Refused while a transition's arc uses the place.
    DeletePlace {
        net: String,
        name: String,
    },
    /// Whether the place is in `initial` / `final` (absent: unchanged).
    SetPlace {
        net: String,
        name: String,
        #[serde(default)]
        initial: Option<bool>,
        #[serde(default, rename = "final")]
        is_final: Option<bool>,
    },
    /// A new transition without arcs, drawn at `at` if given.
    AddTransition {
        net: String,
        name: String,
        #[serde(default)]
        at: Option<(f64, f64)>,
    },
    RenameTransition {
        net: String,
        name: String,
        to: String,
    },
    DeleteTransition {
        net: String,
        name: String,
    },
    /// The transition's event (`on`; empty: immediate), guard (`when`;
    /// empty: none) and actions (`do`; empty: none).
    SetTransition {
        net: String,
        name: String,
        on: String,
        when: String,
        #[serde(rename = "do")]
        actions: Vec<String>,
    },
    /// An arc between `place` and `transition`: an input (place to
    /// transition, `from`) or an output (`to`).
    AddArc {
        net: String,
        transition: String,
        place: String,
        input: bool,
    },
    DeleteArc {
        net: String,
        transition: String,
        place: String,
        input: bool,
    },
    /// Where a node is drawn (the layout file only).
    Move {
        net: String,
        kind: Kind,
        name: String,
        x: f64,
        y: f64,
    },
    /// Forget the net's stored positions: all of it laid out automatically.
    Relayout {
        net: String,
    },
    /// A new net `name` in a new file `NAME.toml` beside project.toml (one
    /// place, `idle`, marked initially), listed last in project.toml's
    /// `[[net]]` tables, active at start or not.
    AddNet {
        name: String,
        #[serde(default)]
        active: bool,
    },
    /// The net `name` gone: its `[[net]]` table out of project.toml, its
    /// file removed (and its positions). Refused while another net's
    /// actions or an `[[exclusive]]` place name it, or when it is the
    /// project's last net.
    DeleteNet {
        name: String,
    },
    /// The net `name` called `to`: its file's `name`, every `activate` /
    /// `deactivate` naming it, `[[exclusive]]` places `NAME.place`, its
    /// positions; its file renamed `TO.toml` (and project.toml's `file`
    /// with it) when it was `NAME.toml`.
    RenameNet {
        name: String,
        to: String,
    },
    /// Whether net `name` is active at start: the `active` key of its
    /// `[[net]]` table in project.toml, written explicitly (added when
    /// absent, `active = false` kept rather than removed).
    SetActive {
        name: String,
        active: bool,
    },
}

impl Op {
    /// The net the edit concerns.
    pub fn net(&self) -> &str {
        match self {
            Op::AddPlace { net, .. }
            | Op::RenamePlace { net, .. }
            | Op::DeletePlace { net, .. }
            | Op::SetPlace { net, .. }
            | Op::AddTransition { net, .. }
            | Op::RenameTransition { net, .. }
            | Op::DeleteTransition { net, .. }
            | Op::SetTransition { net, .. }
            | Op::AddArc { net, .. }
            | Op::DeleteArc { net, .. }
            | Op::Move { net, .. }
            | Op::Relayout { net } => net,
            Op::AddNet { name, .. }
            | Op::DeleteNet { name }
            | Op::RenameNet { name, .. }
            | Op::SetActive { name, .. } => name,
        }
    }

    /// The edit in a few words, as the page's *Undo* names it.
    pub fn describe(&self) -> String {
        let net = self.net();
        match self {
            Op::AddPlace { name, .. } => format!("add place {net}.{name}"),
            Op::RenamePlace { name, to, .. } => format!("rename place {net}.{name} to {to}"),
            Op::DeletePlace { name, .. } => format!("delete place {net}.{name}"),
            Op::SetPlace { name, .. } => format!("set place {net}.{name}"),
            Op::AddTransition { name, .. } => format!("add transition {net}.{name}"),
            Op::RenameTransition { name, to, .. } => {
                format!("rename transition {net}.{name} to {to}")
            }
            Op::DeleteTransition { name, .. } => format!("delete transition {net}.{name}"),
            Op::SetTransition { name, .. } => format!("set transition {net}.{name}"),
            Op::AddArc {
                transition,
                place,
                input,
                ..
            } => {
                if *input {
                    format!("add arc {place} → {net}.{transition}")
                } else {
                    format!("add arc {net}.{transition} → {place}")
                }
            }
            Op::DeleteArc {
                transition,
                place,
                input,
                ..
            } => {
                if *input {
                    format!("delete arc {place} → {net}.{transition}")
                } else {
                    format!("delete arc {net}.{transition} → {place}")
                }
            }
            Op::Move { name, .. } => format!("move {net}.{name}"),
            Op::Relayout { .. } => format!("re-layout {net}"),
            Op::AddNet { .. } => format!("add net {net}"),
            Op::DeleteNet { .. } => format!("delete net {net}"),
            Op::RenameNet { to, .. } => format!("rename net {net} to {to}"),
            Op::SetActive { active: true, .. } => format!("set net {net} active at start"),
            Op::SetActive { active: false, .. } => {
                format!("set net {net} not active at start")
            }
        }
    }
}

/// Why an edit was refused; nothing was changed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EditError {
    #[error("no net named `{0}`")]
    UnknownNet(String),
    #[error("the project already has a net `{0}`")]
    DuplicateNet(String),
    #[error("{0} exists already: a new net gets a file of its own (nothing written)")]
    FileExists(String),
    #[error("net {net} is named by {}: change those first (nothing written)", .uses.join("; "))]
    NetInUse {
        net: String,
        /// Each use: a transition and its action, or an `[[exclusive]]` place.
        uses: Vec<String>,
    },
    #[error("net {net} is already {} at start (nothing written)", if *.active { "active" } else { "not active" })]
    AlreadyActive { net: String, active: bool },
    #[error("net {0} is the project's last net: a project needs one (nothing written)")]
    LastNet(String),
    #[error("net {net} has no {kind} `{name}`")]
    Unknown {
        net: String,
        kind: &'static str,
        name: String,
    },
    #[error("net {net} already has a {kind} `{name}`")]
    Duplicate {
        net: String,
        kind: &'static str,
        name: String,
    },
    #[error(
        "invalid {kind} name `{name}`: use letters, digits and `_`, starting with a letter or `_`"
    )]
    BadName { kind: &'static str, name: String },
    #[error("no global place `@{0}` in project.toml's [globals]")]
    UnknownGlobal(String),
    #[error("global place `{0}` belongs to project.toml: rename or delete it there")]
    GlobalPlace(String),
    #[error("place {net}.{place} is used by {}: delete those arcs first", .transitions.join(", "))]
    PlaceInUse {
        net: String,
        place: String,
        transitions: Vec<String>,
    },
    #[error("{net}.{transition} already has an {} arc {}", if *.input { "input" } else { "output" }, if *.input { format!("from {}", .place) } else { format!("to {}", .place) })]
    DuplicateArc {
        net: String,
        transition: String,
        place: String,
        input: bool,
    },
    #[error("{net}.{transition} has no {} arc {}", if *.input { "input" } else { "output" }, if *.input { format!("from {}", .place) } else { format!("to {}", .place) })]
    UnknownArc {
        net: String,
        transition: String,
        place: String,
        input: bool,
    },
    #[error("a position must be two numbers between -1000000 and 1000000")]
    BadPosition,
    #[error("{file}: {what}")]
    Shape { file: String, what: String },
}

/// Names of nets, places and transitions: letters, digits and `_`,
/// starting with a letter or `_` (as the loader wants them).
pub fn valid_name(name: &str) -> bool {
    let mut chars = name.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}
