//! Conservation laws: momentum and energy in collisions, and in a 500-ball elastic gas.

mod common;

use ballfield::physics::{BallId, Collisions, ContactBody, Effects, Field, Integrator, contact_ball_ball};
use ballfield::scenes;
use common::*;
use glam::DVec2;

fn body(id: u32, p: DVec2, v: DVec2, m: f64, d: f64) -> ContactBody {
    ContactBody { id: BallId(id), position: p, velocity: v, inverse_mass: 1.0 / m, radius: 0.5 * d }
}

/// An oblique collision: b is hit off-centre, so both normal and tangential parts are present.
fn oblique(ma: f64, mb: f64, e: f64) -> (ContactBody, ContactBody, ballfield::physics::BallBallContact) {
    let a = body(0, DVec2::new(0.0, 0.0), DVec2::new(3.0, 0.5), ma, 1.0);
    let b = body(1, DVec2::new(0.8, 0.55), DVec2::new(-1.0, 0.25), mb, 1.0);
    let c = contact_ball_ball(&a, &b, e, 0.0).expect("the balls touch");
    (a, b, c)
}

/// Measured: at most 1.5e-16 of Σ m·|v| (a rounding or two) at every mass ratio and e; bound
/// 2e-15. Seen to fail with ball b's velocity change divided by a's mass (`v_b += J·n/m_a`: 1.7
/// at 1:3).
#[test]
fn momentum_is_conserved_to_rounding_for_any_mass_ratio() {
    for (ma, mb) in [(1.0, 1.0), (1.0, 3.0), (1.0, 1.0e6), (1.0e6, 1.0)] {
        for e in [1.0, 0.5, 0.0] {
            let (a, b, c) = oblique(ma, mb, e);
            assert!(c.impulse > 0.0, "the pair approaches, so it gets an impulse");
            let before = ma * a.velocity + mb * b.velocity;
            let after = ma * (a.velocity + c.velocity_change_a) + mb * (b.velocity + c.velocity_change_b);
            let scale = ma * a.velocity.length() + mb * b.velocity.length();
            let err = (after - before).length() / scale;
            assert!(err <= 2e-15, "mass ratio {ma}:{mb}, e = {e}: relative momentum error {err:e}");
        }
    }
}

/// Measured: the loss is ½·μ·(1 − e²)·v_n² to at most 1.1e-16 of the energy before; bound 2e-15.
/// Seen to fail with the impulse's (1 + e) taken as (1 + e²) (at e = 0.8: 0.13 of the energy).
#[test]
fn kinetic_energy_is_kept_for_e1_and_lost_by_the_right_amount_below() {
    for (ma, mb) in [(1.0, 1.0), (1.0, 3.0), (1.0, 1.0e6)] {
        for e in [1.0, 0.8, 0.3, 0.0] {
            let (a, b, c) = oblique(ma, mb, e);
            let ke = |va: DVec2, vb: DVec2| 0.5 * ma * va.length_squared() + 0.5 * mb * vb.length_squared();
            let before = ke(a.velocity, b.velocity);
            let after = ke(a.velocity + c.velocity_change_a, b.velocity + c.velocity_change_b);
            // Energy lost in a normal impact: ½·μ·(1 − e²)·v_n², μ the reduced mass.
            let mu = ma * mb / (ma + mb);
            let vn = (b.velocity - a.velocity).dot(c.normal);
            let expected_loss = 0.5 * mu * (1.0 - e * e) * vn * vn;
            let err = ((before - after) - expected_loss).abs() / before;
            assert!(err <= 2e-15, "mass ratio {ma}:{mb}, e = {e}: energy error {err:e}");
        }
    }
}

/// Measured: tangential changes 4.4e-16 and 2.2e-16 m/s (2 and 1 ulp of the 0.5 m/s involved),
/// the centre of mass moved 7.8e-18 m, the gap after separation exactly 0.
#[test]
fn tangential_velocity_is_untouched_and_separation_keeps_the_centre_of_mass() {
    let (a, b, c) = oblique(2.0, 5.0, 1.0);
    let t = c.normal.perp();
    assert!((c.velocity_change_a.dot(t)).abs() < 1e-15);
    assert!((c.velocity_change_b.dot(t)).abs() < 1e-15);
    let com_shift = 2.0 * c.shift_a + 5.0 * c.shift_b;
    assert!(com_shift.length() < 1e-16, "centre of mass moved by {com_shift}");
    let gap = (b.position + c.shift_b).distance(a.position + c.shift_a) - (a.radius + b.radius);
    assert!(gap.abs() < 1e-15, "after separation the balls just touch (gap {gap:e})");
}

