//! A new version of the project taken in flight by the real `petrel run`
//! (issue 38): `petrel reload` tells it, the run loads and checks the
//! version, proves it from the running state and swaps at a step
//! boundary; a version that does not load or may not take over is refused
//! while the running one goes on; the recording replays the swap exactly.

use std::path::Path;
use std::time::Duration;

use crate::peer;
use crate::scratch::Scratch;
use mavlink::dialects::ardupilotmega::*;

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

/// A scripted ArduCopter on UDP that flips between STABILIZE and GUIDED
/// every 100 ms.
async fn flipping_copter(port: u16) -> peer::Peer {
    let hb = peer::heartbeat(
        MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        MavType::MAV_TYPE_QUADROTOR,
    );
    let mut guided = hb.clone();
    if let MavMessage::HEARTBEAT(h) = &mut guided {
        h.custom_mode = 4;
    }
    let script: peer::Script = Box::new(|_, m| match peer::command_of(m) {
        Some(c) => vec![peer::now(peer::ack(c, MavResult::MAV_RESULT_ACCEPTED))],
        None => Vec::new(),
    });
    peer::Peer::start(
        &format!("udpout:127.0.0.1:{port}"),
        hb,
        vec![guided],
        script,
    )
    .await
}

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
    let _vehicle = flipping_copter(port).await;
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
    assert!(
        stderr.contains("reload: version 1 took over at step"),
        "{stderr}"
    );
    assert!(
        stderr.contains("reload: version 2 refused, the running version goes on")
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
