//! `petrel check --pnml FILE`: explores the reachability graph of a PNML
//! place/transition net and reports its states, edges, dead markings,
//! safety, the most tokens in a place, shortest counterexamples and loops.
//! `petrel check PROJECT` runs the project-level verifier
//! (`check_project.rs`).
//!
//! Exit status: 0 when the net is 1-safe and has no dead marking, 1 when it
//! is not (or the state limit stopped the exploration first), 2 for bad input.

use crate::preflight::threads;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Instant;

use nets::verify::explore::{explore, Completion, Engine, Exploration, Options};
use nets::verify::pnml::read_ptnet;
use serde_json::json;

use super::{Outcome, VerbResult};

#[derive(clap::Args)]
#[command(group(clap::ArgGroup::new("input").required(true).args(["project", "pnml"])))]
pub struct Args {
    /// A Petrel project folder (holding project.toml).
    pub project: Option<PathBuf>,
    /// Check a PNML place/transition net (ISO/IEC 15909-2) instead of a project.
    #[arg(long, value_name = "FILE")]
    pub pnml: Option<PathBuf>,
    /// Print one JSON object instead of a report for people.
    #[arg(long)]
    pub json: bool,
    /// Threads exploring the state space [default: the number of cores].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=16))]
    pub threads: Option<u16>,
    /// Stop after storing this many markings, or a project's states
    /// (guards against unbounded nets) [default: 100,000,000 markings for
    /// --pnml; 1,000,000 states for a project, the limit `petrel run`
    /// checks with].
    #[arg(long, value_name = "N")]
    pub max_states: Option<u64>,
    /// The elaboration profile whose events the project hears (their
    /// categories, and what they produce): ardupilot, px4 or a FILE.toml
    /// extending the ArduPilot one [default: `[gateway] profile`, else
    /// ardupilot, as `petrel run`].
    #[arg(long, conflicts_with = "pnml")]
    pub profile: Option<String>,
    /// How many loops (cyclic strongly connected components) to list.
    #[arg(long, value_name = "N", default_value_t = 5)]
    pub loops: usize,
    /// Skip the loop analysis (it keeps the reachability graph's arcs:
    /// 4 bytes per arc and 4 per marking more).
    #[arg(long)]
    pub no_loops: bool,
    /// A team project: explore every vehicle, not one representative per
    /// orbit of interchangeable vehicles.
    #[arg(long, conflicts_with = "pnml")]
    pub no_symmetry: bool,
    /// A team project: explore every input in every state, not stubborn
    /// sets of them (partial-order reduction).
    #[arg(long, conflicts_with = "pnml")]
    pub no_por: bool,
}

/// `--max-states`' default for `--pnml`.
const PNML_MAX_STATES: u64 = 100_000_000;

/// A project check's limit: `--max-states` when given (above the
/// pre-flight's too: a ground check may take longer), else `petrel run`'s.
fn project_limit(asked: Option<u64>) -> usize {
    asked.map_or(nets::verify::project::MAX_STATES, |n| {
        usize::try_from(n).unwrap_or(usize::MAX)
    })
}

pub fn run(args: Args) -> VerbResult {
    let Some(file) = &args.pnml else {
        let Some(dir) = &args.project else {
            return Err(miette::miette!("give a project folder or --pnml FILE"));
        };
        return super::check_project::run(
            dir,
            args.profile.as_deref(),
            args.json,
            project_limit(args.max_states),
            threads(args.threads),
            super::check_project::Reductions {
                symmetry: !args.no_symmetry,
                partial_order: !args.no_por,
            },
        );
    };
    if args.project.is_some() {
        return Err(miette::miette!(
            "give either a project or --pnml FILE, not both"
        ));
    }
    let text = std::fs::read_to_string(file)
        .map_err(|e| miette::miette!("cannot read {}: {e}", file.display()))?;
    let net = read_ptnet(&text).map_err(|e| miette::miette!("{}:{e}", file.display()))?;
    let threads = threads(args.threads);
    let start = Instant::now();
    let meter = super::progress::Progress::new(start);
    let report = |states: u64| meter.report(states);
    let options = Options {
        threads,
        max_states: args.max_states.unwrap_or(PNML_MAX_STATES),
        progress: if std::io::stderr().is_terminal() {
            Some(&report)
        } else {
            None
        },
        // the loop analysis reads the successors found by the exploration
        // instead of firing every transition again
        keep_arcs: !args.no_loops,
        ..Options::default()
    };
    let x = explore(&net, &options);
    let loops = if args.no_loops || x.summary.completion != Completion::Complete {
        None
    } else {
        Some(x.loops(args.loops))
    };
    let seconds = start.elapsed().as_secs_f64();
    meter.finish();
    let verdict = Verdict::of(&x);
    if args.json {
        print_json(&x, loops.as_ref(), &verdict, seconds);
    } else {
        print_report(
            &x,
            &net.name,
            net.places.len(),
            net.transitions.len(),
            loops.as_ref(),
            &verdict,
            seconds,
        );
    }
    Ok(if verdict.holds() {
        Outcome::Success
    } else {
        Outcome::Failed
    })
}

