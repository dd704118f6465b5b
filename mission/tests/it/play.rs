//! Playing a script on a project, as `petrel play` does, for what fired.

use nets::{Effect, Player, Project};
use std::sync::Arc;

fn effects(project: &Arc<Project>, script: &str) -> Vec<Effect> {
    let lines = nets::script::parse(script).unwrap_or_else(|e| panic!("script: {e:?}"));
    let mut player = Player::start(project.clone(), 0);
    let mut out: Vec<Effect> = player.effects().collect();
    for line in &lines {
        nets::script::play_line(&mut player, line).unwrap_or_else(|e| panic!("line: {e:?}"));
        out.extend(player.effects());
    }
    out
}

/// `NET.transition` of every firing, in order.
pub fn fired(project: &Arc<Project>, script: &str) -> Vec<String> {
    effects(project, script)
        .iter()
        .filter_map(|e| match e {
            Effect::Fired {
                net, transition, ..
            } => Some(format!(
                "{}.{}",
                project.nets[*net].name, project.nets[*net].transitions[*transition].name
            )),
            _ => None,
        })
        .collect()
}

/// The verb of every command, in order.
pub fn commands(project: &Arc<Project>, script: &str) -> Vec<String> {
    effects(project, script)
        .iter()
        .filter_map(|e| match e {
            Effect::Command { verb, .. } => Some(verb.clone()),
            _ => None,
        })
        .collect()
}

/// The whole trace as text, and the final digest.
pub fn trace(project: &Arc<Project>, script: &str) -> (Vec<String>, String) {
    let lines = nets::script::parse(script).unwrap_or_else(|e| panic!("script: {e:?}"));
    let mut player = Player::start(project.clone(), 0);
    let mut out: Vec<String> = player
        .effects()
        .map(|e| nets::player::effect_text(project, &e))
        .collect();
    for line in &lines {
        nets::script::play_line(&mut player, line).unwrap_or_else(|e| panic!("line: {e:?}"));
        let effects: Vec<Effect> = player.effects().collect();
        out.extend(
            effects
                .iter()
                .map(|e| nets::player::effect_text(project, e)),
        );
    }
    (out, format!("{:?}", player.digest()))
}
