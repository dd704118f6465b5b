//! A new version of the project taken in flight by the real `petrel run`
//! (issue 38): `petrel reload` tells it, the run loads and checks the
//! version, proves it from the running state and swaps at a step
//! boundary; a version that does not load or may not take over is refused
//! while the running one goes on; the recording replays the swap exactly.

use std::path::Path;
use std::time::Duration;

use crate::scratch::Scratch;

fn petrel() -> tokio::process::Command {
    let mut c = tokio::process::Command::new(env!("CARGO_BIN_EXE_petrel"));
    c.current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."));
    c.kill_on_drop(true);
    c
}

/// Busy while the copter is in GUIDED, idle in STABILIZE.
const V0: &str = r#"name = "N"
places = ["idle", "busy"]
initial = ["idle"]
[[transition]]
name = "tick"
from = ["idle"]
to = ["busy"]
on = "mode_changed"
when = 'mode == "GUIDED"'
[[transition]]
name = "tock"
from = ["busy"]
to = ["idle"]
on = "mode_changed"
when = 'mode == "STABILIZE"'
"#;

async fn reload(args: &[&str]) -> std::process::Output {
    tokio::time::timeout(
        Duration::from_secs(20),
        petrel().arg("reload").args(args).output(),
    )
    .await
    .expect("petrel reload returns")
    .expect("petrel runs")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_new_version_takes_over_in_flight_and_a_bad_one_is_refused() {
    let dir = Scratch::new("reload");
    let net = dir.join("n.toml");
    std::fs::write(
        dir.join("project.toml"),
        "[[net]]\nfile = \"n.toml\"\nactive = true\n",
    )
    .expect("write");
    std::fs::write(&net, V0).expect("write");
    let recording = dir.join("flight.mcap");
    let port = std::net::UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .expect("a free port")
        .port();
    let _vehicle = crate::run::flipping_copter(port).await;
    let project = dir.to_str().expect("utf-8").to_owned();
    let run = petrel()
        .args([
            "run",
            &project,
            "--mavlink",
            &format!("udpin:127.0.0.1:{port}"),
            "--duration",
            "7",
            "--json",
            "--record",
            recording.to_str().expect("utf-8"),
        ])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("petrel run starts");
    let pid = run.id().expect("a pid").to_string();

    // Version 1: the same places, its transitions renamed.
    tokio::time::sleep(Duration::from_millis(1500)).await;
    std::fs::write(&net, V0.replace("tick", "rise").replace("tock", "fall")).expect("write");
    let told = reload(&[&project]).await;
    assert_eq!(told.status.code(), Some(0), "{told:?}");
    // A version that does not load: nothing is sent, the run goes on.
    tokio::time::sleep(Duration::from_millis(1500)).await;
    std::fs::write(&net, "name = \"N\"\nplaces = [\"idle\"\n").expect("write");
    let broken = reload(&[&project]).await;
    assert_eq!(broken.status.code(), Some(2), "{broken:?}");
    let said = String::from_utf8_lossy(&broken.stderr);
    assert!(
        said.contains("n.toml:2:") && said.contains("nothing sent"),
        "{said}"
    );
    // Version 2: the places the vehicle is in are gone.
    std::fs::write(
        &net,
        V0.replace("\"idle\"", "\"resting\"")
            .replace("\"busy\"", "\"working\""),
    )
    .expect("write");
    let refused = reload(&[&project, "--pid", &pid]).await;
    assert_eq!(refused.status.code(), Some(0), "{refused:?}");

    let out = tokio::time::timeout(Duration::from_secs(30), run.wait_with_output())
        .await
        .expect("petrel run stops by itself")
        .expect("petrel run");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stdout}{stderr}");
    assert!(stderr.contains("version 1 took over at step"), "{stderr}");
    assert!(
        stderr.contains("version 2 refused, the running version goes on")
            && (stderr.contains("place N.idle is marked")
                || stderr.contains("place N.busy is marked")),
        "{stderr}"
    );
    let lines: Vec<serde_json::Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON line"))
        .collect();
    let swap = lines
        .iter()
        .position(|l| l["input"] == "version")
        .expect("the swap in the timeline");
    assert_eq!(lines[swap]["version"], 1);
    let fired = |lines: &[serde_json::Value]| -> Vec<String> {
        lines
            .iter()
            .filter(|l| l["effect"] == "fired")
            .filter_map(|l| l["transition"].as_str().map(str::to_owned))
            .collect()
    };
    let (before, after) = (fired(&lines[..swap]), fired(&lines[swap..]));
    assert!(
        before.len() >= 4 && before.iter().all(|t| t == "tick" || t == "tock"),
        "{before:?}"
    );
    // Version 1 goes on after version 2 is refused: until the end.
    assert!(
        after.len() >= 20 && after.iter().all(|t| t == "rise" || t == "fall"),
        "{after:?}"
    );
    // The marking went on alternating through the swap.
    let pairs: Vec<(&str, &str)> = before
        .iter()
        .chain(&after)
        .map(String::as_str)
        .zip(before.iter().chain(&after).skip(1).map(String::as_str))
        .collect();
    for (a, b) in pairs {
        let busy = |t: &str| t == "tick" || t == "rise";
        assert_ne!(busy(a), busy(b), "{a} then {b}");
    }

    // The version's files are the recording's attachments too.
    let bytes = std::fs::read(&recording).expect("the recording");
    let summary = mcap::Summary::read(&bytes)
        .expect("a summary")
        .expect("the recording is finished");
    let attached: Vec<String> = summary
        .attachment_indexes
        .iter()
        .map(|a| a.name.clone())
        .collect();
    assert_eq!(attached, ["version-1/project.toml", "version-1/n.toml"]);
    // The recording replays the flight, the swap included, from the
    // version's recorded files (the folder holds version 2 by now; the
    // flight started with version 0).
    std::fs::write(&net, V0).expect("write");
    let replay = tokio::time::timeout(
        Duration::from_secs(60),
        petrel()
            .args([
                "replay",
                recording.to_str().expect("utf-8"),
                &project,
                "--check-against",
            ])
            .output(),
    )
    .await
    .expect("replay ends")
    .expect("petrel replay");
    let replayed = String::from_utf8_lossy(&replay.stdout);
    let said = String::from_utf8_lossy(&replay.stderr);
    assert_eq!(replay.status.code(), Some(0), "{replayed}{said}");
    assert!(replayed.contains("VERSION 1 takes over"), "{replayed}");
    assert!(said.contains("match the recording"), "{said}");
}

