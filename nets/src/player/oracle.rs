//! The verifier's oracle: how a player answers what it cannot know when the
//! verifier runs it (in flight there is no oracle and everything is
//! evaluated).
//!
//! The verifier sends external events without their parameters, because it
//! does not know them. Two kinds of questions stand for them:
//!
//! - **does this guard hold?** — for a guard that reads a parameter the
//!   event does not carry;
//! - **does the external event carry parameter `p`?** — for an action
//!   argument that reads `p`. Absent, the firing is rejected exactly as in
//!   flight (a bad-argument fault and `net_fault`); present, the argument is
//!   left out (its value is unknown).
//!
//! Within one occurrence of an external event the answers agree: a guard
//! that holds must have read some parameters (those every evaluation that
//! holds reads), which the event therefore carries, and a parameter said to
//! be absent makes every guard that needs it false, as in flight. Presence is
//! only asked by arguments: a guard on an absent parameter is false, which
//! its own "no" already covers, so asking there would only repeat states.

use std::sync::Arc;

use crate::expr::{BinOp, Expr};
use crate::value::Params;

/// One question the oracle was asked.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Question {
    /// Does a guard hold? (It reads a parameter the event does not carry.)
    Guard,
    /// Does the external event being handled carry this parameter?
    Carries(Arc<str>),
}

/// How the verifier answers what the player cannot know. In flight there is
/// no oracle: every guard and argument is evaluated. With one, a guard that
/// reads a parameter the event does not carry takes the next answer (false
/// once they run out); an action argument that reads a parameter the
/// external event being handled does not carry asks whether the event
/// carries it (the next answer, absent once they run out): absent, the
/// firing is rejected as in flight; present, the argument is left out. The
/// verifier explores every sequence of answers.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Oracle {
    /// Answers to give, in order of asking.
    pub answers: Vec<bool>,
    /// How many questions were asked.
    pub asked: usize,
    /// The questions asked, in order.
    pub questions: Vec<Question>,
    /// Whether the occurrence being handled is the external event's (whose
    /// parameters the verifier does not know).
    open: bool,
    /// What is known of the external event's parameters: present or not.
    known: Vec<(Arc<str>, bool)>,
    /// Every parameter name asked about so far, kept across occurrences:
    /// a question or a known parameter shares its name instead of
    /// allocating one (the verifier runs millions of occurrences).
    names: Vec<Arc<str>>,
}

/// What a guard reading an unknown parameter comes to.
pub(super) enum GuardAnswer {
    Holds,
    False,
    /// The guard reads a parameter the event lacks: in flight, an error
    /// (counted false, reported).
    Missing(String),
}

impl Oracle {
    /// An oracle that gives these answers, in order.
    pub fn new(answers: Vec<bool>) -> Oracle {
        Oracle {
            answers,
            ..Oracle::default()
        }
    }

    fn ask(&mut self, question: Question) -> bool {
        let answer = self.answers.get(self.asked).copied().unwrap_or(false);
        self.asked += 1;
        self.questions.push(question);
        answer
    }

    /// Starts (`true`) or ends the occurrence of an external event: what was
    /// known of its parameters is forgotten either way.
    pub(super) fn open(&mut self, open: bool) {
        self.open = open;
        self.known.clear();
    }

    fn known(&self, name: &str) -> Option<bool> {
        self.known
            .iter()
            .find(|(n, _)| **n == *name)
            .map(|(_, k)| *k)
    }

    /// `name`, shared.
    fn name(&mut self, name: &str) -> Arc<str> {
        match self.names.iter().find(|n| ***n == *name) {
            Some(n) => Arc::clone(n),
            None => {
                let n: Arc<str> = Arc::from(name);
                self.names.push(Arc::clone(&n));
                n
            }
        }
    }

    /// Whether the external event carries `name`: known, or asked now.
    fn carries(&mut self, name: &str) -> bool {
        if let Some(k) = self.known(name) {
            return k;
        }
        let name = self.name(name);
        let answer = self.ask(Question::Carries(Arc::clone(&name)));
        self.known.push((name, answer));
        answer
    }

