//! Attraction on the threaded runtime at scale: from `TREE_MIN_BALLS` balls on, the ball threads
//! take the pull of the others from the monitor's Barnes–Hut snapshot instead of reading the whole
//! table. Invariants and tolerances, not bits: the path taken (the runtime's counters and the
//! report), no NaN, every ball inside, and the pull of a distant cluster against Newton's law.

mod common;

use std::time::Duration;

use ballfield::EngineKind;
use ballfield::Scene;
use ballfield::headless::{HeadlessOptions, RunLength};
use ballfield::physics::{Ball, BallId, BallKind, TREE_MIN_BALLS};
use ballfield::runtime::{Runtime, RuntimeConfig, RuntimeStats};
use ballfield::scene::Origin;
use common::wait_until;
use glam::DVec2;

/// One runtime at a time: each test runs a few hundred threads, and two at once on a two-core
/// machine would starve each other (cargo runs a file's tests in parallel).
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

/// A gas of `n` balls of 1 kg in a 70 m × 50 m field with attraction at G = 1 (strong enough to
/// matter over a second: a few tenths of a m/s² from the whole field), and collisions if asked.
fn gas(n: usize, collisions: bool) -> Scene {
    let text = format!(
        r#"
name = "attracting-gas"
[simulation]
max-balls = {n}
[effects]
attraction = {{ g-constant = 1.0 }}
{}
[[generate]]
count = {n}
diameter = 0.8
mass = 1.0
speed = 3.0
"#,
        if collisions { "collisions = {}" } else { "" }
    );
    Scene::from_toml_str(&text, &Origin("test".into())).unwrap()
}

fn check_finite_and_inside(rt: &Runtime) {
    let field = rt.params().field;
    for r in rt.snapshot() {
        let b = r.ball;
        assert!(b.is_finite(), "non-finite ball {b:?}");
        assert!(field.contains(b.position.x, b.position.y, b.radius(), 1e-9), "ball outside the field: {b:?}");
    }
}

/// The counters are flushed by each ball when it pauses: pause, then wait until they settle.
fn paused_stats(rt: &Runtime) -> RuntimeStats {
    rt.pause();
    let mut last = rt.stats();
    wait_until(Duration::from_secs(5), || {
        std::thread::sleep(Duration::from_millis(20));
        let s = rt.stats();
        let same = (s.attraction_tree_cycles, s.attraction_direct_cycles)
            == (last.attraction_tree_cycles, last.attraction_direct_cycles);
        last = s;
        same
    });
    last
}

/// At TREE_MIN_BALLS balls and more the ball threads take the tree, the monitor builds it every
/// pass — collisions off, so the monitor's pass runs for attraction alone — and nothing goes
/// wrong.
#[test]
fn a_large_attracting_field_takes_the_tree() {
    let _serial = serial();
    let n = TREE_MIN_BALLS + 72;
    let rt = Runtime::start(&gas(n, false), RuntimeConfig::default()).unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    let s = paused_stats(&rt);
    check_finite_and_inside(&rt);
    assert!(s.tree_builds > 100, "the monitor built {} trees", s.tree_builds);
    assert_eq!(s.messages_dropped, 0);
    // Only the first cycles of the first balls, before the field reached TREE_MIN_BALLS and the
    // monitor's first tree, read the table.
    assert!(
        s.attraction_tree_cycles > 10 * s.attraction_direct_cycles.max(1),
        "tree {} vs direct {} ball cycles",
        s.attraction_tree_cycles,
        s.attraction_direct_cycles
    );
    assert!(s.tree_snapshots >= 1 && s.tree_snapshots <= 8, "{} snapshots", s.tree_snapshots);
    rt.shutdown();
}

/// Below TREE_MIN_BALLS every ball reads the table directly and the monitor builds no tree; a field
/// that shrinks below the threshold goes back to the direct read.
#[test]
fn a_small_field_reads_directly_and_a_shrinking_one_switches_back() {
    let _serial = serial();
    let rt = Runtime::start(&gas(40, true), RuntimeConfig::default()).unwrap();
    std::thread::sleep(Duration::from_millis(300));
    let s = paused_stats(&rt);
    assert_eq!((s.tree_builds, s.attraction_tree_cycles), (0, 0));
    assert!(s.attraction_direct_cycles > 0);
    check_finite_and_inside(&rt);
    rt.shutdown();

    let rt = Runtime::start(&gas(TREE_MIN_BALLS + 2, true), RuntimeConfig::default()).unwrap();
    assert!(wait_until(Duration::from_secs(5), || rt.stats().tree_builds > 50), "no tree built");
    for _ in 0..5 {
        rt.remove_last().unwrap();
    }
    // The monitor withdraws the tree at its next pass; give every ball a few cycles after that.
    std::thread::sleep(Duration::from_millis(100));
    let before = paused_stats(&rt);
    rt.resume();
    std::thread::sleep(Duration::from_millis(300));
    let after = paused_stats(&rt);
    assert_eq!(after.tree_builds, before.tree_builds, "a tree built below the threshold");
    assert_eq!(after.attraction_tree_cycles, before.attraction_tree_cycles, "a ball took a withdrawn tree");
    assert!(after.attraction_direct_cycles > before.attraction_direct_cycles);
    check_finite_and_inside(&rt);
    rt.shutdown();
}

