//! `petrel mirror --push DIR`: a new version of the project sent up to the
//! vehicle through the mirror's uplink (docs/mirror.md, "A version sent
//! up"). The version is loaded and checked here first, as `petrel reload`
//! checks one on board; its files are packed (`gateway::upload::pack`) and
//! handed to the station's upload sender (`petrel_core::mirror::upload`),
//! whose records the loop sends signed with the operator key.

use std::path::Path;
use std::sync::Arc;

use nets::Micros;
use petrel_core::mirror::station::Station;
use petrel_core::mirror::upload::Sent;
use petrel_core::version::Version;

use crate::preflight::{Inputs, Preflight};

/// A version ready to go up.
pub(super) struct Push {
    pub bytes: Vec<u8>,
    pub version: Arc<Version>,
    /// Its files' bytes before packing.
    pub unpacked: usize,
    dir: std::path::PathBuf,
}

impl Push {
    /// What goes up, for people.
    pub fn summary(&self, rate: u64) -> String {
        format!(
            "push: {} checked and packed: {} files, {} bytes ({} unpacked), at {rate} B/s",
            self.dir.display(),
            self.version.files.len(),
            self.bytes.len(),
            self.unpacked,
        )
    }
}

/// Starts sending `push` up from ground time `now`, at `rate` bytes/s.
pub(super) fn start(station: &mut Station, now: Micros, push: Push, rate: u64) {
    // Numbered by the wall clock: two pushes never share a number.
    let upload = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(1, |d| d.as_millis() as u64);
    let config = petrel_core::mirror::upload::Config {
        bytes_per_s: rate.max(1),
        ..Default::default()
    };
    if let Err(e) = station.push(now, upload, push.bytes, push.version, config) {
        say!("push: not sent: {e}");
    }
}

/// The version in `dir`, loaded with `catalog`, checked from its start
/// (with the profile's `layers`), and packed.
pub(super) fn prepare(
    dir: &Path,
    catalog: &nets::load::Catalog,
    layers: &[(String, String)],
) -> Result<Push, miette::Report> {
    let (project, files) = petrel_core::project::load_read(dir, catalog)?;
    let inputs = Inputs {
        files: &files,
        layers,
    };
    if let Preflight::Failed(report) = crate::preflight::check_project(&project, &inputs, false) {
        return Err(miette::miette!(
            "{}\nnot sent: the version in {} fails `petrel check`",
            crate::cli::check_project::human(&project.name, &report, 0.0).trim_end(),
            dir.display()
        ));
    }
    let unpacked = files.iter().map(|(p, t)| p.len() + t.len()).sum();
    let bytes = crate::upload::pack(&files).map_err(|e| miette::miette!("{e}"))?;
    Ok(Push {
        bytes,
        version: Arc::new(Version {
            number: 0,
            project,
            files,
        }),
        unpacked,
        dir: dir.to_path_buf(),
    })
}

/// What became of the upload, for people (`None`: not worth a line).
pub(super) fn said(sent: &Sent, last_tenth: &mut u64) -> Option<String> {
    Some(match sent {
        Sent::Progress { have, of } => {
            let tenth = have * 10 / (*of).max(1);
            if tenth <= *last_tenth || tenth >= 10 {
                return None;
            }
            *last_tenth = tenth;
            format!("push: the vehicle holds {have} of {of} pieces")
        }
        Sent::Delivered { bytes, after } => format!(
            "push: the vehicle has the version whole ({bytes} bytes sent up in {:.1} s); it loads and proves it",
            *after as f64 / 1e6
        ),
        Sent::Verdict { text } => format!("push: the vehicle's verdict: {text}"),
        Sent::GaveUp { why } => format!("push: given up: {why}"),
    })
}
