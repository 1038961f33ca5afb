//! The collision-monitor thread: reads the table, finds touching pairs, and sends each ball its
//! share of the impulse and of the separation as messages. With attraction on in a field of
//! [`TREE_MIN_BALLS`] balls or more it also builds the field's Barnes–Hut tree from the same read
//! and publishes it to the ball threads (`attraction_tree.rs`). It never writes a ball's state.

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Instant;

use crossbeam_channel::Sender;
use parking_lot::RwLock;

use super::attraction_tree::TreePublisher;
use super::message::Message;
use super::shared::Shared;
use super::table::BallRecord;
use crate::physics::{AttractionMethod, BallId, Bodies, BroadPhase, ContactBody, TREE_MIN_BALLS, contact_ball_ball};

/// The ball inboxes by slot. Written (write lock) by the runtime when a ball is added or removed;
/// read (read lock) by the monitor for the whole sending part of a pass, so that once a removal
/// has cleared a slot no message can be sent to the departing ball.
pub(crate) type Inboxes = Arc<RwLock<Vec<Option<Sender<Message>>>>>;

/// Contact messages sent to the ball in a slot, and to which ball (a slot is reused by a later
/// ball, whose own counters start from zero).
#[derive(Clone, Copy, Default)]
struct Sent {
    id: Option<BallId>,
    count: u64,
}

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

pub(crate) fn run_monitor(shared: Arc<Shared>, inboxes: Inboxes) {
    raise_priority();
    let period = shared.config.monitor_period;
    // How far back a collision may be replayed: about one ball cycle of motion.
    let cycle = shared.config.ball_cycle.as_secs_f64();
    let mut records: Vec<BallRecord> = Vec::new();
    let mut bodies = Bodies::new();
    let mut broad_phase = BroadPhase::new();
    let mut pairs: Vec<(u32, u32)> = Vec::new();
    let mut sent: Vec<Sent> = vec![Sent::default(); shared.table.capacity()];
    let mut trees = TreePublisher::default();
    // The parameters change rarely (panel, hotkeys): re-read them only when their generation
    // moved, as the ball threads do. Acquire pairs with the Release increment in
    // `Shared::update_params`: seeing a generation means the read lock returns what was written
    // before it.
    let mut generation = shared.params_generation.load(Ordering::Acquire);
    let mut params = shared.params.read().clone();
    let mut next = Instant::now();
    // Acquire/Release on the flag: the runtime clears it and then joins; nothing else rides on it.
    while shared.monitor_running.load(Ordering::Acquire) {
        let pass_start = Instant::now();
        let g = shared.params_generation.load(Ordering::Acquire);
        if g != generation {
            generation = g;
            params = shared.params.read().clone();
        }
        // Paused means everything stands still, contacts included (Relaxed: no data rides on it).
        let paused = shared.paused.load(Ordering::Relaxed);
        // Acquire: pairs with the runtime's Release store after it wrote a new slot's first record.
        let high = shared.high_water.load(Ordering::Acquire);
        // Attraction by tree needs at least TREE_MIN_BALLS balls, so fewer occupied slots than
        // that rule it out without reading the table.
        let attraction = params.effects.attraction.filter(|_| high >= TREE_MIN_BALLS);
        if !paused && (params.effects.collisions.is_some() || attraction.is_some()) {
            shared.table.read_all(high, &mut records);
        }
        // The tree first: the balls get the fresher field sooner. Paused, the published tree
        // stays (no ball advances).
        match attraction {
            _ if paused => {}
            Some(att) if AttractionMethod::choose(records.len(), &att) == AttractionMethod::Tree => {
                // Rebuilt once the balls have moved on since the last build (see `is_fresh`).
                if !trees.is_fresh(&records, &att) {
                    let t0 = Instant::now();
                    if trees.publish(&records, &att, &shared.attraction_tree) {
                        shared.tree_builds.fetch_add(1, Ordering::Relaxed);
                        shared.tree_build_ns.fetch_add(t0.elapsed().as_nanos() as u64, Ordering::Relaxed);
                    } else {
                        shared.tree_builds_skipped.fetch_add(1, Ordering::Relaxed);
                    }
                    shared.tree_snapshots.store(trees.pool_size(), Ordering::Relaxed);
                }
            }
            _ => trees.withdraw(&shared.attraction_tree),
        }
        if let (Some(collisions), false) = (params.effects.collisions, paused) {
            bodies.clear();
            for r in &records {
                bodies.push(r.ball);
            }
            broad_phase.update(&bodies.position, &bodies.radius, params.field.width, params.field.height);
            pairs.clear();
            broad_phase.for_each_touching_pair(|i, j| pairs.push((i as u32, j as u32)));
            let inboxes = inboxes.read();
            // A ball has a message in flight when the monitor sent it more than the table says it
            // applied. Its state in this snapshot is then stale with respect to that message, and
            // a new impulse computed from it could be a second impulse for the same contact (the
            // original design's "balls stick together" bug): such pairs wait for the next pass.
            let pending = |r: &BallRecord, sent: &mut [Sent]| {
                let s = &mut sent[r.slot];
                if s.id != Some(r.ball.id) {
                    *s = Sent { id: Some(r.ball.id), count: 0 };
                }
                s.count > r.applied
            };
            for &(i, j) in &pairs {
                let (ra, rb) = (&records[i as usize], &records[j as usize]);
                if pending(ra, &mut sent) || pending(rb, &mut sent) {
                    shared.contacts_deferred.fetch_add(1, Ordering::Relaxed);
                    continue;
                }
                let body = |r: &BallRecord| ContactBody {
                    id: r.ball.id,
                    position: r.ball.position,
                    velocity: r.ball.velocity,
                    inverse_mass: 1.0 / r.ball.mass,
                    radius: r.ball.radius(),
                };
                let Some(c) = contact_ball_ball(&body(ra), &body(rb), collisions.restitution, cycle) else { continue };
                // Both halves or neither: a ball being removed gets nothing, and neither does its
                // partner, so the pair's momentum stays whole.
                let inbox = |r: &BallRecord| inboxes.get(r.slot).and_then(|s| s.as_ref());
                let (Some(tx_a), Some(tx_b)) = (inbox(ra), inbox(rb)) else { continue };
                for (tx, r, dv, dx) in
                    [(tx_a, ra, c.velocity_change_a, c.shift_a), (tx_b, rb, c.velocity_change_b, c.shift_b)]
                {
                    // Fails only if the ball's thread is gone (it panicked): counted as dropped.
                    if tx.send(Message::Contact { dv, dx }).is_ok() {
                        sent[r.slot].count += 1;
                        shared.contact_messages_sent.fetch_add(1, Ordering::Relaxed);
                    } else {
                        shared.messages_dropped.fetch_add(1, Ordering::Relaxed);
                    }
                }
            }
        }
        shared.monitor_passes.fetch_add(1, Ordering::Relaxed);
        shared.monitor_busy_ns.fetch_add(pass_start.elapsed().as_nanos() as u64, Ordering::Relaxed);
        next += period;
        let now = Instant::now();
        if next > now {
            std::thread::sleep(next - now);
        } else {
            next = now;
        }
    }
}
