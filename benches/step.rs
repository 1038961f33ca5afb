//! Criterion benches of one step of the lockstep engine.
//!
//! Every bench reports `Throughput::Elements(n_balls)`, so criterion prints balls/s next to the
//! time per step (steps/s = 1 / time per step).
//!
//! Groups:
//! - `effects` — "only the effects a scene calls for": vacuum (no effect at all, walls only)
//!   against all effects (gravity + quadratic drag + attraction + collisions) at 1,000 and
//!   10,000 balls, and each effect alone at 1,000 balls;
//! - `target` — the target scene: 10,000 balls of 2 m, gravity + drag + collisions,
//!   dt = 1 ms, semi-implicit Euler, one thread; goal ≥ 2,000 steps/s (≤ 500 µs per step);
//! - `scale` — the target's scene at 10,000 and 100,000 balls on 1 and 2 threads (see
//!   [`bench_scale`]);
//! - `integrators` — one step of each of [`Integrator::ALL`] at 1,000 balls with gravity + drag
//!   + collisions.
//!
//! What is measured. Each scene is built deterministically (a jittered lattice and velocity
//! directions from a fixed-seed LCG, see [`balls_in_field`]), then *warmed up*: it is run
//! [`WARM_UP_STEPS`] = 2,000 steps (2 s of simulated time at dt = 1 ms) before any timing, so
//! the balls are in motion that the effects shaped — scattered by collisions, slowed by drag,
//! falling — rather than in their initial arrangement with their initial velocities. Criterion then
//! times runs of consecutive steps on a clone of that warmed engine ([`time_steps`]); the clone
//! is re-made, untimed, every [`MAX_RUN`] = 1,000 steps, so every timed step is one of steps
//! 2,001–3,000 of the scene (simulated time 2–3 s), run on a hot engine exactly as
//! `Lockstep::run` would run it. The measured state is therefore the same on every machine and
//! every run, whatever number of iterations criterion chooses.
//!
//! Clock. Criterion's times are wall-clock by default. On a shared machine, where other programs
//! take the cores, run with `BALLFIELD_BENCH_CLOCK=thread-cpu` to time the benchmarking thread's
//! CPU time instead (see [`Clock`]); on an idle machine the two agree, as the engine is
//! single-threaded.
//!
//! Attraction is computed with the real G (`NEWTON_G`): its cost does not depend on G, and with
//! G that small it moves nothing measurable in 2 s, so scenes with attraction are warmed up with
//! attraction off and have it turned on just before timing (warming the 10,000-ball scene with
//! attraction would cost half a minute with the Barnes–Hut tree, minutes with the direct sum, for
//! no change in the state).

use std::cell::OnceCell;
use std::f64::consts::PI;
use std::hint::black_box;
use std::time::Duration;

use ballfield::Lockstep;
use ballfield::physics::{Attraction, Ball, BallId, BallKind, Collisions, Drag, Effects, Field, Gravity, Integrator};
use criterion::{BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use glam::DVec2;

#[path = "clock/mod.rs"]
mod clock;
use clock::Clock;

/// Lockstep time step, s.
const DT: f64 = 1e-3;
/// Steps run before any timing (2 s of simulated time at [`DT`]).
const WARM_UP_STEPS: u64 = 2_000;
/// Longest run of consecutive timed steps before the engine is reset to its warmed state.
const MAX_RUN: u64 = 1_000;
/// Diameter of every ball, m (the design's default ball).
const DIAMETER: f64 = 2.0;
/// Mass of every ball, kg (the design's default ball).
const MASS: f64 = 1.0;
/// Initial speed of every ball, m/s, in a direction drawn from the seed.
const SPEED: f64 = 5.0;
/// Fraction of the field's area the balls cover.
const COVERAGE: f64 = 0.2;
/// Width / height of every field (the window's 8:5).
const ASPECT: f64 = 1.6;
/// Seed of the ball generator.
const SEED: u64 = 0x00ba_11f1_e1d0;

/// Knuth's MMIX 64-bit linear congruential generator: deterministic, no run-time randomness.
struct Lcg(u64);

impl Lcg {
    fn new(seed: u64) -> Self {
        let mut lcg = Lcg(seed);
        lcg.next_u64();
        lcg
    }

    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        self.0
    }

    /// Uniform in [0, 1), from the top 53 bits (the LCG's best ones).
    fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [-1, 1).
    fn next_signed(&mut self) -> f64 {
        2.0 * self.next_f64() - 1.0
    }
}

