//! The live board shared between the gateway's loop and the web server:
//! the loop writes it (`Feed`, once per step, after the step's commands
//! are out), each browser's task reads it at most `FRAME_RATE` times a
//! second, whatever the step rate. Nothing queues per browser: a browser
//! that reads slowly skips states, it never slows the loop or grows its
//! memory (a `watch` of the step number and one frame in flight).

use std::sync::{Arc, Mutex, MutexGuard};

use nets::Player;
use serde_json::{json, Value as Json};
use tokio::sync::watch;

use super::board::Board;
use petrel_core::supervisor::{Input, Step};

/// The log entries a live board keeps.
pub const LOG_LIVE: usize = 1000;
/// At most this many log entries in one frame (a browser that fell further
/// behind sees a gap, said in the frame).
const LOG_PER_FRAME: usize = 300;

/// What one browser has already been sent.
#[derive(Debug, Default)]
pub struct Cursor {
    log: u64,
    /// Per vehicle, the track points ever added when last sent.
    track: Vec<u64>,
    sent: bool,
}

/// The board, shared.
pub struct Live {
    board: Mutex<Board>,
    version: watch::Sender<u64>,
    /// The page (`/page.json`): the nets to draw, and how many times a new
    /// version of the project replaced them (a browser that drew another
    /// number loads the page again).
    page: Mutex<(u64, String)>,
}

impl Live {
    pub fn new(board: Board, page: Json) -> Arc<Live> {
        Arc::new(Live {
            board: Mutex::new(board),
            version: watch::Sender::new(0),
            page: Mutex::new((0, page.to_string())),
        })
    }

    /// The page, as `/page.json` serves it.
    pub fn page(&self) -> String {
        self.page
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .1
            .clone()
    }

    /// A new version of the project took over: its page replaces the last.
    pub fn replace_page(&self, page: Json) {
        let mut held = self.page.lock().unwrap_or_else(|e| e.into_inner());
        *held = (held.0 + 1, page.to_string());
    }

    fn lock(&self) -> MutexGuard<'_, Board> {
        // A panic elsewhere while holding it leaves the board as it was:
        // still worth showing.
        self.board.lock().unwrap_or_else(|e| e.into_inner())
    }

    pub fn subscribe(&self) -> watch::Receiver<u64> {
        self.version.subscribe()
    }

    /// The next frame for a browser at `cursor`: the marking, the strip, and
    /// the log entries and track points it has not had.
    pub fn frame(&self, cursor: &mut Cursor) -> Json {
        let page = self.page.lock().unwrap_or_else(|e| e.into_inner()).0;
        let board = self.lock();
        let project = board.project().clone();
        let mut frame = board.marking.json(&project, board.origin);
        frame["page"] = json!(page);
        let log = board.log();
        let first = log.front().map_or(board.next_entry(), |e| e.id);
        let from = cursor.log.max(first);
        let skip = (from - first) as usize;
        let new = log.len().saturating_sub(skip);
        let take = new.min(LOG_PER_FRAME);
        let gap = cursor.log < first || new > take;
        let entries: Vec<&Json> = log
            .iter()
            .skip(skip + (new - take))
            .map(|e| &e.json)
            .collect();
        frame["log"] = json!(entries);
        frame["log_gap"] = json!(gap && cursor.sent);
        cursor.log = board.next_entry();
        // Each vehicle's strip, with the track points this browser has not
        // had (all of them, `track_reset`, when it fell too far behind).
        let vehicles = &board.vehicle;
        cursor.track.resize(vehicles.all.len(), 0);
        let shown: Vec<Json> = vehicles
            .all
            .iter()
            .zip(&mut cursor.track)
            .map(|(v, sent)| {
                let mut j = super::vehicle::strip_json(v, &v.strip, vehicles.now);
                let fresh = (v.track_added.saturating_sub(*sent) as usize).min(v.track.len());
                let reset =
                    !cursor.sent || v.track_added.saturating_sub(*sent) > v.track.len() as u64;
                let points = if reset { v.track.len() } else { fresh };
                j["track"] = v.track[v.track.len() - points..]
                    .iter()
                    .map(|&(_, a, b)| json!([a, b]))
                    .collect::<Vec<_>>()
                    .into();
                j["track_reset"] = json!(reset);
                *sent = v.track_added;
                j
            })
            .collect();
        frame["vehicles"] = json!(shown);
        if let Some(m) = &board.mirror {
            frame["mirror"] = m.json();
        }
        cursor.sent = true;
        frame
    }
}

/// The gateway's side: feeds the board, never waits for a browser.
#[derive(Clone)]
pub struct Feed {
    live: Arc<Live>,
}

impl Feed {
    pub fn new(live: Arc<Live>) -> Feed {
        Feed { live }
    }

    /// The start's effects (step 0).
    pub fn start(&self, step: &Step, player: &Player) {
        self.live.lock().start(step, player);
        self.publish();
    }

