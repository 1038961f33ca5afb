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

/// One ball, in SI units: position and velocity of its centre (m, m/s), mass (kg), diameter (m).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ball {
    pub id: BallId,
    pub kind: BallKind,
    pub position: DVec2,
    pub velocity: DVec2,
    pub mass: f64,
    pub diameter: f64,
}

impl Ball {
    pub fn radius(&self) -> f64 {
        0.5 * self.diameter
    }

    pub fn inverse_mass(&self) -> f64 {
        1.0 / self.mass
    }

    /// Cross-section of the ball seen by the air, `π (d/2)²`.
    pub fn area(&self) -> f64 {
        disc_area(self.diameter)
    }

    pub fn momentum(&self) -> DVec2 {
        self.mass * self.velocity
    }

    pub fn kinetic_energy(&self) -> f64 {
        0.5 * self.mass * self.velocity.length_squared()
    }

    pub fn is_finite(&self) -> bool {
        self.position.is_finite() && self.velocity.is_finite() && self.mass.is_finite() && self.diameter.is_finite()
    }
}

/// Area of a disc of diameter `d`.
pub fn disc_area(diameter: f64) -> f64 {
    let r = 0.5 * diameter;
    std::f64::consts::PI * r * r
}
