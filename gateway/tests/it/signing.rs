//! `petrel run` on a signed MAVLink 2 link (`--signing-key`,
//! `--require-signed`), against a vehicle peer whose signing is
//! rust-mavlink's own (`SigningConfig`): what the gateway sends verifies at
//! the peer, what the peer signs is accepted, and unsigned or wrongly
//! signed frames are dropped, counted and raised to the nets.

use crate::scratch;

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use mavlink::dialects::ardupilotmega::*;
use mavlink::{AsyncMavConnection, MavHeader, SigningConfig};
use scratch::Scratch;

const KEY: [u8; 32] = [0x5a; 32];

/// A scratch folder holding a project whose net reacts to a rejected
/// signature.
fn scratch(name: &str) -> Scratch {
    let dir = Scratch::new(&format!("signing-{name}"));
    std::fs::write(
        dir.join("project.toml"),
        "[events]\nsignature_rejected = { category = \"communication\", params = [\"count\", \"reason\", \"system\", \"component\"] }\n[[net]]\nfile = \"n.toml\"\nactive = true\n",
    )
    .expect("write");
    std::fs::write(
        dir.join("n.toml"),
        "name = \"N\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\n[[transition]]\nname = \"intruder\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"signature_rejected\"\n",
    )
    .expect("write");
    dir
}

fn key_file(dir: &Path, key: &[u8; 32], mode: u32) -> PathBuf {
    let path = dir.join("link.key");
    let hex: String = key.iter().map(|b| format!("{b:02x}")).collect();
    std::fs::write(&path, hex).expect("write");
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(mode)).expect("chmod");
    path
}

fn free_port() -> u16 {
    let s = std::net::UdpSocket::bind("127.0.0.1:0").expect("bind");
    s.local_addr().expect("addr").port()
}

/// A copter (system 7) heartbeating every 200 ms at `port`, signing with
/// `key` when given, and keeping what it receives (rust-mavlink drops what
/// fails its own signature check when `require` is set).
async fn vehicle(
    port: u16,
    key: Option<[u8; 32]>,
    require: bool,
) -> (
    Arc<Mutex<Vec<(MavHeader, MavMessage)>>>,
    tokio::task::JoinHandle<()>,
) {
    let mut connection = mavlink::connect_async::<MavMessage>(&format!("udpout:127.0.0.1:{port}"))
        .await
        .expect("peer connects");
    connection.set_protocol_version(mavlink::MavlinkVersion::V2);
    let config = match key {
        Some(k) => SigningConfig::new(k, 9, true, !require),
        // Unsigned sender, but checking what it receives against our key.
        None => SigningConfig::new(KEY, 9, false, !require),
    };
    connection.setup_signing(Some(config));
    let connection = Arc::new(connection);
    let heard = Arc::new(Mutex::new(Vec::new()));
    let reader = connection.clone();
    let log = heard.clone();
    let task = tokio::spawn(async move {
        let hb = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: 0,
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: MavModeFlag::empty(),
            system_status: MavState::MAV_STATE_STANDBY,
            mavlink_version: 3,
        });
        let header = MavHeader {
            system_id: 7,
            component_id: 1,
            sequence: 0,
        };
        let mut beat = tokio::time::interval(Duration::from_millis(200));
        loop {
            tokio::select! {
                _ = beat.tick() => { let _ = connection.send(&header, &hb).await; }
                got = reader.recv() => if let Ok(m) = got { log.lock().expect("log").push(m) },
            }
        }
    });
    (heard, task)
}

