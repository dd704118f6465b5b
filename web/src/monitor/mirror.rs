//! The mirror's part of the board (docs/monitor.md, "On the mirror"):
//! whether the replica agrees with the vehicle (exact, provisional,
//! diverged; the last step found equal and the digest then), the
//! disagreements of the independent check with both sides' evidence, and
//! the operator's questions with their deadlines on the vehicle's time
//! and what became of each. Fed by `petrel mirror` from the replica's
//! reports, the check's disagreements and the dialog (`mirror_page.rs`);
//! it only reads them.

use std::collections::{BTreeMap, VecDeque};

use nets::player::Effect;
use nets::Micros;
use serde_json::{json, Value as Json};

use petrel_core::mirror::check::{Disagreement, Side};
use petrel_core::mirror::dialog::Dialog;
use petrel_core::mirror::replica::Report;

/// Disagreements kept for the page (the count says how many in all).
const DISAGREEMENTS: usize = 50;
/// Questions closed (answered, timed out...) still shown, newest first.
const CLOSED: usize = 8;

/// Whether the replica agrees with the vehicle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Agreement {
    /// Nothing heard from the vehicle's gateway yet.
    Waiting,
    /// Every record played, the digests equal.
    Exact,
    /// Records are missing: advanced by the ground's own elaboration.
    Provisional,
    /// The replica's state differs from the vehicle's.
    Diverged,
}

impl Agreement {
    pub fn as_str(self) -> &'static str {
        match self {
            Agreement::Waiting => "waiting",
            Agreement::Exact => "exact",
            Agreement::Provisional => "provisional",
            Agreement::Diverged => "diverged",
        }
    }
}

/// What became of a question.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Fate {
    Pending,
    /// The operator's answer went up (signed), not yet seen played.
    Sent(String),
    /// The vehicle's player took the answer.
    Answered(String),
    /// The vehicle's player refused an answer (late, not offered).
    Refused {
        choice: String,
        reason: String,
    },
    TimedOut,
    /// Its net was deactivated, or the replica no longer has it.
    Closed,
}

#[derive(Debug, Clone)]
struct Asked {
    id: u64,
    net: String,
    ask: String,
    question: String,
    choices: Vec<String>,
    deadline: Micros,
    fate: Fate,
    /// Why the last answer from this mirror was not sent.
    refused: Option<String>,
}

/// The mirror's panel.
#[derive(Debug, Clone)]
pub struct Mirror {
    pub agreement: Agreement,
    /// The last vehicle step played or checked.
    step: Option<u64>,
    /// The last step found equal, and the replica's digest then (when the
    /// page saw the replica at that very step).
    agreed: Option<u64>,
    digest: Option<String>,
    /// Records missing, while provisional: `from..to`.
    gap: Option<(u64, u64)>,
    diverged: Option<Json>,
    resynced: Option<Json>,
    resyncs: u64,
    divergences: u64,
    disagreements: VecDeque<Json>,
    disagreements_total: u64,
    questions: BTreeMap<u64, Asked>,
    closed: VecDeque<u64>,
    /// The vehicle's time now as the mirror knows it (last heartbeat's
    /// offset), and the ground's.
    vehicle_now: Option<Micros>,
    ground_now: Micros,
    /// Whether answers can be sent from this mirror, or why not.
    answering: Result<(), String>,
    /// Downlink packets heard so far, and the ground time of the last.
    packets: u64,
    heard: Option<Micros>,
    /// The team's vehicles as the ground follows them (`vehicles`).
    vehicles: Vec<Json>,
    /// The downlink's signatures, when the mirror requires them.
    pub signatures: Option<petrel_core::mirror::signed::Refusals>,
}

impl Mirror {
    pub fn new(answering: Result<(), String>) -> Mirror {
        Mirror {
            agreement: Agreement::Waiting,
            step: None,
            agreed: None,
            digest: None,
            gap: None,
            diverged: None,
            resynced: None,
            resyncs: 0,
            divergences: 0,
            disagreements: VecDeque::new(),
            disagreements_total: 0,
            questions: BTreeMap::new(),
            closed: VecDeque::new(),
            vehicle_now: None,
            ground_now: 0,
            answering,
            packets: 0,
            heard: None,
            vehicles: Vec::new(),
            signatures: None,
        }
    }

