//! Property tests on the player, over random traces on the example project.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use nets::player::{snapshot, Effect, Outcome, Player};
use nets::{Category, Event, Params, Project, Value};
use proptest::prelude::*;

fn example() -> Arc<Project> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/uav-survey");
    let files: BTreeMap<String, String> = ["project.toml", "mission.toml", "events.toml"]
        .iter()
        .map(|n| {
            (
                n.to_string(),
                std::fs::read_to_string(dir.join(n)).expect("example"),
            )
        })
        .collect();
    Arc::new(nets::load(&files).expect("example loads"))
}

const EVENTS: &[&str] = &[
    "ready_for_takeoff",
    "takeoff",
    "altitude_reached",
    "payload_failure",
    "engine_failure",
    "landed",
    "payload_operation",
    "command.ok",
    "DEC.next_waypoint.done",
    "net_fault",
    "unknown_event",
];

#[derive(Debug, Clone)]
enum Step {
    Event {
        name: usize,
        category: usize,
        params: Vec<(usize, Value)>,
        dt: u64,
    },
    Reply {
        pick: usize,
        ok: bool,
        params: Vec<(usize, Value)>,
        dt: u64,
    },
    Advance {
        dt: u64,
    },
}

const KEYS: &[&str] = &[
    "alt",
    "component",
    "finished",
    "lat",
    "lon",
    "payload",
    "index",
    "verb",
    "x",
];

fn value() -> impl Strategy<Value = Value> {
    prop_oneof![
        any::<bool>().prop_map(Value::Bool),
        (-200i64..200).prop_map(Value::Int),
        (-1e3f64..1e3).prop_map(Value::Float),
        "[a-z]{0,6}".prop_map(Value::Str),
        Just(Value::List(vec![Value::Int(1)])),
    ]
}

fn params() -> impl Strategy<Value = Vec<(usize, Value)>> {
    prop::collection::vec((0..KEYS.len(), value()), 0..4)
}

fn step(max_dt: u64) -> impl Strategy<Value = Step> {
    prop_oneof![
        4 => (0..EVENTS.len(), 0..5usize, params(), 0..max_dt).prop_map(|(name, category, params, dt)| Step::Event { name, category, params, dt }),
        3 => (0..8usize, any::<bool>(), params(), 0..max_dt).prop_map(|(pick, ok, params, dt)| Step::Reply { pick, ok, params, dt }),
        1 => (0..max_dt * 4).prop_map(|dt| Step::Advance { dt }),
    ]
}

fn to_params(p: &[(usize, Value)]) -> Params {
    p.iter()
        .map(|(k, v)| (KEYS[*k].to_owned(), v.clone()))
        .collect()
}

