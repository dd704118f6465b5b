//! QGroundControl's `.plan` JSON (FORMATS.md §1): `fileType` "Plan",
//! `version` 1, a `mission` (version 2: `firmwareType`, `vehicleType`,
//! `plannedHomePosition`, `items`), a `geoFence` and `rallyPoints`.
//!
//! Read as QGroundControl reads it: `null` parameters are NaN; items take
//! sequences from 1 in file order (home is 0); a DO_JUMP's param1 (the
//! target's `doJumpId`) becomes the target's sequence; the items a
//! `survey` (version 4 or 5) or a `CorridorScan` stored are spliced in; the
//! legacy layouts QGroundControl still converts (`coordinate` and four
//! `params`; `param1`..`param4` keys) are converted; a fence or rally
//! section of version 1 (or none) is empty. A pattern that stored no items
//! (`StructureScan`, a landing pattern, a survey of version 2 or 3) and an
//! unknown complex item are [`Unsupported`].

use serde_json::{Map, Value};

use crate::error::{At, PlanError};
use crate::plan::{
    Autopilot, Circle, Fence, Format, Item, Origin, Plan, Polygon, Position, Unsupported,
    VehicleType,
};

const DO_JUMP: u16 = 177;

struct Reader<'a> {
    file: &'a str,
}

impl Reader<'_> {
    fn err(&self, path: &str, message: impl Into<String>) -> PlanError {
        PlanError::new(self.file, At::Path(path.to_owned()), message)
    }

    fn object<'v>(&self, v: &'v Value, path: &str) -> Result<&'v Map<String, Value>, PlanError> {
        v.as_object()
            .ok_or_else(|| self.err(path, format!("an object is expected, not {}", kind(v))))
    }

    fn field<'v>(
        &self,
        o: &'v Map<String, Value>,
        key: &str,
        path: &str,
    ) -> Result<&'v Value, PlanError> {
        o.get(key)
            .ok_or_else(|| self.err(path, format!("`{key}` is missing")))
    }

    fn number(&self, v: &Value, path: &str) -> Result<f64, PlanError> {
        match v {
            Value::Null => Ok(f64::NAN),
            Value::Number(n) => n
                .as_f64()
                .ok_or_else(|| self.err(path, "a number out of range")),
            other => Err(self.err(path, format!("a number is expected, not {}", kind(other)))),
        }
    }

    fn integer(&self, v: &Value, path: &str, max: u64) -> Result<u64, PlanError> {
        match v.as_u64() {
            Some(n) if n <= max => Ok(n),
            _ => Err(self.err(
                path,
                format!("a whole number from 0 to {max} is expected, not {v}"),
            )),
        }
    }

    fn version(o: &Map<String, Value>) -> Option<u64> {
        o.get("version").and_then(Value::as_u64)
    }

    fn position(&self, v: &Value, path: &str, altitude: bool) -> Result<Position, PlanError> {
        let a = v.as_array().ok_or_else(|| {
            self.err(
                path,
                format!("[lat, lon, alt] is expected, not {}", kind(v)),
            )
        })?;
        let want = if altitude { 3 } else { 2 };
        if a.len() < want || a.len() > 3 {
            return Err(self.err(
                path,
                format!(
                    "{} values, [lat, lon{}] is expected",
                    a.len(),
                    if altitude { ", alt" } else { "" }
                ),
            ));
        }
        Ok(Position {
            lat: self.number(&a[0], &format!("{path}[0]"))?,
            lon: self.number(&a[1], &format!("{path}[1]"))?,
            alt: match a.get(2) {
                Some(z) => self.number(z, &format!("{path}[2]"))?,
                None => f64::NAN,
            },
        })
    }

    /// A SimpleItem (or a legacy layout of one): its fields and `doJumpId`.
    fn simple(&self, v: &Value, path: &str) -> Result<(Item, Option<u64>), PlanError> {
        let o = self.object(v, path)?;
        let command = self.integer(
            self.field(o, "command", path)?,
            &format!("{path}.command"),
            u64::from(u16::MAX),
        )? as u16;
        let frame = self.integer(
            self.field(o, "frame", path)?,
            &format!("{path}.frame"),
            u64::from(u8::MAX),
        )? as u8;
        let autocontinue = match o.get("autoContinue") {
            Some(Value::Bool(b)) => *b,
            Some(other) => {
                return Err(self.err(
                    &format!("{path}.autoContinue"),
                    format!("true or false is expected, not {other}"),
                ))
            }
            None => true,
        };
        let mut seven = [f64::NAN; 7];
        if let Some(c) = o.get("coordinate") {
            // Legacy V2: `coordinate` and four `params`.
            let p = self.position(c, &format!("{path}.coordinate"), true)?;
            seven[4] = p.lat;
            seven[5] = p.lon;
            seven[6] = p.alt;
            let params = self.field(o, "params", path)?;
            let a = params.as_array().filter(|a| a.len() == 4).ok_or_else(|| {
                self.err(
                    &format!("{path}.params"),
                    "4 values are expected beside `coordinate`",
                )
            })?;
            for (k, p) in a.iter().enumerate() {
                seven[k] = self.number(p, &format!("{path}.params[{k}]"))?;
            }
        } else if o.contains_key("param1") {
            // Legacy V1: `param1`..`param4` and `coordinate` absent (0, 0, 0).
            for (k, slot) in seven.iter_mut().take(4).enumerate() {
                let key = format!("param{}", k + 1);
                *slot = match o.get(&key) {
                    Some(p) => self.number(p, &format!("{path}.{key}"))?,
                    None => 0.0,
                };
            }
            seven[4..].fill(0.0);
        } else {
            let params = self.field(o, "params", path)?;
            let a = params
                .as_array()
                .ok_or_else(|| self.err(&format!("{path}.params"), "7 values are expected"))?;
            if a.len() != 7 {
                return Err(self.err(
                    &format!("{path}.params"),
                    format!(
                        "{} values, an item has 7 (param1-4, lat, lon, alt)",
                        a.len()
                    ),
                ));
            }
            for (k, p) in a.iter().enumerate() {
                seven[k] = self.number(p, &format!("{path}.params[{k}]"))?;
            }
        }
        let jump_id = o.get("doJumpId").and_then(Value::as_u64);
        let item = Item {
            seq: 0,
            command,
            frame,
            params: [seven[0], seven[1], seven[2], seven[3]],
            x: seven[4],
            y: seven[5],
            z: seven[6],
            autocontinue,
            origin: Origin::PlanItem {
                index: 0,
                within: None,
            },
        };
        Ok((item, jump_id))
    }
}

