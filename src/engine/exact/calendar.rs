//! The event calendar: one slot per ball holding its next predicted event, and a complete binary
//! tournament tree over the slots whose root is the earliest event.
//!
//! Every ball that moves has exactly one event of its own: the earliest it found when it was
//! last predicted (a collision with a neighbour, a wall bounce or the crossing into the next
//! cell). A new prediction overwrites the ball's slot, so an event superseded by a newer one of
//! its owner is gone at once, not left in a heap to be dropped when it comes up. An event with a
//! partner ball carries the partner's course counter (which goes up whenever the partner's
//! trajectory changes) as it was at prediction time; an event whose partner has changed since
//! is found out when it comes to the top: the owner's trajectory is still good but its earliest
//! event is gone, so the owner is predicted again from that instant. Nothing earlier can have
//! been missed: the partner, when it changed, was predicted against the owner itself.
//!
//! This is the one-event-per-ball scheme of Rapaport's "The Art of Molecular Dynamics
//! Simulation" (ch. 14), with counters standing in for its lists of events to delete. The tree
//! holds, at each node, the owner of the earliest event below it (time, then owner), so that an
//! update compares along one path of ⌈log₂ n⌉ nodes, reading only the siblings and their times.
//! The order is the one a heap of all events with lazy invalidation gives its live events (earliest first; simultaneous events by owner): a ball has
//! one live event at a time, so the owner breaks every tie.

/// What the owner of an event meets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Partner {
    /// Another ball, by index, and its course counter at prediction time.
    Ball(u32, u32),
    /// A wall: 0 left, 1 right, 2 bottom, 3 top.
    Wall(u8),
    /// The boundary of its cell: 0 −x, 1 +x, 2 −y, 3 +y.
    Cell(u8),
}

/// One predicted event.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Event {
    /// Absolute simulated time, s.
    pub time: f64,
    /// The ball whose event it is.
    pub owner: u32,
    /// What the owner meets.
    pub partner: Partner,
}

/// The partner codes of walls and cell boundaries: above every ball's index.
const WALL_CODE: u32 = u32::MAX - 16;
const CELL_CODE: u32 = u32::MAX - 8;

/// The time of an empty slot: above every time's bits (an infinite time is `0x7ff0…`).
const NONE: u64 = u64::MAX;

/// A ball's slot, beside its event's time (in [`Calendar`]'s `times`): the partner's code (a
/// ball's index, or [`WALL_CODE`] / [`CELL_CODE`] + side) and the partner ball's course counter.
#[derive(Clone, Copy, Debug)]
struct Slot {
    code: u32,
    count: u32,
}

const EMPTY: Slot = Slot { code: 0, count: 0 };

/// An event's time as bits, which order as the times do for the non-negative times of a
/// calendar (a `-0.0` is made `+0.0`).
fn time_bits(t: f64) -> u64 {
    (t + 0.0).to_bits()
}

impl Slot {
    fn pack(e: &Event) -> Slot {
        let (code, count) = match e.partner {
            Partner::Ball(j, c) => (j, c),
            Partner::Wall(w) => (WALL_CODE + w as u32, 0),
            Partner::Cell(c) => (CELL_CODE + c as u32, 0),
        };
        Slot { code, count }
    }

    fn unpack(self, owner: u32, time: u64) -> Event {
        let code = self.code;
        let partner = if code >= CELL_CODE {
            Partner::Cell((code - CELL_CODE) as u8)
        } else if code >= WALL_CODE {
            Partner::Wall((code - WALL_CODE) as u8)
        } else {
            Partner::Ball(code, self.count)
        };
        Event { time: f64::from_bits(time), owner, partner }
    }
}

/// What the calendar counted.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CalendarStats {
    /// Events put in.
    pub pushed: u64,
    /// Events overwritten by a newer prediction of their owner before they came up.
    pub superseded: u64,
    /// Events that came up with their partner changed (the owner was predicted again).
    pub stale_partner: u64,
    /// Largest number of events the calendar held at once.
    pub peak_len: usize,
}

/// The slots and their tree (see the module comment).
#[derive(Clone, Debug, Default)]
pub struct Calendar {
    slots: Vec<Slot>,
    /// Per leaf, the time of its ball's event as [`time_bits`]; [`NONE`] where it has none, and
    /// for the leaves beyond the last ball.
    times: Vec<u64>,
    /// The winners by owner: `tree[leaves + i] = i` for every leaf, and for `1 ≤ k < leaves`,
    /// `tree[k]` the earlier of `tree[2k]` and `tree[2k + 1]` (`tree[1]`: the earliest of all).
    tree: Vec<u32>,
    leaves: usize,
    /// Events held.
    len: usize,
    /// The ball whose event [`Calendar::pop`] took, whose leaf is emptied but whose path is not
    /// yet updated: most often the ball is predicted again at once, and one update does both.
    taken: Option<u32>,
    /// What it counted.
    pub stats: CalendarStats,
}

impl Calendar {
    /// An empty calendar.
    pub fn new() -> Calendar {
        Calendar::default()
    }

    /// Drops every event and makes room for `balls` balls (the counts stay).
    pub fn reset(&mut self, balls: usize) {
        self.leaves = balls.max(1).next_power_of_two();
        self.slots.clear();
        self.slots.resize(balls, EMPTY);
        self.times.clear();
        self.times.resize(self.leaves, NONE);
        // Every subtree's winner is its first leaf while all are empty (ties go left).
        self.tree.clear();
        self.tree.resize(2 * self.leaves, 0);
        for k in (1..2 * self.leaves).rev() {
            self.tree[k] = if k >= self.leaves { (k - self.leaves) as u32 } else { self.tree[2 * k] };
        }
        self.len = 0;
        self.taken = None;
    }

