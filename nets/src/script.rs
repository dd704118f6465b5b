//! Scripts of timed inputs, as JSON lines, to play a project without a
//! vehicle (`petrel play`). Each line is one input:
//!
//! ```text
//! {"t": 12.5, "event": "ready_for_takeoff", "params": {}, "category": "nominal"}
//! {"t": 14.0, "reply": "DEC.next_waypoint", "params": {"lat": 43.2}}     a call's result
//! {"t": 14.0, "reply": "DEC.replan", "failed": "no plan"}                 a call's failure
//! {"t": 14.5, "reply": "command.arm"}                                     a command's result
//! {"t": 15.0, "reply": 7, "failed": "timeout"}                            by id
//! {"t": 16.0, "answer": "survey", "choice": "yes"}                        the operator's answer to `ask survey`
//! {"t": 16.0, "answer": 9, "choice": "no"}                                by id
//! {"t": 60}                                                               time passes
//! ```
//!
//! `t` is in seconds from the start and never goes backwards. A reply by
//! name goes to the oldest pending call of that function (or command of that
//! verb), an answer by name to the oldest pending question of that ask.
//! Blank lines and lines starting with `#` or `//` are skipped.

use serde_json::Value as Json;

use crate::event::{Category, Event};
use crate::model::Project;
use crate::player::{Outcome, PendingKind, Player};
use crate::time::Micros;
use crate::value::{Params, Value};

/// One input of a script.
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    Event(Event),
    Reply {
        to: ReplyTo,
        outcome: Outcome,
    },
    /// The operator's answer: to question `id`, or to the oldest pending
    /// question of an ask by name.
    Answer {
        to: AnswerTo,
        choice: String,
    },
    Advance,
}

/// What an answer answers.
#[derive(Debug, Clone, PartialEq)]
pub enum AnswerTo {
    Id(u64),
    Ask(String),
}

/// What a reply answers.
#[derive(Debug, Clone, PartialEq)]
pub enum ReplyTo {
    Id(u64),
    Call { program: String, function: String },
    Command { verb: String },
}

/// A line of a script.
#[derive(Debug, Clone, PartialEq)]
pub struct Line {
    /// 1-based line number in the file.
    pub number: usize,
    pub time: Micros,
    pub input: Input,
    /// The 1-based column of each key of the line's object, for errors.
    pub columns: Vec<(String, usize)>,
}

impl Line {
    /// The column where `key` starts on the line (1 if it is absent).
    pub fn column(&self, key: &str) -> usize {
        self.columns
            .iter()
            .find(|(k, _)| k == key)
            .map_or(1, |&(_, c)| c)
    }

    fn err(&self, key: &str, message: impl Into<String>) -> ScriptError {
        ScriptError {
            line: self.number,
            column: self.column(key),
            message: message.into(),
        }
    }
}

/// A problem in a script, at a line (and column, when known).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{line}:{column}: {message}")]
pub struct ScriptError {
    pub line: usize,
    pub column: usize,
    pub message: String,
}

fn err(line: usize, message: impl Into<String>) -> ScriptError {
    ScriptError {
        line,
        column: 1,
        message: message.into(),
    }
}

