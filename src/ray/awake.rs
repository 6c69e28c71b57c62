//! Workers kept awake through a run of short parallel phases.
//!
//! The octree build is a few dozen parallel phases of a millisecond or less,
//! with serial steps between them. A rayon worker that finds no job sleeps
//! within microseconds, and on a virtual machine whose idle cores halt, waking
//! one again took from 0.1 to over a millisecond (measured on a two-core VM):
//! each phase then ran on one thread for much of its length. Here the pool's
//! other workers poll for jobs instead while the build runs, and for a moment
//! after it, for the work that follows (the render).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How long a worker keeps polling, once the work is done, for the work
/// that follows it.
const LINGER: Duration = Duration::from_millis(1);

/// The longest a worker polls without finding a job, done or not: it may
/// have been handed its poll while it waited inside another job, which
/// cannot resume until the poll ends.
const MAX_IDLE: Duration = Duration::from_millis(4);

/// Runs `work` on the calling thread while the other workers of its rayon
/// pool poll for jobs rather than sleep. Outside a pool, or in a pool of one
/// thread, `work` simply runs.
pub(crate) fn with_workers_awake<R>(work: impl FnOnce() -> R) -> R {
    let Some(me) = rayon::current_thread_index() else {
        return work();
    };
    if rayon::current_num_threads() < 2 {
        return work();
    }
    let done = Arc::new(AtomicBool::new(false));
    let polled = done.clone();
    rayon::spawn_broadcast(move |context| {
        if context.index() != me {
            poll(&polled);
        }
    });
    let result = work();
    done.store(true, Ordering::Release);
    result
}

/// Runs the pool's jobs as they come until `done` has been set for
/// [`LINGER`] (or none came for [`MAX_IDLE`]).
fn poll(done: &AtomicBool) {
    let mut last_job = Instant::now();
    loop {
        if rayon::yield_now() == Some(rayon::Yield::Executed) {
            last_job = Instant::now();
            continue;
        }
        let idle = last_job.elapsed();
        if idle > MAX_IDLE || (idle > LINGER && done.load(Ordering::Acquire)) {
            return;
        }
        std::hint::spin_loop();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    fn sum_of_squares(n: u64) -> u64 {
        (0..n).into_par_iter().map(|i| i * i).sum()
    }

    /// The work's own answer, in pools of any size and outside one, and
    /// with builds side by side and one inside another: a worker handed its
    /// poll while inside another job gives it back (no deadlock).
    #[test]
    fn work_runs_to_its_answer_beside_and_inside_other_work() {
        let want: u64 = (0..10_000u64).map(|i| i * i).sum();
        assert_eq!(with_workers_awake(|| sum_of_squares(10_000)), want);
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let answers = pool.install(|| {
                (0..8)
                    .into_par_iter()
                    .map(|_| {
                        let (a, b) = rayon::join(
                            || with_workers_awake(|| sum_of_squares(10_000)),
                            || with_workers_awake(|| with_workers_awake(|| sum_of_squares(10_000))),
                        );
                        a + b
                    })
                    .collect::<Vec<u64>>()
            });
            assert_eq!(answers, vec![2 * want; 8], "{threads} threads");
        }
    }
}
