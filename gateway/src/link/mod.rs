//! The MAVLink link to the autopilot, on tokio: rust-mavlink's addresses
//! (`udpin:`, `udpout:`, `tcpout:`, `tcpin:`, `serial:PORT:BAUD`),
//! MAVLink 1 and 2 both received. Each frame comes with its raw bytes
//! (exactly as on the wire, for the elaborator and the recorder), its
//! receive time (microseconds since the gateway's start, monotonic), and
//! the decoded message where the dialect decodes it. Outgoing messages
//! carry our header, with sequence numbers counted by rust-mavlink.
//!
//! ```text
//! let (mut reader, writer) = Link::open("udpin:0.0.0.0:14550", origin).await?;
//! loop { let frame = reader.recv().await?; ... }       // one task
//! writer.send((1, 191), &message).await?;              // any task (clone the writer)
//! ```
//!
//! A link may carry several vehicles: `reader.supervise(system_id)` keeps
//! one (the configured system, else the first autopilot heard) and drops
//! every frame of the others ([`vehicles`]; docs/multi-vehicle.md).

use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::{Arc, Mutex, RwLock};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

pub mod rejections;
pub mod uplink;
pub mod vehicles;

pub use petrel_core::frame::Received;
pub use petrel_core::signing;

use crate::clock::Clock;
use mavlink::dialects::ardupilotmega::{MavMessage, HEARTBEAT_DATA};
use mavlink::error::{MessageReadError, MessageWriteError};
use mavlink::{
    AsyncMavConnection, MAVLinkMessageRaw, MAVLinkV2MessageRaw, MavHeader, MavlinkVersion, Message,
    MessageData,
};
pub use rejections::Rejections;
use signing::{Signer, Verifier};
use vehicles::{Notice, Vehicles};

/// Microseconds since the Unix epoch, for signing timestamps (0 if the
/// system clock is before 1970; the signer keeps its timestamps growing).
pub fn unix_us() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_micros() as u64)
}

