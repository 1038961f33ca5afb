// Shared helpers for the integration tests (each test file includes it with `mod common;`).
#![allow(dead_code)]

use ballfield::Lockstep;
use ballfield::physics::{Ball, BallId, BallKind, Effects, Field, Integrator};
use glam::DVec2;

pub fn ball(id: u32, x: f64, y: f64, vx: f64, vy: f64, mass: f64, diameter: f64) -> Ball {
    Ball {
        id: BallId(id),
        kind: BallKind::Ball,
        position: DVec2::new(x, y),
        velocity: DVec2::new(vx, vy),
        mass,
        diameter,
    }
}

pub fn engine(field: Field, effects: Effects, integrator: Integrator, dt: f64, balls: &[Ball]) -> Lockstep {
    Lockstep::from_parts(field, effects, integrator, dt, balls.len().max(1), balls)
}

/// A big field with elastic walls, so that a test's balls never reach a wall.
pub fn open_field() -> Field {
    Field { width: 1.0e6, height: 1.0e6, restitution: 1.0 }
}

pub fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(f64::MIN_POSITIVE)
}
