//! A pile on the threaded runtime rests, as invariants of the settled table: its floor carries
//! its weight (the floor's gauge over a stretch of time against M·g·T), its overlaps stay within
//! the solver's slop, its kinetic energy stays within a bound of lockstep's on the same scene.
//! The quick test drops a small pile; the shipped 1,000-ball `pile` is `#[ignore]`d (run it with
//! `cargo test --release --test threaded_pile -- --ignored --nocapture`; about 30 s).

mod common;

use std::time::Duration;

use ballfield::Lockstep;
use ballfield::Scene;
use ballfield::physics::{Bodies, kinetic_energy};
use ballfield::runtime::{Runtime, RuntimeConfig};

static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

/// What a settled runtime shows at one instant (every ball at the horizon, every message
/// applied).
struct Settled {
    /// The instant, s on the runtime clock.
    time: f64,
    floor: f64,
    bodies: Bodies,
}

fn settled(rt: &Runtime) -> Settled {
    assert!(rt.settle(Duration::from_secs(20)), "the runtime did not settle: {:?}", rt.stats());
    let time = rt.snapshot().first().map_or(0.0, |r| r.time as f64 * 1e-9);
    Settled { time, floor: rt.wall_impulses().bottom, bodies: rt.bodies() }
}

/// The figures of one run: the pile left to settle for `settle` seconds of wall time, then
/// watched for `samples` stretches of `every`: the floor's impulse over the watch against M·g·T,
/// the largest overlap at its end, and the kinetic energy at the end of each stretch with the
/// runtime-clock instant it was read at (from the first read).
struct Figures {
    floor_ratio: f64,
    overlap: f64,
    /// `(s since the watch began, J)`.
    kinetic: Vec<(f64, f64)>,
    /// When the watch began, s on the runtime clock (the scene's time).
    began: f64,
}

fn run(scene: &Scene, settle: Duration, every: Duration, samples: usize) -> Figures {
    let rt = Runtime::start(scene, RuntimeConfig::default()).unwrap();
    std::thread::sleep(settle);
    let a = settled(&rt);
    let mut kinetic = Vec::new();
    let mut b = None;
    for _ in 0..samples {
        rt.resume();
        std::thread::sleep(every);
        let s = settled(&rt);
        kinetic.push((s.time - a.time, kinetic_energy(&s.bodies)));
        b = Some(s);
    }
    let b = b.expect("at least one sample");
    let stats = rt.stats();
    rt.shutdown();
    let weight: f64 = b.bodies.mass.iter().sum::<f64>() * 9.81;
    let figures = Figures {
        floor_ratio: (b.floor - a.floor) / (weight * (b.time - a.time)),
        overlap: common::largest_overlap(&b.bodies),
        kinetic,
        began: a.time,
    };
    eprintln!(
        "{}: from {:.3} s, floor {:.5} of M·g·T over {:.3} s, largest overlap {:.4} of a diameter, kinetic {} J; \
         passes {} ({:.0}/s, {:.3} ms each), unconverged {}, clock dropped {:.3} s, slowest ball {:.0}/s",
        scene.name,
        figures.began,
        figures.floor_ratio,
        b.time - a.time,
        figures.overlap,
        sampled(&figures.kinetic),
        stats.monitor_passes,
        stats.monitor_passes_per_second,
        stats.monitor_pass_seconds * 1e3,
        stats.solves_unconverged,
        stats.clock_dropped_seconds,
        stats.ball_rate_min,
    );
    figures
}

fn sampled(kinetic: &[(f64, f64)]) -> String {
    kinetic.iter().map(|(t, k)| format!("{t:.2} s: {k:.1e}")).collect::<Vec<_>>().join(", ")
}

/// Lockstep's kinetic energy on `scene` at each of `instants` (s of the scene's time, rising).
fn lockstep_kinetic(scene: &Scene, instants: &[f64]) -> Vec<f64> {
    let mut l = Lockstep::new(scene);
    let mut steps = 0;
    instants
        .iter()
        .map(|&t| {
            let to = (t / l.dt()).round() as u64;
            l.run(to.saturating_sub(steps));
            steps = steps.max(to);
            kinetic_energy(l.bodies())
        })
        .collect()
}

fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

