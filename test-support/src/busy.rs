//! "The other core busy": a thread spinning until the measure that needs
//! it is over, for the benchmarks measured idle and loaded.

/// Runs `measure` with one thread spinning beside it.
pub fn with_a_core_busy(measure: impl FnOnce()) {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    let stop = Arc::new(AtomicBool::new(false));
    let spinner = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            let mut x = 0u64;
            while !stop.load(Ordering::Relaxed) {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
                std::hint::black_box(x);
            }
        })
    };
    measure();
    stop.store(true, Ordering::Relaxed);
    let _ = spinner.join();
}
