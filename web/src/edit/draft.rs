//! The edit core, sans I/O: a project's net files as `toml_edit`
//! documents and its layout file, and [`Draft::apply`], which makes one
//! edit or refuses it with nothing changed. Only what an edit concerns is
//! touched: every other byte of a net file (comments, order, quoting,
//! blank lines) is written back as it was read.
//!
//! The draft keeps the nets' structure whole — every arc names a place of
//! the net or a declared global, names are unique and well formed — but
//! not what the loader checks beyond it (events, guards, actions, a
//! transition without input): such an edit is made, and the loader's
//! verdict shown on the element (docs/monitor.md, "Editing").

use nets::action::ActionSyntax;
use toml_edit::{value, Array, ArrayOfTables, DocumentMut, Item, Table, Value};

use super::op::{valid_name, EditError, Kind, Op};
use super::positions::Positions;

/// One net file being edited.
#[derive(Debug, Clone)]
pub struct NetText {
    /// Relative to the project folder, as project.toml names it.
    pub file: String,
    pub doc: DocumentMut,
}

impl NetText {
    /// The net's `name` (empty when it has none).
    pub fn name(&self) -> &str {
        self.doc.get("name").and_then(Item::as_str).unwrap_or("")
    }
}

/// The project as edited.
#[derive(Debug, Clone)]
pub struct Draft {
    /// project.toml's `name` (empty when it has none).
    pub name: String,
    /// project.toml itself (a net added appends its `[[net]]` table).
    pub project: DocumentMut,
    pub nets: Vec<NetText>,
    /// project.toml's global places, without `@`.
    pub globals: Vec<String>,
    pub positions: Positions,
}

/// What an edit changed, to be written back.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Applied {
    /// The net file (an index into [`Draft::nets`]).
    pub net_file: Option<usize>,
    /// The layout file.
    pub layout: bool,
    /// project.toml, and the net file is new (a net added).
    pub project: bool,
    /// A net deleted or renamed: project.toml, the layout and every net
    /// file may have changed, a file gone or a new one there; the writer
    /// compares each with the draft before the edit.
    pub all: bool,
}

/// The text of a net added by the editor: one place, marked initially.
/// It loads; `petrel check` finds it dead at the start (nothing moves
/// the token) until a transition is given to it, or `idle` made final.
pub fn new_net_text(name: &str) -> String {
    format!(
        "# {name}: a net added by `petrel edit`.\nname = \"{name}\"\nplaces = [\"idle\"]\ninitial = [\"idle\"]\n"
    )
}

/// The net an action names (`activate` / `deactivate`; of an instance
/// `NET@VEHICLE`, its template `NET`), and where that name is in the
/// action's text. None for any other action, or one that does not parse.
pub fn named_net(action: &str) -> Option<(String, std::ops::Range<usize>)> {
    match nets::action::parse(action).ok()? {
        ActionSyntax::Activate((n, at)) | ActionSyntax::Deactivate((n, at)) => {
            let base = n.split_once('@').map_or(n.as_str(), |(b, _)| b);
            Some((base.to_owned(), at..at + base.len()))
        }
        _ => None,
    }
}

/// The net an `[[exclusive]]` place names (`TEMPLATE.place`).
fn exclusive_net(place: &str) -> Option<&str> {
    place.split_once('.').map(|(net, _)| net)
}

/// A net file renamed with its net: `DIR/OLD.toml` becomes `DIR/NEW.toml`;
/// any other file name is kept (None).
fn renamed_file(file: &str, from: &str, to: &str) -> Option<String> {
    let (dir, base) = match file.rsplit_once('/') {
        Some((dir, base)) => (Some(dir), base),
        None => (None, file),
    };
    if base != format!("{from}.toml") {
        return None;
    }
    Some(match dir {
        Some(dir) => format!("{dir}/{to}.toml"),
        None => format!("{to}.toml"),
    })
}

fn parse(file: &str, text: &str) -> Result<DocumentMut, EditError> {
    text.parse::<DocumentMut>().map_err(|e| EditError::Shape {
        file: file.to_owned(),
        what: e.to_string().trim_end().to_owned(),
    })
}

