//! `petrel play PROJECT --events FILE`: plays a project on a script of timed
//! inputs and prints every input, firing, effect and marking change with its
//! time (JSON lines with `--json`).

use std::io::{BufWriter, Write};
use std::path::PathBuf;

use nets::player::{effect_json, effect_text};
use nets::script::{self, Input, Line, ReplyTo};
use nets::time::seconds;
use nets::{Player, Project};
use serde_json::json;

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
}

pub fn run(args: Args) -> VerbResult {
    let project = crate::project::load(&args.project)?;
    let text = std::fs::read_to_string(&args.events)
        .map_err(|e| miette::miette!("cannot read {}: {e}", args.events.display()))?;
    let lines =
        script::parse(&text).map_err(|e| miette::miette!("{}:{e}", args.events.display()))?;
    let stdout = std::io::stdout();
    let mut out = BufWriter::new(stdout.lock());
    let mut player = Player::start(project.clone(), 0);
    let io = |e: std::io::Error| miette::miette!("cannot write the output: {e}");
    print_effects(&mut out, &project, &mut player, args.json).map_err(io)?;
    for line in &lines {
        print_input(&mut out, &project, line, args.json).map_err(io)?;
        if let Err(e) = script::play_line(&mut player, line) {
            print_effects(&mut out, &project, &mut player, args.json).map_err(io)?;
            out.flush().map_err(io)?;
            return Err(miette::miette!("{}:{e}", args.events.display()));
        }
        print_effects(&mut out, &project, &mut player, args.json).map_err(io)?;
    }
    if args.json {
        writeln!(
            out,
            "{}",
            json!({
                "t": seconds(player.state().now),
                "time_us": player.state().now,
                "end": true,
                "digest": player.digest().to_string(),
                "lockout": player.locked_out(),
            })
        )
        .map_err(io)?;
    } else {
        writeln!(
            out,
            "{:>10.3}  end    digest {}",
            seconds(player.state().now),
            player.digest()
        )
        .map_err(io)?;
    }
    out.flush().map_err(io)?;
    Ok(Outcome::Success)
}

fn print_input(
    out: &mut impl Write,
    project: &Project,
    line: &Line,
    as_json: bool,
) -> std::io::Result<()> {
    let t = seconds(line.time);
    // The category the player will use: the project's declaration wins.
    let category = |e: &nets::Event| project.declared_category(&e.name).unwrap_or(e.category);
    let params = |p: &nets::Params| {
        serde_json::Value::Object(p.iter().map(|(k, v)| (k.clone(), v.to_json())).collect())
    };
    let reply_name = |to: &ReplyTo| match to {
        ReplyTo::Id(id) => json!(id),
        ReplyTo::Call { program, function } => json!(format!("{program}.{function}")),
        ReplyTo::Command { verb } => json!(format!("command.{verb}")),
    };
    if as_json {
        let value = match &line.input {
            Input::Event(e) => {
                json!({"t": t, "time_us": line.time, "input": "event", "event": e.name, "category": category(e).as_str(), "params": params(&e.params)})
            }
            Input::Reply {
                to,
                outcome: nets::Outcome::Done(p),
            } => {
                json!({"t": t, "time_us": line.time, "input": "reply", "reply": reply_name(to), "params": params(p)})
            }
            Input::Reply {
                to,
                outcome: nets::Outcome::Failed(r),
            } => {
                json!({"t": t, "time_us": line.time, "input": "reply", "reply": reply_name(to), "failed": r})
            }
            Input::Advance => json!({"t": t, "time_us": line.time, "input": "advance"}),
        };
        writeln!(out, "{value}")
    } else {
        match &line.input {
            Input::Event(e) => writeln!(out, "{t:>10.3}  EVENT  {e} [{}]", category(e)),
            Input::Reply {
                to,
                outcome: nets::Outcome::Done(p),
            } => {
                let p = nets::Value::Map(p.clone());
                writeln!(
                    out,
                    "{t:>10.3}  REPLY  {} done {p}",
                    reply_name(to).to_string().trim_matches('"')
                )
            }
            Input::Reply {
                to,
                outcome: nets::Outcome::Failed(r),
            } => {
                writeln!(
                    out,
                    "{t:>10.3}  REPLY  {} failed: {r}",
                    reply_name(to).to_string().trim_matches('"')
                )
            }
            Input::Advance => writeln!(out, "{t:>10.3}  ...    time passes"),
        }
    }
}

fn print_effects(
    out: &mut impl Write,
    project: &Project,
    player: &mut Player,
    as_json: bool,
) -> std::io::Result<()> {
    for effect in player.effects() {
        if as_json {
            writeln!(out, "{}", effect_json(project, &effect))?;
        } else {
            writeln!(
                out,
                "{:>10.3}         {}",
                seconds(effect.time()),
                effect_text(project, &effect)
            )?;
        }
    }
    Ok(())
}
