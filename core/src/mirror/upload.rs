//! A new version of the project sent up from the ground (issue 38,
//! docs/mirror.md "A version sent up"), sans-IO on both ends.
//!
//! The ground's [`Sender`] cuts the version's bytes (the driver's
//! compressed files) into pieces: an [`Record::Upload`] offer (its number,
//! length and SHA-256), then [`Record::Piece`]s, paced to a byte rate (a
//! radio's share), every one to go up in a MAVLink 2 frame signed with the
//! operator key. The vehicle's [`Receiver`] takes only what the operator's
//! gate let through, one upload at a time, bounded in size; it says down
//! what it holds ([`Record::Received`]: how many pieces, the first ranges
//! missing) every second while it receives, and the sender sends the
//! missing pieces again. A whole upload whose bytes hash to the offer's
//! digest is handed to the driver ([`Receiver::poll_complete`]), which
//! loads and checks the version off the loop; the vehicle's verdict
//! (taken over at a step, or refused and why) goes down in
//! [`Record::Verdict`] parts, and the sender reports it.
//!
//! Bad input never grows memory past [`MAX_LENGTH`] nor loads anything
//! half: an offer too long, a piece out of range or of the wrong length, a
//! second upload while one is received (refused with a verdict saying
//! so), bytes that do not hash to the offer's digest. An upload the link
//! cut is given up after [`Config::give_up_after`] of silence on both
//! ends. Unsigned, altered and replayed frames never reach the receiver:
//! the gate (`mirror::dialog::AnswerGate`) refuses and counts them.

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use nets::Micros;
use sha2::{Digest as _, Sha256};

use super::record::{self, Record};

/// The bytes of a version in one piece: a piece record fits a TUNNEL
/// payload (128 bytes) with the version byte, its kind, the upload's and
/// the piece's numbers and its length.
pub const PIECE: usize = 96;

/// The longest upload the vehicle takes (compressed: the flight-test
/// example's 80 kB of TOML is about 13 kB).
pub const MAX_LENGTH: u64 = 1 << 20;

/// Missing ranges said in one [`Record::Received`], at most.
const RANGES: usize = 8;

/// The verdict's text in one [`Record::Verdict`] part, at most (bytes).
const VERDICT_PART: usize = 96;

/// Verdict parts, at most (a longer verdict is cut, and says so).
const VERDICT_PARTS: usize = 8;

/// How uploads are paced and given up.
#[derive(Debug, Clone)]
pub struct Config {
    /// Uplink bytes per second for the upload (payload bytes, pieces and
    /// offers): the radio's share it may take.
    pub bytes_per_s: u64,
    /// The offer is sent again this long after the last word from the
    /// vehicle, while nothing says it was heard.
    pub retry_after: Micros,
    /// Given up after this long without a word from the other end.
    pub give_up_after: Micros,
    /// The vehicle says what it holds this often while it receives.
    pub status_every: Micros,
}

impl Default for Config {
    fn default() -> Config {
        Config {
            bytes_per_s: 1_000,
            retry_after: 2_000_000,
            give_up_after: 60_000_000,
            status_every: 1_000_000,
        }
    }
}

/// An upload record for the uplink, to be sent signed with the operator
/// key. Built by the [`Sender`], never by hand.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Signed(Vec<u8>);

impl Signed {
    /// The packet (a Petrel TUNNEL payload).
    pub fn bytes(&self) -> &[u8] {
        &self.0
    }
}

/// What became of an upload, on the ground.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Sent {
    /// The vehicle holds `have` of `of` pieces.
    Progress { have: u64, of: u64 },
    /// The vehicle holds every piece, their digest checked: it loads the
    /// version.
    Delivered { bytes: u64, after: Micros },
    /// The vehicle's verdict, whole.
    Verdict { text: String },
    /// Nothing from the vehicle for [`Config::give_up_after`].
    GaveUp { why: String },
}

