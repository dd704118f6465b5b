//! The ground station's core: every decision `petrel mirror` takes, with
//! no socket, thread or clock (as quinn-proto is to quinn). Feed it the
//! frames the ground receives and ticks, each with its ground time, and
//! the operator's answers; poll it for the requests to send up
//! ([`Station::poll_transmit`]) and for what happened
//! ([`Station::poll_output`]: the replica's reports, the independent
//! check's disagreements, the questions pending, what to tell people).
//! `cli/mirror.rs` only moves bytes, records and prints.
//!
//! Inside: the replica of the vehicle's player ([`Replica`]), the
//! ground's own elaboration and check ([`Ground`]), the operator dialog
//! ([`Dialog`]) and, with the vehicle's key, the signed downlink's
//! admission ([`SignedDownlink`]).

use std::collections::{BTreeMap, HashSet, VecDeque};
use std::sync::Arc;

use elaboration::Frame;
use nets::{Micros, Project};

use super::call::Played;
use super::check::{Disagreement, WINDOW};
use super::dialog::{Dialog, Question};
use super::ground::Ground;
use super::record::Input;
use super::replica::{Config as ReplicaConfig, Repair, Replica, Report, Uplink};
use super::signed::SignedDownlink;
use super::tunnel::Tunnel;
use super::upload::{Config as UploadConfig, Sender, Sent, Signed};
use crate::signing::{Key, Rejection};
use crate::supervisor::Lane;

/// Nothing heard this long (ground time) is said once; a vehicle heard
/// without a downlink record for twice as long too.
pub const SILENCE_WARNING: Micros = 5_000_000;

/// How a station is set up.
pub struct Config {
    pub project: Arc<Project>,
    /// The mirror's own system id: the downlink's records addressed to it
    /// (or broadcast to its component) are the replica's.
    pub system: u8,
    /// The mirror's (system, component) on its uplink.
    pub identity: (u8, u8),
    /// The ground's elaboration: one lane per vehicle of the team.
    pub lanes: Vec<Lane>,
    /// The vehicle's signing key: the downlink must be signed with it.
    pub signing: Option<Key>,
    /// The operator dialog is on (an operator key is held): questions are
    /// shown with their countdown.
    pub dialog: bool,
    /// The replica keeps what it played, for a recording
    /// ([`Output::Played`]).
    pub record: bool,
}

/// What happened, in order.
#[derive(Debug)]
pub enum Output {
    /// A report of the replica (its steps, gaps, resyncs, divergences).
    Report(Report),
    /// The first record missing from a gap came, resent: sent at `sent`,
    /// the gap seen `detected_after` later (vehicle time).
    GapDetected {
        record: u64,
        sent: Micros,
        detected_after: Micros,
    },
    /// A call the replica played, to record.
    Played(Played),
    /// The independent check disagrees with the vehicle.
    Disagreement(Disagreement),
    /// A pending question to show: first shown (`first`), or its
    /// countdown (`left` seconds, every 10 s and each of the last 5).
    Question {
        question: Question,
        first: bool,
        left: Micros,
    },
    /// A downlink record refused, the first time for this reason.
    Refused { system: u8, why: Rejection },
    /// Nothing heard for [`SILENCE_WARNING`] (said once).
    NothingHeard,
    /// The vehicle `system` heard for twice [`SILENCE_WARNING`], but no
    /// downlink record (said once).
    NoDownlink { vehicle: u8 },
    /// A system heard that is no vehicle of the team (said once).
    Foreign { system: u8 },
    /// What became of the version sent up (`mirror::upload`).
    Upload(Sent),
}

/// The ground station's state.
pub struct Station {
    project: Arc<Project>,
    system: u8,
    identity: (u8, u8),
    replica: Replica,
    ground: Ground,
    dialog: Dialog,
    dialog_on: bool,
    signed: Option<SignedDownlink>,
    /// The onboard gateway's address, from its first record admitted.
    onboard: Option<(u8, u8)>,
    /// The refusal reasons said once.
    said_refused: HashSet<Rejection>,
    /// The gap open: its first missing record and when it was seen
    /// (vehicle time).
    gap_seen: Option<(u64, Micros)>,
    heard_any: bool,
    said_silent: bool,
    said_no_downlink: bool,
    /// Each pending question's last countdown mark shown.
    shown: BTreeMap<u64, Micros>,
    out: VecDeque<Output>,
    /// A version being sent up.
    upload: Option<Sender>,
}

