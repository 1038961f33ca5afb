//! The collision-monitor thread. Each pass it reads the table, judges every contact of the coming
//! interval at once, and sends each touched ball one message with its net response. With
//! attraction on in a field of [`TREE_MIN_BALLS`] balls or more it also builds the field's
//! Barnes–Hut tree from the same read and publishes it to the ball threads
//! (`attraction_tree.rs`). It never writes a ball's state.
//!
//! **A pass.** The pass instant `t` is the runtime clock now (see `Shared::clock`). The pass
//! judges the span from where the last pass stopped to about `t + HORIZON`, in whole monitor
//! periods (see [`Monitor::span_end`]): consecutive passes judge consecutive spans, each once, as
//! lockstep's steps do, a horizon ahead of the balls. Why whole periods: the resting solve
//! starts from the last span's impulses taken as forces, and a pile's contacts share its weight
//! in many ways; with spans that followed the monitor's wake-ups (0.3 to 3.7 ms around a pause,
//! 0.5 to 1.5 ms on a busy machine) its passes stopped converging, and a settled pile kept moving
//! at a few mm/s (a pure replay of the solver over such spans: `tests/contact_spans.rs`). Every ball
//! is taken from its own record (each is of its own instant), with the contact messages it has
//! not applied yet added as it will apply them, and carried in free motion (its published uniform
//! acceleration: gravity, the pull) to the end of the span. The contact solver then solves every
//! contact of every ball over the span in one call — impacts swept from the span's start (a pair
//! that passed through each other in the free motion is found by its time of impact), resting
//! contacts, walls — and each ball with a response gets it as one [`Contact`] message stamped
//! with the span's end, to be applied at its first impact in the span (resting contacts alone:
//! at the span's end, where the solve found them). Last, the pass publishes the span's end as the horizon: no ball integrates past
//! it before the next pass has judged further, so every response reaches its ball before the
//! ball reaches the instant it is for.
//!
//! **The grid.** Every span starts and ends on the instants of whole periods from the first
//! (`Grid`), and every ball's thread cuts its own integration there too (and at the instants of
//! its responses), as [`Motion`] does when it carries a ball: the monitor's prediction of a ball
//! is then the ball's own arithmetic, under any integrator. Cut where each ball woke instead,
//! semi-implicit Euler's flight strayed from the parabola by `½·g·Σh²` over each ball's own steps,
//! two balls in flight did not move in a straight line relative to each other, and an oblique
//! collision under gravity came out up to 6.6e-4 of the closing speed off.
//!
//! Why consecutive spans, not overlapping ones: a response in flight makes a ball's predicted
//! path the one after its impact, and that path rewound to before the impact is not where the
//! ball was (two balls that bounced would seem to have come through each other). The solver
//! rewinds only within its span, and every impact of earlier spans lies before this one's start.
//!
//! **No double impulse.** A message the ball has not applied yet is part of the state the next
//! pass solves from (the ball's `applied` count in the table says which are), so a contact whose
//! impulse is in flight is seen as already separating and is not struck again; no ball is left
//! out of a pass because a message to it is in flight.
//!
//! **Late passes.** A pass that comes late (the machine starved the monitor) judges the periods
//! it missed one solve each, as the passes that did not happen would have, while the solves are
//! cheap (their median under half a period); a scene whose solves take more judges them in one
//! (see [`Monitor::judge_span`]). A pass that comes more than [`MAX_ADVANCE`] periods after the last
//! (the process stalled) would have that much to catch up; nobody integrated that time (the
//! horizon held every ball), so the clock drops it, as a pause does, and the span is one period.

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Instant;

use crossbeam_channel::Sender;
use glam::DVec2;
use parking_lot::RwLock;

use super::attraction_tree::TreePublisher;
use super::ball_thread::hold_inside;
use super::contact_ring::{ContactRing, RingWriter};
use super::message::{Contact, Grid, Message, Rest, clock_seconds};
use super::sent_queue::SentQueue;
use super::shared::{Params, Shared};
use super::sleep::{SleepBook, WarmStart};
use super::table::BallRecord;
use crate::physics::{
    Attraction, AttractionMethod, Ball, BallProps, BallResponse, BroadPhase, ContactParams, ContactSolver, Drag,
    DragRateBound, Effects, Field, Forces, Integrator, IntegratorScratch, Islands, NoOtherBalls, SolverBall, SpanRates,
    StepPolicy, TIME_TO_SLEEP, TREE_MIN_BALLS, WallImpulses, WarmKey, advance_ball, held_wall_forces, is_quiet,
    resting_drift, swept_circle,
};

/// The ball inboxes by slot. Written (write lock) by the runtime when a ball is added or removed;
/// read (read lock) by the monitor from its read of the table to the horizon it publishes, so
/// that once a removal has cleared a slot no message can be sent to the departing ball, and a
/// ball added is judged from the instant it begins at (see `Runtime::insert`).
pub(crate) type Inboxes = Arc<RwLock<Vec<Option<Inbox>>>>;

/// One ball's inbox as the monitor and the runtime hold it: the channel for commands (and for a
/// response that finds the ring full), and the ring for contact responses.
#[derive(Clone)]
pub(crate) struct Inbox {
    pub commands: Sender<Message>,
    pub contacts: Arc<ContactRing>,
    /// Which start of a ball this is (the runtime numbers them): a ball put back with its own id
    /// is a new start, with a new ring and its `applied` count from zero.
    pub incarnation: u64,
}

/// Compile-time check: the inboxes are written by the runtime and read by the monitor's thread
/// behind one `Arc<RwLock>`, so an inbox is `Send` and `Sync`.
const _: () = {
    const fn shared<T: Send + Sync>() {}
    shared::<Inbox>();
    shared::<Inboxes>();
};

/// How far ahead of its instant a pass judges the contacts, in monitor periods: the next pass
/// comes one period later and takes a fraction of one, and the balls must not reach the horizon
/// before it has published the next (they would wait). Four periods leave two and a half for
/// a late wake-up of the monitor.
pub(crate) const HORIZON_PERIODS: u32 = 4;

/// Passes more than this many periods apart drop the time beyond one period (see the module
/// comment). A pass that is late by less judges the periods it missed, one solve each while
/// the solves are cheap (see `Monitor::judge_span`), else in one solve, as a lockstep step that
/// long would: a binary impact is exact at any span, and under gravity a resting ball sinks
/// `g·span²/2` into its support before the solver lifts it (2 mm at 20 ms). A monitor preempted
/// for a few milliseconds on a busy machine so costs no simulated time.
pub(crate) const MAX_ADVANCE: u32 = 20;

/// Pairs this close to touching (relative to the sum of their radii) are candidates too.
const TOUCH_MARGIN: f64 = 1e-6;

/// A response smaller than this (relative to the ball's radius, in velocity·span and shift) is
/// not worth a message: the ball is untouched.
const NEGLIGIBLE: f64 = 1e-15;

/// The monitor asks for this nice value, above every ordinary thread (the ball threads but the
/// key ball run `SCHED_IDLE`, below them all; see `ball_thread::background_scheduling`).
/// Lowering niceness needs privilege (root or CAP_SYS_NICE); without it the monitor stays at 0,
/// still ahead of the `SCHED_IDLE` balls.
const MONITOR_NICE: libc::c_int = -5;

