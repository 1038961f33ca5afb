//! Attraction at scale: the monitor's Barnes–Hut snapshot of the field, published lock-free to
//! the ball threads.
//!
//! With attraction on, a ball thread needs the pull of every other ball each cycle. Read
//! directly, that is the whole table and a sum over every other ball: O(n) per ball, O(n²) per
//! round of cycles, and at a thousand balls the reads alone leave each ball a few cycles a second.
//! From [`TREE_MIN_BALLS`] balls on (the same switch the lockstep engine uses, by the same rule,
//! [`AttractionMethod::choose`]) the collision monitor instead builds one [`BarnesHut`] tree of
//! the table each pass and publishes it; each ball thread takes the latest tree once per cycle and
//! asks it for the force at its own position ([`BarnesHut::force_at`]), excluding its own entry:
//! O(log n) per query.
//!
//! **Ownership.** The monitor owns a small pool of snapshots (`TreePublisher::pool`, at most
//! [`MAX_SNAPSHOTS`]). It rebuilds a snapshot only while it holds the only reference to it
//! (`Arc::get_mut`), so nobody ever reads a tree that is being built: a ball thread sees either a
//! whole old snapshot or a whole new one. The published one sits in
//! `Shared::attraction_tree`, an [`ArcSwapOption`]: storing into it never waits for readers, and
//! loading from it never waits for the monitor (arc-swap's load is lock-free: it takes a
//! per-thread "debt" slot instead of touching a shared count; a store pays the debts on the value
//! it replaces, turning each into a real reference, so `Arc::get_mut` sees every ball still
//! holding that snapshot).
//!
//! **Orderings.** arc-swap's store publishes the pointer with release semantics after the tree
//! was written through `Arc::get_mut`, and its load acquires it, so a ball that loads a snapshot
//! sees the whole tree built before it. A ball drops its guard as soon as it has split the force
//! (one walk; the near balls are copied out); `Arc`'s drop decrements with release and
//! `Arc::get_mut` checks the count with acquire, so every read a ball made of a snapshot happens
//! before the monitor rebuilds it. No ordering here is chosen by
//! hand: both halves are the crates' documented guarantees.
//!
//! **Time.** A snapshot is the table as the monitor read it at the start of a pass (each ball's
//! record consistent, not one instant for all, as every table read). A ball takes the latest
//! snapshot once per cycle and uses what it took for every sub-step of that cycle: the other
//! balls' field is frozen at the snapshot's time for that cycle, exactly as the direct read
//! freezes it at the read's time. Only the ball's own position moves through the sub-steps (the
//! far part of the pull is kept from the cycle's start, the near balls are summed at each
//! sub-step: see `ball_thread::advance`). The snapshot is about one monitor period older than a
//! direct read would be.
//!
//! **Pool.** A ball that is preempted in the middle of its walk keeps its snapshot until it runs
//! again (with thousands of ball threads, that can be a while), so more than two may be in use at
//! once; the monitor rebuilds whichever pooled snapshot nobody holds and
//! allocates another only when every one is held, up to [`MAX_SNAPSHOTS`]. With all of them held,
//! the pass builds nothing (counted as skipped) and the balls keep the last published tree. Once
//! the pool has grown, a build allocates nothing (the tree reuses its memory).
//!
//! **Freshness.** A pass rebuilds the tree only once the balls have moved on since the last build
//! — half a cycle per ball on average, or any ball added or removed, or new parameters (see
//! `TreePublisher::is_fresh`).

use std::sync::Arc;

use arc_swap::ArcSwapOption;
use glam::DVec2;

use super::table::BallRecord;
#[cfg(doc)]
use crate::physics::near_force;
use crate::physics::{Attraction, BarnesHut, NearBall};
#[cfg(doc)]
use crate::physics::{AttractionMethod, TREE_MIN_BALLS};

/// Most snapshots the monitor keeps. Each costs about 100 bytes per ball (the tree's sorted
/// copies and nodes). See the module documentation for why more than two may be in use.
pub(crate) const MAX_SNAPSHOTS: usize = 8;

/// `tree_index` of a slot that held no ball when the snapshot was taken.
const NOT_IN_TREE: u32 = u32::MAX;

/// One monitor pass's view of the field's attraction: a tree of the balls in the table.
#[derive(Debug, Default)]
pub(crate) struct AttractionSnapshot {
    tree: BarnesHut,
    /// Table slot → the ball's index in the tree's build (`NOT_IN_TREE` for an empty slot), so
    /// that a ball excludes its own, older, entry.
    tree_index: Vec<u32>,
    // The build's input, kept to reuse its memory.
    position: Vec<DVec2>,
    mass: Vec<f64>,
    radius: Vec<f64>,
}

/// Compile-time check: a snapshot is built on the monitor's thread and read by every ball thread
/// through an `Arc`, so it is `Send` and `Sync`.
const _: () = {
    const fn shared<T: Send + Sync>() {}
    shared::<AttractionSnapshot>();
};

