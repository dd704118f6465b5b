//! The sans-IO core of one program connection: fed the bytes the program
//! sends and the calls the nets make, polled for lines to send, outcomes of
//! calls and events. Every protocol rule lives here and is tested without a
//! socket; the time is an input (`now`), never read.

use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;
use std::time::{Duration, Instant};

use nets::{Category, Event, Outcome, Params, Value};

use super::protocol::{self, Incoming, MAX_LINE};
use super::roster::Roster;

/// Whether a hello's token lets the program in: any hello when the gateway
/// requires none; else the same token, compared in constant time.
fn authorised(required: Option<&str>, given: Option<&str>) -> bool {
    let Some(required) = required else {
        return true;
    };
    let given = given.unwrap_or("").as_bytes();
    let required = required.as_bytes();
    let mut diff = u8::from(given.len() != required.len());
    for (i, r) in required.iter().enumerate() {
        diff |= r ^ given.get(i).copied().unwrap_or(0);
    }
    diff == 0
}

/// Name of the event a lost program becomes.
pub const PROGRAM_LOST: &str = "program_lost";

/// The gateway's event for frames dropped by signature checks
/// (`gateway::link::rejections`); a program may not send it either.
pub const SIGNATURE_REJECTED: &str = "signature_rejected";
/// Reasons of failed outcomes the gateway gives itself.
pub const REASON_LOST: &str = "program lost";
pub const REASON_TIMEOUT: &str = "timeout";
pub const REASON_NOT_CONNECTED: &str = "not connected";
/// The program's connection closed and the gateway is starting it again
/// (its `restart` policy): the nets may ask again, and the call waits for
/// the new process's hello.
pub const REASON_RESTARTED: &str = "restarted";

/// How many settled call ids (timed out or forgotten) a session remembers,
/// so that their late replies are ignored rather than answered with an error.
const SETTLED_MEMORY: usize = 1024;

/// How long a connection may stay without saying hello before it is closed.
pub const HELLO_TIMEOUT: Duration = Duration::from_secs(10);

/// What a session asks of its connection, in order.
#[derive(Debug, Clone, PartialEq)]
pub enum Output {
    /// A line to send to the program (no newline).
    Send(String),
    /// A line the program sent (the traffic record; lossy UTF-8).
    Received(String),
    /// The program said hello and was accepted as this program.
    Hello { program: usize },
    /// The outcome of a call; `answered`: the program sent it (a `done` or
    /// `failed` reply), rather than the gateway deciding it (a timeout, a
    /// loss).
    Outcome {
        id: u64,
        outcome: Outcome,
        answered: bool,
    },
    /// An event the program sent on its own.
    Event(Event),
    /// A reply came for a call that had timed out or was forgotten: ignored.
    Late { id: u64 },
    /// Close the connection (after sending what was queued).
    Close { reason: String },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    /// Waiting for the hello.
    Greeting,
    /// Identified as this program.
    Ready(usize),
    Closed,
}

#[derive(Debug, Clone)]
struct Pending {
    function: usize,
    deadline: Instant,
}

/// One connection's protocol state.
#[derive(Debug)]
pub struct Session {
    roster: Arc<Roster>,
    state: State,
    /// When a connection that has not said hello is closed.
    hello_deadline: Instant,
    /// Lines received so far (the number of the line being read is one more).
    lines: u64,
    buffer: Vec<u8>,
    /// Inside a line longer than [`MAX_LINE`]: dropping bytes up to its end.
    discarding: bool,
    pending: BTreeMap<u64, Pending>,
    settled: VecDeque<u64>,
    outputs: VecDeque<Output>,
}

impl Session {
    /// A connection accepted at `now`: it has [`HELLO_TIMEOUT`] to say hello.
    pub fn new(roster: Arc<Roster>, now: Instant) -> Session {
        Session {
            roster,
            state: State::Greeting,
            hello_deadline: now + HELLO_TIMEOUT,
            lines: 0,
            buffer: Vec::new(),
            discarding: false,
            pending: BTreeMap::new(),
            settled: VecDeque::new(),
            outputs: VecDeque::new(),
        }
    }

