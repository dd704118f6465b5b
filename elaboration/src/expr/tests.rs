use super::*;
use regex::Regex;

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
    assert!(matches!(run("cos(3.14159265 / 3)", &mut m), V::Float(c) if (c - 0.5).abs() < 1e-6));
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

/// One syntax for guards and rules: the same text gives the same tree in
/// the nets (a guard) and in elaboration (a rule condition).
mod one_dialect {
    use super::*;
    use nets::expr::{parse, Context as Nets, Expr};

    /// Constants `A`, `B`, `C` (a guard's parameters of the same names).
    struct Letters(Mock);

    impl Resolver for Letters {
        fn field(&mut self, message: &str, field: &str) -> Result<(usize, usize), String> {
            Resolver::field(&mut self.0, message, field)
        }
        fn timed_message(&mut self, message: &str) -> Result<usize, String> {
            self.0.timed_message(message)
        }
        fn constant(&self, name: &str) -> Option<i64> {
            ["A", "B", "C"]
                .iter()
                .position(|n| *n == name)
                .map(|i| 1001 + i as i64)
        }
        fn regex(&mut self, regex: Regex) -> usize {
            Resolver::regex(&mut self.0, regex)
        }
        fn memo(&mut self) -> usize {
            Resolver::memo(&mut self.0)
        }
    }

    fn leaf(v: &nets::Value) -> String {
        match v {
            nets::Value::Int(i @ 1001..=1003) => ["A", "B", "C"][(*i - 1001) as usize].into(),
            other => format!("{other:?}"),
        }
    }

    fn guard_tree(e: &Expr) -> String {
        match e {
            Expr::Lit(v) => leaf(v),
            Expr::Param { name, .. } => name.clone(),
            Expr::Not(a) => format!("({} {})", UnOp::Not.symbol(), guard_tree(a)),
            Expr::Neg(a) => format!("({} {})", UnOp::Neg.symbol(), guard_tree(a)),
            Expr::BitNot(a) => format!("({} {})", UnOp::BitNot.symbol(), guard_tree(a)),
            Expr::Binary(op, a, b) => {
                format!("({} {} {})", op.symbol(), guard_tree(a), guard_tree(b))
            }
            Expr::List(_) | Expr::Map(_) => "?".into(),
        }
    }

    fn rule_tree(n: &Node) -> String {
        match n {
            Node::Const(v) => v.to_value().map_or("?".into(), |v| leaf(&v)),
            // A guard folds `-literal` into the literal (not `-A`, a name).
            Node::Unary(UnOp::Neg, a) => match &**a {
                Node::Const(V::Int(i)) if !(1001..=1003).contains(i) => leaf(&nets::Value::Int(-i)),
                Node::Const(V::Float(f)) => leaf(&nets::Value::Float(-f)),
                a => format!("(- {})", rule_tree(a)),
            },
            Node::Unary(op, a) => format!("({} {})", op.symbol(), rule_tree(a)),
            Node::Binary(op, a, b) => {
                format!("({} {} {})", op.symbol(), rule_tree(a), rule_tree(b))
            }
            _ => "?".into(),
        }
    }

    fn both(text: &str) -> (String, String) {
        let guard = parse(text, Nets::Guard).unwrap_or_else(|e| panic!("{text}: {e:?}"));
        let mut r = Letters(Mock::default());
        let rule = compile(text, &mut r).unwrap_or_else(|e| panic!("{text}: {e:?}"));
        (guard_tree(&guard), rule_tree(&rule.node))
    }

    #[test]
    fn the_same_text_is_the_same_tree_in_a_guard_and_a_rule() {
        let cases = [
            ("A || B && C", "(|| A (&& B C))"),
            ("A or B and not C", "(|| A (&& B (! C)))"),
            ("(A || B) && C", "(&& (|| A B) C)"),
            // `!` and `not` take a whole comparison…
            ("!A == B", "(! (== A B))"),
            ("not A < 3 && B", "(&& (! (< A Int(3))) B)"),
            // …also after a comparison.
            ("A == !B && C", "(&& (== A (! B)) C)"),
            // `-` and `~` take one operand.
            ("-A * B + C % 2", "(+ (* (- A) B) (% C Int(2)))"),
            ("~A & 7", "(& (~ A) Int(7))"),
            // Bits bind tighter than comparisons, looser than arithmetic.
            ("A & 4 != 0", "(!= (& A Int(4)) Int(0))"),
            ("A | B ^ C & 1", "(| A (^ B (& C Int(1))))"),
            ("A & B + 1", "(& A (+ B Int(1)))"),
            ("A - B - C", "(- (- A B) C)"),
            ("A / B * C", "(* (/ A B) C)"),
            // Every literal spelling, in both.
            ("A + 0x10 >= 1_000", "(>= (+ A Int(16)) Int(1000))"),
            ("2.5e1 > -A", "(> Float(25.0) (- A))"),
            ("1. == -2", "(== Float(1.0) Int(-2))"),
        ];
        for (text, tree) in cases {
            let (guard, rule) = both(text);
            assert_eq!(guard, tree, "guard {text}");
            assert_eq!(rule, tree, "rule {text}");
        }
        let (guard, rule) = both(r#"A == 'it\'s' || B != "say \"hi\"\t""#);
        assert_eq!(guard, rule);
        assert_eq!(
            guard,
            r#"(|| (== A Str("it's")) (!= B Str("say \"hi\"\t")))"#
        );
    }

    #[test]
    fn errors_are_the_same_in_both_at_the_same_column() {
        for (text, at, message) in [
            ("A = 1", 2, "`=` is not a comparison: write `==`"),
            ("A < B < C", 6, "comparisons do not chain: use `&&`"),
            ("(A", 2, "expected `)`"),
            ("A &&", 4, "expected a value"),
            ("A # B", 2, "unexpected character `#`"),
            (
                "A B",
                2,
                "expected an operator or the end of the expression",
            ),
            ("'open", 0, "unterminated string"),
            ("12ab", 0, "malformed number `12ab`"),
        ] {
            let guard = parse(text, Nets::Guard).expect_err(text);
            let rule = compile(text, &mut Letters(Mock::default())).expect_err(text);
            assert_eq!((guard.at, guard.message.as_str()), (at, message), "{text}");
            assert_eq!(
                (rule.offset, rule.message.as_str()),
                (at, message),
                "{text}"
            );
        }
    }

    #[test]
    fn the_guards_spellings_work_in_rules() {
        let mut m = mock(V::Int(1000), V::Float(2.5), "a\tb");
        assert_eq!(run("M.a == 1_000", &mut m), V::Bool(true));
        assert_eq!(run("M.a == 1e3", &mut m), V::Bool(true));
        assert_eq!(run("M.b == 25E-1", &mut m), V::Bool(true));
        assert_eq!(run(r#"M.s == "a\tb""#, &mut m), V::Bool(true));
        assert_eq!(run("not M.a == 7 && M.b > 2", &mut m), V::Bool(true));
        assert_eq!(run("!M.a == 1000", &mut m), V::Bool(false));
        // A guard's parameter has no meaning in a rule: said so, at its column.
        let e = compile("M.a > $alt", &mut m).expect_err("a parameter");
        assert_eq!((e.offset, e.len), (6, 4));
        assert!(e.message.contains("event parameter"), "{}", e.message);
        let e = compile("M.a == [1]", &mut m).expect_err("a list");
        assert_eq!(e.offset, 7);
    }
}
