//! The threaded runtime: invariants, not exact bits. Every ball on its own thread, a lock-free
//! table, a collision monitor sending impulses as messages.

mod common;

use std::sync::Arc;
use std::time::{Duration, Instant};

use ballfield::EngineError;
use ballfield::Scene;
use ballfield::physics::{Ball, BallId, BallKind, Field, measure};
use ballfield::runtime::{Runtime, RuntimeConfig, momentum_of, wait_until};
use ballfield::scene::Origin;
use ballfield::scenes;
use glam::DVec2;

/// The tests here measure a machine's worth of threads; run them one at a time so that one test's
/// thousand threads do not starve another's (cargo runs the tests of a file in parallel).
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

fn scene(text: &str) -> Scene {
    Scene::from_toml_str(text, &Origin("test".into())).unwrap()
}

/// Pauses the runtime and waits until every contact message sent has been applied, so that the
/// table is one consistent instant.
fn settle(rt: &Runtime) {
    rt.pause();
    let ok = wait_until(Duration::from_secs(5), || {
        let s = rt.stats();
        s.impulses_sent == s.impulses_applied
    });
    assert!(ok, "messages still in flight: {:?}", rt.stats());
    std::thread::sleep(Duration::from_millis(5));
}

fn check_inside(field: &Field, balls: &[Ball]) {
    for b in balls {
        assert!(b.is_finite(), "non-finite ball {b:?}");
        assert!(field.contains(b.position.x, b.position.y, b.radius(), 1e-9), "ball outside the field: {b:?}");
    }
}

/// A gas with no gravity and no drag, for 5 s of wall time.
///
/// Momentum: impulses are sent as equal and opposite Δv, so however late they are applied they
/// cancel; shifts move no momentum. The only other change is a wall bounce, whose impulse each ball
/// records. So p_end − p_start equals the walls' net impulse to rounding (bound 1e-9 of the total
/// wall impulse).
///
/// Energy: an e = 1 impulse keeps kinetic energy exactly when applied to the velocities it was
/// computed from. In vacuum a ball's velocity changes between the monitor's snapshot and the
/// message's arrival only if it bounces off a wall in that window (about a millisecond); then the
/// impulse lands on a reflected velocity and energy changes by about J·Δv_wall. Such coincidences
/// are rare (a few per second here) and of either sign, so the drift is a small random walk. The
/// bound, 2 % over 5 s, allows a hundred such events of the typical size (J·v/E ≈ 1/N ≈ 2e-4
/// each... with margin for a loaded CI machine where the window is longer).
#[test]
fn gas_keeps_momentum_through_walls_and_energy_within_bounds() {
    let _serial = serial();
    let gas = scenes::builtin("gas").unwrap().unwrap();
    // The start is the scene itself: the balls begin moving (and may hit a wall) while the
    // others' threads are still being spawned.
    let start_bodies = ballfield::physics::Bodies::from_balls(&gas.balls);
    let start_p = ballfield::physics::momentum(&start_bodies);
    let start = measure(&start_bodies, &gas.field, &gas.effects, Default::default());
    let rt = Runtime::start(&gas, RuntimeConfig::default()).unwrap();
    std::thread::sleep(Duration::from_secs(5));
    settle(&rt);
    let records = rt.snapshot();
    let balls: Vec<Ball> = records.iter().map(|r| r.ball).collect();
    assert_eq!(balls.len(), 500);
    check_inside(&gas.field, &balls);
    let walls = rt.wall_impulses();
    let dp = momentum_of(&records) - start_p;
    let given = walls.momentum_given();
    assert!(walls.total() > 0.0);
    assert!((dp - given).length() <= 1e-9 * walls.total(), "dp {dp} but the walls gave {given}");
    let end = measure(&rt.bodies(), &gas.field, &gas.effects, walls);
    let drift = (end.total - start.total).abs() / start.total;
    let stats = rt.stats();
    eprintln!("gas: energy drift {drift:e}, {stats:?}");
    assert!(drift < 0.02, "energy drift {drift}");
    assert_eq!(stats.messages_dropped, 0);
    assert_eq!(stats.threads_panicked, 0);
    assert!(stats.impulses_sent > 100, "the gas collided");
    assert_eq!(stats.impulses_sent, stats.impulses_applied);
    let report = rt.shutdown();
    assert_eq!(report.joined, 500);
}