fn raise_priority() {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: setpriority on PRIO_PROCESS with who = 0 changes only the calling thread's nice
        // value on Linux; it takes no pointers.
        let rc = unsafe { libc::setpriority(libc::PRIO_PROCESS, 0, MONITOR_NICE) };
        if rc != 0 {
            log::debug!("the monitor could not raise its priority: {}", std::io::Error::last_os_error());
        }
    }
}

/// While it runs, the monitor is the only writer of the clock's offset: it moves the clock back by `ns`.
fn drop_time(shared: &Shared, ns: u64) {
    // Relaxed load: this thread is the only writer. Release store: see `Shared::clock_offset`.
    let offset = shared.clock_offset.load(Ordering::Relaxed);
    shared.clock_offset.store(offset + ns, Ordering::Release);
}

/// Runs the collision monitor until the runtime clears `monitor_running`: one pass per period
/// (see the module comment), each a list of named steps ([`Monitor::pass`]).
///
/// The passes keep to a schedule of one a period. A pass that ends less than a period behind
/// it (a pass that took longer than a period, a late wake-up) is followed at once by the next,
/// and the schedule holds: a pile's passes take 0.6 to 0.8 ms on average but now and then
/// 1.5 ms or more (an unconverged solve, the monitor preempted), and restarting the schedule
/// after each such pass lost 3 to 5 % of the passes on the awake 1,024-ball pile. Further behind
/// (the passes take longer than a period on average, the process stalled), the schedule starts
/// afresh from the pass's end: the monitor does not rush a burst of passes, each of which would
/// judge little (see [`Monitor::span_end`]).
pub(crate) fn run_monitor(shared: Arc<Shared>, inboxes: Inboxes) {
    raise_priority();
    let period = shared.config.monitor_period;
    let mut monitor = Monitor::new(&shared, inboxes);
    let mut next = Instant::now();
    // Acquire/Release on the flag: the runtime clears it and then joins; nothing else rides on it.
    while shared.monitor_running.load(Ordering::Acquire) {
        let pass_start = Instant::now();
        monitor.pass(pass_start);
        monitor.count_pass(pass_start);
        next += period;
        let now = Instant::now();
        if next > now {
            std::thread::sleep(next - now);
        } else if now - next >= period {
            next = now;
        }
    }
}

/// The monitor thread's state between passes.
struct Monitor<'a> {
    shared: &'a Shared,
    inboxes: Inboxes,
    /// The period, the horizon and the longest advance a pass may make, ns.
    period_ns: u64,
    horizon_ns: u64,
    max_advance_ns: u64,
    /// The table as this pass read it.
    records: Vec<BallRecord>,
    contacts: ContactPass,
    trees: TreePublisher,
    /// The parameters and the generation they were read at (see [`Monitor::refresh_params`]).
    generation: u64,
    params: Params,
    /// The force passes balls are carried by, from `params` (see [`free_motion`]).
    free_motion: Forces,
    /// The last pass's instant (runtime clock, ns).
    t_pass: u64,
    /// Where the judged time ends (runtime clock, ns): the next pass judges from here.
    judged: u64,
    /// The longest pass so far, ns.
    busy_max_ns: u64,
    /// The wall time of the last [`SOLVE_TIMES`] contact solves, ns, by `solves` modulo their
    /// number (zero until there were as many: a new monitor takes its first solves as cheap).
    solve_ns: [u64; SOLVE_TIMES],
    solves: usize,
}

/// How many of the last solves [`Monitor::solves_are_cheap`] weighs.
const SOLVE_TIMES: usize = 8;

impl<'a> Monitor<'a> {
    fn new(shared: &'a Shared, inboxes: Inboxes) -> Self {
        let period_ns = shared.grid(0).period;
        let t_pass = shared.clock(Instant::now());
        // The first pass judges from the horizon the runtime set when it started, the instant
        // every ball added since begins at (see `Runtime::insert`), and the grid's first instant
        // (see `Grid`). Acquire: see `Shared::horizon`.
        let judged = shared.horizon.load(Ordering::Acquire);
        // Acquire pairs with the Release increment in `Shared::update_params`: seeing a
        // generation means the read lock returns what was written before it.
        let generation = shared.params_generation.load(Ordering::Acquire);
        let params = shared.params.read().clone();
        Monitor {
            shared,
            inboxes,
            period_ns,
            horizon_ns: HORIZON_PERIODS as u64 * period_ns,
            max_advance_ns: MAX_ADVANCE as u64 * period_ns,
            records: Vec::new(),
            contacts: ContactPass::new(shared.table.capacity()),
            trees: TreePublisher::default(),
            generation,
            free_motion: free_motion(&params.effects),
            params,
            t_pass,
            judged,
            busy_max_ns: 0,
            solve_ns: [0; SOLVE_TIMES],
            solves: 0,
        }
    }

    /// One pass, begun at `pass_start`: the parameters, the clock, then (unless paused) the
    /// table, the attraction tree, the contacts of the next span and the new horizon.
    fn pass(&mut self, pass_start: Instant) {
        self.refresh_params();
        // Paused means everything stands still, contacts and the clock included (Relaxed: no
        // data rides on the flag).
        let paused = self.shared.paused.load(Ordering::Relaxed);
        let now = self.shared.clock(pass_start);
        if paused {
            drop_time(self.shared, now.saturating_sub(self.t_pass));
            return;
        }
        self.advance_clock(now);
        // The inboxes' read lock from the table's read to the new horizon: a ball added meanwhile
        // (under the write lock) either is in this pass's read, or begins at the horizon this
        // pass publishes (see `Runtime::insert`); it never lives through a span judged without
        // it. Once a removal has cleared a slot, no message can be sent to the departing ball.
        let inboxes = self.inboxes.clone();
        let inboxes = inboxes.read();
        let high = self.read_table();
        // The tree first: the balls get the fresher field sooner.
        self.publish_tree(high);
        let end = self.span_end();
        self.judge_span(end, &inboxes);
    }

    /// Judges the time from where the judged time ends to `end`: a period per solve while the
    /// solves are cheap, else in one solve (see [`Monitor::solve_ns`]). A pass judges one
    /// period when it comes on time and several when it comes late (a starved monitor: on a
    /// 2-core machine running tests beside it, passes came 2 to 5 ms apart), and a contact
    /// solve is lockstep's step at the span's length: a ball dropped on a resting ball
    /// rebounded off the chain of sequential impacts by 0.8·g·span (1 ms) to 1.3·g·span (4 ms),
    /// as lockstep at that dt does. One period a solve keeps the threaded engine's contacts
    /// lockstep's at dt = one period however late the monitor is. Each period's horizon is
    /// published as soon as it is judged, so the balls move on meanwhile.
    fn judge_span(&mut self, end: u64, inboxes: &[Option<Inbox>]) {
        loop {
            let one_period = self.judged + self.period_ns;
            let piece_end = if one_period < end && self.solves_are_cheap() { one_period } else { end };
            let t0 = Instant::now();
            self.judge_contacts(piece_end, inboxes);
            if piece_end > self.judged {
                self.note_solve(t0.elapsed().as_nanos() as u64, piece_end - self.judged);
            }
            // Release: every message of this span was sent before (see `Shared::horizon`).
            self.judged = piece_end;
            self.shared.horizon.store(piece_end, Ordering::Release);
            if piece_end >= end {
                return;
            }
        }
    }

