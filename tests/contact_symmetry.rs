//! Order does not pick the physics (issue 13, point 8), on the lockstep engine: a ball striking two
//! touching balls head-on between them leaves them as mirror images to rounding, however the
//! balls are numbered; mirroring and renumbering a pile changes none of its statistics beyond
//! their spread over seeds.

mod common;

use ballfield::physics::{Ball, Collisions, Effects, Field, Gravity, Integrator};
use common::*;
use glam::DVec2;

/// A (1 kg, 1 m) flies along y = 10 at 5 m/s into B and C (`m` kg, 1 m), which touch each
/// other at (20, 10.5) and (20, 9.5); gravity, if any, along the line of flight (it keeps the
/// mirror, and drops out of the relative motion). Returns the largest mirror error of B against C (position and velocity, m and m/s),
/// A's sideways speed, and whether anything collided.
fn strike_between(e: f64, m: f64, ids: [u32; 3], g: f64) -> (f64, f64, u64) {
    let field = Field { width: 200.0, height: 20.0, restitution: 1.0 };
    let effects = Effects {
        collisions: Some(Collisions { restitution: e }),
        gravity: (g != 0.0).then_some(Gravity { g: DVec2::new(g, 0.0) }),
        ..Effects::default()
    };
    let balls = [
        ball(ids[0], 10.0, 10.0, 5.0, 0.0, 1.0, 1.0),
        ball(ids[1], 20.0, 10.5, 0.0, 0.0, m, 1.0),
        ball(ids[2], 20.0, 9.5, 0.0, 0.0, m, 1.0),
    ];
    let mut engine = engine(field, effects, Integrator::Leapfrog, 1e-3, &balls);
    engine.run(2500);
    assert_eq!(engine.wall_impulses().total(), 0.0, "no wall");
    let b = engine.bodies();
    let at = |id: u32| b.id.iter().position(|&x| x.0 == id).unwrap();
    let (a, bb, c) = (at(ids[0]), at(ids[1]), at(ids[2]));
    let mirror = |p: DVec2| DVec2::new(p.x, 20.0 - p.y);
    let dx = (b.position[bb] - mirror(b.position[c])).length();
    let dv = (b.velocity[bb] - DVec2::new(b.velocity[c].x, -b.velocity[c].y)).length();
    (dx.max(dv), b.velocity[a].y.abs() + (b.position[a].y - 10.0).abs(), engine.counters().impulses)
}

/// Exactly mirror-symmetric at every e < 1, mass ratio, numbering and with gravity along the
/// flight. Measured: 0 (bit-exact mirror) in every case: the impacts of a round are solved
/// together (Jacobi sweeps with mass splitting), each from the same velocities. Seen to fail by
/// solving the round's rows one after the other, each seeing the last one's impulse
/// (Gauss–Seidel): B and C mirror each other only to 3e-8 (m, m/s) at e = 0.
///
/// At e = 1 too, where a perfectly elastic field goes through sequential pairwise impulses
/// (they keep its energy to rounding however dense it is): impacts struck at once are solved
/// together there as well (`elastic_contacts::strike_together`). Seen to fail with them taken one
/// by one: at e = 1 without gravity B left at (3.75, 2.17) m/s and C at (1.87, −1.08).
#[test]
fn a_ball_striking_two_touching_balls_between_them_leaves_a_mirror_image() {
    for e in [0.0, 0.5, 0.9, 0.99, 1.0] {
        for m in [1.0, 0.1, 10.0] {
            for ids in [[0, 1, 2], [2, 0, 1], [1, 2, 0]] {
                for g in [0.0, 9.81] {
                    let (mirror, sideways, impacts) = strike_between(e, m, ids, g);
                    assert!(impacts >= 1, "e {e} m {m}: no collision");
                    assert!(mirror <= 1e-12, "e {e} m {m} ids {ids:?} g {g}: mirror off by {mirror}");
                    assert!(sideways <= 1e-12, "e {e} m {m} ids {ids:?} g {g}: A pushed sideways by {sideways}");
                }
            }
        }
    }
}

/// A ball (1 kg, 1 m) dropped from 3 m onto two touching balls (`m` kg, 1 m) at rest on the floor
/// at x = 23.5 and 24.5, gravity down, every restitution 1 (lockstep's elastic path) and 0.5:
/// after 1 s, B and C are mirror images about x = 24 and A is on the axis, however the balls are
/// numbered. Measured: 0 (to the bit) at e = 1 and 0.5. Seen to fail with lockstep's elastic
/// impulses taken one by one: at e = 1, B and C mirror each other only to 0.74 (m and m/s).
#[test]
fn a_ball_dropped_on_two_resting_balls_leaves_a_mirror_image() {
    for e in [1.0, 0.5] {
        for m in [1.0, 3.0] {
            for ids in [[0, 1, 2], [2, 0, 1], [1, 2, 0]] {
                let field = Field { width: 48.0, height: 20.0, restitution: e };
                let effects = Effects {
                    collisions: Some(Collisions { restitution: e }),
                    gravity: Some(Gravity { g: DVec2::new(0.0, -9.81) }),
                    ..Effects::default()
                };
                let balls = [
                    ball(ids[0], 24.0, 3.0, 0.0, 0.0, 1.0, 1.0),
                    ball(ids[1], 23.5, 0.5, 0.0, 0.0, m, 1.0),
                    ball(ids[2], 24.5, 0.5, 0.0, 0.0, m, 1.0),
                ];
                let mut engine = engine(field, effects, Integrator::SemiImplicitEuler, 1e-3, &balls);
                engine.run(1000);
                let b = engine.bodies();
                let at = |id: u32| b.id.iter().position(|&x| x.0 == id).unwrap();
                let (a, bb, c) = (at(ids[0]), at(ids[1]), at(ids[2]));
                let mirror = |p: DVec2| DVec2::new(48.0 - p.x, p.y);
                let dx = (b.position[bb] - mirror(b.position[c])).length();
                let dv = (b.velocity[bb] - DVec2::new(-b.velocity[c].x, b.velocity[c].y)).length();
                let off_axis = (b.position[a].x - 24.0).abs() + b.velocity[a].x.abs();
                assert!(b.velocity[bb].x < -0.5, "e {e} m {m}: B was not struck aside: {:?}", b.velocity[bb]);
                assert!(dx.max(dv) <= 1e-12, "e {e} m {m} ids {ids:?}: mirror off by {}", dx.max(dv));
                assert!(off_axis <= 1e-12, "e {e} m {m} ids {ids:?}: A off the axis by {off_axis}");
            }
        }
    }
}

