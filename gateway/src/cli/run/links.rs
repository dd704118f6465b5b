//! `run`'s MAVLink links: each link of the team opened once (a project
//! without a team has one), filtered to the vehicles supervised on it,
//! signed when asked; then each read by a task of its own into one channel
//! of frames tagged with their link.

use std::sync::Arc;
use std::time::Duration;

use tokio::sync::mpsc;
use tokio::task::JoinHandle;

use super::Setup;
use crate::clock::Clock;
use crate::link::{Link, LinkReader, LinkWriter, Received, Rejections};

/// The links opened, in `team::links` order.
pub(super) struct Opened {
    pub addresses: Vec<String>,
    /// Each vehicle's link (team order; one entry without a team).
    pub link_of: Vec<usize>,
    pub readers: Vec<LinkReader>,
    pub writers: Vec<LinkWriter>,
    /// What each link's signature checks dropped.
    pub rejections: Vec<Arc<Rejections>>,
}

/// Opens each link once. On each, a team keeps its vehicles on that link
/// (every other vehicle dropped, said once); one vehicle keeps the
/// configured system, else the first autopilot heard.
pub(super) async fn open(setup: &Setup, clock: &Clock) -> Result<Opened, miette::Report> {
    let project = &setup.project;
    let links = petrel_core::team::links(project, &setup.address);
    let team = !project.vehicles.is_empty();
    let mut opened = Opened {
        addresses: Vec::new(),
        link_of: vec![0; project.vehicles.len().max(1)],
        readers: Vec::new(),
        writers: Vec::new(),
        rejections: Vec::new(),
    };
    for (i, (address, on)) in links.iter().enumerate() {
        let (mut reader, writer) = Link::open(address, clock.clone())
            .await
            .map_err(|e| miette::miette!("{e}"))?;
        if team {
            let systems = on.iter().map(|&v| project.vehicles[v].system);
            reader.supervise_team(systems.collect());
        } else {
            reader.supervise(setup.vehicle.system);
        }
        if let Some(signing) = &setup.signing {
            use petrel_core::signing::{read_timestamp, Signer, Verifier};
            let persisted = read_timestamp(&signing.timestamp_file);
            writer.sign(Signer::new(signing.key.clone(), signing.link_id, persisted));
            reader.verify(Verifier::new(signing.key.clone(), signing.require));
        }
        for &v in on {
            opened.link_of[v] = i;
        }
        opened.addresses.push(address.clone());
        opened.rejections.push(reader.rejections());
        opened.readers.push(reader);
        opened.writers.push(writer);
    }
    Ok(opened)
}

/// Reads every link on a task of its own, so that a frame is never lost
/// to a select! that picked another branch: the frames, tagged with their
/// link's index, and the tasks (to abort). What a link decides about the
/// vehicles it hears is said once, prefixed with its address when there
/// are several.
pub(super) fn read(
    readers: Vec<LinkReader>,
    addresses: &[String],
) -> (mpsc::Receiver<(usize, Received)>, Vec<JoinHandle<()>>) {
    let (frames_tx, frames) = mpsc::channel(1024);
    let several = readers.len() > 1;
    let tasks = readers
        .into_iter()
        .zip(addresses.iter().cloned())
        .enumerate()
        .map(|(link, (mut reader, address))| {
            let frames_tx = frames_tx.clone();
            tokio::spawn(async move {
                loop {
                    match reader.recv().await {
                        Ok(rx) => {
                            while let Some(notice) = reader.poll_notice() {
                                if several {
                                    say!("{address}: {notice}");
                                } else {
                                    say!("{notice}");
                                }
                            }
                            if frames_tx.send((link, rx)).await.is_err() {
                                break;
                            }
                        }
                        Err(e) => {
                            // Never spin on a link that keeps failing.
                            tracing::warn!("{e}");
                            tokio::time::sleep(Duration::from_millis(200)).await;
                        }
                    }
                }
            })
        })
        .collect();
    (frames, tasks)
}

/// Persists the links' signing timestamp (the latest any used); a failure
/// is said, once per attempt, and supervision goes on.
pub(super) fn persist_timestamps(file: &std::path::Path, writers: &[LinkWriter]) {
    if let Some(ts) = writers
        .iter()
        .filter_map(LinkWriter::signing_timestamp)
        .max()
    {
        if let Err(e) = petrel_core::signing::write_timestamp(file, ts) {
            tracing::warn!(
                "cannot persist the signing timestamp to {}: {e}",
                file.display()
            );
        }
    }
}