    /// Whether a late pass can judge its span a period per solve: the median of the last
    /// [`SOLVE_TIMES`] solves took under half a period of wall time, so a pass late by k
    /// periods catches up in under k/2 periods, and the next comes less late. The median, not
    /// the last: a few solves the machine preempted are not a scene whose solves are dear, and
    /// a few quick ones among dear ones (a pile landing) do not set a pass solving period after
    /// dear period. A scene whose solves are dear (the landing 1,024-ball pile: 1.6 to 2.2 ms a
    /// pass) judges each span in one solve, as many periods as it came late, and so keeps up
    /// with the clock.
    fn solves_are_cheap(&self) -> bool {
        let mut times = self.solve_ns;
        let (_, median, _) = times.select_nth_unstable(SOLVE_TIMES / 2);
        2 * *median < self.period_ns
    }

    /// Notes the wall time a solve of `span` ns took, and the longest span solved at once.
    fn note_solve(&mut self, ns: u64, span: u64) {
        self.solve_ns[self.solves % SOLVE_TIMES] = ns;
        self.solves += 1;
        // Relaxed: a statistic; the monitor is its only writer.
        self.shared.monitor_span_max_ns.fetch_max(span, Ordering::Relaxed);
    }

    /// Where this pass's span ends: whole periods on from where the judged time ends, as many as
    /// bring the horizon nearest to [`HORIZON_PERIODS`] ahead of the pass instant (none if it is
    /// still half a period or more ahead of that).
    fn span_end(&self) -> u64 {
        let wanted = self.t_pass + self.horizon_ns;
        let periods = (wanted.saturating_sub(self.judged) + self.period_ns / 2) / self.period_ns;
        self.judged + periods * self.period_ns
    }

    /// Re-reads the parameters if their generation moved. They change rarely (panel, hotkeys):
    /// the monitor takes the read lock only then, as the ball threads do.
    fn refresh_params(&mut self) {
        // Acquire: see `Monitor::new`.
        let g = self.shared.params_generation.load(Ordering::Acquire);
        if g != self.generation {
            self.generation = g;
            self.params = self.shared.params.read().clone();
            self.free_motion = free_motion(&self.params.effects);
            // New parameters (gravity, the field, restitution, ...) may move what rested.
            self.contacts.book.wake_all();
        }
    }

    /// Moves the pass instant to the clock `now`, or, when this pass comes more than
    /// [`MAX_ADVANCE`] periods after the last, one period on, dropping the rest from the clock
    /// (see the module comment).
    fn advance_clock(&mut self, now: u64) {
        if now > self.t_pass + self.max_advance_ns {
            let dropped = now - self.t_pass - self.period_ns;
            drop_time(self.shared, dropped);
            // Relaxed: a statistic.
            self.shared.clock_dropped_ns.fetch_add(dropped, Ordering::Relaxed);
            self.t_pass += self.period_ns;
        } else {
            self.t_pass = self.t_pass.max(now);
        }
    }

    /// Whether attraction is taken from the tree this pass needs: on, and at least
    /// [`TREE_MIN_BALLS`] occupied slots (fewer rule it out without reading the table).
    fn tree_attraction(&self, high: usize) -> Option<Attraction> {
        self.params.effects.attraction.filter(|_| high >= TREE_MIN_BALLS)
    }

    /// Reads the table into `records`, if anything this pass does needs it (contacts, the tree);
    /// returns the high-water mark it read up to.
    fn read_table(&mut self) -> usize {
        // Acquire: pairs with the runtime's Release store after it wrote a new slot's first
        // record.
        let high = self.shared.high_water.load(Ordering::Acquire);
        if self.params.effects.collisions.is_some() || self.tree_attraction(high).is_some() {
            self.shared.table.read_all(high, &mut self.records);
        }
        high
    }

    /// Builds and publishes the attraction tree from this pass's read, when the field takes it
    /// and the balls have moved on since the last build (see `TreePublisher::is_fresh`);
    /// withdraws it when the field does not take it. `high`: as [`Monitor::read_table`] read it.
    fn publish_tree(&mut self, high: usize) {
        let shared = self.shared;
        match self.tree_attraction(high) {
            Some(att) if AttractionMethod::choose(self.records.len(), &att) == AttractionMethod::Tree => {
                if !self.trees.is_fresh(&self.records, &att) {
                    let t0 = Instant::now();
                    // Relaxed: statistics.
                    if self.trees.publish(&self.records, &att, &shared.attraction_tree) {
                        shared.tree_builds.fetch_add(1, Ordering::Relaxed);
                        shared.tree_build_ns.fetch_add(t0.elapsed().as_nanos() as u64, Ordering::Relaxed);
                    } else {
                        shared.tree_builds_skipped.fetch_add(1, Ordering::Relaxed);
                    }
                    shared.tree_snapshots.store(self.trees.pool_size(), Ordering::Relaxed);
                }
            }
            _ => self.trees.withdraw(&shared.attraction_tree),
        }
    }

    /// Judges every contact from where the judged time ends to `end` and sends the responses
    /// (with collisions on and a span of any length).
    fn judge_contacts(&mut self, end: u64, inboxes: &[Option<Inbox>]) {
        let params = &self.params;
        let span = (end - self.judged) as f64 * 1e-9 * params.time_scale;
        if params.effects.collisions.is_none() {
            // Collisions just went off: the balls the change woke move from the horizon on.
            self.contacts.send_wakes(inboxes, self.judged);
        }
        let Some(collisions) = params.effects.collisions.filter(|_| span > 0.0) else { return };
        // The judged time always ends on the grid: every span is whole periods from the first.
        let grid = self.shared.grid(self.judged);
        // A resting ball crosses the span in whole periods, each in the sub-steps its length
        // alone asks for (no drag to speak of), as `Motion::advance` carries it.
        let piece = self.period_ns as f64 * 1e-9 * params.time_scale;
        let per_piece =
            StepPolicy::new(piece).with_max_step(self.shared.config.max_step).split(piece, &SpanRates::default());
        let substeps = ((end - self.judged) / self.period_ns) as u32 * per_piece.count;
        let setting = PassSetting {
            generation: self.generation,
            may_sleep: params.effects.attraction.is_none() && self.shared.config.sleep,
            start: self.judged,
            end,
            time_scale: params.time_scale,
            motion: Motion {
                grid,
                integrator: params.integrator,
                max_step: self.shared.config.max_step,
                forces: &self.free_motion,
                gravity: params.effects.gravity.map_or(DVec2::ZERO, |g| g.g),
                drag: params.effects.drag.as_ref(),
                time_scale: params.time_scale,
            },
            params: ContactParams {
                restitution: collisions.restitution,
                field: params.field,
                span,
                drift: resting_drift(params.integrator, substeps),
            },
        };
        self.contacts.run(self.shared, inboxes, &self.records, &setting);
    }