/// Applies one step; returns the effects it produced.
fn apply(player: &mut Player, now: &mut u64, s: &Step) -> Vec<Effect> {
    match s {
        Step::Event {
            name,
            category,
            params,
            dt,
        } => {
            *now += dt;
            let event = Event {
                name: EVENTS[*name].to_owned(),
                category: Category::ALL[*category],
                params: to_params(params),
            };
            player.handle(&event, *now);
        }
        Step::Reply {
            pick,
            ok,
            params,
            dt,
        } => {
            *now += dt;
            let ids: Vec<u64> = player.state().pending.keys().copied().collect();
            // Sometimes an id that is not pending: a late or bogus result.
            let id = ids.get(*pick).copied().unwrap_or(1000 + *pick as u64);
            let outcome = if *ok {
                Outcome::Done(to_params(params))
            } else {
                Outcome::Failed("no".into())
            };
            player.result(id, outcome, *now);
        }
        Step::Advance { dt } => {
            *now += dt;
            player.advance(*now);
        }
    }
    player.effects().collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn random_traces_never_panic_and_keep_the_nets_safe(steps in prop::collection::vec(step(30_000_000), 0..60)) {
        let project = example();
        let mut player = Player::start(project.clone(), 0);
        let mut now = 0;
        for s in &steps {
            apply(&mut player, &mut now, s);
            // Between inputs the queue is empty (run to completion) and only
            // active nets hold tokens.
            prop_assert_eq!(player.state().queued(), 0);
            for (n, net) in project.nets.iter().enumerate() {
                if !player.is_active(n) {
                    for p in 0..net.places.len() {
                        prop_assert!(!player.is_marked(n, nets::model::PlaceRef::Local(p)));
                    }
                }
            }
        }
    }

    #[test]
    fn restoring_a_snapshot_and_replaying_the_rest_gives_the_same_effects(
        steps in prop::collection::vec(step(30_000_000), 1..50),
        cut in 0usize..50,
    ) {
        let project = example();
        let cut = cut % steps.len();
        let mut whole = Player::start(project.clone(), 0);
        let mut now = 0;
        let _ = whole.effects().count();
        for s in &steps[..cut] {
            apply(&mut whole, &mut now, s);
        }
        let json = serde_json::to_string(&whole.snapshot()).expect("snapshot serialises");
        let state = serde_json::from_str(&json).expect("snapshot deserialises");
        let mut restored = Player::restore(project, state).expect("restores");
        prop_assert_eq!(restored.digest(), whole.digest());
        let mut now_restored = now;
        for s in &steps[cut..] {
            let a = apply(&mut whole, &mut now, s);
            let b = apply(&mut restored, &mut now_restored, s);
            prop_assert_eq!(a, b);
            prop_assert_eq!(whole.digest(), restored.digest());
        }
    }

    #[test]
    fn equal_digests_mean_equal_states(
        a in prop::collection::vec(step(2), 0..12),
        b in prop::collection::vec(step(2), 0..12),
    ) {
        // Tiny time steps over a small alphabet make equal states common.
        let project = example();
        let run = |steps: &[Step]| {
            let mut player = Player::start(project.clone(), 0);
            let mut now = 0;
            let mut states = vec![(player.digest(), player.snapshot())];
            for s in steps {
                apply(&mut player, &mut now, s);
                states.push((player.digest(), player.snapshot()));
            }
            states
        };
        let sa = run(&a);
        let sb = run(&b);
        for (da, xa) in &sa {
            for (db, xb) in &sb {
                prop_assert_eq!(da == db, xa == xb);
                prop_assert_eq!(
                    da == db,
                    nets::player::canonical_bytes(xa) == nets::player::canonical_bytes(xb)
                );
            }
        }
    }
}

