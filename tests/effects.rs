//! The effects one by one: attraction near r = 0, potentials whose gradient is the force, drag
//! against its formula, and "an effect that is off costs nothing".

mod common;

use ballfield::Lockstep;
use ballfield::physics::{
    Attraction, DEFAULT_OPENING_ANGLE, Drag, Effects, Gravity, Integrator, attraction_force, attraction_potential,
    drag_force, drag_rate, drag_rate_bound, quadratic_terminal_speed,
};
use ballfield::scenes;
use common::*;
use glam::DVec2;

const A: Attraction = Attraction { g_constant: 2.0, opening_angle: DEFAULT_OPENING_ANGLE };

/// Newton's G·m·M/r² = 2·3·5/4² = 1.875 N at 4 m (measured: exact); at contact (r = R = 1 m)
/// 30 N; inside, the force of a uniform ball, G·m·M·r/R³: 15 N at 0.5 m, and 1e-12 m inside
/// contact 30·(1 − 1e-12) N, so the step across contact is the interior force's own slope, 3e-11 N
/// (measured 2.99991e-11; bound 3e-10). Seen to fail with an interior force growing as r² (15 N
/// at 0.5 m became 7.5 N).
#[test]
fn attraction_is_newton_outside_contact_and_finite_down_to_coincidence() {
    let f = attraction_force(DVec2::ZERO, 3.0, 0.5, DVec2::new(4.0, 0.0), 5.0, 0.5, &A);
    assert!((f.x - 1.875).abs() <= 1e-15 && f.y == 0.0, "{f}");
    // Continuous at contact (r = 1), linear inside, exactly zero at r = 0.
    let at = |r: f64| attraction_force(DVec2::ZERO, 3.0, 0.5, DVec2::new(r, 0.0), 5.0, 0.5, &A).x;
    assert!((at(1.0) - 30.0).abs() <= 1e-14, "{}", at(1.0));
    assert!((at(1.0) - at(1.0 - 1e-12)).abs() < 3e-10);
    assert!((at(0.5) - 15.0).abs() < 1e-14, "{}", at(0.5));
    assert_eq!(attraction_force(DVec2::ONE, 3.0, 0.5, DVec2::ONE, 5.0, 0.5, &A), DVec2::ZERO);
    for r in [1e-300, 1e-200, 1e-20, 0.0] {
        let f = attraction_force(DVec2::ZERO, 3.0, 0.5, DVec2::new(r, r), 5.0, 0.5, &A);
        assert!(f.is_finite() && f.length() <= at(1.0), "r = {r}: {f}");
        assert!(attraction_potential(DVec2::ZERO, 3.0, 0.5, DVec2::new(r, r), 5.0, 0.5, &A).is_finite());
    }
}

/// The potential is −G·m·M/r outside contact (−30 J at R = 1 m; −3 J at 10 m) and continuous at
/// contact: its step over 1e-12 m is the force there times that, 3e-11 J (measured 3.0003e-11;
/// bound 3e-10). Its central difference over ±1 µm is the force to 1.3e-9 of max(F, 1 N) at
/// worst (measured at 0.1 m; 2.5e-11–4e-10 elsewhere: the difference's rounding, U·ε/h); bound
/// 1.5e-8. Seen to fail with the interior potential's 3R² taken as 2R² (the step at contact became 15 J).
#[test]
fn attraction_potential_is_continuous_and_its_gradient_is_the_force() {
    let u = |r: f64| attraction_potential(DVec2::ZERO, 3.0, 0.5, DVec2::new(r, 0.0), 5.0, 0.5, &A);
    let f = |r: f64| attraction_force(DVec2::ZERO, 3.0, 0.5, DVec2::new(r, 0.0), 5.0, 0.5, &A).x;
    assert!((u(1.0) - -30.0).abs() <= 1e-14 && (u(10.0) - -3.0).abs() <= 1e-15, "{} {}", u(1.0), u(10.0));
    assert!((u(1.0) - u(1.0 - 1e-12)).abs() < 3e-10);
    for r in [0.1, 0.5, 0.9, 1.5, 3.0, 10.0] {
        let h = 1e-6;
        // The force on a (at the origin) toward b is +x; dU/dr > 0 means pulling together.
        let du = (u(r + h) - u(r - h)) / (2.0 * h);
        assert!((du - f(r)).abs() < 1.5e-8 * f(r).abs().max(1.0), "r = {r}: dU/dr {du} vs F {}", f(r));
    }
}

