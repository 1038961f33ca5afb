//! `Bodies`: a set of balls stored as parallel arrays (structure of arrays), the layout the hot
//! loops want. Index i of every array is the same ball; ids are stable, indices are not.

use glam::DVec2;

use super::ball::{Ball, BallId, BallKind};
use super::forces::BodyProps;

/// A set of balls as parallel arrays, one entry per ball at the same index in each. The arrays
/// are public so that the hot loops can borrow them separately (positions mutably, masses
/// shared); [`Bodies::push`], [`Bodies::remove`] and [`Bodies::set_mass`] keep them the same
/// length and the derived arrays (`inverse_mass`, `radius`) in step.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bodies {
    /// Each ball's stable identity.
    pub id: Vec<BallId>,
    /// Whether each ball is the key ball.
    pub kind: Vec<BallKind>,
    /// Centres, m.
    pub position: Vec<DVec2>,
    /// Velocities of the centres, m/s.
    pub velocity: Vec<DVec2>,
    /// Masses, kg.
    pub mass: Vec<f64>,
    /// `1/mass`, 1/kg, stored so that the contact solver multiplies instead of dividing.
    pub inverse_mass: Vec<f64>,
    /// Diameters, m.
    pub diameter: Vec<f64>,
    /// Radii, m: half the diameters, stored for the broad phase and contacts.
    pub radius: Vec<f64>,
}

impl Bodies {
    /// An empty set.
    pub fn new() -> Self {
        Self::default()
    }

    /// A set holding `balls`, in their order.
    pub fn from_balls(balls: &[Ball]) -> Self {
        let mut b = Bodies::default();
        for ball in balls {
            b.push(*ball);
        }
        b
    }

    /// Empties the set, keeping its memory.
    pub fn clear(&mut self) {
        self.id.clear();
        self.kind.clear();
        self.position.clear();
        self.velocity.clear();
        self.mass.clear();
        self.inverse_mass.clear();
        self.diameter.clear();
        self.radius.clear();
    }

    /// Number of balls.
    pub fn len(&self) -> usize {
        self.id.len()
    }

    /// Whether the set holds no ball.
    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    /// Appends `ball` at the end, computing its inverse mass and radius.
    pub fn push(&mut self, ball: Ball) {
        self.id.push(ball.id);
        self.kind.push(ball.kind);
        self.position.push(ball.position);
        self.velocity.push(ball.velocity);
        self.mass.push(ball.mass);
        self.inverse_mass.push(1.0 / ball.mass);
        self.diameter.push(ball.diameter);
        self.radius.push(0.5 * ball.diameter);
    }

    /// Removes ball `index`, keeping the order of the others (so a run stays deterministic).
    pub fn remove(&mut self, index: usize) -> Ball {
        let ball = self.get(index);
        self.id.remove(index);
        self.kind.remove(index);
        self.position.remove(index);
        self.velocity.remove(index);
        self.mass.remove(index);
        self.inverse_mass.remove(index);
        self.diameter.remove(index);
        self.radius.remove(index);
        ball
    }

    /// A copy of ball `index` as a [`Ball`]. Panics if `index` is out of range, as slice
    /// indexing does; callers look an id up with [`Bodies::index_of`] first.
    pub fn get(&self, index: usize) -> Ball {
        Ball {
            id: self.id[index],
            kind: self.kind[index],
            position: self.position[index],
            velocity: self.velocity[index],
            mass: self.mass[index],
            diameter: self.diameter[index],
        }
    }

    /// The index of the ball with identity `id`, if it is in the set (a linear search).
    pub fn index_of(&self, id: BallId) -> Option<usize> {
        self.id.iter().position(|&x| x == id)
    }

    /// The index of the first key ball, if there is one.
    pub fn key_index(&self) -> Option<usize> {
        self.kind.iter().position(|&k| k == BallKind::Key)
    }

    /// Sets the mass of ball `index` (keeps the inverse in step).
    pub fn set_mass(&mut self, index: usize, mass: f64) {
        self.mass[index] = mass;
        self.inverse_mass[index] = 1.0 / mass;
    }

    /// Every ball as a [`Ball`], in index order.
    pub fn to_balls(&self) -> Vec<Ball> {
        (0..self.len()).map(|i| self.get(i)).collect()
    }

    /// The per-ball constants the force evaluation reads (mass, inverse mass, diameter),
    /// borrowed so that positions and velocities can be borrowed mutably beside them.
    pub fn props(&self) -> BodyProps<'_> {
        BodyProps { mass: &self.mass, inverse_mass: &self.inverse_mass, diameter: &self.diameter }
    }

    /// The largest diameter, m; 0 for an empty set.
    pub fn largest_diameter(&self) -> f64 {
        self.diameter.iter().copied().fold(0.0, f64::max)
    }
}
