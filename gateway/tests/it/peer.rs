//! A scripted autopilot on 127.0.0.1, written with rust-mavlink: it speaks
//! first (heartbeats), records everything the gateway sends, and answers
//! through a script. It can go silent to play a lost link.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::*;
use mavlink::{AsyncMavConnection, MavHeader};

/// One answer: sent `after` the message it answers, from `component`.
pub struct Reply {
    pub after: Duration,
    pub component: u8,
    pub message: MavMessage,
}

/// An immediate answer from the autopilot (component 1).
pub fn now(message: MavMessage) -> Reply {
    Reply {
        after: Duration::ZERO,
        component: 1,
        message,
    }
}

/// The script: given what the gateway sent, what the autopilot answers.
pub type Script = Box<dyn FnMut(&MavHeader, &MavMessage) -> Vec<Reply> + Send>;

/// What the peer saw, with the time since it started.
#[derive(Clone)]
pub struct Seen {
    pub at: Duration,
    pub header: MavHeader,
    pub message: MavMessage,
}

pub struct Peer {
    pub seen: Arc<Mutex<Vec<Seen>>>,
    /// While set, the peer neither hears nor speaks.
    pub down: Arc<AtomicBool>,
    task: tokio::task::JoinHandle<()>,
}

pub fn heartbeat(autopilot: MavAutopilot, mavtype: MavType) -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype,
        autopilot,
        base_mode: MavModeFlag::empty(),
        system_status: MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
    })
}

/// An ack for a command, addressed to the gateway (1/191).
pub fn ack(command: MavCmd, result: MavResult) -> MavMessage {
    MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
        command,
        result,
        progress: 0,
        result_param2: 0,
        target_system: 1,
        target_component: 191,
    })
}

/// The command id of a COMMAND_LONG or COMMAND_INT.
pub fn command_of(m: &MavMessage) -> Option<MavCmd> {
    match m {
        MavMessage::COMMAND_LONG(c) => Some(c.command),
        MavMessage::COMMAND_INT(c) => Some(c.command),
        _ => None,
    }
}

impl Peer {
    /// Connects to the gateway at `address` (a `udpout:` address) as
    /// system 1 component 1, sending `hb` and then `telemetry` every 100 ms.
    pub async fn start(
        address: &str,
        hb: MavMessage,
        telemetry: Vec<MavMessage>,
        mut script: Script,
    ) -> Peer {
        let connection = mavlink::connect_async::<MavMessage>(address)
            .await
            .expect("peer connects on loopback");
        let connection = Arc::new(connection);
        let seen = Arc::new(Mutex::new(Vec::new()));
        let down = Arc::new(AtomicBool::new(false));
        let start = Instant::now();
        let header = MavHeader {
            system_id: 1,
            component_id: 1,
            sequence: 0,
        };
        let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<(MavHeader, MavMessage)>();
        let reader = connection.clone();
        let reading = tokio::spawn(async move {
            while let Ok(got) = reader.recv().await {
                if tx.send(got).is_err() {
                    break;
                }
            }
        });
        let task = {
            let seen = seen.clone();
            let down = down.clone();
            tokio::spawn(async move {
                let mut beat = tokio::time::interval(Duration::from_millis(100));
                loop {
                    tokio::select! {
                        _ = beat.tick() => {
                            if !down.load(Ordering::SeqCst) {
                                let _ = connection.send(&header, &hb).await;
                                for m in &telemetry {
                                    let _ = connection.send(&header, m).await;
                                }
                            }
                        }
                        got = rx.recv() => {
                            let Some((h, m)) = got else { break };
                            if down.load(Ordering::SeqCst) {
                                continue;
                            }
                            seen.lock().expect("peer log").push(Seen { at: start.elapsed(), header: h, message: m.clone() });
                            for reply in script(&h, &m) {
                                let from = MavHeader { component_id: reply.component, ..header };
                                if reply.after.is_zero() {
                                    let _ = connection.send(&from, &reply.message).await;
                                } else {
                                    let connection = connection.clone();
                                    let down = down.clone();
                                    tokio::spawn(async move {
                                        tokio::time::sleep(reply.after).await;
                                        if !down.load(Ordering::SeqCst) {
                                            let _ = connection.send(&from, &reply.message).await;
                                        }
                                    });
                                }
                            }
                        }
                    }
                }
                reading.abort();
            })
        };
        Peer { seen, down, task }
    }

    /// Everything seen so far, heartbeats left out.
    pub fn messages(&self) -> Vec<MavMessage> {
        self.seen
            .lock()
            .expect("peer log")
            .iter()
            .filter(|s| !matches!(s.message, MavMessage::HEARTBEAT(_)))
            .map(|s| s.message.clone())
            .collect()
    }

    pub fn all(&self) -> Vec<Seen> {
        self.seen.lock().expect("peer log").clone()
    }

    /// The COMMAND_LONG/INTs seen for a MAV_CMD, in order.
    pub fn commands(&self, command: MavCmd) -> Vec<MavMessage> {
        self.messages()
            .into_iter()
            .filter(|m| command_of(m) == Some(command))
            .collect()
    }

    pub fn set_down(&self, down: bool) {
        self.down.store(down, Ordering::SeqCst);
    }
}

impl Drop for Peer {
    fn drop(&mut self) {
        self.task.abort();
    }
}