fn example_texts() -> Vec<(String, String)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/uav-survey");
    ["project.toml", "mission.toml", "events.toml"]
        .iter()
        .map(|n| {
            (
                n.to_string(),
                std::fs::read_to_string(dir.join(n)).expect("example"),
            )
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    /// Loading never panics: the example's files with random bytes cut,
    /// replaced or inserted, and wholly random text.
    #[test]
    fn loading_never_panics(
        file in 0usize..3,
        edits in prop::collection::vec((any::<prop::sample::Index>(), 0usize..3, "[ -~\n]{0,8}"), 1..6),
        garbage in "\\PC{0,200}",
    ) {
        let mut files = example_texts();
        let text = &mut files[file].1;
        for (at, kind, s) in &edits {
            let mut chars: Vec<char> = text.chars().collect();
            let i = at.index(chars.len().max(1)).min(chars.len());
            match kind {
                0 => { chars.splice(i..(i + s.len()).min(chars.len()), std::iter::empty()); }
                1 => { chars.splice(i..(i + s.chars().count()).min(chars.len()), s.chars()); }
                _ => { chars.splice(i..i, s.chars()); }
            }
            *text = chars.into_iter().collect();
        }
        let map: BTreeMap<String, String> = files.iter().cloned().collect();
        // A mutant that still loads is played too: every event the example
        // knows, a reply to each pending call, and time passing.
        if let Ok(project) = nets::load(&map) {
            let mut player = Player::start(Arc::new(project), 0);
            for (i, name) in EVENTS.iter().enumerate() {
                let t = (i as u64 + 1) * 30_000_000;
                player.handle(&Event::new(*name).param("alt", 120).param("finished", false), t);
                let ids: Vec<u64> = player.state().pending.keys().copied().collect();
                for id in ids {
                    player.result(id, Outcome::Done(Params::new()), t);
                }
                player.advance(t + 20_000_000);
                let _ = player.effects().count();
            }
        }
        let mut garbage_files = example_texts();
        garbage_files[file].1 = garbage.clone();
        let map: BTreeMap<String, String> = garbage_files.into_iter().collect();
        let _ = nets::load(&map);
        // And every problem reported has a position inside its file.
        if let Err(e) = nets::load(&map) {
            for p in &e.problems {
                let (line, col) = p.line_col();
                prop_assert!(line >= 1 && col >= 1);
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    /// `petrel play`'s input never panics: an example script with random
    /// characters cut, replaced or inserted is refused with a position, or
    /// plays to the end (a reply with nothing to answer is an error, not a
    /// panic); wholly random text too.
    #[test]
    fn scripts_never_panic(
        script in 0usize..3,
        edits in prop::collection::vec((any::<prop::sample::Index>(), 0usize..3, "[ -~\n]{0,8}"), 1..6),
        garbage in "\\PC{0,200}",
    ) {
        let name = ["nominal.jsonl", "payload_failure.jsonl", "engine_failure.jsonl"][script];
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/uav-survey/scripts");
        let mut text: Vec<char> = std::fs::read_to_string(dir.join(name)).expect("script").chars().collect();
        for (at, kind, s) in &edits {
            let i = at.index(text.len().max(1)).min(text.len());
            match kind {
                0 => { text.splice(i..(i + s.len()).min(text.len()), std::iter::empty()); }
                1 => { text.splice(i..(i + s.chars().count()).min(text.len()), s.chars()); }
                _ => { text.splice(i..i, s.chars()); }
            }
        }
        let project = example();
        for text in [text.into_iter().collect::<String>(), garbage] {
            match nets::script::parse(&text) {
                Ok(lines) => {
                    let mut player = Player::start(project.clone(), 0);
                    for line in &lines {
                        if nets::script::play_line(&mut player, line).is_err() {
                            break;
                        }
                        let _ = player.effects().count();
                    }
                }
                Err(e) => prop_assert!(e.line >= 1 && e.column >= 1),
            }
        }
    }
}

/// The player's state after each of `steps`, with the effects of each.
fn play_steps(project: &Arc<Project>, steps: &[Step]) -> (Player, u64) {
    let mut player = Player::start(project.clone(), 0);
    let _ = player.effects().count();
    let mut now = 0;
    for s in steps {
        apply(&mut player, &mut now, s);
    }
    (player, now)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    /// The ground mirror's resync: a player restored from a binary snapshot
    /// taken at any step and fed the rest of the trace produces the same
    /// effects and ends with the same digest as one fed the whole trace.
    #[test]
    fn a_binary_snapshot_at_any_step_then_the_rest_gives_the_same_digest(
        steps in prop::collection::vec(step(30_000_000), 1..60),
        cut in 0usize..60,
    ) {
        let project = example();
        let cut = cut % (steps.len() + 1);
        let (mut whole, mut now) = play_steps(&project, &steps[..cut]);
        let bytes = snapshot::encode(&whole.snapshot());
        let state = snapshot::decode(&bytes).expect("a snapshot decodes");
        prop_assert_eq!(&state, whole.state());
        let mut restored = Player::restore(project.clone(), state).expect("restores");
        let mut now_restored = now;
        for s in &steps[cut..] {
            let a = apply(&mut whole, &mut now, s);
            let b = apply(&mut restored, &mut now_restored, s);
            prop_assert_eq!(a, b);
        }
        prop_assert_eq!(whole.digest(), restored.digest());
        let (reference, _) = play_steps(&project, &steps);
        prop_assert_eq!(reference.digest(), restored.digest());
    }

    /// Snapshots encode and decode losslessly both ways.
    #[test]
    fn snapshots_round_trip(steps in prop::collection::vec(step(30_000_000), 0..60)) {
        let project = example();
        let (player, _) = play_steps(&project, &steps);
        let bytes = snapshot::encode(player.state());
        let state = snapshot::decode(&bytes).expect("decodes");
        prop_assert_eq!(&state, player.state());
        prop_assert_eq!(snapshot::encode(&state), bytes);
    }

    /// A corrupted snapshot (bytes flipped, cut, inserted) is refused, or
    /// decodes to another state whose digest differs — what the mirror
    /// checks against the digest sent with it; nothing panics, and a state
    /// that restores plays on.
    #[test]
    fn corrupt_snapshots_are_refused_or_detected(
        steps in prop::collection::vec(step(30_000_000), 0..40),
        edits in prop::collection::vec((any::<prop::sample::Index>(), 0usize..3, any::<u8>()), 1..4),
        garbage in prop::collection::vec(any::<u8>(), 0..200),
    ) {
        let project = example();
        let (player, now) = play_steps(&project, &steps);
        let good = snapshot::encode(player.state());
        let mut bad = good.clone();
        for (at, kind, byte) in &edits {
            let i = at.index(bad.len().max(1)).min(bad.len());
            match kind {
                0 if i < bad.len() => bad[i] ^= byte | 1,
                1 => bad.truncate(i),
                _ => bad.insert(i, *byte),
            }
        }
        for bytes in [bad, garbage] {
            if bytes == good {
                continue;
            }
            if let Ok(state) = snapshot::decode(&bytes) {
                prop_assert_eq!(snapshot::encode(&state), bytes.clone());
                prop_assert_ne!(snapshot::digest(&state), player.digest());
                if let Ok(mut p) = Player::restore(project.clone(), state) {
                    for (i, name) in EVENTS.iter().enumerate() {
                        p.handle(&Event::new(*name), now + i as u64 * 1_000_000);
                        let ids: Vec<u64> = p.state().pending.keys().copied().collect();
                        for id in ids {
                            p.result(id, Outcome::Done(Params::new()), now + i as u64 * 1_000_000);
                        }
                    }
                    p.advance(now + 3_600_000_000);
                    let _ = p.effects().count();
                }
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 60, ..ProptestConfig::default() })]

    /// A new version that is the running one again is the identity: at
    /// every step of a random trace (events in their declared categories,
    /// as the gateway gives them) the state maps onto itself; at a random
    /// step the swap, checked from there, gives a player with the same
    /// digest that plays the rest of the trace as the running one does. A
    /// state in the catastrophic lockout is refused, and only for that.
    #[test]
    fn a_swap_onto_the_same_version_is_the_identity(
        steps in prop::collection::vec(step(30_000_000), 1..40),
        cut in 0usize..40,
    ) {
        use nets::version::{map, swap, Refusal};
        let project = example();
        let declared = |s: &Step| match s {
            Step::Event { name, params, dt, .. } => {
                let name = EVENTS[*name];
                let category = project
                    .declared_category(name)
                    .unwrap_or(Event::new(name).category);
                Step::Event {
                    name: EVENTS.iter().position(|e| *e == name).unwrap_or(0),
                    category: Category::ALL.iter().position(|c| *c == category).unwrap_or(0),
                    params: params.clone(),
                    dt: *dt,
                }
            }
            other => other.clone(),
        };
        let steps: Vec<Step> = steps.iter().map(declared).collect();
        let cut = cut % steps.len();
        let mut running = Player::start(project.clone(), 0);
        let _ = running.effects().count();
        let mut now = 0;
        for s in &steps[..cut] {
            apply(&mut running, &mut now, s);
            let state = running.state();
            if state.lockout || !state.locked.is_empty() {
                let refused = map(&project, state, &project).expect_err("refused");
                let only_lockout = refused.iter().all(|r| matches!(r, Refusal::Lockout { .. }));
                prop_assert!(only_lockout, "{:?}", refused);
            } else {
                prop_assert_eq!(map(&project, state, &project), Ok(state.clone()));
            }
        }
        if running.state().lockout {
            return Ok(());
        }
        let options = nets::verify::project::Options {
            each_net: false,
            alone: false,
            ..Default::default()
        };
        let mut swapped = swap(&project, running.state(), &project, &options)
            .map_err(|r| TestCaseError::fail(format!("{r:?}")))?;
        prop_assert_eq!(swapped.digest(), running.digest());
        let mut now_swapped = now;
        for s in &steps[cut..] {
            let a = apply(&mut running, &mut now, s);
            let b = apply(&mut swapped, &mut now_swapped, s);
            prop_assert_eq!(a, b);
            prop_assert_eq!(running.digest(), swapped.digest());
        }
    }
}