/// The ground's end of one upload.
pub struct Sender {
    config: Config,
    upload: u64,
    bytes: Vec<u8>,
    digest: [u8; 32],
    count: u64,
    /// Pieces not sent yet, in order (first the whole, then what the
    /// vehicle says is missing).
    due: BTreeSet<u64>,
    offer_due: bool,
    started: Micros,
    heard_at: Micros,
    offered_at: Option<Micros>,
    /// The vehicle said it held the offer.
    heard: bool,
    delivered: bool,
    verdict: BTreeMap<u8, String>,
    done: bool,
    tokens: u64,
    refilled: Micros,
    /// Uplink payload bytes sent (offers and pieces, sent again included).
    pub sent_bytes: u64,
    reports: VecDeque<Sent>,
}

impl Sender {
    /// An upload numbered `upload` (unique for the operator: the ground's
    /// clock makes one) of `bytes`, from ground time `now`.
    pub fn new(upload: u64, bytes: Vec<u8>, now: Micros, config: Config) -> Sender {
        let digest: [u8; 32] = Sha256::digest(&bytes).into();
        let count = (bytes.len() as u64).div_ceil(PIECE as u64).max(1);
        Sender {
            tokens: config.bytes_per_s,
            config,
            upload,
            digest,
            count,
            due: (0..count).collect(),
            offer_due: true,
            started: now,
            heard_at: now,
            offered_at: None,
            heard: false,
            delivered: false,
            verdict: BTreeMap::new(),
            done: false,
            refilled: now,
            sent_bytes: 0,
            bytes,
            reports: VecDeque::new(),
        }
    }

    /// The upload's number.
    pub fn upload(&self) -> u64 {
        self.upload
    }

    /// The number of pieces.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// Over: the verdict came, or it was given up.
    pub fn done(&self) -> bool {
        self.done
    }

    /// The next record to send signed at ground time `now`, within the
    /// byte rate: the offer (again while the vehicle says nothing), then
    /// the pieces due.
    pub fn poll_transmit(&mut self, now: Micros) -> Option<Signed> {
        if self.done {
            return None;
        }
        let elapsed = now.saturating_sub(self.refilled);
        let add = elapsed.saturating_mul(self.config.bytes_per_s) / 1_000_000;
        if add > 0 {
            self.tokens = (self.tokens + add).min(self.config.bytes_per_s.max(PIECE as u64 * 2));
            self.refilled = now;
        }
        // The offer again while the vehicle says nothing of it: before it
        // is heard, and once it holds the version whole while its verdict
        // (or a part of it) is missing: it says its verdict again.
        if (!self.heard || self.delivered)
            && !self.offer_due
            && self.offered_at.is_some_and(|t| {
                now.saturating_sub(t.max(self.heard_at)) >= self.config.retry_after
            })
        {
            self.offer_due = true;
        }
        let record = if self.offer_due {
            self.offer_due = false;
            self.offered_at = Some(now);
            Record::Upload {
                upload: self.upload,
                length: self.bytes.len() as u64,
                digest: self.digest,
            }
        } else {
            let index = *self.due.iter().next()?;
            let start = (index as usize).saturating_mul(PIECE).min(self.bytes.len());
            let end = start.saturating_add(PIECE).min(self.bytes.len());
            Record::Piece {
                upload: self.upload,
                index,
                data: self.bytes[start..end].to_vec(),
            }
        };
        let packet = record::packet(std::slice::from_ref(&record));
        let cost = packet.len() as u64;
        if self.tokens < cost {
            if matches!(record, Record::Upload { .. }) {
                self.offer_due = true;
            }
            return None;
        }
        self.tokens -= cost;
        self.sent_bytes += cost;
        if let Record::Piece { index, .. } = record {
            self.due.remove(&index);
        }
        Some(Signed(packet))
    }

