//! What the runtime's threads share: the table, the parameters, the flags and the counters.

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use parking_lot::RwLock;

use super::attraction_tree::PublishedTree;
use super::message::Grid;
use super::table::BallTable;
use crate::physics::{Effects, Field, Integrator, WallImpulses};

/// How the threaded runtime runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RuntimeConfig {
    /// Period a ball thread aims for between updates (the original design: about 1 ms).
    pub ball_cycle: Duration,
    /// Longest single integration step, s; a longer measured dt is split into sub-steps.
    pub max_step: f64,
    /// Period the collision monitor aims for between passes.
    pub monitor_period: Duration,
    /// Most balls at once (the original design: 1,024).
    pub max_balls: usize,
    /// Ball threads yield their core instead of sleeping while the cores are crowded (see
    /// `ball_thread::Waiter`). Off: they always sleep to the cycle grid (kept for comparison;
    /// `BALLFIELD_BALL_WAIT=sleep` turns it off for headless runs).
    pub yield_when_crowded: bool,
    /// Whether islands at rest may sleep (see `runtime/sleep.rs`); off, the monitor solves
    /// every resting contact every pass (tests of the messages' paths use it).
    pub sleep: bool,
}

impl Default for RuntimeConfig {
    fn default() -> Self {
        RuntimeConfig {
            ball_cycle: Duration::from_millis(1),
            max_step: 0.002,
            monitor_period: Duration::from_millis(1),
            max_balls: 1024,
            yield_when_crowded: true,
            sleep: true,
        }
    }
}

/// Parameters every ball thread follows; changed rarely (panel, hotkeys), read once per change.
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    /// The field: its size and the walls' restitution.
    pub field: Field,
    /// The effects that are on.
    pub effects: Effects,
    /// The integrator every ball thread uses.
    pub integrator: Integrator,
    /// Simulated seconds per wall-clock second (1 = real time, < 1 = slow motion).
    pub time_scale: f64,
}