/// The strings of `table[key]` (an array; anything else reads as empty).
pub fn strings(table: &Table, key: &str) -> Vec<String> {
    table
        .get(key)
        .and_then(Item::as_array)
        .map(|a| {
            a.iter()
                .filter_map(|v| v.as_str().map(str::to_owned))
                .collect()
        })
        .unwrap_or_default()
}

/// The transitions of a net file (none when it has no `[[transition]]`).
pub fn transitions(doc: &DocumentMut) -> Vec<&Table> {
    doc.get("transition")
        .and_then(Item::as_array_of_tables)
        .map(|a| a.iter().collect())
        .unwrap_or_default()
}

fn transition_name(t: &Table) -> &str {
    t.get("name").and_then(Item::as_str).unwrap_or("")
}

/// `table[key]` as an array, created empty at the end of the table when
/// absent (or replaced when it is not an array).
fn list_mut<'a>(table: &'a mut Table, key: &str) -> Option<&'a mut Array> {
    if table.get(key).and_then(Item::as_array).is_none() {
        table.insert(key, value(Array::new()));
    }
    table.get_mut(key).and_then(Item::as_array_mut)
}

/// Appends `name`, laid out as the array already is (one a line, or
/// inline).
fn push(array: &mut Array, name: &str) {
    let decor = array.iter().last().map(|v| v.decor().clone());
    array.push(name);
    // One a line: the new line indented as the last (a comment before the
    // last element stays its own).
    let indent = decor
        .as_ref()
        .and_then(|d| d.prefix().and_then(|p| p.as_str()))
        .and_then(|p| p.rfind('\n').map(|i| p[i..].to_owned()));
    if let (Some(indent), Some(last)) = (indent, array.iter_mut().last()) {
        last.decor_mut().set_prefix(indent);
    }
}

/// Replaces every `from` in the array by `to`, keeping each value's
/// surroundings; true if one was.
fn rename_in(array: &mut Array, from: &str, to: &str) -> bool {
    let mut any = false;
    for v in array.iter_mut() {
        if v.as_str() == Some(from) {
            set_keeping_decor(v, Value::from(to));
            any = true;
        }
    }
    any
}

/// project.toml's `[[net]]` table number `entry`.
fn net_table(project: &DocumentMut, entry: usize) -> Result<&Table, EditError> {
    project
        .get("net")
        .and_then(Item::as_array_of_tables)
        .and_then(|a| a.get(entry))
        .ok_or_else(|| shape(nets::load::PROJECT_FILE, "no such [[net]] table"))
}

/// project.toml's `[[net]]` table number `entry`, to change.
fn net_table_mut(project: &mut DocumentMut, entry: usize) -> Result<&mut Table, EditError> {
    project
        .get_mut("net")
        .and_then(Item::as_array_of_tables_mut)
        .and_then(|a| a.get_mut(entry))
        .ok_or_else(|| shape(nets::load::PROJECT_FILE, "no such [[net]] table"))
}

fn set_keeping_decor(v: &mut Value, new: Value) {
    let decor = v.decor().clone();
    *v = new;
    *v.decor_mut() = decor;
}

/// Removes every `name` from the array; true if one was. The first
/// element's surroundings stay with the array's new first element.
fn remove_from(array: &mut Array, name: &str) -> bool {
    let mut any = false;
    loop {
        let found = array.iter().position(|v| v.as_str() == Some(name));
        let Some(i) = found else { break };
        let first_decor = if i == 0 && array.len() > 1 {
            array.get(0).map(|v| v.decor().clone())
        } else {
            None
        };
        array.remove(i);
        if let Some(decor) = first_decor {
            if let Some(v) = array.get_mut(0) {
                *v.decor_mut() = decor;
            }
        }
        any = true;
    }
    any
}

