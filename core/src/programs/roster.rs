//! What the project expects of its programs: the functions the nets call
//! (the hello is checked against them), each program's settings from its
//! `[programs.NAME]` table, and the gateway's `[gateway] programs` address.

use std::collections::BTreeSet;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use nets::model::Action;
use nets::Project;

use super::address::{self, Address};

/// Default time a program has to answer a call.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(5);

/// When a started program is started again after it exits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Restart {
    /// Only after a failure: a non-zero exit, a signal, or a failure to start.
    OnFailure,
    /// After any exit.
    Always,
    /// Never.
    Never,
}

/// The gateway's settings of one program (the keys of `[programs.NAME]`
/// besides `functions`).
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// `run = ["python3", "dec.py"]`: the gateway starts it, in the project
    /// folder. `None`: the program connects by itself.
    pub run: Option<Vec<String>>,
    /// `restart = "on-failure" | "always" | "never"` (default on-failure).
    pub restart: Restart,
    /// `timeout = "5s"`: how long a call may wait for its reply.
    pub timeout: Duration,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            run: None,
            restart: Restart::OnFailure,
            timeout: DEFAULT_TIMEOUT,
        }
    }
}

/// A problem in the programs' settings, naming the program and key.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("project.toml [programs.{program}] `{key}`: {message}")]
pub struct SettingsError {
    pub program: String,
    pub key: String,
    pub message: String,
}

impl Settings {
    /// Reads a program's settings; unknown keys are errors.
    pub fn parse(
        program: &str,
        table: &std::collections::BTreeMap<String, toml::Value>,
    ) -> Result<Settings, SettingsError> {
        let err = |key: &str, message: String| SettingsError {
            program: program.to_owned(),
            key: key.to_owned(),
            message,
        };
        let mut settings = Settings::default();
        for (key, value) in table {
            match key.as_str() {
                "run" => {
                    let words = value
                        .as_array()
                        .and_then(|a| {
                            a.iter()
                                .map(|w| w.as_str().map(str::to_owned))
                                .collect::<Option<Vec<_>>>()
                        })
                        .filter(|w| !w.is_empty() && !w[0].is_empty())
                        .ok_or_else(|| {
                            err(
                                key,
                                "expected a command line: a list of strings, the program first"
                                    .into(),
                            )
                        })?;
                    settings.run = Some(words);
                }
                "restart" => {
                    settings.restart = match value.as_str() {
                        Some("on-failure") => Restart::OnFailure,
                        Some("always") => Restart::Always,
                        Some("never") => Restart::Never,
                        _ => {
                            return Err(err(
                                key,
                                format!(
                                "expected \"on-failure\", \"always\" or \"never\", found {value}"
                            ),
                            ))
                        }
                    };
                }
                "timeout" => {
                    let text = value.as_str().ok_or_else(|| {
                        err(
                            key,
                            format!("expected a duration such as \"5s\", found {value}"),
                        )
                    })?;
                    let micros =
                        nets::time::parse_duration(text).map_err(|e| err(key, e.to_string()))?;
                    if micros == 0 {
                        return Err(err(key, "a timeout must be longer than zero".into()));
                    }
                    settings.timeout = Duration::from_micros(micros);
                }
                _ => {
                    return Err(err(
                        key,
                        "unknown key (a program has `functions`, `run`, `restart`, `timeout`)"
                            .into(),
                    ))
                }
            }
        }
        Ok(settings)
    }
}

/// The project's programs as the gateway sees them.
#[derive(Debug, Clone)]
pub struct Roster {
    pub project: Arc<Project>,
    /// Per program (project order): the functions the nets call.
    pub called: Vec<BTreeSet<usize>>,
    /// Per program (project order): its settings.
    pub settings: Vec<Settings>,
    /// The token every hello must carry, when the gateway requires one.
    pub token: Option<String>,
}

