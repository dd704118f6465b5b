//! Recording (MCAP) end to end: the recorder in-process on a scripted
//! flight (the SITL plane's telemetry, the uav-survey project, answers to
//! its commands and calls), then `petrel replay FILE.mcap --check-against`,
//! tampered and cut recordings, a recorder killed with SIGKILL, a writer too
//! slow for its queue, and the Python `mcap` package as an independent
//! reader.

use gateway::supervisor;

use gateway::project;

use gateway::record;

#[path = "record/files.rs"]
mod files;
#[path = "record/flight.rs"]
mod flight;
#[path = "record/power.rs"]
mod power;
#[path = "record/python.rs"]
mod python;
#[path = "record/queue.rs"]
mod queue;
#[path = "record/replay.rs"]
mod replay;
#[path = "support/scratch.rs"]
mod scratch;
