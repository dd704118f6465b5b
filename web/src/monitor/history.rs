//! A recording's index for `petrel view`: built in one pass while the
//! player replays the recording's own inputs (the replay path), it keeps
//! what the page shows each time it changes — the marking part at every
//! step that changed it, each vehicle's strip at every change, the whole
//! log and each vehicle's track — so that the state at any instant is a few binary
//! searches away, never a replay.

use std::sync::Arc;

use nets::{Micros, Player, Project};
use serde_json::{json, Value as Json};

use super::board::{seconds, Board, Entry, Marking};
use super::vehicle::{strip_json, Strip, Vehicle};
use petrel_core::supervisor::{Input, Step};

/// Log entries sent with one instant (the latest up to it).
const LOG_SHOWN: usize = 300;

/// The index of a recording.
pub struct History {
    /// The project's versions, each from the instant it took over (the
    /// first from the start), and the page of each (`/page.json?v=N`).
    versions: Vec<(Micros, Arc<Project>)>,
    pages: Vec<String>,
    pub origin: Micros,
    pub start: Micros,
    pub end: Micros,
    /// Every step's time, in order (the step at an instant).
    steps: Vec<Micros>,
    keys: Vec<Marking>,
    /// Per vehicle (team order): the vehicle, its strip at each change.
    vehicles: Vec<(Vehicle, Vec<(Micros, Strip)>)>,
    log: Vec<Entry>,
    /// Sorted, deduplicated instants where the nets changed or the log
    /// grew (where stepping stops).
    moments: Vec<Micros>,
}

/// Builds a [`History`] as the steps are replayed.
pub struct Builder {
    board: Board,
    /// The project's versions, from the instant each took over.
    versions: Vec<(Micros, Arc<Project>)>,
    steps: Vec<Micros>,
    keys: Vec<Marking>,
    /// Per vehicle, its strip at each change.
    strips: Vec<Vec<(Micros, Strip)>>,
}

impl Builder {
    /// From the player's start (step 0).
    pub fn new(project: Arc<Project>, start: &Step, player: &Player, origin: Micros) -> Builder {
        let mut board = Board::new(project.clone(), player, origin, usize::MAX);
        board.start(start, player);
        let keys = vec![board.marking.clone()];
        let strips = vec![Vec::new(); board.vehicle.all.len()];
        Builder {
            board,
            versions: vec![(start.time, project)],
            steps: vec![start.time],
            keys,
            strips,
        }
    }

    pub fn step(&mut self, input: &Input, step: &Step, player: &Player) {
        self.board.step(input, step, player);
        if self
            .versions
            .last()
            .is_none_or(|(_, p)| !Arc::ptr_eq(p, self.board.project()))
        {
            self.versions
                .push((step.time, self.board.project().clone()));
        }
        self.steps.push(step.time);
        if self.board.marking_changed {
            self.keys.push(self.board.marking.clone());
        }
        if self.board.vehicle.changed {
            for (v, strips) in self.board.vehicle.all.iter().zip(&mut self.strips) {
                if v.changed {
                    strips.push((step.time, v.strip.clone()));
                }
            }
        }
    }

    /// The index, each version's page made by `page_of`.
    pub fn finish(self, page_of: impl Fn(&Project) -> Json) -> History {
        let Builder {
            board,
            versions,
            steps,
            keys,
            strips,
        } = self;
        let origin = board.origin;
        let start = steps.first().copied().unwrap_or(origin);
        let end = steps.last().copied().unwrap_or(start);
        let log: Vec<Entry> = board.log().iter().cloned().collect();
        let vehicles: Vec<(Vehicle, Vec<(Micros, Strip)>)> =
            board.vehicle.all.iter().cloned().zip(strips).collect();
        let mut moments: Vec<Micros> = keys
            .iter()
            .map(|k| k.time)
            .chain(log.iter().map(|e| e.time))
            .collect();
        moments.sort_unstable();
        moments.dedup();
        let marks: Vec<Json> = log
            .iter()
            .filter(|e| {
                e.category.is_some() || e.json["kind"] == "fault" || e.json["kind"] == "lockout"
            })
            .map(|e| {
                let category = e
                    .category
                    .map_or(e.json["kind"].as_str().unwrap_or(""), |c| c.as_str());
                json!([
                    seconds(e.time, origin),
                    category,
                    e.json["name"]
                        .as_str()
                        .unwrap_or(e.json["kind"].as_str().unwrap_or(""))
                ])
            })
            .collect();
        let timeline = json!({"start": seconds(start, origin), "end": seconds(end, origin),
                              "start_us": start, "end_us": end, "origin_us": origin,
                              "marks": marks, "steps": steps.len()});
        let pages = versions
            .iter()
            .map(|(_, project)| {
                let mut page = page_of(project);
                page["timeline"] = timeline.clone();
                page.to_string()
            })
            .collect();
        History {
            versions,
            pages,
            origin,
            start,
            end,
            steps,
            keys,
            vehicles,
            log,
            moments,
        }
    }
}

