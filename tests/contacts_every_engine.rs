//! Contacts hold in every engine (issue 13, "each point holds in both engines"): the same cases
//! run on each of `EngineKind::ALL` through `dyn Engine` alone, from scenes written as TOML, as
//! the window and headless runs start them.
//! - an oblique two-ball collision comes out as the closed form says (normal at the instant of
//!   contact) and loses (1 − e²)·½·μ·v_n², with gravity off and on, and e = 0.99 is within a few
//!   percent of e = 1;
//! - a free-falling cluster keeps p₀ + M·g·t whatever collides inside it;
//! - a ball dropped on a ball resting on the floor rebounds as sequential impacts predict, at
//!   every e from 0 to 1 and with either ball 5 times the other's mass;
//! - a ball striking two touching balls between them leaves them mirror images;
//! - a pyramid of three on a frictionless floor spreads as the constrained motion says, and
//!   stands between walls that hold its bottom balls (lockstep and threaded; the exact engine's
//!   pyramid stands, an ignored test).
//!
//! The threaded engine runs in wall time, so its runs are short (under half a second of
//! simulated time each) and one at a time. Where a check needs the balls' instant it reads it off
//! a witness, a ball falling freely from rest far from the others, whose velocity is g·t: that
//! holds whatever the engine's clock says.
//!
//! Tolerances are per engine, near what each achieves (the measured figures are in each test's
//! comment; the threaded engine's are the spread over 10 runs of the file). Where an engine
//! fails a case, that engine's run is an ignored test with the figures in its reason.
//!
//! Every check is seen to fail on a broken build:
//! - (α) ball b's share of every impulse scaled by 1.01 (`apply` in `physics/contact_solver.rs`,
//!   `collide` in `physics/event.rs`): the momentum checks fail in every engine (the cluster at
//!   e = 0.3 off by 3.8e-3 lockstep, 3.8e-3 threaded, 1.5e-3 exact), as do the pairs' velocity
//!   (up to 5.8e-3) and energy (up to 1.0e-2) checks and lockstep's drop (2.846 m/s);
//! - (β) restitution below 1 taken as 0 (the impact phase's target in `contact_solver.rs`, the
//!   outgoing speed in `engine/exact/world.rs`): e = 0.99 leaves 1.0 of the approach speed from
//!   e = 1 in every engine, and the dropped ball stops dead on the resting one (not rising);
//! - (γ) the impact round solved as sequential binary impulses (no mass splitting, each impulse
//!   applied at once, one sweep): B and C mirror each other only to 0.92, A is pushed sideways
//!   by 0.59 (lockstep and threaded);
//! - the scenes' collisions left out: no ball struck; the runs twelve times longer: balls reach
//!   the walls.

use std::fmt::Write as _;
use std::sync::Mutex;

use ballfield::engine::{self, Engine, EngineKind};
use ballfield::physics::{Ball, WallImpulses};
use ballfield::scene::{Origin, Scene};
use glam::DVec2;

/// The threaded engine's runs share the machine's cores: one at a time (every test here runs it).
fn serial() -> std::sync::MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    LOCK.lock().unwrap_or_else(|e| e.into_inner())
}

const G: f64 = 9.81;

/// The scenes' default integrator, the one a player gets.
const DEFAULT: &str = "semi-implicit-euler";
/// Exact for free flight under uniform gravity at any step (drift–kick–drift): under gravity
/// the flight then adds no error of its own, and whatever is off is the contacts'.
const LEAPFROG: &str = "leapfrog";

/// Notes a failed check and goes on, so that one run shows every engine's and every case's
/// failures (each test asserts at its end that there were none).
macro_rules! check {
    ($failures:ident, $ok:expr, $($message:tt)+) => {
        // Negated, so that a comparison with a NaN counts as failed.
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        let failed = !$ok;
        if failed {
            $failures.push(format!($($message)+));
        }
    };
}

/// Fails the test with every failed check.
fn none_failed(failures: Vec<String>) {
    assert!(failures.is_empty(), "{} checks failed:\n{}", failures.len(), failures.join("\n"));
}

/// A ball of a scene: position, velocity, mass, diameter.
#[derive(Clone, Copy, Debug)]
struct Spec {
    x: DVec2,
    v: DVec2,
    m: f64,
    d: f64,
}

fn spec(x: [f64; 2], v: [f64; 2], m: f64, d: f64) -> Spec {
    Spec { x: DVec2::from(x), v: DVec2::from(v), m, d }
}

/// A scene as a TOML document: a `width` × `height` field with walls of restitution `e_wall`,
/// ball restitution `e`, gravity (−y) if `gravity`, the balls advanced by `integrator` (its name
/// in a scene file), and `balls` in order (ids 0, 1, …).
fn scene(width: f64, height: f64, e_wall: f64, e: f64, gravity: bool, integrator: &str, balls: &[Spec]) -> Scene {
    let mut toml = String::new();
    writeln!(toml, "name = \"contacts-every-engine\"").unwrap();
    writeln!(toml, "[field]\nwidth = {width:?}\nheight = {height:?}\nrestitution = {e_wall:?}").unwrap();
    writeln!(toml, "[simulation]\ndt = 0.001\nseed = 7\nintegrator = \"{integrator}\"").unwrap();
    writeln!(toml, "[effects]\ncollisions = {{ restitution = {e:?} }}").unwrap();
    if gravity {
        writeln!(toml, "gravity = {{ g = [0.0, {:?}] }}", -G).unwrap();
    }
    for b in balls {
        writeln!(
            toml,
            "[[balls]]\nposition = [{:?}, {:?}]\nvelocity = [{:?}, {:?}]\nmass = {:?}\ndiameter = {:?}",
            b.x.x, b.x.y, b.v.x, b.v.y, b.m, b.d
        )
        .unwrap();
    }
    Scene::from_toml_str(&toml, &Origin("contacts-every-engine.toml".into())).unwrap()
}

/// What a run ended with: the balls (sorted by id, so in the scene's order), the engine's clock,
/// and the impulse the walls took in all.
struct End {
    balls: Vec<Ball>,
    time: f64,
    walls: f64,
    /// Each wall's impulse.
    gauges: WallImpulses,
    /// Balls put to sleep and woken over the run (the threaded runtime's sleeping islands; 0 on
    /// the other engines).
    slept: u64,
    woken: u64,
}

/// Runs `scene` on `kind` to simulated time `t`, stops it and reads it.
fn run(kind: EngineKind, scene: &Scene, t: f64) -> End {
    let mut e: Box<dyn Engine> = engine::start(kind, scene, Some(1)).unwrap();
    e.advance_to(t);
    e.quiesce();
    let mut balls = Vec::new();
    e.sample(&mut balls);
    let gauges = e.wall_impulses();
    let (slept, woken) = e.figures().runtime.map_or((0, 0), |r| (r.balls_slept, r.balls_woken));
    let end = End { balls, time: e.time(), walls: gauges.total(), gauges, slept, woken };
    e.shutdown();
    assert_eq!(end.balls.len(), scene.balls.len(), "{kind}: every ball is still on the field");
    end
}

/// The balls' instant, from a witness that fell freely from rest under gravity g: its velocity
/// is −g·t (every integrator adds g·dt to the velocity per step, which sums to g·t to rounding).
fn witness_time(witness: &Ball) -> f64 {
    -witness.velocity.y / G
}

/// The closed-form binary collision of `a` and `b` (any uniform gravity drops out of the
/// relative motion): the normal at the instant of contact (from `a` to `b`) and the velocity
/// change of each ball.
fn binary(a: &Spec, b: &Spec, e: f64) -> (DVec2, DVec2, DVec2) {
    let reach = 0.5 * (a.d + b.d);
    let (d, u) = (b.x - a.x, b.v - a.v);
    // |d + u·t| = reach, the earlier root.
    let (qa, qb, qc) = (u.length_squared(), d.dot(u), d.length_squared() - reach * reach);
    let t = (-qb - (qb * qb - qa * qc).sqrt()) / qa;
    let n = (d + u * t) / reach;
    let j = -(1.0 + e) * u.dot(n) / (1.0 / a.m + 1.0 / b.m);
    (n, -j / a.m * n, j / b.m * n)
}

/// Two pairs in lanes 40 m apart, each a 1 kg, 1 m ball meeting a 2 kg, 1.2 m ball at 10 m/s
/// with the impact parameter at `angle`° of the line of centres at contact (30° and 65°), after
/// about 0.1 s; a witness ball falls alone. Nothing reaches a wall in 0.4 s (gravity or not).
fn pairs() -> Vec<Spec> {
    let reach = 0.5 * (1.0 + 1.2);
    let mut balls = Vec::new();
    for (lane, angle) in [(30.0, 30.0f64), (70.0, 65.0)] {
        let b = reach * angle.to_radians().sin();
        balls.push(spec([40.0, lane], [6.0, 1.0], 1.0, 1.0));
        balls.push(spec([40.0 + reach * angle.to_radians().cos() + 1.0, lane + b], [-4.0, 1.0], 2.0, 1.2));
    }
    balls.push(spec([90.0, 90.0], [0.0, 0.0], 1.0, 1.0));
    balls
}

