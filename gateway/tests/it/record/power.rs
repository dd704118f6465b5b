//! A recorder killed with SIGKILL mid-flight (as a power loss would stop
//! it) leaves a file readable up to its last complete chunk, and that
//! prefix replays exactly.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use super::files::check;
use super::flight;
use super::record::read;
use super::record::recorder::{Options, Recorder};
use super::scratch::Scratch;

const CHILD: &str = "PETREL_RECORD_UNTIL_KILLED";

/// In the child: records the flight at 20 times its pace (about 9 s), then
/// waits to be killed, never finishing the file.
fn record_until_killed(path: &str) -> ! {
    let tlog = flight::tlog().expect("the parent found ../shared");
    let recorder =
        Recorder::create(path.as_ref(), flight::project(), Options::default()).expect("recorder");
    flight::fly(&tlog, &recorder, usize::MAX, Some(20.0));
    loop {
        std::thread::sleep(Duration::from_secs(1));
    }
}

#[test]
fn a_recorder_killed_mid_flight_leaves_a_readable_file() {
    if let Ok(path) = std::env::var(CHILD) {
        record_until_killed(&path);
    }
    if flight::shared().is_none() {
        return;
    }
    let dir = Scratch::new("record-killed");
    let path = dir.join("killed.mcap");
    let name = module_path!()
        .split_once("::")
        .map(|(_, m)| format!("{m}::a_recorder_killed_mid_flight_leaves_a_readable_file"))
        .expect("a module path");
    let mut child = Command::new(std::env::current_exe().expect("this test binary"))
        .args([name.as_str(), "--exact", "--nocapture", "--test-threads=1"])
        .env(CHILD, &path)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("child recorder");
    // Wait until two seconds' worth of chunks can be read, then kill.
    let give_up = Instant::now() + Duration::from_secs(60);
    let mut readable = 0;
    while readable < 2 && Instant::now() < give_up {
        std::thread::sleep(Duration::from_millis(200));
        let bytes = std::fs::read(&path).unwrap_or_default();
        if let Ok(rec) = read::read(&bytes, false) {
            let seconds = rec.inputs.last().map_or(0, |i| i.1 - rec.inputs[0].1) / 1_000_000;
            readable = seconds / 20;
        }
    }
    child.kill().expect("SIGKILL");
    let status = child.wait().expect("child ends");
    assert!(readable >= 2, "the child recorded nothing readable in 60 s");
    assert!(!status.success());
    let bytes = std::fs::read(&path).expect("the recording");
    let rec = read::read(&bytes, true).expect("a killed recording stays readable");
    assert!(!rec.finished, "killed before finishing");
    assert!(rec.inputs.len() > 100, "{}", rec.inputs.len());
    let (code, _, err) = check(&path, &[]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("match the recording"), "{err}");
}
