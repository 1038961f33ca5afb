//! The run report: what ran, how long it took, and the state at the start and the end.

use serde::Serialize;

use crate::engine::{ExactStats, RuntimeStats, StepCounters};
use crate::physics::Diagnostics;

/// The report of one headless run, written as JSON by `--report` and summarised on the terminal.
#[derive(Clone, Debug, Serialize)]
pub struct RunReport {
    /// The scene's `name`.
    pub scene: String,
    /// The scene's file, or the built-in name it was chosen by.
    pub scene_file: String,
    /// The engine that ran it (`threaded` or `lockstep`).
    pub engine: String,
    /// The integrator's kebab-case name.
    pub integrator: String,
    /// Time step, s: lockstep's `dt`, or the threaded engine's nominal ball cycle.
    pub dt: f64,
    /// Steps of `dt` taken (lockstep); 0 for the threaded engine, whose balls each take their own.
    pub steps: u64,
    /// Simulated seconds.
    pub simulated_seconds: f64,
    /// Wall-clock seconds spent stepping (diagnostics and I/O excluded).
    pub wall_seconds: f64,
    /// Steps per wall-clock second of stepping (lockstep), or the median ball's cycles per second
    /// (threaded).
    pub steps_per_second: f64,
    /// Balls on the field at the end.
    pub balls: usize,
    /// The effects that ran, in order; walls always run.
    pub active_effects: Vec<String>,
    /// Energies, momentum, overlap and wall impulses of the scene as it starts.
    pub start: Diagnostics,
    /// The same at the end of the run.
    pub end: Diagnostics,
    /// Time per phase, summed over the run (lockstep).
    pub phases: Option<StepCounters>,
    /// FNV-1a of the final state's bits (lockstep), as 16 hex digits.
    pub state_hash: Option<String>,
    /// Threads the lockstep engine shared its phases over.
    pub threads: Option<usize>,
    /// Memory the engine took (headless runs on Linux).
    pub memory: Option<MemoryUse>,
    /// The threaded runtime's own figures.
    pub runtime: Option<ThreadedFigures>,
    /// The exact engine's own figures: collisions, events per second, invalidated events.
    pub exact: Option<ExactStats>,
}

/// Resident memory the engine took: the process's peak resident set (`VmHWM` of
/// `/proc/self/status`) during the run, less its resident set just before the engine was built,
/// per ball. Includes everything the engine allocated (state, grid, scratch, pools; for the
/// threaded runtime the ball threads' stacks and channels).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct MemoryUse {
    /// Resident set just before the engine was built, bytes.
    pub rss_before_bytes: u64,
    /// Peak resident set of the process up to the end of the run, bytes.
    pub rss_peak_bytes: u64,
    /// `(peak − before) / balls`, bytes.
    pub bytes_per_ball: f64,
}

impl MemoryUse {
    /// The resident set now, bytes (None where `/proc/self/status` is not there).
    pub fn now() -> Option<u64> {
        status_kib("VmRSS:").map(|k| k * 1024)
    }

    /// The peak since the process started, against `before`, shared over `balls`.
    pub fn since(before: Option<u64>, balls: usize) -> Option<MemoryUse> {
        let (before, peak) = (before?, status_kib("VmHWM:")? * 1024);
        Some(MemoryUse {
            rss_before_bytes: before,
            rss_peak_bytes: peak,
            bytes_per_ball: peak.saturating_sub(before) as f64 / balls.max(1) as f64,
        })
    }
}

/// A `kB` line of `/proc/self/status`.
fn status_kib(key: &str) -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = text.lines().find(|l| l.starts_with(key))?;
    line[key.len()..].trim().trim_end_matches("kB").trim().parse().ok()
}

/// What the threaded runtime measured about itself during a run.
#[derive(Clone, Debug, Serialize)]
pub struct ThreadedFigures {
    /// The runtime's counters (cycles, messages, monitor passes, guard rails), flattened into
    /// this object in the JSON.
    #[serde(flatten)]
    pub stats: RuntimeStats,
    /// CPU time the whole process used while the engine advanced (see `Stepping`), s.
    pub cpu_seconds: f64,
    /// `cpu_seconds` divided by the wall-clock seconds of stepping (the same stretches): cores
    /// busy on average.
    pub cpu_cores_used: f64,
    /// Wall-clock time the shutdown took to stop and join every thread, s.
    pub shutdown_seconds: f64,
    /// Threads the shutdown joined.
    pub threads_joined: usize,
}

impl RunReport {
    /// A one-screen summary for people.
    pub fn summary(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        self.write_run(&mut s);
        self.write_state(&mut s);
        self.write_engine(&mut s);
        if let Some(h) = &self.state_hash {
            let _ = writeln!(s, "state hash   {h}");
        }
        s
    }

    /// The summary's lines on what ran: scene, engine, effects, balls, time, threads, memory.
    fn write_run(&self, s: &mut String) {
        use std::fmt::Write;
        let _ = writeln!(s, "scene        {} ({})", self.scene, self.scene_file);
        let _ = writeln!(s, "engine       {}, integrator {}, dt {} s", self.engine, self.integrator, self.dt);
        let _ = writeln!(
            s,
            "effects      {}",
            if self.active_effects.is_empty() { "none (vacuum)".into() } else { self.active_effects.join(", ") }
        );
        let _ = writeln!(s, "balls        {}", self.balls);
        // The exact engine takes no steps: its unit of work is the event.
        let unit = if self.exact.is_some() { "events" } else { "steps" };
        let _ = writeln!(
            s,
            "ran          {} {unit} = {:.3} s simulated in {:.3} s wall ({:.0} {unit}/s)",
            self.steps, self.simulated_seconds, self.wall_seconds, self.steps_per_second
        );
        if let Some(threads) = self.threads {
            let _ = writeln!(s, "threads      {threads} (lockstep; the same bits for any number)");
        }
        if let Some(m) = &self.memory {
            let _ = writeln!(
                s,
                "memory       {:.0} bytes per ball (peak resident {:.1} MiB, {:.1} MiB before the engine)",
                m.bytes_per_ball,
                m.rss_peak_bytes as f64 / 1048576.0,
                m.rss_before_bytes as f64 / 1048576.0
            );
        }
    }

