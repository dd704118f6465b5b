//! `petrel run` on a signed MAVLink 2 link (`--signing-key`,
//! `--require-signed`), against a vehicle peer whose signing is
//! rust-mavlink's own (`SigningConfig`): what the gateway sends verifies at
//! the peer, what the peer signs is accepted, and unsigned or wrongly
//! signed frames are dropped, counted and raised to the nets.

use crate::scratch;

use std::path::{Path, PathBuf};
use std::time::Duration;

use mavlink::dialects::ardupilotmega::*;
use mavlink::MavHeader;
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

/// The same key on ArduPilot's own firmware: after SETUP_SIGNING (sent on
/// SERIAL0, the channel ArduPilot always trusts), ArduCopter SITL signs
/// what it sends and rejects unsigned frames on its other ports. The
/// gateway on SERIAL1 with the key commands a mode change and ArduPilot
/// accepts it; without the key, ArduPilot never answers the same command.
#[test]
fn against_ardupilot_sitl_after_setup_signing() {
    // A turn to fly (real/main.rs: at most two flights at once, each on
    // instances of its own).
    let turn = crate::sitl_turn();
    use sitl_tests::ardupilot::{self, Firmware, Options, Sitl};
    use std::io::{Read, Write};
    let test = "against_ardupilot_sitl_after_setup_signing";
    let Some(copter) = ardupilot::require(Firmware::Copter, test) else {
        return;
    };
    let scratch = scratch("sitl");
    // The net asks for LOITER once the parameters are read, and records
    // ArduPilot's answer.
    std::fs::write(
        scratch.join("n.toml"),
        "name = \"N\"\nplaces = [\"a\", \"asked\", \"accepted\", \"refused\"]\ninitial = [\"a\"]\n\
         [[transition]]\nname = \"ask\"\nfrom = [\"a\"]\nto = [\"asked\"]\ndo = [\"command mode {mode: \\\"LOITER\\\"}\"]\n\
         [[transition]]\nname = \"accepted\"\nfrom = [\"asked\"]\nto = [\"accepted\"]\non = \"command.ok\"\n\
         [[transition]]\nname = \"refused\"\nfrom = [\"asked\"]\nto = [\"refused\"]\non = \"command.failed\"\n",
    )
    .expect("write");
    let key = key_file(&scratch, &KEY, 0o600);
    let options = Options {
        instance: turn.instance(11),
        speedup: 1,
        ..Options::default()
    };
    let sitl = Sitl::start(&copter, &options, &scratch.join("sitl")).expect("SITL starts");
    // SERIAL0: start the simulation, hand ArduPilot the key, keep draining.
    let mut serial0 =
        ardupilot::connect(sitl.port(0), Duration::from_secs(20)).expect("SERIAL0 connects");
    let now_us = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .expect("clock")
        .as_micros() as u64;
    let setup = MavMessage::SETUP_SIGNING(SETUP_SIGNING_DATA {
        initial_timestamp: (now_us - 1_420_070_400_000_000) / 10,
        target_system: 1,
        target_component: 1,
        secret_key: KEY,
    });
    let header = MavHeader {
        system_id: 255,
        component_id: 190,
        sequence: 0,
    };
    let mut frame = Vec::new();
    mavlink::write_v2_msg(&mut frame, header, &setup).expect("encode");
    serial0.write_all(&frame).expect("SETUP_SIGNING sent");
    let mut drain = serial0.try_clone().expect("clone");
    let drainer = std::thread::spawn(move || {
        let mut buf = [0u8; 4096];
        while matches!(drain.read(&mut buf), Ok(n) if n > 0) {}
    });
    std::thread::sleep(Duration::from_secs(2));
    let runtime = tokio::runtime::Runtime::new().expect("runtime");
    let fly = |extra: &[&str]| {
        let address = format!("tcpout:127.0.0.1:{}", sitl.port(1));
        let mut args = vec![
            "run",
            scratch.to_str().expect("utf-8"),
            "--mavlink",
            &address,
            "--unchecked",
            "--no-record",
            "--json",
            "--duration",
            "10",
        ];
        args.extend_from_slice(extra);
        runtime.block_on(async {
            let mut command = tokio::process::Command::new(env!("CARGO_BIN_EXE_petrel"));
            command.args(&args).kill_on_drop(true);
            let out = tokio::time::timeout(Duration::from_secs(60), command.output())
                .await
                .expect("petrel stops by itself")
                .expect("petrel runs");
            (
                String::from_utf8_lossy(&out.stdout).into_owned(),
                String::from_utf8_lossy(&out.stderr).into_owned(),
            )
        })
    };
    let fired = |out: &str, t: &str| {
        out.lines()
            .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
            .any(|l| l["effect"] == "fired" && l["transition"] == t)
    };
    let key_arg = key.to_str().expect("utf-8");
    let (signed_out, signed_err) = fly(&["--signing-key", key_arg, "--require-signed"]);
    let (plain_out, plain_err) = fly(&[]);
    let _ = serial0.shutdown(std::net::Shutdown::Both);
    let _ = drainer.join();
    drop(sitl);
    assert!(
        fired(&signed_out, "accepted"),
        "signed: ArduPilot accepted the mode change\n{signed_out}\n{signed_err}"
    );
    assert!(
        !signed_err.contains("frames rejected"),
        "ArduPilot signs everything it sends: {signed_err}"
    );
    assert!(
        !fired(&plain_out, "accepted"),
        "unsigned: ArduPilot must not accept\n{plain_out}\n{plain_err}"
    );
}
