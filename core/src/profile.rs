//! The elaboration profile a verb runs with: a built-in base (`ardupilot`,
//! `px4`) and, optionally, a user's file layered over it (docs/events.md,
//! "Layers"). The layers' text is kept, so that a recording carries it and
//! a replay rebuilds the very profile the flight ran with.

use std::path::Path;

use elaboration::{Profile, ProfileError};
use miette::{miette, LabeledSpan, NamedSource};

/// A profile's layers, in order: the built-in base, then the user's file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layers {
    /// What people called it: `ardupilot`, `px4`, or the file's path.
    pub name: String,
    /// `(file name, TOML text)`, base first.
    pub layers: Vec<(String, String)>,
}

impl Layers {
    /// A built-in profile alone (`ardupilot` unless `px4`).
    pub fn builtin(name: &str) -> Layers {
        let base = if name == "px4" { "px4" } else { "ardupilot" };
        let text = elaboration::profile::builtin(base).unwrap_or_default();
        Layers {
            name: base.to_owned(),
            layers: vec![(format!("{base}.toml"), text.to_owned())],
        }
    }

    /// `ardupilot`, `px4`, or a file extending the built-in `base`. A
    /// relative file path is taken relative to `dir` when given (a profile
    /// named in a project's `[gateway]` table lives beside project.toml).
    pub fn choose(choice: &str, dir: Option<&Path>, base: &str) -> Result<Layers, miette::Report> {
        match choice {
            "ardupilot" | "px4" => Ok(Layers::builtin(choice)),
            file => {
                let path = match dir {
                    Some(d) if Path::new(file).is_relative() => d.join(file),
                    _ => Path::new(file).to_path_buf(),
                };
                let text = std::fs::read_to_string(&path)
                    .map_err(|e| miette!("cannot read the profile {}: {e}", path.display()))?;
                let mut layers = Layers::builtin(base);
                layers.name = path.display().to_string();
                layers.layers.push((path.display().to_string(), text));
                Ok(layers)
            }
        }
    }

    /// The profile for telemetry from an autopilot whose built-in profile
    /// is `detected`: `--profile` when given (a file relative to the working
    /// directory), else the project's `[gateway] profile` (`project`: the
    /// project's folder and that setting; a file relative to the folder),
    /// else the built-in one.
    pub fn pick(
        given: Option<&str>,
        project: Option<(&Path, Option<&str>)>,
        detected: &str,
    ) -> Result<Layers, miette::Report> {
        match (given, project) {
            (Some(choice), _) => Layers::choose(choice, None, detected),
            (None, Some((dir, Some(choice)))) => Layers::choose(choice, Some(dir), detected),
            _ => Ok(Layers::builtin(detected)),
        }
    }

    /// Compiles the layers; every problem comes back for people
    /// (file:line:col, the line and a caret), none printed here.
    pub fn load(&self) -> Result<Profile, Problems> {
        let refs: Vec<(&str, &str)> = self
            .layers
            .iter()
            .map(|(n, t)| (n.as_str(), t.as_str()))
            .collect();
        Profile::load(&refs).map_err(|e| Problems(reports(&e, &self.layers)))
    }
}

/// A profile's problems, each rendered for people with its source line.
#[derive(Debug, thiserror::Error)]
#[error("{}", .0.join("\n"))]
pub struct Problems(pub Vec<String>);

/// Each problem of a profile with its source line, rendered.
pub fn reports(err: &ProfileError, sources: &[(String, String)]) -> Vec<String> {
    err.problems
        .iter()
        .map(|p| {
            let mut r = miette!(
                labels = vec![LabeledSpan::at(p.span.clone(), p.message.clone())],
                "{}:{}:{}: {}",
                p.file,
                p.line,
                p.col,
                p.message
            );
            if let Some((name, text)) = sources.iter().find(|(n, _)| *n == p.file) {
                r = r.with_source_code(NamedSource::new(name, text.clone()));
            }
            format!("{r:?}")
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_relative_file_is_found_beside_the_project() {
        let dir = std::env::temp_dir().join(format!("petrel-profile-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        std::fs::write(
            dir.join("extra.toml"),
            "[rules.battery_low]\ncategory = \"catastrophic\"\n",
        )
        .expect("written");
        let layers = Layers::choose("extra.toml", Some(&dir), "ardupilot").expect("found");
        assert_eq!(layers.layers.len(), 2);
        assert_eq!(layers.layers[0].0, "ardupilot.toml");
        assert!(layers.name.ends_with("extra.toml"));
        let profile = layers.load().expect("loads");
        let catalog = profile.catalog();
        let battery = catalog.get("battery_low").and_then(|d| d.category);
        assert_eq!(battery, Some(nets::Category::Catastrophic));
        // Not beside the working directory.
        assert!(Layers::choose("extra.toml", None, "ardupilot").is_err());
        // A broken layer is refused.
        std::fs::write(dir.join("bad.toml"), "[rules.x]\nwhen = \"NOPE.field\"\n")
            .expect("written");
        let bad = Layers::choose("bad.toml", Some(&dir), "px4").expect("read");
        assert_eq!(bad.layers[0].0, "px4.toml");
        assert!(bad.load().is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