/// Sets `table[key]` to a string (removed when empty), keeping the key's
/// place and surroundings; true if it changed.
fn set_text(table: &mut Table, key: &str, text: &str) -> bool {
    let text = text.trim();
    let now = table.get(key).and_then(Item::as_str);
    if now == Some(text) || (now.is_none() && text.is_empty() && !table.contains_key(key)) {
        return false;
    }
    if text.is_empty() {
        table.remove(key);
        return true;
    }
    match table.get_mut(key).and_then(Item::as_value_mut) {
        Some(v) => set_keeping_decor(v, Value::from(text)),
        None => {
            table.insert(key, value(text));
        }
    }
    true
}

/// Sets `table[key]` to a list of strings (removed when empty), one a
/// line if the list was written so; true if it changed.
fn set_list(table: &mut Table, key: &str, items: &[String]) -> bool {
    let items: Vec<&str> = items
        .iter()
        .map(|s| s.trim())
        .filter(|s| !s.is_empty())
        .collect();
    let now = strings(table, key);
    if now.iter().map(String::as_str).eq(items.iter().copied())
        && (table.contains_key(key) || items.is_empty())
    {
        return false;
    }
    if items.is_empty() {
        table.remove(key);
        return true;
    }
    let old = table.get(key).and_then(Item::as_array);
    let line_prefix = old.and_then(|a| {
        a.iter()
            .filter_map(|v| v.decor().prefix().and_then(|p| p.as_str()))
            .find_map(|p| p.rfind('\n').map(|i| p[i..].to_owned()))
    });
    let mut array = Array::new();
    for s in &items {
        array.push(*s);
    }
    if let Some(prefix) = &line_prefix {
        for v in array.iter_mut() {
            v.decor_mut().set_prefix(prefix.as_str());
        }
        array.set_trailing_comma(true);
        array.set_trailing("\n");
    }
    match table.get_mut(key).and_then(Item::as_value_mut) {
        Some(v) => set_keeping_decor(v, Value::Array(array)),
        None => {
            table.insert(key, value(array));
        }
    }
    true
}

impl Draft {
    /// A draft of the project whose project.toml is `project` and whose net
    /// files are `nets` (`(file, text)` in project.toml's order), with the
    /// layout file's text `layout` (empty when there is none).
    pub fn parse(
        project: &str,
        nets: &[(String, String)],
        layout: &str,
    ) -> Result<Draft, EditError> {
        let p = parse(nets::load::PROJECT_FILE, project)?;
        let globals = p
            .get("globals")
            .and_then(Item::as_table)
            .map(|t| t.iter().map(|(k, _)| k.to_owned()).collect())
            .unwrap_or_default();
        let nets = nets
            .iter()
            .map(|(file, text)| {
                Ok(NetText {
                    file: file.clone(),
                    doc: parse(file, text)?,
                })
            })
            .collect::<Result<Vec<_>, EditError>>()?;
        Ok(Draft {
            name: p
                .get("name")
                .and_then(Item::as_str)
                .unwrap_or("")
                .to_owned(),
            project: p,
            nets,
            globals,
            positions: Positions::parse(layout)?,
        })
    }

    /// The draft with `files` (net files, the layout file) read again
    /// from `text`: None when project.toml is among them, or one is not
    /// the draft's, absent or not TOML (the caller parses the whole
    /// project then).
    pub fn reread(&self, files: &[&str], text: impl Fn(&str) -> Option<String>) -> Option<Draft> {
        let mut next = self.clone();
        for file in files {
            if *file == super::positions::FILE {
                next.positions = Positions::parse(&text(file).unwrap_or_default()).ok()?;
            } else {
                let net = next.nets.iter_mut().find(|n| n.file == *file)?;
                net.doc = parse(file, &text(file)?).ok()?;
            }
        }
        Some(next)
    }

    /// The net files project.toml lists, in its order.
    pub fn net_files(project: &str) -> Result<Vec<String>, EditError> {
        let p = parse(nets::load::PROJECT_FILE, project)?;
        Ok(p.get("net")
            .and_then(Item::as_array_of_tables)
            .map(|a| {
                a.iter()
                    .filter_map(|t| t.get("file").and_then(Item::as_str).map(str::to_owned))
                    .collect()
            })
            .unwrap_or_default())
    }

