//! Helpers shared by the nets integration tests.

use std::collections::BTreeMap;
use std::sync::Arc;

use nets::player::{effect_text, Effect};
use nets::{Event, Player, Project};

/// Loads a project from owned (file name, text) pairs (see [`project`]).
pub fn project_from(files: &[(String, String)]) -> Arc<Project> {
    let refs: Vec<(&str, &str)> = files
        .iter()
        .map(|(a, b)| (a.as_str(), b.as_str()))
        .collect();
    project(&refs)
}

/// Loads a project from (file name, text) pairs; panics with the problems.
pub fn project(files: &[(&str, &str)]) -> Arc<Project> {
    let sources: BTreeMap<String, String> = files
        .iter()
        .map(|(n, t)| (n.to_string(), t.to_string()))
        .collect();
    match nets::load(&sources) {
        Ok(p) => Arc::new(p),
        Err(e) => panic!("{e}"),
    }
}

/// A one-net project: `net` is the net file's text (its name is `N`).
pub fn one_net(net: &str) -> Arc<Project> {
    project(&[
        (
            "project.toml",
            "[[net]]\nfile = \"n.toml\"\nactive = true\n",
        ),
        ("n.toml", net),
    ])
}

/// Drains the effects, as text lines.
pub fn drain(player: &mut Player) -> Vec<String> {
    let project = player.project().clone();
    player
        .effects()
        .map(|e| effect_text(&project, &e))
        .collect()
}

/// Drains the effects, keeping them.
pub fn drain_effects(player: &mut Player) -> Vec<Effect> {
    player.effects().collect()
}

/// The transitions fired, as `NET.transition`, in order.
pub fn fired(project: &Project, effects: &[Effect]) -> Vec<String> {
    effects
        .iter()
        .filter_map(|e| e.fired_label(project))
        .collect()
}

/// Handles an event and returns the firings.
pub fn fire(player: &mut Player, event: &Event, now: u64) -> Vec<String> {
    player.handle(event, now);
    let effects = drain_effects(player);
    fired(&player.project().clone(), &effects)
}

/// Names of the marked places of a net.
pub fn marking(player: &Player, net: &str) -> Vec<String> {
    let project = player.project();
    let n = project.net(net).expect("net exists");
    project.nets[n]
        .places
        .iter()
        .enumerate()
        .filter(|(i, _)| player.is_marked(n, nets::model::PlaceRef::Local(*i)))
        .map(|(_, p)| p.name.clone())
        .collect()
}

/// Whether a global place is marked.
pub fn global(player: &Player, name: &str) -> bool {
    let g = player
        .project()
        .globals
        .iter()
        .position(|g| g.name == name)
        .expect("global exists");
    player.state().marked(g)
}
