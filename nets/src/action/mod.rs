//! The action syntax, as written in a transition's `do` list:
//!
//! ```text
//! activate NET
//! deactivate NET
//! emit EVENT {key: value, ...}
//! timer NAME after DURATION
//! cancel NAME
//! call PROGRAM.FUNCTION {key: value, ...}
//! command VERB {key: value, ...}
//! command VERB @VEHICLE {key: value, ...}   (a team net commanding one vehicle)
//! ask NAME "QUESTION" {choices: [CHOICE, ...]} timeout DURATION
//! ```
//!
//! This module only parses; the loader resolves names.

mod cursor;

use crate::expr::{lex, Context, Expr, SyntaxError};
use cursor::Cursor;

/// A name and its byte offset in the action text.
pub type Name = (String, usize);

/// A parsed, unresolved action.
#[derive(Debug, Clone, PartialEq)]
pub enum ActionSyntax {
    Activate(Name),
    Deactivate(Name),
    Emit {
        event: Name,
        args: Vec<(String, Expr)>,
    },
    Timer {
        name: Name,
        after: Name,
    },
    Cancel(Name),
    Call {
        program: Name,
        function: Name,
        args: Vec<(String, Expr)>,
    },
    Command {
        verb: Name,
        args: Vec<(String, Expr)>,
        /// `command VERB @VEHICLE {..}`: the vehicle a team net commands.
        vehicle: Option<Name>,
    },
    /// `ask NAME "QUESTION" {choices: [..]} timeout DURATION`.
    Ask {
        name: Name,
        question: String,
        /// The choices, each a name, with their offsets.
        choices: Vec<Name>,
        timeout: Name,
    },
}

const STOPS: &[char] = &['{', '}', ',', ':'];

/// Parses one action.
pub fn parse(text: &str) -> Result<ActionSyntax, SyntaxError> {
    let mut p = Cursor::new(text);
    let Some((keyword, at)) = p.name() else {
        return Err(p.error(
            "expected an action: activate, deactivate, emit, timer, cancel, call, command or ask",
        ));
    };
    let action = match keyword.as_str() {
        "activate" => ActionSyntax::Activate(net_name(&mut p)?),
        "deactivate" => ActionSyntax::Deactivate(net_name(&mut p)?),
        "emit" => ActionSyntax::Emit {
            event: p
                .word(STOPS)
                .ok_or_else(|| p.error("expected an event name after `emit`"))?,
            args: args(&mut p)?,
        },
        "timer" => {
            let name = p
                .name()
                .ok_or_else(|| p.error("expected a timer name after `timer`"))?;
            if !p.eat("after") {
                return Err(p.error("expected `after DURATION`"));
            }
            p.skip_ws();
            let at = p.pos;
            let rest = p.text[at..].trim_end().to_owned();
            if rest.is_empty() {
                return Err(p.error("expected a duration after `after`"));
            }
            p.pos = p.text.len();
            ActionSyntax::Timer {
                name,
                after: (rest, at),
            }
        }
        "cancel" => ActionSyntax::Cancel(
            p.name()
                .ok_or_else(|| p.error("expected a timer name after `cancel`"))?,
        ),
        "call" => {
            let program = p
                .name()
                .ok_or_else(|| p.error("expected PROGRAM.FUNCTION after `call`"))?;
            if !p.text[p.pos..].starts_with('.') {
                return Err(p.error("expected `.FUNCTION` after the program name"));
            }
            p.pos += 1;
            let after_dot = p.pos;
            let function = match p.name() {
                Some(f) if f.1 == after_dot => f,
                _ => {
                    return Err(SyntaxError::new(
                        after_dot,
                        1,
                        "expected a function name after `.`",
                    ))
                }
            };
            ActionSyntax::Call {
                program,
                function,
                args: args(&mut p)?,
            }
        }
        "command" => {
            let verb = p
                .name()
                .ok_or_else(|| p.error("expected a verb after `command`"))?;
            p.skip_ws();
            let vehicle = if p.text[p.pos..].starts_with('@') {
                p.pos += 1;
                let after = p.pos;
                match p.name() {
                    Some(v) if v.1 == after => Some(v),
                    _ => return Err(p.error("expected a vehicle name after `@`")),
                }
            } else {
                None
            };
            ActionSyntax::Command {
                verb,
                args: args(&mut p)?,
                vehicle,
            }
        }
        "ask" => ask(&mut p)?,
        other => {
            return Err(SyntaxError::new(
                at,
                other.len(),
                format!(
                    "unknown action `{other}`: expected activate, deactivate, emit, timer, cancel, call, command or ask"
                ),
            ))
        }
    };
    if !p.at_end() {
        return Err(p.error("unexpected text after the action"));
    }
    Ok(action)
}

