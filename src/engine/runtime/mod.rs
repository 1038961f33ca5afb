//! The threaded runtime, the game's default engine (DESIGN.md, "The threaded runtime"): every
//! ball on its own `std::thread`, a lock-free [`BallTable`] they publish to, and a
//! collision-monitor thread that sends impulses as messages. Every thread of the program that
//! simulates lives here, and every one is joined.
//!
//! Channels: each ball's inbox is a crossbeam channel and a contact ring. The channel's receiver
//! is owned by the ball's thread; its senders by the runtime's registry and the monitor's inbox
//! list, both of which drop theirs when the ball is removed or the runtime shuts down — the
//! `Stop` message, not the channel closing, is what ends the thread, and closing is the
//! fallback. The ring (`contact_ring`) carries the monitor's contact responses, the monitor its
//! only producer and the ball's thread its only consumer; both hold it by an `Arc`, freed with
//! the last of them. A response that finds the ring full goes by the channel.

mod attraction_tree;
mod ball_thread;
mod contact_ring;
mod message;
mod monitor;
mod sent_queue;
mod shared;
mod sleep;
mod table;
mod wide_registers;

/// What [`table`] and [`contact_ring`] are built on. `tests/table_loom.rs` and
/// `tests/contact_ring_loom.rs` compile those files themselves beside a `sync` of their own that
/// names loom's atomics instead, and model-check the real protocols.
mod sync {
    pub(crate) use std::hint::spin_loop;
    pub(crate) use std::sync::atomic::{AtomicU64, Ordering, fence};
}

use std::collections::BTreeSet;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crossbeam_channel::Sender;
use glam::DVec2;
use parking_lot::{Mutex, RwLock};
use serde::Serialize;

pub use message::{Contact, Message, Rest};
pub use shared::{Params, RuntimeConfig};
pub use table::{BallRecord, BallTable};
pub use wide_registers::WideRegisters;

use crate::engine::EngineError;
use crate::physics::{Ball, BallId, BallKind, Bodies, Effects, Field, Integrator, WallImpulses};
use crate::scene::Scene;
use contact_ring::ContactRing;
use monitor::{Inbox, Inboxes};
use shared::Shared;

struct Handle {
    id: BallId,
    kind: BallKind,
    slot: usize,
    inbox: Sender<Message>,
    /// Returns how many contact messages the ball was sent and never applied (see
    /// `ball_thread::run_ball`).
    thread: JoinHandle<u64>,
    started: Instant,
}

/// Totals of balls that have left, so that run figures stay whole after removals.
#[derive(Clone, Copy, Debug, Default)]
struct Retired {
    applied: u64,
    /// Contact messages sent to balls that left and never applied (those in flight when a ball is
    /// removed), so that every message sent is accounted for (see [`Runtime::settle`]).
    unapplied: u64,
    walls: WallImpulses,
}

struct Registry {
    /// Live balls in the order they were added.
    balls: Vec<Handle>,
    free_slots: BTreeSet<usize>,
    next_id: u32,
    /// Balls started so far: each start's number tells the monitor a ball put back with its own
    /// id (a grab and throw) from the ball it was, whose messages and ring it must forget.
    incarnations: u64,
    retired: Retired,
    /// Messages of ball threads that panicked, as reported when they were joined.
    panics: Vec<String>,
}

