//! Rule conditions: parsing into a compiled tree with resolved message
//! slots, field indices and constants, and its evaluation.
//!
//! Grammar, lowest precedence first: `||` (`or`), `&&` (`and`), comparisons
//! (`== != < <= > >=`, `~` regex match), `|`, `^`, `&`, `+ -`, `* / %`,
//! unary `! not - ~`, then primaries: numbers (`12`, `0x10`, `2.5`), strings
//! (`"..."`), `true`, `false`, constants (`MAV_STATE_CRITICAL`), fields
//! (`SYS_STATUS.battery_remaining`, `ESC_TELEMETRY_1_TO_4.rpm[0]`), calls
//! (`age(HEARTBEAT)`, `seen(MSG)`, `mode()`, `firmware()`, `loss()`,
//! `changed(e)`, `prev(e)`, `prev(e, default)`, `abs(e)`, `cos(e)` (of radians), `name(e, ENUM)`,
//! `sysid()`, `compid()`)
//! and parentheses.

use std::borrow::Cow;
use std::collections::HashMap;

use regex::Regex;

/// A problem in an expression, at a byte offset of its text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ExprError {
    pub offset: usize,
    pub len: usize,
    pub message: String,
}

/// A value during evaluation. `Missing` is "not known yet" (a field of a
/// message never received): it propagates, and a condition that ends
/// `Missing` leaves its rule as it was.
#[derive(Debug, Clone, PartialEq)]
pub enum V<'a> {
    Missing,
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(Cow<'a, str>),
}

