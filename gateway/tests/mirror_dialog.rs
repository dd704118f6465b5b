//! The operator dialog's key on both sides: `petrel run --operator-key` and
//! `petrel mirror --operator-key` refuse a key others may read, naming the
//! fix, before opening any link. (The dialog itself — signed answers judged
//! on board, the replica equal across it — is tested sans-IO in
//! `gateway/src/mirror/dialog/tests.rs`.)

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("petrel-dialog-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
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
    let _ = std::fs::remove_dir_all(&dir);
}
