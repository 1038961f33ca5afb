//! Criterion benches of the exact (event-driven) engine, on one core.
//!
//! Groups:
//! - `collisions` — collisions per second in an elastic gas of 10,000 disks (diameter 1 m, mass
//!   1 kg, about 1 m/s, no gravity) at packing fractions 0.3 and 0.6
//!   ([`ballfield::accuracy::many_body::disk_gas`]). `Throughput::Elements(1)` per collision, so
//!   criterion's elements/s is collisions/s (wall bounces and cell crossings are processed too,
//!   uncounted). The aim is ≥ 10⁶ collisions/s.
//! - `to_simulated_time` — wall time to run the same gas for [`SPAN`] simulated seconds, the
//!   exact engine against the lockstep engine (semi-implicit Euler, dt = 1 ms, one thread), at
//!   0.3 (sparse) and 0.6 (dense).
//!
//! What is measured. Each gas is built on a square lattice and melted before any timing: the
//! exact engine runs [`MELT_COLLISIONS_PER_DISK`] collisions per disk, and the lockstep engine
//! starts from the exact engine's melted state (the same balls). Criterion then times runs on
//! clones of those warmed engines, re-cloned (untimed) every [`MAX_RUN`] collisions, so every
//! timed collision is one of the first [`MAX_RUN`] after the melt, the same on every run.
//!
//! Clock: as the other benches (`BALLFIELD_BENCH_CLOCK=thread-cpu` on a shared machine).

use std::cell::OnceCell;
use std::hint::black_box;
use std::time::Duration;

use ballfield::Lockstep;
use ballfield::accuracy::many_body::disk_gas;
use ballfield::engine::{Engine, ExactEngine};
use ballfield::physics::{Ball, Collisions, Effects, Field, Integrator};
use criterion::{BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main};

#[path = "clock/mod.rs"]
mod clock;
use clock::Clock;

/// Disks in every gas.
const DISKS: usize = 10_000;
/// Collisions per disk run before any timing: the lattice melts within a few.
const MELT_COLLISIONS_PER_DISK: u64 = 20;
/// Longest run of timed collisions on one clone of the melted engine.
const MAX_RUN: u64 = 1_000_000;
/// Simulated seconds of the `to_simulated_time` group.
const SPAN: f64 = 0.1;
/// The lockstep engine's step, s.
const DT: f64 = 1e-3;
/// Seed of the gas's directions.
const SEED: u64 = 42;

fn elastic() -> Effects {
    Effects { collisions: Some(Collisions { restitution: 1.0 }), ..Effects::default() }
}

/// The melted gas at `packing`: the exact engine, and its balls for the lockstep engine.
fn melted(packing: f64) -> (ExactEngine, Field, Vec<Ball>) {
    let (field, balls) = disk_gas(DISKS, packing, SEED).expect("a valid gas");
    let mut engine = ExactEngine::from_parts(field, elastic(), &balls).expect("an elastic gas runs");
    engine.run_collisions(MELT_COLLISIONS_PER_DISK * DISKS as u64);
    let mut out = Vec::new();
    engine.sample(&mut out);
    let s = engine.stats();
    eprintln!(
        "exact gas at {packing}: {} disks in {:.1} m × {:.1} m, melted by {} collisions ({:.2} s simulated): \
         {:.2} cell crossings and {:.3} wall bounces per collision",
        out.len(),
        field.width,
        field.height,
        s.counters.collisions,
        engine.time(),
        s.counters.cell_crossings as f64 / s.counters.collisions as f64,
        s.counters.wall_bounces as f64 / s.counters.collisions as f64,
    );
    // The melted state, as a fresh engine starts from it (the clones below time from here).
    let engine = ExactEngine::from_parts(field, elastic(), &out).expect("an elastic gas runs");
    (engine, field, out)
}

fn bench_collisions(c: &mut Criterion) {
    let clock = Clock::from_env();
    let mut group = c.benchmark_group("collisions");
    group
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(2))
        .measurement_time(Duration::from_secs(8));
    group.throughput(Throughput::Elements(1));
    for packing in [0.3, 0.6] {
        let warm = OnceCell::new();
        group.bench_function(BenchmarkId::new("gas_10000", packing), |b| {
            let warm = warm.get_or_init(|| melted(packing).0);
            b.iter_custom(|iters| {
                let mut total = Duration::ZERO;
                let mut left = iters;
                while left > 0 {
                    let run = left.min(MAX_RUN);
                    let mut engine = warm.clone();
                    total += clock.time(|| engine.run_collisions(run));
                    black_box(&engine);
                    left -= run;
                }
                total
            });
        });
    }
    group.finish();
}

fn bench_to_simulated_time(c: &mut Criterion) {
    let clock = Clock::from_env();
    let mut group = c.benchmark_group("to_simulated_time");
    group.sampling_mode(SamplingMode::Flat).sample_size(10).warm_up_time(Duration::from_secs(1));
    for (name, packing) in [("sparse", 0.3), ("dense", 0.6)] {
        let warm = OnceCell::new();
        let get = || {
            warm.get_or_init(|| {
                let (exact, field, balls) = melted(packing);
                let mut lockstep =
                    Lockstep::from_parts(field, elastic(), Integrator::SemiImplicitEuler, DT, DISKS, &balls);
                lockstep.set_threads(1);
                (exact, lockstep)
            })
        };
        group.bench_function(BenchmarkId::new("exact", name), |b| {
            let (exact, _) = get();
            b.iter_custom(|iters| {
                (0..iters)
                    .map(|_| {
                        let mut e = exact.clone();
                        let d = clock.time(|| e.advance_to(SPAN));
                        black_box(&e);
                        d
                    })
                    .sum()
            });
        });
        group.bench_function(BenchmarkId::new("lockstep", name), |b| {
            let (_, lockstep) = get();
            b.iter_custom(|iters| {
                (0..iters)
                    .map(|_| {
                        let mut l = lockstep.clone();
                        let d = clock.time(|| l.run((SPAN / DT).round() as u64));
                        black_box(&l);
                        d
                    })
                    .sum()
            });
        });
    }
    group.finish();
}

criterion_group!(benches, bench_collisions, bench_to_simulated_time);
criterion_main!(benches);