    /// The vehicles the ground follows, in team order (one, named `null`,
    /// without a team): each one's frames received, whether its autopilot
    /// was heard, and its independent check's counts.
    pub fn vehicles(&mut self, ground: &petrel_core::mirror::ground::Ground) {
        self.vehicles = ground
            .watches()
            .iter()
            .zip(ground.counts())
            .map(|(w, c)| {
                json!({
                    "vehicle": w.name, "system": w.system, "frames": w.frames, "heard": w.heard,
                    "matched": c.matched, "ground_only": c.ground_only,
                    "vehicle_only": c.vehicle_only, "unjudged": c.unjudged,
                    "unobservable": c.unobservable,
                })
            })
            .collect();
    }

    /// One report of the replica, in order.
    pub fn report(&mut self, report: &Report) {
        match report {
            Report::Step { step, effects, .. } | Report::Timers { step, effects, .. } => {
                self.step = Some(*step);
                for e in effects {
                    self.effect(e);
                }
            }
            Report::Agreed { step } => self.agreed = Some(*step),
            Report::Version { step, .. } => self.step = self.step.max(Some(*step)),
            Report::UnknownVersion { .. } => {
                // Told by the divergence that comes with it (`mirror_diverged`).
            }
            Report::Gap { from, to, .. } => {
                self.gap = Some((*from, *to));
                if self.agreement != Agreement::Diverged {
                    self.agreement = Agreement::Provisional;
                }
            }
            Report::Resynced { .. } | Report::Diverged { .. } => {
                let mut v = json!({});
                if let Some(event) = report.event() {
                    for (k, val) in &event.params {
                        v[k] = val.to_json();
                    }
                }
                if let Report::Diverged { .. } = report {
                    self.divergences += 1;
                    self.diverged = Some(v);
                    self.agreement = Agreement::Diverged;
                } else {
                    self.resyncs += 1;
                    self.resynced = Some(v);
                    if let Report::Resynced { step, .. } = report {
                        self.step = self.step.max(Some(*step));
                    }
                    self.diverged = None;
                    self.gap = None;
                    self.agreement = Agreement::Exact;
                }
            }
        }
    }

    /// A question's outcome read off the replica's effects.
    fn effect(&mut self, effect: &Effect) {
        let (id, fate) = match effect {
            Effect::Answered { id, choice, .. } => (*id, Fate::Answered(choice.clone())),
            Effect::AnswerRefused {
                id, choice, reason, ..
            } => (
                *id,
                Fate::Refused {
                    choice: choice.clone(),
                    reason: reason.as_str().to_owned(),
                },
            ),
            Effect::Unanswered { id, .. } => (*id, Fate::TimedOut),
            Effect::Forgotten { id, .. } => (*id, Fate::Closed),
            _ => return,
        };
        if let Some(q) = self.questions.get_mut(&id) {
            // A refused answer after the timeout says no more than the
            // timeout did.
            if !(matches!(fate, Fate::Refused { .. }) && q.fate == Fate::TimedOut) {
                q.fate = fate;
            }
            self.close(id);
        }
    }

    fn close(&mut self, id: u64) {
        if !self.closed.contains(&id) {
            self.closed.push_front(id);
        }
        while self.closed.len() > CLOSED {
            if let Some(old) = self.closed.pop_back() {
                self.questions.remove(&old);
            }
        }
    }

    /// The replica's state as it stands, after its reports: `exact` when
    /// every record is played (`Replica::exact_time`), `shown` whether it
    /// shows a player at all; `digest` the shown player's (hex).
    pub fn replica(&mut self, exact: bool, shown: bool, digest: Option<String>) {
        self.agreement = match (exact, shown, self.agreement) {
            (true, _, _) => Agreement::Exact,
            (false, false, _) => Agreement::Waiting,
            (false, true, Agreement::Diverged) => Agreement::Diverged,
            (false, true, _) => Agreement::Provisional,
        };
        if exact && self.agreed.is_some() && self.agreed == self.step {
            self.digest = digest;
        }
    }

    /// The clocks: the vehicle's as the mirror knows it, the ground's.
    pub fn clocks(&mut self, vehicle_now: Option<Micros>, ground_now: Micros) {
        self.vehicle_now = vehicle_now;
        self.ground_now = ground_now;
    }