    /// A guard that reads a parameter `params` lacks.
    pub(super) fn guard(&mut self, guard: &Expr, params: &Params) -> GuardAnswer {
        if !self.open {
            return if self.ask(Question::Guard) {
                GuardAnswer::Holds
            } else {
                GuardAnswer::False
            };
        }
        let reads = Reads::of(guard);
        let unknown = |p: &&str| !params.contains_key(*p);
        // Read by every evaluation that succeeds: absent, an error.
        if let Some(p) = reads
            .always()
            .into_iter()
            .flatten()
            .filter(unknown)
            .find(|p| self.known(p) == Some(false))
        {
            return GuardAnswer::Missing(p.to_owned());
        }
        // Read by every evaluation that holds: absent, the guard is false
        // (`None`: it never holds).
        let Some(needed) = reads.truthy else {
            return GuardAnswer::False;
        };
        let needed: Vec<&str> = needed.into_iter().filter(unknown).collect();
        if needed.iter().any(|p| self.known(p) == Some(false)) {
            return GuardAnswer::False;
        }
        if !self.ask(Question::Guard) {
            return GuardAnswer::False;
        }
        for p in needed {
            if self.known(p).is_none() {
                let p = self.name(p);
                self.known.push((p, true));
            }
        }
        GuardAnswer::Holds
    }

    /// An action argument that reads a parameter `params` lacks: the
    /// parameter the external event is said to lack (the firing is then
    /// rejected), or `None` to leave the argument out. Only the parameters
    /// every successful evaluation reads are asked about (one that only
    /// `&&` or `||` may skip is taken as present); outside the external
    /// event's occurrence, nothing is asked.
    pub(super) fn argument(&mut self, argument: &Expr, params: &Params) -> Option<String> {
        if !self.open {
            return None;
        }
        // The common argument `$p`: read by every evaluation, alone (what
        // the general case below comes to, without its lists).
        if let Expr::Param { name, .. } = argument {
            if params.contains_key(name.as_str()) || self.carries(name) {
                return None;
            }
            return Some(name.clone());
        }
        let always = Reads::of(argument).always().unwrap_or_default();
        // In the order evaluation reads them: the first absent one is the
        // error flight reports.
        let mut order = Vec::new();
        argument.params(&mut order);
        let mut seen: Vec<&str> = Vec::new();
        for (name, _) in &order {
            let name = name.as_str();
            if params.contains_key(name) || !always.contains(&name) || seen.contains(&name) {
                continue;
            }
            seen.push(name);
            if !self.carries(name) {
                return Some(name.to_owned());
            }
        }
        None
    }
}

/// A set of parameter names, or `None` for every name: what evaluations
/// that cannot happen read (a literal `true` is never falsy).
type Names<'a> = Option<Vec<&'a str>>;

/// The parameters an expression surely reads: on every evaluation that
/// succeeds with a truthy value, and on every one that succeeds with a
/// falsy value (`&&` and `||` skip their right side). Smaller sets are
/// sound for a guard (a "yes" makes fewer parameters present); for an
/// argument, a parameter outside them is taken as present (see
/// [`Oracle::argument`]).
struct Reads<'a> {
    truthy: Names<'a>,
    falsy: Names<'a>,
}

