//! What `run` says of the check of the autopilot parameters the project
//! needs (`[gateway.parameters]`), and whether it may go on.

/// Reports the check of `[gateway.parameters]`; false when the gateway must
/// refuse to go on: a parameter is wrong or unreadable and the vehicle is
/// not armed. An armed vehicle is never abandoned (`vehicle`: `vehicle R2: `
/// in a team, else empty): the misfit is reported
/// and supervision goes on.
pub(super) fn parameters_fit(
    vehicle: &str,
    verdict: &petrel_core::vehicle::parameters::Verdict,
    armed: Option<bool>,
) -> bool {
    if verdict.holds() {
        let read: Vec<String> = verdict
            .read
            .iter()
            .map(|(name, value)| format!("{name} = {value}"))
            .collect();
        if !read.is_empty() {
            say!("{vehicle}autopilot parameters checked: {}", read.join(", "));
        }
        return true;
    }
    let misfits: Vec<String> = verdict.misfits.iter().map(|m| format!("  {m}")).collect();
    if armed == Some(true) {
        say!(
            "warning: {vehicle}the vehicle's parameters do not fit the project ([gateway.parameters] in project.toml), but it is armed: supervision goes on\n{}",
            misfits.join("\n")
        );
        return true;
    }
    say!(
        "refused: {vehicle}the vehicle's parameters do not fit the project ([gateway.parameters] in project.toml); set them on the autopilot and start again:\n{}",
        misfits.join("\n")
    );
    false
}
