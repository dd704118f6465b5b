//! `petrel check` and the operator dialog: every outcome of every question
//! (each choice, and the timeout) is explored.

use crate::common;
use nets::verify::project::{check, Options, ProjectReport};

fn survey(on_yes: &str, on_no: &str, on_timeout: &str) -> ProjectReport {
    let net = format!(
        r#"name = "N"
places = ["idle", "asking", "surveying", "skipped", "stuck"]
initial = ["idle"]
final = ["surveying", "skipped"]
[[transition]]
name = "ask"
from = ["idle"]
to = ["asking"]
on = "reached_t2"
do = ['ask survey "Survey T2?" {{choices: [yes, no]}} timeout 60s']
[[transition]]
name = "yes"
from = ["asking"]
to = ["{on_yes}"]
on = "survey.yes"
[[transition]]
name = "no"
from = ["asking"]
to = ["{on_no}"]
on = "survey.no"
[[transition]]
name = "timeout"
from = ["asking"]
to = ["{on_timeout}"]
on = "survey.timeout"
"#
    );
    let p = common::project(&[
        (
            "project.toml",
            "[[net]]\nfile = \"n.toml\"\nactive = true\n",
        ),
        ("n.toml", &net),
    ]);
    check(&p, &Options::default())
}

fn never_fired(report: &ProjectReport) -> Vec<String> {
    report
        .project
        .warnings
        .iter()
        .filter(|w| w.ends_with("can never fire"))
        .cloned()
        .collect()
}

#[test]
fn each_choice_and_the_timeout_are_explored() {
    let report = survey("surveying", "skipped", "skipped");
    assert!(report.holds(), "{report:#?}");
    assert_eq!(never_fired(&report), Vec::<String>::new(), "{report:#?}");
    assert_eq!(report.project.dead_markings, 0);
}

#[test]
fn a_timeout_leading_nowhere_is_a_deadlock_found_through_the_timeout() {
    let report = survey("surveying", "skipped", "stuck");
    let r = &report.project;
    assert_eq!(r.dead_markings, 1, "{report:#?}");
    assert_eq!(
        r.deadlock_example.as_deref(),
        Some(
            &[
                "reached_t2 → N.ask".to_owned(),
                "timer N.survey.timeout → N.timeout".to_owned()
            ][..]
        )
    );
}

#[test]
fn a_choice_leading_nowhere_is_a_deadlock_found_through_that_answer() {
    for (yes, no, answer) in [
        ("stuck", "skipped", "survey.yes (answer) → N.yes"),
        ("surveying", "stuck", "survey.no (answer) → N.no"),
    ] {
        let report = survey(yes, no, "skipped");
        let r = &report.project;
        assert_eq!(r.dead_markings, 1, "{report:#?}");
        assert_eq!(
            r.deadlock_example.as_deref(),
            Some(&["reached_t2 → N.ask".to_owned(), answer.to_owned()][..])
        );
    }
}
