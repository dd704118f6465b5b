//! DEC's decisions, without I/O: the functions the nets call, each taking
//! the call's arguments and giving the parameters of its `done` reply or
//! the reason of its `failed` one. DEC keeps the active plan (the one on
//! the vehicle), the progress along it (the last item reached), the
//! payloads that failed, a proposed plan waiting for its upload, and the
//! last emergency site chosen.

use std::collections::BTreeSet;

use serde_json::{json, Map, Value};

use crate::emergency::{self, Choice};
use crate::geo::LatLon;
use crate::mission::Mission;
use crate::plan::{Phase, Plan, Role};

/// Every function DEC serves, as its hello says.
pub const FUNCTIONS: &[&str] = &[
    "plan",
    "item",
    "payload_failed",
    "replan",
    "adopt",
    "emergency_site",
    "emergency_plan",
];

/// The parameters of a `done` reply, or the reason of a `failed` one.
pub type Answer = Result<Map<String, Value>, String>;

/// DEC's state.
#[derive(Debug, Clone)]
pub struct Dec {
    mission: Mission,
    /// The plan the vehicle flies (after `plan` or `adopt`).
    active: Option<Plan>,
    /// The highest seq of `active` reached.
    last_reached: u16,
    /// Once an item was reached (or a plan without take-off adopted).
    airborne: bool,
    failed: BTreeSet<String>,
    proposed: Option<Plan>,
    emergency: Option<Choice>,
    /// Calls answered by this process.
    calls: u64,
}

impl Dec {
    pub fn new(mission: Mission) -> Dec {
        Dec {
            mission,
            active: None,
            last_reached: 0,
            airborne: false,
            failed: BTreeSet::new(),
            proposed: None,
            emergency: None,
            calls: 0,
        }
    }

    /// Calls answered by this process so far.
    pub fn calls(&self) -> u64 {
        self.calls
    }

    /// After a restart: answers again, in order, the calls the process
    /// before it answered (the welcome's `resume.answered`), so that the
    /// plan, the progress, the failed payloads and the emergency site are
    /// what they were. DEC's answers depend only on the calls it answered
    /// before, so replaying them rebuilds its state exactly.
    pub fn resume(&mut self, answered: &[(String, Map<String, Value>)]) {
        for (function, args) in answered {
            let _ = self.call(function, args);
        }
    }

    pub fn mission(&self) -> &Mission {
        &self.mission
    }

    /// The payloads recorded as failed.
    pub fn failed(&self) -> impl Iterator<Item = &str> {
        self.failed.iter().map(String::as_str)
    }

    /// Answers a call of `function` with `args` (a JSON object).
    pub fn call(&mut self, function: &str, args: &Map<String, Value>) -> Answer {
        self.calls += 1;
        match function {
            "plan" => self.plan(),
            "item" => {
                let seq = arg_seq(args)?;
                self.item(seq)
            }
            "payload_failed" => {
                let failed = args.get("failed").ok_or("missing argument `failed`")?;
                Ok(self.payload_failed(failed))
            }
            "replan" => Ok(self.replan()),
            "adopt" => self.adopt(),
            "emergency_site" => {
                let lat = arg_number(args, "lat")?;
                let lon = arg_number(args, "lon")?;
                let alt = arg_number(args, "alt")?;
                if !(-90.0..=90.0).contains(&lat) || !(-180.0..=180.0).contains(&lon) {
                    return Err(format!("no position at lat {lat}, lon {lon}"));
                }
                self.emergency_site(LatLon::new(lat, lon), alt)
            }
            "emergency_plan" => self
                .emergency
                .as_ref()
                .map(choice_params)
                .ok_or_else(|| "no emergency site chosen yet".to_owned()),
            other => Err(format!("DEC serves no function `{other}`")),
        }
    }

