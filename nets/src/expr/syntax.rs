//! The one parser of Petrel's expressions: text to a [`Syntax`] tree, by the
//! precedence of [`super::ops`]. What a name, a field or a call means is the
//! reader's business: the nets lower a tree to an [`super::Expr`] (a bare
//! name is a parameter or a string), elaboration compiles it to message
//! slots and constants.

use super::lex::{self, Tok, Token};
use super::ops::{BinOp, Level, UnOp};
use super::SyntaxError;

/// How deep parentheses, operators and brackets may nest: deeper is an
/// error, never a stack overflow.
const MAX_DEPTH: usize = 128;

/// A name and the byte offset where it is written.
#[derive(Debug, Clone, PartialEq)]
pub struct Word {
    pub text: String,
    pub at: usize,
}

impl Word {
    pub fn len(&self) -> usize {
        self.text.len()
    }

    pub fn is_empty(&self) -> bool {
        self.text.is_empty()
    }
}

/// An expression as written, with the byte span of each part.
#[derive(Debug, Clone, PartialEq)]
pub struct Syntax {
    pub kind: Kind,
    pub at: usize,
    pub len: usize,
}

#[derive(Debug, Clone, PartialEq)]
pub enum Kind {
    Int(i64),
    Float(f64),
    Str(String),
    Bool(bool),
    /// A bare name.
    Name(String),
    /// `$name`.
    Param(String),
    /// `MESSAGE.field`, `MESSAGE.field[index]`.
    Field {
        message: Word,
        field: Word,
        index: Option<usize>,
    },
    /// `name(arg, …)`.
    Call {
        name: Word,
        args: Vec<Syntax>,
    },
    Unary(UnOp, Box<Syntax>),
    /// An operator, the offset of its spelling, and its operands.
    Binary {
        op: BinOp,
        op_at: usize,
        left: Box<Syntax>,
        right: Box<Syntax>,
    },
    /// `[a, b]`.
    List(Vec<Syntax>),
    /// `{key: value, …}` (also `key = value`, and `"key"`).
    Map(Vec<(String, Syntax)>),
}

/// Parses a whole expression.
pub fn parse(text: &str) -> Result<Syntax, SyntaxError> {
    let mut p = Parser::new(text, 0);
    let e = p.expr(Level::Or)?;
    let next = p.peek()?;
    if next.tok != Tok::End {
        return Err(p.error(&next, "expected an operator or the end of the expression"));
    }
    Ok(e)
}

/// Parses `{key: value, …}` starting at byte `at` of `text` (its brace
/// after spaces); returns the map and the offset just past its `}`.
pub fn parse_map_at(text: &str, at: usize) -> Result<(Vec<(String, Syntax)>, usize), SyntaxError> {
    let mut p = Parser::new(text, at);
    let open = p.next()?;
    if open.tok != Tok::Sym("{") {
        return Err(p.error(&open, "expected `{`"));
    }
    let items = p.map()?;
    Ok((items, p.pos))
}

struct Parser<'s> {
    text: &'s str,
    /// Where the next token is read from.
    pos: usize,
    depth: usize,
}

impl<'s> Parser<'s> {
    fn new(text: &'s str, pos: usize) -> Self {
        Parser {
            text,
            pos,
            depth: 0,
        }
    }