fn ask(p: &mut Cursor) -> Result<ActionSyntax, SyntaxError> {
    let name = p
        .name()
        .ok_or_else(|| p.error("expected the ask's name after `ask`"))?;
    p.skip_ws();
    if !p.text[p.pos..].starts_with('"') {
        return Err(p.error("expected the question in double quotes after the ask's name"));
    }
    let question = match lex::string(p.text, p.pos)? {
        lex::Token {
            tok: lex::Tok::Str(s),
            len,
            ..
        } => {
            p.pos += len;
            s
        }
        _ => return Err(p.error("expected the question in double quotes after the ask's name")),
    };
    p.skip_ws();
    let map_at = p.pos;
    let shape = "expected `{choices: [CHOICE, ...]}` after the question";
    if !p.text[p.pos..].starts_with('{') {
        return Err(p.error(shape));
    }
    let map = map(p)?;
    let bad = || {
        SyntaxError::new(
            map_at,
            1,
            "expected `{choices: [CHOICE, ...]}` with at least one choice, each a name",
        )
    };
    let [(key, Expr::List(items))] = map.as_slice() else {
        return Err(bad());
    };
    if key != "choices" || items.is_empty() {
        return Err(bad());
    }
    let mut choices: Vec<Name> = Vec::new();
    for item in items {
        // In an argument a bare name is a string literal; a quoted string
        // must be a name too, since the choice becomes part of an event name.
        match item {
            Expr::Lit(crate::value::Value::Str(s))
                if s.chars()
                    .next()
                    .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
                    && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') =>
            {
                choices.push((s.clone(), map_at));
            }
            _ => return Err(bad()),
        }
    }
    if !p.eat("timeout") {
        return Err(p.error("expected `timeout DURATION` after the choices"));
    }
    p.skip_ws();
    let at = p.pos;
    let rest = p.text[at..].trim_end().to_owned();
    if rest.is_empty() {
        return Err(p.error("expected a duration after `timeout`"));
    }
    p.pos = p.text.len();
    Ok(ActionSyntax::Ask {
        name,
        question,
        choices,
        timeout: (rest, at),
    })
}

fn net_name(p: &mut Cursor) -> Result<Name, SyntaxError> {
    p.word(STOPS).ok_or_else(|| p.error("expected a net name"))
}

fn args(p: &mut Cursor) -> Result<Vec<(String, Expr)>, SyntaxError> {
    if p.at_end() {
        return Ok(Vec::new());
    }
    p.skip_ws();
    if !p.text[p.pos..].starts_with('{') {
        return Err(p.error("expected arguments in braces: {key: value, ...}"));
    }
    map(p)
}

