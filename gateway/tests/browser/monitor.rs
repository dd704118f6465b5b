//! The web monitor in a real browser (docs/monitor.md): Debian's chromium,
//! headless, driven by playwright-core (`tests/monitor/driver.js`).
//! `petrel demo` flies the flight-test example with the page served; every
//! net, place and transition of the example must be drawn, a place must
//! turn red as the flight goes on (one not marked when the page opened)
//! and the log grow; then `petrel view`
//! over the flight's recording is scrubbed to three instants whose
//! markings must be those `petrel replay` computes.
//!
//! Needs node, playwright-core (`target/browser-tools`, or the folder
//! `PETREL_PLAYWRIGHT_CORE` names) and /usr/bin/chromium (`.ci/run`
//! installs them): skipped with the reason without them, failed under
//! `CI=true`. Screenshots go to `target/tmp/monitor/`.

use crate::scratch;

use std::collections::{BTreeMap, BTreeSet};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use serde_json::Value as Json;

use crate::browser;
mod hostile;

use browser::{assert_readable, drive, repo, require, Reaped};
use scratch::Scratch;

const PETREL: &str = env!("CARGO_BIN_EXE_petrel");

fn example() -> PathBuf {
    repo().join("examples/uav-flight-test")
}

/// Spawns petrel with stderr read line by line on a thread.
fn spawn(args: &[&str], dir: &Path) -> (Reaped, mpsc::Receiver<String>) {
    let mut child = Command::new(PETREL)
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start petrel: {e}"));
    let err = child.stderr.take().unwrap_or_else(|| panic!("no stderr"));
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(err).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    (Reaped(child), rx)
}

/// `petrel demo` at 4 times real time with its page on a free port,
/// recording to `mcap`, in `dir`.
fn demo_live(dir: &Path, mcap: &str) -> (Reaped, mpsc::Receiver<String>) {
    spawn(
        &[
            "demo",
            "--speed",
            "4",
            "--http",
            "127.0.0.1:0",
            "--record",
            mcap,
            "--timeout",
            "300",
        ],
        dir,
    )
}

/// The URL after `prefix` in petrel's stderr, waiting at most `limit`.
fn url(rx: &mpsc::Receiver<String>, prefix: &str, limit: Duration) -> String {
    let until = Instant::now() + limit;
    let mut said = Vec::new();
    while let Some(left) = until.checked_duration_since(Instant::now()) {
        match rx.recv_timeout(left) {
            Ok(line) => {
                if let Some(rest) = line.strip_prefix(prefix) {
                    return rest.split_whitespace().next().unwrap_or("").to_owned();
                }
                said.push(line);
            }
            Err(_) => break,
        }
    }
    panic!(
        "petrel never said `{prefix}`; it said:\n{}",
        said.join("\n")
    )
}

