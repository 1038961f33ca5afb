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
