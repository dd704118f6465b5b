//! The operator dialog through the two processes: `petrel run
//! --operator-key` with the simulated ArduPlane behind the mirror tests'
//! router, and `petrel mirror --operator-key` on the ground's port, the
//! answers typed on the mirror's stdin. Only the valid answer in time is
//! delivered; a late, a wrongly signed, an unsigned and a replayed one are
//! rejected and counted by `run`. Also: both sides refuse a key others may
//! read. (The dialog's parts are tested sans-IO in
//! `core/src/mirror/dialog/tests.rs`.)

use crate::flight;
use crate::router;
use crate::scratch;

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use router::{Loss, Router};
use scratch::Scratch;

/// Simulated seconds per wall second: half the flights' pace, so that
/// the two gateways' recorders keep up with the telemetry on a busy
/// machine.
const SPEED: f64 = 5.0;
/// The question's time to answer, in vehicle seconds.
const TIMEOUT_S: f64 = 50.0;

/// A scratch folder holding a project that asks a question.
fn scratch(name: &str) -> Scratch {
    let dir = Scratch::new(&format!("dialog-{name}"));
    std::fs::write(
        dir.join("project.toml"),
        "[events]\nreached = {}\n[[net]]\nfile = \"n.toml\"\nactive = true\n",
    )
    .expect("write");
    std::fs::write(
        dir.join("n.toml"),
        "name = \"N\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\n[[transition]]\nname = \"ask\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"reached\"\ndo = ['ask go \"Go?\" {choices: [yes, no]} timeout 30s']\n",
    )
    .expect("write");
    dir
}

fn key_file(dir: &Path, mode: u32) -> PathBuf {
    let path = dir.join("operator.key");
    std::fs::write(&path, "ab".repeat(32)).expect("write");
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(mode)).expect("chmod");
    path
}

/// Runs petrel with `args`, killed after 20 s at most; (code, stderr).
fn petrel(args: &[&str]) -> (i32, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .args(args)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("petrel starts");
    let deadline = std::time::Instant::now() + Duration::from_secs(20);
    while child.try_wait().expect("wait").is_none() {
        if std::time::Instant::now() > deadline {
            let _ = child.kill();
            break;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let out = child.wait_with_output().expect("output");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn an_operator_key_others_may_read_is_refused_on_both_sides() {
    let dir = scratch("readable");
    let key = key_file(&dir, 0o644);
    let project = dir.to_str().expect("utf-8");
    let key = key.to_str().expect("utf-8");
    for args in [
        vec![
            "run",
            project,
            "--mavlink",
            "udpin:127.0.0.1:0",
            "--no-record",
            "--unchecked",
            "--operator-key",
            key,
            "--duration",
            "1",
        ],
        vec![
            "mirror",
            project,
            "--mavlink",
            "udpin:127.0.0.1:0",
            "--operator-key",
            key,
            "--duration",
            "1",
        ],
    ] {
        let (code, err) = petrel(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains("chmod 600"), "{args:?}: {err}");
    }
}

/// A net that asks `go` ("Go on?", yes or no, 50 s to answer) 20 s
/// after the start and after each answer, 60 s after a timeout.
fn asking_project(dir: &Path) {
    std::fs::write(
        dir.join("project.toml"),
        "name = \"asking\"\n[[net]]\nfile = \"q.toml\"\nactive = true\n",
    )
    .expect("write");
    let mut net = String::from(
        "name = \"Q\"\nplaces = [\"init\", \"waiting\", \"asking\"]\ninitial = [\"init\"]\n\
         [[transition]]\nname = \"begin\"\nfrom = [\"init\"]\nto = [\"waiting\"]\ndo = [\"timer next after 20s\"]\n\
         [[transition]]\nname = \"ask\"\nfrom = [\"waiting\"]\nto = [\"asking\"]\non = \"next\"\n\
         do = ['ask go \"Go on?\" {choices: [yes, no]} timeout 50s']\n",
    );
    for (name, on, after) in [
        ("yes", "go.yes", 20),
        ("no", "go.no", 20),
        ("unanswered", "go.timeout", 60),
    ] {
        net.push_str(&format!(
            "[[transition]]\nname = \"{name}\"\nfrom = [\"asking\"]\nto = [\"waiting\"]\non = \"{on}\"\ndo = [\"timer next after {after}s\"]\n"
        ));
    }
    std::fs::write(dir.join("q.toml"), net).expect("write");
}

/// A key file of 32 bytes, all `byte`, readable by its owner only.
fn key(dir: &Path, name: &str, byte: u8) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, [byte; 32]).expect("write");
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600)).expect("chmod");
    path
}

