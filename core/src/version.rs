//! A new version of the running project, taken over in flight (issue 38):
//! offered, proved from the state the vehicle is in, then swapped at a
//! step boundary — or refused with its reasons while the running version
//! goes on.
//!
//! [`Versions`] is the state machine; [`crate::onboard::Onboard`] drives it.
//! The proof ([`Proof::run`], `nets::version::swap`: the running state
//! mapped onto the new version by name, then explored with the project
//! check's explorer) may take seconds, so the core never runs it: it hands
//! it out ([`Versions::poll_proof`]) for the driver to run beside the
//! supervision, and takes the answer back ([`Versions::proved`]). The
//! state moves meanwhile; the version takes over only if, at the boundary
//! where the answer arrives, the player's state is the one proved (its
//! time aside: time alone changes no marking, no timer's deadline, no
//! pending call). Otherwise it is proved again from the new state, a
//! bounded number of times.
//!
//! What a version may not change in flight, because the gateway around
//! the player holds it (checked here, before any proof): the programs and
//! their functions (their connections and processes are the program
//! server's), and the team's vehicles (their links, commanders and
//! elaborators). The elaboration profile is not reloaded either.

use std::collections::VecDeque;
use std::sync::Arc;

use nets::player::State;
use nets::verify::project::Options;
use nets::{Player, Project};

/// Files of a version, `(path, text)` in the order the loader read them.
pub type Files = crate::project::Files;

/// How many times a version is proved again because the state moved
/// while it was being proved, before it is refused.
pub const PROOFS_AT_MOST: u32 = 12;

/// A version of the project, as offered and as recorded.
pub struct Version {
    /// 0 is the version `run` started with; each offer takes the next.
    pub number: u32,
    pub project: Arc<Project>,
    /// Its files as read, for the recording (replay loads the version from
    /// them).
    pub files: Files,
}

impl std::fmt::Debug for Version {
    /// Its number, files and digest; not the whole project.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let digest: String = self.digest()[..8]
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        f.debug_struct("Version")
            .field("number", &self.number)
            .field("project", &self.project.name)
            .field("files", &self.files.len())
            .field("digest", &digest)
            .finish()
    }
}

impl PartialEq for Version {
    /// The same number and files (the project is what they load to).
    fn eq(&self, other: &Version) -> bool {
        self.number == other.number && self.files == other.files
    }
}

impl Version {
    /// The version `number` loaded from its `files` as the player reads
    /// them (no elaboration profile: the events it waits for may come from
    /// anywhere), for a replica or a replayed recording.
    pub fn from_files(number: u32, files: Files) -> Result<Version, String> {
        let sources: std::collections::BTreeMap<String, String> = files.iter().cloned().collect();
        // A mission project's version compiles its mission first.
        let project = petrel_mission::load(&sources, None).map_err(|e| {
            e.problems
                .iter()
                .map(|p| p.to_string())
                .collect::<Vec<_>>()
                .join("; ")
        })?;
        Ok(Version {
            number,
            project: Arc::new(project),
            files,
        })
    }

    /// What names this version on the downlink: [`digest`] of its files.
    pub fn digest(&self) -> [u8; 32] {
        digest(&self.files)
    }
}

/// The SHA-256 of a version's files, in path order whatever order they
/// were read in (each path and text with its length first): the same
/// files on board and on the ground give the same digest.
pub fn digest(files: &[(String, String)]) -> [u8; 32] {
    use sha2::{Digest as _, Sha256};
    let mut sorted: Vec<&(String, String)> = files.iter().collect();
    sorted.sort_by(|a, b| a.0.cmp(&b.0));
    let mut hash = Sha256::new();
    for (path, text) in sorted {
        hash.update((path.len() as u64).to_le_bytes());
        hash.update(path.as_bytes());
        hash.update((text.len() as u64).to_le_bytes());
        hash.update(text.as_bytes());
    }
    hash.finalize().into()
}

