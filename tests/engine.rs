//! The engine interface: every engine takes the same commands and answers them the same way.
//! Each test runs one command sequence on every engine (`EngineKind::ALL`) through `dyn Engine`
//! alone, as the window and headless do, and checks what a caller relies on: ids kept by in-place
//! changes, bad values refused with an error (never a panic), balls kept inside the field, the
//! clock and the pause.
//!
//! Seen to fail on broken builds: `LockstepEngine::put_back` giving a fresh id (the put-back
//! test), `engine::admit` not moving a ball inside the field (the add test), `set_pull` dropped
//! (the pull test), and the threaded engine clamping a NaN restitution (the bad-values test, which
//! found that bug: `f64::clamp` keeps a NaN).

use std::sync::Mutex;
use std::time::Duration;

use ballfield::engine::{self, Engine, EngineError, EngineKind};
use ballfield::physics::{Ball, BallId, BallKind};
use ballfield::scene::{Origin, Scene};
use glam::DVec2;

/// The threaded engine's tests share the machine's two cores: one at a time.
fn serial() -> std::sync::MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    LOCK.lock().unwrap_or_else(|e| e.into_inner())
}

/// A vacuum without collisions: three plain balls at rest and a key ball of 2 kg pulled by 10 N.
fn scene() -> Scene {
    let toml = r#"
name = "engine-test"
[field]
width = 40.0
height = 30.0
[simulation]
dt = 0.001
seed = 3
max-balls = 8
[key-ball]
position = [20.0, 15.0]
mass = 2.0
diameter = 1.0
pull = 10.0
[[balls]]
position = [5.0, 5.0]
mass = 1.0
diameter = 1.0
[[balls]]
position = [10.0, 5.0]
mass = 1.0
diameter = 1.0
[[balls]]
position = [15.0, 5.0]
mass = 1.0
diameter = 1.0
"#;
    Scene::from_toml_str(toml, &Origin("engine-test.toml".into())).unwrap()
}

fn start(kind: EngineKind) -> Box<dyn Engine> {
    engine::start(kind, &scene(), Some(1)).unwrap()
}

fn balls(e: &mut dyn Engine) -> Vec<Ball> {
    let mut out = Vec::new();
    e.sample(&mut out);
    out
}

fn find(e: &mut dyn Engine, id: BallId) -> Option<Ball> {
    balls(e).into_iter().find(|b| b.id == id)
}

/// Waits (the threaded engine applies commands on the ball's own thread) until `done` holds.
fn eventually(e: &mut dyn Engine, mut done: impl FnMut(&mut dyn Engine) -> bool) -> bool {
    for _ in 0..2000 {
        if done(e) {
            return true;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    false
}

#[test]
fn in_place_changes_keep_the_ball_and_its_id() {
    let _s = serial();
    for kind in EngineKind::ALL {
        let mut e = start(kind);
        let key = e.key_ball().expect("the scene has a key ball");
        e.set_mass(key, 7.5).unwrap();
        assert!(eventually(e.as_mut(), |e| find(e, key).is_some_and(|b| b.mass == 7.5)), "{kind}: mass");
        let plain = balls(e.as_mut()).into_iter().find(|b| b.kind == BallKind::Ball).unwrap().id;
        e.set_velocity(plain, DVec2::new(1.5, -0.5)).unwrap();
        e.advance_steps(5);
        assert!(
            eventually(e.as_mut(), |e| find(e, plain).is_some_and(|b| b.velocity == DVec2::new(1.5, -0.5))),
            "{kind}: velocity"
        );
        assert_eq!(e.ball_count(), 4, "{kind}: no ball was added or removed by the changes");
        e.shutdown();
    }
}

#[test]
fn a_taken_ball_is_put_back_with_its_id() {
    let _s = serial();
    for kind in EngineKind::ALL {
        let mut e = start(kind);
        let id = balls(e.as_mut()).into_iter().find(|b| b.kind == BallKind::Ball).unwrap().id;
        let taken = e.remove_ball(id).unwrap();
        assert_eq!(taken.id, id);
        assert_eq!(e.ball_count(), 3, "{kind}");
        assert!(find(e.as_mut(), id).is_none(), "{kind}: the taken ball is off the field");
        let back = Ball { position: DVec2::new(30.0, 20.0), ..taken };
        assert_eq!(e.put_back(back), Ok(id), "{kind}");
        assert!(eventually(e.as_mut(), |e| find(e, id).is_some()), "{kind}");
        assert_eq!(e.put_back(back), Err(EngineError::IdInUse(id)), "{kind}: one ball per id");
        assert_eq!(e.remove_ball(BallId(999)), Err(EngineError::NoSuchBall(BallId(999))), "{kind}");
        e.shutdown();
    }
}

#[test]
fn bad_values_are_refused_not_panicked_on() {
    let _s = serial();
    for kind in EngineKind::ALL {
        let mut e = start(kind);
        let key = e.key_ball().unwrap();
        for m in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(e.set_mass(key, m), Err(EngineError::InvalidMass(_))), "{kind}: mass {m}");
        }
        assert!(matches!(e.set_velocity(key, DVec2::new(f64::NAN, 0.0)), Err(EngineError::InvalidVelocity(..))));
        let bad = Ball {
            id: BallId(0),
            kind: BallKind::Ball,
            position: DVec2::ONE,
            velocity: DVec2::ZERO,
            mass: 1.0,
            diameter: 0.0,
        };
        assert!(matches!(e.add_ball(bad), Err(EngineError::InvalidBall(_))), "{kind}: zero diameter");
        let huge = Ball { diameter: 100.0, ..bad };
        assert!(matches!(e.add_ball(huge), Err(EngineError::InvalidBall(_))), "{kind}: larger than the field");
        e.set_pull(DVec2::new(f64::NAN, 1.0));
        e.set_restitution(f64::NAN, 2.0);
        assert_eq!(e.field().restitution, 1.0, "{kind}: a NaN restitution keeps the old one");
        e.advance_steps(10);
        assert!(balls(e.as_mut()).iter().all(|b| b.position.is_finite() && b.velocity.is_finite()), "{kind}");
        assert_eq!(e.ball_count(), 4, "{kind}");
        e.shutdown();
    }
}

