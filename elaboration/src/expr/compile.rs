//! A rule's condition compiled: the shared syntax tree
//! ([`nets::expr::syntax`]) with its names resolved — fields to message
//! slots, constants to numbers, calls to functions, `~` to a regex.

use std::borrow::Cow;

use nets::expr::syntax::{self, Kind, Syntax, Word};
use regex::Regex;

use super::{BinOp, Compiled, ExprError, Func, Node, Resolver, V};

/// Compiles an expression.
pub fn compile<R: Resolver>(src: &str, resolver: &mut R) -> Result<Compiled, ExprError> {
    let tree = syntax::parse(src)?;
    let mut c = Compiler {
        resolver,
        reads: Vec::new(),
        ages: Vec::new(),
        seen: Vec::new(),
        timed: false,
        regexes: Vec::new(),
    };
    let node = c.node(tree)?;
    for list in [&mut c.reads, &mut c.ages, &mut c.seen] {
        list.sort_unstable();
        list.dedup();
    }
    Ok(Compiled {
        node,
        reads: c.reads,
        ages: c.ages,
        seen: c.seen,
        timed: c.timed,
        regexes: c.regexes,
    })
}

struct Compiler<'r, R: Resolver> {
    resolver: &'r mut R,
    reads: Vec<usize>,
    ages: Vec<usize>,
    seen: Vec<usize>,
    timed: bool,
    regexes: Vec<usize>,
}

fn error_at(offset: usize, len: usize, message: impl Into<String>) -> ExprError {
    ExprError {
        offset,
        len: len.max(1),
        message: message.into(),
    }
}