/// A proof to run beside the supervision: the new version taken over
/// from `state` of the running project `old`.
pub struct Proof {
    pub id: u64,
    pub old: Arc<Project>,
    pub state: State,
    pub version: Arc<Version>,
}

/// A proof's answer.
#[derive(Debug)]
pub struct Proved {
    pub id: u64,
    /// The state it proved from.
    pub state: State,
    /// Why the version may not take over from there (empty: it may).
    pub refusals: Vec<String>,
}

impl Proof {
    /// Maps the state onto the version and explores it from there (one
    /// thread, no symmetry: the explorer starts from one given state).
    pub fn run(&self) -> Proved {
        let options = Options {
            each_net: false,
            alone: false,
            threads: 1,
            ..Options::default()
        };
        let refusals =
            match nets::version::swap(&self.old, &self.state, &self.version.project, &options) {
                Ok(_) => Vec::new(),
                Err(why) => why.iter().map(ToString::to_string).collect(),
            };
        Proved {
            id: self.id,
            state: self.state.clone(),
            refusals,
        }
    }
}

/// What became of an offered version, to print, record and show.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Report {
    /// Being proved from the running state.
    Proving { number: u32 },
    /// The state moved while it was proved: proved again from the new one.
    ProvingAgain { number: u32, attempt: u32 },
    /// A newer version was offered before this one took over.
    Superseded { number: u32, by: u32 },
    /// It took over at step `seq`.
    Swapped { number: u32, seq: u64 },
    /// It may not take over; the running version goes on.
    Refused { number: u32, reasons: Vec<String> },
}

impl std::fmt::Display for Report {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Report::Proving { number } => {
                write!(f, "version {number}: proving it from the running state")
            }
            Report::ProvingAgain { number, attempt } => write!(
                f,
                "version {number}: the state moved while it was proved; proving again ({attempt} of {PROOFS_AT_MOST})"
            ),
            Report::Superseded { number, by } => {
                write!(f, "version {number}: given up for version {by}, offered since")
            }
            Report::Swapped { number, seq } => write!(
                f,
                "version {number} took over at step {seq}, the marking, timers and pending calls kept"
            ),
            Report::Refused { number, reasons } => {
                write!(f, "version {number} refused, the running version goes on:")?;
                for r in reasons {
                    write!(f, "\n  - {r}")?;
                }
                Ok(())
            }
        }
    }
}

/// The versions offered to a running supervision.
#[derive(Default)]
pub struct Versions {
    /// The running version's number.
    current: u32,
    /// The last number given.
    last: u32,
    next_proof: u64,
    /// The version waiting for its proof, the proof's id, its attempt.
    offered: Option<(Arc<Version>, u64, u32)>,
    proofs: VecDeque<Proof>,
    reports: VecDeque<Report>,
}

impl Versions {
    /// The running version's number (0: the one the run started with).
    pub fn current(&self) -> u32 {
        self.current
    }

    /// The number the next offered version gets.
    pub fn next_number(&self) -> u32 {
        self.last + 1
    }

    /// A version is being proved.
    pub fn pending(&self) -> bool {
        self.offered.is_some()
    }

    /// A new version of the project `player` runs: refused at once if it
    /// changes what the gateway holds, else its proof is queued. A version
    /// still being proved is given up for it.
    pub fn offer(&mut self, project: Arc<Project>, files: Files, player: &Player) {
        self.last += 1;
        let number = self.last;
        if let Some((old, _, _)) = self.offered.take() {
            self.reports.push_back(Report::Superseded {
                number: old.number,
                by: number,
            });
        }
        self.proofs.clear();
        let fixed = fixed_changes(player.project(), &project);
        if !fixed.is_empty() {
            self.reports.push_back(Report::Refused {
                number,
                reasons: fixed,
            });
            return;
        }
        let version = Arc::new(Version {
            number,
            project,
            files,
        });
        self.reports.push_back(Report::Proving { number });
        self.prove(version, 1, player);
    }

    /// The next proof to run.
    pub fn poll_proof(&mut self) -> Option<Proof> {
        self.proofs.pop_front()
    }