    /// Events held.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Sets ball `owner`'s time to `time` and brings the winners on its path up to date.
    ///
    /// At each node the winner so far meets the winner of the sibling subtree; on equal times the
    /// left one wins (its owners are the lower ones), so the order is time, then owner. The
    /// choice is made with masks, not a branch: which of two events is earlier is as good as a
    /// coin toss for the branch predictor.
    #[inline]
    fn update(&mut self, owner: usize, time: u64) {
        let leaves = self.leaves;
        assert!(owner < leaves && self.times.len() == leaves && self.tree.len() == 2 * leaves);
        let (tree, times) = (self.tree.as_mut_ptr(), self.times.as_mut_ptr());
        let mut k = leaves + owner;
        let (mut win, mut t) = (owner as u64, time);
        // SAFETY: `k` starts at a leaf, below `2·leaves`, the tree's length (asserted above), and
        // only falls; `k ^ 1`, its sibling, is below the same bound. Every entry of the tree is
        // an owner below `leaves`, the length of `times` (asserted): `reset` writes only such,
        // and this loop only copies them. Every access is through the two pointers taken from
        // `&mut self`, which nothing else borrows meanwhile. (The bounds checks this saves cost
        // 4 % of the engine's instructions in the gas bench.)
        unsafe {
            *times.add(owner) = time;
            while k > 1 {
                let s = *tree.add(k ^ 1) as u64;
                let ts = *times.add(s as usize);
                // The sibling wins if earlier, or as early and on the left (`k` odd).
                let take = (ts < t) as u64 | ((ts == t) as u64 & (k as u64 & 1));
                let mask = take.wrapping_neg();
                t = (ts & mask) | (t & !mask);
                win = (s & mask) | (win & !mask);
                k /= 2;
                *tree.add(k) = win as u32;
            }
        }
    }

    /// Brings the path of the event last taken up to date.
    #[inline]
    fn settle_taken(&mut self) {
        if let Some(i) = self.taken.take() {
            self.update(i as usize, NONE);
        }
    }

    /// Makes `event` its owner's one event (any it had is superseded).
    #[inline]
    pub fn push(&mut self, event: Event) {
        let i = event.owner as usize;
        if self.taken == Some(event.owner) {
            self.taken = None;
        } else {
            self.settle_taken();
        }
        if self.times[i] == NONE {
            self.len += 1;
        } else {
            self.stats.superseded += 1;
        }
        self.slots[i] = Slot::pack(&event);
        self.update(i, time_bits(event.time));
        self.stats.pushed += 1;
        self.stats.peak_len = self.stats.peak_len.max(self.len);
    }

    /// Drops ball `owner`'s event, if it has one (superseded by a prediction that found none).
    #[inline]
    pub fn remove(&mut self, owner: u32) {
        self.settle_taken();
        let i = owner as usize;
        if self.times[i] != NONE {
            self.stats.superseded += 1;
            self.len -= 1;
            self.update(i, NONE);
        }
    }

    /// The time of the earliest event.
    #[inline]
    pub fn next_time(&mut self) -> Option<f64> {
        self.settle_taken();
        let root = self.times[self.tree[1] as usize];
        (root != NONE).then(|| f64::from_bits(root))
    }

    /// Takes the earliest event.
    #[inline]
    pub fn pop(&mut self) -> Option<Event> {
        self.settle_taken();
        let owner = self.tree[1];
        let i = owner as usize;
        let time = self.times[i];
        if time == NONE {
            return None;
        }
        let event = self.slots[i].unpack(owner, time);
        self.len -= 1;
        self.times[i] = NONE;
        self.taken = Some(owner);
        Some(event)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tree pops the same sequence as a sorted list of each ball's latest event, through
    /// pushes that supersede, removals and pops interleaved (a pseudo-random script; times drawn
    /// from a few values so that ties between owners are common). Seen to fail with ties broken
    /// towards the higher owner (the owner's bits inverted in the nodes).
    #[test]
    fn pops_in_the_order_of_the_latest_events() {
        let n = 37;
        let mut cal = Calendar::new();
        cal.reset(n);
        let mut latest: Vec<Option<Event>> = vec![None; n];
        let mut state = 12345u64;
        let mut rnd = |m: u64| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 33) % m
        };
        let mut popped = 0;
        for _ in 0..20_000 {
            match rnd(10) {
                0..=5 => {
                    let owner = rnd(n as u64) as u32;
                    let e = Event { time: rnd(8) as f64 * 0.5, owner, partner: Partner::Wall(rnd(4) as u8) };
                    cal.push(e);
                    latest[owner as usize] = Some(e);
                }
                6 => {
                    let owner = rnd(n as u64) as u32;
                    cal.remove(owner);
                    latest[owner as usize] = None;
                }
                _ => {
                    let want = latest
                        .iter()
                        .flatten()
                        .min_by(|a, b| a.time.total_cmp(&b.time).then(a.owner.cmp(&b.owner)))
                        .copied();
                    assert_eq!(cal.next_time(), want.map(|e| e.time));
                    let got = cal.pop();
                    assert_eq!(got, want);
                    if let Some(e) = got {
                        latest[e.owner as usize] = None;
                        popped += 1;
                    }
                }
            }
            assert_eq!(cal.len(), latest.iter().flatten().count());
        }
        assert!(popped > 1000, "the script pops ({popped})");
    }
}
