//! Guards that can never hold together: the proof `petrel check` uses to
//! stay silent about a conflict the nets resolve by their guards
//! (`phase == "transit"` and `phase == "return"` on one event).
//!
//! A guard is read as a set of alternatives (a disjunction), each a list of
//! constraints on single parameters: `x == "a"`, `x != 3`, `x < 2.5` (with a
//! literal on either side), `x` (truthy), `!x` (falsy), combined by `&&`,
//! `||` and `!`. What it does not understand (arithmetic, two parameters
//! compared, an order on strings) it takes as "may hold", so the proof errs
//! only towards a warning. Two guards are exclusive when no alternative of
//! one is compatible with an alternative of the other: no values of the
//! event's parameters make both hold, with the player's own comparison
//! rules (integers and floats compare as numbers, `==` between different
//! types is false, an order between a number and a non-number is an error
//! and a guard in error does not hold).

use crate::expr::{BinOp, Expr};
use crate::model::Transition;
use crate::value::Value;

/// What a constraint compares a parameter with.
#[derive(Debug, Clone, PartialEq)]
enum Lit {
    Bool(bool),
    /// A number: every literal kept is exact as a float (see [`literal`]).
    Num(f64),
    Str(String),
}

/// A constraint on one parameter.
#[derive(Debug, Clone, PartialEq)]
enum Atom {
    Eq(Lit),
    Ne(Lit),
    /// The parameter is a number and compares so with the constant.
    Cmp(BinOp, f64),
    Truthy,
    Falsy,
}

/// Alternatives, each a conjunction of constraints on named parameters.
/// `[]` never holds; `[[]]` may hold whatever the parameters.
type Dnf = Vec<Vec<(String, Atom)>>;

/// Beyond this many alternatives a guard is taken as "may hold".
const MAX_ALTERNATIVES: usize = 64;

fn anything() -> Dnf {
    vec![Vec::new()]
}

fn or(mut a: Dnf, b: Dnf) -> Dnf {
    a.extend(b);
    if a.len() > MAX_ALTERNATIVES {
        anything()
    } else {
        a
    }
}

fn and(a: &Dnf, b: &Dnf) -> Dnf {
    if a.len() * b.len() > MAX_ALTERNATIVES {
        return anything();
    }
    let mut out = Vec::new();
    for x in a {
        for y in b {
            let mut c = x.clone();
            c.extend(y.iter().cloned());
            out.push(c);
        }
    }
    out
}

/// A literal the proof can use. Integers beyond 2^53 are not exact as
/// floats: they are left out (taken as anything), which stays sound.
fn literal(e: &Expr) -> Option<Lit> {
    const EXACT: i64 = 1 << 53;
    match e {
        Expr::Lit(Value::Bool(b)) => Some(Lit::Bool(*b)),
        Expr::Lit(Value::Int(i)) if (-EXACT..=EXACT).contains(i) => Some(Lit::Num(*i as f64)),
        Expr::Lit(Value::Float(f)) if f.is_finite() => Some(Lit::Num(*f)),
        Expr::Lit(Value::Str(s)) => Some(Lit::Str(s.clone())),
        _ => None,
    }
}

/// The order that says the same with its sides swapped (`3 < x` is `x > 3`).
fn swapped(op: BinOp) -> BinOp {
    match op {
        BinOp::Lt => BinOp::Gt,
        BinOp::Le => BinOp::Ge,
        BinOp::Gt => BinOp::Lt,
        BinOp::Ge => BinOp::Le,
        other => other,
    }
}

/// The order that holds exactly when `op` does not, between numbers.
fn negated(op: BinOp) -> BinOp {
    match op {
        BinOp::Lt => BinOp::Ge,
        BinOp::Le => BinOp::Gt,
        BinOp::Gt => BinOp::Le,
        BinOp::Ge => BinOp::Lt,
        other => other,
    }
}

