//! The team verifier's reductions (symmetry, partial order) against the
//! unreduced exploration, on small teams built from the team fixture: same
//! verdicts, same dead markings up to symmetry, counterexamples that replay
//! on the unreduced player step by step.

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;

use nets::verify::project::{self, Options, Proviso, Report, Steps};
use nets::Project;
use proptest::prelude::*;

const FIXTURE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/team");

fn read(file: &str) -> String {
    std::fs::read_to_string(format!("{FIXTURE}/{file}")).expect("fixture file")
}

/// A variant of the team fixture.
#[derive(Debug, Clone, Copy)]
struct Variant {
    vehicles: usize,
    /// With the team net WATCH, which names R1 and R2 (it breaks their
    /// symmetry).
    watch: bool,
    /// `enter` takes `@bottleneck_free` (else two robots can be inside).
    guarded: bool,
    /// `blocked` gives the bottleneck back and goes `through` (else a stuck
    /// robot keeps it and waits again, and so do the others, for ever: a
    /// dead marking).
    blocked_frees: bool,
    /// `leave` goes back `outside` (a loop) instead of `through`.
    looping: bool,
    /// A robot inside can lose its engine (catastrophic): it goes `down`
    /// and is locked out, keeping the bottleneck (the others wait for ever).
    failing: bool,
    /// With `failing`: a robot may fail outside the bottleneck too, a
    /// failing robot says `down`, and a team net HALT deactivates R2's MOVE
    /// when R1 is down (a catastrophic reaction that deactivates another
    /// vehicle's net, as SYNC does in examples/ugv-bottleneck).
    halting: bool,
}

const PLAIN: Variant = Variant {
    vehicles: 2,
    watch: false,
    guarded: true,
    blocked_frees: true,
    looping: false,
    failing: false,
    halting: false,
};

const HALT: &str = "name = \"HALT\"\nplaces = [\"on\", \"off\"]\ninitial = [\"on\"]\nfinal = [\"on\", \"off\"]\n\n[[transition]]\nname = \"r1_down\"\nfrom = [\"on\"]\nto = [\"off\"]\non = \"down@R1\"\ndo = [\"deactivate MOVE@R2\"]\n";

fn files(v: Variant) -> BTreeMap<String, String> {
    let mut project = read("project.toml");
    let team: String = (1..=v.vehicles)
        .map(|i| format!("[[vehicle]]\nname = \"R{i}\"\nsystem = {i}\n\n"))
        .collect();
    // The fixture's two vehicles are replaced by the variant's team.
    let start = project.find("[[vehicle]]").expect("a vehicle");
    let end = project.find("[programs").expect("programs");
    project.replace_range(start..end, &team);
    if !v.watch {
        project = project.replace("[[net]]\nfile = \"watch.toml\"\nactive = true\n", "");
    }
    let mut moves = read("move.toml");
    if !v.guarded {
        moves = moves
            .replace(
                "from = [\"waiting\", \"@bottleneck_free\"]",
                "from = [\"waiting\"]",
            )
            .replace(
                "to = [\"through\", \"@bottleneck_free\"]",
                "to = [\"through\"]",
            );
    }
    if !v.blocked_frees {
        moves = moves.replace(
            "from = [\"inside\"]\nto = [\"through\", \"@bottleneck_free\"]\non = \"stuck\"",
            "from = [\"inside\"]\nto = [\"waiting\"]\non = \"stuck\"",
        );
    }
    if v.looping {
        moves = moves.replace(
            "from = [\"inside\"]\nto = [\"through\", \"@bottleneck_free\"]\non = \"through\"",
            "from = [\"inside\"]\nto = [\"outside\", \"@bottleneck_free\"]\non = \"through\"",
        );
    }
    if v.failing {
        moves = moves.replace(
            "places = [\"outside\", \"waiting\", \"inside\", \"through\"]",
            "places = [\"outside\", \"waiting\", \"inside\", \"through\", \"down\"]",
        );
        moves.push_str(
            "\n[[transition]]\nname = \"engine_out\"\nfrom = [\"inside\"]\nto = [\"down\"]\non = \"engine_failure\"\n",
        );
        if v.halting {
            moves.push_str("do = [\"emit down\"]\n");
            moves.push_str("\n[[transition]]\nname = \"engine_out_early\"\nfrom = [\"outside\"]\nto = [\"down\"]\non = \"engine_failure\"\ndo = [\"emit down\"]\n");
            project.push_str("\n[[net]]\nfile = \"halt.toml\"\nactive = true\n");
        }
    }
    let mut out = BTreeMap::from([
        ("project.toml".to_owned(), project),
        ("move.toml".to_owned(), moves),
    ]);
    if v.watch {
        out.insert("watch.toml".to_owned(), read("watch.toml"));
    }
    if v.failing && v.halting {
        out.insert("halt.toml".to_owned(), HALT.to_owned());
    }
    out
}

