//! `petrel check PROJECT`: the project-level verifier's report, for people
//! or as JSON (`nets::verify::project`).
//!
//! The project is loaded as `petrel run` loads it: knowing the events its
//! elaboration profile produces (their categories, which decide priorities
//! and the catastrophic lockout), so that the check explores what the
//! gateway will play.

use std::io::IsTerminal;
use std::path::Path;
use std::time::Instant;

use nets::verify::project::{check, Options, ProjectReport, Report};
use serde_json::{json, Value};

use super::{Outcome, VerbResult};

/// The reductions of a team's exploration asked for (`--no-symmetry`,
/// `--no-por` turn them off).
#[derive(Debug, Clone, Copy)]
pub struct Reductions {
    pub symmetry: bool,
    pub partial_order: bool,
}

/// Checks a project with the elaboration profile `profile` (`--profile`;
/// else the project's `[gateway] profile`, else ArduPilot's); exit 0 when
/// every property holds, 1 when one does not, 2 for bad input.
pub fn run(
    dir: &Path,
    profile: Option<&str>,
    as_json: bool,
    max_states: usize,
    threads: usize,
    reductions: Reductions,
) -> VerbResult {
    let Some((layers, profile)) = crate::cli::project_profile(dir, profile)? else {
        return Ok(Outcome::BadInput);
    };
    let (project, files) =
        petrel_core::project::load_read(dir, &petrel_core::project::catalog(&profile))?;
    let name = if project.name.is_empty() {
        dir.file_name().map_or_else(
            || dir.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        )
    } else {
        project.name.clone()
    };
    let start = Instant::now();
    let meter = super::progress::Progress::new(start);
    let report_progress = |states: usize| meter.report(states as u64);
    let options = Options {
        max_states,
        each_net: true,
        alone: true,
        threads,
        symmetry: reductions.symmetry,
        partial_order: reductions.partial_order,
        compare_unreduced: false,
        proviso: Default::default(),
        steps: Default::default(),
        progress: if std::io::stderr().is_terminal() {
            Some(&report_progress)
        } else {
            None
        },
    };
    let report = check(&project, &options);
    let seconds = start.elapsed().as_secs_f64();
    meter.finish();
    if as_json {
        let mut obj = report_json(&report.project, seconds);
        let nets: serde_json::Map<String, Value> = report
            .nets
            .iter()
            .enumerate()
            .map(|(i, (name, r))| {
                let mut obj = report_json(r, seconds);
                // The net alone: same keys, no time of its own.
                if let Some(alone) = report.alone.get(i) {
                    let mut alone = report_json(alone, seconds);
                    if let Some(map) = alone.as_object_mut() {
                        map.remove("seconds");
                    }
                    obj["alone"] = alone;
                }
                (name.clone(), obj)
            })
            .collect();
        obj["nets"] = Value::Object(nets);
        obj["holds"] = json!(report.holds());
        if let Some(reduction) = reduction_json(&report.project) {
            obj["reduction"] = reduction;
        }
        write_out(&format!("{obj}\n"))?;
    } else {
        write_out(&human(&name, &report, seconds))?;
    }
    // The same check as `petrel run`'s pre-flight one: it starts without
    // exploring again.
    let inputs = crate::preflight::Inputs {
        files: &files,
        layers: &layers.layers,
    };
    // Said at a terminal only, as the progress is: a script's stderr stays
    // empty when all is well.
    let remembered = crate::preflight::remember_held(&inputs, &options, &report);
    if remembered && !as_json && std::io::stderr().is_terminal() {
        say!("remembered: `petrel run` and `petrel demo` start without exploring it again while the nets, the profile and Petrel stay the same (--recheck explores anyway)");
    }
    Ok(if report.holds() {
        Outcome::Success
    } else {
        Outcome::Failed
    })
}

fn write_out(text: &str) -> Result<(), miette::Report> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        // A reader that stopped reading (`| head`) is not an error.
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => Err(miette::miette!("cannot write the report: {e}")),
        Ok(()) => Ok(()),
    }
}

