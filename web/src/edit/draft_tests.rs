//! The edit core: each edit changes what it concerns and nothing else
//! (byte for byte on a commented file), and bad edits are refused with
//! nothing changed.

use super::*;
use crate::edit::op::Op;

const PROJECT: &str = "name = \"p\"\n[[net]]\nfile = \"a.toml\"\nactive = true\n\n[globals]\ng = false\n\n[events]\nx = {}\ny = {}\n";

const A: &str = r#"# The net A: a comment at the top.
name = "A"
places = [
  "idle",   # waiting
  "busy",
]
initial = ["idle"]   # one token
final = []

# Start working.
[[transition]]
name = "go"
from = ["idle"]
to = ["busy"]
on = 'x'      # the event
do = ["emit y"]

# Done.
[[transition]]
name = "done"
from = ["busy"]
to = ["idle", "@g"]
on = "y"
"#;

fn draft() -> Draft {
    Draft::parse(PROJECT, &[("a.toml".into(), A.into())], "").unwrap_or_else(|e| panic!("{e}"))
}

fn text(d: &Draft) -> String {
    d.nets[0].doc.to_string()
}

fn ok(d: &mut Draft, op: Op) -> Applied {
    d.apply(&op).unwrap_or_else(|e| panic!("{op:?}: {e}"))
}

fn refused(d: &mut Draft, op: Op) -> EditError {
    let before = text(d);
    let layout = d.positions.text();
    let e = match d.apply(&op) {
        Ok(a) => panic!("{op:?} was made: {a:?}\n{}", text(d)),
        Err(e) => e,
    };
    assert_eq!(text(d), before, "{op:?} refused but changed the file");
    assert_eq!(
        d.positions.text(),
        layout,
        "{op:?} refused but changed the layout"
    );
    e
}

/// The draft's files load (the loader is the judge of the result).
fn loads(d: &Draft) -> Result<nets::Project, String> {
    let a = text(d);
    nets::load(&[("project.toml", PROJECT), ("a.toml", a.as_str())]).map_err(|e| e.to_string())
}

fn s(x: &str) -> String {
    x.to_owned()
}

#[test]
fn the_unedited_file_is_written_back_byte_for_byte() {
    assert_eq!(text(&draft()), A);
    assert!(loads(&draft()).is_ok());
    assert_eq!(Draft::net_files(PROJECT).ok(), Some(vec![s("a.toml")]));
}

#[test]
fn a_transition_is_appended_after_the_others_and_the_rest_is_unchanged() {
    let mut d = draft();
    let a = ok(
        &mut d,
        Op::AddTransition {
            net: s("A"),
            name: s("rest"),
            at: Some((300.0, 90.0)),
        },
    );
    assert_eq!(
        a,
        Applied {
            net_file: Some(0),
            layout: true,
            project: false,
            all: false,
        }
    );
    ok(
        &mut d,
        Op::AddArc {
            net: s("A"),
            transition: s("rest"),
            place: s("busy"),
            input: true,
        },
    );
    ok(
        &mut d,
        Op::AddArc {
            net: s("A"),
            transition: s("rest"),
            place: s("idle"),
            input: false,
        },
    );
    ok(
        &mut d,
        Op::SetTransition {
            net: s("A"),
            name: s("rest"),
            on: s("x"),
            when: s(""),
            actions: vec![],
        },
    );
    let out = text(&d);
    assert_eq!(
        out,
        format!("{A}\n[[transition]]\nname = \"rest\"\nfrom = [\"busy\"]\nto = [\"idle\"]\non = \"x\"\n")
    );
    assert_eq!(
        d.positions.get("A", Kind::Transition, "rest"),
        Some((300.0, 90.0))
    );
    let p = loads(&d).unwrap_or_else(|e| panic!("{e}\n{out}"));
    assert_eq!(p.nets[0].transitions.len(), 3);
}

#[test]
fn a_place_joins_a_list_written_one_a_line() {
    let mut d = draft();
    let a = ok(
        &mut d,
        Op::AddPlace {
            net: s("A"),
            name: s("spare"),
            at: None,
        },
    );
    assert_eq!(
        a,
        Applied {
            net_file: Some(0),
            layout: false,
            project: false,
            all: false,
        }
    );
    assert_eq!(
        text(&d),
        A.replace("  \"busy\",\n]", "  \"busy\",\n  \"spare\",\n]")
    );
    ok(
        &mut d,
        Op::SetPlace {
            net: s("A"),
            name: s("spare"),
            initial: None,
            is_final: Some(true),
        },
    );
    assert!(text(&d).contains("final = [\"spare\"]\n"), "{}", text(&d));
    ok(
        &mut d,
        Op::SetPlace {
            net: s("A"),
            name: s("spare"),
            initial: None,
            is_final: Some(false),
        },
    );
    assert!(text(&d).contains("final = []\n"));
    // Nothing to change: nothing written.
    let a = ok(
        &mut d,
        Op::SetPlace {
            net: s("A"),
            name: s("idle"),
            initial: Some(true),
            is_final: None,
        },
    );
    assert_eq!(a, Applied::default());
    assert!(loads(&d).is_ok());
}