    fn excluded(&self) -> impl Fn(usize) -> bool + '_ {
        |i| {
            self.mission.waypoints[i]
                .payload
                .as_ref()
                .is_some_and(|p| self.failed.contains(p))
        }
    }

    /// `plan {}` → `{items, count}`: the whole mission from the ground,
    /// without the waypoints of failed payloads. It becomes the active plan.
    pub fn plan(&mut self) -> Answer {
        let route: Vec<usize> = (0..self.mission.waypoints.len())
            .filter(|&i| !(self.excluded())(i))
            .collect();
        let plan = Plan::build(&self.mission, &route, !self.airborne);
        let out = plan_params(&plan, &self.mission);
        self.active = Some(plan);
        self.last_reached = 0;
        self.proposed = None;
        Ok(out)
    }

    /// `item {seq}` → `{seq, phase, payload, waypoint}`: what reaching item
    /// `seq` of the active plan means — the phase the aircraft is now in,
    /// the payload that must operate now ("" none), the waypoint's name.
    ///
    /// DO_LAND_START is a DO command: ArduPilot runs it (and reports it
    /// reached) as soon as the navigation item before it starts — the last
    /// loiter, still under way —, or on a `land` jump. Reaching it says
    /// nothing of where the aircraft is: phase `none`, and no progress.
    pub fn item(&mut self, seq: u16) -> Answer {
        let plan = self.active.as_ref().ok_or("no plan yet")?;
        let (Some(item), Some(phase)) = (plan.item(seq), plan.phase_after(seq)) else {
            return Err(format!(
                "item {seq} is not in the plan (items 1 to {})",
                plan.items.len()
            ));
        };
        let payload = match (item.role, item.waypoint) {
            (Role::Arrival, Some(w)) => self.mission.waypoints[w].payload.clone(),
            _ => None,
        };
        let waypoint = match (item.role, item.waypoint) {
            (_, Some(w)) => self.mission.waypoints[w].name.clone(),
            (Role::Takeoff, _) => "takeoff".into(),
            (Role::LandStart, _) => "landing sequence".into(),
            (Role::Approach, _) => "approach".into(),
            _ => "home".into(),
        };
        let phase = if item.role == Role::LandStart {
            "none"
        } else {
            self.last_reached = self.last_reached.max(seq);
            phase.name()
        };
        self.airborne = true;
        Ok(params(json!({
            "seq": seq,
            "phase": phase,
            "payload": payload.unwrap_or_default(),
            "waypoint": waypoint,
        })))
    }

    /// `payload_failed {failed}` → `{payload, known}`: records a failed
    /// payload, named by its MAVLink component id or its name ("" names
    /// none).
    pub fn payload_failed(&mut self, failed: &Value) -> Map<String, Value> {
        match self.mission.payload_named(failed).map(str::to_owned) {
            Some(name) => {
                self.failed.insert(name.clone());
                params(json!({"payload": name, "known": true}))
            }
            None => params(json!({"payload": "", "known": false})),
        }
    }

    /// `replan {}` → `{changed, items, count, skipped}`: the rest of the
    /// route (from the last item reached) without the waypoints of failed
    /// payloads, and the landing sequence. Unchanged (`changed` false,
    /// no items) when nothing left needs a failed payload. The plan is
    /// proposed: `adopt` makes it active once the vehicle holds it.
    pub fn replan(&mut self) -> Map<String, Value> {
        let unchanged = params(json!({"changed": false, "items": [], "count": 0, "skipped": []}));
        // No plan yet: the first `plan` will leave the failed payloads out.
        let Some(active) = &self.active else {
            return unchanged;
        };
        let remaining = active.remaining(self.last_reached);
        let (kept, skipped): (Vec<usize>, Vec<usize>) = {
            let excluded = self.excluded();
            remaining.iter().partition(|&&i| !excluded(i))
        };
        if skipped.is_empty() {
            return unchanged;
        }
        let plan = Plan::build(&self.mission, &kept, !self.airborne);
        let mut out = plan_params(&plan, &self.mission);
        out.insert("changed".into(), Value::Bool(true));
        out.insert(
            "skipped".into(),
            skipped
                .iter()
                .map(|&i| Value::String(self.mission.waypoints[i].name.clone()))
                .collect(),
        );
        self.proposed = Some(plan);
        out
    }

    /// `adopt {}` → `{count}`: the proposed plan is on the vehicle: it is
    /// the active one, flown from its first item.
    pub fn adopt(&mut self) -> Answer {
        let plan = self.proposed.take().ok_or("no plan proposed")?;
        if plan.items.first().is_some_and(|i| i.role != Role::Takeoff) {
            self.airborne = true;
        }
        let count = plan.items.len();
        self.active = Some(plan);
        self.last_reached = 0;
        Ok(params(json!({"count": count})))
    }

    /// `emergency_site {lat, lon, alt}` → `{name, lat, lon, distance,
    /// reachable, items}`: the nearest site reachable in a glide and its
    /// mission; remembered for `emergency_plan {}`.
    pub fn emergency_site(&mut self, from: LatLon, alt: f64) -> Answer {
        let choice = emergency::choose(&self.mission, from, alt).ok_or("no emergency site")?;
        let out = choice_params(&choice);
        self.emergency = Some(choice);
        Ok(out)
    }

    /// The phase the active plan's next item belongs to (for logs).
    pub fn phase(&self) -> Option<Phase> {
        let plan = self.active.as_ref()?;
        plan.item(self.last_reached + 1)
            .or(plan.items.last())
            .map(|i| i.phase)
    }
}

