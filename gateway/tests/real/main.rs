//! The gateway's tests against real firmware and real peers: ArduPilot
//! and PX4 SITL, MAVProxy, socat, pymavlink, and the hour's soak
//! (`#[ignore]`d). `cargo test -p gateway --test real`.
//!
//! Every test that starts a SITL (ArduPilot or PX4) holds a [`sitl_turn`]
//! for as long as its SITLs run: at most [`at_once`] flights in this
//! process (two by default, `PETREL_SITL_AT_ONCE` to change it). One
//! flight takes a third to a half of one core (ArduPlane's nominal
//! mission: 8 CPU-s in 26 s wall; PX4's survey: 15 CPU-s in 30 s;
//! 2026-12-07), so two fit on the two cores with room for the gateways,
//! where one at a time left the machine 80 % idle for ten minutes.
//!
//! ArduPilot SITL instances (TCP 5760 + 10 × instance), each used by one
//! module only: real_plane 0, real_failures 3 and 4, deploy 5,
//! multi_vehicle 6 and 7, mirror_sitl 9 and 12, real_px4's ArduCopter 10
//! and 13, signing 11, events 14, team 15 and 16. A turn moves them by
//! 20 × its slot ([`Turn::instance`]), so that two flights of one module
//! never share a port. PX4 SITL takes its own instances 0-3 (sitl-tests'
//! pool; ports 14540+, 18570+, apart from ArduPilot's).

use std::sync::{Condvar, Mutex};

#[path = "../scenarios/flight.rs"]
mod flight;
#[path = "../support/gateways.rs"]
mod gateways;
#[path = "../support/harness.rs"]
mod harness;
use petrel_test_support::scratch;
#[path = "../support/team_run.rs"]
mod team_run;
#[path = "../support/wire.rs"]
mod wire;

mod px4;
mod real;

mod deploy;
mod events;
mod mirror_sitl;
mod multi_vehicle;
mod real_failures;
mod real_plane;
mod real_px4;
mod signing;
mod soak;
mod team;

/// The most slots [`at_once`] gives: instance 16 + 20 × 2 = 56 (TCP
/// 6320) is still far below PX4's and the tests' ephemeral ports.
const MOST_AT_ONCE: usize = 3;

static SLOTS: Mutex<[bool; MOST_AT_ONCE]> = Mutex::new([false; MOST_AT_ONCE]);
static FREED: Condvar = Condvar::new();

/// How many SITL flights this binary flies at once: `PETREL_SITL_AT_ONCE`
/// (1 to 3), else 2.
pub fn at_once() -> usize {
    std::env::var("PETREL_SITL_AT_ONCE")
        .ok()
        .and_then(|v| v.trim().parse::<usize>().ok())
        .map_or(2, |n| n.clamp(1, MOST_AT_ONCE))
}

/// A test's turn to fly SITLs: one of [`at_once`] slots, held until
/// dropped. A test that failed while holding it does not stop the others
/// (its slot is given back on unwinding; poison is ignored).
pub struct Turn {
    slot: usize,
    /// Slots held from `slot` on (every one: [`sitl_turn_alone`]).
    held: usize,
}

impl Turn {
    /// The ArduPilot SITL instance a module numbered `base` flies in this
    /// turn: `base + 20 × slot`.
    pub fn instance(&self, base: u8) -> u8 {
        // MOST_AT_ONCE keeps this within u8.
        base + 20 * self.slot as u8
    }
}

impl Drop for Turn {
    fn drop(&mut self) {
        let mut slots = SLOTS.lock().unwrap_or_else(|e| e.into_inner());
        for taken in slots.iter_mut().skip(self.slot).take(self.held) {
            *taken = false;
        }
        FREED.notify_all();
    }
}

/// Waits for a free slot and takes it.
pub fn sitl_turn() -> Turn {
    let limit = at_once();
    let mut slots = SLOTS.lock().unwrap_or_else(|e| e.into_inner());
    loop {
        if let Some(slot) = slots[..limit].iter().position(|taken| !taken) {
            slots[slot] = true;
            return Turn { slot, held: 1 };
        }
        slots = FREED.wait(slots).unwrap_or_else(|e| e.into_inner());
    }
}

/// A turn that has the machine to itself: every slot, once all are free
/// (a flight whose gateway proves a new version of its nets takes a whole
/// core for tens of seconds in a debug build; another flight beside it
/// would fall behind).
pub fn sitl_turn_alone() -> Turn {
    let limit = at_once();
    let mut slots = SLOTS.lock().unwrap_or_else(|e| e.into_inner());
    loop {
        if slots[..limit].iter().all(|taken| !taken) {
            for taken in &mut slots[..limit] {
                *taken = true;
            }
            return Turn {
                slot: 0,
                held: limit,
            };
        }
        slots = FREED.wait(slots).unwrap_or_else(|e| e.into_inner());
    }
}

/// The scenarios' mission file in the project (DEC reads it; the
/// `flight` module, shared with benches/mirror.rs, takes it from here).
pub const MISSION_FILE: &str = "mission.toml";