    /// The index of the net named `name`.
    pub fn net(&self, name: &str) -> Result<usize, EditError> {
        self.nets
            .iter()
            .position(|n| n.name() == name)
            .ok_or_else(|| EditError::UnknownNet(name.to_owned()))
    }

    fn unknown(net: &str, kind: Kind, name: &str) -> EditError {
        EditError::Unknown {
            net: net.to_owned(),
            kind: kind.word(),
            name: name.to_owned(),
        }
    }

    fn check_new_name(&self, n: usize, kind: Kind, name: &str) -> Result<(), EditError> {
        if !valid_name(name) {
            return Err(EditError::BadName {
                kind: kind.word(),
                name: name.to_owned(),
            });
        }
        let taken = match kind {
            Kind::Place => strings(self.nets[n].doc.as_table(), "places")
                .iter()
                .any(|p| p == name),
            Kind::Transition => transitions(&self.nets[n].doc)
                .iter()
                .any(|t| transition_name(t) == name),
        };
        if taken {
            return Err(EditError::Duplicate {
                net: self.nets[n].name().to_owned(),
                kind: kind.word(),
                name: name.to_owned(),
            });
        }
        Ok(())
    }

    /// The place `name` of net `n` (its own, or a declared global `@g`).
    fn check_place(&self, n: usize, name: &str) -> Result<(), EditError> {
        if let Some(g) = name.strip_prefix('@') {
            return if self.globals.iter().any(|x| x == g) {
                Ok(())
            } else {
                Err(EditError::UnknownGlobal(g.to_owned()))
            };
        }
        if strings(self.nets[n].doc.as_table(), "places")
            .iter()
            .any(|p| p == name)
        {
            Ok(())
        } else {
            Err(Self::unknown(self.nets[n].name(), Kind::Place, name))
        }
    }

    /// A local place (not `@global`) of net `n`.
    fn check_local(&self, n: usize, name: &str) -> Result<(), EditError> {
        if name.starts_with('@') {
            return Err(EditError::GlobalPlace(name.to_owned()));
        }
        self.check_place(n, name)
    }

    fn transition_index(&self, n: usize, name: &str) -> Result<usize, EditError> {
        transitions(&self.nets[n].doc)
            .iter()
            .position(|t| transition_name(t) == name)
            .ok_or_else(|| Self::unknown(self.nets[n].name(), Kind::Transition, name))
    }

    fn transition_mut(&mut self, n: usize, i: usize) -> Option<&mut Table> {
        self.nets[n]
            .doc
            .get_mut("transition")
            .and_then(Item::as_array_of_tables_mut)
            .and_then(|a| a.get_mut(i))
    }

    fn transitions_mut(&mut self, n: usize) -> impl Iterator<Item = &mut Table> {
        self.nets[n]
            .doc
            .get_mut("transition")
            .and_then(Item::as_array_of_tables_mut)
            .into_iter()
            .flat_map(|a| a.iter_mut())
    }

    /// A net's new name (added or renamed): one the loader takes, and no
    /// other net's.
    fn check_new_net(&self, name: &str) -> Result<(), EditError> {
        if !valid_name(name) {
            return Err(EditError::BadName {
                kind: "net",
                name: name.to_owned(),
            });
        }
        if self.nets.iter().any(|n| n.name() == name) {
            return Err(EditError::DuplicateNet(name.to_owned()));
        }
        Ok(())
    }

    /// A net's new file: not project.toml, the layout file or another
    /// net's (the writer also refuses one that exists on disk).
    fn check_new_file(&self, file: &str) -> Result<(), EditError> {
        if file == nets::load::PROJECT_FILE
            || file == super::positions::FILE
            || self.nets.iter().any(|n| n.file == file)
        {
            return Err(EditError::FileExists(file.to_owned()));
        }
        Ok(())
    }