/// How far a pair's run is from the closed form: velocity error (relative to the closing speed;
/// without gravity each ball's velocity, with gravity the relative velocity, which gravity does
/// not change), energy loss of the relative motion against (1 − e²)·½·μ·v_n² (relative to the
/// relative motion's energy), and the outcome's relative velocity after.
fn pair_errors(start: &[Spec], end: &[Ball], k: usize, e: f64, gravity: bool) -> (f64, f64, DVec2) {
    let (a, b) = (&start[2 * k], &start[2 * k + 1]);
    let (ea, eb) = (&end[2 * k], &end[2 * k + 1]);
    let (n, dva, dvb) = binary(a, b, e);
    let u = b.v - a.v;
    let after = eb.velocity - ea.velocity;
    let dv = if gravity {
        (after - (u + dvb - dva)).length()
    } else {
        (ea.velocity - (a.v + dva)).length().max((eb.velocity - (b.v + dvb)).length())
    };
    let mu = a.m * b.m / (a.m + b.m);
    let vn = u.dot(n);
    let want_loss = (1.0 - e * e) * 0.5 * mu * vn * vn;
    let loss = 0.5 * mu * (u.length_squared() - after.length_squared());
    (dv / u.length(), (loss - want_loss).abs() / (0.5 * mu * u.length_squared()), after)
}

/// The bounds of the pair checks (relative velocity error, relative energy-loss error).
type PairBounds = fn(EngineKind) -> (f64, f64);

/// The pair checks' bounds per engine, about ten times the largest error measured (see the
/// tests' comments): every engine solves a binary collision in closed form, so what is left is
/// rounding — the exact engine's of one collision, the stepped engines' of the replay from the
/// instant of contact and of the flight's hundreds of steps.
fn pair_bounds(kind: EngineKind) -> (f64, f64) {
    match kind {
        EngineKind::Exact => (1e-13, 1e-13),
        EngineKind::Lockstep => (1e-12, 1e-12),
        EngineKind::Threaded => (5e-12, 5e-12),
    }
}

/// Runs the two pairs at e = 0, 0.5, 0.99 and 1 on each of `kinds` and checks each against the
/// closed form (within `bounds`); with gravity also the four balls' momentum against p₀ + M·g·t;
/// and that e = 0.99 leaves within 2 % of the normal approach speed of e = 1 (the closed form
/// says 1 %).
fn oblique_pairs(kinds: &[EngineKind], gravity: bool, integrator: &str, bounds: PairBounds) {
    let _s = serial();
    let mut failures = Vec::new();
    let start = pairs();
    for &kind in kinds {
        let (dv_bound, de_bound) = bounds(kind);
        let mut outcome = Vec::new();
        for e in [0.0, 0.5, 0.99, 1.0] {
            let s = scene(100.0, 100.0, 1.0, e, gravity, integrator, &start);
            let end = run(kind, &s, 0.4);
            let t = witness_time(&end.balls[4]);
            let mut p_err = 0.0f64;
            if gravity {
                let p0: DVec2 = start[..4].iter().map(|b| b.m * b.v).sum();
                let mass: f64 = start[..4].iter().map(|b| b.m).sum();
                let p: DVec2 = end.balls[..4].iter().map(|b| b.mass * b.velocity).sum();
                let scale: f64 = start[..4].iter().map(|b| b.m * b.v.length()).sum::<f64>() + mass * G * t;
                p_err = (p - (p0 + mass * DVec2::new(0.0, -G) * t)).length() / scale;
            }
            for k in 0..2 {
                let (dv, de, after) = pair_errors(&start, &end.balls, k, e, gravity);
                eprintln!(
                    "{kind} g {gravity} {integrator} e {e} pair {k}: velocity error {dv:.2e}, energy loss error \
                     {de:.2e}, momentum error {p_err:.2e} (clock {:.4} s, balls at {t:.4} s)",
                    end.time
                );
                check!(
                    failures,
                    dv <= dv_bound,
                    "{kind} g {gravity} e {e} pair {k}: velocities off the closed form by {dv:e}"
                );
                check!(failures, de <= de_bound, "{kind} g {gravity} e {e} pair {k}: energy loss off by {de:e}");
                outcome.push((e, k, after));
            }
            check!(failures, end.walls == 0.0, "{kind} g {gravity} e {e}: a ball reached a wall");
            check!(failures, p_err <= dv_bound, "{kind} e {e}: momentum off p₀ + M·g·t by {p_err:e}");
        }
        for k in 0..2 {
            let at = |e: f64| outcome.iter().find(|&&(x, j, _)| x == e && j == k).unwrap().2;
            let (n, _, _) = binary(&start[2 * k], &start[2 * k + 1], 1.0);
            let vn = (start[2 * k + 1].v - start[2 * k].v).dot(n).abs();
            let gap = (at(0.99) - at(1.0)).length() / vn;
            eprintln!("{kind} g {gravity} pair {k}: e = 0.99 is {gap:.6} of the approach speed from e = 1");
            check!(
                failures,
                gap <= 0.02,
                "{kind} g {gravity} pair {k}: e = 0.99 is {gap} of the approach speed from e = 1"
            );
        }
    }
    none_failed(failures);
}

/// Without gravity, at 30° and 65°. Measured (velocity error relative to the closing speed;
/// energy-loss error relative to the relative motion's energy): lockstep 2.0e-13 and 1.2e-13;
/// exact 2.3e-15 and 1.6e-15; threaded 4e-16–3.4e-13 and 0–1.9e-13. e = 0.99 leaves 0.010000 of
/// the approach speed from e = 1 in every engine. Seen to fail with (α) and (β).
#[test]
fn an_oblique_collision_matches_the_closed_form() {
    oblique_pairs(&EngineKind::ALL, false, DEFAULT, pair_bounds);
}

/// With gravity (leapfrog: the flight is exact, so the error is the collision's): the relative
/// velocity as the closed form says, and the pairs' momentum p₀ + M·g·t. Measured: lockstep
/// 4.3e-15 and 6.2e-15; exact 3.5e-15 and 1.6e-15; threaded 7e-16–7.9e-13 and 0–3.0e-13;
/// momentum within 8.2e-16 of its scale in every engine. Seen to fail with (α) (momentum off by
/// 1.6e-3 at e = 0) and (β).
#[test]
fn an_oblique_collision_under_gravity_matches_the_closed_form() {
    oblique_pairs(&EngineKind::ALL, true, LEAPFROG, pair_bounds);
}

/// The same with the default integrator, semi-implicit Euler, on every engine (the exact engine
/// has no steps; the threaded engine's balls cut their steps at the monitor's grid of whole
/// periods, so every ball takes the same steps, as in lockstep). Measured: lockstep 3.0e-13 and
/// 1.2e-13; exact as with leapfrog; threaded 9.4e-14–3.1e-13 and 6.0e-15–1.2e-13, the same in three
/// runs. Seen to fail with the threaded balls' steps cut where each woke (the build before the
/// grid): velocity error 6e-9 to 6.6e-4 of the closing speed over 10 runs, energy-loss error up
/// to 2.3e-4 — each ball's semi-implicit flight strayed from the parabola by ½·g·Σh² over its own
/// uneven cycles, so the pair's relative motion was not the straight line the monitor's time of
/// impact takes.
#[test]
fn an_oblique_collision_under_gravity_with_semi_implicit_euler() {
    oblique_pairs(&EngineKind::ALL, true, DEFAULT, pair_bounds);
}

/// A column of three touching balls falling in mid-air, struck from above at 10 m/s and from
/// the side at 6 m/s, and a fifth ball coming in obliquely; a witness falls alone. Nothing
/// reaches a wall in 0.5 s.
fn cluster() -> Vec<Spec> {
    vec![
        spec([50.0, 50.0], [0.0, 0.0], 1.0, 1.0),
        spec([50.0, 51.0], [0.0, 0.0], 1.5, 1.0),
        spec([50.0, 52.0], [0.0, 0.0], 2.0, 1.0),
        spec([50.0, 54.0], [0.0, -10.0], 2.0, 1.0),
        spec([48.2, 51.0], [6.0, 0.0], 0.7, 0.8),
        spec([53.0, 49.0], [-4.0, 3.0], 1.0, 1.0),
        spec([90.0, 90.0], [0.0, 0.0], 1.0, 1.0),
    ]
}

/// The cluster's momentum is p₀ + M·g·t at e = 0.3 and e = 1 (t the balls' instant, the
/// witness's), relative to the momentum scale Σ m·|v₀| + M·g·t, with the default integrator
/// (momentum does not depend on it). Every ball but the witness is struck (its velocity off free
/// flight by more than 0.5 m/s). Measured: lockstep 5.3e-15; exact 1.0e-16; threaded 0–9.2e-16.
/// Seen to fail with (α).
#[test]
fn a_free_falling_cluster_keeps_p0_plus_mgt() {
    let _s = serial();
    let mut failures = Vec::new();
    let start = cluster();
    let n = start.len() - 1;
    for kind in EngineKind::ALL {
        for e in [0.3, 1.0] {
            let s = scene(100.0, 100.0, 1.0, e, true, DEFAULT, &start);
            let end = run(kind, &s, 0.5);
            let t = witness_time(&end.balls[n]);
            let mass: f64 = start[..n].iter().map(|b| b.m).sum();
            let p0: DVec2 = start[..n].iter().map(|b| b.m * b.v).sum();
            let p: DVec2 = end.balls[..n].iter().map(|b| b.mass * b.velocity).sum();
            let scale = start[..n].iter().map(|b| b.m * b.v.length()).sum::<f64>() + mass * G * t;
            let err = (p - (p0 + mass * DVec2::new(0.0, -G) * t)).length() / scale;
            let struck = (0..n)
                .filter(|&i| (end.balls[i].velocity - (start[i].v + DVec2::new(0.0, -G) * t)).length() > 0.5)
                .count();
            eprintln!(
                "{kind} e {e}: momentum off p₀ + M·g·t by {err:.2e} of its scale; {struck} balls struck \
                 (clock {:.4} s, balls at {t:.4} s)",
                end.time
            );
            check!(failures, end.walls == 0.0, "{kind} e {e}: a ball reached a wall");
            check!(failures, struck == n, "{kind} e {e}: only {struck} of {n} balls were struck");
            check!(failures, err <= 1e-13, "{kind} e {e}: momentum off p₀ + M·g·t by {err:e}");
        }
    }
    none_failed(failures);
}