fn load(v: Variant) -> Arc<Project> {
    match nets::load(&files(v)) {
        Ok(p) => Arc::new(p),
        Err(e) => panic!("{v:?}: {e:?}"),
    }
}

fn options(symmetry: bool, partial_order: bool) -> Options<'static> {
    options_with(symmetry, partial_order, Proviso::default())
}

fn options_with(symmetry: bool, partial_order: bool, proviso: Proviso) -> Options<'static> {
    Options {
        each_net: false,
        symmetry,
        partial_order,
        proviso,
        ..Options::default()
    }
}

/// A check of each net in its project (not alone), without reductions,
/// steps run as `steps` says.
fn unreduced(steps: Steps) -> Options<'static> {
    Options {
        alone: false,
        symmetry: false,
        partial_order: false,
        steps,
        ..Options::default()
    }
}

fn check(p: &Arc<Project>, symmetry: bool, partial_order: bool) -> Report {
    project::check(p, &options(symmetry, partial_order)).project
}

fn check_with(p: &Arc<Project>, symmetry: bool, partial_order: bool, proviso: Proviso) -> Report {
    project::check(p, &options_with(symmetry, partial_order, proviso)).project
}

/// Every combination of reductions compared: symmetry, partial order, and
/// with partial order each cycle proviso.
const REDUCTIONS: [(bool, bool, Proviso); 5] = [
    (true, false, Proviso::Components),
    (false, true, Proviso::Components),
    (true, true, Proviso::Components),
    (false, true, Proviso::Levels),
    (true, true, Proviso::Levels),
];

/// The names of the marked places of a marking.
fn named(p: &Project, marked: &[usize]) -> Vec<String> {
    marked
        .iter()
        .map(|&f| nets::player::flat_place_name(p, f))
        .collect()
}

/// A marking's names, the same for every renaming of the vehicles: the
/// smallest sorted list over every permutation of the team's names.
fn up_to_symmetry(p: &Project, marked: &[usize]) -> Vec<String> {
    let names: Vec<String> = p.vehicles.iter().map(|v| v.name.clone()).collect();
    let plain = named(p, marked);
    let mut best: Option<Vec<String>> = None;
    for perm in permutations(names.len()) {
        let mut renamed: Vec<String> = plain
            .iter()
            .map(|s| {
                names.iter().enumerate().fold(s.clone(), |acc, (i, n)| {
                    acc.replace(&format!("@{n}."), &format!("@#{}.", perm[i]))
                })
            })
            .collect();
        renamed.sort();
        if best.as_ref().is_none_or(|b| renamed < *b) {
            best = Some(renamed);
        }
    }
    best.unwrap_or_default()
}

fn permutations(n: usize) -> Vec<Vec<usize>> {
    if n == 0 {
        return vec![Vec::new()];
    }
    let mut out = Vec::new();
    for p in permutations(n - 1) {
        for i in 0..=p.len() {
            let mut q = p.clone();
            q.insert(i, n - 1);
            out.push(q);
        }
    }
    out
}

/// Compares a reduced check with the unreduced one on variant `v`.
fn same_as_unreduced(v: Variant, symmetry: bool, partial_order: bool, proviso: Proviso) {
    let what = format!("{v:?} symmetry {symmetry} partial order {partial_order} {proviso:?}");
    project_same_as_unreduced(&load(v), &what, symmetry, partial_order, proviso);
}