#[test]
fn balls_under_gravity_and_drag_stay_finite_and_inside() {
    let _serial = serial();
    let s = scenes::builtin("default").unwrap().unwrap();
    let rt = Runtime::start(&s, RuntimeConfig::default()).unwrap();
    std::thread::sleep(Duration::from_secs(2));
    settle(&rt);
    let balls: Vec<Ball> = rt.snapshot().iter().map(|r| r.ball).collect();
    assert_eq!(balls.len(), s.balls.len());
    check_inside(&s.field, &balls);
    // Drag and an inelastic floor take energy out; nothing may put it in.
    let start = measure(&ballfield::physics::Bodies::from_balls(&s.balls), &s.field, &s.effects, Default::default());
    let end = measure(&rt.bodies(), &s.field, &s.effects, Default::default());
    assert!(end.total <= start.total * 1.001, "energy rose from {} to {}", start.total, end.total);
}

#[test]
fn the_pull_moves_the_key_ball_its_way() {
    let _serial = serial();
    let s = scene("name = \"pull\"\n[key-ball]\nposition = [35.0, 25.0]\nmass = 2.0\ndiameter = 1.0\npull = 100.0\n");
    let rt = Runtime::start(&s, RuntimeConfig::default()).unwrap();
    rt.set_pull(DVec2::new(-4.0, 3.0));
    std::thread::sleep(Duration::from_millis(500));
    rt.set_pull(DVec2::ZERO);
    settle(&rt);
    let key = rt.snapshot()[0].ball;
    assert_eq!(key.kind, BallKind::Key);
    let moved = key.position - DVec2::new(35.0, 25.0);
    // a = F/m = 2.5 m/s², along (−4, 3)/5: after ~0.5 s about 0.3 m and 1.25 m/s.
    assert!(moved.x < -0.05 && moved.y > 0.03, "moved {moved}");
    let dir = key.velocity.normalize();
    assert!((dir - DVec2::new(-0.8, 0.6)).length() < 1e-6, "velocity {0} is along the pull", key.velocity);
}

/// Thousands of adds and removes from several threads at once, while the balls run: at the end
/// exactly the balls that should be there are there, each with one live thread, and shutdown
/// joins them all.
#[test]
fn add_remove_storm_leaves_exactly_the_expected_balls() {
    let _serial = serial();
    let s = scene("name = \"storm\"\n[simulation]\nmax-balls = 600\n[effects]\ncollisions = {}\n");
    let rt = Arc::new(Runtime::start(&s, RuntimeConfig { max_balls: 600, ..RuntimeConfig::default() }).unwrap());
    let workers: Vec<_> = (0..4)
        .map(|w| {
            let rt = rt.clone();
            std::thread::spawn(move || {
                let mut mine: Vec<BallId> = Vec::new();
                let mut x: u64 = 12345 + w;
                for op in 0..1000 {
                    x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    let add = mine.len() < 5 || !(x >> 33).is_multiple_of(3);
                    if add {
                        let p =
                            DVec2::new(5.0 + ((x >> 20) % 600) as f64 / 10.0, 5.0 + ((x >> 40) % 400) as f64 / 10.0);
                        let ball = Ball {
                            id: BallId(0),
                            kind: BallKind::Ball,
                            position: p,
                            velocity: DVec2::new(1.0, 0.5),
                            mass: 1.0,
                            diameter: 0.5,
                        };
                        match rt.add_ball(ball) {
                            Ok(id) => mine.push(id),
                            Err(EngineError::TooManyBalls { .. }) => {}
                            Err(e) => panic!("op {op}: {e}"),
                        }
                    } else {
                        let k = (x >> 13) as usize % mine.len();
                        rt.remove_ball(mine.swap_remove(k)).unwrap();
                    }
                }
                mine
            })
        })
        .collect();
    let mut expected: Vec<BallId> = workers.into_iter().flat_map(|w| w.join().unwrap()).collect();
    expected.sort();
    let mut ids = rt.ball_ids();
    ids.sort();
    assert_eq!(ids, expected, "exactly the balls added and not removed");
    assert_eq!(rt.live_threads(), expected.len());
    let mut in_table: Vec<BallId> = rt.snapshot().iter().map(|r| r.ball.id).collect();
    in_table.sort();
    assert_eq!(in_table, expected, "the table holds exactly the live balls");
    let stats = rt.stats();
    assert_eq!(stats.threads_panicked, 0);
    let report = rt.shutdown();
    assert_eq!(report.joined, expected.len());
    assert_eq!(rt.ball_count(), 0);
    assert!(rt.snapshot().is_empty());
}

