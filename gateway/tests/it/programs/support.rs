//! The harness: a project folder in a temporary directory, the program
//! server on it, and bounded waits for its inputs.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use nets::{Outcome, Params, Project, Value};
use tokio::sync::mpsc;

use super::programs::server::{Direction, ProgramInput, Programs, Traffic};
use super::scratch::Scratch;
use petrel_core::programs::roster::Config;

/// Longest wait for any one input.
pub const WAIT: Duration = Duration::from_secs(15);

pub fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/programs/fixture.py")
}

/// The functions of program `P` in the test projects, and their returns.
pub const FUNCTIONS: &str = "[programs.P.functions]\n\
    echo = { returns = [\"value\"] }\n\
    slow = {}\n\
    garbage = { returns = [\"error\", \"line\"] }\n\
    emit = {}\n\
    crash = {}\n\
    hangup = {}\n\
    quit = {}\n";

/// Function indices (the loader orders them by name).
pub const CRASH: usize = 0;
pub const ECHO: usize = 1;
pub const EMIT: usize = 2;
pub const GARBAGE: usize = 3;
pub const HANGUP: usize = 4;
pub const QUIT: usize = 5;
pub const SLOW: usize = 6;

/// A project whose net calls every function of `P`; `programs` is the rest
/// of its project.toml ([programs.P] settings, more programs).
pub fn write_project(dir: &Path, programs: &str, functions: &str) -> Arc<Project> {
    let project = format!(
        "name = \"programs-test\"\n[[net]]\nfile = \"n.toml\"\nactive = true\n\
         [events]\nobstacle = {{ category = \"safety\", params = [\"range\"] }}\n\
         program_lost = \"communication\"\n{programs}\n{functions}"
    );
    let calls: Vec<String> = functions
        .lines()
        .filter_map(|l| l.split_once(" = "))
        .map(|(f, _)| format!("\"call P.{}\"", f.trim()))
        .collect();
    let net = format!(
        "name = \"N\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\n\
         [[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"go\"\n\
         do = [{}]\n",
        calls.join(", ")
    );
    std::fs::write(dir.join("project.toml"), &project).expect("write project.toml");
    std::fs::write(dir.join("n.toml"), &net).expect("write n.toml");
    let files = [("project.toml", project.as_str()), ("n.toml", net.as_str())];
    Arc::new(nets::load(&files).expect("the test project loads"))
}

/// `[programs.P]` started from the fixture, serving `functions`.
pub fn fixture_program(restart: &str, timeout: &str, functions: &[&str]) -> String {
    let mut run = vec![
        "\"python3\"".to_owned(),
        format!("{:?}", fixture().display().to_string()),
    ];
    run.extend(functions.iter().map(|f| format!("{f:?}")));
    format!(
        "[programs.P]\nrun = [{}]\nrestart = \"{restart}\"\ntimeout = \"{timeout}\"\n",
        run.join(", ")
    )
}

pub const ALL: &[&str] = &["echo", "slow", "garbage", "emit", "crash", "quit", "hangup"];

pub fn config() -> Config {
    Config {
        address: "tcp:127.0.0.1:0".parse().expect("address"),
        grace: Duration::from_millis(500),
        backoff_min: Duration::from_millis(50),
        backoff_max: Duration::from_millis(200),
        ..Config::default()
    }
}

pub struct Harness {
    pub programs: Programs,
    pub inputs: mpsc::Receiver<ProgramInput>,
    pub traffic: Vec<Traffic>,
    pub dir: Scratch,
    pub project: Arc<Project>,
}

impl Harness {
    pub async fn start(programs: &str, functions: &str) -> Harness {
        Harness::start_with(programs, functions, config()).await
    }

    pub async fn start_with(programs: &str, functions: &str, config: Config) -> Harness {
        let dir = Scratch::new("programs");
        let project = write_project(dir.path(), programs, functions);
        let (handle, inputs) = Programs::start(Arc::clone(&project), dir.path(), config)
            .await
            .expect("the server starts");
        Harness {
            programs: handle,
            inputs,
            traffic: Vec::new(),
            dir,
            project,
        }
    }

    /// The next input other than traffic (kept in `self.traffic`).
    pub async fn next(&mut self) -> ProgramInput {
        loop {
            let input = tokio::time::timeout(WAIT, self.inputs.recv())
                .await
                .expect("an input within the wait")
                .expect("the server is running");
            match input {
                ProgramInput::Traffic(t) => self.traffic.push(t),
                other => return other,
            }
        }
    }

    /// The next outcome, which must be of call `id`.
    pub async fn outcome(&mut self, id: u64) -> Outcome {
        match self.next().await {
            ProgramInput::Outcome { id: got, outcome } => {
                assert_eq!(got, id, "outcome of another call: {outcome:?}");
                outcome
            }
            other => panic!("expected the outcome of call {id}, got {other:?}"),
        }
    }

    /// Waits until nothing but traffic arrives for `quiet`.
    pub async fn assert_quiet(&mut self, quiet: Duration) {
        let deadline = tokio::time::Instant::now() + quiet;
        while let Ok(input) = tokio::time::timeout_at(deadline, self.inputs.recv()).await {
            match input {
                Some(ProgramInput::Traffic(t)) => self.traffic.push(t),
                Some(other) => panic!("expected nothing, got {other:?}"),
                None => return,
            }
        }
    }

    /// Waits for P's hello to be accepted (its welcome line).
    pub async fn connected(&mut self) {
        let deadline = tokio::time::Instant::now() + WAIT;
        let welcomed = |t: &[Traffic]| {
            t.iter()
                .any(|t| t.direction == Direction::Out && t.line.contains("\"welcome\""))
        };
        while !welcomed(&self.traffic) {
            match tokio::time::timeout_at(deadline, self.inputs.recv()).await {
                Ok(Some(ProgramInput::Traffic(t))) => self.traffic.push(t),
                Ok(Some(other)) => panic!("expected the hello, got {other:?}"),
                Ok(None) | Err(_) => panic!("P never said hello: {:?}", self.traffic),
            }
        }
    }

    pub fn starts(&self) -> Vec<i32> {
        std::fs::read_to_string(self.dir.path().join("starts.log"))
            .unwrap_or_default()
            .lines()
            .filter_map(|l| l.trim().parse().ok())
            .collect()
    }

    pub fn lines(&self, direction: Direction) -> Vec<&str> {
        self.traffic
            .iter()
            .filter(|t| t.direction == direction)
            .map(|t| t.line.as_str())
            .collect()
    }
}

pub fn params(pairs: &[(&str, Value)]) -> Params {
    pairs
        .iter()
        .map(|(k, v)| ((*k).to_owned(), v.clone()))
        .collect()
}

pub fn failed(reason: &str) -> Outcome {
    Outcome::Failed(reason.to_owned())
}

/// Whether a process (or a zombie) with this pid exists.
pub fn exists(pid: i32) -> bool {
    Path::new(&format!("/proc/{pid}")).exists()
}