/// A petrel process whose output lines are collected as they come.
struct Petrel {
    child: Option<Child>,
    stdin: Option<ChildStdin>,
    out: Arc<Mutex<Vec<String>>>,
    err: Arc<Mutex<Vec<String>>>,
}

impl Petrel {
    fn start(args: &[&str]) -> Petrel {
        let mut child = Command::new(env!("CARGO_BIN_EXE_petrel"))
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("petrel starts");
        let collect = |pipe: Box<dyn std::io::Read + Send>| {
            let lines = Arc::new(Mutex::new(Vec::new()));
            let shared = lines.clone();
            std::thread::spawn(move || {
                for line in BufReader::new(pipe).lines() {
                    let Ok(line) = line else { break };
                    shared.lock().expect("lines").push(line);
                }
            });
            lines
        };
        let out = collect(Box::new(child.stdout.take().expect("stdout")));
        let err = collect(Box::new(child.stderr.take().expect("stderr")));
        Petrel {
            stdin: child.stdin.take(),
            child: Some(child),
            out,
            err,
        }
    }

    /// The first stderr line `pick` takes, waiting up to `wait`.
    fn wait_for<T>(&self, wait: Duration, pick: impl Fn(&str) -> Option<T>) -> Option<T> {
        let deadline = Instant::now() + wait;
        loop {
            if let Some(t) = self.err.lock().expect("lines").iter().find_map(|l| pick(l)) {
                return Some(t);
            }
            if Instant::now() > deadline {
                return None;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    fn stderr(&self) -> String {
        self.err.lock().expect("lines").join("\n")
    }

    /// Types a line on its stdin.
    fn type_line(&mut self, line: &str) {
        let stdin = self.stdin.as_mut().expect("stdin");
        writeln!(stdin, "{line}").expect("typed");
        stdin.flush().expect("flushed");
    }

    /// Stops it (SIGTERM) and waits: (stdout lines, stderr).
    fn stop(mut self) -> (Vec<String>, String) {
        if let Some(mut child) = self.child.take() {
            let _ = Command::new("kill")
                .args(["-TERM", &child.id().to_string()])
                .status();
            let deadline = Instant::now() + Duration::from_secs(20);
            while child.try_wait().ok().flatten().is_none() && Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = child.kill();
            let _ = child.wait();
        }
        // The readers end with the pipes.
        std::thread::sleep(Duration::from_millis(200));
        let out = self.out.lock().expect("lines").clone();
        (out, self.stderr())
    }
}

impl Drop for Petrel {
    fn drop(&mut self) {
        if let Some(mut child) = self.child.take() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// The id of a question the mirror shows (`QUESTION #ID from NET: …`) not
/// in `seen`.
fn question(line: &str, seen: &[u64]) -> Option<u64> {
    let rest = line.strip_prefix("QUESTION #")?;
    let (id, rest) = rest.split_once(' ')?;
    let id = id.parse().ok()?;
    (rest.starts_with("from ") && !seen.contains(&id)).then_some(id)
}

/// The answer frames (uplink record kind 7) among the frames the ground
/// sent, in order; the TUNNEL payload read as docs/mirror.md lays it out.
fn answer_frames(frames: &[Vec<u8>]) -> Vec<Vec<u8>> {
    frames
        .iter()
        .filter(|bytes| {
            let Ok(f) = elaboration::Frame::parse(bytes) else {
                return false;
            };
            let p = f.payload();
            f.message_id() == 385 && p.get(5) == Some(&1) && p.get(6) == Some(&7)
        })
        .cloned()
        .collect()
}

/// MAVLink's CRC-16/MCRF4XX.
fn crc(bytes: &[u8], extra: u8) -> u16 {
    let mut crc: u16 = 0xffff;
    for &b in bytes.iter().chain(std::iter::once(&extra)) {
        let mut tmp = b ^ (crc & 0xff) as u8;
        tmp ^= tmp << 4;
        let tmp = u16::from(tmp);
        crc = (crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4);
    }
    crc
}

/// A signed MAVLink 2 frame without its signature: the signed flag
/// cleared, the 13 signature bytes cut, the checksum made again.
fn unsigned(signed: &[u8]) -> Vec<u8> {
    assert_eq!(signed[2] & 1, 1, "a signed frame");
    let len = usize::from(signed[1]);
    let mut bytes = signed[..10 + len].to_vec();
    bytes[2] &= !1;
    // TUNNEL's CRC_EXTRA (MAVLink's common.xml).
    let sum = crc(&bytes[1..], 147);
    // The frame as the gateway signed it checks with the same extra.
    assert_eq!(
        crc(&signed[1..10 + len], 147).to_le_bytes(),
        signed[10 + len..12 + len],
        "TUNNEL's CRC_EXTRA"
    );
    bytes.extend_from_slice(&sum.to_le_bytes());
    bytes
}

#[test]
fn answers_typed_on_the_mirror_are_delivered_on_board_only_when_valid_and_in_time() {
    let dir = scratch("e2e");
    asking_project(&dir);
    let operator = key(&dir, "operator.key", 0x5a);
    let other = key(&dir, "other.key", 0xa5);
    let (project, operator, other) = (
        dir.to_str().expect("utf-8").to_owned(),
        operator.to_str().expect("utf-8").to_owned(),
        other.to_str().expect("utf-8").to_owned(),
    );
    let sim = sitl_tests::Sim::start(sitl_tests::SimConfig {
        listen: "tcpin:127.0.0.1:0".into(),
        boot: sitl_tests::BootTimeline::quick(),
        speedup: SPEED,
        ..sitl_tests::SimConfig::default()
    })
    .expect("the simulator starts");
    let router = Router::start(sim.local_addr(), Loss::default());
    let speed = SPEED.to_string();
    let run_record = dir.join("run.mcap");
    let run = Petrel::start(&[
        "run",
        &project,
        "--mavlink",
        &format!("tcpout:127.0.0.1:{}", router.companion_port),
        "--time-scale",
        &speed,
        "--record",
        run_record.to_str().expect("utf-8"),
        "--duration",
        "120",
        "--json",
        "--downlink",
        "--unchecked",
        "--operator-key",
        &operator,
    ]);
    let mirror = |key: &str, record: &str| {
        Petrel::start(&[
            "mirror",
            &project,
            "--mavlink",
            &format!("tcpout:127.0.0.1:{}", router.ground_port),
            "--time-scale",
            &speed,
            "--duration",
            "120",
            "--json",
            "--operator-key",
            key,
            "--record",
            dir.join(record).to_str().expect("utf-8"),
        ])
    };
    let mut a = mirror(&operator, "mirror-a.mcap");
    let wait = Duration::from_secs(30);
    let started = Instant::now();
    let say = |what: &str| eprintln!("{:6.2} s: {what}", started.elapsed().as_secs_f64());
    let shown = |m: &Petrel, seen: &[u64]| {
        m.wait_for(wait, |l| question(l, seen))
            .unwrap_or_else(|| panic!("no question shown\n{}", m.stderr()))
    };
    let sent = |m: &Petrel, id: u64, choice: &str| {
        let line = format!("answer #{id} {choice} sent (signed)");
        m.wait_for(wait, |l| (l == line).then_some(()))
            .unwrap_or_else(|| panic!("{line:?} not said\n{}", m.stderr()));
    };

    // 1. Answered in time: delivered.
    let first = shown(&a, &[]);
    say(&format!("question #{first} shown"));
    a.type_line(&format!("{first} yes"));
    sent(&a, first, "yes");
    say("answered");

    // 2. Late: the radio loses everything toward the ground, so the mirror
    // still shows the question pending after its deadline on board.
    let second = shown(&a, &[first]);
    say(&format!("question #{second} shown; the downlink muted"));
    router.mute_downlink(true);
    std::thread::sleep(Duration::from_secs_f64(TIMEOUT_S / SPEED + 1.5));
    a.type_line(&format!("{second} no"));
    sent(&a, second, "no");
    say("answered late");
    std::thread::sleep(Duration::from_millis(300));
    router.mute_downlink(false);
    // The replica catches up: it plays the late answer's step.
    let heard = |m: &Petrel, id: u64| {
        let deadline = Instant::now() + wait;
        while Instant::now() < deadline {
            let lines = m.out.lock().expect("lines").clone();
            if flight::timeline(&lines.join("\n"))
                .iter()
                .any(|l| l["input"] == "answer" && l["id"] == id)
            {
                return;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        panic!("the replica never played answer #{id}\n{}", m.stderr());
    };
    heard(&a, second);
    say("the replica played the late answer");

    // 3. Wrongly signed: a mirror with another key answers the third.
    let (a_out, a_err) = a.stop();
    let mut b = mirror(&other, "mirror-b.mcap");
    let third = shown(&b, &[]);
    say(&format!("question #{third} shown by the other mirror"));
    assert!(third > second, "{third}");
    b.type_line(&format!("{third} yes"));
    sent(&b, third, "yes");
    say("answered with the other key");
    std::thread::sleep(Duration::from_millis(500));
    let (b_out, b_err) = b.stop();

    // 4. Replayed and unsigned: the first answer's frame sent again as it
    // was, and without its signature, from the ground's port.
    let answers = answer_frames(&router.traffic().from_ground);
    assert_eq!(answers.len(), 3, "three answers went up");
    let replayed = answers[0].clone();
    let bare = unsigned(&replayed);
    {
        let mut ground = std::net::TcpStream::connect(("127.0.0.1", router.ground_port))
            .expect("the ground's port");
        ground.write_all(&replayed).expect("sent");
        ground.write_all(&bare).expect("sent");
        std::thread::sleep(Duration::from_millis(700));
    }
    std::thread::sleep(Duration::from_millis(300));
    let (run_out, run_err) = run.stop();
    sim.stop();
    let _ = std::fs::write(dir.join("run.jsonl"), run_out.join("\n"));
    let _ = std::fs::write(dir.join("run.err"), &run_err);
    let _ = std::fs::write(dir.join("mirror-a.jsonl"), a_out.join("\n"));
    let _ = std::fs::write(dir.join("mirror-a.err"), &a_err);
    let _ = std::fs::write(dir.join("mirror-b.err"), &b_err);
    let _ = std::fs::write(dir.join("mirror-b.jsonl"), b_out.join("\n"));

    // Counted by run, each by its reason.
    let counts = run_err
        .lines()
        .find(|l| l.starts_with("operator answers: "))
        .unwrap_or_else(|| panic!("run did not count the answers\n{run_err}"));
    assert_eq!(
        counts,
        "operator answers: 1 delivered, rejected: 1 unsigned, 1 bad signature, 1 replayed, 1 late",
        "\n{run_err}"
    );

    // On board: the first answered (Q.yes fired), the second refused after
    // its timeout; nothing delivered for the third (it times out).
    let run_lines = flight::timeline(&run_out.join("\n"));
    let effect = |kind: &str, id: u64| {
        run_lines
            .iter()
            .find(|l| l["effect"] == kind && l["id"] == id)
            .cloned()
    };
    let answered = effect("answered", first).expect("the first answer delivered");
    assert_eq!(answered["choice"], "yes");
    assert!(run_lines
        .iter()
        .any(|l| l["effect"] == "fired" && l["net"] == "Q" && l["transition"] == "yes"));
    assert!(
        effect("unanswered", second).is_some(),
        "the second timed out"
    );
    let refused = effect("answer_refused", second).expect("the late answer refused");
    assert_eq!(refused["reason"], "not pending", "{refused}");
    assert!(effect("answered", third).is_none());
    assert!(effect("answered", second).is_none());

    // The vehicle's recording: the two answers that reached the player,
    // with their steps.
    let bytes = std::fs::read(&run_record).expect("run's recording");
    let mut steps = std::collections::BTreeMap::new();
    for m in mcap::MessageStream::new(&bytes).expect("MCAP") {
        let m = m.expect("message");
        if m.channel.topic == "/petrel/inputs" {
            let v: serde_json::Value = serde_json::from_slice(&m.data).expect("JSON");
            if v["input"] == "answer" {
                steps.insert(
                    v["id"].as_u64().expect("id"),
                    (v["seq"].clone(), v["choice"].clone()),
                );
            }
        }
    }
    assert_eq!(steps.len(), 2, "{steps:?}");
    // The replica saw each at the same step, with the same verdict.
    let mirror_lines = flight::timeline(&a_out.join("\n"));
    for (id, choice) in [(first, "yes"), (second, "no")] {
        let (seq, recorded) = &steps[&id];
        assert_eq!(recorded, choice);
        let seen = mirror_lines
            .iter()
            .find(|l| l["input"] == "answer" && l["id"] == id)
            .unwrap_or_else(|| panic!("the replica did not see answer #{id}\n{a_err}"));
        assert_eq!(&seen["vehicle_step"], seq, "{seen}");
        assert_eq!(seen["choice"], choice);
    }
    let replica_effect = |kind: &str, id: u64| {
        mirror_lines
            .iter()
            .find(|l| l["effect"] == kind && l["id"] == id)
            .cloned()
    };
    assert_eq!(
        replica_effect("answered", first).map(|l| l["t"].clone()),
        Some(answered["t"].clone())
    );
    assert_eq!(
        replica_effect("answer_refused", second).map(|l| l["t"].clone()),
        Some(refused["t"].clone())
    );
    assert!(
        mirror_lines
            .iter()
            .all(|l| l["mirror"] != "mirror_diverged"),
        "{a_err}"
    );
    // And the mirror's recording replays across the dialog.
    let check = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .arg("replay")
        .arg(dir.join("mirror-a.mcap"))
        .arg(&project)
        .arg("--check-against")
        .output()
        .expect("petrel replay runs");
    assert!(
        check.status.success(),
        "{}",
        String::from_utf8_lossy(&check.stderr)
    );
    drop(router);
}
