//! Reading a Petrel recording back for replay: the inputs in order, the raw
//! frames they refer to, and (when checking) the effects and digest of each
//! step. A file cut short (power loss: no summary, a half-written chunk) is
//! read up to its last complete chunk and says where it was cut.

use std::collections::HashMap;

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
    /// The elaboration config and profile name recorded with the start.
    pub setup: Option<(elaboration::Config, String)>,
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

/// Reads `bytes`, a Petrel MCAP; with `expectations`, also each step's
/// effects and digest (for `--check-against`).
pub fn read(bytes: &[u8], expectations: bool) -> Result<Recording, ReadError> {
    if bytes.len() < mcap::MAGIC.len() || &bytes[..mcap::MAGIC.len()] != mcap::MAGIC {
        return Err(ReadError::NotMcap("no MCAP magic at the start".into()));
    }
    let stream = mcap::MessageStream::new(bytes).map_err(|e| ReadError::NotMcap(e.to_string()))?;
    let mut rec = Recording::default();
    let mut saw_inputs = false;
    let mut count_inputs = 0u64;
    let mut count_effects = 0u64;
    let mut count_digests = 0u64;
    for message in stream {
        let message = match message {
            Ok(m) => m,
            Err(e) => {
                rec.cut = Some(e.to_string());
                break;
            }
        };
        let topic = message.channel.topic.as_str();
        let json = |topic: &'static str, index: u64| {
            serde_json::from_slice::<Json>(&message.data).map_err(|e| ReadError::Bad {
                topic,
                index,
                what: e.to_string(),
            })
        };
        match topic {
            layout::RAW => {
                rec.frames.push(rec.tlog.len());
                rec.tlog.extend_from_slice(&message.data);
            }
            layout::INPUTS => {
                saw_inputs = true;
                let bad = |what: String| ReadError::Bad {
                    topic: layout::INPUTS,
                    index: count_inputs,
                    what,
                };
                let (input, setup) = layout::input_with_setup(&message.data).ok_or_else(|| {
                    bad(format!(
                        "not an input: {}",
                        String::from_utf8_lossy(&message.data)
                    ))
                })?;
                if let Some(setup) = setup {
                    rec.setup = Some(
                        layout::setup_from(&setup)
                            .ok_or_else(|| bad(format!("not an elaboration setup: {setup}")))?,
                    );
                }
                rec.inputs.push(input);
                count_inputs += 1;
            }
            layout::EFFECTS if expectations => {
                let mut v = json(layout::EFFECTS, count_effects)?;
                count_effects += 1;
                let seq = v
                    .as_object_mut()
                    .and_then(|o| o.remove("seq"))
                    .and_then(|s| s.as_u64())
                    .ok_or_else(|| ReadError::Bad {
                        topic: layout::EFFECTS,
                        index: count_effects - 1,
                        what: "no seq".into(),
                    })?;
                rec.steps.entry(seq).or_default().effects.push(v);
            }
            layout::DIGESTS if expectations => {
                let line: DigestLine =
                    serde_json::from_slice(&message.data).map_err(|e| ReadError::Bad {
                        topic: layout::DIGESTS,
                        index: count_digests,
                        what: e.to_string(),
                    })?;
                count_digests += 1;
                let step = rec.steps.entry(line.seq).or_default();
                step.digest = Some(line.digest.into_owned());
                step.boot_ms = line.boot_ms;
            }
            layout::RECORDER => {
                if let Ok(v) = serde_json::from_slice::<Json>(&message.data) {
                    if let Some(d) = v.get("dropped").and_then(Json::as_u64) {
                        rec.dropped = rec.dropped.max(d);
                    }
                    if let Some(d) = v.get("dropped_steps").and_then(Json::as_u64) {
                        rec.dropped_steps = rec.dropped_steps.max(d);
                    }
                }
            }
            _ => {}
        }
    }
    if !saw_inputs {
        if let Some(cut) = &rec.cut {
            return Err(ReadError::NotMcap(cut.clone()));
        }
        return Err(ReadError::NotPetrel);
    }
    rec.finished = rec.cut.is_none() && matches!(mcap::Summary::read(bytes), Ok(Some(_)));
    Ok(rec)
}