    /// The program this connection is, once its hello was accepted.
    pub fn program(&self) -> Option<usize> {
        match self.state {
            State::Ready(p) => Some(p),
            _ => None,
        }
    }

    pub fn is_closed(&self) -> bool {
        self.state == State::Closed
    }

    /// Calls waiting for their reply.
    pub fn pending(&self) -> usize {
        self.pending.len()
    }

    /// The next output, in order.
    pub fn poll(&mut self) -> Option<Output> {
        self.outputs.pop_front()
    }

    /// Feeds bytes the program sent. `taken(program)` tells whether another
    /// connection already is that program (its hello is then refused).
    pub fn feed(&mut self, bytes: &[u8], taken: impl Fn(usize) -> bool) {
        self.feed_resuming(bytes, taken, |_| None)
    }

    /// [`Self::feed`], where `resume(program)` is what the welcome tells a
    /// program that connected before in this run (`"resume"`,
    /// docs/programs.md "Restarts").
    pub fn feed_resuming(
        &mut self,
        mut bytes: &[u8],
        taken: impl Fn(usize) -> bool,
        resume: impl Fn(usize) -> Option<serde_json::Value>,
    ) {
        while !bytes.is_empty() && self.state != State::Closed {
            let newline = bytes.iter().position(|&b| b == b'\n');
            let (chunk, rest) = match newline {
                Some(i) => (&bytes[..i], &bytes[i + 1..]),
                None => (bytes, &[][..]),
            };
            bytes = rest;
            if !self.discarding {
                if self.buffer.len() + chunk.len() > MAX_LINE {
                    self.lines += 1;
                    self.discarding = true;
                    self.buffer.clear();
                    self.outputs.push_back(Output::Received(format!(
                        "<a line longer than {MAX_LINE} bytes, discarded>"
                    )));
                    self.error(&format!(
                        "line longer than {MAX_LINE} bytes: discarded up to its end"
                    ));
                } else {
                    self.buffer.extend_from_slice(chunk);
                }
            }
            if newline.is_some() {
                if self.discarding {
                    self.discarding = false;
                } else {
                    let line = std::mem::take(&mut self.buffer);
                    self.lines += 1;
                    self.line(&line, &taken, &resume);
                }
            }
        }
    }

    fn error(&mut self, message: &str) {
        self.outputs
            .push_back(Output::Send(protocol::error(message, self.lines)));
    }

    fn line(
        &mut self,
        raw: &[u8],
        taken: &impl Fn(usize) -> bool,
        resume: &impl Fn(usize) -> Option<serde_json::Value>,
    ) {
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        let parsed = std::str::from_utf8(raw).map(|text| (text, protocol::parse(text)));
        // What is logged and recorded: the line, with a hello's token
        // redacted (a recording must never hold the secret).
        let received = match &parsed {
            Ok((text, Ok(Incoming::Hello { token: Some(_), .. }))) => protocol::redact_token(text),
            _ => String::from_utf8_lossy(raw).into_owned(),
        };
        self.outputs.push_back(Output::Received(received));
        let Ok((text, incoming)) = parsed else {
            return self.error("not UTF-8");
        };
        if text.trim().is_empty() {
            return;
        }
        let incoming = match incoming {
            Ok(i) => i,
            Err(message) => return self.error(&message),
        };
        match (incoming, self.state) {
            (
                Incoming::Hello {
                    program,
                    functions,
                    token,
                },
                State::Greeting,
            ) => {
                if !authorised(self.roster.token.as_deref(), token.as_deref()) {
                    return self.refuse(
                        "unauthorised: the gateway requires a `token` in the hello, and this one is missing or wrong",
                    );
                }
                self.hello(&program, &functions, taken, resume)
            }
            (Incoming::Hello { .. }, _) => {
                self.error("hello again: this connection already said hello")
            }
            (_, State::Greeting) => {
                self.error("say hello first: {\"hello\": NAME, \"functions\": [...]}")
            }
            (Incoming::Done { id, params }, State::Ready(p)) => self.done(p, id, params),
            (Incoming::Failed { id, reason }, State::Ready(_)) => {
                if self.settle(id) {
                    self.outputs.push_back(Output::Outcome {
                        id,
                        outcome: Outcome::Failed(reason),
                        answered: true,
                    });
                }
            }
            (Incoming::Event { name, params }, State::Ready(_)) => self.event(name, params),
            (_, State::Closed) => {}
        }
    }