    /// A new net `name` in `NAME.toml`, its `[[net]]` table appended to
    /// project.toml after the last one (every other byte kept).
    fn add_net(&mut self, name: &str, active: bool) -> Result<Applied, EditError> {
        self.check_new_net(name)?;
        let file = format!("{name}.toml");
        self.check_new_file(&file)?;
        let doc = parse(&file, &new_net_text(name))?;
        let root = self.project.as_table_mut();
        if root.get("net").is_none() {
            root.insert("net", Item::ArrayOfTables(ArrayOfTables::new()));
        }
        let entries = root
            .get_mut("net")
            .and_then(Item::as_array_of_tables_mut)
            .ok_or_else(|| {
                shape(
                    nets::load::PROJECT_FILE,
                    "`net` is not [[net]] tables: add the net there by hand",
                )
            })?;
        let mut t = Table::new();
        t.insert("file", value(file.as_str()));
        t.insert("active", value(active));
        t.decor_mut().set_prefix("\n");
        entries.push(t);
        self.nets.push(NetText { file, doc });
        Ok(Applied {
            net_file: Some(self.nets.len() - 1),
            layout: false,
            project: true,
            all: false,
        })
    }

    /// Where the other nets' actions and project.toml's `[[exclusive]]`
    /// places name net `n`, in words (`B.go: \`activate A\``).
    pub fn uses_of_net(&self, n: usize) -> Vec<String> {
        let name = self.nets[n].name();
        let mut uses = Vec::new();
        for (m, other) in self.nets.iter().enumerate() {
            if m == n {
                continue;
            }
            for t in transitions(&other.doc) {
                for action in strings(t, "do") {
                    if named_net(&action).is_some_and(|(net, _)| net == name) {
                        uses.push(format!(
                            "{}.{}: `{action}`",
                            other.name(),
                            transition_name(t)
                        ));
                    }
                }
            }
        }
        let exclusive = self
            .project
            .get("exclusive")
            .and_then(Item::as_array_of_tables);
        for r in exclusive.into_iter().flat_map(|a| a.iter()) {
            for place in strings(r, "places") {
                if exclusive_net(&place) == Some(name) {
                    uses.push(format!(
                        "{} [[exclusive]] {}: `{place}`",
                        nets::load::PROJECT_FILE,
                        r.get("name").and_then(Item::as_str).unwrap_or("")
                    ));
                }
            }
        }
        uses
    }

    /// The index of net `n`'s `[[net]]` table in project.toml.
    fn net_entry(&self, n: usize) -> Result<usize, EditError> {
        let file = &self.nets[n].file;
        self.project
            .get("net")
            .and_then(Item::as_array_of_tables)
            .and_then(|a| {
                a.iter()
                    .position(|t| t.get("file").and_then(Item::as_str) == Some(file.as_str()))
            })
            .ok_or_else(|| {
                shape(
                    nets::load::PROJECT_FILE,
                    &format!("no [[net]] table has file = \"{file}\""),
                )
            })
    }

    /// Net `name` gone: its `[[net]]` table and its file (every other byte
    /// of project.toml kept), its positions.
    fn delete_net(&mut self, name: &str) -> Result<Applied, EditError> {
        let n = self.net(name)?;
        if self.nets.len() == 1 {
            return Err(EditError::LastNet(name.to_owned()));
        }
        let uses = self.uses_of_net(n);
        if !uses.is_empty() {
            return Err(EditError::NetInUse {
                net: name.to_owned(),
                uses,
            });
        }
        let i = self.net_entry(n)?;
        if let Some(entries) = self
            .project
            .get_mut("net")
            .and_then(Item::as_array_of_tables_mut)
        {
            entries.remove(i);
        }
        self.nets.remove(n);
        self.positions.clear(name);
        Ok(Applied {
            all: true,
            ..Applied::default()
        })
    }

