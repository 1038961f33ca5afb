//! Heavy and light balls landing together on the threaded runtime (issue 13: hard cases, extreme
//! mass ratios; resting piles), as invariants of the table read at one instant: 80 balls of
//! 100 kg and 80 of 1 kg, all 1 m across, fall from up to 30 m into a 20 m wide box and land on
//! each other (`landing_heavy_and_light.rs` runs the same scene on lockstep). Light balls caught
//! between heavy ones are struck to many times the fastest free speed, and the monitor's
//! position passes push them nearly the whole of each overlap. No two balls overlap by more
//! than 2 % of a diameter (the threaded bound of a resting pile) at any read, through the
//! landing as well as once settled.

mod common;

use std::time::Duration;

use ballfield::physics::{
    BroadPhase, ContactParams, ContactSolver, Integrator, SolveTally, SolverBall, TOUCH_MARGIN, resting_drift,
    swept_circle,
};
use ballfield::runtime::{Runtime, RuntimeConfig};
use glam::DVec2;

/// The monitor's solve alone (no threads: the same work every run), span after span as the
/// monitor judges them: every ball carried over the span in free motion (semi-implicit Euler
/// under gravity), the circle of its path grown by twice the fastest travel (as `find_pairs`
/// grows it), the broad phase, one solve given that broad phase, the responses applied, for
/// 3.5 s (the piles land from 1.5 s on). Spans run from 1 to `longest_ms` ms (a fixed sequence:
/// a landing pile's passes come late, and a late pass judges its whole span in one solve).
/// `with_shapes` false leaves the solver the candidate pairs alone. Returns the largest overlap
/// at the end of any span (of a diameter) and the solves' tallies summed.
fn monitor_solve_landing(e: f64, seed: u64, longest_ms: u32, with_shapes: bool) -> (f64, SolveTally) {
    let scene = common::heavy_and_light(e, seed);
    let gravity = DVec2::new(0.0, -9.81);
    let mut balls: Vec<SolverBall> = scene
        .balls
        .iter()
        .map(|b| SolverBall {
            id: b.id,
            position: b.position,
            velocity: b.velocity,
            acceleration: gravity,
            inverse_mass: b.inverse_mass(),
            radius: b.radius(),
        })
        .collect();
    let mut start: Vec<(DVec2, DVec2)> = balls.iter().map(|b| (b.position, b.velocity)).collect();
    let mut broad_phase = BroadPhase::new();
    broad_phase.set_margin(TOUCH_MARGIN);
    let mut solver = ContactSolver::new();
    let drift = resting_drift(Integrator::SemiImplicitEuler, 1);
    let (mut centres, mut reach, mut pairs) = (Vec::new(), Vec::new(), Vec::new());
    let (mut t, mut k, mut worst) = (0.0, 0u32, 0.0f64);
    let mut sum = SolveTally::default();
    while t < 3.5 {
        let h = 1e-3 * f64::from(1 + k % longest_ms);
        k += 1;
        let params = ContactParams { restitution: e, field: scene.field, span: h, drift };
        centres.clear();
        reach.clear();
        let mut fastest = 0.0f64;
        for (b, &(x, v)) in balls.iter_mut().zip(&start) {
            let v1 = v + gravity * h;
            let x1 = x + v1 * h;
            fastest = fastest.max(v.length()).max(v1.length());
            (b.position, b.velocity) = (x1, v1);
            let (c, r) = swept_circle(x, x1, gravity, h, b.radius);
            centres.push(c);
            reach.push(r);
        }
        for r in &mut reach {
            *r += 2.0 * fastest * h;
        }
        broad_phase.update(&centres, &reach, scene.field.width, scene.field.height);
        pairs.clear();
        broad_phase.for_each_touching_pair(|i, j| pairs.push((i as u32, j as u32)));
        let tally = solver.solve(&balls, &pairs, &params, with_shapes.then_some(&broad_phase));
        sum.pushed_together += tally.pushed_together;
        sum.pairs_reached += tally.pairs_reached;
        for ((s, b), r) in start.iter_mut().zip(&balls).zip(solver.responses()) {
            *s = (b.position + r.shift, b.velocity + r.velocity_change);
        }
        for i in 0..start.len() {
            for j in i + 1..start.len() {
                let contact = balls[i].radius + balls[j].radius;
                worst = worst.max((contact - start[i].0.distance(start[j].0)) / contact);
            }
        }
        t += h;
    }
    (worst, sum)
}