/// The chain of binary impacts a ball A dropped onto a ball B resting on the floor goes through,
/// one at a time (the sequential-impact model of tests/restitution.rs): A–B, then B–floor, then
/// A–B again, … until nothing approaches. Velocities are vertical, up positive. Returns A's
/// final velocity. (Lockstep's own test also softens the impacts slower than a few cm/s; in this
/// chain only B's last bounce on the floor is that slow, and it no longer reaches A.) For equal
/// masses at e = 0.8 it is 0.638 of the speed of arrival, against 0.8 off an immovable B.
fn sequential_impacts(va: f64, vb: f64, ma: f64, mb: f64, e: f64, e_wall: f64) -> f64 {
    sequential_impacts_of_both(va, vb, ma, mb, e, e_wall).0
}

/// [`sequential_impacts`], returning B's final velocity as well.
fn sequential_impacts_of_both(mut va: f64, mut vb: f64, ma: f64, mb: f64, e: f64, e_wall: f64) -> (f64, f64) {
    for _ in 0..1000 {
        if va - vb < 0.0 {
            let j = -(1.0 + e) * (va - vb) / (1.0 / ma + 1.0 / mb);
            va += j / ma;
            vb -= j / mb;
        } else if vb < 0.0 {
            vb *= -e_wall;
        } else {
            break;
        }
    }
    (va, vb)
}

/// Drops A (1 kg, 1 m) from 1 m above B (1 kg, 1 m) resting on the floor, e = 0.8 for the balls
/// and the walls (leapfrog: A's flight is exact), and returns A's measured and predicted
/// rebound speeds and its velocity then. The measured speed is read 0.2 s after the impact, in
/// flight, off A's energy: √(v² + 2·g·(y − y_contact)), so it needs no instant (the threaded
/// engine's balls stand a little ahead of its clock).
fn drop_on_resting_ball(kind: EngineKind) -> (f64, f64, f64) {
    let (e, fall) = (0.8, 1.0);
    let contact_y = 1.5;
    let start = [spec([5.0, contact_y + fall], [0.0, 0.0], 1.0, 1.0), spec([5.0, 0.5], [0.0, 0.0], 1.0, 1.0)];
    let s = scene(10.0, 20.0, e, e, true, LEAPFROG, &start);
    let t_impact = (2.0 * fall / G).sqrt();
    let end = run(kind, &s, t_impact + 0.2);
    let a = &end.balls[0];
    let measured = (a.velocity.y * a.velocity.y + 2.0 * G * (a.position.y - contact_y)).max(0.0).sqrt();
    (measured, sequential_impacts(-(2.0 * G * fall).sqrt(), 0.0, 1.0, 1.0, e, e), a.velocity.y)
}

/// Checks the rebound of [`drop_on_resting_ball`] on each of `kinds` within `bound(kind)` m/s
/// of the chain's, A still rising (the chain's rebound tops out 0.29 s after the impact).
fn drops(kinds: &[EngineKind], bound: fn(EngineKind) -> f64) {
    let _s = serial();
    let mut failures = Vec::new();
    for &kind in kinds {
        let (measured, predicted, vy) = drop_on_resting_ball(kind);
        let off = measured - predicted;
        eprintln!("{kind}: A rebounds at {measured:.5} m/s, the chain predicts {predicted:.5} m/s ({off:+.5} m/s)");
        check!(failures, vy > 0.0, "{kind}: A is not rising 0.2 s after the impact (at {vy} m/s)");
        check!(
            failures,
            off.abs() <= bound(kind),
            "{kind}: A rebounds at {measured} m/s, the chain predicts {predicted} m/s"
        );
    }
    none_failed(failures);
}

/// The rebound matches the chain (2.826 m/s from an arrival at 4.429 m/s) within what a step or
/// a ball cycle takes: the impact falls inside a step of dt = 1 ms (or a cycle of about that),
/// and the struck ball B is taken at its end-of-step velocity, which the floor's support reaches
/// only in the resting phase (tests/restitution.rs), so the approach is off by up to g·dt.
/// Lockstep and threaded within g·dt = 0.0098 m/s (both measured 0.0084 m/s low): the threaded
/// monitor judges one period (1 ms) per solve, also when it wakes late (before 2026-12-06 a late
/// pass judged its periods in one solve, and this rebound was up to 0.024 m/s low under a load
/// average in the hundreds). Seen to fail with (α) (lockstep) and (β).
#[test]
fn a_ball_dropped_on_a_resting_ball_rebounds_as_sequential_impacts_predict() {
    drops(&[EngineKind::Lockstep, EngineKind::Threaded], |_| G * 1e-3);
}

/// The exact engine strikes a ball at rest on the floor (touching no other ball at rest) through
/// to the floor, as the chain does: measured 2.825987 m/s against the chain's 2.825987 m/s
/// (2e-15 off). Before (the struck ball held immovable by the rest model) A rebounded at e·v,
/// 3.5436 m/s; seen to fail so with `World::strike_through_rest` off.
#[test]
fn exact_ball_dropped_on_a_resting_ball_rebounds_as_sequential_impacts_predict() {
    drops(&[EngineKind::Exact], |_| 1e-12);
}

/// The chain of binary impacts a ball dropped onto a column of balls resting on the floor goes
/// through, one at a time: `v` the balls' vertical velocities from the bottom (up positive),
/// each step the floor if the bottom ball moves into it, else the lowest pair that closes.
/// Returns the velocities once nothing closes.
fn column_chain(mut v: Vec<f64>, e: f64, e_wall: f64) -> Vec<f64> {
    for _ in 0..100_000 {
        if v[0] < 0.0 {
            v[0] *= -e_wall;
            continue;
        }
        let Some(k) = (0..v.len() - 1).find(|&k| v[k + 1] < v[k]) else { break };
        // Equal masses: J = (1 + e)·(v_k − v_{k+1})/2 each way.
        let j = 0.5 * (1.0 + e) * (v[k] - v[k + 1]);
        v[k] -= j;
        v[k + 1] += j;
    }
    v
}

/// A ball dropped from 1 m onto a column of `below` balls resting on the floor (1 kg, 1 m each,
/// leapfrog), ball restitution `e` and walls `e_wall`, on `kind`: the dropped ball's rebound
/// speed (read 0.1 s after the impact, off its energy, as [`drop_on_resting_ball`] does) and the
/// chain's ([`column_chain`]).
fn drop_on_stack(kind: EngineKind, below: usize, e: f64, e_wall: f64) -> (f64, f64) {
    let mut balls: Vec<Spec> = (0..below).map(|k| spec([5.0, 0.5 + k as f64], [0.0, 0.0], 1.0, 1.0)).collect();
    let contact_y = 0.5 + below as f64;
    balls.push(spec([5.0, contact_y + 1.0], [0.0, 0.0], 1.0, 1.0));
    let s = scene(10.0, 20.0, e_wall, e, true, LEAPFROG, &balls);
    let end = run(kind, &s, (2.0 / G).sqrt() + 0.1);
    let a = &end.balls[below];
    let measured = (a.velocity.y * a.velocity.y + 2.0 * G * (a.position.y - contact_y)).max(0.0).sqrt();
    let mut v = vec![0.0; below + 1];
    v[below] = -(2.0 * G).sqrt();
    (measured, column_chain(v, e, e_wall)[below])
}

/// A ball dropped on a stack of two or three balls resting on the floor rebounds as the chain of
/// sequential impacts down the stack and back says, on every engine: at e = 1 on a floor of 0.5
/// at half its arrival speed (2.2147 m/s from 4.4294), not all of it; at e = 0.8 (walls 0.8) at
/// 2.2448 m/s (two below) and 1.7740 (three below); at e = 1 everywhere at all of it; at e = 0.9
/// on a floor of 0.3 at 1.0613 and 0.9467.
///
/// Measured: lockstep to rounding at e = 1 (its elastic passes) and 0.0121–0.0131 m/s low at
/// e < 1; threaded 0.0077–0.0131 low; the exact engine to rounding at e = 1 and up to 0.0014
/// high at e < 1. Bounds: lockstep and threaded 1.5·g·dt (one ball below: g·dt, measured 0.0084
/// low; each struck ball of the stack is taken at its end-of-step velocity, off by up to g·dt,
/// see [`a_ball_dropped_on_a_resting_ball_rebounds_as_sequential_impacts_predict`]; the threaded
/// monitor judges one period per solve), the exact engine 2e-3 m/s: it strikes the contacts that close
/// at one instant together, as rounds, where the chain takes them one at a time from the bottom
/// (three below at e = 0.8: 1.7753 against 1.7740). Before (2026-12-06) the exact engine held a
/// stack immovable (the rest model) and the ball rebounded at e·v: 4.4294 m/s at e = 1 on a floor
/// of 0.5 and 3.5436 at e = 0.8, two below (seen to fail so).
#[test]
fn a_ball_dropped_on_a_resting_stack_rebounds_as_sequential_impacts_predict() {
    let _s = serial();
    let mut failures = Vec::new();
    for kind in [EngineKind::Lockstep, EngineKind::Threaded, EngineKind::Exact] {
        let bound = match kind {
            EngineKind::Lockstep | EngineKind::Threaded => 1.5 * G * 1e-3,
            _ => 2e-3,
        };
        for below in [2, 3] {
            for (e, e_wall) in [(1.0, 0.5), (0.8, 0.8), (1.0, 1.0), (0.9, 0.3)] {
                let (measured, predicted) = drop_on_stack(kind, below, e, e_wall);
                let off = measured - predicted;
                eprintln!(
                    "{kind}, {below} below, e {e}, walls {e_wall}: rebounds at {measured:.5} m/s, the chain {predicted:.5} ({off:+.5})"
                );
                check!(
                    failures,
                    off.abs() <= bound,
                    "{kind}, {below} below, e {e}, walls {e_wall}: rebounds at {measured} m/s, the chain predicts {predicted}"
                );
            }
        }
    }
    none_failed(failures);
}

