//! Keeping the thread pool's workers at hand through a frame.
//!
//! An untraced frame alternates short serial steps (the controller's
//! plans, the migration) with parallel ones (the PEs' rows and samples),
//! a few tens of microseconds each. A rayon worker that finds no work
//! soon sleeps, and waking it costs tens of microseconds on this kind of
//! machine (more when its virtual core has halted), so each parallel step
//! would start on one thread and end waiting for a wake-up. While a frame
//! runs, the pool's other workers instead poll for its work
//! ([`rayon::yield_now`], yielding to the OS when there is none) for up
//! to [`SPIN`] after the last work they found, which covers the gaps
//! between the steps of a slice; a serial stretch longer than that (a
//! merge's set-up, the readout's host writes) parks them until the next
//! parallel step posts its items ([`each_mut`] wakes them), so that an
//! idle worker does not burn a core the whole frame. A parallel step
//! waits for its last item by polling too, never in rayon's sleeping
//! join. Where work runs never changes what it computes: every result
//! comes back in item order.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};

/// How long a worker polls after the last work it found before parking:
/// longer than the gaps between a slice's parallel steps, short against
/// a frame.
const SPIN: Duration = Duration::from_micros(100);

/// Where idle pollers park: the number of parked ones (read without the
/// lock by [`each_mut`], so that posting work costs an atomic load when
/// none is parked) and a generation that posting work advances. Shared
/// by every pool: a poller woken for another pool's step finds no work
/// and parks again.
struct Parking {
    parked: AtomicUsize,
    generation: Mutex<u64>,
    wake: Condvar,
}

static PARKING: Parking = Parking {
    parked: AtomicUsize::new(0),
    generation: Mutex::new(0),
    wake: Condvar::new(),
};

impl Parking {
    /// Wakes every parked poller (work was posted, or a frame ended).
    fn wake_all(&self) {
        if self.parked.load(Ordering::SeqCst) > 0 {
            let mut g = self.generation.lock().unwrap_or_else(|e| e.into_inner());
            *g = g.wrapping_add(1);
            self.wake.notify_all();
        }
    }

    /// Parks the calling poller until work is posted or `done` is set;
    /// returns at once when work was posted since it counted itself
    /// parked (it then polls again).
    fn park(&self, done: &AtomicBool) {
        let mut g = self.generation.lock().unwrap_or_else(|e| e.into_inner());
        self.parked.fetch_add(1, Ordering::SeqCst);
        let seen = *g;
        // Work posted before the count above was seen by no waker: look
        // once more (without the lock, which a waker needs) before waiting.
        drop(g);
        if rayon::yield_now() == Some(rayon::Yield::Executed) {
            self.parked.fetch_sub(1, Ordering::SeqCst);
            return;
        }
        g = self.generation.lock().unwrap_or_else(|e| e.into_inner());
        while *g == seen && !done.load(Ordering::Acquire) {
            g = self.wake.wait(g).unwrap_or_else(|e| e.into_inner());
        }
        drop(g);
        self.parked.fetch_sub(1, Ordering::SeqCst);
    }
}

/// Runs `f` on this thread while every other worker of the current pool
/// polls for rayon work (parking after [`SPIN`] without any) instead of
/// going to sleep in rayon between the frame's parallel steps.
pub(crate) fn with_warm_pool<T: Send>(f: impl FnOnce() -> T + Send) -> T {
    let n = rayon::current_num_threads();
    if n < 2 {
        return f();
    }
    let done = AtomicBool::new(false);
    let frame = rayon::current_thread_index();
    rayon::scope(|s| {
        for _ in 1..n {
            s.spawn(|_| {
                // A poller taken up by the frame's own thread (waiting in
                // a step while no other worker had started it) would poll
                // until the frame ends, which it never would: it leaves.
                if rayon::current_thread_index() == frame {
                    return;
                }
                let mut last = Instant::now();
                while !done.load(Ordering::Acquire) {
                    if rayon::yield_now() == Some(rayon::Yield::Executed) {
                        last = Instant::now();
                    } else if last.elapsed() < SPIN {
                        std::thread::yield_now();
                    } else {
                        PARKING.park(&done);
                        last = Instant::now();
                    }
                }
            });
        }
        let out = f();
        done.store(true, Ordering::Release);
        PARKING.wake_all();
        out
    })
}

