//! The lines of the program protocol (docs/programs.md): parsing what a
//! program sends, writing what the gateway sends. Parsing never panics:
//! anything unexpected is an error message for an `{"error": …}` reply.

use nets::{Params, Value};
use serde_json::{json, Map};

/// The longest line a program may send, in bytes (newline excluded).
pub const MAX_LINE: usize = 1 << 20;

/// A line from a program.
#[derive(Debug, Clone, PartialEq)]
pub enum Incoming {
    /// `{"hello": "DEC", "functions": ["next_waypoint", …], "token": "…"}`
    /// (`token` when the gateway requires one).
    Hello {
        program: String,
        functions: Vec<String>,
        token: Option<String>,
    },
    /// `{"reply": 7, "event": "done", "params": {…}}`
    Done { id: u64, params: Params },
    /// `{"reply": 7, "event": "failed", "params": {"reason": "…"}}`
    Failed { id: u64, reason: String },
    /// `{"event": "obstacle", "params": {…}}`
    Event { name: String, params: Params },
}

/// A hello line with its `token` replaced by `"(redacted)"`, for logs and
/// recordings.
pub fn redact_token(line: &str) -> String {
    match serde_json::from_str::<serde_json::Value>(line) {
        Ok(serde_json::Value::Object(mut object)) => {
            if object.contains_key("token") {
                object.insert("token".into(), json!("(redacted)"));
            }
            serde_json::Value::Object(object).to_string()
        }
        _ => "(a hello, redacted)".to_owned(),
    }
}

/// Parses one line (without its newline).
pub fn parse(line: &str) -> Result<Incoming, String> {
    let value: serde_json::Value =
        serde_json::from_str(line).map_err(|e| format!("not JSON: {e}"))?;
    let serde_json::Value::Object(object) = value else {
        return Err("expected a JSON object".into());
    };
    if object.contains_key("hello") {
        only(&object, &["hello", "functions", "token"], "a hello")?;
        let token = match object.get("token") {
            None => None,
            Some(serde_json::Value::String(t)) => Some(t.clone()),
            Some(_) => return Err("`token` must be a string".into()),
        };
        let program = string(&object, "hello")?;
        let functions = match object.get("functions") {
            Some(serde_json::Value::Array(a)) => a
                .iter()
                .map(|f| f.as_str().map(str::to_owned))
                .collect::<Option<Vec<_>>>()
                .ok_or("`functions` must be a list of strings")?,
            Some(_) => return Err("`functions` must be a list of strings".into()),
            None => {
                return Err("a hello needs `functions`: the functions the program serves".into())
            }
        };
        Ok(Incoming::Hello {
            program,
            functions,
            token,
        })
    } else if object.contains_key("reply") {
        only(&object, &["reply", "event", "params"], "a reply")?;
        let id = object
            .get("reply")
            .and_then(serde_json::Value::as_u64)
            .ok_or("`reply` must be the call's id, a non-negative integer")?;
        let event = string(&object, "event")?;
        let mut params = params(&object)?;
        match event.as_str() {
            "done" => Ok(Incoming::Done { id, params }),
            "failed" => {
                let reason = match params.remove("reason") {
                    Some(Value::Str(r)) => r,
                    _ => return Err("a failed reply needs `params.reason`, a string".into()),
                };
                if let Some(extra) = params.keys().next() {
                    return Err(format!(
                        "a failed reply has only `reason` in its params, not `{extra}`"
                    ));
                }
                Ok(Incoming::Failed { id, reason })
            }
            other => Err(format!(
                "a reply's `event` is \"done\" or \"failed\", not {other:?}"
            )),
        }
    } else if object.contains_key("event") {
        only(&object, &["event", "params"], "an event")?;
        let name = string(&object, "event")?;
        let params = params(&object)?;
        Ok(Incoming::Event { name, params })
    } else {
        Err("expected a hello, a reply or an event (key `hello`, `reply` or `event`)".into())
    }
}

fn only(object: &Map<String, serde_json::Value>, keys: &[&str], what: &str) -> Result<(), String> {
    match object.keys().find(|k| !keys.contains(&k.as_str())) {
        Some(k) => Err(format!(
            "unknown key `{k}` in {what} (it has: {})",
            keys.join(", ")
        )),
        None => Ok(()),
    }
}

fn string(object: &Map<String, serde_json::Value>, key: &str) -> Result<String, String> {
    match object.get(key) {
        Some(serde_json::Value::String(s)) => Ok(s.clone()),
        Some(_) => Err(format!("`{key}` must be a string")),
        None => Err(format!("missing `{key}`")),
    }
}

fn params(object: &Map<String, serde_json::Value>) -> Result<Params, String> {
    match object.get("params") {
        None => Ok(Params::new()),
        Some(serde_json::Value::Object(o)) => o
            .iter()
            .map(|(k, v)| {
                Value::from_json(v)
                    .map(|v| (k.clone(), v))
                    .ok_or_else(|| format!("parameter `{k}` holds null, which is not a value"))
            })
            .collect(),
        Some(_) => Err("`params` must be a JSON object".into()),
    }
}

pub fn json_params(params: &Params) -> serde_json::Value {
    serde_json::Value::Object(
        params
            .iter()
            .map(|(k, v)| (k.clone(), v.to_json()))
            .collect(),
    )
}

/// `{"welcome": "DEC", "functions": […]}`: the hello was accepted; the
/// functions are those the nets call. With `resume` (a program that
/// connected before in this run), `"resume": {…}` as well.
pub fn welcome(program: &str, called: &[&str], resume: Option<serde_json::Value>) -> String {
    let mut welcome = json!({"welcome": program, "functions": called});
    if let Some(resume) = resume {
        welcome["resume"] = resume;
    }
    welcome.to_string()
}