/// Compares a reduced check of `p` with the unreduced one.
fn project_same_as_unreduced(
    p: &Arc<Project>,
    what: &str,
    symmetry: bool,
    partial_order: bool,
    proviso: Proviso,
) {
    let p = p.clone();
    let whole = check(&p, false, false);
    let reduced = check_with(&p, symmetry, partial_order, proviso);
    assert!(whole.complete && reduced.complete, "{what}");
    assert_eq!(whole.holds(), reduced.holds(), "{what}");
    assert_eq!(whole.safe, reduced.safe, "{what}");
    assert_eq!(
        whole.livelocks.is_empty(),
        reduced.livelocks.is_empty(),
        "{what}"
    );
    assert_eq!(
        whole.dead_markings == 0,
        reduced.dead_markings == 0,
        "{what}"
    );
    assert_eq!(whole.loops.is_empty(), reduced.loops.is_empty(), "{what}");
    let resources =
        |r: &Report| -> Vec<String> { r.exclusion.iter().map(|x| x.resource.clone()).collect() };
    assert_eq!(resources(&whole), resources(&reduced), "{what}");
    assert!(reduced.states <= whole.states, "{what}");
    // The same transitions can never fire.
    let never = |r: &Report| -> Vec<String> {
        r.warnings
            .iter()
            .filter(|w| w.contains("can never fire"))
            .cloned()
            .collect()
    };
    assert_eq!(never(&whole), never(&reduced), "{what}");

    // Dead markings: the reduced ones are real, and every real one is
    // found up to symmetry.
    let all: BTreeSet<Vec<String>> = project::dead_markings(&p, &options(false, false))
        .iter()
        .map(|m| up_to_symmetry(&p, m))
        .collect();
    let found: BTreeSet<Vec<String>> =
        project::dead_markings(&p, &options_with(symmetry, partial_order, proviso))
            .iter()
            .map(|m| up_to_symmetry(&p, m))
            .collect();
    assert_eq!(all, found, "{what}");

    // Counterexamples replay on the unreduced player.
    if let Some(example) = &reduced.deadlock_example {
        let ends = project::replay(&p, example).unwrap_or_else(|e| panic!("{what}: {e}"));
        let dead: BTreeSet<Vec<String>> = project::dead_markings(&p, &options(false, false))
            .iter()
            .map(|m| named(&p, m))
            .collect();
        assert!(
            ends.iter().any(|m| dead.contains(&named(&p, m))),
            "{what}: {example:?} ends in no dead marking"
        );
    }
    if let Some(example) = &reduced.unsafe_example {
        project::replay(&p, example).unwrap_or_else(|e| panic!("{what}: {e}"));
    }
    for x in &reduced.exclusion {
        let ends = project::replay(&p, &x.example).unwrap_or_else(|e| panic!("{what}: {e}"));
        let resource = &p.exclusive[0];
        let holders: Vec<String> = ends
            .iter()
            .map(|m| resource.holders(|f| m.contains(&f)))
            .find(|h| h.len() > 1)
            .unwrap_or_else(|| panic!("{what}: {:?} ends with one holder", x.example))
            .iter()
            .map(|&v| p.vehicles[v].name.clone())
            .collect();
        assert_eq!(holders, x.vehicles, "{what}");
    }
    for cycle in &reduced.loops {
        assert!(!cycle.is_empty(), "{what}");
    }
    // Each net in its project: the same verdicts.
    if partial_order {
        let each = |symmetry: bool, partial_order: bool| {
            project::check(
                &p,
                &Options {
                    alone: false,
                    symmetry,
                    partial_order,
                    proviso,
                    ..Options::default()
                },
            )
        };
        let (whole, reduced) = (each(false, false), each(symmetry, partial_order));
        for ((name, a), (_, b)) in whole.nets.iter().zip(&reduced.nets) {
            assert_eq!(a.holds(), b.holds(), "{what} {name}");
            assert_eq!(a.safe, b.safe, "{what} {name}");
            assert_eq!(a.dead_markings == 0, b.dead_markings == 0, "{what} {name}");
        }
    }
}

fn every_reduction(v: Variant) {
    for (symmetry, partial_order, proviso) in REDUCTIONS {
        same_as_unreduced(v, symmetry, partial_order, proviso);
    }
}

#[test]
fn two_and_three_interchangeable_robots_check_alike_reduced_or_not() {
    for vehicles in [2, 3] {
        every_reduction(Variant { vehicles, ..PLAIN });
    }
}

