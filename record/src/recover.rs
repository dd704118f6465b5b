//! A damaged or unfinished MCAP copied whole into a clean, indexed one
//! (`petrel recover`): every record up to the damage (schemas, channels,
//! messages, metadata, attachments), in order and with their ids, chunk by
//! chunk as they were, then the summary, the chunk and message indexes and
//! the statistics a clean finish writes. Any MCAP, not only Petrel's.

use std::io::{Seek, Write};

use mcap::records::{op, Record};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

use super::read::chunk_records;

/// What was copied.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct Recovered {
    /// Chunks copied whole.
    pub chunks: u64,
    pub messages: u64,
    pub schemas: u64,
    pub channels: u64,
    pub metadata: u64,
    pub attachments: u64,
    /// The first and last log times of the messages copied (ns).
    pub log_times: Option<(u64, u64)>,
    /// Where and why the file stopped being readable, if it did before its
    /// end: the rest is lost.
    pub cut: Option<String>,
    /// Whether the file had its summary (it was finished cleanly).
    pub had_summary: bool,
}

/// Why nothing could be copied.
#[derive(Debug, thiserror::Error)]
pub enum RecoverError {
    #[error("not an MCAP file: {0}")]
    NotMcap(String),
    #[error("cannot write the copy: {0}")]
    Write(String),
}

impl From<mcap::McapError> for RecoverError {
    fn from(e: mcap::McapError) -> Self {
        let mut text = e.to_string();
        if let Some(source) = std::error::Error::source(&e) {
            text = format!("{text}: {source}");
        }
        RecoverError::Write(text)
    }
}

/// The largest record believed outside chunks: the file itself bounds it.
fn reader(len: usize) -> LinearReader {
    LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_emit_chunks(true)
            .with_record_length_limit(len),
    )
}

/// Copies what `bytes` holds into a new MCAP written to `out`.
pub fn recover<W: Write + Seek>(bytes: &[u8], out: W) -> Result<Recovered, RecoverError> {
    if bytes.len() < mcap::MAGIC.len() || &bytes[..mcap::MAGIC.len()] != mcap::MAGIC {
        return Err(RecoverError::NotMcap("no MCAP magic at the start".into()));
    }
    let mut top = reader(bytes.len());
    let mut fed = false;
    let mut copy = Copy {
        out: None,
        sink: Some(out),
        got: Recovered::default(),
    };
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
            Err(e) => {
                copy.got.cut = Some(e.to_string());
                break;
            }
        };
        match opcode {
            op::DATA_END => {
                copy.got.had_summary = super::fields::has_summary(bytes);
                break;
            }
            op::CHUNK => {
                // The chunk is checked whole (its CRC, every record) before
                // any of it is copied.
                let mut raw = Vec::with_capacity(9 + data.len());
                raw.push(op::CHUNK);
                raw.extend_from_slice(&(data.len() as u64).to_le_bytes());
                raw.extend_from_slice(data);
                let mut records = Vec::new();
                let whole = chunk_records(&raw, |op, data| {
                    records.push((op, data.to_vec()));
                    Ok(())
                });
                if let Err(e) = whole {
                    copy.got.cut = Some(format!("a damaged chunk: {e}"));
                    break;
                }
                for (op, data) in &records {
                    if let Err(e) = copy.record(*op, data) {
                        match e {
                            Fault::Cut(e) => copy.got.cut = Some(e),
                            Fault::Write(e) => return Err(e),
                        }
                        break;
                    }
                }
                if copy.got.cut.is_some() {
                    break;
                }
                copy.got.chunks += 1;
                copy.writer(None)?.flush()?;
            }
            _ => {
                if let Err(e) = copy.record(opcode, data) {
                    match e {
                        Fault::Cut(e) => copy.got.cut = Some(e),
                        Fault::Write(e) => return Err(e),
                    }
                    break;
                }
            }
        }
    }
    let Copy { out, got, .. } = copy;
    let Some(mut out) = out else {
        return Err(RecoverError::NotMcap(
            got.cut.unwrap_or_else(|| "no header record".into()),
        ));
    };
    out.finish()?;
    Ok(got)
}

enum Fault {
    /// The input is damaged here.
    Cut(String),
    Write(RecoverError),
}

impl From<mcap::McapError> for Fault {
    fn from(e: mcap::McapError) -> Self {
        Fault::Write(e.into())
    }
}

struct Copy<W: Write + Seek> {
    out: Option<mcap::Writer<W>>,
    sink: Option<W>,
    got: Recovered,
}

impl<W: Write + Seek> Copy<W> {
    /// The writer, created with the input's header profile.
    fn writer(&mut self, profile: Option<&str>) -> Result<&mut mcap::Writer<W>, RecoverError> {
        if self.out.is_none() {
            let Some(sink) = self.sink.take() else {
                return Err(RecoverError::Write("the copy was lost".into()));
            };
            self.out = Some(
                mcap::WriteOptions::new()
                    .compression(Some(mcap::Compression::Zstd))
                    .compression_threads(0)
                    .chunk_size(None)
                    .profile(profile.unwrap_or(""))
                    .create(sink)?,
            );
        }
        match &mut self.out {
            Some(w) => Ok(w),
            None => Err(RecoverError::Write("the copy was lost".into())),
        }
    }

    fn record(&mut self, opcode: u8, data: &[u8]) -> Result<(), Fault> {
        if !super::fields::lengths_fit(opcode, data) {
            return Err(Fault::Cut(format!(
                "a damaged record (opcode {opcode:#04x}): a length inside it runs past its end"
            )));
        }
        let record = mcap::parse_record(opcode, data)
            .map_err(|e| Fault::Cut(format!("a bad record (opcode {opcode:#04x}): {e}")))?;
        if self.out.is_none() {
            let Record::Header(h) = &record else {
                return Err(Fault::Cut("the file does not begin with a header".into()));
            };
            self.writer(Some(&h.profile)).map_err(Fault::Write)?;
            return Ok(());
        }
        let w = self.writer(None).map_err(Fault::Write)?;
        let bad = |e: mcap::McapError| Fault::Cut(e.to_string());
        match record {
            Record::Schema { header, data } => {
                w.add_schema_with_id(header.id, &header.name, &header.encoding, &data)
                    .map_err(bad)?;
                self.got.schemas += 1;
            }
            Record::Channel(c) => {
                w.add_channel_with_id(
                    c.id,
                    c.schema_id,
                    &c.topic,
                    &c.message_encoding,
                    &c.metadata,
                )
                .map_err(bad)?;
                self.got.channels += 1;
            }
            Record::Message { header, data } => {
                w.write_to_known_channel(&header, &data).map_err(bad)?;
                self.got.messages += 1;
                let t = header.log_time;
                self.got.log_times = Some(match self.got.log_times {
                    None => (t, t),
                    Some((a, b)) => (a.min(t), b.max(t)),
                });
            }
            Record::Metadata(m) => {
                w.write_metadata(&m)?;
                self.got.metadata += 1;
            }
            Record::Attachment { header, data, .. } => {
                w.attach(&mcap::Attachment {
                    log_time: header.log_time,
                    create_time: header.create_time,
                    name: header.name,
                    media_type: header.media_type,
                    data,
                })?;
                self.got.attachments += 1;
            }
            // Indexes and summaries are written anew; a second header is
            // damage.
            Record::Header(_) => return Err(Fault::Cut("a second header".into())),
            _ => {}
        }
        Ok(())
    }
}
