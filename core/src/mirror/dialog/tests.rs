//! The dialog end to end, sans-IO: the real `Supervisor` on board with the
//! answer gate, the publisher, the replica on the ground with its
//! [`Dialog`], and answers as signed MAVLink 2 frames.

use std::collections::BTreeMap;
use std::sync::Arc;

use mavlink::{MAVLinkMessageRaw, MAVLinkV2MessageRaw, MavHeader};
use nets::{Event, Micros, Project};

use super::*;
use crate::mirror::publisher::{self, Publisher};
use crate::mirror::replica::{self, Replica, Report};
use crate::mirror::step_inputs;
use crate::supervisor::{Input, Supervisor};

const S: Micros = 1_000_000;
/// The ground's and the vehicle's wall clock at vehicle time 0 (2026).
const UNIX0: u64 = 1_780_000_000_000_000;
const GATEWAY: (u8, u8) = (1, 191);
const MIRROR: (u8, u8) = (245, 190);

const NET: &str = r#"name = "N"
places = ["idle", "asking", "surveying", "skipped", "timed_out"]
initial = ["idle"]
[[transition]]
name = "ask"
from = ["idle"]
to = ["asking"]
on = "reached_t2"
do = ['ask survey "Survey T2?" {choices: [yes, no]} timeout 60s']
[[transition]]
name = "yes"
from = ["asking"]
to = ["surveying"]
on = "survey.yes"
[[transition]]
name = "no"
from = ["asking"]
to = ["skipped"]
on = "survey.no"
[[transition]]
name = "timeout"
from = ["asking"]
to = ["timed_out"]
on = "survey.timeout"
"#;

fn project() -> Arc<Project> {
    let sources: BTreeMap<String, String> = [
        (
            "project.toml".to_owned(),
            "[events]\nreached_t2 = {}\n[[net]]\nfile = \"n.toml\"\nactive = true\n".to_owned(),
        ),
        ("n.toml".to_owned(), NET.to_owned()),
    ]
    .into();
    Arc::new(nets::load(&sources).expect("loads"))
}

fn key(b: u8) -> Key {
    Key::new([b; 32])
}

struct Dialogue {
    project: Arc<Project>,
    supervisor: Supervisor,
    publisher: Publisher,
    replica: Replica,
    dialog: Dialog,
    gate: AnswerGate,
    signer: Signer,
    now: Micros,
    sequence: u8,
}

impl Dialogue {
    fn new() -> Dialogue {
        let project = project();
        let (supervisor, _) = Supervisor::start(
            project.clone(),
            elaboration::Profile::builtin("ardupilot").expect("the built-in profile"),
            elaboration::Config::default(),
            0,
        );
        let mut d = Dialogue {
            replica: Replica::new(project.clone(), replica::Config::default()),
            project,
            supervisor,
            publisher: Publisher::new(3, publisher::Config::default(), 0),
            dialog: Dialog::new(),
            gate: AnswerGate::new(key(7)),
            signer: Signer::new(key(7), 1, None),
            now: 0,
            sequence: 0,
        };
        d.exchange();
        d
    }

    fn feed(&mut self, input: Input) -> Vec<Effect> {
        let before = self.supervisor.player().state().now;
        let step = self.supervisor.step(self.now, input.clone());
        if let Some(inputs) = step_inputs(&input, &step, &crate::mirror::Unread::none()) {
            self.publisher.step(
                step.seq,
                before,
                step.time,
                inputs,
                &self.supervisor.player().digest(),
            );
        }
        self.exchange();
        let mut effects = step.effects;
        effects.extend(step.events.into_iter().flat_map(|(_, e)| e));
        effects
    }

    fn exchange(&mut self) {
        self.publisher
            .tick(self.now, self.supervisor.seq(), self.supervisor.player());
        while let Some(p) = self.publisher.poll_transmit() {
            self.replica.receive(self.now, &p);
        }
        self.replica.tick(self.now);
        while let Some(u) = self.replica.poll_transmit() {
            self.publisher.receive(u.bytes());
        }
        while let Some(r) = self.replica.poll_report() {
            match r {
                Report::Step { effects, .. } | Report::Timers { effects, .. } => {
                    for e in &effects {
                        self.dialog.observe(&self.project, e);
                    }
                }
                Report::Diverged { .. } => panic!("diverged: {r:?}"),
                _ => {}
            }
        }
    }

    fn wait(&mut self, until: Micros) {
        while self.now < until {
            self.now = (self.now + S / 2).min(until);
            self.feed(Input::Tick);
        }
    }

    /// The ground's answer, as a signed frame.
    fn answer(&mut self, id: u64, choice: &str) -> MAVLinkMessageRaw {
        let record = self.dialog.answer(id, choice).expect("a valid answer");
        self.sequence = self.sequence.wrapping_add(1);
        MAVLinkMessageRaw::V2(answer_frame(
            &mut self.signer,
            MIRROR,
            self.sequence,
            GATEWAY,
            &record,
            UNIX0 + self.now,
        ))
    }