impl Station {
    pub fn new(config: Config) -> Station {
        Station {
            replica: Replica::new(
                config.project.clone(),
                ReplicaConfig {
                    record: config.record,
                    ..ReplicaConfig::default()
                },
            ),
            ground: Ground::new(config.lanes, WINDOW),
            project: config.project,
            system: config.system,
            identity: config.identity,
            dialog: Dialog::new(),
            dialog_on: config.dialog,
            signed: config.signing.map(SignedDownlink::new),
            onboard: None,
            said_refused: HashSet::new(),
            gap_seen: None,
            heard_any: false,
            said_silent: false,
            said_no_downlink: false,
            shown: BTreeMap::new(),
            out: VecDeque::new(),
            upload: None,
        }
    }

    /// Sends a new version up (`bytes`: its files, as the driver packed
    /// them; `upload`: its number), from ground time `now`; the replica
    /// follows the vehicle onto it when it takes it over. One at a time.
    pub fn push(
        &mut self,
        now: Micros,
        upload: u64,
        bytes: Vec<u8>,
        version: Arc<crate::version::Version>,
        config: UploadConfig,
    ) -> Result<(), String> {
        if let Some(u) = self.upload.as_ref().filter(|u| !u.done()) {
            return Err(format!(
                "upload {} is still under way: one version at a time",
                u.upload()
            ));
        }
        self.replica.know(version);
        self.upload = Some(Sender::new(upload, bytes, now, config));
        Ok(())
    }

    /// The next upload record to send signed with the operator key, and
    /// whom to: none until the vehicle is heard, or beyond the upload's
    /// byte rate.
    pub fn poll_signed(&mut self, now: Micros) -> Option<((u8, u8), Signed)> {
        let to = self.target()?;
        let signed = self.upload.as_mut()?.poll_transmit(now)?;
        Some((to, signed))
    }

    /// The version being sent up, if any.
    pub fn upload(&self) -> Option<&Sender> {
        self.upload.as_ref()
    }

    /// A frame received at ground time `now` (`unix_us`: the wall clock's
    /// UNIX time, for the downlink's signatures).
    pub fn handle_frame(&mut self, now: Micros, bytes: &[u8], unix_us: u64) {
        self.heard_any = true;
        if let Ok(frame) = Frame::parse(bytes) {
            let replica = &self.replica;
            self.ground.heard(now, &frame, |t| replica.vehicle_time(t));
            match Tunnel::from_frame(&frame) {
                Some(t)
                    if t.target_system == self.system
                        && (t.target_component == 0 || t.target_component == self.identity.1) =>
                {
                    let admitted = match &mut self.signed {
                        Some(s) => s.admit(bytes, unix_us),
                        None => Ok(()),
                    };
                    match admitted {
                        Ok(()) => {
                            self.onboard = Some((frame.system_id(), frame.component_id()));
                            self.replica.receive(now, &t.payload);
                        }
                        Err(why) => {
                            if self.said_refused.insert(why) {
                                self.out.push_back(Output::Refused {
                                    system: frame.system_id(),
                                    why,
                                });
                            }
                        }
                    }
                }
                Some(_) => {}
                None => self.ground.elaborate(now, &frame),
            }
        }
        self.settle(now);
    }

    /// Time passes at ground time `now` with nothing received.
    pub fn handle_tick(&mut self, now: Micros) {
        self.ground.tick(now);
        self.replica.tick(now);
        self.settle(now);
    }

    /// The operator's answer `choice` to question `id` at ground time
    /// `now`: checked by the dialog; whom to send it to (the onboard
    /// gateway, else the vehicle's companion), or why it cannot go.
    pub fn answer(&mut self, now: Micros, id: u64, choice: &str) -> Result<(u8, u8), String> {
        let to = self.target();
        let result = match self.dialog.answer(id, choice) {
            Err(e) => Err(format!("not sent: {e}")),
            Ok(_) => to.ok_or_else(|| format!("answer #{id} not sent: no vehicle heard yet")),
        };
        self.settle(now);
        result
    }

