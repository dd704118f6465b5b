//! Expressions: guards (`seq == 3 && remaining < 20`) and action arguments
//! (`{lat: $lat, alt: $alt + 10, mode: AUTO}`) of the nets, and — through
//! the same lexer, operator table and parser — the conditions of
//! elaboration's rules, which compile names to message slots
//! (`elaboration::expr`).
//!
//! - [`lex`]: the one lexer (names, `$parameters`, numbers, strings, symbols);
//! - [`ops`]: the one operator table (spellings and precedence);
//! - [`syntax`]: the one parser, to a [`syntax::Syntax`] tree;
//! - `lower`: that tree to an [`Expr`] of a guard or an argument;
//! - `eval`: an [`Expr`] against the triggering event's parameters.
//!
//! In a guard a bare name is a parameter of the triggering event (`$name`
//! works too); in an argument a bare word is a string (`mode: AUTO`) and
//! parameters are written `$name`. The syntax, loosest first (docs/nets.md,
//! "Expressions"):
//!
//! ```text
//! expr    := expr ("||" | "or") expr            left to right
//!          | expr ("&&" | "and") expr           left to right
//!          | ("!" | "not") expr                 its operand: a comparison or tighter
//!          | expr cmp expr                      cmp: == != < <= > >= ~, no chaining
//!          | expr "|" expr | expr "^" expr | expr "&" expr
//!          | expr ("+" | "-") expr | expr ("*" | "/" | "%") expr
//!          | ("-" | "~") expr                   its operand: a single atom
//!          | atom
//! atom    := number | string | true | false | $name | name | name "." name ("[" int "]")?
//!          | name "(" (expr ("," expr)*)? ")" | "(" expr ")"
//!          | "[" (expr ("," expr)*)? "]" | "{" (key (":" | "=") expr ("," …)*)? "}"
//! ```
//!
//! Fields, calls and `~` are elaboration's; a guard or an argument that
//! writes one is an error at its column.

use std::fmt;

use crate::value::Value;

mod eval;
pub mod lex;
mod lower;
pub mod ops;
pub mod syntax;

pub use eval::EvalError;
pub use ops::{BinOp, UnOp};

/// Where an expression's bare names point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Context {
    /// Bare names are event parameters.
    Guard,
    /// Bare names are strings; parameters are `$name`.
    Argument,
}

/// A parsed expression. Byte offsets are relative to the parsed text.
#[derive(Debug, Clone, PartialEq)]
pub enum Expr {
    Lit(Value),
    Param {
        name: String,
        at: usize,
    },
    Not(Box<Expr>),
    Neg(Box<Expr>),
    /// `~e`: every bit of an integer flipped.
    BitNot(Box<Expr>),
    Binary(BinOp, Box<Expr>, Box<Expr>),
    List(Vec<Expr>),
    Map(Vec<(String, Expr)>),
}

/// A syntax error at a byte span of the parsed text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SyntaxError {
    pub at: usize,
    /// The length of what it points at (at least 1).
    pub len: usize,
    pub message: String,
}

impl SyntaxError {
    pub fn new(at: usize, len: usize, message: impl Into<String>) -> Self {
        SyntaxError {
            at,
            len: len.max(1),
            message: message.into(),
        }
    }
}

impl Expr {
    /// Every parameter the expression reads, with its byte offset.
    pub fn params(&self, out: &mut Vec<(String, usize)>) {
        match self {
            Expr::Lit(_) => {}
            Expr::Param { name, at } => out.push((name.clone(), *at)),
            Expr::Not(e) | Expr::Neg(e) | Expr::BitNot(e) => e.params(out),
            Expr::Binary(_, a, b) => {
                a.params(out);
                b.params(out);
            }
            Expr::List(items) => items.iter().for_each(|e| e.params(out)),
            Expr::Map(items) => items.iter().for_each(|(_, e)| e.params(out)),
        }
    }
}

impl fmt::Display for Expr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Expr::Lit(v) => write!(f, "{v}"),
            Expr::Param { name, .. } => write!(f, "${name}"),
            Expr::Not(e) => write!(f, "!{e}"),
            Expr::Neg(e) => write!(f, "-{e}"),
            Expr::BitNot(e) => write!(f, "~{e}"),
            Expr::Binary(op, a, b) => write!(f, "({a} {} {b})", op.symbol()),
            Expr::List(items) => {
                f.write_str("[")?;
                for (i, e) in items.iter().enumerate() {
                    if i > 0 {
                        f.write_str(", ")?;
                    }
                    write!(f, "{e}")?;
                }
                f.write_str("]")
            }
            Expr::Map(items) => {
                f.write_str("{")?;
                for (i, (k, e)) in items.iter().enumerate() {
                    if i > 0 {
                        f.write_str(", ")?;
                    }
                    write!(f, "{k}: {e}")?;
                }
                f.write_str("}")
            }
        }
    }
}

/// Parses a whole expression.
pub fn parse(text: &str, context: Context) -> Result<Expr, SyntaxError> {
    lower::lower(syntax::parse(text)?, context)
}

/// Parses `{key: value, …}` at byte `at` of `text`, as action arguments;
/// returns the entries and the offset just past the `}`.
pub fn parse_map_at(
    text: &str,
    at: usize,
    context: Context,
) -> Result<(Vec<(String, Expr)>, usize), SyntaxError> {
    let (items, end) = syntax::parse_map_at(text, at)?;
    let items = items
        .into_iter()
        .map(|(k, v)| Ok((k, lower::lower(v, context)?)))
        .collect::<Result<_, SyntaxError>>()?;
    Ok((items, end))
}

#[cfg(test)]
mod tests;
