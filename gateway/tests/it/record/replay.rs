//! `petrel replay FILE.mcap --check-against` on faithful, tampered and cut
//! recordings.

use std::collections::BTreeMap;

use serde_json::{json, Value};

use super::files::{check, chunky_flight, rewrite, whole_flight};
use super::record::{layout, read};
use super::scratch::Scratch;

#[test]
fn a_recording_replays_exactly_and_checks_out() {
    let Some(flown) = whole_flight() else { return };
    let fed = &flown.fed;
    // The script answered commands and calls and injected a program event.
    assert!(fed.results >= 4, "{fed:?}");
    assert!(!fed.command_results.is_empty(), "{fed:?}");
    assert_eq!(fed.events, 1);
    assert!(fed.ticks > 0 && fed.frames == 21_698, "{fed:?}");
    assert_eq!(flown.report.steps, fed.steps + 1);
    assert_eq!(flown.report.dropped, 0);

    let (code, out, err) = check(&flown.path, &["--json"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("match the recording"), "{err}");
    assert!(
        err.contains(&format!("replayed {} steps", fed.steps)),
        "{err}"
    );
    let lines: Vec<Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON line"))
        .collect();
    let end = lines.last().expect("an end line");
    assert_eq!(end["end"], true);
    assert_eq!(end["digest"], fed.final_digest.as_str());
    // Decisions taken on recorded answers are taken again: the takeoff
    // command follows the recorded acknowledgement of the arming.
    let verbs: Vec<&str> = lines
        .iter()
        .filter(|l| l["effect"] == "command")
        .filter_map(|l| l["verb"].as_str())
        .collect();
    assert_eq!(&verbs[..2], ["arm", "takeoff"], "{verbs:?}");
    assert!(lines
        .iter()
        .any(|l| l["effect"] == "call" && l["function"] == "replan"));
    // The recorded answers and the program's event are printed as inputs.
    let replies = lines.iter().filter(|l| l["input"] == "reply").count();
    assert_eq!(replies as u64, fed.results);
    assert!(lines
        .iter()
        .any(|l| l["input"] == "event" && l["event"] == "payload_failure" && l["program"] == true));

    // The recording itself: every input, every raw frame, a summary.
    let bytes = std::fs::read(&flown.path).expect("recording");
    let rec = read::read(&bytes, true).expect("readable");
    assert!(rec.finished && rec.cut.is_none());
    let setup = rec.setup.clone().expect("a setup");
    assert_eq!(
        (setup.config, setup.profile.as_str()),
        (elaboration::Config::default(), "ardupilot")
    );
    assert_eq!(rec.inputs.len() as u64, fed.steps + 1);
    assert_eq!(rec.frame_count() as u64, fed.frames);
    assert_eq!(rec.steps.len() as u64, fed.steps + 1);
    // Raw frames are tlog records: together they are the flight's tlog.
    let tlog = super::flight::tlog().expect("tlog");
    assert_eq!(rec.tlog(), tlog);
    let summary = mcap::Summary::read(&bytes)
        .expect("summary")
        .expect("a summary");
    let counts: BTreeMap<String, u64> = summary
        .stats
        .as_ref()
        .expect("statistics")
        .channel_message_counts
        .iter()
        .map(|(id, n)| (summary.channels[id].topic.clone(), *n))
        .collect();
    assert_eq!(counts[layout::INPUTS], fed.steps + 1);
    assert_eq!(counts[layout::DIGESTS], fed.steps + 1);
    assert_eq!(counts[layout::RAW], fed.frames);
    assert!(fed.sent > 0);
    assert_eq!(counts[layout::SENT], fed.sent);
    assert_eq!(counts["/mavlink/sent/1/191/COMMAND_LONG"], fed.sent);
    for topic in [
        "/mavlink/1/1/HEARTBEAT",
        "/mavlink/1/1/GLOBAL_POSITION_INT",
        "/mavlink/1/1/SYSTEM_TIME",
        layout::LOCATION,
        layout::EVENTS,
        layout::EFFECTS,
        layout::COMMANDS,
        layout::PROGRAMS,
        layout::RECORDER,
        layout::LOG,
        "/petrel/marking/MISSION",
        "/petrel/marking/EVENTS",
        "/petrel/marking/@globals",
    ] {
        assert!(
            counts.get(topic).is_some_and(|n| *n > 0),
            "{topic}: {counts:?}"
        );
    }
    assert_eq!(
        counts[layout::LOCATION],
        counts["/mavlink/1/1/GLOBAL_POSITION_INT"]
    );
    let location = summary
        .channels
        .values()
        .find(|c| c.topic == layout::LOCATION)
        .expect("location channel");
    let schema = location.schema.as_ref().expect("a schema");
    assert_eq!(schema.name, "foxglove.LocationFix");
    assert_eq!(schema.encoding, "jsonschema");
    let log = summary
        .channels
        .values()
        .find(|c| c.topic == layout::LOG)
        .expect("log channel");
    assert_eq!(log.schema.as_ref().expect("a schema").name, "foxglove.Log");
    assert_eq!(counts[layout::LOG], 1);
    // Both times are set; the autopilot's boot time rides with the digests
    // once SYSTEM_TIME was seen; a decoded HEARTBEAT is flat with names.
    let mut boot = Vec::new();
    let mut heartbeat = None;
    for m in mcap::MessageStream::new(&bytes).expect("MCAP") {
        let m = m.expect("message");
        assert_eq!(m.log_time, m.publish_time, "{}", m.channel.topic);
        if m.channel.topic == layout::DIGESTS {
            let v: Value = serde_json::from_slice(&m.data).expect("JSON");
            boot.push(v["boot_ms"].as_u64());
        }
        if m.channel.topic == "/mavlink/1/1/HEARTBEAT" && heartbeat.is_none() {
            heartbeat = Some(serde_json::from_slice::<Value>(&m.data).expect("JSON"));
        }
    }
    assert_eq!(boot[0], None);
    let known: Vec<u64> = boot.iter().flatten().copied().collect();
    assert!(known.len() > boot.len() / 2);
    assert!(known.windows(2).all(|w| w[0] <= w[1]));
    let hb = heartbeat.expect("a heartbeat");
    assert_eq!(hb["type"], 1, "{hb}");
    assert_eq!(hb["type_name"], "MAV_TYPE_FIXED_WING", "{hb}");
    assert_eq!(hb["autopilot"], 3, "{hb}");
    assert!(hb["base_mode"].is_u64(), "{hb}");
}

#[test]
fn a_digest_tampered_with_is_reported_at_its_step() {
    let Some(flown) = whole_flight() else { return };
    let k = flown.fed.steps / 2;
    let dir = Scratch::new("record-tampered");
    let out = dir.join("tampered-digest.mcap");
    let edits = rewrite(&flown.path, &out, |topic, v| {
        if topic == layout::DIGESTS && v["seq"] == k {
            v["digest"] = json!("0".repeat(64));
            return true;
        }
        false
    });
    assert_eq!(edits, 1);
    let (code, _, err) = check(&out, &[]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains(&format!("first difference at step {k} ")),
        "{err}"
    );
    assert!(
        err.contains(&format!("digest: recorded {}", "0".repeat(64))),
        "{err}"
    );
    // With --json the difference is also the last line.
    let (code, out, _) = check(&out, &["--json"]);
    assert_eq!(code, 1);
    let last: Value = serde_json::from_str(out.lines().last().expect("a line")).expect("JSON");
    assert_eq!(last["check"], "differ");
    assert_eq!(last["seq"], k);
}

#[test]
fn an_input_tampered_with_is_reported_at_its_step() {
    let Some(flown) = whole_flight() else { return };
    // The autopilot's acknowledgement of the arming turned into a refusal.
    let k = flown.fed.command_results[0];
    let dir = Scratch::new("record-tampered");
    let out = dir.join("tampered-input.mcap");
    let edits = rewrite(&flown.path, &out, |topic, v| {
        if topic == layout::INPUTS && v["seq"] == k {
            assert_eq!(v["input"], "result", "{v}");
            v["outcome"] = json!({"failed": "tampered"});
            return true;
        }
        false
    });
    assert_eq!(edits, 1);
    let (code, _, err) = check(&out, &[]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains(&format!("first difference at step {k} ")),
        "{err}"
    );
    assert!(err.contains("effect 1: recorded"), "{err}");
    assert!(err.contains("arm_refused"), "{err}");
}

#[test]
fn a_recording_cut_short_replays_up_to_its_last_complete_chunk() {
    let Some(flown) = chunky_flight() else { return };
    let bytes = std::fs::read(&flown.path).expect("recording");
    let full = read::read(&bytes, true).expect("readable");
    assert_eq!(full.inputs.len() as u64, flown.fed.steps + 1);
    let mut before = 0;
    for percent in [20, 50, 80, 99] {
        let cut = &bytes[..bytes.len() * percent / 100];
        let rec = read::read(cut, true).expect("a cut recording stays readable");
        assert!(rec.cut.is_some() && !rec.finished, "{percent}%");
        let n = rec.inputs.len();
        assert!(n > before, "{percent}%: {n} inputs after {before}");
        assert_eq!(rec.inputs[..], full.inputs[..n], "{percent}%");
        // Everything a complete chunk holds of a step is there: its
        // digest, and its frame.
        for (seq, _, input) in &rec.inputs {
            assert!(rec.steps[seq].digest.is_some(), "{percent}% step {seq}");
            if let layout::Input::Frame(i) = input {
                assert!(rec.frame(*i).is_some());
            }
        }
        before = n;
    }
    // 1 % short of the end loses at most a few steps of 3,000.
    assert!(before as u64 + 100 > flown.fed.steps, "{before}");
    let dir = Scratch::new("record-cut");
    let cut_path = dir.join("cut.mcap");
    std::fs::write(&cut_path, &bytes[..bytes.len() / 2]).expect("written");
    let (code, _, err) = check(&cut_path, &[]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("was cut short"), "{err}");
    assert!(err.contains("torn record"), "{err}");
    assert!(err.contains("match the recording"), "{err}");
}

#[test]
fn files_that_are_not_petrel_recordings_are_refused() {
    let dir = Scratch::new("record-refused");
    let not_mcap = dir.join("not.mcap");
    std::fs::write(&not_mcap, b"hello, world").expect("written");
    let (code, _, err) = check(&not_mcap, &[]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("not an MCAP file"), "{err}");
    // An MCAP without Petrel's inputs.
    let other = dir.join("other.mcap");
    {
        let file = std::fs::File::create(&other).expect("file");
        let mut w = mcap::Writer::new(std::io::BufWriter::new(file)).expect("writer");
        let c = w
            .add_channel(0, "/chatter", "json", &Default::default())
            .expect("channel");
        w.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: c,
                sequence: 0,
                log_time: 1,
                publish_time: 1,
            },
            b"{}",
        )
        .expect("written");
        w.finish().expect("finished");
    }
    let (code, _, err) = check(&other, &[]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("not a Petrel recording"), "{err}");
}

