//! Which autopilot is on the link, when the elaboration profile follows
//! it: the first autopilot HEARTBEAT heard, and the profile and project
//! loaded for it.

use std::time::Duration;

use mavlink::dialects::ardupilotmega::{MavAutopilot, MavMessage, MavType};

use super::signals::Signals;
use super::{ProfileChoice, Setup};
use crate::link::{LinkReader, LinkWriter, Received};

/// Reads the link until the first autopilot HEARTBEAT (not a ground
/// station's, not a companion's), at most `limit` of wall time: the frames
/// read, and the autopilot's family when one was heard.
pub(super) async fn identify(
    reader: &mut LinkReader,
    writer: &LinkWriter,
    announce: (u8, u8),
    limit: Duration,
    signals: &mut Signals,
) -> (Vec<Received>, Option<elaboration::Firmware>, bool) {
    let until = tokio::time::Instant::now() + limit;
    let mut early = Vec::new();
    // Speak first while waiting, as the commander will (docs/run.md):
    // behind an endpoint that waits for its client, nothing comes otherwise.
    let mut beat = tokio::time::interval(Duration::from_secs(1));
    loop {
        let received = tokio::select! {
            r = tokio::time::timeout_at(until, reader.recv()) => r,
            _ = beat.tick() => {
                let _ = writer.send(announce, &petrel_core::vehicle::commander::companion_heartbeat()).await;
                continue;
            }
            _ = signals.recv() => return (early, None, true),
        };
        match received {
            Err(_) => return (early, None, false),
            Ok(Ok(rx)) => {
                let heard = match &rx.message {
                    Some(MavMessage::HEARTBEAT(hb))
                        if hb.autopilot != MavAutopilot::MAV_AUTOPILOT_INVALID
                            && hb.mavtype != MavType::MAV_TYPE_GCS
                            && hb.mavtype != MavType::MAV_TYPE_ONBOARD_CONTROLLER =>
                    {
                        Some(elaboration::Firmware::from_heartbeat(
                            hb.autopilot as i64,
                            hb.mavtype as i64,
                        ))
                    }
                    _ => None,
                };
                early.push(rx);
                if heard.is_some() {
                    return (early, heard, false);
                }
            }
            Ok(Err(e)) => {
                tracing::warn!("{e}");
                tokio::time::sleep(Duration::from_millis(200)).await;
            }
        }
    }
}

/// The profile and the project for the autopilot heard (`None`: none within
/// the wait; ArduPilot's profile stays, and the user is told).
pub(super) fn adopt(
    setup: &mut Setup,
    choice: &ProfileChoice,
    heard: Option<elaboration::Firmware>,
) -> Result<(), miette::Report> {
    let base = match heard {
        Some(elaboration::Firmware::Px4) => "px4",
        Some(_) => "ardupilot",
        None => {
            say!(
                "no autopilot HEARTBEAT yet: elaboration uses the ArduPilot profile (give --profile px4 or [gateway] firmware = \"px4\" for PX4)"
            );
            return Ok(());
        }
    };
    say!(
        "autopilot: {}, elaboration profile {base}",
        if base == "px4" { "PX4" } else { "ArduPilot" }
    );
    if setup.layers.layers.first().map(|(n, _)| n.as_str()) == Some(&format!("{base}.toml")) {
        return Ok(());
    }
    let layers = choice.layers(&setup.dir, base)?;
    let Some(profile) = crate::cli::loaded(&layers) else {
        return Err(miette::miette!("the {base} profile does not load"));
    };
    setup.project =
        petrel_core::project::load_with(&setup.dir, &petrel_core::project::catalog(&profile))?;
    setup.profile = profile;
    setup.layers = layers;
    Ok(())
}
