//! Evaluating a compiled expression.

use std::borrow::Cow;

use super::{BinOp, Context, Node, UnOp, V};

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
