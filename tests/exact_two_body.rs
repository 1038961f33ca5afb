//! The exact engine on one collision and one wall bounce: the state after them is the closed-form
//! answer to rounding, at any mass ratio, impact parameter and angle, with gravity and without.
//!
//! The closed forms here are written independently of `physics::event` (the textbook root
//! `(−b − √(b² − a·c))/a` of the contact quadratic, the reflection `v′ = v − 2·m_b/(m_a + m_b)·
//! (Δv·n)·n`), so a wrong root, normal or impulse in the engine shows as a difference far above
//! rounding.
//!
//! Seen to fail on broken builds: the impulse of `physics::collide` over `dᵀW_a d` alone, and the
//! contact root taken as the larger one in `entry_time` (each: the pair at mass ratio 1e-6 collides
//! more than once); the wall bounce with `−0.999·e·v_n` (state error 1.4e-3 at the floor).

use ballfield::engine::{Engine, ExactEngine};
use ballfield::physics::{Ball, BallId, BallKind, Collisions, Effects, Field, Gravity};
use glam::DVec2;

fn ball(id: u32, x: DVec2, v: DVec2, mass: f64, diameter: f64) -> Ball {
    Ball { id: BallId(id), kind: BallKind::Ball, position: x, velocity: v, mass, diameter }
}

fn effects(g: f64) -> Effects {
    Effects {
        collisions: Some(Collisions { restitution: 1.0 }),
        gravity: (g != 0.0).then_some(Gravity { g: DVec2::new(0.0, -g) }),
        ..Effects::default()
    }
}

/// The largest difference of position (m) and velocity (m/s) between the engine's balls and
/// `want`, each relative to `scale` (a length, a speed).
fn error(e: &mut ExactEngine, want: &[(DVec2, DVec2)], scale: (f64, f64)) -> f64 {
    let mut got = Vec::new();
    e.sample(&mut got);
    got.iter()
        .zip(want)
        .map(|(b, (x, v))| (b.position.distance(*x) / scale.0).max(b.velocity.distance(*v) / scale.1))
        .fold(0.0, f64::max)
}

/// Where a ball from `x` at `v` is after `t` under `g` (downwards), and its velocity.
fn fly(x: DVec2, v: DVec2, g: f64, t: f64) -> (DVec2, DVec2) {
    let a = DVec2::new(0.0, -g);
    (x + v * t + 0.5 * a * t * t, v + a * t)
}

/// Two balls of diameters 1 and 0.6 m meet: b, ahead of a by 4 m along the approach direction
/// `angle` and offset sideways by `impact` times the contact distance, approaches at 3 m/s (a
/// moving at 1 m/s). The field is large enough that no wall is reached.
///
/// Measured: at most 1.7e-14 (positions relative to their 26 m, velocities to 3 m/s) over mass
/// ratios 1e-6..1e6, impact parameters 0..0.9, six angles, g = 0 and 9.81: the rounding of the
/// contact normal, which is taken from coordinates of ~20 m (ulp 3.6e-15 m) over a contact
/// distance of 0.8 m, times the 6 m/s a light ball leaves with. Momentum kept to 1.2e-15 and
/// energy to 6.3e-16 (relative). Bounds: 5e-14, 1e-14 and 1e-14.
#[test]
fn a_collision_is_the_closed_form_to_rounding_at_any_mass_ratio_and_angle() {
    let field = Field { width: 40.0, height: 40.0, restitution: 1.0 };
    let (da, db) = (1.0, 0.6);
    let sigma = 0.5 * (da + db);
    let mut worst = (0.0f64, 0.0f64, 0.0f64);
    for g in [0.0, 9.81] {
        for ratio in [1e-6, 1e-3, 0.25, 1.0, 3.0, 1e3, 1e6] {
            for impact in [0.0, 0.3, 0.6, 0.9] {
                for angle in [0.0, 0.4, 1.3, 2.2, 3.5, 5.1] {
                    let (ma, mb) = (1.0, ratio);
                    let dir = DVec2::from_angle(angle);
                    let xa = DVec2::new(14.0, 22.0);
                    let xb = xa + 4.0 * dir + impact * sigma * dir.perp();
                    let va = 1.0 * dir.perp();
                    let vb = va - 3.0 * dir;
                    let mut e =
                        ExactEngine::from_parts(field, effects(g), &[ball(0, xa, va, ma, da), ball(1, xb, vb, mb, db)])
                            .unwrap();
                    // Gravity is common to both: the contact is where the straight relative
                    // motion reaches σ.
                    let (dr, dv) = (xb - xa, vb - va);
                    let (qa, qb, qc) = (dv.length_squared(), dr.dot(dv), dr.length_squared() - sigma * sigma);
                    let tc = (-qb - (qb * qb - qa * qc).sqrt()) / qa;
                    let (xa1, va1) = fly(xa, va, g, tc);
                    let (xb1, vb1) = fly(xb, vb, g, tc);
                    let n = (xb1 - xa1).normalize();
                    let vn = (vb1 - va1).dot(n);
                    let va2 = va1 + 2.0 * mb / (ma + mb) * vn * n;
                    let vb2 = vb1 - 2.0 * ma / (ma + mb) * vn * n;
                    let end = tc + 0.5;
                    e.advance_to(end);
                    let want = [fly(xa1, va2, g, end - tc), fly(xb1, vb2, g, end - tc)];
                    let err = error(&mut e, &want, (xa.length(), 3.0));
                    let mut got = Vec::new();
                    e.sample(&mut got);
                    let ke = |b: &[Ball]| b.iter().map(|b| 0.5 * b.mass * b.velocity.length_squared()).sum::<f64>();
                    let p = |b: &[Ball]| b.iter().map(|b| b.mass * b.velocity).sum::<DVec2>();
                    let before = [ball(0, xa, va, ma, da), ball(1, xb, vb, mb, db)];
                    // At `end` both have fallen for the same time: gravity adds the same to both.
                    let fallen: Vec<Ball> = before
                        .iter()
                        .map(|b| Ball { velocity: b.velocity + DVec2::new(0.0, -g * end), ..*b })
                        .collect();
                    let de = (ke(&got) - ke(&fallen)).abs() / ke(&fallen);
                    let dp = (p(&got) - p(&fallen)).length() / (ma * 3.0 + mb * 3.0);
                    assert_eq!(
                        e.stats().counters.collisions,
                        1,
                        "one collision (g {g}, ratio {ratio}, impact {impact})"
                    );
                    assert!(
                        err < 5e-14 && dp < 1e-14,
                        "g {g}, ratio {ratio}, impact {impact}, angle {angle}: state error {err:e}, momentum {dp:e}"
                    );
                    if g == 0.0 {
                        assert!(de < 1e-14, "ratio {ratio}, impact {impact}, angle {angle}: energy error {de:e}");
                        worst.2 = worst.2.max(de);
                    }
                    worst = (worst.0.max(err), worst.1.max(dp), worst.2);
                }
            }
        }
    }
    eprintln!("worst state error {:e}, momentum {:e}, energy {:e}", worst.0, worst.1, worst.2);
}

