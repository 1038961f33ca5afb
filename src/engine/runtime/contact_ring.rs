//! A ball's contact inbox: the monitor's responses to one ball, in a ring of slots that the
//! monitor (its only producer) fills and the ball's thread (its only consumer) empties, in order.
//! All atomic words, no `unsafe`: a racing read is never undefined behaviour.
//!
//! **Why a ring beside the ball's channel.** The monitor sends every ball of a pile one response
//! a pass. Through the ball's crossbeam channel each send takes two locked read-modify-writes
//! (the channel's tail index and the slot's ready bit) on cache lines the ball's core last
//! touched, and the pass waits on each miss: on the settled 1,024-ball pile, with the channel
//! alone, a fifth of the monitor's time is in `Channel::send` (docs/measurements.md). A push
//! here is plain stores (on
//! x86 a release store is an ordinary `mov`): the store buffer absorbs the misses and the pass
//! goes on. Commands (the pull, a mass, a throw, stop) still come by the channel, and so does a
//! response that finds the ring full (see [`ContactRing::push`]), in order:
//! - the producer, once it has sent a response by the channel, sends every one after it by the
//!   channel too, until the consumer's count of responses taken from the channel
//!   ([`ContactRing::taken_from_channel`]) has caught up with how many it sent so;
//! - the consumer takes the ring before its channel, and takes the ring again before each
//!   response from the channel (the ring may have filled since it last looked, with responses
//!   older than that one: pushed before it was sent, they are in the ring once it is received),
//!   and counts the response after it holds it ([`ContactRing::note_from_channel`]).
//!
//! So every response in the ring is older than any in the channel, and one pushed to the ring
//! after the producer saw the count catch up is newer than every response the consumer holds.
//!
//! Protocol (`cap` slots, a power of two; response `k` goes in slot `k % cap`):
//! - **producer** (the monitor): it counts the responses it pushed (`pushed`) and keeps the last
//!   `taken` it read. Response `k = pushed` fits if `k − taken < cap`; if not by the count it
//!   has, it reads `taken` again (acquire), and if still not, the push fails. Otherwise it writes
//!   the slot's words (relaxed), then the slot's `seq ← k + 1` (release).
//! - **consumer** (the ball's thread): it counts the responses it took (`next`). Response
//!   `next` is there when its slot's `seq` (acquire) reads `next + 1`; it reads the words
//!   (relaxed) and counts it. After taking what is there, it stores `taken ← next` (release).
//!
//! Orderings: the release store of `seq` and the consumer's acquire load of it make the words
//! written before it visible to the reads after it. The consumer's release store of `taken`
//! after its reads, and the producer's acquire load of it before it writes the slot again (one
//! lap later), order those reads before the new writes, so a slot is never rewritten while it is
//! read: a response is never read torn. A slot's `seq` from an older lap (`next + 1 − cap`) or
//! zero reads as empty.

use super::message::{Contact, Rest};
// The atomics come from the parent module: std's here, loom's when `tests/contact_ring_loom.rs`
// compiles this very file into a loom model.
use super::sync::{AtomicU64, Ordering};

/// Slots per ring: a ball whose thread takes its inbox at least once in this many passes never
/// needs the channel for a response (16 KB a ball). On the 1,024-ball pile a ball takes its inbox
/// every few passes, but one starved for more than 128 passes is not rare: with 64 slots the
/// channel's sends take 4.9 % of the monitor's time, with 128 3.5 %, with 256 0.05 %.
pub(crate) const RING_SLOTS: usize = 256;

/// One response: `seq` (0, or the response's number + 1) and its seven words.
#[repr(align(64))] // one slot per cache line
struct RingSlot {
    seq: AtomicU64,
    words: [AtomicU64; 7],
}

/// The consumer's counts on a cache line of their own: it writes them, and the producer, which
/// writes the slots every push, reads them only when the ring looks full or it has sent by the
/// channel.
#[repr(align(64))]
struct Taken {
    /// Responses taken from the ring.
    ring: AtomicU64,
    /// Responses taken from the channel (see [`ContactRing::note_from_channel`]).
    channel: AtomicU64,
}

/// The ring (see the module comment), `N` slots (a power of two), its slots in the ring itself:
/// the producer finds a slot from the ring's address alone, reading none of its other lines.
pub(crate) struct ContactRing<const N: usize = RING_SLOTS> {
    taken: Taken,
    slots: [RingSlot; N],
}

/// The producer's side of one ring: how many it pushed, and the consumer's count as last read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct RingWriter {
    pushed: u64,
    taken_seen: u64,
}