/// The headless report says which way attraction was summed, as the lockstep report does, and
/// carries the tree's figures and the memory used.
#[test]
fn the_report_names_the_tree_and_its_figures() {
    let _serial = serial();
    let options = HeadlessOptions {
        scene_file: "test".into(),
        length: RunLength::Duration(0.5),
        dt: None,
        integrator: None,
        engine: EngineKind::Threaded,
        state_in: None,
        state_out: None,
        threads: None,
        frames: None,
    };
    let report = ballfield::headless::run(&gas(TREE_MIN_BALLS, true), &options).unwrap().report;
    assert!(report.active_effects.contains(&"attraction (tree)".to_string()), "{:?}", report.active_effects);
    let t = report.runtime.as_ref().unwrap();
    assert!(t.stats.tree_builds > 0 && t.stats.tree_builds_per_second > 0.0);
    assert!(t.stats.tree_build_seconds > 0.0);
    assert!(report.summary().contains("trees built"));
    if cfg!(target_os = "linux") {
        let m = report.memory.expect("memory is measured on Linux");
        assert!(m.rss_peak_bytes > 0 && m.bytes_per_ball > 0.0);
    }
    let report = ballfield::headless::run(&gas(TREE_MIN_BALLS - 1, true), &options).unwrap().report;
    assert!(report.active_effects.contains(&"attraction (direct)".to_string()), "{:?}", report.active_effects);
}

/// A small heavy cluster of `TREE_MIN_BALLS + 32` overlapping 1 kg balls about (25, 25) and a
/// 1 g probe 20 m to its right, at rest, under attraction with G = `g`; the probe's id last.
fn cluster_and_probe(g: f64) -> (Scene, DVec2, BallId) {
    let mut scene = Scene::from_toml_str(
        &format!(
            r#"
name = "cluster-and-probe"
[simulation]
integrator = "leapfrog"
[effects]
attraction = {{ g-constant = {g:?} }}
"#
        ),
        &Origin("test".into()),
    )
    .unwrap();
    let centre = DVec2::new(25.0, 25.0);
    let cluster = TREE_MIN_BALLS + 32;
    let mut balls: Vec<Ball> = (0..cluster)
        .map(|k| {
            // A sunflower spiral of radius 0.2 m: every pair overlaps (diameters 1 m).
            let f = (k as f64 + 0.5) / cluster as f64;
            let angle = k as f64 * 2.399_963_229_728_653;
            Ball {
                id: BallId(k as u32),
                kind: BallKind::Ball,
                position: centre + 0.2 * f.sqrt() * DVec2::new(angle.cos(), angle.sin()),
                velocity: DVec2::ZERO,
                mass: 1.0,
                diameter: 1.0,
            }
        })
        .collect();
    // The probe last: its thread starts when the whole cluster is on the field.
    let probe = BallId(cluster as u32);
    balls.push(Ball {
        id: probe,
        kind: BallKind::Ball,
        position: centre + DVec2::new(20.0, 0.0),
        velocity: DVec2::ZERO,
        mass: 1e-3,
        diameter: 0.2,
    });
    scene.max_balls = balls.len();
    scene.balls = balls;
    (scene, centre, probe)
}