/// What the exploration proved, and the warnings for people.
struct Verdict {
    complete: bool,
    safe: bool,
    deadlock_free: bool,
    warnings: Vec<String>,
}

impl Verdict {
    fn of(x: &Exploration) -> Verdict {
        let s = &x.summary;
        let mut warnings = Vec::new();
        match s.completion {
            Completion::Complete => {}
            Completion::StateLimit => warnings.push(format!(
                "state limit reached after {} markings: the net may be unbounded; nothing is proven (raise --max-states)",
                s.states
            )),
            Completion::TokenLimit => {
                warnings.push("a place would hold more than 4294967295 tokens: the net is unbounded".to_string())
            }
        }
        if s.completion == Completion::Complete {
            const SHOWN: usize = 10;
            let names = x.names(&s.never_fired);
            for n in names.iter().take(SHOWN) {
                warnings.push(format!("transition `{n}` can never fire"));
            }
            if names.len() > SHOWN {
                warnings.push(format!(
                    "... and {} more transitions that can never fire",
                    names.len() - SHOWN
                ));
            }
        }
        Verdict {
            complete: s.completion == Completion::Complete,
            safe: s.safe,
            deadlock_free: s.dead_markings == 0,
            warnings,
        }
    }

    fn holds(&self) -> bool {
        self.complete && self.safe && self.deadlock_free
    }
}

fn engine_name(e: Engine) -> &'static str {
    match e {
        Engine::Bits => "bits",
        Engine::Counts8 => "counts8",
        Engine::Counts16 => "counts16",
        Engine::Counts32 => "counts32",
    }
}

fn print_json(
    x: &Exploration,
    loops: Option<&nets::verify::explore::Loops>,
    v: &Verdict,
    seconds: f64,
) {
    let s = &x.summary;
    let listed: Vec<serde_json::Value> = loops
        .map(|l| {
            l.listed
                .iter()
                .map(|c| json!({"states": c.states, "prefix": x.names(&c.prefix), "cycle": x.names(&c.cycle)}))
                .collect()
        })
        .unwrap_or_default();
    let out = json!({
        "states": s.states,
        "edges": s.edges,
        "dead_markings": s.dead_markings,
        "safe": s.safe,
        "max_tokens": s.max_tokens,
        "deadlock_example": x.deadlock_example().map(|p| x.names(&p)),
        "unsafe_example": x.unsafe_example().map(|p| x.names(&p)),
        "loops": listed,
        "cyclic_components": loops.map(|l| l.cyclic_components),
        "warnings": v.warnings,
        "complete": v.complete,
        "engine": engine_name(s.engine),
        "threads": s.threads,
        "seconds": seconds,
    });
    show!("{out}");
}

fn sequence(names: &[String]) -> String {
    if names.is_empty() {
        "(the initial marking)".to_string()
    } else {
        names.join(" ")
    }
}

fn print_report(
    x: &Exploration,
    name: &str,
    places: usize,
    transitions: usize,
    loops: Option<&nets::verify::explore::Loops>,
    v: &Verdict,
    seconds: f64,
) {
    let s = &x.summary;
    let ok = |b: bool| if b { "yes" } else { "NO" };
    show!("net {name}: {places} places, {transitions} transitions");
    show!("  states          {}", s.states);
    show!("  edges           {}", s.edges);
    show!("  dead markings   {}", s.dead_markings);
    show!("  max tokens      {}", s.max_tokens);
    show!("  1-safe          {}", ok(s.safe));
    show!("  deadlock-free   {}", ok(s.dead_markings == 0));
    if let Some(p) = x.unsafe_example() {
        show!("  unsafe after    {}", sequence(&x.names(&p)));
    }
    if let Some(p) = x.deadlock_example() {
        show!("  deadlock after  {}", sequence(&x.names(&p)));
    }
    if let Some(l) = loops {
        if l.cyclic_components == 0 {
            show!("  loops           none");
        } else {
            show!(
                "  loops           {} cyclic component(s), the largest of {} markings",
                l.cyclic_components,
                l.largest
            );
        }
        for c in &l.listed {
            show!(
                "    after {}: {} (back to the same marking)",
                sequence(&x.names(&c.prefix)),
                x.names(&c.cycle).join(" ")
            );
        }
    }
    for w in &v.warnings {
        show!("  warning: {w}");
    }
    show!(
        "  time            {seconds:.3} s ({} engine, {} thread(s), {:.1} bytes per marking)",
        engine_name(s.engine),
        s.threads,
        s.stored_bytes as f64 / s.states.max(1) as f64
    );
    show!(
        "{}",
        if v.holds() {
            "OK: 1-safe and deadlock-free"
        } else if !v.complete {
            "INCONCLUSIVE: the exploration stopped before the end"
        } else {
            "FAILED"
        }
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_projects_limit_is_run_s_unless_asked_above_or_below() {
        assert_eq!(project_limit(None), nets::verify::project::MAX_STATES);
        assert_eq!(project_limit(Some(100)), 100);
        assert_eq!(project_limit(Some(2_000_000)), 2_000_000);
    }
}
