//! The tokio layer: the listener, one reader and one writer task per
//! connection, the started programs, and one task (the switchboard) that
//! owns every [`Session`] and routes calls, replies and timeouts. The
//! gateway's loop talks to it through [`Programs`] (never blocking) and
//! receives [`ProgramInput`]s on a bounded channel.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use nets::{Outcome, Params, Project};
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::net::{TcpListener, UnixListener};
use tokio::sync::{mpsc, watch};
use tokio::task::JoinHandle;

use super::child::{self, stopped, ChildEvent, Launch};
use petrel_core::programs::address::Address;
use petrel_core::programs::protocol::json_params;
use petrel_core::programs::roster::{Config, Roster, SettingsError};
use petrel_core::programs::session::{self, Output, Session};

/// Capacity of the channel of inputs to the gateway's loop.
const INPUTS: usize = 1024;
/// Capacity of the channel of bytes from the connections (backpressure on
/// programs that send faster than the gateway handles).
const READS: usize = 64;
/// Bytes read from a socket at once.
const READ_CHUNK: usize = 64 * 1024;

/// Which way a line went.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// From the program to the gateway.
    In,
    /// From the gateway to the program.
    Out,
}

/// One line of program traffic, for the recording.
#[derive(Debug, Clone, PartialEq)]
pub struct Traffic {
    /// Connection number, from 1, in order of acceptance.
    pub connection: u64,
    /// The program, once its hello was accepted.
    pub program: Option<String>,
    pub direction: Direction,
    pub line: String,
}

/// What the programs give the gateway's loop. No timestamps: the loop stamps
/// each on receipt.
#[derive(Debug, Clone, PartialEq)]
pub enum ProgramInput {
    /// The outcome of call `id`: for `Player::result(id, outcome, now)`.
    Outcome { id: u64, outcome: Outcome },
    /// An event a program sent on its own: for `Player::handle`.
    Event { program: String, event: nets::Event },
    /// A program disconnected or died; `event` is `program_lost {name}` for
    /// `Player::handle`. Its pending calls have failed ("program lost") just
    /// before.
    Lost { program: String, event: nets::Event },
    /// A line in or out, for the recording.
    Traffic(Traffic),
}

