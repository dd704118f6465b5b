//! The operator dialog (docs/mirror.md, "Operator dialog"), sans-IO.
//!
//! - [`Dialog`]: the questions pending, as the player that plays the nets
//!   (the replica on the ground, the supervisor on board) asked them: its
//!   [`Effect::Ask`] effects open one, `Answered` / `Unanswered` /
//!   `Forgotten` close it. It gives the countdown at a vehicle time and
//!   builds the answer record, refusing a choice not offered. A web page
//!   shows the same state.
//! - [`answer_frame`]: the answer as a MAVLink 2 *signed* TUNNEL frame (the
//!   operator key, rust-mavlink's signature through [`Signer`]).
//! - [`AnswerGate`]: on board, judges an answer frame: unsigned, wrongly
//!   signed, replayed or stale frames are rejected and counted, never
//!   delivered; a valid one gives (question id, choice) for the player,
//!   which refuses it if it comes late ([`AnswerGate::rejected`] counts it as [`AnswerRejection::Late`]).

use std::collections::BTreeMap;

use mavlink::{MAVLinkMessageRaw, MAVLinkV2MessageRaw, MavHeader};
use nets::player::{AnswerRefusal, Effect};
use nets::{Micros, Project};

use super::record::{self, Record};
use super::tunnel::{Tunnel, PAYLOAD_TYPE};
use crate::signing::{Key, Rejection, Signer, Verifier};

/// A question pending.
#[derive(Debug, Clone, PartialEq)]
pub struct Question {
    pub id: u64,
    /// The asking net.
    pub net: String,
    /// The ask's name (`NAME` of `NAME.CHOICE`).
    pub ask: String,
    pub question: String,
    pub choices: Vec<String>,
    /// The vehicle time the timeout fires at.
    pub deadline: Micros,
}

impl Question {
    /// Time left at vehicle time `now` (0 once due).
    pub fn remaining(&self, now: Micros) -> Micros {
        self.deadline.saturating_sub(now)
    }
}

/// Why the operator's answer is not sent.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DialogError {
    #[error("no question #{0} is pending")]
    NotPending(u64),
    #[error("`{choice}` is not a choice of question #{id} (its choices: {offered})")]
    NotOffered {
        id: u64,
        choice: String,
        offered: String,
    },
}

/// The questions pending.
#[derive(Debug, Clone, Default)]
pub struct Dialog {
    questions: BTreeMap<u64, Question>,
}

impl Dialog {
    pub fn new() -> Dialog {
        Dialog::default()
    }

    /// Follows one effect of the player.
    pub fn observe(&mut self, project: &Project, effect: &Effect) {
        match effect {
            Effect::Ask {
                id,
                net,
                ask,
                question,
                choices,
                deadline,
                ..
            } => {
                let n = &project.nets[*net];
                self.questions.insert(
                    *id,
                    Question {
                        id: *id,
                        net: n.name.clone(),
                        ask: n
                            .asks
                            .get(*ask)
                            .map_or_else(String::new, |a| a.name.clone()),
                        question: question.clone(),
                        choices: choices.clone(),
                        deadline: *deadline,
                    },
                );
            }
            Effect::Answered { id, .. }
            | Effect::Unanswered { id, .. }
            | Effect::Forgotten { id, .. } => {
                self.questions.remove(id);
            }
            _ => {}
        }
    }

    /// After a snapshot restore: keeps only the questions `player` still
    /// has pending (a question asked while the replica was restoring is
    /// shown by its ask's name, its text being in the step not seen).
    pub fn sync(&mut self, player: &nets::Player) {
        let project = player.project().clone();
        let pending: Vec<(u64, usize, usize)> = player.questions().collect();
        self.questions
            .retain(|id, _| pending.iter().any(|(p, _, _)| p == id));
        for (id, net, ask) in pending {
            self.questions.entry(id).or_insert_with(|| {
                let n = &project.nets[net];
                let a = &n.asks[ask];
                let deadline = player
                    .state()
                    .timers
                    .iter()
                    .find(|t| t.net == net && t.timer == a.timer)
                    .map_or(0, |t| t.deadline);
                Question {
                    id,
                    net: n.name.clone(),
                    ask: a.name.clone(),
                    question: a.name.clone(),
                    choices: a.choices.clone(),
                    deadline,
                }
            });
        }
    }

    /// The questions pending, oldest first.
    pub fn pending(&self) -> impl Iterator<Item = &Question> {
        self.questions.values()
    }