fn kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// Reads a QGroundControl `.plan` file `name` whose text is `text`.
pub fn read(name: &str, text: &str) -> Result<Plan, PlanError> {
    let json: Value = serde_json::from_str(text).map_err(|e| {
        PlanError::new(
            name,
            At::LineCol(e.line().max(1), e.column().max(1)),
            format!("not a QGroundControl plan (JSON): {e}"),
        )
    })?;
    let r = Reader { file: name };
    let top = r.object(&json, "(top)")?;
    match top.get("fileType").and_then(Value::as_str) {
        Some("Plan") => {}
        Some(other) => return Err(r.err("fileType", format!("\"{other}\": a plan's is \"Plan\""))),
        None => return Err(r.err("fileType", "missing: is this a QGroundControl plan?")),
    }
    match top.get("version").and_then(Value::as_u64) {
        Some(1) => {}
        other => {
            return Err(r.err(
                "version",
                format!(
                    "{}: QGroundControl reads plans of version 1 only",
                    other.map_or("missing".to_owned(), |v| v.to_string())
                ),
            ))
        }
    }
    let mission = r.object(r.field(top, "mission", "(top)")?, "mission")?;
    match Reader::version(mission) {
        Some(2) => {}
        other => {
            return Err(r.err(
                "mission.version",
                format!(
                    "{}: QGroundControl reads missions of version 2 only",
                    other.map_or("missing".to_owned(), |v| v.to_string())
                ),
            ))
        }
    }
    let autopilot = mission
        .get("firmwareType")
        .and_then(Value::as_u64)
        .and_then(|n| u8::try_from(n).ok())
        .map(Autopilot::from_mav_autopilot);
    let vehicle = mission
        .get("vehicleType")
        .and_then(Value::as_u64)
        .and_then(|n| u8::try_from(n).ok())
        .map(VehicleType::from_mav_type);
    let home = match mission.get("plannedHomePosition") {
        Some(v) => Some(r.position(v, "mission.plannedHomePosition", true)?),
        None => None,
    };
    let items = r.field(mission, "items", "mission")?;
    let items = items.as_array().ok_or_else(|| {
        r.err(
            "mission.items",
            format!("an array is expected, not {}", kind(items)),
        )
    })?;
    let mut plan = Plan {
        format: Format::QgcPlan,
        autopilot,
        vehicle,
        home,
        items: Vec::new(),
        fence: Fence::default(),
        rally: Vec::new(),
        unsupported: Vec::new(),
    };
    // doJumpId → sequence, and the jumps to resolve once all are known.
    let mut jump_ids: Vec<(u64, u16)> = Vec::new();
    let mut push = |plan: &mut Plan, (mut item, jump_id): (Item, Option<u64>), origin: Origin| {
        let seq = u16::try_from(plan.items.len() + 1).unwrap_or(u16::MAX);
        item.seq = seq;
        item.origin = origin;
        if let Some(id) = jump_id {
            jump_ids.push((id, seq));
        }
        plan.items.push(item);
    };
    for (index, v) in items.iter().enumerate() {
        let path = format!("mission.items[{index}]");
        let o = r.object(v, &path)?;
        let kind = o
            .get("type")
            .and_then(Value::as_str)
            .unwrap_or("SimpleItem");
        match kind {
            "SimpleItem" | "missionItem" => {
                let item = r.simple(v, &path)?;
                push(
                    &mut plan,
                    item,
                    Origin::PlanItem {
                        index,
                        within: None,
                    },
                );
            }
            "ComplexItem" => {
                let what = o
                    .get("complexItemType")
                    .and_then(Value::as_str)
                    .unwrap_or("(no complexItemType)");
                let version = o.get("version").and_then(Value::as_u64).unwrap_or(0);
                if what == "survey" && !(2..=5).contains(&version) {
                    return Err(r.err(
                        &format!("{path}.version"),
                        format!("survey version {version}: QGroundControl reads versions 2 to 5"),
                    ));
                }
                let stored = match what {
                    "survey" => version >= 4,
                    "CorridorScan" => true,
                    _ => false,
                };
                let items = o
                    .get("TransectStyleComplexItem")
                    .and_then(|t| t.get("Items"))
                    .and_then(Value::as_array)
                    .filter(|a| !a.is_empty());
                match (stored, items) {
                    (true, Some(inner)) => {
                        for (k, v) in inner.iter().enumerate() {
                            let item = r.simple(
                                v,
                                &format!("{path}.TransectStyleComplexItem.Items[{k}]"),
                            )?;
                            push(
                                &mut plan,
                                item,
                                Origin::PlanItem {
                                    index,
                                    within: Some(k),
                                },
                            );
                        }
                    }
                    _ => {
                        let (what, remedy) = match what {
                            "survey" | "CorridorScan" => (
                                format!("{what} version {version} without its waypoints"),
                                "open the plan in QGroundControl 4 or later and save it again: the pattern's waypoints are then stored in the file",
                            ),
                            "StructureScan" => (
                                what.to_owned(),
                                "QGroundControl does not store a structure scan's waypoints: save the mission from the vehicle after uploading it (a .waypoints file), or replace the pattern with waypoints",
                            ),
                            "fwLandingPattern" | "vtolLandingPattern" => (
                                what.to_owned(),
                                "QGroundControl does not store a landing pattern's items: replace it with DO_LAND_START, a waypoint and NAV_LAND items, or save the mission from the vehicle after uploading it",
                            ),
                            _ => (
                                format!("complex item `{what}`"),
                                "QGroundControl knows no such pattern: replace it with mission items",
                            ),
                        };
                        plan.unsupported.push(Unsupported {
                            origin: Origin::PlanItem {
                                index,
                                within: None,
                            },
                            what,
                            remedy: remedy.to_owned(),
                        });
                    }
                }
            }
            other => {
                return Err(r.err(
                    &format!("{path}.type"),
                    format!("\"{other}\": an item is a SimpleItem or a ComplexItem"),
                ))
            }
        }
    }
    for item in &mut plan.items {
        if item.command != DO_JUMP {
            continue;
        }
        let Origin::PlanItem { index, within } = item.origin else {
            continue;
        };
        let id = item.params[0];
        let target = jump_ids
            .iter()
            .find(|(j, _)| (*j as f64) == id)
            .map(|(_, seq)| *seq);
        match target {
            Some(seq) => item.params[0] = f64::from(seq),
            None => {
                let path = match within {
                    None => format!("mission.items[{index}]"),
                    Some(k) => {
                        format!("mission.items[{index}].TransectStyleComplexItem.Items[{k}]")
                    }
                };
                return Err(r.err(
                    &path,
                    format!("DO_JUMP to doJumpId {id}, which no item has"),
                ));
            }
        }
    }
    if let Some(fence) = top.get("geoFence") {
        plan.fence = read_fence(&r, fence)?;
    }
    if let Some(rally) = top.get("rallyPoints") {
        let o = r.object(rally, "rallyPoints")?;
        match Reader::version(o) {
            None | Some(1) => {}
            Some(2) => {
                if let Some(points) = o.get("points").and_then(Value::as_array) {
                    for (k, p) in points.iter().enumerate() {
                        plan.rally.push(r.position(
                            p,
                            &format!("rallyPoints.points[{k}]"),
                            true,
                        )?);
                    }
                }
            }
            Some(v) => {
                return Err(r.err(
                    "rallyPoints.version",
                    format!("{v}: QGroundControl reads rally points of version 2 only"),
                ))
            }
        }
    }
    Ok(plan)
}

