//! Telemetry logs (`.tlog`): each frame preceded by an 8-byte big-endian
//! timestamp, microseconds since the UNIX epoch. The reader keeps the
//! timestamps (rust-mavlink's `file:` transport drops them) and survives
//! anything: bad checksums, unknown ids, garbage, truncation and timestamps
//! that go backwards are skipped or counted, never fatal.

use std::collections::BTreeMap;
use std::io::{self, Write};

use crate::frame::{announced_len, Frame, FrameError, MIN_FRAME_LEN, STX_V1, STX_V2};

const STAMP: usize = 8;

/// One frame of a log with its timestamp.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Record<'a> {
    /// The tlog timestamp, microseconds since the UNIX epoch.
    pub time_us: u64,
    pub frame: Frame<'a>,
}

/// What the reader skipped or noticed.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReadStats {
    /// Frames returned.
    pub frames: u64,
    /// Well-framed records whose checksum failed, by message id.
    pub bad_crc: BTreeMap<u32, u64>,
    /// Well-framed records with a message id outside the dialect, by id.
    pub unknown_ids: BTreeMap<u32, u64>,
    /// Well-framed MAVLink 2 records with unknown incompatibility flags.
    pub incompatible: u64,
    /// Bytes skipped while looking for the next record.
    pub skipped_bytes: u64,
    /// Times the reader lost the record boundaries and found them again.
    pub resyncs: u64,
    /// Frames whose timestamp is earlier than the one before.
    pub backwards_timestamps: u64,
    /// Bytes at the end too short to hold a whole record.
    pub truncated_tail: u64,
}

impl ReadStats {
    /// Records skipped for a bad checksum, all ids together.
    pub fn bad_crc_total(&self) -> u64 {
        self.bad_crc.values().sum()
    }
}

/// Reads the records of a tlog held in memory.
#[derive(Debug, Clone)]
pub struct TlogReader<'a> {
    bytes: &'a [u8],
    pos: usize,
    lost: bool,
    last_time: Option<u64>,
    stats: ReadStats,
}

impl<'a> TlogReader<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        TlogReader {
            bytes,
            pos: 0,
            lost: false,
            last_time: None,
            stats: ReadStats::default(),
        }
    }

    /// What has been skipped or noticed so far.
    pub fn stats(&self) -> &ReadStats {
        &self.stats
    }

    /// Whether a record could start at `at`: the end of the data, or a
    /// start marker after a timestamp.
    fn boundary_at(&self, at: usize) -> bool {
        at == self.bytes.len()
            || self
                .bytes
                .get(at + STAMP)
                .is_some_and(|&b| b == STX_V1 || b == STX_V2)
    }

    fn skip_byte(&mut self) {
        self.pos += 1;
        self.stats.skipped_bytes += 1;
        self.lost = true;
    }
}

impl<'a> Iterator for TlogReader<'a> {
    type Item = Record<'a>;

    fn next(&mut self) -> Option<Record<'a>> {
        loop {
            let rest = self.bytes.len() - self.pos;
            if rest == 0 {
                return None;
            }
            if rest < STAMP + MIN_FRAME_LEN {
                self.stats.truncated_tail += rest as u64;
                self.pos = self.bytes.len();
                return None;
            }
            let at = self.pos;
            let mut stamp = [0u8; STAMP];
            stamp.copy_from_slice(&self.bytes[at..at + STAMP]);
            let time_us = u64::from_be_bytes(stamp);
            match Frame::parse(&self.bytes[at + STAMP..]) {
                Ok(frame) => {
                    self.pos = at + STAMP + frame.bytes().len();
                    if self.lost {
                        self.lost = false;
                        self.stats.resyncs += 1;
                    }
                    if self.last_time.is_some_and(|last| time_us < last) {
                        self.stats.backwards_timestamps += 1;
                    }
                    self.last_time = Some(time_us);
                    self.stats.frames += 1;
                    return Some(Record { time_us, frame });
                }
                Err(FrameError::Truncated { .. })
                    if announced_len(&self.bytes[at + STAMP..])
                        .is_some_and(|n| at + STAMP + n > self.bytes.len())
                        && !self.lost =>
                {
                    // The log ends inside a frame.
                    self.stats.truncated_tail += rest as u64;
                    self.pos = self.bytes.len();
                    return None;
                }
                Err(
                    e @ (FrameError::BadCrc { .. }
                    | FrameError::UnknownMessage { .. }
                    | FrameError::IncompatibleFlags { .. }),
                ) if !self.lost => {
                    // Whole records with a bad checksum or an unknown id are
                    // skipped as records when the next one starts where the
                    // header says; otherwise the boundaries are lost.
                    let end = at + STAMP + e.announced_len().unwrap_or(0);
                    if self.boundary_at(end) {
                        match e {
                            FrameError::BadCrc { id, .. } => {
                                *self.stats.bad_crc.entry(id).or_default() += 1
                            }
                            FrameError::UnknownMessage { id, .. } => {
                                *self.stats.unknown_ids.entry(id).or_default() += 1
                            }
                            FrameError::IncompatibleFlags { .. } => self.stats.incompatible += 1,
                            _ => {}
                        }
                        self.pos = end;
                    } else {
                        self.skip_byte();
                    }
                }
                Err(_) => self.skip_byte(),
            }
        }
    }
}