/// The small pile settled by lockstep for 15 s, then run on the threaded runtime from that state
/// (its warm start begins cold, and the pile takes about a second to settle into the monitor's
/// spans): after 1.5 s it is watched for six stretches of half a second. Its floor takes the
/// pile's weight within 5 % (the bound), no two balls overlap by more than 2 % of a
/// diameter, its median kinetic energy over the six reads is within 8 times that of lockstep
/// started from the same state (cold too) at the same instants, and no read shows it moving at
/// 0.5 mm/s on average (a player sees 5 cm/s: half a pixel a second at 10 px/m).
///
/// Measured (twelve runs, an otherwise idle 2-core machine): floor 0.99998 to 1.00001 of M·g·T,
/// largest overlap 0.46 % to 0.48 % (the solver's slop is 0.5 %), median kinetic energy 1.2e-7 to
/// 4.9e-7 J against lockstep's 1.0e-7 J (1.2 to 4.9 times: a few times, as the issue asks, the
/// spread being the runtime's timing; six more runs once the balls' steps were on the monitor's
/// grid: 1.2 to 4.1 times), the largest read 7.7e-7 J (0.1 mm/s). Seen to fail with
/// spans that follow the monitor's wake-ups and a resting drift of one sub-step for a late span
/// (the build before this test): reads of 1.2e-3 to 2.2e-2 J, where a long span sank the pile and
/// a short one after it struck it whole; and with the responses in flight left out of the state a
/// pass solves from: floor 1,385 times the weight, overlaps of 97 %, 1e7 J.
#[test]
fn a_settled_pile_stays_at_rest_and_its_floor_carries_it() {
    let _serial = serial();
    let (scene, _) = common::settled_small_pile();
    let f = run(&scene, Duration::from_millis(1500), Duration::from_millis(500), 6);
    let instants: Vec<f64> = f.kinetic.iter().map(|(t, _)| f.began + t).collect();
    let reference = lockstep_kinetic(&scene, &instants);
    let threaded: Vec<f64> = f.kinetic.iter().map(|(_, k)| *k).collect();
    let bodies = common::small_pile().balls.len();
    let bound = 0.5 * bodies as f64 * 5e-4 * 5e-4;
    eprintln!(
        "lockstep from the same state at the same instants: {:?} J; medians {:.2e} / {:.2e} J",
        reference.iter().map(|k| format!("{k:.1e}")).collect::<Vec<_>>(),
        median(&threaded),
        median(&reference)
    );
    assert!((f.floor_ratio - 1.0).abs() < 0.05, "the floor took {} of the weight", f.floor_ratio);
    assert!(f.overlap < 0.02, "largest overlap {} of a diameter", f.overlap);
    assert!(
        median(&threaded) < 8.0 * median(&reference),
        "median kinetic {} J against lockstep's {} J",
        median(&threaded),
        median(&reference)
    );
    assert!(threaded.iter().all(|&k| k < bound), "a read over {bound} J: {}", sampled(&f.kinetic));
}

/// The small pile, dropped on the threaded runtime from 4 to 20 m, left for 8.5 s and watched
/// for ten stretches of half a second (to about 13.5 s): its floor takes its weight within 5 %,
/// no two balls overlap by more than 2 % of a diameter, and it comes to rest: at least one of
/// the six reads has its kinetic energy below that of every ball at 1 mm/s (a player sees
/// 5 cm/s). Lockstep's figures on the scene, its mirror image and with its balls renumbered are
/// printed beside it.
///
/// Why no read at a fixed instant is the bound: the balls are frictionless, and a frictionless
/// heap has no angle of repose, so a settled pile can still give way and slide flatter. Lockstep
/// does so too: over 9–11.5 s, 3 of 40 seeds of this scene (25, 36 and the shipped 3) read above
/// the bound once or more, seed 25 climbing from 4e-8 J at 9 s to 0.14 J at 11 s as its heap
/// slid, 1.5e-2 J still at 11.5 s. On the threaded runtime (30 runs, an idle 2-core machine) 6
/// had a read above it, the highest 2.8e-2 J, and every run had reads below it: the lowest read of
/// a run was 2e-12 to 2.5e-6 J. Two of about twenty CI runs failed the earlier bound on the last
/// read alone (9.2e-4 J at 11.5 s, decaying), and one (2026-12-02) had all six reads of a watch
/// to 11.5 s above this one (lowest 2.9e-4 J: its heap slid, 4.9e-2 J at 11 s, 3.0e-4 J at
/// 11.5 s, decaying), so the watch goes on to 13.5 s. The settled pile's test above holds the
/// threaded pile's steady state to lockstep's.
///
/// Seen to fail with the responses in flight left out of the state a pass solves from: floor
/// 1,196 times the weight, overlaps of 94 %, 4e7 J.
#[test]
fn a_dropped_pile_comes_to_rest_and_its_floor_carries_it() {
    let _serial = serial();
    let scene = common::small_pile();
    let f = run(&scene, Duration::from_millis(8500), Duration::from_millis(500), 10);
    let &(t, _) = f.kinetic.last().unwrap();
    let end = f.began + t;
    let lowest = f.kinetic.iter().map(|&(_, k)| k).fold(f64::INFINITY, f64::min);
    let mut mirrored = scene.clone();
    for b in &mut mirrored.balls {
        b.position.x = mirrored.field.width - b.position.x;
        b.velocity.x = -b.velocity.x;
    }
    let mut renumbered = scene.clone();
    renumbered.balls.reverse();
    let reference: Vec<f64> = [&scene, &mirrored, &renumbered].iter().map(|s| lockstep_kinetic(s, &[end])[0]).collect();
    let visible = 0.5 * scene.balls.len() as f64 * 1e-3 * 1e-3;
    eprintln!(
        "lockstep at {end:.2} s (scene, mirrored, renumbered): {:?} J",
        reference.iter().map(|k| format!("{k:.1e}")).collect::<Vec<_>>()
    );
    assert!((f.floor_ratio - 1.0).abs() < 0.05, "the floor took {} of the weight", f.floor_ratio);
    assert!(f.overlap < 0.02, "largest overlap {} of a diameter", f.overlap);
    assert!(lowest < visible, "no read below {visible} J: {}", sampled(&f.kinetic));
}

