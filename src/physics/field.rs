//! The field: a rectangle `[0, width] × [0, height]` (m, y up) walled on four sides.

use serde::{Deserialize, Serialize};

/// The field the balls move in.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Field {
    /// Extent along x, m: the right wall is at `x = width`.
    pub width: f64,
    /// Extent along y, m: the top wall is at `y = height`.
    pub height: f64,
    /// Coefficient of restitution of the walls, in [0, 1].
    pub restitution: f64,
}

impl Default for Field {
    fn default() -> Self {
        Field { width: 70.0, height: 50.0, restitution: 1.0 }
    }
}

impl Field {
    /// Whether a ball of radius `radius` centred at (x, y) lies wholly inside, with a tolerance.
    pub fn contains(&self, x: f64, y: f64, radius: f64, tolerance: f64) -> bool {
        x - radius >= -tolerance
            && x + radius <= self.width + tolerance
            && y - radius >= -tolerance
            && y + radius <= self.height + tolerance
    }
}

/// One of the four walls.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Wall {
    /// The wall at `x = 0`.
    Left,
    /// The wall at `x = width`.
    Right,
    /// The floor, at `y = 0`.
    Bottom,
    /// The ceiling, at `y = height`.
    Top,
}

impl Wall {
    /// The wall's place in the order left, right, bottom, top (that of [`WallImpulses`]'s
    /// fields), for tables kept per wall.
    #[inline]
    pub fn index(self) -> usize {
        match self {
            Wall::Left => 0,
            Wall::Right => 1,
            Wall::Bottom => 2,
            Wall::Top => 3,
        }
    }
}

/// Impulse taken by each wall (N·s, magnitudes), summed over a run: the field's pressure gauge.
/// Divided by the elapsed time and the wall's length it is the pressure on that wall.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WallImpulses {
    /// Impulse taken by the left wall (`x = 0`), N·s.
    pub left: f64,
    /// Impulse taken by the right wall (`x = width`), N·s.
    pub right: f64,
    /// Impulse taken by the floor (`y = 0`), N·s: for a resting pile, its weight times the time.
    pub bottom: f64,
    /// Impulse taken by the ceiling (`y = height`), N·s.
    pub top: f64,
}

impl WallImpulses {
    /// Adds `impulse` (N·s, a magnitude) to the tally of `wall`.
    #[inline]
    pub fn add(&mut self, wall: Wall, impulse: f64) {
        match wall {
            Wall::Left => self.left += impulse,
            Wall::Right => self.right += impulse,
            Wall::Bottom => self.bottom += impulse,
            Wall::Top => self.top += impulse,
        }
    }

    /// Adds another tally, wall by wall.
    pub fn add_all(&mut self, other: &WallImpulses) {
        self.left += other.left;
        self.right += other.right;
        self.bottom += other.bottom;
        self.top += other.top;
    }

    /// Sum of the four walls' impulses, N·s.
    pub fn total(&self) -> f64 {
        self.left + self.right + self.bottom + self.top
    }

    /// The net momentum the walls gave the balls: left pushes +x, right −x, bottom +y, top −y.
    pub fn momentum_given(&self) -> glam::DVec2 {
        glam::DVec2::new(self.left - self.right, self.bottom - self.top)
    }
}
