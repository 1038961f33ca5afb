//! The effects one by one: attraction near r = 0, potentials whose gradient is the force, drag
//! against its formula, and "an effect that is off costs nothing".

mod common;

use ballfield::Lockstep;
use ballfield::physics::{
    Attraction, DEFAULT_OPENING_ANGLE, Drag, Effects, Gravity, Integrator, attraction_force, attraction_potential,
    disc_area, drag_force, drag_rate, drag_rate_bound, quadratic_terminal_speed,
};
use ballfield::scenes;
use common::*;
use glam::DVec2;

const A: Attraction = Attraction { g_constant: 2.0, opening_angle: DEFAULT_OPENING_ANGLE };

#[test]
fn attraction_is_newton_outside_contact_and_finite_down_to_coincidence() {
    let f = attraction_force(DVec2::ZERO, 3.0, 0.5, DVec2::new(4.0, 0.0), 5.0, 0.5, &A);
    assert!((f.x - 2.0 * 3.0 * 5.0 / 16.0).abs() < 1e-14 && f.y == 0.0);
    // Continuous at contact (r = 1), linear inside, exactly zero at r = 0.
    let at = |r: f64| attraction_force(DVec2::ZERO, 3.0, 0.5, DVec2::new(r, 0.0), 5.0, 0.5, &A).x;
    assert!((at(1.0) - at(1.0 - 1e-12)).abs() < 1e-9);
    assert!((at(0.5) - 0.5 * at(1.0)).abs() < 1e-14);
    assert_eq!(attraction_force(DVec2::ONE, 3.0, 0.5, DVec2::ONE, 5.0, 0.5, &A), DVec2::ZERO);
    for r in [1e-300, 1e-200, 1e-20, 0.0] {
        let f = attraction_force(DVec2::ZERO, 3.0, 0.5, DVec2::new(r, r), 5.0, 0.5, &A);
        assert!(f.is_finite() && f.length() <= at(1.0), "r = {r}: {f}");
        assert!(attraction_potential(DVec2::ZERO, 3.0, 0.5, DVec2::new(r, r), 5.0, 0.5, &A).is_finite());
    }
}

#[test]
fn attraction_potential_is_continuous_and_its_gradient_is_the_force() {
    let u = |r: f64| attraction_potential(DVec2::ZERO, 3.0, 0.5, DVec2::new(r, 0.0), 5.0, 0.5, &A);
    let f = |r: f64| attraction_force(DVec2::ZERO, 3.0, 0.5, DVec2::new(r, 0.0), 5.0, 0.5, &A).x;
    assert!((u(1.0) - u(1.0 - 1e-12)).abs() < 1e-9);
    for r in [0.1, 0.5, 0.9, 1.5, 3.0, 10.0] {
        let h = 1e-6;
        // The force on a (at the origin) toward b is +x; dU/dr > 0 means pulling together.
        let du = (u(r + h) - u(r - h)) / (2.0 * h);
        assert!((du - f(r)).abs() < 1e-6 * f(r).abs().max(1.0), "r = {r}: dU/dr {du} vs F {}", f(r));
    }
}

#[test]
fn drag_follows_its_formulas() {
    let v = DVec2::new(3.0, -4.0);
    let q = drag_force(v, 2.0, &Drag::Quadratic { rho: 1.225, cd: 0.47 });
    let expected = -0.5 * 1.225 * 0.47 * disc_area(2.0) * 5.0 * v;
    assert!((q - expected).length() < 1e-12);
    let l = drag_force(v, 2.0, &Drag::Linear { mu: 1.81e-5 });
    assert!((l - -3.0 * std::f64::consts::PI * 1.81e-5 * 2.0 * v).length() < 1e-18);
    assert_eq!(drag_force(DVec2::ZERO, 2.0, &Drag::default()), DVec2::ZERO);
}