/// Figures the runtime measured about itself (the report's `runtime` section).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct RuntimeStats {
    /// Live balls.
    pub balls: usize,
    /// Seconds since the runtime started.
    pub seconds: f64,
    /// Update cycles per second achieved by the slowest ball.
    pub ball_rate_min: f64,
    /// Update cycles per second achieved by the median ball.
    pub ball_rate_median: f64,
    /// Passes the collision monitor made.
    pub monitor_passes: u64,
    /// Monitor passes per second since the runtime started.
    pub monitor_passes_per_second: f64,
    /// Mean wall time of one monitor pass, s (includes time it was preempted).
    pub monitor_pass_seconds: f64,
    /// The longest monitor pass, s.
    pub monitor_pass_seconds_max: f64,
    /// The longest span the monitor judged in one contact solve, s of the runtime's clock (one
    /// period while its solves are cheap; see `monitor::Monitor::judge_span`).
    pub monitor_span_max_seconds: f64,
    /// Contact messages (impulse + shift) the monitor sent.
    pub impulses_sent: u64,
    /// Contact messages the balls applied (equal to those sent once the runtime has settled).
    pub impulses_applied: u64,
    /// Contacts (ball pairs and walls) the monitor's solver found touching, summed over its
    /// passes.
    pub contacts_solved: u64,
    /// Those of them that got an impact (restitution) impulse.
    pub contact_impacts: u64,
    /// Solves that hit an iteration cap.
    pub solves_unconverged: u64,
    /// Candidate pairs the monitor's position passes pushed together, listed and separated
    /// (`physics::pushed_together`): landings of heavy and light balls.
    pub pairs_pushed_together: u64,
    /// Pairs the monitor added to its broad phase's for balls an impact or the position passes
    /// sent out of their circles (see `physics::ContactSolver::solve`).
    pub pairs_reached: u64,
    /// Wall time the runtime clock dropped because the monitor came too late to have watched it
    /// (a stalled process, a starved monitor), s.
    pub clock_dropped_seconds: f64,
    /// Ball cycles that stopped at the monitor's horizon short of the clock.
    pub horizon_waits: u64,
    /// The largest distance between where the monitor judged a ball to be at the end of a span
    /// and where the ball's next record put it then, m (its own integration of drag, attraction
    /// and its step sizes against the monitor's), over the run.
    pub judged_drift_max: f64,
    /// Contact responses applied after the instant they were for (see `Shared::responses_late`).
    pub responses_late: u64,
    /// Balls asleep after the monitor's last pass (at rest, left out of its solve and held still
    /// by their threads; see `physics::sleep`).
    pub balls_asleep: u64,
    /// How many times the monitor put a ball to sleep over the run.
    pub balls_slept: u64,
    /// How many times it woke one.
    pub balls_woken: u64,
    /// Messages that could not be delivered (their ball's thread was gone). Must be 0.
    pub messages_dropped: u64,
    /// Contact responses sent by the ball's channel because its ring was full (a ball starved of
    /// the CPU for more passes than the ring holds), or after such a response, in order (see
    /// `contact_ring`).
    pub responses_by_channel: u64,
    /// The ball threads' speed guard rail, as in lockstep: sub-steps whose speed was capped at
    /// `MAX_SPEED` (0 in every sane field).
    pub speed_limited: u64,
    /// The drag guard rail: cycles with a sub-step whose drag was too stiff even for the
    /// shortest sub-step (0 in every sane field).
    pub drag_limited: u64,
    /// The longest cycle a ball ran, simulated s (a stall makes one long).
    pub longest_cycle_seconds: f64,
    /// The sub-steps that cycle was split into.
    pub longest_cycle_substeps: u64,
    /// Ball threads that panicked.
    pub threads_panicked: u64,
    /// Their messages, as reported when they were joined.
    pub panics: Vec<String>,
    /// Attraction trees the monitor built and published (from `TREE_MIN_BALLS` balls on).
    pub tree_builds: u64,
    /// Tree builds per second since the runtime started.
    pub tree_builds_per_second: f64,
    /// Mean wall time of one build (table snapshot to publication), s.
    pub tree_build_seconds: f64,
    /// Passes that built no tree because every pooled snapshot was still held by a ball.
    pub tree_builds_skipped: u64,
    /// Tree snapshots the monitor allocated (its pool).
    pub tree_snapshots: usize,
    /// Ball cycles with attraction on that took the force from the tree (each ball reports its
    /// counts every 16 cycles, so this may lag by that).
    pub attraction_tree_cycles: u64,
    /// Ball cycles with attraction on that read the table directly (lagging as the last).
    pub attraction_direct_cycles: u64,
}

/// How a shutdown went.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShutdownReport {
    /// Ball threads joined.
    pub joined: usize,
    /// Messages of the ball threads that panicked over the run.
    pub panics: Vec<String>,
    /// Wall time the shutdown took, s.
    pub seconds: f64,
}

