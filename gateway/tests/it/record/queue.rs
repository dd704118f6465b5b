//! A writer too slow for its queue: the caller never waits, what is dropped
//! is counted and the count is recorded; replay stops at the gap.

use std::io::{Cursor, Seek, SeekFrom, Write};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::files::check;
use super::flight;
use super::record::read;
use super::record::recorder::{Options, Recorder};
use super::scratch::Scratch;

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
    let dir = Scratch::new("record-dropped");
    let path = dir.join("dropped.mcap");
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
        let step = super::supervisor::Step::default();
        recorder.step(&super::supervisor::Input::Tick, &step, &player);
    }
    assert!(recorder.dropped() > 0, "{fed:?}");
    let err = recorder.finish().expect_err("the recording failed");
    assert!(err.to_string().contains("no space left"), "{err}");
}

/// A sink whose writes wait while its gate is closed, saying when one
/// waits.
#[derive(Clone, Default)]
struct GatedSink {
    bytes: Arc<Mutex<Cursor<Vec<u8>>>>,
    /// (closed, a write waiting)
    gate: Arc<(Mutex<(bool, bool)>, std::sync::Condvar)>,
}

impl GatedSink {
    fn close(&self) {
        self.gate.0.lock().expect("gate").0 = true;
    }
    fn open(&self) {
        self.gate.0.lock().expect("gate").0 = false;
        self.gate.1.notify_all();
    }
    fn waiting(&self) -> bool {
        self.gate.0.lock().expect("gate").1
    }
}

impl Write for GatedSink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let (lock, wake) = &*self.gate;
        let mut state = lock.lock().expect("gate");
        while state.0 {
            state.1 = true;
            state = wake.wait(state).expect("gate");
        }
        state.1 = false;
        drop(state);
        self.bytes.lock().expect("sink").write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Seek for GatedSink {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.bytes.lock().expect("sink").seek(pos)
    }
}

/// The ground mirror's received frames yield the queue's last quarter to
/// the replica's steps: a writer that stalls drops the frames, not the
/// steps.
#[test]
fn received_frames_yield_the_queue_to_the_replicas_steps() {
    use super::supervisor::Step;
    let sink = GatedSink::default();
    let project = flight::project();
    let recorder = Recorder::with_sink(
        sink.clone(),
        project.clone(),
        Options {
            queue: 16,
            flush_every: Duration::from_millis(5),
            ..Options::default()
        },
    )
    .expect("recorder");
    let mut player = nets::Player::start(project, 0);
    let start = Step {
        seq: 0,
        time: 0,
        events: Vec::new(),
        effects: player.effects().collect(),
    };
    recorder.start(&start, &player);
    // The writer stalls in its next chunk.
    sink.close();
    let stalled = std::time::Instant::now() + Duration::from_secs(10);
    while !sink.waiting() {
        assert!(
            std::time::Instant::now() < stalled,
            "the writer never wrote"
        );
        std::thread::sleep(Duration::from_millis(1));
    }
    // A HEARTBEAT frame, received again and again.
    let frame = [
        0xfd, 9, 0, 0, 0, 1, 1, 0, 0, 0, 0, 0, 0, 0, 1, 3, 0x51, 4, 3, 0x1c, 0x7f,
    ];
    for i in 0..100 {
        recorder.received(i, &frame);
    }
    let frames_dropped = recorder.dropped();
    assert!(frames_dropped >= 100 - 12, "{frames_dropped}");
    for seq in 1..=4 {
        let step = Step {
            seq,
            time: seq * 1000,
            events: Vec::new(),
            effects: Vec::new(),
        };
        player.advance(seq * 1000);
        recorder.replica(
            seq * 1000 + 7,
            serde_json::json!({"call": "advance"}),
            step,
            player.digest(),
        );
    }
    assert_eq!(recorder.dropped(), frames_dropped, "no step dropped");
    sink.open();
    let report = recorder.finish().expect("finished");
    assert_eq!(report.dropped_steps, 0);
    assert_eq!(report.steps, 5);
    let bytes = sink.bytes.lock().expect("sink").get_ref().clone();
    let rec = read::read(&bytes, true).expect("readable");
    assert_eq!(rec.inputs.len(), 5);
    assert_eq!(rec.frame_count() as u64, 100 - frames_dropped);
}