    /// Counts a pass begun at `pass_start` and the time it took, for the report.
    fn count_pass(&mut self, pass_start: Instant) {
        // Relaxed: statistics (the monitor is the only writer of the longest pass).
        let busy = pass_start.elapsed().as_nanos() as u64;
        self.busy_max_ns = self.busy_max_ns.max(busy);
        self.shared.monitor_passes.fetch_add(1, Ordering::Relaxed);
        self.shared.monitor_busy_ns.fetch_add(busy, Ordering::Relaxed);
        self.shared.monitor_busy_max_ns.store(self.busy_max_ns, Ordering::Relaxed);
    }
}

/// What one pass solves over.
struct PassSetting<'a> {
    /// The generation of the parameters the pass runs with (see [`Monitor::refresh_params`]).
    generation: u64,
    /// Whether balls may sleep under the parameters' effects: not with attraction on (every
    /// ball pulls every other).
    may_sleep: bool,
    /// The span the pass judges (runtime clock, ns).
    start: u64,
    end: u64,
    time_scale: f64,
    motion: Motion<'a>,
    params: ContactParams,
}

/// The contact messages sent to the ball in a slot that it has not applied yet, and how many it
/// was sent in all (a slot is reused by a later ball, whose own counts start from zero).
#[derive(Default)]
struct InFlight {
    /// The ball's start these counts are of (see [`Inbox::incarnation`]).
    incarnation: Option<u64>,
    sent: u64,
    /// The ring's producer side for this ball (see `contact_ring`).
    ring: RingWriter,
    /// Messages sent by the channel (the ring was full), and how many of them the ball had taken
    /// when last read: while they differ, every message goes by the channel too (see
    /// `contact_ring`, the order).
    by_channel: u64,
    channel_seen: u64,
    /// The last `queue.len()` messages sent, oldest first: their sequence numbers run on to
    /// `sent`, and message k is applied once the ball's `applied` count exceeds k (a ball applies
    /// its contact messages in the order they were sent). The newest [`INLINE_SENT`] are kept in
    /// this slot itself (see `sent_queue`).
    queue: SentQueue<Sent, INLINE_SENT>,
}

/// Messages in flight to one ball kept in its slot of the monitor's array: a ball's thread takes
/// its inbox every one to six passes on the 1,024-ball pile, so eight cover all but a starved
/// ball's (whose older ones go to the heap).
const INLINE_SENT: usize = 8;

/// How many balls ahead `send_responses` asks for the ring slot it will write.
const PREFETCH_AHEAD: usize = 8;

/// A contact message sent, and the ball as the pass that sent it carried it to the message's
/// stamp, its response applied (see [`ContactPass::send_responses`]).
#[derive(Clone, Copy)]
struct Sent {
    message: Contact,
    /// `None` for a wake sent without the ball's record (see [`ContactPass::send_wakes`]).
    after: Option<Ball>,
}

impl InFlight {
    /// Forgets what the record says was applied; resets for a new ball in the slot (or the same
    /// ball started again: see [`Inbox::incarnation`]). Returns the
    /// newest message it forgot, if any (the ball has applied it since the last pass). The count
    /// alone says how many to forget: the queue's messages are not read but that one (on a
    /// 1,024-ball pile, reading each slot's oldest message took a twentieth of the pass in cache
    /// misses).
    fn sync(&mut self, r: &BallRecord, incarnation: u64) -> Option<Sent> {
        if self.incarnation != Some(incarnation) {
            *self = InFlight { incarnation: Some(incarnation), ..InFlight::default() };
        }
        let first = self.sent - self.queue.len() as u64;
        let applied = r.applied.saturating_sub(first).min(self.queue.len() as u64) as usize;
        let newest = applied.checked_sub(1).and_then(|k| self.queue.get(k).copied());
        self.queue.forget_oldest(applied);
        newest
    }

    /// Notes a message sent.
    fn push(&mut self, sent: Sent) {
        self.queue.push(sent);
        self.sent += 1;
    }
}

/// What a pass judged a ball's state to be at the end of its span (its response included), and
/// of which record: while the ball publishes nothing newer, the next pass continues from here.
#[derive(Clone, Copy)]
struct Judged {
    /// The ball's start (see [`Inbox::incarnation`]).
    incarnation: u64,
    record_time: u64,
    record_applied: u64,
    time: u64,
    position: DVec2,
    velocity: DVec2,
    /// The uniform acceleration and the parameters' generation the pass carried the ball with.
    acceleration: DVec2,
    generation: u64,
}

/// How a ball moves between contacts, as its own thread integrates it: through
/// `physics::advance_ball`, the ball thread's own loop, in its integrator's sub-steps judged by
/// the step policy (no longer than the runtime's `max_step`; drag resolved, or its guard rail
/// on), under the force passes of the parameters' effects (gravity, drag) and the ball's pull,
/// with the speed guard rail after each. The other balls' attraction is left out: the threads
/// take it from the tree.
struct Motion<'a> {
    /// The grid the balls' stretches are cut at (see [`Grid`]).
    grid: Grid,
    integrator: Integrator,
    max_step: f64,
    /// The parameters' force passes without attraction (see [`free_motion`]).
    forces: &'a Forces,
    /// The parameters' gravity (zero with gravity off): a ball's uniform acceleration less this
    /// is its pull over its mass.
    gravity: DVec2,
    drag: Option<&'a Drag>,
    time_scale: f64,
}

/// The force passes the monitor carries balls by: `effects` but attraction (see [`Motion`]).
fn free_motion(effects: &Effects) -> Forces {
    Forces::new(&Effects { attraction: None, ..*effects })
}

impl Motion<'_> {
    /// Moves `(x, v)` from clock instant `from` to `to` (no further than `to`; nothing if `to` is
    /// not later), grid piece by grid piece as the ball thread cuts its stretches; `a` is the
    /// ball's uniform acceleration as its record says (gravity and its pull over its mass).
    ///
    /// Each sub-step is judged afresh by the drag rate where the ball is, as the ball thread
    /// judges its own: a light, large ball at speed is stiff, and fixed steps of `max_step` would
    /// overshoot through zero and run away to NaN, which the pass would then send to the ball
    /// (a 1.6 g ball of 2.2 m at 300 m/s did, within the first passes). The terminal-speed rate
    /// under `a` is worked out once for the whole carry (`DragRateBound`).
    #[allow(clippy::too_many_arguments)]
    fn advance(
        &self,
        x: &mut DVec2,
        v: &mut DVec2,
        ball: &Ball,
        a: DVec2,
        from: u64,
        to: u64,
        scratch: &mut IntegratorScratch,
    ) {
        let bound = self.drag.map(|d| DragRateBound::new(a, ball.diameter, ball.mass, d));
        let rates =
            |_: DVec2, v: DVec2| SpanRates { drag: bound.as_ref().map_or(0.0, |b| b.at(v)), ..SpanRates::default() };
        let props = BallProps { mass: ball.mass, inverse_mass: 1.0 / ball.mass, diameter: ball.diameter };
        // The pull the ball's thread adds after gravity: exactly zero for every ball but the key
        // ball, whose sum then rounds as the thread's does to within an ulp or so.
        let pull = (a - self.gravity) * ball.mass;
        let forces = self.forces.on_ball(props, pull, NoOtherBalls);
        for (from, to) in self.grid.pieces(from, to) {
            let dt = clock_seconds(to, from) * self.time_scale;
            let policy = StepPolicy::new(dt).with_max_step(self.max_step);
            advance_ball(self.integrator, &policy, dt, forces, rates, (&mut *x, &mut *v), scratch, |_, _| {});
        }
    }
}

