//! `Bodies`: a set of balls stored as parallel arrays (structure of arrays), the layout the hot
//! loops want. Index i of every array is the same ball; ids are stable, indices are not.

use glam::DVec2;

use super::ball::{Ball, BallId, BallKind};
use super::forces::BodyProps;

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bodies {
    pub id: Vec<BallId>,
    pub kind: Vec<BallKind>,
    pub position: Vec<DVec2>,
    pub velocity: Vec<DVec2>,
    pub mass: Vec<f64>,
    pub inverse_mass: Vec<f64>,
    pub diameter: Vec<f64>,
    pub radius: Vec<f64>,
}

impl Bodies {
    pub fn new() -> Self {
        Self::default()
    }

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

    pub fn len(&self) -> usize {
        self.id.len()
    }

    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

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

    pub fn index_of(&self, id: BallId) -> Option<usize> {
        self.id.iter().position(|&x| x == id)
    }

    pub fn key_index(&self) -> Option<usize> {
        self.kind.iter().position(|&k| k == BallKind::Key)
    }

    /// Sets the mass of ball `index` (keeps the inverse in step).
    pub fn set_mass(&mut self, index: usize, mass: f64) {
        self.mass[index] = mass;
        self.inverse_mass[index] = 1.0 / mass;
    }

    pub fn to_balls(&self) -> Vec<Ball> {
        (0..self.len()).map(|i| self.get(i)).collect()
    }

    pub fn props(&self) -> BodyProps<'_> {
        BodyProps { mass: &self.mass, inverse_mass: &self.inverse_mass, diameter: &self.diameter }
    }

    pub fn largest_diameter(&self) -> f64 {
        self.diameter.iter().copied().fold(0.0, f64::max)
    }
}