    fn hello(
        &mut self,
        name: &str,
        functions: &[String],
        taken: &impl Fn(usize) -> bool,
        resume: &impl Fn(usize) -> Option<serde_json::Value>,
    ) {
        let roster = Arc::clone(&self.roster);
        let Some(program) = roster.program(name) else {
            let known: Vec<&str> = roster
                .project
                .programs
                .iter()
                .map(|p| p.name.as_str())
                .collect();
            return self.refuse(&format!(
                "unknown program `{name}`: the project declares {}",
                if known.is_empty() {
                    "none".to_owned()
                } else {
                    known.join(", ")
                }
            ));
        };
        let missing: Vec<&str> = roster
            .called_names(program)
            .into_iter()
            .filter(|f| !functions.iter().any(|s| s == f))
            .collect();
        if !missing.is_empty() {
            return self.refuse(&format!(
                "program `{name}` does not serve {}, which the nets call",
                missing.join(", ")
            ));
        }
        if taken(program) {
            return self.refuse(&format!("program `{name}` is already connected"));
        }
        self.state = State::Ready(program);
        self.outputs.push_back(Output::Send(protocol::welcome(
            name,
            &roster.called_names(program),
            resume(program),
        )));
        self.outputs.push_back(Output::Hello { program });
    }

    /// Refuses the connection: an error reply, then close.
    fn refuse(&mut self, message: &str) {
        self.error(message);
        self.state = State::Closed;
        self.outputs.push_back(Output::Close {
            reason: message.to_owned(),
        });
    }

    /// Removes a pending call answered now; false (with an error reply, or
    /// a `Late` output for a settled call) if it was not pending.
    fn settle(&mut self, id: u64) -> bool {
        if self.pending.remove(&id).is_some() {
            return true;
        }
        if self.settled.contains(&id) {
            self.outputs.push_back(Output::Late { id });
        } else {
            self.error(&format!("reply to call {id}, which is not pending"));
        }
        false
    }

    fn done(&mut self, program: usize, id: u64, params: Params) {
        let roster = Arc::clone(&self.roster);
        let function = self.pending.get(&id).and_then(|pending| {
            roster
                .project
                .programs
                .get(program)
                .and_then(|p| p.functions.get(pending.function))
        });
        if let Some(function) = function {
            let missing: Vec<&str> = function
                .returns
                .iter()
                .filter(|r| !params.contains_key(*r))
                .map(String::as_str)
                .collect();
            let unknown: Vec<&str> = params
                .keys()
                .filter(|k| !function.returns.contains(k))
                .map(String::as_str)
                .collect();
            if !missing.is_empty() || !unknown.is_empty() {
                let mut why = Vec::new();
                if !missing.is_empty() {
                    why.push(format!("missing {}", missing.join(", ")));
                }
                if !unknown.is_empty() {
                    why.push(format!("unknown {}", unknown.join(", ")));
                }
                return self.error(&format!(
                    "reply to call {id}: {}.{} returns [{}]: {}",
                    roster.name(program),
                    function.name,
                    function.returns.join(", "),
                    why.join("; ")
                ));
            }
        }
        if self.settle(id) {
            self.outputs.push_back(Output::Outcome {
                id,
                outcome: Outcome::Done(params),
                answered: true,
            });
        }
    }

    fn event(&mut self, name: String, params: Params) {
        let identifier = name
            .chars()
            .next()
            .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
            && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !identifier {
            return self.error(&format!(
                "event name {name:?}: letters, digits and `_` only (names with `.` are results)"
            ));
        }
        if name == PROGRAM_LOST || name == SIGNATURE_REJECTED {
            return self.error(&format!("event `{name}` is the gateway's own"));
        }
        if let Some(refusal) = nets::outside::refusal(&self.roster.project, &name) {
            return self.error(&format!("event `{name}`: {refusal}"));
        }
        let decl = self.roster.project.events.get(&name);
        if let Some(declared) = decl.and_then(|d| d.params.as_ref()) {
            if let Some(unknown) = params.keys().find(|k| !declared.contains(k)) {
                return self.error(&format!(
                    "event `{name}` has no parameter `{unknown}` (declared: {})",
                    declared.join(", ")
                ));
            }
        }
        let category = decl.and_then(|d| d.category).unwrap_or(Category::Nominal);
        self.outputs.push_back(Output::Event(Event {
            name,
            category,
            params,
        }));
    }