/// When the expression evaluates to a truthy value (`true`) or to a falsy
/// one (`false`), without error: a superset of the parameters' values.
fn when(e: &Expr, truthy: bool) -> Dnf {
    match e {
        Expr::Lit(v) => {
            if v.truthy() == truthy {
                anything()
            } else {
                Vec::new()
            }
        }
        Expr::Param { name, .. } => {
            vec![vec![(
                name.clone(),
                if truthy { Atom::Truthy } else { Atom::Falsy },
            )]]
        }
        Expr::Not(a) => when(a, !truthy),
        // Holds: both hold. False: the left is false, or the right is
        // (the left then held).
        Expr::Binary(BinOp::And, a, b) if truthy => and(&when(a, true), &when(b, true)),
        Expr::Binary(BinOp::And, a, b) => or(when(a, false), when(b, false)),
        Expr::Binary(BinOp::Or, a, b) if truthy => or(when(a, true), when(b, true)),
        Expr::Binary(BinOp::Or, a, b) => and(&when(a, false), &when(b, false)),
        Expr::Binary(op, a, b) => {
            let (name, lit, op) = match (&**a, &**b) {
                (Expr::Param { name, .. }, other) => match literal(other) {
                    Some(l) => (name, l, *op),
                    None => return anything(),
                },
                (other, Expr::Param { name, .. }) => match literal(other) {
                    Some(l) => (name, l, swapped(*op)),
                    None => return anything(),
                },
                _ => return anything(),
            };
            let atom = match (op, lit) {
                (BinOp::Eq, l) => {
                    if truthy {
                        Atom::Eq(l)
                    } else {
                        Atom::Ne(l)
                    }
                }
                (BinOp::Ne, l) => {
                    if truthy {
                        Atom::Ne(l)
                    } else {
                        Atom::Eq(l)
                    }
                }
                (BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge, Lit::Num(c)) => {
                    Atom::Cmp(if truthy { op } else { negated(op) }, c)
                }
                _ => return anything(),
            };
            vec![vec![(name.clone(), atom)]]
        }
        _ => anything(),
    }
}

/// Whether some value satisfies every constraint (of one parameter).
fn satisfiable(atoms: &[&Atom]) -> bool {
    as_bool(atoms) || as_number(atoms) || as_string(atoms) || as_collection(atoms)
}

fn as_bool(atoms: &[&Atom]) -> bool {
    [false, true].into_iter().any(|b| {
        atoms.iter().all(|a| match a {
            Atom::Eq(l) => *l == Lit::Bool(b),
            Atom::Ne(l) => *l != Lit::Bool(b),
            Atom::Cmp(..) => false,
            Atom::Truthy => b,
            Atom::Falsy => !b,
        })
    })
}

fn as_number(atoms: &[&Atom]) -> bool {
    let mut equal: Option<f64> = None;
    let mut unequal: Vec<f64> = Vec::new();
    // Bounds: value and whether it is excluded.
    let mut low: Option<(f64, bool)> = None;
    let mut high: Option<(f64, bool)> = None;
    let tighter_low = |low: &mut Option<(f64, bool)>, v: f64, strict: bool| {
        if low.is_none_or(|(l, s)| v > l || (v == l && strict && !s)) {
            *low = Some((v, strict));
        }
    };
    let tighter_high = |high: &mut Option<(f64, bool)>, v: f64, strict: bool| {
        if high.is_none_or(|(h, s)| v < h || (v == h && strict && !s)) {
            *high = Some((v, strict));
        }
    };
    for a in atoms {
        match a {
            Atom::Eq(Lit::Num(v)) => match equal {
                Some(e) if e != *v => return false,
                _ => equal = Some(*v),
            },
            Atom::Eq(_) => return false,
            Atom::Ne(Lit::Num(v)) => unequal.push(*v),
            Atom::Ne(_) => {}
            Atom::Truthy => unequal.push(0.0),
            Atom::Falsy => match equal {
                Some(e) if e != 0.0 => return false,
                _ => equal = Some(0.0),
            },
            Atom::Cmp(BinOp::Lt, c) => tighter_high(&mut high, *c, true),
            Atom::Cmp(BinOp::Le, c) => tighter_high(&mut high, *c, false),
            Atom::Cmp(BinOp::Gt, c) => tighter_low(&mut low, *c, true),
            Atom::Cmp(_, c) => tighter_low(&mut low, *c, false),
        }
    }
    let fits = |v: f64| {
        !unequal.contains(&v)
            && low.is_none_or(|(l, s)| v > l || (v == l && !s))
            && high.is_none_or(|(h, s)| v < h || (v == h && !s))
    };
    match (equal, low, high) {
        (Some(v), _, _) => fits(v),
        (None, Some((l, _)), Some((h, _))) if l == h => fits(l),
        // An interval of positive length, or unbounded: infinitely many
        // numbers, a few excluded.
        (None, Some((l, _)), Some((h, _))) => l < h,
        _ => true,
    }
}