impl<const N: usize> ContactRing<N> {
    const MASK: u64 = {
        assert!(N.is_power_of_two(), "a ring's slots are a power of two");
        N as u64 - 1
    };

    /// An empty ring.
    pub(crate) fn new() -> Self {
        ContactRing {
            taken: Taken { ring: AtomicU64::new(0), channel: AtomicU64::new(0) },
            slots: std::array::from_fn(|_| RingSlot {
                seq: AtomicU64::new(0),
                words: std::array::from_fn(|_| AtomicU64::new(0)),
            }),
        }
    }

    /// Pushes `m` (producer only, with its own `writer`); returns false, pushing nothing, if the
    /// ring is full.
    pub(crate) fn push(&self, writer: &mut RingWriter, m: &Contact) -> bool {
        let k = writer.pushed;
        if k - writer.taken_seen > Self::MASK {
            // Acquire: pairs with the consumer's Release store after its reads (see the module
            // comment): the slot about to be rewritten has been read.
            writer.taken_seen = self.taken.ring.load(Ordering::Acquire);
            if k - writer.taken_seen > Self::MASK {
                return false;
            }
        }
        let slot = &self.slots[(k & Self::MASK) as usize];
        let words = [
            m.dv.x.to_bits(),
            m.dv.y.to_bits(),
            m.dx.x.to_bits(),
            m.dx.y.to_bits(),
            m.stamp,
            m.apply_at,
            m.rest.word(),
        ];
        for (word, value) in slot.words.iter().zip(words) {
            // Relaxed: published by the Release store of `seq` below.
            word.store(value, Ordering::Relaxed);
        }
        // Release: the words above are visible to a consumer that Acquires this value.
        slot.seq.store(k + 1, Ordering::Release);
        writer.pushed = k + 1;
        true
    }

    /// Asks the core to fetch the slot the next push from `writer` fills (producer only; a hint,
    /// which changes nothing the ring holds). The slot's line was last read by the ball's core, so
    /// a push that finds it there waits for it; fetched a few balls ahead, it is here by then.
    #[inline]
    pub(crate) fn prefetch_next(&self, writer: &RingWriter) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            let slot: *const RingSlot = &self.slots[(writer.pushed & Self::MASK) as usize];
            // SAFETY: SSE is in x86_64's baseline, so the instruction exists; a prefetch reads
            // and writes no memory and faults on no address (this one is in the ring). A read
            // prefetch: the write prefetch (PREFETCHW, `prfchw`) is not stable Rust.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(slot.cast()) };
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = writer;
    }

    /// Takes the response numbered `*next` if it is there (consumer only), counting it.
    pub(crate) fn pop(&self, next: &mut u64) -> Option<Contact> {
        let slot = &self.slots[(*next & Self::MASK) as usize];
        // Acquire: pairs with the producer's Release store of this value.
        if slot.seq.load(Ordering::Acquire) != *next + 1 {
            return None;
        }
        // Relaxed: ordered after the Acquire load above.
        let w: [u64; 7] = std::array::from_fn(|i| slot.words[i].load(Ordering::Relaxed));
        *next += 1;
        Some(Contact {
            dv: glam::DVec2::new(f64::from_bits(w[0]), f64::from_bits(w[1])),
            dx: glam::DVec2::new(f64::from_bits(w[2]), f64::from_bits(w[3])),
            stamp: w[4],
            apply_at: w[5],
            rest: Rest::from_word(w[6]),
        })
    }

    /// Tells the producer that every response before `next` has been taken (consumer only).
    pub(crate) fn release(&self, next: u64) {
        // Release: the reads of the slots taken happen before a producer that Acquires this
        // value rewrites them.
        self.taken.ring.store(next, Ordering::Release);
    }

    /// Tells the producer that the consumer holds `count` responses taken from the channel in all,
    /// each after taking the ring (consumer only).
    pub(crate) fn note_from_channel(&self, count: u64) {
        // Release: what the consumer took before (the ring, the channel's responses) happens
        // before a producer that Acquires this count pushes to the ring again.
        self.taken.channel.store(count, Ordering::Release);
    }

    /// How many responses the consumer has taken from the channel (producer only).
    pub(crate) fn taken_from_channel(&self) -> u64 {
        // Acquire: pairs with the Release store in `note_from_channel`.
        self.taken.channel.load(Ordering::Acquire)
    }
}

/// Compile-time check: the monitor and the ball's thread share the ring through an `Arc`, so it
/// is `Send` and `Sync` (all its fields are atomics).
const _: () = {
    const fn shared<T: Send + Sync>() {}
    shared::<ContactRing>();
};