/// The probe's fall from rest at `start` (the runtime paused now): its acceleration against
/// Newton's `G·M/d²` toward the cluster's centre of mass. Returns measured / Newton.
///
/// Threaded time is each ball's own wall clock, so the run's length is not known exactly; but from
/// rest under a constant acceleration, `a = v²/(2·Δx)` whatever the time, and leapfrog (drift, kick,
/// drift) keeps that exact for any steps. The field is nearly constant: the cluster's balls all
/// overlap, so they pull one another with the linear interior force and only oscillate about
/// their nearly fixed centre of mass (the probe, 1 g, moves it by nothing measurable), and the
/// probe moves a few centimetres of its 20 m.
fn fall_against_newton(rt: &Runtime, probe: BallId, start: DVec2, centre: DVec2, g: f64) -> f64 {
    let records = rt.snapshot();
    let p = records.iter().find(|r| r.ball.id == probe).unwrap().ball;
    let m_cluster: f64 = records.iter().filter(|r| r.ball.id != probe).map(|r| r.ball.mass).sum();
    let com =
        records.iter().filter(|r| r.ball.id != probe).map(|r| r.ball.mass * r.ball.position).sum::<DVec2>() / m_cluster;
    // Each ball pulls the others from the state they last published, so pairs are not summed at
    // one instant and the cluster's momentum is kept only to that lag: under load (a ball thread
    // waiting tens of ms for its turn) the centre of mass drifted up to 5 cm in 0.7 s (measured,
    // one core busy). A drift of 0.1 m changes the pull 20 m away by 1 % — inside the 3 % below.
    assert!(com.distance(centre) < 0.1, "the cluster's centre of mass moved to {com}");
    let dx = p.position - start;
    let v = p.velocity;
    let toward = (centre - start).normalize();
    assert!(dx.length() > 0.01, "the probe barely moved: {dx}");
    assert!(dx.normalize().dot(toward) > 0.999 && v.normalize().dot(toward) > 0.999, "dx {dx}, v {v}");
    let measured = v.length_squared() / (2.0 * dx.length());
    // Newton at the middle of the probe's path (the field grows by 2·Δx/d over it).
    let d = (centre - (start + 0.5 * dx)).length();
    let newton = g * m_cluster / (d * d);
    eprintln!("probe: a = {measured} m/s², Newton (G = {g}) {newton}: ratio {}", measured / newton);
    measured / newton
}

/// A distant ball falls toward a small heavy cluster as Newton says: `a = G·M/d²` toward the
/// cluster's centre of mass, within 3 %, through the tree (from 20 m the 0.4 m cluster is one far
/// node: its multipole, not pairs).
#[test]
fn a_distant_cluster_pulls_a_ball_as_newton_says() {
    let _serial = serial();
    let (scene, centre, probe) = cluster_and_probe(1.0);
    let start = scene.balls.last().unwrap().position;
    let rt = Runtime::start(&scene, RuntimeConfig::default()).unwrap();
    std::thread::sleep(Duration::from_millis(700));
    let s = paused_stats(&rt);
    let ratio = fall_against_newton(&rt, probe, start, centre, 1.0);
    assert!((ratio - 1.0).abs() < 0.03, "a / Newton = {ratio}");
    assert!(s.attraction_tree_cycles > 10 * s.attraction_direct_cycles.max(1), "{s:?}");
    check_finite_and_inside(&rt);
    rt.shutdown();
}

/// New attraction parameters reach the balls: G doubled in the middle of a run, the probe then
/// falls at Newton's rate for the new G (within 3 %; at the old one it would be half). They reach
/// them through a new tree: a ball whose snapshot was built with the old ones reads the table
/// directly meanwhile, and soon all are back on the tree. (Seen to fail with the ball threads
/// not re-reading the parameters when their generation moves: the probe fell at the old G, 0.5
/// of Newton's rate for the new one, and every cycle read the table directly.)
#[test]
fn new_parameters_reach_the_balls_through_a_new_tree() {
    let _serial = serial();
    let (scene, centre, probe) = cluster_and_probe(1.0);
    let rt = Runtime::start(&scene, RuntimeConfig::default()).unwrap();
    assert!(wait_until(Duration::from_secs(5), || rt.stats().tree_builds > 20), "no tree built");
    // Paused, every ball caught up to the horizon: the new G, and the probe stopped where it is
    // (messages land while paused); its fall from rest is measured from there.
    assert!(rt.settle(Duration::from_secs(60)), "the balls caught up: {:?}", rt.stats());
    let mut effects = rt.params().effects;
    effects.attraction.as_mut().unwrap().g_constant = 2.0;
    rt.set_effects(effects);
    rt.set_velocity(probe, DVec2::ZERO).unwrap();
    let at_rest = |rt: &Runtime| rt.snapshot().iter().find(|r| r.ball.id == probe).map(|r| r.ball);
    assert!(wait_until(Duration::from_secs(5), || at_rest(&rt).is_some_and(|b| b.velocity == DVec2::ZERO)));
    let start = at_rest(&rt).unwrap().position;
    let before = paused_stats(&rt);
    rt.resume();
    std::thread::sleep(Duration::from_millis(700));
    let after = paused_stats(&rt);
    let ratio = fall_against_newton(&rt, probe, start, centre, 2.0);
    assert!((ratio - 1.0).abs() < 0.03, "a / Newton at the new G = {ratio}");
    let tree = after.attraction_tree_cycles - before.attraction_tree_cycles;
    let direct = after.attraction_direct_cycles - before.attraction_direct_cycles;
    assert!(tree > 10 * direct.max(1), "after the change: tree {tree}, direct {direct} ball cycles");
    check_finite_and_inside(&rt);
    rt.shutdown();
}
