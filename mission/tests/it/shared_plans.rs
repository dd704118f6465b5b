//! Every file of `../shared/plans` through [`petrel_mission::read`].

use petrel_mission::{read, review, Autopilot, Format, Origin};

use crate::skip;

/// The plans folder, or `None` (the test skipped, saying why; a failure
/// under CI=true).
fn plans() -> Option<std::path::PathBuf> {
    let dir = skip::shared_dir().join("plans");
    if dir.join("INDEX.md").is_file() {
        return Some(dir);
    }
    let why = format!(
        "{} is missing (../shared beside the workspace root)",
        dir.display()
    );
    assert!(!skip::in_ci(), "{why}");
    skip::skip(&why);
    None
}

/// The files QGroundControl itself refuses, and why (FORMATS.md).
const REFUSED: &[(&str, &str)] = &[
    (
        "mavsdk-missionraw_qgroundcontrol_sample_wrong_mission_version.plan",
        "mission.version: 7: QGroundControl reads missions of version 2 only",
    ),
    (
        "mavsdk-missionraw_qgroundcontrol_sample_without_mission.plan",
        "(top): `mission` is missing",
    ),
    (
        "mavsdk-missionraw_qgroundcontrol_sample_with_survey_wrong_version.plan",
        "survey version 9: QGroundControl reads versions 2 to 5",
    ),
    // A `//` comment: not JSON, as QGroundControl's reader says too.
    (
        "px4-mavsdktests_fw_mission.plan",
        "not a QGroundControl plan (JSON)",
    ),
];

#[test]
fn every_shared_plan_reads_or_is_refused_with_its_reason() {
    let Some(dir) = plans() else { return };
    let mut read_ok = 0;
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .expect("the plans folder")
        .filter_map(Result::ok)
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !n.ends_with(".md"))
        .collect();
    names.sort();
    assert!(names.len() >= 20, "{names:?}");
    for name in &names {
        let text = std::fs::read_to_string(dir.join(name)).expect("a plan file");
        let result = read(name, &text);
        match REFUSED.iter().find(|(n, _)| n == name) {
            Some((_, why)) => {
                let e = result.expect_err(name);
                assert!(e.to_string().contains(why), "{name}: {e}");
            }
            None => {
                let plan = result.unwrap_or_else(|e| panic!("{e}"));
                // Sequences from 1, in order; every item has its origin.
                for (k, item) in plan.items.iter().enumerate() {
                    assert_eq!(usize::from(item.seq), k + 1, "{name}");
                }
                assert!(
                    !plan.items.is_empty()
                        || !plan.fence.is_empty()
                        || !plan.unsupported.is_empty(),
                    "{name}: nothing read"
                );
                read_ok += 1;
            }
        }
    }
    eprintln!(
        "{read_ok} of {} plan files read, {} refused as QGroundControl refuses them",
        names.len(),
        REFUSED.len()
    );
}

#[test]
fn real_arduplane_files_read_with_their_home_jumps_and_autopilot() {
    let Some(dir) = plans() else { return };
    let text = std::fs::read_to_string(dir.join("ardupilot-autotest_CMAC-toff-loop.txt"))
        .expect("the waypoint file");
    let plan = read("ardupilot-autotest_CMAC-toff-loop.txt", &text).expect("reads");
    assert_eq!(plan.format, Format::Wpl110);
    assert!(plan.home.is_some());
    assert_eq!(plan.items[0].origin, Origin::Line(3));
    // Its DO_JUMP targets an item that exists.
    for jump in plan.items.iter().filter(|i| i.command == 177) {
        let target = jump.params[0] as usize;
        assert!(target >= 1 && target <= plan.items.len(), "{jump:?}");
    }
    let text = std::fs::read_to_string(dir.join("qgc-testplans_ArduPilotSITL-ArduPlane.plan"))
        .expect("the plan");
    let plan = read("qgc-testplans_ArduPilotSITL-ArduPlane.plan", &text).expect("reads");
    assert_eq!(plan.format, Format::QgcPlan);
    assert_eq!(plan.autopilot, Some(Autopilot::ArduPilot));
    assert!(!plan.items.is_empty());
}

#[test]
fn a_survey_without_its_waypoints_is_named_with_what_to_do() {
    let Some(dir) = plans() else { return };
    let name = "mavsdk-missionraw_qgroundcontrol_sample_with_structured_scan.plan";
    let text = std::fs::read_to_string(dir.join(name)).expect("the plan");
    let plan = read(name, &text).expect("reads");
    assert!(
        plan.unsupported
            .iter()
            .any(|u| u.what == "StructureScan" && !u.remedy.is_empty()),
        "{:?}",
        plan.unsupported
    );
}

#[test]
fn a_waypoint_file_whose_row_0_is_no_home_says_so_and_a_fence_file_has_none() {
    let Some(dir) = plans() else { return };
    let name = "px4-integrationtests_vtol_new_1.txt";
    let text = std::fs::read_to_string(dir.join(name)).expect("the file");
    let plan = read(name, &text).expect("reads");
    assert!(
        plan.unsupported
            .iter()
            .any(|u| u.what == "row 0 is NAV_VTOL_TAKEOFF, read as home"
                && u.origin == Origin::Line(3)),
        "{:?}",
        plan.unsupported
    );
    let name = "mavproxy-fieldcheck_springvalleybottom-foamy-fence.txt";
    let text = std::fs::read_to_string(dir.join(name)).expect("the file");
    let plan = read(name, &text).expect("reads");
    assert!(plan.home.is_none());
    assert!(plan.fence.breach_return.is_some());
    assert_eq!(plan.fence.polygons.len(), 1);
    assert_eq!(plan.fence.polygons[0].vertices.len(), 4);
    assert!(plan.items.is_empty());
}

#[test]
fn the_review_finds_what_the_shared_files_hold_and_nothing_else() {
    let Some(dir) = plans() else { return };
    let findings = |name: &str| -> Vec<(Option<u16>, String)> {
        let text = std::fs::read_to_string(dir.join(name)).expect("the file");
        let plan = read(name, &text).expect("reads");
        review(&plan).into_iter().map(|f| (f.seq, f.what)).collect()
    };
    // ArduPilot's own autotest and MAVProxy's field check loop for ever.
    for name in [
        "ardupilot-autotest_CMAC-toff-loop.txt",
        "mavproxy-fieldcheck_cmac-foamy-mission-ccw.txt",
    ] {
        assert_eq!(
            findings(name),
            [(Some(6), "DO_JUMP to item 2 repeats for ever".to_owned())],
            "{name}"
        );
    }
    // A bounded jump is fine.
    assert_eq!(findings("ardupilot-autotest_copter_mission.txt"), []);
    assert_eq!(
        findings("qgc-custom_ce_geofence_home_base.plan"),
        [(None, "no mission items (a fence or rally plan)".to_owned())]
    );
    assert!(
        findings("mavsdk-missionraw_qgroundcontrol_sample_with_structured_scan.plan")
            .iter()
            .any(|(_, w)| w == "StructureScan")
    );
    // QGroundControl's own ArduPlane test plan: its terrain-computed
    // altitudes are missing until QGroundControl had terrain data.
    assert_eq!(
        findings("qgc-testplans_ArduPilotSITL-ArduPlane.plan"),
        [(Some(4), "NAV_LOITER_TURNS without an altitude".to_owned())]
    );
}
