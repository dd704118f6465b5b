//! Which element a load problem concerns: the loader gives a file and a
//! byte range; in a net file, an offset inside a `[[transition]]` table is
//! that transition's, one inside the `places`, `initial` or `final` list
//! is the place written there, anything else the net's. Pure.

use serde::Serialize;
use toml_edit::{Document, Item};

use super::op::Kind;

/// Where a problem is shown.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Element {
    /// The net (none: the project's, e.g. project.toml).
    pub net: Option<String>,
    /// The place or transition (none: the net itself).
    pub kind: Option<&'static str>,
    pub name: Option<String>,
}

/// The byte offsets where each table header (`[x]`, `[[x]]`) starts, with
/// whether it is `[[transition]]`.
fn headers(text: &str) -> Vec<(usize, bool)> {
    let mut out = Vec::new();
    let mut at = 0;
    for line in text.split_inclusive('\n') {
        let t = line.trim_start();
        if t.starts_with('[') {
            let head = t.split('#').next().unwrap_or("").trim();
            let inner = head.trim_start_matches('[').trim_end_matches(']').trim();
            out.push((
                at + line.len() - t.len(),
                head.starts_with("[[") && inner == "transition",
            ));
        }
        at += line.len();
    }
    out
}

/// The element of net `net` (its file's `text`) at byte `offset`.
pub fn locate(net: &str, text: &str, offset: usize) -> Element {
    let whole = |kind: Option<Kind>, name: Option<String>| Element {
        net: Some(net.to_owned()),
        kind: kind.map(Kind::word),
        name,
    };
    let Ok(doc) = Document::parse(text) else {
        return whole(None, None);
    };
    // Inside a transition's table?
    let heads = headers(text);
    let mut k = 0;
    for (i, &(start, is_transition)) in heads.iter().enumerate() {
        let end = heads.get(i + 1).map_or(text.len() + 1, |h| h.0);
        if is_transition {
            if (start..end).contains(&offset) {
                let name = doc
                    .get("transition")
                    .and_then(Item::as_array_of_tables)
                    .and_then(|a| a.get(k))
                    .and_then(|t| t.get("name"))
                    .and_then(Item::as_str)
                    .map(str::to_owned);
                return whole(name.is_some().then_some(Kind::Transition), name);
            }
            k += 1;
        }
    }
    // In a list of places?
    for key in ["places", "initial", "final"] {
        let Some(a) = doc.get(key).and_then(Item::as_array) else {
            continue;
        };
        for v in a.iter() {
            if v.span().is_some_and(|s| s.contains(&offset)) {
                return whole(Some(Kind::Place), v.as_str().map(str::to_owned));
            }
        }
    }
    whole(None, None)
}

#[cfg(test)]
mod tests {
    use super::*;

    const A: &str = "name = \"A\"\nplaces = [\"idle\", \"busy\"]\ninitial = [\"idle\"]\n\n[[transition]]\nname = \"go\"\nfrom = [\"idle\"]\non = \"nope\"\n\n[[transition]]   # the second\nname = \"done\"\nfrom = [\"busy\"]\n";

    fn at(needle: &str) -> usize {
        A.find(needle).unwrap_or_else(|| panic!("{needle}"))
    }

    #[test]
    fn problems_land_on_their_element() {
        let go = locate("A", A, at("\"nope\""));
        assert_eq!(go.kind, Some("transition"));
        assert_eq!(go.name.as_deref(), Some("go"));
        assert_eq!(
            locate("A", A, at("[\"busy\"]\n")).name.as_deref(),
            Some("done")
        );
        let busy = locate("A", A, at("\"busy\""));
        assert_eq!(
            (busy.kind, busy.name.as_deref()),
            (Some("place"), Some("busy"))
        );
        assert_eq!(
            locate("A", A, at("[\"idle\"]\n\n") + 1).name.as_deref(),
            Some("idle")
        );
        let net = locate("A", A, 0);
        assert_eq!(
            (net.net.as_deref(), net.kind, net.name),
            (Some("A"), None, None)
        );
        // Broken TOML: the net.
        assert_eq!(locate("A", "name = ", 3).kind, None);
    }
}
