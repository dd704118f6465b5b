//! `petrel events FILE.tlog [--profile ardupilot|px4|FILE.toml] [--json]`:
//! elaborates a telemetry log into supervision events.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use elaboration::{Config, Elaborated, Elaborator, Firmware, Profile, TlogReader};
use miette::{miette, IntoDiagnostic, WrapErr};

use super::{Outcome, VerbResult};

#[derive(clap::Args)]
pub struct Args {
    /// The telemetry log (8-byte big-endian microsecond timestamp before each frame).
    pub file: PathBuf,
    /// `ardupilot`, `px4`, or a profile file extending the built-in one of
    /// the log's autopilot. By default, the built-in one of the log's autopilot.
    #[arg(long)]
    pub profile: Option<String>,
    /// One JSON object a line on stdout instead of a timeline for people.
    #[arg(long)]
    pub json: bool,
    /// The supervised vehicle's system id (default: the first autopilot heard).
    #[arg(long)]
    pub sysid: Option<u8>,
    /// Its autopilot's component id.
    #[arg(long)]
    pub compid: Option<u8>,
    /// Firmware family for mode names: copter, plane, rover, sub, px4.
    #[arg(long)]
    pub firmware: Option<String>,
}

/// The built-in profile of the first autopilot HEARTBEAT in the log.
fn detect(bytes: &[u8]) -> &'static str {
    use mavlink::dialects::ardupilotmega::{MavAutopilot, MavMessage, MavType};
    for rec in TlogReader::new(bytes) {
        if rec.frame.message_id() != 0 {
            continue;
        }
        if let Ok(MavMessage::HEARTBEAT(hb)) = rec.frame.decode() {
            if hb.mavtype == MavType::MAV_TYPE_GCS
                || hb.autopilot == MavAutopilot::MAV_AUTOPILOT_INVALID
            {
                continue;
            }
            return if hb.autopilot == MavAutopilot::MAV_AUTOPILOT_PX4 {
                "px4"
            } else {
                "ardupilot"
            };
        }
    }
    "ardupilot"
}

/// The profile for a log: `choice` (`ardupilot`, `px4` or a file extending
/// the log's built-in one), else the project's `[gateway] profile`, else the
/// built-in profile of the log's autopilot. Problems are printed; `Err(())`
/// then.
pub(crate) fn load_profile(
    choice: Option<&str>,
    project: Option<&Path>,
    bytes: &[u8],
) -> Result<Result<(Profile, petrel_core::profile::Layers), ()>, miette::Report> {
    let setting = match project {
        Some(dir) if choice.is_none() => petrel_core::project::gateway_setting(dir, "profile")?,
        _ => None,
    };
    let project = project.map(|dir| (dir, setting.as_deref()));
    let layers = petrel_core::profile::Layers::pick(choice, project, detect(bytes))?;
    Ok(crate::cli::loaded(&layers).map(|p| (p, layers)).ok_or(()))
}

fn json_line(e: &Elaborated, first_us: u64) -> serde_json::Value {
    let params: serde_json::Map<String, serde_json::Value> = e
        .event
        .params
        .iter()
        .map(|(k, v)| (k.clone(), v.to_json()))
        .collect();
    serde_json::json!({
        "time_us": e.time_us,
        "t": seconds(e.time_us, first_us),
        "event": e.event.name,
        "category": e.event.category.as_str(),
        "params": params,
        "sysid": e.sysid,
        "compid": e.compid,
    })
}

fn seconds(time_us: u64, first_us: u64) -> f64 {
    let d = time_us as i128 - first_us as i128;
    (d as f64 / 1e6 * 1e6).round() / 1e6
}

pub fn run(args: Args) -> VerbResult {
    let bytes = petrel_record::read::whole(&args.file)
        .into_diagnostic()
        .wrap_err_with(|| format!("cannot read {}", args.file.display()))?;
    let firmware = match args.firmware.as_deref() {
        None => None,
        Some(f) => match Firmware::parse(f) {
            Some(f) => Some(f),
            None => {
                return Err(miette!(
                    "unknown firmware `{f}` (copter, plane, rover, sub, px4)"
                ))
            }
        },
    };
    let Ok((profile, _)) = load_profile(args.profile.as_deref(), None, &bytes)? else {
        return Ok(Outcome::BadInput);
    };
    run_on(&args.file, &bytes, profile, firmware, &args)
}

