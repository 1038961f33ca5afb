//! Analytic solutions: free fall, a fall with quadratic drag, and a circular two-body orbit.

mod common;

use ballfield::physics::{Attraction, Drag, Effects, Gravity, Integrator, quadratic_terminal_speed};
use common::*;
use glam::DVec2;

const G: f64 = 9.81;

fn gravity() -> Effects {
    Effects { gravity: Some(Gravity { g: DVec2::new(0.0, -G) }), ..Effects::default() }
}

/// Free fall from rest: y(t) = y0 − ½·g·t². Second- and higher-order integrators are exact for a
/// constant force (to rounding); the first-order ones err by exactly their known O(dt) term.
/// Measured: y off by at most 1.7e-10 m (3 ulp of y0 = 5e5 m) and vy by 5.1e-13 m/s, for every
/// integrator; the bounds are about 10× that. Seen to fail with Yoshida's weight w₁ rounded to 9
/// digits, 1.35120719 (yoshida4's y off by 1.5e-7 m).
#[test]
fn free_fall_matches_half_g_t_squared() {
    let (y0, dt, steps) = (5.0e5, 1e-3, 2000u64);
    let t = steps as f64 * dt;
    let exact = y0 - 0.5 * G * t * t;
    for integrator in Integrator::ALL {
        let mut e = engine(open_field(), gravity(), integrator, dt, &[ball(0, 5.0e5, y0, 0.0, 0.0, 1.0, 1.0)]);
        e.run(steps);
        let y = e.bodies().position[0].y;
        let vy = e.bodies().velocity[0].y;
        // Euler variants: semi-implicit lands ½·g·dt·t low, explicit ½·g·dt·t high.
        let bias = match integrator {
            Integrator::SemiImplicitEuler => -0.5 * G * dt * t,
            Integrator::ExplicitEuler => 0.5 * G * dt * t,
            _ => 0.0,
        };
        let (dy, dvy) = ((y - (exact + bias)).abs(), (vy - -G * t).abs());
        eprintln!("free fall, {integrator}: y off by {dy:e} m, vy by {dvy:e} m/s");
        assert!(dy < 2e-9, "{integrator}: y = {y}, expected {}", exact + bias);
        assert!(dvy < 5e-12, "{integrator}: vy = {vy}");
    }
}

/// The terminal speed of a 1 kg ball of 1 m in air (ρ = 1.225 kg/m³, C_d = 0.47, g = 9.81 m/s²),
/// v_t = sqrt(2mg/(ρ·C_d·π·(d/2)²)), worked out outside the crate (python3:
/// `sqrt(2*1*9.81/(1.225*0.47*pi*0.5**2))`).
const TERMINAL_1KG_1M: f64 = 6.586998848500079;

/// A fall from rest with quadratic drag: v(t) = v_t·tanh(g·t/v_t), fallen distance
/// (v_t²/g)·ln cosh(g·t/v_t), with v_t the written-out constant above.
///
/// Measured worst relative errors over the 40 samples (bounds about 10× that): rk4 5.1e-12,
/// yoshida4 2.0e-11, leapfrog 1.9e-7 at dt = 1 ms; semi-implicit Euler 1.0e-3 at dt = 0.1 ms,
/// its first-order term dt/t at the first sample, which the bound of 1.5e-3 follows. Seen to fail
/// with the drag area taken as π·d² instead of π·(d/2)² (the crate's v_t halved, 3.29 m/s), and
/// with Yoshida's weight w₁ rounded to 9 digits (yoshida4's worst error 7.9e-9, which the old
/// bound, 1e-5, passed).
#[test]
fn drag_fall_follows_tanh_to_terminal_speed() {
    let (m, d, rho, cd) = (1.0, 1.0, 1.225, 0.47);
    let vt = TERMINAL_1KG_1M;
    let computed = quadratic_terminal_speed(m, d, G, rho, cd);
    assert!(relative(computed, vt) < 1e-15, "the crate's terminal speed {computed} m/s, worked out {vt} m/s");
    let effects = Effects { drag: Some(Drag::Quadratic { rho, cd }), ..gravity() };
    // Start low in a tall field so that rounding of y is small against the distance fallen.
    let y0 = 2000.0;
    for (integrator, dt, tolerance) in [
        (Integrator::Rk4, 1e-3, 5e-11),
        (Integrator::Yoshida4, 1e-3, 2e-10),
        (Integrator::Leapfrog, 1e-3, 2e-6),
        // First order: the relative error in the distance fallen is about dt/t, 1e-3 at the first
        // sample (t = 0.1 s).
        (Integrator::SemiImplicitEuler, 1e-4, 1.5e-3),
    ] {
        let mut e = engine(open_field(), effects, integrator, dt, &[ball(0, 5.0e5, y0, 0.0, 0.0, m, d)]);
        let mut worst = 0.0f64;
        for _ in 0..40 {
            e.run((0.1 / dt).round() as u64);
            let t = e.time();
            let v_exact = vt * (G * t / vt).tanh();
            let fall_exact = vt * vt / G * (G * t / vt).cosh().ln();
            let v = -e.bodies().velocity[0].y;
            let fall = y0 - e.bodies().position[0].y;
            worst = worst.max(relative(v, v_exact)).max(relative(fall, fall_exact));
        }
        eprintln!("drag fall, {integrator} dt {dt}: worst relative error {worst:e}");
        assert!(worst < tolerance, "{integrator} dt {dt}: worst relative error {worst:e}");
        // After 4 s: 1 − tanh(g·t/v_t) ≈ 2·exp(−2·g·t/v_t) = 1.34e-5 short of v_t (measured the same).
        let v = -e.bodies().velocity[0].y;
        assert!(relative(v, vt) < 1.5e-5, "after 4 s the ball falls at its terminal speed {vt}, not {v}");
    }
}

