//! `petrel replay FILE.mcap PROJECT`: the recorded Supervisor inputs fed
//! back in order — frames from `/mavlink/raw`, ticks, results and program
//! events from `/petrel/inputs` — so every decision of the flight is made
//! again; with `--check-against`, each step's effects and digest are
//! compared with the recorded ones and the first difference is reported.

use std::io::{BufWriter, IsTerminal, Write};
use std::time::{Duration, Instant};

use serde_json::json;

use super::{print_step, Args};
use crate::cli::timeline::Timeline;
use crate::cli::{Outcome, VerbResult};
use petrel_core::supervisor::{Input, Supervisor};
use petrel_core::version::Version;
use petrel_record::check::{compare, Difference};
use petrel_record::layout::Input as Recorded;
use petrel_record::read;

/// A recording read, with the profile and project it replays with.
pub(crate) struct Opened {
    pub rec: read::Recording,
    /// The time of the player's start (step 0).
    pub origin: nets::Micros,
    /// The elaboration lanes the flight ran with: one, or one per vehicle
    /// of a team (`team::lanes`, as `run` builds them).
    pub lanes: Vec<petrel_core::supervisor::Lane>,
    pub project: std::sync::Arc<nets::Project>,
    /// The versions of the project that took over in flight, loaded from
    /// their recorded files, by the step they took over at.
    pub versions: std::collections::BTreeMap<u64, std::sync::Arc<Version>>,
    /// How long reading the file took.
    pub reading: Duration,
}

/// Reads `file` (saying what a file cut short still holds) and loads
/// `project` with the profile the flight ran with (or `profile`); `None`
/// when the profile does not load (already reported).
pub(crate) fn open(
    file: &std::path::Path,
    project: &std::path::Path,
    profile: Option<&str>,
    expectations: bool,
) -> Result<Option<Opened>, miette::Report> {
    let name = file.display().to_string();
    let bytes = petrel_record::read::whole(file)
        .map_err(|e| miette::miette!("cannot read the MCAP recording {name}: {e}"))?;
    let reading = Instant::now();
    let rec = read::read(&bytes, expectations).map_err(|e| miette::miette!("{name}: {e}"))?;
    let reading = reading.elapsed();
    drop(bytes);
    if !rec.finished {
        // What a file cut short still holds, said before it replays.
        let span = match (rec.inputs.first(), rec.inputs.last()) {
            (Some(a), Some(b)) => nets::time::seconds(b.1.saturating_sub(a.1)),
            _ => 0.0,
        };
        let how = match &rec.cut {
            Some(cut) => format!("it ends in a torn record ({cut}): everything before it"),
            None => {
                "it has no summary (the gateway did not stop cleanly): every closed chunk".into()
            }
        };
        say!(
            "warning: {name} was cut short; {how} is recovered: {} steps, {} frames, {span:.1} s of flight; it replays up to there (`petrel recover` writes a clean, indexed copy)",
            rec.inputs.len(),
            rec.frame_count()
        );
    }
    if rec.dropped > 0 {
        say!(
            "warning: the recorder dropped {} entries of this flight (it fell behind)",
            rec.dropped
        );
    }
    let Some(&(0, origin, Recorded::Start)) = rec.inputs.first() else {
        return Err(miette::miette!(
            "{name}: the inputs log does not begin with the player's start (step 0)"
        ));
    };
    let setup = rec.setup.clone().unwrap_or_default();
    let config = setup.config.clone();
    // The profile the flight ran with, as recorded, unless told otherwise;
    // recordings from before the layers were recorded name a built-in one.
    let profile = if profile.is_none() && !setup.layers.is_empty() {
        crate::cli::loaded(&petrel_core::profile::Layers {
            name: setup.profile.clone(),
            layers: setup.layers.clone(),
        })
    } else {
        let builtin = match setup.profile.as_str() {
            p @ ("ardupilot" | "px4") => Some(p),
            _ => None,
        };
        let choice = profile.or(builtin);
        super::super::events::load_profile(choice, Some(project), rec.tlog())?
            .ok()
            .map(|(p, _)| p)
    };
    let Some(profile) = profile else {
        return Ok(None);
    };
    let dir = project;
    let project = petrel_core::project::load_with(dir, &petrel_core::project::catalog(&profile))?;
    let family = if setup.layers.is_empty() {
        if setup.profile == "px4" {
            "px4"
        } else {
            "ardupilot"
        }
    } else {
        petrel_core::team::family(&setup.layers)
    };
    let lanes = petrel_core::team::lanes(&project, dir, &profile, family, &config)?;
    let catalog = petrel_core::project::catalog(&profile);
    let mut versions = std::collections::BTreeMap::new();
    for (seq, _, input) in &rec.inputs {
        if let Recorded::Version { number, files } = input {
            versions.insert(*seq, load_version(&name, *number, files, &catalog)?);
        }
    }
    Ok(Some(Opened {
        rec,
        origin,
        lanes,
        project,
        versions,
        reading,
    }))
}

