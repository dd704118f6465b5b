//! `petrel replay FILE PROJECT`: replays recorded telemetry through
//! elaboration and the player, as `petrel run` would have on board. Commands
//! and program calls are printed, never sent.
//!
//! From a telemetry log (.tlog) it feeds the frames and ticks across gaps;
//! from a Petrel recording (.mcap) it feeds exactly the recorded inputs
//! (frames, ticks, command and program results, program events), so the
//! flight's decisions are reproduced, and `--check-against` compares every
//! step's effects and digest with the recorded ones.

use std::io::{BufWriter, IsTerminal, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use elaboration::TlogReader;
use serde_json::json;

use super::timeline::Timeline;

pub(crate) mod from_mcap;
use super::{Outcome, VerbResult};
use petrel_core::supervisor::{Input, Supervisor};

#[derive(clap::Args)]
pub struct Args {
    /// The recording: a telemetry log (.tlog) or a Petrel recording (.mcap).
    pub file: PathBuf,
    /// The project folder (holding project.toml).
    pub project: PathBuf,
    /// Elaboration profile: ardupilot, px4 or a FILE.toml extending the
    /// built-in one [default: from the first autopilot HEARTBEAT].
    #[arg(long)]
    pub profile: Option<String>,
    /// Replay at N times the recorded pace [default: as fast as it goes].
    #[arg(long, value_name = "N")]
    pub speed: Option<f64>,
    /// Print JSON lines (as `petrel play --json`) instead of text for people.
    #[arg(long)]
    pub json: bool,
    /// (.mcap) Compare each replayed step's effects and digest with the
    /// recorded ones; report the first difference and exit 1.
    #[arg(long)]
    pub check_against: bool,
    /// (.tlog) The supervised vehicle's system id, when the log holds
    /// several [default: the first autopilot heard].
    #[arg(long, value_name = "ID")]
    pub sysid: Option<u8>,
    /// (.tlog) The autopilot's component id [default: from its HEARTBEAT].
    #[arg(long, value_name = "ID")]
    pub compid: Option<u8>,
}

/// Elaboration ticks between frames, at most this far apart (µs), so that
/// timeouts fire in a gap of the log as they would have live.
const TICK: u64 = 100_000;

/// The fastest `--speed` (a day's recording in under a tenth of a second).
const REPLAY_FASTEST: f64 = 1e6;

pub fn run(args: Args) -> VerbResult {
    if let Some(s) = args.speed {
        super::run::check_factor("--speed", s, REPLAY_FASTEST)?;
    }
    let ext = args.file.extension().and_then(|e| e.to_str()).unwrap_or("");
    if ext == "mcap" {
        if args.sysid.is_some() || args.compid.is_some() {
            return Err(miette::miette!(
                "--sysid and --compid are for telemetry logs: a Petrel recording replays the vehicle it supervised"
            ));
        }
        return from_mcap::run(args);
    }
    if args.check_against {
        return Err(miette::miette!(
            "--check-against needs a Petrel recording (.mcap): a telemetry log records no decisions"
        ));
    }
    let bytes = petrel_record::read::whole(&args.file)
        .map_err(|e| miette::miette!("cannot read {}: {e}", args.file.display()))?;
    let Ok((profile, _)) =
        super::events::load_profile(args.profile.as_deref(), Some(&args.project), &bytes)?
    else {
        return Ok(Outcome::BadInput);
    };
    let project =
        petrel_core::project::load_with(&args.project, &petrel_core::project::catalog(&profile))?;
    let records: Vec<_> = TlogReader::new(&bytes).collect();
    let Some(first) = records.first() else {
        return Err(miette::miette!(
            "{}: no MAVLink frame in the file",
            args.file.display()
        ));
    };
    let origin = first.time_us;
    let io = |e: std::io::Error| miette::miette!("cannot write the output: {e}");
    let mut out = Timeline {
        out: BufWriter::new(std::io::stdout().lock()),
        json: args.json,
        origin,
    };
    let config = elaboration::Config {
        sysid: args.sysid,
        compid: args.compid,
        ..elaboration::Config::default()
    };
    // A team elaborates each vehicle's telemetry apart (its system from
    // project.toml), as `run` did.
    let family = if args.profile.as_deref() == Some("px4") {
        "px4"
    } else {
        "ardupilot"
    };
    let lanes = petrel_core::team::lanes(&project, &args.project, &profile, family, &config)?;
    let (mut sup, start) = Supervisor::start_lanes(project.clone(), lanes, origin);
    out.effects(&project, &start.effects).map_err(io)?;
    let progress = std::io::stderr().is_terminal() && !args.json;
    let wall = Instant::now();
    let mut last = origin;
    let mut events = 0usize;
    for (i, rec) in records.iter().enumerate() {
        let time = rec.time_us.max(last);
        // Ticks across a gap, so timeouts fire at their time.
        let mut t = last + TICK;
        while t < time {
            let step = sup.step(t, Input::Tick);
            events += step.events.len();
            print_step(&mut out, &project, &step).map_err(io)?;
            t += TICK;
        }
        if let Some(speed) = args.speed {
            let due = Duration::from_secs_f64((time - origin) as f64 / 1e6 / speed);
            if let Some(wait) = due.checked_sub(wall.elapsed()) {
                out.out.flush().map_err(io)?;
                std::thread::sleep(wait);
            }
        }
        let step = sup.step(time, Input::Frame(rec.frame.bytes()));
        events += step.events.len();
        print_step(&mut out, &project, &step).map_err(io)?;
        last = time;
        if progress && i % 20_000 == 0 {
            say_part!(
                "\r{:>5.1}% {} frames",
                100.0 * i as f64 / records.len() as f64,
                i
            );
        }
    }
    if progress {
        say!("\r100.0% {} frames", records.len());
    }
    let player = sup.player();
    out.end(last, player).map_err(io)?;
    out.out.flush().map_err(io)?;
    say!(
        "replayed {} frames ({} bad) in {:.3} s; {events} events; {} commands and calls left unanswered",
        records.len(),
        sup.bad_frames,
        wall.elapsed().as_secs_f64(),
        player.state().pending.len()
    );
    Ok(Outcome::Success)
}

fn print_step<W: Write>(
    out: &mut Timeline<W>,
    project: &nets::Project,
    step: &petrel_core::supervisor::Step,
) -> std::io::Result<()> {
    out.effects(project, &step.effects)?;
    for (e, effects) in &step.events {
        out.event(
            project,
            e.time_us,
            &e.event,
            Some(json!({"sysid": e.sysid, "compid": e.compid})),
        )?;
        out.effects(project, effects)?;
    }
    Ok(())
}