/// A column of three balls on a floor of restitution 0.5, e = 1 between them, the top one moving
/// down at 0.15 m/s onto the two at rest, on `kind`: the largest kinetic energy of a ball (J) and
/// speed (m/s) it shows at 2, 2.5 and 3 s. Each bounce of the top ball reaches the floor through the
/// two below and loses three quarters of its energy there (the chain of sequential impacts), so
/// the column comes to rest within a second.
fn elastic_column_left(kind: EngineKind) -> (f64, f64) {
    let balls = [
        spec([5.0, 0.5], [0.0, 0.0], 1.0, 1.0),
        spec([5.0, 1.5], [0.0, 0.0], 1.0, 1.0),
        spec([5.0, 2.5], [0.0, -0.15], 1.0, 1.0),
    ];
    let s = scene(10.0, 20.0, 0.5, 1.0, true, DEFAULT, &balls);
    let (mut kinetic, mut speed) = (0.0f64, 0.0f64);
    for t in [2.0, 2.5, 3.0] {
        let end = run(kind, &s, t);
        for b in &end.balls {
            kinetic = kinetic.max(0.5 * b.mass * b.velocity.length_squared());
            speed = speed.max(b.velocity.length());
        }
    }
    (kinetic, speed)
}

/// [`elastic_column_left`] on lockstep and the threaded runtime: at rest (measured: lockstep
/// 2.6e-26 J and 2.3e-13 m/s a ball, threaded 0 J and 0 m/s, its column asleep). Bounds: 1e-9 J
/// and 1e-6 m/s a ball. Lockstep sent every e = 1 field through its elastic passes until
/// 2026-12-07, where the column kept a cycle of three steps in which the middle ball moved down
/// at 2·g·dt every step and stayed where it was (1.9e-4 J a ball, 0.0196 m/s: the passes handed
/// its approach to the bottom ball, the finish pass stopped that one on the floor, and the next
/// step's pair push lifted it back, giving back what the floor took); a field whose walls take
/// energy now goes through the contact solver, whose rules for a settling pile hold for its
/// elastic contacts too (seen to fail so, with the elastic passes: 1.9e-4 J).
#[test]
fn an_elastic_column_on_a_dissipative_floor_comes_to_rest_on_lockstep_and_threaded() {
    let _s = serial();
    let mut failures = Vec::new();
    for kind in [EngineKind::Lockstep, EngineKind::Threaded] {
        let (kinetic, speed) = elastic_column_left(kind);
        eprintln!("{kind}: kinetic ≤ {kinetic:e} J, speed ≤ {speed:e} m/s at 2–3 s");
        check!(failures, kinetic <= 1e-9 && speed <= 1e-6, "{kind}: kinetic {kinetic} J, speed {speed} m/s");
    }
    none_failed(failures);
}

/// [`elastic_column_left`] on the exact engine: at rest (measured 0 J and 0 m/s, every ball at
/// rest from the top ball's second landing, 32 events). Before (2026-12-07) the top ball kept
/// hopping a micrometre high on the two below for ever (1.1e-5 J, 4.7e-3 m/s; seen to fail so):
/// slower than the collapse speed, the hop met a stack the rest model held immovable, and
/// bounced off it elastically; such a hop is now struck through the stack to the floor, as a
/// fast one is.
#[test]
fn an_elastic_column_on_a_dissipative_floor_comes_to_rest_on_exact() {
    let _s = serial();
    let (kinetic, speed) = elastic_column_left(EngineKind::Exact);
    eprintln!("exact: kinetic ≤ {kinetic:e} J, speed ≤ {speed:e} m/s at 2–3 s");
    assert!(kinetic <= 1e-9 && speed <= 1e-6, "exact: kinetic {kinetic} J, speed {speed} m/s");
}

/// The drop over restitutions and mass ratios, on `kind`: A (mass `ma`) from 1 m onto B (`mb`)
/// resting on the floor, e for balls and walls alike, read 5 ms after the impact (at low e A
/// tops out within 15 ms and lands on B again). A's rebound speed against the chain's, within
/// `bound` m/s; where `b_bound` is given, B's too where the chain has it leave faster than 1 cm/s
/// (else B at most that: the rest models hold slower bounces); where `balance` is given, the momentum against the walls' impulses,
/// `p(t) = p₀ − M·g·t + J_floor − J_top`, within it (relative to M·g·t); e = 0.99 apart from
/// e = 1 as the chain's own two are, within twice `bound` (the chain's own difference is 1.3–3.7 %
/// for masses 5 to 1 apart, 6.9 % for A 20 times B's mass: each of its impacts loses 2 % of its
/// energy, and a heavy A strikes a light B about π·√(m_A/m_B) times; within 5 % of each other,
/// as this asked before the 20:1 case, the chain itself is not); and once with B in the floor's
/// corner, touching the side wall too. The masses: B 5
/// times lighter, as heavy, 5 times heavier, and 20 times lighter (the chain of 14 impacts that
/// lockstep's elastic passes left at 4 before its walls came between the passes, 2026-12-05).
fn drop_sweep(kind: EngineKind, bound: f64, balance_bound: Option<f64>, b_bound: Option<f64>) {
    drop_sweep_from(kind, 1.0, bound, balance_bound, b_bound, false);
}

/// [`drop_sweep`] with A dropped from `fall` m above B; `onto_sleeping`: every case checks that B
/// was asleep when A arrived and that A woke it (the threaded runtime's sleeping islands: B,
/// resting on the floor from the start, sleeps after `TIME_TO_SLEEP`).
fn drop_sweep_from(
    kind: EngineKind,
    fall: f64,
    bound: f64,
    balance_bound: Option<f64>,
    b_bound: Option<f64>,
    onto_sleeping: bool,
) {
    let _s = serial();
    let mut failures = Vec::new();
    let contact_y = 1.5;
    let t_impact = (2.0 * fall / G).sqrt();
    let at = |e: f64, ma: f64, mb: f64, x: f64, failures: &mut Vec<String>| {
        let start = [spec([x, contact_y + fall], [0.0, 0.0], ma, 1.0), spec([x, 0.5], [0.0, 0.0], mb, 1.0)];
        let s = scene(10.0, 20.0, e, e, true, LEAPFROG, &start);
        let End { balls, time, gauges: walls, slept, woken, .. } = run(kind, &s, t_impact + 5e-3);
        if onto_sleeping {
            // B alone slept (A was falling), and A's arrival woke it.
            check!(
                failures,
                slept >= 1 && woken >= 1,
                "{kind} e {e} ma {ma} mb {mb} x {x}: {slept} slept, {woken} woken"
            );
        }
        let a = &balls[0];
        let measured = (a.velocity.y * a.velocity.y + 2.0 * G * (a.position.y - contact_y)).max(0.0).sqrt();
        let (chain, chain_b) = sequential_impacts_of_both(-(2.0 * G * fall).sqrt(), 0.0, ma, mb, e, e);
        let chain = chain.max(0.0);
        // B's rebound off the floor the same way (it has left the floor by then, or rests on it).
        let b = &balls[1];
        let measured_b = (b.velocity.y * b.velocity.y + 2.0 * G * (b.position.y - 0.5)).max(0.0).sqrt();
        // The rest model (exact engine) puts the momentum of a ball that comes to rest moving up
        // on the top wall's gauge.
        let p: f64 = balls.iter().map(|b| b.mass * b.velocity.y).sum();
        let weight_time = (ma + mb) * G * time;
        let balance = (p - (-weight_time + walls.bottom - walls.top)).abs() / weight_time;
        eprintln!(
            "{kind} e {e} ma {ma} mb {mb} x {x}: A rebounds at {measured:.6} m/s, the chain {chain:.6} m/s ({:+.1e}); \
             B at {measured_b:.6} m/s, the chain {chain_b:.6} m/s ({:+.1e}); momentum balance {balance:.1e}",
            measured - chain,
            measured_b - chain_b
        );
        check!(
            failures,
            (measured - chain).abs() <= bound,
            "{kind} e {e} ma {ma} mb {mb}: A at {measured}, chain {chain}"
        );
        // B too, where the chain has it leave faster than the rest model's speeds (mm/s).
        if let Some(bb) = b_bound {
            let ok = if chain_b > 0.01 { (measured_b - chain_b).abs() <= bb } else { measured_b <= 0.01 };
            check!(failures, ok, "{kind} e {e} ma {ma} mb {mb} x {x}: B at {measured_b}, chain {chain_b}");
        }
        if let Some(b) = balance_bound {
            check!(
                failures,
                balance <= b,
                "{kind} e {e} ma {ma} mb {mb}: momentum off the walls' impulses by {balance:e}"
            );
        }
        check!(failures, walls.left + walls.right == 0.0, "{kind} e {e}: a side wall was struck");
        measured
    };
    for (ma, mb) in [(1.0, 1.0), (1.0, 0.2), (0.2, 1.0), (20.0, 1.0)] {
        for e in [0.0, 0.3, 0.8] {
            at(e, ma, mb, 5.0, &mut failures);
        }
        let (near, one) = (at(0.99, ma, mb, 5.0, &mut failures), at(1.0, ma, mb, 5.0, &mut failures));
        let arrival = -(2.0 * G * fall).sqrt();
        let chain = |e: f64| sequential_impacts(arrival, 0.0, ma, mb, e, e).max(0.0);
        let (chain_near, chain_one) = (chain(0.99), chain(1.0));
        check!(
            failures,
            ((near - one) - (chain_near - chain_one)).abs() <= 2.0 * bound,
            "{kind} ma {ma} mb {mb}: e = 0.99 gives {near}, e = 1 {one}; the chain {chain_near}, {chain_one}"
        );
    }
    // B in the floor's corner, touching the side wall too: A rebounds the same.
    at(0.8, 1.0, 1.0, 0.5, &mut failures);
    none_failed(failures);
}