pub(crate) struct Shared {
    pub config: RuntimeConfig,
    /// The instant the runtime started: ball cycles are aligned to it.
    pub epoch: Instant,
    pub table: BallTable,
    pub params: RwLock<Params>,
    /// Bumped (Release) after every change of `params`; ball threads poll it (Acquire) once per
    /// cycle and take the read lock only when it moved — the hot path never locks.
    pub params_generation: AtomicU64,
    pub paused: AtomicBool,
    /// The runtime's clock (see [`Shared::clock`]): wall time since `epoch` less this, ns. It is
    /// raised by the time nobody simulated: once by the runtime as it starts, by the time the
    /// ball threads took to spawn (before the monitor runs), then only by the monitor, while
    /// paused, and when it woke too late to have watched the contacts meanwhile (a stalled
    /// process). Store Release, load
    /// Acquire: a ball that reads a horizon (Acquire, below) then this offset sees at least the
    /// offset the monitor stored before that horizon, so it never sees a horizon of the new
    /// clock with the old offset.
    pub clock_offset: AtomicU64,
    /// The instant (runtime clock, ns) up to which the monitor has judged every contact: no ball
    /// integrates past it (see `ball_thread::run_ball`). Stored with Release after the pass has
    /// sent its messages; a ball loads it with Acquire before it empties its inbox, so every
    /// message of that pass is in the inbox by then.
    pub horizon: AtomicU64,
    /// Wall impulses of the contacts the monitor solved (walls are contacts in its solver), as
    /// f64 bits, left, right, bottom, top. The monitor is the only writer (Relaxed: a gauge read
    /// only for reports, each word whole).
    pub monitor_walls: [AtomicU64; 4],
    /// Wall time the monitor's clock dropped (ns): paused time is not counted here, only passes
    /// that came too late to be watched (see `monitor::MAX_ADVANCE`). Relaxed: a statistic.
    pub clock_dropped_ns: AtomicU64,
    /// Ball cycles that stopped short of the time they woke at because the monitor's horizon was
    /// behind it (the monitor was late or the process stalled). Relaxed: a statistic.
    pub horizon_waits: AtomicU64,
    /// `RuntimeStats::judged_drift_max` as f64 bits (the monitor is its only writer; Relaxed: a
    /// statistic).
    pub judged_drift_max: AtomicU64,
    /// Contact responses a ball applied after the instant they were for (it had integrated past
    /// it before the message came: only a ball placed ahead of the monitor's horizon can).
    /// Relaxed: a statistic.
    pub responses_late: AtomicU64,
    /// Balls asleep after the monitor's last pass, and balls it put to sleep and woke so far
    /// (see `physics::sleep`; the monitor is the only writer; Relaxed: statistics).
    pub balls_asleep: AtomicU64,
    pub balls_slept: AtomicU64,
    pub balls_woken: AtomicU64,
    /// Cleared to stop the monitor.
    pub monitor_running: AtomicBool,
    /// Every occupied slot is below this. Raised (Release) by the runtime after it has written
    /// the new slot's first record, so a reader that loads it (Acquire) sees that record.
    pub high_water: AtomicUsize,
    /// Ball threads that panicked.
    pub panicked: AtomicU64,
    // Monitor statistics. Relaxed everywhere: plain counters, read only for reports.
    pub monitor_passes: AtomicU64,
    /// Wall time the monitor spent inside its passes (not sleeping), ns.
    pub monitor_busy_ns: AtomicU64,
    /// The longest pass so far, ns (the monitor is its only writer).
    pub monitor_busy_max_ns: AtomicU64,
    /// The longest span the monitor judged in one contact solve, ns (see
    /// `Monitor::judge_span`; the monitor is the only writer; Relaxed: a statistic).
    pub monitor_span_max_ns: AtomicU64,
    pub contact_messages_sent: AtomicU64,
    /// Contacts (pairs and walls) the monitor's solver found touching, those that got an
    /// impact (restitution) impulse, and the solves that hit an iteration cap.
    pub contacts_solved: AtomicU64,
    pub contact_impacts: AtomicU64,
    pub solves_unconverged: AtomicU64,
    /// See `RuntimeStats::pairs_pushed_together` (Relaxed: statistics the monitor alone writes).
    pub pairs_pushed_together: AtomicU64,
    pub pairs_reached: AtomicU64,
    pub messages_dropped: AtomicU64,
    /// Contact responses the monitor sent by a ball's channel instead of its ring (Relaxed: a
    /// statistic, added once a pass).
    pub responses_by_channel: AtomicU64,
    /// The ball threads' guard rails (see `Lockstep`'s): speeds capped at `MAX_SPEED`, and cycles
    /// whose drag had its rate capped at 1/h. Relaxed: plain counters, touched only when a rail
    /// acts (0 in every sane field).
    pub speed_limited: AtomicU64,
    pub drag_limited: AtomicU64,
    /// The longest cycle any ball ran and the sub-steps it took, packed by `pack_cycle` so that
    /// one `fetch_max` keeps the pair together. Relaxed: a statistic; each ball touches it only
    /// when one of its own cycles is longer than all its earlier ones.
    pub longest_cycle: AtomicU64,
    /// The monitor's latest attraction tree, or none (see `attraction_tree.rs`: the monitor is
    /// its only writer, the ball threads read it lock-free once per cycle).
    pub attraction_tree: PublishedTree,
    // Attraction statistics. Relaxed everywhere: plain counters, read only for reports.
    /// Trees the monitor built and published, the wall time it spent on them (ns), the passes it
    /// built none because every pooled snapshot was still held, and the snapshots it allocated.
    pub tree_builds: AtomicU64,
    pub tree_build_ns: AtomicU64,
    pub tree_builds_skipped: AtomicU64,
    pub tree_snapshots: AtomicUsize,
    /// Ball cycles with attraction on that took the tree snapshot, and those that read the table
    /// directly. Each ball adds its own count every `COUNTER_FLUSH` cycles (and when it pauses or
    /// stops), not every cycle: a thousand threads adding to one shared word every cycle would
    /// bounce its cache line between the cores at every update.
    pub attraction_tree_cycles: AtomicU64,
    pub attraction_direct_cycles: AtomicU64,
}

