//! Expressions: guards (`seq == 3 && remaining < 20`) and action arguments
//! (`{lat: $lat, alt: $alt + 10, mode: AUTO}`).
//!
//! One grammar serves both. In a guard a bare name is a parameter of the
//! triggering event (`$name` works too); in an argument a bare word is a
//! string (`mode: AUTO`) and parameters are written `$name`.
//!
//! ```text
//! expr    := or
//! or      := and (("||" | "or") and)*
//! and     := not (("&&" | "and") not)*
//! not     := ("!" | "not") not | cmp
//! cmp     := sum (("==" | "!=" | "<" | "<=" | ">" | ">=") sum)?
//! sum     := product (("+" | "-") product)*
//! product := unary (("*" | "/" | "%") unary)*
//! unary   := "-" unary | atom
//! atom    := number | string | true | false | $name | name | "(" expr ")"
//!          | "[" (expr ("," expr)*)? "]" | "{" (key ":" expr ("," key ":" expr)*)? "}"
//! ```

use std::fmt;

use crate::value::{Params, Value};

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
    Param { name: String, at: usize },
    Not(Box<Expr>),
    Neg(Box<Expr>),
    Binary(BinOp, Box<Expr>, Box<Expr>),
    List(Vec<Expr>),
    Map(Vec<(String, Expr)>),
}

/// Binary operators.
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
    Add,
    Sub,
    Mul,
    Div,
    Rem,
}

impl BinOp {
    fn symbol(self) -> &'static str {
        match self {
            BinOp::Or => "||",
            BinOp::And => "&&",
            BinOp::Eq => "==",
            BinOp::Ne => "!=",
            BinOp::Lt => "<",
            BinOp::Le => "<=",
            BinOp::Gt => ">",
            BinOp::Ge => ">=",
            BinOp::Add => "+",
            BinOp::Sub => "-",
            BinOp::Mul => "*",
            BinOp::Div => "/",
            BinOp::Rem => "%",
        }
    }
}

/// A syntax error at a byte offset of the parsed text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SyntaxError {
    pub at: usize,
    pub message: String,
}

/// Why an expression could not be evaluated.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EvalError {
    #[error("the event has no parameter `{0}`")]
    MissingParam(String),
    #[error("cannot apply `{op}` to {left} and {right}")]
    Types {
        op: &'static str,
        left: &'static str,
        right: &'static str,
    },
    #[error("cannot apply `{op}` to {operand}")]
    Unary {
        op: &'static str,
        operand: &'static str,
    },
    #[error("division by zero")]
    DivisionByZero,
    #[error("integer overflow")]
    Overflow,
    /// A float that is infinite or NaN, computed (`1e300 * 1e300`) or read
    /// from a parameter: it must never reach a program or the vehicle.
    #[error("{0} is not a finite number")]
    NotFinite(String),
}

impl Expr {
    /// Every parameter the expression reads, with its byte offset.
    pub fn params(&self, out: &mut Vec<(String, usize)>) {
        match self {
            Expr::Lit(_) => {}
            Expr::Param { name, at } => out.push((name.clone(), *at)),
            Expr::Not(e) | Expr::Neg(e) => e.params(out),
            Expr::Binary(_, a, b) => {
                a.params(out);
                b.params(out);
            }
            Expr::List(items) => items.iter().for_each(|e| e.params(out)),
            Expr::Map(items) => items.iter().for_each(|(_, e)| e.params(out)),
        }
    }

    /// Evaluates against the triggering event's parameters.
    pub fn eval(&self, params: &Params) -> Result<Value, EvalError> {
        Ok(match self {
            Expr::Lit(v) => v.clone(),
            Expr::Param { name, .. } => {
                let value = params
                    .get(name)
                    .ok_or_else(|| EvalError::MissingParam(name.clone()))?;
                if !value.is_finite() {
                    return Err(EvalError::NotFinite(format!("parameter `{name}`")));
                }
                value.clone()
            }
            Expr::Not(e) => Value::Bool(!e.eval(params)?.truthy()),
            Expr::Neg(e) => match e.eval(params)? {
                Value::Int(i) => Value::Int(i.checked_neg().ok_or(EvalError::Overflow)?),
                Value::Float(f) => Value::Float(-f),
                other => {
                    return Err(EvalError::Unary {
                        op: "-",
                        operand: other.type_name(),
                    })
                }
            },
            Expr::Binary(BinOp::Or, a, b) => {
                Value::Bool(a.eval(params)?.truthy() || b.eval(params)?.truthy())
            }
            Expr::Binary(BinOp::And, a, b) => {
                Value::Bool(a.eval(params)?.truthy() && b.eval(params)?.truthy())
            }
            Expr::Binary(op, a, b) => binary(*op, &a.eval(params)?, &b.eval(params)?)?,
            Expr::List(items) => Value::List(
                items
                    .iter()
                    .map(|e| e.eval(params))
                    .collect::<Result<_, _>>()?,
            ),
            Expr::Map(items) => Value::Map(
                items
                    .iter()
                    .map(|(k, e)| Ok((k.clone(), e.eval(params)?)))
                    .collect::<Result<_, _>>()?,
            ),
        })
    }