    /// The downlink packets the replica has received by ground time `now`
    /// (`Counts::packets`): the page says when the vehicle falls silent.
    pub fn downlink(&mut self, packets: u64, now: Micros) {
        if packets > self.packets {
            self.packets = packets;
            self.heard = Some(now);
        }
    }

    /// The last vehicle step the page knows of (played, checked or agreed).
    pub fn step(&self) -> Option<u64> {
        self.step.max(self.agreed)
    }

    /// The questions the dialog has pending: new ones shown, those gone
    /// without an outcome closed.
    pub fn questions(&mut self, dialog: &Dialog) {
        for q in dialog.pending() {
            self.questions.entry(q.id).or_insert_with(|| Asked {
                id: q.id,
                net: q.net.clone(),
                ask: q.ask.clone(),
                question: q.question.clone(),
                choices: q.choices.clone(),
                deadline: q.deadline,
                fate: Fate::Pending,
                refused: None,
            });
        }
        let gone: Vec<u64> = self
            .questions
            .values()
            .filter(|a| matches!(a.fate, Fate::Pending | Fate::Sent(_)))
            .filter(|a| !dialog.pending().any(|q| q.id == a.id))
            .map(|a| a.id)
            .collect();
        for id in gone {
            if let Some(q) = self.questions.get_mut(&id) {
                q.fate = Fate::Closed;
            }
            self.close(id);
        }
    }

    /// The operator's answer to `id`: sent (signed), or why not.
    pub fn answer(&mut self, id: u64, choice: &str, sent: Result<(), String>) {
        if let Some(q) = self.questions.get_mut(&id) {
            match sent {
                Ok(()) => {
                    if q.fate == Fate::Pending {
                        q.fate = Fate::Sent(choice.to_owned());
                    }
                    q.refused = None;
                }
                Err(why) => q.refused = Some(why),
            }
        }
    }

    /// A disagreement of the independent check.
    pub fn disagreement(&mut self, d: &Disagreement) {
        self.disagreements_total += 1;
        let side = |s: Side| match s {
            Side::Ground => "ground",
            Side::Vehicle => "vehicle",
        };
        let params = nets::value::params_json;
        let other = match d.seen_by {
            Side::Ground => Side::Vehicle,
            Side::Vehicle => Side::Ground,
        };
        self.disagreements.push_front(json!({
            "event": d.event,
            "vehicle": vehicle_of(&d.event),
            "seen_by": side(d.seen_by),
            "other": side(other),
            "t": d.time as f64 / 1e6,
            "params": params(&d.params),
            "window_s": d.window as f64 / 1e6,
            "other_t": d.other.as_ref().map(|(t, _)| *t as f64 / 1e6),
            "other_params": d.other.as_ref().map(|(_, p)| params(p)),
        }));
        self.disagreements.truncate(DISAGREEMENTS);
    }

    /// As the page reads it (the frame's `mirror`).
    pub fn json(&self) -> Json {
        let question = |q: &Asked| {
            let (fate, choice, reason) = match &q.fate {
                Fate::Pending => ("pending", None, None),
                Fate::Sent(c) => ("sent", Some(c.as_str()), None),
                Fate::Answered(c) => ("answered", Some(c.as_str()), None),
                Fate::Refused { choice, reason } => {
                    ("refused", Some(choice.as_str()), Some(reason.as_str()))
                }
                Fate::TimedOut => ("timed_out", None, None),
                Fate::Closed => ("closed", None, None),
            };
            json!({
                "id": q.id, "net": q.net, "vehicle": vehicle_of(&q.net), "ask": q.ask, "question": q.question,
                "choices": q.choices, "deadline": q.deadline as f64 / 1e6,
                "left": self.vehicle_now.map(|t| q.deadline.saturating_sub(t) as f64 / 1e6),
                "fate": fate, "choice": choice, "reason": reason, "not_sent": q.refused,
            })
        };
        let open: Vec<Json> = self
            .questions
            .values()
            .filter(|q| matches!(q.fate, Fate::Pending | Fate::Sent(_)))
            .map(question)
            .collect();
        let closed: Vec<Json> = self
            .closed
            .iter()
            .filter_map(|id| self.questions.get(id))
            .map(question)
            .collect();
        json!({
            "agreement": self.agreement.as_str(),
            "step": self.step(),
            "agreed": self.agreed,
            "digest": self.digest,
            "gap": self.gap.map(|(from, to)| json!({"from": from, "to": to})),
            "diverged": self.diverged,
            "resynced": self.resynced,
            "resyncs": self.resyncs,
            "divergences": self.divergences,
            "disagreements": self.disagreements,
            "disagreements_total": self.disagreements_total,
            "questions": open,
            "closed": closed,
            "vehicle_t": self.vehicle_now.map(|t| t as f64 / 1e6),
            "silent_s": self.heard.map(|h| self.ground_now.saturating_sub(h) as f64 / 1e6),
            "answering": self.answering.is_ok(),
            "read_only": self.answering.as_ref().err(),
            "vehicles": self.vehicles,
            "signatures": self.signatures,
        })
    }
}