impl V<'_> {
    pub fn truth(&self) -> Option<bool> {
        match self {
            V::Missing => None,
            V::Bool(b) => Some(*b),
            V::Int(i) => Some(*i != 0),
            V::Float(f) => Some(*f != 0.0),
            V::Str(s) => Some(!s.is_empty()),
        }
    }

    fn num(&self) -> Option<f64> {
        match self {
            V::Int(i) => Some(*i as f64),
            V::Float(f) => Some(*f),
            V::Bool(b) => Some(*b as i64 as f64),
            _ => None,
        }
    }

    fn int(&self) -> Option<i64> {
        match self {
            V::Int(i) => Some(*i),
            V::Bool(b) => Some(*b as i64),
            V::Float(f) if f.fract() == 0.0 => Some(*f as i64),
            _ => None,
        }
    }

    pub fn into_owned(self) -> V<'static> {
        match self {
            V::Missing => V::Missing,
            V::Bool(b) => V::Bool(b),
            V::Int(i) => V::Int(i),
            V::Float(f) => V::Float(f),
            V::Str(s) => V::Str(Cow::Owned(s.into_owned())),
        }
    }

    /// As an event parameter (`None` when missing).
    pub fn to_value(&self) -> Option<nets::Value> {
        Some(match self {
            V::Missing => return None,
            V::Bool(b) => nets::Value::Bool(*b),
            V::Int(i) => nets::Value::Int(*i),
            V::Float(f) => nets::Value::Float(*f),
            V::Str(s) => nets::Value::Str(s.to_string()),
        })
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinOp {
    Or,
    And,
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
    BitOr,
    BitXor,
    BitAnd,
    Add,
    Sub,
    Mul,
    Div,
    Rem,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UnOp {
    Not,
    Neg,
    BitNot,
}

/// Functions of the language.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Func {
    Mode,
    Firmware,
    Loss,
    SysId,
    CompId,
}

/// The compiled form of an expression.
#[derive(Debug, Clone)]
pub enum Node {
    Const(V<'static>),
    /// A field of the last message of a slot from this source.
    Field {
        slot: usize,
        field: usize,
        index: Option<usize>,
    },
    /// Seconds since the last frame of a message id from this source.
    Age(usize),
    /// Whether a message id was ever received from this source.
    Seen(usize),
    Call(Func),
    /// True when the inner value differs from its value at the previous
    /// evaluation; `memo` is its memory slot.
    Changed {
        memo: usize,
        inner: Box<Node>,
    },
    /// The inner value at the previous evaluation; `default` (else
    /// unknown) when there was none.
    Prev {
        memo: usize,
        inner: Box<Node>,
        default: Option<Box<Node>>,
    },
    Abs(Box<Node>),
    /// The cosine of an angle in radians (always a float).
    Cos(Box<Node>),
    /// The name of an enum value (`name(COMMAND_ACK.result, MAV_RESULT)`
    /// is `"DENIED"`); a value the enum does not name gives its number as
    /// text.
    Name {
        inner: Box<Node>,
        names: &'static HashMap<i64, String>,
    },
    Unary(UnOp, Box<Node>),
    Binary(BinOp, Box<Node>, Box<Node>),
    Match {
        text: Box<Node>,
        regex: usize,
    },
}

/// What compiling an expression needs from the profile: message and field
/// names, constants, and tables it fills (message slots, regexes, memories).
pub trait Resolver {
    /// The slot of a message read for its fields, and the index of a field.
    fn field(&mut self, message: &str, field: &str) -> Result<(usize, usize), String>;
    /// The slot of a message whose frame times are tracked.
    fn timed_message(&mut self, message: &str) -> Result<usize, String>;
    fn constant(&self, name: &str) -> Option<i64>;
    /// The values of an enum by its MAVLink name, with their names.
    fn enum_names(&self, name: &str) -> Option<&'static HashMap<i64, String>> {
        crate::constants::enum_names(name)
    }
    fn regex(&mut self, regex: Regex) -> usize;
    fn memo(&mut self) -> usize;
}

/// What evaluating an expression reads.
pub trait Context {
    fn field(&self, slot: usize, field: usize, index: Option<usize>) -> V<'_>;
    fn age(&self, slot: usize) -> f64;
    fn seen(&self, slot: usize) -> bool;
    fn call(&self, func: Func) -> V<'static>;
    fn regex(&self, regex: usize) -> &Regex;
    fn memo(&mut self, memo: usize) -> &mut V<'static>;
}

// ---------------------------------------------------------------- lexer

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Num(V<'static>),
    Str(String),
    Ident(String),
    Op(&'static str),
    End,
}

struct Lexer<'s> {
    src: &'s str,
    pos: usize,
}

const OPS: [&str; 25] = [
    "||", "&&", "==", "!=", "<=", ">=", "<", ">", "~", "|", "^", "&", "+", "-", "*", "/", "%", "!",
    "(", ")", ".", ",", "[", "]", "=",
];

impl Lexer<'_> {
    fn next(&mut self) -> Result<(Tok, usize, usize), ExprError> {
        let bytes = self.src.as_bytes();
        while self.pos < bytes.len() && bytes[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        let start = self.pos;
        let Some(&c) = bytes.get(start) else {
            return Ok((Tok::End, start, 0));
        };
        let err = |len: usize, m: String| ExprError {
            offset: start,
            len,
            message: m,
        };
        if c.is_ascii_digit() {
            let mut end = start;
            let hex = self.src[start..].starts_with("0x") || self.src[start..].starts_with("0X");
            if hex {
                end += 2;
                while end < bytes.len() && bytes[end].is_ascii_hexdigit() {
                    end += 1;
                }
                self.pos = end;
                let text = &self.src[start + 2..end];
                return i64::from_str_radix(text, 16)
                    .map(|n| (Tok::Num(V::Int(n)), start, end - start))
                    .map_err(|_| err(end - start, format!("bad hexadecimal number `{text}`")));
            }
            while end < bytes.len() && (bytes[end].is_ascii_digit() || bytes[end] == b'.') {
                end += 1;
            }
            self.pos = end;
            let text = &self.src[start..end];
            let v = if text.contains('.') {
                text.parse::<f64>().ok().map(V::Float)
            } else {
                text.parse::<i64>().ok().map(V::Int)
            };
            return v
                .map(|v| (Tok::Num(v), start, end - start))
                .ok_or_else(|| err(end - start, format!("bad number `{text}`")));
        }
        if c.is_ascii_alphabetic() || c == b'_' {
            let mut end = start;
            while end < bytes.len() && (bytes[end].is_ascii_alphanumeric() || bytes[end] == b'_') {
                end += 1;
            }
            self.pos = end;
            return Ok((
                Tok::Ident(self.src[start..end].to_owned()),
                start,
                end - start,
            ));
        }
        if c == b'"' || c == b'\'' {
            let mut out = String::new();
            let mut chars = self.src[start + 1..].char_indices();
            while let Some((i, ch)) = chars.next() {
                if ch as u32 == c as u32 {
                    self.pos = start + 1 + i + 1;
                    return Ok((Tok::Str(out), start, self.pos - start));
                }
                if ch == '\\' {
                    match chars.next() {
                        Some((_, e @ ('"' | '\'' | '\\'))) => out.push(e),
                        Some((_, 'n')) => out.push('\n'),
                        // Other escapes are kept for the regex engine.
                        Some((_, e)) => {
                            out.push('\\');
                            out.push(e);
                        }
                        None => break,
                    }
                } else {
                    out.push(ch);
                }
            }
            return Err(err(self.src.len() - start, "unterminated string".into()));
        }
        for op in OPS {
            if self.src[start..].starts_with(op) {
                self.pos += op.len();
                return Ok((Tok::Op(op), start, op.len()));
            }
        }
        let ch = self.src[start..].chars().next().unwrap_or('?');
        Err(err(ch.len_utf8(), format!("unexpected character `{ch}`")))
    }
}

// ---------------------------------------------------------------- parser

struct Parser<'s, 'r, R: Resolver> {
    lexer: Lexer<'s>,
    tok: Tok,
    at: usize,
    len: usize,
    resolver: &'r mut R,
    /// Messages the expression reads fields of (slots), for triggering.
    pub reads: Vec<usize>,
    pub ages: Vec<usize>,
    pub seen: Vec<usize>,
    pub timed: bool,
    pub regexes: Vec<usize>,
}

/// A compiled expression and what it depends on.
#[derive(Debug, Clone)]
pub struct Compiled {
    pub node: Node,
    /// Slots of the messages whose fields it reads (or `mode()`'s HEARTBEAT).
    pub reads: Vec<usize>,
    /// Slots of the messages whose age it reads: their frames trigger an
    /// evaluation too (a link is restored the moment a heartbeat arrives).
    pub ages: Vec<usize>,
    /// Slots of the messages it asks whether they were ever heard
    /// (`seen()`): no trigger, but what it depends on
    /// (`Profile::event_needs`).
    pub seen: Vec<usize>,
    /// Whether its value can change without a message it reads (`age()`,
    /// `loss()`): evaluated on every tick.
    pub timed: bool,
    /// Regexes it matches, in order (their named captures become parameters).
    pub regexes: Vec<usize>,
}

/// Compiles an expression. `heartbeat_slot` is called for `mode()`, which
/// reads the source's HEARTBEAT.
pub fn compile<R: Resolver>(src: &str, resolver: &mut R) -> Result<Compiled, ExprError> {
    let mut lexer = Lexer { src, pos: 0 };
    let (tok, at, len) = lexer.next()?;
    let mut p = Parser {
        lexer,
        tok,
        at,
        len,
        resolver,
        reads: Vec::new(),
        ages: Vec::new(),
        seen: Vec::new(),
        timed: false,
        regexes: Vec::new(),
    };
    let node = p.or()?;
    if p.tok != Tok::End {
        return Err(p.error("expected an operator or the end of the expression"));
    }
    p.reads.sort_unstable();
    p.reads.dedup();
    p.ages.sort_unstable();
    p.ages.dedup();
    p.seen.sort_unstable();
    p.seen.dedup();
    Ok(Compiled {
        node,
        reads: p.reads,
        ages: p.ages,
        seen: p.seen,
        timed: p.timed,
        regexes: p.regexes,
    })
}

impl<R: Resolver> Parser<'_, '_, R> {
    fn bump(&mut self) -> Result<(), ExprError> {
        let (tok, at, len) = self.lexer.next()?;
        self.tok = tok;
        self.at = at;
        self.len = len;
        Ok(())
    }

    fn error(&self, message: impl Into<String>) -> ExprError {
        ExprError {
            offset: self.at,
            len: self.len.max(1),
            message: message.into(),
        }
    }

    fn error_at(&self, offset: usize, len: usize, message: impl Into<String>) -> ExprError {
        ExprError {
            offset,
            len: len.max(1),
            message: message.into(),
        }
    }

    fn is_op(&self, op: &str) -> bool {
        matches!(self.tok, Tok::Op(o) if o == op)
    }

    fn is_word(&self, w: &str) -> bool {
        matches!(&self.tok, Tok::Ident(i) if i == w)
    }

    fn expect(&mut self, op: &str) -> Result<(), ExprError> {
        if self.is_op(op) {
            self.bump()
        } else {
            Err(self.error(format!("expected `{op}`")))
        }
    }

    fn or(&mut self) -> Result<Node, ExprError> {
        let mut left = self.and()?;
        while self.is_op("||") || self.is_word("or") {
            self.bump()?;
            let right = self.and()?;
            left = Node::Binary(BinOp::Or, Box::new(left), Box::new(right));
        }
        Ok(left)
    }

    fn and(&mut self) -> Result<Node, ExprError> {
        let mut left = self.cmp()?;
        while self.is_op("&&") || self.is_word("and") {
            self.bump()?;
            let right = self.cmp()?;
            left = Node::Binary(BinOp::And, Box::new(left), Box::new(right));
        }
        Ok(left)
    }

    fn cmp(&mut self) -> Result<Node, ExprError> {
        let left = self.bitor()?;
        let op = match self.tok {
            Tok::Op("==") => BinOp::Eq,
            Tok::Op("!=") => BinOp::Ne,
            Tok::Op("<") => BinOp::Lt,
            Tok::Op("<=") => BinOp::Le,
            Tok::Op(">") => BinOp::Gt,
            Tok::Op(">=") => BinOp::Ge,
            Tok::Op("=") => return Err(self.error("`=` is not a comparison: use `==`")),
            Tok::Op("~") => {
                self.bump()?;
                let (at, len) = (self.at, self.len);
                let Tok::Str(pattern) = self.tok.clone() else {
                    return Err(self.error("`~` takes a regular expression in quotes"));
                };
                let regex = Regex::new(&pattern)
                    .map_err(|e| self.error_at(at, len, format!("bad regular expression: {e}")))?;
                self.bump()?;
                let id = self.resolver.regex(regex);
                self.regexes.push(id);
                return Ok(Node::Match {
                    text: Box::new(left),
                    regex: id,
                });
            }
            _ => return Ok(left),
        };
        self.bump()?;
        let right = self.bitor()?;
        Ok(Node::Binary(op, Box::new(left), Box::new(right)))
    }

    fn bitor(&mut self) -> Result<Node, ExprError> {
        let mut left = self.bitxor()?;
        while self.is_op("|") {
            self.bump()?;
            let right = self.bitxor()?;
            left = Node::Binary(BinOp::BitOr, Box::new(left), Box::new(right));
        }
        Ok(left)
    }

    fn bitxor(&mut self) -> Result<Node, ExprError> {
        let mut left = self.bitand()?;
        while self.is_op("^") {
            self.bump()?;
            let right = self.bitand()?;
            left = Node::Binary(BinOp::BitXor, Box::new(left), Box::new(right));
        }
        Ok(left)
    }

    fn bitand(&mut self) -> Result<Node, ExprError> {
        let mut left = self.sum()?;
        while self.is_op("&") {
            self.bump()?;
            let right = self.sum()?;
            left = Node::Binary(BinOp::BitAnd, Box::new(left), Box::new(right));
        }
        Ok(left)
    }

    fn sum(&mut self) -> Result<Node, ExprError> {
        let mut left = self.product()?;
        loop {
            let op = match self.tok {
                Tok::Op("+") => BinOp::Add,
                Tok::Op("-") => BinOp::Sub,
                _ => return Ok(left),
            };
            self.bump()?;
            let right = self.product()?;
            left = Node::Binary(op, Box::new(left), Box::new(right));
        }
    }

    fn product(&mut self) -> Result<Node, ExprError> {
        let mut left = self.unary()?;
        loop {
            let op = match self.tok {
                Tok::Op("*") => BinOp::Mul,
                Tok::Op("/") => BinOp::Div,
                Tok::Op("%") => BinOp::Rem,
                _ => return Ok(left),
            };
            self.bump()?;
            let right = self.unary()?;
            left = Node::Binary(op, Box::new(left), Box::new(right));
        }
    }

    fn unary(&mut self) -> Result<Node, ExprError> {
        let op = match &self.tok {
            Tok::Op("!") => UnOp::Not,
            Tok::Ident(w) if w == "not" => UnOp::Not,
            Tok::Op("-") => UnOp::Neg,
            Tok::Op("~") => UnOp::BitNot,
            _ => return self.primary(),
        };
        self.bump()?;
        let inner = self.unary()?;
        Ok(Node::Unary(op, Box::new(inner)))
    }

    fn message_arg(&mut self, func: &str) -> Result<(String, usize, usize), ExprError> {
        self.expect("(")?;
        let (at, len) = (self.at, self.len);
        let Tok::Ident(name) = self.tok.clone() else {
            return Err(self.error(format!(
                "`{func}` takes a message name, as in {func}(HEARTBEAT)"
            )));
        };
        self.bump()?;
        self.expect(")")?;
        Ok((name, at, len))
    }

    fn primary(&mut self) -> Result<Node, ExprError> {
        let (at, len) = (self.at, self.len);
        match self.tok.clone() {
            Tok::Num(v) => {
                self.bump()?;
                Ok(Node::Const(v))
            }
            Tok::Str(s) => {
                self.bump()?;
                Ok(Node::Const(V::Str(Cow::Owned(s))))
            }
            Tok::Op("(") => {
                self.bump()?;
                let inner = self.or()?;
                self.expect(")")?;
                Ok(inner)
            }
            Tok::Ident(name) => {
                self.bump()?;
                if self.is_op("(") {
                    return self.call(&name, at, len);
                }
                if self.is_op(".") {
                    self.bump()?;
                    let Tok::Ident(field) = self.tok.clone() else {
                        return Err(self.error("expected a field name after `.`"));
                    };
                    let end = self.at + self.len;
                    self.bump()?;
                    let (slot, field) = self
                        .resolver
                        .field(&name, &field)
                        .map_err(|m| self.error_at(at, end - at, m))?;
                    self.reads.push(slot);
                    let index = if self.is_op("[") {
                        self.bump()?;
                        let Tok::Num(V::Int(i)) = self.tok else {
                            return Err(self.error("expected an index"));
                        };
                        let i = usize::try_from(i).map_err(|_| self.error("bad index"))?;
                        self.bump()?;
                        self.expect("]")?;
                        Some(i)
                    } else {
                        None
                    };
                    return Ok(Node::Field { slot, field, index });
                }
                match name.as_str() {
                    "true" => Ok(Node::Const(V::Bool(true))),
                    "false" => Ok(Node::Const(V::Bool(false))),
                    _ => match self.resolver.constant(&name) {
                        Some(v) => Ok(Node::Const(V::Int(v))),
                        None => Err(self.error_at(
                            at,
                            len,
                            format!("unknown name `{name}` (not a MAVLink enum value or flag; fields are written MESSAGE.field)"),
                        )),
                    },
                }
            }
            Tok::End => Err(self.error("unexpected end of the expression")),
            _ => Err(self.error("expected a value")),
        }
    }

    fn call(&mut self, name: &str, at: usize, len: usize) -> Result<Node, ExprError> {
        let simple = |f| Some(f);
        let func = match name {
            "mode" => simple(Func::Mode),
            "firmware" => simple(Func::Firmware),
            "loss" => simple(Func::Loss),
            "sysid" => simple(Func::SysId),
            "compid" => simple(Func::CompId),
            _ => None,
        };
        if let Some(func) = func {
            self.expect("(")?;
            self.expect(")")?;
            if func == Func::Loss {
                // The loss estimate moves with every frame of the source:
                // evaluated on every tick.
                self.timed = true;
            }
            if matches!(func, Func::Mode | Func::Firmware) {
                let (slot, _) = self
                    .resolver
                    .field("HEARTBEAT", "custom_mode")
                    .map_err(|m| self.error_at(at, len, m))?;
                self.reads.push(slot);
            }
            return Ok(Node::Call(func));
        }
        match name {
            "age" | "seen" => {
                let (msg, mat, mlen) = self.message_arg(name)?;
                let slot = self
                    .resolver
                    .timed_message(&msg)
                    .map_err(|m| self.error_at(mat, mlen, m))?;
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
                self.expect("(")?;
                let inner = Box::new(self.or()?);
                self.expect(",")?;
                let (eat, elen) = (self.at, self.len);
                let Tok::Ident(enum_name) = self.tok.clone() else {
                    return Err(self.error(
                        "`name` takes an enum's MAVLink name second, as in name(COMMAND_ACK.result, MAV_RESULT)",
                    ));
                };
                let names = self.resolver.enum_names(&enum_name).ok_or_else(|| {
                    self.error_at(
                        eat,
                        elen,
                        format!("unknown enum `{enum_name}` (an enum of the dialect, as MAV_CMD or MAV_RESULT)"),
                    )
                })?;
                self.bump()?;
                self.expect(")")?;
                Ok(Node::Name { inner, names })
            }
            "changed" | "prev" | "abs" | "cos" => {
                self.expect("(")?;
                let inner = Box::new(self.or()?);
                // prev(e, d): d when there is no previous value.
                let default = if name == "prev" && self.is_op(",") {
                    self.bump()?;
                    Some(Box::new(self.or()?))
                } else {
                    None
                };
                self.expect(")")?;
                Ok(match name {
                    "changed" => Node::Changed {
                        memo: self.resolver.memo(),
                        inner,
                    },
                    "prev" => Node::Prev {
                        memo: self.resolver.memo(),
                        inner,
                        default,
                    },
                    "cos" => Node::Cos(inner),
                    _ => Node::Abs(inner),
                })
            }
            _ => Err(self.error_at(
                at,
                len,
                format!("unknown function `{name}` (known: age, seen, mode, firmware, loss, changed, prev, abs, cos, name, sysid, compid)"),
            )),
        }
    }
}

// ---------------------------------------------------------------- evaluation

fn compare(op: BinOp, a: &V, b: &V) -> V<'static> {
    let ord = match (a, b) {
        (V::Str(x), V::Str(y)) => x.as_ref().partial_cmp(y.as_ref()),
        (V::Int(x), V::Int(y)) => x.partial_cmp(y),
        _ => match (a.num(), b.num()) {
            (Some(x), Some(y)) => x.partial_cmp(&y),
            _ => {
                // A string against a number: only (in)equality means something.
                return match op {
                    BinOp::Eq => V::Bool(false),
                    BinOp::Ne => V::Bool(true),
                    _ => V::Missing,
                };
            }
        },
    };
    let Some(ord) = ord else {
        return V::Bool(op == BinOp::Ne);
    };
    use std::cmp::Ordering::*;
    V::Bool(match op {
        BinOp::Eq => ord == Equal,
        BinOp::Ne => ord != Equal,
        BinOp::Lt => ord == Less,
        BinOp::Le => ord != Greater,
        BinOp::Gt => ord == Greater,
        BinOp::Ge => ord != Less,
        _ => return V::Missing,
    })
}

