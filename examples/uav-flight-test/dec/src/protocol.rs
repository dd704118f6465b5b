//! The program protocol's lines (docs/programs.md), as a program sees them:
//! what the gateway sends (welcome, error, call), what DEC sends (hello,
//! reply). JSON lines, one object each.

use serde_json::{json, Map, Value};

/// A line from the gateway.
#[derive(Debug, Clone, PartialEq)]
pub enum FromGateway {
    /// The hello was accepted; the functions the nets call, and, after a
    /// restart, the calls this program answered earlier in the flight
    /// (function and args, oldest first: the welcome's `resume.answered`).
    Welcome {
        functions: Vec<String>,
        answered: Vec<(String, Map<String, Value>)>,
    },
    /// A line of ours the gateway could not take (`line` counts our lines
    /// from 1; 0 for no hello in time).
    Error { message: String, line: Option<u64> },
    /// A call to answer.
    Call {
        id: u64,
        function: String,
        args: Map<String, Value>,
    },
}

/// Why a line from the gateway was not understood.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BadLine {
    #[error("not JSON: {0}")]
    Json(String),
    #[error("not a JSON object")]
    NotObject,
    /// A call with an id but something else wrong: it can be answered.
    #[error("call {id}: {reason}")]
    Call { id: u64, reason: String },
    #[error("{0}")]
    Other(String),
}

/// Reads one line from the gateway.
pub fn parse(line: &[u8]) -> Result<FromGateway, BadLine> {
    let value: Value = serde_json::from_slice(line).map_err(|e| BadLine::Json(e.to_string()))?;
    let Value::Object(obj) = value else {
        return Err(BadLine::NotObject);
    };
    if let Some(w) = obj.get("welcome") {
        if !w.is_string() {
            return Err(BadLine::Other("`welcome` is not a string".into()));
        }
        let functions = obj
            .get("functions")
            .and_then(Value::as_array)
            .map(|a| {
                a.iter()
                    .filter_map(|f| f.as_str().map(str::to_owned))
                    .collect()
            })
            .unwrap_or_default();
        let answered = obj
            .get("resume")
            .and_then(|r| r.get("answered"))
            .and_then(Value::as_array)
            .map(|a| {
                a.iter()
                    .filter_map(|c| {
                        let function = c.get("function")?.as_str()?.to_owned();
                        let args = c.get("args")?.as_object()?.clone();
                        Some((function, args))
                    })
                    .collect()
            })
            .unwrap_or_default();
        return Ok(FromGateway::Welcome {
            functions,
            answered,
        });
    }
    if let Some(e) = obj.get("error") {
        return Ok(FromGateway::Error {
            message: e.as_str().map_or_else(|| e.to_string(), str::to_owned),
            line: obj.get("line").and_then(Value::as_u64),
        });
    }
    if let Some(id) = obj.get("call") {
        let id = id
            .as_u64()
            .ok_or_else(|| BadLine::Other(format!("`call` is not an id: {id}")))?;
        let function = match obj.get("function").and_then(Value::as_str) {
            Some(f) => f.to_owned(),
            None => {
                return Err(BadLine::Call {
                    id,
                    reason: "no `function` string".into(),
                })
            }
        };
        let args = match obj.get("args") {
            None => Map::new(),
            Some(Value::Object(a)) => a.clone(),
            Some(other) => {
                return Err(BadLine::Call {
                    id,
                    reason: format!("`args` is not an object: {other}"),
                })
            }
        };
        return Ok(FromGateway::Call { id, function, args });
    }
    Err(BadLine::Other(format!(
        "unknown line (keys: {})",
        obj.keys().cloned().collect::<Vec<_>>().join(", ")
    )))
}

/// The hello line, with the gateway's token when it requires one (the
/// gateway gives it to the programs it starts as PETREL_PROGRAMS_TOKEN).
pub fn hello(name: &str, functions: &[&str]) -> String {
    let mut line = json!({"hello": name, "functions": functions});
    if let Ok(token) = std::env::var("PETREL_PROGRAMS_TOKEN") {
        line["token"] = json!(token);
    }
    line.to_string() + "\n"
}

/// A `done` reply.
pub fn done(id: u64, params: Map<String, Value>) -> String {
    json!({"reply": id, "event": "done", "params": params}).to_string() + "\n"
}

/// A `failed` reply.
pub fn failed(id: u64, reason: &str) -> String {
    json!({"reply": id, "event": "failed", "params": {"reason": reason}}).to_string() + "\n"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_the_gateways_lines() {
        assert_eq!(
            parse(br#"{"welcome": "DEC", "functions": ["item", "plan"]}"#),
            Ok(FromGateway::Welcome {
                functions: vec!["item".into(), "plan".into()],
                answered: vec![],
            })
        );
        // After a restart: what DEC answered before, to replay.
        assert_eq!(
            parse(
                br#"{"welcome": "DEC", "functions": ["item"], "resume": {"connection": 2,
                    "answered": [{"call": 3, "function": "item", "args": {"seq": 2},
                                  "event": "done", "params": {}}], "dropped": 0, "restarted": [4]}}"#
            ),
            Ok(FromGateway::Welcome {
                functions: vec!["item".into()],
                answered: vec![(
                    "item".into(),
                    json!({"seq": 2}).as_object().cloned().unwrap_or_default()
                )],
            })
        );
        assert_eq!(
            parse(br#"{"call": 7, "function": "item", "args": {"seq": 3}}"#),
            Ok(FromGateway::Call {
                id: 7,
                function: "item".into(),
                args: json!({"seq": 3}).as_object().cloned().unwrap_or_default(),
            })
        );
        assert_eq!(
            parse(br#"{"error": "unknown key `x`", "line": 3}"#),
            Ok(FromGateway::Error {
                message: "unknown key `x`".into(),
                line: Some(3)
            })
        );
    }

    #[test]
    fn bad_lines_say_why_and_calls_keep_their_id() {
        assert!(matches!(parse(b"{nope"), Err(BadLine::Json(_))));
        assert_eq!(parse(b"[1, 2]"), Err(BadLine::NotObject));
        assert!(matches!(parse(br#"{"call": -1}"#), Err(BadLine::Other(_))));
        assert!(matches!(parse(br#"{"what": 1}"#), Err(BadLine::Other(_))));
        assert_eq!(
            parse(br#"{"call": 4, "args": {}}"#),
            Err(BadLine::Call {
                id: 4,
                reason: "no `function` string".into()
            })
        );
        assert!(matches!(
            parse(br#"{"call": 5, "function": "item", "args": [1]}"#),
            Err(BadLine::Call { id: 5, .. })
        ));
    }

    #[test]
    fn writes_hello_and_replies() {
        assert_eq!(
            hello("DEC", &["plan", "item"]),
            "{\"hello\":\"DEC\",\"functions\":[\"plan\",\"item\"]}\n"
        );
        let p = json!({"count": 5}).as_object().cloned().unwrap_or_default();
        assert_eq!(
            done(3, p),
            "{\"reply\":3,\"event\":\"done\",\"params\":{\"count\":5}}\n"
        );
        assert_eq!(
            failed(4, "no plan"),
            "{\"reply\":4,\"event\":\"failed\",\"params\":{\"reason\":\"no plan\"}}\n"
        );
    }
}