/// [`drop_sweep`] on the exact engine. Measured: every rebound of A and B within 1.8e-14 m/s of
/// the chain (e = 0, 0.3, 0.8, 0.99, 1; B 5 times lighter, as heavy, 5 times heavier; B in the
/// corner) but B's at e = 0.99 (0.2 mm/s in the chain, at rest here), the balance to 3.3e-16. Seen to fail with `World::strike_through_rest` off (the struck ball held immovable: A
/// off by up to 1.47 m/s, and by 0.11 m/s at e = 1 onto a lighter B) and with its wall impulses
/// left off the gauge (the balance off by 0.17–1.7 of M·g·t), and with B kept at rest unless it
/// leaves every wall it touches (B in the corner at 0 for the chain's 0.064 m/s).
#[test]
fn exact_drop_on_a_resting_ball_is_the_chain_at_every_restitution_and_mass_ratio() {
    drop_sweep(EngineKind::Exact, 1e-12, Some(1e-13), Some(1e-12));
}

/// [`drop_sweep`] on lockstep (dt = 1 ms): its approach is off by up to g·dt (see the e = 0.8 case
/// above). Measured: 0 (e = 0) to 1.02e-2 m/s low (e = 0.99), at most 1.04·g·dt; 4.2e-3 m/s high at
/// e = 1 onto a lighter B; the balance to 5.9e-15; A 20 times B's mass: 9.9e-3 m/s low at
/// e = 0.99, 7.1e-5 m/s at e = 1. Bound 1.2·g·dt. Seen to fail with (β): A at 0 wherever the
/// chain rebounds; and with the walls left out of the elastic passes (as before 2026-12-05): at
/// e = 1, A 20 times B's mass, A at 3.86 m/s against the chain's 4.42 (B at 9.7 against 1.2). (B is not checked: lockstep's settling ramp holds B's slow last
/// bounces, 6 cm/s at e = 0.8, that the chain gives, and B is up to 4e-2 m/s off elsewhere.)
#[test]
fn lockstep_drop_on_a_resting_ball_is_the_chain_at_every_restitution_and_mass_ratio() {
    drop_sweep(EngineKind::Lockstep, 1.2 * G * 1e-3, Some(1e-12), None);
}

/// [`drop_sweep`] on the threaded engine, within lockstep's bound: its monitor judges one period
/// (1 ms) per solve, however late its passes come (`threaded_stall.rs`, the late monitor).
/// Measured (2026-12-06, in every run the same): 0 (e = 0) to 1.03e-2 m/s low, lockstep's figures
/// to the printed digit but at e = 1 (1.0e-2 m/s low where lockstep is within 5e-4); the
/// balance is not checked (its balls stand at slightly different instants: 4e-5–9e-5). Judged
/// in one solve a late pass is a longer step: passes 2 to 5 ms apart on the 2-core CI machine
/// put A 0.037 m/s low (e = 0.8, A five times lighter than B).
#[test]
fn threaded_drop_on_a_resting_ball_is_the_chain_at_every_restitution_and_mass_ratio() {
    drop_sweep(EngineKind::Threaded, 1.2 * G * 1e-3, None, None);
}

/// [`drop_sweep_from`] on the threaded engine, A dropped from 2 m (0.64 s) onto a B that has
/// slept since 0.5 s (`TIME_TO_SLEEP`): a ball landing on a sleeping one meets it as it would an
/// awake one, at every e and mass ratio, within 1.2·g·dt of the chain as above. Measured
/// (2026-12-06): A 0 (e = 0) to 1.08e-2 m/s low (1.10·g·dt), B asleep and woken in every case. Seen to fail
/// with the broad phase's awake–asleep pairs waking nothing (`monitor.rs`, the `to_wake` pushes
/// left out): A falls through B at 6.26 m/s, "1 slept, 0 woken".
#[test]
fn threaded_drop_on_a_sleeping_ball_is_the_chain_at_every_restitution_and_mass_ratio() {
    drop_sweep_from(EngineKind::Threaded, 2.0, 1.2 * G * 1e-3, None, None, true);
}

/// The chain of binary impacts of an oblique strike along the fixed normal `n` (from A to B):
/// A–B, then B–floor, … until nothing approaches. Returns A's and B's velocities.
fn sequential_impacts_2d(
    (mut va, mut vb): (DVec2, DVec2),
    (ma, mb): (f64, f64),
    n: DVec2,
    (e, e_wall): (f64, f64),
) -> (DVec2, DVec2) {
    for _ in 0..1000 {
        let vn = (vb - va).dot(n);
        if vn < 0.0 {
            let j = -(1.0 + e) * vn / (1.0 / ma + 1.0 / mb);
            va -= j / ma * n;
            vb += j / mb * n;
        } else if vb.y < 0.0 {
            vb.y *= -e_wall;
        } else {
            break;
        }
    }
    (va, vb)
}

/// The exact engine: A falls onto B, at rest on the floor, half a diameter off its axis (the
/// normal 30° off the vertical), balls e = 0.8, the floor plastic (e = 0) or not (0.8). B is
/// knocked along the floor (sliding, on the plastic floor) or off it, and both leave as the chain
/// of sequential impacts says; the momentum balances the walls' impulses. Read 5 ms after the
/// impact.
#[test]
fn exact_oblique_strike_on_a_resting_ball_is_the_chain() {
    let mut failures = Vec::new();
    let (fall, d, offset): (f64, f64, f64) = (1.0, 1.0, 0.5);
    let drop_y = 0.5 + (d * d - offset * offset).sqrt();
    let t_impact = (2.0 * fall / G).sqrt();
    let delta = 5e-3;
    for e_wall in [0.0, 0.8] {
        let start = [spec([5.0 - offset, drop_y + fall], [0.0, 0.0], 1.0, d), spec([5.0, 0.5], [0.0, 0.0], 1.0, d)];
        let s = scene(10.0, 20.0, e_wall, 0.8, true, LEAPFROG, &start);
        let End { balls, time, gauges: walls, .. } = run(EngineKind::Exact, &s, t_impact + delta);
        let n = DVec2::new(offset, -(d * d - offset * offset).sqrt()) / d;
        let (va, vb) =
            sequential_impacts_2d((DVec2::new(0.0, -G * t_impact), DVec2::ZERO), (1.0, 1.0), n, (0.8, e_wall));
        let g = DVec2::new(0.0, -G * delta);
        let want_a = va + g;
        let want_b = if vb.y > 0.0 { vb + g } else { DVec2::new(vb.x, 0.0) };
        let (err_a, err_b) = ((balls[0].velocity - want_a).length(), (balls[1].velocity - want_b).length());
        let p: DVec2 = balls.iter().map(|b| b.mass * b.velocity).sum();
        let weight_time = 2.0 * G * time;
        let balance =
            (p - DVec2::new(walls.left - walls.right, -weight_time + walls.bottom - walls.top)).length() / weight_time;
        eprintln!(
            "e_wall {e_wall}: A {:?} (chain {want_a:?}, off {err_a:.1e}), B {:?} (chain {want_b:?}, off {err_b:.1e}); \
             balance {balance:.1e}",
            balls[0].velocity, balls[1].velocity
        );
        check!(
            failures,
            err_a <= 1e-12 && err_b <= 1e-12,
            "e_wall {e_wall}: A off the chain by {err_a:e}, B by {err_b:e}"
        );
        check!(failures, vb.x > 0.1, "e_wall {e_wall}: B not knocked sideways ({vb:?})");
        check!(failures, balance <= 1e-13, "e_wall {e_wall}: momentum off the walls' impulses by {balance:e}");
    }
    none_failed(failures);
}