/// Compile-time check: the runtime, the monitor and every ball thread hold `Shared` through one
/// `Arc` and read it at once (the parameters behind its lock included), so it and `Params` are
/// `Send` and `Sync`.
const _: () = {
    const fn shared<T: Send + Sync>() {}
    shared::<Shared>();
    shared::<Params>();
    shared::<RuntimeConfig>();
};

impl Shared {
    pub fn new(config: RuntimeConfig, params: Params) -> Self {
        Shared {
            config,
            epoch: Instant::now(),
            table: BallTable::new(config.max_balls),
            params: RwLock::new(params),
            params_generation: AtomicU64::new(0),
            paused: AtomicBool::new(false),
            clock_offset: AtomicU64::new(0),
            horizon: AtomicU64::new(0),
            monitor_walls: std::array::from_fn(|_| AtomicU64::new(0)),
            clock_dropped_ns: AtomicU64::new(0),
            horizon_waits: AtomicU64::new(0),
            judged_drift_max: AtomicU64::new(0),
            balls_asleep: AtomicU64::new(0),
            balls_slept: AtomicU64::new(0),
            balls_woken: AtomicU64::new(0),
            responses_late: AtomicU64::new(0),
            monitor_running: AtomicBool::new(true),
            high_water: AtomicUsize::new(0),
            panicked: AtomicU64::new(0),
            monitor_passes: AtomicU64::new(0),
            monitor_busy_ns: AtomicU64::new(0),
            monitor_busy_max_ns: AtomicU64::new(0),
            monitor_span_max_ns: AtomicU64::new(0),
            contact_messages_sent: AtomicU64::new(0),
            contacts_solved: AtomicU64::new(0),
            contact_impacts: AtomicU64::new(0),
            pairs_pushed_together: AtomicU64::new(0),
            pairs_reached: AtomicU64::new(0),
            solves_unconverged: AtomicU64::new(0),
            messages_dropped: AtomicU64::new(0),
            responses_by_channel: AtomicU64::new(0),
            speed_limited: AtomicU64::new(0),
            drag_limited: AtomicU64::new(0),
            longest_cycle: AtomicU64::new(0),
            attraction_tree: PublishedTree::empty(),
            tree_builds: AtomicU64::new(0),
            tree_build_ns: AtomicU64::new(0),
            tree_builds_skipped: AtomicU64::new(0),
            tree_snapshots: AtomicUsize::new(0),
            attraction_tree_cycles: AtomicU64::new(0),
            attraction_direct_cycles: AtomicU64::new(0),
        }
    }

    /// A cycle's length (ns, in the high 48 bits) and its sub-steps (the low 16 bits, enough for
    /// `MAX_SUBSTEPS`): packed values order by length first.
    pub fn pack_cycle(dt: f64, steps: u64) -> u64 {
        let ns = (dt * 1e9).clamp(0.0, ((1u64 << 48) - 1) as f64) as u64;
        (ns << 16) | steps.min(0xFFFF)
    }

    /// The grid of whole monitor periods through `reference` (see [`Grid`]): the one the ball
    /// threads and the monitor both cut their stretches at.
    pub fn grid(&self, reference: u64) -> Grid {
        Grid { reference, period: (self.config.monitor_period.as_nanos() as u64).max(1) }
    }

    /// The runtime clock at `t` (ns): wall time since the epoch, less the time the monitor
    /// dropped (see `clock_offset`). It may step back when the monitor drops time; every
    /// instant in the table, in a contact message and in `horizon` is on this clock.
    pub fn clock(&self, t: Instant) -> u64 {
        let wall = t.saturating_duration_since(self.epoch).as_nanos() as u64;
        wall.saturating_sub(self.clock_offset.load(Ordering::Acquire))
    }

    /// The impulse each wall took in the contacts the monitor solved.
    pub fn monitor_wall_impulses(&self) -> WallImpulses {
        let w = |k: usize| f64::from_bits(self.monitor_walls[k].load(Ordering::Relaxed));
        WallImpulses { left: w(0), right: w(1), bottom: w(2), top: w(3) }
    }

    pub fn update_params(&self, f: impl FnOnce(&mut Params)) {
        f(&mut self.params.write());
        // Release: a thread that sees the new generation with Acquire then reads the new params.
        self.params_generation.fetch_add(1, Ordering::Release);
    }
}