#[test]
fn added_balls_land_inside_the_field_and_the_limit_holds() {
    let _s = serial();
    for kind in EngineKind::ALL {
        let mut e = start(kind);
        let outside = Ball {
            id: BallId(0),
            kind: BallKind::Ball,
            position: DVec2::new(-5.0, 100.0),
            velocity: DVec2::ZERO,
            mass: 1.0,
            diameter: 2.0,
        };
        let id = e.add_ball(outside).unwrap();
        let b = find(e.as_mut(), id).expect("added");
        assert_eq!(b.position, DVec2::new(1.0, 29.0), "{kind}: moved just inside the corner");
        // Free spots: the field has room for more; max-balls = 8 stops the fifth new ball.
        for _ in 0..3 {
            e.add_ball_at_free_spot(1.0, 1.0).unwrap();
        }
        assert_eq!(e.add_ball_at_free_spot(1.0, 1.0), Err(EngineError::TooManyBalls { limit: 8 }), "{kind}");
        let all = balls(e.as_mut());
        assert_eq!(all.len(), 8);
        for (k, a) in all.iter().enumerate() {
            for c in &all[k + 1..] {
                assert!(a.position.distance(c.position) >= a.radius() + c.radius() - 1e-9, "{kind}: overlap");
            }
        }
        assert!(e.remove_last().is_some_and(|b| b.kind == BallKind::Ball), "{kind}");
        e.shutdown();
    }
}

/// The pull accelerates the key ball as F/m: 10 N on 2 kg for 0.5 s of the engine's clock
/// moves it ½·5·0.25 = 0.625 m. Lockstep's semi-implicit Euler (dt = 1 ms) moves it exactly
/// ½·a·t·(t + dt) = 0.62625 m (asserted to 1e-9 relative: measured 1.4e-15); the threaded
/// engine's clock is the wall clock, so its key ball starts and stops pulling a cycle or so
/// off the clock's instants (measured 0.6237-0.6261 m against ½·a·t² = 0.6250 m, load average
/// 10): 5 % is about ten times that. Seen to fail with the pull dropped in `set_pull` of either
/// engine.
#[test]
fn the_pull_moves_the_key_ball_as_f_over_m() {
    let _s = serial();
    for kind in EngineKind::ALL {
        let mut e = start(kind);
        let key = e.key_ball().unwrap();
        let x0 = find(e.as_mut(), key).unwrap().position;
        e.set_pull(DVec2::new(10.0, 0.0));
        let t0 = e.time();
        e.advance_to(t0 + 0.5);
        e.quiesce();
        let dt = e.time() - t0;
        let x = find(e.as_mut(), key).unwrap().position;
        eprintln!("{kind}: the key ball moved {} m in {dt} s", x.x - x0.x);
        let (expected, tolerance) = match kind {
            EngineKind::Lockstep => (0.5 * 5.0 * dt * (dt + 0.001), 1e-9),
            _ => (0.5 * 5.0 * dt * dt, 0.05),
        };
        assert!(
            ((x.x - x0.x) - expected).abs() <= tolerance * expected,
            "{kind}: moved {} m in {dt} s, expected {expected}",
            x.x - x0.x
        );
        assert!((x.y - x0.y).abs() < 1e-9, "{kind}: the pull is horizontal");
        e.shutdown();
    }
}