/// Why the programs could not start.
#[derive(Debug, thiserror::Error)]
pub enum ProgramsError {
    #[error(transparent)]
    Settings(#[from] SettingsError),
    #[error("cannot listen for programs on {address}: {source}")]
    Listen {
        address: Address,
        source: std::io::Error,
    },
    #[error("programs would listen on {address}, reachable from other computers, with no token: give one (--programs-token FILE, or [gateway] programs_token) so that only authorised programs connect, or listen on loopback")]
    Exposed { address: Address },
}

enum Command {
    Call {
        id: u64,
        program: usize,
        function: usize,
        args: Params,
        vehicle: Option<String>,
    },
    Forget(u64),
}

enum ConnEvent {
    Bytes(u64, Vec<u8>),
    Closed(u64),
}

/// The handle on the program server. Dropping it without `shutdown` stops
/// the server and kills started programs as well, without the grace period.
pub struct Programs {
    commands: mpsc::UnboundedSender<Command>,
    stop: watch::Sender<bool>,
    task: JoinHandle<()>,
    address: Address,
    /// The team's vehicle names, by `VehicleId` (empty without a team).
    vehicles: Vec<String>,
}

impl Programs {
    /// Listens on `config.address`, starts the programs that have a `run`
    /// setting, and serves. Must be called within a tokio runtime.
    pub async fn start(
        project: Arc<Project>,
        project_dir: &Path,
        config: Config,
    ) -> Result<(Programs, mpsc::Receiver<ProgramInput>), ProgramsError> {
        let vehicles = project.vehicles.iter().map(|v| v.name.clone()).collect();
        let mut roster = Roster::new(project)?;
        roster.token = config.token.clone();
        if let (Address::Tcp(a), None) = (&config.address, &roster.token) {
            if !a.ip().is_loopback() {
                return Err(ProgramsError::Exposed {
                    address: config.address.clone(),
                });
            }
        }
        let roster = Arc::new(roster);
        let listen_error = |source| ProgramsError::Listen {
            address: config.address.clone(),
            source,
        };
        let (listener, address) = match &config.address {
            Address::Tcp(a) => {
                let l = TcpListener::bind(a).await.map_err(listen_error)?;
                let bound = l.local_addr().map_err(listen_error)?;
                (Listener::Tcp(l), Address::Tcp(bound))
            }
            Address::Unix(path) => {
                remove_stale_socket(path).map_err(listen_error)?;
                let l = UnixListener::bind(path).map_err(listen_error)?;
                (Listener::Unix(l, path.clone()), Address::Unix(path.clone()))
            }
        };
        tracing::info!("listening for programs on {address}");
        let (commands_tx, commands) = mpsc::unbounded_channel();
        let (out, inputs) = mpsc::channel(INPUTS);
        let (stop_tx, stop) = watch::channel(false);
        let (conn_tx, conn_rx) = mpsc::channel(READS);
        let (child_tx, child_rx) = mpsc::unbounded_channel();
        let mut slots = vec![Slot::default(); roster.project.programs.len()];
        let mut children = Vec::new();
        for (program, settings) in roster.settings.iter().enumerate() {
            let Some(run) = &settings.run else { continue };
            slots[program].starting = true;
            slots[program].started = true;
            let launch = Launch {
                program,
                name: roster.name(program).to_owned(),
                run: run.clone(),
                restart: settings.restart,
                dir: project_dir.to_path_buf(),
                address: address.to_string(),
                token: config.token.clone(),
                backoff_min: config.backoff_min,
                backoff_max: config.backoff_max,
                stable_after: config.stable_after,
                grace: config.grace,
            };
            children.push(tokio::spawn(child::supervise(
                launch,
                child_tx.clone(),
                stop.clone(),
            )));
        }
        let switchboard = Switchboard {
            roster,
            out,
            stop,
            connections: HashMap::new(),
            next_connection: 1,
            slots,
            waiting: Vec::new(),
            conn_tx,
            children,
            sent: HashMap::new(),
            parked: Vec::new(),
        };
        let task = tokio::spawn(switchboard.run(listener, commands, conn_rx, child_rx));
        Ok((
            Programs {
                commands: commands_tx,
                stop: stop_tx,
                task,
                address: address.clone(),
                vehicles,
            },
            inputs,
        ))
    }

    /// The address programs connect to (with the real port when 0 was
    /// asked).
    pub fn address(&self) -> &Address {
        &self.address
    }

    /// Calls `function` of `program` (indices into the project, as in
    /// `Effect::Call`). Never blocks; the outcome comes back as
    /// [`ProgramInput::Outcome`].
    pub fn call(&self, id: u64, program: usize, function: usize, args: Params) {
        self.call_for(id, program, function, args, None);
    }

    /// [`Self::call`] for a vehicle of a team: the call's line names it
    /// (`"vehicle": "R1"`, docs/programs.md).
    pub fn call_for(
        &self,
        id: u64,
        program: usize,
        function: usize,
        args: Params,
        vehicle: Option<String>,
    ) {
        let _ = self.commands.send(Command::Call {
            id,
            program,
            function,
            args,
            vehicle,
        });
    }

    /// Forgets call `id` (its net was deactivated: `Effect::Forgotten`): no
    /// outcome will come, and a late reply is ignored.
    pub fn forget(&self, id: u64) {
        let _ = self.commands.send(Command::Forget(id));
    }