    /// A downlink record about uploads, at ground time `now`.
    pub fn handle(&mut self, now: Micros, record: &Record) {
        match record {
            Record::Received {
                upload,
                have,
                missing,
            } if *upload == self.upload && !self.done => {
                self.heard = true;
                self.heard_at = now;
                self.reports.push_back(Sent::Progress {
                    have: *have,
                    of: self.count,
                });
                if *have >= self.count {
                    if !self.delivered {
                        self.delivered = true;
                        self.reports.push_back(Sent::Delivered {
                            bytes: self.sent_bytes,
                            after: now.saturating_sub(self.started),
                        });
                    }
                    self.due.clear();
                    return;
                }
                // What it still lacks goes again, once what was sent
                // since has had its chance: only the ranges it names.
                for (from, count) in missing {
                    let end = from.saturating_add(*count).min(self.count);
                    for i in *from..end {
                        self.due.insert(i);
                    }
                }
            }
            Record::Verdict {
                upload,
                part,
                parts,
                text,
            } if *upload == self.upload && !self.done => {
                self.heard = true;
                self.heard_at = now;
                self.verdict.insert(*part, text.clone());
                if (0..*parts).all(|p| self.verdict.contains_key(&p)) {
                    let text: String = self.verdict.values().map(String::as_str).collect();
                    self.done = true;
                    self.reports.push_back(Sent::Verdict { text });
                }
            }
            _ => {}
        }
    }

    /// Time passes at `now`: the upload is given up after a silence (the
    /// vehicle keeps saying it holds the version while it proves it).
    pub fn tick(&mut self, now: Micros) {
        if !self.done && now.saturating_sub(self.heard_at) >= self.config.give_up_after {
            self.done = true;
            self.reports.push_back(Sent::GaveUp {
                why: format!(
                    "nothing from the vehicle for {} s (the link; or its `petrel run` has no --downlink, or not this mirror's --operator-key)",
                    self.config.give_up_after / 1_000_000
                ),
            });
        }
    }

    /// What became of the upload, in order.
    pub fn poll_report(&mut self) -> Option<Sent> {
        self.reports.pop_front()
    }
}

/// One upload being received.
struct Reception {
    upload: u64,
    length: u64,
    digest: [u8; 32],
    pieces: Vec<Option<Vec<u8>>>,
    have: u64,
    heard_at: Micros,
    status_at: Option<Micros>,
}

/// What the vehicle's end counted.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Counts {
    pub offers: u64,
    pub pieces: u64,
    /// Pieces and offers refused: out of range, of the wrong length, too
    /// long, of an upload not being received.
    pub refused: u64,
    /// Offers refused because another upload was being received.
    pub busy: u64,
    /// Uploads whose bytes did not hash to their offer's digest.
    pub altered: u64,
    pub completed: u64,
}

/// What became of an upload received whole.
#[derive(Debug, Clone)]
enum Finished {
    /// Loaded and proved: `have` pieces, said last at `said_at`.
    Awaiting {
        have: u64,
        said_at: Micros,
    },
    Given(String),
}

/// The vehicle's end: one upload at a time.
pub struct Receiver {
    config: Config,
    current: Option<Reception>,
    /// Uploads completed, with their verdict once given (an offer of one
    /// heard again gets the verdict again); until then, how many pieces
    /// and when that was last said (the ground hears the vehicle is at
    /// work while it proves the version).
    finished: BTreeMap<u64, Finished>,
    complete: VecDeque<(u64, Vec<u8>)>,
    down: VecDeque<Record>,
    pub counts: Counts,
}

impl Receiver {
    pub fn new(config: Config) -> Receiver {
        Receiver {
            config,
            current: None,
            finished: BTreeMap::new(),
            complete: VecDeque::new(),
            down: VecDeque::new(),
            counts: Counts::default(),
        }
    }

    /// An upload record from a frame the operator's gate let through, at
    /// vehicle time `now`.
    pub fn handle(&mut self, now: Micros, record: Record) {
        match record {
            Record::Upload {
                upload,
                length,
                digest,
            } => self.offer(now, upload, length, digest),
            Record::Piece {
                upload,
                index,
                data,
            } => self.piece(now, upload, index, data),
            _ => self.counts.refused += 1,
        }
    }