/// The contact part of a pass, with the memory it reuses from pass to pass.
struct ContactPass {
    in_flight: Vec<InFlight>,
    /// By slot: where the last pass left each ball.
    judged: Vec<Option<Judged>>,
    /// The balls at the end of the span, and which record each came from.
    balls: Vec<SolverBall>,
    record_of: Vec<u32>,
    /// Each ball's state at the span's start.
    starts: Vec<(DVec2, DVec2)>,
    /// The circle each ball's path over the span lies in, for the broad phase.
    centres: Vec<DVec2>,
    reach: Vec<f64>,
    broad_phase: BroadPhase,
    pairs: Vec<(u32, u32)>,
    solver: ContactSolver,
    scratch: IntegratorScratch,
    /// The fastest speed any ball has during this pass's span (m/s).
    fastest: f64,
    /// The largest distance so far between where a pass left a ball and where the ball's next
    /// record puts it at that instant (m): how well the monitor's motion matches the threads'.
    drift_max: f64,
    /// The resting balls' book: quiet stretches, sleeping islands (see `sleep.rs`).
    book: SleepBook,
    /// Passes so far (for the book's `seen`).
    pass: u64,
    /// The records of the balls asleep this pass, and where each is held.
    sleepers: Vec<u32>,
    held: Vec<DVec2>,
    /// The broad phase's circles: the awake balls' (reach grown by a struck ball's travel), then
    /// the sleepers'.
    all_centres: Vec<DVec2>,
    all_reach: Vec<f64>,
    /// Scratch of the pass's sleep: sleepers to wake, slots woken, islands, per-ball walls and
    /// quiet, per-island readiness, members, wall force and warm start, whether each ball goes to
    /// sleep now.
    to_wake: Vec<u32>,
    woken: Vec<usize>,
    islands: Islands,
    ball_walls: Vec<[f64; 4]>,
    touches: Vec<bool>,
    island_ready: Vec<bool>,
    island_touches: Vec<bool>,
    island_members: Vec<Vec<usize>>,
    island_force: Vec<[f64; 4]>,
    /// Per island (by root), the mass of its balls (kg).
    island_mass: Vec<f64>,
    island_warm: Vec<Vec<(WarmKey, f64)>>,
    sleep_now: Vec<bool>,
    /// Messages sent, dropped and sent by channel this pass (added to the statistics once).
    sent: u64,
    dropped: u64,
    by_channel: u64,
}

impl ContactPass {
    fn new(capacity: usize) -> Self {
        ContactPass {
            in_flight: (0..capacity).map(|_| InFlight::default()).collect(),
            judged: vec![None; capacity],
            balls: Vec::new(),
            record_of: Vec::new(),
            starts: Vec::new(),
            centres: Vec::new(),
            reach: Vec::new(),
            broad_phase: BroadPhase::new(),
            pairs: Vec::new(),
            solver: ContactSolver::new(),
            scratch: IntegratorScratch::default(),
            drift_max: 0.0,
            fastest: 0.0,
            book: SleepBook::new(capacity),
            pass: 0,
            sleepers: Vec::new(),
            held: Vec::new(),
            all_centres: Vec::new(),
            all_reach: Vec::new(),
            to_wake: Vec::new(),
            woken: Vec::new(),
            islands: Islands::default(),
            ball_walls: Vec::new(),
            touches: Vec::new(),
            island_ready: Vec::new(),
            island_touches: Vec::new(),
            island_members: Vec::new(),
            island_warm: Vec::new(),
            island_force: Vec::new(),
            island_mass: Vec::new(),
            sleep_now: Vec::new(),
            sent: 0,
            dropped: 0,
            by_channel: 0,
        }
    }

    /// The contact part of one pass, in named steps: every awake ball carried to the end of the
    /// span ([`ContactPass::gather`]), the candidate pairs and the sleeping islands they wake
    /// ([`ContactPass::find_pairs`]), the wakes sent ([`ContactPass::send_wakes`]) and the
    /// sleeping islands' weight put on the walls, one solve of every contact
    /// ([`ContactPass::solve`]), the islands that may sleep now ([`ContactPass::settle`]) and
    /// one message per touched ball ([`ContactPass::send_responses`]).
    fn run(&mut self, shared: &Shared, inboxes: &[Option<Inbox>], records: &[BallRecord], s: &PassSetting) {
        self.gather(records, inboxes, s);
        self.find_pairs(records, inboxes, s);
        self.send_wakes(inboxes, s.start);
        let solver = &mut self.solver;
        self.book.take_waking_warm(|w| solver.restore_warm_start(&w.impulses, w.span));
        if self.book.any_asleep() {
            add_monitor_walls(shared, &self.book.wall_impulses(s.params.span));
        }
        self.solve(shared, s);
        self.settle(records, s);
        self.send_responses(records, inboxes, s);
        // Relaxed: statistics (the monitor is their only writer), added once a pass (an atomic
        // add per message cost more than the rest of its bookkeeping).
        shared.judged_drift_max.store(self.drift_max.to_bits(), Ordering::Relaxed);
        shared.contact_messages_sent.fetch_add(std::mem::take(&mut self.sent), Ordering::Relaxed);
        shared.messages_dropped.fetch_add(std::mem::take(&mut self.dropped), Ordering::Relaxed);
        shared.responses_by_channel.fetch_add(std::mem::take(&mut self.by_channel), Ordering::Relaxed);
        let (slept, woken) = self.book.take_counts();
        shared.balls_asleep.store(self.book.asleep(), Ordering::Relaxed);
        shared.balls_slept.fetch_add(slept, Ordering::Relaxed);
        shared.balls_woken.fetch_add(woken, Ordering::Relaxed);
    }

    /// Sends every ball woken since the last call its wake, stamped `stamp` (the start of the
    /// span being judged: the horizon, which no ball has passed).
    fn send_wakes(&mut self, inboxes: &[Option<Inbox>], stamp: u64) {
        let mut woken = std::mem::take(&mut self.woken);
        self.book.take_waking(&mut woken);
        for &slot in &woken {
            let Some(inbox) = inboxes.get(slot).and_then(|i| i.as_ref()) else { continue };
            if self.book.watch(slot).incarnation != Some(inbox.incarnation) {
                continue;
            }
            let message = Contact { dv: DVec2::ZERO, dx: DVec2::ZERO, stamp, apply_at: stamp, rest: Rest::Wake };
            self.send(inbox, slot, message, None);
        }
        self.woken = woken;
    }

