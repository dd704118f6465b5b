//! The mirror's only way to send: [`UplinkWriter`] takes the link's writer
//! and sends nothing but [`Uplink`] packets — resync requests the replica
//! built — the operator's answers (signed with the operator key,
//! `mirror::dialog`) and the pieces of a version sent up (signed too,
//! `mirror::upload`) in TUNNEL messages to the onboard gateway. It has no method for
//! any other message: the mirror cannot command the vehicle, call a
//! program, or send a HEARTBEAT (under any system id, and never under the
//! ground station's 255 that ArduPilot's GCS failsafe watches).

use super::{LinkError, LinkWriter};
use petrel_core::mirror::record::{self, Record};
use petrel_core::mirror::replica::Uplink;
use petrel_core::mirror::tunnel::Tunnel;
use petrel_core::mirror::upload::Signed;
use petrel_core::signing::Signer;

/// The mirror's component id: a ground component beside its own system id.
pub const MIRROR_COMPONENT: u8 = 190;

/// Sends the replica's requests, and only them.
pub struct UplinkWriter {
    writer: LinkWriter,
    me: (u8, u8),
}

impl UplinkWriter {
    /// `system` is the mirror's own system id.
    pub fn new(writer: LinkWriter, system: u8) -> UplinkWriter {
        UplinkWriter {
            writer,
            me: (system, MIRROR_COMPONENT),
        }
    }

    /// The mirror's (system, component).
    pub fn identity(&self) -> (u8, u8) {
        self.me
    }

    /// Sends one request to the onboard gateway `to` = (system, component);
    /// returns the frame's bytes as written.
    pub async fn send(&self, to: (u8, u8), uplink: &Uplink) -> Result<Vec<u8>, LinkError> {
        let tunnel = Tunnel::petrel(to, uplink.bytes().to_vec());
        self.writer.send_data(self.me, &tunnel).await
    }

    /// Sends an upload record (a version sent up, built by the station's
    /// sender) to `to`, as a MAVLink 2 frame signed with the operator key.
    pub async fn send_signed(
        &self,
        to: (u8, u8),
        signed: &Signed,
        signer: &mut Signer,
    ) -> Result<Vec<u8>, LinkError> {
        let tunnel = Tunnel::petrel(to, signed.bytes().to_vec());
        self.writer.send_data_signed(self.me, &tunnel, signer).await
    }

    /// Sends the operator's answer `choice` to question `id` (checked by
    /// the dialog first) to `to`, as a MAVLink 2 frame signed with the
    /// operator key.
    pub async fn send_answer(
        &self,
        to: (u8, u8),
        id: u64,
        choice: &str,
        signer: &mut Signer,
    ) -> Result<Vec<u8>, LinkError> {
        let answer = Record::Answer {
            id,
            choice: choice.to_owned(),
        };
        let tunnel = Tunnel::petrel(to, record::packet(std::slice::from_ref(&answer)));
        self.writer.send_data_signed(self.me, &tunnel, signer).await
    }
}