    /// Carries out a player effect if it concerns programs: `Call` (sent)
    /// and `Forgotten` (forgotten; harmless for a command's id). True if it
    /// was one of them.
    pub fn effect(&self, effect: &nets::Effect) -> bool {
        match effect {
            nets::Effect::Call {
                id,
                program,
                function,
                args,
                vehicle,
                ..
            } => {
                let vehicle = vehicle.and_then(|v| self.vehicles.get(v)).cloned();
                self.call_for(*id, *program, *function, args.clone(), vehicle);
                true
            }
            nets::Effect::Forgotten { id, .. } => {
                self.forget(*id);
                true
            }
            _ => false,
        }
    }

    /// Stops: started programs get SIGTERM, then SIGKILL after the grace
    /// period, and are waited for; connections are closed; a Unix socket
    /// file is removed. Calls still pending get no outcome.
    pub async fn shutdown(self) {
        let _ = self.stop.send(true);
        let _ = self.task.await;
    }
}

fn remove_stale_socket(path: &Path) -> std::io::Result<()> {
    use std::os::unix::fs::FileTypeExt;
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_socket() => std::fs::remove_file(path),
        Ok(_) => Err(std::io::Error::new(
            std::io::ErrorKind::AlreadyExists,
            "the path exists and is not a socket",
        )),
        Err(_) => Ok(()),
    }
}

trait Stream: AsyncRead + AsyncWrite + Send + Unpin {}
impl<T: AsyncRead + AsyncWrite + Send + Unpin> Stream for T {}

enum Listener {
    Tcp(TcpListener),
    Unix(UnixListener, PathBuf),
}

impl Listener {
    async fn accept(&self) -> std::io::Result<Box<dyn Stream>> {
        match self {
            Listener::Tcp(l) => {
                let (s, peer) = l.accept().await?;
                let _ = s.set_nodelay(true);
                tracing::debug!("program connection from {peer}");
                Ok(Box::new(s))
            }
            Listener::Unix(l, _) => Ok(Box::new(l.accept().await?.0)),
        }
    }
}

#[derive(Debug, Clone, Default)]
struct Slot {
    /// The connection that is this program.
    connection: Option<u64>,
    /// Started by the gateway and running or about to be restarted: calls
    /// wait for its hello.
    starting: bool,
    /// It said hello since it was last started.
    connected_since_start: bool,
    /// The gateway starts it (`run`).
    started: bool,
    /// Whether its process exited since its last hello, and if so whether
    /// it is started again.
    exited: Option<bool>,
    /// Hellos accepted in this run.
    hellos: u64,
    /// What it answered, oldest first, for the welcome after a restart.
    history: History,
    /// Calls failed as `restarted` since its last hello.
    restarted: Vec<u64>,
}

/// The answers a program gave in this run, as a restarted program gets
/// them back (docs/programs.md "Restarts"): at most [`HISTORY`] answers
/// and [`HISTORY_BYTES`] of JSON, the oldest dropped first.
#[derive(Debug, Clone, Default)]
struct History {
    answers: std::collections::VecDeque<(serde_json::Value, usize)>,
    bytes: usize,
    dropped: u64,
}

/// Answers kept per program for its restart.
const HISTORY: usize = 256;
/// Their JSON at most (a welcome line stays well under a program's 1 MiB).
const HISTORY_BYTES: usize = 512 * 1024;
/// How long a started program's closed connection waits for the process's
/// exit, to tell a restart from a loss.
const EXIT_WAIT: std::time::Duration = std::time::Duration::from_secs(1);

impl History {
    fn push(&mut self, answer: serde_json::Value) {
        let size = answer.to_string().len();
        self.answers.push_back((answer, size));
        self.bytes += size;
        while self.answers.len() > HISTORY || self.bytes > HISTORY_BYTES {
            let Some((_, size)) = self.answers.pop_front() else {
                break;
            };
            self.bytes -= size;
            self.dropped += 1;
        }
    }
}

impl Slot {
    /// The welcome's `resume` for a program that connected before in this
    /// run: its hello's number, what it answered, the calls failed as
    /// `restarted` that the nets may ask again.
    fn resume(&self) -> Option<serde_json::Value> {
        (self.hellos > 0).then(|| {
            serde_json::json!({
                "connection": self.hellos + 1,
                "answered": self.history.answers.iter().map(|(a, _)| a).collect::<Vec<_>>(),
                "dropped": self.history.dropped,
                "restarted": self.restarted,
            })
        })
    }
}

