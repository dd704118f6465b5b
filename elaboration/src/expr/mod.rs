//! Rule conditions: compiled into a tree with resolved message slots, field
//! indices and constants, and evaluated.
//!
//! The text is read by the nets' lexer and parser ([`nets::expr::syntax`]),
//! with the operators and precedence of [`nets::expr::ops`] — one syntax for
//! guards and rules (docs/nets.md, "Expressions"). This module gives the
//! names their meaning ([`compile()`]): constants (`MAV_STATE_CRITICAL`),
//! fields (`SYS_STATUS.battery_remaining`, `ESC_TELEMETRY_1_TO_4.rpm[0]`),
//! calls (`age(HEARTBEAT)`, `seen(MSG)`, `mode()`, `firmware()`, `loss()`,
//! `changed(e)`, `prev(e)`, `prev(e, default)`, `abs(e)`, `cos(e)` (of
//! radians), `name(e, ENUM)`, `sysid()`, `compid()`) and `~` regex matches;
//! and evaluates the result ([`eval()`]: `/` gives a float, a value not known
//! yet propagates).

use std::borrow::Cow;
use std::collections::HashMap;

use regex::Regex;

pub use nets::expr::{BinOp, UnOp};

mod compile;
mod eval;

pub use compile::compile;
pub use eval::{captures, eval};

/// A problem in an expression, at a byte offset of its text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ExprError {
    pub offset: usize,
    pub len: usize,
    pub message: String,
}

impl From<nets::expr::SyntaxError> for ExprError {
    fn from(e: nets::expr::SyntaxError) -> Self {
        ExprError {
            offset: e.at,
            len: e.len,
            message: e.message,
        }
    }
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

#[cfg(test)]
mod tests;
