//! `petrel mirror` as the end-to-end tests start it: on `project`, over
//! `mavlink`, recording to `recording`, its clock `time_scale` times the
//! wall, stopping after `duration`, its timeline as JSON lines; stdout and
//! stderr piped.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

pub fn petrel_mirror(
    project: &Path,
    mavlink: &str,
    recording: &Path,
    time_scale: f64,
    duration: Duration,
    extra: &[&str],
) -> Child {
    Command::new(env!("CARGO_BIN_EXE_petrel"))
        .arg("mirror")
        .arg(project)
        .arg("--record")
        .arg(recording)
        .args(["--mavlink", mavlink])
        .args(["--time-scale", &time_scale.to_string()])
        .args(["--duration", &format!("{:.0}", duration.as_secs_f64())])
        .arg("--json")
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("petrel mirror runs")
}
