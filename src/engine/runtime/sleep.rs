//! The monitor's book of resting balls: how long each has been quiet, which islands sleep, and
//! what their walls carry meanwhile (the rules are `physics::sleep`'s).
//!
//! **Why balls sleep.** A settled pile's resting solve is most of a monitor pass, and every ball of
//! it gets a response every pass and applies it on its own thread: on the 1,024-ball pile the
//! monitor made 805–950 of its 1,000 passes a second and the slowest ball 122–426 updates a
//! second, against 983–993 passes and 832–928 updates on a 1,024-ball gas in the same sittings
//! (docs/measurements.md). An island that has rested for [`TIME_TO_SLEEP`] is left out of the
//! solve; its balls' threads hold them still (the clock goes on, their records stay fresh), and
//! the monitor puts on the walls' gauges, every span, what those walls carried on average while
//! the island was quiet: by momentum balance the island's weight, to the speed it still had
//! (below `sleep_speed`) over half a second.
//!
//! **Waking.** An island wakes whole, at the start of a span the monitor judges, when an awake
//! ball may touch one of its balls in that span (a candidate pair of the broad phase, which is a
//! superset of the contacts), when one of its balls is pulled, thrown or given a new mass (its
//! record shows it), when one of its balls leaves the field, and when the parameters change. Its
//! balls then take part in that span's solve from where they were held, so a ball dropped on a
//! sleeping pile meets it exactly as it would meet an awake one, and their contacts with the warm
//! start they fell asleep with (`ContactSolver::restore_warm_start`): a pile woken with nothing
//! striking it stays where it slept (10–20 µm) instead of sagging 0.4 mm while its resting solve
//! builds its support again from nothing (`tests/threaded_sleep.rs`).
//!
//! [`TIME_TO_SLEEP`]: crate::physics::TIME_TO_SLEEP

use glam::DVec2;

use crate::physics::{WallImpulses, WarmKey};

/// The monitor's watch of one slot's ball.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct RestWatch {
    /// The ball's start the watch is of (see `monitor::Inbox::incarnation`).
    pub incarnation: Option<u64>,
    /// Where the ball's present quiet stretch began (runtime clock, ns), while it is quiet.
    pub quiet_since: Option<u64>,
    /// The walls' impulses on the ball over its quiet stretch (left, right, bottom, top), N·s.
    pub walls: [f64; 4],
    /// The island it sleeps in, while it sleeps.
    pub island: Option<u32>,
    /// The last pass that found the ball on the field while it slept.
    pub seen: u64,
    /// What the ball was put to sleep with: where the monitor left it, its mass, its diameter
    /// and its uniform acceleration.
    pub held: DVec2,
    pub mass: f64,
    pub diameter: f64,
    pub acceleration: DVec2,
}

/// An island asleep: its balls' slots and the force its walls carry (N, left, right, bottom,
/// top).
#[derive(Clone, Debug)]
struct SleepingIsland {
    members: Vec<usize>,
    force: [f64; 4],
    /// Its contacts' warm start when it fell asleep: handed back to the solver when it wakes.
    warm: WarmStart,
}

/// An island's contacts' warm-start impulses (see `ContactSolver::for_each_warm_start`), taken
/// over `span` s.
#[derive(Clone, Debug, Default)]
pub(crate) struct WarmStart {
    pub impulses: Vec<(WarmKey, f64)>,
    pub span: f64,
}

/// The book (see the module comment), by slot.
pub(crate) struct SleepBook {
    watch: Vec<RestWatch>,
    islands: Vec<Option<SleepingIsland>>,
    /// The sum of the sleeping islands' wall forces, N.
    force: [f64; 4],
    /// Balls asleep now.
    asleep: u64,
    /// Balls put to sleep and woken since the counts were last taken.
    slept: u64,
    woken: u64,
    /// Slots woken and not yet sent their wake.
    waking: Vec<usize>,
    /// Warm starts of the islands woken, not yet handed to the solver.
    waking_warm: Vec<WarmStart>,
}

impl SleepBook {
    pub fn new(capacity: usize) -> Self {
        SleepBook {
            watch: vec![RestWatch::default(); capacity],
            islands: Vec::new(),
            force: [0.0; 4],
            asleep: 0,
            slept: 0,
            woken: 0,
            waking: Vec::new(),
            waking_warm: Vec::new(),
        }
    }

    pub fn watch(&self, slot: usize) -> &RestWatch {
        &self.watch[slot]
    }

    pub fn watch_mut(&mut self, slot: usize) -> &mut RestWatch {
        &mut self.watch[slot]
    }

    /// Whether any island sleeps.
    pub fn any_asleep(&self) -> bool {
        self.asleep > 0
    }

    /// Balls asleep now.
    pub fn asleep(&self) -> u64 {
        self.asleep
    }

    /// Balls put to sleep and woken since the last call.
    pub fn take_counts(&mut self) -> (u64, u64) {
        (std::mem::take(&mut self.slept), std::mem::take(&mut self.woken))
    }