/// A call sent or waiting, until its outcome: what a restarted program
/// gets back of it.
struct Sent {
    program: usize,
    function: usize,
    args: Params,
    vehicle: Option<String>,
}

struct Connection {
    session: Session,
    writer: Option<mpsc::UnboundedSender<String>>,
    reader: JoinHandle<()>,
}

/// A call waiting for a started program's hello.
struct Waiting {
    id: u64,
    program: usize,
    function: usize,
    args: Params,
    vehicle: Option<String>,
    deadline: Instant,
}

struct Switchboard {
    roster: Arc<Roster>,
    out: mpsc::Sender<ProgramInput>,
    stop: watch::Receiver<bool>,
    connections: HashMap<u64, Connection>,
    next_connection: u64,
    slots: Vec<Slot>,
    waiting: Vec<Waiting>,
    conn_tx: mpsc::Sender<ConnEvent>,
    children: Vec<JoinHandle<()>>,
    /// Calls without an outcome yet, by id.
    sent: HashMap<u64, Sent>,
    /// Closed connections of started programs waiting for the process's
    /// exit: (connection, program, until when).
    parked: Vec<(u64, usize, Instant)>,
}

impl Switchboard {
    async fn run(
        mut self,
        listener: Listener,
        mut commands: mpsc::UnboundedReceiver<Command>,
        mut conn_rx: mpsc::Receiver<ConnEvent>,
        mut child_rx: mpsc::UnboundedReceiver<ChildEvent>,
    ) {
        let mut stop = self.stop.clone();
        loop {
            let deadline = self.next_deadline();
            tokio::select! {
                _ = stopped(&mut stop) => break,
                command = commands.recv() => match command {
                    Some(Command::Call { id, program, function, args, vehicle }) => {
                        self.call(id, program, function, args, vehicle).await
                    }
                    Some(Command::Forget(id)) => self.forget(id),
                    None => break,
                },
                accepted = listener.accept() => match accepted {
                    Ok(stream) => self.accept(stream),
                    Err(e) => {
                        tracing::warn!("accepting a program connection failed: {e}");
                        tokio::time::sleep(std::time::Duration::from_millis(50)).await;
                    }
                },
                Some(event) = conn_rx.recv() => match event {
                    ConnEvent::Bytes(conn, bytes) => {
                        let slots = &self.slots;
                        if let Some(c) = self.connections.get_mut(&conn) {
                            c.session.feed_resuming(
                                &bytes,
                                |p| slots.get(p).is_some_and(|s| s.connection.is_some()),
                                |p| slots.get(p).and_then(Slot::resume),
                            );
                        }
                        self.drain(conn).await;
                    }
                    ConnEvent::Closed(conn) => self.closed(conn).await,
                },
                Some(event) = child_rx.recv() => self.child(event).await,
                _ = sleep_until(deadline), if deadline.is_some() => self.timeouts().await,
            }
        }
        self.close().await;
        if let Listener::Unix(_, path) = &listener {
            let _ = std::fs::remove_file(path);
        }
    }

    /// Hands an input to the gateway's loop; gives up when shutting down.
    async fn emit(&mut self, input: ProgramInput) {
        tokio::select! {
            biased;
            _ = self.out.send(input) => {}
            _ = stopped(&mut self.stop) => {}
        }
    }

    fn accept(&mut self, stream: Box<dyn Stream>) {
        let conn = self.next_connection;
        self.next_connection += 1;
        let (read, write) = tokio::io::split(stream);
        let (writer, lines) = mpsc::unbounded_channel();
        tokio::spawn(write_lines(write, lines));
        let reader = tokio::spawn(read_bytes(conn, read, self.conn_tx.clone()));
        self.connections.insert(
            conn,
            Connection {
                session: Session::new(Arc::clone(&self.roster), Instant::now()),
                writer: Some(writer),
                reader,
            },
        );
    }

