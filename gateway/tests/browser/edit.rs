//! The editor in a real browser (docs/monitor.md, "Editing"): Debian's
//! chromium, headless, driven by playwright-core (`tests/edit/driver.js`).
//! The flight-test example is copied to a temporary folder and `petrel
//! edit` serves it; through the page (real clicks and typing) a transition
//! is added to COMMUNICATION — first without arcs, the loader's problem
//! shown on it — then named, given its event and arcs, and its place
//! dragged: the net's TOML on disk must be the original with exactly that
//! transition appended, the other files untouched, the position in
//! layout.toml, and a fresh `petrel check` of the copy must hold. Then a
//! place and an arc that let the new transition put a second token in it:
//! the page's check fails, its counterexample is stepped through to the
//! double token, and a fresh `petrel check` fails too.
//!
//! Needs node, playwright-core and /usr/bin/chromium as tests/monitor.rs
//! does: skipped with the reason without them, failed under `CI=true`.
//! Screenshots go to `target/tmp/monitor/edit-*.png`.

use crate::scratch;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use serde_json::Value as Json;

use crate::browser;

use browser::{copy_example, repo, require, strings, Reaped};
use scratch::Scratch;

const PETREL: &str = env!("CARGO_BIN_EXE_petrel");

fn example() -> PathBuf {
    repo().join("examples/uav-flight-test")
}

