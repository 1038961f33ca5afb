//! Sleeping islands on the threaded runtime (`src/engine/runtime/sleep.rs`): a pile at rest falls
//! asleep, its floor still carries its weight and it does not move; a ball dropped on it wakes it,
//! and it comes to rest and sleeps again with its overlaps kept; woken with nothing striking it,
//! it goes on resting where it slept (its contacts keep their warm start).

mod common;

use std::sync::Mutex;
use std::time::{Duration, Instant};

use ballfield::physics::{Bodies, kinetic_energy};
use ballfield::runtime::{Runtime, RuntimeConfig};
use glam::DVec2;

/// The runtimes of this file share the machine's cores: one at a time.
fn serial() -> std::sync::MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    LOCK.lock().unwrap_or_else(|e| e.into_inner())
}

/// Waits (up to `limit` of wall time) until every ball sleeps.
fn all_asleep(rt: &Runtime, limit: Duration) -> bool {
    let t0 = Instant::now();
    while t0.elapsed() < limit {
        if rt.stats().balls_asleep as usize == rt.ball_count() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    false
}

/// The floor's impulse over a watch of `wall` against M·g·T, with the bodies at its end.
fn watch(rt: &Runtime, wall: Duration) -> (f64, Bodies) {
    assert!(rt.settle(Duration::from_secs(20)));
    let t = |rt: &Runtime| rt.snapshot().first().map_or(0.0, |r| r.time as f64 * 1e-9);
    let (t0, f0) = (t(rt), rt.wall_impulses().bottom);
    rt.resume();
    std::thread::sleep(wall);
    assert!(rt.settle(Duration::from_secs(20)));
    let (t1, f1, bodies) = (t(rt), rt.wall_impulses().bottom, rt.bodies());
    rt.resume();
    let weight: f64 = bodies.mass.iter().sum::<f64>() * 9.81;
    ((f1 - f0) / (weight * (t1 - t0)), bodies)
}

/// The settled small pile (150 balls, e = 0.5 on lockstep for 15 s) on the threaded runtime:
/// every ball sleeps within 10 s; asleep, its floor carries M·g·T within 0.2 % and its kinetic
/// energy is zero; a ball dropped from 3 m above its top wakes it, and it sleeps again within
/// 10 s, its floor within 0.4 % (see the check) and no overlap above 2 % of a diameter. (The watch's clock is a
/// ball's record, the gauge the monitor's: under load they differ by a pass or so in 0.5 s.)
///
/// Measured (2026-12-05): asleep, the floor 1.000065 of M·g·T, kinetic 0 J; asleep again after
/// the landing, 1.000000 (1.00077 with another test binary running beside it), largest overlap
/// 0.36 %, 150 balls woken. (2026-12-02: 0.99991 and 1.00011. Once every ball near a wall had its wall contact in every span,
/// the averages of the balls' wall loads over their quiet stretches came to 0.9975 after the
/// landing, until an island's walls were made to hold its weight exactly:
/// `physics::held_wall_forces`.) Seen to fail with the sleeping islands' walls left off the
/// gauge: "asleep, the floor took 0 of the weight"; with the broad phase's awake–asleep pairs
/// waking nothing (`monitor.rs`, the `to_wake` pushes left out): "the landing woke nothing";
/// and with the measured averages put to sleep as they are: 0.9975.
#[test]
fn a_pile_sleeps_carries_its_weight_and_wakes_when_a_ball_lands_on_it() {
    let _s = serial();
    let (scene, _) = common::settled_small_pile();
    let rt = Runtime::start(&scene, RuntimeConfig::default()).unwrap();
    assert!(all_asleep(&rt, Duration::from_secs(10)), "the pile did not fall asleep: {:?}", rt.stats());
    let (floor, bodies) = watch(&rt, Duration::from_millis(500));
    let kinetic = kinetic_energy(&bodies);
    eprintln!(
        "asleep: floor {floor:.6} of M·g·T, kinetic {kinetic:e} J, overlap {:.4}",
        common::largest_overlap(&bodies)
    );
    assert!((floor - 1.0).abs() < 2e-3, "asleep, the floor took {floor} of the weight");
    assert_eq!(kinetic, 0.0);
    // A ball dropped on the pile's top.
    let top = (0..bodies.len()).max_by(|&a, &b| bodies.position[a].y.total_cmp(&bodies.position[b].y)).unwrap();
    let mut ball = bodies.get(top);
    ball.position += DVec2::new(0.0, 3.0);
    ball.velocity = DVec2::ZERO;
    let woken_before = rt.stats().balls_woken;
    rt.add_ball(ball).unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    let stats = rt.stats();
    assert!(stats.balls_woken > woken_before, "the landing woke nothing: {stats:?}");
    assert!(all_asleep(&rt, Duration::from_secs(10)), "the pile did not sleep again: {:?}", rt.stats());
    let (floor, bodies) = watch(&rt, Duration::from_millis(500));
    let overlap = common::largest_overlap(&bodies);
    let stats = rt.stats();
    eprintln!("asleep again: floor {floor:.6} of M·g·T, overlap {overlap:.4}; {stats:?}");
    rt.shutdown();
    // Some runs sleep again in an arrangement whose floor reads 1.0021–1.0022 of the weight (a
    // CI run under load, and 1 run in 7 here, with 0.5 s and with 2 s watches alike, so not the
    // clocks' pass of difference); the rest read 1.000000. The issue asks for 5 %; why that
    // arrangement carries 0.2 % more is not found yet.
    assert!((floor - 1.0).abs() < 4e-3, "asleep again, the floor took {floor} of the weight");
    assert!(overlap < 0.02, "largest overlap {overlap} of a diameter");
    assert_eq!(stats.messages_dropped, 0);
}

/// The settled small pile asleep, woken by a change no contact notices (its top ball's mass
/// times 1 + 1e-9): read every 10 ms for 1 s, the median ball moves at most 20 µm from where it
/// slept and none more than 1 mm; the pile sleeps again. (The median, not the largest: a ball
/// that crept just under the sleep speed goes on creeping once woken, up to 1e-4 m in a second.
/// Not the kinetic energy as the records show it: an awake ball resting in a pile falls freely
/// between the monitor's responses, up to g times a span, 1 cm/s, which 150 balls make ~7e-3 J at
/// any instant.)
///
/// Measured (2026-12-03): the median ball's largest displacement 2.5e-6 to 3.4e-6 m, the largest
/// 9.8e-6 to 1.0e-4 m, asleep again 0.501–0.510 s after the wake (`TIME_TO_SLEEP` is 0.5 s).
/// Before the islands kept their contacts' warm start (seen to fail so: `ContactPass::run` not
/// handing the woken islands' warm start to the solver), the woken pile's resting solve started
/// from nothing and the pile sagged: the median ball 7.7e-5 to 9.1e-5 m, the largest 3.7e-4 to
/// 8.8e-4 m, asleep again after 0.68–0.70 s.
#[test]
fn a_pile_woken_with_nothing_striking_it_stays_where_it_slept() {
    let _s = serial();
    let (scene, _) = common::settled_small_pile();
    let rt = Runtime::start(&scene, RuntimeConfig::default()).unwrap();
    assert!(all_asleep(&rt, Duration::from_secs(10)), "the pile did not fall asleep: {:?}", rt.stats());
    std::thread::sleep(Duration::from_millis(200));
    let slept = rt.snapshot();
    let top = slept.iter().max_by(|a, b| a.ball.position.y.total_cmp(&b.ball.position.y)).unwrap();
    let woken_before = rt.stats().balls_woken;
    rt.set_mass(top.ball.id, top.ball.mass * (1.0 + 1e-9)).unwrap();
    // Each ball's largest displacement from where it slept.
    let mut moved = vec![0.0f64; slept.len()];
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_secs(1) {
        std::thread::sleep(Duration::from_millis(10));
        for r in &rt.snapshot() {
            let k = slept.iter().position(|s| s.ball.id == r.ball.id).expect("every ball is still on the field");
            moved[k] = moved[k].max(r.ball.position.distance(slept[k].ball.position));
        }
    }
    moved.sort_by(f64::total_cmp);
    let (median, largest) = (moved[moved.len() / 2], moved[moved.len() - 1]);
    let woken = rt.stats().balls_woken - woken_before;
    let again = all_asleep(&rt, Duration::from_secs(10));
    let stats = rt.stats();
    rt.shutdown();
    eprintln!("woken {woken}: the median ball moved {median:e} m, the farthest {largest:e} m; {stats:?}");
    assert_eq!(woken as usize, slept.len(), "the mass change woke {woken} of {} balls", slept.len());
    assert!(median < 2e-5, "the median ball moved {median} m from where it slept");
    assert!(largest < 1e-3, "a ball moved {largest} m from where it slept");
    assert!(again, "the pile did not sleep again: {stats:?}");
}

/// Two balls on the floor 10 µm apart (they never touch: two islands; within a span's reach of
/// each other while an awake ball falls between the monitor's responses), the second dropped from
/// 1 cm so that it comes to rest about 45 ms after the first: both fall asleep and stay asleep.
/// A sleeping ball is woken by an awake ball that may touch it within a span (a candidate pair of
/// the broad phase), so such islands sleep together, as one, when all their balls are quiet.
///
/// Measured (2026-12-07, three runs): both asleep, 2 balls put to sleep and none woken. Seen to
/// fail with islands joined by touching contacts alone: each ball fell asleep while the other was
/// not yet due and was woken by it, again and again (19 put to sleep and 19 woken in 5 s, none
/// asleep at the end; the settled 150-ball pile of the tests above: none asleep after 10 s).
#[test]
fn two_quiet_islands_a_hair_apart_sleep_together_and_stay_asleep() {
    let _s = serial();
    let source = "name = \"two islands\"\n[field]\nwidth = 10.0\nheight = 10.0\nrestitution = 0.5\n\
                  [simulation]\ndt = 0.001\n[effects]\ncollisions = { restitution = 0.5 }\n\
                  gravity = { g = [0.0, -9.81] }\n\
                  [[balls]]\nposition = [4.0, 0.5]\nvelocity = [0.0, 0.0]\nmass = 1.0\ndiameter = 1.0\n\
                  [[balls]]\nposition = [5.00001, 0.51]\nvelocity = [0.0, 0.0]\nmass = 1.0\ndiameter = 1.0\n";
    let scene = ballfield::Scene::from_toml_str(source, &ballfield::scene::Origin("test".into())).unwrap();
    let rt = Runtime::start(&scene, RuntimeConfig::default()).unwrap();
    let asleep = all_asleep(&rt, Duration::from_secs(3));
    std::thread::sleep(Duration::from_millis(2000));
    let stats = rt.stats();
    rt.shutdown();
    eprintln!("asleep {}: put to sleep {}, woken {}", stats.balls_asleep, stats.balls_slept, stats.balls_woken);
    assert!(asleep, "the two balls did not fall asleep: {stats:?}");
    assert_eq!(stats.balls_asleep, 2, "{stats:?}");
    assert_eq!(stats.balls_woken, 0, "quiet balls woke each other: {stats:?}");
}
