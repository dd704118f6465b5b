//! Why a plan is refused, and where.

use std::fmt;

/// Where in the file a problem is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum At {
    /// Line and column, from 1.
    LineCol(usize, usize),
    /// A `.plan`'s path to the value (`mission.items[3].params`).
    Path(String),
    /// The file as a whole.
    File,
}

/// A plan refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{file}{at}: {message}")]
pub struct PlanError {
    pub file: String,
    pub at: At,
    pub message: String,
}

impl fmt::Display for At {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            At::LineCol(line, col) => write!(f, ":{line}:{col}"),
            At::Path(path) => write!(f, ": {path}"),
            At::File => Ok(()),
        }
    }
}

impl PlanError {
    pub fn new(file: &str, at: At, message: impl Into<String>) -> PlanError {
        PlanError {
            file: file.to_owned(),
            at,
            message: message.into(),
        }
    }
}
