//! The verbs of the `petrel` command line, one module each.

use std::process::ExitCode;

pub mod check;
pub mod check_project;
pub mod demo;
pub mod draw;
pub mod edit;
pub mod events;
pub mod export;
pub mod mirror;
pub mod play;
pub mod recover;
pub mod replay;
pub mod run;
pub mod stubs;
pub mod timeline;
pub mod view;

/// How a verb ended, as an exit status.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Exit 0: everything held.
    Success,
    /// Exit 1: a property or check failed.
    Failed,
    /// Exit 2: bad input.
    BadInput,
}

impl From<Outcome> for ExitCode {
    fn from(o: Outcome) -> ExitCode {
        ExitCode::from(match o {
            Outcome::Success => 0,
            Outcome::Failed => 1,
            Outcome::BadInput => 2,
        })
    }
}

/// A verb's result: an outcome, or an error for people (printed with miette,
/// exit status 2).
pub type VerbResult = Result<Outcome, miette::Report>;
