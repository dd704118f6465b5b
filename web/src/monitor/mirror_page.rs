//! `petrel mirror --http` (docs/monitor.md, "On the mirror"): the live
//! board fed from the mirror's loop — the replica's steps as `run`'s steps
//! are (`Board::played`), the ground's own frames for the vehicle strip,
//! the mirror's panel (`mirror.rs`) — and served with the answer desk
//! (`answer.rs`).

use std::net::SocketAddr;
use std::path::Path;
use std::sync::Arc;

use nets::player::Effect;
use nets::{Micros, Project};
use serde_json::json;
use tokio::sync::mpsc;

use super::answer::{Desk, Request};
use super::board::Board;
use super::live::{Feed, Live};
use super::mirror::Mirror;
use super::server::Server;
use petrel_core::mirror::check::Disagreement;
use petrel_core::mirror::dialog::Dialog;
use petrel_core::mirror::ground::Ground;
use petrel_core::mirror::record::Input as RecordInput;
use petrel_core::mirror::replica::{Replica, Report};
use petrel_core::mirror::signed::Refusals;
use petrel_core::supervisor::{Input, Step};

/// `petrel mirror --http`: the board fed from the mirror's loop, once per
/// turn of it after the turn's requests are sent, and served with the
/// answer desk. What the turn brought is kept until then (the frames,
/// reports and disagreements of one turn); the board is locked briefly,
/// never waiting for a browser (`live.rs`).
pub struct Page {
    feed: Feed,
    /// The project's folder (a new version's page shows its files).
    dir: std::path::PathBuf,
    pub server: Server,
    frames: Vec<(Micros, Vec<u8>)>,
    reports: Vec<Report>,
    disagreements: Vec<Disagreement>,
    /// The downlink's signatures, when the mirror requires them.
    signatures: Option<Refusals>,
}

impl Page {
    /// Serves the mirror's page on `address`; `answering`: whether the
    /// operator key is loaded, or why not. The receiver takes the page's
    /// answers (with the key only).
    pub fn start(
        address: SocketAddr,
        project: Arc<Project>,
        dir: &Path,
        answering: Result<(), String>,
    ) -> std::io::Result<(Page, Option<mpsc::Receiver<Request>>)> {
        let mut page = super::page::page(&project, Some(dir), "live");
        page["mirror"] = json!(true);
        // The replica's player starts at vehicle time 0, as on board.
        let mut player = nets::Player::start(project.clone(), 0);
        let start = Step {
            seq: 0,
            time: 0,
            events: Vec::new(),
            effects: player.effects().collect(),
        };
        let mut board = Board::new(project, &player, 0, super::live::LOG_LIVE);
        board.mirror = Some(Mirror::new(answering.clone()));
        let live = Live::new(board, page);
        let feed = Feed::new(live.clone());
        feed.start(&start, &player);
        let (desk, answers) = Desk::new(answering);
        let server = Server::start_mirror(address, live, desk)?;
        let page = Page {
            feed,
            dir: dir.to_path_buf(),
            server,
            frames: Vec::new(),
            reports: Vec::new(),
            disagreements: Vec::new(),
            signatures: None,
        };
        Ok((page, answers))
    }

    /// A frame the ground received at `now` (for the vehicle strip and map).
    pub fn frame(&mut self, now: Micros, bytes: &[u8]) {
        self.frames.push((now, bytes.to_vec()));
    }

    /// A report of the replica.
    pub fn report(&mut self, report: &Report) {
        self.reports.push(report.clone());
    }

    /// A disagreement of the independent check.
    pub fn disagreement(&mut self, d: &Disagreement) {
        self.disagreements.push(d.clone());
    }

    /// The downlink's signatures as they stand (with `--signing-key`).
    pub fn signatures(&mut self, refusals: Refusals) {
        self.signatures = Some(refusals);
    }

