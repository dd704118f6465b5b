//! The layout file: where `petrel edit` draws the nodes a person moved, so
//! that the nets' own files stay as people write them. One file per
//! project, `layout.toml` beside `project.toml`, a table per net and kind:
//!
//! ```toml
//! [FLIGHT.places]
//! transit = [250.0, 120.0]
//! "@flying" = [40.0, 300.0]
//!
//! [FLIGHT.transitions]
//! arrive = [310.0, 120.0]
//! ```
//!
//! Nodes without an entry are laid out automatically (`nets::layout`).
//! Kept as a `toml_edit` document: comments a person adds survive.

use toml_edit::{value, Array, DocumentMut, Item, Table};

use super::op::{EditError, Kind};

/// The layout file's name, in the project folder.
pub const FILE: &str = "layout.toml";

fn table_name(kind: Kind) -> &'static str {
    match kind {
        Kind::Place => "places",
        Kind::Transition => "transitions",
    }
}

/// The stored positions of a project's nodes.
#[derive(Debug, Clone, Default)]
pub struct Positions {
    doc: DocumentMut,
}

/// How far from the origin a node may be drawn: far beyond any page, and
/// small enough that rounding to a tenth stays finite (`1e308 * 10` is
/// infinite, and was written into layout.toml as `inf`).
pub const FARTHEST: f64 = 1e6;

/// Whether `at` is a position the layout can store: two finite numbers
/// within [`FARTHEST`] of the origin.
pub fn drawable(at: (f64, f64)) -> bool {
    [at.0, at.1]
        .iter()
        .all(|v| v.is_finite() && v.abs() <= FARTHEST)
}

impl Positions {
    /// Reads the layout file's text; entries that are not two numbers are
    /// ignored (and dropped at the next write of their table).
    pub fn parse(text: &str) -> Result<Positions, EditError> {
        let doc: DocumentMut =
            text.parse()
                .map_err(|e: toml_edit::TomlError| EditError::Shape {
                    file: FILE.into(),
                    what: e.message().to_owned(),
                })?;
        Ok(Positions { doc })
    }

    pub fn text(&self) -> String {
        self.doc.to_string()
    }

    fn table(&self, net: &str, kind: Kind) -> Option<&Table> {
        self.doc
            .get(net)?
            .as_table()?
            .get(table_name(kind))?
            .as_table()
    }

    fn table_mut(&mut self, net: &str, kind: Kind) -> Option<&mut Table> {
        let item = &mut self.doc[net];
        if !item.is_table() {
            let mut t = Table::new();
            t.set_implicit(true);
            *item = Item::Table(t);
        }
        let item = &mut item[table_name(kind)];
        if !item.is_table() {
            *item = Item::Table(Table::new());
        }
        item.as_table_mut()
    }