/// `{"call": id, "function": "…", "args": {…}}`, with `"vehicle": "R1"`
/// when the call is for a vehicle of a team (absent without a team).
pub fn call(id: u64, function: &str, args: &Params, vehicle: Option<&str>) -> String {
    let mut line = json!({"call": id, "function": function, "args": json_params(args)});
    if let (Some(v), Some(map)) = (vehicle, line.as_object_mut()) {
        map.insert("vehicle".into(), json!(v));
    }
    line.to_string()
}

/// `{"error": "…", "line": N}`
pub fn error(message: &str, line: u64) -> String {
    json!({"error": message, "line": line}).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_four_kinds_of_line() {
        assert_eq!(
            parse(r#"{"hello": "DEC", "functions": ["a", "b"]}"#),
            Ok(Incoming::Hello {
                program: "DEC".into(),
                functions: vec!["a".into(), "b".into()],
                token: None,
            })
        );
        assert_eq!(
            parse(r#"{"hello": "DEC", "functions": [], "token": "s3cret"}"#),
            Ok(Incoming::Hello {
                program: "DEC".into(),
                functions: vec![],
                token: Some("s3cret".into()),
            })
        );
        assert_eq!(
            parse(r#"{"reply": 3, "event": "done", "params": {"lat": 43.5, "n": 2, "ok": true}}"#),
            Ok(Incoming::Done {
                id: 3,
                params: Params::from([
                    ("lat".into(), Value::Float(43.5)),
                    ("n".into(), Value::Int(2)),
                    ("ok".into(), Value::Bool(true)),
                ])
            })
        );
        assert_eq!(
            parse(r#"{"reply": 3, "event": "done"}"#),
            Ok(Incoming::Done {
                id: 3,
                params: Params::new()
            })
        );
        assert_eq!(
            parse(r#"{"reply": 4, "event": "failed", "params": {"reason": "no plan"}}"#),
            Ok(Incoming::Failed {
                id: 4,
                reason: "no plan".into()
            })
        );
        assert_eq!(
            parse(r#"{"event": "obstacle", "params": {"range": [1, 2]}}"#),
            Ok(Incoming::Event {
                name: "obstacle".into(),
                params: Params::from([(
                    "range".into(),
                    Value::List(vec![Value::Int(1), Value::Int(2)])
                )])
            })
        );
    }

    #[test]
    fn malformed_lines_are_errors_that_say_what_is_wrong() {
        for (line, says) in [
            ("not json", "not JSON"),
            ("[1, 2]", "JSON object"),
            ("{}", "expected a hello"),
            (
                r#"{"hello": 1, "functions": []}"#,
                "`hello` must be a string",
            ),
            (r#"{"hello": "DEC"}"#, "needs `functions`"),
            (r#"{"hello": "DEC", "functions": [1]}"#, "list of strings"),
            (
                r#"{"hello": "DEC", "functions": [], "x": 1}"#,
                "unknown key `x`",
            ),
            (r#"{"reply": -1, "event": "done"}"#, "non-negative integer"),
            (r#"{"reply": "1", "event": "done"}"#, "non-negative integer"),
            (
                r#"{"reply": 1, "event": "maybe"}"#,
                "\"done\" or \"failed\"",
            ),
            (r#"{"reply": 1}"#, "missing `event`"),
            (r#"{"reply": 1, "event": "failed"}"#, "params.reason"),
            (
                r#"{"reply": 1, "event": "failed", "params": {"reason": 3}}"#,
                "params.reason",
            ),
            (
                r#"{"reply": 1, "event": "failed", "params": {"reason": "x", "y": 1}}"#,
                "only `reason`",
            ),
            (
                r#"{"reply": 1, "event": "done", "params": [1]}"#,
                "JSON object",
            ),
            (
                r#"{"reply": 1, "event": "done", "params": {"a": null}}"#,
                "null",
            ),
            (
                r#"{"reply": 1, "event": "done", "extra": 1}"#,
                "unknown key `extra`",
            ),
            (r#"{"event": 5}"#, "`event` must be a string"),
            (r#"{"event": "e", "call": 1}"#, "unknown key `call`"),
        ] {
            let e = parse(line).expect_err(line);
            assert!(e.contains(says), "{line}: {e}");
        }
    }

    #[test]
    fn outgoing_lines_are_single_line_json() {
        let args = Params::from([("failed".into(), Value::Str("cam\n1".into()))]);
        let line = call(7, "replan", &args, None);
        assert!(!line.contains('\n'));
        let v: serde_json::Value = serde_json::from_str(&line).expect("json");
        assert_eq!(
            v,
            json!({"call": 7, "function": "replan", "args": {"failed": "cam\n1"}})
        );
        // A team's call names its vehicle; without a team there is no key.
        let v: serde_json::Value =
            serde_json::from_str(&call(8, "replan", &args, Some("R2"))).expect("json");
        assert_eq!(
            v,
            json!({"call": 8, "function": "replan", "args": {"failed": "cam\n1"}, "vehicle": "R2"})
        );
        let v: serde_json::Value = serde_json::from_str(&error("bad", 3)).expect("json");
        assert_eq!(v, json!({"error": "bad", "line": 3}));
        let v: serde_json::Value =
            serde_json::from_str(&welcome("DEC", &["a"], None)).expect("json");
        assert_eq!(v, json!({"welcome": "DEC", "functions": ["a"]}));
    }
}