/// Reads a whole script; every line is checked before anything is played.
pub fn parse(text: &str) -> Result<Vec<Line>, ScriptError> {
    let mut lines = Vec::new();
    let mut last: Micros = 0;
    for (i, raw) in text.lines().enumerate() {
        let number = i + 1;
        let trimmed = raw.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') || trimmed.starts_with("//") {
            continue;
        }
        let json: Json = serde_json::from_str(trimmed).map_err(|e| ScriptError {
            line: number,
            column: e.column().max(1) + (raw.len() - raw.trim_start().len()),
            message: format!("not JSON: {e}"),
        })?;
        let Json::Object(obj) = json else {
            return Err(err(number, "expected a JSON object"));
        };
        let keys = key_columns(raw);
        if let Some((key, column)) = keys.duplicate {
            return Err(ScriptError {
                line: number,
                column,
                message: format!("duplicate key `{key}`"),
            });
        }
        let columns = keys.top;
        let at = |key: &str| {
            columns
                .iter()
                .find(|(k, _)| k == key)
                .map_or(1, |&(_, c)| c)
        };
        let err_at = |key: &str, message: &dyn std::fmt::Display| ScriptError {
            line: number,
            column: at(key),
            message: message.to_string(),
        };
        for key in obj.keys() {
            if ![
                "t", "event", "params", "category", "reply", "failed", "answer", "choice",
            ]
            .contains(&key.as_str())
            {
                return Err(err_at(
                    key,
                    &format!(
                        "unknown key `{key}` (expected t, event, params, category, reply, failed, answer, choice)"
                    ),
                ));
            }
        }
        let t = obj
            .get("t")
            .and_then(Json::as_f64)
            .ok_or_else(|| err_at("t", &"missing `t` (seconds, a number)"))?;
        if !(0.0..=1e9).contains(&t) {
            return Err(err_at(
                "t",
                &format!("`t` = {t} is out of range (0 to 1e9 seconds)"),
            ));
        }
        let time = (t * 1e6).round() as Micros;
        if time < last {
            return Err(err_at(
                "t",
                &format!("`t` goes backwards ({t} after {})", last as f64 / 1e6),
            ));
        }
        last = time;
        let params: Params = match obj.get("params") {
            None => Params::new(),
            Some(Json::Object(p)) => p
                .iter()
                .map(|(k, v)| {
                    Value::from_json(v)
                        .map(|v| (k.clone(), v))
                        .ok_or_else(|| err_at("params", &format!("parameter `{k}` is null")))
                })
                .collect::<Result<_, _>>()?,
            Some(_) => return Err(err_at("params", &"`params` must be an object")),
        };
        if let Some(answer) = obj.get("answer") {
            if let Some(other) = ["event", "reply", "params", "category", "failed"]
                .iter()
                .find(|k| obj.contains_key(**k))
            {
                return Err(err_at(
                    other,
                    &"an `answer` line takes only `t`, `answer` and `choice`",
                ));
            }
            let to = match answer {
                Json::Number(n) => AnswerTo::Id(
                    n.as_u64()
                        .ok_or_else(|| err_at("answer", &"a question id is a positive integer"))?,
                ),
                Json::String(s) if !s.is_empty() => AnswerTo::Ask(s.clone()),
                _ => {
                    return Err(err_at(
                        "answer",
                        &"`answer` must be an ask's name or a question id",
                    ))
                }
            };
            let Some(Json::String(choice)) = obj.get("choice") else {
                return Err(err_at("answer", &"an answer needs `choice`, a string"));
            };
            lines.push(Line {
                number,
                time,
                input: Input::Answer {
                    to,
                    choice: choice.clone(),
                },
                columns,
            });
            continue;
        }
        if obj.contains_key("choice") {
            return Err(err_at("choice", &"`choice` belongs to an `answer` line"));
        }
        let input = match (obj.get("event"), obj.get("reply")) {
            (Some(_), Some(_)) => {
                return Err(err_at(
                    "reply",
                    &"a line is an `event` or a `reply`, not both",
                ))
            }
            (Some(event), None) => {
                let name = event
                    .as_str()
                    .filter(|s| !s.is_empty())
                    .ok_or_else(|| err_at("event", &"`event` must be a non-empty string"))?;
                if obj.contains_key("failed") {
                    return Err(err_at("failed", &"`failed` belongs to replies"));
                }
                let category = match obj.get("category") {
                    None => Category::Nominal,
                    Some(c) => c
                        .as_str()
                        .ok_or_else(|| err_at("category", &"`category` must be a string"))?
                        .parse()
                        .map_err(|e: crate::event::UnknownCategory| {
                            err_at("category", &e.to_string())
                        })?,
                };
                Input::Event(Event {
                    name: name.to_owned(),
                    category,
                    params,
                })
            }
            (None, Some(reply)) => {
                if obj.contains_key("category") {
                    return Err(err_at(
                        "category",
                        &"`category` belongs to events: a reply's category comes from its call",
                    ));
                }
                let to = match reply {
                    Json::Number(n) => ReplyTo::Id(n.as_u64().ok_or_else(|| err_at("reply", &"a reply id is a positive integer"))?),
                    Json::String(s) => match s.split_once('.') {
                        Some(("command", verb)) if !verb.is_empty() => ReplyTo::Command { verb: verb.to_owned() },
                        Some((program, function)) if !program.is_empty() && !function.is_empty() && !function.contains('.') => {
                            ReplyTo::Call {
                                program: program.to_owned(),
                                function: function.to_owned(),
                            }
                        }
                        _ => return Err(err_at("reply", &format!("`reply` must be PROGRAM.FUNCTION, command.VERB or an id, not `{s}`"))),
                    },
                    _ => return Err(err_at("reply", &"`reply` must be PROGRAM.FUNCTION, command.VERB or an id")),
                };
                let outcome = match obj.get("failed") {
                    None => Outcome::Done(params),
                    Some(Json::String(reason)) if params.is_empty() => {
                        Outcome::Failed(reason.clone())
                    }
                    Some(Json::String(_)) => {
                        return Err(err_at(
                            "params",
                            &"a failed reply carries a reason, not `params`",
                        ))
                    }
                    Some(_) => {
                        return Err(err_at("failed", &"`failed` must be a string (the reason)"))
                    }
                };
                Input::Reply { to, outcome }
            }
            (None, None) => {
                if obj.len() > 1 {
                    let other = columns
                        .iter()
                        .find(|(k, _)| k != "t")
                        .map_or("t", |(k, _)| k.as_str());
                    return Err(err_at(other, &"a line with neither `event` nor `reply` only lets time pass: it takes only `t`"));
                }
                Input::Advance
            }
        };
        lines.push(Line {
            number,
            time,
            input,
            columns,
        });
    }
    Ok(lines)
}