/// `{key: value, ...}` at the cursor, read by the expression parser.
fn map(p: &mut Cursor) -> Result<Vec<(String, Expr)>, SyntaxError> {
    let (items, end) = crate::expr::parse_map_at(p.text, p.pos, Context::Argument)?;
    p.pos = end;
    Ok(items)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::value::Value;

    #[test]
    fn every_form() {
        assert_eq!(
            parse("activate MISSION"),
            Ok(ActionSyntax::Activate(("MISSION".into(), 9)))
        );
        assert_eq!(
            parse("deactivate  EVENTS "),
            Ok(ActionSyntax::Deactivate(("EVENTS".into(), 12)))
        );
        assert_eq!(
            parse("timer climb after 30s"),
            Ok(ActionSyntax::Timer {
                name: ("climb".into(), 6),
                after: ("30s".into(), 18)
            })
        );
        assert_eq!(
            parse("cancel climb"),
            Ok(ActionSyntax::Cancel(("climb".into(), 7)))
        );
        let ActionSyntax::Call {
            program,
            function,
            args,
        } = parse("call DEC.next_waypoint {index: $seq}").unwrap()
        else {
            panic!("not a call")
        };
        assert_eq!(
            (program.0.as_str(), function.0.as_str()),
            ("DEC", "next_waypoint")
        );
        assert_eq!(args[0].0, "index");
        let ActionSyntax::Command { verb, args, .. } = parse("command mode {mode: AUTO}").unwrap()
        else {
            panic!("not a command")
        };
        assert_eq!(verb.0, "mode");
        assert_eq!(args[0].1, Expr::Lit(Value::Str("AUTO".into())));
        let ActionSyntax::Ask {
            name,
            question,
            choices,
            timeout,
        } = parse(r#"ask survey "Survey T2?" {choices: [yes, "no"]} timeout 60s"#).unwrap()
        else {
            panic!("not an ask")
        };
        assert_eq!(
            (name.0.as_str(), question.as_str()),
            ("survey", "Survey T2?")
        );
        let choices: Vec<&str> = choices.iter().map(|c| c.0.as_str()).collect();
        assert_eq!(choices, ["yes", "no"]);
        assert_eq!(timeout, ("60s".into(), 55));
        let ActionSyntax::Emit { event, args } = parse("emit replanned").unwrap() else {
            panic!("not an emit")
        };
        assert_eq!((event.0.as_str(), args.len()), ("replanned", 0));
    }

    #[test]
    fn a_command_names_its_vehicle_after_the_verb() {
        let ActionSyntax::Command {
            verb,
            args,
            vehicle,
        } = parse("command goto @R2 {lat: 1}").unwrap()
        else {
            panic!("not a command")
        };
        assert_eq!(verb.0, "goto");
        assert_eq!(vehicle, Some(("R2".into(), 14)));
        assert_eq!(args.len(), 1);
        let Ok(ActionSyntax::Command { vehicle, .. }) = parse("command rtl @R1") else {
            panic!("not a command")
        };
        assert_eq!(vehicle, Some(("R1".into(), 13)));
        assert_eq!(
            parse("command rtl @ R1").map(|_| ()).unwrap_err().message,
            "expected a vehicle name after `@`"
        );
    }

    #[test]
    fn errors() {
        let cases = [
            ("", 0, "expected an action: activate, deactivate, emit, timer, cancel, call, command or ask"),
            ("launch rockets", 0, "unknown action `launch`: expected activate, deactivate, emit, timer, cancel, call, command or ask"),
            ("ask q {choices: [a]} timeout 1s", 6, "expected the question in double quotes after the ask's name"),
            ("ask q \"Go?\" timeout 1s", 12, "expected `{choices: [CHOICE, ...]}` after the question"),
            ("ask q \"Go?\" {choices: []} timeout 1s", 12, "expected `{choices: [CHOICE, ...]}` with at least one choice, each a name"),
            ("ask q \"Go?\" {choices: [a, \"b c\"]} timeout 1s", 12, "expected `{choices: [CHOICE, ...]}` with at least one choice, each a name"),
            ("ask q \"Go?\" {choices: [a]}", 26, "expected `timeout DURATION` after the choices"),
            ("timer t 30s", 8, "expected `after DURATION`"),
            ("call DEC", 8, "expected `.FUNCTION` after the program name"),
            ("call DEC. f", 9, "expected a function name after `.`"),
            ("command arm force", 12, "expected arguments in braces: {key: value, ...}"),
            ("command mode {mode AUTO}", 19, "expected `:` after `mode`"),
            ("activate A B", 11, "unexpected text after the action"),
        ];
        for (text, at, message) in cases {
            let e = parse(text).expect_err(text);
            assert_eq!((e.at, e.message.as_str()), (at, message), "{text}");
        }
    }
}
