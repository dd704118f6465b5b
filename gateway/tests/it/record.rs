//! Recording (MCAP) end to end: the recorder in-process on a scripted
//! flight (the SITL plane's telemetry, the uav-survey project, answers to
//! its commands and calls), then `petrel replay FILE.mcap --check-against`,
//! tampered and cut recordings, a recorder killed with SIGKILL, a writer too
//! slow for its queue, and the Python `mcap` package as an independent
//! reader.

use petrel_core::supervisor;

use petrel_core::project;

use petrel_record as record;

mod files;
mod flight;
mod power;
mod python;
mod queue;
mod replay;
use crate::scratch;
