//! Keeping the thread pool's workers awake through a frame.
//!
//! An untraced frame alternates short serial steps (the controller's
//! plans, the migration) with parallel ones (the PEs' rows and samples),
//! a few hundred microseconds each. A rayon worker that finds no work soon
//! sleeps, and waking it costs tens of microseconds on this kind of
//! machine, so each parallel step would start on one thread. While a frame
//! runs, the pool's other workers instead poll for its work
//! ([`rayon::yield_now`], yielding to the OS when there is none). Where
//! work runs never changes what it computes.

use std::sync::atomic::{AtomicBool, Ordering};

/// Runs `f` on this thread while every other worker of the current pool
/// polls for rayon work instead of going to sleep between the frame's
/// parallel steps.
pub(crate) fn with_warm_pool<T: Send>(f: impl FnOnce() -> T + Send) -> T {
    let n = rayon::current_num_threads();
    if n < 2 {
        return f();
    }
    let done = AtomicBool::new(false);
    rayon::scope(|s| {
        for _ in 1..n {
            s.spawn(|_| {
                while !done.load(Ordering::Acquire) {
                    if rayon::yield_now() != Some(rayon::Yield::Executed) {
                        std::thread::yield_now();
                    }
                }
            });
        }
        let out = f();
        done.store(true, Ordering::Release);
        out
    })
}