    fn offer(&mut self, now: Micros, upload: u64, length: u64, digest: [u8; 32]) {
        self.counts.offers += 1;
        if let Some(finished) = self.finished.get(&upload) {
            // Heard again: say again what became of it.
            match finished.clone() {
                Finished::Given(text) => self.verdict(upload, &text),
                Finished::Awaiting { have, .. } => self.down.push_back(Record::Received {
                    upload,
                    have,
                    missing: Vec::new(),
                }),
            }
            return;
        }
        match &mut self.current {
            Some(r) if r.upload == upload => {
                r.heard_at = now;
                self.status(upload, now);
                return;
            }
            Some(r) if now.saturating_sub(r.heard_at) < self.config.give_up_after => {
                self.counts.busy += 1;
                let busy = r.upload;
                self.verdict(
                    upload,
                    &format!(
                        "refused: upload {busy} is being received; send again once it is over"
                    ),
                );
                return;
            }
            _ => {}
        }
        if length == 0 || length > MAX_LENGTH {
            self.counts.refused += 1;
            self.verdict(
                upload,
                &format!("refused: {length} bytes; an upload is 1 to {MAX_LENGTH} bytes"),
            );
            return;
        }
        let count = length.div_ceil(PIECE as u64) as usize;
        self.current = Some(Reception {
            upload,
            length,
            digest,
            pieces: vec![None; count],
            have: 0,
            heard_at: now,
            status_at: None,
        });
        self.status(upload, now);
    }

    fn piece(&mut self, now: Micros, upload: u64, index: u64, data: Vec<u8>) {
        let Some(r) = self.current.as_mut().filter(|r| r.upload == upload) else {
            // Of an upload over, or never offered: said again if over.
            if !self.finished.contains_key(&upload) {
                self.counts.refused += 1;
            }
            return;
        };
        let count = r.pieces.len() as u64;
        if index >= count {
            self.counts.refused += 1;
            return;
        }
        let expected = if index + 1 == count {
            (r.length - index * PIECE as u64) as usize
        } else {
            PIECE
        };
        let Some(slot) = r.pieces.get_mut(index as usize) else {
            self.counts.refused += 1;
            return;
        };
        if data.len() != expected {
            self.counts.refused += 1;
            return;
        }
        self.counts.pieces += 1;
        r.heard_at = now;
        if slot.is_none() {
            *slot = Some(data);
            r.have += 1;
        }
        if r.have == count {
            self.finish(now);
        }
    }

    /// Every piece is here: the bytes, if they hash to the offer's digest.
    fn finish(&mut self, now: Micros) {
        let Some(r) = self.current.take() else { return };
        let bytes: Vec<u8> = r.pieces.into_iter().flatten().flatten().collect();
        let digest: [u8; 32] = Sha256::digest(&bytes).into();
        let awaiting = Finished::Awaiting {
            have: r.have,
            said_at: now,
        };
        if digest != r.digest {
            self.counts.altered += 1;
            self.finished.insert(r.upload, awaiting);
            self.verdict(
                r.upload,
                "refused: the bytes received do not hash to the offer's digest",
            );
            return;
        }
        self.counts.completed += 1;
        self.finished.insert(r.upload, awaiting);
        self.down.push_back(Record::Received {
            upload: r.upload,
            have: r.have,
            missing: Vec::new(),
        });
        self.complete.push_back((r.upload, bytes));
        // Remember the last few only.
        while self.finished.len() > 16 {
            self.finished.pop_first();
        }
    }

    /// Time passes at vehicle time `now`: what it holds said every
    /// [`Config::status_every`]; an upload silent too long is given up.
    pub fn tick(&mut self, now: Micros) {
        // Whole, not yet judged: the ground hears it is being proved.
        let every = self.config.status_every;
        for (upload, f) in &mut self.finished {
            if let Finished::Awaiting { have, said_at } = f {
                if now.saturating_sub(*said_at) >= every {
                    *said_at = now;
                    self.down.push_back(Record::Received {
                        upload: *upload,
                        have: *have,
                        missing: Vec::new(),
                    });
                }
            }
        }
        let Some(r) = &self.current else { return };
        if now.saturating_sub(r.heard_at) >= self.config.give_up_after {
            self.current = None;
            return;
        }
        if r.status_at
            .is_none_or(|t| now.saturating_sub(t) >= self.config.status_every)
        {
            let upload = r.upload;
            self.status(upload, now);
        }
    }