/// `petrel edit DIR` on a free port; the child and the page's URL.
fn edit(dir: &Path) -> (Reaped, String) {
    let mut child = Command::new(PETREL)
        .args(["edit", "--http", "127.0.0.1:0"])
        .arg(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start petrel: {e}"));
    let err = child.stderr.take().unwrap_or_else(|| panic!("no stderr"));
    let child = Reaped(child);
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(err).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let until = Instant::now() + Duration::from_secs(30);
    let mut said = Vec::new();
    while let Some(left) = until.checked_duration_since(Instant::now()) {
        match rx.recv_timeout(left) {
            Ok(line) => {
                if let Some(rest) = line.strip_prefix("edit: ") {
                    let url = rest.split_whitespace().next().unwrap_or("").to_owned();
                    return (child, url);
                }
                said.push(line);
            }
            Err(_) => break,
        }
    }
    panic!(
        "petrel edit never gave its address; it said:\n{}",
        said.join("\n")
    )
}

/// Runs the editor's driver; its JSON. Bounded: the driver's own waits
/// (a check of the example included) add up to well under 600 s.
fn drive(tools: &(PathBuf, PathBuf, PathBuf), mode: &str, url: &str, shots: &Path) -> Json {
    let shots = shots.to_string_lossy();
    browser::drive_script(
        tools,
        "gateway/tests/edit/driver.js",
        &[mode, url, &shots],
        &[],
        Duration::from_secs(600),
    )
}

/// A fresh `petrel check` of the folder: its exit status.
fn check(dir: &Path) -> Option<i32> {
    let out = Command::new(PETREL)
        .args(["check", "--json"])
        .arg(dir)
        .output()
        .unwrap_or_else(|e| panic!("cannot run petrel check: {e}"));
    out.status.code()
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn a_transition_added_in_the_page_is_written_checked_and_its_counterexample_stepped() {
    let Some(tools) = require() else { return };
    let shots = browser::shots();
    let tmp = Scratch::new("edit");
    let dir = tmp.path();
    copy_example(dir);
    let original = read(&example().join("communication.toml"));

    let (editor, url) = edit(dir);
    let seen = drive(&tools, "add", &url, &shots);
    // Every net of the example drawn.
    assert_eq!(
        seen["nets"].as_array().map(Vec::len),
        Some(8),
        "{}",
        seen["nets"]
    );
    assert!(strings(&seen["ids"]).contains(&"t-COMMUNICATION-gcs_lost".to_owned()));
    // The transition without input: the loader's problem on it.
    let rows = strings(&seen["error_rows"]).join("\n");
    assert!(
        rows.contains("COMMUNICATION.t1") && rows.contains("no input place"),
        "{rows}"
    );
    assert!(
        seen["error_title"]
            .as_str()
            .unwrap_or("")
            .contains("no input place"),
        "{}",
        seen["error_title"]
    );
    assert!(
        seen["error_form"]
            .as_str()
            .unwrap_or("")
            .contains("communication.toml:"),
        "{}",
        seen["error_form"]
    );
    assert_eq!(seen["problems_after"], 0, "the finished transition loads");
    assert_eq!(seen["check"]["state"], "holds", "{}", seen["check"]);

    // On disk: the original, the transition appended, nothing else.
    let now = read(&dir.join("communication.toml"));
    assert_eq!(
        now,
        format!("{original}\n[[transition]]\nname = \"rc_back\"\nfrom = [\"proceeding\"]\nto = [\"proceeding\"]\non = \"link_degraded\"\n")
    );
    for entry in std::fs::read_dir(example()).unwrap_or_else(|e| panic!("{e}")) {
        let path = entry.unwrap_or_else(|e| panic!("{e}")).path();
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        if path.is_file() && name != "communication.toml" {
            assert_eq!(read(&dir.join(&name)), read(&path), "{name} changed");
        }
    }
    // The dragged place and the transition put where clicked: layout.toml.
    let layout: toml::Table = read(&dir.join("layout.toml"))
        .parse()
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(
        layout["COMMUNICATION"]["places"]
            .get("proceeding")
            .is_some(),
        "{layout}"
    );
    assert!(
        layout["COMMUNICATION"]["transitions"]
            .get("rc_back")
            .is_some(),
        "{layout}"
    );
    assert_eq!(
        check(dir),
        Some(0),
        "a fresh petrel check of the edited copy"
    );

    // A second token possible in a new place: the check fails.
    let seen = drive(&tools, "break", &url, &shots);
    drop(editor);
    assert_eq!(seen["check"]["state"], "violated", "{}", seen["check"]);
    assert!(
        seen["title"]
            .as_str()
            .unwrap_or("")
            .contains("double token"),
        "{}",
        seen["title"]
    );
    let steps = seen["steps"].as_array().cloned().unwrap_or_default();
    assert!(
        steps.len() >= 3,
        "the start and two firings at least: {steps:?}"
    );
    let p1 = "p-COMMUNICATION-p1".to_owned();
    let first = &steps[0];
    let last = &steps[steps.len() - 1];
    assert!(
        strings(&first["marked"]).contains(&"p-COMMUNICATION-proceeding".to_owned()),
        "{first}"
    );
    assert!(!strings(&first["marked"]).contains(&p1), "{first}");
    assert!(strings(&last["marked"]).contains(&p1), "{last}");
    assert!(
        strings(&last["fired"]).contains(&"t-COMMUNICATION-rc_back".to_owned()),
        "{last}"
    );
    assert!(
        last["label"]
            .as_str()
            .unwrap_or("")
            .contains("COMMUNICATION.rc_back"),
        "{last}"
    );
    assert_eq!(last["p1_fill"], "rgb(224, 0, 0)", "a marked place is red");
    assert_ne!(first["p1_fill"], last["p1_fill"]);
    assert_eq!(
        seen["back"],
        format!("step {} / {}", steps.len() - 2, steps.len() - 1)
    );
    let now = read(&dir.join("communication.toml"));
    assert!(now.contains("places = [\"proceeding\", \"p1\"]\n"), "{now}");
    assert!(now.contains("to = [\"proceeding\", \"p1\"]\n"), "{now}");
    assert_eq!(check(dir), Some(1), "a fresh petrel check fails too");
}

/// The children of process `pid` (Linux: /proc/PID/task/*/children).
fn children(pid: u32) -> Vec<u32> {
    let mut out = Vec::new();
    for task in std::fs::read_dir(format!("/proc/{pid}/task"))
        .into_iter()
        .flatten()
        .flatten()
    {
        let text = std::fs::read_to_string(task.path().join("children")).unwrap_or_default();
        out.extend(
            text.split_whitespace()
                .filter_map(|p| p.parse::<u32>().ok()),
        );
    }
    out
}

/// Whether process `pid` runs (a zombie does not).
fn alive(pid: u32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .ok()
        .and_then(|s| s.rsplit_once(") ").map(|(_, rest)| !rest.starts_with('Z')))
        .unwrap_or(false)
}

/// One HTTP/1.1 request to the editor: (status, body as JSON).
fn http(url: &str, method: &str, path: &str, body: &str) -> (u16, Json) {
    http_with(url, method, path, body, "application/json", None)
}

fn http_with(
    url: &str,
    method: &str,
    path: &str,
    body: &str,
    kind: &str,
    origin: Option<&str>,
) -> (u16, Json) {
    use std::io::{Read, Write};
    let host = url
        .trim_start_matches("http://")
        .trim_end_matches('/')
        .to_owned();
    let mut s = std::net::TcpStream::connect(&host).unwrap_or_else(|e| panic!("{host}: {e}"));
    let _ = s.set_read_timeout(Some(Duration::from_secs(30)));
    let request = format!(
        "{method} {path} HTTP/1.1\r\nHost: {host}\r\nContent-Type: {kind}\r\n{}Content-Length: {}\r\nConnection: close\r\n\r\n{body}",
        origin.map(|o| format!("Origin: {o}\r\n")).unwrap_or_default(),
        body.len()
    );
    s.write_all(request.as_bytes())
        .unwrap_or_else(|e| panic!("{e}"));
    let mut answer = String::new();
    let _ = s.read_to_string(&mut answer);
    let status = answer
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    let json = answer
        .split_once("\r\n\r\n")
        .and_then(|(_, b)| serde_json::from_str(b.trim()).ok())
        .unwrap_or(Json::Null);
    (status, json)
}

/// Without a browser: the editor's routes refuse bad edits, refuse to
/// overwrite a file changed on disk (keeping that change), write again
/// after a reload, and generate the programs' stubs; bad input exits 2.
#[test]
fn the_editor_never_overwrites_a_file_changed_on_disk() {
    let tmp = Scratch::new("edit");
    let dir = tmp.path();
    copy_example(dir);
    let (editor, url) = edit(dir);
    let add = r#"{"op":"add_place","net":"COMMUNICATION","name":"spare"}"#;

    let (status, a) = http(
        &url,
        "POST",
        "/edit",
        r#"{"op":"add_place","net":"NOPE","name":"x"}"#,
    );
    assert_eq!(
        (status, a["error"].as_str()),
        (400, Some("no net named `NOPE`"))
    );
    let (status, a) = http(
        &url,
        "POST",
        "/edit",
        r#"{"op":"delete_place","net":"COMMUNICATION","name":"proceeding"}"#,
    );
    assert_eq!(status, 400);
    assert!(
        a["error"]
            .as_str()
            .unwrap_or("")
            .contains("is used by link_lost"),
        "{a}"
    );
    let (status, a) = http(&url, "POST", "/edit", "{\"op\": ");
    assert_eq!(status, 400, "{a}");
    // Another site's page cannot post an edit (a form's text/plain body,
    // or a foreign origin).
    let (status, _) = http_with(&url, "POST", "/edit", add, "text/plain", None);
    assert_eq!(status, 403);
    let (status, _) = http_with(
        &url,
        "POST",
        "/edit",
        add,
        "application/json",
        Some("http://evil.example"),
    );
    assert_eq!(status, 403);
    assert_eq!(
        read(&dir.join("communication.toml")),
        read(&example().join("communication.toml"))
    );

    // Someone else writes the file: the edit is refused, their text kept.
    let theirs = format!("{}# theirs\n", read(&example().join("communication.toml")));
    std::fs::write(dir.join("communication.toml"), &theirs).unwrap_or_else(|e| panic!("{e}"));
    let (status, a) = http(&url, "POST", "/edit", add);
    assert_eq!((status, a["conflict"].as_bool()), (409, Some(true)), "{a}");
    assert!(
        a["error"]
            .as_str()
            .unwrap_or("")
            .contains("changed on disk"),
        "{a}"
    );
    assert_eq!(read(&dir.join("communication.toml")), theirs);
    // Reloaded: the edit is made on their text.
    assert_eq!(http(&url, "POST", "/reload", "{}").0, 200);
    let (status, a) = http(&url, "POST", "/edit", add);
    assert_eq!(status, 200, "{a}");
    let now = read(&dir.join("communication.toml"));
    assert_eq!(
        now,
        theirs.replace(
            "places = [\"proceeding\"]",
            "places = [\"proceeding\", \"spare\"]"
        )
    );
    // Written again by someone else, then the page polls the version (as
    // it does every half second): the file is read again without Reload,
    // the page shows it, and the next edit is made on it.
    let (_, v0) = http(&url, "GET", "/version", "");
    let theirs = now.replace(
        "places = [\"proceeding\", \"spare\"]",
        "places = [\"proceeding\", \"spare\", \"outside\"]",
    );
    assert_ne!(theirs, now);
    std::fs::write(dir.join("communication.toml"), &theirs).unwrap_or_else(|e| panic!("{e}"));
    let (status, v1) = http(&url, "GET", "/version", "");
    assert_eq!(status, 200);
    assert!(
        v1["version"].as_u64() > v0["version"].as_u64(),
        "a change on disk is a new version: {v0} then {v1}"
    );
    let (_, page) = http(&url, "GET", "/page.json", "");
    let places: Vec<String> = page["nets"]
        .as_array()
        .into_iter()
        .flatten()
        .filter(|n| n["name"] == "COMMUNICATION")
        .flat_map(|n| n["places"].as_array().cloned().unwrap_or_default())
        .filter_map(|p| p["name"].as_str().map(str::to_owned))
        .collect();
    assert!(places.contains(&"outside".to_owned()), "{places:?}");
    let (status, a) = http(
        &url,
        "POST",
        "/edit",
        r#"{"op":"add_place","net":"COMMUNICATION","name":"spare2"}"#,
    );
    assert_eq!(status, 200, "made on their text, no conflict: {a}");
    let edited = read(&dir.join("communication.toml"));
    assert_eq!(
        edited,
        theirs.replace("\"outside\"]", "\"outside\", \"spare2\"]")
    );
    // A net's file gone, then back (a branch switched and back): broken
    // at the next poll, editable again at the one after its return.
    std::fs::remove_file(dir.join("communication.toml")).unwrap_or_else(|e| panic!("{e}"));
    http(&url, "GET", "/version", "");
    let (_, page) = http(&url, "GET", "/page.json", "");
    let broken = page["broken"].as_str().unwrap_or("");
    assert!(
        broken.contains("communication.toml: no such file"),
        "{page}"
    );
    std::fs::write(dir.join("communication.toml"), &edited).unwrap_or_else(|e| panic!("{e}"));
    http(&url, "GET", "/version", "");
    let (_, page) = http(&url, "GET", "/page.json", "");
    assert_eq!(page["broken"], Json::Null, "{page}");
    assert_eq!(page["loads"], true, "{}", page["problems"]);
    let leftovers: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{e}"))
        .filter_map(Result::ok)
        .filter(|e| e.file_name().to_string_lossy().contains("petrel-edit"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
    let (_, page) = http(&url, "GET", "/page.json", "");
    assert_eq!(page["name"], "uav-flight-test");
    assert_eq!(page["loads"], true, "{}", page["problems"]);
    // Each edit started a check and killed the one before: one runs.
    assert_eq!(page["check"]["state"], "running", "{}", page["check"]);
    let checks = children(editor.0.id());
    assert_eq!(checks.len(), 1, "one petrel check at a time: {checks:?}");

    // The programs' stubs, as `petrel stubs` writes them.
    let (status, a) = http(&url, "POST", "/stubs", r#"{"lang":"python","out":"stubs"}"#);
    assert_eq!(status, 200, "{a}");
    let files: Vec<String> = strings(&a["files"]);
    assert!(
        !files.is_empty() && files.iter().all(|f| Path::new(f).exists()),
        "{files:?}"
    );
    let (status, a) = http(&url, "POST", "/stubs", r#"{"lang":"python","out":"stubs"}"#);
    assert_eq!(status, 400, "not overwritten without force: {a}");
    // The editor killed: its check dies with it.
    drop(editor);
    let until = Instant::now() + Duration::from_secs(10);
    while checks.iter().any(|pid| alive(*pid)) {
        assert!(
            Instant::now() < until,
            "petrel check {checks:?} outlived the editor"
        );
        std::thread::sleep(Duration::from_millis(50));
    }

    // Bad input: exit 2, with the reason.
    let out = Command::new(PETREL)
        .args(["edit", "--http", "127.0.0.1:0"])
        .arg(dir.join("nowhere"))
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not a Petrel project"));
    let help = Command::new(PETREL)
        .arg("--help")
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(
        String::from_utf8_lossy(&help.stdout).contains("edit "),
        "petrel --help lists edit"
    );
}

/// Every regular file of the folder, by name (what an undo must restore,
/// absent files included).
fn files(dir: &Path) -> std::collections::BTreeMap<String, String> {
    std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{e}"))
        .filter_map(Result::ok)
        .filter(|e| e.path().is_file())
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                read(&e.path()),
            )
        })
        .collect()
}

/// The `[[net]]` table the editor appends for an added net.
fn net_entry(name: &str, active: bool) -> String {
    format!("\n[[net]]\nfile = \"{name}.toml\"\nactive = {active}\n")
}

/// project.toml with `entry` right after its last `[[net]]` table (the
/// example's: operations.toml, before the globals' comment).
fn with_entry(project: &str, entry: &str) -> String {
    let last =
        "file = \"operations.toml\"        # activated by FLIGHT on entering the operations area\n";
    assert_eq!(project.matches(last).count(), 1);
    project.replace(last, &format!("{last}{entry}"))
}

/// A refusal: 400, its message holding `text`.
fn assert_refused(status: u16, a: &Json, text: &str) {
    assert_eq!(status, 400, "{a}");
    assert!(a["error"].as_str().unwrap_or("").contains(text), "{a}");
}

fn post_edit(url: &str, op: &str) -> (u16, Json) {
    http(url, "POST", "/edit", op)
}

/// Without a browser: a net added through the routes (refused when its
/// name is bad or taken, its file exists, or project.toml changed on
/// disk; else its file written and its `[[net]]` table appended, every
/// other byte of project.toml kept), then edits undone one at a time,
/// each restoring every file to its exact bytes before it, and redone,
/// both refused when a file changed on disk since.
#[test]
fn a_net_added_and_edits_undone_through_the_routes() {
    let tmp = Scratch::new("edit-undo");
    let dir = tmp.path();
    copy_example(dir);
    let original = files(dir);
    let project = original["project.toml"].clone();
    let (_editor, url) = edit(dir);

    // Nothing to undo yet.
    let (status, a) = http(&url, "POST", "/undo", "{}");
    assert_eq!(
        (status, a["error"].as_str()),
        (400, Some("nothing to undo"))
    );
    // Refused, nothing written: a bad name, a name taken, a file there.
    let (status, a) = post_edit(&url, r#"{"op":"add_net","name":"2nd","active":true}"#);
    assert_refused(status, &a, "invalid net name `2nd`");
    let (status, a) = post_edit(&url, r#"{"op":"add_net","name":"COMMUNICATION"}"#);
    assert_eq!(
        (status, a["error"].as_str()),
        (400, Some("the project already has a net `COMMUNICATION`"))
    );
    std::fs::write(dir.join("MINE.toml"), "# mine\n").unwrap_or_else(|e| panic!("{e}"));
    let (status, a) = post_edit(&url, r#"{"op":"add_net","name":"MINE"}"#);
    assert_refused(status, &a, "MINE.toml exists already");
    assert_eq!(read(&dir.join("MINE.toml")), "# mine\n");
    std::fs::remove_file(dir.join("MINE.toml")).unwrap_or_else(|e| panic!("{e}"));
    // project.toml changed on disk: 409, theirs kept, no net file.
    let theirs = format!("{project}# theirs\n");
    std::fs::write(dir.join("project.toml"), &theirs).unwrap_or_else(|e| panic!("{e}"));
    let (status, a) = post_edit(&url, r#"{"op":"add_net","name":"NEW","active":true}"#);
    assert_eq!((status, a["conflict"].as_bool()), (409, Some(true)), "{a}");
    assert!(
        a["error"]
            .as_str()
            .unwrap_or("")
            .starts_with("project.toml changed on disk"),
        "{a}"
    );
    assert_eq!(read(&dir.join("project.toml")), theirs);
    assert!(!dir.join("NEW.toml").exists());
    std::fs::write(dir.join("project.toml"), &project).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(files(dir), original, "nothing written by the refusals");

    // Made: the new file, and the entry after the last [[net]].
    let mut states = vec![files(dir)];
    let (status, a) = post_edit(&url, r#"{"op":"add_net","name":"NEW"}"#);
    assert_eq!(status, 200, "{a}");
    assert_eq!(
        read(&dir.join("project.toml")),
        with_entry(&project, &net_entry("NEW", false))
    );
    let new_net = read(&dir.join("NEW.toml"));
    assert_eq!(
        new_net,
        "# NEW: a net added by `petrel edit`.\nname = \"NEW\"\nplaces = [\"idle\"]\ninitial = [\"idle\"]\n"
    );
    // The copy loads with the nets loader, the new net last, inactive.
    let loaded = nets::load(&files(dir)).unwrap_or_else(|e| panic!("{e:?}"));
    let last = loaded
        .nets
        .last()
        .map(|n| (n.name.as_str(), n.file.as_str(), n.active_at_start));
    assert_eq!(loaded.nets.len(), 9);
    assert_eq!(last, Some(("NEW", "NEW.toml", false)));
    // The page has it, editable; the whole project loads and is checked.
    let (_, page) = http(&url, "GET", "/page.json", "");
    let new = page["nets"]
        .as_array()
        .and_then(|n| n.iter().find(|n| n["name"] == "NEW"))
        .cloned()
        .unwrap_or_else(|| panic!("no NEW in {}", page["nets"]));
    assert_eq!(new["places"][0]["name"], "idle");
    assert_eq!(new["places"][0]["initial"], true);
    assert_eq!(page["loads"], true, "{}", page["problems"]);
    assert_eq!(page["check"]["state"], "running", "{}", page["check"]);
    assert_eq!(page["undo"], "add net NEW");
    states.push(files(dir));

    // Several edits in a row, of several files (layout.toml created).
    for op in [
        r#"{"op":"add_transition","net":"NEW","name":"t1","at":[120,60]}"#,
        r#"{"op":"add_arc","net":"NEW","transition":"t1","place":"idle","input":true}"#,
        r#"{"op":"set_transition","net":"NEW","name":"t1","on":"link_lost","when":"","do":[]}"#,
        r#"{"op":"add_place","net":"COMMUNICATION","name":"spare"}"#,
        r#"{"op":"move","net":"COMMUNICATION","kind":"place","name":"spare","x":300,"y":80}"#,
        r#"{"op":"add_net","name":"LATER","active":true}"#,
        r#"{"op":"rename_place","net":"NEW","name":"idle","to":"waiting"}"#,
    ] {
        let (status, a) = post_edit(&url, op);
        assert_eq!(status, 200, "{op}: {a}");
        states.push(files(dir));
    }
    assert!(states.last().is_some_and(|s| s.contains_key("layout.toml")));
    assert!(!original.contains_key("layout.toml"));
    assert_eq!(
        read(&dir.join("project.toml")),
        with_entry(
            &project,
            &format!("{}{}", net_entry("NEW", false), net_entry("LATER", true))
        )
    );
    // An edit refused is not undone: it made nothing.
    let (status, _) = post_edit(&url, r#"{"op":"add_place","net":"NEW","name":"waiting"}"#);
    assert_eq!(status, 400);
    // An edit that changes nothing is not on the stack either.
    let (status, _) = post_edit(
        &url,
        r#"{"op":"set_place","net":"NEW","name":"waiting","initial":true}"#,
    );
    assert_eq!(status, 200);
    assert_eq!(
        &files(dir),
        states.last().unwrap_or_else(|| panic!("no state"))
    );

    // Undone one at a time: each time every file as it was before.
    let all = states.clone();
    let mut names = Vec::new();
    for _ in 0..3 {
        let (status, a) = http(&url, "POST", "/undo", "{}");
        assert_eq!(status, 200, "{a}");
        names.push(a["undone"].as_str().unwrap_or("").to_owned());
        states.pop();
        assert_eq!(
            &files(dir),
            states.last().unwrap_or_else(|| panic!("no state"))
        );
    }
    assert_eq!(
        names,
        [
            "rename place NEW.idle to waiting",
            "add net LATER",
            "move COMMUNICATION.spare"
        ]
    );
    assert!(!dir.join("LATER.toml").exists());
    // Redone: the bytes the edits wrote, again (LATER.toml made anew);
    // then undone again.
    let k = states.len() - 1;
    for (i, want) in ["move COMMUNICATION.spare", "add net LATER"]
        .iter()
        .enumerate()
    {
        let (status, a) = http(&url, "POST", "/redo", "{}");
        assert_eq!((status, a["redone"].as_str()), (200, Some(*want)), "{a}");
        assert_eq!(files(dir), all[k + 1 + i]);
    }
    for i in (0..2).rev() {
        let (status, a) = http(&url, "POST", "/undo", "{}");
        assert_eq!(status, 200, "{a}");
        assert_eq!(files(dir), all[k + i]);
    }

    // Someone else changes a file the next undo restores: refused, their
    // change kept, nothing else written; the edit stays undoable.
    let (_, page) = http(&url, "GET", "/page.json", "");
    assert_eq!(page["undo"], "add place COMMUNICATION.spare");
    let ours = read(&dir.join("communication.toml"));
    let theirs = format!("{ours}# theirs\n");
    std::fs::write(dir.join("communication.toml"), &theirs).unwrap_or_else(|e| panic!("{e}"));
    let (status, a) = http(&url, "POST", "/undo", "{}");
    assert_eq!((status, a["conflict"].as_bool()), (409, Some(true)), "{a}");
    assert!(
        a["error"]
            .as_str()
            .unwrap_or("")
            .starts_with("communication.toml changed on disk"),
        "{a}"
    );
    let mut expected = states.last().cloned().unwrap_or_default();
    expected.insert("communication.toml".into(), theirs.clone());
    assert_eq!(files(dir), expected, "nothing written by the refused undo");
    // A foreign page cannot undo.
    let (status, _) = http_with(&url, "POST", "/undo", "{}", "text/plain", None);
    assert_eq!(status, 403);
    std::fs::write(dir.join("communication.toml"), &ours).unwrap_or_else(|e| panic!("{e}"));
    // Back to the bytes the editor wrote: the undo is made.
    while states.len() > 1 {
        let (status, a) = http(&url, "POST", "/undo", "{}");
        assert_eq!(status, 200, "{a}");
        states.pop();
        assert_eq!(
            &files(dir),
            states.last().unwrap_or_else(|| panic!("no state")),
            "after undoing {}",
            a["undone"]
        );
    }
    // The added net undone: its file gone, project.toml byte for byte.
    assert_eq!(files(dir), original);
    let (status, a) = http(&url, "POST", "/undo", "{}");
    assert_eq!(
        (status, a["error"].as_str()),
        (400, Some("nothing to undo"))
    );
    let (_, page) = http(&url, "GET", "/page.json", "");
    assert_eq!(page["nets"].as_array().map(Vec::len), Some(8));
    assert_eq!(page["undo"], Json::Null);

    // Redo refused while a file is in the way of the net's (their file
    // kept), made once it is gone.
    assert_eq!(page["redo"], "add net NEW");
    std::fs::write(dir.join("NEW.toml"), "# mine\n").unwrap_or_else(|e| panic!("{e}"));
    let (status, a) = http(&url, "POST", "/redo", "{}");
    assert_eq!((status, a["conflict"].as_bool()), (409, Some(true)), "{a}");
    assert!(
        a["error"]
            .as_str()
            .unwrap_or("")
            .starts_with("NEW.toml changed on disk"),
        "{a}"
    );
    assert_eq!(read(&dir.join("NEW.toml")), "# mine\n");
    assert_eq!(read(&dir.join("project.toml")), project);
    std::fs::remove_file(dir.join("NEW.toml")).unwrap_or_else(|e| panic!("{e}"));
    let (status, a) = http(&url, "POST", "/redo", "{}");
    assert_eq!(
        (status, a["redone"].as_str()),
        (200, Some("add net NEW")),
        "{a}"
    );
    assert_eq!(files(dir), all[1]);
    // An edit made: nothing left to redo.
    let (status, _) = post_edit(
        &url,
        r#"{"op":"add_place","net":"COMMUNICATION","name":"spare"}"#,
    );
    assert_eq!(status, 200);
    let (status, a) = http(&url, "POST", "/redo", "{}");
    assert_eq!(
        (status, a["error"].as_str()),
        (400, Some("nothing to redo"))
    );
    // That edit was made on the draft the undos left: the file on disk.
    assert_eq!(
        read(&dir.join("communication.toml")),
        original["communication.toml"].replace(
            "places = [\"proceeding\"]",
            "places = [\"proceeding\", \"spare\"]"
        )
    );

    // A reload after someone else's change forgets the history (what it
    // would undo is no longer on disk); one that finds nothing changed
    // keeps it.
    assert_eq!(http(&url, "POST", "/reload", "{}").0, 200);
    let (_, page) = http(&url, "GET", "/page.json", "");
    assert_eq!(page["undo"], "add place COMMUNICATION.spare");
    let theirs = format!("{}# theirs\n", read(&dir.join("safety.toml")));
    std::fs::write(dir.join("safety.toml"), &theirs).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(http(&url, "POST", "/reload", "{}").0, 200);
    let (_, page) = http(&url, "GET", "/page.json", "");
    assert_eq!(page["undo"], Json::Null);
}

/// In the browser: a net added with the toolbar's form (a name taken
/// refused with the reason shown), drawn at once, checked (dead at the
/// start), given a transition (still dead after a catastrophe: nothing
/// final) and its place made final: the files on disk, a fresh `petrel
/// check` holds. Then undone with Ctrl-Z and the Undo button until the
/// example is back byte for byte (a redo and an undo on the way).
#[test]
fn a_net_added_in_the_page_is_written_checked_and_undone() {
    let Some(tools) = require() else { return };
    let shots = browser::shots();
    let tmp = Scratch::new("edit-net");
    let dir = tmp.path();
    copy_example(dir);
    let original = files(dir);
    let (editor, url) = edit(dir);

    let seen = drive(&tools, "net", &url, &shots);
    assert!(seen.get("failure").is_none(), "{}", seen["failure"]);
    assert_eq!(seen["undo_at_start"], true, "nothing to undo at first");
    assert!(
        seen["taken"]
            .as_str()
            .unwrap_or("")
            .contains("the project already has a net `COMMUNICATION`"),
        "{}",
        seen["taken"]
    );
    assert_eq!(seen["active_ticked"], true);
    assert_eq!(seen["message_after"], true, "the refusal cleared");
    assert_eq!(
        strings(&seen["nets"]).last().map(String::as_str),
        Some("NEW")
    );
    assert_eq!(strings(&seen["new_ids"]), ["p-NEW-idle"]);
    assert_eq!(seen["new_marked_at_start"], 1);
    assert!(
        seen["undo_title"]
            .as_str()
            .unwrap_or("")
            .starts_with("undo: add net NEW"),
        "{}",
        seen["undo_title"]
    );
    // The check judges the new net as any: dead at the start.
    assert_eq!(
        seen["first_check"]["state"], "violated",
        "{}",
        seen["first_check"]
    );
    assert_eq!(
        seen["first_check"]["title"], "net NEW: a deadlock",
        "{}",
        seen["first_check"]
    );
    // With its transition, still dead once a catastrophe locks it out
    // (nothing final): as any net.
    assert_eq!(
        seen["arcs_check"]["state"], "violated",
        "{}",
        seen["arcs_check"]
    );
    assert_eq!(
        seen["arcs_check"]["title"], "net NEW: a deadlock",
        "{}",
        seen["arcs_check"]
    );
    assert_eq!(seen["problems_after"], 0);
    assert_eq!(seen["check"]["state"], "holds", "{}", seen["check"]);

    let project = &original["project.toml"];
    assert_eq!(
        read(&dir.join("project.toml")),
        with_entry(project, &net_entry("NEW", true))
    );
    assert_eq!(
        read(&dir.join("NEW.toml")),
        "# NEW: a net added by `petrel edit`.\nname = \"NEW\"\nplaces = [\"idle\"]\ninitial = [\"idle\"]\nfinal = [\"idle\"]\n\n[[transition]]\nname = \"t1\"\nfrom = [\"idle\"]\nto = [\"idle\"]\non = \"link_lost\"\n"
    );
    for (name, text) in &original {
        if name != "project.toml" {
            assert_eq!(&read(&dir.join(name)), text, "{name} changed");
        }
    }
    assert_eq!(check(dir), Some(0), "a fresh petrel check of the copy");

    let seen = drive(&tools, "undo", &url, &shots);
    drop(editor);
    assert!(seen.get("failure").is_none(), "{}", seen["failure"]);
    assert_eq!(
        strings(&seen["undone"]),
        [
            "set place NEW.idle",
            "add arc NEW.t1 → idle",
            "add arc idle → NEW.t1",
            "set transition NEW.t1",
            "add transition NEW.t1",
            "add net NEW"
        ]
    );
    let mut arcs = strings(&seen["arcs_after_ctrl_z"]);
    arcs.sort();
    assert_eq!(
        arcs,
        ["idle->t1", "idle<-t1"],
        "Ctrl-Z undid the final place only"
    );
    assert!(!strings(&seen["nets"]).contains(&"NEW".to_owned()));
    assert_eq!(seen["undo_disabled"], true);
    assert_eq!(
        strings(&seen["nets_after_redo"]).last().map(String::as_str),
        Some("NEW")
    );
    assert!(
        seen["redo_title"]
            .as_str()
            .unwrap_or("")
            .starts_with("redo: add transition NEW.t1"),
        "{}",
        seen["redo_title"]
    );
    assert_eq!(seen["nets_at_end"], seen["nets"]);
    assert_eq!(files(dir), original, "the example back, byte for byte");
}

/// The files of the example with OPERATIONS renamed `to`: its own `name`,
/// FLIGHT's `activate` and CATASTROPHIC's `deactivate` (its file keeps
/// its name: `operations.toml` is not `OPERATIONS.toml`).
fn operations_renamed(
    original: &std::collections::BTreeMap<String, String>,
    to: &str,
) -> std::collections::BTreeMap<String, String> {
    let mut want = original.clone();
    for (file, from, into) in [
        (
            "operations.toml",
            "name = \"OPERATIONS\"".to_owned(),
            format!("name = \"{to}\""),
        ),
        (
            "flight.toml",
            "\"activate OPERATIONS\"".to_owned(),
            format!("\"activate {to}\""),
        ),
        (
            "catastrophic.toml",
            "\"deactivate OPERATIONS\"".to_owned(),
            format!("\"deactivate {to}\""),
        ),
    ] {
        let text = &original[file];
        assert!(text.contains(&from), "{file} has {from}");
        want.insert(file.into(), text.replace(&from, &into));
    }
    want
}

/// Without a browser: nets deleted and renamed through the routes.
/// Refused with the reasons and nothing written: a net other nets'
/// actions name, a name taken or malformed, a file in the way of the
/// renamed one. Made: OPERATIONS renamed (every action naming it with
/// it), a net added then renamed (its file with it) and deleted (its file
/// and its `[[net]]` table: project.toml back byte for byte); the copy
/// loads. Then undone to the example byte for byte, an undo refused
/// (409) while a file is in the way of one it would bring back.
#[test]
fn nets_deleted_and_renamed_through_the_routes() {
    let tmp = Scratch::new("edit-netops");
    let dir = tmp.path();
    copy_example(dir);
    let original = files(dir);
    let project = original["project.toml"].clone();
    let (_editor, url) = edit(dir);

    // Refused, nothing written.
    let (status, a) = post_edit(&url, r#"{"op":"delete_net","name":"COMMUNICATION"}"#);
    assert_eq!(status, 400, "{a}");
    let why = a["error"].as_str().unwrap_or("");
    assert!(
        why.starts_with("net COMMUNICATION is named by CATASTROPHIC.engine_failure: `deactivate COMMUNICATION`; CATASTROPHIC.engine_failure_no_position: `deactivate COMMUNICATION`;"),
        "{why}"
    );
    assert_eq!(
        why.matches("`deactivate COMMUNICATION`").count(),
        6,
        "{why}"
    );
    let (status, a) = post_edit(
        &url,
        r#"{"op":"rename_net","name":"OPERATIONS","to":"FLIGHT"}"#,
    );
    assert_eq!(
        (status, a["error"].as_str()),
        (400, Some("the project already has a net `FLIGHT`"))
    );
    let (status, a) = post_edit(
        &url,
        r#"{"op":"rename_net","name":"OPERATIONS","to":"op s"}"#,
    );
    assert_refused(status, &a, "invalid net name `op s`");
    let (status, a) = post_edit(&url, r#"{"op":"delete_net","name":"NOPE"}"#);
    assert_eq!(
        (status, a["error"].as_str()),
        (400, Some("no net named `NOPE`"))
    );
    assert_eq!(files(dir), original, "nothing written by the refusals");

    // OPERATIONS renamed OPS: its file kept, every action naming it too.
    let mut states = vec![files(dir)];
    let (status, a) = post_edit(
        &url,
        r#"{"op":"rename_net","name":"OPERATIONS","to":"OPS"}"#,
    );
    assert_eq!(status, 200, "{a}");
    assert_eq!(files(dir), operations_renamed(&original, "OPS"));
    let (_, page) = http(&url, "GET", "/page.json", "");
    assert_eq!(page["loads"], true, "{}", page["problems"]);
    assert_eq!(page["undo"], "rename net OPERATIONS to OPS");
    states.push(files(dir));

    // A net added, renamed: its file with it, project.toml's entry too.
    let (status, a) = post_edit(&url, r#"{"op":"add_net","name":"NEW","active":true}"#);
    assert_eq!(status, 200, "{a}");
    states.push(files(dir));
    std::fs::write(dir.join("MINE.toml"), "# mine\n").unwrap_or_else(|e| panic!("{e}"));
    let (status, a) = post_edit(&url, r#"{"op":"rename_net","name":"NEW","to":"MINE"}"#);
    assert_refused(status, &a, "MINE.toml exists already");
    assert_eq!(read(&dir.join("MINE.toml")), "# mine\n");
    std::fs::remove_file(dir.join("MINE.toml")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        &files(dir),
        states.last().unwrap_or_else(|| panic!("no state"))
    );
    let (status, a) = post_edit(&url, r#"{"op":"rename_net","name":"NEW","to":"SPARE"}"#);
    assert_eq!(status, 200, "{a}");
    let mut want = operations_renamed(&original, "OPS");
    want.insert(
        "project.toml".into(),
        with_entry(&project, &net_entry("SPARE", true)),
    );
    want.insert(
        "SPARE.toml".into(),
        "# NEW: a net added by `petrel edit`.\nname = \"SPARE\"\nplaces = [\"idle\"]\ninitial = [\"idle\"]\n".into(),
    );
    assert_eq!(files(dir), want, "NEW.toml gone, SPARE.toml there");
    let loaded = nets::load(&files(dir)).unwrap_or_else(|e| panic!("{e:?}"));
    let names: Vec<&str> = loaded.nets.iter().map(|n| n.name.as_str()).collect();
    assert_eq!(names.last(), Some(&"SPARE"));
    assert!(
        names.contains(&"OPS") && !names.contains(&"OPERATIONS"),
        "{names:?}"
    );
    states.push(files(dir));

    // SPARE deleted: its file and its table gone, every other byte kept.
    let (status, a) = post_edit(&url, r#"{"op":"delete_net","name":"SPARE"}"#);
    assert_eq!(status, 200, "{a}");
    assert_eq!(files(dir), operations_renamed(&original, "OPS"));
    let (_, page) = http(&url, "GET", "/page.json", "");
    assert_eq!(page["nets"].as_array().map(Vec::len), Some(8));
    assert_eq!(page["loads"], true, "{}", page["problems"]);
    assert_eq!(page["undo"], "delete net SPARE");
    let loaded = nets::load(&files(dir)).unwrap_or_else(|e| panic!("{e:?}"));
    assert_eq!(loaded.nets.len(), 8);

    // The undo would bring SPARE.toml back: refused while a file is there.
    std::fs::write(dir.join("SPARE.toml"), "# mine\n").unwrap_or_else(|e| panic!("{e}"));
    let (status, a) = http(&url, "POST", "/undo", "{}");
    assert_eq!((status, a["conflict"].as_bool()), (409, Some(true)), "{a}");
    assert_eq!(read(&dir.join("SPARE.toml")), "# mine\n");
    std::fs::remove_file(dir.join("SPARE.toml")).unwrap_or_else(|e| panic!("{e}"));
    // Undone (SPARE.toml and its table back), redone (gone again).
    let (status, a) = http(&url, "POST", "/undo", "{}");
    assert_eq!(
        (status, a["undone"].as_str()),
        (200, Some("delete net SPARE")),
        "{a}"
    );
    assert_eq!(
        &files(dir),
        states.last().unwrap_or_else(|| panic!("no state"))
    );
    let (status, a) = http(&url, "POST", "/redo", "{}");
    assert_eq!(
        (status, a["redone"].as_str()),
        (200, Some("delete net SPARE")),
        "{a}"
    );
    assert_eq!(files(dir), operations_renamed(&original, "OPS"));
    // Undone one at a time, each back to the bytes before it.
    let mut names = Vec::new();
    while let Some(want) = states.pop() {
        let (status, a) = http(&url, "POST", "/undo", "{}");
        assert_eq!(status, 200, "{a}");
        names.push(a["undone"].as_str().unwrap_or("").to_owned());
        assert_eq!(files(dir), want, "after undoing {}", a["undone"]);
    }
    assert_eq!(
        names,
        [
            "delete net SPARE",
            "rename net NEW to SPARE",
            "add net NEW",
            "rename net OPERATIONS to OPS"
        ]
    );
    assert_eq!(files(dir), original, "the example back, byte for byte");
    // Redone: the rename again, then undone.
    let (status, a) = http(&url, "POST", "/redo", "{}");
    assert_eq!(
        (status, a["redone"].as_str()),
        (200, Some("rename net OPERATIONS to OPS")),
        "{a}"
    );
    assert_eq!(files(dir), operations_renamed(&original, "OPS"));
    let (status, _) = http(&url, "POST", "/undo", "{}");
    assert_eq!(status, 200);
    assert_eq!(files(dir), original);
    let (_, page) = http(&url, "GET", "/page.json", "");
    assert_eq!(page["loads"], true, "{}", page["problems"]);
}

/// project.toml with FLIGHT's `[[net]]` table given `active = ACTIVE`
/// (the example's table has no `active`: the key added after `file`).
fn flight_active(project: &str, active: bool) -> String {
    let file = "file = \"flight.toml\"            # activated by MISSION once INIT is done\n";
    assert_eq!(project.matches(file).count(), 1);
    project.replace(file, &format!("{file}active = {active}\n"))
}

/// The page's `active` of each net, by name.
fn actives(url: &str) -> Vec<(String, bool)> {
    let (_, page) = http(url, "GET", "/page.json", "");
    page["nets"]
        .as_array()
        .map(|nets| {
            nets.iter()
                .map(|n| {
                    (
                        n["name"].as_str().unwrap_or("").to_owned(),
                        n["active"].as_bool().unwrap_or_else(|| panic!("{n}")),
                    )
                })
                .collect()
        })
        .unwrap_or_default()
}

/// Without a browser: a net's active at start set through the routes.
/// Refused with the reason and nothing written for an unknown net or no
/// change; FLIGHT (no `active` in its table) made active (the key added
/// after `file`, every other byte kept), then not (`active = false`
/// written, not removed), the page showing each; undone to the example
/// byte for byte, redone, refused (409) when project.toml changed on disk.
#[test]
fn active_at_start_set_through_the_routes() {
    let tmp = Scratch::new("edit-active");
    let dir = tmp.path();
    copy_example(dir);
    let original = files(dir);
    let project = original["project.toml"].clone();
    let (_editor, url) = edit(dir);
    let before = actives(&url);
    assert_eq!(before.len(), 8);
    let flight = |v: &[(String, bool)]| v.iter().find(|(n, _)| n == "FLIGHT").map(|(_, a)| *a);
    assert_eq!(flight(&before), Some(false));
    assert_eq!(
        before.iter().filter(|(_, a)| *a).count(),
        6,
        "six nets active at start: {before:?}"
    );

    let (status, a) = post_edit(&url, r#"{"op":"set_active","name":"NOPE","active":true}"#);
    assert_eq!(
        (status, a["error"].as_str()),
        (400, Some("no net named `NOPE`"))
    );
    let (status, a) = post_edit(
        &url,
        r#"{"op":"set_active","name":"FLIGHT","active":false}"#,
    );
    assert_eq!(
        (status, a["error"].as_str()),
        (
            400,
            Some("net FLIGHT is already not active at start (nothing written)")
        )
    );
    let (status, a) = post_edit(&url, r#"{"op":"set_active","name":"SAFETY","active":true}"#);
    assert_refused(status, &a, "net SAFETY is already active at start");
    assert_eq!(files(dir), original, "nothing written by the refusals");

    let (status, a) = post_edit(&url, r#"{"op":"set_active","name":"FLIGHT","active":true}"#);
    assert_eq!(status, 200, "{a}");
    let mut want = original.clone();
    want.insert("project.toml".into(), flight_active(&project, true));
    assert_eq!(files(dir), want, "project.toml only, one line added");
    let now = actives(&url);
    assert_eq!(flight(&now), Some(true));
    assert_eq!(
        now.iter()
            .filter(|(n, _)| n != "FLIGHT")
            .collect::<Vec<_>>(),
        before
            .iter()
            .filter(|(n, _)| n != "FLIGHT")
            .collect::<Vec<_>>()
    );
    let (_, page) = http(&url, "GET", "/page.json", "");
    assert_eq!(page["undo"], "set net FLIGHT active at start");
    assert_eq!(page["loads"], true, "{}", page["problems"]);

    let (status, a) = post_edit(
        &url,
        r#"{"op":"set_active","name":"FLIGHT","active":false}"#,
    );
    assert_eq!(status, 200, "{a}");
    want.insert("project.toml".into(), flight_active(&project, false));
    assert_eq!(files(dir), want, "false written, not removed");
    assert_eq!(flight(&actives(&url)), Some(false));
    let loaded = nets::load(&files(dir)).unwrap_or_else(|e| panic!("{e:?}"));
    let reference = nets::load(&original).unwrap_or_else(|e| panic!("{e:?}"));
    let active_of = |p: &nets::Project| -> Vec<(String, bool)> {
        p.nets
            .iter()
            .map(|n| (n.name.clone(), n.active_at_start))
            .collect()
    };
    assert_eq!(
        active_of(&loaded),
        active_of(&reference),
        "the same project"
    );

    // Undone: the key's line, then the original bytes; redone.
    let (status, a) = http(&url, "POST", "/undo", "{}");
    assert_eq!(
        (status, a["undone"].as_str()),
        (200, Some("set net FLIGHT not active at start")),
        "{a}"
    );
    assert_eq!(
        read(&dir.join("project.toml")),
        flight_active(&project, true)
    );
    let (status, a) = http(&url, "POST", "/undo", "{}");
    assert_eq!(
        (status, a["undone"].as_str()),
        (200, Some("set net FLIGHT active at start")),
        "{a}"
    );
    assert_eq!(files(dir), original, "the example back, byte for byte");
    assert_eq!(actives(&url), before);
    let (status, a) = http(&url, "POST", "/redo", "{}");
    assert_eq!(status, 200, "{a}");
    assert_eq!(
        read(&dir.join("project.toml")),
        flight_active(&project, true)
    );
    // project.toml changed on disk: the next undo refused, nothing written.
    let mine = format!("{}# mine\n", flight_active(&project, true));
    std::fs::write(dir.join("project.toml"), &mine).unwrap_or_else(|e| panic!("{e}"));
    let (status, a) = http(&url, "POST", "/undo", "{}");
    assert_eq!((status, a["conflict"].as_bool()), (409, Some(true)), "{a}");
    assert_eq!(read(&dir.join("project.toml")), mine);
    std::fs::write(dir.join("project.toml"), flight_active(&project, true))
        .unwrap_or_else(|e| panic!("{e}"));
    let (status, a) = http(&url, "POST", "/undo", "{}");
    assert_eq!(status, 200, "{a}");
    assert_eq!(files(dir), original);
}

/// In the browser: a net's delete confirmed and refused with the reasons
/// (other nets name it), OPERATIONS renamed (a name taken refused first),
/// FLIGHT's *active at start* ticked then unticked (`active = false`
/// written), a net added, renamed (its file with it), its delete
/// cancelled then confirmed: the files on disk, the page's check and a
/// fresh `petrel check` hold. Then the Undo button until the example is back byte for
/// byte.
#[test]
fn nets_deleted_and_renamed_in_the_page_and_undone() {
    let Some(tools) = require() else { return };
    let shots = browser::shots();
    let tmp = Scratch::new("edit-netpage");
    let dir = tmp.path();
    copy_example(dir);
    let original = files(dir);
    let (editor, url) = edit(dir);

    let seen = drive(&tools, "netops", &url, &shots);
    assert!(seen.get("failure").is_none(), "{}", seen["failure"]);
    assert_eq!(seen["errors"], Json::Array(Vec::new()), "no page error");
    assert!(
        seen["confirm"]
            .as_str()
            .unwrap_or("")
            .starts_with("Delete net COMMUNICATION? Its [[net]] table leaves project.toml and communication.toml is removed"),
        "{}",
        seen["confirm"]
    );
    let in_use = seen["in_use"].as_str().unwrap_or("");
    assert!(
        in_use.starts_with("net COMMUNICATION is named by CATASTROPHIC.engine_failure: `deactivate COMMUNICATION`;"),
        "{in_use}"
    );
    assert_eq!(seen["still"], 1, "COMMUNICATION still drawn");
    assert_eq!(seen["rename_value"], "OPERATIONS");
    assert!(
        seen["taken"]
            .as_str()
            .unwrap_or("")
            .contains("the project already has a net `FLIGHT`"),
        "{}",
        seen["taken"]
    );
    assert_eq!(
        strings(&seen["form_after_refusal"]),
        ["FLIGHT"],
        "the form stays"
    );
    assert_eq!(
        seen["typed_over"], "OPS",
        "a redraw keeps the rename field's selection"
    );
    assert_eq!(seen["message_after"], true, "the refusal cleared");
    let renamed = strings(&seen["nets_renamed"]);
    assert!(
        renamed.contains(&"OPS".to_owned()) && !renamed.contains(&"OPERATIONS".to_owned()),
        "{renamed:?}"
    );
    assert_eq!(
        seen["flight_active"],
        serde_json::json!([false, true, false]),
        "FLIGHT's box: unticked, ticked, unticked"
    );
    assert_eq!(
        strings(&seen["actives"]),
        [
            "CATASTROPHIC",
            "SAFETY",
            "PAYLOAD",
            "COMMUNICATION",
            "INIT",
            "MISSION",
            "FLIGHT"
        ]
    );
    assert_eq!(seen["spare_file"], "SPARE.toml");
    assert_eq!(
        strings(&seen["after_cancel"]).last().map(String::as_str),
        Some("SPARE"),
        "cancelled: kept"
    );
    assert_eq!(seen["nets"], seen["nets_renamed"]);
    assert!(
        seen["undo_title"]
            .as_str()
            .unwrap_or("")
            .starts_with("undo: delete net SPARE"),
        "{}",
        seen["undo_title"]
    );
    assert_eq!(seen["check"]["state"], "holds", "{}", seen["check"]);
    // FLIGHT not active at start again, written explicitly.
    let mut want = operations_renamed(&original, "OPS");
    want.insert(
        "project.toml".into(),
        flight_active(&original["project.toml"], false),
    );
    assert_eq!(files(dir), want);
    assert_eq!(check(dir), Some(0), "a fresh petrel check of the copy");

    let seen = drive(&tools, "netundo", &url, &shots);
    drop(editor);
    assert!(seen.get("failure").is_none(), "{}", seen["failure"]);
    assert_eq!(
        strings(&seen["undone"]),
        [
            "delete net SPARE",
            "rename net NEW to SPARE",
            "add net NEW",
            "set net FLIGHT not active at start",
            "set net FLIGHT active at start",
            "rename net OPERATIONS to OPS"
        ]
    );
    assert!(strings(&seen["nets"]).contains(&"OPERATIONS".to_owned()));
    assert_eq!(files(dir), original, "the example back, byte for byte");
}

/// The page draws once per edit, and once per change made by another
/// client: page.json answered late (longer than the page's 500 ms poll),
/// so that the poll asks `/version` while an edit's own refresh is on its
/// way and sees the edit's version (the race that drew the page twice).
/// Three places dragged (moves: no check, one version each), then a
/// fourth moved through the routes as another tab would; last,
/// layout.toml changed on disk by another program and reloaded from
/// another tab: drawn, then the check's verdict, no version twice.
#[test]
fn the_page_draws_once_per_edit_and_once_per_change_from_outside() {
    let Some(tools) = require() else { return };
    let shots = browser::shots();
    let tmp = Scratch::new("edit-draws");
    let dir = tmp.path();
    copy_example(dir);
    let (editor, url) = edit(dir);

    let seen = browser::drive_script(
        &tools,
        "gateway/tests/edit/driver.js",
        &["draws", &url, &shots.to_string_lossy()],
        &[("PROJECT_DIR", &dir.to_string_lossy())],
        Duration::from_secs(600),
    );
    drop(editor);
    eprintln!(
        "moves: {}; from outside: {}, drawn after {} ms; on disk: {}, drawn after {} ms; reloaded: {}, drawn after {} ms",
        seen["edits"], seen["outside"], seen["outside_ms"], seen["disk"], seen["disk_ms"], seen["reload"], seen["reload_ms"]
    );
    assert!(seen.get("failure").is_none(), "{}", seen["failure"]);
    assert_eq!(seen["errors"], Json::Array(Vec::new()), "no page error");
    let edits = seen["edits"].as_array().cloned().unwrap_or_default();
    assert_eq!(edits.len(), 3, "{}", seen["edits"]);
    for e in &edits {
        assert_eq!(e["versions"], 1, "one version per move: {e}");
        assert_eq!(e["draws"], 1, "one draw per edit: {}", seen["edits"]);
    }
    assert_eq!(
        seen["outside_answer"]["ok"], true,
        "{}",
        seen["outside_answer"]
    );
    assert_eq!(seen["outside"]["versions"], 1, "{}", seen["outside"]);
    assert_eq!(
        seen["outside"]["draws"], 1,
        "one draw for a change from outside: {}",
        seen["outside"]
    );
    // Soon: a poll period and the late page.json, with room.
    let ms = seen["outside_ms"].as_u64().unwrap_or(u64::MAX);
    assert!(ms < 3000, "drawn {ms} ms after the change");
    // Changed on disk, no Reload: read again at the page's poll; the
    // reload's version and the check's verdict, each drawn at most once
    // (the verdict may come before the poll asks).
    assert_eq!(seen["disk"]["versions"], 2, "{}", seen["disk"]);
    let draws = seen["disk"]["draws"].as_u64().unwrap_or(0);
    assert!((1..=2).contains(&draws), "{}", seen["disk"]);
    assert_eq!(seen["disk"]["check"], "holds", "{}", seen["disk"]);
    let ms = seen["disk_ms"].as_u64().unwrap_or(u64::MAX);
    assert!(ms < 3000, "drawn {ms} ms after the change on disk");
    // Reloaded, nothing changed: the same, a version and a verdict.
    assert_eq!(
        seen["reload_answer"]["ok"], true,
        "{}",
        seen["reload_answer"]
    );
    assert_eq!(seen["reload"]["versions"], 2, "{}", seen["reload"]);
    let draws = seen["reload"]["draws"].as_u64().unwrap_or(0);
    assert!((1..=2).contains(&draws), "{}", seen["reload"]);
    assert_eq!(seen["reload"]["check"], "holds", "{}", seen["reload"]);
    let ms = seen["reload_ms"].as_u64().unwrap_or(u64::MAX);
    assert!(ms < 3000, "drawn {ms} ms after the reload");
    // The moves on disk, the last one as the other program wrote it.
    let layout = read(&dir.join("layout.toml"));
    assert!(layout.contains("[INIT.places]"), "{layout}");
    let at = &seen["disk"]["at"];
    let fourth = seen["outside"]["place"].as_str().unwrap_or("?");
    assert!(
        layout.contains(&format!("{fourth} = [{}.0, {}.0]", at[0], at[1])),
        "{layout}"
    );
    for e in &edits {
        let place = e["place"].as_str().unwrap_or("?");
        assert!(layout.contains(&format!("\n{place} = [")), "{layout}");
    }
}
