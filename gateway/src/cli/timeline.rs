//! The timeline `play` and `replay` print: every input, then every effect it
//! caused, with its time — as text for people or as JSON lines.

use nets::value::params_json;
use std::io::Write;

use nets::player::{effect_json, effect_text};
use nets::{Effect, Event, Micros, Project};
use serde_json::{json, Value};

/// Where and how a timeline is printed.
pub struct Timeline<W: Write> {
    pub out: W,
    pub json: bool,
    /// Times are printed relative to this instant (a log's first frame).
    pub origin: Micros,
}

impl<W: Write> Timeline<W> {
    fn t(&self, time: Micros) -> f64 {
        nets::time::seconds(time.saturating_sub(self.origin))
    }

    /// An input line: `kind` is `event`, `reply` or `advance`; `fields` its
    /// JSON fields, `text` its text for people.
    pub fn input(
        &mut self,
        time: Micros,
        kind: &str,
        mut fields: Value,
        text: &str,
    ) -> std::io::Result<()> {
        if self.json {
            let mut obj = json!({"t": self.t(time), "time_us": time, "input": kind});
            if let (Value::Object(o), Value::Object(f)) = (&mut obj, fields.take()) {
                o.extend(f);
            }
            writeln!(self.out, "{obj}")
        } else {
            let t = self.t(time);
            writeln!(self.out, "{t:>10.3}  {text}")
        }
    }

    /// An event as an input, with the category the player will use.
    pub fn event(
        &mut self,
        project: &Project,
        time: Micros,
        event: &Event,
        source: Option<Value>,
    ) -> std::io::Result<()> {
        let category = project
            .declared_category(&event.name)
            .unwrap_or(event.category);
        let mut fields = json!({
            "event": event.name,
            "category": category.as_str(),
            "params": params_json(&event.params),
        });
        if let (Some(Value::Object(s)), Value::Object(f)) = (source, &mut fields) {
            f.extend(s);
        }
        self.input(
            time,
            "event",
            fields,
            &format!("EVENT  {event} [{category}]"),
        )
    }

    /// Effects, each with its own time.
    pub fn effects<'a>(
        &mut self,
        project: &Project,
        effects: impl IntoIterator<Item = &'a Effect>,
    ) -> std::io::Result<()> {
        for effect in effects {
            if self.json {
                let mut v = effect_json(project, effect);
                v["t"] = json!(self.t(effect.time()));
                writeln!(self.out, "{v}")?;
            } else {
                let t = self.t(effect.time());
                writeln!(
                    self.out,
                    "{t:>10.3}         {}",
                    effect_text(project, effect)
                )?;
            }
        }
        Ok(())
    }

    /// The closing line: the final digest and the lockout (the team's, and
    /// in a team the vehicles locked out one by one).
    pub fn end(&mut self, time: Micros, player: &nets::Player) -> std::io::Result<()> {
        let digest = player.digest();
        if self.json {
            let mut line = json!({"t": self.t(time), "time_us": time, "end": true, "digest": digest.to_string(), "lockout": player.locked_out()});
            let locked: Vec<&str> = player
                .state()
                .locked
                .iter()
                .filter_map(|&v| player.project().vehicles.get(v).map(|v| v.name.as_str()))
                .collect();
            if !locked.is_empty() {
                line["locked"] = json!(locked);
            }
            writeln!(self.out, "{line}")
        } else {
            let t = self.t(time);
            writeln!(self.out, "{t:>10.3}  end    digest {digest}")
        }
    }
}