#[test]
fn a_robot_locked_out_by_its_engine_failure_checks_alike_reduced_or_not() {
    // The lockout is per vehicle: the keys carry who is locked out, renamed
    // by the symmetry; the failing robot keeps the bottleneck.
    for vehicles in [2, 3] {
        let v = Variant {
            vehicles,
            failing: true,
            ..PLAIN
        };
        let unreduced = check(&load(v), false, false);
        assert!(unreduced.dead_markings > 0, "{unreduced:?}");
        every_reduction(v);
    }
}

#[test]
fn a_catastrophic_reaction_stopping_another_robot_checks_alike_reduced_or_not() {
    // R1's engine failure locks R1 out, and HALT deactivates R2's MOVE.
    // With three robots, R2 waits for ever when R3 fails inside: R2's MOVE
    // is dead there, and R1 failing outside (any time) must not be taken
    // first by the reduction, which would deactivate it.
    for vehicles in [2, 3] {
        let v = Variant {
            vehicles,
            failing: true,
            halting: true,
            ..PLAIN
        };
        let p = load(v);
        let each = project::check(
            &p,
            &Options {
                alone: false,
                symmetry: false,
                partial_order: false,
                ..Options::default()
            },
        );
        // The verdict the reduction must keep.
        assert!(
            vehicles == 2
                || each
                    .nets
                    .iter()
                    .any(|(name, r)| name == "MOVE@R2" && r.dead_markings > 0),
            "{:?}",
            each.nets
                .iter()
                .map(|(n, r)| (n, r.dead_markings))
                .collect::<Vec<_>>()
        );
        every_reduction(v);
    }
}

#[test]
fn the_two_robot_example_checks_alike_reduced_or_not() {
    let p = ugv(EXAMPLE);
    assert_eq!(p.vehicles.len(), 2);
    for (symmetry, partial_order, proviso) in REDUCTIONS.into_iter().filter(|r| r.1) {
        project_same_as_unreduced(&p, "ugv-bottleneck", symmetry, partial_order, proviso);
    }
}

#[test]
fn the_four_robot_fixture_has_the_example_s_nets() {
    for file in [
        "route.toml",
        "corridor.toml",
        "safety.toml",
        "sync.toml",
        "profile.toml",
    ] {
        let read = |dir: &str| std::fs::read_to_string(format!("{dir}/{file}")).expect(file);
        assert_eq!(read(EXAMPLE), read(UGV4), "{file}");
    }
    assert_eq!(ugv(UGV4).vehicles.len(), 4);
}

const EXAMPLE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/ugv-bottleneck");
const UGV4: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/ugv4");

/// The two-robot example or its four-robot copy, without its profile.
fn ugv(dir: &str) -> Arc<Project> {
    let files: BTreeMap<String, String> = [
        "project.toml",
        "route.toml",
        "corridor.toml",
        "safety.toml",
        "sync.toml",
    ]
    .iter()
    .map(|f| {
        let text = std::fs::read_to_string(format!("{dir}/{f}")).expect("example file");
        ((*f).to_owned(), text)
    })
    .collect();
    Arc::new(nets::load(&files).unwrap_or_else(|e| panic!("{e:?}")))
}

#[test]
fn a_team_net_naming_a_robot_checks_alike_reduced_or_not() {
    for vehicles in [2, 3] {
        every_reduction(Variant {
            vehicles,
            watch: true,
            ..PLAIN
        });
    }
}

#[test]
fn a_violated_exclusion_is_found_reduced_and_replays() {
    for vehicles in [2, 3] {
        for watch in [false, true] {
            let v = Variant {
                vehicles,
                watch,
                guarded: false,
                ..PLAIN
            };
            assert!(!check(&load(v), false, false).exclusion.is_empty(), "{v:?}");
            every_reduction(v);
        }
    }
}

#[test]
fn a_deadlock_is_found_reduced_and_replays() {
    for vehicles in [2, 3] {
        let v = Variant {
            vehicles,
            blocked_frees: false,
            ..PLAIN
        };
        assert!(check(&load(v), false, false).dead_markings > 0, "{v:?}");
        every_reduction(v);
    }
}