fn arith(op: BinOp, a: &V, b: &V) -> V<'static> {
    if let (V::Int(x), V::Int(y)) = (a, b) {
        let r = match op {
            BinOp::Add => x.checked_add(*y),
            BinOp::Sub => x.checked_sub(*y),
            BinOp::Mul => x.checked_mul(*y),
            BinOp::Div => {
                return if *y == 0 {
                    V::Missing
                } else {
                    V::Float(*x as f64 / *y as f64)
                }
            }
            BinOp::Rem => x.checked_rem(*y),
            _ => None,
        };
        return r.map(V::Int).unwrap_or(V::Missing);
    }
    let (Some(x), Some(y)) = (a.num(), b.num()) else {
        return V::Missing;
    };
    let r = match op {
        BinOp::Add => x + y,
        BinOp::Sub => x - y,
        BinOp::Mul => x * y,
        BinOp::Div if y != 0.0 => x / y,
        BinOp::Rem if y != 0.0 => x % y,
        _ => return V::Missing,
    };
    V::Float(r)
}

fn bits(op: BinOp, a: &V, b: &V) -> V<'static> {
    let (Some(x), Some(y)) = (a.int(), b.int()) else {
        return V::Missing;
    };
    V::Int(match op {
        BinOp::BitAnd => x & y,
        BinOp::BitOr => x | y,
        _ => x ^ y,
    })
}