impl Roster {
    /// Reads every program's settings and the calls the nets make.
    pub fn new(project: Arc<Project>) -> Result<Roster, SettingsError> {
        let settings = project
            .programs
            .iter()
            .map(|p| Settings::parse(&p.name, &p.settings))
            .collect::<Result<Vec<_>, _>>()?;
        let called = called_functions(&project);
        Ok(Roster {
            project,
            called,
            settings,
            token: None,
        })
    }

    /// The index of the program of that name.
    pub fn program(&self, name: &str) -> Option<usize> {
        self.project.programs.iter().position(|p| p.name == name)
    }

    /// A program's name.
    pub fn name(&self, program: usize) -> &str {
        self.project
            .programs
            .get(program)
            .map(|p| p.name.as_str())
            .unwrap_or("?")
    }

    /// A function's name.
    pub fn function_name(&self, program: usize, function: usize) -> &str {
        self.project
            .programs
            .get(program)
            .and_then(|p| p.functions.get(function))
            .map(|f| f.name.as_str())
            .unwrap_or("?")
    }

    /// Programs the nets call, with the functions called (names, sorted).
    pub fn called_names(&self, program: usize) -> Vec<&str> {
        let mut names: Vec<&str> = self.called[program]
            .iter()
            .map(|&f| self.function_name(program, f))
            .collect();
        names.sort_unstable();
        names
    }
}

/// Per program: the functions that some net's `call` action names.
pub fn called_functions(project: &Project) -> Vec<BTreeSet<usize>> {
    let mut called = vec![BTreeSet::new(); project.programs.len()];
    for net in &project.nets {
        for t in &net.transitions {
            for a in &t.actions {
                if let Action::Call {
                    program, function, ..
                } = a
                {
                    if let Some(set) = called.get_mut(*program) {
                        set.insert(*function);
                    }
                }
            }
        }
    }
    called
}

/// The server's settings beside the project's.
#[derive(Debug, Clone)]
pub struct Config {
    /// Where to listen (`[gateway] programs`).
    pub address: Address,
    /// On shutdown, how long started programs have between SIGTERM and
    /// SIGKILL.
    pub grace: Duration,
    /// Restart backoff: the first delay, doubled after each quick exit up
    /// to `backoff_max`.
    pub backoff_min: Duration,
    pub backoff_max: Duration,
    /// A program that ran this long before exiting restarts after
    /// `backoff_min` again.
    pub stable_after: Duration,
    /// The token programs must give in their hello (`--programs-token
    /// FILE` or `[gateway] programs_token = "FILE"`); required to listen
    /// anywhere but loopback.
    pub token: Option<String>,
    /// `[gateway] programs_token`: the token's file, relative to the
    /// project folder (read by `run` into `token`).
    pub token_file: Option<std::path::PathBuf>,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            address: address::DEFAULT
                .parse()
                .unwrap_or(Address::Tcp(std::net::SocketAddr::from((
                    [127, 0, 0, 1],
                    5790,
                )))),
            grace: Duration::from_secs(3),
            backoff_min: Duration::from_millis(200),
            backoff_max: Duration::from_secs(10),
            stable_after: Duration::from_secs(30),
            token: None,
            token_file: None,
        }
    }
}

/// A problem with the `[gateway]` table.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("cannot read {path}: {message}")]
    Read { path: String, message: String },
    #[error("project.toml [gateway] `programs`: {0}")]
    Address(#[from] address::AddressError),
    #[error("project.toml [gateway] `programs`: expected a string such as \"tcp:127.0.0.1:5790\"")]
    NotAString,
    #[error("project.toml [gateway] `programs_token`: expected the path of the token's file")]
    TokenNotAString,
}

impl Config {
    /// The settings given by a project's `[gateway]` table (defaults for
    /// what it does not say).
    pub fn from_gateway(table: Option<&toml::Table>) -> Result<Config, ConfigError> {
        let mut config = Config::default();
        if let Some(value) = table.and_then(|t| t.get("programs")) {
            let text = value.as_str().ok_or(ConfigError::NotAString)?;
            config.address = text.parse()?;
        }
        if let Some(value) = table.and_then(|t| t.get("programs_token")) {
            let text = value.as_str().ok_or(ConfigError::TokenNotAString)?;
            config.token_file = Some(text.into());
        }
        Ok(config)
    }