/// One report as the JSON object the issue defines.
pub fn report_json(r: &Report, seconds: f64) -> Value {
    let mut out = json!({
        "states": r.states,
        "edges": r.edges,
        "dead_markings": r.dead_markings,
        "safe": r.safe,
        "max_tokens": r.max_tokens,
        // `null` when there is none; `[]` is the initial state itself.
        "deadlock_example": r.deadlock_example,
        "unsafe_example": r.unsafe_example,
        "livelocks": r.livelocks,
        "loops": r.loops,
        "relies": r.relies,
        "warnings": r.warnings,
        "complete": r.complete,
        "seconds": seconds,
    });
    // Teams only (docs/nets.md, "Teams of vehicles"): a shared resource two
    // vehicles hold at once.
    if !r.exclusion.is_empty() {
        out["exclusion"] = json!(r
            .exclusion
            .iter()
            .map(
                |x| json!({ "resource": x.resource, "vehicles": x.vehicles, "example": x.example })
            )
            .collect::<Vec<_>>());
    }
    out
}

/// A team's reductions, as JSON (`None` for a project without a team,
/// which is always explored whole).
fn reduction_json(r: &Report) -> Option<Value> {
    let x = &r.reduction;
    if x.group <= 1 && !x.partial_order && !x.order_free && x.notes.is_empty() {
        return None;
    }
    Some(json!({
        "symmetry": x.symmetry,
        "group": x.group,
        "partial_order": x.partial_order,
        "order_free": x.order_free,
        "notes": x.notes,
        "unreduced_states": x.unreduced_states,
    }))
}

/// A team's reductions, one line for people (nothing without a team).
fn reduction_line(out: &mut String, r: &Report) {
    let x = &r.reduction;
    if x.group <= 1 && !x.partial_order && !x.order_free && x.notes.is_empty() {
        return;
    }
    let mut ran = Vec::new();
    if x.group > 1 {
        let classes: Vec<String> = x.symmetry.iter().map(|c| c.join(", ")).collect();
        ran.push(format!(
            "symmetry of {} (a group of {}: {} states are orbits)",
            classes.join("; "),
            x.group,
            r.states
        ));
    }
    if x.partial_order {
        ran.push("partial order (stubborn sets)".to_owned());
    }
    if x.order_free {
        ran.push("states without the orders the player cannot tell apart".to_owned());
    }
    out.push_str(&format!(
        "  reductions       {}\n",
        if ran.is_empty() {
            "none".to_owned()
        } else {
            ran.join(", ")
        }
    ));
    if let Some(whole) = x.unreduced_states {
        out.push_str(&format!(
            "    {} states unreduced ({:.1}x)\n",
            whole,
            whole as f64 / r.states.max(1) as f64
        ));
    }
    for note in &x.notes {
        out.push_str(&format!("    {note}\n"));
    }
}

fn verdict(ok: bool) -> &'static str {
    if ok {
        "ok"
    } else {
        "FAILED"
    }
}

fn sequence(out: &mut String, steps: &[String]) {
    if steps.is_empty() {
        out.push_str("      (at the start)\n");
    }
    for (i, s) in steps.iter().enumerate() {
        out.push_str(&format!("      {:>2}. {s}\n", i + 1));
    }
}