    /// The summary's lines on the state: energies, momentum, walls, overlap.
    fn write_state(&self, s: &mut String) {
        use std::fmt::Write;
        let _ = writeln!(s, "                   {:>16} {:>16} {:>16}", "kinetic J", "potential J", "total J");
        for (label, d) in [("start", &self.start), ("end", &self.end)] {
            let _ = writeln!(s, "energy {label:<11} {:>16.6e} {:>16.6e} {:>16.6e}", d.kinetic, d.potential, d.total);
        }
        let _ = writeln!(
            s,
            "momentum     start [{:.6e}, {:.6e}]  end [{:.6e}, {:.6e}] kg·m/s",
            self.start.momentum[0], self.start.momentum[1], self.end.momentum[0], self.end.momentum[1]
        );
        let w = &self.end.wall_impulses;
        let _ = writeln!(
            s,
            "walls        impulse N·s: left {:.4e}, right {:.4e}, bottom {:.4e}, top {:.4e}",
            w.left, w.right, w.bottom, w.top
        );
        let _ = writeln!(
            s,
            "overlap      largest {:.3e} m ({:.3}% of a diameter); {} outside, {} non-finite",
            self.end.largest_overlap,
            100.0 * self.end.largest_overlap_ratio,
            self.end.outside,
            self.end.non_finite
        );
    }

    /// The summary's lines of the engine's own figures: lockstep's phases, the threaded
    /// runtime's rates and messages, the exact engine's events and calendar.
    fn write_engine(&self, s: &mut String) {
        use std::fmt::Write;
        if let Some(p) = &self.phases {
            let total = p.total().as_secs_f64().max(1e-12);
            let pct = |d: std::time::Duration| 100.0 * d.as_secs_f64() / total;
            let _ = writeln!(
                s,
                "phases       integrate {:.0}%, broad phase {:.0}%, contacts {:.0}%, walls {:.0}%",
                pct(p.integrate),
                pct(p.broad_phase),
                pct(p.contacts),
                pct(p.walls)
            );
        }
        if let Some(t) = &self.runtime {
            let st = &t.stats;
            let _ = writeln!(
                s,
                "threads      {} balls: update rate min {:.0}/s, median {:.0}/s; monitor {:.0} passes/s ({:.0} µs each)",
                st.balls,
                st.ball_rate_min,
                st.ball_rate_median,
                st.monitor_passes_per_second,
                st.monitor_pass_seconds * 1e6
            );
            let _ = writeln!(
                s,
                "messages     {} impulses sent ({} by channel, the ring full), {} applied, {} dropped; {} threads panicked",
                st.impulses_sent,
                st.responses_by_channel,
                st.impulses_applied,
                st.messages_dropped,
                st.threads_panicked
            );
            if st.balls_slept > 0 {
                let _ = writeln!(
                    s,
                    "sleep        {} balls asleep at the end; {} times put to sleep, {} woken",
                    st.balls_asleep, st.balls_slept, st.balls_woken
                );
            }
            if st.speed_limited + st.drag_limited > 0 {
                let _ = writeln!(
                    s,
                    "guard rails  {} speeds capped at 1e5 m/s, {} cycles with drag capped (the field outran its sub-steps)",
                    st.speed_limited, st.drag_limited
                );
            }
            if st.attraction_tree_cycles + st.attraction_direct_cycles > 0 || st.tree_builds > 0 {
                let _ = writeln!(
                    s,
                    "attraction   {} ball cycles from the tree, {} direct; {} trees built ({:.0}/s, {:.0} µs each, {} skipped, {} in the pool)",
                    st.attraction_tree_cycles,
                    st.attraction_direct_cycles,
                    st.tree_builds,
                    st.tree_builds_per_second,
                    st.tree_build_seconds * 1e6,
                    st.tree_builds_skipped,
                    st.tree_snapshots
                );
            }
            let _ = writeln!(
                s,
                "cost         {:.2} CPU s in {:.2} s ({:.2} cores); shutdown joined {} threads in {:.3} s",
                t.cpu_seconds, self.wall_seconds, t.cpu_cores_used, t.threads_joined, t.shutdown_seconds
            );
        }
        if let Some(x) = &self.exact {
            let c = &x.counters;
            let _ = writeln!(
                s,
                "events       {} ({} collisions, {} wall bounces, {} cell crossings): {:.0} events/s, {:.0} collisions/s",
                x.events, c.collisions, c.wall_bounces, c.cell_crossings, x.events_per_second, x.collisions_per_second
            );
            let _ = writeln!(
                s,
                "calendar     {} predictions; invalidated {} superseded, {} by a partner's change; peak {} events",
                c.predictions, x.invalidated_superseded, x.invalidated_partner, x.calendar_peak
            );
            if c.soft_collisions + c.rests + c.slides + c.hops > 0 {
                let _ = writeln!(
                    s,
                    "rest model   {} soft collisions (collapse model), {} rests, {} slides, {} wakes, {} hops; {} at rest, {} sliding now",
                    c.soft_collisions, c.rests, c.slides, c.wakes, c.hops, x.at_rest, x.sliding
                );
            }
        }
    }
}
