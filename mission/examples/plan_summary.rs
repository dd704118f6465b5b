//! Reads each plan file named on the command line and says what it holds,
//! or why it is refused: `cargo run -p petrel-mission --example
//! plan_summary -- FILE...`. Exit status 1 if any file is refused.

fn main() {
    let mut refused = false;
    for path in std::env::args().skip(1) {
        let text = match std::fs::read(&path) {
            Ok(bytes) => String::from_utf8_lossy(&bytes).into_owned(),
            Err(e) => {
                println!("{path}: cannot be read: {e}");
                refused = true;
                continue;
            }
        };
        match petrel_mission::read(&path, &text) {
            Ok(plan) => {
                for f in petrel_mission::review(&plan) {
                    println!(
                        "{path}: {}{}: {}",
                        f.seq.map_or(String::new(), |s| format!("item {s}: ")),
                        f.what,
                        f.remedy
                    );
                }
                let commands: Vec<String> = plan.items.iter().map(|i| i.command_name()).collect();
                println!(
                    "{path}: {:?}, {:?} {:?}, home {}, {} items ({}), fence {} polygons {} circles, {} rally points, {} unsupported{}",
                    plan.format,
                    plan.autopilot,
                    plan.vehicle,
                    plan.home.is_some(),
                    plan.items.len(),
                    commands.join(" "),
                    plan.fence.polygons.len(),
                    plan.fence.circles.len(),
                    plan.rally.len(),
                    plan.unsupported.len(),
                    plan.unsupported
                        .iter()
                        .map(|u| format!(" [{:?}: {}: {}]", u.origin, u.what, u.remedy))
                        .collect::<String>()
                );
            }
            Err(e) => {
                println!("{e}");
                refused = true;
            }
        }
    }
    std::process::exit(i32::from(refused));
}
