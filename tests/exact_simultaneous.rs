//! Simultaneous impacts on balls at rest, in the exact engine: impacts that fall on one instant
//! and involve a ball at rest on the floor are one round, solved together with every striker
//! (`World::strike_simultaneous`), so the order in which the engine meets them does not pick the
//! physics.
//! - struck from both sides at once by mirror-image strikers, a ball at rest stays at rest and
//!   the strikers leave as mirror images, each at e times its speed;
//! - struck by two unequal strikers at once, the three balls leave as the round's closed form
//!   says (both contacts reach their restitution together), as lockstep gives at a small step;
//! - a ball dropped on two balls at rest on the floor (touching each other, or apart) leaves them
//!   as mirror images, and stays on the axis.
//!
//! Seen to fail on the engine before rounds took balls at rest and sliding balls (each impact
//! then its own event, one after the other): every test fails, by metres per second (the
//! figures are in each test's comment).

mod common;

use ballfield::engine::{Engine, ExactEngine};
use ballfield::physics::{Ball, Collisions, Effects, Field, Gravity, Integrator, WallImpulses};
use common::ball;
use glam::DVec2;

const G: f64 = 9.81;

fn field(e: f64) -> Field {
    Field { width: 48.0, height: 20.0, restitution: e }
}

fn effects(e: f64) -> Effects {
    Effects {
        collisions: Some(Collisions { restitution: e }),
        gravity: Some(Gravity { g: DVec2::new(0.0, -G) }),
        ..Effects::default()
    }
}

/// The exact engine's balls (in `balls`' order) and its walls' impulses at `t`.
fn exact(e: f64, balls: &[Ball], t: f64) -> (Vec<Ball>, WallImpulses) {
    let mut engine = ExactEngine::from_parts(field(e), effects(e), balls).unwrap();
    engine.advance_to(t);
    let mut out = Vec::new();
    engine.sample(&mut out);
    let ordered = balls.iter().map(|b| *out.iter().find(|o| o.id == b.id).unwrap()).collect();
    (ordered, engine.wall_impulses())
}

/// Lockstep's balls (in `balls`' order) at `t`, at step `dt` (leapfrog: exact in free flight
/// under gravity, so what differs is the contacts').
fn lockstep(e: f64, balls: &[Ball], dt: f64, t: f64) -> Vec<Ball> {
    let mut engine = common::engine(field(e), effects(e), Integrator::Leapfrog, dt, balls);
    engine.run((t / dt).round() as u64);
    let b = engine.bodies();
    balls
        .iter()
        .map(|s| {
            let k = b.id.iter().position(|&id| id == s.id).unwrap();
            Ball { position: b.position[k], velocity: b.velocity[k], ..*s }
        })
        .collect()
}

/// How far the balls' momentum at `t` is from p₀ + M·g·t plus the walls' impulses (N·s).
fn momentum_error(start: &[Ball], end: &[Ball], walls: WallImpulses, t: f64) -> f64 {
    let p0: DVec2 = start.iter().map(|b| b.mass * b.velocity).sum();
    let p: DVec2 = end.iter().map(|b| b.mass * b.velocity).sum();
    let mass: f64 = start.iter().map(|b| b.mass).sum();
    let from_walls = DVec2::new(walls.left - walls.right, walls.bottom - walls.top);
    (p - (p0 + mass * DVec2::new(0.0, -G) * t + from_walls)).length()
}

/// The ids of the three balls in the three orders the tests number them in.
const NUMBERINGS: [[u32; 3]; 3] = [[0, 1, 2], [2, 0, 1], [1, 2, 0]];

