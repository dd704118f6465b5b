//! A team's `petrel run` and what it printed: the gateway started on a
//! fixture project, its timeline and log read back, its recording
//! replayed. Shared by the scripted team tests (`it`) and the real
//! copters' (`real`).
#![allow(dead_code)] // each binary uses a part

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use serde_json::Value;

use crate::harness::Process;

pub(crate) fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// `petrel run PROJECT --mavlink ADDRESS`, timeline to `dir/petrel.jsonl`,
/// log to `dir/petrel.err`, recording to `dir/petrel.mcap`.
pub(crate) fn petrel(
    project: &Path,
    address: &str,
    dir: &Path,
    time_scale: u32,
    limit: Duration,
) -> Process {
    let file = |ext: &str| dir.join(format!("petrel.{ext}"));
    Process::spawn(
        "petrel",
        Command::new(env!("CARGO_BIN_EXE_petrel"))
            .arg("run")
            .arg(project)
            .args(["--mavlink", address, "--json"])
            .args(["--time-scale", &time_scale.to_string()])
            .args(["--duration", &limit.as_secs_f64().to_string()])
            .arg("--record")
            .arg(file("mcap"))
            .stdout(std::fs::File::create(file("jsonl")).expect("timeline file"))
            .stderr(std::fs::File::create(file("err")).expect("log file")),
    )
}

/// The gateway's timeline (JSON lines) and log.
pub(crate) struct Timeline {
    pub(crate) lines: Vec<Value>,
    pub(crate) log: String,
}

impl Timeline {
    pub(crate) fn read(dir: &Path) -> Timeline {
        Timeline::parse(
            &std::fs::read_to_string(dir.join("petrel.jsonl")).unwrap_or_default(),
            std::fs::read_to_string(dir.join("petrel.err")).unwrap_or_default(),
        )
    }

    pub(crate) fn parse(text: &str, log: String) -> Timeline {
        let lines = text
            .lines()
            .filter_map(|l| serde_json::from_str(l).ok())
            .collect();
        Timeline { lines, log }
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

    pub(crate) fn fired(&self, net: &str, transition: &str) -> bool {
        self.lines
            .iter()
            .any(|l| l["effect"] == "fired" && l["net"] == net && l["transition"] == transition)
    }

    /// The command effects: (verb, vehicle).
    pub(crate) fn commands(&self) -> Vec<(String, String)> {
        self.lines
            .iter()
            .filter(|l| l["effect"] == "command")
            .map(|l| {
                (
                    l["verb"].as_str().unwrap_or("?").to_owned(),
                    l["vehicle"].as_str().unwrap_or("?").to_owned(),
                )
            })
            .collect()
    }

    /// Log lines containing `text`.
    pub(crate) fn told(&self, text: &str) -> usize {
        self.log.lines().filter(|l| l.contains(text)).count()
    }

    /// The timeline without markings, for failure messages.
    pub(crate) fn decisions(&self) -> String {
        let mut out = String::new();
        for l in self.lines.iter().filter(|l| l["effect"] != "marking") {
            out.push_str(&l.to_string());
            out.push('\n');
        }
        format!("{out}{}", self.log)
    }

    /// Every event is qualified with the vehicle whose system sent it
    /// (`R1` system 1, `R2` system 2); a ground station's are no vehicle's.
    pub(crate) fn tagged_by_vehicle(&self) {
        let events = self.events();
        for system in [1, 2] {
            assert!(
                events.iter().any(|(_, s)| *s == system),
                "no event of vehicle {system}\n{}",
                self.decisions()
            );
        }
        for (name, system) in &events {
            let expected = match system {
                1 => "@R1",
                2 => "@R2",
                _ => panic!("an event of system {system}: {name}"),
            };
            assert!(name.ends_with(expected), "{name} from system {system}");
        }
    }
}

/// `petrel replay RECORDING PROJECT --check-against --json`: its timeline,
/// after asserting it agrees with the flight step for step.
pub(crate) fn replay_agrees(dir: &Path, project: &Path) -> Timeline {
    let replay = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .arg("replay")
        .arg(dir.join("petrel.mcap"))
        .arg(project)
        .args(["--check-against", "--json"])
        .output()
        .expect("petrel replay");
    let stderr = String::from_utf8_lossy(&replay.stderr).into_owned();
    assert!(
        replay.status.success(),
        "the team's recording does not replay:\n{stderr}"
    );
    assert!(stderr.contains("match the recording"), "{stderr}");
    Timeline::parse(&String::from_utf8_lossy(&replay.stdout), stderr)
}