/// The running field. All methods take `&self` and may be called from any thread.
pub struct Runtime {
    shared: Arc<Shared>,
    registry: Mutex<Registry>,
    inboxes: Inboxes,
    monitor: Mutex<Option<JoinHandle<()>>>,
    started: Instant,
    /// The instant at which the runtime's clock read the instant the balls begin at, once the
    /// time their threads took to spawn was dropped: simulated time 0 on the wall clock.
    zero: Instant,
}

fn panic_message(payload: Box<dyn std::any::Any + Send>) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        s.to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "a panic with a non-text payload".into()
    }
}

impl Runtime {
    /// Starts a thread for every ball of `scene` and the collision monitor.
    pub fn start(scene: &Scene, config: RuntimeConfig) -> Result<Runtime, EngineError> {
        let config = RuntimeConfig { max_balls: config.max_balls.max(scene.balls.len()), ..config };
        let params =
            Params { field: scene.field, effects: scene.effects, integrator: scene.integrator, time_scale: 1.0 };
        let mut runtime = Runtime {
            shared: Arc::new(Shared::new(config, params)),
            registry: Mutex::new(Registry {
                balls: Vec::new(),
                free_slots: BTreeSet::new(),
                next_id: 0,
                incarnations: 0,
                retired: Retired::default(),
                panics: Vec::new(),
            }),
            inboxes: Arc::new(RwLock::new(vec![None; config.max_balls])),
            monitor: Mutex::new(None),
            started: Instant::now(),
            zero: Instant::now(),
        };
        // The instant the balls begin at and the monitor's first span starts from (see
        // `Runtime::insert`). Release: see `Shared::horizon`.
        let shared = &runtime.shared;
        let begin = shared.clock(Instant::now());
        shared.horizon.store(begin, Ordering::Release);
        for ball in &scene.balls {
            runtime.insert(*ball, Some(ball.id))?;
        }
        // No ball went past the horizon while the others' threads were spawned (a thousand take
        // most of a second on a busy machine): the time that took was not simulated, and the
        // clock drops it, as a pause does, so that the monitor's first span is one of its
        // periods and the whole field starts at one instant, with the caller's clock. The
        // monitor is not running yet, so this is the offset's only writer. Relaxed load: no
        // other thread writes it; Release store: see `Shared::clock_offset`.
        let zero = Instant::now();
        let spawned = shared.clock(zero).saturating_sub(begin);
        let offset = shared.clock_offset.load(Ordering::Relaxed);
        shared.clock_offset.store(offset + spawned, Ordering::Release);
        // The clock now reads `begin` at `zero`.
        runtime.zero = zero;
        let (shared, inboxes) = (runtime.shared.clone(), runtime.inboxes.clone());
        let monitor = std::thread::Builder::new()
            .name("collision-monitor".into())
            .spawn(move || monitor::run_monitor(shared, inboxes))
            .map_err(|e| EngineError::Spawn(e.to_string()))?;
        *runtime.monitor.lock() = Some(monitor);
        Ok(runtime)
    }

    /// The wall-clock instant of simulated time 0: the runtime's clock read the balls' starting
    /// instant then (the time their threads took to spawn dropped from it). An engine clock that
    /// starts here counts the balls' own time; one started when [`Runtime::start`] returned ran
    /// behind them by the monitor's spawn (about 20 µs).
    pub fn zero_instant(&self) -> Instant {
        self.zero
    }

    /// The configuration the runtime runs with.
    pub fn config(&self) -> RuntimeConfig {
        self.shared.config
    }

    /// The current parameters (field, effects, integrator, time scale).
    pub fn params(&self) -> Params {
        self.shared.params.read().clone()
    }

    /// Adds a ball (its `id` is replaced by a fresh one) and starts its thread.
    pub fn add_ball(&self, ball: Ball) -> Result<BallId, EngineError> {
        self.insert(ball, None)
    }

