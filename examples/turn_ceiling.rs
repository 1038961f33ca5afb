//! The most updates a second this machine lets a thread-per-ball runtime give each ball: N
//! threads scheduled as the ball threads are (`SCHED_IDLE`), each doing nothing but yield the
//! core (`sched_yield`, as a crowded ball thread waits for its turn) and count its turns, for a
//! few seconds. A ball's update is one such turn plus its work, so the slowest and median thread
//! here bound the threaded runtime's `ball_rate_min` and `ball_rate_median` at the same number
//! of balls, in the same sitting: the context switch, not the ball's own arithmetic, is what a
//! thousand threads on two cores spend most of their time in (`perf` on a 1,024-ball gas: about
//! three quarters of the CPU in the scheduler). Like the ball threads, each thread first puts
//! its AVX-512 registers back in their initial state (`ballfield::runtime::WideRegisters`), so
//! that its switches do not save them; `--keep-avx512` leaves them in use, to show the
//! difference.
//!
//! ```sh
//! cargo run --release --example turn_ceiling -- --threads 1024 --seconds 5
//! ```

use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use ballfield::runtime::WideRegisters;
use clap::Parser;

#[derive(Parser, Debug)]
#[command(about = "Turns a second per thread for N SCHED_IDLE threads that only yield")]
struct Args {
    /// Threads (the balls).
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    threads: u32,
    /// How long to count, s.
    #[arg(long, default_value_t = 5.0)]
    seconds: f64,
    /// Leave the threads' AVX-512 registers in use, as they start (copied from the main thread,
    /// which glibc's string functions dirty), instead of clearing them as the ball threads do:
    /// what that costs each switch.
    #[arg(long)]
    keep_avx512: bool,
}

fn idle_scheduling() {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: sched_setscheduler with pid 0 acts on the calling thread; `param` is a valid,
        // initialised sched_param that outlives the call.
        let param = libc::sched_param { sched_priority: 0 };
        unsafe { libc::sched_setscheduler(0, libc::SCHED_IDLE, &param) };
    }
}

fn main() -> ExitCode {
    let args = Args::parse();
    if !(args.seconds.is_finite() && args.seconds > 0.0 && args.seconds <= 3600.0) {
        eprintln!("turn_ceiling: --seconds {} is not a duration in (0, 3600] s", args.seconds);
        return ExitCode::FAILURE;
    }
    let n = args.threads as usize;
    // Relaxed: the flags carry no data; each thread's count is read after its join. Threads
    // count only between `go` and `stop`, so that the ones started first do not count the rest's
    // start.
    let go = Arc::new(AtomicBool::new(false));
    let stop = Arc::new(AtomicBool::new(false));
    let turns: Arc<Vec<AtomicU64>> = Arc::new((0..n).map(|_| AtomicU64::new(0)).collect());
    let mut threads = Vec::with_capacity(n);
    let keep_avx512 = args.keep_avx512;
    for i in 0..n {
        let (thread_go, thread_stop, thread_turns) = (go.clone(), stop.clone(), turns.clone());
        let spawned = std::thread::Builder::new().stack_size(64 << 10).spawn(move || {
            idle_scheduling();
            if !keep_avx512 {
                WideRegisters::detect().release();
            }
            while !thread_go.load(Ordering::Relaxed) && !thread_stop.load(Ordering::Relaxed) {
                std::thread::yield_now();
            }
            let mut k = 0u64;
            while !thread_stop.load(Ordering::Relaxed) {
                std::thread::yield_now();
                k += 1;
            }
            thread_turns[i].store(k, Ordering::Relaxed);
        });
        match spawned {
            Ok(t) => threads.push(t),
            Err(e) => {
                eprintln!("turn_ceiling: could not start thread {i} of {n}: {e}");
                stop.store(true, Ordering::Relaxed);
                break;
            }
        }
    }
    go.store(true, Ordering::Relaxed);
    let started = Instant::now();
    std::thread::sleep(Duration::from_secs_f64(args.seconds));
    stop.store(true, Ordering::Relaxed);
    let elapsed = started.elapsed().as_secs_f64();
    let joined = threads.len();
    for t in threads {
        let _ = t.join();
    }
    if joined < n {
        return ExitCode::FAILURE;
    }
    // The join made every count visible (Relaxed loads suffice after it).
    let mut rates: Vec<f64> = turns.iter().map(|t| t.load(Ordering::Relaxed) as f64 / elapsed).collect();
    rates.sort_by(f64::total_cmp);
    let total: f64 = rates.iter().sum();
    println!(
        "{n} SCHED_IDLE threads that only yield{}, {elapsed:.1} s: turns a second per thread slowest {:.0}, median {:.0}; \
         {:.0} switches a second in all ({:.2} µs each on {} cores)",
        if keep_avx512 { " (AVX-512 registers kept in use)" } else { "" },
        rates[0],
        rates[n / 2],
        total,
        std::thread::available_parallelism().map_or(1, |p| p.get()) as f64 / total * 1e6,
        std::thread::available_parallelism().map_or(1, |p| p.get()),
    );
    ExitCode::SUCCESS
}