/// A field of aspect [`ASPECT`] in which `n` balls of `diameter` cover `coverage` of the area.
///
/// For 10,000 balls of 2 m at 20 %: area = 10,000 · π · (1 m)² / 0.2 = 157,080 m², so the field is
/// 501.3 m × 313.3 m. For 1,000 balls: 15,708 m², 158.5 m × 99.1 m.
fn field_for(n: usize, diameter: f64, coverage: f64) -> Field {
    let balls_area = n as f64 * PI * 0.25 * diameter * diameter;
    let area = balls_area / coverage;
    let width = (area * ASPECT).sqrt();
    Field { width, height: area / width, restitution: 1.0 }
}

/// `n` non-overlapping balls of [`DIAMETER`] and [`MASS`] spread over `field`.
///
/// The balls sit on a lattice of `cols × rows` cells filling the field, each jittered within its
/// cell by at most a quarter of the gap between neighbours, so no two balls touch and none
/// touches a wall. Each moves at [`SPEED`] in a direction drawn from an LCG seeded with
/// [`SEED`]: the same balls, to the bit, on every run.
fn balls_in_field(n: usize, field: &Field) -> Vec<Ball> {
    let cols = ((n as f64 * field.width / field.height).sqrt().ceil() as usize).max(1);
    let rows = n.div_ceil(cols);
    let (sx, sy) = (field.width / cols as f64, field.height / rows as f64);
    let gap = sx.min(sy) - DIAMETER;
    assert!(gap > 0.0, "{n} balls of {DIAMETER} m do not fit in {field:?} on a lattice");
    let jitter = 0.25 * gap;
    let mut lcg = Lcg::new(SEED);
    (0..n)
        .map(|i| {
            let (c, r) = (i % cols, i / cols);
            let centre = DVec2::new((c as f64 + 0.5) * sx, (r as f64 + 0.5) * sy);
            let position = centre + jitter * DVec2::new(lcg.next_signed(), lcg.next_signed());
            let angle = 2.0 * PI * lcg.next_f64();
            Ball {
                id: BallId(i as u32),
                kind: BallKind::Ball,
                position,
                velocity: SPEED * DVec2::new(angle.cos(), angle.sin()),
                mass: MASS,
                diameter: DIAMETER,
            }
        })
        .collect()
}

/// Gravity + quadratic drag + collisions: the game's everyday scene, and the target's.
fn gravity_drag_collisions() -> Effects {
    Effects {
        gravity: Some(Gravity::default()),
        drag: Some(Drag::default()),
        attraction: None,
        collisions: Some(Collisions::default()),
    }
}

/// Every effect on, attraction with the real G.
fn all_effects() -> Effects {
    Effects { attraction: Some(Attraction::default()), ..gravity_drag_collisions() }
}

/// A lockstep engine with `n` balls in a field sized for them ([`field_for`]), warmed up by
/// [`WARM_UP_STEPS`] steps (with attraction off; see the module comment) and then given
/// `effects`.
fn warmed_engine(n: usize, effects: Effects, integrator: Integrator) -> Lockstep {
    let field = field_for(n, DIAMETER, COVERAGE);
    let balls = balls_in_field(n, &field);
    let warm_effects = Effects { attraction: None, ..effects };
    let mut engine = Lockstep::from_parts(field, warm_effects, integrator, DT, n, &balls);
    engine.run(WARM_UP_STEPS);
    let bodies = engine.bodies();
    assert!(
        bodies.position.iter().chain(&bodies.velocity).all(|v| v.is_finite()),
        "the warm-up produced a non-finite state"
    );
    engine.set_effects(effects);
    engine
}

/// The timed loop: `n` steps (one `run`, so a multi-threaded engine enters its pool once).
#[inline(always)]
fn run_steps(engine: &mut Lockstep, n: u64) {
    engine.run(n);
}

/// Times `iters` consecutive steps starting from a clone of `warm`, re-cloning it (untimed) every
/// [`MAX_RUN`] steps, so every timed step is one of the [`MAX_RUN`] steps after the warm-up.
fn time_steps(warm: &Lockstep, iters: u64, clock: Clock) -> Duration {
    let mut total = Duration::ZERO;
    let mut left = iters;
    while left > 0 {
        let run = left.min(MAX_RUN);
        let mut engine = warm.clone();
        total += clock.time(|| run_steps(&mut engine, run));
        black_box(&engine);
        left -= run;
    }
    total
}