#[test]
fn renaming_a_place_renames_it_everywhere_and_only_there() {
    let mut d = draft();
    d.positions
        .set("A", Kind::Place, "idle", (1.0, 2.0))
        .unwrap_or_else(|e| panic!("{e}"));
    let a = ok(
        &mut d,
        Op::RenamePlace {
            net: s("A"),
            name: s("idle"),
            to: s("waiting"),
        },
    );
    assert_eq!(
        a,
        Applied {
            net_file: Some(0),
            layout: true,
            project: false,
            all: false,
        }
    );
    assert_eq!(text(&d), A.replace("\"idle\"", "\"waiting\""));
    assert_eq!(
        d.positions.get("A", Kind::Place, "waiting"),
        Some((1.0, 2.0))
    );
    assert!(loads(&d).is_ok());
}

#[test]
fn renaming_a_transition_keeps_its_comment_and_place() {
    let mut d = draft();
    ok(
        &mut d,
        Op::RenameTransition {
            net: s("A"),
            name: s("go"),
            to: s("start"),
        },
    );
    assert_eq!(text(&d), A.replace("name = \"go\"", "name = \"start\""));
}

#[test]
fn setting_a_transition_changes_only_the_keys_that_differ() {
    let mut d = draft();
    // Same event, a guard added, actions removed.
    ok(
        &mut d,
        Op::SetTransition {
            net: s("A"),
            name: s("go"),
            on: s("x"),
            when: s("true"),
            actions: vec![],
        },
    );
    let want = A.replace(
        "on = 'x'      # the event\ndo = [\"emit y\"]\n",
        "on = 'x'      # the event\nwhen = \"true\"\n",
    );
    assert_eq!(text(&d), want);
    // The event changed: its comment stays.
    ok(
        &mut d,
        Op::SetTransition {
            net: s("A"),
            name: s("go"),
            on: s("y"),
            when: s("true"),
            actions: vec![s("emit x"), s(" "), s("emit y")],
        },
    );
    assert!(
        text(&d).contains(
            "on = \"y\"      # the event\nwhen = \"true\"\ndo = [\"emit x\", \"emit y\"]\n"
        ),
        "{}",
        text(&d)
    );
    // Immediate: `on` removed.
    ok(
        &mut d,
        Op::SetTransition {
            net: s("A"),
            name: s("done"),
            on: s(""),
            when: s(""),
            actions: vec![],
        },
    );
    assert!(!text(&d).contains("on = \"y\"\n"), "{}", text(&d));
    // Unchanged: nothing to write.
    let a = ok(
        &mut d,
        Op::SetTransition {
            net: s("A"),
            name: s("done"),
            on: s(""),
            when: s(""),
            actions: vec![],
        },
    );
    assert_eq!(a, Applied::default());
}

#[test]
fn actions_written_one_a_line_stay_so() {
    let a = A.replace("do = [\"emit y\"]", "do = [\n  \"emit y\",\n]");
    let mut d = Draft::parse(PROJECT, &[("a.toml".into(), a.clone())], "")
        .unwrap_or_else(|e| panic!("{e}"));
    ok(
        &mut d,
        Op::SetTransition {
            net: s("A"),
            name: s("go"),
            on: s("x"),
            when: s(""),
            actions: vec![s("emit y"), s("emit x")],
        },
    );
    assert_eq!(
        text(&d),
        a.replace("  \"emit y\",\n]", "  \"emit y\",\n  \"emit x\",\n]")
    );
}

#[test]
fn deleting_a_transition_removes_its_table_and_its_comment() {
    let mut d = draft();
    ok(
        &mut d,
        Op::DeleteTransition {
            net: s("A"),
            name: s("done"),
        },
    );
    let cut = A.find("\n# Done.").unwrap_or(A.len());
    assert_eq!(text(&d), &A[..cut]);
    ok(
        &mut d,
        Op::DeleteTransition {
            net: s("A"),
            name: s("go"),
        },
    );
    assert!(!text(&d).contains("[[transition]]"));
    assert!(text(&d).starts_with("# The net A: a comment at the top.\nname = \"A\"\n"));
}

#[test]
fn arcs_are_added_and_deleted_on_either_side() {
    let mut d = draft();
    ok(
        &mut d,
        Op::AddArc {
            net: s("A"),
            transition: s("go"),
            place: s("@g"),
            input: false,
        },
    );
    assert!(text(&d).contains("to = [\"busy\", \"@g\"]\n"));
    ok(
        &mut d,
        Op::DeleteArc {
            net: s("A"),
            transition: s("done"),
            place: s("idle"),
            input: false,
        },
    );
    assert!(text(&d).contains("to = [\"@g\"]\n"), "{}", text(&d));
    ok(
        &mut d,
        Op::DeleteArc {
            net: s("A"),
            transition: s("go"),
            place: s("idle"),
            input: true,
        },
    );
    assert!(text(&d).contains("from = []\n"));
    // The loader, not the draft, says a transition needs an input.
    let e = loads(&d).err().unwrap_or_default();
    assert!(e.contains("a.toml"), "{e}");
}

