//! The operator table of every Petrel expression — the nets' guards and
//! arguments and the elaboration rules' conditions: each operator's
//! spellings and its precedence level. The parser ([`super::syntax`]) reads
//! precedence only from here.

/// Binary operators.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BinOp {
    Or,
    And,
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
    /// `text ~ "regex"`: a regular expression match (elaboration rules).
    Match,
    BitOr,
    BitXor,
    BitAnd,
    Add,
    Sub,
    Mul,
    Div,
    Rem,
}

/// Prefix operators.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum UnOp {
    /// `!` or `not`.
    Not,
    /// `-`.
    Neg,
    /// `~`: every bit flipped.
    BitNot,
}

/// Precedence levels, loosest first: an operator binds its operands
/// tighter than any operator of a lower level.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// `||`, `or` (left to right).
    Or,
    /// `&&`, `and` (left to right).
    And,
    /// The prefix `!`, `not`: `!a == b` is `!(a == b)`.
    Not,
    /// `== != < <= > >= ~`: they do not chain (`a < b < c` is an error).
    Compare,
    /// `|`.
    BitOr,
    /// `^`.
    BitXor,
    /// `&`: `flags & MASK != 0` is `(flags & MASK) != 0`.
    BitAnd,
    /// `+ -`.
    Sum,
    /// `* / %`.
    Product,
    /// The prefix `-` and `~`: `-a * b` is `(-a) * b`.
    Prefix,
}

impl Level {
    /// The next tighter level (the right operand of a left-associative
    /// operator of this level is parsed at it).
    pub fn tighter(self) -> Level {
        match self {
            Level::Or => Level::And,
            Level::And => Level::Not,
            Level::Not => Level::Compare,
            Level::Compare => Level::BitOr,
            Level::BitOr => Level::BitXor,
            Level::BitXor => Level::BitAnd,
            Level::BitAnd => Level::Sum,
            Level::Sum => Level::Product,
            Level::Product | Level::Prefix => Level::Prefix,
        }
    }
}

/// Every binary operator's spellings, symbols and words alike.
pub const BINARY: &[(&str, BinOp)] = &[
    ("||", BinOp::Or),
    ("or", BinOp::Or),
    ("&&", BinOp::And),
    ("and", BinOp::And),
    ("==", BinOp::Eq),
    ("!=", BinOp::Ne),
    ("<", BinOp::Lt),
    ("<=", BinOp::Le),
    (">", BinOp::Gt),
    (">=", BinOp::Ge),
    ("~", BinOp::Match),
    ("|", BinOp::BitOr),
    ("^", BinOp::BitXor),
    ("&", BinOp::BitAnd),
    ("+", BinOp::Add),
    ("-", BinOp::Sub),
    ("*", BinOp::Mul),
    ("/", BinOp::Div),
    ("%", BinOp::Rem),
];

/// Every prefix operator's spellings.
pub const PREFIX: &[(&str, UnOp)] = &[
    ("!", UnOp::Not),
    ("not", UnOp::Not),
    ("-", UnOp::Neg),
    ("~", UnOp::BitNot),
];

/// The symbols the lexer knows (operators and punctuation), longest first
/// so that `<=` is never read as `<` then `=`.
pub const SYMBOLS: &[&str] = &[
    "||", "&&", "==", "!=", "<=", ">=", "<", ">", "~", "|", "^", "&", "+", "-", "*", "/", "%", "!",
    "(", ")", "[", "]", "{", "}", ".", ",", ":", "=",
];

impl BinOp {
    /// The operator spelled `spelling` (a symbol or a word), if any.
    pub fn spelled(spelling: &str) -> Option<BinOp> {
        BINARY
            .iter()
            .find(|(s, _)| *s == spelling)
            .map(|(_, op)| *op)
    }

    pub fn level(self) -> Level {
        match self {
            BinOp::Or => Level::Or,
            BinOp::And => Level::And,
            BinOp::Eq
            | BinOp::Ne
            | BinOp::Lt
            | BinOp::Le
            | BinOp::Gt
            | BinOp::Ge
            | BinOp::Match => Level::Compare,
            BinOp::BitOr => Level::BitOr,
            BinOp::BitXor => Level::BitXor,
            BinOp::BitAnd => Level::BitAnd,
            BinOp::Add | BinOp::Sub => Level::Sum,
            BinOp::Mul | BinOp::Div | BinOp::Rem => Level::Product,
        }
    }

    /// The operator's symbol (its first spelling), for messages.
    pub fn symbol(self) -> &'static str {
        BINARY
            .iter()
            .find(|(_, op)| *op == self)
            .map_or("?", |(s, _)| *s)
    }
}

impl UnOp {
    /// The prefix operator spelled `spelling`, if any.
    pub fn spelled(spelling: &str) -> Option<UnOp> {
        PREFIX
            .iter()
            .find(|(s, _)| *s == spelling)
            .map(|(_, op)| *op)
    }

    /// The level its operand is parsed at: `!` takes a comparison, `-` and
    /// `~` a single operand.
    pub fn operand(self) -> Level {
        match self {
            UnOp::Not => Level::Not,
            UnOp::Neg | UnOp::BitNot => Level::Prefix,
        }
    }

    pub fn symbol(self) -> &'static str {
        PREFIX
            .iter()
            .find(|(_, op)| *op == self)
            .map_or("?", |(s, _)| *s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_operator_has_a_symbol_the_lexer_knows() {
        for (spelling, op) in BINARY {
            assert!(
                SYMBOLS.contains(spelling) || spelling.chars().all(|c| c.is_ascii_lowercase()),
                "{spelling}"
            );
            assert_eq!(BinOp::spelled(op.symbol()), Some(*op));
        }
        for (spelling, op) in PREFIX {
            assert!(
                SYMBOLS.contains(spelling) || spelling.chars().all(|c| c.is_ascii_lowercase()),
                "{spelling}"
            );
            assert_eq!(UnOp::spelled(op.symbol()), Some(*op));
        }
    }

    #[test]
    fn longer_symbols_come_before_their_prefixes() {
        for (i, long) in SYMBOLS.iter().enumerate() {
            for short in &SYMBOLS[..i] {
                assert!(
                    !(long.len() > short.len() && long.starts_with(short)),
                    "`{long}` after `{short}`"
                );
            }
        }
    }

    #[test]
    fn levels_go_from_loosest_to_tightest() {
        assert!(BinOp::Or.level() < BinOp::And.level());
        assert!(BinOp::And.level() < UnOp::Not.operand());
        assert!(UnOp::Not.operand() < BinOp::Eq.level());
        assert!(BinOp::Eq.level() < BinOp::BitOr.level());
        assert!(BinOp::BitAnd.level() < BinOp::Add.level());
        assert!(BinOp::Add.level() < BinOp::Mul.level());
        assert!(BinOp::Mul.level() < UnOp::Neg.operand());
        assert_eq!(Level::Product.tighter(), Level::Prefix);
    }
}
