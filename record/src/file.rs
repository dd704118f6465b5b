//! The recording's file: a complete MCAP after every closed chunk.
//!
//! The MCAP writer hands this sink whole records (chunks are compressed in
//! memory: `disable_seeking`), which it keeps until the writer flushes,
//! that is until a chunk is closed. Then what it kept is written in one
//! call at the end of the data already in the file, followed by a
//! provisional end of file — a Data End record, a Footer with no summary and
//! the closing magic — and the file is synced. The next flush writes over
//! that provisional end. So a file cut at any instant (the process killed
//! with SIGKILL, a power loss after the sync) is a valid MCAP that any
//! conforming reader opens, streaming or seeking, and holds every chunk
//! closed before the cut; only a kill that lands inside the one `write` of
//! a chunk can leave a torn end, which `petrel replay` and `petrel recover`
//! read up to. A chunk's length is never a placeholder on the disk.
//!
//! When a write fails (a full disk), the provisional end is written back
//! over the bytes it occupied before (no new space is needed), so the file
//! stays valid up to the last chunk that was written whole.

use std::fs::File;
use std::io::{self, Seek, SeekFrom, Write};
use std::os::unix::fs::FileExt;

use mcap::records::op;

/// The provisional end of file: Data End (no CRC: 0), Footer (no summary:
/// every offset 0), magic.
const TRAILER: [u8; 50] = trailer();

const fn trailer() -> [u8; 50] {
    let mut t = [0u8; 50];
    // Data End: opcode, length 4, data_section_crc 0.
    t[0] = op::DATA_END;
    t[1] = 4;
    // Footer: opcode, length 20, summary_start 0, summary_offset_start 0,
    // summary_crc 0.
    t[13] = op::FOOTER;
    t[14] = 20;
    // Magic.
    let magic = mcap::MAGIC;
    let mut i = 0;
    while i < magic.len() {
        t[42 + i] = magic[i];
        i += 1;
    }
    t
}

/// The sink the MCAP writer writes into (see the module's documentation).
pub struct RecordingFile {
    file: File,
    /// Bytes of the MCAP in the file, before the provisional end.
    written: u64,
    /// Records not yet in the file.
    pending: Vec<u8>,
    /// Whether the file is synced to the disk at each flush (off only in
    /// tests and benchmarks that measure the writer without the disk).
    sync: bool,
}

impl RecordingFile {
    /// An empty file to record into.
    pub fn new(file: File) -> RecordingFile {
        RecordingFile {
            file,
            written: 0,
            pending: Vec::new(),
            sync: true,
        }
    }

    /// Writes what is pending then the provisional end, and syncs.
    fn commit(&mut self, trailer: bool) -> io::Result<()> {
        let data = self.pending.len();
        if trailer {
            self.pending.extend_from_slice(&TRAILER);
        }
        let result = self.file.write_all_at(&self.pending, self.written);
        self.pending.truncate(data);
        match result {
            Ok(()) => {
                self.written += data as u64;
                self.pending.clear();
                if !trailer {
                    self.file.set_len(self.written)?;
                }
                if self.sync {
                    self.file.sync_data()?;
                }
                Ok(())
            }
            Err(e) => {
                self.restore();
                Err(e)
            }
        }
    }

    /// After a failed write: the provisional end back where it was, over
    /// bytes the file already holds, and nothing after it.
    fn restore(&mut self) {
        if self.written == 0 {
            let _ = self.file.set_len(0);
            return;
        }
        let _ = self.file.set_len(self.written + TRAILER.len() as u64);
        let _ = self.file.write_all_at(&TRAILER, self.written);
        let _ = self.file.sync_data();
    }

    /// The writer has finished the file (its summary, footer and magic are
    /// pending): writes them in place of the provisional end.
    pub fn seal(mut self) -> io::Result<()> {
        self.commit(false)
    }
}

impl Write for RecordingFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.pending.extend_from_slice(buf);
        Ok(buf.len())
    }

    /// A chunk was closed: into the file, followed by the provisional end.
    fn flush(&mut self) -> io::Result<()> {
        if self.pending.is_empty() {
            return Ok(());
        }
        self.commit(true)
    }
}

impl Seek for RecordingFile {
    /// Only where the writer already is: the MCAP writer asks its position
    /// and never seeks elsewhere with `disable_seeking`.
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        let here = self.written + self.pending.len() as u64;
        let ok = match pos {
            SeekFrom::Current(0) => true,
            SeekFrom::Start(p) => p == here,
            _ => false,
        };
        if ok {
            Ok(here)
        } else {
            Err(io::Error::new(
                io::ErrorKind::Unsupported,
                "the recording's file is written in order",
            ))
        }
    }

    fn stream_position(&mut self) -> io::Result<u64> {
        Ok(self.written + self.pending.len() as u64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_provisional_end_is_a_data_end_a_footer_without_summary_and_the_magic() {
        let mut w = mcap::WriteOptions::new()
            .use_chunks(false)
            .emit_summary_records(false)
            .emit_summary_offsets(false)
            .calculate_data_section_crc(false)
            .calculate_summary_section_crc(false)
            .create(std::io::Cursor::new(Vec::new()))
            .expect("writer");
        w.finish().expect("finish");
        let bytes = w.into_inner().into_inner();
        assert!(bytes.ends_with(&TRAILER), "{bytes:?}");
    }
}