    /// Puts a ball back with its own id (one taken off with [`Runtime::remove_ball`]) and starts
    /// its thread; refused if a ball with that id is on the field.
    pub fn put_back(&self, ball: Ball) -> Result<BallId, EngineError> {
        if self.registry.lock().balls.iter().any(|h| h.id == ball.id) {
            return Err(EngineError::IdInUse(ball.id));
        }
        self.insert(ball, Some(ball.id))
    }

    fn insert(&self, mut ball: Ball, keep_id: Option<BallId>) -> Result<BallId, EngineError> {
        let field = self.params().field;
        if !(ball.is_finite()
            && ball.mass > 0.0
            && ball.diameter > 0.0
            && ball.diameter <= field.width.min(field.height))
        {
            return Err(EngineError::InvalidBall(format!("{ball:?}")));
        }
        let r = ball.radius();
        ball.position.x = ball.position.x.clamp(r, field.width - r);
        ball.position.y = ball.position.y.clamp(r, field.height - r);
        let mut reg = self.registry.lock();
        self.reap(&mut reg);
        let limit = self.shared.config.max_balls;
        if reg.balls.len() >= limit {
            return Err(EngineError::TooManyBalls { limit });
        }
        ball.id = keep_id.unwrap_or(BallId(reg.next_id));
        reg.next_id = reg.next_id.max(ball.id.0 + 1);
        let high = self.shared.high_water.load(Ordering::Relaxed);
        let slot = reg.free_slots.pop_first().unwrap_or(high);
        let gravity = self.params().effects.gravity.map_or(DVec2::ZERO, |g| g.g);
        let (tx, rx) = crossbeam_channel::unbounded();
        let contacts = Arc::new(ContactRing::new());
        {
            // Under the inboxes' write lock, which a monitor pass holds (read) from its read of the
            // table to the horizon it publishes: the ball begins at the horizon, the end of the
            // time judged so far, so its whole life is judged. Begun at the clock instead, it
            // would fall freely through the horizon the monitor had judged without it (up to
            // four periods: 4 cm/s under gravity, into whatever it rests on). Acquire: see
            // `Shared::horizon`.
            let mut inboxes = self.inboxes.write();
            let time = self.shared.horizon.load(Ordering::Acquire);
            // The slot is free and no thread owns it yet: the runtime writes the first record.
            // The spawn below hands the slot to the new thread (spawn happens-before the thread's
            // start).
            let record = BallRecord {
                slot,
                ball,
                applied: 0,
                updates: 0,
                wall_impulses: WallImpulses::default(),
                time,
                acceleration: gravity,
                asleep: false,
            };
            self.shared.table.write(slot, &record);
            if slot >= high {
                // Release: readers that Acquire the new high-water mark see the record just
                // written.
                self.shared.high_water.store(slot + 1, Ordering::Release);
            }
            reg.incarnations += 1;
            inboxes[slot] =
                Some(Inbox { commands: tx.clone(), contacts: contacts.clone(), incarnation: reg.incarnations });
        }
        let shared = self.shared.clone();
        let spawned = std::thread::Builder::new()
            .name(format!("ball-{}", ball.id))
            .spawn(move || ball_thread::run_ball(shared, slot, ball, rx, contacts));
        match spawned {
            Ok(thread) => {
                reg.balls.push(Handle {
                    id: ball.id,
                    kind: ball.kind,
                    slot,
                    inbox: tx,
                    thread,
                    started: Instant::now(),
                });
                Ok(ball.id)
            }
            Err(e) => {
                self.inboxes.write()[slot] = None;
                self.shared.table.clear(slot);
                reg.free_slots.insert(slot);
                Err(EngineError::Spawn(e.to_string()))
            }
        }
    }

    /// Joins the threads of balls that died (panicked), reports them, and frees their slots.
    fn reap(&self, reg: &mut Registry) {
        let mut k = 0;
        while k < reg.balls.len() {
            if reg.balls[k].thread.is_finished() {
                let h = reg.balls.remove(k);
                self.finish(reg, h, false);
            } else {
                k += 1;
            }
        }
    }