/// A ball of `mid` kg at rest on the floor at x = 24, struck at t = 1 s at once by balls of
/// `striker` kg from x = 19 at +4 m/s and from x = 29 at −4 m/s (all 1 m): by symmetry the ball
/// between stays where it is, and the round's closed form has each striker leave at −e times
/// its speed (both contacts reverse their normal speed with e, the middle ball's speed being
/// zero), whatever the masses. Measured at e = 0, 0.5, 0.99 and 1, 1, 3 and 0.2 kg between
/// strikers of 1 kg, three numberings: the ball between at rest to the bit, the strikers mirror
/// images to the bit and off −e·v by at most 6.2e-14 m/s (the round's sweeps stop within 1e-14
/// of the approach speed), momentum against the walls' impulses to 1.4e-14 N·s. Seen to fail
/// with the impacts one after the other: at e = 0.5 and equal masses the ball between left at
/// 0.1875 m/s and the strikers at −1.4375 and 1.25 m/s; 2.55 m/s at worst (0.2 kg, e = 1).
#[test]
fn a_ball_at_rest_struck_from_both_sides_at_once_stays_at_rest() {
    let mut worst = [0.0f64; 4];
    for e in [0.0, 0.5, 0.99, 1.0] {
        for (mid, striker) in [(1.0, 1.0), (3.0, 1.0), (0.2, 1.0)] {
            for ids in NUMBERINGS {
                let start = [
                    ball(ids[0], 24.0, 0.5, 0.0, 0.0, mid, 1.0),
                    ball(ids[1], 19.0, 0.5, 4.0, 0.0, striker, 1.0),
                    ball(ids[2], 29.0, 0.5, -4.0, 0.0, striker, 1.0),
                ];
                let t = 1.5;
                let (end, walls) = exact(e, &start, t);
                let (m, a, b) = (&end[0], &end[1], &end[2]);
                let still = m.velocity.length().max((m.position - DVec2::new(24.0, 0.5)).length());
                let mirror = (a.position.x + b.position.x - 48.0)
                    .abs()
                    .max((a.position.y - b.position.y).abs())
                    .max((a.velocity + b.velocity).length());
                let closed = (a.velocity - DVec2::new(-4.0 * e, 0.0)).length();
                let p = momentum_error(&start, &end, walls, t);
                eprintln!(
                    "e {e} mid {mid} ids {ids:?}: middle {:?} {:?}, strikers {:?} {:?}: still {still:.2e}, mirror \
                     {mirror:.2e}, off −e·v by {closed:.2e}, momentum {p:.2e}",
                    m.position, m.velocity, a.velocity, b.velocity
                );
                for (w, x) in worst.iter_mut().zip([still, mirror, closed, p]) {
                    *w = w.max(x);
                }
            }
        }
    }
    eprintln!(
        "worst: still {:.2e}, mirror {:.2e}, closed form {:.2e}, momentum {:.2e}",
        worst[0], worst[1], worst[2], worst[3]
    );
    assert!(worst[0] <= 1e-12, "the ball between moved: {:e}", worst[0]);
    assert!(worst[1] <= 1e-12, "the strikers are not mirror images: {:e}", worst[1]);
    assert!(worst[2] <= 1e-12, "the strikers are off −e·v by {:e}", worst[2]);
    assert!(worst[3] <= 1e-12, "momentum off the walls' impulses by {:e}", worst[3]);
}

/// The round's closed form for striker A (`ma` kg at `va` m/s, along +x) and striker B (`mb` kg
/// at `vb`) meeting a ball of `mm` kg at rest between them at once: both contacts reach
/// their restitution, `v_M − v_A = −e·(0 − v_A)` and `v_B − v_M = −e·(v_B − 0)`, a linear system
/// in the two impulses. Returns the velocities after (A, M, B) and the impulses.
fn round(ma: f64, mm: f64, mb: f64, va: f64, vb: f64, e: f64) -> ([f64; 3], [f64; 2]) {
    // j1·(1/mm + 1/ma) − j2/mm = (1 + e)·va;  −j1/mm + j2·(1/mm + 1/mb) = −(1 + e)·vb.
    let (a11, a12, a22) = (1.0 / mm + 1.0 / ma, -1.0 / mm, 1.0 / mm + 1.0 / mb);
    let (r1, r2) = ((1.0 + e) * va, -(1.0 + e) * vb);
    let det = a11 * a22 - a12 * a12;
    let j1 = (r1 * a22 - a12 * r2) / det;
    let j2 = (a11 * r2 - a12 * r1) / det;
    ([va - j1 / ma, (j1 - j2) / mm, vb + j2 / mb], [j1, j2])
}