    /// The frame arrives on board: judged, and if let through, played.
    fn receive(&mut self, frame: &MAVLinkMessageRaw) -> Result<(), AnswerRejection> {
        let (id, choice) = self.gate.judge(frame, UNIX0 + self.now)?;
        let effects = self.feed(Input::Answer { id, choice });
        let v = verdict(&effects, id).expect("the player's verdict");
        self.gate.delivered(v);
        v.map_err(|r| match r {
            AnswerRefusal::NotPending => AnswerRejection::Late,
            AnswerRefusal::NotOffered => AnswerRejection::NotOffered,
        })
    }

    fn ask(&mut self) -> u64 {
        self.now += 10 * S;
        self.feed(Input::Event(Event::new("reached_t2")));
        let q: Vec<&super::Question> = self.dialog.pending().collect();
        assert_eq!(q.len(), 1, "the ground sees the question");
        assert_eq!(q[0].question, "Survey T2?");
        assert_eq!(q[0].choices, ["yes", "no"]);
        assert_eq!(q[0].remaining(self.now), 60 * S);
        q[0].id
    }

    fn marking(&self) -> Vec<String> {
        let p = self.supervisor.player();
        let net = &self.project.nets[0];
        (0..net.places.len())
            .filter(|&i| p.is_marked(0, nets::model::PlaceRef::Local(i)))
            .map(|i| net.places[i].name.clone())
            .collect()
    }

    fn assert_equal(&self) {
        let vehicle = self.supervisor.player();
        let mut exact = self.replica.exact().expect("the replica is exact").clone();
        exact.advance(vehicle.state().now);
        assert_eq!(exact.digest(), vehicle.digest());
    }
}

#[test]
fn an_answer_in_time_is_delivered_with_each_choice_and_the_replica_stays_equal() {
    for (choice, place) in [("yes", "surveying"), ("no", "skipped")] {
        let mut d = Dialogue::new();
        let id = d.ask();
        d.wait(40 * S);
        assert_eq!(
            d.dialog.pending().next().map(|q| q.remaining(d.now)),
            Some(30 * S),
            "the countdown"
        );
        let frame = d.answer(id, choice);
        assert_eq!(d.receive(&frame), Ok(()));
        assert_eq!(d.marking(), [place]);
        assert_eq!(d.dialog.pending().count(), 0, "the ground saw the answer");
        d.wait(80 * S);
        assert_eq!(d.marking(), [place], "no timeout after the answer");
        assert_eq!(d.gate.delivered_count(), 1);
        assert!(d.gate.rejected().is_empty());
        d.assert_equal();
    }
}

#[test]
fn unsigned_wrongly_signed_replayed_and_late_answers_are_rejected_and_counted() {
    let mut d = Dialogue::new();
    let id = d.ask();
    d.now += S;
    let record = d.dialog.answer(id, "yes").expect("valid");
    let tunnel = Tunnel {
        payload_type: PAYLOAD_TYPE,
        target_system: GATEWAY.0,
        target_component: GATEWAY.1,
        payload: record::packet(std::slice::from_ref(&record)),
    };
    // Unsigned.
    let mut raw = MAVLinkV2MessageRaw::new();
    raw.serialize_message_data(
        MavHeader {
            system_id: MIRROR.0.into(),
            component_id: MIRROR.1,
            sequence: 0,
        },
        &tunnel,
    );
    assert_eq!(
        d.receive(&MAVLinkMessageRaw::V2(raw)),
        Err(AnswerRejection::Unsigned)
    );
    // Signed with another key.
    let mut stranger = Signer::new(key(8), 1, None);
    let forged = answer_frame(&mut stranger, MIRROR, 1, GATEWAY, &record, UNIX0 + d.now);
    assert_eq!(
        d.receive(&MAVLinkMessageRaw::V2(forged)),
        Err(AnswerRejection::BadSignature)
    );
    // Altered after signing: the choice changed.
    let mut altered = match d.answer(id, "yes") {
        MAVLinkMessageRaw::V2(raw) => raw,
        MAVLinkMessageRaw::V1(_) => unreachable!(),
    };
    // The last payload byte (after the 10 bytes of STX and header).
    let at = 10 + altered.payload().len() - 1;
    altered.as_mut_slice()[at] ^= 0x01;
    assert_eq!(
        d.receive(&MAVLinkMessageRaw::V2(altered)),
        Err(AnswerRejection::BadSignature)
    );
    assert_eq!(d.marking(), ["asking"], "nothing delivered yet");
    // A valid one, then the same frame replayed.
    let valid = d.answer(id, "no");
    let copy = match &valid {
        MAVLinkMessageRaw::V2(raw) => MAVLinkMessageRaw::V2(*raw),
        MAVLinkMessageRaw::V1(_) => unreachable!(),
    };
    assert_eq!(d.receive(&valid), Ok(()));
    assert_eq!(d.receive(&copy), Err(AnswerRejection::Replayed));
    assert_eq!(d.marking(), ["skipped"]);
    // A second question: answered after its timeout.
    let mut late = Dialogue::new();
    let id = late.ask();
    let old = late.answer(id, "yes"); // signed at 10 s…
    late.wait(69 * S);
    let frame = late.answer(id, "yes"); // …and at 69 s, in time…
    late.wait(71 * S); // …both arrive after the deadline
    assert_eq!(late.marking(), ["timed_out"]);
    assert_eq!(
        late.dialog.pending().count(),
        0,
        "the ground saw the timeout"
    );
    assert_eq!(late.receive(&frame), Err(AnswerRejection::Late));
    // A first frame of its stream more than a minute old: stale (replayed
    // from an old recording, say).
    let mut fresh = Dialogue::new();
    fresh.ask();
    fresh.wait(71 * S);
    assert_eq!(fresh.receive(&old), Err(AnswerRejection::Stale));
    assert_eq!(late.marking(), ["timed_out"]);
    late.assert_equal();
    d.assert_equal();
    let counts = |g: &AnswerGate| {
        g.rejected()
            .iter()
            .map(|(r, n)| (r.as_str(), *n))
            .collect::<Vec<_>>()
    };
    assert_eq!(
        counts(&d.gate),
        [("unsigned", 1), ("bad signature", 2), ("replayed", 1)]
    );
    assert_eq!(d.gate.delivered_count(), 1);
    assert_eq!(counts(&late.gate), [("late", 1)]);
    assert_eq!(counts(&fresh.gate), [("stale", 1)]);
    assert_eq!(late.gate.delivered_count(), 0);
}