    /// Evaluates a guard: its truthiness.
    pub fn holds(&self, params: &Params) -> Result<bool, EvalError> {
        Ok(self.eval(params)?.truthy())
    }
}

fn binary(op: BinOp, a: &Value, b: &Value) -> Result<Value, EvalError> {
    use std::cmp::Ordering;
    let types = || EvalError::Types {
        op: op.symbol(),
        left: a.type_name(),
        right: b.type_name(),
    };
    let order: Option<Ordering> = match (a, b) {
        (Value::Int(x), Value::Int(y)) => Some(x.cmp(y)),
        (Value::Int(_) | Value::Float(_), Value::Int(_) | Value::Float(_)) => a
            .as_f64()
            .zip(b.as_f64())
            .and_then(|(x, y)| x.partial_cmp(&y)),
        (Value::Str(x), Value::Str(y)) => Some(x.cmp(y)),
        (Value::Bool(x), Value::Bool(y)) => Some(x.cmp(y)),
        _ => None,
    };
    match op {
        BinOp::Eq => {
            return Ok(Value::Bool(
                order == Some(Ordering::Equal)
                    || (order.is_none() && a == b && !matches!(a, Value::Float(_))),
            ))
        }
        BinOp::Ne => {
            return Ok(Value::Bool(
                !(order == Some(Ordering::Equal)
                    || (order.is_none() && a == b && !matches!(a, Value::Float(_)))),
            ))
        }
        BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge => {
            if matches!(
                (a, b),
                (Value::List(_) | Value::Map(_), _) | (_, Value::List(_) | Value::Map(_))
            ) || (order.is_none()
                && !matches!(
                    (a, b),
                    (
                        Value::Int(_) | Value::Float(_),
                        Value::Int(_) | Value::Float(_)
                    )
                ))
            {
                return Err(types());
            }
            // NaN compares false with everything.
            let Some(o) = order else {
                return Ok(Value::Bool(false));
            };
            return Ok(Value::Bool(match op {
                BinOp::Lt => o == Ordering::Less,
                BinOp::Le => o != Ordering::Greater,
                BinOp::Gt => o == Ordering::Greater,
                _ => o != Ordering::Less,
            }));
        }
        _ => {}
    }
    match (a, b) {
        (Value::Int(x), Value::Int(y)) => {
            let r = match op {
                BinOp::Add => x.checked_add(*y),
                BinOp::Sub => x.checked_sub(*y),
                BinOp::Mul => x.checked_mul(*y),
                BinOp::Div | BinOp::Rem if *y == 0 => return Err(EvalError::DivisionByZero),
                BinOp::Div => x.checked_div(*y),
                BinOp::Rem => x.checked_rem(*y),
                _ => return Err(types()),
            };
            r.map(Value::Int).ok_or(EvalError::Overflow)
        }
        (Value::Int(_) | Value::Float(_), Value::Int(_) | Value::Float(_)) => {
            let (x, y) = (a.as_f64().unwrap_or(0.0), b.as_f64().unwrap_or(0.0));
            let r = match op {
                BinOp::Add => x + y,
                BinOp::Sub => x - y,
                BinOp::Mul => x * y,
                BinOp::Div if y == 0.0 => return Err(EvalError::DivisionByZero),
                BinOp::Div => x / y,
                BinOp::Rem if y == 0.0 => return Err(EvalError::DivisionByZero),
                BinOp::Rem => x % y,
                _ => return Err(types()),
            };
            if !r.is_finite() {
                return Err(EvalError::NotFinite(format!(
                    "the result of `{x:?} {} {y:?}`",
                    op.symbol()
                )));
            }
            Ok(Value::Float(r))
        }
        (Value::Str(x), Value::Str(y)) if op == BinOp::Add => Ok(Value::Str(format!("{x}{y}"))),
        _ => Err(types()),
    }
}

