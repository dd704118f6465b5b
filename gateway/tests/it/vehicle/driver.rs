//! A minimal gateway loop around the commander and the link, as `petrel
//! run` drives them: one task reads frames into a channel, one loop feeds
//! the commander and drains it.

use std::time::{Duration, Instant};

use nets::{Outcome, Params};
use tokio::sync::mpsc;

use super::link::{Link, Received};
use super::vehicle::commander::Commander;
use super::vehicle::config::VehicleConfig;

pub enum Input {
    Command(u64, String, Params),
    Streams(Vec<(u32, f32)>),
}

pub struct Gateway {
    inputs: mpsc::UnboundedSender<Input>,
    outcomes: mpsc::UnboundedReceiver<(u64, Outcome)>,
    task: tokio::task::JoinHandle<()>,
}

/// A free UDP port on loopback (bound then released).
pub fn free_port() -> u16 {
    std::net::UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .map(|a| a.port())
        .expect("a free loopback port")
}

impl Gateway {
    /// Listens on `udpin:127.0.0.1:PORT`.
    pub async fn start(port: u16, config: VehicleConfig) -> Gateway {
        let origin = Instant::now();
        let (mut reader, writer) = Link::open(&format!("udpin:127.0.0.1:{port}"), origin)
            .await
            .expect("gateway link opens");
        let (frames_tx, mut frames) = mpsc::unbounded_channel::<Received>();
        tokio::spawn(async move {
            while let Ok(r) = reader.recv().await {
                if frames_tx.send(r).is_err() {
                    break;
                }
            }
        });
        let (inputs, mut inputs_rx) = mpsc::unbounded_channel();
        let (outcomes_tx, outcomes) = mpsc::unbounded_channel();
        let task = tokio::spawn(async move {
            let mut commander = Commander::new(config);
            let now = || origin.elapsed().as_micros() as u64;
            loop {
                let wait = commander
                    .next_deadline()
                    .map(|d| Duration::from_micros(d.saturating_sub(now())))
                    .unwrap_or(Duration::from_millis(50));
                tokio::select! {
                    frame = frames.recv() => {
                        let Some(frame) = frame else { break };
                        assert!(!frame.bytes.is_empty());
                        if let Some(m) = &frame.message {
                            commander.message(frame.time_us, &frame.header, m);
                        }
                    }
                    input = inputs_rx.recv() => match input {
                        Some(Input::Command(id, verb, args)) => commander.command(id, &verb, &args, now()),
                        Some(Input::Streams(s)) => commander.request_streams(&s, now()),
                        None => break,
                    },
                    _ = tokio::time::sleep(wait) => commander.tick(now()),
                }
                while let Some(m) = commander.poll_transmit() {
                    let _ = writer.send(commander.sender(), &m).await;
                }
                while let Some(o) = commander.poll_outcome() {
                    let _ = outcomes_tx.send(o);
                }
            }
        });
        Gateway {
            inputs,
            outcomes,
            task,
        }
    }

    pub fn command(&self, id: u64, verb: &str, args: Params) {
        let _ = self.inputs.send(Input::Command(id, verb.to_owned(), args));
    }

    pub fn streams(&self, s: &[(u32, f32)]) {
        let _ = self.inputs.send(Input::Streams(s.to_vec()));
    }

    /// The next outcome, within `limit`.
    pub async fn outcome(&mut self, limit: Duration) -> (u64, Outcome) {
        tokio::time::timeout(limit, self.outcomes.recv())
            .await
            .expect("an outcome in time")
            .expect("gateway running")
    }
}

impl Drop for Gateway {
    fn drop(&mut self) {
        self.task.abort();
    }
}

/// Polls `check` every 10 ms until it holds, within `limit`.
pub async fn eventually(limit: Duration, mut check: impl FnMut() -> bool) -> bool {
    let end = Instant::now() + limit;
    while Instant::now() < end {
        if check() {
            return true;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    check()
}