    /// Starts the watch of a new ball in `slot` (or the same ball started again): the island the
    /// slot's last ball slept in wakes, as it would when that ball left the field.
    pub fn renew(&mut self, slot: usize, incarnation: u64) {
        if let Some(i) = self.watch[slot].island {
            self.wake_island(i);
            self.waking.retain(|&s| s != slot);
        }
        self.watch[slot] = RestWatch { incarnation: Some(incarnation), ..RestWatch::default() };
    }

    /// Wakes island `i` (if it still sleeps): its balls are awake in the book from now, and wait
    /// for their wake messages (see [`SleepBook::take_waking`]).
    pub fn wake_island(&mut self, i: u32) {
        let Some(island) = self.islands.get_mut(i as usize).and_then(Option::take) else { return };
        for &slot in &island.members {
            let w = &mut self.watch[slot];
            if w.island == Some(i) {
                w.island = None;
                w.quiet_since = None;
                w.walls = [0.0; 4];
            }
        }
        self.waking.extend_from_slice(&island.members);
        self.waking_warm.push(island.warm);
        let n = island.members.len() as u64;
        self.asleep -= n;
        self.woken += n;
        self.sum_force();
    }

    /// The slots woken since the last call, each to be sent its wake (into `out`, cleared first).
    pub fn take_waking(&mut self, out: &mut Vec<usize>) {
        out.clear();
        out.append(&mut self.waking);
    }

    /// The warm starts of the islands woken since the last call, each handed to `f`.
    pub fn take_waking_warm(&mut self, mut f: impl FnMut(&WarmStart)) {
        for w in self.waking_warm.drain(..) {
            f(&w);
        }
    }

    /// Wakes every island.
    pub fn wake_all(&mut self) {
        for i in 0..self.islands.len() as u32 {
            self.wake_island(i);
        }
    }

    /// Wakes every island with a ball the pass numbered `pass` did not find asleep on the field.
    pub fn wake_islands_missing_a_ball(&mut self, pass: u64) {
        for i in 0..self.islands.len() {
            let missing = self.islands[i]
                .as_ref()
                .is_some_and(|island| island.members.iter().any(|&slot| self.watch[slot].seen != pass));
            if missing {
                self.wake_island(i as u32);
            }
        }
    }

    /// Puts an island to sleep: its balls by slot, each with its walls' mean force (N), and its
    /// contacts' warm start. The caller sets each ball's `held` state.
    pub fn put_to_sleep(&mut self, members: Vec<usize>, force: [f64; 4], warm: WarmStart) {
        let free = self.islands.iter().position(Option::is_none);
        let i = free.unwrap_or(self.islands.len());
        for &slot in &members {
            let w = &mut self.watch[slot];
            w.island = Some(i as u32);
            w.quiet_since = None;
            w.walls = [0.0; 4];
        }
        let n = members.len() as u64;
        self.asleep += n;
        self.slept += n;
        let island = Some(SleepingIsland { members, force, warm });
        if i == self.islands.len() {
            self.islands.push(island);
        } else {
            self.islands[i] = island;
        }
        self.sum_force();
    }

    /// What the sleeping islands' walls carry over `span` simulated seconds.
    pub fn wall_impulses(&self, span: f64) -> WallImpulses {
        let [left, right, bottom, top] = self.force.map(|f| f * span);
        WallImpulses { left, right, bottom, top }
    }

    fn sum_force(&mut self) {
        self.force = [0.0; 4];
        for island in self.islands.iter().flatten() {
            for (sum, f) in self.force.iter_mut().zip(island.force) {
                *sum += f;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_island_wakes_whole_and_its_walls_stop_carrying() {
        let mut book = SleepBook::new(4);
        for slot in 0..4 {
            book.renew(slot, 1);
        }
        book.put_to_sleep(vec![0, 2], [0.0, 0.0, 19.62, 0.0], WarmStart::default());
        book.put_to_sleep(vec![3], [1.0, 0.0, 9.81, 0.0], WarmStart::default());
        assert_eq!(book.asleep(), 3);
        assert_eq!(book.wall_impulses(0.5).bottom, 0.5 * (19.62 + 9.81));
        for slot in [0, 2] {
            book.watch_mut(slot).seen = 7;
        }
        // Ball 3 was not seen in pass 7: its island wakes, and only it.
        book.wake_islands_missing_a_ball(7);
        assert!(book.watch(3).island.is_none());
        let mut waking = Vec::new();
        book.take_waking(&mut waking);
        assert_eq!(waking, [3]);
        assert_eq!(book.asleep(), 2);
        assert_eq!(book.wall_impulses(1.0).left, 0.0);
        // A new ball in slot 2 wakes the island slot 2 slept in: ball 0 wakes, slot 2 starts afresh.
        book.renew(2, 2);
        book.take_waking(&mut waking);
        assert_eq!(waking, [0]);
        assert!(book.watch(2).island.is_none() && book.watch(2).incarnation == Some(2));
        assert!(!book.any_asleep());
        assert_eq!(book.take_counts(), (3, 3));
        assert_eq!(book.wall_impulses(1.0).bottom, 0.0);
    }
}