    /// Sends `message` to the ball in `slot` (its ring, or its channel: see `contact_ring`) and
    /// notes it in flight, `after` the ball as the message leaves it.
    fn send(&mut self, inbox: &Inbox, slot: usize, message: Contact, after: Option<Ball>) {
        let in_flight = &mut self.in_flight[slot];
        // The ring only once the ball holds every message sent by the channel (read again
        // only while some are out: the count is on a line the ball writes).
        let ring_open = in_flight.by_channel == in_flight.channel_seen || {
            in_flight.channel_seen = inbox.contacts.taken_from_channel();
            in_flight.by_channel == in_flight.channel_seen
        };
        let by_ring = ring_open && inbox.contacts.push(&mut in_flight.ring, &message);
        // The channel's send fails only if the ball's thread is gone (it panicked): counted
        // as dropped. (A push to the ring of a ball that panicked counts as sent: its slot is
        // cleared at once, so for a pass at most.)
        if by_ring || inbox.commands.send(Message::Contact(message)).is_ok() {
            if !by_ring {
                in_flight.by_channel += 1;
                self.by_channel += 1;
            }
            in_flight.push(Sent { message, after });
            self.sent += 1;
        } else {
            self.dropped += 1;
        }
    }

    /// Every awake ball that takes part, at the end of the span in free motion (`balls`, see
    /// [`ContactPass::take_part`]); the sleeping ones in `sleepers`, where they are held. A
    /// sleeping island wakes here when one of its balls was pulled, thrown or given a new mass
    /// (its record shows it), or is gone from the field.
    fn gather(&mut self, records: &[BallRecord], inboxes: &[Option<Inbox>], s: &PassSetting) {
        self.balls.clear();
        self.record_of.clear();
        self.starts.clear();
        self.centres.clear();
        self.reach.clear();
        self.sleepers.clear();
        self.fastest = 0.0;
        self.pass += 1;
        for (k, r) in records.iter().enumerate() {
            // A ball being removed takes part in no contact: its partners get no half-impulse
            // it would not get.
            let Some(incarnation) = inbox(inboxes, r).map(|i| i.incarnation) else { continue };
            let applied = self.in_flight[r.slot].sync(r, incarnation);
            if self.book.watch(r.slot).incarnation != Some(incarnation) {
                self.book.renew(r.slot, incarnation);
            }
            if !(r.ball.is_finite() && r.ball.mass > 0.0 && r.ball.diameter > 0.0) {
                continue;
            }
            let w = self.book.watch_mut(r.slot);
            if let Some(island) = w.island {
                w.seen = self.pass;
                // Commands reach a sleeping ball's state but do not move it: the monitor wakes it.
                let moved = r.acceleration != w.acceleration
                    || r.ball.mass != w.mass
                    || r.ball.diameter != w.diameter
                    || (r.asleep && r.ball.velocity != DVec2::ZERO);
                if moved {
                    self.book.wake_island(island);
                }
                self.sleepers.push(k as u32);
                continue;
            }
            self.take_part(k, r, incarnation, applied, s);
        }
        if !self.book.any_asleep() && self.sleepers.is_empty() {
            return;
        }
        self.book.wake_islands_missing_a_ball(self.pass);
        self.sort_sleepers(records, inboxes, s);
    }

    /// Takes the woken balls of `sleepers` into the pass ([`ContactPass::take_part`]) and notes
    /// where the others are held (`held`): where the record says once the ball holds every
    /// message sent (a sleep applied late leaves it a little off where the monitor put it), where
    /// the monitor put it before.
    fn sort_sleepers(&mut self, records: &[BallRecord], inboxes: &[Option<Inbox>], s: &PassSetting) {
        // Taken out for the loop (`take_part` borrows the pass) and compacted in place: the ones
        // still asleep keep their order at the front.
        let mut sleepers = std::mem::take(&mut self.sleepers);
        self.held.clear();
        let mut kept = 0;
        for i in 0..sleepers.len() {
            let k = sleepers[i];
            let r = &records[k as usize];
            let w = self.book.watch(r.slot);
            if w.island.is_some() {
                let at_record = r.asleep && self.in_flight[r.slot].queue.is_empty();
                self.held.push(if at_record { r.ball.position } else { w.held });
                sleepers[kept] = k;
                kept += 1;
                continue;
            }
            let Some(incarnation) = inbox(inboxes, r).map(|i| i.incarnation) else { continue };
            self.take_part(k as usize, r, incarnation, None, s);
        }
        sleepers.truncate(kept);
        self.sleepers = sleepers;
    }

    /// Ball `k` of the records, `r`, takes part in the pass: carried from the span's start to its
    /// end in free motion, with the circle its path lies in (`centres`, `reach`) and the fastest
    /// speed met. `applied`: see [`InFlight::sync`].
    fn take_part(&mut self, k: usize, r: &BallRecord, incarnation: u64, applied: Option<Sent>, s: &PassSetting) {
        {
            let a = if r.acceleration.is_finite() { r.acceleration } else { DVec2::ZERO };
            let (x_start, v_start) = self.span_start(r, incarnation, a, applied, s);
            let (mut x, mut v) = (x_start, v_start);
            s.motion.advance(&mut x, &mut v, &r.ball, a, s.start, s.end, &mut self.scratch);
            self.fastest = self.fastest.max(v_start.length()).max(v.length());
            let radius = r.ball.radius();
            let (centre, reach) = swept_circle(x_start, x, a, s.params.span, radius);
            self.balls.push(SolverBall {
                id: r.ball.id,
                position: x,
                velocity: v,
                acceleration: a,
                inverse_mass: 1.0 / r.ball.mass,
                radius,
            });
            self.record_of.push(k as u32);
            self.starts.push((x_start, v_start));
            self.centres.push(centre);
            self.reach.push(reach);
        }
    }

    /// The ball of record `r` (uniform acceleration `a`) at the span's start: as the last pass
    /// left it if it has published nothing since, or if what it published is where a pass put
    /// it; otherwise from its record, moved on as its thread will move it, in the same stretches
    /// (see `ball_thread::catch_up`): each response in flight applied at its instant (the thread
    /// holds each to that instant, and every one in flight is for an earlier span, so before this
    /// one's start), then on to the end of its span. `applied`: the newest message the ball has
    /// applied since the last pass (see [`InFlight::sync`]).
    ///
    /// Where a pass put it: a ball that applies a message goes on to its stamp, so a ball in a
    /// pile, sent one every pass, publishes its state at the stamp of the newest it applied. If
    /// that state is, to the bit, the one the pass that sent the message carried it to, and its
    /// acceleration and the parameters are those the passes since carried it with, its thread
    /// and the passes since did the same arithmetic on the same numbers, and the last pass's end
    /// is where the ball will be: the record is not carried again (on a 1,024-ball pile, where a
    /// ball publishes every five or six passes, carrying each through its messages in flight
    /// costs a tenth of the pass).
    fn span_start(
        &mut self,
        r: &BallRecord,
        incarnation: u64,
        a: DVec2,
        applied: Option<Sent>,
        s: &PassSetting,
    ) -> (DVec2, DVec2) {
        let last = self.judged[r.slot].filter(|j| j.incarnation == incarnation && j.time == s.start);
        if let Some(j) = last.filter(|j| j.record_time == r.time && j.record_applied == r.applied) {
            return (j.position, j.velocity);
        }
        let as_put = applied.is_some_and(|m| m.message.stamp == r.time && m.after == Some(r.ball));
        if let Some(j) = last.filter(|j| as_put && j.acceleration == a && j.generation == s.generation) {
            return (j.position, j.velocity);
        }
        let (mut x, mut v, mut t, mut asleep) = (r.ball.position, r.ball.velocity, r.time, r.asleep);
        for Sent { message: m, .. } in self.in_flight[r.slot].queue.iter() {
            t = follow(&s.motion, &s.params.field, (&mut x, &mut v, t, &mut asleep), m, &r.ball, a, &mut self.scratch);
        }
        // A ball the book has woken is held to the span's start, where its wake is stamped.
        if !asleep {
            s.motion.advance(&mut x, &mut v, &r.ball, a, t, s.start, &mut self.scratch);
        }
        // How far the ball's own motion took it from where the last pass left it.
        if let Some(j) = last {
            self.drift_max = self.drift_max.max(x.distance(j.position));
        }
        (x, v)
    }

