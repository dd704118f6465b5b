//! The one lexer of Petrel's expressions: names, `$parameters`, numbers,
//! quoted strings and the symbols of [`super::ops::SYMBOLS`]. Words that are
//! operators (`and`, `or`, `not`) come out as names; the parser reads them
//! in the operator table.
//!
//! - numbers: `12`, `1_000`, `0x1F`, `2.5`, `1.`, `1e3`, `2.5E-3`
//! - strings: `"…"` or `'…'`; `\n`, `\t`, `\\`, `\"` and `\'` are escapes,
//!   any other backslash is kept as written (a regular expression's `\d`)
//! - spaces between tokens are any Unicode white space

use super::ops::SYMBOLS;
use super::SyntaxError;

/// A token's kind.
#[derive(Debug, Clone, PartialEq)]
pub enum Tok<'s> {
    Int(i64),
    Float(f64),
    Str(String),
    /// A name: a letter or `_`, then letters, digits and `_`.
    Name(&'s str),
    /// `$name`: the name, without its `$`.
    Param(&'s str),
    /// An operator or punctuation, one of [`SYMBOLS`].
    Sym(&'static str),
    End,
}

/// A token and its byte span in the text.
#[derive(Debug, Clone, PartialEq)]
pub struct Token<'s> {
    pub tok: Tok<'s>,
    pub at: usize,
    pub len: usize,
}

pub fn is_name_start(c: char) -> bool {
    c.is_ascii_alphabetic() || c == '_'
}

pub fn is_name_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// The token that starts at `pos` (after spaces).
pub fn token(src: &str, pos: usize) -> Result<Token<'_>, SyntaxError> {
    let rest = &src[pos..];
    let at = pos + (rest.len() - rest.trim_start().len());
    let rest = &src[at..];
    let token = |tok, len| Ok(Token { tok, at, len });
    let Some(c) = rest.chars().next() else {
        return token(Tok::End, 0);
    };
    if c.is_ascii_digit() {
        return number(src, at);
    }
    if is_name_start(c) {
        let len = name_len(rest);
        return token(Tok::Name(&rest[..len]), len);
    }
    if c == '"' || c == '\'' {
        return string(src, at);
    }
    if c == '$' {
        let len = name_len(&rest[1..]);
        if len == 0 {
            return Err(SyntaxError::new(
                at,
                1,
                "expected a parameter name after `$`",
            ));
        }
        return token(Tok::Param(&rest[1..1 + len]), 1 + len);
    }
    match SYMBOLS.iter().find(|s| rest.starts_with(**s)) {
        Some(s) => token(Tok::Sym(s), s.len()),
        None => Err(SyntaxError::new(
            at,
            c.len_utf8(),
            format!("unexpected character `{c}`"),
        )),
    }
}

fn name_len(rest: &str) -> usize {
    if !rest.starts_with(is_name_start) {
        return 0;
    }
    rest.find(|c: char| !is_name_char(c)).unwrap_or(rest.len())
}

fn digits_len(rest: &str, digit: fn(&char) -> bool) -> usize {
    rest.find(|c: char| !(digit(&c) || c == '_'))
        .unwrap_or(rest.len())
}

/// A number at `at`: decimal with `_` separators, hexadecimal (`0x`), or a
/// float (a fraction, `1.`, or an exponent).
fn number(src: &str, at: usize) -> Result<Token<'_>, SyntaxError> {
    let rest = &src[at..];
    let hex = rest.starts_with("0x") || rest.starts_with("0X");
    let mut len;
    let mut float = false;
    if hex {
        len = 2 + digits_len(&rest[2..], char::is_ascii_hexdigit);
    } else {
        len = digits_len(rest, char::is_ascii_digit);
        let after = &rest[len..];
        if let Some(fraction) = after.strip_prefix('.') {
            if fraction.starts_with(|c: char| c.is_ascii_digit()) {
                float = true;
                len += 1 + digits_len(fraction, char::is_ascii_digit);
            } else if !fraction.starts_with(|c: char| is_name_char(c) || c == '.') {
                // `1.`, as rules have always read it.
                float = true;
                len += 1;
            }
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
    }
    // A number runs into a name or another dot: malformed as a whole.
    if rest[len..].starts_with(|c: char| is_name_char(c) || c == '.') {
        let whole = rest
            .find(|c: char| !(is_name_char(c) || c == '.'))
            .unwrap_or(rest.len());
        return Err(SyntaxError::new(
            at,
            whole,
            format!("malformed number `{}`", &rest[..whole]),
        ));
    }
    let written = &rest[..len];
    let digits: String = written.chars().filter(|c| *c != '_').collect();
    let tok = if hex {
        i64::from_str_radix(&digits[2..], 16)
            .map(Tok::Int)
            .map_err(|_| {
                if digits.len() == 2 {
                    format!("malformed number `{written}`")
                } else {
                    format!("number `{written}` is too large for a 64-bit integer")
                }
            })
    } else if float {
        match digits.parse::<f64>() {
            Ok(f) if f.is_finite() => Ok(Tok::Float(f)),
            Ok(_) => Err(format!("number `{written}` is too large for a float")),
            Err(_) => Err(format!("malformed number `{written}`")),
        }
    } else {
        digits
            .parse()
            .map(Tok::Int)
            .map_err(|_| format!("number `{written}` is too large for a 64-bit integer"))
    };
    tok.map(|tok| Token { tok, at, len })
        .map_err(|m| SyntaxError::new(at, len, m))
}