    /// Net `name` called `to` everywhere the loader reads it; its file
    /// renamed with it when named after it.
    fn rename_net(&mut self, name: &str, to: &str) -> Result<Applied, EditError> {
        let n = self.net(name)?;
        if name == to {
            return Ok(Applied::default());
        }
        self.check_new_net(to)?;
        let file = renamed_file(&self.nets[n].file, name, to);
        if let Some(file) = &file {
            self.check_new_file(file)?;
        }
        let entry = self.net_entry(n)?;
        // Made on a copy: nothing changed unless all of it is.
        let mut next = self.clone();
        set_text(next.nets[n].doc.as_table_mut(), "name", to);
        for m in 0..next.nets.len() {
            for t in next.transitions_mut(m) {
                let Some(actions) = t.get_mut("do").and_then(Item::as_array_mut) else {
                    continue;
                };
                for v in actions.iter_mut() {
                    let Some(action) = v.as_str() else { continue };
                    let Some((net, at)) = named_net(action) else {
                        continue;
                    };
                    if net == name {
                        let mut renamed = action.to_owned();
                        renamed.replace_range(at, to);
                        set_keeping_decor(v, Value::from(renamed));
                    }
                }
            }
        }
        let exclusive = next
            .project
            .get_mut("exclusive")
            .and_then(Item::as_array_of_tables_mut);
        for r in exclusive.into_iter().flat_map(|a| a.iter_mut()) {
            let Some(places) = r.get_mut("places").and_then(Item::as_array_mut) else {
                continue;
            };
            for v in places.iter_mut() {
                let Some(place) = v.as_str() else { continue };
                if let (Some(net), Some((_, rest))) = (exclusive_net(place), place.split_once('.'))
                {
                    if net == name {
                        let renamed = format!("{to}.{rest}");
                        set_keeping_decor(v, Value::from(renamed));
                    }
                }
            }
        }
        if let Some(file) = file {
            let t = net_table_mut(&mut next.project, entry)?;
            set_text(t, "file", &file);
            next.nets[n].file = file;
        }
        next.positions.rename_net(name, to);
        *self = next;
        Ok(Applied {
            all: true,
            ..Applied::default()
        })
    }

    /// Whether net `n` is active at start: its `[[net]]` table's `active`
    /// (absent: false, the loader's default; not a boolean: false too,
    /// the loader says why).
    pub fn net_active(&self, n: usize) -> bool {
        self.net_entry(n)
            .and_then(|i| net_table(&self.project, i))
            .ok()
            .and_then(|t| t.get("active"))
            .and_then(Item::as_bool)
            .unwrap_or(false)
    }

    /// Net `name` active at start or not: its `[[net]]` table's `active`
    /// set (added after the table's last key when absent; `false` written,
    /// not removed), every other byte of project.toml kept. Refused when
    /// nothing would change.
    fn set_active(&mut self, name: &str, active: bool) -> Result<Applied, EditError> {
        let n = self.net(name)?;
        if self.net_active(n) == active {
            return Err(EditError::AlreadyActive {
                net: name.to_owned(),
                active,
            });
        }
        let i = self.net_entry(n)?;
        let t = net_table_mut(&mut self.project, i)?;
        match t.get_mut("active") {
            Some(Item::Value(v)) if v.as_bool().is_some() => {
                set_keeping_decor(v, Value::from(active))
            }
            Some(_) => {
                return Err(shape(
                    nets::load::PROJECT_FILE,
                    &format!("net {name}'s `active` is not a boolean: set it by hand"),
                ))
            }
            None => {
                t.insert("active", value(active));
            }
        }
        Ok(Applied {
            all: true,
            ..Applied::default()
        })
    }