/// Drag on a ball of 2 m at (3, −4) m/s, worked out outside the crate (python3): quadratic
/// −½·ρ·C_d·π·1²·|v|·v = (−13.565789777282426, 18.087719703043234) N (ρ = 1.225, C_d = 0.47);
/// Stokes −3π·μ·d·v = (−0.0010235308865395546, 0.0013647078487194061) N (μ = 1.81e-5). Measured:
/// both exact; the bounds are a few ulp. Seen to fail with the drag area taken as π·d² (4×).
#[test]
fn drag_follows_its_formulas() {
    let v = DVec2::new(3.0, -4.0);
    let q = drag_force(v, 2.0, &Drag::Quadratic { rho: 1.225, cd: 0.47 });
    assert!((q - DVec2::new(-13.565789777282426, 18.087719703043234)).length() < 2e-14, "{q}");
    let l = drag_force(v, 2.0, &Drag::Linear { mu: 1.81e-5 });
    assert!((l - DVec2::new(-0.0010235308865395546, 0.0013647078487194061)).length() < 2e-18, "{l}");
    assert_eq!(drag_force(DVec2::ZERO, 2.0, &Drag::default()), DVec2::ZERO);
}

/// The drag rate a step must resolve: the rate now, or the rate at the terminal speed the other
/// forces drive the ball to — `c·v_t` with `v_t` the analytic terminal speed — whichever is larger.
///
/// For the fuzzer's 1.6 g ball of 2.2 m under g = 9.81 m/s², worked out outside the crate
/// (python3): `c = ½·ρ·C_d·π·1.1²/m = 683.9419012713223` /m, `v_t = √(g/c) = 0.11976361542727416`
/// m/s, the rate there `c·v_t = √(g·c) = 81.91135483845736` /s, at 3·v_t 245.73406451537207 /s,
/// and Stokes' `3π·μ·d/m = 0.23455916149864794` /s. Measured: within 2 ulp of each; bounds 1e-15
/// relative. Seen to fail with the drag area taken as π·d² (v_t halved, 0.0599 m/s).
#[test]
fn the_drag_rate_bound_is_the_rate_at_the_terminal_speed() {
    let (rho, cd, d, m, g) = (1.225, 0.47, 2.2, 1.6e-3, 9.81);
    let drag = Drag::Quadratic { rho, cd };
    let down = DVec2::new(0.0, -g);
    let terminal = quadratic_terminal_speed(m, d, g, rho, cd);
    assert!(relative(terminal, 0.11976361542727416) < 1e-15, "terminal speed {terminal:?}");
    let at_terminal = 81.91135483845736;
    assert!(relative(drag_rate(DVec2::new(terminal, 0.0), d, m, &drag), at_terminal) < 1e-15);
    // At rest, and below the terminal speed: the terminal speed's rate.
    for speed in [0.0, 0.5 * terminal] {
        let bound = drag_rate_bound(DVec2::new(0.0, -speed), down, d, m, &drag);
        assert!(relative(bound, at_terminal) < 1e-15, "{bound:?} vs {at_terminal:?}");
    }
    // Faster than it: the rate now.
    let fast = DVec2::new(0.0, -3.0 * terminal);
    assert_eq!(drag_rate_bound(fast, down, d, m, &drag), drag_rate(fast, d, m, &drag));
    assert!(relative(drag_rate(fast, d, m, &drag), 245.73406451537207) < 1e-15);
    // Linear drag's rate does not depend on the speed.
    let linear = Drag::Linear { mu: 1.81e-5 };
    let stokes = drag_rate_bound(DVec2::ZERO, down * 1e6, d, m, &linear);
    assert_eq!(stokes, drag_rate(DVec2::new(5.0, 0.0), d, m, &linear));
    assert!(relative(stokes, 0.23455916149864794) < 1e-15, "{stokes:?}");
}

/// Two heavy balls released at rest with collisions off pass through each other's centre
/// without a singular kick: energy stays bounded and nothing becomes NaN. Measured: closest
/// approach 7.4e-5 m, energy drift 1.5e-6 over 10 s (bound 1.5e-5). Seen to fail with an
/// interior force growing as r² (drift 1.85e-5, which the old bound, 1e-4, passed).
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
    let drift = relative(end.total, start.total);
    eprintln!("falling through each other: closest {closest:e} m, energy drift {drift:e}");
    assert!(drift < 1.5e-5, "energy {} -> {}", start.total, end.total);
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
