//! A loom model check of the contact ring's push/pop protocol (`src/engine/runtime/contact_ring.rs`),
//! the way `tests/table_loom.rs` checks the table: the real file, compiled beside a `sync` module
//! that hands it loom's atomics. Loom runs the monitor (the producer) and a ball's thread (the
//! consumer) under every interleaving up to a preemption bound and, for each relaxed load, every
//! value the memory model allows. The consumer must get every response, whole, in the order
//! pushed, and the producer must never overwrite a response before it is taken.
//!
//! Bounded to one preemption in the ordinary run, like the table's models (0.1 s at three
//! preemptions). Each of these mutations of `contact_ring.rs` fails a model here: the push's
//! `seq` store relaxed, the pop's `seq` load relaxed, the push not reading `taken` again when
//! the ring looks full (it then refuses for ever), and a full ring taken to hold one slot more
//! than it has. Not caught, at any bound: `taken`'s release store and acquire load both relaxed.
//! What those orderings rule out is the consumer's reads of a slot seeing the producer's next
//! lap written into it, a load reading a store that comes after it ("load buffering"), which
//! loom does not model; the module comment argues it. Widen by hand:
//! `LOOM_MAX_PREEMPTIONS=3 cargo test --release --test contact_ring_loom`.

mod loom_model;

#[allow(dead_code)]
mod sync {
    pub(crate) use loom::sync::atomic::{AtomicU64, Ordering};
}

mod message {
    pub use ballfield::runtime::{Contact, Rest};
}

#[allow(dead_code)]
#[path = "../src/engine/runtime/contact_ring.rs"]
mod contact_ring;

use contact_ring::{ContactRing, RingWriter};
use glam::DVec2;
use loom::sync::Arc;
use loom_model::model;
use message::{Contact, Rest};

/// Response number `k`: every word a different function of `k`, so a torn one is recognised.
fn response(k: u64) -> Contact {
    let f = k as f64;
    Contact {
        dv: DVec2::new(f + 0.5, -f),
        dx: DVec2::new(0.25 * f, 2.0 * f),
        stamp: 10 * k + 3,
        apply_at: 10 * k + 1,
        rest: Rest::from_word(k % 3),
    }
}

/// On one thread: responses come out in order, and a full ring refuses a push until the
/// consumer has released what it took.
#[test]
fn responses_come_out_in_order_and_a_full_ring_refuses_until_they_are_released() {
    model(|| {
        let ring = ContactRing::<4>::new();
        let mut w = RingWriter::default();
        for k in 1..=4 {
            assert!(ring.push(&mut w, &response(k)));
        }
        assert!(!ring.push(&mut w, &response(5)), "a fifth response in four slots");
        let mut next = 0;
        assert_eq!(ring.pop(&mut next), Some(response(1)));
        assert_eq!(ring.pop(&mut next), Some(response(2)));
        assert!(!ring.push(&mut w, &response(5)), "taken but not released: still full");
        ring.release(next);
        assert!(ring.push(&mut w, &response(5)));
        assert!(ring.push(&mut w, &response(6)));
        assert!(!ring.push(&mut w, &response(7)));
        let got: Vec<Contact> = std::iter::from_fn(|| ring.pop(&mut next)).collect();
        assert_eq!(got, (3..=6).map(response).collect::<Vec<_>>());
        assert_eq!(ring.pop(&mut next), None);
    });
}

/// The monitor pushes three responses into a ring of two slots (it wraps; a refused push is
/// tried again) while the ball's thread takes them: it gets all three, whole, in order.
#[test]
fn a_consumer_racing_the_producer_gets_every_response_whole_and_in_order() {
    model(|| {
        let ring = Arc::new(ContactRing::<2>::new());
        let producer = {
            let ring = ring.clone();
            loom::thread::spawn(move || {
                let mut w = RingWriter::default();
                for k in 1..=3 {
                    while !ring.push(&mut w, &response(k)) {
                        loom::thread::yield_now();
                    }
                }
            })
        };
        let (mut next, mut got) = (0, Vec::new());
        while got.len() < 3 {
            match ring.pop(&mut next) {
                Some(m) => got.push(m),
                None => {
                    ring.release(next);
                    loom::thread::yield_now();
                }
            }
        }
        ring.release(next);
        producer.join().unwrap();
        assert_eq!(got, (1..=3).map(response).collect::<Vec<_>>());
        assert_eq!(ring.pop(&mut next), None);
    });
}
