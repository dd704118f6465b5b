//! `petrel play PROJECT --events FILE`: plays a project on a script of timed
//! inputs and prints every input, firing, effect and marking change with its
//! time (JSON lines with `--json`).

use std::io::{BufWriter, Write};
use std::path::PathBuf;

use nets::script::{self, Input, ReplyTo};
use nets::{Outcome as Result_, Player, Value};
use serde_json::json;

use super::timeline::Timeline;
use super::{Outcome, VerbResult};

#[derive(clap::Args)]
pub struct Args {
    /// The project folder (holding project.toml).
    pub project: PathBuf,
    /// Timed inputs, one JSON object a line: {"t": 12.5, "event": "name", "params": {}}.
    #[arg(long)]
    pub events: PathBuf,
    /// Print JSON lines instead of text for people.
    #[arg(long)]
    pub json: bool,
    /// The elaboration profile whose events' categories apply (default: the
    /// project's `[gateway] profile`, else ArduPilot's).
    #[arg(long)]
    pub profile: Option<String>,
}

fn reply_name(to: &ReplyTo) -> serde_json::Value {
    match to {
        ReplyTo::Id(id) => json!(id),
        ReplyTo::Call { program, function } => json!(format!("{program}.{function}")),
        ReplyTo::Command { verb } => json!(format!("command.{verb}")),
    }
}

pub fn run(args: Args) -> VerbResult {
    // The events' categories as in flight: the elaboration profile's
    // catalog (`--profile`, else `[gateway] profile`, else ArduPilot's),
    // then the project's declarations.
    petrel_core::project::load(&args.project)?;
    let setting = petrel_core::project::gateway_setting(&args.project, "profile")?;
    let layers = petrel_core::profile::Layers::pick(
        args.profile.as_deref(),
        Some((&args.project, setting.as_deref())),
        "ardupilot",
    )?;
    let Some(profile) = crate::cli::loaded(&layers) else {
        return Ok(Outcome::BadInput);
    };
    let project =
        petrel_core::project::load_with(&args.project, &petrel_core::project::catalog(&profile))?;
    let text = std::fs::read_to_string(&args.events)
        .map_err(|e| miette::miette!("cannot read {}: {e}", args.events.display()))?;
    let lines = script::parse(&text)
        .and_then(|lines| script::check(&project, &lines).map(|()| lines))
        .map_err(|e| miette::miette!("{}:{e}", args.events.display()))?;
    let io = |e: std::io::Error| miette::miette!("cannot write the output: {e}");
    let mut out = Timeline {
        out: BufWriter::new(std::io::stdout().lock()),
        json: args.json,
        origin: 0,
    };
    let mut player = Player::start(project.clone(), 0);
    let effects: Vec<_> = player.effects().collect();
    out.effects(&project, &effects).map_err(io)?;
    for line in &lines {
        // The timers due by the input's time expire at their own times,
        // before it, and are printed so.
        player.advance(line.time);
        let effects: Vec<_> = player.effects().collect();
        out.effects(&project, &effects).map_err(io)?;
        match &line.input {
            Input::Event(e) => out.event(&project, line.time, e, None),
            Input::Reply {
                to,
                outcome: Result_::Done(p),
            } => {
                let text = format!(
                    "REPLY  {} done {}",
                    reply_name(to).to_string().trim_matches('"'),
                    Value::Map(p.clone())
                );
                let params = nets::value::params_json(p);
                out.input(
                    line.time,
                    "reply",
                    json!({"reply": reply_name(to), "params": params}),
                    &text,
                )
            }
            Input::Reply {
                to,
                outcome: Result_::Failed(r),
            } => {
                let text = format!(
                    "REPLY  {} failed: {r}",
                    reply_name(to).to_string().trim_matches('"')
                );
                out.input(
                    line.time,
                    "reply",
                    json!({"reply": reply_name(to), "failed": r}),
                    &text,
                )
            }
            Input::Answer { to, choice } => {
                let to = match to {
                    script::AnswerTo::Id(id) => json!(id),
                    script::AnswerTo::Ask(name) => json!(name),
                };
                out.input(
                    line.time,
                    "answer",
                    json!({"answer": to, "choice": choice}),
                    &format!("ANSWER {} {choice}", to.to_string().trim_matches('"')),
                )
            }
            Input::Advance => out.input(line.time, "advance", json!({}), "...    time passes"),
        }
        .map_err(io)?;
        let played = script::play_line(&mut player, line);
        let effects: Vec<_> = player.effects().collect();
        out.effects(&project, &effects).map_err(io)?;
        if let Err(e) = played {
            out.out.flush().map_err(io)?;
            return Err(miette::miette!("{}:{e}", args.events.display()));
        }
    }
    out.end(player.state().now, &player).map_err(io)?;
    out.out.flush().map_err(io)?;
    Ok(Outcome::Success)
}