/// The small pile with collisions at e = 1 (its walls at 0.8 and its drag take the energy),
/// dropped on the threaded runtime and watched as above, from 8.5 s for ten stretches of half a
/// second: its floor takes its weight within 5 %, no two balls overlap by more than 2 % of a
/// diameter, and it is at rest by the end: each of the last five reads (11–13.5 s) below every
/// ball at 1 mm/s. Lockstep's kinetic energy at the end is printed beside it. Measured (three
/// runs): asleep, 0 J, at every read from 9 s; floor 1.00000 of M·g·T; overlap 0.19 %; lockstep
/// 2.5e-9–2.7e-9 J at 13.5 s. Seen to fail on a build of f67401c (before sessions 30 and 31,
/// run by mistake through a target directory two checkouts shared): reads of 2.3e-2–4.5 J to
/// 13.5 s in two runs (lockstep 0.15 J at 13.5 s), the e = 1 heap jiggling on. With only the
/// contact solver's rule of 2026-12-07 reverted (`Tolerances::elastic`) it passes: the monitor
/// already took these slow e = 1 contacts as resting (0 J, lockstep 5.1e-7 J).
#[test]
fn a_dropped_elastic_pile_on_walls_that_take_energy_comes_to_rest() {
    let _serial = serial();
    let source = common::SMALL_PILE.replace("collisions = { restitution = 0.8 }", "collisions = { restitution = 1.0 }");
    assert_ne!(source, common::SMALL_PILE, "the small pile's collisions are at e = 0.8");
    let scene = Scene::from_toml_str(&source, &ballfield::scene::Origin("elastic small pile".into())).unwrap();
    let f = run(&scene, Duration::from_millis(8500), Duration::from_millis(500), 10);
    let &(t, _) = f.kinetic.last().unwrap();
    let last = f.kinetic[f.kinetic.len() - 5..].iter().map(|&(_, k)| k).fold(0.0, f64::max);
    let visible = 0.5 * scene.balls.len() as f64 * 1e-3 * 1e-3;
    eprintln!("lockstep at {:.2} s: {:.1e} J", f.began + t, lockstep_kinetic(&scene, &[f.began + t])[0]);
    assert!((f.floor_ratio - 1.0).abs() < 0.05, "the floor took {} of the weight", f.floor_ratio);
    assert!(f.overlap < 0.02, "largest overlap {} of a diameter", f.overlap);
    assert!(last < visible, "a read of the last five over {visible} J: {}", sampled(&f.kinetic));
}

/// The shipped `pile` (1,000 balls, e = 0.8) dropped on the threaded runtime, settled for 20 s
/// and watched for 5 s: floor within 5 %, overlaps within 2 %, moving at less than 2 mm/s on
/// average. Heavy (half a minute of both cores, and it needs them: ball threads take only the CPU
/// nothing else wants), so ignored in the suite; `scripts/threaded-contacts.sh pile` measures the
/// same with the headless report. Measured (one run, an idle machine): floor 1.00001, overlap
/// 0.50 %, kinetic 1.3e-6 to 4.0e-5 J over the five reads (1.1e-5 J at 25 s; lockstep 1.4e-6 J).
#[test]
#[ignore]
fn the_shipped_pile_comes_to_rest_and_its_floor_carries_it() {
    let _serial = serial();
    let scene = ballfield::scenes::builtin("pile").unwrap().unwrap();
    let f = run(&scene, Duration::from_secs(20), Duration::from_secs(1), 5);
    let &(t, kinetic) = f.kinetic.last().unwrap();
    let reference = lockstep_kinetic(&scene, &[f.began + t])[0];
    eprintln!("lockstep's kinetic energy at the same time: {reference:.3e} J");
    let bound = 0.5 * 1000.0 * 2e-3 * 2e-3;
    assert!((f.floor_ratio - 1.0).abs() < 0.05, "the floor took {} of the weight", f.floor_ratio);
    assert!(f.overlap < 0.02, "largest overlap {} of a diameter", f.overlap);
    assert!(kinetic < bound, "kinetic {kinetic} J");
}