/// The keys of the top-level object on a line, with the 1-based column (in
/// characters) of each key's opening quote, in the order written; and the
/// first key repeated within one object at any depth, which a JSON map
/// would silently merge.
struct Keys {
    top: Vec<(String, usize)>,
    duplicate: Option<(String, usize)>,
}

fn key_columns(raw: &str) -> Keys {
    let mut keys = Keys {
        top: Vec::new(),
        duplicate: None,
    };
    // The keys seen in each open object (`None` for an array).
    let mut open: Vec<Option<Vec<String>>> = Vec::new();
    let mut chars = raw.char_indices().enumerate();
    while let Some((column, (start, c))) = chars.next() {
        match c {
            '{' => open.push(Some(Vec::new())),
            '[' => open.push(None),
            '}' | ']' => {
                open.pop();
            }
            '"' => {
                let mut end = raw.len();
                let mut escaped = false;
                for (_, (i, c)) in chars.by_ref() {
                    if escaped {
                        escaped = false;
                    } else if c == '\\' {
                        escaped = true;
                    } else if c == '"' {
                        end = i + 1;
                        break;
                    }
                }
                if !raw[end..].trim_start().starts_with(':') {
                    continue;
                }
                let Some(Some(seen)) = open.last_mut() else {
                    continue;
                };
                let key = serde_json::from_str::<String>(&raw[start..end])
                    .unwrap_or_else(|_| raw[start..end].trim_matches('"').to_owned());
                if seen.contains(&key) && keys.duplicate.is_none() {
                    keys.duplicate = Some((key.clone(), column + 1));
                }
                seen.push(key.clone());
                if open.len() == 1 {
                    keys.top.push((key, column + 1));
                }
            }
            _ => {}
        }
    }
    keys
}