/// A version that took over in flight, loaded from the files `file`
/// recorded for it.
fn load_version(
    file: &str,
    number: u32,
    files: &[(String, String)],
    catalog: &nets::load::Catalog,
) -> Result<std::sync::Arc<Version>, miette::Report> {
    let sources: std::collections::BTreeMap<String, String> = files.iter().cloned().collect();
    // A mission project's version compiles its mission as the run did.
    let project = petrel_mission::load(&sources, Some(catalog)).map_err(|e| {
        miette::Report::new(petrel_core::project::Unloadable {
            dir: format!("{file}: version {number}").into(),
            problems: e.problems,
        })
    })?;
    Ok(std::sync::Arc::new(Version {
        number,
        project: std::sync::Arc::new(project),
        files: files.to_vec(),
    }))
}

/// The Supervisor input a recorded input stands for.
pub(crate) fn input<'a>(
    opened: &'a Opened,
    seq: u64,
    input: &'a Recorded,
) -> Result<Input<'a>, String> {
    let rec = &opened.rec;
    Ok(match input {
        Recorded::Frame(index) => {
            let Some((_, bytes)) = rec.frame(*index) else {
                return Err(format!(
                    "step {seq} refers to raw frame {index}, which is not in the recording"
                ));
            };
            Input::Frame(bytes)
        }
        Recorded::Tick => Input::Tick,
        Recorded::Result { id, outcome } => Input::Result {
            id: *id,
            outcome: outcome.clone(),
        },
        Recorded::Event(e) => Input::Event(e.clone()),
        Recorded::Answer { id, choice } => Input::Answer {
            id: *id,
            choice: choice.clone(),
        },
        Recorded::Version { .. } => match opened.versions.get(&seq) {
            Some(version) => Input::Version(version),
            None => return Err(format!("step {seq}'s version was not loaded")),
        },
        Recorded::Start => return Err(format!("a second start at step {seq}")),
        Recorded::Replica(_) => {
            return Err(format!(
                "step {seq} is a ground mirror's call, not a Supervisor input"
            ))
        }
    })
}

