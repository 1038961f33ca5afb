//! The shared ball table: one slot per ball, one writer per slot, readers that never block.
//!
//! Each slot is a *latched* sequence lock (Linux's `seqcount_latch`) over two copies of the
//! record, all atomic words — no `unsafe` anywhere: a racing read is never undefined behaviour,
//! only possibly inconsistent, and the sequence number tells the reader when, so it retries.
//!
//! Why two copies: with a plain seqlock a reader must wait while a write is in progress, and on a
//! loaded machine with a thousand ball threads the writer can be preempted in the middle of its
//! write for many milliseconds — the monitor and the renderer would spin all that time. With the
//! latch, the writer updates the copies one after the other and `seq` always points readers at
//! the copy that is *not* being written, so a reader never waits for a stalled writer; it retries
//! only if the writer finished a copy and moved on while it was reading.
//!
//! Protocol:
//! - **writer** (the ball's own thread, the only one): `seq ← s + 1` (odd: readers use copy 1),
//!   release fence, write copy 0; `seq ← s + 2` with a release store (even: readers use copy 0),
//!   release fence, write copy 1.
//! - **reader** (monitor, renderer, other balls): `s1 ← seq` (acquire); read copy `s1 & 1`
//!   (relaxed); acquire fence; `s2 ← seq` (relaxed); if `s1 ≠ s2`, retry.
//!
//! Orderings: each release fence keeps the copy writes after it from becoming visible before the
//! `seq` store before it, so a reader that sees any word of a copy being rewritten also sees `seq`
//! moved on when it re-reads it after its acquire fence, and retries. The release store of
//! `s + 2` publishes the finished copy 0 to readers that acquire that value (copy 1 is published
//! by the next write's odd store and its fence in the same way). Together: if both loads of `seq`
//! agree, every word read belongs to one write — no torn entry (x of one step with y of another).

use glam::DVec2;

// The atomics come from the parent module: std's here, loom's when `tests/table_loom.rs` compiles
// this very file into a loom model (it puts its own `sync` beside it).
use super::sync::{AtomicU64, Ordering, fence, spin_loop};

use crate::physics::{Ball, BallId, BallKind, WallImpulses};

/// Words in a slot besides the sequence number.
const WORDS: usize = 16;
// Word indices.
const W_ID: usize = 0; // id + 1 with bit 63 set for the key ball, bit 62 while it sleeps; 0 = empty slot
const W_X: usize = 1;
const W_Y: usize = 2;
const W_VX: usize = 3;
const W_VY: usize = 4;
const W_MASS: usize = 5;
const W_DIAMETER: usize = 6;
const W_APPLIED: usize = 7; // monitor messages this ball has applied
const W_UPDATES: usize = 8; // cycles this ball has completed
const W_WALL: usize = 9; // 9..13: wall impulses left, right, bottom, top
const W_TIME: usize = 13; // the runtime clock instant the state is of (see `Shared::clock`)
const W_AX: usize = 14; // the ball's uniform acceleration (gravity + its pull / mass)
const W_AY: usize = 15;

const KEY_BIT: u64 = 1 << 63;
const ASLEEP_BIT: u64 = 1 << 62;

/// What the table says about one ball at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BallRecord {
    /// The table slot the ball's thread publishes to.
    pub slot: usize,
    /// The ball's state at `time`.
    pub ball: Ball,
    /// Monitor messages (impulses/shifts) this ball has applied so far.
    pub applied: u64,
    /// Update cycles this ball has completed.
    pub updates: u64,
    /// Impulse each wall took from this ball so far.
    pub wall_impulses: WallImpulses,
    /// The instant this state is of, on the runtime's clock (ns; see [`crate::engine::runtime`]): the
    /// monitor extrapolates every ball from its own instant to a common one.
    pub time: u64,
    /// The ball's uniform acceleration (m/s²: gravity, plus the pull over the mass for the key
    /// ball), for that extrapolation.
    pub acceleration: DVec2,
    /// Whether the ball sleeps at `time` (the monitor put it to sleep: its thread holds it still;
    /// see `physics::sleep`).
    pub asleep: bool,
}

/// One latched seqlock over `N` words (the table uses `N = WORDS`; the loom model also checks it
/// with fewer words, so that it can afford more writes and readers).
#[repr(align(128))] // one slot per pair of cache lines: writers of neighbouring slots don't false-share
pub(crate) struct Slot<const N: usize> {
    seq: AtomicU64,
    copies: [[AtomicU64; N]; 2],
}

impl<const N: usize> Slot<N> {
    pub(crate) fn new() -> Self {
        Slot { seq: AtomicU64::new(0), copies: std::array::from_fn(|_| std::array::from_fn(|_| AtomicU64::new(0))) }
    }