/// Prints what a warmed scene looks like over the timed window, steps 2,001–3,000 (to stderr, so
/// the numbers criterion reports can be read against the state they were measured in). The phase
/// times are the engine's own counters from this untimed probe run, not criterion's.
fn describe(name: &str, warm: &Lockstep) {
    let mut probe = warm.clone();
    let before = *probe.counters();
    probe.run(MAX_RUN);
    let after = probe.counters();
    let steps = (after.steps - before.steps) as f64;
    let field = warm.field();
    let bodies = warm.bodies();
    let mean_speed = bodies.velocity.iter().map(|v| v.length()).sum::<f64>() / bodies.len().max(1) as f64;
    let phases = [
        ("integrate", after.integrate - before.integrate),
        ("broad phase", after.broad_phase - before.broad_phase),
        ("contacts", after.contacts - before.contacts),
        ("walls", after.walls - before.walls),
    ];
    let phases: Vec<String> =
        phases.iter().map(|(p, d)| format!("{p} {:.1} µs", d.as_secs_f64() * 1e6 / steps)).collect();
    eprintln!(
        "{name}: {} balls, field {:.1} m × {:.1} m, effects [{}], {}; at step {}: mean speed {:.2} m/s; \
         over the next {} steps, per step: {:.0} touching pairs, {:.0} impulses, {:.0} wall contacts; \
         engine's phase counters: {}",
        bodies.len(),
        field.width,
        field.height,
        warm.active_effects().join(", "),
        warm.integrator(),
        warm.steps(),
        mean_speed,
        MAX_RUN,
        (after.touching_pairs - before.touching_pairs) as f64 / steps,
        (after.impulses - before.impulses) as f64 / steps,
        (after.wall_contacts - before.wall_contacts) as f64 / steps,
        phases.join(", "),
    );
}

fn bench_effects(c: &mut Criterion) {
    let clock = Clock::from_env();
    let mut group = c.benchmark_group("effects");
    group.warm_up_time(Duration::from_secs(1)).measurement_time(Duration::from_secs(3));
    let only = |f: fn(&mut Effects)| {
        let mut e = Effects::default();
        f(&mut e);
        e
    };
    let cases: [(&str, usize, Effects); 7] = [
        ("vacuum", 1_000, Effects::default()),
        ("vacuum", 10_000, Effects::default()),
        ("all", 1_000, all_effects()),
        ("gravity", 1_000, only(|e| e.gravity = Some(Gravity::default()))),
        ("drag", 1_000, only(|e| e.drag = Some(Drag::default()))),
        ("attraction", 1_000, only(|e| e.attraction = Some(Attraction::default()))),
        ("collisions", 1_000, only(|e| e.collisions = Some(Collisions::default()))),
    ];
    for (name, n, effects) in cases {
        let warm = OnceCell::new();
        group.throughput(Throughput::Elements(n as u64));
        group.bench_function(BenchmarkId::new(name, n), |b| {
            let warm = warm.get_or_init(|| {
                let warm = warmed_engine(n, effects, Integrator::SemiImplicitEuler);
                if effects.attraction.is_none() {
                    describe(&format!("effects/{name}/{n}"), &warm);
                }
                warm
            });
            b.iter_custom(|iters| time_steps(warm, iters, clock))
        });
    }
    // All effects at 10,000 balls: attraction goes through the Barnes–Hut tree (≈ 15 ms a step;
    // the direct sum, ≈ 50 M pairs, took a quarter of a second or more), so take few samples,
    // each of a fixed number of steps.
    let n = 10_000;
    let warm = OnceCell::new();
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    group.throughput(Throughput::Elements(n as u64));
    group.bench_function(BenchmarkId::new("all", n), |b| {
        let warm = warm.get_or_init(|| warmed_engine(n, all_effects(), Integrator::SemiImplicitEuler));
        b.iter_custom(|iters| time_steps(warm, iters, clock))
    });
    group.finish();
}

