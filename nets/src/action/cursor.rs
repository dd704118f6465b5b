//! A cursor over an action's text: the words around its expressions
//! (`timer NAME after DURATION`). The expressions themselves are read by
//! [`crate::expr`]'s lexer and parser.

use crate::expr::lex::{is_name_char, is_name_start};
use crate::expr::SyntaxError;

pub struct Cursor<'a> {
    pub text: &'a str,
    pub pos: usize,
}

impl<'a> Cursor<'a> {
    pub fn new(text: &'a str) -> Self {
        Cursor { text, pos: 0 }
    }

    /// An error at the cursor.
    pub fn error(&self, message: impl Into<String>) -> SyntaxError {
        SyntaxError::new(self.pos, 1, message)
    }

    pub fn rest(&self) -> &'a str {
        &self.text[self.pos..]
    }

    pub fn skip_ws(&mut self) {
        let rest = self.rest();
        self.pos += rest.len() - rest.trim_start().len();
    }

    pub fn at_end(&mut self) -> bool {
        self.skip_ws();
        self.pos >= self.text.len()
    }

    /// Consumes the word `word` (after spaces) if it comes next, and is not
    /// the start of a longer name.
    pub fn eat(&mut self, word: &str) -> bool {
        self.skip_ws();
        let rest = self.rest();
        if rest.starts_with(word) && !rest[word.len()..].starts_with(is_name_char) {
            self.pos += word.len();
            return true;
        }
        false
    }

    /// Reads a name: a letter or `_`, then letters, digits and `_`.
    pub fn name(&mut self) -> Option<(String, usize)> {
        self.skip_ws();
        let start = self.pos;
        let rest = self.rest();
        if !rest.starts_with(is_name_start) {
            return None;
        }
        let len = rest.find(|c: char| !is_name_char(c)).unwrap_or(rest.len());
        self.pos += len;
        Some((rest[..len].to_owned(), start))
    }

    /// Reads a run of characters that are not spaces nor any of `stops`.
    pub fn word(&mut self, stops: &[char]) -> Option<(String, usize)> {
        self.skip_ws();
        let start = self.pos;
        let rest = self.rest();
        let len = rest
            .find(|c: char| c.is_whitespace() || stops.contains(&c))
            .unwrap_or(rest.len());
        if len == 0 {
            return None;
        }
        self.pos += len;
        Some((rest[..len].to_owned(), start))
    }
}