/// An id fragment as `nets::svg` makes it.
fn id(s: &str) -> String {
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

/// The example read from its TOML files, independently of Petrel: net
/// names, the element ids each net's drawing must have, the nets that use
/// each global place.
struct Example {
    nets: Vec<String>,
    ids: BTreeSet<String>,
    globals: BTreeMap<String, BTreeSet<String>>,
    transitions: BTreeMap<String, Vec<String>>,
}

fn read_example() -> Example {
    let read = |f: &str| -> toml::Table {
        let text =
            std::fs::read_to_string(example().join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
        text.parse().unwrap_or_else(|e| panic!("{f}: {e}"))
    };
    let project = read("project.toml");
    let mut ex = Example {
        nets: Vec::new(),
        ids: BTreeSet::new(),
        globals: BTreeMap::new(),
        transitions: BTreeMap::new(),
    };
    let strs = |v: Option<&toml::Value>| -> Vec<String> {
        v.and_then(|v| v.as_array())
            .map(|a| {
                a.iter()
                    .filter_map(|s| s.as_str().map(str::to_owned))
                    .collect()
            })
            .unwrap_or_default()
    };
    for g in project["globals"]
        .as_table()
        .into_iter()
        .flat_map(|t| t.keys())
    {
        ex.globals.insert(g.clone(), BTreeSet::new());
    }
    for net in project["net"].as_array().unwrap_or(&Vec::new()) {
        let file = net["file"].as_str().unwrap_or("");
        let t = read(file);
        let name = t["name"].as_str().unwrap_or("").to_owned();
        for p in strs(t.get("places")) {
            ex.ids.insert(format!("p-{}-{}", id(&name), id(&p)));
        }
        let mut names = Vec::new();
        for tr in t
            .get("transition")
            .and_then(|v| v.as_array())
            .unwrap_or(&Vec::new())
        {
            let tn = tr["name"].as_str().unwrap_or("").to_owned();
            ex.ids.insert(format!("t-{}-{}", id(&name), id(&tn)));
            for p in strs(tr.get("from")).into_iter().chain(strs(tr.get("to"))) {
                if let Some(g) = p.strip_prefix('@') {
                    ex.ids.insert(format!("p-{}-{}", id(&name), id(&p)));
                    ex.globals
                        .entry(g.to_owned())
                        .or_default()
                        .insert(name.clone());
                }
            }
            names.push(tn);
        }
        ex.transitions.insert(name.clone(), names);
        ex.nets.push(name);
    }
    ex
}

/// The ids of the places marked at `at` (µs) by `petrel replay --json`'s
/// marking effects.
fn replay_marked(lines: &[Json], at: u64, ex: &Example) -> BTreeSet<String> {
    let mut marking: BTreeMap<Option<String>, Vec<String>> = BTreeMap::new();
    for l in lines {
        if l["effect"] == "marking" && l["time_us"].as_u64().is_some_and(|t| t <= at) {
            let net = l["net"].as_str().map(str::to_owned);
            let marked = l["marked"]
                .as_array()
                .map(|a| {
                    a.iter()
                        .filter_map(|s| s.as_str().map(str::to_owned))
                        .collect()
                })
                .unwrap_or_default();
            marking.insert(net, marked);
        }
    }
    let mut ids = BTreeSet::new();
    for (net, marked) in marking {
        for p in marked {
            match (&net, p.strip_prefix('@')) {
                (Some(n), None) => {
                    ids.insert(format!("p-{}-{}", id(n), id(&p)));
                }
                (None, Some(g)) => {
                    for n in ex.globals.get(g).into_iter().flatten() {
                        ids.insert(format!("p-{}-{}", id(n), id(&p)));
                    }
                }
                _ => {}
            }
        }
    }
    ids
}

#[test]
fn the_flight_live_in_the_browser_then_its_recording_scrubbed() {
    let Some(tools) = require() else { return };
    let ex = read_example();
    let shots = browser::shots();
    // This test's own screenshots of an earlier run (the view's are named by
    // their instants); the mirror's test keeps its own beside them.
    for entry in std::fs::read_dir(&shots).into_iter().flatten().flatten() {
        let name = entry.file_name().to_string_lossy().to_string();
        if ["monitor-live", "monitor-view", "monitor-zoom"]
            .iter()
            .any(|p| name.starts_with(p))
        {
            let _ = std::fs::remove_file(entry.path());
        }
    }
    let dir = Scratch::new("monitor");
    let mcap = dir.path().join("flight.mcap");
    let mcap_s = mcap.to_string_lossy().to_string();
    let shots_s = shots.to_string_lossy().to_string();

    // 1. Live: the demo's flight with the page served on a free port.
    let (mut demo, rx) = demo_live(dir.path(), &mcap_s);
    let live = url(&rx, "monitor: ", Duration::from_secs(600));
    let first_flight = &ex.transitions["FLIGHT"][0];
    let seen = drive(
        &tools,
        &["live", &live, &shots_s],
        &[
            (
                "MONITOR_CLICK_TRANSITION",
                &format!("t-FLIGHT-{}", id(first_flight)),
            ),
            ("MONITOR_ZOOM_NET", "FLIGHT"),
        ],
    );
    let drawn: BTreeSet<String> = seen["ids"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|s| s.as_str().map(str::to_owned))
                .collect()
        })
        .unwrap_or_default();
    let missing: Vec<&String> = ex.ids.difference(&drawn).collect();
    assert!(missing.is_empty(), "not drawn: {missing:?}");
    assert!(
        ex.ids.len() > 100,
        "the example has {} elements",
        ex.ids.len()
    );
    let nets: Vec<String> = seen["nets"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|s| s.as_str().map(str::to_owned))
                .collect()
        })
        .unwrap_or_default();
    assert_eq!(
        nets.iter().collect::<BTreeSet<_>>(),
        ex.nets.iter().collect::<BTreeSet<_>>()
    );
    assert_eq!(
        seen["globals"].as_array().map(Vec::len),
        Some(ex.globals.len())
    );
    let red = seen["turned_red"].as_str().unwrap_or("");
    assert!(
        ex.ids.contains(red),
        "{red} turned red: a place of the example"
    );
    assert_eq!(
        seen["fill"], "rgb(224, 0, 0)",
        "a marked place is filled red"
    );
    assert_eq!(
        seen["unmarked_fill"], "rgb(255, 255, 255)",
        "the others white"
    );
    let (first, later) = (seen["log_first"].as_u64(), seen["log_later"].as_u64());
    assert!(later > first, "the log grew: {first:?} then {later:?}");
    for kind in ["event", "command", "call", "result"] {
        assert!(
            seen["log_kinds"]
                .as_array()
                .is_some_and(|k| k.iter().any(|x| x == kind)),
            "no {kind} in the log: {}",
            seen["log_kinds"]
        );
    }
    assert!(
        seen["enabled"].as_u64() > Some(0),
        "enabled transitions outlined"
    );
    assert_readable(&seen);
    let definition = seen["definition"].as_str().unwrap_or("");
    assert!(
        definition.contains(&format!("FLIGHT.{first_flight}"))
            && definition.contains("flight.toml:"),
        "{definition}"
    );
    assert!(
        seen["zoom_ids"].as_u64() > Some(30),
        "FLIGHT opened alone: {}",
        seen["zoom_ids"]
    );
    assert!(seen["zoom_marked"].as_u64() > Some(0));

    // The demo ends by itself when the aircraft is down.
    let until = Instant::now() + Duration::from_secs(400);
    while demo.0.try_wait().ok().flatten().is_none() {
        assert!(Instant::now() < until, "the demo did not end");
        std::thread::sleep(Duration::from_millis(200));
    }

    // 2. The recording: `petrel replay`'s markings at three instants.
    let replay = Command::new(PETREL)
        .args(["replay", &mcap_s])
        .arg(example())
        .arg("--json")
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(
        replay.status.success(),
        "{}",
        String::from_utf8_lossy(&replay.stderr)
    );
    let lines: Vec<Json> = String::from_utf8_lossy(&replay.stdout)
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect();
    let mut changes: Vec<u64> = lines
        .iter()
        .filter(|l| l["effect"] == "marking")
        .filter_map(|l| l["time_us"].as_u64())
        .collect();
    changes.dedup();
    let end = lines
        .iter()
        .filter_map(|l| l["time_us"].as_u64())
        .max()
        .unwrap_or(0);
    assert!(end > 30_000_000, "a flight of {end} µs");
    // Instants well inside quiet stretches (no marking change within 0.4 s):
    // the page's scrubbing resolution cannot blur them.
    let instants: Vec<u64> = [0.3, 0.55, 0.8]
        .iter()
        .map(|f| {
            let want = (end as f64 * f) as u64;
            let i = changes.partition_point(|&c| c <= want);
            let (a, b) = (
                changes[i.max(1) - 1],
                changes.get(i).copied().unwrap_or(end),
            );
            assert!(b - a > 800_000, "no quiet stretch around {want} µs");
            (a + b) / 2 / 100_000 * 100_000
        })
        .collect();
    let (_view, rx) = spawn(&["view", &mcap_s, &example().to_string_lossy()], dir.path());
    // `view` serves on 8090 or a free port; the URL is what it says.
    let _ = &rx;
    let view_url = url(&rx, "view: ", Duration::from_secs(120));
    let secs: Vec<String> = instants
        .iter()
        .map(|t| format!("{:.1}", *t as f64 / 1e6))
        .collect();
    let mut args = vec!["view", view_url.as_str(), shots_s.as_str()];
    args.extend(secs.iter().map(String::as_str));
    let seen = drive(&tools, &args, &[]);
    assert!(
        seen["timeline"]["catastrophic"].as_u64() > Some(0),
        "{}",
        seen["timeline"]
    );
    assert!(seen["catastrophic_marks_drawn"].as_u64() > Some(0));
    let at = seen["instants"].as_array().cloned().unwrap_or_default();
    assert_eq!(at.len(), 3);
    for (got, &t) in at.iter().zip(&instants) {
        let want = replay_marked(&lines, t, &ex);
        let marked: BTreeSet<String> = got["marked"]
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|s| s.as_str().map(str::to_owned))
                    .collect()
            })
            .unwrap_or_default();
        assert!(
            got["span"]
                .as_str()
                .is_some_and(|s| s.starts_with(&format!("{:.1} /", t as f64 / 1e6))),
            "scrubbed to {t} µs, the page shows {}",
            got["span"]
        );
        assert!(!want.is_empty());
        assert_eq!(marked, want, "the marking at {t} µs");
        assert!(
            got["log_max"].as_f64() <= Some(t as f64 / 1e6 + 0.05),
            "the log stops at the instant"
        );
    }
    assert_ne!(seen["stepped_to"], seen["stepped_from"], "step moved");
    assert_ne!(seen["played_to"], seen["stepped_to"], "play moved");
}