/// Version 1 with COMMUNICATION's place `returning` renamed, no
/// `[reload]` mapping: refused once the vehicle is in it.
fn without_returning(scratch: &Scratch) -> std::path::PathBuf {
    let dir = version_one(scratch);
    let renamed = scratch.join("version-2");
    std::fs::create_dir_all(&renamed).expect("a folder");
    for entry in std::fs::read_dir(&dir).expect("version 1") {
        let path = entry.expect("an entry").path();
        std::fs::copy(&path, renamed.join(path.file_name().expect("a name"))).expect("copied");
    }
    let net = renamed.join("communication.toml");
    let text = std::fs::read_to_string(&net).expect("the net");
    std::fs::write(&net, text.replace("\"returning\"", "\"homeward\"")).expect("write");
    renamed
}

/// A copy of the flight-test example with COMMUNICATION's version 1.
pub(crate) fn version_one(scratch: &Scratch) -> std::path::PathBuf {
    let dir = crate::flight::example_copy(&scratch.join("version-1"));
    std::fs::write(
        dir.join("communication.toml"),
        crate::flight::returning_after_a_link_hole(&crate::flight::project()),
    )
    .expect("write");
    dir
}

/// Issue 38's flight: mid-flight, COMMUNICATION's reaction to a link hole
/// changes from "proceed" to "return"; the later 10 s link hole gets the
/// new reaction, and the recording replays the swap exactly.
#[test]
fn a_link_hole_after_the_swap_gets_the_new_reaction() {
    use crate::simulated::{fly_with, Offer, Setup};
    let scratch = Scratch::new("reload-simulated");
    let setup = Setup {
        faults: &["link_loss@wp3:10s"],
        version: Some(Offer {
            at_s: 30.0,
            dir: version_one(&scratch),
            proof_s: 1.5,
            ground_at_s: None,
        }),
        ..Setup::default()
    };
    let m = fly_with("reload", setup, 400.0, |s| s.landed && !s.armed);
    let f = &m.flown;
    let reports: Vec<String> = m.versions.iter().map(|(_, r)| r.to_string()).collect();
    let swapped_at = m.versions.iter().find_map(|(t, r)| {
        matches!(r, petrel_core::version::Report::Swapped { number: 1, .. }).then_some(*t)
    });
    let swapped_at = swapped_at.unwrap_or_else(|| panic!("{reports:#?}"));
    // Offered at 30 s, answered 1.5 s later (or later again if the state
    // moved meanwhile).
    assert!(
        (31_500_000..45_000_000).contains(&swapped_at),
        "{swapped_at} µs: {reports:#?}"
    );
    let swap = f
        .timeline
        .iter()
        .position(|l| l["input"] == "version")
        .expect("the swap in the timeline");
    let verbs_after: Vec<&str> = f.timeline[swap..]
        .iter()
        .filter(|l| l["effect"] == "command")
        .filter_map(|l| l["verb"].as_str())
        .collect();
    assert!(verbs_after.contains(&"rtl"), "{verbs_after:?}");
    assert!(
        !f.timeline[..swap]
            .iter()
            .any(|l| l["effect"] == "command" && l["verb"] == "rtl"),
        "no return before the swap"
    );
    // ArduPlane's RTL with RTL_AUTOLAND = 2 (the example's parameter)
    // flies the landing sequence at once: the operations area's items
    // after the hole (5 to 8) are never flown, and it lands. Version 0
    // flies them all through the same hole (`mirror_simulated`'s
    // `link_loss_and_radio_bursts…`, scenarios' link loss).
    let reached: Vec<u16> = f.state.reached.iter().map(|r| r.seq).collect();
    assert!(
        reached.contains(&9) && !reached.iter().any(|s| (5..=8).contains(s)),
        "{reached:?}"
    );
    assert!(f.state.landed, "{:?}", f.state);
    // The same hole without the new version: the mission goes on.
    let same = Setup {
        faults: &["link_loss@wp3:10s"],
        ..Setup::default()
    };
    let v0 = fly_with("no-reload", same, 400.0, |s| s.landed && !s.armed);
    let reached: Vec<u16> = v0.flown.state.reached.iter().map(|r| r.seq).collect();
    assert!((5..=8).all(|s| reached.contains(&s)), "{reached:?}");
    assert!(!v0.flown.verbs().contains(&"rtl".to_owned()));
    let (code, stderr) = f.replay_check();
    assert_eq!(code, Some(0), "{stderr}");
    assert!(stderr.contains("match the recording"), "{stderr}");
}

