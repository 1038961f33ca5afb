//! Walls reflect the normal velocity with their restitution and count the impulse they take.

mod common;

use ballfield::physics::{Effects, Field, Gravity, Integrator};
use common::*;

#[test]
fn a_ball_bouncing_between_two_walls_gives_each_2mv_per_hit() {
    let field = Field { width: 10.0, height: 10.0, restitution: 1.0 };
    // 1 m ball at 4 m/s in x: it travels 9 m between hits, one hit every 2.25 s.
    let mut e = engine(
        field,
        Effects::default(),
        Integrator::SemiImplicitEuler,
        1e-3,
        &[ball(0, 5.0, 5.0, 4.0, 0.0, 2.0, 1.0)],
    );
    e.run(10_000); // 10 s: hits at 1.125 (right), 3.375 (left), 5.625 (right), 7.875 (left)
    let w = e.wall_impulses();
    assert!((w.right - 2.0 * 2.0 * 2.0 * 4.0).abs() < 1e-12, "right {}", w.right);
    assert!((w.left - 2.0 * 2.0 * 2.0 * 4.0).abs() < 1e-12, "left {}", w.left);
    assert_eq!((w.top, w.bottom), (0.0, 0.0));
    assert_eq!(e.bodies().velocity[0].x, 4.0);
    assert!(e.diagnostics().outside == 0);
}

#[test]
fn wall_restitution_scales_the_rebound() {
    let field = Field { width: 10.0, height: 10.0, restitution: 0.5 };
    let mut e = engine(
        field,
        Effects::default(),
        Integrator::SemiImplicitEuler,
        1e-3,
        &[ball(0, 5.0, 5.0, -4.0, 0.0, 1.0, 1.0)],
    );
    e.run(2000);
    assert_eq!(e.bodies().velocity[0].x, 2.0);
    assert!((e.wall_impulses().left - 1.5 * 4.0).abs() < 1e-12);
}

/// A ball dropped on the floor with e = 1 bounces back to its release height, and over many
/// bounces the floor's impulse equals m·g·t (it carries the ball's weight on average).
#[test]
fn an_elastic_ball_keeps_bouncing_and_the_floor_carries_its_weight() {
    let field = Field { width: 10.0, height: 20.0, restitution: 1.0 };
    let effects = Effects { gravity: Some(Gravity::default()), ..Effects::default() };
    let mut e = engine(field, effects, Integrator::Leapfrog, 1e-4, &[ball(0, 5.0, 10.0, 0.0, 0.0, 3.0, 1.0)]);
    let start = e.diagnostics().total;
    let mut top = 0.0f64;
    for _ in 0..200_000 {
        e.step();
        if e.time() > 15.0 {
            top = top.max(e.bodies().position[0].y);
        }
    }
    assert!((top - 10.0).abs() < 2e-3, "bounces back to 10 m, reached {top}");
    assert!(relative(e.diagnostics().total, start) < 1e-3);
    let weight_impulse = 3.0 * 9.81 * e.time();
    assert!(
        relative(e.wall_impulses().bottom, weight_impulse) < 0.1,
        "{} vs {}",
        e.wall_impulses().bottom,
        weight_impulse
    );
}