/// The drag rate a step must resolve: the rate now, or the rate at the terminal speed the other
/// forces drive the ball to — `c·v_t` with `v_t` the analytic terminal speed — whichever is larger.
#[test]
fn the_drag_rate_bound_is_the_rate_at_the_terminal_speed() {
    let (rho, cd, d, m, g) = (1.225, 0.47, 2.2, 1.6e-3, 9.81);
    let drag = Drag::Quadratic { rho, cd };
    let down = DVec2::new(0.0, -g);
    let terminal = quadratic_terminal_speed(m, d, g, rho, cd);
    let at_terminal = drag_rate(DVec2::new(terminal, 0.0), d, m, &drag);
    // At rest, and below the terminal speed: the terminal speed's rate.
    for speed in [0.0, 0.5 * terminal] {
        let bound = drag_rate_bound(DVec2::new(0.0, -speed), down, d, m, &drag);
        assert!((bound - at_terminal).abs() <= 1e-12 * at_terminal, "{bound} vs {at_terminal}");
    }
    // Faster than it: the rate now.
    let fast = DVec2::new(0.0, -3.0 * terminal);
    assert_eq!(drag_rate_bound(fast, down, d, m, &drag), drag_rate(fast, d, m, &drag));
    // Linear drag's rate does not depend on the speed.
    let linear = Drag::Linear { mu: 1.81e-5 };
    assert_eq!(drag_rate_bound(DVec2::ZERO, down * 1e6, d, m, &linear), drag_rate(DVec2::ZERO, d, m, &linear));
}

/// Two heavy balls released at rest with collisions off pass through each other's centre
/// without a singular kick: energy stays bounded and nothing becomes NaN.
#[test]
fn attracting_balls_fall_through_each_other_without_a_singularity() {
    let effects =
        Effects { attraction: Some(Attraction { g_constant: 1.0, ..Attraction::default() }), ..Effects::default() };
    let balls =
        [ball(0, 5.0e5 - 5.0, 5.0e5, 0.0, 0.0, 1000.0, 2.0), ball(1, 5.0e5 + 5.0, 5.0e5, 0.0, 0.0, 1000.0, 2.0)];
    let mut e = engine(open_field(), effects, Integrator::Leapfrog, 1e-4, &balls);
    let start = e.diagnostics();
    let mut closest = f64::MAX;
    for _ in 0..100_000 {
        e.step();
        closest = closest.min(e.bodies().position[0].distance(e.bodies().position[1]));
        assert!(e.bodies().position.iter().all(|p| p.is_finite()));
    }
    assert!(closest < 0.01, "the balls met ({closest})");
    let end = e.diagnostics();
    assert!(relative(end.total, start.total) < 1e-4, "energy {} -> {}", start.total, end.total);
}

#[test]
fn the_report_lists_exactly_the_effects_that_ran() {
    for (name, expected) in [
        ("vacuum", vec!["collisions"]),
        ("gas", vec!["collisions"]),
        ("gravity", vec!["gravity", "collisions"]),
        ("default", vec!["gravity", "drag", "collisions"]),
        ("attraction", vec!["attraction (direct)", "collisions"]),
    ] {
        let scene = scenes::builtin(name).unwrap().unwrap();
        assert_eq!(Lockstep::new(&scene).active_effects(), expected, "scene {name}");
    }
}

/// With collisions off the broad phase and contact phases never run: their counters stay at zero.
#[test]
fn an_effect_that_is_off_does_no_work() {
    let balls: Vec<_> = (0..50).map(|k| ball(k, 1.0 + 1.3 * k as f64, 5.0, 1.0, 0.0, 1.0, 1.0)).collect();
    let field = ballfield::physics::Field { width: 100.0, height: 10.0, restitution: 1.0 };
    let effects = Effects { gravity: Some(Gravity::default()), ..Effects::default() };
    let mut e = engine(field, effects, Integrator::SemiImplicitEuler, 1e-3, &balls);
    e.run(1000);
    let c = e.counters();
    assert_eq!(c.broad_phase, std::time::Duration::ZERO);
    assert_eq!(c.contacts, std::time::Duration::ZERO);
    assert_eq!(c.touching_pairs, 0);
}