/// The vehicle a net instance (`MOVE@R1`) or an event (`armed@R1`) is
/// of; `None` for a team net or a project without a team — the field the
/// live monitor's board names `vehicle` too.
fn vehicle_of(name: &str) -> Option<&str> {
    nets::model::split_vehicle(name).1
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use petrel_core::mirror::replica::Repair;

    pub(crate) fn asking() -> std::sync::Arc<nets::Project> {
        let files = [
            (
                "project.toml",
                "[[net]]\nfile = \"q.toml\"\nactive = true\n[events]\nreached = {}\n",
            ),
            (
                "q.toml",
                "name = \"Q\"\nplaces = [\"a\", \"b\", \"c\"]\ninitial = [\"a\"]\n\
                 [[transition]]\nname = \"ask\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"reached\"\n\
                 do = ['ask go \"Go on?\" {choices: [yes, no]} timeout 30s']\n\
                 [[transition]]\nname = \"yes\"\nfrom = [\"b\"]\nto = [\"c\"]\non = \"go.yes\"\n\
                 [[transition]]\nname = \"no\"\nfrom = [\"b\"]\nto = [\"a\"]\non = \"go.no\"\n\
                 [[transition]]\nname = \"late\"\nfrom = [\"b\"]\nto = [\"a\"]\non = \"go.timeout\"\n",
            ),
        ];
        std::sync::Arc::new(nets::load(&files).unwrap_or_else(|e| panic!("{e}")))
    }

    /// The player asked, its effects through the dialog and the panel.
    fn asked(
        mirror: &mut Mirror,
        dialog: &mut Dialog,
        player: &mut nets::Player,
        at: Micros,
    ) -> u64 {
        player.handle(&nets::Event::new("reached"), at);
        let effects: Vec<Effect> = player.effects().collect();
        for e in &effects {
            dialog.observe(player.project(), e);
        }
        mirror.report(&Report::Step {
            number: 0,
            step: 1,
            time: at,
            inputs: Vec::new(),
            effects,
        });
        mirror.questions(dialog);
        dialog.pending().map(|q| q.id).next().unwrap_or(u64::MAX)
    }

    #[test]
    fn agreement_follows_the_replicas_reports_and_state() {
        let mut m = Mirror::new(Ok(()));
        m.replica(false, false, None);
        assert_eq!(m.json()["agreement"], "waiting");
        m.report(&Report::Resynced {
            step: 0,
            how: Repair::Start,
            after: 0,
        });
        m.report(&Report::Timers {
            step: 7,
            time: 1_000_000,
            effects: Vec::new(),
        });
        m.report(&Report::Agreed { step: 7 });
        m.replica(true, true, Some("00aa".into()));
        let v = m.json();
        assert_eq!(v["agreement"], "exact");
        assert_eq!(v["agreed"], 7);
        assert_eq!(v["digest"], "00aa", "the digest at the agreed step");
        // A step played but not yet checked: the digest stays the agreed one.
        m.report(&Report::Timers {
            step: 8,
            time: 2_000_000,
            effects: Vec::new(),
        });
        m.replica(true, true, Some("00bb".into()));
        assert_eq!(m.json()["digest"], "00aa");
        // A gap: provisional, with the records missing.
        m.report(&Report::Gap {
            from: 9,
            to: 12,
            step: 8,
        });
        m.replica(false, true, Some("00cc".into()));
        let v = m.json();
        assert_eq!(v["agreement"], "provisional");
        assert_eq!(v["gap"], json!({"from": 9, "to": 12}));
        // Diverged stays diverged while the replica is not exact.
        m.report(&Report::Diverged {
            step: 9,
            agreed: Some(7),
            reason: "records lost and not repaired".into(),
        });
        m.replica(false, true, None);
        let v = m.json();
        assert_eq!(v["agreement"], "diverged");
        assert_eq!(v["diverged"]["step"], 9);
        assert_eq!(v["diverged"]["agreed"], 7);
        assert_eq!(v["divergences"], 1);
        // Resynced: exact again, the banners' causes gone.
        m.report(&Report::Resynced {
            step: 20,
            how: Repair::Snapshot,
            after: 3_000_000,
        });
        m.replica(true, true, None);
        let v = m.json();
        assert_eq!(v["agreement"], "exact");
        assert_eq!(v["diverged"], Json::Null);
        assert_eq!(v["gap"], Json::Null);
        assert_eq!(v["resynced"]["how"], "snapshot");
        assert_eq!(v["resyncs"], 2);
        assert_eq!(m.step(), Some(20), "the step the resync reached");
    }

    #[test]
    fn the_page_says_how_long_the_vehicle_has_been_silent() {
        let mut m = Mirror::new(Ok(()));
        m.downlink(0, 1_000_000);
        m.clocks(None, 1_000_000);
        assert_eq!(m.json()["silent_s"], Json::Null, "nothing heard yet");
        m.downlink(3, 2_000_000);
        m.clocks(None, 2_000_000);
        assert_eq!(m.json()["silent_s"], 0.0);
        m.downlink(3, 6_500_000);
        m.clocks(None, 6_500_000);
        assert_eq!(m.json()["silent_s"], 4.5);
    }

    #[test]
    fn a_question_counts_down_on_the_vehicles_time_and_ends_answered() {
        let project = asking();
        let mut player = nets::Player::start(project.clone(), 0);
        let _ = player.effects().count();
        let (mut m, mut dialog) = (Mirror::new(Ok(())), Dialog::new());
        let id = asked(&mut m, &mut dialog, &mut player, 10_000_000);
        m.clocks(Some(22_500_000), 5_000_000);
        let v = m.json();
        let q = &v["questions"][0];
        assert_eq!(q["id"], id);
        assert_eq!(q["question"], "Go on?");
        assert_eq!(q["choices"], json!(["yes", "no"]));
        assert_eq!(q["deadline"], 40.0);
        assert_eq!(q["left"], 17.5, "40 s - 22.5 s, vehicle time");
        assert_eq!(q["fate"], "pending");
        assert_eq!(v["answering"], true);
        // Refused by the dialog: said on the question, still pending.
        m.answer(id, "maybe", Err("`maybe` is not a choice".into()));
        assert_eq!(
            m.json()["questions"][0]["not_sent"],
            "`maybe` is not a choice"
        );
        m.answer(id, "yes", Ok(()));
        assert_eq!(m.json()["questions"][0]["fate"], "sent");
        // The vehicle takes it: the replica plays its step.
        let _ = player.answer(id, "yes", 25_000_000);
        let effects: Vec<Effect> = player.effects().collect();
        for e in &effects {
            dialog.observe(&project, e);
        }
        m.report(&Report::Step {
            number: 1,
            step: 2,
            time: 25_000_000,
            inputs: Vec::new(),
            effects,
        });
        m.questions(&dialog);
        let v = m.json();
        assert_eq!(v["questions"], json!([]));
        assert_eq!(v["closed"][0]["fate"], "answered");
        assert_eq!(v["closed"][0]["choice"], "yes");
    }

    #[test]
    fn a_question_timed_out_then_answered_late_says_timed_out() {
        let project = asking();
        let mut player = nets::Player::start(project.clone(), 0);
        let _ = player.effects().count();
        let (mut m, mut dialog) = (Mirror::new(Err("no operator key".into())), Dialog::new());
        let id = asked(&mut m, &mut dialog, &mut player, 0);
        assert_eq!(m.json()["read_only"], "no operator key");
        assert_eq!(m.json()["answering"], false);
        player.advance(31_000_000);
        let _ = player.answer(id, "no", 31_000_000);
        let effects: Vec<Effect> = player.effects().collect();
        assert!(effects
            .iter()
            .any(|e| matches!(e, Effect::AnswerRefused { .. })));
        for e in &effects {
            dialog.observe(&project, e);
        }
        m.report(&Report::Timers {
            step: 2,
            time: 31_000_000,
            effects,
        });
        m.questions(&dialog);
        assert_eq!(m.json()["closed"][0]["fate"], "timed_out");
    }

    #[test]
    fn questions_closed_are_forgotten_past_the_last_few() {
        let project = asking();
        let mut player = nets::Player::start(project.clone(), 0);
        let _ = player.effects().count();
        let (mut m, mut dialog) = (Mirror::new(Ok(())), Dialog::new());
        let mut t = 0;
        for _ in 0..100 {
            t += 1_000_000;
            let id = asked(&mut m, &mut dialog, &mut player, t);
            t += 1_000_000;
            let _ = player.answer(id, "no", t);
            let effects: Vec<Effect> = player.effects().collect();
            for e in &effects {
                dialog.observe(&project, e);
            }
            m.report(&Report::Step {
                number: 0,
                step: 2,
                time: t,
                inputs: Vec::new(),
                effects,
            });
            m.questions(&dialog);
        }
        assert_eq!(m.questions.len(), CLOSED, "what the page keeps");
        let v = m.json();
        assert_eq!(v["closed"].as_array().map(Vec::len), Some(CLOSED));
        assert_eq!(v["closed"][0]["fate"], "answered");
        assert_eq!(v["questions"], json!([]));
    }

    #[test]
    fn disagreements_carry_both_sides_and_are_bounded() {
        let mut m = Mirror::new(Ok(()));
        for i in 0..(DISAGREEMENTS as u64 + 5) {
            m.disagreement(&Disagreement {
                event: "engine_failure".into(),
                seen_by: Side::Ground,
                time: 52_900_000 + i,
                params: [("rpm".to_owned(), nets::Value::Int(0))]
                    .into_iter()
                    .collect(),
                window: 2_000_000,
                other: Some((
                    50_000_000,
                    [("rpm".to_owned(), nets::Value::Int(3000))]
                        .into_iter()
                        .collect(),
                )),
            });
        }
        let v = m.json();
        assert_eq!(v["disagreements_total"], DISAGREEMENTS as u64 + 5);
        let d = v["disagreements"].as_array().cloned().unwrap_or_default();
        assert_eq!(d.len(), DISAGREEMENTS);
        assert_eq!(d[0]["t"], 52.900054, "newest first");
        assert_eq!(d[0]["seen_by"], "ground");
        assert_eq!(d[0]["other"], "vehicle");
        assert_eq!(d[0]["params"]["rpm"], 0);
        assert_eq!(d[0]["other_params"]["rpm"], 3000);
        assert_eq!(d[0]["other_t"], 50.0);
        assert_eq!(d[0]["vehicle"], Json::Null, "no team");
    }

    #[test]
    fn a_teams_disagreements_and_vehicles_say_which_vehicle() {
        let mut m = Mirror::new(Ok(()));
        m.disagreement(&Disagreement {
            event: "engine_failure@R2".into(),
            seen_by: Side::Vehicle,
            time: 1_000_000,
            params: nets::Params::new(),
            window: 2_000_000,
            other: None,
        });
        let project = petrel_core::team::fixtures::team();
        let layers = petrel_core::profile::Layers::builtin("ardupilot");
        let profile = layers.load().expect("profile");
        let lanes = petrel_core::team::lanes(
            &project,
            std::path::Path::new("."),
            &profile,
            petrel_core::team::family(&layers.layers),
            &elaboration::Config::default(),
        )
        .expect("lanes");
        let ground =
            petrel_core::mirror::ground::Ground::new(lanes, petrel_core::mirror::check::WINDOW);
        m.vehicles(&ground);
        let v = m.json();
        assert_eq!(v["disagreements"][0]["vehicle"], "R2");
        let names: Vec<_> = v["vehicles"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|w| {
                (
                    w["vehicle"].clone(),
                    w["system"].clone(),
                    w["frames"].clone(),
                )
            })
            .collect();
        assert_eq!(
            names,
            [
                (json!("R1"), json!(1), json!(0)),
                (json!("R2"), json!(2), json!(0))
            ]
        );
        assert_eq!(vehicle_of("MOVE@R1"), Some("R1"));
        assert_eq!(vehicle_of("SYNC"), None);
    }
}