impl History {
    /// The page of version `v` (0: the one the flight started with).
    pub fn page(&self, v: usize) -> String {
        self.pages
            .get(v)
            .or(self.pages.first())
            .cloned()
            .unwrap_or_default()
    }

    /// The version the nets ran at `at` (its index) and its project.
    fn version_at(&self, at: Micros) -> (usize, &Arc<Project>) {
        let i = self.versions.partition_point(|(t, _)| *t <= at).max(1) - 1;
        (i, &self.versions[i].1)
    }

    /// The next (`dir` > 0) or previous moment something changed, from `at`.
    pub fn moment(&self, at: Micros, dir: i64) -> Micros {
        if dir > 0 {
            let i = self.moments.partition_point(|&m| m <= at);
            self.moments.get(i).copied().unwrap_or(self.end)
        } else {
            let i = self.moments.partition_point(|&m| m < at);
            i.checked_sub(1)
                .and_then(|i| self.moments.get(i))
                .copied()
                .unwrap_or(self.start)
        }
    }

    /// The marking part at `at`: after the last step at or before it.
    pub fn marking_at(&self, at: Micros) -> &Marking {
        let i = self.keys.partition_point(|k| k.time <= at).max(1) - 1;
        &self.keys[i]
    }

    /// The page's frame for instant `at` (clamped to the recording).
    pub fn frame_at(&self, at: Micros) -> Json {
        let at = at.clamp(self.start, self.end);
        let (version, project) = self.version_at(at);
        let mut frame = self.marking_at(at).json(project, self.origin);
        // Which version's page draws it (another: the page loads it).
        frame["page"] = json!(version);
        let seq = self.steps.partition_point(|&t| t <= at).max(1) - 1;
        frame["seq"] = json!(seq);
        frame["time_us"] = json!(at);
        frame["t"] = json!(seconds(at, self.origin));
        let n = self.log.partition_point(|e| e.time <= at);
        let entries: Vec<&Json> = self.log[n.saturating_sub(LOG_SHOWN)..n]
            .iter()
            .map(|e| &e.json)
            .collect();
        frame["log"] = json!(entries);
        frame["log_reset"] = json!(true);
        let vehicles: Vec<Json> = self
            .vehicles
            .iter()
            .map(|(v, strips)| {
                let s = strips.partition_point(|s| s.0 <= at);
                let strip = s.checked_sub(1).map(|i| &strips[i].1);
                let mut j = strip_json(v, strip.unwrap_or(&Strip::default()), at);
                let k = v.track.partition_point(|p| p.0 <= at);
                j["track"] = v.track[..k]
                    .iter()
                    .map(|&(_, a, b)| json!([a, b]))
                    .collect::<Vec<_>>()
                    .into();
                j["track_reset"] = json!(true);
                j
            })
            .collect();
        frame["vehicles"] = json!(vehicles);
        frame
    }
}

#[cfg(test)]
mod tests {
    use super::super::board::tests::{project, step};
    use super::*;

    #[test]
    fn an_instant_after_a_new_version_is_drawn_with_its_page() {
        let project = project();
        let mut player = Player::start(project.clone(), 0);
        let start = Step {
            seq: 0,
            time: 0,
            events: Vec::new(),
            effects: player.effects().collect(),
        };
        let mut builder = Builder::new(project.clone(), &start, &player, 0);
        let x = Input::Event(nets::Event::new("x"));
        let s = step(&mut player, 1, 1_000_000, &x);
        builder.step(&x, &s, &player);
        // Version 1: a net before A (A's places numbered after B's).
        let files = [
            (
                "project.toml",
                "[[net]]\nfile = \"b.toml\"\nactive = true\n[[net]]\nfile = \"a.toml\"\nactive = true\n[events]\nx = {}\ny = {}\n",
            ),
            (
                "b.toml",
                "name = \"B\"\nplaces = [\"p\", \"q\"]\ninitial = [\"p\"]\nfinal = [\"q\"]\n[[transition]]\nname = \"t\"\nfrom = [\"p\"]\nto = [\"q\"]\non = \"y\"\n",
            ),
            (
                "a.toml",
                "name = \"A\"\nplaces = [\"idle\", \"on\"]\ninitial = [\"idle\"]\n[[transition]]\nname = \"go\"\nfrom = [\"idle\"]\nto = [\"on\"]\non = \"x\"\ndo = [\"command arm\"]\n[[transition]]\nname = \"back\"\nfrom = [\"on\"]\nto = [\"idle\"]\non = \"y\"\n",
            ),
        ];
        let new = Arc::new(nets::load(&files).unwrap_or_else(|e| panic!("{e}")));
        let version = Arc::new(petrel_core::version::Version {
            number: 1,
            project: new.clone(),
            files: Vec::new(),
        });
        let input = Input::Version(&version);
        let s = step(&mut player, 2, 2_000_000, &input);
        builder.step(&input, &s, &player);
        let history = builder.finish(|p| json!({"name": p.nets[0].name}));
        let before = history.frame_at(1_500_000);
        let after = history.frame_at(2_500_000);
        assert_eq!(
            (before["page"].clone(), after["page"].clone()),
            (json!(0), json!(1))
        );
        // A.on: flat 1 in version 0, flat 3 in version 1 (B's two first).
        assert_eq!(before["marked"], json!([1]));
        assert_eq!(
            after["marked"],
            json!([
                new.flat(0, nets::model::PlaceRef::Local(0)),
                new.flat(1, nets::model::PlaceRef::Local(1))
            ])
        );
        assert!(history.page(0).contains("\"A\"") && history.page(1).contains("\"B\""));
        // An unknown version's page is the first.
        assert_eq!(history.page(9), history.page(0));
    }