/// After `advance_to` and `quiesce`, `time()` is the instant the balls stand at, read off a ball
/// falling freely from rest under gravity (its velocity is −g·t in every engine and integrator):
/// at 0.02, 0.1 and 0.5 s on every engine. Measured: lockstep and exact to rounding; threaded
/// 5e-8–2.8e-7 s (the balls stand at the monitor's horizon, up to a few periods past the instant
/// asked for, and the engine's clock reads that). Bounds 1e-12 s and 5e-6 s. Seen to fail with
/// the threaded engine's clock started when the runtime had started, not at its zero: 2e-5 to
/// 6e-5 s behind the balls (1.6e-3 s once on a loaded machine) — the time the monitor's thread
/// took to spawn.
#[test]
fn after_quiesce_the_clock_is_the_balls_instant() {
    let _s = serial();
    let toml = "name = \"fall\"\n[field]\nwidth = 10.0\nheight = 20.0\n[simulation]\ndt = 0.001\n\
                [effects]\ngravity = { g = [0.0, -9.81] }\n[[balls]]\nposition = [5.0, 15.0]\nmass = 1.0\n\
                diameter = 1.0\n";
    let scene = Scene::from_toml_str(toml, &Origin("fall.toml".into())).unwrap();
    for kind in EngineKind::ALL {
        let bound = if kind == EngineKind::Threaded { 5e-6 } else { 1e-12 };
        for t in [0.02, 0.1, 0.5] {
            let mut e = engine::start(kind, &scene, Some(1)).unwrap();
            e.advance_to(t);
            e.quiesce();
            let mut balls = Vec::new();
            e.sample(&mut balls);
            let fallen = -balls[0].velocity.y / 9.81;
            eprintln!("{kind}: asked {t} s, time() {} s, the ball's fall {fallen} s", e.time());
            assert!(
                (e.time() - fallen).abs() <= bound,
                "{kind}: time() reads {} s after quiesce, the balls stand at {fallen} s",
                e.time()
            );
            e.shutdown();
        }
    }
}

/// Paused, the clock and the balls stand still; a single step advances by about its span and
/// pauses again.
#[test]
fn pause_holds_and_a_single_step_advances() {
    let _s = serial();
    for kind in EngineKind::ALL {
        let mut e = start(kind);
        let key = e.key_ball().unwrap();
        e.set_pull(DVec2::new(10.0, 0.0));
        e.set_paused(true);
        assert!(e.is_paused());
        let (t, x) = (e.time(), find(e.as_mut(), key).unwrap().position);
        std::thread::sleep(Duration::from_millis(50));
        e.tick(Duration::from_millis(50));
        e.advance_to(t + 1.0);
        assert_eq!(e.time(), t, "{kind}: the clock stands still while paused");
        assert!(find(e.as_mut(), key).unwrap().position.distance(x) < 1e-3, "{kind}: the balls too");
        e.single_step(Duration::from_millis(15));
        // The window ticks every 15 ms; the threaded engine's step ends at the first tick after it.
        for _ in 0..12 {
            std::thread::sleep(Duration::from_millis(5));
            e.tick(Duration::from_millis(5));
        }
        assert!(e.is_paused(), "{kind}: paused again after the step");
        let stepped = e.time() - t;
        assert!(stepped > 0.010 && stepped < 0.060, "{kind}: one step of 15 ms advanced {stepped} s");
        e.set_paused(false);
        e.shutdown();
    }
}

#[test]
fn the_engine_kind_cycles_and_names_itself() {
    assert_eq!(EngineKind::Threaded.next(), EngineKind::Lockstep);
    assert_eq!(EngineKind::ALL.iter().fold(EngineKind::Threaded, |k, _| k.next()), EngineKind::Threaded);
    for kind in EngineKind::ALL {
        assert_eq!(kind.to_string(), kind.name());
    }
}
