//! The monitor's record of the messages a ball has not applied yet, oldest first: a queue whose
//! newest `N` entries live inline, in the ball's own slot of the monitor's per-slot array, and
//! only older ones on the heap.
//!
//! **Why inline.** Every pass reads one entry of every ball's queue (the newest the ball applied)
//! and appends one to each ball it sends a response to. With each queue a `VecDeque` of its own,
//! those were reads and writes at 1,024 scattered heap addresses, evicted between passes by the
//! ball threads that share the cores: on the awake 1,024-ball pile the read and the append were
//! each a tenth of the monitor's pass, in cache misses. Inline, they are at addresses that rise
//! with the slot as the pass walks the slots, which the hardware prefetches. A ball's thread
//! takes its inbox every one to six passes on a loaded machine, so a few entries cover it; a ball
//! starved for longer spills its older entries to the heap, where they cost what they did.

use std::collections::VecDeque;

/// A FIFO of `T` (see the module comment): entry `i` of `len` is the `i`-th oldest. The newest
/// `min(len, N)` are in `recent`, by their sequence number modulo `N`; the older ones in `spill`,
/// oldest first, so `spill.len() == len.saturating_sub(N)` always.
#[derive(Clone, Debug)]
pub(crate) struct SentQueue<T: Copy, const N: usize> {
    recent: [Option<T>; N],
    spill: VecDeque<T>,
    /// Entries pushed in all: the next one's sequence number.
    pushed: u64,
    len: usize,
}

impl<T: Copy, const N: usize> Default for SentQueue<T, N> {
    fn default() -> Self {
        SentQueue { recent: [None; N], spill: VecDeque::new(), pushed: 0, len: 0 }
    }
}

impl<T: Copy, const N: usize> SentQueue<T, N> {
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Appends `item` as the newest entry.
    pub fn push(&mut self, item: T) {
        let at = (self.pushed % N as u64) as usize;
        if self.len >= N {
            // The entry in `at` is the oldest of the newest N; from now on it is older.
            self.spill.extend(self.recent[at]);
        }
        self.recent[at] = Some(item);
        self.pushed += 1;
        self.len += 1;
    }

    /// Forgets the `n` oldest entries (all of them if there are fewer).
    pub fn forget_oldest(&mut self, n: usize) {
        let n = n.min(self.len);
        self.spill.drain(..n.min(self.spill.len()));
        self.len -= n;
    }

    /// The `i`-th oldest entry.
    pub fn get(&self, i: usize) -> Option<&T> {
        if i >= self.len {
            return None;
        }
        let spilled = self.spill.len();
        if i < spilled {
            return self.spill.get(i);
        }
        let seq = self.pushed - (self.len - i) as u64;
        self.recent[(seq % N as u64) as usize].as_ref()
    }

    /// Every entry, oldest first.
    pub fn iter(&self) -> impl Iterator<Item = &T> {
        let spilled = self.spill.len();
        self.spill.iter().chain((spilled..self.len).filter_map(|i| self.get(i)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against a `VecDeque` under every mix of pushes and forgets, through spills and back.
    #[test]
    fn it_is_a_fifo() {
        let mut q = SentQueue::<u64, 4>::default();
        let mut reference = VecDeque::new();
        let mut next = 0u64;
        // A small LCG: pushes outnumber forgets at first (the queue spills), then the reverse.
        let mut state = 12345u64;
        let mut longest = 0;
        for round in 0..4000 {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let r = (state >> 33) % 10;
            let push_bias = if round < 2000 { 6 } else { 3 };
            if r < push_bias {
                q.push(next);
                reference.push_back(next);
                next += 1;
            } else {
                let n = ((state >> 40) % if round < 2000 { 3 } else { 4 }) as usize;
                q.forget_oldest(n);
                reference.drain(..n.min(reference.len()));
            }
            assert_eq!(q.len(), reference.len());
            longest = longest.max(q.len());
            assert_eq!(q.is_empty(), reference.is_empty());
            assert!(q.iter().eq(reference.iter()), "round {round}");
            for i in 0..=reference.len() {
                assert_eq!(q.get(i), reference.get(i), "round {round}, entry {i}");
            }
        }
        assert!(longest > 100 && q.len() < 4, "the walk spilled (longest {longest}) and came back ({})", q.len());
    }
}
