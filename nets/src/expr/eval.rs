//! Evaluating an [`Expr`] against the triggering event's parameters.

use super::{BinOp, Expr};
use crate::value::{Params, Value};

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
            Expr::BitNot(e) => match e.eval(params)? {
                Value::Int(i) => Value::Int(!i),
                other => {
                    return Err(EvalError::Unary {
                        op: "~",
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
                BinOp::BitAnd => Some(x & y),
                BinOp::BitOr => Some(x | y),
                BinOp::BitXor => Some(x ^ y),
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
