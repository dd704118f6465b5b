//! The gateway's clock: this computer's monotonic clock, in microseconds
//! since the gateway started, optionally running `scale` times faster than
//! the wall for a simulated vehicle that does (`petrel run --time-scale`).
//! Frame receive times, elaboration, the player's timers and the vehicle
//! commands' timeouts all read this one clock, so they stay consistent with
//! each other whatever the scale.

use std::time::{Duration, Instant};

use nets::Micros;

#[derive(Debug, Clone, Copy)]
pub struct Clock {
    origin: Instant,
    scale: f64,
}

impl Clock {
    /// A clock counting from `origin`, `scale` times faster than the wall
    /// (1 in flight; finite and positive).
    pub fn new(origin: Instant, scale: f64) -> Clock {
        let scale = if scale.is_finite() && scale > 0.0 {
            scale
        } else {
            1.0
        };
        Clock { origin, scale }
    }

    /// Gateway time at `instant` (0 before the origin).
    pub fn at(&self, instant: Instant) -> Micros {
        let wall = instant.saturating_duration_since(self.origin);
        if self.scale == 1.0 {
            wall.as_micros() as Micros
        } else {
            (wall.as_secs_f64() * self.scale * 1e6) as Micros
        }
    }

    /// Gateway time now.
    pub fn now(&self) -> Micros {
        self.at(Instant::now())
    }

    /// The wall-clock duration of `us` microseconds of gateway time.
    pub fn wall(&self, us: Micros) -> Duration {
        if self.scale == 1.0 {
            Duration::from_micros(us)
        } else {
            Duration::from_secs_f64(us as f64 / 1e6 / self.scale)
        }
    }

    pub fn scale(&self) -> f64 {
        self.scale
    }
}

impl From<Instant> for Clock {
    fn from(origin: Instant) -> Clock {
        Clock::new(origin, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scaled_clock_runs_faster_and_converts_back() {
        let origin = Instant::now();
        let real = Clock::from(origin);
        let fast = Clock::new(origin, 10.0);
        let later = origin + Duration::from_millis(250);
        assert_eq!(real.at(later), 250_000);
        assert_eq!(fast.at(later), 2_500_000);
        assert_eq!(fast.wall(2_500_000), Duration::from_millis(250));
        assert_eq!(real.wall(1_500), Duration::from_micros(1_500));
        // Before the origin, and nonsense scales.
        assert_eq!(
            fast.at(origin
                .checked_sub(Duration::from_millis(1))
                .unwrap_or(origin)),
            0
        );
        assert_eq!(Clock::new(origin, f64::NAN).scale(), 1.0);
        assert_eq!(Clock::new(origin, -2.0).scale(), 1.0);
    }
}