    /// The latch write (see the module comment). Single writer only.
    pub(crate) fn write_words(&self, words: &[u64; N]) {
        // Only this thread writes `seq`, so a relaxed load of it is exact.
        let seq = self.seq.load(Ordering::Relaxed);
        for (k, copy) in self.copies.iter().enumerate() {
            // k = 0: odd, readers move to copy 1; k = 1: even, readers move to copy 0. Release
            // publishes the copy finished just before (for k = 1) to readers acquiring this value.
            self.seq.store(seq.wrapping_add(1 + k as u64), Ordering::Release);
            // Keeps the stores below from being seen before the `seq` store above.
            fence(Ordering::Release);
            for (w, v) in copy.iter().zip(words) {
                w.store(*v, Ordering::Relaxed);
            }
        }
    }

    pub(crate) fn read_words(&self) -> [u64; N] {
        loop {
            let seq1 = self.seq.load(Ordering::Acquire);
            let copy = &self.copies[(seq1 & 1) as usize];
            let mut raw = [0u64; N];
            for (r, w) in raw.iter_mut().zip(copy) {
                *r = w.load(Ordering::Relaxed);
            }
            // Keeps the data loads above from being reordered after the second `seq` load.
            fence(Ordering::Acquire);
            if self.seq.load(Ordering::Relaxed) == seq1 {
                return raw;
            }
            spin_loop();
        }
    }
}

/// The table: a fixed number of slots, allocated once.
pub struct BallTable {
    slots: Box<[Slot<WORDS>]>,
}

/// Compile-time check: the table is read by every thread and written by each ball's own (inside
/// `Shared`), so it is `Send` and `Sync`; a record is copied out to any thread, so it is `Send`.
const _: () = {
    const fn shared<T: Send + Sync>() {}
    const fn send<T: Send>() {}
    shared::<BallTable>();
    send::<BallRecord>();
};

impl BallTable {
    /// A table of `capacity` empty slots.
    pub fn new(capacity: usize) -> Self {
        BallTable { slots: (0..capacity).map(|_| Slot::new()).collect() }
    }

    /// The number of slots.
    pub fn capacity(&self) -> usize {
        self.slots.len()
    }

    /// Publishes the state of the ball in `slot`. Only that ball's own thread may call this (and
    /// the runtime, to clear a slot after that thread has been joined).
    pub fn write(&self, slot: usize, record: &BallRecord) {
        let b = &record.ball;
        let wi = &record.wall_impulses;
        let mut w = [0u64; WORDS];
        w[W_ID] = (b.id.0 as u64 + 1)
            | if b.kind == BallKind::Key { KEY_BIT } else { 0 }
            | if record.asleep { ASLEEP_BIT } else { 0 };
        w[W_X] = b.position.x.to_bits();
        w[W_Y] = b.position.y.to_bits();
        w[W_VX] = b.velocity.x.to_bits();
        w[W_VY] = b.velocity.y.to_bits();
        w[W_MASS] = b.mass.to_bits();
        w[W_DIAMETER] = b.diameter.to_bits();
        w[W_APPLIED] = record.applied;
        w[W_UPDATES] = record.updates;
        for (k, v) in [wi.left, wi.right, wi.bottom, wi.top].into_iter().enumerate() {
            w[W_WALL + k] = v.to_bits();
        }
        w[W_TIME] = record.time;
        w[W_AX] = record.acceleration.x.to_bits();
        w[W_AY] = record.acceleration.y.to_bits();
        self.slots[slot].write_words(&w);
    }

    /// Marks `slot` empty. Same single-writer rule as [`BallTable::write`].
    pub fn clear(&self, slot: usize) {
        self.slots[slot].write_words(&[0; WORDS]);
    }

    /// Reads a consistent record of `slot`, or `None` if the slot is empty. Never blocks the
    /// writer and never waits for it: it retries only if a write completed while it read.
    pub fn read(&self, slot: usize) -> Option<BallRecord> {
        let raw = self.slots[slot].read_words();
        if raw[W_ID] == 0 {
            return None;
        }
        let f = |k: usize| f64::from_bits(raw[k]);
        let kind = if raw[W_ID] & KEY_BIT != 0 { BallKind::Key } else { BallKind::Ball };
        Some(BallRecord {
            slot,
            ball: Ball {
                id: BallId(((raw[W_ID] & !(KEY_BIT | ASLEEP_BIT)) - 1) as u32),
                kind,
                position: DVec2::new(f(W_X), f(W_Y)),
                velocity: DVec2::new(f(W_VX), f(W_VY)),
                mass: f(W_MASS),
                diameter: f(W_DIAMETER),
            },
            applied: raw[W_APPLIED],
            updates: raw[W_UPDATES],
            wall_impulses: WallImpulses {
                left: f(W_WALL),
                right: f(W_WALL + 1),
                bottom: f(W_WALL + 2),
                top: f(W_WALL + 3),
            },
            time: raw[W_TIME],
            acceleration: DVec2::new(f(W_AX), f(W_AY)),
            asleep: raw[W_ID] & ASLEEP_BIT != 0,
        })
    }

    /// Reads every occupied slot below `high_water` into `out` (cleared first), in slot order.
    pub fn read_all(&self, high_water: usize, out: &mut Vec<BallRecord>) {
        out.clear();
        for slot in 0..high_water.min(self.slots.len()) {
            if let Some(r) = self.read(slot) {
                out.push(r);
            }
        }
    }
}