async fn petrel(dir: &Path, port: u16, extra: &[&str]) -> (i32, String, String) {
    let mut command = tokio::process::Command::new(env!("CARGO_BIN_EXE_petrel"));
    command
        .args([
            "run",
            dir.to_str().expect("utf-8"),
            "--mavlink",
            &format!("udpin:127.0.0.1:{port}"),
            "--unchecked",
            "--no-record",
            "--json",
            "--duration",
            "6",
        ])
        .args(extra)
        .kill_on_drop(true);
    let out = tokio::time::timeout(Duration::from_secs(30), command.output())
        .await
        .expect("petrel stops by itself")
        .expect("petrel runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn gateway_heartbeats(heard: &Mutex<Vec<(MavHeader, MavMessage)>>) -> Vec<(u32, u8)> {
    heard
        .lock()
        .expect("log")
        .iter()
        .filter(|(_, m)| matches!(m, MavMessage::HEARTBEAT(h) if h.mavtype == MavType::MAV_TYPE_ONBOARD_CONTROLLER))
        .map(|(h, _)| (h.system_id, h.component_id))
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_signed_vehicle_is_heard_and_verifies_everything_the_gateway_sends() {
    let dir = scratch("signed");
    let key = key_file(&dir, &KEY, 0o600);
    let port = free_port();
    let (heard, task) = vehicle(port, Some(KEY), true).await;
    let (code, out, err) = petrel(
        &dir,
        port,
        &[
            "--signing-key",
            key.to_str().expect("utf-8"),
            "--require-signed",
        ],
    )
    .await;
    task.abort();
    assert_eq!(code, 0, "{out}{err}");
    // The peer accepts only frames signed with the key: it heard the
    // gateway, and the gateway adopted the vehicle's system id, so it
    // accepted the vehicle's signed frames.
    let beats = gateway_heartbeats(&heard);
    assert!(beats.contains(&(7, 191)), "{beats:?}\n{err}");
    assert!(!err.contains("frames rejected"), "{err}");
    assert!(!out.contains("signature_rejected"), "{out}");
    // The timestamp persisted, later than the start of 2026.
    let ts: u64 = std::fs::read_to_string(dir.join("link.key.timestamp"))
        .expect("timestamp persisted")
        .trim()
        .parse()
        .expect("a number");
    assert!(ts > (1_767_225_600 - 1_420_070_400) * 100_000, "{ts}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn unsigned_and_wrongly_signed_vehicles_are_rejected_counted_and_raised() {
    for (name, peer_key, reason) in [
        ("unsigned", None, "unsigned"),
        ("stranger", Some([0x11u8; 32]), "bad signature"),
    ] {
        let dir = scratch(name);
        let key = key_file(&dir, &KEY, 0o600);
        let port = free_port();
        let (heard, task) = vehicle(port, peer_key, false).await;
        let (code, out, err) = petrel(
            &dir,
            port,
            &[
                "--signing-key",
                key.to_str().expect("utf-8"),
                "--require-signed",
            ],
        )
        .await;
        task.abort();
        assert_eq!(code, 0, "{name}: {out}{err}");
        let beats = gateway_heartbeats(&heard);
        if peer_key.is_none() {
            // Never adopted: it still announces under the default system id
            // (the unsigned peer checks our signatures with the right key).
            assert!(
                !beats.is_empty() && beats.iter().all(|b| *b == (1, 191)),
                "{name}: {beats:?}"
            );
        } else {
            // The stranger's key does not verify what the gateway signs.
            assert!(beats.is_empty(), "{name}: {beats:?}");
        }
        assert!(
            err.contains("frames rejected") && err.contains(reason),
            "{name}: {err}"
        );
        let lines: Vec<serde_json::Value> = out
            .lines()
            .filter_map(|l| serde_json::from_str(l).ok())
            .collect();
        let event = lines
            .iter()
            .find(|l| l["event"] == "signature_rejected")
            .unwrap_or_else(|| panic!("{name}: no signature_rejected event:\n{out}"));
        assert_eq!(event["params"]["reason"], reason, "{name}");
        assert_eq!(event["params"]["system"], 7, "{name}");
        assert!(event["params"]["count"].as_i64().is_some_and(|c| c >= 1));
        assert!(
            lines
                .iter()
                .any(|l| l["effect"] == "fired" && l["transition"] == "intruder"),
            "{name}: the net reacted:\n{out}"
        );
    }
}

#[tokio::test]
async fn a_key_others_may_read_is_refused() {
    let dir = scratch("readable");
    let key = key_file(&dir, &KEY, 0o644);
    let port = free_port();
    let (code, _, err) = petrel(&dir, port, &["--signing-key", key.to_str().expect("utf-8")]).await;
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("chmod 600"), "{err}");
    let (code, _, err) = petrel(&dir, port, &["--require-signed"]).await;
    assert_eq!(code, 2, "--require-signed needs a key: {err}");
}