impl AttractionSnapshot {
    /// The G and opening angle the tree was built with. A ball whose parameters differ (the user
    /// just changed them) reads the table directly for that cycle instead.
    pub(crate) fn attraction(&self) -> &Attraction {
        self.tree.attraction()
    }

    /// The attraction on the ball in table slot `slot`, of `mass` and `radius`, from every ball of
    /// the snapshot but the slot's own entry, split for a cycle of sub-steps
    /// ([`BarnesHut::split_at`]): returns the far force (N) at the cycle's start `position`, for a
    /// ball that may move up to `margin` in the cycle, and the orbit rate² there (1/s²); the near
    /// balls are copied to `near`, for [`near_force`] at each sub-step. A ball added after the
    /// snapshot is not in it (it excludes nothing, and pulls the others from the next pass on);
    /// a ball removed since still pulls until the next pass.
    pub(crate) fn split_on(
        &self,
        slot: usize,
        position: DVec2,
        mass: f64,
        radius: f64,
        margin: f64,
        near: &mut Vec<NearBall>,
    ) -> (DVec2, f64) {
        self.tree.split_at(position, mass, radius, self.own(slot), margin, near)
    }

    fn own(&self, slot: usize) -> Option<usize> {
        self.tree_index.get(slot).copied().filter(|&i| i != NOT_IN_TREE).map(|i| i as usize)
    }

    fn rebuild(&mut self, records: &[BallRecord], attraction: &Attraction) {
        self.position.clear();
        self.mass.clear();
        self.radius.clear();
        self.tree_index.clear();
        let slots = records.iter().map(|r| r.slot + 1).max().unwrap_or(0);
        self.tree_index.resize(slots, NOT_IN_TREE);
        for (i, r) in records.iter().enumerate() {
            self.tree_index[r.slot] = i as u32;
            self.position.push(r.ball.position);
            self.mass.push(r.ball.mass);
            self.radius.push(r.ball.radius());
        }
        self.tree.build(&self.position, &self.mass, &self.radius, attraction);
    }
}

/// What the published slot holds: the latest snapshot, or none (attraction off, or too few balls
/// for the tree: the balls read the table directly).
pub(crate) type PublishedTree = ArcSwapOption<AttractionSnapshot>;

/// The monitor's side: the pool, and what the published snapshot was built from.
#[derive(Default)]
pub(crate) struct TreePublisher {
    pool: Vec<Arc<AttractionSnapshot>>,
    /// The published snapshot's ball count, parameters and the sum of its balls' update counts
    /// (None: nothing published).
    published: Option<(usize, Attraction, u64)>,
}

impl TreePublisher {
    /// Whether the published snapshot is still fresh for `records`: the same balls and
    /// parameters, and fewer than half a cycle per ball made since it was built (the sum of the
    /// balls' update counters grew by less than half the ball count). Rebuilding any sooner would
    /// refresh a field most balls have not moved in: at 256 balls a tree is built every pass
    /// (each ball updates about every millisecond), at 4,096 about every tenth (each updates a
    /// few dozen times a second), which spares the monitor most of a build's cost (0.3–0.5 ms at
    /// 4,096 balls, measured) where its core is needed most. A ball's snapshot is thus at most
    /// about half its own cycle older than its neighbours' records.
    pub(crate) fn is_fresh(&self, records: &[BallRecord], attraction: &Attraction) -> bool {
        let Some((balls, att, updates)) = self.published else { return false };
        let now: u64 = records.iter().map(|r| r.updates).sum();
        balls == records.len() && att == *attraction && now >= updates && now - updates < (balls as u64).div_ceil(2)
    }

    /// Builds a snapshot of `records` into a pooled snapshot nobody holds and publishes it.
    /// Returns false (and publishes nothing new) when all [`MAX_SNAPSHOTS`] are still held.
    pub(crate) fn publish(&mut self, records: &[BallRecord], attraction: &Attraction, to: &PublishedTree) -> bool {
        let free = self.pool.iter_mut().position(|s| Arc::get_mut(s).is_some());
        let k = match free {
            Some(k) => k,
            None if self.pool.len() < MAX_SNAPSHOTS => {
                self.pool.push(Arc::new(AttractionSnapshot::default()));
                self.pool.len() - 1
            }
            None => return false,
        };
        let snapshot = Arc::get_mut(&mut self.pool[k]).expect("a snapshot nobody else holds");
        snapshot.rebuild(records, attraction);
        to.store(Some(Arc::clone(&self.pool[k])));
        self.published = Some((records.len(), *attraction, records.iter().map(|r| r.updates).sum()));
        true
    }

    /// Stops publishing (the balls go back to reading the table). Cheap when nothing is published.
    pub(crate) fn withdraw(&mut self, from: &PublishedTree) {
        if self.published.take().is_some() {
            from.store(None);
        }
    }

    /// Snapshots allocated so far.
    pub(crate) fn pool_size(&self) -> usize {
        self.pool.len()
    }
}
