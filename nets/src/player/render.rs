//! Effects as JSON and as text for people, with names instead of indices.
//! `petrel play`, `replay` and the recording all use these, so the same
//! effect always reads the same.

use crate::value::params_json;
use serde_json::{json, Map, Value as Json};

use super::effect::{Effect, Fault};
use super::flat_place_name;
use crate::model::{NetId, Project, VehicleId};
use crate::time::seconds;
use crate::value::{fmt_params, Params};

fn net_name(project: &Project, n: NetId) -> &str {
    &project.nets[n].name
}

fn transition_name(project: &Project, n: NetId, t: usize) -> &str {
    &project.nets[n].transitions[t].name
}

fn timer_name(project: &Project, n: NetId, t: usize) -> &str {
    &project.nets[n].timers[t]
}

/// The names of the places an effect's marking holds.
fn marked_names(project: &Project, net: Option<NetId>, marked: &[u16]) -> Vec<String> {
    marked
        .iter()
        .map(|&i| match net {
            Some(n) => project.nets[n].places[i as usize].name.clone(),
            None => format!("@{}", project.globals[i as usize].name),
        })
        .collect()
}

/// One effect as a JSON object: `{"t": seconds, "time_us": µs, "effect": kind, …}`.
pub fn effect_json(project: &Project, effect: &Effect) -> Json {
    let time = effect.time();
    let mut obj = Map::new();
    obj.insert("t".into(), json!(seconds(time)));
    obj.insert("time_us".into(), json!(time));
    let (kind, fields) = match effect {
        Effect::Fired {
            net, transition, ..
        } => (
            "fired",
            json!({
                "net": net_name(project, *net),
                "transition": transition_name(project, *net, *transition),
                "event": project.nets[*net].transitions[*transition].event,
            }),
        ),
        Effect::Marking {
            net,
            marked,
            active,
            ..
        } => {
            let mut fields = json!({
                "net": net.map(|n| net_name(project, n)),
                "marked": marked_names(project, *net, marked),
            });
            if !active {
                // Only a deactivation's marking says so: an empty `marked`
                // alone is also an active net without a token.
                fields["active"] = json!(false);
            }
            ("marking", fields)
        }
        Effect::Activated { net, .. } => ("activated", json!({ "net": net_name(project, *net) })),
        Effect::Deactivated { net, .. } => {
            ("deactivated", json!({ "net": net_name(project, *net) }))
        }
        Effect::Ignored {
            net, action, by, ..
        } => (
            "ignored",
            json!({ "net": net_name(project, *net), "action": action, "by": net_name(project, *by) }),
        ),
        Effect::Emitted { net, event, .. } => (
            "emitted",
            json!({
                "net": net_name(project, *net),
                "event": event.name,
                "category": event.category.as_str(),
                "params": params_json(&event.params),
            }),
        ),
        Effect::TimerStarted {
            net,
            timer,
            deadline,
            restarted,
            ..
        } => (
            "timer_started",
            json!({
                "net": net_name(project, *net),
                "timer": timer_name(project, *net, *timer),
                "deadline_t": seconds(*deadline),
                "restarted": restarted,
            }),
        ),
        Effect::TimerCancelled { net, timer, .. } => (
            "timer_cancelled",
            json!({ "net": net_name(project, *net), "timer": timer_name(project, *net, *timer) }),
        ),
        Effect::TimerExpired { net, timer, .. } => (
            "timer_expired",
            json!({ "net": net_name(project, *net), "timer": timer_name(project, *net, *timer) }),
        ),
        Effect::Call {
            id,
            net,
            program,
            function,
            args,
            vehicle,
            ..
        } => {
            let p = &project.programs[*program];
            let mut body = json!({
                "id": id,
                "net": net_name(project, *net),
                "program": p.name,
                "function": p.functions[*function].name,
                "args": params_json(args),
            });
            with_vehicle(&mut body, project, *vehicle);
            ("call", body)
        }
        Effect::Command {
            id,
            net,
            verb,
            args,
            vehicle,
            ..
        } => {
            let mut body = json!({ "id": id, "net": net_name(project, *net), "verb": verb, "args": params_json(args) });
            with_vehicle(&mut body, project, *vehicle);
            ("command", body)
        }
        Effect::Forgotten { id, net, .. } => (
            "forgotten",
            json!({ "id": id, "net": net_name(project, *net) }),
        ),
        Effect::Dropped { event, reason, .. } => (
            "dropped",
            json!({
                "event": event.name,
                "category": event.category.as_str(),
                "params": params_json(&event.params),
                "reason": reason.as_str(),
            }),
        ),
        Effect::LateResult { id, .. } => ("late_result", json!({ "id": id })),
        Effect::Ask {
            id,
            net,
            ask,
            question,
            choices,
            deadline,
            ..
        } => (
            "ask",
            json!({
                "id": id,
                "net": net_name(project, *net),
                "ask": project.nets[*net].asks[*ask].name,
                "question": question,
                "choices": choices,
                "deadline_t": seconds(*deadline),
            }),
        ),
        Effect::Answered {
            id, net, choice, ..
        } => (
            "answered",
            json!({ "id": id, "net": net_name(project, *net), "choice": choice }),
        ),
        Effect::AnswerRefused {
            id, choice, reason, ..
        } => (
            "answer_refused",
            json!({ "id": id, "choice": choice, "reason": reason.as_str() }),
        ),
        Effect::Unanswered { id, net, .. } => (
            "unanswered",
            json!({ "id": id, "net": net_name(project, *net) }),
        ),
        Effect::Lockout {
            event,
            net,
            transition,
            vehicle,
            ..
        } => {
            let mut body = json!({
                "event": event,
                "net": net_name(project, *net),
                "transition": transition_name(project, *net, *transition),
            });
            with_vehicle(&mut body, project, *vehicle);
            ("lockout", body)
        }
        Effect::Fault { fault, .. } => ("fault", fault_json(project, fault)),
    };
    obj.insert("effect".into(), json!(kind));
    if let Json::Object(fields) = fields {
        obj.extend(fields);
    }
    Json::Object(obj)
}