    #[test]
    fn any_instant_shows_the_state_after_the_last_step_before_it() {
        let project = project();
        let mut player = Player::start(project.clone(), 0);
        let start = Step {
            seq: 0,
            time: 0,
            events: Vec::new(),
            effects: player.effects().collect(),
        };
        let mut builder = Builder::new(project.clone(), &start, &player, 0);
        let mut after = vec![(0, player.state().marking.clone())];
        for i in 1..=40u64 {
            let input = match i % 5 {
                0 => Input::Tick,
                1 | 3 => Input::Event(nets::Event::new("x")),
                _ => Input::Event(nets::Event::new("y")),
            };
            let s = step(&mut player, i, i * 1_000_000, &input);
            builder.step(&input, &s, &player);
            after.push((i * 1_000_000, player.state().marking.clone()));
        }
        let history = builder.finish(|_| json!({}));
        for (time, marking) in &after {
            for at in [*time, time + 500_000] {
                let frame = history.frame_at(at);
                let marked: Vec<usize> = (0..project.place_count)
                    .filter(|&p| marking[p / 64] & (1 << (p % 64)) != 0)
                    .collect();
                assert_eq!(frame["marked"], json!(marked), "at {at}");
                let last = frame["log"].as_array().and_then(|l| l.last()).cloned();
                if let Some(l) = last {
                    assert!(l["t"].as_f64() <= Some(at as f64 / 1e6), "{l} after {at}");
                }
            }
        }
        assert_eq!(history.moment(2_000_000, 1), 3_000_000);
        assert_eq!(history.moment(2_000_000, -1), 1_000_000);
        assert_eq!(history.frame_at(u64::MAX)["time_us"], 40_000_000);
    }

    #[test]
    fn a_teams_strips_and_tracks_at_any_instant_are_each_vehicles_own() {
        use super::super::vehicle::tests::{heartbeat, position};
        let project = super::super::board::tests::team();
        let mut player = Player::start(project.clone(), 0);
        let start = Step {
            seq: 0,
            time: 0,
            events: Vec::new(),
            effects: player.effects().collect(),
        };
        let mut builder = Builder::new(project.clone(), &start, &player, 0);
        let frames = [
            (1_000_000, heartbeat(1, 15, true)),
            (1_000_000, heartbeat(2, 4, false)),
            (2_000_000, position(1, 51.0, -2.0)),
            (3_000_000, position(2, 52.0, -2.0)),
            (4_000_000, heartbeat(2, 15, true)),
            (5_000_000, position(1, 51.001, -2.0)),
        ];
        for (i, (time, bytes)) in frames.iter().enumerate() {
            let input = Input::Frame(bytes);
            let s = step(&mut player, i as u64 + 1, *time, &input);
            builder.step(&input, &s, &player);
        }
        let history = builder.finish(|_| json!({}));
        let at = |t: u64| history.frame_at(t)["vehicles"].clone();
        let v = at(3_500_000);
        assert_eq!((&v[0]["name"], &v[1]["name"]), (&json!("R1"), &json!("R2")));
        assert_eq!(v[0]["track"], json!([[51.0, -2.0]]));
        assert_eq!(v[1]["track"], json!([[52.0, -2.0]]));
        assert_eq!(
            (&v[0]["mode"], &v[1]["mode"]),
            (&json!("GUIDED"), &json!("HOLD"))
        );
        let v = at(5_000_000);
        assert_eq!(v[0]["track"], json!([[51.0, -2.0], [51.001, -2.0]]));
        assert_eq!(v[1]["mode"], "GUIDED", "R2's strip as changed at 4 s");
        assert_eq!(v[1]["armed"], true);
        let v = at(1_500_000);
        assert_eq!(
            (&v[0]["track"], &v[0]["position"]),
            (&json!([]), &Json::Null)
        );
    }
}