    fn status(&mut self, upload: u64, now: Micros) {
        let Some(r) = self.current.as_mut().filter(|r| r.upload == upload) else {
            return;
        };
        r.status_at = Some(now);
        let mut missing = Vec::new();
        let mut i = 0;
        while i < r.pieces.len() && missing.len() < RANGES {
            if r.pieces[i].is_some() {
                i += 1;
                continue;
            }
            let from = i;
            while i < r.pieces.len() && r.pieces[i].is_none() {
                i += 1;
            }
            missing.push((from as u64, (i - from) as u64));
        }
        self.down.push_back(Record::Received {
            upload,
            have: r.have,
            missing,
        });
    }

    /// The next whole upload, its digest checked, for the driver to load:
    /// `(upload, bytes)`.
    pub fn poll_complete(&mut self) -> Option<(u64, Vec<u8>)> {
        self.complete.pop_front()
    }

    /// The vehicle's verdict on `upload`, said down (in parts) and kept
    /// for an offer heard again.
    pub fn verdict(&mut self, upload: u64, text: &str) {
        if let Some(kept) = self.finished.get_mut(&upload) {
            *kept = Finished::Given(text.to_owned());
        }
        let mut parts: Vec<String> = Vec::new();
        let mut rest = text;
        while !rest.is_empty() && parts.len() < VERDICT_PARTS {
            let mut cut = rest.len().min(VERDICT_PART);
            while !rest.is_char_boundary(cut) {
                cut -= 1;
            }
            parts.push(rest[..cut].to_owned());
            rest = &rest[cut..];
        }
        if !rest.is_empty() {
            if let Some(last) = parts.last_mut() {
                last.push('…');
            }
        }
        if parts.is_empty() {
            parts.push(String::new());
        }
        let n = parts.len() as u8;
        for (i, text) in parts.into_iter().enumerate() {
            self.down.push_back(Record::Verdict {
                upload,
                part: i as u8,
                parts: n,
                text,
            });
        }
    }

    /// The next record to say down.
    pub fn poll_downlink(&mut self) -> Option<Record> {
        self.down.pop_front()
    }
}

/// A version's files as upload bytes, before the driver compresses them:
/// `uvarint n, { str path, str text } × n` (`nets::binary`).
pub fn files_bytes(files: &[(String, String)]) -> Vec<u8> {
    let mut w = nets::binary::Writer::new();
    w.len(files.len());
    for (path, text) in files {
        w.str(path);
        w.str(text);
    }
    w.bytes
}

/// Reads [`files_bytes`] back: the files, or why not. Paths are relative,
/// without `..`: they name a project's files, never the vehicle's.
pub fn files_from(bytes: &[u8]) -> Result<Vec<(String, String)>, String> {
    let mut r = nets::binary::Reader::new(bytes);
    let mut read = || -> Result<Vec<(String, String)>, nets::binary::DecodeError> {
        let n = r.count(2)?;
        let mut files = Vec::with_capacity(n);
        for _ in 0..n {
            files.push((r.str()?, r.str()?));
        }
        r.finish()?;
        Ok(files)
    };
    let files = read().map_err(|e| format!("the files do not decode: {e}"))?;
    for (path, _) in &files {
        let bad = path.is_empty()
            || path.starts_with('/')
            || path.split(['/', '\\']).any(|c| c == ".." || c.is_empty());
        if bad {
            return Err(format!("file name {path:?}: not a path inside a project"));
        }
    }
    Ok(files)
}

#[cfg(test)]
#[path = "upload_tests.rs"]
mod tests;