/// An MCAP of zeros on one channel, one chunk of `mib` MiB per entry.
fn zeros(path: &std::path::Path, chunks: &[usize]) {
    let file = std::fs::File::create(path).expect("file");
    let mut w = mcap::WriteOptions::new()
        .compression(Some(mcap::Compression::Zstd))
        .chunk_size(None)
        .create(std::io::BufWriter::new(file))
        .expect("writer");
    let c = w
        .add_channel(0, "/chatter", "json", &Default::default())
        .expect("channel");
    for (i, mib) in chunks.iter().enumerate() {
        w.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: c,
                sequence: i as u32,
                log_time: i as u64,
                publish_time: i as u64,
            },
            &vec![0u8; mib << 20],
        )
        .expect("written");
        w.flush().expect("chunk closed");
    }
    w.finish().expect("finished");
}

/// Issue 39: a file cut before the flight's start says so (not "length
/// exceeds limit: 1472"); a zstd bomb is refused before it is expanded
/// (a 65 KB one took `petrel view` to 926 MB); a device is not read.
#[test]
fn a_cut_start_a_zstd_bomb_and_a_device_are_refused_with_their_reason() {
    let Some(flown) = chunky_flight() else { return };
    let bytes = std::fs::read(&flown.path).expect("recording");
    let dir = Scratch::new("record-bombs");
    let cut = dir.join("cut.mcap");
    std::fs::write(&cut, &bytes[..100]).expect("written");
    let (code, _, err) = check(&cut, &[]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("cut short before the flight's start"), "{err}");
    assert!(
        err.contains("the file ends inside a chunk of") && err.contains("in a file of 100 bytes"),
        "{err}"
    );
    assert!(!err.contains("exceeds limit"), "{err}");

    for (name, chunks) in [("one", &[80][..]), ("many", &[40, 40])] {
        let bomb = dir.join(format!("{name}.mcap"));
        zeros(&bomb, chunks);
        let size = std::fs::metadata(&bomb).expect("bomb").len();
        assert!(size < 64 << 10, "{name}: {size} bytes");
        let e = read::read(&std::fs::read(&bomb).expect("bomb"), false)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("refused as damaged"), "{name}: {e}");
        let (code, _, err) = check(&bomb, &[]);
        assert_eq!(code, 2, "{err}");
        assert!(err.contains("would expand to over"), "{err}");
    }
    // Within the bounds, the same file is read (and is no Petrel
    // recording): the bound is not a blanket refusal.
    let small = dir.join("small.mcap");
    zeros(&small, &[8, 8]);
    let e = read::read(&std::fs::read(&small).expect("small"), false)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(e.contains("not a Petrel recording"), "{e}");

    // A device that never ends, under a recording's name.
    let endless = dir.join("endless.mcap");
    std::os::unix::fs::symlink("/dev/zero", &endless).expect("link");
    let (code, _, err) = check(&endless, &[]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("not a regular file"), "{err}");
}