    fn peek(&self) -> Result<Token<'s>, SyntaxError> {
        lex::token(self.text, self.pos)
    }

    fn next(&mut self) -> Result<Token<'s>, SyntaxError> {
        let t = self.peek()?;
        self.pos = t.at + t.len;
        Ok(t)
    }

    fn error(&self, at: &Token, message: impl Into<String>) -> SyntaxError {
        SyntaxError::new(at.at, at.len.max(1), message)
    }

    /// Consumes the symbol `sym` or fails with "expected `sym`".
    fn expect(&mut self, sym: &'static str) -> Result<Token<'s>, SyntaxError> {
        let t = self.peek()?;
        if t.tok != Tok::Sym(sym) {
            return Err(self.error(&t, format!("expected `{sym}`")));
        }
        self.next()
    }

    fn eat(&mut self, sym: &'static str) -> Result<bool, SyntaxError> {
        if self.peek()?.tok == Tok::Sym(sym) {
            self.next()?;
            return Ok(true);
        }
        Ok(false)
    }

    fn deeper(&mut self, at: &Token) -> Result<(), SyntaxError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(self.error(at, "the expression nests too deeply"));
        }
        Ok(())
    }

    /// An expression of operators of level `min` and tighter.
    fn expr(&mut self, min: Level) -> Result<Syntax, SyntaxError> {
        let first = self.peek()?;
        self.deeper(&first)?;
        let mut left = self.prefix()?;
        let mut compared = false;
        loop {
            let t = self.peek()?;
            let op = match &t.tok {
                Tok::Sym(s) | Tok::Name(s) => BinOp::spelled(s),
                _ => None,
            };
            let Some(op) = op else {
                if t.tok == Tok::Sym("=") {
                    return Err(self.error(&t, "`=` is not a comparison: write `==`"));
                }
                break;
            };
            if op.level() < min {
                break;
            }
            if op.level() == Level::Compare {
                if compared {
                    return Err(self.error(&t, "comparisons do not chain: use `&&`"));
                }
                compared = true;
            }
            self.next()?;
            let right = self.expr(op.level().tighter())?;
            let end = right.at + right.len;
            left = Syntax {
                at: left.at,
                len: end - left.at,
                kind: Kind::Binary {
                    op,
                    op_at: t.at,
                    left: Box::new(left),
                    right: Box::new(right),
                },
            };
        }
        self.depth -= 1;
        Ok(left)
    }

    /// A prefix operator and its operand, or a primary.
    fn prefix(&mut self) -> Result<Syntax, SyntaxError> {
        let t = self.peek()?;
        let op = match &t.tok {
            Tok::Sym(s) | Tok::Name(s) => UnOp::spelled(s),
            _ => None,
        };
        let Some(op) = op else {
            return self.primary();
        };
        self.next()?;
        let operand = self.expr(op.operand())?;
        let end = operand.at + operand.len;
        Ok(Syntax {
            at: t.at,
            len: end - t.at,
            kind: Kind::Unary(op, Box::new(operand)),
        })
    }

    fn primary(&mut self) -> Result<Syntax, SyntaxError> {
        let t = self.next()?;
        let at = t.at;
        let kind = match t.tok {
            Tok::Int(i) => Kind::Int(i),
            Tok::Float(f) => Kind::Float(f),
            Tok::Str(ref s) => Kind::Str(s.clone()),
            Tok::Param(name) => Kind::Param(name.to_owned()),
            Tok::Sym("(") => {
                let inner = self.expr(Level::Or)?;
                self.expect(")")?;
                return Ok(inner);
            }
            Tok::Sym("[") => Kind::List(self.list()?),
            Tok::Sym("{") => Kind::Map(self.map()?),
            Tok::Name(name) => {
                let word = Word {
                    text: name.to_owned(),
                    at,
                };
                if self.eat("(")? {
                    Kind::Call {
                        name: word,
                        args: self.args()?,
                    }
                } else if self.eat(".")? {
                    self.field(word)?
                } else {
                    match name {
                        "true" => Kind::Bool(true),
                        "false" => Kind::Bool(false),
                        _ => Kind::Name(word.text),
                    }
                }
            }
            Tok::Sym(_) | Tok::End => return Err(self.error(&t, "expected a value")),
        };
        Ok(Syntax {
            kind,
            at,
            len: self.pos - at,
        })
    }

    /// `.field` and `[index]` after a message name (its dot read).
    fn field(&mut self, message: Word) -> Result<Kind, SyntaxError> {
        let t = self.next()?;
        let Tok::Name(field) = t.tok else {
            return Err(self.error(&t, "expected a field name after `.`"));
        };
        let field = Word {
            text: field.to_owned(),
            at: t.at,
        };
        let index = if self.eat("[")? {
            let t = self.next()?;
            let Tok::Int(i) = t.tok else {
                return Err(self.error(&t, "expected an index"));
            };
            let i = usize::try_from(i).map_err(|_| self.error(&t, "bad index"))?;
            self.expect("]")?;
            Some(i)
        } else {
            None
        };
        Ok(Kind::Field {
            message,
            field,
            index,
        })
    }

    /// A call's arguments, its `(` read.
    fn args(&mut self) -> Result<Vec<Syntax>, SyntaxError> {
        let mut args = Vec::new();
        if self.eat(")")? {
            return Ok(args);
        }
        loop {
            args.push(self.expr(Level::Or)?);
            if self.eat(")")? {
                return Ok(args);
            }
            let t = self.peek()?;
            if t.tok != Tok::Sym(",") {
                return Err(self.error(&t, "expected `,` or `)`"));
            }
            self.next()?;
        }
    }

    /// A list's items, its `[` read.
    fn list(&mut self) -> Result<Vec<Syntax>, SyntaxError> {
        let mut items = Vec::new();
        if self.eat("]")? {
            return Ok(items);
        }
        loop {
            items.push(self.expr(Level::Or)?);
            if self.eat("]")? {
                return Ok(items);
            }
            let t = self.peek()?;
            if t.tok != Tok::Sym(",") {
                return Err(self.error(&t, "expected `,` or `]`"));
            }
            self.next()?;
        }
    }

    /// A map's entries, its `{` read.
    fn map(&mut self) -> Result<Vec<(String, Syntax)>, SyntaxError> {
        let mut items: Vec<(String, Syntax)> = Vec::new();
        if self.eat("}")? {
            return Ok(items);
        }
        loop {
            let t = self.next()?;
            let key = match t.tok {
                Tok::Name(name) => name.to_owned(),
                Tok::Str(ref s) => s.clone(),
                _ => return Err(self.error(&t, "expected a key name")),
            };
            if items.iter().any(|(k, _)| *k == key) {
                return Err(self.error(&t, format!("duplicate key `{key}`")));
            }
            if !(self.eat(":")? || self.eat("=")?) {
                let next = self.peek()?;
                return Err(self.error(&next, format!("expected `:` after `{key}`")));
            }
            let value = self.expr(Level::Or)?;
            items.push((key, value));
            if self.eat("}")? {
                return Ok(items);
            }
            let t = self.peek()?;
            if t.tok != Tok::Sym(",") {
                return Err(self.error(&t, "expected `,` or `}`"));
            }
            self.next()?;
        }
    }
}