/// 300 balls of 0.6–1.4 m on a jittered lattice with random sideways speeds, for a 30 m box;
/// `mirrored` reflects it about the box's middle, `reversed` numbers the balls the other way.
fn pile(seed: u64, mirrored: bool, reversed: bool) -> Vec<Ball> {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut balls = Vec::new();
    for k in 0..300u32 {
        let d = 0.6 + 0.8 * next();
        let (col, row) = (k % 20, k / 20);
        let x = 0.75 + 1.45 * col as f64 + 0.1 * next();
        let y = 1.0 + 1.6 * row as f64;
        let x = if mirrored { 30.0 - x } else { x };
        let id = if reversed { 299 - k } else { k };
        balls.push(ball(id, x, y, 2.0 * next() - 1.0, 0.0, d * d, d));
    }
    if reversed {
        balls.reverse();
    }
    balls
}

/// Statistics of a settled pile: mean height of the balls' centres, floor force over M·g (the
/// last two seconds), and touching pairs per ball.
fn settle(balls: &[Ball], e: f64) -> [f64; 3] {
    let field = Field { width: 30.0, height: 40.0, restitution: e };
    let effects = Effects {
        collisions: Some(Collisions { restitution: e }),
        gravity: Some(Gravity { g: DVec2::new(0.0, -9.81) }),
        ..Effects::default()
    };
    let mut engine = engine(field, effects, Integrator::SemiImplicitEuler, 1e-3, balls);
    engine.run(4000);
    let floor0 = engine.wall_impulses().bottom;
    let t0 = engine.time();
    engine.run(2000);
    let mass: f64 = balls.iter().map(|b| b.mass).sum();
    let floor = (engine.wall_impulses().bottom - floor0) / (mass * 9.81 * (engine.time() - t0));
    let b = engine.bodies();
    let height = b.position.iter().map(|p| p.y).sum::<f64>() / b.len() as f64;
    let mut touching = 0;
    for i in 0..b.len() {
        for j in i + 1..b.len() {
            if b.position[i].distance(b.position[j]) < (b.radius[i] + b.radius[j]) * (1.0 + 1e-4) {
                touching += 1;
            }
        }
    }
    [height, floor, touching as f64 / b.len() as f64]
}

/// Mirroring the pile and renumbering its balls changes its height and packing by no more than
/// twice their range over the seeds (four seeds at each of e = 0 and 0.5, the ranges pooled over
/// both: e barely changes how the pile packs, and four samples' range alone is a poor measure of
/// a spread — the touching pairs per ball, about 530 pairs of 300 balls, fluctuate by about
/// √530/300 = 0.08 from run to run, yet the four seeds at e = 0.5 happened to span 0.017), and its
/// floor carries its weight either way (within 2e-3 over the two seconds from 4 s: these
/// frictionless piles still slump now and then, a few joules, and over one second the floor
/// force was up to 2.8e-3 off the weight in a second a pile slumped). Measured: the mirrored and
/// renumbered piles differ from seed 1 by at most 0.16 of the pooled range in height and
/// 1.0 of it in packing; floors within 6.6e-4 of the weight (e = 0 and 0.5).
#[test]
fn mirroring_or_renumbering_a_pile_changes_its_statistics_only_within_their_spread() {
    let es = [0.0, 0.5];
    let seeds: Vec<Vec<[f64; 3]>> =
        es.iter().map(|&e| (1..=4).map(|s| settle(&pile(s, false, false), e)).collect()).collect();
    let spread: Vec<f64> = (0..3)
        .map(|k| {
            seeds
                .iter()
                .map(|runs| {
                    let (lo, hi) =
                        runs.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), s| (l.min(s[k]), h.max(s[k])));
                    hi - lo
                })
                .fold(0.0, f64::max)
        })
        .collect();
    for (&e, seeds) in es.iter().zip(&seeds) {
        eprintln!("e {e}: seeds {seeds:?}, pooled spread {spread:?}");
        for (mirrored, reversed) in [(true, false), (false, true), (true, true)] {
            let s = settle(&pile(1, mirrored, reversed), e);
            eprintln!("e {e} mirrored {mirrored} reversed {reversed}: {s:?} against seed 1 {:?}", seeds[0]);
            for k in [0, 2] {
                assert!(
                    (s[k] - seeds[0][k]).abs() <= 2.0 * spread[k],
                    "e {e} mirrored {mirrored} reversed {reversed}: statistic {k} {} against {} (spread {})",
                    s[k],
                    seeds[0][k],
                    spread[k]
                );
            }
            assert!((s[1] - 1.0).abs() < 2e-3, "e {e}: the floor carries {} of the weight", s[1]);
        }
        for s in seeds {
            assert!((s[1] - 1.0).abs() < 2e-3, "e {e}: the floor carries {} of the weight", s[1]);
        }
    }
}
