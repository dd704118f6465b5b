//! `petrel stubs`: the skeletons, filled in minimally, serve calls.

use std::path::Path;
use std::process::Command;
use std::sync::Arc;

use nets::{Outcome, Params, Value};

use super::programs::server::Programs;
use super::scratch::Scratch;
use super::support::{config, failed, params, Harness};

const DEC_FUNCTIONS: &str = "[programs.DEC.functions]\n\
    next = { returns = [\"lat\", \"lon\"] }\n\
    replan = { args = [\"failed\", \"type\"], returns = [\"waypoints\"] }\n\
    later = {}\n\
    unused = {}\n";

/// Function indices (by name): later, next, replan, unused.
const LATER: usize = 0;
const NEXT: usize = 1;
const REPLAN: usize = 2;

fn project(dir: &Path, dec_settings: &str) -> Arc<nets::Project> {
    let project = format!(
        "name = \"stubs-test\"\n[events]\ngo = {{ params = [\"x\"] }}\n\
         [[net]]\nfile = \"n.toml\"\nactive = true\n{dec_settings}\n{DEC_FUNCTIONS}"
    );
    let net = "name = \"N\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\n\
               [[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"go\"\n\
               do = [\"call DEC.next\", \"call DEC.replan {failed: $x, type: 1}\", \"call DEC.later\"]\n";
    std::fs::write(dir.join("project.toml"), &project).expect("write");
    std::fs::write(dir.join("n.toml"), net).expect("write");
    let files = [("project.toml", project.as_str()), ("n.toml", net)];
    Arc::new(nets::load(&files).expect("loads"))
}