fn fault_json(project: &Project, fault: &Fault) -> Json {
    match fault {
        Fault::DoubleToken {
            net,
            transition,
            place,
        } => json!({
            "fault": "double_token",
            "net": net_name(project, *net),
            "transition": transition_name(project, *net, *transition),
            "place": flat_place_name(project, *place),
        }),
        Fault::BadArgument {
            net,
            transition,
            message,
        }
        | Fault::Guard {
            net,
            transition,
            message,
        } => json!({
            "fault": if matches!(fault, Fault::Guard { .. }) { "guard" } else { "bad_argument" },
            "net": net_name(project, *net),
            "transition": transition_name(project, *net, *transition),
            "message": message,
        }),
        Fault::Livelock {
            net,
            transition,
            firings,
        } => json!({
            "fault": "livelock",
            "net": net_name(project, *net),
            "transition": transition_name(project, *net, *transition),
            "firings": firings,
        }),
        Fault::Overflow { steps } => json!({ "fault": "overflow", "steps": steps }),
    }
}

struct P<'a>(&'a Params);

impl std::fmt::Display for P<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.0.is_empty() {
            Ok(())
        } else {
            f.write_str(" ")?;
            fmt_params(f, self.0)
        }
    }
}

/// What a marking line says after the net's name, in every verb's
/// timeline (`run`, `demo`, `play`, `replay`, `mirror`): `deactivated` for
/// a net no longer active, `(empty)` for an active net without a token,
/// else the marked places joined by `sep`.
pub fn marking_words<S: AsRef<str>>(active: bool, names: &[S], sep: &str) -> String {
    if !active {
        "deactivated".to_owned()
    } else if names.is_empty() {
        "(empty)".to_owned()
    } else {
        names
            .iter()
            .map(AsRef::as_ref)
            .collect::<Vec<_>>()
            .join(sep)
    }
}