/// A (1 kg, 1 m) flies along y = 10 at 5 m/s into B and C (1 kg, 1 m), which touch each other
/// at (20, 10.5) and (20, 9.5), e = 0.7, no gravity; the balls are listed in the scene in
/// `order` (so numbered differently each time). Returns the mirror error of B against C
/// (position and velocity, m and m/s, the larger), A's sideways drift (speed and offset), B's
/// speed (zero if nothing collided), and the impulse the walls took.
fn strike_between(kind: EngineKind, order: [usize; 3]) -> (f64, f64, f64, f64) {
    let balls = [
        spec([18.0, 10.0], [5.0, 0.0], 1.0, 1.0),
        spec([20.0, 10.5], [0.0, 0.0], 1.0, 1.0),
        spec([20.0, 9.5], [0.0, 0.0], 1.0, 1.0),
    ];
    let listed: Vec<Spec> = order.iter().map(|&k| balls[k]).collect();
    let s = scene(40.0, 20.0, 1.0, 0.7, false, DEFAULT, &listed);
    let end = run(kind, &s, 0.5);
    let at = |k: usize| &end.balls[order.iter().position(|&o| o == k).unwrap()];
    let (a, b, c) = (at(0), at(1), at(2));
    let mirror = |p: DVec2| DVec2::new(p.x, 20.0 - p.y);
    let dx = (b.position - mirror(c.position)).length();
    let dv = (b.velocity - DVec2::new(c.velocity.x, -c.velocity.y)).length();
    (dx.max(dv), a.velocity.y.abs() + (a.position.y - 10.0).abs(), b.velocity.length(), end.walls)
}

/// Checks [`strike_between`] on each of `kinds` in three numberings: mirror error and A's
/// sideways drift within `bound`.
fn strikes(kinds: &[EngineKind], bound: fn(EngineKind) -> f64) {
    let _s = serial();
    let mut failures = Vec::new();
    for &kind in kinds {
        for order in [[0, 1, 2], [2, 0, 1], [1, 2, 0]] {
            let (mirror, sideways, speed, walls) = strike_between(kind, order);
            eprintln!(
                "{kind} order {order:?}: mirror off by {mirror:.2e}, A sideways {sideways:.2e}, B at {speed:.4} m/s"
            );
            check!(failures, walls == 0.0, "{kind} order {order:?}: a ball reached a wall");
            check!(failures, speed > 1.0, "{kind} order {order:?}: B was not struck (at {speed} m/s)");
            check!(failures, mirror <= bound(kind), "{kind} order {order:?}: mirror off by {mirror:e}");
            check!(failures, sideways <= bound(kind), "{kind} order {order:?}: A pushed sideways by {sideways:e}");
        }
    }
    none_failed(failures);
}

/// B and C leave as mirror images, A straight on, in every numbering. Measured: lockstep 0 (the
/// round's impulses are computed from the same velocities), A's drift 0; threaded 1.1e-14 to
/// 8.2e-14 (positions of ~20 m: 3.6e-15 is one rounding), A's drift 0; exact 0 and 0, B at 2.9445
/// m/s as in the other two (the two impacts of one instant are one round of simultaneous
/// impacts, `physics::solve_simultaneous`). Seen to fail with (γ), and on the exact engine with
/// its rounds off (`World::strike_simultaneous` returning false): it took the two impacts one
/// after the other, mirror off by 1.56 (m, m/s), A pushed sideways by 0.996, B at 3.68 or 2.12
/// m/s by the numbering.
#[test]
fn a_ball_striking_two_touching_balls_between_them_leaves_a_mirror_image() {
    strikes(&[EngineKind::Lockstep, EngineKind::Threaded, EngineKind::Exact], |kind| match kind {
        EngineKind::Threaded => 1e-12,
        _ => 1e-14,
    });
}

/// The rounds of sequential impacts, in one dimension, of balls of `masses` touching in a row
/// with `velocities` (along the row): each round strikes together every touching neighbour pair
/// that closes, with restitution `e` (impulses λ ≥ 0 with each struck pair leaving at ≥ −e times
/// its closing speed, complementary: projected Gauss–Seidel to convergence, which for these few
/// contacts is the round's unique solution), until none closes. Independent of the engines' code.
fn row_rounds(masses: &[f64], mut v: Vec<f64>, e: f64) -> Vec<f64> {
    for _ in 0..1000 {
        let closing: Vec<(usize, f64)> =
            (0..v.len() - 1).map(|k| (k, v[k + 1] - v[k])).filter(|&(_, vn)| vn < -1e-15).collect();
        if closing.is_empty() {
            return v;
        }
        let mut lambda = vec![0.0; closing.len()];
        for _ in 0..100_000 {
            let mut change = 0.0f64;
            for (c, &(k, vn0)) in closing.iter().enumerate() {
                let w = 1.0 / masses[k] + 1.0 / masses[k + 1];
                let vn = v[k + 1] - v[k];
                let new = (lambda[c] + (-e * vn0 - vn) / w).max(0.0);
                let dl = new - lambda[c];
                lambda[c] = new;
                v[k] -= dl / masses[k];
                v[k + 1] += dl / masses[k + 1];
                change = change.max(dl.abs());
            }
            if change < 1e-17 {
                break;
            }
        }
    }
    panic!("the rounds did not end");
}

/// A row of touching balls (1 m) at rest from x = 22 on height `y`, masses `row`, struck along
/// it by balls of `strikers` (mass, speed; the first from the left, the second, if any, from the
/// right), each touching its end of the row at t = 1 s (on the end of a 1 ms step), ball
/// restitution `e`, walls 1, gravity if `gravity`. Returns the run's end after 1.5 s (the balls
/// left to right).
fn struck_row(kind: EngineKind, e: f64, y: f64, gravity: bool, row: &[f64], strikers: &[(f64, f64)]) -> End {
    let (m, speed) = strikers[0];
    let mut balls = vec![spec([21.0 - speed, y], [speed, 0.0], m, 1.0)];
    for (k, &mass) in row.iter().enumerate() {
        balls.push(spec([22.0 + k as f64, y], [0.0, 0.0], mass, 1.0));
    }
    if let Some(&(m, speed)) = strikers.get(1) {
        balls.push(spec([22.0 + row.len() as f64 + speed, y], [-speed, 0.0], m, 1.0));
    }
    run(kind, &scene(48.0, 20.0, 1.0, e, gravity, DEFAULT, &balls), 1.5)
}

/// A row of `n` touching balls (1 kg, 1 m) at rest on y = 10, struck at once from both ends by
/// balls of 2 kg at ±`speed` m/s ([`struck_row`]), no gravity. Returns each ball's x-velocity
/// after 1.5 s, left to right.
fn row_struck_from_both_ends(kind: EngineKind, e: f64, n: usize, speed: f64) -> Vec<f64> {
    let end = struck_row(kind, e, 10.0, false, &vec![1.0; n], &[(2.0, speed), (2.0, speed)]);
    assert_eq!(end.walls, 0.0, "{kind} e {e} n {n}: a ball reached a wall");
    end.balls.iter().map(|b| b.velocity.x).collect()
}

/// Struck at once from both ends, the row comes out a mirror image (each ball's velocity the
/// negative of its mirror's), as the rounds of sequential impacts say ([`row_rounds`]: both
/// waves advance a ball per round and meet in the middle), with its momentum zero, at every e
/// from 0 to 1; the energy is kept at e = 1 and e = 0.99 is within a few percent of e = 1.
/// Rows of 5 (strikers at 3 m/s: they leave at ∓2.556 m/s at e = 1, ∓2.464 at e = 0.99) and 6
/// (at 2 m/s: ∓1.753). Measured at e = 0, 0.5, 0.99 and 1, off the rounds (m/s): lockstep
/// 6.1e-13 (at e = 0; 3.2e-14 above), threaded 3.3e-14, exact 4.1e-14 (row of 5) and, in the
/// row of 6 at e < 1, 9.4e-5 (its collapse model, see the bounds); a mirror to the bit but
/// lockstep at e ≤ 0.5 (3.2e-13) and exact's row of 6 at e = 0 (5.9e-8); energy at e = 1
/// within 2.1e-14. Seen to fail: lockstep's elastic
/// passes striking a fast pair whose ball a fast impulse of the same pass struck (the wave from
/// the end listed first went through the whole row of 5 in one pass: strikers at −2.654 and
/// 2.333 m/s); lockstep striking a pair short of touching by a rounding only in the next step
/// (row of 6: the two strikers met their ends a step apart, −2.220 and 1.333 m/s); the exact
/// engine with its cluster rounds off (`World::strike_free_cluster`): the impacts of one
/// instant went by ball index, strikers at −3.321 and 2.244 m/s (row of 5).
#[test]
fn a_row_struck_from_both_ends_at_once_leaves_a_mirror_image() {
    let _s = serial();
    let mut failures = Vec::new();
    for (n, speed) in [(5, 3.0), (6, 2.0)] {
        let mut masses = vec![2.0];
        masses.extend(vec![1.0; n]);
        masses.push(2.0);
        let mut start = vec![0.0; n + 2];
        (start[0], start[n + 1]) = (speed, -speed);
        for kind in [EngineKind::Lockstep, EngineKind::Threaded, EngineKind::Exact] {
            let mut striker = Vec::new();
            for e in [0.0, 0.5, 0.99, 1.0] {
                let want = row_rounds(&masses, start.clone(), e);
                let v = row_struck_from_both_ends(kind, e, n, speed);
                let off = v.iter().zip(&want).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                let mirror = (0..v.len()).map(|k| (v[k] + v[v.len() - 1 - k]).abs()).fold(0.0, f64::max);
                let momentum: f64 = v.iter().zip(&masses).map(|(u, m)| u * m).sum();
                let energy = |u: &[f64]| u.iter().zip(&masses).map(|(u, m)| 0.5 * m * u * u).sum::<f64>();
                let energy_change = energy(&v) / energy(&start) - 1.0;
                eprintln!(
                    "{kind} n {n} e {e}: {v:.4?} (rounds {want:.4?}): off {off:.1e}, mirror {mirror:.1e}, \
                     momentum {momentum:.1e}, energy {energy_change:.1e}"
                );
                // The exact engine's collapse model strikes the last slow impacts of an
                // inelastic row (closing below its collapse speed) with a softened restitution:
                // it leaves them creeping at up to 9.4e-5 m/s (row of 6, e = 0.5), off its mirror
                // by up to 5.9e-8 (e = 0).
                let (off_bound, mirror_bound) =
                    if kind == EngineKind::Exact && e < 1.0 { (2e-4, 2e-7) } else { (1e-12, 1e-12) };
                check!(
                    failures,
                    off <= off_bound,
                    "{kind} n {n} e {e}: off the rounds by {off:e} m/s: {v:?} against {want:?}"
                );
                check!(
                    failures,
                    mirror <= mirror_bound,
                    "{kind} n {n} e {e}: not a mirror image by {mirror:e} m/s: {v:?}"
                );
                check!(failures, momentum.abs() <= 1e-12, "{kind} n {n} e {e}: momentum {momentum:e} N·s");
                if e == 1.0 {
                    check!(failures, energy_change.abs() <= 1e-12, "{kind} n {n}: energy changed by {energy_change:e}");
                }
                striker.push(v[0]);
            }
            let (at_99, at_1) = (striker[2], striker[3]);
            let gap = (at_99 - at_1).abs() / speed;
            check!(
                failures,
                gap <= 0.05,
                "{kind} n {n}: the striker leaves at {at_99} m/s at e = 0.99, {at_1} at e = 1"
            );
        }
    }
    none_failed(failures);
}