    /// The uplink record answering question `id` with `choice`.
    pub fn answer(&self, id: u64, choice: &str) -> Result<Record, DialogError> {
        let q = self.questions.get(&id).ok_or(DialogError::NotPending(id))?;
        if !q.choices.iter().any(|c| c == choice) {
            return Err(DialogError::NotOffered {
                id,
                choice: choice.to_owned(),
                offered: q.choices.join(", "),
            });
        }
        Ok(Record::Answer {
            id,
            choice: choice.to_owned(),
        })
    }
}

/// The answer record as a signed TUNNEL frame from `from` to the onboard
/// gateway `to` (system, component): what `UplinkWriter::send_answer`
/// sends, built without a link (tests, and a web page's backend later).
pub fn answer_frame(
    signer: &mut Signer,
    from: (u8, u8),
    sequence: u8,
    to: (u8, u8),
    answer: &Record,
    unix_us: u64,
) -> MAVLinkV2MessageRaw {
    let tunnel = Tunnel::petrel(to, record::packet(std::slice::from_ref(answer)));
    let header = MavHeader {
        system_id: from.0.into(),
        component_id: from.1,
        sequence,
    };
    signer.sign_data(header, &tunnel, unix_us)
}

/// Why an answer frame is not delivered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum AnswerRejection {
    Unsigned,
    BadSignature,
    Replayed,
    Stale,
    /// Signed, but not a Petrel TUNNEL holding one answer record.
    Malformed,
    /// Valid, but its question was no longer pending (timed out, answered,
    /// forgotten): refused by the player.
    Late,
    /// Valid, but the choice is not one the question offers.
    NotOffered,
}

impl AnswerRejection {
    pub fn as_str(self) -> &'static str {
        match self {
            AnswerRejection::Unsigned => "unsigned",
            AnswerRejection::BadSignature => "bad signature",
            AnswerRejection::Replayed => "replayed",
            AnswerRejection::Stale => "stale",
            AnswerRejection::Malformed => "malformed",
            AnswerRejection::Late => "late",
            AnswerRejection::NotOffered => "not offered",
        }
    }
}

impl From<Rejection> for AnswerRejection {
    fn from(r: Rejection) -> AnswerRejection {
        match r {
            Rejection::Unsigned => AnswerRejection::Unsigned,
            Rejection::BadSignature => AnswerRejection::BadSignature,
            Rejection::Replayed => AnswerRejection::Replayed,
            Rejection::Stale => AnswerRejection::Stale,
        }
    }
}

/// On board: judges the answer frames received.
#[derive(Debug)]
pub struct AnswerGate {
    verifier: Verifier,
    rejected: BTreeMap<AnswerRejection, u64>,
    delivered: u64,
}

impl AnswerGate {
    /// `key`: the operator key (signatures are required).
    pub fn new(key: Key) -> AnswerGate {
        AnswerGate {
            verifier: Verifier::new(key, true),
            rejected: BTreeMap::new(),
            delivered: 0,
        }
    }

    /// Judges a frame carrying an answer, received at `unix_us`: the
    /// question id and choice to give the player, or why not (counted).
    pub fn judge(
        &mut self,
        frame: &MAVLinkMessageRaw,
        unix_us: u64,
    ) -> Result<(u64, String), AnswerRejection> {
        let judged = self
            .verifier
            .check(frame, unix_us)
            .map_err(AnswerRejection::from)
            .and_then(|()| answer_of(frame).ok_or(AnswerRejection::Malformed));
        match &judged {
            Ok(_) => {}
            Err(r) => *self.rejected.entry(*r).or_default() += 1,
        }
        judged
    }

    /// Judges a frame carrying upload records (`mirror::upload`) as
    /// received on the wire: signed with the operator key like an answer,
    /// fresh and not replayed; the records, or why not (counted).
    pub fn judge_upload(
        &mut self,
        bytes: &[u8],
        unix_us: u64,
    ) -> Result<Vec<Record>, AnswerRejection> {
        let frame = self.signed_frame(bytes)?;
        let judged = self
            .verifier
            .check(&frame, unix_us)
            .map_err(AnswerRejection::from)
            .and_then(|()| upload_of(&frame).ok_or(AnswerRejection::Malformed));
        if let Err(r) = &judged {
            *self.rejected.entry(*r).or_default() += 1;
        }
        judged
    }