impl<'a> Reads<'a> {
    fn of(expr: &'a Expr) -> Reads<'a> {
        match expr {
            Expr::Lit(v) if v.truthy() => Reads {
                truthy: Some(Vec::new()),
                falsy: None,
            },
            Expr::Lit(_) => Reads {
                truthy: None,
                falsy: Some(Vec::new()),
            },
            Expr::Param { name, .. } => Reads::both(Some(vec![name.as_str()])),
            Expr::Not(e) => {
                let r = Reads::of(e);
                Reads {
                    truthy: r.falsy,
                    falsy: r.truthy,
                }
            }
            Expr::Binary(BinOp::And, a, b) => {
                let (a, b) = (Reads::of(a), Reads::of(b));
                Reads {
                    truthy: union(&a.truthy, &b.truthy),
                    falsy: intersection(&a.falsy, &union(&a.truthy, &b.falsy)),
                }
            }
            Expr::Binary(BinOp::Or, a, b) => {
                let (a, b) = (Reads::of(a), Reads::of(b));
                Reads {
                    truthy: intersection(&a.truthy, &union(&a.falsy, &b.truthy)),
                    falsy: union(&a.falsy, &b.falsy),
                }
            }
            Expr::Neg(e) | Expr::BitNot(e) => Reads::both(Reads::of(e).always()),
            Expr::Binary(_, a, b) => {
                Reads::both(union(&Reads::of(a).always(), &Reads::of(b).always()))
            }
            Expr::List(items) => Reads::both(always_all(items.iter())),
            Expr::Map(items) => Reads::both(always_all(items.iter().map(|(_, e)| e))),
        }
    }

    fn both(names: Names<'a>) -> Reads<'a> {
        Reads {
            truthy: names.clone(),
            falsy: names,
        }
    }

    /// Read by every evaluation that succeeds.
    fn always(&self) -> Names<'a> {
        intersection(&self.truthy, &self.falsy)
    }
}

/// Read by every successful evaluation of all of them.
fn always_all<'a>(items: impl Iterator<Item = &'a Expr>) -> Names<'a> {
    let mut out = Some(Vec::new());
    for e in items {
        out = union(&out, &Reads::of(e).always());
    }
    out
}

fn union<'a>(a: &Names<'a>, b: &Names<'a>) -> Names<'a> {
    let (a, b) = (a.as_ref()?, b.as_ref()?);
    let mut out = a.clone();
    out.extend(b.iter().filter(|x| !a.contains(x)));
    Some(out)
}

