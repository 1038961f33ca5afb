//! The event calendar: a binary min-heap of predicted events with lazy invalidation.
//!
//! Every ball that moves keeps exactly one live event of its own in the calendar: the earliest it
//! found when it was last predicted (a collision with a neighbour, a wall bounce or the crossing
//! into the next cell). An event carries its owner's prediction serial (which goes up at every
//! prediction of that ball) and, when it has a partner ball, the partner's course counter (which
//! goes up whenever the partner's trajectory changes), as they were when it was predicted.
//! Nothing is ever searched for and removed: an event whose numbers no longer match is dropped
//! when it comes to the top (lazy invalidation), for one of two reasons that the calendar counts
//! apart:
//! - its *owner* was predicted again since (after a change of course, or to see a new
//!   neighbour), and pushed a newer event: the event is simply dropped;
//! - its *partner* changed, but the owner did not: the owner's trajectory is still good but its
//!   earliest event is gone, so the owner is predicted again from this instant. Nothing earlier
//!   can have been missed: the partner, when it changed, was predicted against the owner itself.
//!
//! This is the one-event-per-ball scheme of Rapaport's "The Art of Molecular Dynamics
//! Simulation" (ch. 14), with counters standing in for its linked lists of events to delete. The
//! heap holds one live event per moving ball plus the dropped ones not yet at the top; when the
//! dead outnumber the live three to one it is rebuilt from the live ones ([`Calendar::compact`]).

use std::cmp::Ordering;
use std::collections::BinaryHeap;

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
    /// The owner's prediction serial.
    pub serial: u32,
    /// What the owner meets.
    pub partner: Partner,
}

/// The partner codes of walls and cell boundaries: above every ball's index, so that among
/// simultaneous events of one owner the collisions come first, then the walls, then the cells.
const WALL_CODE: u32 = u32::MAX - 16;
const CELL_CODE: u32 = u32::MAX - 8;

/// The heap's element, 24 bytes: the event packed with its order. Earliest first: time, then
/// owner, then partner, so that simultaneous events come out in the same order on every run. The time is kept as its bits, which order as the time does for the
/// non-negative times of a calendar (a `-0.0` is made `+0.0` when packed), so that a comparison
/// is two integer comparisons.
#[derive(Clone, Copy, Debug)]
struct Entry {
    time: u64,
    /// `owner << 32 | partner code` (a ball's index, or [`WALL_CODE`] / [`CELL_CODE`] + side).
    tie: u64,
    serial: u32,
    /// The partner ball's course counter (0 for walls and cells).
    count: u32,
}

impl Entry {
    fn pack(e: Event) -> Entry {
        let (code, count) = match e.partner {
            Partner::Ball(j, c) => (j, c),
            Partner::Wall(w) => (WALL_CODE + w as u32, 0),
            Partner::Cell(c) => (CELL_CODE + c as u32, 0),
        };
        Entry { time: (e.time + 0.0).to_bits(), tie: (e.owner as u64) << 32 | code as u64, serial: e.serial, count }
    }

    fn unpack(self) -> Event {
        let code = self.tie as u32;
        let partner = if code >= CELL_CODE {
            Partner::Cell((code - CELL_CODE) as u8)
        } else if code >= WALL_CODE {
            Partner::Wall((code - WALL_CODE) as u8)
        } else {
            Partner::Ball(code, self.count)
        };
        Event { time: f64::from_bits(self.time), owner: (self.tie >> 32) as u32, serial: self.serial, partner }
    }
}

impl PartialEq for Entry {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        // Reversed: the earliest event is the heap's greatest.
        (other.time, other.tie).cmp(&(self.time, self.tie))
    }
}

/// What the calendar counted.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CalendarStats {
    /// Events pushed.
    pub pushed: u64,
    /// Events dropped because their owner had changed.
    pub stale_owner: u64,
    /// Events dropped because their partner had changed (the owner was predicted again).
    pub stale_partner: u64,
    /// Largest number of entries the heap held.
    pub peak_len: usize,
    /// Times the heap was rebuilt from its live events.
    pub compactions: u64,
}

/// The heap of events (see the module comment).
#[derive(Clone, Debug, Default)]
pub struct Calendar {
    heap: BinaryHeap<Entry>,
    /// What it counted.
    pub stats: CalendarStats,
}

impl Calendar {
    /// An empty calendar.
    pub fn new() -> Calendar {
        Calendar::default()
    }

    /// Drops every event (the counts stay).
    pub fn clear(&mut self) {
        self.heap.clear();
    }

    /// Events held, live or dropped-to-be.
    pub fn len(&self) -> usize {
        self.heap.len()
    }

    /// Adds an event.
    pub fn push(&mut self, event: Event) {
        self.heap.push(Entry::pack(event));
        self.stats.pushed += 1;
        self.stats.peak_len = self.stats.peak_len.max(self.heap.len());
    }

    /// The time of the earliest event, live or not.
    pub fn next_time(&self) -> Option<f64> {
        self.heap.peek().map(|e| f64::from_bits(e.time))
    }

    /// Takes the earliest event, live or not (the caller checks it).
    pub fn pop(&mut self) -> Option<Event> {
        self.heap.pop().map(Entry::unpack)
    }

    /// Rebuilds the heap from the events `live` keeps, when the heap holds more than four times
    /// `balls` + 64 entries: the dead ones would otherwise pile up behind far-future events.
    pub fn compact(&mut self, balls: usize, live: impl Fn(&Event) -> bool) {
        if self.heap.len() <= 4 * balls + 64 {
            return;
        }
        let mut v = std::mem::take(&mut self.heap).into_vec();
        v.retain(|e| live(&e.unpack()));
        self.heap = BinaryHeap::from(v);
        self.stats.compactions += 1;
    }
}