#[test]
fn a_place_in_use_is_not_deleted_and_a_free_one_is() {
    let mut d = draft();
    let e = refused(
        &mut d,
        Op::DeletePlace {
            net: s("A"),
            name: s("busy"),
        },
    );
    assert_eq!(
        e.to_string(),
        "place A.busy is used by go, done: delete those arcs first"
    );
    ok(
        &mut d,
        Op::AddPlace {
            net: s("A"),
            name: s("spare"),
            at: Some((5.0, 6.0)),
        },
    );
    ok(
        &mut d,
        Op::SetPlace {
            net: s("A"),
            name: s("spare"),
            initial: Some(true),
            is_final: None,
        },
    );
    let a = ok(
        &mut d,
        Op::DeletePlace {
            net: s("A"),
            name: s("spare"),
        },
    );
    assert_eq!(
        a,
        Applied {
            net_file: Some(0),
            layout: true,
            project: false,
            all: false,
        }
    );
    assert_eq!(text(&d), A);
    assert_eq!(d.positions.get("A", Kind::Place, "spare"), None);
}

#[test]
fn moves_touch_the_layout_only() {
    let mut d = draft();
    let a = ok(
        &mut d,
        Op::Move {
            net: s("A"),
            kind: Kind::Transition,
            name: s("go"),
            x: 10.0,
            y: 20.0,
        },
    );
    assert_eq!(
        a,
        Applied {
            net_file: None,
            layout: true,
            project: false,
            all: false,
        }
    );
    ok(
        &mut d,
        Op::Move {
            net: s("A"),
            kind: Kind::Place,
            name: s("@g"),
            x: 1.0,
            y: 2.0,
        },
    );
    assert_eq!(text(&d), A);
    assert_eq!(
        d.positions.get("A", Kind::Transition, "go"),
        Some((10.0, 20.0))
    );
    let a = ok(&mut d, Op::Relayout { net: s("A") });
    assert_eq!(
        a,
        Applied {
            net_file: None,
            layout: true,
            project: false,
            all: false,
        }
    );
    assert_eq!(d.positions.get("A", Kind::Transition, "go"), None);
    assert_eq!(ok(&mut d, Op::Relayout { net: s("A") }), Applied::default());
}

#[test]
fn bad_edits_are_refused_with_nothing_changed() {
    let mut d = draft();
    let cases: Vec<(Op, &str)> = vec![
        (
            Op::AddPlace {
                net: s("B"),
                name: s("x"),
                at: None,
            },
            "no net named `B`",
        ),
        (
            Op::AddPlace {
                net: s("A"),
                name: s("idle"),
                at: None,
            },
            "net A already has a place `idle`",
        ),
        (
            Op::AddPlace {
                net: s("A"),
                name: s("2x"),
                at: None,
            },
            "invalid place name `2x`",
        ),
        (
            Op::AddPlace {
                net: s("A"),
                name: s(""),
                at: None,
            },
            "invalid place name ``",
        ),
        (
            Op::AddPlace {
                net: s("A"),
                name: s("a b"),
                at: None,
            },
            "invalid place name `a b`",
        ),
        (
            Op::AddPlace {
                net: s("A"),
                name: s("ok"),
                at: Some((f64::INFINITY, 0.0)),
            },
            "a position must be two numbers between",
        ),
        (
            Op::RenamePlace {
                net: s("A"),
                name: s("nope"),
                to: s("x"),
            },
            "net A has no place `nope`",
        ),
        (
            Op::RenamePlace {
                net: s("A"),
                name: s("idle"),
                to: s("busy"),
            },
            "net A already has a place `busy`",
        ),
        (
            Op::RenamePlace {
                net: s("A"),
                name: s("@g"),
                to: s("h"),
            },
            "global place `@g` belongs to project.toml",
        ),
        (
            Op::RenamePlace {
                net: s("A"),
                name: s("idle"),
                to: s("@h"),
            },
            "global place `@h` belongs to project.toml",
        ),
        (
            Op::DeletePlace {
                net: s("A"),
                name: s("nope"),
            },
            "net A has no place `nope`",
        ),
        (
            Op::DeletePlace {
                net: s("A"),
                name: s("@g"),
            },
            "global place `@g`",
        ),
        (
            Op::SetPlace {
                net: s("A"),
                name: s("nope"),
                initial: Some(true),
                is_final: None,
            },
            "net A has no place `nope`",
        ),
        (
            Op::AddTransition {
                net: s("A"),
                name: s("go"),
                at: None,
            },
            "net A already has a transition `go`",
        ),
        (
            Op::AddTransition {
                net: s("A"),
                name: s("x-y"),
                at: None,
            },
            "invalid transition name `x-y`",
        ),
        (
            Op::RenameTransition {
                net: s("A"),
                name: s("nope"),
                to: s("x"),
            },
            "net A has no transition `nope`",
        ),
        (
            Op::RenameTransition {
                net: s("A"),
                name: s("go"),
                to: s("done"),
            },
            "net A already has a transition `done`",
        ),
        (
            Op::DeleteTransition {
                net: s("A"),
                name: s("nope"),
            },
            "net A has no transition `nope`",
        ),
        (
            Op::SetTransition {
                net: s("A"),
                name: s("nope"),
                on: s(""),
                when: s(""),
                actions: vec![],
            },
            "net A has no transition `nope`",
        ),
        (
            Op::AddArc {
                net: s("A"),
                transition: s("go"),
                place: s("nope"),
                input: true,
            },
            "net A has no place `nope`",
        ),
        (
            Op::AddArc {
                net: s("A"),
                transition: s("go"),
                place: s("@h"),
                input: true,
            },
            "no global place `@h`",
        ),
        (
            Op::AddArc {
                net: s("A"),
                transition: s("nope"),
                place: s("idle"),
                input: true,
            },
            "net A has no transition `nope`",
        ),
        (
            Op::AddArc {
                net: s("A"),
                transition: s("go"),
                place: s("idle"),
                input: true,
            },
            "A.go already has an input arc from idle",
        ),
        (
            Op::AddArc {
                net: s("A"),
                transition: s("done"),
                place: s("@g"),
                input: false,
            },
            "A.done already has an output arc to @g",
        ),
        (
            Op::DeleteArc {
                net: s("A"),
                transition: s("go"),
                place: s("busy"),
                input: true,
            },
            "A.go has no input arc from busy",
        ),
        (
            Op::DeleteArc {
                net: s("A"),
                transition: s("go"),
                place: s("idle"),
                input: false,
            },
            "A.go has no output arc to idle",
        ),
        (
            Op::Move {
                net: s("A"),
                kind: Kind::Place,
                name: s("go"),
                x: 0.0,
                y: 0.0,
            },
            "net A has no place `go`",
        ),
        (
            Op::Move {
                net: s("A"),
                kind: Kind::Transition,
                name: s("idle"),
                x: 0.0,
                y: 0.0,
            },
            "net A has no transition `idle`",
        ),
        (
            Op::Move {
                net: s("A"),
                kind: Kind::Place,
                name: s("idle"),
                x: f64::NAN,
                y: 0.0,
            },
            "a position must be two numbers between",
        ),
        (
            Op::Move {
                net: s("A"),
                kind: Kind::Place,
                name: s("idle"),
                x: 1e308,
                y: 0.0,
            },
            "a position must be two numbers between",
        ),
        (Op::Relayout { net: s("Z") }, "no net named `Z`"),
    ];
    for (op, want) in cases {
        let e = refused(&mut d, op.clone());
        assert!(
            e.to_string().starts_with(want),
            "{op:?}: {e} (wanted {want})"
        );
    }
    assert_eq!(text(&d), A);
}