#[test]
fn a_loop_is_found_reduced() {
    for vehicles in [2, 3] {
        let v = Variant {
            vehicles,
            looping: true,
            ..PLAIN
        };
        assert!(!check(&load(v), false, false).loops.is_empty(), "{v:?}");
        every_reduction(v);
    }
}

#[test]
fn two_interchangeable_robots_are_explored_one_per_orbit() {
    let p = load(PLAIN);
    let report = project::check(
        &p,
        &Options {
            each_net: false,
            partial_order: false,
            compare_unreduced: true,
            ..Options::default()
        },
    )
    .project;
    assert_eq!(report.reduction.symmetry, [["R1", "R2"]]);
    assert_eq!(report.reduction.group, 2);
    let whole = report.reduction.unreduced_states.expect("compared");
    // Only the initial state and states where both robots are alike are
    // their own image: the rest pair up.
    assert!(
        report.states < whole && report.states * 2 > whole,
        "{report:?}"
    );
}

#[test]
fn a_team_net_naming_a_robot_breaks_its_symmetry() {
    let p = load(Variant {
        watch: true,
        ..PLAIN
    });
    let report = check(&p, true, false);
    assert!(
        report.reduction.symmetry.is_empty(),
        "{:?}",
        report.reduction
    );
    assert_eq!(report.reduction.group, 1);
}

#[test]
fn three_robots_waiting_for_one_bottleneck_are_not_symmetric_for_the_player() {
    // The player fires immediate transitions first declared first: when R1
    // leaves with R2 and R3 waiting, R2 always enters. The model is
    // symmetric, the player is not: the check explores without symmetry
    // and says why.
    let p = load(Variant {
        vehicles: 3,
        ..PLAIN
    });
    let report = check(&p, true, false);
    assert!(
        report.reduction.symmetry.is_empty(),
        "{:?}",
        report.reduction
    );
    assert!(
        report
            .reduction
            .notes
            .iter()
            .any(|n| n.contains("MOVE@R") && n.contains(".enter") && n.contains("declared first")),
        "{:?}",
        report.reduction.notes
    );
    assert_eq!(report.states, check(&p, false, false).states);
}

#[test]
fn the_reductions_say_what_ran() {
    let p = load(PLAIN);
    let plain = check(&p, false, false);
    assert_eq!(plain.reduction.group, 1);
    assert!(!plain.reduction.partial_order);
    assert!(!plain.reduction.order_free);
    let reduced = check(&p, true, true);
    assert!(reduced.reduction.partial_order);
    assert!(reduced.reduction.order_free);
    assert_eq!(reduced.reduction.group, 2);
}

#[test]
fn a_project_without_a_team_is_explored_whole() {
    let files: BTreeMap<String, String> = [
        (
            "project.toml".to_owned(),
            "[events]\ngo = \"nominal\"\n[[net]]\nfile = \"n.toml\"\nactive = true\n".to_owned(),
        ),
        (
            "n.toml".to_owned(),
            "name = \"N\"\nplaces = [\"a\", \"b\"]\ninitial = [\"a\"]\nfinal = [\"b\"]\n[[transition]]\nname = \"t\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"go\"\n".to_owned(),
        ),
    ]
    .into();
    let p = Arc::new(nets::load(&files).unwrap_or_else(|e| panic!("{e:?}")));
    let report = check(&p, true, true);
    assert!(!report.reduction.partial_order);
    assert_eq!(report.reduction.group, 1);
    assert!(report.reduction.notes.is_empty());
}

#[test]
fn each_net_in_its_project_gets_the_same_verdict_reduced() {
    for v in [
        PLAIN,
        Variant {
            blocked_frees: false,
            ..PLAIN
        },
        Variant {
            guarded: false,
            watch: true,
            ..PLAIN
        },
    ] {
        let p = load(v);
        let whole = project::check(
            &p,
            &Options {
                alone: false,
                symmetry: false,
                partial_order: false,
                ..Options::default()
            },
        );
        let reduced = project::check(
            &p,
            &Options {
                alone: false,
                ..Options::default()
            },
        );
        for ((name, a), (_, b)) in whole.nets.iter().zip(&reduced.nets) {
            assert_eq!(a.holds(), b.holds(), "{v:?} {name}");
            assert_eq!(a.safe, b.safe, "{v:?} {name}");
            assert_eq!(a.dead_markings == 0, b.dead_markings == 0, "{v:?} {name}");
            if let Some(example) = &b.deadlock_example {
                project::replay(&p, example).unwrap_or_else(|e| panic!("{v:?} {name}: {e}"));
            }
        }
    }
}