fn read_fence(r: &Reader, v: &Value) -> Result<Fence, PlanError> {
    let o = r.object(v, "geoFence")?;
    let mut fence = Fence::default();
    match Reader::version(o) {
        // QGroundControl loads an old or unversioned fence as none.
        None | Some(1) => return Ok(fence),
        Some(2) => {}
        Some(v) => {
            return Err(r.err(
                "geoFence.version",
                format!("{v}: QGroundControl reads fences of version 2 only"),
            ))
        }
    }
    let list = |key: &str| -> Result<&Vec<Value>, PlanError> {
        match o.get(key) {
            Some(Value::Array(a)) => Ok(a),
            Some(other) => Err(r.err(
                &format!("geoFence.{key}"),
                format!("an array is expected, not {}", kind(other)),
            )),
            None => Err(r.err("geoFence", format!("`{key}` is missing"))),
        }
    };
    for (k, p) in list("polygons")?.iter().enumerate() {
        let path = format!("geoFence.polygons[{k}]");
        let po = r.object(p, &path)?;
        let inclusion = po.get("inclusion").and_then(Value::as_bool).unwrap_or(true);
        let vertices = po
            .get("polygon")
            .and_then(Value::as_array)
            .ok_or_else(|| r.err(&path, "`polygon` is missing"))?;
        let mut out = Vec::with_capacity(vertices.len());
        for (i, vx) in vertices.iter().enumerate() {
            let p = r.position(vx, &format!("{path}.polygon[{i}]"), false)?;
            out.push((p.lat, p.lon));
        }
        if out.len() < 3 {
            return Err(r.err(
                &path,
                format!("{} vertices, a polygon has 3 at least", out.len()),
            ));
        }
        fence.polygons.push(Polygon {
            inclusion,
            vertices: out,
        });
    }
    for (k, c) in list("circles")?.iter().enumerate() {
        let path = format!("geoFence.circles[{k}]");
        let co = r.object(c, &path)?;
        let inclusion = co.get("inclusion").and_then(Value::as_bool).unwrap_or(true);
        let circle = co
            .get("circle")
            .and_then(Value::as_object)
            .ok_or_else(|| r.err(&path, "`circle` is missing"))?;
        let center = r.position(
            r.field(circle, "center", &format!("{path}.circle"))?,
            &format!("{path}.circle.center"),
            false,
        )?;
        let radius = r.number(
            r.field(circle, "radius", &format!("{path}.circle"))?,
            &format!("{path}.circle.radius"),
        )?;
        if radius.is_nan() || radius <= 0.0 {
            return Err(r.err(
                &format!("{path}.circle.radius"),
                format!("{radius} m: a radius is positive"),
            ));
        }
        fence.circles.push(Circle {
            inclusion,
            center: (center.lat, center.lon),
            radius,
        });
    }
    if let Some(b) = o.get("breachReturn") {
        fence.breach_return = Some(r.position(b, "geoFence.breachReturn", false)?);
    }
    Ok(fence)
}

