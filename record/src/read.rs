//! Reading a Petrel recording back for replay: the inputs in order, the raw
//! frames they refer to, and (when checking) the effects and digest of each
//! step. A file cut short (power loss: no summary, a half-written chunk) is
//! read up to its last complete chunk and says where it was cut.

use std::collections::HashMap;

use mcap::records::{op, Record};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use nets::Micros;
use serde_json::Value as Json;

use super::layout::{self, Input};

/// What one step recorded: its effects (as `effect_json`, without `seq`)
/// and the digest after it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Recorded {
    pub effects: Vec<Json>,
    pub digest: Option<String>,
    pub boot_ms: Option<u64>,
}

/// A recording read back.
#[derive(Debug, Default)]
pub struct Recording {
    /// Every input, in the recorded order: `(seq, time, input)`.
    pub inputs: Vec<(u64, Micros, Input)>,
    /// The link each frame input came in on, by frame index, when recorded
    /// (a team's `run` records it; older recordings do not: link 0).
    pub links: std::collections::BTreeMap<u64, u64>,
    /// Raw frames on `/mavlink/raw`, tlog records (time, frame) one after
    /// the other: the flight's tlog.
    tlog: Vec<u8>,
    /// Where each raw frame's record starts in `tlog`, by index.
    frames: Vec<usize>,
    /// What each step recorded, by seq (read only when asked).
    pub steps: HashMap<u64, Recorded>,
    /// Entries the recorder dropped, as last recorded.
    pub dropped: u64,
    /// Of which Supervisor steps.
    pub dropped_steps: u64,
    /// Why reading stopped before the end of the file, if it did (the
    /// recording was cut, e.g. by a power loss).
    pub cut: Option<String>,
    /// Whether the file has its summary (a clean finish).
    pub finished: bool,
    /// How the flight was elaborated, recorded with the start.
    pub setup: Option<layout::Setup>,
}

/// A digest line as read.
#[derive(serde::Deserialize)]
struct DigestLine<'a> {
    seq: u64,
    #[serde(borrow)]
    digest: std::borrow::Cow<'a, str>,
    boot_ms: Option<u64>,
}

/// Why a file is not a readable Petrel recording.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error("not an MCAP file: {0}")]
    NotMcap(String),
    #[error("not a Petrel recording: no {} channel", layout::INPUTS)]
    NotPetrel,
    #[error("cut short before the flight's start: {0}")]
    CutBeforeStart(String),
    #[error("{0}")]
    Bomb(String),
    #[error("bad record on {topic} (message {index}): {what}")]
    Bad {
        topic: &'static str,
        index: u64,
        what: String,
    },
}

impl Recording {
    /// The frames as one tlog (to detect the autopilot, or to export).
    pub fn tlog(&self) -> &[u8] {
        &self.tlog
    }

    /// How many raw frames were read.
    pub fn frame_count(&self) -> usize {
        self.frames.len()
    }

    /// The frame bytes and receive time of raw frame `index`.
    pub fn frame(&self, index: u64) -> Option<(Micros, &[u8])> {
        let i = usize::try_from(index).ok()?;
        let start = *self.frames.get(i)?;
        let end = self.frames.get(i + 1).copied().unwrap_or(self.tlog.len());
        let (stamp, bytes) = self.tlog.get(start..end)?.split_at_checked(8)?;
        let time = u64::from_be_bytes(stamp.try_into().ok()?);
        Some((time, bytes))
    }
}

/// The largest file a verb reads whole (a recording or a tlog): a day of
/// one vehicle's flights is a few hundred MB.
pub const FILE_LIMIT: u64 = 4 << 30;

/// The bytes of the file at `path`, a recording or a telemetry log read
/// whole: a regular file (not a FIFO or a device, which might never end)
/// of at most [`FILE_LIMIT`] bytes.
pub fn whole(path: &std::path::Path) -> std::io::Result<Vec<u8>> {
    use std::io::{Error, ErrorKind, Read};
    let file = std::fs::File::open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            "not a regular file (a recording or a telemetry log is read whole)",
        ));
    }
    if meta.len() > FILE_LIMIT {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            format!(
                "{} MiB: larger than the {} MiB read at once",
                meta.len() >> 20,
                FILE_LIMIT >> 20
            ),
        ));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    // The file may grow while it is read (a flight still recording): what
    // it held when opened, at most the limit.
    file.take(FILE_LIMIT).read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// Reads `bytes`, a Petrel MCAP; with `expectations`, also each step's