    /// Carries out what a session asks, until it has nothing more.
    async fn drain(&mut self, conn: u64) {
        loop {
            let Some(c) = self.connections.get_mut(&conn) else {
                return;
            };
            let program = c.session.program();
            let Some(output) = c.session.poll() else {
                break;
            };
            let name = program.map(|p| self.roster.name(p).to_owned());
            match output {
                Output::Send(line) => {
                    if let Some(w) = &c.writer {
                        let _ = w.send(line.clone());
                    }
                    self.traffic(conn, name, Direction::Out, line).await;
                }
                Output::Received(line) => self.traffic(conn, name, Direction::In, line).await,
                Output::Hello { program } => {
                    tracing::info!(program = %self.roster.name(program), connection = conn, "program connected");
                    if let Some(slot) = self.slots.get_mut(program) {
                        slot.connection = Some(conn);
                        slot.connected_since_start = true;
                        slot.exited = None;
                        slot.hellos += 1;
                        slot.restarted.clear();
                    }
                    let now = Instant::now();
                    let (ready, rest): (Vec<_>, Vec<_>) = std::mem::take(&mut self.waiting)
                        .into_iter()
                        .partition(|w| w.program == program);
                    self.waiting = rest;
                    if let Some(c) = self.connections.get_mut(&conn) {
                        for w in ready {
                            c.session.call_for(
                                w.id,
                                w.function,
                                &w.args,
                                w.vehicle.as_deref(),
                                now,
                            );
                        }
                    }
                }
                Output::Outcome {
                    id,
                    outcome,
                    answered,
                } => {
                    self.settled(id, &outcome, answered);
                    if let Outcome::Failed(reason) = &outcome {
                        tracing::info!(
                            program = name.as_deref().unwrap_or("?"),
                            "call {id} failed: {reason}"
                        );
                    }
                    self.emit(ProgramInput::Outcome { id, outcome }).await
                }
                Output::Event(event) => {
                    self.emit(ProgramInput::Event {
                        program: name.unwrap_or_default(),
                        event,
                    })
                    .await
                }
                Output::Late { id } => {
                    tracing::warn!(
                        program = name.as_deref().unwrap_or("?"),
                        "late reply to call {id} ignored"
                    );
                }
                Output::Close { reason } => {
                    tracing::warn!(connection = conn, "program connection refused: {reason}");
                    c.writer = None;
                    c.reader.abort();
                }
            }
        }
        let closed = self
            .connections
            .get(&conn)
            .is_some_and(|c| c.session.is_closed());
        if closed {
            self.connections.remove(&conn);
            let lost = self.slots.iter().position(|s| s.connection == Some(conn));
            if let Some(program) = lost {
                self.slots[program].connection = None;
                self.lost(program).await;
            }
        }
    }

    async fn lost(&mut self, program: usize) {
        let name = self.roster.name(program).to_owned();
        tracing::warn!(program = %name, "program lost");
        let event = session::lost_event(&self.roster.project, &name);
        self.emit(ProgramInput::Lost {
            program: name,
            event,
        })
        .await;
    }

    async fn traffic(
        &mut self,
        connection: u64,
        program: Option<String>,
        direction: Direction,
        line: String,
    ) {
        self.emit(ProgramInput::Traffic(Traffic {
            connection,
            program,
            direction,
            line,
        }))
        .await;
    }