    /// Sends a call. False if the session is not ready (no hello yet, or
    /// closed): the caller fails it.
    pub fn call(&mut self, id: u64, function: usize, args: &Params, now: Instant) -> bool {
        self.call_for(id, function, args, None, now)
    }

    /// [`Self::call`] for a vehicle of a team: the line carries its name.
    pub fn call_for(
        &mut self,
        id: u64,
        function: usize,
        args: &Params,
        vehicle: Option<&str>,
        now: Instant,
    ) -> bool {
        let State::Ready(program) = self.state else {
            return false;
        };
        let roster = Arc::clone(&self.roster);
        let timeout = roster.settings[program].timeout;
        self.outputs.push_back(Output::Send(protocol::call(
            id,
            roster.function_name(program, function),
            args,
            vehicle,
        )));
        self.pending.insert(
            id,
            Pending {
                function,
                deadline: now + timeout,
            },
        );
        true
    }

    /// Forgets a pending call (its net was deactivated): no outcome, and a
    /// late reply is ignored. False if it was not pending here.
    pub fn forget(&mut self, id: u64) -> bool {
        let known = self.pending.remove(&id).is_some();
        if known {
            self.remember(id);
        }
        known
    }

    fn remember(&mut self, id: u64) {
        if self.settled.len() == SETTLED_MEMORY {
            self.settled.pop_front();
        }
        self.settled.push_back(id);
    }

    /// The earliest instant a pending call times out (or, before the hello,
    /// the connection is closed).
    pub fn poll_timeout(&self) -> Option<Instant> {
        match self.state {
            State::Greeting => Some(self.hello_deadline),
            State::Ready(_) => self.pending.values().map(|p| p.deadline).min(),
            State::Closed => None,
        }
    }

    /// Fails the calls whose deadline is past with reason "timeout"; closes
    /// a connection that did not say hello in time.
    pub fn handle_timeout(&mut self, now: Instant) {
        if self.state == State::Greeting && now >= self.hello_deadline {
            return self.refuse(&format!("no hello within {HELLO_TIMEOUT:?}"));
        }
        let expired: Vec<u64> = self
            .pending
            .iter()
            .filter(|(_, p)| p.deadline <= now)
            .map(|(&id, _)| id)
            .collect();
        for id in expired {
            self.pending.remove(&id);
            self.remember(id);
            self.outputs.push_back(Output::Outcome {
                id,
                outcome: Outcome::Failed(REASON_TIMEOUT.into()),
                answered: false,
            });
        }
    }

    /// The connection is gone: every pending call fails with "program lost".
    pub fn lost(&mut self) {
        self.lost_because(REASON_LOST);
    }

    /// The connection is gone: every pending call fails with `reason`
    /// ([`REASON_LOST`], or [`REASON_RESTARTED`] when the gateway starts
    /// the program again).
    pub fn lost_because(&mut self, reason: &str) {
        self.state = State::Closed;
        for id in std::mem::take(&mut self.pending).into_keys() {
            self.remember(id);
            self.outputs.push_back(Output::Outcome {
                id,
                outcome: Outcome::Failed(reason.into()),
                answered: false,
            });
        }
    }
}

/// The event a lost program becomes: `program_lost {name}`, in the category
/// the project declares (nominal otherwise).
pub fn lost_event(project: &nets::Project, program: &str) -> Event {
    let category = project
        .events
        .get(PROGRAM_LOST)
        .and_then(|d| d.category)
        .unwrap_or(Category::Nominal);
    Event::new(PROGRAM_LOST)
        .category(category)
        .param("name", Value::Str(program.to_owned()))
}

#[cfg(test)]
mod tests;