    /// Where `name` is drawn, if stored.
    pub fn get(&self, net: &str, kind: Kind, name: &str) -> Option<(f64, f64)> {
        let a = self.table(net, kind)?.get(name)?.as_array()?;
        let num = |i: usize| {
            a.get(i)
                .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|n| n as f64)))
        };
        if a.len() != 2 {
            return None;
        }
        Some((num(0)?, num(1)?)).filter(|(x, y)| x.is_finite() && y.is_finite())
    }

    /// Stores where `name` is drawn (rounded to a tenth; refused unless
    /// [`drawable`]).
    pub fn set(
        &mut self,
        net: &str,
        kind: Kind,
        name: &str,
        at: (f64, f64),
    ) -> Result<(), EditError> {
        if !drawable(at) {
            return Err(EditError::BadPosition);
        }
        let round = |v: f64| (v * 10.0).round() / 10.0;
        let mut a = Array::new();
        a.push(round(at.0));
        a.push(round(at.1));
        let t = self.table_mut(net, kind).ok_or(EditError::BadPosition)?;
        match t.get_mut(name).and_then(Item::as_value_mut) {
            Some(v) => {
                let decor = v.decor().clone();
                *v = toml_edit::Value::Array(a);
                *v.decor_mut() = decor;
            }
            None => {
                t.insert(name, value(a));
            }
        }
        Ok(())
    }

    /// Forgets where `name` is drawn; true if it was stored.
    pub fn remove(&mut self, net: &str, kind: Kind, name: &str) -> bool {
        let Some(t) = self
            .doc
            .get_mut(net)
            .and_then(Item::as_table_mut)
            .and_then(|n| n.get_mut(table_name(kind)))
            .and_then(Item::as_table_mut)
        else {
            return false;
        };
        t.remove(name).is_some()
    }

    /// Carries a renamed node's position over; true if one was stored.
    pub fn rename(&mut self, net: &str, kind: Kind, from: &str, to: &str) -> bool {
        match self.get(net, kind, from) {
            Some(at) => {
                self.remove(net, kind, from);
                self.set(net, kind, to, at).is_ok()
            }
            None => false,
        }
    }

    /// Carries a renamed net's positions over; true if any were stored.
    pub fn rename_net(&mut self, from: &str, to: &str) -> bool {
        let root = self.doc.as_table_mut();
        match root.remove(from) {
            Some(item) => {
                root.insert(to, item);
                true
            }
            None => false,
        }
    }

    /// Forgets every position of `net`; true if there were any.
    pub fn clear(&mut self, net: &str) -> bool {
        self.doc.as_table_mut().remove(net).is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_are_stored_renamed_removed_and_comments_kept() {
        let text = "# moved by hand\n[A.places]\nidle = [1.0, 2.0] # here\n";
        let mut p = Positions::parse(text).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(p.get("A", Kind::Place, "idle"), Some((1.0, 2.0)));
        assert_eq!(p.get("A", Kind::Transition, "idle"), None);
        assert_eq!(p.get("B", Kind::Place, "idle"), None);
        p.set("A", Kind::Transition, "go", (10.04, 20.06))
            .unwrap_or_else(|e| panic!("{e}"));
        p.set("A", Kind::Place, "@busy", (3.0, 4.0))
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(p.get("A", Kind::Transition, "go"), Some((10.0, 20.1)));
        assert!(p.rename("A", Kind::Place, "idle", "rest"));
        assert_eq!(p.get("A", Kind::Place, "idle"), None);
        assert_eq!(p.get("A", Kind::Place, "rest"), Some((1.0, 2.0)));
        assert!(!p.rename("A", Kind::Place, "nothing", "x"));
        let out = p.text();
        assert!(out.starts_with("# moved by hand\n[A.places]\n"), "{out}");
        assert!(out.contains("\"@busy\" = [3.0, 4.0]"), "{out}");
        let again = Positions::parse(&out).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(again.get("A", Kind::Transition, "go"), Some((10.0, 20.1)));
        assert!(p.remove("A", Kind::Transition, "go"));
        assert!(!p.remove("A", Kind::Transition, "go"));
        assert!(p.clear("A"));
        assert_eq!(p.get("A", Kind::Place, "rest"), None);
        assert!(p.set("A", Kind::Place, "x", (f64::NAN, 1.0)).is_err());
        // Finite, but infinite once rounded (issue 39: `[inf, -inf]` was
        // written), or beyond any page.
        assert!(p.set("A", Kind::Place, "x", (1e308, -1e308)).is_err());
        assert!(p.set("A", Kind::Place, "x", (2e6, 0.0)).is_err());
        assert!(!p.text().contains("inf"), "{}", p.text());
    }

    #[test]
    fn entries_that_are_not_two_numbers_are_ignored() {
        let p = Positions::parse("[A.places]\na = [1]\nb = \"x\"\nc = [1, 2]\n")
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(p.get("A", Kind::Place, "a"), None);
        assert_eq!(p.get("A", Kind::Place, "b"), None);
        assert_eq!(p.get("A", Kind::Place, "c"), Some((1.0, 2.0)));
        assert!(Positions::parse("[A\n").is_err());
    }
}