/// Struck at once by A (from x = 19 at 4 m/s) and B (from x = 28 at −3 m/s), the ball at rest
/// at x = 24 and both strikers leave as the round's closed form says, at every e and mass
/// ratio, however numbered; lockstep at dt = 1e-5 s agrees. Measured at e = 0, 0.5, 0.99 and 1:
/// within 7.3e-14 (m/s, and m) of the closed form, momentum to 1.3e-15 N·s; lockstep (leapfrog)
/// within 8.0e-8 m/s at e < 1 and 6.2e-14 at e = 1. Seen to fail with the impacts one after the
/// other: 2.67 m/s off the closed form (e = 0.5, equal masses: 0.375, −0.875 and 1.5 m/s against
/// 0.5, −1.5 and 2); and at e = 1 by lockstep before its elastic passes took a pair that closes
/// while touching within the margin into the round (both impacts fall on the end of a step here:
/// one pair overlapped by a rounding, the other fell short by one, and the two went one after
/// the other, M, A, B at 0, −3 and 4 m/s against the round's 2/3, −10/3 and 11/3).
#[test]
fn unequal_strikers_at_once_leave_as_the_round_says() {
    let mut worst = [0.0f64; 3];
    for e in [0.0, 0.5, 0.99, 1.0] {
        for [ma, mm, mb] in [[1.0, 1.0, 1.0], [1.0, 3.0, 2.0], [2.0, 0.5, 1.0]] {
            let (want, j) = round(ma, mm, mb, 4.0, -3.0, e);
            assert!(j[0] > 0.0 && j[1] > 0.0, "both contacts push: {j:?}");
            let t = 1.25;
            // Each ball's x after the impact at t = 1 s, where A, M and B are at 23, 24 and 25.
            let at = |x: f64, v: f64| DVec2::new(x + v * (t - 1.0), 0.5);
            let expected = [at(24.0, want[1]), at(23.0, want[0]), at(25.0, want[2])];
            let velocities = [want[1], want[0], want[2]];
            for ids in NUMBERINGS {
                let start = [
                    ball(ids[0], 24.0, 0.5, 0.0, 0.0, mm, 1.0),
                    ball(ids[1], 19.0, 0.5, 4.0, 0.0, ma, 1.0),
                    ball(ids[2], 28.0, 0.5, -3.0, 0.0, mb, 1.0),
                ];
                let (end, walls) = exact(e, &start, t);
                let off = end
                    .iter()
                    .zip(expected.iter().zip(velocities))
                    .map(|(b, (x, v))| (b.position - *x).length().max((b.velocity - DVec2::new(v, 0.0)).length()))
                    .fold(0.0, f64::max);
                let p = momentum_error(&start, &end, walls, t);
                eprintln!(
                    "e {e} masses {:?} ids {ids:?}: exact v {:?}, closed form {velocities:?}: off {off:.2e}, \
                     momentum {p:.2e}",
                    [ma, mm, mb],
                    end.iter().map(|b| b.velocity.x).collect::<Vec<_>>()
                );
                worst[0] = worst[0].max(off);
                worst[1] = worst[1].max(p);
            }
            let start = [
                ball(0, 24.0, 0.5, 0.0, 0.0, mm, 1.0),
                ball(1, 19.0, 0.5, 4.0, 0.0, ma, 1.0),
                ball(2, 28.0, 0.5, -3.0, 0.0, mb, 1.0),
            ];
            let stepped = lockstep(e, &start, 1e-5, t);
            let off = stepped
                .iter()
                .zip(velocities)
                .map(|(b, v)| (b.velocity - DVec2::new(v, 0.0)).length())
                .fold(0.0, f64::max);
            eprintln!(
                "e {e} masses {:?}: lockstep v {:?}: off the closed form by {off:.2e}",
                [ma, mm, mb],
                stepped.iter().map(|b| b.velocity).collect::<Vec<_>>()
            );
            worst[2] = worst[2].max(off);
        }
    }
    eprintln!("worst: exact {:.2e}, momentum {:.2e}, lockstep {:.2e}", worst[0], worst[1], worst[2]);
    assert!(worst[0] <= 1e-12, "exact off the closed form by {:e}", worst[0]);
    assert!(worst[1] <= 1e-12, "momentum off the walls' impulses by {:e}", worst[1]);
    assert!(worst[2] <= 1e-6, "lockstep off the closed form by {:e}", worst[2]);
}