    /// The connection `conn` closed. A program the gateway starts waits
    /// (at most [`EXIT_WAIT`]) for its process's exit, which tells whether
    /// its pending calls fail as `restarted` or `program lost`.
    async fn closed(&mut self, conn: u64) {
        let program = self.slots.iter().position(|s| s.connection == Some(conn));
        let reason = match program.map(|p| &self.slots[p]) {
            Some(slot) if slot.started => match slot.exited {
                Some(true) => Some(session::REASON_RESTARTED),
                Some(false) => Some(session::REASON_LOST),
                None => None,
            },
            _ => Some(session::REASON_LOST),
        };
        match (reason, program) {
            (None, Some(program)) => {
                // New calls wait for the next hello meanwhile.
                self.slots[program].connection = None;
                self.parked
                    .push((conn, program, Instant::now() + EXIT_WAIT));
            }
            (reason, _) => {
                if let Some(c) = self.connections.get_mut(&conn) {
                    c.session
                        .lost_because(reason.unwrap_or(session::REASON_LOST));
                }
                self.drain(conn).await;
            }
        }
    }

    /// A parked connection's calls fail with `reason`, then the program is
    /// lost for the nets.
    async fn unpark(&mut self, conn: u64, program: usize, reason: &str) {
        self.parked.retain(|(c, _, _)| *c != conn);
        if let Some(c) = self.connections.get_mut(&conn) {
            c.session.lost_because(reason);
        }
        self.drain(conn).await;
        self.connections.remove(&conn);
        self.lost(program).await;
    }

    /// Call `id` has its outcome: a program's own answer joins its history;
    /// a call failed as `restarted` is named to the restarted program.
    fn settled(&mut self, id: u64, outcome: &Outcome, answered: bool) {
        let Some(sent) = self.sent.remove(&id) else {
            return;
        };
        let Some(slot) = self.slots.get_mut(sent.program) else {
            return;
        };
        if answered {
            let function = self.roster.function_name(sent.program, sent.function);
            let mut answer = serde_json::json!({
                "call": id,
                "function": function,
                "args": json_params(&sent.args),
            });
            match outcome {
                Outcome::Done(params) => {
                    answer["event"] = "done".into();
                    answer["params"] = json_params(params);
                }
                Outcome::Failed(reason) => {
                    answer["event"] = "failed".into();
                    answer["params"] = serde_json::json!({ "reason": reason });
                }
            }
            if let Some(vehicle) = sent.vehicle {
                answer["vehicle"] = vehicle.into();
            }
            slot.history.push(answer);
        } else if matches!(outcome, Outcome::Failed(r) if r == session::REASON_RESTARTED) {
            slot.restarted.push(id);
        }
    }

    async fn fail(&mut self, id: u64, reason: &str) {
        self.sent.remove(&id);
        self.emit(ProgramInput::Outcome {
            id,
            outcome: Outcome::Failed(reason.to_owned()),
        })
        .await;
    }

    async fn call(
        &mut self,
        id: u64,
        program: usize,
        function: usize,
        args: Params,
        vehicle: Option<String>,
    ) {
        let known = self
            .roster
            .project
            .programs
            .get(program)
            .is_some_and(|p| function < p.functions.len());
        if !known {
            return self.fail(id, "unknown program or function").await;
        }
        self.sent.insert(
            id,
            Sent {
                program,
                function,
                args: args.clone(),
                vehicle: vehicle.clone(),
            },
        );
        let slot = &self.slots[program];
        if let Some(conn) = slot.connection {
            if let Some(c) = self.connections.get_mut(&conn) {
                if c.session
                    .call_for(id, function, &args, vehicle.as_deref(), Instant::now())
                {
                    return self.drain(conn).await;
                }
            }
        }
        if slot.starting {
            let deadline = Instant::now() + self.roster.settings[program].timeout;
            self.waiting.push(Waiting {
                id,
                program,
                function,
                args,
                vehicle,
                deadline,
            });
            return;
        }
        self.fail(id, session::REASON_NOT_CONNECTED).await;
    }

    fn forget(&mut self, id: u64) {
        self.sent.remove(&id);
        self.waiting.retain(|w| w.id != id);
        for c in self.connections.values_mut() {
            if c.session.forget(id) {
                break;
            }
        }
    }