/// Evaluates a compiled expression.
pub fn eval<'n, C: Context>(node: &'n Node, cx: &mut C) -> V<'n> {
    match node {
        Node::Const(V::Str(s)) => V::Str(Cow::Borrowed(s.as_ref())),
        Node::Const(v) => v.clone(),
        Node::Field { slot, field, index } => cx.field(*slot, *field, *index).into_owned(),
        Node::Age(slot) => V::Float(cx.age(*slot)),
        Node::Seen(slot) => V::Bool(cx.seen(*slot)),
        Node::Call(f) => cx.call(*f),
        Node::Changed { memo, inner } => {
            let now = eval(inner, cx);
            if now == V::Missing {
                return V::Missing;
            }
            let before = std::mem::replace(cx.memo(*memo), now.clone().into_owned());
            match before {
                V::Missing => V::Bool(false),
                b => V::Bool(b != now),
            }
        }
        Node::Prev {
            memo,
            inner,
            default,
        } => {
            let now = eval(inner, cx);
            if now == V::Missing {
                return V::Missing;
            }
            match std::mem::replace(cx.memo(*memo), now.into_owned()) {
                V::Missing => match default {
                    Some(d) => eval(d, cx).into_owned(),
                    None => V::Missing,
                },
                before => before,
            }
        }
        Node::Abs(inner) => match eval(inner, cx) {
            V::Int(i) => V::Int(i.saturating_abs()),
            V::Float(f) => V::Float(f.abs()),
            _ => V::Missing,
        },
        Node::Cos(inner) => match eval(inner, cx) {
            V::Int(i) => V::Float((i as f64).cos()),
            V::Float(f) => V::Float(f.cos()),
            _ => V::Missing,
        },
        Node::Name { inner, names } => match eval(inner, cx) {
            V::Int(i) => V::Str(match names.get(&i) {
                Some(name) => Cow::Borrowed(name.as_str()),
                None => Cow::Owned(i.to_string()),
            }),
            V::Str(s) => V::Str(Cow::Owned(s.into_owned())),
            _ => V::Missing,
        },
        Node::Unary(op, inner) => {
            let v = eval(inner, cx);
            match op {
                UnOp::Not => v.truth().map(|b| V::Bool(!b)).unwrap_or(V::Missing),
                UnOp::Neg => match v {
                    V::Int(i) => i.checked_neg().map(V::Int).unwrap_or(V::Missing),
                    V::Float(f) => V::Float(-f),
                    _ => V::Missing,
                },
                UnOp::BitNot => v.int().map(|i| V::Int(!i)).unwrap_or(V::Missing),
            }
        }
        Node::Binary(BinOp::Or, a, b) => match eval(a, cx).truth() {
            Some(true) => V::Bool(true),
            left => match (left, eval(b, cx).truth()) {
                (_, Some(true)) => V::Bool(true),
                (Some(false), Some(false)) => V::Bool(false),
                _ => V::Missing,
            },
        },
        Node::Binary(BinOp::And, a, b) => match eval(a, cx).truth() {
            Some(false) => V::Bool(false),
            left => match (left, eval(b, cx).truth()) {
                (_, Some(false)) => V::Bool(false),
                (Some(true), Some(true)) => V::Bool(true),
                _ => V::Missing,
            },
        },
        Node::Binary(op, a, b) => {
            let x = eval(a, cx);
            let y = eval(b, cx);
            if x == V::Missing || y == V::Missing {
                return V::Missing;
            }
            match op {
                BinOp::Eq | BinOp::Ne | BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge => {
                    compare(*op, &x, &y)
                }
                BinOp::BitAnd | BinOp::BitOr | BinOp::BitXor => bits(*op, &x, &y),
                _ => arith(*op, &x, &y),
            }
        }
        Node::Match { text, regex } => match eval(text, cx) {
            V::Str(s) => V::Bool(cx.regex(*regex).is_match(&s)),
            V::Missing => V::Missing,
            _ => V::Bool(false),
        },
    }
}

