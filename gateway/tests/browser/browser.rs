//! The browser tests' tools (tests/monitor.rs, tests/monitor_mirror.rs,
//! tests/monitor_team.rs, tests/edit.rs): node, playwright-core and Debian's
//! chromium found or the test skipped (failed under `CI=true`),
//! `monitor/driver.js` run, the screenshots' folder, the page's lists read.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value as Json;

/// Where the browser tests leave their screenshots: `target/tmp/monitor/`.
pub fn shots() -> PathBuf {
    let shots = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("monitor");
    std::fs::create_dir_all(&shots).unwrap_or_else(|e| panic!("{}: {e}", shots.display()));
    shots
}

/// The strings of a JSON array the page reported (none if it is not one).
pub fn strings(v: &Json) -> Vec<String> {
    v.as_array()
        .map(|a| {
            a.iter()
                .filter_map(|s| s.as_str().map(str::to_owned))
                .collect()
        })
        .unwrap_or_default()
}

pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A child killed and waited for when dropped, whatever happened.
pub struct Reaped(pub Child);

impl Drop for Reaped {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// node, playwright-core's folder and chromium, or why not.
fn browser_tools() -> Result<(PathBuf, PathBuf, PathBuf), String> {
    let chromium = PathBuf::from(std::env::var("CHROMIUM").unwrap_or("/usr/bin/chromium".into()));
    if !chromium.exists() {
        return Err(format!("no chromium at {}", chromium.display()));
    }
    let node = Command::new("node").arg("--version").output();
    if !node.is_ok_and(|o| o.status.success()) {
        return Err("no node on PATH".into());
    }
    let core = std::env::var("PETREL_PLAYWRIGHT_CORE")
        .map(PathBuf::from)
        .unwrap_or_else(|_| repo().join("target/browser-tools/node_modules/playwright-core"));
    if !core.join("package.json").exists() {
        return Err(format!(
            "no playwright-core at {} (npm install --prefix target/browser-tools playwright-core)",
            core.display()
        ));
    }
    Ok((PathBuf::from("node"), core, chromium))
}

/// Skips (returns None) with the reason, or fails under CI.
pub fn require() -> Option<(PathBuf, PathBuf, PathBuf)> {
    match browser_tools() {
        Ok(t) => Some(t),
        Err(why) if std::env::var("CI").as_deref() == Ok("true") => {
            panic!("CI=true but the browser tests cannot run: {why}")
        }
        Err(why) => {
            sitl_tests::skip::skip(&why);
            None
        }
    }
}

/// Runs the monitor's driver; its JSON.
pub fn drive(tools: &(PathBuf, PathBuf, PathBuf), args: &[&str], env: &[(&str, &str)]) -> Json {
    drive_script(
        tools,
        "gateway/tests/monitor/driver.js",
        args,
        env,
        Duration::from_secs(400),
    )
}

/// Runs a driver script (a path from the repository's root) for at most
/// `limit`; its JSON, which must report no failure and no page error.
pub fn drive_script(
    tools: &(PathBuf, PathBuf, PathBuf),
    script: &str,
    args: &[&str],
    env: &[(&str, &str)],
    limit: Duration,
) -> Json {
    let (node, core, chromium) = tools;
    let mut cmd = Command::new(node);
    cmd.arg(repo().join(script))
        .args(args)
        .env("PLAYWRIGHT_CORE", core)
        .env("CHROMIUM", chromium)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit());
    for (k, v) in env {
        cmd.env(k, v);
    }
    let child = cmd
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start node: {e}"));
    let mut child = Reaped(child);
    // Bounded: the driver's own waits add up to well under this.
    let until = Instant::now() + limit;
    loop {
        if let Ok(Some(_)) = child.0.try_wait() {
            break;
        }
        assert!(Instant::now() < until, "the browser driver hung");
        std::thread::sleep(Duration::from_millis(100));
    }
    let mut out = String::new();
    if let Some(mut s) = child.0.stdout.take() {
        use std::io::Read;
        let _ = s.read_to_string(&mut out);
    }
    let seen: Json = serde_json::from_str(out.trim())
        .unwrap_or_else(|e| panic!("the driver printed no JSON ({e}): {out}"));
    assert!(
        seen["failure"].is_null(),
        "in the browser: {}",
        seen["failure"]
    );
    assert_eq!(seen["errors"], serde_json::json!([]), "the page threw");
    seen
}

/// Issue 40: every net's labels render at 8 px or more at the page's
/// default size, and each active net's marked places are in its card's
/// view (a long net scrolls and follows its marking).
pub fn assert_readable(seen: &Json) {
    let nets = seen["readable"].as_array().cloned().unwrap_or_default();
    assert!(!nets.is_empty(), "no nets measured: {seen}");
    for n in &nets {
        let px = n["px"].as_f64().unwrap_or(0.0);
        assert!(
            px >= 8.0,
            "net {} drawn with {px:.1} px labels: {nets:?}",
            n["net"]
        );
        assert_eq!(
            n["out"].as_array().map(Vec::len),
            Some(0),
            "net {}: marked places out of view: {nets:?}",
            n["net"]
        );
    }
}

/// Copies the flight-test example's files (not its folders) into `to`.
pub fn copy_example(to: &Path) {
    let example = repo().join("examples/uav-flight-test");
    for entry in std::fs::read_dir(example).unwrap_or_else(|e| panic!("{e}")) {
        let entry = entry.unwrap_or_else(|e| panic!("{e}"));
        if entry.path().is_file() {
            std::fs::copy(entry.path(), to.join(entry.file_name()))
                .unwrap_or_else(|e| panic!("{e}"));
        }
    }
}
