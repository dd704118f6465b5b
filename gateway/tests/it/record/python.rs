//! The Python `mcap` package, an independent reader, reads a recording:
//! channels, schemas and message counts as expected.
//!
//! CI installs the package after `cargo test --workspace` (its own section
//! of .ci/run) and runs this test again with PETREL_PYTHON_MCAP=required:
//! then a missing package fails; otherwise it skips with the reason.

use std::process::Command;

use serde_json::Value;

use super::files::whole_flight;
use super::flight::root;

#[test]
fn the_python_mcap_reader_reads_a_recording() {
    let required = std::env::var("PETREL_PYTHON_MCAP").as_deref() == Ok("required");
    let probe = Command::new("python3").args(["-c", "import mcap"]).output();
    if !probe.is_ok_and(|o| o.status.success()) {
        assert!(
            !required,
            "the Python mcap package is missing, and PETREL_PYTHON_MCAP=required"
        );
        sitl_tests::skip::skip("python3 with the mcap package is not installed (pip install mcap)");
        return;
    }
    let Some(flown) = whole_flight() else { return };
    let out = Command::new("python3")
        .arg(root().join("gateway/tests/record/read_mcap.py"))
        .arg(&flown.path)
        .output()
        .expect("python3 runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let v: Value = serde_json::from_slice(&out.stdout).expect("JSON from the script");
    let fed = &flown.fed;
    let channels = &v["channels"];
    let count = |topic: &str| channels[topic]["count"].as_u64().unwrap_or(0);
    assert_eq!(count("/petrel/inputs"), fed.steps + 1);
    assert_eq!(count("/petrel/digests"), fed.steps + 1);
    assert_eq!(count("/mavlink/raw"), fed.frames);
    assert_eq!(
        channels["/mavlink/raw"]["message_encoding"],
        "petrel.tlog-record"
    );
    assert_eq!(
        channels["/vehicle/location"]["schema"],
        "foxglove.LocationFix"
    );
    assert_eq!(
        channels["/vehicle/location"]["schema_encoding"],
        "jsonschema"
    );
    assert_eq!(
        channels["/mavlink/1/1/HEARTBEAT"]["schema"],
        "mavlink.HEARTBEAT"
    );
    assert!(count("/mavlink/1/1/HEARTBEAT") > 100);
    // The reader parsed every JSON message and every JSON schema, and its
    // summary's counts agree with what it read.
    assert_eq!(v["json_errors"], 0, "{v}");
    assert_eq!(v["summary_matches"], true, "{v}");
    assert_eq!(v["profile"], "petrel");
    let first = &v["first_input"];
    assert_eq!(first["input"], "start");
    assert_eq!(first["seq"], 0);
}
