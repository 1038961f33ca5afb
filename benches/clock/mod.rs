//! The clock the benches time with, shared by `step.rs` and `attraction.rs` (included with
//! `#[path]`; a folder, so cargo does not take it for a bench of its own).

use std::time::{Duration, Instant};

use cpu_time::ThreadTime;

/// What a bench measures with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Clock {
    /// Wall-clock time (`Instant`), criterion's usual measure: what a user waits. The default.
    Wall,
    /// CPU time of the benchmarking thread (`CLOCK_THREAD_CPUTIME_ID`): excludes the time the
    /// thread is descheduled while other programs hold the cores, though not their effect on the
    /// caches and memory bandwidth (nor, in a VM, on the host's cores), so on a loaded machine it
    /// is still an upper bound. For a single-threaded engine the two clocks agree on an idle
    /// machine; for the `scale` benches on 2 threads it counts only the calling thread's share,
    /// so use the wall clock there.
    ThreadCpu,
}

impl Clock {
    /// `BALLFIELD_BENCH_CLOCK=thread-cpu` selects [`Clock::ThreadCpu`]; unset or `wall` selects
    /// [`Clock::Wall`].
    pub fn from_env() -> Clock {
        match std::env::var("BALLFIELD_BENCH_CLOCK").as_deref() {
            Err(_) | Ok("wall") => Clock::Wall,
            Ok("thread-cpu") => Clock::ThreadCpu,
            Ok(other) => panic!("BALLFIELD_BENCH_CLOCK={other}: expected `wall` or `thread-cpu`"),
        }
    }
}

impl Clock {
    /// How long `f` takes on this clock.
    pub fn time(self, f: impl FnOnce()) -> Duration {
        match self {
            Clock::Wall => {
                let start = Instant::now();
                f();
                start.elapsed()
            }
            Clock::ThreadCpu => {
                let start = ThreadTime::now();
                f();
                start.elapsed()
            }
        }
    }
}