fn bench_target(c: &mut Criterion) {
    let clock = Clock::from_env();
    // The target: 10,000 balls of 2 m, 1 kg covering 20 % of a 501.3 m × 313.3 m field
    // (157,080 m²; 31,416 m² of balls), gravity + quadratic drag + collisions (restitution 1,
    // walls too), dt = 1 ms, semi-implicit Euler, one thread; goal ≥ 2,000 steps/s, i.e.
    // ≤ 500 µs per step.
    //
    // Measured state: steps 2,001–3,000 (t = 2–3 s). Drag (about 22 m/s² at 5 m/s for a 1 kg,
    // 2 m ball) has taken away the initial 5 m/s random velocities within a few tenths of a
    // second, so the balls fall together at about their terminal speed, 3.3 m/s (the mean speed
    // printed by `describe` is 3.25 m/s): a dilute rain, still close to the jittered lattice,
    // with 1–2 touching pairs per step and the lowest balls bouncing off the floor. It is the
    // scene's state at 2 s, not a settled pile (falling 313 m would take about 95 s of
    // simulated time): the broad phase, which visits every grid cell, is paid in full; the
    // contact solver is nearly idle.
    let n = 10_000;
    let warm = OnceCell::new();
    let mut group = c.benchmark_group("target");
    group.warm_up_time(Duration::from_secs(2)).measurement_time(Duration::from_secs(8));
    group.throughput(Throughput::Elements(n as u64));
    group.bench_function(BenchmarkId::new("gravity-drag-collisions/semi-implicit-euler", n), |b| {
        let warm = warm.get_or_init(|| {
            let mut warm = warmed_engine(n, gravity_drag_collisions(), Integrator::SemiImplicitEuler);
            warm.set_threads(1);
            describe("target", &warm);
            warm
        });
        b.iter_custom(|iters| time_steps(warm, iters, clock))
    });
    group.finish();
}

/// Scale (issue "Scale"): the target's scene at 10,000 and 100,000 balls (the field grows to keep
/// 20 % coverage: 1,585 m × 991 m at 100,000), on 1 and 2 threads. Goals on this 2-core machine:
/// 10,000 balls on 2 threads ≥ 3,500 steps/s (≤ 286 µs per step); 100,000 balls ≥ 200 steps/s
/// (≤ 5 ms per step). The thread count changes no bit of the result (tests/determinism.rs).
fn bench_scale(c: &mut Criterion) {
    let clock = Clock::from_env();
    let mut group = c.benchmark_group("scale");
    for n in [10_000, 100_000] {
        let warm = OnceCell::new();
        if n > 10_000 {
            group.sample_size(20).warm_up_time(Duration::from_secs(2)).measurement_time(Duration::from_secs(10));
        } else {
            group.warm_up_time(Duration::from_secs(2)).measurement_time(Duration::from_secs(6));
        }
        group.throughput(Throughput::Elements(n as u64));
        for threads in [1, 2] {
            group.bench_function(BenchmarkId::new(format!("{threads}-threads"), n), |b| {
                let warm: &Lockstep = warm.get_or_init(|| {
                    let warm = warmed_engine(n, gravity_drag_collisions(), Integrator::SemiImplicitEuler);
                    describe(&format!("scale/{n}"), &warm);
                    warm
                });
                let mut warm = warm.clone();
                warm.set_threads(threads);
                b.iter_custom(|iters| time_steps(&warm, iters, clock))
            });
        }
    }
    group.finish();
}

fn bench_integrators(c: &mut Criterion) {
    let clock = Clock::from_env();
    let n = 1_000;
    let mut group = c.benchmark_group("integrators");
    group.warm_up_time(Duration::from_secs(1)).measurement_time(Duration::from_secs(3));
    group.throughput(Throughput::Elements(n as u64));
    for integrator in Integrator::ALL {
        // Each integrator is warmed up with itself, so it is timed on its own trajectory.
        let warm = OnceCell::new();
        group.bench_function(BenchmarkId::new(integrator.name(), n), |b| {
            let warm = warm.get_or_init(|| {
                let warm = warmed_engine(n, gravity_drag_collisions(), integrator);
                describe(&format!("integrators/{integrator}/{n}"), &warm);
                warm
            });
            b.iter_custom(|iters| time_steps(warm, iters, clock))
        });
    }
    group.finish();
}

criterion_group!(benches, bench_effects, bench_target, bench_scale, bench_integrators);
criterion_main!(benches);