    /// The end of a turn of the mirror's loop at ground time `now`: what
    /// it brought, the replica and the dialog as they stand, on the board.
    pub fn settle(&mut self, now: Micros, replica: &Replica, dialog: &Dialog, ground: &Ground) {
        let shown = replica.shown();
        let (frames, reports, disagreements) = (&self.frames, &self.reports, &self.disagreements);
        let signatures = self.signatures;
        self.feed.update(|b| {
            b.vehicle.changed = false;
            for (t, bytes) in frames {
                b.vehicle.frame(*t, bytes);
            }
            if let Some((player, _)) = shown {
                for r in reports {
                    played(b, r, player);
                }
                b.show(player, player.state().now);
            }
            b.vehicle.now = b.vehicle.now.max(now);
            if let Some(m) = &mut b.mirror {
                for r in reports {
                    m.report(r);
                }
                for d in disagreements {
                    m.disagreement(d);
                }
                m.questions(dialog);
                m.vehicles(ground);
                let digest = shown.map(|(p, _)| hex8(&p.digest().0));
                m.replica(replica.exact_time().is_some(), shown.is_some(), digest);
                m.clocks(replica.vehicle_time(now), now);
                m.downlink(replica.counts.packets, now);
                m.signatures = signatures;
                if let Some(step) = m.step() {
                    b.marking.seq = b.marking.seq.max(step);
                }
            }
        });
        // A new version the replica took over: open pages draw its nets.
        for r in &self.reports {
            if let Report::Version { version, .. } = r {
                let mut page = super::page::page(&version.project, Some(&self.dir), "live");
                page["mirror"] = json!(true);
                self.feed.replace_page(page);
            }
        }
        self.feed.publish();
        self.frames.clear();
        self.reports.clear();
        self.disagreements.clear();
    }

    /// What became of a version sent up (`petrel mirror --push`), on the
    /// page's log.
    pub fn pushed(&self, text: &str) {
        self.feed.update(|b| b.note("push", text));
        self.feed.publish();
    }

    /// The operator's answer to `id` from the page or the CLI: `sent`, what
    /// the dialog and the uplink did.
    pub fn answered(&self, id: u64, choice: &str, sent: &Result<String, String>) {
        self.feed.update(|b| {
            if let Some(m) = &mut b.mirror {
                m.answer(id, choice, sent.as_ref().map(|_| ()).map_err(Clone::clone));
            }
        });
        self.feed.publish();
    }
}

/// The first 8 bytes of a digest, in hex (what the step records carry).
fn hex8(digest: &[u8]) -> String {
    digest.iter().take(8).map(|b| format!("{b:02x}")).collect()
}

/// A replica's report on the board's log and marking, as `run`'s steps
/// are: each input with what it fired (a step of several inputs shows its
/// firings on the first).
fn played(board: &mut Board, report: &Report, player: &nets::Player) {
    let (seq, time, inputs, effects): (u64, Micros, &[RecordInput], &[Effect]) = match report {
        Report::Step {
            step,
            time,
            inputs,
            effects,
            ..
        } => (*step, *time, inputs, effects),
        Report::Timers {
            step,
            time,
            effects,
        } => (*step, *time, &[], effects),
        _ => return,
    };
    let mut effects = Some(effects.to_vec());
    let mut take = || effects.take().unwrap_or_default();
    if inputs.is_empty() {
        let step = Step {
            seq,
            time,
            events: Vec::new(),
            effects: take(),
        };
        board.played(&Input::Tick, &step, player);
    }
    for input in inputs {
        let (input, step) = match input {
            RecordInput::Elaborated { time: t, event, .. } => {
                let elaborated = elaboration::Elaborated {
                    time_us: *t,
                    event: event.clone(),
                    sysid: 0,
                    compid: 0,
                    boot_us: None,
                    rule: None,
                };
                (
                    Input::Tick,
                    Step {
                        seq,
                        time,
                        events: vec![(elaborated, take())],
                        effects: Vec::new(),
                    },
                )
            }
            RecordInput::Version { number, .. } => {
                // The replica took it over before playing the record: the
                // board draws the project its player runs now.
                let version = Arc::new(petrel_core::version::Version {
                    number: *number,
                    project: player.project().clone(),
                    files: Vec::new(),
                });
                let step = Step {
                    seq,
                    time,
                    events: Vec::new(),
                    effects: take(),
                };
                board.played(&Input::Version(&version), &step, player);
                continue;
            }
            other => {
                let input = match other {
                    RecordInput::Result { id, outcome, .. } => Input::Result {
                        id: *id,
                        outcome: outcome.clone(),
                    },
                    RecordInput::Answered { id, choice, .. } => Input::Answer {
                        id: *id,
                        choice: choice.clone(),
                    },
                    RecordInput::Program { event, .. }
                    | RecordInput::Answer { event, .. }
                    | RecordInput::Elaborated { event, .. } => Input::Event(event.clone()),
                    RecordInput::Version { .. } => Input::Tick,
                };
                let step = Step {
                    seq,
                    time,
                    events: Vec::new(),
                    effects: take(),
                };
                (input, step)
            }
        };
        board.played(&input, &step, player);
    }
}