/// effects and digest (for `--check-against`).
pub fn read(bytes: &[u8], expectations: bool) -> Result<Recording, ReadError> {
    if bytes.len() < mcap::MAGIC.len() || &bytes[..mcap::MAGIC.len()] != mcap::MAGIC {
        return Err(ReadError::NotMcap("no MCAP magic at the start".into()));
    }
    let mut reader = Reader {
        rec: Recording::default(),
        expectations,
        kinds: HashMap::new(),
        saw_inputs: false,
        counts: [0; 3],
    };
    // The records outside chunks in order (mcap's sans-IO reader, chunks
    // whole); a file cut short ends with an error after its last complete
    // record. Chunks are read in order until the replay channels are known
    // (the writer declares them first), then decompressed in batches on
    // every core.
    let workers = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .clamp(1, 4);
    let mut top = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_emit_chunks(true)
            .with_record_length_limit(bytes.len()),
    );
    let mut fed = false;
    let mut batch: Vec<Vec<u8>> = Vec::new();
    let mut ended = None;
    // The summary (after the data end) repeats channels: it is only read
    // through, so that a cut there is noticed too.
    let mut in_summary = false;
    let mut expanded: u64 = 0;
    while let Some(event) = top.next_event() {
        let (opcode, data) = match event {
            Ok(LinearReadEvent::ReadRequest(_)) => {
                if fed {
                    top.notify_read(0);
                } else {
                    top.insert(bytes.len()).copy_from_slice(bytes);
                    top.notify_read(bytes.len());
                    fed = true;
                }
                continue;
            }
            Ok(LinearReadEvent::Record { opcode, data }) => (opcode, data),
            Err(mcap::McapError::RecordTooLarge { opcode, len }) => {
                // Longer than the whole file: the file ends inside it.
                ended = Some(format!(
                    "the file ends inside {} of {len} bytes, in a file of {} bytes",
                    record_name(opcode),
                    bytes.len()
                ));
                break;
            }
            Err(e) => {
                ended = Some(e.to_string());
                break;
            }
        };
        match opcode {
            op::DATA_END => in_summary = true,
            op::CHUNK if !in_summary => {
                // What the chunk says it holds once decompressed, counted
                // before it is: a small file may not expand without bound.
                let unpacked = data
                    .get(16..24)
                    .and_then(|b| b.try_into().ok())
                    .map_or(0, u64::from_le_bytes);
                expanded = expanded.saturating_add(unpacked);
                if unpacked > RECORD_LIMIT as u64 || expanded > expansion_limit(bytes.len()) {
                    return Err(ReadError::Bomb(format!(
                        "its chunks would expand to over {} MiB from a {} KiB file (a chunk holds at most {} MiB, a recording expands at most {EXPANSION}-fold): refused as damaged",
                        expanded >> 20,
                        bytes.len() >> 10,
                        RECORD_LIMIT >> 20
                    )));
                }
                let mut raw = Vec::with_capacity(9 + data.len());
                raw.push(op::CHUNK);
                raw.extend_from_slice(&(data.len() as u64).to_le_bytes());
                raw.extend_from_slice(data);
                if reader.knows_channels() {
                    batch.push(raw);
                    if batch.len() == workers * 16 {
                        reader.parallel(&batch, workers)?;
                        batch.clear();
                    }
                } else {
                    let mut records = Vec::new();
                    match chunk_records(&raw, |op, data| {
                        records.push((op, data.to_vec()));
                        Ok(())
                    }) {
                        Ok(()) => {
                            for (op, data) in &records {
                                reader.raw_record(*op, data)?;
                            }
                        }
                        Err(e) => reader.rec.cut = Some(e),
                    }
                }
            }
            op::CHANNEL | op::MESSAGE if !in_summary => {
                // Outside chunks (not written by Petrel): in order.
                if !batch.is_empty() {
                    reader.parallel(&batch, workers)?;
                    batch.clear();
                }
                if reader.rec.cut.is_none() {
                    let data = data.to_vec();
                    reader.raw_record(opcode, &data)?;
                }
            }
            _ => {}
        }
        if reader.rec.cut.is_some() {
            break;
        }
    }
    if reader.rec.cut.is_none() && !batch.is_empty() {
        reader.parallel(&batch, workers)?;
    }
    if reader.rec.cut.is_none() {
        reader.rec.cut = ended;
    }
    let mut rec = reader.finish()?;
    rec.finished = rec.cut.is_none() && super::fields::has_summary(bytes);
    Ok(rec)
}

/// The largest record believed inside a chunk, and the largest chunk
/// (uncompressed): Petrel closes a chunk every second (about 1 MiB for
/// one plane's second at 20 times real time); anything larger is damage,
/// which must not be allocated.
const RECORD_LIMIT: usize = 64 << 20;