impl<R: Resolver> Compiler<'_, R> {
    fn boxed(&mut self, s: Syntax) -> Result<Box<Node>, ExprError> {
        self.node(s).map(Box::new)
    }

    fn node(&mut self, s: Syntax) -> Result<Node, ExprError> {
        let Syntax { kind, at, len } = s;
        Ok(match kind {
            Kind::Int(i) => Node::Const(V::Int(i)),
            Kind::Float(f) => Node::Const(V::Float(f)),
            Kind::Str(s) => Node::Const(V::Str(Cow::Owned(s))),
            Kind::Bool(b) => Node::Const(V::Bool(b)),
            Kind::Name(name) => match self.resolver.constant(&name) {
                Some(v) => Node::Const(V::Int(v)),
                None => return Err(error_at(
                    at,
                    len,
                    format!("unknown name `{name}` (not a MAVLink enum value or flag; fields are written MESSAGE.field)"),
                )),
            },
            Kind::Param(name) => {
                return Err(error_at(
                    at,
                    len,
                    format!("`${name}` is an event parameter, for the nets' guards and arguments: a rule reads fields as MESSAGE.field"),
                ))
            }
            Kind::Field {
                message,
                field,
                index,
            } => {
                let end = field.at + field.len();
                let (slot, field) = self
                    .resolver
                    .field(&message.text, &field.text)
                    .map_err(|m| error_at(message.at, end - message.at, m))?;
                self.reads.push(slot);
                Node::Field { slot, field, index }
            }
            Kind::Call { name, args } => self.call(name, args)?,
            Kind::Unary(op, operand) => Node::Unary(op, self.boxed(*operand)?),
            Kind::Binary {
                op: BinOp::Match,
                left,
                right,
                ..
            } => {
                let text = self.boxed(*left)?;
                let Syntax {
                    kind: Kind::Str(pattern),
                    at,
                    len,
                } = *right
                else {
                    return Err(error_at(
                        right.at,
                        right.len,
                        "`~` takes a regular expression in quotes",
                    ));
                };
                let regex = Regex::new(&pattern)
                    .map_err(|e| error_at(at, len, format!("bad regular expression: {e}")))?;
                let id = self.resolver.regex(regex);
                self.regexes.push(id);
                Node::Match { text, regex: id }
            }
            Kind::Binary {
                op, left, right, ..
            } => Node::Binary(op, self.boxed(*left)?, self.boxed(*right)?),
            Kind::List(_) | Kind::Map(_) => {
                return Err(error_at(
                    at,
                    len,
                    "lists and maps are for the nets' action arguments, not rules",
                ))
            }
        })
    }

    fn call(&mut self, name: Word, args: Vec<Syntax>) -> Result<Node, ExprError> {
        let (at, len) = (name.at, name.len());
        let simple = match name.text.as_str() {
            "mode" => Some(Func::Mode),
            "firmware" => Some(Func::Firmware),
            "loss" => Some(Func::Loss),
            "sysid" => Some(Func::SysId),
            "compid" => Some(Func::CompId),
            _ => None,
        };
        if let Some(func) = simple {
            if let Some(first) = args.first() {
                return Err(error_at(
                    first.at,
                    first.len,
                    format!("`{}()` takes no arguments", name.text),
                ));
            }
            if func == Func::Loss {
                // The loss estimate moves with every frame of the source:
                // evaluated on every tick.
                self.timed = true;
            }
            if matches!(func, Func::Mode | Func::Firmware) {
                let (slot, _) = self
                    .resolver
                    .field("HEARTBEAT", "custom_mode")
                    .map_err(|m| error_at(at, len, m))?;
                self.reads.push(slot);
            }
            return Ok(Node::Call(func));
        }
        let name = name.text;
        let arity = |n: usize, shape: &str| -> Result<(), ExprError> {
            if args.len() == n {
                return Ok(());
            }
            let (at, len) = args.get(n).map_or((at, len), |extra| (extra.at, extra.len));
            Err(error_at(at, len, format!("`{name}` takes {shape}")))
        };
        match name.as_str() {
            "age" | "seen" => {
                let shape = format!("a message name, as in {name}(HEARTBEAT)");
                arity(1, &shape)?;
                let mut args = args.into_iter();
                let (message, mat, mlen) = match args.next() {
                    Some(Syntax {
                        kind: Kind::Name(m),
                        at,
                        len,
                    }) => (m, at, len),
                    Some(other) => {
                        return Err(error_at(other.at, other.len, format!("`{name}` takes {shape}")))
                    }
                    None => return Err(error_at(at, len, format!("`{name}` takes {shape}"))),
                };
                let slot = self
                    .resolver
                    .timed_message(&message)
                    .map_err(|m| error_at(mat, mlen, m))?;
                if name == "age" {
                    self.timed = true;
                    self.ages.push(slot);
                    Ok(Node::Age(slot))
                } else {
                    self.seen.push(slot);
                    Ok(Node::Seen(slot))
                }
            }
            "name" => {
                let shape = "an expression, then an enum's MAVLink name, as in name(COMMAND_ACK.result, MAV_RESULT)";
                arity(2, shape)?;
                let mut args = args.into_iter();
                let (Some(value), Some(enum_arg)) = (args.next(), args.next()) else {
                    return Err(error_at(at, len, format!("`name` takes {shape}")));
                };
                let inner = self.boxed(value)?;
                let Kind::Name(enum_name) = &enum_arg.kind else {
                    return Err(error_at(
                        enum_arg.at,
                        enum_arg.len,
                        "`name` takes an enum's MAVLink name second, as in name(COMMAND_ACK.result, MAV_RESULT)",
                    ));
                };
                let names = self.resolver.enum_names(enum_name).ok_or_else(|| {
                    error_at(
                        enum_arg.at,
                        enum_arg.len,
                        format!("unknown enum `{enum_name}` (an enum of the dialect, as MAV_CMD or MAV_RESULT)"),
                    )
                })?;
                Ok(Node::Name { inner, names })
            }
            "changed" | "abs" | "cos" => {
                arity(1, "one expression")?;
                let Some(e) = args.into_iter().next() else {
                    return Err(error_at(at, len, format!("`{name}` takes one expression")));
                };
                let inner = self.boxed(e)?;
                Ok(match name.as_str() {
                    "changed" => Node::Changed {
                        memo: self.resolver.memo(),
                        inner,
                    },
                    "cos" => Node::Cos(inner),
                    _ => Node::Abs(inner),
                })
            }
            "prev" => {
                if args.len() > 2 || args.is_empty() {
                    arity(2, "an expression and, optionally, its default")?;
                }
                let mut args = args.into_iter();
                let Some(e) = args.next() else {
                    return Err(error_at(at, len, "`prev` takes an expression"));
                };
                let inner = self.boxed(e)?;
                // prev(e, d): d when there is no previous value.
                let default = args.next().map(|d| self.boxed(d)).transpose()?;
                Ok(Node::Prev {
                    memo: self.resolver.memo(),
                    inner,
                    default,
                })
            }
            _ => Err(error_at(
                at,
                len,
                format!("unknown function `{name}` (known: age, seen, mode, firmware, loss, changed, prev, abs, cos, name, sysid, compid)"),
            )),
        }
    }
}