#[cfg(test)]
mod tests {
    use super::*;

    const PLAN: &str = r#"{
    "fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
    "geoFence": { "version": 2, "polygons": [], "circles": [
        { "inclusion": false, "circle": { "center": [47.39, 8.54], "radius": 111.05 }, "version": 1 } ] },
    "mission": { "version": 2, "firmwareType": 12, "vehicleType": 2,
        "plannedHomePosition": [47.397, 8.545, 487.9],
        "items": [
            { "type": "SimpleItem", "command": 22, "frame": 3, "autoContinue": true, "doJumpId": 1,
              "params": [0, 0, 0, null, 47.39, 8.54, 50] },
            { "type": "SimpleItem", "command": 16, "frame": 3, "autoContinue": true, "doJumpId": 2,
              "params": [0, 0, 0, null, 47.40, 8.55, 50] },
            { "type": "ComplexItem", "complexItemType": "survey", "version": 5,
              "TransectStyleComplexItem": { "Items": [
                { "type": "SimpleItem", "command": 16, "frame": 3, "autoContinue": true, "doJumpId": 3,
                  "params": [0, 0, 0, null, 47.41, 8.56, 60] },
                { "type": "SimpleItem", "command": 206, "frame": 2, "autoContinue": true, "doJumpId": 4,
                  "params": [25, 0, 1, 0, 0, 0, 0] } ] } },
            { "type": "ComplexItem", "complexItemType": "StructureScan", "version": 3 },
            { "type": "SimpleItem", "command": 177, "frame": 2, "autoContinue": true, "doJumpId": 5,
              "params": [2, 3, 0, 0, 0, 0, 0] }
        ] },
    "rallyPoints": { "version": 2, "points": [[47.398, 8.546, 30]] }
}"#;

    #[test]
    fn a_plan_reads_with_its_patterns_spliced_and_jumps_by_sequence() {
        let plan = read("p.plan", PLAN).expect("reads");
        assert_eq!(plan.autopilot, Some(Autopilot::Px4));
        assert_eq!(plan.vehicle, Some(VehicleType::Copter));
        assert_eq!(plan.home.map(|h| h.alt), Some(487.9));
        let seqs: Vec<(u16, String)> = plan
            .items
            .iter()
            .map(|i| (i.seq, i.command_name()))
            .collect();
        assert_eq!(
            seqs,
            [
                (1, "NAV_TAKEOFF".to_owned()),
                (2, "NAV_WAYPOINT".to_owned()),
                (3, "NAV_WAYPOINT".to_owned()),
                (4, "DO_SET_CAM_TRIGG_DIST".to_owned()),
                (5, "DO_JUMP".to_owned()),
            ]
        );
        assert!(plan.items[0].params[3].is_nan());
        // doJumpId 2 is the second item: sequence 2.
        assert_eq!(plan.items[4].params[0], 2.0);
        assert_eq!(
            plan.items[2].origin,
            Origin::PlanItem {
                index: 2,
                within: Some(0)
            }
        );
        assert_eq!(plan.unsupported.len(), 1);
        assert_eq!(
            plan.unsupported[0].origin,
            Origin::PlanItem {
                index: 3,
                within: None
            }
        );
        assert_eq!(plan.unsupported[0].what, "StructureScan");
        assert_eq!(plan.fence.circles.len(), 1);
        assert!(!plan.fence.circles[0].inclusion);
        assert_eq!(plan.rally.len(), 1);
    }

    #[test]
    fn bad_plans_say_where_and_why() {
        let cases: &[(&str, &str)] = &[
            ("{\n  \"fileType\": \"Plan\",\n  oops\n}", "p.plan:3:3: not a QGroundControl plan (JSON): key must be a string at line 3 column 3"),
            ("[]", "p.plan: (top): an object is expected, not an array"),
            ("{\"fileType\": \"Fence\", \"version\": 1}", "p.plan: fileType: \"Fence\": a plan's is \"Plan\""),
            ("{\"fileType\": \"Plan\", \"version\": 2}", "p.plan: version: 2: QGroundControl reads plans of version 1 only"),
            ("{\"fileType\": \"Plan\", \"version\": 1}", "p.plan: (top): `mission` is missing"),
            ("{\"fileType\": \"Plan\", \"version\": 1, \"mission\": {\"version\": 1, \"items\": []}}", "p.plan: mission.version: 1: QGroundControl reads missions of version 2 only"),
            ("{\"fileType\": \"Plan\", \"version\": 1, \"mission\": {\"version\": 2, \"items\": [{\"type\": \"SimpleItem\", \"command\": 16, \"frame\": 3, \"params\": [1, 2]}]}}", "p.plan: mission.items[0].params: 2 values, an item has 7 (param1-4, lat, lon, alt)"),
            ("{\"fileType\": \"Plan\", \"version\": 1, \"mission\": {\"version\": 2, \"items\": [{\"type\": \"SimpleItem\", \"command\": 177, \"frame\": 2, \"params\": [9, 0, 0, 0, 0, 0, 0]}]}}", "p.plan: mission.items[0]: DO_JUMP to doJumpId 9, which no item has"),
            ("{\"fileType\": \"Plan\", \"version\": 1, \"mission\": {\"version\": 2, \"items\": [{\"type\": \"SimpleItem\", \"command\": -1, \"frame\": 2, \"params\": [0, 0, 0, 0, 0, 0, 0]}]}}", "p.plan: mission.items[0].command: a whole number from 0 to 65535 is expected, not -1"),
        ];
        for (text, want) in cases {
            let e = read("p.plan", text).expect_err(text);
            assert_eq!(e.to_string(), *want, "{text}");
        }
    }
}