    /// The next request for the vehicle, with whom to send it to: none
    /// until someone is heard to ask.
    pub fn poll_transmit(&mut self) -> Option<((u8, u8), Uplink)> {
        let to = self.target()?;
        self.replica.poll_transmit().map(|r| (to, r))
    }

    /// What happened, in order.
    pub fn poll_output(&mut self) -> Option<Output> {
        self.out.pop_front()
    }

    /// Where requests and answers go: the onboard gateway, else the
    /// vehicle's companion.
    pub fn target(&self) -> Option<(u8, u8)> {
        self.onboard.or(self.ground.companion())
    }

    pub fn replica(&self) -> &Replica {
        &self.replica
    }

    pub fn ground(&self) -> &Ground {
        &self.ground
    }

    pub fn dialog(&self) -> &Dialog {
        &self.dialog
    }

    pub fn signed(&self) -> Option<&SignedDownlink> {
        self.signed.as_ref()
    }

    pub fn project(&self) -> &Arc<Project> {
        &self.project
    }

    /// A version of the project the vehicle may take over (the mirror's
    /// folder read again, or a version the ground sent up): the replica
    /// follows the vehicle onto it (`Replica::know`).
    pub fn know(&mut self, version: Arc<crate::version::Version>) {
        self.replica.know(version);
    }

    /// Everything an input leads to, at ground time `now`.
    fn settle(&mut self, now: Micros) {
        {
            // The replica is advanced by the ground's events while
            // provisional; `vehicle_time` reads only the time base.
            let (replica, mut ground_seen) = (&self.replica, Vec::new());
            self.ground
                .drain(|t| replica.vehicle_time(t), |e| ground_seen.push(e.clone()));
            for e in &ground_seen {
                self.replica.ground_event(now, e);
            }
        }
        while let Some(report) = self.replica.poll_report() {
            self.reported(now, &report);
            self.out.push_back(Output::Report(report));
        }
        while let Some(played) = self.replica.poll_played() {
            self.out.push_back(Output::Played(played));
        }
        // The vehicle's word on the version sent up.
        while let Some(word) = self.replica.poll_upload() {
            if let Some(u) = &mut self.upload {
                u.handle(now, &word);
            }
        }
        if let Some(u) = &mut self.upload {
            u.tick(now);
            while let Some(sent) = u.poll_report() {
                self.out.push_back(Output::Upload(sent));
            }
        }
        // Nothing tells a new user why the mirror stays blank otherwise.
        if !self.said_silent && !self.heard_any && now >= SILENCE_WARNING {
            self.said_silent = true;
            self.out.push_back(Output::NothingHeard);
        }
        if !self.said_no_downlink && self.replica.counts.packets == 0 && now >= 2 * SILENCE_WARNING
        {
            if let Some(v) = self.ground.some_heard() {
                self.said_no_downlink = true;
                self.out.push_back(Output::NoDownlink { vehicle: v });
            }
        }
        // Each vehicle's ground view reaches its last autopilot frame heard.
        let replica = &self.replica;
        self.ground.advance(
            replica.exact_time(),
            |lane| replica.exact_boot(lane),
            |t| replica.vehicle_time(t),
        );
        while let Some(system) = self.ground.poll_foreign() {
            self.out.push_back(Output::Foreign { system });
        }
        while let Some((_, d)) = self.ground.poll_disagreement() {
            self.out.push_back(Output::Disagreement(d));
        }
        if self.dialog_on {
            self.questions(now);
        }
        // A ground event the vehicle has not reported: a heartbeat asked
        // for at the end of its window proves the vehicle's records
        // complete through it, so the check judges it then. Asked twice,
        // in two packets, for two heartbeats a publisher's gap apart: a
        // request or a heartbeat the radio loses (10 % of them, one time
        // in five for the pair) leaves the other, 0.25 s later, instead of
        // the periodic heartbeat up to a second later.
        while let Some(at) = self
            .ground
            .poll_heartbeat_wanted(self.replica.vehicle_time(now))
        {
            self.replica.ask_heartbeat(at);
            self.replica
                .ask_heartbeat(at.saturating_add(super::publisher::HEARTBEAT_ASKED_GAP));
        }
    }