/// How many times its size a file's chunks may expand to, all together:
/// Petrel's own recordings expand about 6-fold (`demo.mcap`: 0.8 MB of
/// chunks, 4.7 MB decompressed); a zstd bomb of 65 KB took `petrel view`
/// to 926 MB.
const EXPANSION: u64 = 100;

/// What the chunks of a file of `len` bytes may expand to.
fn expansion_limit(len: usize) -> u64 {
    (len as u64)
        .saturating_mul(EXPANSION)
        .max(RECORD_LIMIT as u64)
}

/// An MCAP record's name, by opcode, for a person.
fn record_name(opcode: u8) -> String {
    match opcode {
        op::HEADER => "the header".into(),
        op::SCHEMA => "a schema".into(),
        op::CHANNEL => "a channel".into(),
        op::MESSAGE => "a message".into(),
        op::CHUNK => "a chunk".into(),
        op::DATA_END => "the data end".into(),
        op::FOOTER => "the footer".into(),
        other => format!("a record of opcode {other:#04x}"),
    }
}

/// Hands each record of a chunk (given as its whole record: opcode, length,
/// body) to `f`, after checking the chunk's CRC.
pub(super) fn chunk_records(
    raw: &[u8],
    mut f: impl FnMut(u8, &[u8]) -> Result<(), String>,
) -> Result<(), String> {
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_skip_start_magic(true)
            .with_skip_end_magic(true)
            .with_prevalidate_chunk_crcs(true)
            .with_record_length_limit(RECORD_LIMIT),
    );
    let mut fed = false;
    while let Some(event) = reader.next_event() {
        match event.map_err(|e| e.to_string())? {
            LinearReadEvent::ReadRequest(_) => {
                if fed {
                    reader.notify_read(0);
                } else {
                    reader.insert(raw.len()).copy_from_slice(raw);
                    reader.notify_read(raw.len());
                    fed = true;
                }
            }
            LinearReadEvent::Record { opcode, data } => f(opcode, data)?,
        }
    }
    Ok(())
}

/// What a channel carries, for replay.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Raw,
    Inputs,
    Effects,
    Digests,
    Recorder,
}

fn kind_of(topic: &str) -> Option<Kind> {
    Some(match topic {
        layout::RAW => Kind::Raw,
        layout::INPUTS => Kind::Inputs,
        layout::EFFECTS => Kind::Effects,
        layout::DIGESTS => Kind::Digests,
        layout::RECORDER => Kind::Recorder,
        _ => return None,
    })
}

/// A message of a chunk kept for replay.
type Kept = (Kind, Vec<u8>);

struct Reader {
    rec: Recording,
    expectations: bool,
    /// Channels that matter, by id.
    kinds: HashMap<u16, Kind>,
    saw_inputs: bool,
    /// Messages read on inputs, effects, digests (for errors).
    counts: [u64; 3],
}

impl Reader {
    fn knows_channels(&self) -> bool {
        [
            Kind::Raw,
            Kind::Inputs,
            Kind::Effects,
            Kind::Digests,
            Kind::Recorder,
        ]
        .iter()
        .all(|k| self.kinds.values().any(|v| v == k))
    }

    fn wanted(&self, kind: Kind) -> bool {
        self.expectations || !matches!(kind, Kind::Effects | Kind::Digests)
    }

    /// A channel or message record (opcode and body), in file order.
    fn raw_record(&mut self, opcode: u8, data: &[u8]) -> Result<(), ReadError> {
        if !super::fields::lengths_fit(opcode, data) {
            self.rec.cut = Some(format!(
                "a damaged record (opcode {opcode:#04x}): a length inside it runs past its end"
            ));
            return Ok(());
        }
        match mcap::parse_record(opcode, data) {
            Ok(Record::Channel(c)) => {
                if let Some(kind) = kind_of(&c.topic) {
                    self.kinds.insert(c.id, kind);
                }
            }
            Ok(Record::Message { header, data }) => match self.kinds.get(&header.channel_id) {
                Some(&kind) if self.wanted(kind) => self.message(kind, &data)?,
                _ => {}
            },
            Ok(_) => {}
            Err(e) => self.rec.cut = Some(e.to_string()),
        }
        Ok(())
    }

    /// Decompresses the chunks of `tops` on `workers` threads, keeping only
    /// what replay reads, then takes the messages in file order.
    fn parallel(&mut self, tops: &[Vec<u8>], workers: usize) -> Result<(), ReadError> {
        let results = self.extract(tops, workers);
        for result in results {
            match result {
                Some(Ok(kept)) => {
                    for (kind, data) in kept {
                        self.message(kind, &data)?;
                    }
                }
                Some(Err(e)) => {
                    self.rec.cut = Some(e);
                    break;
                }
                None => {
                    self.rec.cut = Some("a chunk could not be read".into());
                    break;
                }
            }
        }
        Ok(())
    }