#[test]
fn a_recording_damaged_mid_file_is_read_up_to_the_damage_or_refused() {
    let Some(flown) = chunky_flight() else { return };
    let bytes = std::fs::read(&flown.path).expect("recording");
    let full = read::read(&bytes, true).expect("readable");
    let dir = Scratch::new("record-damaged");
    for percent in [30, 60] {
        let mut damaged = bytes.clone();
        let at = bytes.len() * percent / 100;
        for b in &mut damaged[at..at + 64] {
            *b ^= 0x5a;
        }
        match read::read(&damaged, true) {
            Ok(rec) => {
                let n = rec.inputs.len();
                assert!(rec.cut.is_some() || n == full.inputs.len(), "{percent}%");
                // What was read before the damage is what was recorded.
                let same = rec
                    .inputs
                    .iter()
                    .zip(&full.inputs)
                    .take_while(|(a, b)| a == b)
                    .count();
                assert!(
                    same * 100 >= full.inputs.len() * (percent - 5),
                    "{percent}%: {same}"
                );
            }
            Err(e) => assert!(!e.to_string().is_empty()),
        }
        let path = dir.join(format!("damaged-{percent}.mcap"));
        std::fs::write(&path, &damaged).expect("written");
        let (code, _, err) = check(&path, &[]);
        assert!(matches!(code, 0..=2), "{code}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}