/// A row lying on the floor, struck along it, is a cradle: the floor is frictionless and takes
/// no impulse along the row, so the row passes the impulse on as the rounds of sequential
/// impacts say ([`row_rounds`]) at every e from 0 to 1, on every engine, horizontal momentum
/// kept, the side walls untouched, the balls left on the floor. Rows of three 1 kg balls struck
/// by 1 kg at 3 m/s, of 1, 3 and 0.5 kg struck by 2 kg at 2 m/s, and of four 1 kg balls struck
/// from both ends at once by 2 kg at ±3 m/s (a mirror image). Measured at e = 0, 0.5, 0.99, 1,
/// off the rounds (m/s): at e = 1 at most 5.6e-16 on every engine; at e < 1 lockstep 1.3e-2,
/// threaded up to 2.6e-2, exact 7.8e-4 (see the bounds); momentum kept to 2.2e-15 N·s, no ball off the
/// floor faster than 2.1e-14 m/s. Seen to fail: the exact engine held a
/// ball at rest that touched another ball at rest immovable, as in a pile (the striker
/// rebounded at −e·v off the row, e = 1 included: horizontal momentum 3 → −3 N·s, the side
/// walls' gauges taking the difference).
#[test]
fn a_row_lying_on_the_floor_struck_along_it_is_a_cradle_on_every_engine() {
    let _s = serial();
    let mut failures = Vec::new();
    // (the row's masses, the strikers' masses and speeds)
    type Case<'a> = (&'a [f64], &'a [(f64, f64)]);
    let cases: [Case; 3] =
        [(&[1.0, 1.0, 1.0], &[(1.0, 3.0)]), (&[1.0, 3.0, 0.5], &[(2.0, 2.0)]), (&[1.0; 4], &[(2.0, 3.0), (2.0, 3.0)])];
    for (row, strikers) in cases {
        let mut masses = vec![strikers[0].0];
        masses.extend_from_slice(row);
        let mut start = vec![strikers[0].1];
        start.extend(vec![0.0; row.len()]);
        if let Some(&(m, speed)) = strikers.get(1) {
            masses.push(m);
            start.push(-speed);
        }
        let p0: f64 = start.iter().zip(&masses).map(|(u, m)| u * m).sum();
        for kind in [EngineKind::Lockstep, EngineKind::Threaded, EngineKind::Exact] {
            let mut striker = Vec::new();
            for e in [0.0, 0.5, 0.99, 1.0] {
                let want = row_rounds(&masses, start.clone(), e);
                let end = struck_row(kind, e, 0.5, true, row, strikers);
                let v: Vec<DVec2> = end.balls.iter().map(|b| b.velocity).collect();
                let gauges = end.gauges;
                let vx: Vec<f64> = v.iter().map(|u| u.x).collect();
                let off = vx.iter().zip(&want).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                let lifted = v.iter().map(|u| u.y.abs()).fold(0.0, f64::max);
                let momentum: f64 = vx.iter().zip(&masses).map(|(u, m)| u * m).sum::<f64>() - p0;
                let (sides, net) = (gauges.left + gauges.right, gauges.left - gauges.right);
                let mirror = if strikers.len() == 2 {
                    (0..vx.len()).map(|k| (vx[k] + vx[vx.len() - 1 - k]).abs()).fold(0.0, f64::max)
                } else {
                    0.0
                };
                eprintln!(
                    "{kind} {masses:?} e {e}: {vx:.4?} (rounds {want:.4?}): off {off:.1e}, mirror {mirror:.1e}, \
                     vy {lifted:.1e}, momentum {momentum:.1e}, side walls {sides:.1e} (net {net:.1e})"
                );
                // Off the rounds at e < 1: lockstep and threaded take the chain's slow end in
                // their resting phase (lockstep up to 1.3e-2 m/s, the row of three at e = 0.5;
                // threaded, where its spans fall deciding which impacts are slow, up to 2.6e-2 in
                // the row struck from both ends at e = 0.5, whose rounds end at a hundredth of
                // the strike speed); the exact engine, in its collapse model's softened
                // restitution (up to 7.8e-4, e = 0).
                let off_bound = match (kind, e < 1.0) {
                    (_, false) => 1e-12,
                    (EngineKind::Exact, true) => 1e-3,
                    (EngineKind::Threaded, true) => 3e-2,
                    _ => 1.5e-2,
                };
                check!(
                    failures,
                    off <= off_bound,
                    "{kind} {masses:?} e {e}: off the rounds by {off:e} m/s: {vx:?} against {want:?}"
                );
                check!(
                    failures,
                    momentum.abs() <= 1e-12,
                    "{kind} {masses:?} e {e}: momentum changed by {momentum:e} N·s"
                );
                // Lockstep's and the threaded monitor's resting passes at e < 1 go through the
                // row in list order: a mirror to 3.2e-6 m/s (exact to the bit elsewhere).
                let mirror_bound = if kind != EngineKind::Exact && e < 1.0 { 5e-6 } else { 0.0 };
                check!(
                    failures,
                    mirror <= mirror_bound,
                    "{kind} {masses:?} e {e}: not a mirror image by {mirror:e} m/s"
                );
                // The exact engine at e = 0, struck from both ends: the balls the two waves
                // squeeze between them at the end of the collapse come to rest where they are
                // (its wedge rule) and hand the momentum they had to the walls: 5.2e-2 N·s, the
                // two sides' shares cancelling. Nothing else touches a side wall.
                let sides_bound = if kind == EngineKind::Exact && e == 0.0 { 6e-2 } else { 0.0 };
                check!(failures, sides <= sides_bound, "{kind} {masses:?} e {e}: the side walls took {sides:e} N·s");
                check!(failures, net.abs() <= 1e-12, "{kind} {masses:?} e {e}: the side walls' net {net:e} N·s");
                check!(failures, lifted <= 1e-13, "{kind} {masses:?} e {e}: a ball left the floor at {lifted:e} m/s");
                striker.push(vx[0]);
            }
            let gap = (striker[2] - striker[3]).abs() / strikers[0].1;
            check!(
                failures,
                gap <= 0.05,
                "{kind} {masses:?}: the striker leaves at {} m/s at e = 0.99, {} at 1",
                striker[2],
                striker[3]
            );
        }
    }
    none_failed(failures);
}

/// A ball (1 kg, 1 m) falls along x = 20 at 2 m/s onto the top of a pyramid of three touching
/// balls at rest (1 kg, 1 m: two side by side at x = 19.5 and 20.5, one on top), no gravity,
/// meeting it at t = 1 s; the balls listed in `order`. Returns the velocities after 2 s in the
/// scene's order (bottom left, bottom right, top, striker).
fn pyramid_struck_on_top(kind: EngineKind, e: f64, order: [usize; 4]) -> Vec<DVec2> {
    let top = 5.0 + 0.75f64.sqrt();
    let balls = [
        spec([19.5, 5.0], [0.0, 0.0], 1.0, 1.0),
        spec([20.5, 5.0], [0.0, 0.0], 1.0, 1.0),
        spec([20.0, top], [0.0, 0.0], 1.0, 1.0),
        spec([20.0, top + 3.0], [0.0, -2.0], 1.0, 1.0),
    ];
    let listed: Vec<Spec> = order.iter().map(|&k| balls[k]).collect();
    let s = scene(40.0, 20.0, 1.0, e, false, DEFAULT, &listed);
    let end = run(kind, &s, 2.0);
    assert_eq!(end.walls, 0.0, "{kind} e {e}: a ball reached a wall");
    (0..4).map(|k| end.balls[order.iter().position(|&o| o == k).unwrap()].velocity).collect()
}