    /// The messages replay reads from each chunk of `tops` (whole chunk
    /// records), decompressed by `workers` threads; `None` where a thread
    /// failed.
    fn extract(&self, tops: &[Vec<u8>], workers: usize) -> Vec<Option<Result<Vec<Kept>, String>>> {
        let one = |raw: &Vec<u8>| -> Result<Vec<Kept>, String> {
            let mut kept = Vec::new();
            chunk_records(raw, |opcode, data| {
                if opcode == op::MESSAGE {
                    if let Record::Message { header, data } =
                        mcap::parse_record(opcode, data).map_err(|e| e.to_string())?
                    {
                        if let Some(&kind) = self.kinds.get(&header.channel_id) {
                            if self.wanted(kind) {
                                kept.push((kind, data.into_owned()));
                            }
                        }
                    }
                }
                Ok(())
            })?;
            Ok(kept)
        };
        let mut results: Vec<Option<Result<Vec<Kept>, String>>> = vec![None; tops.len()];
        let done: Vec<(usize, Result<Vec<Kept>, String>)> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..workers)
                .map(|w| {
                    let one = &one;
                    scope.spawn(move || {
                        (w..tops.len())
                            .step_by(workers)
                            .map(|i| (i, one(&tops[i])))
                            .collect::<Vec<_>>()
                    })
                })
                .collect();
            handles
                .into_iter()
                .flat_map(|h| h.join().unwrap_or_default())
                .collect()
        });
        for (i, r) in done {
            results[i] = Some(r);
        }
        results
    }

    fn message(&mut self, kind: Kind, data: &[u8]) -> Result<(), ReadError> {
        let rec = &mut self.rec;
        match kind {
            Kind::Raw => {
                rec.frames.push(rec.tlog.len());
                rec.tlog.extend_from_slice(data);
            }
            Kind::Inputs => {
                self.saw_inputs = true;
                let index = self.counts[0];
                self.counts[0] += 1;
                let bad = |what: String| ReadError::Bad {
                    topic: layout::INPUTS,
                    index,
                    what,
                };
                let (input, setup, link) = layout::input_with_setup(data).ok_or_else(|| {
                    bad(format!("not an input: {}", String::from_utf8_lossy(data)))
                })?;
                if let Some(setup) = setup {
                    rec.setup = Some(
                        layout::setup_from(&setup)
                            .ok_or_else(|| bad(format!("not an elaboration setup: {setup}")))?,
                    );
                }
                if let (Some(link), Input::Frame(frame)) = (link, &input.2) {
                    rec.links.insert(*frame, link);
                }
                rec.inputs.push(input);
            }
            Kind::Effects => {
                let index = self.counts[1];
                self.counts[1] += 1;
                let bad = |what: String| ReadError::Bad {
                    topic: layout::EFFECTS,
                    index,
                    what,
                };
                let mut v: Json = serde_json::from_slice(data).map_err(|e| bad(e.to_string()))?;
                let seq = v
                    .as_object_mut()
                    .and_then(|o| o.remove("seq"))
                    .and_then(|s| s.as_u64())
                    .ok_or_else(|| bad("no seq".into()))?;
                rec.steps.entry(seq).or_default().effects.push(v);
            }
            Kind::Digests => {
                let index = self.counts[2];
                self.counts[2] += 1;
                let line: DigestLine =
                    serde_json::from_slice(data).map_err(|e| ReadError::Bad {
                        topic: layout::DIGESTS,
                        index,
                        what: e.to_string(),
                    })?;
                let step = rec.steps.entry(line.seq).or_default();
                step.digest = Some(line.digest.into_owned());
                step.boot_ms = line.boot_ms;
            }
            Kind::Recorder => {
                if let Ok(v) = serde_json::from_slice::<Json>(data) {
                    if let Some(d) = v.get("dropped").and_then(Json::as_u64) {
                        rec.dropped = rec.dropped.max(d);
                    }
                    if let Some(d) = v.get("dropped_steps").and_then(Json::as_u64) {
                        rec.dropped_steps = rec.dropped_steps.max(d);
                    }
                }
            }
        }
        Ok(())
    }

    fn finish(self) -> Result<Recording, ReadError> {
        if !self.saw_inputs {
            if let Some(cut) = &self.rec.cut {
                return Err(ReadError::CutBeforeStart(cut.clone()));
            }
            return Err(ReadError::NotPetrel);
        }
        Ok(self.rec)
    }
}