#[cfg(test)]
mod tests {
    use super::super::mirror::tests::asking;
    use super::*;
    use serde_json::Value as Json;

    #[test]
    fn the_replicas_steps_go_on_the_board_as_runs_do() {
        let project = asking();
        let mut player = nets::Player::start(project.clone(), 0);
        let _ = player.effects().count();
        let mut board = Board::new(project.clone(), &player, 0, 100);
        let reached = nets::Event::new("reached");
        player.handle(&reached, 2_000_000);
        let effects: Vec<Effect> = player.effects().collect();
        let id = effects
            .iter()
            .find_map(|e| match e {
                Effect::Ask { id, .. } => Some(*id),
                _ => None,
            })
            .unwrap_or(u64::MAX);
        let step = Report::Step {
            number: 0,
            step: 12,
            time: 2_000_000,
            inputs: vec![RecordInput::Elaborated {
                time: 2_000_000,
                boot: None,
                event: reached,
            }],
            effects,
        };
        played(&mut board, &step, &player);
        let _ = player.answer(id, "yes", 3_000_000);
        let answered = Report::Step {
            number: 1,
            step: 13,
            time: 3_000_000,
            inputs: vec![RecordInput::Answered {
                time: 3_000_000,
                id,
                choice: "yes".into(),
            }],
            effects: player.effects().collect(),
        };
        played(&mut board, &answered, &player);
        let log: Vec<&Json> = board.log().iter().map(|e| &e.json).collect();
        let kinds: Vec<&str> = log.iter().filter_map(|e| e["kind"].as_str()).collect();
        assert_eq!(kinds, ["event", "question", "answer"], "{log:?}");
        assert_eq!(log[0]["name"], "reached");
        assert_eq!(log[0]["fired"], json!(["Q.ask"]), "its firing on it");
        assert_eq!(log[1]["question"], "Go on?");
        assert_eq!(log[2]["choice"], "yes");
        assert_eq!(log[2]["fired"], json!(["Q.yes"]));
        assert_eq!(board.marking.seq, 13, "the vehicle's step");
        let c = project.flat(0, nets::model::PlaceRef::Local(2));
        assert!(board.marking.marked(c), "the marking after the answer");
    }

    #[test]
    fn what_became_of_a_version_sent_up_goes_on_the_log() {
        let project = asking();
        let player = nets::Player::start(project.clone(), 0);
        let mut board = Board::new(project, &player, 0, 100);
        board.note(
            "push",
            "push: the vehicle's verdict: version 1 took over at step 9",
        );
        let last = board
            .log()
            .back()
            .map(|e| e.json.clone())
            .unwrap_or_default();
        assert_eq!(last["kind"], "push");
        assert!(last["text"]
            .as_str()
            .is_some_and(|t| t.contains("took over")));
    }
}