fn as_string(atoms: &[&Atom]) -> bool {
    let mut equal: Option<&str> = None;
    let mut unequal: Vec<&str> = Vec::new();
    let mut empty: Option<bool> = None;
    for a in atoms {
        match a {
            Atom::Eq(Lit::Str(s)) => match equal {
                Some(e) if e != s => return false,
                _ => equal = Some(s),
            },
            Atom::Eq(_) | Atom::Cmp(..) => return false,
            Atom::Ne(Lit::Str(s)) => unequal.push(s),
            Atom::Ne(_) => {}
            Atom::Truthy => {
                if empty == Some(true) {
                    return false;
                }
                empty = Some(false);
            }
            Atom::Falsy => {
                if empty == Some(false) {
                    return false;
                }
                empty = Some(true);
            }
        }
    }
    match (equal, empty) {
        (Some(s), _) => !unequal.contains(&s) && empty.is_none_or(|e| e == s.is_empty()),
        (None, Some(true)) => !unequal.contains(&""),
        _ => true,
    }
}

/// A list or a map: equal to no literal, ordered with nothing; empty or not.
fn as_collection(atoms: &[&Atom]) -> bool {
    atoms
        .iter()
        .all(|a| !matches!(a, Atom::Eq(_) | Atom::Cmp(..)))
        && !(atoms.contains(&&Atom::Truthy) && atoms.contains(&&Atom::Falsy))
}

/// Whether some parameter values satisfy every constraint of the list.
fn compatible(constraints: &[(String, Atom)]) -> bool {
    let mut names: Vec<&str> = constraints.iter().map(|(n, _)| n.as_str()).collect();
    names.sort_unstable();
    names.dedup();
    names.into_iter().all(|name| {
        let atoms: Vec<&Atom> = constraints
            .iter()
            .filter(|(n, _)| n == name)
            .map(|(_, a)| a)
            .collect();
        satisfiable(&atoms)
    })
}

/// Whether the two guards can never both hold on one occurrence of an
/// event (a missing guard always holds).
pub fn exclusive(a: Option<&Expr>, b: Option<&Expr>) -> bool {
    let (da, db) = (
        a.map_or_else(anything, |e| when(e, true)),
        b.map_or_else(anything, |e| when(e, true)),
    );
    da.iter().all(|x| {
        db.iter().all(|y| {
            let mut both = x.clone();
            both.extend(y.iter().cloned());
            !compatible(&both)
        })
    })
}

