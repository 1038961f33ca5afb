//! Criterion benches of one force evaluation of mutual attraction: the direct O(n²) sum against
//! the Barnes–Hut tree (build + one query per ball), through `Forces::accelerations` as the
//! engine calls it, with the method fixed by `Forces::set_attraction_method`.
//!
//! Groups (every bench reports `Throughput::Elements(balls)`):
//! - `attraction/direct/N` and `attraction/tree/N` — a uniform field of N balls at the default
//!   opening angle, N from 50 to 10,000 (and 100,000 for the tree alone): where the two cross
//!   is [`ballfield::physics::TREE_MIN_BALLS`];
//! - `attraction/tree-clustered/10000` — the same count in ten dense clusters;
//! - `attraction/opening-angle/θ` — the tree at 10,000 balls for θ from 0.3 to 0.9: the cost side
//!   of the accuracy sweep in `tests/barnes_hut.rs` (`opening_angle_sweep`);
//! - `attraction/tree-build/N` — the build alone at 10,000 and 100,000 balls;
//! - `attraction/force-at/N` and `attraction/near-force/N` — a threaded ball's queries: every
//!   ball once, 1 cm from its entry in the tree and excluding it, at 256, 1,024 and 4,096 balls
//!   (throughput per query): the whole walk (`BarnesHut::force_at`), and the exact sum over the
//!   near balls of a cycle's split (`BarnesHut::near_force`), which is what a ball thread
//!   computes at each sub-step — at least 500 a second (2 ms sub-steps).
//!
//! The field: balls of 1 m and 1 kg at random (fixed seed) in a square where they cover 20 % of
//! the area (about 2 m apart, as in the step bench). The state does not move between iterations.
//!
//! Clock: wall time by default; `BALLFIELD_BENCH_CLOCK=thread-cpu` times the benchmarking
//! thread's CPU time instead (for a shared machine; the work is single-threaded).

use std::hint::black_box;
use std::time::Duration;