    /// What a report changes beside the replica: the ground's check, the
    /// gap's detection time, the dialog.
    fn reported(&mut self, now: Micros, report: &Report) {
        if let (
            Report::Resynced {
                how: Repair::Snapshot,
                ..
            },
            Some(t),
        ) = (report, self.replica.exact_time())
        {
            self.ground.unknown_before(t);
        }
        match report {
            Report::Gap { from, .. } => {
                self.gap_seen = self.replica.vehicle_time(now).map(|t| (*from, t));
            }
            // The first missing record sent again: the radio lost it
            // when it was sent, at its step's time.
            Report::Step { number, time, .. }
                if self.gap_seen.is_some_and(|(n, _)| n == *number) =>
            {
                if let Some((_, seen)) = self.gap_seen.take() {
                    self.out.push_back(Output::GapDetected {
                        record: *number,
                        sent: *time,
                        detected_after: seen.saturating_sub(*time),
                    });
                }
            }
            _ => {}
        }
        if let Report::Step { inputs, .. } = report {
            for input in inputs {
                if let Input::Elaborated { time, boot, event } = input {
                    self.ground.vehicle_event(now, *time, *boot, event);
                }
            }
        }
        match report {
            Report::Step { effects, .. } | Report::Timers { effects, .. } => {
                for e in effects {
                    self.dialog.observe(&self.project, e);
                }
            }
            Report::Resynced {
                how: Repair::Snapshot,
                ..
            } => {
                if let Some((p, _)) = self.replica.shown() {
                    // A snapshot may be of another version.
                    self.project = p.project().clone();
                    self.dialog.sync(p);
                }
            }
            // What follows is of the new version's nets.
            Report::Version { version, .. } => self.project = version.project.clone(),
            _ => {}
        }
    }