/// Struck on top, the pyramid's top ball strikes both bottom balls at once: they leave as mirror
/// images, the top ball and the striker on the axis, the same in every engine and numbering, at
/// e = 0.5, 0.99 and 1 (e = 1: bottom balls at (∓0.6928, −1.2) m/s, the striker back at 0.4).
/// Measured: lockstep and threaded a mirror image to the bit and within 7.3e-13 m/s of exact;
/// exact a mirror image to 1.4e-12, the same in every numbering to 1.4e-12. Seen to fail with lockstep's elastic passes looking for impacts struck at
/// once only in the pass after a wall bounce or a pair left waiting, not after any fast impulse:
/// at e = 1 the top ball's two impacts came before its own in the list and went one by one,
/// bottom balls at (−0.866, −1.5) and (0.433, −0.75), the top ball off the axis at 0.433 m/s.
#[test]
fn a_pyramid_struck_on_top_leaves_a_mirror_image() {
    let _s = serial();
    let mut failures = Vec::new();
    for e in [0.5, 0.99, 1.0] {
        let reference = pyramid_struck_on_top(EngineKind::Exact, e, [0, 1, 2, 3]);
        for kind in [EngineKind::Lockstep, EngineKind::Threaded, EngineKind::Exact] {
            // The exact engine's mirror is good to its event times' rounding.
            let bound = if kind == EngineKind::Exact { 1e-11 } else { 1e-12 };
            for order in [[0, 1, 2, 3], [3, 2, 1, 0], [2, 0, 3, 1]] {
                let v = pyramid_struck_on_top(kind, e, order);
                let mirror = (v[0] - DVec2::new(-v[1].x, v[1].y)).length().max(v[2].x.abs()).max(v[3].x.abs());
                let off = v.iter().zip(&reference).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
                eprintln!("{kind} e {e} order {order:?}: {v:.4?}: mirror {mirror:.1e}, off exact {off:.1e}");
                check!(failures, v[0].length() > 0.1, "{kind} e {e} order {order:?}: the bottom was not struck");
                check!(failures, mirror <= bound, "{kind} e {e} order {order:?}: not a mirror image by {mirror:e}");
                check!(failures, off <= bound, "{kind} e {e} order {order:?}: off the exact engine by {off:e}");
            }
        }
    }
    none_failed(failures);
}

/// The speed (m/s) each bottom ball of a frictionless pyramid leaves with: a ball of mass `top`
/// at rest on two of mass `bottom` (diameter `d`) that touch each other's sides at rest on a
/// frictionless floor, their centres at 60°. While the top ball presses them, the angle θ of
/// each line of centres (from the floor) says everything: the bottom balls at ±d·cos θ, the top
/// ball d·sin θ above them, and energy gives their speed as θ falls,
/// ṡ² = 2·M·g·d·u²·(u₀ − u) / (M·(1 − u²) + 2·m·u²), u = sin θ. The contacts push only, so
/// the bottom balls speed up until the push is zero, where ṡ is largest: they part there and
/// keep it.
fn pyramid_spread(top: f64, bottom: f64, d: f64) -> f64 {
    let u0 = 60f64.to_radians().sin();
    let speed2 = |u: f64| 2.0 * top * G * d * u * u * (u0 - u) / (top * (1.0 - u * u) + 2.0 * bottom * u * u);
    // Golden-section search for the largest ṡ² on (0, u₀): it rises from 0 and falls to 0 once.
    let (mut lo, mut hi) = (0.0, u0);
    let phi = (5f64.sqrt() - 1.0) / 2.0;
    while hi - lo > 1e-12 {
        let (a, b) = (hi - phi * (hi - lo), lo + phi * (hi - lo));
        if speed2(a) < speed2(b) {
            lo = a;
        } else {
            hi = b;
        }
    }
    speed2(0.5 * (lo + hi)).sqrt()
}

/// A pyramid of three balls on the floor is not held: frictionless contacts only push, so the
/// top ball pushes the two below apart and comes down between them. At e = 0, 0.5 and 1 and with
/// the top ball 1 and 3 kg (the bottom ones 1 kg, all 1 m), after 1.5 s: the bottom balls leave
/// at the speed of the constrained motion ([`pyramid_spread`]: 1.2024 m/s under a 1 kg top ball,
/// 1.4613 under 3 kg), mirror images of each other, the top ball between them, no horizontal
/// momentum. Between side walls that touch the bottom balls the same pyramid stands: the top
/// ball stays where it is, the bottom ones still.
///
/// Measured (the bounds in [`pyramid_bounds`]): off the constrained motion's speed by at most
/// 1.3e-3 (relative) at e < 1 on lockstep and threaded, 2.1e-3 at e = 1 on lockstep (3 kg top);
/// mirror images to 4.4e-16 m/s on lockstep at e < 1 and 5.1e-11 at e = 1 (its elastic passes
/// take the pressing contacts one by one in list order), where its few resting contacts are
/// solved exactly (`physics::islands_after_passes`; before, 3.8e-7 and 2.7e-7, the resting
/// passes taking the contacts in list order), and to 1.8e-15 on threaded, whose monitor solves them exactly
/// too (5.1e-7 before; 2.7e-6 with slow contacts of a resting cluster left to the passes alone);
/// momentum to 2.3e-15 N·s. Held: the top ball sinks at most 2.8e-5 m and the bottom balls move
/// at most 8.5e-3 m/s (lockstep, e = 1). Seen to fail: on the exact engine, whose free pyramid
/// stands (the speed off by 1, the ignored test below); on threaded with its few resting
/// contacts left to the passes (2.7e-6); and on lockstep so (3.8e-7).
fn pyramid(kind: EngineKind, failures: &mut Vec<String>) {
    let (d, h) = (1.0, 60f64.to_radians().sin());
    let (speed_bound, mirror_bound, sink_bound, still_bound) = pyramid_bounds(kind);
    for top in [1.0, 3.0] {
        let want = pyramid_spread(top, 1.0, d);
        for e in [0.0, 0.5, 1.0] {
            // Free: a field 20 m wide; held: the side walls touch the bottom balls.
            for (width, held) in [(20.0, false), (2.0, true)] {
                let c = 0.5 * width;
                let balls = [
                    spec([c - 0.5 * d, 0.5 * d], [0.0, 0.0], 1.0, d),
                    spec([c + 0.5 * d, 0.5 * d], [0.0, 0.0], 1.0, d),
                    spec([c, 0.5 * d + h * d], [0.0, 0.0], top, d),
                ];
                let end = run(kind, &scene(width, 10.0, 0.5, e, true, DEFAULT, &balls), 1.5);
                let b = &end.balls;
                let (left, right, apex) = (b[0].velocity, b[1].velocity, b[2].position);
                if held {
                    let sunk = (0.5 * d + h * d - apex.y).abs();
                    let moving = left.length().max(right.length());
                    check!(
                        failures,
                        sunk <= sink_bound,
                        "{kind} top {top} e {e}: the held pyramid's top sank {sunk:e} m"
                    );
                    check!(
                        failures,
                        moving <= still_bound,
                        "{kind} top {top} e {e}: the held pyramid's bottom balls move at {moving:e} m/s"
                    );
                    continue;
                }
                let off = (right.x - want).abs().max((-left.x - want).abs()) / want;
                let mirror = (left.x + right.x).abs().max((apex.x - c).abs());
                let momentum = left.x + right.x + top * b[2].velocity.x;
                check!(
                    failures,
                    off <= speed_bound,
                    "{kind} top {top} e {e}: bottom balls at {} and {} m/s, want ±{want} (off by {off:e})",
                    left.x,
                    right.x
                );
                check!(failures, mirror <= mirror_bound(e), "{kind} top {top} e {e}: not a mirror image by {mirror:e}");
                check!(
                    failures,
                    momentum.abs() <= 1e-12,
                    "{kind} top {top} e {e}: horizontal momentum {momentum:e} N·s"
                );
            }
        }
    }
}

/// Per engine: the bottom balls' speed off the constrained motion's (relative), the mirror
/// difference at restitution e (m/s, m), how far the held top ball may sink (m) and the held
/// bottom balls move (m/s). See [`pyramid`] for the figures measured.
fn pyramid_bounds(kind: EngineKind) -> (f64, fn(f64) -> f64, f64, f64) {
    match kind {
        EngineKind::Lockstep => (3e-3, |e| if e == 1.0 { 1e-10 } else { 1e-14 }, 1e-4, 1.2e-2),
        _ => (3e-3, |_| 1e-14, 1e-4, 1.2e-2),
    }
}

#[test]
fn a_pyramid_of_three_on_the_floor_spreads_on_lockstep_and_threaded() {
    let _one = serial();
    let mut failures = Vec::new();
    for kind in [EngineKind::Lockstep, EngineKind::Threaded] {
        pyramid(kind, &mut failures);
    }
    none_failed(failures);
}

#[test]
#[ignore = "exact engine: the free pyramid stands (bottom balls at rest, 0 m/s against ±1.2024): \
            its rest model holds a ball at rest when its supports surround its own weight, and a \
            ball at rest takes any push its supports hold, sideways too (docs/measurements.md, \
            session 24)"]
fn exact_pyramid_of_three_on_the_floor_spreads() {
    let mut failures = Vec::new();
    pyramid(EngineKind::Exact, &mut failures);
    none_failed(failures);
}