/// Two balls on a circular orbit about their common centre of mass return to their start after
/// one Kepler period T = 2π·sqrt(a³/(G·(m₁+m₂))), and keep their energy.
///
/// Measured (bounds about 10× that): rk4 at 2,000 steps an orbit, position 1.4e-9·a and energy
/// 2.9e-10; yoshida4 at 2,000, 6.4e-10·a and 1.5e-10; leapfrog at 20,000, 2.1e-7·a and 1.7e-9.
/// Seen to fail with Yoshida's weight w₁ rounded to 9 digits (yoshida4 2.7e-8·a from the start,
/// which the old bound, 1e-7, passed).
#[test]
fn circular_orbit_returns_after_one_kepler_period() {
    let (g, m1, m2, a) = (1.0, 100.0, 1.0, 10.0);
    let effects =
        Effects { attraction: Some(Attraction { g_constant: g, ..Attraction::default() }), ..Effects::default() };
    let mu = g * (m1 + m2);
    let v_rel = (mu / a).sqrt();
    let c = DVec2::splat(5.0e5);
    // Positions and velocities about the centre of mass, which stays at rest.
    let r1 = -a * m2 / (m1 + m2);
    let r2 = a * m1 / (m1 + m2);
    let v1 = -v_rel * m2 / (m1 + m2);
    let v2 = v_rel * m1 / (m1 + m2);
    let balls = [ball(0, c.x + r1, c.y, 0.0, v1, m1, 2.0), ball(1, c.x + r2, c.y, 0.0, v2, m2, 1.0)];
    let period = std::f64::consts::TAU * (a * a * a / mu).sqrt();
    for (integrator, steps_per_orbit, position_bound, energy_bound) in [
        (Integrator::Rk4, 2000u64, 1.5e-8, 3e-9),
        (Integrator::Yoshida4, 2000, 6e-9, 1.5e-9),
        (Integrator::Leapfrog, 20_000, 2e-6, 2e-8),
    ] {
        let dt = period / steps_per_orbit as f64;
        let mut e = engine(open_field(), effects, integrator, dt, &balls);
        let start = e.diagnostics();
        e.run(steps_per_orbit);
        let b = e.bodies();
        for (k, orig) in balls.iter().enumerate() {
            let err = b.position[k].distance(orig.position) / a;
            eprintln!("kepler, {integrator}: ball {k} {err:e}·a from its start");
            assert!(err < position_bound, "{integrator}: ball {k} is {err:e}·a from its start after one period");
        }
        let end = e.diagnostics();
        let drift = relative(end.total, start.total);
        eprintln!("kepler, {integrator}: energy drift {drift:e}");
        assert!(drift < energy_bound, "{integrator}: energy drift {drift:e}");
    }
}
