//! Criterion bench of the threaded runtime's contact work per monitor pass, without its threads:
//! the shipped `pile` scene (1,000 balls, e = 0.8), settled by lockstep for 15 s of simulated
//! time, then judged span after span as the monitor judges it — every ball carried over the span
//! in free motion (one semi-implicit Euler step under gravity; drag at rest is nil), the circle
//! of its path grown by twice the fastest travel (as `ContactPass::find_pairs` grows it), the
//! broad phase, one `ContactSolver::solve` of every contact, the responses applied. The state
//! after each span is the next span's start, so the bench times a pile resting under the
//! monitor's solver, with the warm start carried over as in a run.
//!
//! Two groups of spans: `fixed`, every span 1 ms; `jittered`, spans from 1 to 2 ms, as the
//! monitor's passes come (each span runs from where the last ended to a horizon ahead of the
//! pass's clock). Before timing, the pile is judged [`WARM_SPANS`] spans, and the mean tally per
//! span over them is printed once: contacts, resting and position passes, impact rounds,
//! unconverged solves, and the kinetic energy left. Each timed iteration is one span, the mean
//! of the same [`RUN`] spans from the same state (a clone of the warmed pile), so every sample
//! times the same work.
//!
//! Run with `BALLFIELD_BENCH_CLOCK=thread-cpu` on a shared machine (see `clock/mod.rs`).

use std::hint::black_box;
use std::time::Duration;

use ballfield::Lockstep;
use ballfield::physics::{
    BroadPhase, ContactParams, ContactSolver, Integrator, SolveTally, SolverBall, resting_drift, swept_circle,
};
use criterion::{Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use glam::DVec2;

#[path = "clock/mod.rs"]
mod clock;
use clock::Clock;

/// The monitor's period: the shortest span a pass judges (s).
const SPAN: f64 = 1e-3;
/// Lockstep's settling time before the monitor's spans (s).
const SETTLE: f64 = 15.0;
/// Spans judged before timing.
const WARM_SPANS: u32 = 2000;
/// Spans each timed run takes, from the same state.
const RUN: u32 = 100;

/// The pile as the monitor carries it from span to span.
#[derive(Clone)]
struct Pass {
    balls: Vec<SolverBall>,
    start: Vec<(DVec2, DVec2)>,
    centres: Vec<DVec2>,
    reach: Vec<f64>,
    pairs: Vec<(u32, u32)>,
    broad_phase: BroadPhase,
    solver: ContactSolver,
    params: ContactParams,
    gravity: DVec2,
    /// Jittered spans: an LCG's state; `None`: every span is [`SPAN`].
    jitter: Option<u64>,
}

impl Pass {
    fn new(jittered: bool) -> Pass {
        let scene = ballfield::scenes::builtin("pile").unwrap().unwrap();
        let mut lockstep = Lockstep::new(&scene);
        lockstep.set_threads(1);
        lockstep.run((SETTLE / lockstep.dt()).round() as u64);
        let bodies = lockstep.bodies();
        let gravity = scene.effects.gravity.map_or(DVec2::ZERO, |g| g.g);
        let collisions = scene.effects.collisions.unwrap();
        let balls: Vec<SolverBall> = (0..bodies.len())
            .map(|i| SolverBall {
                id: bodies.id[i],
                position: bodies.position[i],
                velocity: bodies.velocity[i],
                acceleration: gravity,
                inverse_mass: bodies.inverse_mass[i],
                radius: bodies.radius[i],
            })
            .collect();
        let start = balls.iter().map(|b| (b.position, b.velocity)).collect();
        let mut broad_phase = BroadPhase::new();
        broad_phase.set_margin(1e-6);
        Pass {
            balls,
            start,
            centres: Vec::new(),
            reach: Vec::new(),
            pairs: Vec::new(),
            broad_phase,
            solver: ContactSolver::new(),
            params: ContactParams {
                restitution: collisions.restitution,
                field: scene.field,
                span: SPAN,
                drift: resting_drift(Integrator::SemiImplicitEuler, 1),
            },
            gravity,
            jitter: jittered.then_some(1),
        }
    }

    /// One span: free motion, pairs, one solve, the responses applied.
    fn span(&mut self) -> SolveTally {
        if let Some(seed) = &mut self.jitter {
            *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            self.params.span = SPAN * (1.0 + (*seed >> 11) as f64 / (1u64 << 53) as f64);
        }
        let h = self.params.span;
        self.centres.clear();
        self.reach.clear();
        let mut fastest = 0.0f64;
        for (b, &(x, v)) in self.balls.iter_mut().zip(&self.start) {
            let v1 = v + self.gravity * h;
            let x1 = x + v1 * h;
            fastest = fastest.max(v.length()).max(v1.length());
            b.position = x1;
            b.velocity = v1;
            let (c, r) = swept_circle(x, x1, self.gravity, h, b.radius);
            self.centres.push(c);
            self.reach.push(r);
        }
        for r in &mut self.reach {
            *r += 2.0 * fastest * h;
        }
        let field = &self.params.field;
        self.broad_phase.update(&self.centres, &self.reach, field.width, field.height);
        self.pairs.clear();
        let pairs = &mut self.pairs;
        self.broad_phase.for_each_touching_pair(|i, j| pairs.push((i as u32, j as u32)));
        let tally = self.solver.solve(&self.balls, &self.pairs, &self.params, Some(&self.broad_phase));
        for ((s, b), r) in self.start.iter_mut().zip(&self.balls).zip(self.solver.responses()) {
            *s = (b.position + r.shift, b.velocity + r.velocity_change);
        }
        tally
    }

    /// Judges [`WARM_SPANS`] spans and prints their mean tally.
    fn warm_up(&mut self, name: &str) {
        let (mut contacts, mut resting, mut positions, mut rounds, mut unconverged) = (0u64, 0u64, 0u64, 0u64, 0u64);
        for _ in 0..WARM_SPANS {
            let t = self.span();
            contacts += t.contacts;
            resting += t.resting_passes as u64;
            positions += t.position_passes as u64;
            rounds += t.impact_rounds as u64;
            unconverged += !t.converged as u64;
        }
        let kinetic: f64 =
            self.start.iter().zip(&self.balls).map(|((_, v), b)| 0.5 * v.length_squared() / b.inverse_mass).sum();
        let s = WARM_SPANS as f64;
        eprintln!(
            "{name}: per span over {WARM_SPANS} spans: {:.0} contacts, {:.1} resting passes, {:.2} position passes, \
             {:.3} impact rounds; {unconverged} unconverged; kinetic energy after them {kinetic:.2e} J",
            contacts as f64 / s,
            resting as f64 / s,
            positions as f64 / s,
            rounds as f64 / s,
        );
    }
}

fn bench_monitor_pass(c: &mut Criterion) {
    let clock = Clock::from_env();
    let mut group = c.benchmark_group("monitor-pass");
    group
        .sampling_mode(SamplingMode::Flat)
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(10));
    for (name, jittered) in [("pile-1000-fixed", false), ("pile-1000-jittered", true)] {
        let mut pass = Pass::new(jittered);
        pass.warm_up(name);
        group.throughput(Throughput::Elements(pass.balls.len() as u64));
        group.bench_function(name, |b| {
            b.iter_custom(|iters| {
                let mut total = Duration::ZERO;
                for _ in 0..iters {
                    let mut p = pass.clone();
                    total += clock.time(|| {
                        for _ in 0..RUN {
                            black_box(p.span());
                        }
                    });
                }
                total / RUN
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_monitor_pass);
criterion_main!(benches);