use ballfield::physics::{Attraction, AttractionMethod, BarnesHut, BodyProps, Effects, Forces, NearBall, near_force};
use criterion::{BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use glam::DVec2;

#[path = "clock/mod.rs"]
mod clock;
use clock::Clock;

const DIAMETER: f64 = 1.0;
const MASS: f64 = 1.0;
const COVERAGE: f64 = 0.2;

/// SplitMix64: a fixed random stream.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

struct Balls {
    pos: Vec<DVec2>,
    vel: Vec<DVec2>,
    mass: Vec<f64>,
    inverse_mass: Vec<f64>,
    diameter: Vec<f64>,
}

impl Balls {
    fn from_positions(pos: Vec<DVec2>) -> Self {
        let n = pos.len();
        Balls {
            pos,
            vel: vec![DVec2::ZERO; n],
            mass: vec![MASS; n],
            inverse_mass: vec![1.0 / MASS; n],
            diameter: vec![DIAMETER; n],
        }
    }

    /// `n` balls at random in a square where they cover [`COVERAGE`] of the area.
    fn uniform(n: usize) -> Self {
        let side = (n as f64 * std::f64::consts::FRAC_PI_4 * DIAMETER * DIAMETER / COVERAGE).sqrt();
        let mut rng = Rng(42);
        Self::from_positions((0..n).map(|_| DVec2::new(side * rng.next(), side * rng.next())).collect())
    }

    /// `n` balls in ten clusters (Gaussian-like, radius 5–25 m) over a square of the same size.
    fn clustered(n: usize) -> Self {
        let side = (n as f64 * std::f64::consts::FRAC_PI_4 * DIAMETER * DIAMETER / COVERAGE).sqrt();
        let mut rng = Rng(7);
        let centres: Vec<(DVec2, f64)> =
            (0..10).map(|_| (DVec2::new(side * rng.next(), side * rng.next()), 5.0 + 20.0 * rng.next())).collect();
        let pos = (0..n)
            .map(|k| {
                let (c, a) = centres[k % 10];
                // Sum of uniforms: a cheap bell shape.
                let dx = (rng.next() + rng.next() + rng.next() - 1.5) * a;
                let dy = (rng.next() + rng.next() + rng.next() - 1.5) * a;
                c + DVec2::new(dx, dy)
            })
            .collect();
        Self::from_positions(pos)
    }
}

/// Times `iters` force evaluations.
fn evaluate(forces: &mut Forces, balls: &Balls, acc: &mut [DVec2], iters: u64, clock: Clock) -> Duration {
    let props = BodyProps { mass: &balls.mass, inverse_mass: &balls.inverse_mass, diameter: &balls.diameter };
    clock.time(|| {
        for _ in 0..iters {
            forces.accelerations(props, None, &balls.pos, &balls.vel, acc);
            black_box(&*acc);
            black_box(forces.take_orbit_rate_squared());
        }
    })
}

fn forces(method: AttractionMethod, opening_angle: f64) -> Forces {
    let attraction = Attraction { g_constant: 1.0, opening_angle };
    let mut forces = Forces::new(&Effects { attraction: Some(attraction), ..Effects::default() });
    forces.set_attraction_method(Some(method));
    forces
}

fn bench(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    id: BenchmarkId,
    balls: &Balls,
    mut forces: Forces,
) {
    let clock = Clock::from_env();
    let mut acc = vec![DVec2::ZERO; balls.pos.len()];
    group.throughput(Throughput::Elements(balls.pos.len() as u64));
    group.bench_function(id, |b| b.iter_custom(|iters| evaluate(&mut forces, balls, &mut acc, iters, clock)));
}

fn bench_attraction(c: &mut Criterion) {
    let theta = Attraction::default().opening_angle;
    let mut group = c.benchmark_group("attraction");
    group
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(4));
    for n in [50, 64, 80, 100, 128, 160, 200, 500, 1_000, 2_000, 5_000, 10_000] {
        let balls = Balls::uniform(n);
        group.sample_size(if n >= 5_000 { 10 } else { 30 });
        bench(&mut group, BenchmarkId::new("direct", n), &balls, forces(AttractionMethod::Direct, theta));
        bench(&mut group, BenchmarkId::new("tree", n), &balls, forces(AttractionMethod::Tree, theta));
    }
    group.sample_size(10);
    let balls = Balls::uniform(100_000);
    bench(&mut group, BenchmarkId::new("tree", 100_000), &balls, forces(AttractionMethod::Tree, theta));
    let balls = Balls::clustered(10_000);
    bench(&mut group, BenchmarkId::new("tree-clustered", 10_000), &balls, forces(AttractionMethod::Tree, theta));
    let balls = Balls::uniform(10_000);
    for t in [0.3, 0.5, 0.7, 0.9] {
        bench(&mut group, BenchmarkId::new("opening-angle", t), &balls, forces(AttractionMethod::Tree, t));
    }
    // The build alone (sort, arena, moments): the part of a tree evaluation that is not a query.
    let clock = Clock::from_env();
    for n in [10_000, 100_000] {
        let balls = Balls::uniform(n);
        let radius: Vec<f64> = balls.diameter.iter().map(|d| 0.5 * d).collect();
        let attraction = Attraction { g_constant: 1.0, opening_angle: theta };
        let mut tree = BarnesHut::new();
        group.throughput(Throughput::Elements(n as u64));
        group.bench_function(BenchmarkId::new("tree-build", n), |b| {
            b.iter_custom(|iters| {
                clock.time(|| {
                    for _ in 0..iters {
                        tree.build(&balls.pos, &balls.mass, &radius, &attraction);
                        black_box(tree.node_count());
                    }
                })
            })
        });
    }
    // The threaded runtime's queries, for a ball that has moved 1 cm since the snapshot,
    // excluding its entry: the whole walk, and the near balls' exact sum a sub-step makes once a
    // cycle's split (margin 0.1 m) is taken.
    for n in [256, 1_024, 4_096] {
        let balls = Balls::uniform(n);
        let radius: Vec<f64> = balls.diameter.iter().map(|d| 0.5 * d).collect();
        let attraction = Attraction { g_constant: 1.0, opening_angle: theta };
        let mut tree = BarnesHut::new();
        tree.build(&balls.pos, &balls.mass, &radius, &attraction);
        let moved: Vec<(DVec2, f64, f64)> =
            (0..n).map(|i| (balls.pos[i] + DVec2::new(0.01, 0.0), balls.mass[i], radius[i])).collect();
        let near: Vec<Vec<NearBall>> = moved
            .iter()
            .enumerate()
            .map(|(i, &(p, m, r))| {
                let mut near = Vec::new();
                tree.split_at(p, m, r, Some(i), 0.1, &mut near);
                near
            })
            .collect();
        group.throughput(Throughput::Elements(n as u64));
        group.bench_function(BenchmarkId::new("force-at", n), |b| {
            b.iter_custom(|iters| {
                clock.time(|| {
                    for _ in 0..iters {
                        for (i, &(p, m, r)) in moved.iter().enumerate() {
                            black_box(tree.force_at(p, m, r, Some(i)));
                        }
                    }
                })
            })
        });
        group.bench_function(BenchmarkId::new("near-force", n), |b| {
            b.iter_custom(|iters| {
                clock.time(|| {
                    for _ in 0..iters {
                        for (near, &(p, m, r)) in near.iter().zip(&moved) {
                            black_box(near_force(near, p, m, r, &attraction));
                        }
                    }
                })
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_attraction);
criterion_main!(benches);