    /// Stops (unless already dead), joins and forgets one ball.
    /// Returns the ball as its thread last published it (None if its slot was already cleared: it
    /// panicked).
    fn finish(&self, reg: &mut Registry, h: Handle, stop: bool) -> Option<Ball> {
        // No new contact message can be sent once the inbox is gone from the monitor's list.
        self.inboxes.write()[h.slot] = None;
        if stop {
            let _ = h.inbox.send(Message::Stop);
        }
        drop(h.inbox);
        let joined = h.thread.join();
        let last = self.shared.table.read(h.slot);
        if let Some(last) = &last {
            reg.retired.applied += last.applied;
            let w = &mut reg.retired.walls;
            w.left += last.wall_impulses.left;
            w.right += last.wall_impulses.right;
            w.bottom += last.wall_impulses.bottom;
            w.top += last.wall_impulses.top;
        }
        match joined {
            Ok(unapplied) => reg.retired.unapplied += unapplied,
            Err(payload) => {
                let message = format!("ball {}: {}", h.id, panic_message(payload));
                log::error!("a ball thread panicked: {message}");
                reg.panics.push(message);
            }
        }
        // The thread is joined: the runtime is the slot's only writer again.
        self.shared.table.clear(h.slot);
        reg.free_slots.insert(h.slot);
        last.map(|r| r.ball)
    }

    /// Removes a ball by id, joins its thread and returns the ball as it last was.
    pub fn remove_ball(&self, id: BallId) -> Result<Ball, EngineError> {
        let mut reg = self.registry.lock();
        let k = reg.balls.iter().position(|h| h.id == id).ok_or(EngineError::NoSuchBall(id))?;
        let h = reg.balls.remove(k);
        // A thread that panicked has cleared its slot: the ball is gone either way.
        self.finish(&mut reg, h, true).ok_or(EngineError::NoSuchBall(id))
    }

    /// Removes the most recently added ball that is not the key ball and returns it.
    pub fn remove_last(&self) -> Option<Ball> {
        let mut reg = self.registry.lock();
        let k = reg.balls.iter().rposition(|h| h.kind != BallKind::Key)?;
        let h = reg.balls.remove(k);
        self.finish(&mut reg, h, true)
    }

    /// The id of the key ball, if there is one.
    pub fn key_ball(&self) -> Option<BallId> {
        self.registry.lock().balls.iter().find(|h| h.kind == BallKind::Key).map(|h| h.id)
    }

    /// Sends `message` to ball `id`'s thread.
    fn send_to(&self, id: BallId, message: Message) -> Result<(), EngineError> {
        let reg = self.registry.lock();
        let h = reg.balls.iter().find(|h| h.id == id).ok_or(EngineError::NoSuchBall(id))?;
        // Fails only if the thread is gone (it panicked); the next reap reports it.
        let _ = h.inbox.send(message);
        Ok(())
    }

    fn send_to_key(&self, message: Message) {
        let reg = self.registry.lock();
        if let Some(h) = reg.balls.iter().find(|h| h.kind == BallKind::Key) {
            let _ = h.inbox.send(message);
        }
    }

    /// Sets the pull (N) on the key ball; zero releases it.
    pub fn set_pull(&self, force: DVec2) {
        self.send_to_key(Message::Pull(force));
    }

    /// Sets ball `id`'s mass, kg, in place (the ball keeps its id, position and velocity).
    pub fn set_mass(&self, id: BallId, mass: f64) -> Result<(), EngineError> {
        if !(mass.is_finite() && mass > 0.0) {
            return Err(EngineError::InvalidMass(mass));
        }
        self.send_to(id, Message::SetMass(mass))
    }

    /// Sets ball `id`'s velocity (the mouse's throw): the only absolute change a ball accepts.
    pub fn set_velocity(&self, id: BallId, velocity: DVec2) -> Result<(), EngineError> {
        if !velocity.is_finite() {
            return Err(EngineError::InvalidVelocity(velocity.x, velocity.y));
        }
        self.send_to(id, Message::Throw(velocity))
    }

    /// Turns effects on and off: every ball thread and the monitor follow from their next cycle.
    pub fn set_effects(&self, effects: Effects) {
        self.shared.update_params(|p| p.effects = effects);
    }

    /// The integrator every ball thread uses from its next cycle.
    pub fn set_integrator(&self, integrator: Integrator) {
        self.shared.update_params(|p| p.integrator = integrator);
    }