/// A quoted string at `at` (its quote is `"` or `'`).
pub fn string(src: &str, at: usize) -> Result<Token<'_>, SyntaxError> {
    let rest = &src[at..];
    let quote = rest.chars().next().unwrap_or('"');
    let mut out = String::new();
    let mut chars = rest.char_indices().skip(1);
    while let Some((i, c)) = chars.next() {
        match c {
            c if c == quote => {
                return Ok(Token {
                    tok: Tok::Str(out),
                    at,
                    len: i + 1,
                })
            }
            '\\' => match chars.next() {
                Some((_, 'n')) => out.push('\n'),
                Some((_, 't')) => out.push('\t'),
                Some((_, c @ ('"' | '\'' | '\\'))) => out.push(c),
                // Kept as written, for a regular expression (`\d`, `\(`).
                Some((_, c)) => {
                    out.push('\\');
                    out.push(c);
                }
                None => break,
            },
            c => out.push(c),
        }
    }
    Err(SyntaxError::new(at, rest.len(), "unterminated string"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tokens(src: &str) -> Result<Vec<Tok<'_>>, SyntaxError> {
        let mut pos = 0;
        let mut out = Vec::new();
        loop {
            let t = token(src, pos)?;
            pos = t.at + t.len;
            if t.tok == Tok::End {
                return Ok(out);
            }
            out.push(t.tok);
        }
    }

    #[test]
    fn numbers_of_both_former_dialects() {
        let cases: [(&str, Tok); 9] = [
            ("12", Tok::Int(12)),
            ("1_000", Tok::Int(1000)),
            ("0x10", Tok::Int(16)),
            ("0XfF", Tok::Int(255)),
            ("2.5", Tok::Float(2.5)),
            ("1.", Tok::Float(1.0)),
            ("1e3", Tok::Float(1000.0)),
            ("2.5E-3", Tok::Float(0.0025)),
            ("0x7fff_ffff_ffff_ffff", Tok::Int(i64::MAX)),
        ];
        for (src, tok) in cases {
            assert_eq!(tokens(src), Ok(vec![tok]), "{src}");
        }
    }

    #[test]
    fn malformed_numbers_are_errors_at_their_start() {
        let cases = [
            ("12ab", "malformed number `12ab`"),
            ("1.2.3", "malformed number `1.2.3`"),
            ("0x", "malformed number `0x`"),
            ("0x1g", "malformed number `0x1g`"),
            ("1e999", "number `1e999` is too large for a float"),
            (
                "99999999999999999999",
                "number `99999999999999999999` is too large for a 64-bit integer",
            ),
        ];
        for (src, message) in cases {
            let e = tokens(src).expect_err(src);
            assert_eq!((e.at, e.message.as_str()), (0, message), "{src}");
        }
    }

    #[test]
    fn strings_in_either_quote() {
        assert_eq!(
            tokens(r#""a\"b" 'c\'d' "tab\there" 're\d\(' "it's""#),
            Ok(vec![
                Tok::Str("a\"b".into()),
                Tok::Str("c'd".into()),
                Tok::Str("tab\there".into()),
                Tok::Str(r"re\d\(".into()),
                Tok::Str("it's".into()),
            ])
        );
        let e = tokens("x == 'open").expect_err("unterminated");
        assert_eq!(
            (e.at, e.len, e.message.as_str()),
            (5, 5, "unterminated string")
        );
    }

    #[test]
    fn symbols_names_and_parameters() {
        assert_eq!(
            tokens("$alt>=-1&&not x.y[2]|~z"),
            Ok(vec![
                Tok::Param("alt"),
                Tok::Sym(">="),
                Tok::Sym("-"),
                Tok::Int(1),
                Tok::Sym("&&"),
                Tok::Name("not"),
                Tok::Name("x"),
                Tok::Sym("."),
                Tok::Name("y"),
                Tok::Sym("["),
                Tok::Int(2),
                Tok::Sym("]"),
                Tok::Sym("|"),
                Tok::Sym("~"),
                Tok::Name("z"),
            ])
        );
        let e = tokens("a # b").expect_err("#");
        assert_eq!((e.at, e.message.as_str()), (2, "unexpected character `#`"));
        let e = tokens("$ x").expect_err("$");
        assert_eq!(
            (e.at, e.message.as_str()),
            (0, "expected a parameter name after `$`")
        );
        // Any Unicode white space separates tokens.
        assert_eq!(tokens("a\u{a0}b"), Ok(vec![Tok::Name("a"), Tok::Name("b")]));
    }
}