/// A ball (1 kg, 1 m) dropped from 3 m above the floor at x = 24 onto two balls of `m` kg at rest
/// on the floor, touching each other (x = 23.5 and 24.5) or 0.5 m apart (x = 23.25 and 24.75):
/// after 1 s, B and C are mirror images about x = 24 and A is on the axis, however numbered, and
/// the balls are where lockstep at dt = 1e-5 s puts them.
///
/// Measured at e = 0.5, 0.8, 0.99 and 1, m = 1 and 3 kg, both spacings, three numberings: a
/// mirror image with A on the axis to the bit, momentum against the walls' impulses to
/// 9.6e-14 N·s, within 5.1e-4 (m, m/s) of lockstep (which itself moves by up to 4.8e-3 from
/// dt = 1e-4 to 1e-5 s). At e = 0 and 0.3 the dropped ball can stay wedged between the two it
/// struck and press them apart under gravity in collisions slower than the collapse speed,
/// which are binary events, not rounds: the mirror is off by up to 2.3e-3 there (m = 3,
/// touching; to the bit in four of the eight cases), bounded at 5e-3. Seen to fail with the
/// impacts one after the other: mirror off by 4.24 (e ≥ 0.5; 1.42 below), 4.35 from lockstep.
#[test]
fn a_ball_dropped_on_two_balls_at_rest_leaves_a_mirror_image() {
    let (mut worst, mut wedged_worst) = ([0.0f64; 4], 0.0f64);
    for e in [0.0, 0.3, 0.5, 0.8, 0.99, 1.0] {
        for m in [1.0, 3.0] {
            for half in [0.5, 0.75] {
                let t = 1.0;
                let start = |ids: [u32; 3]| {
                    [
                        ball(ids[0], 24.0, 3.0, 0.0, 0.0, 1.0, 1.0),
                        ball(ids[1], 24.0 - half, 0.5, 0.0, 0.0, m, 1.0),
                        ball(ids[2], 24.0 + half, 0.5, 0.0, 0.0, m, 1.0),
                    ]
                };
                let stepped = lockstep(e, &start(NUMBERINGS[0]), 1e-5, t);
                for ids in NUMBERINGS {
                    let (end, walls) = exact(e, &start(ids), t);
                    let (a, b, c) = (&end[0], &end[1], &end[2]);
                    let mirror = (b.position.x + c.position.x - 48.0)
                        .abs()
                        .max((b.position.y - c.position.y).abs())
                        .max((b.velocity.x + c.velocity.x).abs())
                        .max((b.velocity.y - c.velocity.y).abs())
                        .max((a.position.x - 24.0).abs())
                        .max(a.velocity.x.abs());
                    let p = momentum_error(&start(ids), &end, walls, t);
                    let apart = end
                        .iter()
                        .zip(&stepped)
                        .map(|(x, y)| x.position.distance(y.position).max(x.velocity.distance(y.velocity)))
                        .fold(0.0, f64::max);
                    eprintln!(
                        "e {e} m {m} half-gap {half} ids {ids:?}: A {:?} {:?}, B {:?}, C {:?}: mirror {mirror:.2e}, \
                         momentum {p:.2e}, from lockstep {apart:.2e}",
                        a.position, a.velocity, b.velocity, c.velocity
                    );
                    assert!(b.velocity.x < -0.1, "B was struck aside: {:?}", b.velocity);
                    if e < 0.5 {
                        wedged_worst = wedged_worst.max(mirror);
                        worst[2] = worst[2].max(p);
                    } else {
                        for (w, x) in worst.iter_mut().zip([mirror, 0.0, p, apart]) {
                            *w = w.max(x);
                        }
                    }
                }
            }
        }
    }
    eprintln!(
        "worst: mirror {:.2e} (e < 0.5: {wedged_worst:.2e}), momentum {:.2e}, from lockstep {:.2e}",
        worst[0], worst[2], worst[3]
    );
    assert!(worst[0] <= 1e-12, "B and C are not mirror images, or A is off the axis: {:e}", worst[0]);
    assert!(worst[2] <= 1e-12, "momentum off the walls' impulses by {:e}", worst[2]);
    assert!(worst[3] <= 2e-3, "exact and lockstep apart by {:e}", worst[3]);
    assert!(wedged_worst <= 5e-3, "wedged: mirror off by {wedged_worst:e}");
}