    /// Every pair whose paths come within reach during the span: a superset of the pairs that
    /// touch in it, whatever their speed. A ball struck in mid-span leaves its free path: it then
    /// moves at most twice as fast as the fastest ball (an elastic strike by a much heavier one),
    /// so every path's circle grows by that much travel, and a struck ball's next contact in the
    /// span is among its pairs too. The margin keeps pairs that the solver left exactly touching
    /// (a row at rest, struck at one end).
    ///
    /// The sleeping balls are in the broad phase too, each its own circle: a pair of an awake
    /// ball and a sleeping one wakes the sleeper's island, whose balls then take part in the pass
    /// (and may wake more in turn). Two sleepers make no pair.
    fn find_pairs(&mut self, records: &[BallRecord], inboxes: &[Option<Inbox>], s: &PassSetting) {
        self.broad_phase.set_margin(TOUCH_MARGIN);
        loop {
            self.pairs.clear();
            let awake = self.balls.len();
            if awake == 0 {
                return;
            }
            let struck_travel = 2.0 * self.fastest * s.params.span;
            self.all_centres.clear();
            self.all_reach.clear();
            self.all_centres.extend_from_slice(&self.centres);
            self.all_reach.extend(self.reach.iter().map(|r| r + struck_travel));
            self.all_centres.extend_from_slice(&self.held);
            self.all_reach.extend(self.sleepers.iter().map(|&k| records[k as usize].ball.radius()));
            let field = &s.params.field;
            self.broad_phase.update(&self.all_centres, &self.all_reach, field.width, field.height);
            let (pairs, to_wake) = (&mut self.pairs, &mut self.to_wake);
            to_wake.clear();
            self.broad_phase.for_each_touching_pair(|i, j| match (i < awake, j < awake) {
                (true, true) => pairs.push((i as u32, j as u32)),
                (true, false) => to_wake.push((j - awake) as u32),
                (false, true) => to_wake.push((i - awake) as u32),
                (false, false) => {}
            });
            if self.to_wake.is_empty() {
                return;
            }
            for &k in &self.to_wake {
                let slot = records[self.sleepers[k as usize] as usize].slot;
                if let Some(island) = self.book.watch(slot).island {
                    self.book.wake_island(island);
                }
            }
            self.sort_sleepers(records, inboxes, s);
        }
    }

    /// Which of the pass's balls sleep from the span's end (`sleep_now`): the islands of touching
    /// balls (the solve's resting contacts, and the candidate pairs: balls that may touch within
    /// a span) that touch something and whose every ball has been
    /// quiet for [`TIME_TO_SLEEP`] (see `physics::sleep`). Keeps each ball's quiet stretch and
    /// its walls' impulses over it, and books the islands that sleep with their walls' mean
    /// force.
    fn settle(&mut self, records: &[BallRecord], s: &PassSetting) {
        let n = self.balls.len();
        self.sleep_now.clear();
        self.sleep_now.resize(n, false);
        if n == 0 {
            return;
        }
        self.ball_walls.clear();
        self.ball_walls.resize(n, [0.0; 4]);
        self.touches.clear();
        self.touches.resize(n, false);
        self.islands.reset(n);
        let (walls, touches, islands) = (&mut self.ball_walls, &mut self.touches, &mut self.islands);
        self.solver.for_each_wall_impulse(|i, wall, j| walls[i][wall.index()] += j);
        self.solver.for_each_touching(|a, b| {
            touches[a] = true;
            if let Some(b) = b {
                touches[b] = true;
                islands.join(a as u32, b as u32);
            }
        });
        // Balls that may touch within a span (the candidate pairs) sleep together too: a sleeping
        // ball is woken by an awake one within that reach (`find_pairs`), so two quiet islands a
        // hair apart, each falling asleep while the other was not quite due, woke each other
        // every half second for ever (a settled 150-ball pile: 300 balls put to sleep and woken
        // a second, none asleep after 10 s).
        for &(a, b) in self.pairs.iter().chain(self.solver.reached_pairs()) {
            islands.join(a, b);
        }
        self.island_ready.clear();
        self.island_ready.resize(n, s.may_sleep);
        self.island_touches.clear();
        self.island_touches.resize(n, false);
        let responses = self.solver.responses();
        let gravity = s.motion.gravity;
        let ns_to_s = 1e-9 * s.time_scale;
        for (i, b) in self.balls.iter().enumerate() {
            let slot = records[self.record_of[i] as usize].slot;
            let response = &responses[i];
            let v = b.velocity + response.velocity_change;
            let quiet = s.may_sleep && is_quiet(v, 2.0 * b.radius, b.acceleration, gravity, response.struck);
            let w = self.book.watch_mut(slot);
            let rested = if quiet {
                let since = *w.quiet_since.get_or_insert(s.start);
                for (sum, j) in w.walls.iter_mut().zip(self.ball_walls[i]) {
                    *sum += j;
                }
                (s.end - since) as f64 * ns_to_s >= TIME_TO_SLEEP
            } else {
                w.quiet_since = None;
                w.walls = [0.0; 4];
                false
            };
            let root = self.islands.find(i as u32) as usize;
            self.island_ready[root] &= rested;
            self.island_touches[root] |= self.touches[i];
        }
        // Each island that sleeps, as one list of slots (indexed by root until booked).
        self.island_members.resize_with(n, Vec::new);
        self.island_force.clear();
        self.island_force.resize(n, [0.0; 4]);
        self.island_mass.clear();
        self.island_mass.resize(n, 0.0);
        let mut roots = Vec::new();
        for i in 0..n {
            let root = self.islands.find(i as u32) as usize;
            if !(self.island_ready[root] && self.island_touches[root]) {
                continue;
            }
            self.sleep_now[i] = true;
            let slot = records[self.record_of[i] as usize].slot;
            let w = self.book.watch(slot);
            let quiet = (s.end - w.quiet_since.unwrap_or(s.start)) as f64 * ns_to_s;
            for (f, j) in self.island_force[root].iter_mut().zip(w.walls) {
                *f += j / quiet;
            }
            self.island_mass[root] += 1.0 / self.balls[i].inverse_mass;
            if self.island_members[root].is_empty() {
                roots.push(root);
            }
            self.island_members[root].push(slot);
        }
        if roots.is_empty() {
            return;
        }
        // Each island's contacts' warm start, which it takes to sleep with it (every contact
        // touching a ball of the island is the island's: that is what joins it).
        self.island_warm.resize_with(n, Vec::new);
        let (islands, sleep_now, island_warm) = (&mut self.islands, &self.sleep_now, &mut self.island_warm);
        self.solver.for_each_warm_start(&self.balls, |a, key, j| {
            if sleep_now[a] {
                island_warm[islands.find(a as u32) as usize].push((key, j));
            }
        });
        let span = self.solver.warm_span();
        for root in roots {
            let members = std::mem::take(&mut self.island_members[root]);
            let warm = WarmStart { impulses: std::mem::take(&mut self.island_warm[root]), span };
            let force = held_wall_forces(self.island_force[root], self.island_mass[root] * gravity);
            self.book.put_to_sleep(members, force, warm);
        }
    }

