//! When balls at rest may sleep: left out of the contact solve and held still, their weight on
//! the walls that carried it, until something touches them (Box2D's islands and sleep timer).
//!
//! A ball is *quiet* in a span when nothing but its supports acts on it (no pull, no attraction),
//! no impact struck it, and its speed at the span's end is below [`sleep_speed`]. An *island* is
//! a set of balls joined by touching contacts; it may sleep once every ball in it has been quiet
//! for [`TIME_TO_SLEEP`] and it touches something (a wall or another ball: a lone ball in flight
//! never sleeps, whatever its speed). Its walls then carry what they carried on average while
//! it was quiet.

use glam::DVec2;

/// How long (simulated seconds) every ball of an island stays quiet before it sleeps: Box2D's
/// `b2_timeToSleep`.
pub const TIME_TO_SLEEP: f64 = 0.5;

/// The speed (m/s) below which a ball of `diameter` (m) is quiet: a millimetre a second, or a
/// hundredth of its diameter a second for balls under 10 cm. At 10 px per metre a millimetre a
/// second is a hundredth of a pixel a second; a settled pile's balls move at 0.02–0.2 mm/s.
pub fn sleep_speed(diameter: f64) -> f64 {
    (1e-2 * diameter).min(1e-3)
}

/// Whether a ball is quiet in a span: its uniform acceleration is the field's gravity alone
/// (exactly: no pull), it took no impact, and its velocity `v` at the span's end is below
/// [`sleep_speed`].
pub fn is_quiet(v: DVec2, diameter: f64, acceleration: DVec2, gravity: DVec2, struck: bool) -> bool {
    !struck && acceleration == gravity && v.is_finite() && v.length() < sleep_speed(diameter)
}

/// The forces (N; left, right, bottom, top) the walls carry for an island asleep, of weight
/// `weight` (its mass times gravity, N): what they carried on average while it was quiet
/// (`measured`), each pair of opposite walls made to hold the island's weight exactly. An island
/// at rest takes from its walls exactly what holds it still, but the averages do not add up to
/// that: each ball's stretch of quiet begins when it itself fell quiet, and the load moves
/// between balls while the pile settles (a small pile asleep after a ball landed on it read
/// 0.9975 of its weight on the floor). A pair of walls keeps its measured sum (a frictionless
/// pile's push on the side walls is that pair's own business); its difference becomes the
/// weight's component, neither wall below zero. A pair that carried nothing is left so.
pub fn held_wall_forces(measured: [f64; 4], weight: DVec2) -> [f64; 4] {
    let hold = |low: f64, high: f64, need: f64| {
        let sum = low + high;
        if sum <= 0.0 {
            return (low, high);
        }
        let (low, high) = (0.5 * (sum + need), 0.5 * (sum - need));
        if high < 0.0 {
            (need, 0.0)
        } else if low < 0.0 {
            (0.0, -need)
        } else {
            (low, high)
        }
    };
    // The left and bottom walls push along +x and +y, the others against.
    let (left, right) = hold(measured[0], measured[1], -weight.x);
    let (bottom, top) = hold(measured[2], measured[3], -weight.y);
    [left, right, bottom, top]
}

/// The islands of `n` balls joined by touching pairs: a union–find with path halving and union by
/// size, reused from pass to pass.
#[derive(Clone, Debug, Default)]
pub struct Islands {
    parent: Vec<u32>,
    size: Vec<u32>,
}

impl Islands {
    /// Every ball of `0..n` an island of its own.
    pub fn reset(&mut self, n: usize) {
        self.parent.clear();
        self.parent.extend(0..n as u32);
        self.size.clear();
        self.size.resize(n, 1);
    }

    /// The island ball `i` is in (its root).
    pub fn find(&mut self, mut i: u32) -> u32 {
        while self.parent[i as usize] != i {
            let grand = self.parent[self.parent[i as usize] as usize];
            self.parent[i as usize] = grand;
            i = grand;
        }
        i
    }

    /// Joins the islands of `a` and `b`.
    pub fn join(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra == rb {
            return;
        }
        let (big, small) = if self.size[ra as usize] >= self.size[rb as usize] { (ra, rb) } else { (rb, ra) };
        self.parent[small as usize] = big;
        self.size[big as usize] += self.size[small as usize];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The walls of an island asleep hold its weight exactly: a floor that read 0.9975 of it
    /// carries it all, the side walls keep their sum and share it; a pair that carried nothing
    /// stays at zero.
    #[test]
    fn an_island_asleep_is_held_by_its_walls_exactly() {
        let weight = DVec2::new(0.0, -100.0);
        let held = held_wall_forces([3.0, 5.0, 99.75, 0.0], weight);
        assert_eq!(held, [4.0, 4.0, 100.0, 0.0]);
        // A pile pressed against the top as well keeps the floor's and the top's sum.
        assert_eq!(held_wall_forces([0.0, 0.0, 130.0, 20.0], weight), [0.0, 0.0, 125.0, 25.0]);
        assert_eq!(held_wall_forces([0.0, 0.0, 0.0, 0.0], weight), [0.0; 4]);
    }

    #[test]
    fn islands_are_the_connected_sets_of_touching_pairs() {
        let mut islands = Islands::default();
        islands.reset(6);
        for (a, b) in [(0, 1), (2, 3), (1, 3), (4, 4)] {
            islands.join(a, b);
        }
        let roots: Vec<u32> = (0..6).map(|i| islands.find(i)).collect();
        assert!(roots[0] == roots[1] && roots[1] == roots[2] && roots[2] == roots[3]);
        assert_ne!(roots[0], roots[4]);
        assert_ne!(roots[4], roots[5]);
        islands.reset(2);
        assert_ne!(islands.find(0), islands.find(1));
    }

    #[test]
    fn a_ball_is_quiet_only_slow_unstruck_and_under_gravity_alone() {
        let g = DVec2::new(0.0, -9.81);
        let slow = DVec2::new(0.0, 5e-4);
        assert!(is_quiet(slow, 1.0, g, g, false));
        assert!(!is_quiet(slow, 1.0, g, g, true), "struck");
        assert!(!is_quiet(slow, 1.0, g + DVec2::X * 1e-12, g, false), "pulled");
        assert!(!is_quiet(DVec2::new(0.0, 1.1e-3), 1.0, g, g, false), "too fast for a 1 m ball");
        // A 2 cm ball: a hundredth of its diameter a second, 0.2 mm/s.
        assert!(!is_quiet(slow, 0.02, g, g, false));
        assert!(is_quiet(DVec2::new(1.9e-4, 0.0), 0.02, g, g, false));
        assert!(!is_quiet(DVec2::new(f64::NAN, 0.0), 1.0, g, g, false));
    }
}