/// `f(k, &mut items[k])` for every item, on the pool's threads when it
/// has several, the results in item order. The calling thread takes the
/// items from the last (the pool's other workers steal from the first),
/// and waits for the others' last item by polling, not asleep. Items
/// share nothing, so the order they run in cannot change a result.
pub(crate) fn each_mut<T: Send, R: Send>(
    items: &mut [T],
    f: impl Fn(usize, &mut T) -> R + Sync,
) -> Vec<R> {
    if rayon::current_num_threads() < 2 || items.len() < 2 {
        return items.iter_mut().enumerate().map(|(k, t)| f(k, t)).collect();
    }
    let mut out: Vec<Option<R>> = std::iter::repeat_with(|| None).take(items.len()).collect();
    let left = AtomicUsize::new(items.len());
    rayon::in_place_scope(|s| {
        for (k, (item, slot)) in items.iter_mut().zip(out.iter_mut()).enumerate() {
            let (f, left) = (&f, &left);
            s.spawn(move |_| {
                // Counted done even if `f` panics (the scope then passes
                // the panic on), so the wait below always ends.
                let _done = Done(left);
                *slot = Some(f(k, item));
            });
        }
        PARKING.wake_all();
        while left.load(Ordering::Acquire) > 0 {
            if rayon::yield_now() != Some(rayon::Yield::Executed) {
                std::hint::spin_loop();
            }
        }
    });
    out.into_iter()
        .map(|r| r.expect("every item ran before the scope ended"))
        .collect()
}

/// Counts an item done when dropped.
struct Done<'a>(&'a AtomicUsize);

impl Drop for Done<'_> {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::Release);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rayon pool of `threads` threads.
    fn pool(threads: usize) -> rayon::ThreadPool {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
    }

    /// Every item runs once, at its own index, and the results come back
    /// in item order, on one thread and on several (inside a warm frame
    /// and nested in another step, as the sampling's column jobs are).
    #[test]
    fn each_mut_runs_every_item_once_in_order() {
        for threads in [1, 2, 3] {
            let pool = pool(threads);
            let got = pool.install(|| {
                with_warm_pool(|| {
                    let mut outer: Vec<Vec<u64>> = (0..7)
                        .map(|i| (0..i * 5).map(|v| v as u64).collect())
                        .collect();
                    each_mut(&mut outer, |k, v| {
                        let inner = each_mut(v, |j, x| {
                            *x += 1;
                            (k * 100 + j) as u64 + *x
                        });
                        inner.iter().sum::<u64>()
                    })
                })
            });
            let want: Vec<u64> = (0..7u64)
                .map(|k| (0..k * 5).map(|j| k * 100 + j + j + 1).sum())
                .collect();
            assert_eq!(got, want, "{threads} threads");
        }
    }

    /// Steps after serial stretches longer than [`SPIN`] (the pollers
    /// parked) still run every item once and in order, and the frame
    /// ends: posting the items wakes the parked pollers, and the frame's
    /// end wakes them to leave.
    #[test]
    fn steps_after_the_pollers_park_run_and_the_frame_ends() {
        for threads in [2, 3] {
            let pool = pool(threads);
            let got = pool.install(|| {
                with_warm_pool(|| {
                    let mut sums = Vec::new();
                    for step in 0..4u64 {
                        std::thread::sleep(SPIN * 5);
                        let mut items: Vec<u64> = (0..9).collect();
                        let out = each_mut(&mut items, |k, x| {
                            *x += step;
                            *x * 10 + k as u64
                        });
                        sums.push(out.iter().sum::<u64>());
                    }
                    sums
                })
            });
            let want: Vec<u64> = (0..4u64)
                .map(|step| (0..9u64).map(|k| (k + step) * 10 + k).sum())
                .collect();
            assert_eq!(got, want, "{threads} threads");
        }
    }

    /// An item that panics makes the step panic once every item is done,
    /// rather than leaving the caller waiting for it.
    #[test]
    fn a_panicking_item_ends_the_step() {
        let pool = pool(2);
        let ran = AtomicUsize::new(0);
        let out = pool.install(|| {
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                let mut items = vec![0u32; 16];
                each_mut(&mut items, |k, _| {
                    ran.fetch_add(1, Ordering::Relaxed);
                    assert_ne!(k, 5, "item 5 fails");
                })
            }))
        });
        assert!(out.is_err());
        assert_eq!(ran.load(Ordering::Relaxed), 16);
    }
}