/// Writes records in the tlog format.
#[derive(Debug)]
pub struct TlogWriter<W: Write> {
    out: W,
}

impl<W: Write> TlogWriter<W> {
    pub fn new(out: W) -> Self {
        TlogWriter { out }
    }

    /// Appends one frame (its exact wire bytes) with its timestamp.
    pub fn write_frame(&mut self, time_us: u64, frame_bytes: &[u8]) -> io::Result<()> {
        self.out.write_all(&time_us.to_be_bytes())?;
        self.out.write_all(frame_bytes)
    }

    /// Flushes and returns the underlying writer.
    pub fn into_inner(mut self) -> io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::serialize;
    use mavlink::dialects::ardupilotmega::{MavMessage, HEARTBEAT_DATA, SYS_STATUS_DATA};
    use mavlink::{MavHeader, MavlinkVersion};

    fn frame(seq: u8, v: MavlinkVersion, msg: &MavMessage) -> Vec<u8> {
        serialize(
            MavHeader {
                system_id: 1,
                component_id: 1,
                sequence: seq,
            },
            v,
            msg,
        )
    }

    fn hb() -> MavMessage {
        MavMessage::HEARTBEAT(HEARTBEAT_DATA::DEFAULT)
    }

    fn log(frames: &[(u64, Vec<u8>)]) -> Vec<u8> {
        let mut w = TlogWriter::new(Vec::new());
        for (t, f) in frames {
            w.write_frame(*t, f).expect("vec write");
        }
        w.into_inner().expect("vec flush")
    }

    #[test]
    fn round_trip_keeps_timestamps_and_bytes() {
        let frames = vec![
            (1_000, frame(0, MavlinkVersion::V1, &hb())),
            (
                2_000,
                frame(
                    1,
                    MavlinkVersion::V2,
                    &MavMessage::SYS_STATUS(SYS_STATUS_DATA::DEFAULT),
                ),
            ),
            (3_000, frame(2, MavlinkVersion::V2, &hb())),
        ];
        let bytes = log(&frames);
        let mut r = TlogReader::new(&bytes);
        let got: Vec<(u64, Vec<u8>)> = r
            .by_ref()
            .map(|rec| (rec.time_us, rec.frame.bytes().to_vec()))
            .collect();
        assert_eq!(got, frames);
        assert_eq!(r.stats().frames, 3);
        assert_eq!(r.stats().skipped_bytes, 0);
    }

    #[test]
    fn survives_bad_crc_garbage_backwards_time_and_truncation() {
        let mut bad = frame(1, MavlinkVersion::V2, &hb());
        let n = bad.len();
        bad[n - 1] ^= 0x55;
        let mut bytes = log(&[
            (10, frame(0, MavlinkVersion::V2, &hb())),
            (20, bad),
            (5, frame(2, MavlinkVersion::V2, &hb())),
        ]);
        bytes.extend_from_slice(&[0xAA; 37]); // garbage between records
        bytes.extend(log(&[(30, frame(3, MavlinkVersion::V1, &hb()))]));
        let whole = log(&[(40, frame(4, MavlinkVersion::V2, &hb()))]);
        bytes.extend_from_slice(&whole[..whole.len() - 3]); // cut mid-frame
        let mut r = TlogReader::new(&bytes);
        let times: Vec<u64> = r.by_ref().map(|rec| rec.time_us).collect();
        assert_eq!(times, vec![10, 5, 30]);
        let s = r.stats();
        assert_eq!(s.bad_crc.get(&0), Some(&1));
        assert_eq!(s.backwards_timestamps, 1);
        assert_eq!(s.skipped_bytes, 37);
        assert_eq!(s.resyncs, 1);
        assert_eq!(s.truncated_tail, whole.len() as u64 - 3);
    }
}
