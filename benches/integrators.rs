//! Criterion benches of one lockstep step per integrator and per effect set — the cost side of
//! `ballfield accuracy`, measured by the ecosystem's own tool.
//!
//! Groups `integrators/<effects>`, one bench per integrator and ball count, each reporting
//! `Throughput::Elements(balls)` so criterion prints balls/s beside the time per step:
//! - `vacuum` — no force at all: every integrator reduces to the same drift (the engine skips
//!   force evaluation), so these are the floor of a step's cost;
//! - `gravity` — a uniform force: one cheap pass per force evaluation;
//! - `gravity+drag` — a velocity-dependent force: leapfrog and Yoshida solve their kicks as
//!   implicit midpoints (2 and 3 extra evaluations per kick);
//! - `attraction` — the pair sum (direct at 10 and 100 balls, the Barnes–Hut tree at 1,000: see
//!   `TREE_MIN_BALLS`), where the number of force evaluations per step (1 for
//!   the Euler methods and leapfrog, 3 for Yoshida, 4 for RK4) is the whole story.
//!
//! No collisions: this measures the integrators, not the contact solver (benches/step.rs
//! covers the whole step). Balls sit on a square lattice with speeds from a fixed-seed LCG; the
//! state drifts on between iterations, which does not change the work a step does.

use std::hint::black_box;
use std::time::Duration;

use ballfield::Lockstep;
use ballfield::physics::{
    AIR_DENSITY, Attraction, Ball, BallId, BallKind, Drag, Effects, Field, Gravity, Integrator, NEWTON_G,
    SPHERE_DRAG_COEFFICIENT,
};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec2;

const DT: f64 = 1e-3;
/// Lattice spacing and ball diameter, m.
const SPACING: f64 = 1.0;
const DIAMETER: f64 = 0.5;

/// `n` balls on a square lattice in a field just big enough, moving at up to 5 m/s.
fn balls(n: usize) -> (Field, Vec<Ball>) {
    let side = (n as f64).sqrt().ceil() as usize;
    let size = side as f64 * SPACING + SPACING;
    let field = Field { width: size, height: size, restitution: 1.0 };
    let mut state: u64 = 0x00ba_11f1_e1d0;
    let mut next = || {
        state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let balls = (0..n)
        .map(|i| Ball {
            id: BallId(i as u32),
            kind: BallKind::Ball,
            position: DVec2::new(((i % side) + 1) as f64 * SPACING, ((i / side) + 1) as f64 * SPACING),
            velocity: DVec2::new(next(), next()) * 3.5,
            mass: 1.0,
            diameter: DIAMETER,
        })
        .collect();
    (field, balls)
}

fn effect_sets() -> [(&'static str, Effects, &'static [usize]); 4] {
    let gravity = Some(Gravity { g: DVec2::new(0.0, -9.81) });
    let drag = Some(Drag::Quadratic { rho: AIR_DENSITY, cd: SPHERE_DRAG_COEFFICIENT });
    [
        ("vacuum", Effects::default(), &[100, 1_000, 10_000]),
        ("gravity", Effects { gravity, ..Effects::default() }, &[100, 1_000, 10_000]),
        ("gravity+drag", Effects { gravity, drag, ..Effects::default() }, &[100, 1_000, 10_000]),
        (
            "attraction",
            Effects {
                attraction: Some(Attraction { g_constant: NEWTON_G, ..Attraction::default() }),
                ..Effects::default()
            },
            &[10, 100, 1_000],
        ),
    ]
}

fn integrators(c: &mut Criterion) {
    for (name, effects, counts) in effect_sets() {
        let mut group = c.benchmark_group(format!("integrators/{name}"));
        group.warm_up_time(Duration::from_millis(300)).measurement_time(Duration::from_secs(1)).sample_size(20);
        for &n in counts {
            let (field, balls) = balls(n);
            group.throughput(Throughput::Elements(n as u64));
            for integrator in Integrator::ALL {
                let mut engine = Lockstep::from_parts(field, effects, integrator, DT, n, &balls);
                group.bench_function(BenchmarkId::new(integrator.name(), n), |b| {
                    b.iter(|| {
                        engine.step();
                        black_box(engine.bodies().position[0])
                    })
                });
            }
        }
        group.finish();
    }
}

criterion_group!(benches, integrators);
criterion_main!(benches);
