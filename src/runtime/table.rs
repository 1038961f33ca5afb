//! The shared ball table: one slot per ball, one writer per slot, readers that never block.
//!
//! Each slot is a sequence lock over atomic words (no `unsafe` anywhere: every word is an
//! `AtomicU64`, so a racing read is never undefined behaviour, only possibly inconsistent — and
//! the sequence number tells the reader when it was, so it retries).
//!
//! Protocol (Boehm, "Can seqlocks get along with programming language memory models?", 2012):
//! - **writer** (the ball's own thread, the only one): `seq ← seq + 1` (odd: write in progress),
//!   a release fence, the data words with relaxed stores, then `seq ← seq + 2` with a release
//!   store (even: stable).
//! - **reader** (monitor, renderer, other balls): load `seq` with acquire; if odd, retry; load the
//!   data words relaxed; an acquire fence; load `seq` relaxed again; if it changed, retry.
//!
//! Why these orderings: the release fence after the odd store keeps the data stores from being
//! seen before the odd `seq` (so a reader that read any new data word then sees `seq` changed);
//! the release store of the even `seq` publishes all data stores before it to a reader whose
//! acquire load sees it; the reader's acquire fence keeps its data loads from moving after its
//! second `seq` load. Together: if both loads of `seq` return the same even value, every data
//! word read belongs to that one write — no torn entry (x of one step with y of another).

use std::sync::atomic::{AtomicU64, Ordering, fence};

use glam::DVec2;

use crate::physics::{Ball, BallId, BallKind, WallImpulses};

/// Words in a slot besides the sequence number.
const WORDS: usize = 13;
// Word indices.
const W_ID: usize = 0; // id + 1 with bit 63 set for the key ball; 0 = empty slot
const W_X: usize = 1;
const W_Y: usize = 2;
const W_VX: usize = 3;
const W_VY: usize = 4;
const W_MASS: usize = 5;
const W_DIAMETER: usize = 6;
const W_APPLIED: usize = 7; // monitor messages this ball has applied
const W_UPDATES: usize = 8; // cycles this ball has completed
const W_WALL: usize = 9; // 9..13: wall impulses left, right, bottom, top

const KEY_BIT: u64 = 1 << 63;

/// What the table says about one ball at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BallRecord {
    pub slot: usize,
    pub ball: Ball,
    /// Monitor messages (impulses/shifts) this ball has applied so far.
    pub applied: u64,
    /// Update cycles this ball has completed.
    pub updates: u64,
    /// Impulse each wall took from this ball so far.
    pub wall_impulses: WallImpulses,
}

#[repr(align(128))] // one slot per pair of cache lines: writers of neighbouring slots don't false-share
struct Slot {
    seq: AtomicU64,
    words: [AtomicU64; WORDS],
}

impl Slot {
    fn new() -> Self {
        Slot { seq: AtomicU64::new(0), words: std::array::from_fn(|_| AtomicU64::new(0)) }
    }
}

/// The table: a fixed number of slots, allocated once.
pub struct BallTable {
    slots: Box<[Slot]>,
}

impl BallTable {
    pub fn new(capacity: usize) -> Self {
        BallTable { slots: (0..capacity).map(|_| Slot::new()).collect() }
    }

    pub fn capacity(&self) -> usize {
        self.slots.len()
    }

    /// Publishes the state of the ball in `slot`. Only that ball's own thread may call this (and
    /// the runtime, to clear a slot after that thread has been joined).
    pub fn write(&self, slot: usize, record: &BallRecord) {
        let s = &self.slots[slot];
        // Only this thread writes `seq`, so a relaxed load of it is exact.
        let seq = s.seq.load(Ordering::Relaxed);
        s.seq.store(seq.wrapping_add(1), Ordering::Relaxed);
        // Orders the odd `seq` store before the data stores below (see the module comment).
        fence(Ordering::Release);
        let b = &record.ball;
        let id_word = (b.id.0 as u64 + 1) | if b.kind == BallKind::Key { KEY_BIT } else { 0 };
        let w = &s.words;
        w[W_ID].store(id_word, Ordering::Relaxed);
        w[W_X].store(b.position.x.to_bits(), Ordering::Relaxed);
        w[W_Y].store(b.position.y.to_bits(), Ordering::Relaxed);
        w[W_VX].store(b.velocity.x.to_bits(), Ordering::Relaxed);
        w[W_VY].store(b.velocity.y.to_bits(), Ordering::Relaxed);
        w[W_MASS].store(b.mass.to_bits(), Ordering::Relaxed);
        w[W_DIAMETER].store(b.diameter.to_bits(), Ordering::Relaxed);
        w[W_APPLIED].store(record.applied, Ordering::Relaxed);
        w[W_UPDATES].store(record.updates, Ordering::Relaxed);
        let wi = &record.wall_impulses;
        for (k, v) in [wi.left, wi.right, wi.bottom, wi.top].into_iter().enumerate() {
            w[W_WALL + k].store(v.to_bits(), Ordering::Relaxed);
        }
        // Publishes every data store above to readers that acquire the even `seq`.
        s.seq.store(seq.wrapping_add(2), Ordering::Release);
    }

    /// Marks `slot` empty. Same single-writer rule as [`BallTable::write`].
    pub fn clear(&self, slot: usize) {
        let s = &self.slots[slot];
        let seq = s.seq.load(Ordering::Relaxed);
        s.seq.store(seq.wrapping_add(1), Ordering::Relaxed);
        fence(Ordering::Release);
        s.words[W_ID].store(0, Ordering::Relaxed);
        s.seq.store(seq.wrapping_add(2), Ordering::Release);
    }

    /// Reads a consistent record of `slot`, or `None` if the slot is empty. Never blocks the
    /// writer; retries (spinning) only while a write is in progress, which takes nanoseconds.
    pub fn read(&self, slot: usize) -> Option<BallRecord> {
        let s = &self.slots[slot];
        loop {
            let seq1 = s.seq.load(Ordering::Acquire);
            if seq1 & 1 == 1 {
                std::hint::spin_loop();
                continue;
            }
            let mut raw = [0u64; WORDS];
            for (r, w) in raw.iter_mut().zip(&s.words) {
                *r = w.load(Ordering::Relaxed);
            }
            // Keeps the data loads above from being reordered after the second `seq` load.
            fence(Ordering::Acquire);
            if s.seq.load(Ordering::Relaxed) != seq1 {
                std::hint::spin_loop();
                continue;
            }
            if raw[W_ID] == 0 {
                return None;
            }
            let f = |k: usize| f64::from_bits(raw[k]);
            let kind = if raw[W_ID] & KEY_BIT != 0 { BallKind::Key } else { BallKind::Ball };
            return Some(BallRecord {
                slot,
                ball: Ball {
                    id: BallId(((raw[W_ID] & !KEY_BIT) - 1) as u32),
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
            });
        }
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