pub fn run(args: Args) -> VerbResult {
    let name = args.file.display().to_string();
    let Some(mut opened) = open(
        &args.file,
        &args.project,
        args.profile.as_deref(),
        args.check_against,
    )?
    else {
        return Ok(Outcome::BadInput);
    };
    let (origin, reading) = (opened.origin, opened.reading);
    let lanes = std::mem::take(&mut opened.lanes);
    let mut project = opened.project.clone();
    let rec = &opened.rec;
    let io = |e: std::io::Error| miette::miette!("cannot write the output: {e}");
    let mut out = Timeline {
        out: BufWriter::new(std::io::stdout().lock()),
        json: args.json,
        origin,
    };
    let (mut sup, start) = Supervisor::start_lanes(project.clone(), lanes, origin);
    out.effects(&project, &start.effects).map_err(io)?;
    let mut difference = None;
    if args.check_against {
        difference = compare(&project, &start, &sup.player().digest(), rec.steps.get(&0));
    }
    let progress = std::io::stderr().is_terminal() && !args.json;
    let wall = Instant::now();
    let mut last = origin;
    let mut events = 0usize;
    let mut frames = 0usize;
    let mut steps = 0usize;
    for (i, (seq, time, input)) in rec.inputs.iter().enumerate().skip(1) {
        if difference.is_some() {
            break;
        }
        if *seq != sup.seq() + 1 {
            let what = format!(
                "the recording jumps from step {} to step {seq} (the recorder dropped steps): replay stops here",
                sup.seq()
            );
            say!("warning: {what}");
            if args.check_against {
                difference = Some(Difference {
                    seq: sup.seq() + 1,
                    time: *time,
                    what,
                });
            }
            break;
        }
        let time = *time;
        if let Some(speed) = args.speed {
            let due = Duration::from_secs_f64(time.saturating_sub(origin) as f64 / 1e6 / speed);
            if let Some(wait) = due.checked_sub(wall.elapsed()) {
                out.out.flush().map_err(io)?;
                std::thread::sleep(wait);
            }
        }
        if let Recorded::Replica(json) = input {
            // A ground mirror's recording: the replica's calls on its player.
            let call = petrel_core::mirror::call::call_from(json).ok_or_else(|| {
                miette::miette!("{name}: step {seq}: not a call of the replica: {json}")
            })?;
            let step = sup
                .play_with(time, |p| petrel_core::mirror::call::apply(p, time, &call))
                .map_err(|e| miette::miette!("{name}: step {seq}: {e}"))?;
            if !std::sync::Arc::ptr_eq(sup.player().project(), &project) {
                // The replica took over a new version (`Call::Version`).
                project = sup.player().project().clone();
            }
            if let petrel_core::mirror::call::Call::Record { inputs, .. } = &call {
                print_record_inputs(&mut out, &project, inputs).map_err(io)?;
            }
            steps += 1;
            out.effects(&project, &step.effects).map_err(io)?;
            if args.check_against {
                difference = compare(&project, &step, &sup.player().digest(), rec.steps.get(seq));
            }
            last = time;
            continue;
        }
        let input =
            self::input(&opened, *seq, input).map_err(|e| miette::miette!("{name}: {e}"))?;
        if matches!(input, Input::Frame(_)) {
            frames += 1;
        }
        // Recorded answers and program events are inputs: print them as
        // `petrel play` prints its script's.
        match &input {
            Input::Result { id, outcome } => {
                let (fields, text) = match outcome {
                    nets::Outcome::Done(p) => (
                        json!({"reply": id, "params": petrel_record::layout::outcome_json(outcome)["done"]}),
                        format!("REPLY  {id} done {}", nets::Value::Map(p.clone())),
                    ),
                    nets::Outcome::Failed(r) => (
                        json!({"reply": id, "failed": r}),
                        format!("REPLY  {id} failed {r:?}"),
                    ),
                };
                out.input(time, "reply", fields, &text).map_err(io)?;
            }
            Input::Event(e) => out
                .event(&project, time, e, Some(json!({"program": true})))
                .map_err(io)?,
            Input::Answer { id, choice } => out
                .input(
                    time,
                    "answer",
                    json!({"answer": id, "choice": choice}),
                    &format!("ANSWER #{id} {choice}"),
                )
                .map_err(io)?,
            Input::Version(v) => out
                .input(
                    time,
                    "version",
                    json!({"version": v.number}),
                    &format!("VERSION {} takes over", v.number),
                )
                .map_err(io)?,
            Input::Frame(_) | Input::Tick => {}
        }
        let step = sup.step(time, input);
        if !std::sync::Arc::ptr_eq(sup.player().project(), &project) {
            project = sup.player().project().clone();
        }
        steps += 1;
        events += step.events.len();
        print_step(&mut out, &project, &step).map_err(io)?;
        if args.check_against {
            difference = compare(&project, &step, &sup.player().digest(), rec.steps.get(seq));
        }
        last = time;
        if progress && i % 20_000 == 0 {
            say_part!(
                "\r{:>5.1}% {} steps",
                100.0 * i as f64 / rec.inputs.len() as f64,
                i
            );
        }
    }
    if progress {
        say!("\r100.0% {} steps", rec.inputs.len());
    }
    if difference.is_none() && rec.dropped_steps > 0 && steps + 1 == rec.inputs.len() {
        // Every recorded step replayed, but steps were dropped after them.
        let what = format!(
            "the recorder dropped {} steps after step {} (it fell behind): replay stops here",
            rec.dropped_steps,
            sup.seq()
        );
        say!("warning: {what}");
        if args.check_against {
            difference = Some(Difference {
                seq: sup.seq() + 1,
                time: last,
                what,
            });
        }
    }
    let player = sup.player();
    out.end(last, player).map_err(io)?;
    if let (Some(d), true) = (&difference, args.json) {
        writeln!(
            out.out,
            "{}",
            json!({"check": "differ", "seq": d.seq, "time_us": d.time, "t": nets::time::seconds(d.time.saturating_sub(origin)), "what": d.what})
        )
        .map_err(io)?;
    }
    out.out.flush().map_err(io)?;
    say!(
        "replayed {steps} steps ({frames} frames, {} bad) in {:.3} s after reading the recording in {:.3} s; {events} events; {} commands and calls left unanswered",
        sup.bad_frames,
        wall.elapsed().as_secs_f64(),
        reading.as_secs_f64(),
        player.state().pending.len()
    );
    if !rec.links.is_empty() {
        // A team's recording says which link each frame came in on.
        let mut per_link: std::collections::BTreeMap<u64, u64> = Default::default();
        for link in rec.links.values() {
            *per_link.entry(*link).or_default() += 1;
        }
        let text: Vec<String> = per_link
            .iter()
            .map(|(l, n)| format!("link {l}: {n}"))
            .collect();
        say!("frames by link: {}", text.join(", "));
    }
    if !args.check_against {
        return Ok(Outcome::Success);
    }
    match difference {
        Some(d) => {
            say!(
                "check: first difference at step {} (t = {:.3} s, time_us {}): {}",
                d.seq,
                nets::time::seconds(d.time.saturating_sub(origin)),
                d.time,
                d.what
            );
            Ok(Outcome::Failed)
        }
        None => {
            say!(
                "check: the {} replayed steps match the recording (effects and digests)",
                steps + 1
            );
            Ok(Outcome::Success)
        }
    }
}