    /// The bytes as a MAVLink 2 frame (a MAVLink 1 frame cannot be signed).
    fn signed_frame(&mut self, bytes: &[u8]) -> Result<MAVLinkMessageRaw, AnswerRejection> {
        let mut raw = MAVLinkV2MessageRaw::new();
        if bytes.first() == Some(&mavlink::MAV_STX_V2) && bytes.len() <= raw.as_mut_slice().len() {
            raw.as_mut_slice()[..bytes.len()].copy_from_slice(bytes);
            Ok(MAVLinkMessageRaw::V2(raw))
        } else {
            *self.rejected.entry(AnswerRejection::Unsigned).or_default() += 1;
            Err(AnswerRejection::Unsigned)
        }
    }

    /// Judges a frame as received on the wire (bytes): a MAVLink 1 frame
    /// cannot be signed.
    pub fn judge_bytes(
        &mut self,
        bytes: &[u8],
        unix_us: u64,
    ) -> Result<(u64, String), AnswerRejection> {
        let frame = self.signed_frame(bytes)?;
        self.judge(&frame, unix_us)
    }

    /// The player's verdict on an answer the gate let through.
    pub fn delivered(&mut self, verdict: Result<(), AnswerRefusal>) {
        match verdict {
            Ok(()) => self.delivered += 1,
            Err(AnswerRefusal::NotPending) => {
                *self.rejected.entry(AnswerRejection::Late).or_default() += 1
            }
            Err(AnswerRefusal::NotOffered) => {
                *self
                    .rejected
                    .entry(AnswerRejection::NotOffered)
                    .or_default() += 1
            }
        }
    }

    /// Answers delivered to the player.
    pub fn delivered_count(&self) -> u64 {
        self.delivered
    }

    /// Answers rejected, by reason.
    pub fn rejected(&self) -> &BTreeMap<AnswerRejection, u64> {
        &self.rejected
    }
}

/// The player's verdict on answer `id`, read off a step's effects: `None`
/// when the effects say nothing of it.
pub fn verdict(effects: &[Effect], id: u64) -> Option<Result<(), AnswerRefusal>> {
    effects.iter().find_map(|e| match e {
        Effect::Answered { id: i, .. } if *i == id => Some(Ok(())),
        Effect::AnswerRefused { id: i, reason, .. } if *i == id => Some(Err(*reason)),
        _ => None,
    })
}

/// Whether a Petrel TUNNEL payload is an answer (to judge with the gate,
/// not to hand the publisher).
pub fn is_answer(payload: &[u8]) -> bool {
    matches!(
        record::decode_packet(payload).as_deref(),
        Ok([Record::Answer { .. }])
    )
}

/// Whether a Petrel TUNNEL payload holds upload records (to judge with
/// the gate, not to hand the publisher).
pub fn is_upload(payload: &[u8]) -> bool {
    record::decode_packet(payload).is_ok_and(|records| {
        !records.is_empty()
            && records
                .iter()
                .all(|r| matches!(r, Record::Upload { .. } | Record::Piece { .. }))
    })
}

/// The upload records a signed Petrel TUNNEL frame holds (only those).
fn upload_of(frame: &MAVLinkMessageRaw) -> Option<Vec<Record>> {
    let payload = petrel_payload(frame)?;
    let records = record::decode_packet(&payload).ok()?;
    is_upload(&payload).then_some(records)
}

/// The payload of a Petrel TUNNEL frame.
fn petrel_payload(frame: &MAVLinkMessageRaw) -> Option<Vec<u8>> {
    use mavlink::MessageData;
    if frame.message_id() != mavlink::dialects::ardupilotmega::TUNNEL_DATA::ID {
        return None;
    }
    let version = match frame {
        MAVLinkMessageRaw::V1(_) => mavlink::MavlinkVersion::V1,
        MAVLinkMessageRaw::V2(_) => mavlink::MavlinkVersion::V2,
    };
    let tunnel = Tunnel::deser(version, frame.payload()).ok()?;
    (tunnel.payload_type == PAYLOAD_TYPE).then_some(tunnel.payload)
}

/// The answer record a Petrel TUNNEL frame holds, if it holds exactly one.
fn answer_of(frame: &MAVLinkMessageRaw) -> Option<(u64, String)> {
    match record::decode_packet(&petrel_payload(frame)?)
        .ok()?
        .as_slice()
    {
        [Record::Answer { id, choice }] => Some((*id, choice.clone())),
        _ => None,
    }
}

#[cfg(test)]
mod tests;