fn params(v: Value) -> Map<String, Value> {
    match v {
        Value::Object(m) => m,
        _ => Map::new(),
    }
}

fn plan_params(plan: &Plan, mission: &Mission) -> Map<String, Value> {
    params(json!({"items": plan.to_json(mission), "count": plan.items.len()}))
}

fn choice_params(c: &Choice) -> Map<String, Value> {
    params(json!({
        "name": c.name,
        "lat": c.at.lat,
        "lon": c.at.lon,
        "distance": (c.distance * 10.0).round() / 10.0,
        "reachable": c.reachable,
        "items": c.items,
    }))
}

fn arg_number(args: &Map<String, Value>, name: &str) -> Result<f64, String> {
    match args.get(name) {
        None => Err(format!("missing argument `{name}`")),
        Some(v) => v
            .as_f64()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("argument `{name}` must be a number, not {v}")),
    }
}

fn arg_seq(args: &Map<String, Value>) -> Result<u16, String> {
    let x = arg_number(args, "seq")?;
    if x.fract() != 0.0 || !(0.0..=f64::from(u16::MAX)).contains(&x) {
        return Err(format!(
            "argument `seq` must be a mission item number, not {x}"
        ));
    }
    Ok(x as u16)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mission::tests::example;

    fn call(dec: &mut Dec, function: &str, args: Value) -> Answer {
        dec.call(function, &params(args))
    }

    fn ok(answer: Answer) -> Map<String, Value> {
        match answer {
            Ok(m) => m,
            Err(e) => panic!("failed: {e}"),
        }
    }

    fn item(dec: &mut Dec, seq: u16) -> (String, String) {
        let a = ok(call(dec, "item", json!({"seq": seq})));
        (
            a["phase"].as_str().unwrap_or("?").to_owned(),
            a["payload"].as_str().unwrap_or("?").to_owned(),
        )
    }

    fn commands(items: &Value) -> Vec<&str> {
        items
            .as_array()
            .map(|a| a.iter().filter_map(|i| i["command"].as_str()).collect())
            .unwrap_or_default()
    }

    #[test]
    fn a_nominal_flight_item_by_item() {
        let mut dec = Dec::new(example());
        let plan = ok(call(&mut dec, "plan", json!({})));
        assert_eq!(plan["count"], 11);
        assert_eq!(commands(&plan["items"]).len(), 11);
        let seen: Vec<(String, String)> = (1..=11).map(|s| item(&mut dec, s)).collect();
        let expect = [
            ("transit", ""),
            ("operations", ""),
            ("operations", "camera"),
            ("operations", ""),
            ("operations", "sensor"),
            ("operations", ""),
            ("operations", "camera"),
            ("return", ""),
            ("none", ""), // DO_LAND_START: reported as O3's loiter starts
            ("landing", ""),
            ("landing", ""),
        ];
        let expect: Vec<(String, String)> = expect
            .iter()
            .map(|(a, b)| ((*a).to_owned(), (*b).to_owned()))
            .collect();
        assert_eq!(seen, expect);
        let a = ok(call(&mut dec, "item", json!({"seq": 3})));
        assert_eq!(a["waypoint"], "O1");
        assert_eq!(a["seq"], 3);
    }

    #[test]
    fn a_restarted_dec_replaying_its_answers_decides_as_before() {
        let mut dec = Dec::new(example());
        let mut answered = Vec::new();
        let mut ask = |dec: &mut Dec, f: &str, args: Value| {
            answered.push((f.to_owned(), args.as_object().cloned().unwrap_or_default()));
            call(dec, f, args)
        };
        ok(ask(&mut dec, "plan", json!({})));
        ok(ask(&mut dec, "item", json!({"seq": 3})));
        ok(ask(&mut dec, "payload_failed", json!({"failed": "camera"})));
        ok(ask(&mut dec, "replan", json!({})));
        // A fresh process knows nothing; replayed, it answers as the first.
        let mut fresh = Dec::new(example());
        assert!(call(&mut fresh, "adopt", json!({})).is_err());
        let mut restarted = Dec::new(example());
        restarted.resume(&answered);
        assert_eq!(restarted.calls(), 4);
        assert_eq!(
            call(&mut restarted, "adopt", json!({})),
            call(&mut dec, "adopt", json!({}))
        );
        assert_eq!(
            call(&mut restarted, "item", json!({"seq": 4})),
            call(&mut dec, "item", json!({"seq": 4}))
        );
        assert_eq!(restarted.failed().collect::<Vec<_>>(), ["camera"]);
    }

    #[test]
    fn items_outside_the_plan_and_bad_arguments_fail() {
        let mut dec = Dec::new(example());
        assert_eq!(
            call(&mut dec, "item", json!({"seq": 1})),
            Err("no plan yet".into())
        );
        ok(call(&mut dec, "plan", json!({})));
        assert!(call(&mut dec, "item", json!({"seq": 0})).is_err());
        assert!(call(&mut dec, "item", json!({"seq": 12})).is_err());
        assert!(call(&mut dec, "item", json!({"seq": 2.5})).is_err());
        assert!(call(&mut dec, "item", json!({"seq": "3"})).is_err());
        assert!(call(&mut dec, "item", json!({})).is_err());
        assert!(call(
            &mut dec,
            "emergency_site",
            json!({"lat": 95, "lon": 0, "alt": 50})
        )
        .is_err());
        assert!(call(&mut dec, "warp", json!({})).is_err());
        // A float that is an integer is a fine seq (JSON numbers).
        assert!(call(&mut dec, "item", json!({"seq": 2.0})).is_ok());
    }

    #[test]
    fn camera_failure_at_o1_skips_the_camera_waypoints() {
        let mut dec = Dec::new(example());
        ok(call(&mut dec, "plan", json!({})));
        for s in 1..=3 {
            item(&mut dec, s); // at O1, camera operating
        }
        let f = ok(call(&mut dec, "payload_failed", json!({"failed": 100})));
        assert_eq!(
            (f["payload"].as_str(), f["known"].as_bool()),
            (Some("camera"), Some(true))
        );
        let r = ok(call(&mut dec, "replan", json!({})));
        assert_eq!(r["changed"], true);
        assert_eq!(r["skipped"], json!(["O1", "O3"]));
        // No take-off: it flies. O2 with its sensor, then home.
        assert_eq!(
            commands(&r["items"]),
            [
                "WAYPOINT",
                "LOITER_TIME",
                "DO_LAND_START",
                "WAYPOINT",
                "LAND"
            ]
        );
        // Until adopted, items are the old plan's.
        assert_eq!(item(&mut dec, 4), ("operations".into(), "".into()));
        let a = ok(call(&mut dec, "adopt", json!({})));
        assert_eq!(a["count"], 5);
        assert_eq!(item(&mut dec, 1), ("operations".into(), "sensor".into()));
        assert_eq!(item(&mut dec, 2), ("return".into(), "".into()));
        assert_eq!(item(&mut dec, 3), ("none".into(), "".into()));
        // Checked again: nothing more to change.
        let r = ok(call(&mut dec, "replan", json!({})));
        assert_eq!(r["changed"], false);
        assert_eq!(r["items"], json!([]));
        assert!(call(&mut dec, "adopt", json!({})).is_err());
    }

    #[test]
    fn a_failure_nothing_needs_any_more_changes_nothing() {
        let mut dec = Dec::new(example());
        ok(call(&mut dec, "plan", json!({})));
        for s in 1..=6 {
            item(&mut dec, s); // O2 done: O3 (camera) left
        }
        ok(call(
            &mut dec,
            "payload_failed",
            json!({"failed": "sensor"}),
        ));
        let r = ok(call(&mut dec, "replan", json!({})));
        assert_eq!(r["changed"], false);
        // Past the operations area, even the camera changes nothing.
        for s in 7..=9 {
            item(&mut dec, s);
        }
        ok(call(&mut dec, "payload_failed", json!({"failed": 100})));
        assert_eq!(ok(call(&mut dec, "replan", json!({})))["changed"], false);
        assert_eq!(dec.failed().collect::<Vec<_>>(), ["camera", "sensor"]);
    }

    #[test]
    fn the_landing_sequence_start_is_no_progress() {
        // ArduPilot reports DO_LAND_START (9) reached as O3's loiter (8)
        // starts: O3 is still under way, a camera failure now skips it.
        let mut dec = Dec::new(example());
        ok(call(&mut dec, "plan", json!({})));
        for s in [1, 2, 3, 4, 5, 6, 7, 9] {
            item(&mut dec, s);
        }
        ok(call(&mut dec, "payload_failed", json!({"failed": 100})));
        let r = ok(call(&mut dec, "replan", json!({})));
        assert_eq!(r["changed"], true);
        assert_eq!(r["skipped"], json!(["O3"]));
        assert_eq!(commands(&r["items"]), ["DO_LAND_START", "WAYPOINT", "LAND"]);
    }

    #[test]
    fn unknown_payloads_are_reported_not_recorded() {
        let mut dec = Dec::new(example());
        let f = ok(call(&mut dec, "payload_failed", json!({"failed": 154})));
        assert_eq!(
            (f["payload"].as_str(), f["known"].as_bool()),
            (Some(""), Some(false))
        );
        let f = ok(call(&mut dec, "payload_failed", json!({"failed": ""})));
        assert_eq!(f["known"], false);
        assert_eq!(dec.failed().count(), 0);
    }

    #[test]
    fn a_failure_on_the_ground_keeps_the_take_off() {
        let mut dec = Dec::new(example());
        ok(call(&mut dec, "plan", json!({})));
        ok(call(
            &mut dec,
            "payload_failed",
            json!({"failed": "camera"}),
        ));
        let r = ok(call(&mut dec, "replan", json!({})));
        assert_eq!(r["changed"], true);
        assert_eq!(
            commands(&r["items"]),
            [
                "TAKEOFF",
                "WAYPOINT",
                "WAYPOINT",
                "LOITER_TIME",
                "DO_LAND_START",
                "WAYPOINT",
                "LAND"
            ]
        );
        // Before any plan, `plan` itself leaves it out.
        let mut dec = Dec::new(example());
        ok(call(
            &mut dec,
            "payload_failed",
            json!({"failed": "camera"}),
        ));
        assert_eq!(ok(call(&mut dec, "replan", json!({})))["changed"], false);
        assert_eq!(ok(call(&mut dec, "plan", json!({})))["count"], 7);
    }

    #[test]
    fn emergency_sites_depend_on_where_the_engine_fails() {
        let mut dec = Dec::new(crate::mission::tests::glider());
        assert!(call(&mut dec, "emergency_plan", json!({})).is_err());
        // Near T1, 80 m up.
        let a = ok(call(
            &mut dec,
            "emergency_site",
            json!({"lat": -35.3600, "lon": 149.16523, "alt": 80}),
        ));
        assert_eq!(a["name"], "North field");
        assert_eq!(a["reachable"], true);
        assert_eq!(commands(&a["items"]).last(), Some(&"LAND"));
        // Over O2.
        let b = ok(call(
            &mut dec,
            "emergency_site",
            json!({"lat": -35.357673, "lon": 149.171282, "alt": 80.0}),
        ));
        assert_eq!(b["name"], "East field");
        // The last one is remembered.
        assert_eq!(ok(call(&mut dec, "emergency_plan", json!({}))), b);
    }
}