    /// A proof's answer, at a step boundary where `player` runs: the
    /// version to take over now, if the proof holds for the state the
    /// player is in.
    pub fn proved(&mut self, proved: Proved, player: &Player) -> Option<Arc<Version>> {
        let (version, id, attempt) = self.offered.take()?;
        if id != proved.id {
            // The answer to a proof given up: keep waiting for the last.
            self.offered = Some((version, id, attempt));
            return None;
        }
        if !proved.refusals.is_empty() {
            self.reports.push_back(Report::Refused {
                number: version.number,
                reasons: proved.refusals,
            });
            return None;
        }
        if !same_but_time(&proved.state, player.state()) {
            if attempt >= PROOFS_AT_MOST {
                self.reports.push_back(Report::Refused {
                    number: version.number,
                    reasons: vec![format!(
                        "the state moved during each of {PROOFS_AT_MOST} proofs: offer it again when the vehicle is steadier"
                    )],
                });
                return None;
            }
            self.reports.push_back(Report::ProvingAgain {
                number: version.number,
                attempt: attempt + 1,
            });
            self.prove(version, attempt + 1, player);
            return None;
        }
        Some(version)
    }

    /// The version took over at step `seq` (or, `refusals` not empty,
    /// could not be restored after all).
    pub fn took_over(&mut self, version: &Version, seq: u64, refusals: Vec<String>) {
        if refusals.is_empty() {
            self.current = version.number;
            self.reports.push_back(Report::Swapped {
                number: version.number,
                seq,
            });
        } else {
            self.reports.push_back(Report::Refused {
                number: version.number,
                reasons: refusals,
            });
        }
    }

    /// What became of the versions offered, in order.
    pub fn poll_report(&mut self) -> Option<Report> {
        self.reports.pop_front()
    }

    fn prove(&mut self, version: Arc<Version>, attempt: u32, player: &Player) {
        self.next_proof += 1;
        let id = self.next_proof;
        self.proofs.push_back(Proof {
            id,
            old: player.project().clone(),
            state: player.state().clone(),
            version: version.clone(),
        });
        self.offered = Some((version, id, attempt));
    }
}

/// Two states equal but for their time.
fn same_but_time(a: &State, b: &State) -> bool {
    let now = a.now.max(b.now);
    let (mut a, mut b) = (a.clone(), b.clone());
    (a.now, b.now) = (now, now);
    a == b
}

/// What `new` changes that the gateway around the player holds: the
/// programs and their functions, the team's vehicles.
pub fn fixed_changes(old: &Project, new: &Project) -> Vec<String> {
    let mut why = Vec::new();
    let same_function = |f: &nets::model::Function, g: &nets::model::Function| {
        f.name == g.name && f.args == g.args && f.returns == g.returns
    };
    let same_programs = old.programs.len() == new.programs.len()
        && old.programs.iter().zip(&new.programs).all(|(a, b)| {
            a.name == b.name
                && a.functions.len() == b.functions.len()
                && a.functions
                    .iter()
                    .zip(&b.functions)
                    .all(|(f, g)| same_function(f, g))
        });
    if !same_programs {
        why.push(
            "its [programs] differ from the running version's (programs, functions, args, returns): the program server keeps the running ones, so programs change with a restart of `petrel run`"
                .to_owned(),
        );
    }
    let same_team = old.vehicles.len() == new.vehicles.len()
        && old.vehicles.iter().zip(&new.vehicles).all(|(a, b)| {
            (&a.name, a.system, a.component, &a.profile, &a.link)
                == (&b.name, b.system, b.component, &b.profile, &b.link)
        });
    if !same_team {
        why.push(
            "its [[vehicle]] team differs from the running version's (names, ids, profiles, links): the links and commanders are the running ones, so the team changes with a restart of `petrel run`"
                .to_owned(),
        );
    }
    why
}

#[cfg(test)]
#[path = "version_tests.rs"]
mod tests;
