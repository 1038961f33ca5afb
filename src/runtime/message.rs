//! Messages to a ball's thread. Everyone but the ball itself changes a ball only by sending it
//! one of these: the ball's thread stays the single writer of its state.

use glam::DVec2;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Message {
    /// From the collision monitor: add `dv` to the velocity and `dx` to the position. Relative
    /// changes, not absolute values: however late it is applied, momentum stays exact and what
    /// gravity did meanwhile is kept. Counted in the ball's `applied` counter.
    Contact { dv: DVec2, dx: DVec2 },
    /// The player's pull (N) on the key ball, held until the next `Pull`.
    Pull(DVec2),
    /// A new mass (kg) for this ball (the panel's key-ball mass slider).
    SetMass(f64),
    /// Grab: set the velocity (only the user's mouse throw does this).
    Throw(DVec2),
    /// Finish the current cycle and exit.
    Stop,
    /// Test hook: the ball's thread sleeps this long inside its cycle, as if the machine had
    /// stalled it; its next dt is then that long (and is split into sub-steps).
    #[doc(hidden)]
    Stall(std::time::Duration),
    /// Test hook: panic inside the ball's thread.
    #[doc(hidden)]
    Panic,
}