/// Checks a parsed script against the project it plays, before anything is
/// played: a script may only send what the gateway could deliver. Refused:
/// events the player alone produces (results, `net_fault`) and events only
/// the nets emit ([`crate::outside`]), and a `category` that contradicts the
/// project's declaration (which always wins in flight, so the script would
/// show a flight that cannot happen). A `category` on an undeclared event
/// is the category the event arrives with, as an elaboration rule or a
/// program would give it.
pub fn check(project: &Project, lines: &[Line]) -> Result<(), ScriptError> {
    for line in lines {
        let Input::Event(event) = &line.input else {
            continue;
        };
        if let Some(refusal) = crate::outside::refusal(project, &event.name) {
            return Err(line.err(
                "event",
                format!("event `{}` cannot come from outside: {refusal}", event.name),
            ));
        }
        let declared = project.declared_category(&event.name);
        if let Some(declared) = declared.filter(|&d| d != event.category) {
            if line.columns.iter().any(|(k, _)| k == "category") {
                return Err(line.err(
                    "category",
                    format!(
                        "`category`: event `{}` is declared {declared} (by project.toml or the elaboration profile), which always wins; give no category, or {declared}",
                        event.name
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Finds the pending call or command a reply answers.
pub fn resolve(player: &Player, line: &Line, to: &ReplyTo) -> Result<u64, ScriptError> {
    let project = player.project();
    let pending = &player.state().pending;
    let found = match to {
        ReplyTo::Id(id) => return Ok(*id),
        ReplyTo::Call { program, function } => pending.iter().find(|(_, p)| match &p.kind {
            PendingKind::Call {
                program: pr,
                function: f,
            } => {
                let prog = &project.programs[*pr];
                prog.name == *program && prog.functions[*f].name == *function
            }
            PendingKind::Command { .. } | PendingKind::Question { .. } => false,
        }),
        ReplyTo::Command { verb } => pending
            .iter()
            .find(|(_, p)| matches!(&p.kind, PendingKind::Command { verb: v } if v == verb)),
    };
    found.map(|(id, _)| *id).ok_or_else(|| {
        let what = match to {
            ReplyTo::Call { program, function } => format!("call of {program}.{function}"),
            ReplyTo::Command { verb } => format!("`{verb}` command"),
            ReplyTo::Id(_) => unreachable!("ids return early"),
        };
        err(
            line.number,
            format!("no pending {what} to reply to (reply by id to send a late result)"),
        )
    })
}

/// Plays one line on a player.
pub fn play_line(player: &mut Player, line: &Line) -> Result<(), ScriptError> {
    match &line.input {
        Input::Event(event) => player.handle(event, line.time),
        Input::Advance => player.advance(line.time),
        Input::Reply { to, outcome } => {
            // Timers due before the reply fire first, and may change what is
            // pending.
            player.advance(line.time);
            let id = resolve(player, line, to)?;
            player.result(id, outcome.clone(), line.time);
        }
        Input::Answer { to, choice } => {
            // Timers due before the answer fire first: a late answer is
            // refused by the player, recorded.
            player.advance(line.time);
            let id = match to {
                AnswerTo::Id(id) => *id,
                AnswerTo::Ask(name) => {
                    let project = player.project().clone();
                    player
                        .questions()
                        .find(|(_, net, ask)| project.nets[*net].asks[*ask].name == *name)
                        .map(|(id, _, _)| id)
                        .ok_or_else(|| ScriptError {
                            line: line.number,
                            column: line.column("answer"),
                            message: format!(
                                "no pending question `{name}` to answer (answer by id to send a late answer)"
                            ),
                        })?
                }
            };
            let _ = player.answer(id, choice, line.time);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one(line: &str) -> Input {
        let lines = parse(line).unwrap_or_else(|e| panic!("{line}: {e}"));
        assert_eq!(lines.len(), 1);
        lines[0].input.clone()
    }

    #[test]
    fn answers_by_name_or_id_and_their_errors() {
        assert_eq!(
            one(r#"{"t": 1, "answer": "survey", "choice": "yes"}"#),
            Input::Answer {
                to: AnswerTo::Ask("survey".into()),
                choice: "yes".into()
            }
        );
        assert_eq!(
            one(r#"{"t": 1, "answer": 9, "choice": "no"}"#),
            Input::Answer {
                to: AnswerTo::Id(9),
                choice: "no".into()
            }
        );
        for (line, message) in [
            (
                r#"{"t": 1, "answer": "survey"}"#,
                "an answer needs `choice`, a string",
            ),
            (
                r#"{"t": 1, "answer": "s", "choice": "y", "event": "e"}"#,
                "an `answer` line takes only `t`, `answer` and `choice`",
            ),
            (
                r#"{"t": 1, "event": "e", "choice": "y"}"#,
                "`choice` belongs to an `answer` line",
            ),
            (
                r#"{"t": 1, "answer": true, "choice": "y"}"#,
                "`answer` must be an ask's name or a question id",
            ),
        ] {
            let e = parse(line).expect_err(line);
            assert_eq!(e.message, message, "{line}");
        }
    }

    #[test]
    fn every_form() {
        let lines = parse(
            "# a comment\n\n// another\n{\"t\": 12.5, \"event\": \"ready\", \"params\": {\"alt\": 3}, \"category\": \"safety\"}\n{\"t\": 14}\n",
        )
        .expect("parses");
        assert_eq!(lines.len(), 2);
        assert_eq!((lines[0].number, lines[0].time), (4, 12_500_000));
        assert_eq!(
            lines[0].input,
            Input::Event(
                Event::new("ready")
                    .category(Category::Safety)
                    .param("alt", 3)
            )
        );
        assert_eq!((lines[1].number, lines[1].time), (5, 14_000_000));
        assert_eq!(lines[1].input, Input::Advance);
        assert_eq!(
            one(r#"{"t": 1, "reply": "DEC.next", "params": {"lat": 43.5}}"#),
            Input::Reply {
                to: ReplyTo::Call {
                    program: "DEC".into(),
                    function: "next".into()
                },
                outcome: Outcome::Done(Params::from([("lat".into(), Value::Float(43.5))])),
            }
        );
        assert_eq!(
            one(r#"{"t": 1, "reply": "command.arm", "failed": "denied"}"#),
            Input::Reply {
                to: ReplyTo::Command { verb: "arm".into() },
                outcome: Outcome::Failed("denied".into()),
            }
        );
        assert_eq!(
            one(r#"{"t": 1, "reply": 7}"#),
            Input::Reply {
                to: ReplyTo::Id(7),
                outcome: Outcome::Done(Params::new()),
            }
        );
    }

    #[test]
    fn bad_lines_report_their_line_and_column() {
        let cases = [
            ("{\"t\": 1, \"event\": \"x\"}\n{\"t\": 0.5, \"event\": \"y\"}", "2:2: `t` goes backwards (0.5 after 1)"),
            ("{\"t\": 1, \"event\": }", "1:19: not JSON: expected value at line 1 column 19"),
            ("  [1, 2]", "1:1: expected a JSON object"),
            ("{\"event\": \"x\"}", "1:1: missing `t` (seconds, a number)"),
            ("{\"t\": -1}", "1:2: `t` = -1 is out of range (0 to 1e9 seconds)"),
            ("{\"t\": 1, \"evnt\": \"x\"}", "1:10: unknown key `evnt` (expected t, event, params, category, reply, failed, answer, choice)"),
            ("{\"t\": 1, \"event\": \"\"}", "1:10: `event` must be a non-empty string"),
            ("{\"t\": 1, \"event\": \"x\", \"params\": [1]}", "1:24: `params` must be an object"),
            ("{\"t\": 1, \"event\": \"x\", \"params\": {\"a\": null}}", "1:24: parameter `a` is null"),
            ("{\"t\": 1, \"event\": \"x\", \"category\": \"urgent\"}", "1:24: unknown category `urgent` (expected catastrophic, safety, communication, mission or nominal)"),
            ("{\"t\": 1, \"event\": \"x\", \"failed\": \"no\"}", "1:24: `failed` belongs to replies"),
            ("{\"t\": 1, \"event\": \"x\", \"reply\": 3}", "1:24: a line is an `event` or a `reply`, not both"),
            ("{\"t\": 1, \"reply\": \"DEC\"}", "1:10: `reply` must be PROGRAM.FUNCTION, command.VERB or an id, not `DEC`"),
            ("{\"t\": 1, \"reply\": -3}", "1:10: a reply id is a positive integer"),
            ("{\"t\": 1, \"reply\": \"DEC.f\", \"category\": \"safety\"}", "1:28: `category` belongs to events: a reply's category comes from its call"),
            ("{\"t\": 1, \"reply\": \"DEC.f\", \"failed\": \"no\", \"params\": {\"a\": 1}}", "1:44: a failed reply carries a reason, not `params`"),
            ("{\"t\": 1, \"reply\": \"DEC.f\", \"failed\": 3}", "1:28: `failed` must be a string (the reason)"),
            ("{\"t\": 1, \"t\": 2, \"event\": \"x\"}", "1:10: duplicate key `t`"),
            ("  {\"t\": 1, \"event\": \"x\", \"params\": {\"a\": 1, \"a\": 2}, \"event\": \"y\"}", "1:45: duplicate key `a`"),
            ("{\"t\": 1, \"params\": {}}", "1:10: a line with neither `event` nor `reply` only lets time pass: it takes only `t`"),
        ];
        let mut failures = Vec::new();
        for (text, expected) in cases {
            match parse(text) {
                Ok(_) => failures.push(format!("{text}: parsed")),
                Err(e) if e.to_string() != expected => {
                    failures.push(format!("{text}:\n  expected {expected}\n  got      {e}"))
                }
                Err(_) => {}
            }
        }
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }

    #[test]
    fn a_script_sends_only_what_the_gateway_could_deliver() {
        let files: std::collections::BTreeMap<String, String> = [
            ("project.toml".to_owned(), "[events]\nengine_failure = \"catastrophic\"\n[programs.DEC.functions]\nf = {}\n[[net]]\nfile = \"n.toml\"\nactive = true\n".to_owned()),
            ("n.toml".to_owned(), "name = \"N\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\n[[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"go\"\ndo = [\"call DEC.f\", \"emit replanned\"]\n[[transition]]\nname = \"u\"\nfrom = [\"b\"]\nto = [\"a\"]\non = \"DEC.f.done\"\n[[transition]]\nname = \"v\"\nfrom = [\"b\"]\nto = [\"a\"]\non = \"replanned\"\n".to_owned()),
        ]
        .into();
        let project = crate::load(&files).expect("loads");
        let cases = [
            (
                r#"{"t": 1, "event": "DEC.f.done"}"#,
                "1:10: event `DEC.f.done` cannot come from outside: a call's result",
            ),
            (
                r#"{"t": 1, "event": "command.ok"}"#,
                "1:10: event `command.ok` cannot come from outside: a command's result",
            ),
            (
                r#"{"t": 1, "event": "net_fault", "category": "nominal"}"#,
                "1:10: event `net_fault` cannot come from outside: `net_fault` is raised",
            ),
            (
                r#"{"t": 1, "event": "replanned"}"#,
                "1:10: event `replanned` cannot come from outside: the nets emit this event",
            ),
            (
                r#"{"t": 1, "event": "engine_failure", "category": "nominal"}"#,
                "1:37: `category`: event `engine_failure` is declared catastrophic",
            ),
        ];
        for (text, says) in cases {
            let lines = parse(text).expect("parses");
            let e = check(&project, &lines).expect_err(text).to_string();
            assert!(e.starts_with(says), "{text}: {e}");
        }
        for text in [
            r#"{"t": 1, "event": "go"}"#,
            r#"{"t": 1, "event": "engine_failure", "category": "catastrophic"}"#,
            r#"{"t": 1, "event": "engine_failure"}"#,
            r#"{"t": 1, "event": "obstacle", "category": "safety"}"#,
            r#"{"t": 1, "reply": "DEC.f"}"#,
        ] {
            let lines = parse(text).expect("parses");
            assert_eq!(check(&project, &lines), Ok(()), "{text}");
        }
    }

    #[test]
    fn a_reply_by_name_answers_the_oldest_pending_call_and_a_missing_one_is_an_error() {
        let files: std::collections::BTreeMap<String, String> = [
            ("project.toml".to_owned(), "[programs.DEC.functions]\nf = {}\n[[net]]\nfile = \"n.toml\"\nactive = true\n".to_owned()),
            ("n.toml".to_owned(), "name = \"N\"\nplaces = [\"a\"]\ninitial = [\"a\"]\n[[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"a\"]\non = \"go\"\ndo = [\"command arm\", \"call DEC.f\"]\n".to_owned()),
        ]
        .into();
        let project = std::sync::Arc::new(crate::load(&files).expect("loads"));
        let mut player = Player::start(project, 0);
        let lines = parse(
            "{\"t\": 1, \"event\": \"go\"}\n{\"t\": 2, \"event\": \"go\"}\n{\"t\": 3, \"reply\": \"DEC.f\"}\n{\"t\": 4, \"reply\": \"command.arm\"}\n{\"t\": 5, \"reply\": \"command.disarm\"}\n",
        )
        .expect("parses");
        for line in &lines[..2] {
            play_line(&mut player, line).expect("plays");
        }
        // Ids: arm 1, DEC.f 2, arm 3, DEC.f 4.
        for (line, id) in [(&lines[2], 2), (&lines[3], 1)] {
            let Input::Reply { to, .. } = &line.input else {
                panic!("a reply")
            };
            assert_eq!(resolve(&player, line, to), Ok(id));
            play_line(&mut player, line).expect("plays");
        }
        let ids: Vec<u64> = player.state().pending.keys().copied().collect();
        assert_eq!(ids, [3, 4]);
        assert_eq!(
            play_line(&mut player, &lines[4]).map_err(|e| e.to_string()),
            Err(
                "5:1: no pending `disarm` command to reply to (reply by id to send a late result)"
                    .into()
            )
        );
    }
}
