//! Messages to a ball's thread. Everyone but the ball itself changes a ball only by sending it
//! one of these: the ball's thread stays the single writer of its state.

use glam::DVec2;

/// A message to one ball's thread. Everyone but the ball itself changes a ball only by sending it
/// one of these: the ball's thread stays the single writer of its state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Message {
    /// From the collision monitor: one pass's net response of every contact of this ball.
    /// Relative changes, not absolute values: however late it is applied, momentum stays exact
    /// and what gravity did meanwhile is kept. Counted in the ball's `applied` counter.
    Contact(Contact),
    /// The player's pull (N) on the key ball, held until the next `Pull`.
    Pull(DVec2),
    /// A new mass (kg) for this ball (the panel's key-ball mass slider).
    SetMass(f64),
    /// Grab: set the velocity (only the user's mouse throw does this).
    Throw(DVec2),
    /// Finish the current cycle and exit.
    Stop,
    /// Test hook (feature `test-hooks`): the ball's thread sleeps this long while it takes its
    /// inbox, as if the machine had stalled it; its next cycle starts after the sleep and is that
    /// much longer (and is split into sub-steps).
    #[cfg(feature = "test-hooks")]
    Stall(std::time::Duration),
    /// Test hook (feature `test-hooks`): panic inside the ball's thread.
    #[cfg(feature = "test-hooks")]
    Panic,
}

/// A contact response, stamped. The monitor solved the ball's contacts on its state extrapolated
/// to the instant `stamp` (the end of the interval the pass judged): there, the velocity changes
/// by `dv` and the position by `dx`. Applied at any instant `t` of the ball's own timeline, it is
/// the same change as at `stamp`: `v += dv`, `x += dx + dv·(t − stamp)` (the ball then moves on
/// with the new velocity for `t − stamp`, or has moved with it since). Under uniform forces this
/// is exact whenever it is applied. The ball applies it no earlier than `apply_at` (the instant
/// of its first impact in the pass, or the start of the interval for resting contacts), so that
/// it never shows a state between the impact's two sides, and never later than it reaches the
/// horizon the pass published.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// The velocity change, m/s.
    pub dv: DVec2,
    /// The position change at `stamp`, m.
    pub dx: DVec2,
    /// The instant the response is of (runtime clock, ns; see `Shared::clock`).
    pub stamp: u64,
    /// The earliest instant the ball applies it (runtime clock, ns).
    pub apply_at: u64,
}

impl Contact {
    /// The position change when applied at instant `t` (runtime clock, ns), with `time_scale`
    /// simulated seconds per clock second.
    pub fn shift_at(&self, t: u64, time_scale: f64) -> DVec2 {
        self.dx + self.dv * (clock_seconds(t, self.stamp) * time_scale)
    }
}

/// `a − b` in seconds, signed, for two runtime clock instants (ns).
pub fn clock_seconds(a: u64, b: u64) -> f64 {
    if a >= b { (a - b) as f64 * 1e-9 } else { -((b - a) as f64 * 1e-9) }
}