fn petrel(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_petrel"))
        .args(args)
        .output()
        .expect("petrel runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn replace(path: &Path, from: &str, to: &str) {
    let text = std::fs::read_to_string(path).expect("read the skeleton");
    assert!(text.contains(from), "{} lacks {from:?}", path.display());
    std::fs::write(path, text.replacen(from, to, 1)).expect("write");
}

#[test]
fn stubs_verb_writes_skeletons_refuses_to_overwrite_and_rejects_bad_input() {
    let dir = Scratch::new("stubs");
    project(dir.path(), "");
    let p = dir.path().to_str().expect("utf-8 path");
    let out = dir.path().join("out");
    let o = out.to_str().expect("utf-8 path");
    let (code, stdout, stderr) = petrel(&["stubs", p, "--lang", "python", o]);
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(stdout.trim(), out.join("DEC.py").display().to_string());
    let text = std::fs::read_to_string(out.join("DEC.py")).expect("written");
    assert!(text.contains("def replan(failed, type):") && !text.contains("def unused"));
    assert!(text.contains("Called by: N.t."));
    let (code, _, stderr) = petrel(&["stubs", p, "--lang", "python", o]);
    assert_eq!(code, 2);
    assert!(
        stderr.contains("not overwriting") && stderr.contains("--force"),
        "{stderr}"
    );
    let (code, _, stderr) = petrel(&["stubs", p, "--lang", "python", o, "--force"]);
    assert_eq!(code, 0, "{stderr}");
    let (code, stdout, _) = petrel(&["stubs", p, "--lang", "rust", o]);
    assert_eq!(code, 0);
    assert_eq!(stdout.lines().count(), 3, "{stdout}");
    let (code, _, _) = petrel(&["stubs", p, "--lang", "cobol", o]);
    assert_eq!(code, 2);
    let missing = dir.path().join("nowhere");
    let (code, _, stderr) = petrel(&[
        "stubs",
        missing.to_str().expect("utf-8"),
        "--lang",
        "rust",
        o,
    ]);
    assert_eq!(code, 2);
    assert!(stderr.contains("not a Petrel project"), "{stderr}");
}

/// Calls the three functions of DEC through the server and checks the
/// answers of a skeleton filled in as `fill` did.
async fn serve_three_calls(dir: &Path, project: Arc<nets::Project>) {
    let (programs, inputs) = Programs::start(project.clone(), dir, config())
        .await
        .expect("the server starts");
    let mut h = Harness {
        programs,
        inputs,
        traffic: Vec::new(),
        dir: Scratch::new("stubs"),
        project,
    };
    h.programs.call(1, 0, NEXT, Params::new());
    assert_eq!(
        h.outcome(1).await,
        Outcome::Done(params(&[
            ("lat", Value::Float(43.5)),
            ("lon", Value::Int(1))
        ]))
    );
    let args = params(&[
        ("failed", Value::Str("camera".into())),
        ("type", Value::Int(1)),
    ]);
    h.programs.call(2, 0, REPLAN, args);
    assert_eq!(
        h.outcome(2).await,
        Outcome::Done(params(&[("waypoints", Value::Str("camera".into()))]))
    );
    h.programs.call(3, 0, LATER, Params::new());
    assert_eq!(
        h.outcome(3).await,
        failed("DEC.later is not implemented yet")
    );
    h.programs.shutdown().await;
}

#[tokio::test]
async fn a_python_skeleton_filled_in_serves_calls() {
    let dir = Scratch::new("stubs");
    let p = dir.path().to_str().expect("utf-8 path");
    project(dir.path(), "");
    let (code, _, stderr) = petrel(&["stubs", p, "--lang", "python", p]);
    assert_eq!(code, 0, "{stderr}");
    let file = dir.path().join("DEC.py");
    replace(
        &file,
        "raise Failure(\"DEC.next is not implemented yet\")",
        "return {\"lat\": 43.5, \"lon\": 1}",
    );
    replace(
        &file,
        "raise Failure(\"DEC.replan is not implemented yet\")",
        "return {\"waypoints\": failed}",
    );
    let project = project(
        dir.path(),
        "[programs.DEC]\nrun = [\"python3\", \"DEC.py\"]\n",
    );
    serve_three_calls(dir.path(), project).await;
}

#[tokio::test]
async fn a_rust_skeleton_builds_offline_and_filled_in_serves_calls() {
    let ci = std::env::var("CI").is_ok_and(|v| v == "true");
    if Command::new("cargo").arg("--version").output().is_err() {
        assert!(!ci, "cargo is needed in CI to build the Rust skeleton");
        sitl_tests::skip::skip("no cargo on PATH to build the Rust skeleton");
        return;
    }
    let dir = Scratch::new("stubs");
    let p = dir.path().to_str().expect("utf-8 path");
    project(dir.path(), "");
    let (code, _, stderr) = petrel(&["stubs", p, "--lang", "rust", p]);
    assert_eq!(code, 0, "{stderr}");
    let functions = dir.path().join("dec/src/functions.rs");
    replace(
        &functions,
        "Err(\"DEC.next is not implemented yet\".into())",
        "Ok(params(json!({\"lat\": 43.5, \"lon\": 1})))",
    );
    replace(
        &functions,
        "Err(\"DEC.replan is not implemented yet\".into())",
        "Ok(params(json!({\"waypoints\": failed})))",
    );
    // The workspace's target folder keeps serde_json built between runs.
    let target = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/stubs-check");
    let build = Command::new("cargo")
        .args(["build", "--offline", "--quiet"])
        .current_dir(dir.path().join("dec"))
        .env("CARGO_TARGET_DIR", &target)
        .env("RUSTFLAGS", "-D warnings")
        .output()
        .expect("cargo runs");
    let stderr = String::from_utf8_lossy(&build.stderr);
    if !build.status.success() && stderr.contains("offline") && !ci {
        eprintln!("{stderr}");
        sitl_tests::skip::skip(
            "serde_json is not in the offline registry cache (cargo fetch in the skeleton)",
        );
        return;
    }
    assert!(build.status.success(), "the Rust skeleton builds: {stderr}");
    let binary = target.join("debug/dec");
    let run = format!(
        "[programs.DEC]\nrun = [{:?}]\n",
        binary.display().to_string()
    );
    let project = project(dir.path(), &run);
    serve_three_calls(dir.path(), project).await;
}

#[tokio::test]
async fn a_python_skeleton_connecting_by_itself_is_served_refused_and_lost() {
    let dir = Scratch::new("stubs");
    let p = dir.path().to_str().expect("utf-8 path");
    let project = project(dir.path(), "");
    let (code, _, stderr) = petrel(&["stubs", p, "--lang", "python", p]);
    assert_eq!(code, 0, "{stderr}");
    let (programs, inputs) = Programs::start(project.clone(), dir.path(), config())
        .await
        .expect("the server starts");
    let address = programs.address().to_string();
    let mut h = Harness {
        programs,
        inputs,
        traffic: Vec::new(),
        dir: Scratch::new("stubs"),
        project,
    };
    let start = |name: &str| {
        tokio::process::Command::new("python3")
            .arg("DEC.py")
            .current_dir(dir.path())
            .env("PETREL_PROGRAMS", &address)
            .env("PETREL_PROGRAM", name)
            .stderr(std::process::Stdio::piped())
            .kill_on_drop(true)
            .spawn()
            .expect("python3 starts")
    };
    // A wrong name: refused, and the skeleton exits with status 1.
    let refused = tokio::time::timeout(super::support::WAIT, start("NOPE").wait_with_output())
        .await
        .expect("the refused skeleton exits")
        .expect("status");
    assert_eq!(refused.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(stderr.contains("unknown program `NOPE`"), "{stderr}");
    // Its own name: served (the TODO body fails as generated), then lost
    // when it dies.
    let mut child = start("DEC");
    h.connected().await;
    h.programs.call(1, 0, NEXT, Params::new());
    assert_eq!(
        h.outcome(1).await,
        failed("DEC.next is not implemented yet")
    );
    child.start_kill().expect("kill");
    match h.next().await {
        super::programs::server::ProgramInput::Lost { program, .. } => assert_eq!(program, "DEC"),
        other => panic!("expected DEC lost, got {other:?}"),
    }
    let _ = child.wait().await;
    h.programs.call(2, 0, NEXT, Params::new());
    assert_eq!(h.outcome(2).await, failed("not connected"));
    h.programs.shutdown().await;
}
