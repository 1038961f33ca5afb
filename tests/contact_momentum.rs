//! Contacts between balls never create or destroy momentum (issue 13, point 2), on the lockstep
//! engine: uniform gravity drops out of the relative motion, so a cluster falling freely keeps
//! p₀ + M·g·t to rounding whatever collides inside it and whatever e. Only walls exchange
//! momentum with the field.

mod common;

use ballfield::physics::{Ball, Collisions, Effects, Field, Gravity, Integrator};
use common::*;
use glam::DVec2;

const G: DVec2 = DVec2::new(0.0, -9.81);

/// A column of 6 touching balls falling in mid-air, struck from above by a ball at 10 m/s and
/// from the side by another, plus a crowd of 40 overlapping balls (their contacts pushing apart
/// from the start).
fn cluster() -> Vec<Ball> {
    let mut balls = Vec::new();
    for k in 0..6 {
        balls.push(ball(k, 500.0, 500.0 + k as f64, 0.0, 0.0, 1.0 + 0.5 * k as f64, 1.0));
    }
    balls.push(ball(6, 500.0, 508.0, 0.0, -10.0, 2.0, 1.0));
    balls.push(ball(7, 497.0, 502.0, 6.0, 0.0, 0.7, 0.8));
    let mut state = 12345u64;
    let mut next = || {
        state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    for k in 0..40 {
        let (x, y) = (520.0 + 4.0 * next(), 500.0 + 4.0 * next());
        let (vx, vy) = (2.0 * next() - 1.0, 2.0 * next() - 1.0);
        balls.push(ball(8 + k, x, y, vx, vy, 0.5 + next(), 0.6 + 0.6 * next()));
    }
    balls
}

/// Largest departure of the momentum from p₀ + M·g·t over 3 s, relative to the momentum scale
/// (|p₀| + M·|g|·t + Σ m·|v₀|).
fn drift(e: f64, integrator: Integrator) -> f64 {
    let balls = cluster();
    let field = Field { width: 1000.0, height: 1000.0, restitution: 1.0 };
    let effects = Effects {
        collisions: Some(Collisions { restitution: e }),
        gravity: Some(Gravity { g: G }),
        ..Effects::default()
    };
    let mut engine = engine(field, effects, integrator, 1e-3, &balls);
    let mass: f64 = balls.iter().map(|b| b.mass).sum();
    let p0: DVec2 = balls.iter().map(|b| b.mass * b.velocity).sum();
    let scale0: f64 = balls.iter().map(|b| b.mass * b.velocity.length()).sum();
    let mut worst = 0.0f64;
    for _ in 0..3000 {
        engine.step();
        let t = engine.time();
        let p = DVec2::from(engine.diagnostics().momentum);
        let want = p0 + mass * G * t;
        worst = worst.max((p - want).length() / (scale0 + mass * G.length() * t));
    }
    assert_eq!(engine.wall_impulses().total(), 0.0, "the cluster met no wall");
    assert!(engine.counters().impulses > 50, "the cluster collided ({} impacts)", engine.counters().impulses);
    worst
}

/// Measured: 1.42e-13 of the momentum scale for every e and integrator: the free fall's own
/// rounding (3,000 additions of g·dt to each velocity), the same for every e. On
/// main, with e < 1 the support pass lifted one ball of a pair and gave the other no reaction:
/// the column lost about a quarter of its momentum. Seen to fail by giving the resting phase's
/// impulse to ball a only (`apply` skipping b): drift 0.05.
#[test]
fn a_free_falling_cluster_keeps_p0_plus_mgt_whatever_collides_inside_it() {
    for integrator in [Integrator::SemiImplicitEuler, Integrator::Leapfrog] {
        for e in [0.0, 0.3, 0.7, 0.99, 1.0] {
            let d = drift(e, integrator);
            eprintln!("{integrator} e {e}: momentum drift {d:e}");
            assert!(d < 1e-12, "{integrator}, e = {e}: momentum off by {d} of its scale");
        }
    }
}

/// With walls, the momentum changes by exactly what the walls' gauges say they gave: a pile
/// dropped into a small box at e = 0.5. Measured: 3.4e-14 of the momentum scale.
#[test]
fn only_walls_exchange_momentum_with_the_field() {
    let mut balls = Vec::new();
    for k in 0..60u32 {
        let (i, j) = (k % 10, k / 10);
        let x = 1.0 + 1.1 * i as f64 + 0.05 * (j % 2) as f64;
        balls.push(ball(k, x, 1.0 + 1.2 * j as f64, 3.0 - 0.6 * i as f64, 0.0, 1.0, 1.0));
    }
    let field = Field { width: 12.0, height: 20.0, restitution: 0.5 };
    let effects = Effects {
        collisions: Some(Collisions { restitution: 0.5 }),
        gravity: Some(Gravity { g: G }),
        ..Effects::default()
    };
    let mut engine = engine(field, effects, Integrator::SemiImplicitEuler, 1e-3, &balls);
    let mass: f64 = balls.iter().map(|b| b.mass).sum();
    let p0: DVec2 = balls.iter().map(|b| b.mass * b.velocity).sum();
    let mut worst = 0.0f64;
    for _ in 0..3000 {
        engine.step();
        let d = engine.diagnostics();
        let want = p0 + mass * G * engine.time() + d.wall_impulses.momentum_given();
        let scale = mass * G.length() * engine.time() + d.wall_impulses.total();
        worst = worst.max((DVec2::from(d.momentum) - want).length() / scale);
    }
    eprintln!("box: momentum off the walls' account by {worst:e} of the scale");
    assert!(worst < 1e-12, "momentum off the walls' account by {worst}");
}