fn run_on(
    file: &Path,
    bytes: &[u8],
    profile: Profile,
    firmware: Option<Firmware>,
    args: &Args,
) -> VerbResult {
    let config = Config {
        sysid: args.sysid,
        compid: args.compid,
        firmware,
        ..Config::default()
    };
    let mut elab = Elaborator::new(profile, config);
    let mut reader = TlogReader::new(bytes);
    let mut first_us = None;
    let mut counts: BTreeMap<String, u64> = BTreeMap::new();
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let mut emit = |e: Elaborated, first: u64, out: &mut dyn Write| -> std::io::Result<()> {
        *counts.entry(e.event.name.clone()).or_default() += 1;
        if args.json {
            writeln!(out, "{}", json_line(&e, first))
        } else {
            writeln!(
                out,
                "{:>10.3}s  {:<13}  {}  [{}/{}]",
                seconds(e.time_us, first),
                e.event.category.as_str(),
                e.event,
                e.sysid,
                e.compid
            )
        }
    };
    for rec in reader.by_ref() {
        let first = *first_us.get_or_insert(rec.time_us);
        elab.frame(rec.time_us, &rec.frame);
        while let Some(e) = elab.poll_event() {
            emit(e, first, &mut out).into_diagnostic()?;
        }
    }
    out.flush().into_diagnostic()?;
    drop(out);
    let read = reader.stats();
    let stats = elab.stats();
    let mut err = std::io::stderr().lock();
    let _ = writeln!(err, "{}: {} frames", file.display(), read.frames);
    let _ = writeln!(
        err,
        "  skipped: {} bad-CRC records {:?}, {} unknown-id records {:?}, {} with unknown MAVLink 2 flags, {} bytes of garbage ({} resyncs), {} truncated bytes at the end; {} backwards timestamps",
        read.bad_crc_total(),
        read.bad_crc,
        read.unknown_ids.values().sum::<u64>(),
        read.unknown_ids,
        read.incompatible,
        read.skipped_bytes,
        read.resyncs,
        read.truncated_tail,
        read.backwards_timestamps
    );
    let _ = writeln!(
        err,
        "  decoded {} frames; decode failures by message id: {:?}; {} frames lost by sequence; {} frames from senders beyond the {} followed",
        stats.decoded,
        stats.decode_failures,
        stats.sequence_lost,
        stats.ignored_senders,
        elaboration::elaborator::MAX_SOURCES
    );
    match elab.vehicle() {
        Some((s, c)) => {
            let _ = writeln!(err, "  vehicle autopilot: {s}/{c}");
        }
        None => {
            let _ = writeln!(err, "  no autopilot HEARTBEAT found");
        }
    }
    let _ = writeln!(err, "  events: {counts:?}");
    Ok(Outcome::Success)
}

#[cfg(test)]
mod tests {
    use super::*;
    use elaboration::frame::serialize;
    use elaboration::TlogWriter;
    use mavlink::dialects::ardupilotmega::{MavAutopilot, MavMessage, MavType, HEARTBEAT_DATA};
    use mavlink::{MavHeader, MavlinkVersion};

    fn log_of(autopilots: &[(u8, MavType, MavAutopilot)]) -> Vec<u8> {
        let mut w = TlogWriter::new(Vec::new());
        for (i, (sysid, mavtype, autopilot)) in autopilots.iter().enumerate() {
            let msg = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
                mavtype: *mavtype,
                autopilot: *autopilot,
                ..HEARTBEAT_DATA::DEFAULT
            });
            let h = MavHeader {
                system_id: *sysid as u32,
                component_id: 1,
                sequence: i as u8,
            };
            w.write_frame(i as u64, &serialize(h, MavlinkVersion::V2, &msg))
                .expect("vec");
        }
        w.into_inner().expect("vec")
    }

    #[test]
    fn the_profile_follows_the_first_autopilot_not_the_gcs() {
        let px4 = log_of(&[
            (
                255,
                MavType::MAV_TYPE_GCS,
                MavAutopilot::MAV_AUTOPILOT_INVALID,
            ),
            (
                1,
                MavType::MAV_TYPE_QUADROTOR,
                MavAutopilot::MAV_AUTOPILOT_PX4,
            ),
        ]);
        assert_eq!(detect(&px4), "px4");
        let ardupilot = log_of(&[(
            1,
            MavType::MAV_TYPE_FIXED_WING,
            MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        )]);
        assert_eq!(detect(&ardupilot), "ardupilot");
        assert_eq!(detect(&[]), "ardupilot");
    }

    #[test]
    fn json_lines_carry_time_category_params_and_sender() {
        let e = Elaborated {
            time_us: 1_500_000,
            event: nets::Event::new("mode_changed").param("mode", "RTL"),
            sysid: 1,
            compid: 1,
            boot_us: None,
            rule: None,
        };
        let j = json_line(&e, 1_000_000);
        assert_eq!(
            j,
            serde_json::json!({"time_us": 1_500_000, "t": 0.5, "event": "mode_changed",
                "category": "nominal", "params": {"mode": "RTL"}, "sysid": 1, "compid": 1})
        );
    }

    #[test]
    fn a_bad_profile_file_is_bad_input() {
        let dir = std::env::temp_dir().join(format!("petrel-events-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("bad.toml");
        std::fs::write(
            &path,
            "[rules.x]\ncategory = \"sometimes\"\nwhen = \"NOPE.x\"\n",
        )
        .expect("write");
        let loaded = load_profile(path.to_str(), None, &[]).expect("readable");
        assert!(loaded.is_err());
        let missing = load_profile(Some("/nonexistent/profile.toml"), None, &[]);
        assert!(missing.is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