/// The monitor's solve alone through the landing ([`monitor_solve_landing`]) at e = 0, 0.5,
/// 0.99 and 1, seeds 1 and 2, over spans of 1 to 4 ms (a pass up to three periods late): no
/// span ends with two balls more than 1.1 % of a diameter into each other; over spans of 1 to
/// 8 ms, 3.5 %. Measured (2026-12-08, these figures are deterministic): at most 1.004 % (e = 0.5,
/// seed 2) over spans to 4 ms; over spans to 8 ms 1.09 % but for e = 0.5, seed 2, 3.37 % (a span
/// of 6 ms whose impacts reached their cap and whose position passes, 9,000 of them, never
/// converged: a 100 kg ball pushed 0.69 m).
///
/// Seen to fail: without the listing of the pairs the position passes push together, 2.5 to
/// 59 % over spans to 4 ms at every e; without the broad phase given to the solve (the look-up
/// of balls sent out of their circles), 9.6 % and 96.9 % at e = 0.5 over spans to 8 ms (over
/// spans to 4 ms no ball leaves its circle far enough to matter).
#[test]
fn the_monitors_solve_lands_heavy_and_light_balls_without_deep_overlaps() {
    let (mut pushed, mut reached) = (0, 0);
    let mut failures = Vec::new();
    for (longest_ms, bound) in [(4, 0.011), (8, 0.035)] {
        for e in [0.0, 0.5, 0.99, 1.0] {
            for seed in 1..=2 {
                let (worst, tally) = monitor_solve_landing(e, seed, longest_ms, true);
                eprintln!(
                    "spans to {longest_ms} ms, e {e}, seed {seed}: largest overlap {:.3} %; pairs pushed together {}, \
                     reached {}",
                    100.0 * worst,
                    tally.pushed_together,
                    tally.pairs_reached
                );
                pushed += tally.pushed_together;
                reached += tally.pairs_reached;
                if worst > bound {
                    failures.push(format!("spans to {longest_ms} ms, e {e}, seed {seed}: {:.3} %", 100.0 * worst));
                }
            }
        }
    }
    assert!(failures.is_empty(), "a span ended with balls deep in each other: {failures:#?}");
    // The landings do take these paths: the test checks them, not quieter scenes.
    assert!(pushed > 0, "the position passes pushed no unlisted pair together");
    assert!(reached > 0, "no ball left its circle in the broad phase");
}

/// Each run read every 40 ms of wall time for 3.6 s of the runtime's clock (the piles land from
/// 1.5 s on and are settled, if still awake, by 3 s), at one instant for every ball
/// ([`Runtime::settle`]): the largest overlap of any read stays within 2 % of a diameter, at
/// e = 0, 0.5 and 0.99, seeds 1 and 2.
///
/// Measured (2026-12-08, seeds 1 to 4 in probes, e = 0 to 1): at most 1.47 % (e = 0.5), the
/// settled piles 0.50 %. One probe run of 40 (walls of restitution 1, e = 0.5) read 75 % once;
/// it did not come again in nine runs of that case, and its cause is not known. Seen to fail (before the monitor listed the pairs the position passes push together
/// and looked up the balls sent out of their circles, `physics::ContactSolver::solve`): 15 to
/// 95 % at e = 0 and 0.5 in every run, the monitor leaving candidate pairs it had not listed
/// overlapping by up to 64 %; with the listing but without the look-up, light balls pushed
/// 1 to 3.8 m by the position passes through balls they had no pair with (up to 95 %).
#[test]
fn heavy_and_light_balls_land_without_deep_overlaps_on_the_threaded_runtime() {
    let (mut pushed, mut reached) = (0, 0);
    let mut failures = Vec::new();
    for e in [0.0, 0.5, 0.99] {
        for seed in 1..=2 {
            let rt = Runtime::start(&common::heavy_and_light(e, seed), RuntimeConfig::default())
                .expect("the runtime starts");
            let (mut worst, mut at, mut now) = (0.0f64, 0.0, 0.0);
            while now < 3.6 {
                std::thread::sleep(Duration::from_millis(40));
                assert!(rt.settle(Duration::from_secs(20)), "e {e}, seed {seed}: the balls did not catch up");
                now = rt.snapshot().first().map_or(0.0, |r| r.time as f64 * 1e-9);
                let overlap = common::largest_overlap(&rt.bodies());
                if overlap > worst {
                    (worst, at) = (overlap, now);
                }
                rt.resume();
            }
            let stats = rt.stats();
            rt.shutdown();
            pushed += stats.pairs_pushed_together;
            reached += stats.pairs_reached;
            eprintln!(
                "e {e}, seed {seed}: largest overlap {:.3} % of a diameter at {at:.3} s; pairs pushed together {}, \
                 reached {}; {:.0} passes a second",
                100.0 * worst,
                stats.pairs_pushed_together,
                stats.pairs_reached,
                stats.monitor_passes_per_second,
            );
            if worst > 0.02 {
                failures.push(format!("e {e}, seed {seed}: {:.2} % of a diameter at {at:.3} s", 100.0 * worst));
            }
        }
    }
    assert!(failures.is_empty(), "balls overlapped deeply: {failures:#?}");
    // The landings do take this path (the look-up of balls sent out of their circles only now
    // and then, 0 to 34 pairs a run: the solve's own test above checks it).
    eprintln!("pairs reached in all: {reached}");
    assert!(pushed > 0, "the position passes pushed no unlisted pair together");
}