impl fmt::Display for Expr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Expr::Lit(v) => write!(f, "{v}"),
            Expr::Param { name, .. } => write!(f, "${name}"),
            Expr::Not(e) => write!(f, "!{e}"),
            Expr::Neg(e) => write!(f, "-{e}"),
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
    let mut p = Parser::new(text, context);
    let e = p.expr()?;
    p.skip_ws();
    if p.pos < text.len() {
        return Err(p.error("unexpected text after the expression"));
    }
    Ok(e)
}

/// A cursor over text, shared with the action parser.
pub struct Parser<'a> {
    pub text: &'a str,
    pub pos: usize,
    context: Context,
}

fn is_name_start(c: char) -> bool {
    c.is_ascii_alphabetic() || c == '_'
}

fn is_name_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

impl<'a> Parser<'a> {
    pub fn new(text: &'a str, context: Context) -> Self {
        Parser {
            text,
            pos: 0,
            context,
        }
    }

    pub fn error(&self, message: impl Into<String>) -> SyntaxError {
        SyntaxError {
            at: self.pos,
            message: message.into(),
        }
    }

    fn rest(&self) -> &'a str {
        &self.text[self.pos..]
    }

    pub fn skip_ws(&mut self) {
        let rest = self.rest();
        self.pos += rest.len() - rest.trim_start().len();
    }

    pub fn at_end(&mut self) -> bool {
        self.skip_ws();
        self.pos >= self.text.len()
    }

    /// Consumes `token` (after spaces) if it comes next.
    pub fn eat(&mut self, token: &str) -> bool {
        self.skip_ws();
        if self.rest().starts_with(token) {
            // A word token must not be the prefix of a longer name.
            if token.chars().all(is_name_char)
                && self.rest()[token.len()..].starts_with(is_name_char)
            {
                return false;
            }
            self.pos += token.len();
            true
        } else {
            false
        }
    }

    /// Reads a name: a letter or `_`, then letters, digits and `_`.
    pub fn name(&mut self) -> Option<(String, usize)> {
        self.skip_ws();
        let start = self.pos;
        let rest = self.rest();
        if !rest.starts_with(is_name_start) {
            return None;
        }
        let len = rest.find(|c: char| !is_name_char(c)).unwrap_or(rest.len());
        self.pos += len;
        Some((rest[..len].to_owned(), start))
    }

    /// Reads a run of characters that are not spaces nor any of `stops`.
    pub fn word(&mut self, stops: &[char]) -> Option<(String, usize)> {
        self.skip_ws();
        let start = self.pos;
        let rest = self.rest();
        let len = rest
            .find(|c: char| c.is_whitespace() || stops.contains(&c))
            .unwrap_or(rest.len());
        if len == 0 {
            return None;
        }
        self.pos += len;
        Some((rest[..len].to_owned(), start))
    }

    pub fn expr(&mut self) -> Result<Expr, SyntaxError> {
        let mut left = self.and()?;
        while self.eat("||") || self.eat("or") {
            let right = self.and()?;
            left = Expr::Binary(BinOp::Or, Box::new(left), Box::new(right));
        }
        Ok(left)
    }

    fn and(&mut self) -> Result<Expr, SyntaxError> {
        let mut left = self.not()?;
        while self.eat("&&") || self.eat("and") {
            let right = self.not()?;
            left = Expr::Binary(BinOp::And, Box::new(left), Box::new(right));
        }
        Ok(left)
    }

    fn not(&mut self) -> Result<Expr, SyntaxError> {
        self.skip_ws();
        if (self.rest().starts_with('!') && !self.rest().starts_with("!=")) || self.eat("not") {
            if self.rest().starts_with('!') {
                self.pos += 1;
            }
            return Ok(Expr::Not(Box::new(self.not()?)));
        }
        self.cmp()
    }

    fn cmp(&mut self) -> Result<Expr, SyntaxError> {
        let left = self.sum()?;
        self.skip_ws();
        let op = [
            ("==", BinOp::Eq),
            ("!=", BinOp::Ne),
            ("<=", BinOp::Le),
            (">=", BinOp::Ge),
            ("<", BinOp::Lt),
            (">", BinOp::Gt),
        ]
        .into_iter()
        .find(|(t, _)| self.rest().starts_with(t));
        let Some((token, op)) = op else {
            if self.rest().starts_with('=') {
                return Err(self.error("`=` is not a comparison: write `==`"));
            }
            return Ok(left);
        };
        self.pos += token.len();
        let right = self.sum()?;
        self.skip_ws();
        if ["==", "!=", "<", ">"]
            .iter()
            .any(|t| self.rest().starts_with(t))
        {
            return Err(self.error("comparisons do not chain: use `&&`"));
        }
        Ok(Expr::Binary(op, Box::new(left), Box::new(right)))
    }

    fn sum(&mut self) -> Result<Expr, SyntaxError> {
        let mut left = self.product()?;
        loop {
            let op = if self.eat("+") {
                BinOp::Add
            } else if self.eat("-") {
                BinOp::Sub
            } else {
                return Ok(left);
            };
            let right = self.product()?;
            left = Expr::Binary(op, Box::new(left), Box::new(right));
        }
    }

    fn product(&mut self) -> Result<Expr, SyntaxError> {
        let mut left = self.unary()?;
        loop {
            let op = if self.eat("*") {
                BinOp::Mul
            } else if self.eat("/") {
                BinOp::Div
            } else if self.eat("%") {
                BinOp::Rem
            } else {
                return Ok(left);
            };
            let right = self.unary()?;
            left = Expr::Binary(op, Box::new(left), Box::new(right));
        }
    }

    fn unary(&mut self) -> Result<Expr, SyntaxError> {
        if self.eat("-") {
            let inner = self.unary()?;
            return Ok(match inner {
                Expr::Lit(Value::Int(i)) => Expr::Lit(Value::Int(-i)),
                Expr::Lit(Value::Float(f)) => Expr::Lit(Value::Float(-f)),
                e => Expr::Neg(Box::new(e)),
            });
        }
        self.atom()
    }

    fn atom(&mut self) -> Result<Expr, SyntaxError> {
        self.skip_ws();
        let start = self.pos;
        let Some(c) = self.rest().chars().next() else {
            return Err(self.error("expected a value"));
        };
        match c {
            '(' => {
                self.pos += 1;
                let e = self.expr()?;
                if !self.eat(")") {
                    return Err(self.error("expected `)`"));
                }
                Ok(e)
            }
            '[' => {
                self.pos += 1;
                let mut items = Vec::new();
                if !self.eat("]") {
                    loop {
                        items.push(self.expr()?);
                        if self.eat("]") {
                            break;
                        }
                        if !self.eat(",") {
                            return Err(self.error("expected `,` or `]`"));
                        }
                    }
                }
                Ok(Expr::List(items))
            }
            '{' => self.map().map(Expr::Map),
            '"' => self.string().map(|s| Expr::Lit(Value::Str(s))),
            '$' => {
                self.pos += 1;
                match self.name() {
                    Some((name, _)) if self.pos == start + 1 + name.len() => {
                        Ok(Expr::Param { name, at: start })
                    }
                    _ => Err(SyntaxError {
                        at: start,
                        message: "expected a parameter name after `$`".into(),
                    }),
                }
            }
            c if c.is_ascii_digit() => self.number(),
            c if is_name_start(c) => {
                let (name, at) = self.name().ok_or_else(|| self.error("expected a name"))?;
                Ok(match name.as_str() {
                    "true" => Expr::Lit(Value::Bool(true)),
                    "false" => Expr::Lit(Value::Bool(false)),
                    _ => match self.context {
                        Context::Guard => Expr::Param { name, at },
                        Context::Argument => Expr::Lit(Value::Str(name)),
                    },
                })
            }
            _ => Err(self.error(format!("unexpected `{c}`"))),
        }
    }

    /// Parses `{key: expr, ...}`; the opening brace is next.
    pub fn map(&mut self) -> Result<Vec<(String, Expr)>, SyntaxError> {
        if !self.eat("{") {
            return Err(self.error("expected `{`"));
        }
        let mut items: Vec<(String, Expr)> = Vec::new();
        if self.eat("}") {
            return Ok(items);
        }
        loop {
            self.skip_ws();
            let key_at = self.pos;
            let key = if self.rest().starts_with('"') {
                self.string()?
            } else {
                self.name()
                    .ok_or_else(|| self.error("expected a key name"))?
                    .0
            };
            if items.iter().any(|(k, _)| *k == key) {
                return Err(SyntaxError {
                    at: key_at,
                    message: format!("duplicate key `{key}`"),
                });
            }
            if !(self.eat(":") || self.eat("=")) {
                return Err(self.error(format!("expected `:` after `{key}`")));
            }
            let value = self.expr()?;
            items.push((key, value));
            if self.eat("}") {
                return Ok(items);
            }
            if !self.eat(",") {
                return Err(self.error("expected `,` or `}`"));
            }
        }
    }

    /// Parses a quoted string; the opening quote is next.
    pub fn string(&mut self) -> Result<String, SyntaxError> {
        let start = self.pos;
        self.pos += 1; // opening quote
        let mut out = String::new();
        let mut chars = self.rest().char_indices();
        while let Some((i, c)) = chars.next() {
            match c {
                '"' => {
                    self.pos += i + 1;
                    return Ok(out);
                }
                '\\' => match chars.next() {
                    Some((_, 'n')) => out.push('\n'),
                    Some((_, 't')) => out.push('\t'),
                    Some((_, c @ ('"' | '\\'))) => out.push(c),
                    _ => {
                        return Err(SyntaxError {
                            at: self.pos + i,
                            message: "unknown escape in string".into(),
                        })
                    }
                },
                c => out.push(c),
            }
        }
        Err(SyntaxError {
            at: start,
            message: "unterminated string".into(),
        })
    }

    fn number(&mut self) -> Result<Expr, SyntaxError> {
        let start = self.pos;
        let rest = self.rest();
        let mut len = rest
            .find(|c: char| !(c.is_ascii_digit() || c == '_'))
            .unwrap_or(rest.len());
        let mut float = false;
        if rest[len..].starts_with('.') && rest[len + 1..].starts_with(|c: char| c.is_ascii_digit())
        {
            float = true;
            len += 1;
            len += rest[len..]
                .find(|c: char| !(c.is_ascii_digit() || c == '_'))
                .unwrap_or(rest.len() - len);
        }
        if rest[len..].starts_with(['e', 'E']) {
            let exp = &rest[len + 1..];
            let sign = usize::from(exp.starts_with(['+', '-']));
            let digits = exp[sign..]
                .find(|c: char| !c.is_ascii_digit())
                .unwrap_or(exp.len() - sign);
            if digits > 0 {
                float = true;
                len += 1 + sign + digits;
            }
        }
        let text: String = rest[..len].chars().filter(|c| *c != '_').collect();
        self.pos += len;
        if self.rest().starts_with(is_name_char) {
            return Err(SyntaxError {
                at: start,
                message: format!("malformed number `{}`", &self.text[start..self.pos + 1]),
            });
        }
        let bad = || SyntaxError {
            at: start,
            message: format!("malformed number `{}`", &rest[..len]),
        };
        if float {
            match text.parse::<f64>() {
                Ok(f) if f.is_finite() => Ok(Expr::Lit(Value::Float(f))),
                Ok(_) => Err(SyntaxError {
                    at: start,
                    message: format!("number `{}` is too large for a float", &rest[..len]),
                }),
                Err(_) => Err(bad()),
            }
        } else {
            text.parse()
                .map(|i| Expr::Lit(Value::Int(i)))
                .map_err(|_| bad())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn guard(text: &str, params: &[(&str, Value)]) -> Result<bool, EvalError> {
        let params: Params = params
            .iter()
            .map(|(k, v)| (k.to_string(), v.clone()))
            .collect();
        parse(text, Context::Guard).expect("parses").holds(&params)
    }

    #[test]
    fn comparisons_and_logic() {
        assert_eq!(guard("seq == 3", &[("seq", Value::Int(3))]), Ok(true));
        assert_eq!(guard("seq == 3", &[("seq", Value::Int(4))]), Ok(false));
        assert_eq!(
            guard("remaining < 20", &[("remaining", Value::Int(19))]),
            Ok(true)
        );
        assert_eq!(
            guard("remaining < 20", &[("remaining", Value::Float(20.0))]),
            Ok(false)
        );
        assert_eq!(
            guard("$remaining <= 20.0", &[("remaining", Value::Int(20))]),
            Ok(true)
        );
        assert_eq!(
            guard(
                "a > 1 && (b == \"x\" || !c)",
                &[("a", 2.into()), ("b", "y".into()), ("c", false.into())]
            ),
            Ok(true)
        );
        assert_eq!(
            guard("not a and b", &[("a", false.into()), ("b", true.into())]),
            Ok(true)
        );
        assert_eq!(guard("a + 2 * 3 == 7", &[("a", 1.into())]), Ok(true));
        assert_eq!(guard("a % 2 != 0", &[("a", 7.into())]), Ok(true));
        assert_eq!(guard("-a < 0", &[("a", 1.5.into())]), Ok(true));
        assert_eq!(
            guard("mode == \"AUTO\"", &[("mode", "AUTO".into())]),
            Ok(true)
        );
    }

    #[test]
    fn evaluation_errors_are_values_not_panics() {
        assert_eq!(
            guard("x > 1", &[]),
            Err(EvalError::MissingParam("x".into()))
        );
        assert!(matches!(
            guard("x > 1", &[("x", "a".into())]),
            Err(EvalError::Types { .. })
        ));
        assert_eq!(
            guard("x / 0 == 1", &[("x", 1.into())]),
            Err(EvalError::DivisionByZero)
        );
        assert_eq!(
            guard("x + 1 > 0", &[("x", i64::MAX.into())]),
            Err(EvalError::Overflow)
        );
        // Float overflow and non-finite parameters are errors, never inf
        // or NaN.
        assert!(matches!(
            guard("1e100 * 1e300 > 0", &[]),
            Err(EvalError::NotFinite(_))
        ));
        assert!(matches!(
            guard("x - x == 0", &[("x", Value::Float(f64::INFINITY))]),
            Err(EvalError::NotFinite(p)) if p == "parameter `x`"
        ));
        assert!(matches!(
            guard("x < 1", &[("x", Value::List(vec![Value::Float(f64::NAN)]))]),
            Err(EvalError::NotFinite(_))
        ));
        assert!(matches!(
            guard("-x * 2.0 < 0", &[("x", Value::Float(f64::MAX))]),
            Err(EvalError::NotFinite(_))
        ));
        // Equality between different types is false, not an error.
        assert_eq!(guard("x == 1", &[("x", "1".into())]), Ok(false));
        // Short-circuit: the missing parameter is never read.
        assert_eq!(guard("false && x", &[]), Ok(false));
    }

    #[test]
    fn arguments() {
        let e = parse(
            "{lat: $lat, alt: $alt + 10, mode: AUTO, items: [1, 2.5, \"w\"]}",
            Context::Argument,
        )
        .unwrap();
        let params: Params = [
            ("lat".to_string(), Value::Float(43.5)),
            ("alt".to_string(), Value::Int(90)),
        ]
        .into();
        let Value::Map(m) = e.eval(&params).unwrap() else {
            panic!("not a map")
        };
        assert_eq!(m["lat"], Value::Float(43.5));
        assert_eq!(m["alt"], Value::Int(100));
        assert_eq!(m["mode"], Value::Str("AUTO".into()));
        assert_eq!(
            m["items"],
            Value::List(vec![1.into(), 2.5.into(), "w".into()])
        );
        let mut read = Vec::new();
        e.params(&mut read);
        assert_eq!(read, vec![("lat".to_string(), 6), ("alt".to_string(), 17)]);
    }

    #[test]
    fn syntax_errors_have_positions() {
        let cases = [
            ("seq = 3", 4, "`=` is not a comparison: write `==`"),
            ("a < b < c", 6, "comparisons do not chain: use `&&`"),
            ("(a", 2, "expected `)`"),
            ("a &&", 4, "expected a value"),
            ("a # b", 2, "unexpected text after the expression"),
            ("\"abc", 0, "unterminated string"),
            ("$ x", 0, "expected a parameter name after `$`"),
            ("12ab", 0, "malformed number `12a`"),
            ("{a: 1, a: 2}", 7, "duplicate key `a`"),
        ];
        for (text, at, message) in cases {
            let e = parse(text, Context::Guard).expect_err(text);
            assert_eq!((e.at, e.message.as_str()), (at, message), "{text}");
        }
    }
}