/// A recording whose project took a new version in flight, in `petrel
/// view`: each instant is drawn with the version that ran then, the page
/// loading again (at the same instant) when the scrub crosses the swap.
/// The recording is written here by the recorder `petrel run` uses: ten
/// events, version 1 (its transitions renamed), ten events more.
#[test]
fn a_recording_with_a_new_version_is_drawn_with_each_version() {
    let Some(tools) = require() else { return };
    let dir = Scratch::new("view-versions");
    let net = |go: &str, back: &str| {
        format!(
            "name = \"N\"\nplaces = [\"idle\", \"busy\"]\ninitial = [\"idle\"]\n\
             [[transition]]\nname = \"{go}\"\nfrom = [\"idle\"]\nto = [\"busy\"]\non = \"x\"\n\
             [[transition]]\nname = \"{back}\"\nfrom = [\"busy\"]\nto = [\"idle\"]\non = \"y\"\n"
        )
    };
    let project_toml =
        "[[net]]\nfile = \"n.toml\"\nactive = true\n[events]\nx = \"nominal\"\ny = \"nominal\"\n";
    std::fs::write(dir.join("project.toml"), project_toml).expect("write");
    std::fs::write(dir.join("n.toml"), net("tick", "tock")).expect("write");
    let load = |files: &[(String, String)]| {
        let sources: BTreeMap<String, String> = files.iter().cloned().collect();
        std::sync::Arc::new(nets::load(&sources).unwrap_or_else(|e| panic!("{e:?}")))
    };
    let v0 = load(&[
        ("project.toml".into(), project_toml.into()),
        ("n.toml".into(), net("tick", "tock")),
    ]);
    let files1 = vec![
        ("project.toml".to_owned(), project_toml.to_owned()),
        ("n.toml".to_owned(), net("rise", "fall")),
    ];
    let version = std::sync::Arc::new(petrel_core::version::Version {
        number: 1,
        project: load(&files1),
        files: files1,
    });
    let mcap = dir.join("flight.mcap");
    let recorder = petrel_record::recorder::Recorder::create(
        &mcap,
        v0.clone(),
        petrel_record::recorder::Options::default(),
    )
    .expect("a recording");
    let profile = elaboration::Profile::builtin("ardupilot").expect("the profile");
    let (mut sup, start) =
        petrel_core::supervisor::Supervisor::start(v0, profile, elaboration::Config::default(), 0);
    recorder.start(&start, sup.player());
    use petrel_core::supervisor::Input;
    for i in 1..=21u64 {
        let input = if i == 11 {
            Input::Version(&version)
        } else {
            Input::Event(nets::Event::new(if i % 2 == 1 { "x" } else { "y" }))
        };
        recorder.feed(&mut sup, i * 1_000_000, input);
    }
    recorder.finish().expect("the recording ends");
    let (_view, rx) = spawn(
        &[
            "view",
            &mcap.to_string_lossy(),
            &dir.to_string_lossy(),
            "--http",
            "127.0.0.1:0",
        ],
        dir.path(),
    );
    let view_url = url(&rx, "view: ", Duration::from_secs(60));
    let shots = repo().join("target/tmp/monitor");
    std::fs::create_dir_all(&shots).expect("a folder");
    let shots_s = shots.to_string_lossy().into_owned();
    // 5.5 s: version 0, after x (busy); 15.5 s: version 1, after x (busy);
    // 3.5 s: back across the swap.
    let seen = drive(
        &tools,
        &["view-versions", &view_url, &shots_s, "5.5", "15.5", "3.5"],
        &[],
    );
    let instants = seen["instants"].as_array().cloned().unwrap_or_default();
    let drawn = |i: usize| -> Vec<String> {
        instants[i]["transitions"]
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|s| s.as_str().map(str::to_owned))
                    .collect()
            })
            .unwrap_or_default()
    };
    assert_eq!(instants.len(), 3, "{seen}");
    assert_eq!(drawn(0), ["t-N-tick", "t-N-tock"], "{seen}");
    assert_eq!(drawn(1), ["t-N-rise", "t-N-fall"], "{seen}");
    assert_eq!(drawn(2), ["t-N-tick", "t-N-tock"], "{seen}");
    for instant in &instants {
        assert_eq!(instant["marked"], serde_json::json!(["p-N-busy"]), "{seen}");
    }
    assert!(
        instants[1]["hash"]
            .as_str()
            .is_some_and(|h| h.contains("v=1")),
        "{seen}"
    );
}