fn intersection<'a>(a: &Names<'a>, b: &Names<'a>) -> Names<'a> {
    match (a, b) {
        (None, x) | (x, None) => x.clone(),
        (Some(a), Some(b)) => Some(a.iter().copied().filter(|x| b.contains(x)).collect()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::Context;

    /// What every evaluation that holds reads, and every one that succeeds
    /// (`*`: there is none).
    fn reads(text: &str) -> (Vec<String>, Vec<String>) {
        let e = crate::expr::parse(text, Context::Guard).expect("parses");
        let r = Reads::of(&e);
        let sorted = |names: Names| -> Vec<String> {
            let mut v: Vec<String> = names
                .unwrap_or(vec!["*"])
                .iter()
                .map(|s| s.to_string())
                .collect();
            v.sort();
            v
        };
        (sorted(r.truthy.clone()), sorted(r.always()))
    }

    #[test]
    fn reads_follow_short_circuits() {
        assert_eq!(reads("lat > 45"), (vec!["lat".into()], vec!["lat".into()]));
        // Holds only with both; fails, with `a` alone if `a` is false.
        assert_eq!(
            reads("a == 1 && b == 2"),
            (vec!["a".into(), "b".into()], vec!["a".into()])
        );
        // Holds with `a` alone; false only with both.
        assert_eq!(reads("a || b"), (vec!["a".into()], vec!["a".into()]));
        assert_eq!(
            reads("!(a || b)"),
            (vec!["a".into(), "b".into()], vec!["a".into()])
        );
        assert_eq!(
            reads("a + b > c"),
            (
                vec!["a".into(), "b".into(), "c".into()],
                vec!["a".into(), "b".into(), "c".into()]
            )
        );
        // Literals short-circuit the same way every time.
        assert_eq!(reads("true || a"), (vec![], vec![]));
        assert_eq!(reads("true && a"), (vec!["a".into()], vec!["a".into()]));
        assert_eq!(reads("false || a"), (vec!["a".into()], vec!["a".into()]));
        assert_eq!(
            reads("a == 1 && false"),
            (vec!["*".into()], vec!["a".into()])
        );
        assert_eq!(
            reads("[a, {k: b}] != []"),
            (vec!["a".into(), "b".into()], vec!["a".into(), "b".into()])
        );
    }

    fn expr(text: &str, context: Context) -> Expr {
        crate::expr::parse(text, context).expect("parses")
    }

    #[test]
    fn a_guard_that_holds_makes_what_it_read_present_for_arguments() {
        let mut o = Oracle::new(vec![true]);
        o.open(true);
        let none = Params::new();
        assert!(matches!(
            o.guard(&expr("lat > 45 && lon < 2", Context::Guard), &none),
            GuardAnswer::Holds
        ));
        // Neither is asked again.
        assert_eq!(o.argument(&expr("$lat", Context::Argument), &none), None);
        assert_eq!(o.argument(&expr("$lon", Context::Argument), &none), None);
        assert_eq!(o.questions, [Question::Guard]);
        // `alt` is asked, and absent once the answers run out.
        assert_eq!(
            o.argument(&expr("{a: $alt}", Context::Argument), &none),
            Some("alt".to_owned())
        );
        assert_eq!(
            o.questions,
            [Question::Guard, Question::Carries("alt".into())]
        );
    }

    #[test]
    fn a_parameter_said_absent_makes_the_guards_that_need_it_fail_as_in_flight() {
        let mut o = Oracle::new(vec![false, true]);
        o.open(true);
        let none = Params::new();
        assert_eq!(
            o.argument(&expr("$lat + 1", Context::Argument), &none),
            Some("lat".to_owned())
        );
        // Read by every evaluation: an error, as in flight.
        assert!(matches!(
            o.guard(&expr("lat > 45", Context::Guard), &none),
            GuardAnswer::Missing(p) if p == "lat"
        ));
        // Needed to hold, but `a` may be false first: false, no question.
        assert!(matches!(
            o.guard(&expr("a && lat > 45", Context::Guard), &none),
            GuardAnswer::False
        ));
        assert_eq!(o.questions, [Question::Carries("lat".into())]);
        // `a || lat` may hold without `lat`: asked (the next answer, yes).
        assert!(matches!(
            o.guard(&expr("a || lat", Context::Guard), &none),
            GuardAnswer::Holds
        ));
        // A new occurrence forgets.
        o.open(true);
        assert!(matches!(
            o.guard(&expr("lat > 45", Context::Guard), &none),
            GuardAnswer::False
        ));
    }

    #[test]
    fn a_guard_that_can_never_hold_is_not_asked_and_a_literal_does_not_hide_a_read() {
        let mut o = Oracle::new(vec![true]);
        o.open(true);
        let none = Params::new();
        assert!(matches!(
            o.guard(&expr("lat > 45 && false", Context::Guard), &none),
            GuardAnswer::False
        ));
        assert!(o.questions.is_empty());
        assert_eq!(
            o.argument(&expr("true && $lat", Context::Argument), &none),
            None
        );
        assert_eq!(o.questions, [Question::Carries("lat".into())]);
    }

    #[test]
    fn outside_the_external_events_occurrence_arguments_are_left_out_and_guards_asked() {
        let mut o = Oracle::new(vec![true]);
        let none = Params::new();
        assert_eq!(o.argument(&expr("$lat", Context::Argument), &none), None);
        assert!(matches!(
            o.guard(&expr("lat > 45", Context::Guard), &none),
            GuardAnswer::Holds
        ));
        assert_eq!(o.questions, [Question::Guard]);
    }

    #[test]
    fn parameters_the_event_carries_are_not_asked_about() {
        let mut o = Oracle::new(vec![]);
        o.open(true);
        let params = Params::from([("lat".to_owned(), crate::value::Value::Int(3))]);
        assert_eq!(
            o.argument(&expr("{a: $lat, b: $lon}", Context::Argument), &params),
            Some("lon".to_owned())
        );
        assert_eq!(o.questions, [Question::Carries("lon".into())]);
    }
}