    /// One solve of every contact of the span, counted, its wall impulses on the monitor's gauge.
    fn solve(&mut self, shared: &Shared, s: &PassSetting) {
        let tally = self.solver.solve(&self.balls, &self.pairs, &s.params, Some(&self.broad_phase));
        // Relaxed: statistics.
        shared.contacts_solved.fetch_add(tally.contacts, Ordering::Relaxed);
        shared.contact_impacts.fetch_add(tally.impacts, Ordering::Relaxed);
        if tally.pushed_together + tally.pairs_reached > 0 {
            shared.pairs_pushed_together.fetch_add(tally.pushed_together, Ordering::Relaxed);
            shared.pairs_reached.fetch_add(tally.pairs_reached, Ordering::Relaxed);
        }
        if !tally.converged {
            shared.solves_unconverged.fetch_add(1, Ordering::Relaxed);
        }
        add_monitor_walls(shared, &tally.walls);
    }

    /// Remembers where the solve left every ball at the span's end (the next pass continues from
    /// there), and sends each ball with a response worth sending one stamped message, and each
    /// ball that sleeps from the span's end its sleep (see [`Rest::Sleep`]).
    fn send_responses(&mut self, records: &[BallRecord], inboxes: &[Option<Inbox>], s: &PassSetting) {
        for i in 0..self.balls.len() {
            // The ring slot a few balls on, asked for now: it is on a line the ball's core holds.
            if let Some(&k) = self.record_of.get(i + PREFETCH_AHEAD) {
                let r = &records[k as usize];
                if let Some(inbox) = inbox(inboxes, r) {
                    inbox.contacts.prefetch_next(&self.in_flight[r.slot].ring);
                }
            }
            let response = self.solver.responses()[i];
            let b = self.balls[i];
            let r = &records[self.record_of[i] as usize];
            let Some(inbox) = inbox(inboxes, r) else { continue };
            let sleeps = self.sleep_now[i];
            let mut judged = Judged {
                incarnation: inbox.incarnation,
                record_time: r.time,
                record_applied: r.applied,
                time: s.end,
                position: b.position + response.shift,
                velocity: b.velocity + response.velocity_change,
                acceleration: b.acceleration,
                generation: s.generation,
            };
            if !sleeps && negligible(&response, b.radius, s.params.span) {
                // No message: the ball moves on in free motion, as the solve found it.
                (judged.position, judged.velocity) = (b.position, b.velocity);
                self.judged[r.slot] = Some(judged);
                continue;
            }
            let before_end = (response.instant / s.time_scale * 1e9).clamp(0.0, (s.end - s.start) as f64) as u64;
            let message = if sleeps {
                // Quiet balls took no impact: the response acts at the span's end, and the ball
                // stops there, `dv` taking away the very velocity the monitor carried it to.
                Contact { dv: -b.velocity, dx: response.shift, stamp: s.end, apply_at: s.end, rest: Rest::Sleep }
            } else {
                Contact {
                    dv: response.velocity_change,
                    dx: response.shift,
                    stamp: s.end,
                    apply_at: s.end - before_end,
                    rest: Rest::Unchanged,
                }
            };
            // The next pass goes on from where the ball will be: carried through its response as
            // its thread carries it (applied at its instant, not at the span's end as the solve
            // adds it). The two differ under a velocity-dependent force (drag acts on the path
            // the response changed), and at an impact in mid-span, which cuts the ball's stretch
            // in two (under semi-implicit Euler, micrometres); a ball starved of the CPU for a few
            // hundred passes, continued from the solve's end states, ends tens of micrometres from
            // where it is when it next publishes.
            // A response at the span's end (resting contacts alone) follows the free motion over
            // the whole span, which `gather` carried the ball through already, to the bit.
            let (mut x, mut v, t) = if message.apply_at == s.end {
                (b.position, b.velocity, s.end)
            } else {
                (self.starts[i].0, self.starts[i].1, s.start)
            };
            let a = b.acceleration;
            let mut asleep = false;
            let state = (&mut x, &mut v, t, &mut asleep);
            follow(&s.motion, &s.params.field, state, &message, &r.ball, a, &mut self.scratch);
            (judged.position, judged.velocity) = (x, v);
            self.judged[r.slot] = Some(judged);
            if sleeps {
                let w = self.book.watch_mut(r.slot);
                (w.held, w.mass, w.diameter, w.acceleration) = (x, r.ball.mass, r.ball.diameter, a);
            }
            self.send(inbox, r.slot, message, Some(Ball { position: x, velocity: v, ..r.ball }));
        }
    }
}

/// Carries a ball from `(x, v)` at instant `t` through the response `m` as its thread does (see
/// `ball_thread::catch_up`): on to the response's instant, the response applied, on to the end of
/// its span in one stretch, held inside the field there; then asleep or awake as the message
/// says (a sleeping ball is held still). Returns the instant it is then at.
#[inline]
fn follow(
    motion: &Motion<'_>,
    field: &Field,
    (x, v, mut t, asleep): (&mut DVec2, &mut DVec2, u64, &mut bool),
    m: &Contact,
    ball: &Ball,
    a: DVec2,
    scratch: &mut IntegratorScratch,
) -> u64 {
    if m.apply_at > t {
        if !*asleep {
            motion.advance(x, v, ball, a, t, m.apply_at, scratch);
        }
        t = m.apply_at;
    }
    *v += m.dv;
    *x += m.shift_at(t, motion.time_scale);
    if m.stamp > t {
        if !*asleep {
            motion.advance(x, v, ball, a, t, m.stamp, scratch);
        }
        t = m.stamp;
    }
    if t == m.stamp {
        hold_inside(x, ball.radius(), field);
    }
    m.rest.apply(asleep);
    t
}

/// The inbox of the ball of record `r`, if it is still on the field.
fn inbox<'a>(inboxes: &'a [Option<Inbox>], r: &BallRecord) -> Option<&'a Inbox> {
    inboxes.get(r.slot).and_then(|s| s.as_ref())
}

fn negligible(r: &BallResponse, radius: f64, span: f64) -> bool {
    let tiny = NEGLIGIBLE * radius;
    r.velocity_change.length() * span <= tiny && r.shift.length() <= tiny
}

/// Adds a pass's wall impulses to the monitor's gauge (it is the gauge's only writer).
fn add_monitor_walls(shared: &Shared, walls: &WallImpulses) {
    for (word, j) in shared.monitor_walls.iter().zip([walls.left, walls.right, walls.bottom, walls.top]) {
        if j != 0.0 {
            // Relaxed: see `Shared::monitor_walls`.
            let total = f64::from_bits(word.load(Ordering::Relaxed)) + j;
            word.store(total.to_bits(), Ordering::Relaxed);
        }
    }
}