    /// One step, `player` as it stands now.
    pub fn step(&self, input: &Input, step: &Step, player: &Player) {
        self.live.lock().step(input, step, player);
    }

    /// A new version of the project took over: the page shows its nets
    /// (`page::page` of it), and open pages load it again.
    pub fn replace_page(&self, page: Json) {
        self.live.replace_page(page);
    }

    /// Changes the board otherwise (the mirror's panel and replica).
    pub fn update(&self, change: impl FnOnce(&mut Board)) {
        change(&mut self.live.lock());
    }

    /// Tells the browsers' tasks that the board changed.
    pub fn publish(&self) {
        self.live.version.send_modify(|v| *v += 1);
    }
}

#[cfg(test)]
mod tests {
    use super::super::board::tests::{project, step};
    use super::*;

    #[test]
    fn a_browser_that_reads_late_gets_the_latest_state_and_a_bounded_frame() {
        let project = project();
        let mut player = Player::start(project.clone(), 0);
        let _ = player.effects().count();
        let board = Board::new(project.clone(), &player, 0, LOG_LIVE);
        let live = Live::new(board, json!({}));
        let feed = Feed::new(live.clone());
        let mut cursor = Cursor::default();
        let first = live.frame(&mut cursor);
        assert_eq!(first["log"], json!([]));
        // Ten thousand steps while the browser reads nothing.
        for i in 0..10_000u64 {
            let name = if i % 2 == 0 { "x" } else { "y" };
            let input = Input::Event(nets::Event::new(name));
            let s = step(&mut player, i + 1, (i + 1) * 1000, &input);
            feed.step(&input, &s, &player);
        }
        feed.publish();
        assert!(live.lock().log().len() <= LOG_LIVE, "the log is bounded");
        let frame = live.frame(&mut cursor);
        assert_eq!(frame["seq"], 10_000);
        assert_eq!(frame["log"].as_array().map(Vec::len), Some(LOG_PER_FRAME));
        assert_eq!(frame["log_gap"], true, "the skipped entries are said");
        let last = frame["log"].as_array().and_then(|a| a.last()).cloned();
        assert_eq!(last.map(|l| l["name"].clone()), Some(json!("y")));
        assert_eq!(
            frame["marked"],
            json!([project.flat(0, nets::model::PlaceRef::Local(0))])
        );
        // Nothing new: nothing resent.
        let again = live.frame(&mut cursor);
        assert_eq!(again["log"], json!([]));
        assert_eq!(again["log_gap"], false);
    }

    #[test]
    fn each_team_vehicle_has_its_strip_and_its_track_sent_once() {
        use super::super::vehicle::tests::{heartbeat, position};
        let project = super::super::board::tests::team();
        let mut player = Player::start(project.clone(), 0);
        let _ = player.effects().count();
        let board = Board::new(project.clone(), &player, 0, LOG_LIVE);
        let live = Live::new(board, json!({}));
        let feed = Feed::new(live.clone());
        let mut cursor = Cursor::default();
        let mut seq = 0;
        let mut feed_frame = |bytes: Vec<u8>, time: u64| {
            seq += 1;
            let input = Input::Frame(&bytes);
            let s = step(&mut player, seq, time, &input);
            feed.step(&input, &s, &player);
        };
        feed_frame(heartbeat(1, 15, true), 1_000_000);
        feed_frame(heartbeat(2, 4, false), 1_000_000);
        // Two points each, far apart (a point at least every 15 m).
        for (i, time) in [(0.0, 2_000_000), (0.001, 3_000_000)] {
            feed_frame(position(1, 51.0 + i, -2.0), time);
            feed_frame(position(2, 52.0 + i, -2.0), time);
        }
        let first = live.frame(&mut cursor);
        let vehicles = first["vehicles"].as_array().cloned().unwrap_or_default();
        assert_eq!(vehicles.len(), 2);
        assert_eq!(vehicles[0]["name"], "R1");
        assert_eq!(vehicles[0]["mode"], "GUIDED");
        assert_eq!(vehicles[1]["mode"], "HOLD");
        assert_eq!(vehicles[0]["track"], json!([[51.0, -2.0], [51.001, -2.0]]));
        assert_eq!(vehicles[1]["track"], json!([[52.0, -2.0], [52.001, -2.0]]));
        assert_eq!(vehicles[1]["track_reset"], true);
        // Only R2 moves on: R2's new point alone is sent.
        feed_frame(position(2, 52.002, -2.0), 4_000_000);
        let next = live.frame(&mut cursor);
        assert_eq!(next["vehicles"][0]["track"], json!([]));
        assert_eq!(next["vehicles"][1]["track"], json!([[52.002, -2.0]]));
        assert_eq!(next["vehicles"][1]["track_reset"], false);
        assert_eq!(next["vehicles"][1]["position"], json!([52.002, -2.0]));
    }
}
