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

/// Compile-time check: messages cross from the runtime and the monitor to a ball's thread (by
/// channel and ring), so they are `Send`; the grid is read by every thread, so it is `Sync` too.
const _: () = {
    const fn send<T: Send>() {}
    const fn shared<T: Send + Sync>() {}
    send::<Message>();
    send::<Contact>();
    shared::<Grid>();
};

/// A contact response, stamped. The monitor solved the ball's contacts on its state extrapolated
/// to the instant `stamp` (the end of the interval the pass judged): there, the velocity changes
/// by `dv` and the position by `dx`. Applied at any instant `t` of the ball's own timeline, it is
/// the same change as at `stamp`: `v += dv`, `x += dx + dv·(t − stamp)` (the ball then moves on
/// with the new velocity for `t − stamp`, or has moved with it since). Under uniform forces this
/// is exact whenever it is applied. The ball applies it no earlier than `apply_at` (the instant
/// of its first impact in the pass, so that it never shows a state between the impact's two
/// sides; `stamp` for resting contacts alone), and never later than it reaches the horizon the
/// pass published.
///
/// Why resting contacts act at `stamp`: the solve found them in the ball's free motion to
/// `stamp`, which the monitor has carried the ball through already, so it carries the ball
/// through the response without integrating the span again (a ball applying its support at the
/// start of the span was integrated twice a pass, once free and once supported: on the 1,024-ball
/// pile that was a tenth of the monitor's pass). Between passes the ball shows its free fall,
/// ½·g·h² into its support (5 µm for a 1 ms span), which the response takes back.
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
    /// Whether the ball sleeps or wakes at `stamp` (see [`Rest`]).
    pub rest: Rest,
}

/// What a contact message does to a ball's sleep (see `physics::sleep`). The monitor alone puts
/// balls to sleep and wakes them, each at the edge of a span it judged, so that no ball sleeps or
/// wakes inside a span whose contacts were judged the other way.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Rest {
    /// Neither.
    #[default]
    Unchanged,
    /// From `stamp` on the ball is held still: its thread stops integrating it (the clock goes
    /// on), and the message's `dv` is minus the velocity the monitor carried the ball to (so the
    /// ball stops exactly when its motion was the monitor's to the bit; a velocity a throw set
    /// since is kept, and the monitor then wakes the ball). Applied at `stamp` only.
    Sleep,
    /// From `stamp` on the ball moves again, from where it was held, with its velocity and its
    /// uniform acceleration. A wake moves nothing itself (`dv` and `dx` are zero).
    Wake,
}

impl Rest {
    /// A ball's sleep (`asleep`) once a message with this rest is applied: the ball's thread and
    /// the monitor's prediction of it follow the same rule.
    #[inline]
    pub fn apply(self, asleep: &mut bool) {
        match self {
            Rest::Unchanged => {}
            Rest::Sleep => *asleep = true,
            Rest::Wake => *asleep = false,
        }
    }

    /// The message word for the ring.
    pub fn word(self) -> u64 {
        match self {
            Rest::Unchanged => 0,
            Rest::Sleep => 1,
            Rest::Wake => 2,
        }
    }

    /// The rest of a ring word (what `word` wrote; anything else reads as `Unchanged`).
    pub fn from_word(w: u64) -> Self {
        match w {
            1 => Rest::Sleep,
            2 => Rest::Wake,
            _ => Rest::Unchanged,
        }
    }
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

/// The grid every ball's integration is cut at: the instants `reference + k·period` (runtime
/// clock, ns; `reference` any instant of it — the monitor's horizon always is one, as every span
/// it judges is whole periods from the first). A ball thread and the monitor both cross any
/// stretch of time as the same pieces, cut at the grid's instants, so that the monitor's
/// prediction of a ball is the ball's own arithmetic: under an integrator that is not exact for
/// a uniform force (semi-implicit Euler strays from the parabola by `½·g·Σh²` over steps `h`),
/// balls that took steps cut where each happened to wake did not move in a straight line
/// relative to each other, and the time of impact the monitor took from it was off.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Grid {
    pub reference: u64,
    pub period: u64,
}

impl Grid {
    /// The first instant of the grid after `t`.
    pub fn next_after(&self, t: u64) -> u64 {
        let p = self.period.max(1);
        if t >= self.reference {
            self.reference + ((t - self.reference) / p + 1) * p
        } else {
            self.reference - ((self.reference - t - 1) / p) * p
        }
    }

    /// The last instant of the grid at or before `t` (0 if there is none: the clock reads 0 for a
    /// moment after the runtime starts, before its first instant).
    pub fn at_or_before(&self, t: u64) -> u64 {
        let p = self.period.max(1);
        if t >= self.reference {
            self.reference + ((t - self.reference) / p) * p
        } else {
            self.reference.saturating_sub((self.reference - t).div_ceil(p) * p)
        }
    }

    /// The pieces `[a, b)` that `[from, to)` is crossed in, cut at the grid's instants (none if
    /// `to` is not later than `from`).
    pub fn pieces(&self, from: u64, to: u64) -> impl Iterator<Item = (u64, u64)> + '_ {
        let mut t = from;
        std::iter::from_fn(move || {
            (t < to).then(|| {
                let next = self.next_after(t).min(to);
                let piece = (t, next);
                t = next;
                piece
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::Grid;

    #[test]
    fn the_grid_cuts_at_whole_periods_through_its_reference() {
        let g = Grid { reference: 10, period: 3 };
        assert_eq!([6, 7, 9, 10, 11, 13].map(|t| g.next_after(t)), [7, 10, 10, 13, 13, 16]);
        assert_eq!([6, 7, 9, 10, 11, 13].map(|t| g.at_or_before(t)), [4, 7, 7, 10, 10, 13]);
        // Before the grid's first instant on the clock: none, and no wrap-around (a ball thread
        // reading the clock at 0 right after the start crossed 2^64 ns of pieces).
        assert_eq!([0, 1, 3].map(|t| g.at_or_before(t)), [0, 1, 1]);
        assert_eq!(g.pieces(8, 17).collect::<Vec<_>>(), [(8, 10), (10, 13), (13, 16), (16, 17)]);
        assert_eq!(g.pieces(10, 13).collect::<Vec<_>>(), [(10, 13)]);
        assert_eq!(g.pieces(13, 13).count(), 0);
    }
}