/// The named captures of the regexes an expression matches, as parameters
/// (evaluated again when the rule fires; integers become `Int`).
pub fn captures<C: Context>(node: &Node, cx: &mut C, out: &mut nets::Params) {
    match node {
        Node::Match { text, regex } => {
            if let V::Str(s) = eval(text, cx) {
                let re = cx.regex(*regex);
                if let Some(caps) = re.captures(&s) {
                    for name in re.capture_names().flatten() {
                        if let Some(m) = caps.name(name) {
                            let v = m
                                .as_str()
                                .parse::<i64>()
                                .map(nets::Value::Int)
                                .unwrap_or_else(|_| nets::Value::Str(m.as_str().to_owned()));
                            out.insert(name.to_owned(), v);
                        }
                    }
                }
            }
        }
        Node::Binary(_, a, b) => {
            captures(a, cx, out);
            captures(b, cx, out);
        }
        Node::Unary(_, a) | Node::Abs(a) | Node::Cos(a) | Node::Name { inner: a, .. } => {
            captures(a, cx, out)
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One message `M` (slot 0) with fields a, b, s, l; constants ONE, FOUR.
    #[derive(Default)]
    struct Mock {
        regexes: Vec<Regex>,
        memos: Vec<V<'static>>,
        values: Vec<V<'static>>,
        list: Vec<i64>,
        age: f64,
    }

    impl Resolver for Mock {
        fn field(&mut self, message: &str, field: &str) -> Result<(usize, usize), String> {
            if message != "M" && message != "HEARTBEAT" {
                return Err(format!("unknown message `{message}`"));
            }
            ["a", "b", "s", "l", "custom_mode"]
                .iter()
                .position(|f| *f == field)
                .map(|i| (0, i))
                .ok_or_else(|| format!("no field `{field}`"))
        }
        fn timed_message(&mut self, message: &str) -> Result<usize, String> {
            self.field(message, "a").map(|(s, _)| s)
        }
        fn constant(&self, name: &str) -> Option<i64> {
            match name {
                "ONE" => Some(1),
                "FOUR" => Some(4),
                _ => None,
            }
        }
        fn regex(&mut self, regex: Regex) -> usize {
            self.regexes.push(regex);
            self.regexes.len() - 1
        }
        fn memo(&mut self) -> usize {
            self.memos.push(V::Missing);
            self.memos.len() - 1
        }
    }

    impl Context for Mock {
        fn field(&self, _slot: usize, field: usize, index: Option<usize>) -> V<'_> {
            match (field, index) {
                (3, Some(i)) => self.list.get(i).map(|x| V::Int(*x)).unwrap_or(V::Missing),
                (f, None) => self.values.get(f).cloned().unwrap_or(V::Missing),
                _ => V::Missing,
            }
        }
        fn age(&self, _slot: usize) -> f64 {
            self.age
        }
        fn seen(&self, _slot: usize) -> bool {
            self.age < 1e9
        }
        fn call(&self, func: Func) -> V<'static> {
            match func {
                Func::Mode => V::Str("LOITER".into()),
                Func::Firmware => V::Str("copter".into()),
                Func::Loss => V::Float(12.5),
                Func::SysId => V::Int(1),
                Func::CompId => V::Int(1),
            }
        }
        fn regex(&self, regex: usize) -> &Regex {
            &self.regexes[regex]
        }
        fn memo(&mut self, memo: usize) -> &mut V<'static> {
            &mut self.memos[memo]
        }
    }

    fn mock(a: V<'static>, b: V<'static>, s: &str) -> Mock {
        Mock {
            values: vec![a, b, V::Str(s.to_owned().into())],
            list: vec![10, 0, 30],
            age: 2.0,
            ..Mock::default()
        }
    }

    fn run(src: &str, m: &mut Mock) -> V<'static> {
        let c = compile(src, m).unwrap_or_else(|e| panic!("{src}: {e:?}"));
        eval(&c.node, m).into_owned()
    }

    #[test]
    fn arithmetic_and_precedence() {
        let mut m = mock(V::Int(7), V::Float(2.5), "x");
        assert_eq!(run("1 + 2 * 3", &mut m), V::Int(7));
        assert_eq!(run("(1 + 2) * 3", &mut m), V::Int(9));
        assert_eq!(run("M.a - 10", &mut m), V::Int(-3));
        assert_eq!(run("M.a / 2", &mut m), V::Float(3.5));
        assert_eq!(run("M.a % 4", &mut m), V::Int(3));
        assert_eq!(run("M.b * 2", &mut m), V::Float(5.0));
        assert_eq!(run("-M.a", &mut m), V::Int(-7));
        assert_eq!(run("M.a / 0", &mut m), V::Missing);
        assert_eq!(run("0x10 + 1", &mut m), V::Int(17));
        assert_eq!(run("abs(-3)", &mut m), V::Int(3));
        assert_eq!(run("cos(0)", &mut m), V::Float(1.0));
        assert_eq!(run("cos(M.b - M.b)", &mut m), V::Float(1.0));
        assert!(
            matches!(run("cos(3.14159265 / 3)", &mut m), V::Float(c) if (c - 0.5).abs() < 1e-6)
        );
        assert_eq!(run("cos(\"x\")", &mut m), V::Missing);
        assert_eq!(run("cos(M.a / 0)", &mut m), V::Missing);
    }

    #[test]
    fn comparisons_and_logic() {
        let mut m = mock(V::Int(7), V::Float(2.5), "hello");
        assert_eq!(run("M.a > 5 && M.b < 3", &mut m), V::Bool(true));
        assert_eq!(run("M.a >= 8 or M.b <= 2.5", &mut m), V::Bool(true));
        assert_eq!(run("M.a == 7 and not (M.b != 2.5)", &mut m), V::Bool(true));
        assert_eq!(run("!(M.a == 7)", &mut m), V::Bool(false));
        assert_eq!(run("M.s == \"hello\"", &mut m), V::Bool(true));
        assert_eq!(run("M.s == 3", &mut m), V::Bool(false));
        assert_eq!(run("M.a == 7.0", &mut m), V::Bool(true));
    }

    #[test]
    fn bits_with_constant_names() {
        let mut m = mock(V::Int(0b101), V::Int(0), "");
        assert_eq!(run("M.a & FOUR", &mut m), V::Int(4));
        assert_eq!(run("(M.a & FOUR) != 0", &mut m), V::Bool(true));
        assert_eq!(run("M.a & 2", &mut m), V::Int(0));
        assert_eq!(run("M.a | 2", &mut m), V::Int(7));
        assert_eq!(run("M.a ^ ONE", &mut m), V::Int(4));
        assert_eq!(run("~M.a & 7", &mut m), V::Int(2));
    }

    #[test]
    fn missing_values_propagate_but_logic_can_decide() {
        let mut m = mock(V::Missing, V::Int(1), "");
        assert_eq!(run("M.a > 3", &mut m), V::Missing);
        assert_eq!(run("M.a > 3 || M.b == 1", &mut m), V::Bool(true));
        assert_eq!(run("M.a > 3 && M.b == 0", &mut m), V::Bool(false));
        assert_eq!(run("M.a > 3 && M.b == 1", &mut m), V::Missing);
        assert_eq!(run("!(M.a > 3)", &mut m), V::Missing);
    }

    #[test]
    fn functions_arrays_and_regex_captures() {
        let mut m = mock(V::Int(1), V::Int(0), "Potential Thrust Loss (3)");
        assert_eq!(run("mode() == \"LOITER\"", &mut m), V::Bool(true));
        assert_eq!(run("firmware()", &mut m), V::Str("copter".into()));
        assert_eq!(run("age(M) > 1.5", &mut m), V::Bool(true));
        assert_eq!(run("seen(M)", &mut m), V::Bool(true));
        assert_eq!(run("loss() > 10", &mut m), V::Bool(true));
        assert_eq!(run("M.l[2] - M.l[0]", &mut m), V::Int(20));
        assert_eq!(run("M.l[9]", &mut m), V::Missing);
        let src = r#"M.s ~ "Thrust Loss \((?P<motor>\d+)\)""#;
        let c = compile(src, &mut m).expect("compiles");
        assert_eq!(eval(&c.node, &mut m), V::Bool(true));
        let mut params = nets::Params::new();
        captures(&c.node, &mut m, &mut params);
        assert_eq!(params.get("motor"), Some(&nets::Value::Int(3)));
    }

    #[test]
    fn changed_and_prev_remember_the_previous_evaluation() {
        let mut m = mock(V::Int(1), V::Int(0), "");
        let changed = compile("changed(M.a)", &mut m).expect("compiles");
        let prev = compile("prev(M.a)", &mut m).expect("compiles");
        let prev_or = compile("prev(M.a, 65535)", &mut m).expect("compiles");
        assert_eq!(eval(&changed.node, &mut m), V::Bool(false));
        assert_eq!(eval(&prev.node, &mut m), V::Missing);
        assert_eq!(eval(&prev_or.node, &mut m), V::Int(65535));
        assert_eq!(eval(&prev_or.node, &mut m), V::Int(1));
        m.values[0] = V::Int(2);
        assert_eq!(eval(&changed.node, &mut m), V::Bool(true));
        assert_eq!(eval(&prev.node, &mut m), V::Int(1));
        assert_eq!(eval(&changed.node, &mut m), V::Bool(false));
    }

    #[test]
    fn name_gives_an_enum_value_its_name() {
        let mut m = mock(V::Int(511), V::Int(2), "x");
        assert_eq!(
            run("name(M.a, MAV_CMD)", &mut m),
            V::Str("SET_MESSAGE_INTERVAL".into())
        );
        assert_eq!(
            run("name(M.b, MAV_RESULT)", &mut m),
            V::Str("DENIED".into())
        );
        assert_eq!(
            run("name(M.b, MAV_RESULT) == \"DENIED\"", &mut m),
            V::Bool(true)
        );
        // A value the enum does not name: its number, as text.
        assert_eq!(
            run("name(M.a + 40000, MAV_RESULT)", &mut m),
            V::Str("40511".into())
        );
        let mut m = mock(V::Missing, V::Int(2), "x");
        assert_eq!(run("name(M.a, MAV_CMD)", &mut m), V::Missing);
        let e = compile("name(M.a, NOT_AN_ENUM)", &mut m).expect_err("unknown enum");
        assert_eq!((e.offset, e.len), (10, 11));
        assert!(e.message.contains("unknown enum"), "{}", e.message);
        assert!(compile("name(M.a)", &mut m).is_err());
        assert!(compile("name(M.a, 3)", &mut m).is_err());
    }

    #[test]
    fn errors_point_at_the_culprit() {
        let mut m = Mock::default();
        let err = |src: &str, m: &mut Mock| compile(src, m).expect_err(src);
        let e = err("M.a > NOPE", &mut m);
        assert_eq!((e.offset, e.len), (6, 4));
        assert!(e.message.contains("unknown name `NOPE`"));
        let e = err("M.zz == 1", &mut m);
        assert_eq!(e.offset, 0);
        assert!(e.message.contains("no field"));
        let e = err("X.a == 1", &mut m);
        assert!(e.message.contains("unknown message"));
        assert_eq!(err("M.a = 1", &mut m).offset, 4);
        assert_eq!(err("(M.a", &mut m).offset, 4);
        assert_eq!(err("M.a ~ \"(\"", &mut m).offset, 6);
        assert_eq!(err("M.a > 1 2", &mut m).offset, 8);
        assert!(err("bogus(1)", &mut m).message.contains("unknown function"));
        assert!(err("\"open", &mut m).message.contains("unterminated"));
        assert!(err("M.a # 1", &mut m)
            .message
            .contains("unexpected character"));
    }
}