#[test]
fn separating_pairs_get_no_impulse_and_distant_pairs_no_contact() {
    let a = body(0, DVec2::ZERO, DVec2::new(-1.0, 0.0), 1.0, 1.0);
    let b = body(1, DVec2::new(0.9, 0.0), DVec2::new(1.0, 0.0), 1.0, 1.0);
    let c = contact_ball_ball(&a, &b, 1.0, 0.0).unwrap();
    assert_eq!(c.impulse, 0.0);
    assert!(c.penetration > 0.0);
    let far = body(1, DVec2::new(1.0, 0.0), DVec2::new(-1.0, 0.0), 1.0, 1.0);
    assert!(contact_ball_ball(&a, &far, 1.0, 0.0).is_none(), "exactly touching is not overlapping");
}

#[test]
fn head_on_equal_masses_exchange_velocities_in_the_engine() {
    let balls = [ball(0, 10.0, 10.0, 2.0, 0.0, 1.0, 1.0), ball(1, 14.0, 10.0, -1.0, 0.0, 1.0, 1.0)];
    let effects = Effects { collisions: Some(Collisions { restitution: 1.0 }), ..Effects::default() };
    let mut e = engine(
        Field { width: 30.0, height: 20.0, restitution: 1.0 },
        effects,
        Integrator::SemiImplicitEuler,
        1e-3,
        &balls,
    );
    e.run(2000);
    let b = e.bodies();
    // Measured: exact; bound a few ulp of 2 m/s.
    assert!((b.velocity[0].x - -1.0).abs() < 1e-14 && (b.velocity[1].x - 2.0).abs() < 1e-14, "{:?}", b.velocity);
}

/// The 500-ball gas: vacuum, e = 1 everywhere. Kinetic energy is all the energy there is; every
/// impulse and wall bounce keeps it to rounding, so over 10,000 steps it may drift only by
/// accumulated rounding. Measured: 1.0e-15 (bound 1e-14), and p_end − p_start equal to the
/// walls' momentum to 1.8e-16 of their total impulse (bound 2e-15). These two figures depend on
/// the contact solver, but only as any exact impulse does: each collision keeps energy and
/// momentum to a rounding of the pair's, whatever the solver's order of pairs. Seen to fail with
/// the impulse's (1 + e) taken as (1 + e·(1 − 1e-12)): drift 2.2e-11, which the old bound, 1e-9,
/// passed.
#[test]
fn elastic_gas_keeps_energy_to_rounding_over_10000_steps() {
    let scene = scenes::builtin("gas").unwrap().unwrap();
    assert_eq!(scene.balls.len(), 500);
    let mut e = ballfield::Lockstep::new(&scene);
    let start = e.diagnostics();
    e.run(10_000);
    let end = e.diagnostics();
    let drift = relative(end.total, start.total);
    eprintln!("elastic gas: energy drift {drift:e}");
    assert!(drift <= 1e-14, "energy drift {drift:e}");
    assert!(end.largest_overlap_ratio <= 0.01, "largest overlap {} of a diameter", end.largest_overlap_ratio);
    assert_eq!(end.non_finite, 0);
    assert_eq!(end.outside, 0);
    assert!(e.counters().impulses > 1000, "the gas really collided ({} impulses)", e.counters().impulses);
    // Momentum changes only through the walls: p_end − p_start = momentum the walls gave.
    let dp = DVec2::from(end.momentum) - DVec2::from(start.momentum);
    let walls = end.wall_impulses.momentum_given();
    let scale = end.wall_impulses.total();
    eprintln!("elastic gas: momentum off by {:e} of the walls' impulse", (dp - walls).length() / scale);
    assert!((dp - walls).length() <= 2e-15 * scale, "dp {dp} vs walls {walls}");
}
