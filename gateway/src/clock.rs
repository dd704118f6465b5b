//! The gateway's clock: this computer's monotonic clock, in microseconds
//! since the gateway started, optionally running `scale` times faster than
//! the wall for a simulated vehicle that does (`petrel run --time-scale`).
//! Frame receive times, elaboration, the player's timers and the vehicle
//! commands' timeouts all read this one clock, so they stay consistent with
//! each other whatever the scale.
//!
//! A simulator asked to run N times faster does so only while the machine
//! keeps up: ArduPilot's SITL on a busy two-core computer may fall to 1×
//! for a while. A scaled clock therefore follows the simulated vehicle's
//! own time ([`Clock::sync`] with the autopilot's `time_boot_ms`): between
//! two of its messages it runs at the rate the vehicle was last seen
//! running (at most `scale`), and it never goes backwards. At scale 1 (a
//! real vehicle) it is the monotonic clock, nothing else.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use nets::Micros;

/// Wall time over which the vehicle's rate is measured.
const RATE_WINDOW: Duration = Duration::from_millis(500);

#[derive(Debug, Clone)]
pub struct Clock {
    origin: Instant,
    scale: f64,
    /// For a scaled clock: how it follows the vehicle.
    follow: Option<Arc<Mutex<Follow>>>,
}

/// A scaled clock's state: gateway time `anchor_us` at `anchor_wall`,
/// running at `rate` gateway µs per wall µs since.
#[derive(Debug, Clone)]
struct Follow {
    anchor_wall: Instant,
    anchor_us: Micros,
    rate: f64,
    /// The last time returned (the clock never goes back).
    last: Micros,
    /// Gateway time minus vehicle time, from the first sync (and again
    /// after the vehicle rebooted).
    offset: Option<i128>,
    /// Where the rate was last measured: (wall, vehicle µs).
    measured: Option<(Instant, Micros)>,
    /// The vehicle's last time.
    vehicle: Option<Micros>,
    /// The vehicle's measured rate (`rate` is this, or half of it while
    /// the clock is ahead of the vehicle).
    vehicle_rate: f64,
}

