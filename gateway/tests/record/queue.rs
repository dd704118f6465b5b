//! A writer too slow for its queue: the caller never waits, what is dropped
//! is counted and the count is recorded; replay stops at the gap.

use std::io::{Cursor, Seek, SeekFrom, Write};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use crate::files::{check, scratch};
use crate::flight;
use crate::record::read;
use crate::record::recorder::{Options, Recorder};

/// An in-memory sink that takes 2 ms per write, shared with the test.
#[derive(Clone, Default)]
struct SlowSink(Arc<Mutex<Cursor<Vec<u8>>>>);

impl Write for SlowSink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        std::thread::sleep(Duration::from_millis(2));
        self.0.lock().expect("sink").write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Seek for SlowSink {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.0.lock().expect("sink").seek(pos)
    }
}

#[test]
fn a_slow_writer_drops_counts_and_records_the_count() {
    let Some(tlog) = flight::tlog() else { return };
    let sink = SlowSink::default();
    let recorder = Recorder::with_sink(
        sink.clone(),
        flight::project(),
        Options {
            queue: 16,
            flush_every: Duration::from_millis(1),
            ..Options::default()
        },
    )
    .expect("recorder");
    let fed = flight::fly(&tlog, &recorder, 2_000, None);
    let dropped = recorder.dropped();
    assert!(dropped > 0, "nothing dropped");
    let report = recorder.finish().expect("finished");
    assert_eq!(report.dropped, dropped);
    // Steps and the other entries (frames sent, program lines) are counted.
    assert!(report.dropped_steps > 0 && report.dropped_steps <= dropped);
    assert_eq!(report.steps + report.dropped_steps, fed.steps + 1);
    let bytes = sink.0.lock().expect("sink").get_ref().clone();
    let rec = read::read(&bytes, true).expect("readable");
    assert!(rec.finished);
    assert_eq!(rec.dropped, dropped, "the count is recorded");
    assert_eq!(rec.dropped_steps, report.dropped_steps);
    assert_eq!(rec.inputs.len() as u64, report.steps);
    // Replay cannot be exact past the first gap, and says so.
    let path = scratch("dropped.mcap");
    std::fs::write(&path, &bytes).expect("written");
    let (code, _, err) = check(&path, &[]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("dropped"), "{err}");
    assert!(err.contains("first difference at step"), "{err}");
}

/// A sink whose disk is full after `room` bytes.
struct FullDisk {
    written: Cursor<Vec<u8>>,
    room: usize,
}

impl Write for FullDisk {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.written.get_ref().len() + buf.len() > self.room {
            return Err(std::io::Error::other("no space left on device"));
        }
        self.written.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Seek for FullDisk {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.written.seek(pos)
    }
}

#[test]
fn a_full_disk_stops_the_recording_not_the_flight() {
    let Some(tlog) = flight::tlog() else { return };
    let recorder = Recorder::with_sink(
        FullDisk {
            written: Cursor::default(),
            room: 4096,
        },
        flight::project(),
        Options {
            flush_every: Duration::from_millis(1),
            ..Options::default()
        },
    )
    .expect("recorder");
    let fed = flight::fly(&tlog, &recorder, 3_000, None);
    // Entries after the failure are counted as dropped (the flight goes on).
    let player = nets::Player::start(flight::project(), 0);
    let give_up = std::time::Instant::now() + Duration::from_secs(10);
    while recorder.dropped() == 0 && std::time::Instant::now() < give_up {
        std::thread::sleep(Duration::from_millis(10));
        let step = crate::supervisor::Step::default();
        recorder.step(&crate::supervisor::Input::Tick, &step, &player);
    }
    assert!(recorder.dropped() > 0, "{fed:?}");
    let err = recorder.finish().expect_err("the recording failed");
    assert!(err.to_string().contains("no space left"), "{err}");
}