prop_compose! {
    /// A random small team (two or three vehicles).
    fn variant()(
        vehicles in 2usize..=3,
        watch: bool,
        guarded: bool,
        blocked_frees: bool,
        looping: bool,
        failing: bool,
        halting: bool,
    ) -> Variant {
        Variant { vehicles, watch, guarded, blocked_frees, looping, failing, halting }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn random_small_teams_check_alike_reduced_or_not(
        v in variant(),
        symmetry: bool,
        partial_order: bool,
        levels: bool,
    ) {
        same_as_unreduced(
            v,
            symmetry,
            partial_order,
            if levels { Proviso::Levels } else { Proviso::Components },
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, ..ProptestConfig::default() })]

    /// Unreduced, a team's states keep the order of its vehicles' calls
    /// and timers (lockouts too): reusing steps gives the player's steps.
    #[test]
    fn random_small_teams_check_alike_with_steps_reused_or_run(v in variant()) {
        let p = load(v);
        let reused = project::check(&p, &unreduced(Steps::Reuse));
        let run = project::check(&p, &unreduced(Steps::Run));
        prop_assert_eq!(&reused, &run, "{:?}", v);
        if let Err(d) = project::compare_steps(&p, 1) {
            panic!("{v:?}: {d}");
        }
    }
}

#[test]
fn the_ugv_example_unreduced_reuses_the_player_s_steps() {
    // Two robots' calls, timers and lockouts in every order: the states
    // that differ only there reuse each other's steps.
    let p = ugv(EXAMPLE);
    let run = project::check(&p, &unreduced(Steps::Run));
    assert_eq!(project::check(&p, &unreduced(Steps::Reuse)), run);
    let compared = project::compare_steps(&p, 2).unwrap_or_else(|d| panic!("{d}"));
    assert!(
        compared * 4 > run.project.states,
        "{compared} of {} states",
        run.project.states
    );
}

#[test]
fn an_event_of_a_family_the_nets_emit_for_others_is_produced_by_nothing() {
    // SYNC emits `detour@R1`, `detour@R2` (and `resume@…`) only; `detour` is
    // not declared: R3's and R4's are the nets' own family, which no
    // program may send and nothing produces.
    let warnings: Vec<String> = project::static_warnings(&ugv(UGV4))
        .into_iter()
        .map(|w| w.text)
        .collect();
    for (event, transition) in [
        ("detour@R3", "CORRIDOR@R3.told"),
        ("resume@R4", "CORRIDOR@R4.resume"),
    ] {
        let base = event.split('@').next().unwrap_or(event);
        let expected = format!(
            "event `{event}` (awaited by {transition}) is produced by nothing: of its family `{base}` the nets emit `{base}@R1`, `{base}@R2` only"
        );
        assert!(
            warnings.iter().any(|w| w.starts_with(&expected)),
            "{expected}\n{warnings:#?}"
        );
    }
    // The two-robot example: every robot's `detour` and `resume` is
    // emitted.
    let two = project::static_warnings(&ugv(EXAMPLE));
    assert!(
        !two.iter().any(|w| w.text.contains("of its family")),
        "{two:?}"
    );
}

#[test]
fn results_delivered_to_each_robot_s_own_net_keep_the_symmetry_of_r3_and_r4() {
    // R3 and R4 are named by no team net: exchanging them maps the project
    // onto itself. A result is handed to the net that called, so
    // ROUTE@R3.end and ROUTE@R4.leg enabled together (both wait for
    // `PLN.next.done`) are no order the player decides between vehicles.
    let p = ugv(UGV4);
    let report = project::check(
        &p,
        &Options {
            each_net: false,
            partial_order: false,
            max_states: 20_000,
            ..Options::default()
        },
    )
    .project;
    assert_eq!(report.reduction.symmetry, [["R3", "R4"]]);
    assert_eq!(report.reduction.group, 2, "{:?}", report.reduction.notes);
    assert!(
        report.reduction.notes.is_empty(),
        "{:?}",
        report.reduction.notes
    );
}

