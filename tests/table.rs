//! The lock-free table never hands a reader a torn entry: writers publish records whose every
//! field is a function of one counter; readers hammering the same slots check that every record
//! they get is whole.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use ballfield::physics::{Ball, BallId, BallKind, WallImpulses};
use ballfield::runtime::{BallRecord, BallTable};
use glam::DVec2;

fn record(slot: usize, k: u64) -> BallRecord {
    let f = k as f64;
    BallRecord {
        slot,
        ball: Ball {
            id: BallId(slot as u32),
            kind: BallKind::Ball,
            position: DVec2::new(f, 2.0 * f),
            velocity: DVec2::new(3.0 * f, 4.0 * f),
            mass: 5.0 * f + 1.0,
            diameter: 6.0 * f + 1.0,
        },
        applied: k,
        updates: 7 * k,
        wall_impulses: WallImpulses { left: 8.0 * f, right: 9.0 * f, bottom: 10.0 * f, top: 11.0 * f },
        time: 12 * k,
        acceleration: DVec2::new(13.0 * f, 14.0 * f),
        asleep: k % 3 == 1,
    }
}

#[test]
fn readers_never_see_a_torn_entry() {
    const SLOTS: usize = 4;
    let table = Arc::new(BallTable::new(SLOTS));
    for slot in 0..SLOTS {
        table.write(slot, &record(slot, 0));
    }
    let stop = Arc::new(AtomicBool::new(false));
    let reads = Arc::new(AtomicU64::new(0));
    let mut threads = Vec::new();
    // One writer per slot, as in the runtime.
    for slot in 0..SLOTS {
        let (table, stop) = (table.clone(), stop.clone());
        threads.push(std::thread::spawn(move || {
            let mut k = 0u64;
            while !stop.load(Ordering::Relaxed) {
                k += 1;
                table.write(slot, &record(slot, k));
            }
            k
        }));
    }
    // Readers: each record read must equal record(slot, k) for the k its `applied` says.
    for _ in 0..3 {
        let (table, stop, reads) = (table.clone(), stop.clone(), reads.clone());
        threads.push(std::thread::spawn(move || {
            let mut last = [0u64; SLOTS];
            let mut n = 0;
            while !stop.load(Ordering::Relaxed) {
                for (slot, last) in last.iter_mut().enumerate() {
                    let r = table.read(slot).expect("slot is occupied");
                    assert_eq!(r, record(slot, r.applied), "torn entry in slot {slot}");
                    assert!(r.applied >= *last, "slot {slot} went back in time");
                    *last = r.applied;
                    n += 1;
                }
            }
            reads.fetch_add(n, Ordering::Relaxed);
            0
        }));
    }
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_millis(1500) {
        std::thread::sleep(Duration::from_millis(10));
    }
    stop.store(true, Ordering::Relaxed);
    let writes: u64 = threads.into_iter().map(|t| t.join().expect("no thread panicked")).sum();
    let reads = reads.load(Ordering::Relaxed);
    assert!(writes > 10_000 && reads > 10_000, "the test really raced ({writes} writes, {reads} reads)");
}

#[test]
fn cleared_slots_read_as_empty() {
    let table = BallTable::new(2);
    assert!(table.read(0).is_none());
    table.write(1, &record(1, 3));
    assert_eq!(table.read(1), Some(record(1, 3)));
    table.clear(1);
    assert!(table.read(1).is_none());
    let mut out = Vec::new();
    table.write(0, &record(0, 2));
    table.read_all(2, &mut out);
    assert_eq!(out, vec![record(0, 2)]);
}
