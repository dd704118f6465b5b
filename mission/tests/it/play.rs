//! Playing a script on a project, as `petrel play` does, for what fired.

use nets::{Effect, Player, Project};
use std::sync::Arc;

/// Plays `script` from the start: every effect, and the player at the end.
fn run(project: &Arc<Project>, script: &str) -> (Vec<Effect>, Player) {
    let lines = nets::script::parse(script).unwrap_or_else(|e| panic!("script: {e:?}"));
    let mut player = Player::start(project.clone(), 0);
    let mut out: Vec<Effect> = player.effects().collect();
    for line in &lines {
        nets::script::play_line(&mut player, line).unwrap_or_else(|e| panic!("line: {e:?}"));
        out.extend(player.effects());
    }
    (out, player)
}

fn effects(project: &Arc<Project>, script: &str) -> Vec<Effect> {
    run(project, script).0
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
    let (effects, player) = run(project, script);
    let text = effects
        .iter()
        .map(|e| nets::player::effect_text(project, e))
        .collect();
    (text, format!("{:?}", player.digest()))
}