#[test]
fn two_robots_without_the_team_net_are_symmetric_and_check_alike_reduced_or_not() {
    // The example without SYNC: R1 and R2 interchangeable, each robot's
    // results handed to its own nets (the symmetry holds for the player).
    let mut files: BTreeMap<String, String> =
        ["project.toml", "route.toml", "corridor.toml", "safety.toml"]
            .iter()
            .map(|f| {
                let text = std::fs::read_to_string(format!("{EXAMPLE}/{f}")).expect("example file");
                ((*f).to_owned(), text)
            })
            .collect();
    let project =
        files["project.toml"].replace("[[net]]\nfile = \"sync.toml\"\nactive = true\n", "");
    assert_ne!(project, files["project.toml"], "SYNC's [[net]] left out");
    files.insert("project.toml".to_owned(), project);
    let p = Arc::new(nets::load(&files).unwrap_or_else(|e| panic!("{e:?}")));
    let reduced = check(&p, true, true);
    assert_eq!(reduced.reduction.group, 2, "{:?}", reduced.reduction.notes);
    for (symmetry, partial_order, proviso) in REDUCTIONS {
        project_same_as_unreduced(
            &p,
            "ugv-bottleneck without SYNC",
            symmetry,
            partial_order,
            proviso,
        );
    }
}

/// One robot's net with two tokens: `ask` calls PLN.f; its result moves
/// `p0` to `p1` and, if `q_in` is marked by then, `q_in` to `q_out` too
/// (one occurrence fires both); `go` marks `q_in`. When the result comes
/// before `go`, `q_in` stays marked (a final place); after, the robot ends
/// at `p1` and `q_out`, no final place marked: a dead marking.
const TWO_TOKENS: &str = "name = \"X\"\nvehicles = \"all\"\nplaces = [\"idle\", \"p0\", \"p1\", \"q_wait\", \"q_in\", \"q_out\"]\ninitial = [\"idle\", \"q_wait\"]\nfinal = [\"q_in\"]\n\n[[transition]]\nname = \"ask\"\nfrom = [\"idle\"]\nto = [\"p0\"]\non = \"start\"\ndo = [\"call PLN.f\"]\n\n[[transition]]\nname = \"first\"\nfrom = [\"p0\"]\nto = [\"p1\"]\non = \"PLN.f.done\"\n\n[[transition]]\nname = \"second\"\nfrom = [\"q_in\"]\nto = [\"q_out\"]\non = \"PLN.f.done\"\n\n[[transition]]\nname = \"go\"\nfrom = [\"q_wait\"]\nto = [\"q_in\"]\non = \"go\"\n";

#[test]
fn a_step_that_fires_more_once_another_input_marks_a_place_keeps_its_dead_marking() {
    // In the state after `ask`, the result of PLN.f can fire only `first`
    // (`q_in` is not marked): its footprint read in the state is `p0`,
    // `p1` and the pending call, which `go` does not touch. But `go` marks
    // what `second` lacks: a stubborn set holding the result must hold
    // `go` too, or the reduction takes the result first every time and
    // never reaches the dead marking (`p1`, `q_out`) that `go` then the
    // result make.
    let files: BTreeMap<String, String> = [
        (
            "project.toml".to_owned(),
            "[events]\nstart = \"nominal\"\ngo = \"nominal\"\n\n[[vehicle]]\nname = \"R1\"\nsystem = 1\n\n[[vehicle]]\nname = \"R2\"\nsystem = 2\n\n[programs.PLN.functions]\nf = {}\n\n[[net]]\nfile = \"x.toml\"\nactive = true\n".to_owned(),
        ),
        ("x.toml".to_owned(), TWO_TOKENS.to_owned()),
    ]
    .into();
    let p = Arc::new(nets::load(&files).unwrap_or_else(|e| panic!("{e:?}")));
    let whole = check(&p, false, false);
    assert!(whole.dead_markings > 0, "{whole:?}");
    for (symmetry, partial_order, proviso) in REDUCTIONS {
        project_same_as_unreduced(&p, "two tokens", symmetry, partial_order, proviso);
    }
    // The reduction does reduce here: R1 and R2 are independent.
    let reduced = check(&p, false, true);
    assert!(reduced.states < whole.states, "{reduced:?}");
}
