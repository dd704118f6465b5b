//! The live log for people: the gateway's timeline lines, read as they
//! come, printed when they are worth it and counted for the summary.

use nets::player::marking_words;
use serde_json::Value as Json;

/// What the live log has counted.
#[derive(Default)]
pub(super) struct Log {
    pub events: std::collections::BTreeMap<String, u64>,
    pub commands: u64,
    pub calls: u64,
    pub dropped: u64,
    pub phase: std::collections::BTreeMap<String, String>,
    /// The nets deactivated, until they come back.
    deactivated: std::collections::BTreeSet<String>,
    /// From the timeline's closing line: the lockout on, and the vehicles
    /// locked out (a team's).
    pub lockout: bool,
    pub locked: Vec<String>,
}

impl Log {
    /// Prints one timeline line for people, if it is worth it.
    pub fn line(&mut self, v: &Json) {
        if let Some(text) = self.text(v) {
            show!("{text}");
        }
    }

    /// One timeline line for people, if it is worth it, counted.
    fn text(&mut self, v: &Json) -> Option<String> {
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
            return None;
        }
        if v["input"] == "event" {
            let category = s("category");
            *self.events.entry(category.clone()).or_default() += 1;
            let params = params_text(&v["params"]);
            return Some(format!(
                "{t:>8.1}s  event    {}{params}  [{category}]",
                s("event")
            ));
        }
        match v["effect"].as_str() {
            Some("command") => {
                self.commands += 1;
                Some(format!(
                    "{t:>8.1}s  command  {}{}  ({})",
                    s("verb"),
                    params_text(&v["args"]),
                    s("net")
                ))
            }
            Some("call") => {
                self.calls += 1;
                Some(format!(
                    "{t:>8.1}s  call     {}.{}{}  ({})",
                    s("program"),
                    s("function"),
                    params_text(&v["args"]),
                    s("net")
                ))
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
                // A deactivation's marking says so (`"active": false`).
                let active = v["active"] != false;
                let now = marking_words(active, &marked, ", ");
                if net.is_empty() || self.phase.get(&net) == Some(&now) {
                    return None;
                }
                let back = if active {
                    self.deactivated.remove(&net)
                } else {
                    self.deactivated.insert(net.clone());
                    false
                };
                let back = if back { "activated: " } else { "" };
                let line = format!("{t:>8.1}s  {net:<8} {back}{now}");
                self.phase.insert(net, now);
                Some(line)
            }
            Some("dropped") => {
                self.dropped += 1;
                Some(format!(
                    "{t:>8.1}s  dropped  {} ({})",
                    s("event"),
                    s("reason")
                ))
            }
            // An event a net emits for the crew or the nets (the
            // flight-test example's `site_out_of_reach`).
            Some("emitted") => Some(format!(
                "{t:>8.1}s  emitted  {}{}  [{}] by {}",
                s("event"),
                params_text(&v["params"]),
                s("category"),
                s("net")
            )),
            Some("fault") => Some(format!("{t:>8.1}s  FAULT    {v}")),
            _ => None,
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

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn marking(log: &mut Log, t: f64, net: &str, marked: &[&str], active: bool) -> Option<String> {
        let mut v = json!({"t": t, "effect": "marking", "net": net, "marked": marked});
        if !active {
            v["active"] = json!(false);
        }
        log.text(&v)
    }

    #[test]
    fn a_deactivated_net_says_so_and_says_activated_when_it_comes_back() {
        let mut log = Log::default();
        assert_eq!(
            marking(&mut log, 1.0, "FLIGHT", &["climb"], true).as_deref(),
            Some("     1.0s  FLIGHT   climb")
        );
        assert_eq!(
            marking(&mut log, 44.8, "FLIGHT", &[], false).as_deref(),
            Some("    44.8s  FLIGHT   deactivated")
        );
        assert_eq!(
            marking(&mut log, 50.0, "FLIGHT", &["checks"], true).as_deref(),
            Some("    50.0s  FLIGHT   activated: checks")
        );
        assert_eq!(
            marking(&mut log, 51.0, "FLIGHT", &["auto_1", "@airborne"], true).as_deref(),
            Some("    51.0s  FLIGHT   auto_1")
        );
        // An active net without a token is not a deactivation.
        assert_eq!(
            marking(&mut log, 52.0, "FLIGHT", &[], true).as_deref(),
            Some("    52.0s  FLIGHT   (empty)")
        );
    }

    #[test]
    fn an_emitted_event_is_shown_with_the_net_that_emitted_it() {
        let mut log = Log::default();
        let v = json!({"t": 25.2, "effect": "emitted", "net": "CATASTROPHIC",
                       "event": "site_out_of_reach", "category": "catastrophic",
                       "params": {"distance": 275.4, "name": "North field"}});
        assert_eq!(
            log.text(&v).as_deref(),
            Some("    25.2s  emitted  site_out_of_reach {distance: 275.4, name: \"North field\"}  [catastrophic] by CATASTROPHIC")
        );
    }
}