/// A ball of diameter 1.2 m thrown at a wall at an angle: it meets the wall where the closed
/// form says and leaves with its normal velocity reversed; the wall's gauge takes `2·m·|v_n|`.
/// The floor under gravity (the impact speed `√(v_y² + 2·g·h)`), and each side wall.
///
/// Measured: at most 1.8e-16 in state (relative to 10 m and 10 m/s) and in the gauge, at masses
/// 1e-3..1e6 kg and angles from 5° to 85°. Bounds: 1e-14.
#[test]
fn a_wall_bounce_is_the_closed_form_to_rounding() {
    let field = Field { width: 40.0, height: 30.0, restitution: 1.0 };
    let d = 1.2;
    let r = 0.5 * d;
    let mut worst = 0.0f64;
    for mass in [1e-3, 1.0, 1e6] {
        for deg in [5.0f64, 30.0, 60.0, 85.0] {
            let a = deg.to_radians();
            // The floor, under gravity: thrown down and sideways from 10 m.
            let g = 9.81;
            let (x0, v0) = (DVec2::new(20.0, 10.0), 8.0 * DVec2::new(a.cos(), -a.sin()));
            let h = x0.y - r;
            let impact = (v0.y * v0.y + 2.0 * g * h).sqrt();
            let tb = 2.0 * h / (impact - v0.y);
            let (x1, v1) = fly(x0, v0, g, tb);
            let v2 = DVec2::new(v1.x, -v1.y);
            let end = tb + 0.3;
            let mut e = ExactEngine::from_parts(field, effects(g), &[ball(0, x0, v0, mass, d)]).unwrap();
            e.advance_to(end);
            let err = error(&mut e, &[fly(x1, v2, g, end - tb)], (10.0, 10.0));
            let gauge = (e.wall_impulses().bottom - 2.0 * mass * impact).abs() / (2.0 * mass * impact);
            assert_eq!(e.stats().counters.wall_bounces, 1, "mass {mass}, {deg}°: one bounce");
            assert!(err < 1e-14 && gauge < 1e-14, "floor, mass {mass}, {deg}°: state {err:e}, gauge {gauge:e}");
            worst = worst.max(err).max(gauge);

            // The right wall, without gravity, from 1 m before it (`deg` from its normal).
            let (x0, v0) = (DVec2::new(field.width - r - 1.0, 15.0), 6.0 * DVec2::new(a.cos(), a.sin()));
            let tb = (field.width - r - x0.x) / v0.x;
            let x1 = x0 + v0 * tb;
            let v2 = DVec2::new(-v0.x, v0.y);
            let end = tb + 0.1;
            let mut e = ExactEngine::from_parts(field, effects(0.0), &[ball(0, x0, v0, mass, d)]).unwrap();
            e.advance_to(end);
            let err = error(&mut e, &[(x1 + v2 * (end - tb), v2)], (10.0, 10.0));
            let gauge = (e.wall_impulses().right - 2.0 * mass * v0.x).abs() / (2.0 * mass * v0.x);
            assert!(err < 1e-14 && gauge < 1e-14, "right wall, mass {mass}, {deg}°: state {err:e}, gauge {gauge:e}");
            worst = worst.max(err).max(gauge);
        }
    }
    eprintln!("worst wall-bounce error {worst:e}");
}