    /// Restitution of the walls and of ball–ball collisions (if on), clamped to [0, 1].
    pub fn set_restitution(&self, walls: f64, collisions: f64) {
        self.shared.update_params(|p| {
            p.field.restitution = walls.clamp(0.0, 1.0);
            if let Some(c) = &mut p.effects.collisions {
                c.restitution = collisions.clamp(0.0, 1.0);
            }
        });
    }

    /// Simulated seconds per wall-clock second (slow motion below 1).
    pub fn set_time_scale(&self, scale: f64) {
        if scale.is_finite() && scale >= 0.0 {
            self.shared.update_params(|p| p.time_scale = scale);
        }
    }

    /// A new field (size, wall restitution), followed from the next cycle.
    pub fn set_field(&self, field: Field) {
        self.shared.update_params(|p| p.field = field);
    }

    /// Stops simulated time: the monitor judges nothing more and the clock stands; every ball
    /// catches up to the monitor's horizon and stands there (see [`Runtime::settle`]).
    pub fn pause(&self) {
        // Relaxed: see the ball loop; the flag carries no data.
        self.shared.paused.store(true, Ordering::Relaxed);
    }

    /// Lets simulated time run again after [`Runtime::pause`].
    pub fn resume(&self) {
        self.shared.paused.store(false, Ordering::Relaxed);
    }

    /// Pauses and waits (up to `timeout`) until every ball has caught up to the monitor's
    /// horizon with every contact message applied: the table is then one instant for all balls.
    /// Returns whether that happened in time (a starved machine may take a while).
    pub fn settle(&self, timeout: Duration) -> bool {
        self.pause();
        wait_until(timeout, || {
            // Acquire: see `Shared::horizon` (nothing rides on it here but the value).
            let horizon = self.shared.horizon.load(Ordering::Acquire);
            let records = self.snapshot();
            let sent = self.shared.contact_messages_sent.load(Ordering::Relaxed);
            let retired = self.registry.lock().retired;
            let applied = retired.applied + retired.unapplied + records.iter().map(|r| r.applied).sum::<u64>();
            sent == applied && records.iter().all(|r| r.time == horizon)
        })
    }

    /// Waits (up to `timeout`) until the monitor's horizon is at or past the clock as it reads
    /// now: every contact up to this instant judged. A monitor running late (a loaded machine)
    /// leaves its horizon behind the clock, and a pause then stands the balls at that horizon,
    /// before the instant the caller ran the runtime to: on a CI machine a ball dropped on
    /// another was read 5 ms after the impact, still falling, its monitor more than 5 ms late.
    /// Returns at once when paused (the horizon stands), and whether it caught up.
    pub fn catch_up(&self, timeout: Duration) -> bool {
        if self.is_paused() {
            return true;
        }
        let target = self.shared.clock(Instant::now());
        // Acquire: see `Shared::horizon` (only the value is read here).
        wait_until(timeout, || self.shared.horizon.load(Ordering::Acquire) >= target)
    }

    /// The runtime's clock now, s (see `Shared::clock`: wall time less what it dropped).
    pub fn clock_seconds(&self) -> f64 {
        self.shared.clock(Instant::now()) as f64 * 1e-9
    }

    /// The monitor's horizon, on the runtime's clock, s: no ball integrates past it; a paused
    /// runtime's balls catch up to it and stand there (see [`Runtime::settle`]).
    pub fn horizon_seconds(&self) -> f64 {
        // Acquire: see `Shared::horizon` (only the value is read here).
        self.shared.horizon.load(Ordering::Acquire) as f64 * 1e-9
    }

    /// Seconds of wall time the runtime's clock dropped (a stall of the whole process is not
    /// simulated: see `Shared::clock`).
    pub fn clock_dropped_seconds(&self) -> f64 {
        // Relaxed: a figure; nothing else is read through it.
        self.shared.clock_dropped_ns.load(Ordering::Relaxed) as f64 * 1e-9
    }

    /// Whether the runtime is paused.
    pub fn is_paused(&self) -> bool {
        self.shared.paused.load(Ordering::Relaxed)
    }

