//! A ball: the plain data every engine moves.

use glam::DVec2;
use serde::{Deserialize, Serialize};

/// A ball's identity. Stable for the ball's whole life; never reused within one run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct BallId(pub u32);

impl std::fmt::Display for BallId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// Whether the ball is the one the player pulls.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BallKind {
    /// The key ball: the arrow keys pull it.
    Key,
    /// Any other ball.
    Ball,
}

impl BallKind {
    /// The word used in state files: `key` or `ball`.
    pub fn as_str(self) -> &'static str {
        match self {
            BallKind::Key => "key",
            BallKind::Ball => "ball",
        }
    }
}

/// The lightest ball an engine accepts, kg: its `1/m` (what every impulse is scaled by) stays a
/// normal number far from overflow. (A scene ball of 1e-320 kg, a subnormal, made `1/m` infinite
/// and every state it touched NaN.)
pub const MIN_MASS: f64 = 1e-12;
/// The heaviest ball an engine accepts, kg: its momentum and energy at the speed limit
/// ([`crate::physics::MAX_SPEED`]), summed over a full field, stay finite with room to spare.
pub const MAX_MASS: f64 = 1e15;

/// One ball, in SI units: position and velocity of its centre (m, m/s), mass (kg), diameter (m).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ball {
    /// The ball's identity, kept when its velocity or mass is changed in place.
    pub id: BallId,
    /// Whether this is the key ball (the one the arrow keys pull).
    pub kind: BallKind,
    /// Position of the centre, m, in field coordinates (origin at the bottom-left corner, y up).
    pub position: DVec2,
    /// Velocity of the centre, m/s.
    pub velocity: DVec2,
    /// Mass, kg; positive for a ball that an engine accepts.
    pub mass: f64,
    /// Diameter, m; positive for a ball that an engine accepts.
    pub diameter: f64,
}

impl Ball {
    /// Radius, m: half the diameter.
    pub fn radius(&self) -> f64 {
        0.5 * self.diameter
    }

    /// `1/m`, 1/kg: the factor an impulse is divided by, the form the contact solver uses.
    pub fn inverse_mass(&self) -> f64 {
        1.0 / self.mass
    }

    /// Cross-section of the ball seen by the air, `π (d/2)²`.
    pub fn area(&self) -> f64 {
        disc_area(self.diameter)
    }

    /// Momentum `m·v`, kg·m/s (N·s).
    pub fn momentum(&self) -> DVec2 {
        self.mass * self.velocity
    }

    /// Kinetic energy `½·m·|v|²`, J.
    pub fn kinetic_energy(&self) -> f64 {
        0.5 * self.mass * self.velocity.length_squared()
    }

    /// Whether position, velocity, mass and diameter are all finite (no NaN or infinity): the
    /// first check on a ball read from a file or handed in by a caller.
    pub fn is_finite(&self) -> bool {
        self.position.is_finite() && self.velocity.is_finite() && self.mass.is_finite() && self.diameter.is_finite()
    }
}

/// Area of a disc of diameter `d` (m), m².
pub fn disc_area(diameter: f64) -> f64 {
    let r = 0.5 * diameter;
    std::f64::consts::PI * r * r
}