#[test]
fn the_ball_limit_is_an_error_not_a_crash() {
    let _serial = serial();
    let s = scene("name = \"limit\"\n[simulation]\nmax-balls = 3\n");
    let rt = Runtime::start(&s, RuntimeConfig { max_balls: 3, ..RuntimeConfig::default() }).unwrap();
    let at = |k: u32| Ball {
        id: BallId(0),
        kind: BallKind::Ball,
        position: DVec2::new(5.0 + 5.0 * k as f64, 10.0),
        velocity: DVec2::ZERO,
        mass: 1.0,
        diameter: 1.0,
    };
    for k in 0..3 {
        rt.add_ball(at(k)).unwrap();
    }
    assert_eq!(rt.add_ball(at(3)), Err(EngineError::TooManyBalls { limit: 3 }));
    assert_eq!(rt.ball_count(), 3);
    assert!(rt.remove_last().is_some());
    assert!(rt.add_ball(at(4)).is_ok(), "a freed place can be used again");
    assert!(matches!(rt.remove_ball(BallId(999)), Err(EngineError::NoSuchBall(_))));
}

#[test]
fn shutdown_with_1024_balls_joins_every_thread_within_a_second() {
    let _serial = serial();
    let s = scene(
        "name = \"crowd\"\n[simulation]\nmax-balls = 1024\n[effects]\ncollisions = {}\n\
         [[generate]]\ncount = 1024\ndiameter = 0.8\nmass = 1.0\nspeed = 3.0\n",
    );
    let rt = Runtime::start(&s, RuntimeConfig::default()).unwrap();
    assert_eq!(rt.ball_count(), 1024);
    std::thread::sleep(Duration::from_millis(1000));
    let t0 = Instant::now();
    let report = rt.shutdown();
    let took = t0.elapsed();
    assert_eq!(report.joined, 1024);
    assert!(report.panics.is_empty());
    assert!(took < Duration::from_secs(1), "shutdown took {took:?}");
    assert_eq!(rt.live_threads(), 0);
}

#[test]
fn a_panicking_ball_is_reported_and_the_others_keep_running() {
    let _serial = serial();
    let s = scenes::builtin("vacuum").unwrap().unwrap();
    let rt = Runtime::start(&s, RuntimeConfig::default()).unwrap();
    let victim = rt.ball_ids()[3];
    let before = rt.ball_count();
    rt.inject_panic(victim).unwrap();
    assert!(wait_until(Duration::from_secs(20), || rt.stats().threads_panicked == 1));
    let stats = rt.stats();
    assert_eq!(stats.panics.len(), 1, "{:?}", stats.panics);
    assert!(stats.panics[0].contains(&format!("ball {victim}")));
    assert_eq!(rt.ball_count(), before - 1);
    assert!(!rt.snapshot().iter().any(|r| r.ball.id == victim), "no ghost of the dead ball in the table");
    let updates = |rt: &Runtime| rt.snapshot().iter().map(|r| r.updates).sum::<u64>();
    let u0 = updates(&rt);
    std::thread::sleep(Duration::from_millis(100));
    assert!(updates(&rt) > u0, "the other balls keep running");
    assert_eq!(rt.shutdown().joined, before - 1);
}

