//! The verbs of the `petrel` command line, one module each.

use std::process::ExitCode;

pub mod check;
pub mod check_project;
pub mod compile;
#[cfg(feature = "demo")]
pub mod demo;
pub mod draw;
pub mod edit;
pub mod events;
pub mod examples;
pub mod export;
pub mod mirror;
pub mod play;
mod progress;
pub mod recover;
pub mod reload;
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

/// Loads the project knowing the events of its elaboration profile
/// (`[gateway] profile`, else ArduPilot's), as `petrel check` does without
/// `--profile`: for the verbs that take no profile (`draw`, `export`,
/// `stubs`). `None`: the profile does not load (already said).
pub fn load_profiled(
    dir: &std::path::Path,
) -> Result<Option<std::sync::Arc<nets::Project>>, miette::Report> {
    let Some((_, profile)) = project_profile(dir, None)? else {
        return Ok(None);
    };
    petrel_core::project::load_with(dir, &petrel_core::project::catalog(&profile)).map(Some)
}

/// The elaboration profile a project in `dir` is checked with: `given`
/// (`--profile`), else its `[gateway] profile`, else ArduPilot's; its
/// layers and the profile, or `None` when it does not load (already
/// said).
pub(crate) fn project_profile(
    dir: &std::path::Path,
    given: Option<&str>,
) -> Result<Option<(petrel_core::profile::Layers, elaboration::Profile)>, miette::Report> {
    let setting = match petrel_core::project::gateway_setting(dir, "profile") {
        Ok(s) => s,
        Err(e) => {
            // No project, or broken TOML: the loader says it best.
            petrel_core::project::load(dir)?;
            return Err(e);
        }
    };
    let layers =
        petrel_core::profile::Layers::pick(given, Some((dir, setting.as_deref())), "ardupilot")?;
    Ok(crate::cli::loaded(&layers).map(|profile| (layers, profile)))
}

/// The profile the layers compile to, or `None` once every problem is
/// printed for people (file:line:col, the line and a caret).
pub(crate) fn loaded(layers: &petrel_core::profile::Layers) -> Option<elaboration::Profile> {
    layers.load().map_err(|problems| say!("{problems}")).ok()
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_loader_knows_every_event_the_gateway_raises() {
        assert_eq!(
            petrel_core::project::RAISED,
            [
                petrel_core::programs::session::PROGRAM_LOST,
                crate::link::rejections::SIGNATURE_REJECTED
            ]
        );
    }
}