#[test]
fn ops_come_from_the_page_as_json() {
    let op: Op = serde_json::from_str(
        r#"{"op":"add_arc","net":"A","transition":"go","place":"@g","input":false}"#,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        op,
        Op::AddArc {
            net: s("A"),
            transition: s("go"),
            place: s("@g"),
            input: false
        }
    );
    let op: Op = serde_json::from_str(r#"{"op":"set_place","net":"A","name":"idle","final":true}"#)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        op,
        Op::SetPlace {
            net: s("A"),
            name: s("idle"),
            initial: None,
            is_final: Some(true)
        }
    );
    let op: Op = serde_json::from_str(
        r#"{"op":"move","net":"A","kind":"place","name":"idle","x":1,"y":2.5}"#,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(op.net(), "A");
    assert!(serde_json::from_str::<Op>(r#"{"op":"explode","net":"A"}"#).is_err());
    assert!(
        serde_json::from_str::<Op>(r#"{"op":"add_place","net":"A","name":"x","extra":1}"#).is_err()
    );
}

#[test]
fn a_file_that_is_not_toml_is_reported_with_its_name() {
    let e = Draft::parse(PROJECT, &[("a.toml".into(), "name = \n".into())], "");
    match e {
        Err(EditError::Shape { file, .. }) => assert_eq!(file, "a.toml"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_net_added_gets_its_file_and_a_net_table_after_the_last_one() {
    // A commented project.toml with tables after the nets.
    let project = "# The project.\nname = \"p\"\n\n[[net]]\nfile = \"a.toml\"   # first\nactive = true\n\n# Globals: shared.\n[globals]\ng = false\n\n[events]\nx = {}\n";
    let mut d =
        Draft::parse(project, &[("a.toml".into(), A.into())], "").unwrap_or_else(|e| panic!("{e}"));
    let a = ok(
        &mut d,
        Op::AddNet {
            name: "NEW".into(),
            active: true,
        },
    );
    assert_eq!(
        a,
        Applied {
            net_file: Some(1),
            layout: false,
            project: true,
            all: false,
        }
    );
    assert_eq!(
        d.project.to_string(),
        project.replace(
            "# first\nactive = true\n",
            "# first\nactive = true\n\n[[net]]\nfile = \"NEW.toml\"\nactive = true\n"
        )
    );
    assert_eq!(d.nets[1].file, "NEW.toml");
    assert_eq!(d.nets[1].name(), "NEW");
    assert_eq!(d.nets[1].doc.to_string(), new_net_text("NEW"));
    assert_eq!(text(&d), A, "the other net untouched");
    // Editable at once: a transition on it.
    ok(
        &mut d,
        Op::AddTransition {
            net: "NEW".into(),
            name: "t1".into(),
            at: None,
        },
    );
    assert!(d.nets[1]
        .doc
        .to_string()
        .ends_with("\n[[transition]]\nname = \"t1\"\nfrom = []\nto = []\n"));
    // A second one, inactive, goes after the first added.
    ok(
        &mut d,
        Op::AddNet {
            name: "_later".into(),
            active: false,
        },
    );
    assert!(d.project.to_string().contains(
        "active = true\n\n[[net]]\nfile = \"NEW.toml\"\nactive = true\n\n[[net]]\nfile = \"_later.toml\"\nactive = false\n\n# Globals: shared.\n"
    ), "{}", d.project);

    // Refused, nothing changed: a name taken, malformed, or whose file is
    // the project's.
    let before = d.project.to_string();
    for (name, want) in [
        ("A", EditError::DuplicateNet("A".into())),
        ("NEW", EditError::DuplicateNet("NEW".into())),
        (
            "1st",
            EditError::BadName {
                kind: "net",
                name: "1st".into(),
            },
        ),
        (
            "a b",
            EditError::BadName {
                kind: "net",
                name: "a b".into(),
            },
        ),
        (
            "",
            EditError::BadName {
                kind: "net",
                name: "".into(),
            },
        ),
        ("project", EditError::FileExists("project.toml".into())),
        ("layout", EditError::FileExists("layout.toml".into())),
        ("a", EditError::FileExists("a.toml".into())),
    ] {
        let e = d.apply(&Op::AddNet {
            name: name.into(),
            active: true,
        });
        assert_eq!(e, Err(want), "{name}");
        assert_eq!(d.project.to_string(), before);
        assert_eq!(d.nets.len(), 3);
    }
    // A project.toml whose `net` is not [[net]] tables: refused.
    let mut odd = Draft::parse("net = 3\n", &[], "").unwrap_or_else(|e| panic!("{e}"));
    assert!(matches!(
        odd.apply(&Op::AddNet {
            name: "N".into(),
            active: true
        }),
        Err(EditError::Shape { .. })
    ));
    assert_eq!(odd.project.to_string(), "net = 3\n");
    assert!(odd.nets.is_empty());
    // The op as the page sends it; `active` defaults to false.
    let op: Op =
        serde_json::from_str(r#"{"op":"add_net","name":"N"}"#).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        op,
        Op::AddNet {
            name: "N".into(),
            active: false
        }
    );
    assert_eq!(op.describe(), "add net N");
}

#[test]
fn a_net_added_loads_and_is_dead_until_given_a_transition() {
    let project = "name = \"p\"\n\n[[net]]\nfile = \"a.toml\"\nactive = true\n\n[globals]\ng = false\n\n[events]\nx = {}\ny = {}\n";
    let mut d =
        Draft::parse(project, &[("a.toml".into(), A.into())], "").unwrap_or_else(|e| panic!("{e}"));
    ok(
        &mut d,
        Op::AddNet {
            name: "NEW".into(),
            active: true,
        },
    );
    let mut files: std::collections::BTreeMap<String, String> = d
        .nets
        .iter()
        .map(|n| (n.file.clone(), n.doc.to_string()))
        .collect();
    files.insert("project.toml".into(), d.project.to_string());
    let project = nets::load(&files).unwrap_or_else(|e| panic!("{e:?}"));
    assert!(project.nets.iter().any(|n| n.name == "NEW"));
}

#[test]
fn a_draft_reread_is_the_draft_parsed_anew() {
    let mut d = draft();
    ok(
        &mut d,
        Op::AddPlace {
            net: "A".into(),
            name: "spare".into(),
            at: Some((10.0, 20.0)),
        },
    );
    let (net, layout) = (text(&d), d.positions.text());
    // The files as they were, read again over the edited draft: the
    // original draft's texts.
    let back = d
        .reread(&["a.toml", "layout.toml"], |f| match f {
            "a.toml" => Some(A.to_owned()),
            _ => None,
        })
        .unwrap_or_else(|| panic!("not reread"));
    assert_eq!(text(&back), A);
    assert_eq!(back.positions.text(), draft().positions.text());
    // And forward again.
    let again = back
        .reread(&["a.toml", "layout.toml"], |f| match f {
            "a.toml" => Some(net.clone()),
            _ => Some(layout.clone()),
        })
        .unwrap_or_else(|| panic!("not reread"));
    assert_eq!(text(&again), net);
    assert_eq!(again.positions.text(), layout);
    // project.toml, a file not the draft's, one gone or not TOML: None.
    assert!(d
        .reread(&["project.toml"], |_| Some(PROJECT.into()))
        .is_none());
    assert!(d.reread(&["b.toml"], |_| Some(A.into())).is_none());
    assert!(d.reread(&["a.toml"], |_| None).is_none());
    assert!(d
        .reread(&["a.toml"], |_| Some("name = \n".into()))
        .is_none());
}

// ---- nets deleted and renamed --------------------------------------------

const P3: &str = "# The project.\nname = \"p\"\n\n# The main net.\n[[net]]\nfile = \"a.toml\"   # first\nactive = true\n\n# Its helper.\n[[net]]\nfile = \"nets/B.toml\"\nactive = false\n\n[[net]]\nfile = \"C.toml\"\nactive = true\n\n# Globals: shared.\n[globals]\ng = false\n\n[events]\nx = {}\ny = {}\n";

const B: &str = "# B: started by A.\nname = \"B\"\nplaces = [\"wait\", \"on\"]\ninitial = [\"wait\"]\nfinal = [\"on\"]\n\n[[transition]]\nname = \"stop\"\nfrom = [\"wait\"]\nto = [\"on\"]\non = \"y\"\ndo = [\n  \"deactivate B\",   # itself\n]\n";

const C: &str =
    "name = \"C\" # alone\nplaces = [\"idle\"]\ninitial = [\"idle\"]\nfinal = [\"idle\"]\n";

const LAYOUT3: &str = "# by hand\n[B.places]\nwait = [1.0, 2.0]\n\n[C.places]\nidle = [3.0, 4.0]\n";

fn a3() -> String {
    A.replace("do = [\"emit y\"]", "do = [\"emit y\", \"activate B\"]")
}

fn draft3() -> Draft {
    Draft::parse(
        P3,
        &[
            ("a.toml".into(), a3()),
            ("nets/B.toml".into(), B.into()),
            ("C.toml".into(), C.into()),
        ],
        LAYOUT3,
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

/// Every file of the draft: (file, text), project.toml first, the layout
/// last.
fn files3(d: &Draft) -> Vec<(String, String)> {
    let mut f = vec![(s("project.toml"), d.project.to_string())];
    f.extend(d.nets.iter().map(|n| (n.file.clone(), n.doc.to_string())));
    f.push((s("layout.toml"), d.positions.text()));
    f
}

fn loads3(d: &Draft) -> Result<nets::Project, String> {
    let f = files3(d);
    let f: std::collections::BTreeMap<String, String> = f[..f.len() - 1].iter().cloned().collect();
    nets::load(&f).map_err(|e| format!("{e:?}"))
}

fn refused3(d: &mut Draft, op: Op) -> EditError {
    let before = files3(d);
    let e = match d.apply(&op) {
        Ok(a) => panic!("{op:?} was made: {a:?}"),
        Err(e) => e,
    };
    assert_eq!(files3(d), before, "{op:?} refused but changed a file");
    e
}

#[test]
fn the_three_net_project_loads_as_written() {
    let d = draft3();
    assert_eq!(
        files3(&d),
        vec![
            (s("project.toml"), s(P3)),
            (s("a.toml"), a3()),
            (s("nets/B.toml"), s(B)),
            (s("C.toml"), s(C)),
            (s("layout.toml"), s(LAYOUT3)),
        ]
    );
    assert!(loads3(&d).is_ok(), "{:?}", loads3(&d).err());
}

#[test]
fn a_net_deleted_leaves_every_other_byte() {
    let mut d = draft3();
    let a = ok(&mut d, Op::DeleteNet { name: s("C") });
    assert_eq!(
        a,
        Applied {
            all: true,
            ..Applied::default()
        }
    );
    assert_eq!(
        files3(&d),
        vec![
            (
                s("project.toml"),
                P3.replace("\n[[net]]\nfile = \"C.toml\"\nactive = true\n", "")
            ),
            (s("a.toml"), a3()),
            (s("nets/B.toml"), s(B)),
            (
                s("layout.toml"),
                s("# by hand\n[B.places]\nwait = [1.0, 2.0]\n")
            ),
        ]
    );
    assert!(loads3(&d).is_ok(), "{:?}", loads3(&d).err());
    // A net named only by itself goes too (B's own `deactivate B`), once
    // A no longer names it; and A, named by no one, goes after it... but
    // not the last net.
    let mut d = draft3();
    let go = Op::SetTransition {
        net: s("A"),
        name: s("go"),
        on: s("x"),
        when: s(""),
        actions: vec![s("emit y")],
    };
    ok(&mut d, go);
    ok(&mut d, Op::DeleteNet { name: s("B") });
    assert_eq!(
        d.project.to_string(),
        P3.replace(
            "# Its helper.\n[[net]]\nfile = \"nets/B.toml\"\nactive = false\n\n",
            ""
        )
    );
    // The comment above B's table went with it, as a `[[net]]` table's.
    assert_eq!(d.positions.text(), "\n[C.places]\nidle = [3.0, 4.0]\n");
    assert!(loads3(&d).is_ok(), "{:?}", loads3(&d).err());
    ok(&mut d, Op::DeleteNet { name: s("A") });
    assert_eq!(
        d.nets
            .iter()
            .map(|n| n.name().to_owned())
            .collect::<Vec<_>>(),
        vec![s("C")]
    );
    // The first table gone with its comment; the project's own kept.
    assert_eq!(
        d.project.to_string(),
        "# The project.\nname = \"p\"\n\n[[net]]\nfile = \"C.toml\"\nactive = true\n\n# Globals: shared.\n[globals]\ng = false\n\n[events]\nx = {}\ny = {}\n"
    );
    assert_eq!(
        refused3(&mut d, Op::DeleteNet { name: s("C") }),
        EditError::LastNet(s("C"))
    );
    assert!(loads3(&d).is_ok(), "{:?}", loads3(&d).err());
}

#[test]
fn a_net_named_by_another_or_unknown_is_not_deleted() {
    let mut d = draft3();
    let e = refused3(&mut d, Op::DeleteNet { name: s("B") });
    assert_eq!(
        e,
        EditError::NetInUse {
            net: s("B"),
            uses: vec![s("A.go: `activate B`")],
        }
    );
    assert_eq!(
        e.to_string(),
        "net B is named by A.go: `activate B`: change those first (nothing written)"
    );
    assert_eq!(
        refused3(&mut d, Op::DeleteNet { name: s("Z") }),
        EditError::UnknownNet(s("Z"))
    );
    // The project's only net.
    let mut one = draft();
    let before = (one.project.to_string(), text(&one));
    assert_eq!(
        one.apply(&Op::DeleteNet { name: s("A") }),
        Err(EditError::LastNet(s("A")))
    );
    assert_eq!((one.project.to_string(), text(&one)), before);
}

#[test]
fn a_net_renamed_is_renamed_where_the_loader_reads_it_and_its_file_with_it() {
    let mut d = draft3();
    let a = ok(
        &mut d,
        Op::RenameNet {
            name: s("B"),
            to: s("Helper"),
        },
    );
    assert_eq!(
        a,
        Applied {
            all: true,
            ..Applied::default()
        }
    );
    assert_eq!(
        files3(&d),
        vec![
            (
                s("project.toml"),
                P3.replace("file = \"nets/B.toml\"", "file = \"nets/Helper.toml\"")
            ),
            (
                s("a.toml"),
                a3().replace("\"activate B\"", "\"activate Helper\"")
            ),
            (
                s("nets/Helper.toml"),
                B.replace("name = \"B\"", "name = \"Helper\"").replace(
                    "\"deactivate B\",   # itself",
                    "\"deactivate Helper\",   # itself"
                )
            ),
            (s("C.toml"), s(C)),
            (
                s("layout.toml"),
                LAYOUT3.replace("[B.places]", "[Helper.places]")
            ),
        ]
    );
    let p = loads3(&d).unwrap_or_else(|e| panic!("{e}"));
    assert!(p.nets.iter().any(|n| n.name == "Helper"));
    assert!(!p.nets.iter().any(|n| n.name == "B"));
    // A net whose file is not named after it keeps its file: `a.toml`
    // holds A.
    ok(
        &mut d,
        Op::RenameNet {
            name: s("A"),
            to: s("Main"),
        },
    );
    assert_eq!(d.nets[0].file, "a.toml");
    assert_eq!(
        d.nets[0].doc.to_string(),
        a3().replace("\"activate B\"", "\"activate Helper\"")
            .replace("name = \"A\"", "name = \"Main\"")
    );
    assert!(d
        .project
        .to_string()
        .contains("file = \"a.toml\"   # first\n"));
    // The same name: nothing to do, nothing written.
    let before = files3(&d);
    assert_eq!(
        ok(
            &mut d,
            Op::RenameNet {
                name: s("C"),
                to: s("C"),
            }
        ),
        Applied::default()
    );
    assert_eq!(files3(&d), before);
    assert!(loads3(&d).is_ok(), "{:?}", loads3(&d).err());
}

#[test]
fn a_net_is_not_renamed_to_a_name_taken_or_malformed_or_over_a_file() {
    let mut d = draft3();
    for (name, to, want) in [
        ("B", "C", EditError::DuplicateNet(s("C"))),
        ("B", "A", EditError::DuplicateNet(s("A"))),
        (
            "B",
            "1st",
            EditError::BadName {
                kind: "net",
                name: s("1st"),
            },
        ),
        (
            "B",
            "B@R1",
            EditError::BadName {
                kind: "net",
                name: s("B@R1"),
            },
        ),
        ("C", "a", EditError::FileExists(s("a.toml"))),
        ("C", "project", EditError::FileExists(s("project.toml"))),
        ("C", "layout", EditError::FileExists(s("layout.toml"))),
        ("Z", "Y", EditError::UnknownNet(s("Z"))),
    ] {
        let e = refused3(
            &mut d,
            Op::RenameNet {
                name: s(name),
                to: s(to),
            },
        );
        assert_eq!(e, want, "{name} → {to}");
    }
}

#[test]
fn exclusive_places_and_instances_name_a_net_too() {
    // Not a loadable team (no vehicles): the draft's reading only.
    let project = format!(
        "{P3}\n[[exclusive]]\nname = \"arm\"\nplaces = [\"B.on\", \"C.idle\"]   # shared\n"
    );
    let a = a3().replace("\"activate B\"", "\"activate B@R1\", \"deactivate Bx\"");
    let mut d = Draft::parse(
        &project,
        &[
            ("a.toml".into(), a.clone()),
            ("nets/B.toml".into(), B.into()),
            ("C.toml".into(), C.into()),
        ],
        "",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        refused3(&mut d, Op::DeleteNet { name: s("B") }),
        EditError::NetInUse {
            net: s("B"),
            uses: vec![
                s("A.go: `activate B@R1`"),
                s("project.toml [[exclusive]] arm: `B.on`")
            ],
        }
    );
    ok(
        &mut d,
        Op::RenameNet {
            name: s("B"),
            to: s("Rover"),
        },
    );
    assert_eq!(
        d.project.to_string(),
        project
            .replace("\"B.on\", \"C.idle\"", "\"Rover.on\", \"C.idle\"")
            .replace("nets/B.toml", "nets/Rover.toml")
    );
    assert_eq!(
        d.nets[0].doc.to_string(),
        a.replace("activate B@R1", "activate Rover@R1"),
        "`Bx` is another net"
    );
    assert_eq!(named_net("activate X@R2"), Some((s("X"), 9..10)));
    assert_eq!(named_net("  deactivate  Y"), Some((s("Y"), 14..15)));
    assert_eq!(named_net("emit X"), None);
    assert_eq!(named_net("activate"), None);
}

#[test]
fn net_ops_come_from_the_page_as_json() {
    let op: Op =
        serde_json::from_str(r#"{"op":"delete_net","name":"B"}"#).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(op, Op::DeleteNet { name: s("B") });
    assert_eq!(op.describe(), "delete net B");
    let op: Op = serde_json::from_str(r#"{"op":"rename_net","name":"B","to":"H"}"#)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        op,
        Op::RenameNet {
            name: s("B"),
            to: s("H")
        }
    );
    assert_eq!(op.describe(), "rename net B to H");
}

#[test]
fn a_net_set_active_or_not_changes_only_its_active_key() {
    let mut d = draft3();
    assert_eq!(
        (0..3).map(|n| d.net_active(n)).collect::<Vec<_>>(),
        vec![true, false, true]
    );
    // Set: B's `active = false` becomes true, in place.
    let set = Op::SetActive {
        name: s("B"),
        active: true,
    };
    assert_eq!(set.describe(), "set net B active at start");
    let a = ok(&mut d, set);
    assert_eq!(
        a,
        Applied {
            all: true,
            ..Applied::default()
        }
    );
    let p_b = P3.replace(
        "file = \"nets/B.toml\"\nactive = false\n",
        "file = \"nets/B.toml\"\nactive = true\n",
    );
    assert_ne!(p_b, P3);
    let mut want = files3(&draft3());
    want[0].1 = p_b.clone();
    assert_eq!(files3(&d), want);
    assert!(d.net_active(1));
    assert!(loads3(&d).is_ok(), "{:?}", loads3(&d).err());
    // Unset: A's `active = true` becomes an explicit false (not removed).
    ok(
        &mut d,
        Op::SetActive {
            name: s("A"),
            active: false,
        },
    );
    want[0].1 = p_b.replace(
        "file = \"a.toml\"   # first\nactive = true\n",
        "file = \"a.toml\"   # first\nactive = false\n",
    );
    assert_ne!(want[0].1, p_b);
    assert_eq!(files3(&d), want);
    assert!(!d.net_active(0));
    // And back: the original bytes.
    ok(
        &mut d,
        Op::SetActive {
            name: s("A"),
            active: true,
        },
    );
    ok(
        &mut d,
        Op::SetActive {
            name: s("B"),
            active: false,
        },
    );
    assert_eq!(files3(&d), files3(&draft3()));
}

#[test]
fn a_net_table_without_active_gets_the_key_and_its_comment_stays() {
    // C's table has no `active` (the loader's default: not active); A's
    // carries a comment after its value.
    let p = P3
        .replace("file = \"C.toml\"\nactive = true\n", "file = \"C.toml\"\n")
        .replace(
            "file = \"a.toml\"   # first\nactive = true\n",
            "file = \"a.toml\"   # first\nactive = true  # starts it all\n",
        );
    let mut d = Draft::parse(
        &p,
        &[
            ("a.toml".into(), a3()),
            ("nets/B.toml".into(), B.into()),
            ("C.toml".into(), C.into()),
        ],
        LAYOUT3,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(!d.net_active(2));
    assert_eq!(
        refused3(
            &mut d,
            Op::SetActive {
                name: s("C"),
                active: false,
            }
        ),
        EditError::AlreadyActive {
            net: s("C"),
            active: false,
        }
    );
    ok(
        &mut d,
        Op::SetActive {
            name: s("C"),
            active: true,
        },
    );
    assert_eq!(
        d.project.to_string(),
        p.replace("file = \"C.toml\"\n", "file = \"C.toml\"\nactive = true\n")
    );
    // Set back to the default: written explicitly, not removed.
    ok(
        &mut d,
        Op::SetActive {
            name: s("C"),
            active: false,
        },
    );
    assert_eq!(
        d.project.to_string(),
        p.replace("file = \"C.toml\"\n", "file = \"C.toml\"\nactive = false\n")
    );
    ok(
        &mut d,
        Op::SetActive {
            name: s("A"),
            active: false,
        },
    );
    assert!(
        d.project
            .to_string()
            .contains("file = \"a.toml\"   # first\nactive = false  # starts it all\n"),
        "{}",
        d.project
    );
    assert!(loads3(&d).is_ok(), "{:?}", loads3(&d).err());
}

#[test]
fn active_at_start_is_refused_for_an_unknown_net_or_no_change() {
    let mut d = draft3();
    assert_eq!(
        refused3(
            &mut d,
            Op::SetActive {
                name: s("Z"),
                active: true,
            }
        ),
        EditError::UnknownNet(s("Z"))
    );
    let e = refused3(
        &mut d,
        Op::SetActive {
            name: s("A"),
            active: true,
        },
    );
    assert_eq!(
        e.to_string(),
        "net A is already active at start (nothing written)"
    );
    let e = refused3(
        &mut d,
        Op::SetActive {
            name: s("B"),
            active: false,
        },
    );
    assert_eq!(
        e.to_string(),
        "net B is already not active at start (nothing written)"
    );
    // An `active` that is not a boolean is left to the person.
    let mut odd = Draft::parse(
        &P3.replace(
            "file = \"nets/B.toml\"\nactive = false\n",
            "file = \"nets/B.toml\"\nactive = \"no\"\n",
        ),
        &[
            ("a.toml".into(), a3()),
            ("nets/B.toml".into(), B.into()),
            ("C.toml".into(), C.into()),
        ],
        LAYOUT3,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    // Read as not active: asking for false is a no-op; true is refused too.
    assert!(matches!(
        refused3(
            &mut odd,
            Op::SetActive {
                name: s("B"),
                active: true,
            }
        ),
        EditError::Shape { .. }
    ));
    // From the page.
    let op: Op = serde_json::from_str(r#"{"op":"set_active","name":"B","active":true}"#)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        op,
        Op::SetActive {
            name: s("B"),
            active: true,
        }
    );
    assert!(serde_json::from_str::<Op>(r#"{"op":"set_active","name":"B"}"#).is_err());
}