/// Whether two siblings (transitions waiting for one event that share an
/// input place) make an intended choice: their guards exclude each other,
/// or they declare different ranks (`else`, `priority`).
pub fn intended(a: &Transition, b: &Transition) -> bool {
    a.choice.rank() != b.choice.rank()
        || exclusive(
            a.guard.as_ref().map(|g| &g.expr),
            b.guard.as_ref().map(|g| &g.expr),
        )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::{parse, Context};
    use crate::value::Params;

    fn ex(a: &str, b: &str) -> bool {
        let a = parse(a, Context::Guard).expect("parses");
        let b = parse(b, Context::Guard).expect("parses");
        exclusive(Some(&a), Some(&b))
    }

    #[test]
    fn different_values_of_one_parameter_exclude_each_other() {
        assert!(ex(r#"phase == "transit""#, r#"phase == "return""#));
        assert!(ex(r#""transit" == phase"#, r#"phase == "return""#));
        assert!(ex("seq == 3", "seq == 4"));
        assert!(ex("seq == 3", "seq == 3.5"));
        assert!(ex("finished", "!finished"));
        assert!(ex("alt >= 100", "alt < 100"));
        assert!(ex("alt > 100", "!(alt > 100)"));
        assert!(ex("x < 1 || x > 5", "x >= 2 && x <= 4"));
        assert!(ex(
            r#"verb == "arm" && reason == "timeout""#,
            r#"verb == "mode""#
        ));
        assert!(ex(r#"a == "x" && b"#, r#"a == "x" && !b"#));
        assert!(ex("x == true", "x == 1"));
    }

    #[test]
    fn guards_that_may_hold_together_are_not_exclusive() {
        assert!(!ex(r#"payload == "camera""#, r#"phase == "return""#));
        assert!(!ex(
            r#"verb == "set_current" && reason == "timeout""#,
            r#"verb == "set_current""#
        ));
        assert!(!ex("seq == 3", "seq == 3.0"));
        assert!(!ex("alt >= 100", "alt <= 100"));
        assert!(!ex("x < 1", "x != 0"));
        assert!(!ex("x", "x != 0"));
        // Not understood: taken as "may hold".
        assert!(!ex("a + 1 == 2", "a + 1 == 3"));
        assert!(!ex("a == b", "a != b"));
        assert!(!ex(r#"s < "m""#, r#"s > "m""#));
        assert!(!ex("alt > 9007199254740993", "alt < 9007199254740992"));
        // Without a guard, a transition always may.
        let g = parse("x == 1", Context::Guard).expect("parses");
        assert!(!exclusive(None, Some(&g)));
    }

    /// Every pair said exclusive is never true together on sample values,
    /// as the player evaluates guards.
    #[test]
    fn exclusive_guards_never_both_hold_on_sample_values() {
        let guards = [
            "x == 1",
            "x == 1.0",
            "x != 1",
            "x < 1",
            "x >= 1",
            "x > 0 && x < 1",
            "x",
            "!x",
            r#"x == "a""#,
            r#"x != "a""#,
            r#"x == """#,
            "x == true",
            "x == false",
            "x == 0",
            "!(x < 1 || x == 3)",
            "x || y",
            "!x && y == 2",
            "y == 2",
        ];
        let values: Vec<Value> = vec![
            Value::Bool(true),
            Value::Bool(false),
            Value::Int(0),
            Value::Int(1),
            Value::Int(3),
            Value::Float(0.5),
            Value::Float(1.0),
            Value::Float(-2.0),
            Value::Str(String::new()),
            Value::Str("a".into()),
            Value::Str("b".into()),
            Value::List(Vec::new()),
            Value::List(vec![Value::Int(1)]),
        ];
        let mut checked = 0;
        for a in &guards {
            for b in &guards {
                if !ex(a, b) {
                    continue;
                }
                let (ea, eb) = (
                    parse(a, Context::Guard).expect("parses"),
                    parse(b, Context::Guard).expect("parses"),
                );
                for x in &values {
                    for y in &values {
                        let params = Params::from([
                            ("x".to_owned(), x.clone()),
                            ("y".to_owned(), y.clone()),
                        ]);
                        let holds = |e: &Expr| e.holds(&params).unwrap_or(false);
                        assert!(
                            !(holds(&ea) && holds(&eb)),
                            "{a} and {b} both hold with x = {x:?}, y = {y:?}"
                        );
                    }
                }
                checked += 1;
            }
        }
        assert!(checked > 20, "only {checked} exclusive pairs");
    }
}