    async fn child(&mut self, event: ChildEvent) {
        match event {
            ChildEvent::Spawned { program, .. } => {
                if let Some(slot) = self.slots.get_mut(program) {
                    slot.starting = true;
                    slot.connected_since_start = false;
                }
            }
            ChildEvent::Exited {
                program, restart, ..
            } => {
                let Some(slot) = self.slots.get_mut(program) else {
                    return;
                };
                let never_connected = !slot.connected_since_start;
                slot.connected_since_start = true;
                slot.starting = restart;
                slot.exited = Some(restart);
                let reason = if restart {
                    session::REASON_RESTARTED
                } else {
                    session::REASON_LOST
                };
                let parked: Vec<u64> = self
                    .parked
                    .iter()
                    .filter(|(_, p, _)| *p == program)
                    .map(|(c, _, _)| *c)
                    .collect();
                for conn in parked {
                    self.unpark(conn, program, reason).await;
                }
                let Some(slot) = self.slots.get_mut(program) else {
                    return;
                };
                if never_connected && slot.connection.is_none() {
                    // It died before saying hello: still a loss for the nets.
                    self.lost(program).await;
                }
                if !restart {
                    let (gone, rest): (Vec<_>, Vec<_>) = std::mem::take(&mut self.waiting)
                        .into_iter()
                        .partition(|w| w.program == program);
                    self.waiting = rest;
                    for w in gone {
                        self.fail(w.id, session::REASON_NOT_CONNECTED).await;
                    }
                }
            }
        }
    }

    fn next_deadline(&self) -> Option<Instant> {
        let sessions = self
            .connections
            .values()
            .filter_map(|c| c.session.poll_timeout());
        let waiting = self.waiting.iter().map(|w| w.deadline);
        let parked = self.parked.iter().map(|(_, _, d)| *d);
        sessions.chain(waiting).chain(parked).min()
    }

    async fn timeouts(&mut self) {
        let now = Instant::now();
        let conns: Vec<u64> = self.connections.keys().copied().collect();
        for conn in conns {
            if let Some(c) = self.connections.get_mut(&conn) {
                c.session.handle_timeout(now);
            }
            self.drain(conn).await;
        }
        let (expired, rest): (Vec<_>, Vec<_>) = std::mem::take(&mut self.waiting)
            .into_iter()
            .partition(|w| w.deadline <= now);
        self.waiting = rest;
        for w in expired {
            self.fail(w.id, session::REASON_NOT_CONNECTED).await;
        }
        // A connection closed while its process goes on: lost.
        let gone: Vec<(u64, usize)> = self
            .parked
            .iter()
            .filter(|(_, _, d)| *d <= now)
            .map(|(c, p, _)| (*c, *p))
            .collect();
        for (conn, program) in gone {
            self.unpark(conn, program, session::REASON_LOST).await;
        }
    }

    async fn close(&mut self) {
        for child in std::mem::take(&mut self.children) {
            let _ = child.await;
        }
        for (_, c) in self.connections.drain() {
            c.reader.abort();
        }
    }
}

async fn sleep_until(deadline: Option<Instant>) {
    if let Some(d) = deadline {
        tokio::time::sleep_until(tokio::time::Instant::from_std(d)).await;
    }
}

async fn read_bytes(conn: u64, mut read: impl AsyncRead + Unpin, tx: mpsc::Sender<ConnEvent>) {
    let mut buffer = vec![0u8; READ_CHUNK];
    loop {
        match read.read(&mut buffer).await {
            Ok(0) | Err(_) => break,
            Ok(n) => {
                if tx
                    .send(ConnEvent::Bytes(conn, buffer[..n].to_vec()))
                    .await
                    .is_err()
                {
                    return;
                }
            }
        }
    }
    let _ = tx.send(ConnEvent::Closed(conn)).await;
}

async fn write_lines(
    mut write: impl AsyncWrite + Unpin,
    mut lines: mpsc::UnboundedReceiver<String>,
) {
    while let Some(mut line) = lines.recv().await {
        line.push('\n');
        if write.write_all(line.as_bytes()).await.is_err() {
            break;
        }
    }
    let _ = write.shutdown().await;
}
