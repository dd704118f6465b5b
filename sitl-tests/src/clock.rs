//! The simulated clock: sim time = speedup × wall time since it started.

use std::time::{Duration, Instant};

/// A clock running `speedup` times faster than the wall clock.
#[derive(Debug, Clone, Copy)]
pub struct SimClock {
    start: Option<Instant>,
    speedup: f64,
}

impl SimClock {
    /// A stopped clock (sim time 0 until [`SimClock::start`]).
    pub fn new(speedup: f64) -> SimClock {
        SimClock {
            start: None,
            speedup,
        }
    }

    /// Starts the clock now (again: nothing).
    pub fn start(&mut self) {
        if self.start.is_none() {
            self.start = Some(Instant::now());
        }
    }

    pub fn started(&self) -> bool {
        self.start.is_some()
    }

    /// Sim microseconds since the start.
    pub fn now_us(&self) -> u64 {
        match self.start {
            Some(s) => (s.elapsed().as_secs_f64() * self.speedup * 1e6) as u64,
            None => 0,
        }
    }

    /// The wall time until sim time `sim_us` (zero when past).
    pub fn wall_until(&self, sim_us: u64) -> Duration {
        let now = self.now_us();
        if sim_us <= now || self.start.is_none() {
            return Duration::ZERO;
        }
        Duration::from_secs_f64((sim_us - now) as f64 / 1e6 / self.speedup)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stopped_until_started_then_scaled() {
        let mut c = SimClock::new(1000.0);
        assert_eq!(c.now_us(), 0);
        assert_eq!(c.wall_until(5_000_000), Duration::ZERO);
        c.start();
        assert!(c.started());
        let w = c.wall_until(10_000_000_000);
        // 10 000 sim seconds at ×1000: at most 10 s of wall time.
        assert!(w <= Duration::from_secs(10) && w > Duration::from_secs(9));
    }
}
