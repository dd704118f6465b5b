//! The progress line of a long check on stderr (`petrel check`, on a net
//! or a project).

use std::sync::Mutex;
use std::time::Instant;

/// The progress line on stderr: shown after the first second, twice a
/// second, erased at the end.
pub(super) struct Progress {
    start: Instant,
    last: Mutex<Option<Instant>>,
}

impl Progress {
    pub(super) fn new(start: Instant) -> Progress {
        Progress {
            start,
            last: Mutex::new(None),
        }
    }

    /// Prints the progress line if it is due.
    pub(super) fn report(&self, states: u64) {
        if let Some(line) = self.line(states, Instant::now()) {
            say_part!("{line}");
        }
    }

    /// The line to print at `now` after `states` states, if one is due: none
    /// in the first second, then at most two a second.
    fn line(&self, states: u64, now: Instant) -> Option<String> {
        let elapsed = now.duration_since(self.start).as_secs_f64();
        if elapsed < 1.0 {
            return None;
        }
        let mut last = self.last.lock().unwrap_or_else(|e| e.into_inner());
        if last.is_some_and(|l| now.duration_since(l).as_secs_f64() < 0.5) {
            return None;
        }
        *last = Some(now);
        Some(format!(
            "\r{states} states, {:.0} states/s   ",
            states as f64 / elapsed
        ))
    }

    pub(super) fn finish(&self) {
        if self
            .last
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .is_some()
        {
            say_part!("\r{:60}\r", "");
        }
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    #[test]
    fn the_progress_line_comes_after_a_second_at_most_twice_a_second() {
        let start = Instant::now();
        let p = Progress::new(start);
        let at = |ms: u64| start + Duration::from_millis(ms);
        assert_eq!(p.line(10, at(900)), None);
        assert_eq!(
            p.line(4000, at(2000)).as_deref(),
            Some("\r4000 states, 2000 states/s   ")
        );
        assert_eq!(p.line(5000, at(2400)), None);
        assert!(p.line(6000, at(2500)).is_some());
    }
}