fn section(out: &mut String, title: &str, r: &Report, loops: bool) {
    out.push_str(&format!(
        "{title}: {} states, {} steps{}\n",
        r.states,
        r.edges,
        if r.complete {
            ""
        } else {
            " (INCOMPLETE: state limit reached)"
        }
    ));
    out.push_str(&format!("  place safety     {}\n", verdict(r.safe)));
    if let Some(ex) = &r.unsafe_example {
        out.push_str("    a double token, reached by:\n");
        sequence(out, ex);
    }
    out.push_str(&format!(
        "  deadlocks        {}{}\n",
        verdict(r.dead_markings == 0),
        if r.dead_markings > 0 {
            format!(" ({} dead markings)", r.dead_markings)
        } else {
            String::new()
        }
    ));
    if let Some(ex) = &r.deadlock_example {
        out.push_str("    the first, reached by:\n");
        sequence(out, ex);
    }
    out.push_str(&format!(
        "  livelocks        {}\n",
        verdict(r.livelocks.is_empty())
    ));
    for l in &r.livelocks {
        sequence(out, l);
    }
    for x in &r.exclusion {
        out.push_str(&format!(
            "  mutual exclusion FAILED: `{}` held by {} at once, reached by:\n",
            x.resource,
            x.vehicles.join(" and ")
        ));
        sequence(out, &x.example);
    }
    if loops && !r.loops.is_empty() {
        out.push_str(&format!("  loops (information): {}\n", r.loops.len()));
        for l in &r.loops {
            out.push_str(&format!("    - {}\n", l.join("  ⟶  ")));
        }
    }
    if !r.relies.is_empty() {
        // By design, usually: the project level above is the verdict.
        out.push_str(&format!(
            "  nets relying on others (information): {}\n",
            r.relies.len()
        ));
        for w in &r.relies {
            out.push_str(&format!("    - {w}\n"));
        }
    }
    for w in &r.warnings {
        out.push_str(&format!("  warning: {w}\n"));
    }
}

/// One line for a net alone (the single-procedure level), with the
/// examples of what fails and its own warnings. What it shows alone and
/// not in its project (`in_project`) it owes to the other nets: said in
/// lower case, as information.
fn alone_section(out: &mut String, r: &Report, in_project: &Report) {
    let mut verdicts = vec![
        if r.safe {
            "safe"
        } else if in_project.safe {
            "a double token without the other nets"
        } else {
            "UNSAFE"
        },
        if r.dead_markings == 0 {
            "no deadlock"
        } else if in_project.dead_markings == 0 {
            "dead without the other nets"
        } else {
            "DEADLOCK"
        },
        if r.livelocks.is_empty() {
            "no livelock"
        } else if in_project.livelocks.is_empty() {
            "a livelock without the other nets"
        } else {
            "LIVELOCK"
        },
    ];
    if !r.complete {
        verdicts.push("INCOMPLETE: state limit reached");
    }
    out.push_str(&format!(
        "  alone: {} states, {} steps; {}\n",
        r.states,
        r.edges,
        verdicts.join(", ")
    ));
    if let Some(ex) = &r.unsafe_example {
        out.push_str("    alone, a double token, reached by:\n");
        sequence(out, ex);
    }
    if let Some(ex) = &r.deadlock_example {
        out.push_str(&format!(
            "    alone, {} dead markings; the first, reached by:\n",
            r.dead_markings
        ));
        sequence(out, ex);
    }
    for l in &r.livelocks {
        out.push_str("    alone, a livelock:\n");
        sequence(out, l);
    }
    // Transitions that never fire alone wait for the other nets: one line.
    let mut never = Vec::new();
    for w in &r.warnings {
        match w
            .strip_prefix("transition ")
            .and_then(|t| t.strip_suffix(" can never fire"))
        {
            Some(t) => never.push(t),
            None => out.push_str(&format!("    alone, warning: {w}\n")),
        }
    }
    if !never.is_empty() {
        out.push_str(&format!(
            "    alone, {} transitions never fire: {}\n",
            never.len(),
            never.join(", ")
        ));
    }
}

/// The report for people.
pub fn human(name: &str, report: &ProjectReport, seconds: f64) -> String {
    let mut out = String::new();
    section(&mut out, &format!("project {name}"), &report.project, true);
    reduction_line(&mut out, &report.project);
    for (i, (net, r)) in report.nets.iter().enumerate() {
        out.push('\n');
        let mut r = r.clone();
        // Warnings and information already printed for the project.
        r.warnings.retain(|w| !report.project.warnings.contains(w));
        r.relies.retain(|w| !report.project.relies.contains(w));
        section(&mut out, &format!("net {net}"), &r, true);
        if let Some(alone) = report.alone.get(i) {
            alone_section(&mut out, alone, &r);
        }
    }
    out.push_str(&format!(
        "\n{} in {:.3} s\n",
        if report.holds() {
            "every property holds"
        } else {
            "a property is violated"
        },
        seconds
    ));
    out
}
