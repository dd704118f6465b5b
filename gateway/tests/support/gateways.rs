//! Gateways side by side, each its own `petrel run` on a fixture of
//! `tests/multi_vehicle/`, and what each printed. Shared by the scripted
//! vehicles' test (`it`) and the real copters' (`real`).
#![allow(dead_code)] // each binary uses a part

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use serde_json::Value;

use crate::harness::Process;

pub(crate) fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/multi_vehicle")
        .join(name)
}

/// `petrel run PROJECT --mavlink ADDRESS`, timeline to `dir/NAME.jsonl`,
/// log to `dir/NAME.err`, recording to `dir/NAME.mcap`.
pub(crate) fn petrel_with(
    name: &'static str,
    project: &Path,
    address: &str,
    dir: &Path,
    time_scale: u32,
    duration: Duration,
) -> Process {
    let file = |ext: &str| dir.join(format!("{name}.{ext}"));
    Process::spawn(
        name,
        Command::new(env!("CARGO_BIN_EXE_petrel"))
            .arg("run")
            .arg(project)
            .args(["--mavlink", address, "--json"])
            .args(["--time-scale", &time_scale.to_string()])
            .args(["--duration", &duration.as_secs_f64().to_string()])
            .arg("--record")
            .arg(file("mcap"))
            .stdout(std::fs::File::create(file("jsonl")).expect("timeline file"))
            .stderr(std::fs::File::create(file("err")).expect("log file")),
    )
}

/// A gateway's timeline (JSON lines) and log.
pub(crate) struct Gateway {
    pub(crate) name: &'static str,
    pub(crate) lines: Vec<Value>,
    pub(crate) log: String,
}

impl Gateway {
    pub(crate) fn read(name: &'static str, dir: &Path) -> Gateway {
        let text = std::fs::read_to_string(dir.join(format!("{name}.jsonl"))).unwrap_or_default();
        let lines = text
            .lines()
            .filter_map(|l| serde_json::from_str(l).ok())
            .collect();
        let log = std::fs::read_to_string(dir.join(format!("{name}.err"))).unwrap_or_default();
        Gateway { name, lines, log }
    }

    /// Elaborated events: (name, sysid).
    pub(crate) fn events(&self) -> Vec<(String, i64)> {
        self.lines
            .iter()
            .filter(|l| l["input"] == "event")
            .map(|l| {
                (
                    l["event"].as_str().unwrap_or("?").to_owned(),
                    l["sysid"].as_i64().unwrap_or(-1),
                )
            })
            .collect()
    }

    /// The timeline without markings and with at most 5 of each event,
    /// for failure messages.
    pub(crate) fn decisions(&self) -> String {
        let mut seen = std::collections::BTreeMap::<String, usize>::new();
        let mut out = String::new();
        for l in &self.lines {
            if l["effect"] == "marking" {
                continue;
            }
            if let Some(e) = l["event"].as_str().filter(|_| l["input"] == "event") {
                let n = seen.entry(e.to_owned()).or_default();
                *n += 1;
                if *n > 5 {
                    continue;
                }
            }
            out.push_str(&l.to_string());
            out.push('\n');
        }
        out
    }

    pub(crate) fn heard(&self, event: &str) -> bool {
        self.events().iter().any(|(e, _)| e == event)
    }

    pub(crate) fn fired(&self, transition: &str) -> bool {
        self.lines
            .iter()
            .any(|l| l["effect"] == "fired" && l["transition"] == transition)
    }

    pub(crate) fn commands(&self) -> usize {
        self.lines
            .iter()
            .filter(|l| l["effect"] == "command")
            .count()
    }

    /// Log lines containing `text`.
    pub(crate) fn told(&self, text: &str) -> usize {
        self.log.lines().filter(|l| l.contains(text)).count()
    }

    /// Events name `sysid` and never the other vehicle (1 or 2); a ground
    /// station's (`gcs_lost {sysid: 255}`: MAVProxy's heartbeat, routed by
    /// the autopilot) are no vehicle's.
    pub(crate) fn only_from(&self, sysid: i64) {
        let events = self.events();
        assert!(
            events.iter().any(|(_, s)| *s == sysid),
            "{}: no event of vehicle {sysid}\n{}",
            self.name,
            self.log
        );
        let foreign: Vec<_> = events
            .iter()
            .filter(|(e, s)| *s != sysid && !(e.starts_with("gcs_") && *s == 255))
            .collect();
        assert!(
            foreign.is_empty(),
            "{}: events of another vehicle than {sysid}: {foreign:?}",
            self.name
        );
    }
}