/// One effect as a line for people (without the time, which the caller
/// prints in its own column).
pub fn effect_text(project: &Project, effect: &Effect) -> String {
    match effect {
        Effect::Fired {
            net, transition, ..
        } => {
            let tr = &project.nets[*net].transitions[*transition];
            match &tr.event {
                Some(e) => format!("fire   {}.{} on {e}", net_name(project, *net), tr.name),
                None => format!("fire   {}.{} (immediate)", net_name(project, *net), tr.name),
            }
        }
        Effect::Marking {
            net,
            marked,
            active,
            ..
        } => format!(
            "mark   {}: {}",
            net.map_or("@globals", |n| net_name(project, n)),
            marking_words(*active, &marked_names(project, *net, marked), " ")
        ),
        Effect::Activated { net, .. } => format!("net    {} activated", net_name(project, *net)),
        Effect::Deactivated { net, .. } => {
            format!("net    {} deactivated", net_name(project, *net))
        }
        Effect::Ignored {
            net, action, by, ..
        } => format!(
            "note   {action} {} by {} ignored: already {}",
            net_name(project, *net),
            net_name(project, *by),
            if *action == "activate" {
                "active"
            } else {
                "inactive"
            }
        ),
        Effect::Emitted { net, event, .. } => format!(
            "emit   {}{} [{}] by {}",
            event.name,
            P(&event.params),
            event.category,
            net_name(project, *net)
        ),
        Effect::TimerStarted {
            net,
            timer,
            deadline,
            restarted,
            ..
        } => format!(
            "timer  {}.{} {} until {:.3}",
            net_name(project, *net),
            timer_name(project, *net, *timer),
            if *restarted { "restarted" } else { "started" },
            seconds(*deadline)
        ),
        Effect::TimerCancelled { net, timer, .. } => format!(
            "timer  {}.{} cancelled",
            net_name(project, *net),
            timer_name(project, *net, *timer)
        ),
        Effect::TimerExpired { net, timer, .. } => format!(
            "timer  {}.{} expired",
            net_name(project, *net),
            timer_name(project, *net, *timer)
        ),
        Effect::Call {
            id,
            net,
            program,
            function,
            args,
            vehicle,
            ..
        } => {
            let p = &project.programs[*program];
            format!(
                "call   #{id} {}.{}{}{} by {}",
                p.name,
                p.functions[*function].name,
                P(args),
                for_vehicle(project, *vehicle),
                net_name(project, *net)
            )
        }
        Effect::Command {
            id,
            net,
            verb,
            args,
            vehicle,
            ..
        } => {
            format!(
                "cmd    #{id} {verb}{}{} by {}",
                P(args),
                for_vehicle(project, *vehicle),
                net_name(project, *net)
            )
        }
        Effect::Forgotten { id, net, .. } => {
            format!("forget #{id} (net {} deactivated)", net_name(project, *net))
        }
        Effect::Dropped { event, reason, .. } => format!(
            "drop   {}{} [{}]: {}",
            event.name,
            P(&event.params),
            event.category,
            reason.as_str()
        ),
        Effect::LateResult { id, .. } => format!("drop   result #{id}: not pending"),
        Effect::Ask {
            id,
            net,
            question,
            choices,
            deadline,
            ..
        } => format!(
            "ask    #{id} {question:?} [{}] by {} until {:.3}",
            choices.join(", "),
            net_name(project, *net),
            seconds(*deadline)
        ),
        Effect::Answered {
            id, net, choice, ..
        } => format!("answer #{id} {choice} for {}", net_name(project, *net)),
        Effect::AnswerRefused {
            id, choice, reason, ..
        } => format!("refuse answer #{id} {choice}: {}", reason.as_str()),
        Effect::Unanswered { id, net, .. } => {
            format!(
                "unanswered #{id} (net {}): timed out",
                net_name(project, *net)
            )
        }
        Effect::Lockout {
            event,
            net,
            transition,
            vehicle,
            ..
        } => match vehicle.and_then(|v| project.vehicles.get(v)) {
            None => format!(
                "LOCKOUT catastrophic {event} fired {}.{}: other events are dropped from now on",
                net_name(project, *net),
                transition_name(project, *net, *transition)
            ),
            Some(v) => format!(
                "LOCKOUT @{} catastrophic {event} fired {}.{}: {}'s other events are dropped from now on",
                v.name,
                net_name(project, *net),
                transition_name(project, *net, *transition),
                v.name
            ),
        },
        Effect::Fault { fault, .. } => format!("FAULT  {}", fault_text(project, fault)),
    }
}

fn fault_text(project: &Project, fault: &Fault) -> String {
    match fault {
        Fault::DoubleToken {
            net,
            transition,
            place,
        } => format!(
            "{}.{} rejected: a second token in {}",
            net_name(project, *net),
            transition_name(project, *net, *transition),
            flat_place_name(project, *place)
        ),
        Fault::BadArgument {
            net,
            transition,
            message,
        } => format!(
            "{}.{} rejected: {message}",
            net_name(project, *net),
            transition_name(project, *net, *transition)
        ),
        Fault::Guard {
            net,
            transition,
            message,
        } => format!(
            "guard of {}.{} counts as false: {message}",
            net_name(project, *net),
            transition_name(project, *net, *transition)
        ),
        Fault::Livelock {
            net,
            transition,
            firings,
        } => format!(
            "livelock: {firings} immediate firings in one step, stopped at {}.{}",
            net_name(project, *net),
            transition_name(project, *net, *transition)
        ),
        Fault::Overflow { steps } => {
            format!("overflow: {steps} events in one run to completion; the rest were dropped")
        }
    }
}

/// Adds `"vehicle": NAME` to an effect's JSON body when it has a vehicle
/// (a single-vehicle project's output is unchanged).
fn with_vehicle(body: &mut Json, project: &Project, vehicle: Option<VehicleId>) {
    if let (Some(v), Some(map)) = (vehicle, body.as_object_mut()) {
        let name = project
            .vehicles
            .get(v)
            .map_or_else(|| v.to_string(), |v| v.name.clone());
        map.insert("vehicle".into(), Json::String(name));
    }
}

/// ` @VEHICLE` in the text rendering, or nothing.
fn for_vehicle(project: &Project, vehicle: Option<VehicleId>) -> String {
    match vehicle {
        Some(v) => format!(
            " @{}",
            project
                .vehicles
                .get(v)
                .map_or_else(|| v.to_string(), |v| v.name.clone())
        ),
        None => String::new(),
    }
}