    /// Number of live balls.
    pub fn ball_count(&self) -> usize {
        self.registry.lock().balls.len()
    }

    /// Ids of the live balls, in the order they were added.
    pub fn ball_ids(&self) -> Vec<BallId> {
        self.registry.lock().balls.iter().map(|h| h.id).collect()
    }

    /// Ball threads still running (not finished), for leak checks.
    pub fn live_threads(&self) -> usize {
        self.registry.lock().balls.iter().filter(|h| !h.thread.is_finished()).count()
    }

    /// The table read now: a consistent record per ball (not one instant for all balls).
    pub fn snapshot(&self) -> Vec<BallRecord> {
        let mut out = Vec::new();
        self.shared.table.read_all(self.shared.high_water.load(Ordering::Acquire), &mut out);
        out
    }

    /// Reads the table into `out` (cleared first), reusing its memory: the renderer's path.
    pub fn snapshot_into(&self, out: &mut Vec<BallRecord>) {
        self.shared.table.read_all(self.shared.high_water.load(Ordering::Acquire), out);
    }

    /// The snapshot as a set of bodies, sorted by id.
    pub fn bodies(&self) -> Bodies {
        let mut balls: Vec<Ball> = self.snapshot().into_iter().map(|r| r.ball).collect();
        balls.sort_by_key(|b| b.id);
        Bodies::from_balls(&balls)
    }

    /// Impulse each wall took so far: in the contacts the monitor solved, and in the bounces of
    /// live and removed balls' own threads (collisions off).
    pub fn wall_impulses(&self) -> WallImpulses {
        let mut total = self.registry.lock().retired.walls;
        total.add_all(&self.shared.monitor_wall_impulses());
        self.snapshot().iter().fold(total, |mut w, r| {
            w.left += r.wall_impulses.left;
            w.right += r.wall_impulses.right;
            w.bottom += r.wall_impulses.bottom;
            w.top += r.wall_impulses.top;
            w
        })
    }

