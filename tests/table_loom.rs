//! A loom model check of the ball table's publish/read protocol (`src/engine/runtime/table.rs`).
//!
//! This compiles the real `table.rs` — the very file the runtime uses, not a copy — beside a
//! `sync` module that hands it loom's atomics, fences and spin hint instead of std's, and a
//! `physics` module that re-exports the crate's own record types. Loom then runs the writer and
//! the readers under every interleaving (up to a preemption bound) and, for each relaxed load,
//! every value the C11 memory model lets it return. A reader must always get a whole record
//! (every word from one write) and never wait for a writer.
//!
//! It runs in the ordinary `cargo test --release` with the search bounded to one preemption per
//! execution (about 4 s of CPU for the four models; the same four at two preemptions take about
//! 27 s of CPU, most of it the two-reader model). One preemption is enough for what the models
//! are for: each of these mutations of `table.rs` fails at least two of the four models at bound
//! 1, exactly as at bound 2 — dropping the reader's second sequence check, the reader's acquire
//! fence or the writer's release fence, making the reader's first sequence load relaxed, making
//! the writer's sequence stores relaxed, and reading the copy being written instead of the other.
//! Widen the search by hand (minutes):
//!
//! ```sh
//! LOOM_MAX_PREEMPTIONS=2 cargo test --release --test table_loom
//! LOOM_MAX_PREEMPTIONS=3 cargo test --release --test table_loom
//! ```

mod loom_model;

#[allow(dead_code)]
mod sync {
    pub(crate) use loom::hint::spin_loop;
    pub(crate) use loom::sync::atomic::{AtomicU64, Ordering, fence};
}

mod physics {
    pub use ballfield::physics::{Ball, BallId, BallKind, WallImpulses};
}

#[allow(dead_code)]
#[path = "../src/engine/runtime/table.rs"]
mod table;

use glam::DVec2;
use loom::sync::Arc;
use loom_model::model;
use physics::{Ball, BallId, BallKind, WallImpulses};
use table::{BallRecord, BallTable, Slot};

/// Write number `k`: every word of the record is a different function of `k`, so a record made
/// of words from two writes is recognised.
fn record(k: u64) -> BallRecord {
    let f = k as f64;
    BallRecord {
        slot: 0,
        ball: Ball {
            id: BallId(k as u32),
            kind: if k % 2 == 1 { BallKind::Key } else { BallKind::Ball },
            position: DVec2::new(f + 0.5, 2.0 * f),
            velocity: DVec2::new(3.0 * f, 4.0 * f),
            mass: 5.0 * f + 1.0,
            diameter: 6.0 * f + 1.0,
        },
        applied: 100 + k,
        updates: 7 * k,
        wall_impulses: WallImpulses { left: 8.0 * f, right: 9.0 * f, bottom: 10.0 * f, top: 11.0 * f },
        time: 12 * k,
        acceleration: DVec2::new(13.0 * f, 14.0 * f),
        asleep: k % 3 == 1,
    }
}

/// The `k` a whole record was written with, or a panic naming the torn record.
fn whole(r: &BallRecord) -> u64 {
    let k = r.applied - 100;
    assert_eq!(*r, record(k), "torn record: words of different writes");
    k
}

/// The latch itself, on a slot of two words (the table's slots are the same code with 16): one
/// writer publishes two writes after the first while a reader reads twice. Every read is one
/// whole write, and the reader never goes back to an older write than one it saw.
#[test]
fn latch_readers_get_whole_writes_in_order() {
    fn words(k: u64) -> [u64; 2] {
        [k, 1000 + 7 * k]
    }
    fn whole(w: [u64; 2]) -> u64 {
        assert_eq!(w, words(w[0]), "torn read: words of different writes");
        w[0]
    }
    model(|| {
        let slot = Arc::new(Slot::<2>::new());
        slot.write_words(&words(0));
        let writer = {
            let slot = slot.clone();
            loom::thread::spawn(move || {
                for k in 1..=2 {
                    slot.write_words(&words(k));
                }
            })
        };
        let first = whole(slot.read_words());
        let second = whole(slot.read_words());
        assert!(second >= first, "went back from write {first} to write {second}");
        writer.join().unwrap();
        assert_eq!(whole(slot.read_words()), 2, "after the join the last write is visible");
    });
}

/// Two readers at once (the monitor and the renderer both read every slot): each gets a whole
/// write while the writer publishes two.
#[test]
fn latch_two_readers_get_whole_writes() {
    model(|| {
        let slot = Arc::new(Slot::<2>::new());
        slot.write_words(&[0, 1000]);
        let writer = {
            let slot = slot.clone();
            loom::thread::spawn(move || {
                for k in 1..=2 {
                    slot.write_words(&[k, 1000 + 7 * k]);
                }
            })
        };
        let read = |slot: &Slot<2>| {
            let w = slot.read_words();
            assert_eq!(w[1], 1000 + 7 * w[0], "torn read: {w:?}");
        };
        let reader = {
            let slot = slot.clone();
            loom::thread::spawn(move || read(&slot))
        };
        read(&slot);
        reader.join().unwrap();
        writer.join().unwrap();
    });
}

/// The table's own records (16 words, encoded and decoded by `BallTable`): a reader racing a
/// write gets the old record or the new one, whole.
#[test]
fn a_reader_racing_the_writer_gets_a_whole_record() {
    model(|| {
        let table = Arc::new(BallTable::new(1));
        table.write(0, &record(0));
        let writer = {
            let table = table.clone();
            loom::thread::spawn(move || table.write(0, &record(1)))
        };
        let seen = whole(&table.read(0).expect("the slot is occupied"));
        assert!(seen <= 1);
        writer.join().unwrap();
        assert_eq!(whole(&table.read(0).unwrap()), 1, "after the join the last write is visible");
    });
}

/// Clearing a slot (the runtime does it after joining a ball's thread) races a reader: the reader
/// gets the whole old record or nothing, never a mix of its words and the zeros.
#[test]
fn clearing_races_readers_without_tearing() {
    model(|| {
        let table = Arc::new(BallTable::new(1));
        table.write(0, &record(1));
        let writer = {
            let table = table.clone();
            loom::thread::spawn(move || table.clear(0))
        };
        if let Some(r) = table.read(0) {
            assert_eq!(whole(&r), 1);
        }
        writer.join().unwrap();
        assert_eq!(table.read(0), None);
    });
}
