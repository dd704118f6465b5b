//! A [`Syntax`] tree to the [`Expr`] of a guard or an action argument: bare
//! names become parameters (guards) or strings (arguments); elaboration's
//! own forms (fields, calls, `~`) are errors at their column.

use super::syntax::{Kind, Syntax};
use super::{BinOp, Context, Expr, SyntaxError, UnOp};
use crate::value::Value;

pub(super) fn lower(syntax: Syntax, context: Context) -> Result<Expr, SyntaxError> {
    let Syntax { kind, at, len } = syntax;
    Ok(match kind {
        Kind::Int(i) => Expr::Lit(Value::Int(i)),
        Kind::Float(f) => Expr::Lit(Value::Float(f)),
        Kind::Str(s) => Expr::Lit(Value::Str(s)),
        Kind::Bool(b) => Expr::Lit(Value::Bool(b)),
        Kind::Param(name) => Expr::Param { name, at },
        Kind::Name(name) => match context {
            Context::Guard => Expr::Param { name, at },
            Context::Argument => Expr::Lit(Value::Str(name)),
        },
        Kind::Unary(op, operand) => {
            let operand = lower(*operand, context)?;
            match (op, operand) {
                (UnOp::Not, e) => Expr::Not(Box::new(e)),
                // `-3` is a literal.
                (UnOp::Neg, Expr::Lit(Value::Int(i))) => Expr::Lit(Value::Int(-i)),
                (UnOp::Neg, Expr::Lit(Value::Float(f))) => Expr::Lit(Value::Float(-f)),
                (UnOp::Neg, e) => Expr::Neg(Box::new(e)),
                (UnOp::BitNot, e) => Expr::BitNot(Box::new(e)),
            }
        }
        Kind::Binary {
            op: BinOp::Match,
            op_at,
            ..
        } => {
            return Err(SyntaxError::new(
                op_at,
                1,
                "`~` (a regular expression match) is for elaboration rules: compare with `==`",
            ))
        }
        Kind::Binary {
            op, left, right, ..
        } => Expr::Binary(
            op,
            Box::new(lower(*left, context)?),
            Box::new(lower(*right, context)?),
        ),
        Kind::List(items) => Expr::List(
            items
                .into_iter()
                .map(|e| lower(e, context))
                .collect::<Result<_, _>>()?,
        ),
        Kind::Map(items) => Expr::Map(
            items
                .into_iter()
                .map(|(k, e)| Ok((k, lower(e, context)?)))
                .collect::<Result<_, _>>()?,
        ),
        Kind::Field { message, field, .. } => {
            return Err(SyntaxError::new(
                at,
                len,
                format!(
                    "`{}.{}` is a message field, read by elaboration rules: {}",
                    message.text,
                    field.text,
                    reads(context)
                ),
            ))
        }
        Kind::Call { name, .. } => {
            return Err(SyntaxError::new(
                name.at,
                name.len(),
                format!(
                    "`{}(…)` is a function of elaboration rules: {}",
                    name.text,
                    reads(context)
                ),
            ))
        }
    })
}

fn reads(context: Context) -> &'static str {
    match context {
        Context::Guard => "a guard reads the event's parameters (`name` or `$name`)",
        Context::Argument => "an argument reads the event's parameters (`$name`)",
    }
}