/// The ground mirror follows the vehicle onto the new version: given it
/// before the swap (its folder read again), its replica takes it over at
/// the same step and stays exact; given it only later, it says which
/// version it lacks, waits, and resyncs from a snapshot of that version.
#[test]
fn the_mirror_follows_the_swap_when_it_has_the_version() {
    use crate::simulated::{fly_with, Offer, Radio, Setup};
    use petrel_core::mirror::replica::{Repair, Report};
    use petrel_core::mirror::station::Output;
    let scratch = Scratch::new("reload-mirror");
    for (ground_at_s, name) in [(Some(20.0), "known"), (Some(60.0), "late")] {
        let setup = Setup {
            faults: &["link_loss@wp3:10s"],
            radio: Some(Radio::default()),
            version: Some(Offer {
                at_s: 30.0,
                dir: version_one(&scratch),
                proof_s: 1.5,
                ground_at_s,
            }),
            ..Setup::default()
        };
        let m = fly_with(name, setup, 400.0, |s| s.landed && !s.armed);
        let reports: Vec<(u64, &Report)> = m
            .outputs
            .iter()
            .filter_map(|(t, o)| match o {
                Output::Report(r) => Some((*t, r)),
                _ => None,
            })
            .collect();
        let swapped = reports
            .iter()
            .position(|(_, r)| matches!(r, Report::Version { number: 1, .. }));
        let unknown = reports
            .iter()
            .position(|(_, r)| matches!(r, Report::UnknownVersion { number: 1, .. }));
        let diverged = reports
            .iter()
            .filter(|(_, r)| matches!(r, Report::Diverged { .. }))
            .count();
        let summary: Vec<String> = reports
            .iter()
            .filter(|(_, r)| {
                !matches!(
                    r,
                    Report::Step { .. } | Report::Agreed { .. } | Report::Timers { .. }
                )
            })
            .map(|(t, r)| format!("{t}: {r:?}").chars().take(160).collect())
            .collect();
        if name == "known" {
            assert!(swapped.is_some() && unknown.is_none(), "{summary:#?}");
            assert_eq!(diverged, 0, "{summary:#?}");
        } else {
            let unknown = unknown.unwrap_or_else(|| panic!("{summary:#?}"));
            assert!(swapped.is_none(), "{summary:#?}");
            assert!(diverged >= 1, "{summary:#?}");
            // Resynced from a snapshot of version 1 once the ground has it.
            let resynced = reports[unknown..].iter().find_map(|(t, r)| match r {
                Report::Resynced {
                    how: Repair::Snapshot,
                    ..
                } => Some(*t),
                _ => None,
            });
            let resynced = resynced.unwrap_or_else(|| panic!("{summary:#?}"));
            assert!(resynced >= 60_000_000, "{summary:#?}");
        }
        // Either way the replica ends exact, on version 1, agreeing.
        let last_agreed = reports
            .iter()
            .rev()
            .find(|(_, r)| matches!(r, Report::Agreed { .. }))
            .map(|(t, _)| *t);
        assert!(last_agreed.is_some_and(|t| t > 80_000_000), "{summary:#?}");
        assert!(
            m.flown.verbs().contains(&"rtl".to_owned()),
            "the vehicle took the new reaction"
        );
    }
}