    /// The questions pending, with their countdown (every 10 s, and each
    /// second of the last 5).
    fn questions(&mut self, now: Micros) {
        let vehicle_now = self.replica.vehicle_time(now);
        let dialog = &self.dialog;
        self.shown
            .retain(|id, _| dialog.pending().any(|q| q.id == *id));
        for q in self.dialog.pending() {
            let left = vehicle_now.map_or(q.deadline, |t| q.remaining(t)) / 1_000_000;
            let mark = if left <= 5 { left } else { left / 10 * 10 };
            if self.shown.get(&q.id) != Some(&mark) {
                self.out.push_back(Output::Question {
                    question: q.clone(),
                    first: !self.shown.contains_key(&q.id),
                    left,
                });
                self.shown.insert(q.id, mark);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    //! The station in simulated time: the real `Supervisor` and
    //! `Publisher` on board, their records as the TUNNEL frames the radio
    //! carries, lost by a rule; no socket, no clock.

    use mavlink::MavHeader;
    use nets::Event;

    use super::*;
    use crate::mirror::publisher::{self, Publisher};
    use crate::mirror::{step_inputs, Unread, COMPANION, MIRROR_SYSTEM};
    use crate::signing::Signer;
    use crate::supervisor::{Input as SupervisorInput, Supervisor};

    const VEHICLE: (u8, u8) = (1, COMPANION);
    const UNIX: u64 = 1_780_000_000_000_000;

    fn station(signing: Option<Key>) -> Station {
        let (project, profile) = crate::mirror::tests::example();
        let lanes = crate::team::lanes(
            &project,
            std::path::Path::new("."),
            &profile,
            crate::team::family(&[]),
            &elaboration::Config::default(),
        )
        .expect("lanes");
        Station::new(Config {
            project,
            system: MIRROR_SYSTEM,
            identity: (MIRROR_SYSTEM, 190),
            lanes,
            signing,
            dialog: true,
            record: false,
        })
    }

    /// A downlink packet as the onboard gateway frames it, to `to`.
    fn frame(seq: u8, to: u8, packet: &[u8], signer: Option<&mut Signer>, unix: u64) -> Vec<u8> {
        let tunnel = Tunnel::petrel((to, 0), packet.to_vec());
        let header = MavHeader {
            system_id: u32::from(VEHICLE.0),
            component_id: VEHICLE.1,
            sequence: seq,
        };
        match signer {
            Some(s) => s.sign_data(header, &tunnel, unix).raw_bytes().to_vec(),
            None => tunnel.unsigned_frame(VEHICLE, seq),
        }
    }

    fn outputs(s: &mut Station) -> Vec<Output> {
        std::iter::from_fn(|| s.poll_output()).collect()
    }

    /// The vehicle's side: its supervisor and publisher.
    struct Vehicle {
        supervisor: Supervisor,
        publisher: Publisher,
        seq: u8,
    }

    impl Vehicle {
        fn new() -> Vehicle {
            let (project, profile) = crate::mirror::tests::example();
            let (supervisor, _) =
                Supervisor::start(project, profile, elaboration::Config::default(), 0);
            Vehicle {
                supervisor,
                publisher: Publisher::new(7, publisher::Config::default(), 0),
                seq: 0,
            }
        }

        fn feed(&mut self, now: Micros, input: SupervisorInput) {
            let before = self.supervisor.player().state().now;
            let step = self.supervisor.step(now, input.clone());
            if let Some(inputs) = step_inputs(&input, &step, &Unread::none()) {
                let digest = self.supervisor.player().digest();
                self.publisher
                    .step(step.seq, before, step.time, inputs, &digest);
            }
        }

        /// Its packets of this turn, framed.
        fn frames(&mut self, now: Micros, mut signer: Option<&mut Signer>) -> Vec<Vec<u8>> {
            self.publisher
                .tick(now, self.supervisor.seq(), self.supervisor.player());
            let mut out = Vec::new();
            while let Some(p) = self.publisher.poll_transmit() {
                self.seq = self.seq.wrapping_add(1);
                out.push(frame(
                    self.seq,
                    MIRROR_SYSTEM,
                    &p,
                    signer.as_deref_mut(),
                    UNIX + now,
                ));
            }
            out
        }
    }

    /// Two minutes of a flight's program events and ticks, every fourth
    /// downlink frame lost: the station asks the onboard gateway (learnt
    /// from its records) for what was lost, and its replica ends equal to
    /// the vehicle's player.
    #[test]
    fn the_downlink_in_frames_keeps_the_replica_equal_and_requests_go_to_the_onboard_gateway() {
        let mut vehicle = Vehicle::new();
        let mut s = station(None);
        let names: Vec<String> = s.project().events.keys().cloned().collect();
        let (mut sent, mut lost, mut gaps, mut agreed) = (0u32, 0u32, 0u32, 0u32);
        for i in 0..1_200u64 {
            let now = i * 100_000;
            if i % 7 == 3 {
                let name = names[(i as usize / 7) % names.len()].clone();
                vehicle.feed(now, SupervisorInput::Event(Event::new(name)));
            } else {
                vehicle.feed(now, SupervisorInput::Tick);
            }
            // The last 10 s lose nothing, so that every gap is repaired.
            for f in vehicle.frames(now, None) {
                sent += 1;
                if sent % 4 == 0 && i < 1_100 {
                    lost += 1;
                    continue;
                }
                s.handle_frame(now, &f, UNIX + now);
            }
            s.handle_tick(now);
            while let Some((to, request)) = s.poll_transmit() {
                assert_eq!(to, VEHICLE, "requests go to the onboard gateway");
                vehicle.publisher.receive(request.bytes());
            }
            for o in outputs(&mut s) {
                match o {
                    Output::Report(Report::Gap { .. }) => gaps += 1,
                    Output::Report(Report::Agreed { .. }) => agreed += 1,
                    Output::Report(Report::Diverged { .. }) => panic!("a divergence"),
                    _ => {}
                }
            }
        }
        assert!(
            lost > 10 && gaps > 0 && agreed > 0,
            "{lost} lost, {gaps} gaps, {agreed} agreed"
        );
        let exact = s.replica().exact().expect("the replica ends exact");
        let mut exact = exact.clone();
        let player = vehicle.supervisor.player();
        exact.advance(player.state().now);
        assert_eq!(exact.digest(), player.digest());
    }

    /// With the vehicle's key, unsigned records and records signed with
    /// another key reach no replica; each reason is said once, all are
    /// counted. Records for another mirror are not this one's.
    #[test]
    fn unsigned_or_foreign_records_are_refused_said_once_and_others_mirrors_ignored() {
        let key = Key::new([5; 32]);
        let mut vehicle = Vehicle::new();
        let mut s = station(Some(key.clone()));
        let mut other = Signer::new(Key::new([6; 32]), 0, None);
        for i in 0..30u64 {
            let now = i * 100_000;
            vehicle.feed(now, SupervisorInput::Tick);
            // Each packet unsigned, then signed with another key.
            for f in vehicle.frames(now, None) {
                s.handle_frame(now, &f, UNIX + now);
                let tunnel = Frame::parse(&f).ok().and_then(|f| Tunnel::from_frame(&f));
                let packet = tunnel.expect("a downlink frame").payload;
                let forged = frame(0, MIRROR_SYSTEM, &packet, Some(&mut other), UNIX + now);
                s.handle_frame(now, &forged, UNIX + now);
            }
        }
        let refused: Vec<(u8, Rejection)> = outputs(&mut s)
            .into_iter()
            .filter_map(|o| match o {
                Output::Refused { system, why } => Some((system, why)),
                _ => None,
            })
            .collect();
        assert_eq!(
            refused,
            [(1, Rejection::Unsigned), (1, Rejection::BadSignature)]
        );
        assert_eq!(s.replica().counts.packets, 0);
        let r = s.signed().expect("signed").refusals();
        assert!(r.unsigned > 1 && r.bad_signature > 1, "{r:?}");
        assert_eq!(s.target(), None, "no record admitted: no onboard gateway");
        // Signed with the key, but for mirror 200: not played here.
        let mut signer = Signer::new(key, 0, None);
        let packet = [0u8; 4];
        let elsewhere = frame(1, 200, &packet, Some(&mut signer), UNIX + 3_000_000);
        s.handle_frame(3_000_000, &elsewhere, UNIX + 3_000_000);
        assert_eq!(s.replica().counts.packets, 0);
        assert!(outputs(&mut s).is_empty());
    }

    /// Silence is said once, on the station's time: nothing heard after
    /// 5 s; then the vehicle heard without a downlink record after 10 s.
    #[test]
    fn silence_and_a_missing_downlink_are_said_once_each() {
        let mut s = station(None);
        let said = |s: &mut Station| -> Vec<String> {
            outputs(s)
                .into_iter()
                .filter_map(|o| match o {
                    Output::NothingHeard => Some("nothing".to_owned()),
                    Output::NoDownlink { vehicle } => Some(format!("no downlink from {vehicle}")),
                    _ => None,
                })
                .collect()
        };
        for i in 0..49u64 {
            s.handle_tick(i * 100_000);
        }
        assert!(said(&mut s).is_empty());
        for i in 49..200u64 {
            s.handle_tick(i * 100_000);
        }
        assert_eq!(said(&mut s), ["nothing"]);
        // The autopilot heard from 20 s, never a downlink record.
        let mut heard = Vec::new();
        for i in 200..320u64 {
            let now = i * 100_000;
            if i % 10 == 0 {
                let hb = mavlink::dialects::ardupilotmega::MavMessage::HEARTBEAT(
                    mavlink::dialects::ardupilotmega::HEARTBEAT_DATA {
                        autopilot:
                            mavlink::dialects::ardupilotmega::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
                        mavtype: mavlink::dialects::ardupilotmega::MavType::MAV_TYPE_FIXED_WING,
                        mavlink_version: 3,
                        ..Default::default()
                    },
                );
                let header = MavHeader {
                    system_id: 1,
                    component_id: 1,
                    sequence: i as u8,
                };
                let bytes = elaboration::frame::serialize(header, mavlink::MavlinkVersion::V2, &hb);
                s.handle_frame(now, &bytes, UNIX + now);
            } else {
                s.handle_tick(now);
            }
            heard.extend(said(&mut s));
        }
        assert_eq!(heard, ["no downlink from 1"]);
    }
}