    /// The runtime's figures now (joins and reports ball threads that panicked meanwhile).
    pub fn stats(&self) -> RuntimeStats {
        let now = Instant::now();
        let records = self.snapshot();
        let mut reg = self.registry.lock();
        self.reap(&mut reg);
        let mut rates: Vec<f64> = reg
            .balls
            .iter()
            .filter_map(|h| {
                let r = records.iter().find(|r| r.slot == h.slot && r.ball.id == h.id)?;
                let secs = (now - h.started).as_secs_f64();
                (secs > 0.0).then(|| r.updates as f64 / secs)
            })
            .collect();
        rates.sort_by(f64::total_cmp);
        let seconds = (now - self.started).as_secs_f64();
        let passes = self.shared.monitor_passes.load(Ordering::Relaxed);
        let builds = self.shared.tree_builds.load(Ordering::Relaxed);
        let longest = self.shared.longest_cycle.load(Ordering::Relaxed);
        RuntimeStats {
            balls: reg.balls.len(),
            seconds,
            ball_rate_min: rates.first().copied().unwrap_or(0.0),
            ball_rate_median: rates.get(rates.len() / 2).copied().unwrap_or(0.0),
            monitor_passes: passes,
            monitor_passes_per_second: passes as f64 / seconds.max(1e-9),
            monitor_pass_seconds: self.shared.monitor_busy_ns.load(Ordering::Relaxed) as f64 * 1e-9
                / passes.max(1) as f64,
            impulses_sent: self.shared.contact_messages_sent.load(Ordering::Relaxed),
            impulses_applied: reg.retired.applied + records.iter().map(|r| r.applied).sum::<u64>(),
            monitor_pass_seconds_max: self.shared.monitor_busy_max_ns.load(Ordering::Relaxed) as f64 * 1e-9,
            monitor_span_max_seconds: self.shared.monitor_span_max_ns.load(Ordering::Relaxed) as f64 * 1e-9,
            contacts_solved: self.shared.contacts_solved.load(Ordering::Relaxed),
            contact_impacts: self.shared.contact_impacts.load(Ordering::Relaxed),
            pairs_pushed_together: self.shared.pairs_pushed_together.load(Ordering::Relaxed),
            pairs_reached: self.shared.pairs_reached.load(Ordering::Relaxed),
            solves_unconverged: self.shared.solves_unconverged.load(Ordering::Relaxed),
            clock_dropped_seconds: self.shared.clock_dropped_ns.load(Ordering::Relaxed) as f64 * 1e-9,
            horizon_waits: self.shared.horizon_waits.load(Ordering::Relaxed),
            judged_drift_max: f64::from_bits(self.shared.judged_drift_max.load(Ordering::Relaxed)),
            responses_late: self.shared.responses_late.load(Ordering::Relaxed),
            balls_asleep: self.shared.balls_asleep.load(Ordering::Relaxed),
            balls_slept: self.shared.balls_slept.load(Ordering::Relaxed),
            balls_woken: self.shared.balls_woken.load(Ordering::Relaxed),
            messages_dropped: self.shared.messages_dropped.load(Ordering::Relaxed),
            responses_by_channel: self.shared.responses_by_channel.load(Ordering::Relaxed),
            speed_limited: self.shared.speed_limited.load(Ordering::Relaxed),
            drag_limited: self.shared.drag_limited.load(Ordering::Relaxed),
            longest_cycle_seconds: (longest >> 16) as f64 * 1e-9,
            longest_cycle_substeps: longest & 0xFFFF,
            threads_panicked: self.shared.panicked.load(Ordering::Relaxed),
            panics: reg.panics.clone(),
            tree_builds: builds,
            tree_builds_per_second: builds as f64 / seconds.max(1e-9),
            tree_build_seconds: self.shared.tree_build_ns.load(Ordering::Relaxed) as f64 * 1e-9 / builds.max(1) as f64,
            tree_builds_skipped: self.shared.tree_builds_skipped.load(Ordering::Relaxed),
            tree_snapshots: self.shared.tree_snapshots.load(Ordering::Relaxed),
            attraction_tree_cycles: self.shared.attraction_tree_cycles.load(Ordering::Relaxed),
            attraction_direct_cycles: self.shared.attraction_direct_cycles.load(Ordering::Relaxed),
        }
    }

    /// Test hook (feature `test-hooks`): makes a ball's thread panic, to check that the panic is
    /// reported and the others keep running.
    #[cfg(feature = "test-hooks")]
    pub fn inject_panic(&self, id: BallId) -> Result<(), EngineError> {
        self.send_to(id, Message::Panic)
    }

    /// Test hook (feature `test-hooks`): stalls a ball's thread for `duration`, as if the machine
    /// had stalled it (see [`Message::Stall`]).
    #[cfg(feature = "test-hooks")]
    pub fn inject_stall(&self, id: BallId, duration: Duration) -> Result<(), EngineError> {
        self.send_to(id, Message::Stall(duration))
    }

    /// Stops every thread and joins it: the monitor first (so no message is sent to a ball that
    /// is stopping), then all balls are told to stop at once and joined.
    pub fn shutdown(&self) -> ShutdownReport {
        let t0 = Instant::now();
        self.shared.monitor_running.store(false, Ordering::Release);
        if let Some(m) = self.monitor.lock().take()
            && let Err(payload) = m.join()
        {
            log::error!("the collision monitor panicked: {}", panic_message(payload));
        }
        let mut reg = self.registry.lock();
        let balls = std::mem::take(&mut reg.balls);
        for h in &balls {
            let _ = h.inbox.send(Message::Stop);
        }
        let joined = balls.len();
        for h in balls {
            self.finish(&mut reg, h, false);
        }
        ShutdownReport { joined, panics: reg.panics.clone(), seconds: t0.elapsed().as_secs_f64() }
    }
}

impl Drop for Runtime {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// Polls `done` every millisecond until it holds or `timeout` has passed; returns whether it held
/// (see [`Runtime::settle`]).
fn wait_until(timeout: Duration, mut done: impl FnMut() -> bool) -> bool {
    let end = Instant::now() + timeout;
    while Instant::now() < end {
        if done() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    done()
}