#[test]
fn the_ground_refuses_to_send_a_choice_not_offered_or_for_no_question() {
    let mut d = Dialogue::new();
    let id = d.ask();
    assert!(matches!(
        d.dialog.answer(id, "maybe"),
        Err(DialogError::NotOffered { .. })
    ));
    assert_eq!(
        d.dialog.answer(id + 1, "yes"),
        Err(DialogError::NotPending(id + 1))
    );
}

/// The pieces of a version sent up pass the operator's gate as answers do:
/// signed with the operator key, fresh and never replayed; anything else
/// is refused, counted, and never reaches the receiver.
#[test]
fn upload_frames_pass_the_gate_only_signed_with_the_operator_key() {
    let mut gate = AnswerGate::new(key(7));
    let piece = Record::Piece {
        upload: 3,
        index: 0,
        data: vec![1, 2, 3],
    };
    let tunnel = Tunnel::petrel(GATEWAY, record::packet(std::slice::from_ref(&piece)));
    let header = MavHeader {
        system_id: MIRROR.0.into(),
        component_id: MIRROR.1,
        sequence: 0,
    };
    assert!(is_upload(&tunnel.payload) && !is_answer(&tunnel.payload));
    let mut signer = Signer::new(key(7), 1, None);
    let signed = signer.sign_data(header, &tunnel, UNIX0);
    let bytes = signed.raw_bytes().to_vec();
    assert_eq!(gate.judge_upload(&bytes, UNIX0), Ok(vec![piece.clone()]));
    assert_eq!(
        gate.judge_upload(&bytes, UNIX0),
        Err(AnswerRejection::Replayed)
    );
    let mut unsigned = MAVLinkV2MessageRaw::new();
    unsigned.serialize_message_data(header, &tunnel);
    assert_eq!(
        gate.judge_upload(unsigned.raw_bytes(), UNIX0),
        Err(AnswerRejection::Unsigned)
    );
    let mut stranger = Signer::new(key(8), 1, None);
    let forged = stranger.sign_data(header, &tunnel, UNIX0 + 1_000);
    assert_eq!(
        gate.judge_upload(forged.raw_bytes(), UNIX0 + 1_000),
        Err(AnswerRejection::BadSignature)
    );
    let mut altered = signer.sign_data(header, &tunnel, UNIX0 + 2_000);
    let at = 10 + altered.payload().len() - 1;
    altered.as_mut_slice()[at] ^= 0x01;
    assert_eq!(
        gate.judge_upload(altered.raw_bytes(), UNIX0 + 2_000),
        Err(AnswerRejection::BadSignature)
    );
    // An answer through the upload door is no upload.
    let answer = answer_frame(
        &mut signer,
        MIRROR,
        1,
        GATEWAY,
        &Record::Answer {
            id: 1,
            choice: "yes".into(),
        },
        UNIX0 + 3_000,
    );
    assert_eq!(
        gate.judge_upload(answer.raw_bytes(), UNIX0 + 3_000),
        Err(AnswerRejection::Malformed)
    );
    let counted: u64 = gate.rejected().values().sum();
    assert_eq!(counted, 5);
}