/// The inputs of a downlink step record a mirror's replica played, printed
/// as `petrel mirror` prints them.
fn print_record_inputs<W: Write>(
    out: &mut Timeline<W>,
    project: &nets::Project,
    inputs: &[petrel_core::mirror::record::Input],
) -> std::io::Result<()> {
    use petrel_core::mirror::record::Input as Downlink;
    for input in inputs {
        match input {
            Downlink::Elaborated { time, event, .. }
            | Downlink::Program { time, event }
            | Downlink::Answer { time, event } => out.event(project, *time, event, None)?,
            Downlink::Result { time, id, outcome } => {
                let (ok, text) = match outcome {
                    nets::Outcome::Done(_) => (true, "done".to_owned()),
                    nets::Outcome::Failed(r) => (false, format!("failed: {r}")),
                };
                out.input(
                    *time,
                    "reply",
                    json!({"id": id, "ok": ok}),
                    &format!("REPLY  #{id} {text}"),
                )?;
            }
            Downlink::Answered { time, id, choice } => out.input(
                *time,
                "answer",
                json!({"answer": id, "choice": choice}),
                &format!("ANSWER #{id} {choice}"),
            )?,
            Downlink::Version { time, number, .. } => out.input(
                *time,
                "version",
                json!({"version": number}),
                &format!("VERSION {number} takes over"),
            )?,
        }
    }
    Ok(())
}
