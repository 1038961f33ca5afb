//! The grid broad phase finds exactly the touching pairs a brute-force search finds, for equal and
//! mixed diameters (including balls far larger than the rest), each pair once.

use std::collections::BTreeSet;

use ballfield::physics::BroadPhase;
use glam::DVec2;

/// Deterministic pseudo-random numbers in [0, 1).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn check(positions: &[DVec2], radii: &[f64], w: f64, h: f64) {
    let mut grid = BroadPhase::new();
    grid.update(positions, radii, w, h);
    let mut found = BTreeSet::new();
    grid.for_each_touching_pair(|i, j| {
        assert_ne!(i, j);
        assert!(touching(positions, radii, i, j), "({i}, {j}) does not touch");
        assert!(found.insert((i.min(j), i.max(j))), "pair ({i}, {j}) visited twice");
    });
    let mut brute = BTreeSet::new();
    for i in 0..positions.len() {
        for j in (i + 1)..positions.len() {
            if touching(positions, radii, i, j) {
                brute.insert((i, j));
            }
        }
    }
    assert_eq!(found, brute);
}

fn touching(p: &[DVec2], r: &[f64], i: usize, j: usize) -> bool {
    p[i].distance(p[j]) < r[i] + r[j]
}

#[test]
fn equal_balls_dense_field() {
    let mut rng = Lcg(1);
    let (w, h) = (70.0, 50.0);
    let p: Vec<DVec2> = (0..3000).map(|_| DVec2::new(w * rng.next(), h * rng.next())).collect();
    let r = vec![0.5; p.len()];
    check(&p, &r, w, h);
}

#[test]
fn mixed_diameters_and_a_few_giants() {
    let mut rng = Lcg(2);
    let (w, h) = (200.0, 100.0);
    let mut p = Vec::new();
    let mut r = Vec::new();
    for k in 0..2000 {
        p.push(DVec2::new(w * rng.next(), h * rng.next()));
        r.push(match k % 100 {
            0 => 10.0,             // giants: kept out of the grid
            1..=9 => 0.0005,       // 1 mm balls
            _ => 0.2 + rng.next(), // ordinary balls of mixed sizes
        });
    }
    check(&p, &r, w, h);
}

#[test]
fn balls_slightly_outside_the_field_and_coincident_balls() {
    let p = vec![
        DVec2::new(-0.3, 5.0),
        DVec2::new(0.2, 5.0),
        DVec2::new(10.4, 10.3),
        DVec2::new(9.9, 9.9),
        DVec2::new(5.0, 5.0),
        DVec2::new(5.0, 5.0),
        DVec2::new(5.0, 5.0),
    ];
    let r = vec![0.5; p.len()];
    check(&p, &r, 10.0, 10.0);
}

/// The grid re-plans when the set of radii changes in any way: a big ball removed from the middle
/// and another added at the end (same count, same sum of radii) is still found.
#[test]
fn swapping_a_big_ball_keeps_the_layout_right() {
    let mut grid = BroadPhase::new();
    let mut p: Vec<DVec2> =
        (0..40).map(|k| DVec2::new(2.0 + 2.0 * (k % 10) as f64, 2.0 + 2.0 * (k / 10) as f64)).collect();
    let mut r = vec![0.5; 40];
    r[5] = 15.0;
    grid.update(&p, &r, 100.0, 100.0);
    // Remove the big ball (index 5), add a big one at the end, next to ball 0.
    p.remove(5);
    r.remove(5);
    p.push(DVec2::new(2.0, 2.0 + 15.3));
    r.push(15.0);
    check(&p, &r, 100.0, 100.0);
    grid.update(&p, &r, 100.0, 100.0);
    let mut found = BTreeSet::new();
    grid.for_each_touching_pair(|i, j| {
        found.insert((i.min(j), i.max(j)));
    });
    assert!(found.contains(&(0, 39)), "the new big ball touches ball 0: {found:?}");
}
