use super::*;
use crate::value::Params;

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
        ("a # b", 2, "unexpected character `#`"),
        (
            "a b",
            2,
            "expected an operator or the end of the expression",
        ),
        ("\"abc", 0, "unterminated string"),
        ("$ x", 0, "expected a parameter name after `$`"),
        ("12ab", 0, "malformed number `12ab`"),
        ("{a: 1, a: 2}", 7, "duplicate key `a`"),
    ];
    for (text, at, message) in cases {
        let e = parse(text, Context::Guard).expect_err(text);
        assert_eq!((e.at, e.message.as_str()), (at, message), "{text}");
    }
}

/// Spellings that came from elaboration's rules work in guards.
#[test]
fn the_rules_spellings_work_in_guards() {
    assert_eq!(guard("flags & 4 != 0", &[("flags", 5.into())]), Ok(true));
    assert_eq!(guard("flags & 0x4 == 0", &[("flags", 3.into())]), Ok(true));
    assert_eq!(guard("(a | 2) ^ 1 == 6", &[("a", 5.into())]), Ok(true));
    assert_eq!(guard("~a & 7 == 2", &[("a", 5.into())]), Ok(true));
    assert_eq!(
        guard("mode == 'AUTO'", &[("mode", "AUTO".into())]),
        Ok(true)
    );
    assert_eq!(guard("x == 1.", &[("x", Value::Float(1.0))]), Ok(true));
    assert!(matches!(
        guard("x & 1 == 1", &[("x", Value::Float(1.0))]),
        Err(EvalError::Types { op: "&", .. })
    ));
    assert!(matches!(
        guard("~x == 1", &[("x", true.into())]),
        Err(EvalError::Unary { op: "~", .. })
    ));
}

#[test]
fn precedence_is_the_one_table() {
    let cases = [
        ("!a == b", "!($a == $b)"),
        ("not a and b", "(!$a && $b)"),
        ("a == !b && c", "(($a == !$b) && $c)"),
        ("a || b && c", "($a || ($b && $c))"),
        ("-a * b + c", "((-$a * $b) + $c)"),
        ("a & 4 != 0", "(($a & 4) != 0)"),
        ("a | b ^ c & d", "($a | ($b ^ ($c & $d)))"),
        ("~a & 7", "(~$a & 7)"),
        ("- -3 == 3", "(3 == 3)"),
    ];
    for (text, shown) in cases {
        assert_eq!(
            parse(text, Context::Guard).map(|e| e.to_string()),
            Ok(shown.to_string()),
            "{text}"
        );
    }
}

/// Fields, calls and regex matches belong to elaboration's rules: a guard
/// or an argument that writes one is an error at its column.
#[test]
fn rule_forms_are_errors_in_guards() {
    let cases = [
        ("seq == M.seq", 7, "`M.seq` is a message field"),
        (
            "age(HEARTBEAT) > 1",
            0,
            "`age(…)` is a function of elaboration rules",
        ),
        ("text ~ \"x\"", 5, "`~` (a regular expression match)"),
    ];
    for (text, at, start) in cases {
        let e = parse(text, Context::Guard).expect_err(text);
        assert_eq!(e.at, at, "{text}");
        assert!(e.message.starts_with(start), "{text}: {}", e.message);
    }
}

#[test]
fn nesting_is_bounded() {
    let deep = format!("{}a{}", "(".repeat(10_000), ")".repeat(10_000));
    let e = parse(&deep, Context::Guard).expect_err("too deep");
    assert_eq!(e.message, "the expression nests too deeply");
    let fine = format!("{}a{}", "(".repeat(100), ")".repeat(100));
    assert!(parse(&fine, Context::Guard).is_ok());
    let nots = format!("{}a", "!".repeat(10_000));
    assert!(parse(&nots, Context::Guard).is_err());
}