    /// Makes the edit, or refuses it with nothing changed.
    pub fn apply(&mut self, op: &Op) -> Result<Applied, EditError> {
        match op {
            Op::AddNet { name, active } => return self.add_net(name, *active),
            Op::DeleteNet { name } => return self.delete_net(name),
            Op::RenameNet { name, to } => return self.rename_net(name, to),
            Op::SetActive { name, active } => return self.set_active(name, *active),
            _ => {}
        }
        let n = self.net(op.net())?;
        let net_name = self.nets[n].name().to_owned();
        let file_name = self.nets[n].file.clone();
        let file = Applied {
            net_file: Some(n),
            ..Applied::default()
        };
        let both = Applied {
            net_file: Some(n),
            layout: true,
            project: false,
            all: false,
        };
        match op {
            Op::AddPlace { name, at, .. } => {
                self.check_new_name(n, Kind::Place, name)?;
                if at.is_some_and(|at| !super::positions::drawable(at)) {
                    return Err(EditError::BadPosition);
                }
                let places = list_mut(self.nets[n].doc.as_table_mut(), "places")
                    .ok_or_else(|| shape(&file_name, "`places` is not a list"))?;
                push(places, name);
                match at {
                    Some(at) => {
                        self.positions.set(&net_name, Kind::Place, name, *at)?;
                        Ok(both)
                    }
                    None => Ok(file),
                }
            }
            Op::RenamePlace { name, to, .. } => {
                self.check_local(n, name)?;
                if to.starts_with('@') {
                    return Err(EditError::GlobalPlace(to.clone()));
                }
                self.check_new_name(n, Kind::Place, to)?;
                let root = self.nets[n].doc.as_table_mut();
                for key in ["places", "initial", "final"] {
                    if let Some(a) = root.get_mut(key).and_then(Item::as_array_mut) {
                        rename_in(a, name, to);
                    }
                }
                for t in self.transitions_mut(n) {
                    for key in ["from", "to"] {
                        if let Some(a) = t.get_mut(key).and_then(Item::as_array_mut) {
                            rename_in(a, name, to);
                        }
                    }
                }
                let layout = self.positions.rename(&net_name, Kind::Place, name, to);
                Ok(Applied {
                    net_file: Some(n),
                    layout,
                    project: false,
                    all: false,
                })
            }
            Op::DeletePlace { name, .. } => {
                self.check_local(n, name)?;
                let users: Vec<String> = transitions(&self.nets[n].doc)
                    .iter()
                    .filter(|t| {
                        strings(t, "from")
                            .iter()
                            .chain(&strings(t, "to"))
                            .any(|p| p == name)
                    })
                    .map(|t| transition_name(t).to_owned())
                    .collect();
                if !users.is_empty() {
                    return Err(EditError::PlaceInUse {
                        net: net_name,
                        place: name.clone(),
                        transitions: users,
                    });
                }
                let root = self.nets[n].doc.as_table_mut();
                for key in ["places", "initial", "final"] {
                    if let Some(a) = root.get_mut(key).and_then(Item::as_array_mut) {
                        remove_from(a, name);
                    }
                }
                let layout = self.positions.remove(&net_name, Kind::Place, name);
                Ok(Applied {
                    net_file: Some(n),
                    layout,
                    project: false,
                    all: false,
                })
            }
            Op::SetPlace {
                name,
                initial,
                is_final,
                ..
            } => {
                self.check_local(n, name)?;
                let mut changed = false;
                for (key, want) in [("initial", initial), ("final", is_final)] {
                    let Some(want) = want else { continue };
                    let root = self.nets[n].doc.as_table_mut();
                    let has = strings(root, key).iter().any(|p| p == name);
                    if has == *want {
                        continue;
                    }
                    changed = true;
                    if *want {
                        let a =
                            list_mut(root, key).ok_or_else(|| shape(&file_name, "not a list"))?;
                        push(a, name);
                    } else if let Some(a) = root.get_mut(key).and_then(Item::as_array_mut) {
                        remove_from(a, name);
                    }
                }
                Ok(if changed { file } else { Applied::default() })
            }
            Op::AddTransition { name, at, .. } => {
                self.check_new_name(n, Kind::Transition, name)?;
                if at.is_some_and(|at| !super::positions::drawable(at)) {
                    return Err(EditError::BadPosition);
                }
                let mut t = Table::new();
                t.insert("name", value(name.as_str()));
                t.insert("from", value(Array::new()));
                t.insert("to", value(Array::new()));
                t.decor_mut().set_prefix("\n");
                let root = self.nets[n].doc.as_table_mut();
                if !root.get("transition").is_some_and(Item::is_array_of_tables) {
                    root.insert("transition", Item::ArrayOfTables(ArrayOfTables::new()));
                }
                let aot = root
                    .get_mut("transition")
                    .and_then(Item::as_array_of_tables_mut)
                    .ok_or_else(|| {
                        shape(&file_name, "`transition` is not [[transition]] tables")
                    })?;
                aot.push(t);
                match at {
                    Some(at) => {
                        self.positions.set(&net_name, Kind::Transition, name, *at)?;
                        Ok(both)
                    }
                    None => Ok(file),
                }
            }
            Op::RenameTransition { name, to, .. } => {
                let i = self.transition_index(n, name)?;
                self.check_new_name(n, Kind::Transition, to)?;
                if let Some(t) = self.transition_mut(n, i) {
                    set_text(t, "name", to);
                }
                let layout = self.positions.rename(&net_name, Kind::Transition, name, to);
                Ok(Applied {
                    net_file: Some(n),
                    layout,
                    project: false,
                    all: false,
                })
            }
            Op::DeleteTransition { name, .. } => {
                let i = self.transition_index(n, name)?;
                if let Some(a) = self.nets[n]
                    .doc
                    .get_mut("transition")
                    .and_then(Item::as_array_of_tables_mut)
                {
                    a.remove(i);
                }
                let layout = self.positions.remove(&net_name, Kind::Transition, name);
                Ok(Applied {
                    net_file: Some(n),
                    layout,
                    project: false,
                    all: false,
                })
            }
            Op::SetTransition {
                name,
                on,
                when,
                actions,
                ..
            } => {
                let i = self.transition_index(n, name)?;
                let Some(t) = self.transition_mut(n, i) else {
                    return Err(Self::unknown(&net_name, Kind::Transition, name));
                };
                let a = set_text(t, "on", on);
                let b = set_text(t, "when", when);
                let c = set_list(t, "do", actions);
                Ok(if a || b || c {
                    file
                } else {
                    Applied::default()
                })
            }
            Op::AddArc {
                transition,
                place,
                input,
                ..
            } => {
                let i = self.transition_index(n, transition)?;
                self.check_place(n, place)?;
                let key = if *input { "from" } else { "to" };
                let Some(t) = self.transition_mut(n, i) else {
                    return Err(Self::unknown(&net_name, Kind::Transition, transition));
                };
                if strings(t, key).iter().any(|p| p == place) {
                    return Err(EditError::DuplicateArc {
                        net: net_name,
                        transition: transition.clone(),
                        place: place.clone(),
                        input: *input,
                    });
                }
                let a = list_mut(t, key).ok_or_else(|| shape(&file_name, "not a list"))?;
                push(a, place);
                Ok(file)
            }
            Op::DeleteArc {
                transition,
                place,
                input,
                ..
            } => {
                let i = self.transition_index(n, transition)?;
                let key = if *input { "from" } else { "to" };
                let removed = self
                    .transition_mut(n, i)
                    .and_then(|t| t.get_mut(key))
                    .and_then(Item::as_array_mut)
                    .is_some_and(|a| remove_from(a, place));
                if !removed {
                    return Err(EditError::UnknownArc {
                        net: net_name,
                        transition: transition.clone(),
                        place: place.clone(),
                        input: *input,
                    });
                }
                Ok(file)
            }
            Op::Move {
                kind, name, x, y, ..
            } => {
                match kind {
                    Kind::Place => self.check_place(n, name)?,
                    Kind::Transition => {
                        self.transition_index(n, name)?;
                    }
                }
                self.positions.set(&net_name, *kind, name, (*x, *y))?;
                Ok(Applied {
                    net_file: None,
                    layout: true,
                    project: false,
                    all: false,
                })
            }
            Op::Relayout { .. } => Ok(Applied {
                net_file: None,
                layout: self.positions.clear(&net_name),
                project: false,
                all: false,
            }),
            // Made above.
            Op::AddNet { .. }
            | Op::DeleteNet { .. }
            | Op::RenameNet { .. }
            | Op::SetActive { .. } => Ok(Applied::default()),
        }
    }
}

fn shape(file: &str, what: &str) -> EditError {
    EditError::Shape {
        file: file.to_owned(),
        what: what.to_owned(),
    }
}

#[cfg(test)]
#[path = "draft_tests.rs"]
mod tests;