/// Issue 38's flight with the version sent up from the ground: pushed at
/// 20 s over a radio losing a tenth of the frames both ways, at 600 B/s
/// (about a tenth of a 57,600 baud radio), signed with the operator key;
/// the vehicle takes it over and says so down, the mirror follows it, and
/// the later link hole gets the new reaction.
#[test]
fn a_version_sent_up_from_the_ground_takes_over_and_the_mirror_follows() {
    use crate::simulated::{fly_with, Push, Radio, Setup};
    use petrel_core::mirror::replica::Report;
    use petrel_core::mirror::station::Output;
    use petrel_core::mirror::upload::Sent;
    let scratch = Scratch::new("reload-push");
    let setup = Setup {
        faults: &["link_loss@wp3:10s"],
        radio: Some(Radio {
            per_mille: 100,
            seed: 11,
            ..Radio::default()
        }),
        push: vec![
            Push {
                at_s: 5.0,
                dir: version_one(&scratch),
                bytes_per_s: 600,
                proof_s: 1.0,
            },
            // Then, once the hole sent the vehicle home, one without the
            // place COMMUNICATION is in.
            Push {
                at_s: 50.0,
                dir: without_returning(&scratch),
                bytes_per_s: 600,
                proof_s: 1.0,
            },
        ],
        ..Setup::default()
    };
    let m = fly_with("push", setup, 400.0, |s| s.landed && !s.armed);
    let sent: Vec<(u64, &Sent)> = m
        .outputs
        .iter()
        .filter_map(|(t, o)| match o {
            Output::Upload(s) => Some((*t, s)),
            _ => None,
        })
        .collect();
    let delivered = sent.iter().find_map(|(t, s)| match s {
        Sent::Delivered { bytes, after } => Some((*t, *bytes, *after)),
        _ => None,
    });
    let (_, bytes, after) = delivered.unwrap_or_else(|| panic!("{sent:#?}"));
    let verdicts: Vec<String> = sent
        .iter()
        .filter_map(|(_, s)| match s {
            Sent::Verdict { text } => Some(text.clone()),
            _ => None,
        })
        .collect();
    let [verdict, refused] = &verdicts[..] else {
        panic!("{sent:#?}")
    };
    assert!(
        verdict.starts_with("version 1 took over at step"),
        "{verdict}"
    );
    // The second is refused with its reason, said down whole; the flight
    // goes on with version 1.
    assert!(
        refused.starts_with("version 2 refused")
            && refused.contains("place COMMUNICATION.returning is marked"),
        "{refused}"
    );
    // On the air: the signed frames the ground sent while it pushed.
    let (from, to) = (5_000_000, 5_000_000 + after);
    let frames: Vec<&Vec<u8>> = m
        .uplink
        .iter()
        .filter(|(t, _)| (from..=to).contains(t))
        .map(|(_, b)| b)
        .collect();
    let on_air: usize = frames.iter().map(|b| b.len()).sum();
    println!(
        "pushed the flight-test version over a 10 % lossy radio at 600 B/s: {bytes} bytes of records, {} frames and {on_air} bytes on the air (MAVLink 2, signed), whole after {:.1} s; verdict: {verdict}",
        frames.len(),
        after as f64 / 1e6
    );
    // The version is about 14 kB packed: at 600 B/s, 25 s and the losses'
    // retransmission.
    assert!(after < 60_000_000, "{after}");
    let followed = m
        .outputs
        .iter()
        .any(|(_, o)| matches!(o, Output::Report(Report::Version { number: 1, .. })));
    assert!(followed, "the mirror followed the swap");
    assert!(m.flown.verbs().contains(&"rtl".to_owned()));
    let (code, stderr) = m.flown.replay_check();
    assert_eq!(code, Some(0), "{stderr}");
}