/// Why the link failed.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    #[error("cannot open MAVLink link {address}: {source}")]
    Open {
        address: String,
        source: std::io::Error,
    },
    #[error("MAVLink link read failed: {0}")]
    Read(#[from] MessageReadError),
    #[error("MAVLink link write failed: {0}")]
    Write(#[from] MessageWriteError),
    #[error("MAVLink link down (being reopened)")]
    Down,
}

type Connection = mavlink::AsyncConnection<MavMessage>;

/// Wait between attempts to reopen a TCP link.
const REOPEN_WAIT: Duration = Duration::from_millis(500);

struct Shared {
    address: String,
    /// `None` while a TCP link is being reopened.
    connection: RwLock<Option<Arc<Connection>>>,
    /// The sequence number of the next frame sent (one counter per link,
    /// as rust-mavlink keeps).
    sequence: AtomicU8,
    /// Signs every frame sent, when the link is signed.
    signer: Mutex<Option<Signer>>,
}

impl Shared {
    fn current(&self) -> Option<Arc<Connection>> {
        match self.connection.read() {
            Ok(c) => c.clone(),
            Err(poisoned) => poisoned.into_inner().clone(),
        }
    }

    fn set(&self, connection: Option<Arc<Connection>>) {
        match self.connection.write() {
            Ok(mut c) => *c = connection,
            Err(poisoned) => *poisoned.into_inner() = connection,
        }
    }
}

async fn connect(address: &str) -> std::io::Result<Connection> {
    let mut connection = mavlink::connect_async::<MavMessage>(address).await?;
    connection.set_allow_recv_any_version(true);
    connection.set_protocol_version(MavlinkVersion::V2);
    Ok(connection)
}

/// Opens links.
pub struct Link;

impl Link {
    /// Opens a rust-mavlink address. `tcpin:` waits for its one client;
    /// `udpin:` answers the last sender (nothing is sent before someone
    /// has spoken). Receive times are read on `clock` (an `Instant` is a
    /// clock counting from it).
    pub async fn open(
        address: &str,
        clock: impl Into<Clock>,
    ) -> Result<(LinkReader, LinkWriter), LinkError> {
        let clock = clock.into();
        let connection = connect(address).await.map_err(|source| LinkError::Open {
            address: address.to_owned(),
            source,
        })?;
        let shared = Arc::new(Shared {
            address: address.to_owned(),
            connection: RwLock::new(Some(Arc::new(connection))),
            sequence: AtomicU8::new(0),
            signer: Mutex::new(None),
        });
        Ok((
            LinkReader {
                shared: shared.clone(),
                clock,
                vehicles: None,
                verifier: None,
                rejections: Arc::new(Rejections::default()),
            },
            LinkWriter { shared },
        ))
    }
}

/// The receiving half. One task reads; the writer may be used meanwhile.
pub struct LinkReader {
    shared: Arc<Shared>,
    clock: Clock,
    /// When set, frames of vehicles other than the supervised one are dropped.
    vehicles: Option<Vehicles>,
    /// When set, frames whose signature fails are dropped and counted.
    verifier: Option<Verifier>,
    rejections: Arc<Rejections>,
}

impl LinkReader {
    /// From now on, checks every frame's MAVLink 2 signature: frames that
    /// fail (and unsigned ones, if the verifier requires signatures) are
    /// dropped and counted in [`Self::rejections`].
    pub fn verify(&mut self, verifier: Verifier) {
        self.verifier = Some(verifier);
    }

    /// The frames rejected by signature checks.
    pub fn rejections(&self) -> Arc<Rejections> {
        self.rejections.clone()
    }

    /// From now on, delivers only the frames of one vehicle's system (the
    /// configured `system`, else the first autopilot heard) and of systems
    /// that are no vehicle (ground stations, radios); other vehicles'
    /// frames are dropped. What it decides comes from [`Self::poll_notice`].
    pub fn supervise(&mut self, system: Option<u8>) {
        self.vehicles = Some(Vehicles::new(system));
    }

    /// From now on, delivers only the frames of the team's `systems` (its
    /// vehicles on this link) and of systems that are no vehicle; other
    /// vehicles' frames are dropped ([`Vehicles::team`]).
    pub fn supervise_team(&mut self, systems: Vec<u8>) {
        self.vehicles = Some(Vehicles::team(systems));
    }

    /// The next decision about a vehicle to tell people (each told once).
    pub fn poll_notice(&mut self) -> Option<Notice> {
        self.vehicles.as_mut().and_then(Vehicles::poll_notice)
    }

    /// Whether the supervised-vehicle filter keeps this frame; a HEARTBEAT
    /// is decoded for it, nothing else.
    fn admit(&mut self, raw: &MAVLinkMessageRaw) -> bool {
        let Some(vehicles) = self.vehicles.as_mut() else {
            return true;
        };
        let heartbeat = match raw.message_id() {
            HEARTBEAT_DATA::ID => {
                match MavMessage::parse(raw.version(), raw.message_id(), raw.payload()) {
                    Ok(MavMessage::HEARTBEAT(hb)) => Some(hb),
                    _ => None,
                }
            }
            _ => None,
        };
        let system = u8::try_from(raw.system_id()).unwrap_or(u8::MAX);
        vehicles.admit(system, raw.component_id(), heartbeat.as_ref())
    }

    /// TCP and serial links are reopened when they break (a peer gone, a
    /// USB adapter pulled out); UDP has no connection to lose.
    fn reopens(&self) -> bool {
        let a = &self.shared.address;
        a.starts_with("tcp") || a.starts_with("serial")
    }

    /// The next frame. Frames with a bad checksum or an unknown message id
    /// are skipped by rust-mavlink; UDP errors are retried by rust-mavlink.
    /// A TCP or serial link that breaks (a serial device that goes away
    /// reads as the end of the stream) is reopened here (every 0.5 s until
    /// it comes back; `tcpin:` listens again), so this waits across the
    /// outage; meanwhile the writer reports `LinkError::Down`.
    pub async fn recv(&mut self) -> Result<Received, LinkError> {
        loop {
            let connection = match self.shared.current() {
                Some(c) => c,
                None => {
                    match connect(&self.shared.address).await {
                        Ok(c) => {
                            tracing::info!(address = %self.shared.address, "MAVLink link reopened");
                            self.shared.set(Some(Arc::new(c)));
                        }
                        Err(e) => {
                            tracing::debug!(address = %self.shared.address, error = %e, "MAVLink link still down");
                            tokio::time::sleep(REOPEN_WAIT).await;
                        }
                    }
                    continue;
                }
            };
            let raw = match connection.recv_raw().await {
                Ok(raw) => raw,
                Err(e) if self.reopens() => {
                    tracing::warn!(address = %self.shared.address, error = %e, "MAVLink link broken: reopening");
                    self.shared.set(None);
                    continue;
                }
                Err(e) => return Err(e.into()),
            };
            if let Some(verifier) = &mut self.verifier {
                if let Err(why) = verifier.check(&raw, unix_us()) {
                    let system = u8::try_from(raw.system_id()).unwrap_or(u8::MAX);
                    tracing::debug!(
                        system,
                        component = raw.component_id(),
                        "frame rejected: {why}"
                    );
                    self.rejections.add(why, system, raw.component_id());
                    continue;
                }
            }
            if !self.admit(&raw) {
                continue;
            }
            return Ok(self.received(&raw));
        }
    }

    fn received(&self, raw: &MAVLinkMessageRaw) -> Received {
        let time_us = self.clock.now();
        let (bytes, version) = match raw {
            MAVLinkMessageRaw::V1(m) => (m.raw_bytes().to_vec(), MavlinkVersion::V1),
            MAVLinkMessageRaw::V2(m) => (m.raw_bytes().to_vec(), MavlinkVersion::V2),
        };
        let header = MavHeader {
            system_id: raw.system_id(),
            component_id: raw.component_id(),
            sequence: raw.sequence(),
        };
        let message = elaboration::Frame::parse(&bytes)
            .ok()
            .and_then(|f| f.decode().ok());
        Received {
            time_us,
            bytes,
            version,
            header,
            message,
        }
    }
}

/// The sending half; cheap to clone.
#[derive(Clone)]
pub struct LinkWriter {
    shared: Arc<Shared>,
}

impl LinkWriter {
    /// From now on, signs every frame sent.
    pub fn sign(&self, signer: Signer) {
        *self.shared.signer.lock().unwrap_or_else(|p| p.into_inner()) = Some(signer);
    }

    /// The last signing timestamp used, to persist across restarts.
    pub fn signing_timestamp(&self) -> Option<u64> {
        self.shared
            .signer
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .as_ref()
            .map(Signer::timestamp)
    }

    /// Sends a message as `from` = (system, component), MAVLink 2. The
    /// sequence number is the link's own counter. Returns the frame's bytes
    /// as written on the wire (empty on `udpin:` before anyone has spoken),
    /// so that they can be recorded.
    pub async fn send(&self, from: (u8, u8), message: &MavMessage) -> Result<Vec<u8>, LinkError> {
        self.send_with(from, |header, raw, signer| match signer {
            Some(signer) => *raw = signer.sign(header, message, unix_us()),
            None => raw.serialize_message(header, message),
        })
        .await
    }

    /// Sends a message that the dialect's types cannot hold (the mirror's
    /// TUNNEL with a private payload type), framed by rust-mavlink, and
    /// signed when the link is (the downlink's records: docs/mirror.md, "A
    /// signed downlink").
    pub async fn send_data<D: MessageData>(
        &self,
        from: (u8, u8),
        data: &D,
    ) -> Result<Vec<u8>, LinkError> {
        self.send_with(from, |header, raw, signer| match signer {
            Some(signer) => *raw = signer.sign_data(header, data, unix_us()),
            None => raw.serialize_message_data(header, data),
        })
        .await
    }

    /// Sends a message the dialect's types cannot hold, signed with
    /// `signer` (not the link's own): the operator's answers
    /// (`mirror::dialog`), whatever the link's signing.
    pub async fn send_data_signed<D: MessageData>(
        &self,
        from: (u8, u8),
        data: &D,
        signer: &mut Signer,
    ) -> Result<Vec<u8>, LinkError> {
        self.send_with(from, |header, raw, _| {
            *raw = signer.sign_data(header, data, unix_us())
        })
        .await
    }

    async fn send_with(
        &self,
        from: (u8, u8),
        serialize: impl FnOnce(MavHeader, &mut MAVLinkV2MessageRaw, Option<&mut Signer>),
    ) -> Result<Vec<u8>, LinkError> {
        let connection = self.shared.current().ok_or(LinkError::Down)?;
        let header = MavHeader {
            system_id: from.0 as u32,
            component_id: from.1,
            sequence: self.shared.sequence.fetch_add(1, Ordering::Relaxed),
        };
        let mut raw = MAVLinkV2MessageRaw::new();
        {
            let mut signer = self.shared.signer.lock().unwrap_or_else(|p| p.into_inner());
            serialize(header, &mut raw, signer.as_mut());
        }
        let frame = MAVLinkMessageRaw::V2(raw);
        let written = connection.send_raw(&frame).await?;
        Ok(match (&frame, written) {
            (_, 0) => Vec::new(),
            (MAVLinkMessageRaw::V2(raw), _) => raw.raw_bytes().to_vec(),
            (MAVLinkMessageRaw::V1(raw), _) => raw.raw_bytes().to_vec(),
        })
    }
}
