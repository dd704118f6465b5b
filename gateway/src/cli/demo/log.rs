//! The live log for people: the gateway's timeline lines, read as they
//! come, printed when they are worth it and counted for the summary.

use serde_json::Value as Json;

/// What the live log has counted.
#[derive(Default)]
pub(super) struct Log {
    pub events: std::collections::BTreeMap<String, u64>,
    pub commands: u64,
    pub calls: u64,
    pub dropped: u64,
    pub phase: std::collections::BTreeMap<String, String>,
    /// From the timeline's closing line: the lockout on, and the vehicles
    /// locked out (a team's).
    pub lockout: bool,
    pub locked: Vec<String>,
}

impl Log {
    /// Prints one timeline line for people, if it is worth it.
    pub fn line(&mut self, v: &Json) {
        let t = v["t"].as_f64().unwrap_or(0.0);
        let s = |k: &str| v[k].as_str().unwrap_or("").to_owned();
        if v["end"] == true {
            self.lockout = v["lockout"] == true;
            self.locked = v["locked"]
                .as_array()
                .map(|a| {
                    a.iter()
                        .filter_map(Json::as_str)
                        .map(str::to_owned)
                        .collect()
                })
                .unwrap_or_default();
            return;
        }
        if v["input"] == "event" {
            let category = s("category");
            *self.events.entry(category.clone()).or_default() += 1;
            let params = params_text(&v["params"]);
            show!("{t:>8.1}s  event    {}{params}  [{category}]", s("event"));
            return;
        }
        match v["effect"].as_str() {
            Some("command") => {
                self.commands += 1;
                show!(
                    "{t:>8.1}s  command  {}{}  ({})",
                    s("verb"),
                    params_text(&v["args"]),
                    s("net")
                );
            }
            Some("call") => {
                self.calls += 1;
                show!(
                    "{t:>8.1}s  call     {}.{}{}  ({})",
                    s("program"),
                    s("function"),
                    params_text(&v["args"]),
                    s("net")
                );
            }
            Some("marking") => {
                let net = s("net");
                let marked: Vec<&str> = v["marked"]
                    .as_array()
                    .map(|a| {
                        a.iter()
                            .filter_map(Json::as_str)
                            .filter(|p| !p.starts_with('@'))
                            .collect()
                    })
                    .unwrap_or_default();
                let now = marked.join(", ");
                if !net.is_empty() && self.phase.get(&net) != Some(&now) {
                    show!("{t:>8.1}s  {net:<8} {now}");
                    self.phase.insert(net, now);
                }
            }
            Some("dropped") => {
                self.dropped += 1;
                show!("{t:>8.1}s  dropped  {} ({})", s("event"), s("reason"));
            }
            Some("fault") => show!("{t:>8.1}s  FAULT    {v}"),
            _ => {}
        }
    }
}

/// ` {a: 1, b: "x"}`, or nothing for no parameters; long values cut.
fn params_text(p: &Json) -> String {
    let Some(map) = p.as_object().filter(|m| !m.is_empty()) else {
        return String::new();
    };
    let parts: Vec<String> = map
        .iter()
        .map(|(k, v)| {
            let text = v.to_string();
            if text.len() > 40 {
                format!("{k}: …")
            } else {
                format!("{k}: {text}")
            }
        })
        .collect();
    format!(" {{{}}}", parts.join(", "))
}

/// `a, b, c`, or `none`.
pub(super) fn list_or_none(items: &[String]) -> String {
    if items.is_empty() {
        "none".into()
    } else {
        items.join(", ")
    }
}

impl Log {
    /// The summary's line of counts.
    pub fn counts(&self) -> String {
        let events: Vec<String> = self
            .events
            .iter()
            .map(|(c, n)| format!("{n} {c}"))
            .collect();
        let lockout = if !self.locked.is_empty() {
            format!("; locked out at the end: {}", self.locked.join(", "))
        } else if self.lockout {
            "; the catastrophic lockout on at the end".into()
        } else {
            String::new()
        };
        format!(
            "events: {}; commands: {}; program calls: {}; dropped under the catastrophic lockout: {}{lockout}",
            list_or_none(&events),
            self.commands,
            self.calls,
            self.dropped
        )
    }
}