#[test]
fn pause_stops_time_and_resume_continues() {
    let _serial = serial();
    let s = scenes::builtin("vacuum").unwrap().unwrap();
    let rt = Runtime::start(&s, RuntimeConfig::default()).unwrap();
    std::thread::sleep(Duration::from_millis(100));
    settle(&rt);
    let a: Vec<_> = rt.snapshot().iter().map(|r| r.ball.position).collect();
    std::thread::sleep(Duration::from_millis(200));
    let b: Vec<_> = rt.snapshot().iter().map(|r| r.ball.position).collect();
    assert_eq!(a, b, "nothing moves while paused");
    rt.resume();
    std::thread::sleep(Duration::from_millis(100));
    let c: Vec<_> = rt.snapshot().iter().map(|r| r.ball.position).collect();
    assert_ne!(a, c);
}

/// Hard case 7, time spike: a ball thread stalled for 0.5 s (its next dt is 0.5 s) sub-steps it:
/// it does not tunnel through the floor and its energy does not jump.
#[test]
fn a_stalled_ball_sub_steps_its_long_dt() {
    let _serial = serial();
    let s = scene(
        "name = \"stall\"\n[simulation]\nintegrator = \"leapfrog\"\n[effects]\ngravity = {}\n\
         [[balls]]\nposition = [35.0, 3.0]\nvelocity = [0.0, -20.0]\nmass = 1.0\ndiameter = 1.0\n",
    );
    let energy = |b: &Ball| 0.5 * b.mass * b.velocity.length_squared() + b.mass * 9.81 * b.position.y;
    let start = energy(&s.balls[0]);
    let rt = Runtime::start(&s, RuntimeConfig::default()).unwrap();
    let id = rt.ball_ids()[0];
    // At 20 m/s the ball is 2.5 m from the floor: the 0.5 s stall spans the bounce.
    rt.inject_stall(id, Duration::from_millis(500)).unwrap();
    std::thread::sleep(Duration::from_millis(800));
    settle(&rt);
    let b = rt.snapshot()[0].ball;
    check_inside(&s.field, &[b]);
    let end = energy(&b);
    assert!(rt.wall_impulses().bottom > 0.0, "it bounced");
    assert!((end - start).abs() < 1e-3 * start, "energy {start} -> {end}");
}

/// The lockstep engine's fuzz finding (tests/fuzz.rs, seed 12) on this runtime: a 1.6 g ball of
/// 2.2 m with a 2e5 kg grain passing inside it (G = 1), under drag, is pulled hard enough that
/// its drag turns stiff within a cycle. Its thread judges its sub-steps by the drag rate at the
/// terminal speed the grain drives it to, as the lockstep split does; a 0.3 s stall on it makes
/// the cycle long (the sub-step floor). Nothing becomes NaN, nothing leaves the field.
#[test]
fn a_light_ball_pulled_hard_into_its_drag_stays_finite() {
    let _serial = serial();
    let s = scene(
        "name = \"pulled-into-drag\"\n[field]\nwidth = 20.0\nheight = 10.0\nrestitution = 0.0\n\
         [simulation]\nintegrator = \"yoshida4\"\n[effects]\ngravity = {}\ndrag = {}\nattraction = { g-constant = 1.0 }\n",
    );
    let rt = Runtime::start(&s, RuntimeConfig::default()).unwrap();
    // The field's heavy grains, the 28 kg ball and the light one (its coincident 1 kg balls
    // left out: the runtime refuses overlapping balls).
    let rows = [1, 2, 4, 7, 6].map(|k| common::PULLED_INTO_DRAG[k]);
    let mut light = None;
    for (x, y, vx, vy, mass, diameter) in rows {
        let id = rt.add_ball(common::ball(0, x, y, vx, vy, mass, diameter)).unwrap();
        if mass < 0.01 {
            light = Some(id);
        }
    }
    rt.inject_stall(light.unwrap(), Duration::from_millis(300)).unwrap();
    std::thread::sleep(Duration::from_millis(800));
    settle(&rt);
    let balls: Vec<Ball> = rt.snapshot().iter().map(|r| r.ball).collect();
    assert_eq!(balls.len(), rows.len());
    assert!(balls.iter().all(|b| b.position.is_finite() && b.velocity.is_finite()), "{balls:?}");
    check_inside(&s.field, &balls);
}