impl Follow {
    fn at(&mut self, instant: Instant) -> Micros {
        let wall = instant.saturating_duration_since(self.anchor_wall);
        let t = self.anchor_us + (wall.as_secs_f64() * self.rate * 1e6) as Micros;
        self.last = self.last.max(t);
        self.last
    }
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
        let follow = (scale != 1.0).then(|| {
            Arc::new(Mutex::new(Follow {
                anchor_wall: origin,
                anchor_us: 0,
                rate: scale,
                last: 0,
                offset: None,
                measured: None,
                vehicle: None,
                vehicle_rate: scale,
            }))
        });
        Clock {
            origin,
            scale,
            follow,
        }
    }

    /// Gateway time at `instant` (0 before the origin). On a scaled clock,
    /// `instant` is taken as now: it only moves forward.
    pub fn at(&self, instant: Instant) -> Micros {
        if let Some(follow) = &self.follow {
            if let Ok(mut f) = follow.lock() {
                return f.at(instant);
            }
        }
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

    /// The simulated vehicle said its time is `vehicle_us` (its
    /// `time_boot_ms`, in µs), in a message received now. A clock at scale
    /// 1 ignores it.
    pub fn sync(&self, vehicle_us: Micros) {
        self.sync_at(Instant::now(), vehicle_us);
    }

    fn sync_at(&self, instant: Instant, vehicle_us: Micros) {
        let Some(follow) = &self.follow else {
            return;
        };
        let Ok(mut f) = follow.lock() else {
            return;
        };
        let now = f.at(instant);
        // A vehicle seen for the first time, or that rebooted (its time
        // went back by more than a second), is followed from here on.
        let rebooted = f.vehicle.is_some_and(|v| vehicle_us + 1_000_000 < v);
        let offset = match f.offset {
            Some(o) if !rebooted => o,
            _ => {
                let o = now as i128 - vehicle_us as i128;
                f.offset = Some(o);
                f.measured = None;
                o
            }
        };
        f.vehicle = Some(vehicle_us);
        match f.measured {
            None => f.measured = Some((instant, vehicle_us)),
            Some((wall, v)) => {
                let elapsed = instant.saturating_duration_since(wall);
                if elapsed >= RATE_WINDOW && vehicle_us > v {
                    let rate = (vehicle_us - v) as f64 / 1e6 / elapsed.as_secs_f64();
                    f.vehicle_rate = rate.clamp(self.scale * 0.02, self.scale);
                    f.measured = Some((instant, vehicle_us));
                }
            }
        }
        // Behind the vehicle: jump to it. Ahead (it ran slower than
        // expected): never back, but at half its rate until it catches up.
        let target = (vehicle_us as i128 + offset).max(0) as Micros;
        f.anchor_wall = instant;
        if target >= now {
            f.anchor_us = target;
            f.rate = f.vehicle_rate;
        } else {
            f.anchor_us = now;
            f.rate = f.vehicle_rate / 2.0;
        }
        f.last = f.anchor_us;
    }

    /// The wall-clock duration of `us` microseconds of gateway time, at
    /// the rate the clock runs now.
    pub fn wall(&self, us: Micros) -> Duration {
        let rate = match &self.follow {
            Some(f) => f.lock().map(|f| f.rate).unwrap_or(self.scale),
            None => self.scale,
        };
        if rate == 1.0 {
            Duration::from_micros(us)
        } else {
            Duration::from_secs_f64(us as f64 / 1e6 / rate)
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
            real.at(origin
                .checked_sub(Duration::from_millis(1))
                .unwrap_or(origin)),
            0
        );
        assert_eq!(Clock::new(origin, f64::NAN).scale(), 1.0);
        assert_eq!(Clock::new(origin, -2.0).scale(), 1.0);
    }

    #[test]
    fn a_scaled_clock_follows_a_vehicle_that_falls_behind_its_speed_up() {
        let origin = Instant::now();
        let clock = Clock::new(origin, 10.0);
        let at = |ms: u64| origin + Duration::from_millis(ms);
        // Heard 100 ms in, up for 5 s; then running at 2× only, a message
        // every 125 ms of wall time.
        clock.sync_at(at(100), 5_000_000);
        assert_eq!(clock.at(at(100)), 1_000_000, "no jump at the first sync");
        let offset = 1_000_000i128 - 5_000_000;
        let mut last = 0;
        for step in 1..=40u64 {
            let wall = 100 + 125 * step;
            let vehicle = 5_000_000 + 250_000 * step;
            let mid = clock.at(at(wall - 60));
            assert!(mid >= last, "never back");
            clock.sync_at(at(wall), vehicle);
            last = clock.at(at(wall));
            if step > 20 {
                let lag = last as i128 - (vehicle as i128 + offset);
                assert!(lag.abs() < 300_000, "step {step}: {lag} µs off the vehicle");
            }
        }
        // The vehicle's rate is known: 2 s of its time take 1 s of wall.
        let wall = clock.wall(2_000_000).as_secs_f64();
        assert!((wall - 1.0).abs() < 0.1, "{wall}");
        // Silence (a link hole): the clock keeps running at that rate.
        let t = clock.at(at(5100));
        let later = clock.at(at(7100));
        let ran = (later - t) as f64 / 1e6;
        assert!((3.5..=4.5).contains(&ran), "{ran} s in 2 s of silence");
    }

    #[test]
    fn a_followed_clock_never_goes_back_even_when_the_vehicle_reboots() {
        let origin = Instant::now();
        let clock = Clock::new(origin, 5.0);
        let at = |ms: u64| origin + Duration::from_millis(ms);
        clock.sync_at(at(0), 60_000_000);
        let before = clock.at(at(1000));
        clock.sync_at(at(1000), 1_000_000); // rebooted
        assert!(clock.at(at(1000)) >= before);
        clock.sync_at(at(1600), 4_000_000);
        assert!(clock.at(at(1600)) >= before + 3_000_000 - 1);
        let mut last = 0;
        for n in (1600..3000).step_by(50) {
            let t = clock.at(at(n));
            assert!(t >= last);
            last = t;
        }
    }

    #[test]
    fn a_clock_at_scale_one_ignores_the_vehicle() {
        let origin = Instant::now();
        let clock = Clock::from(origin);
        clock.sync_at(origin, 99_000_000);
        assert_eq!(clock.at(origin + Duration::from_millis(5)), 5_000);
    }
}
