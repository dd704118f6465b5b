//! A new version taken in flight (issue 38): the time from the last piece
//! of a version sent up from the ground to its swap, as `petrel run` does
//! it — unpacked (`gateway::upload::unpack`) and loaded, checked from its
//! own start (the pre-flight check: explored, or remembered because the
//! same files were checked before: `petrel reload`, or the mirror that
//! sent it, on the same machine), proved from the running state
//! (`petrel_core::version`, the exploration from the mid-mission state)
//! and swapped — beside, in the same run, the pre-flight check alone
//! (what `petrel run` waits for before it flies; the baseline). A version
//! read from disk on SIGHUP takes the same path, reading instead of
//! unpacking.
//!
//! The project: `examples/uav-flight-test` mid-mission (its nominal
//! script played to line 26, the operations area); the new version is the
//! example with a comment added to COMMUNICATION (other files, so another
//! pre-flight digest; the same nets, so everything is reachable: the
//! exploration's worst case).
//!
//! Run: `cargo bench -p gateway --bench reload` (`PETREL_BENCH_RUNS`
//! runs, 3 by default: medians).

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use gateway::preflight::{check_project, Inputs, Preflight};
use nets::{Player, Project};
use petrel_core::version::{Report, Versions};

fn example() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/uav-flight-test")
}

/// The player after the first `lines` lines of the nominal script.
fn mid_mission(project: &Arc<Project>, lines: usize) -> Player {
    let text =
        std::fs::read_to_string(example().join("scripts/nominal.jsonl")).expect("the script");
    let script = nets::script::parse(&text).unwrap_or_else(|e| panic!("{e:?}"));
    let mut player = Player::start(project.clone(), 0);
    let _ = player.effects().count();
    for line in script.iter().take(lines) {
        nets::script::play_line(&mut player, line).unwrap_or_else(|e| panic!("{e:?}"));
        let _ = player.effects().count();
    }
    player
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// One version taken from its packed bytes: unpack, load, check
/// (remembered when `cached`), prove, swap. The seconds it took.
fn reload(
    packed: &[u8],
    catalog: &nets::load::Catalog,
    layers: &[(String, String)],
    player: &Player,
    cached: bool,
) -> f64 {
    let start = Instant::now();
    let files = gateway::upload::unpack(packed).expect("it unpacks");
    let sources: std::collections::BTreeMap<String, String> = files.iter().cloned().collect();
    let new = Arc::new(petrel_mission::load(&sources, Some(catalog)).expect("it loads"));
    let inputs = Inputs {
        files: &files,
        layers,
    };
    match check_project(&new, &inputs, !cached) {
        Preflight::Failed(_) => panic!("the new version fails its check"),
        Preflight::Remembered { .. } => assert!(cached, "remembered without asking"),
        Preflight::Held { .. } => assert!(!cached, "explored though remembered"),
    }
    let mut versions = Versions::default();
    versions.offer(new, files, player);
    let proof = versions.poll_proof().expect("a proof");
    let version = versions
        .proved(proof.run(), player)
        .unwrap_or_else(|| panic!("{:?}", std::iter::from_fn(|| versions.poll_report()).last()));
    let state =
        nets::version::map(player.project(), player.state(), &version.project).expect("it maps");
    let swapped = Player::restore(version.project.clone(), state).expect("it restores");
    let seconds = start.elapsed().as_secs_f64();
    assert_eq!(
        swapped.state().marking,
        player.state().marking,
        "the marking kept"
    );
    versions.took_over(&version, 1, Vec::new());
    assert!(
        std::iter::from_fn(|| versions.poll_report()).any(|r| matches!(r, Report::Swapped { .. }))
    );
    seconds
}

fn main() {
    let runs = std::env::var("PETREL_BENCH_RUNS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3usize);
    // The pre-flight cache of this bench alone.
    let scratch = tempfile::tempdir().expect("a folder");
    std::env::set_var("XDG_CACHE_HOME", scratch.path().join("cache"));
    let dir = scratch.path().join("version");
    std::fs::create_dir_all(&dir).expect("a folder");
    for entry in std::fs::read_dir(example()).expect("the example") {
        let path = entry.expect("an entry").path();
        if path.is_file() {
            std::fs::copy(&path, dir.join(path.file_name().expect("a name"))).expect("copied");
        }
    }
    let communication = dir.join("communication.toml");
    let text = std::fs::read_to_string(&communication).expect("the net");
    std::fs::write(&communication, format!("{text}\n# version 1\n")).expect("write");

    let layers = petrel_core::profile::Layers::pick(
        None,
        Some((&example(), Some("profile.toml"))),
        "ardupilot",
    )
    .expect("the profile's layers");
    let profile = layers.load().expect("the profile");
    let catalog = petrel_core::project::catalog(&profile);
    let (running, _) =
        petrel_core::project::load_read(&example(), &catalog).expect("the example loads");
    let player = mid_mission(&running, 26);

    let (_, version_files) = petrel_core::project::load_read(&dir, &catalog).expect("loads");
    let packed = gateway::upload::pack(&version_files).expect("it packs");
    println!(
        "the version: {} files, {} bytes packed",
        version_files.len(),
        packed.len()
    );
    let (mut checks, mut uncached, mut cached) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..runs {
        let (new, files) = petrel_core::project::load_read(&dir, &catalog).expect("loads");
        let inputs = Inputs {
            files: &files,
            layers: &layers.layers,
        };
        let t = Instant::now();
        let held = check_project(&new, &inputs, true);
        checks.push(t.elapsed().as_secs_f64());
        assert!(matches!(held, Preflight::Held { .. }));
        uncached.push(reload(&packed, &catalog, &layers.layers, &player, false));
        cached.push(reload(&packed, &catalog, &layers.layers, &player, true));
    }
    let (base, uncached, cached) = (median(checks), median(uncached), median(cached));
    println!(
        "last piece to swap, flight-test mid-mission: {uncached:.3} s with its check explored, {cached:.3} s with it remembered; the pre-flight check alone {base:.3} s; ratios {:.2} and {:.2} (median of {runs})",
        uncached / base,
        cached / base
    );
}