    /// Reads `project.toml` in `dir` for its `[gateway]` table.
    pub fn from_project_dir(dir: &Path) -> Result<Config, ConfigError> {
        let path = dir.join(nets::load::PROJECT_FILE);
        let read = |message: String| ConfigError::Read {
            path: path.display().to_string(),
            message,
        };
        let text = std::fs::read_to_string(&path).map_err(|e| read(e.to_string()))?;
        let table: toml::Table = toml::from_str(&text).map_err(|e| read(e.to_string()))?;
        Config::from_gateway(table.get("gateway").and_then(|g| g.as_table()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn project(programs: &str) -> Arc<Project> {
        let toml = format!("[[net]]\nfile = \"n.toml\"\nactive = true\n{programs}");
        let files = [
            ("project.toml", toml.as_str()),
            (
                "n.toml",
                "name = \"N\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\n\
                 [[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"go\"\n\
                 do = [\"call DEC.next\"]\n",
            ),
        ];
        Arc::new(nets::load(&files).expect("loads"))
    }

    #[test]
    fn settings_default_and_parse() {
        let p = project(
            "[programs.DEC]\nrun = [\"python3\", \"dec.py\"]\nrestart = \"always\"\ntimeout = \"250ms\"\n\
             [programs.DEC.functions]\nnext = {}\nunused = {}\n[programs.GUI.functions]\ngo = {}\n",
        );
        let r = Roster::new(p).expect("settings");
        let dec = r.program("DEC").expect("DEC");
        assert_eq!(
            r.settings[dec],
            Settings {
                run: Some(vec!["python3".into(), "dec.py".into()]),
                restart: Restart::Always,
                timeout: Duration::from_millis(250),
            }
        );
        let gui = r.program("GUI").expect("GUI");
        assert_eq!(r.settings[gui], Settings::default());
        assert_eq!(r.called_names(dec), vec!["next"]);
        assert!(r.called[gui].is_empty());
    }

    #[test]
    fn bad_settings_name_program_and_key() {
        for (body, key) in [
            ("run = []", "run"),
            ("run = \"dec.py\"", "run"),
            ("run = [1]", "run"),
            ("restart = \"sometimes\"", "restart"),
            ("timeout = 5", "timeout"),
            ("timeout = \"5 parsecs\"", "timeout"),
            ("timeout = \"0s\"", "timeout"),
            ("color = \"red\"", "color"),
        ] {
            let p = project(&format!(
                "[programs.DEC]\n{body}\n[programs.DEC.functions]\nnext = {{}}\n"
            ));
            let e = Roster::new(p).expect_err(body);
            assert_eq!((e.program.as_str(), e.key.as_str()), ("DEC", key), "{body}");
            assert!(e.to_string().contains("[programs.DEC]"), "{e}");
        }
    }

    #[test]
    fn gateway_table_gives_the_address() {
        let table: toml::Table =
            toml::from_str("programs = \"unix:/tmp/p.sock\"\nmavlink = \"udpin:0.0.0.0:14550\"")
                .expect("toml");
        let c = Config::from_gateway(Some(&table)).expect("config");
        assert_eq!(c.address, Address::Unix("/tmp/p.sock".into()));
        assert_eq!(
            Config::from_gateway(None)
                .expect("default")
                .address
                .to_string(),
            address::DEFAULT
        );
        let bad: toml::Table = toml::from_str("programs = 5").expect("toml");
        assert!(matches!(
            Config::from_gateway(Some(&bad)),
            Err(ConfigError::NotAString)
        ));
        let bad: toml::Table = toml::from_str("programs = \"tcp:nowhere\"").expect("toml");
        assert!(matches!(
            Config::from_gateway(Some(&bad)),
            Err(ConfigError::Address(_))
        ));
    }
}
