//! Determinism: the same scene gives the same bits; a run continued from a state file gives the
//! same bits as one long run.

mod common;

use ballfield::Lockstep;
use ballfield::headless::{parse_state, write_state};
use ballfield::scenes;

#[test]
fn two_runs_of_the_same_scene_hash_identically() {
    for name in ["default", "pile", "attraction"] {
        let scene = scenes::builtin(name).unwrap().unwrap();
        let mut a = Lockstep::new(&scene);
        let mut b = Lockstep::new(&scene);
        a.run(1500);
        b.run(1500);
        assert_eq!(a.state_hash(), b.state_hash(), "scene {name}");
        assert_ne!(a.state_hash(), Lockstep::new(&scene).state_hash(), "scene {name} moved");
    }
}

#[test]
fn generated_scenes_are_the_same_for_the_same_seed_and_differ_for_another() {
    let text = scenes::BUILTIN.iter().find(|(n, _)| *n == "gas").unwrap().1;
    let origin = ballfield::scene::Origin("gas".into());
    let a = ballfield::Scene::from_toml_str(text, &origin).unwrap();
    let b = ballfield::Scene::from_toml_str(text, &origin).unwrap();
    assert_eq!(a.balls, b.balls);
    let c = ballfield::Scene::from_toml_str(&text.replace("seed = 42", "seed = 43"), &origin).unwrap();
    assert_ne!(a.balls, c.balls);
}

#[test]
fn a_run_continued_from_its_state_file_matches_one_long_run() {
    let dir = std::env::temp_dir().join(format!("ballfield-determinism-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for name in ["default", "pile", "attraction", "gas"] {
        let scene = scenes::builtin(name).unwrap().unwrap();
        let mut long = Lockstep::new(&scene);
        long.run(2000);

        let mut first = Lockstep::new(&scene);
        first.run(1000);
        let path = dir.join(format!("{name}.csv"));
        write_state(&path, &first.bodies().to_balls()).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with("id,kind,x,y,vx,vy,mass,diameter\n"));
        let balls = parse_state(&text, &path, &scene.field).unwrap();
        assert_eq!(balls, first.bodies().to_balls(), "{name}: the state file round-trips exactly");

        let mut continued = scene.clone();
        continued.balls = balls;
        let mut second = Lockstep::new(&continued);
        second.run(1000);
        assert_eq!(second.state_hash(), long.state_hash(), "{name}: 1000 + 1000 steps == 2000 steps");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A field big enough that every phase is shared out over threads (more than
/// `PARALLEL_MIN_BALLS` balls, more than `PARALLEL_MIN_PAIRS` touching pairs, many bands, big
/// balls): a crowd started overlapping, falling under gravity with drag, two giants in it, and
/// the key ball pulled. The bits after 200 steps are the same on 1, 2 and 4 threads, at e = 0.9
/// (the contact solver) and at e = 1 (the elastic passes, with the walls met between them).
#[test]
fn the_same_bits_on_any_number_of_threads() {
    for e in [0.9, 1.0] {
        the_same_bits_on_any_number_of_threads_at(e);
    }
}

fn the_same_bits_on_any_number_of_threads_at(e: f64) {
    let text = r#"
        name = "threads"
        [field]
        width = 120.0
        height = 80.0
        [simulation]
        integrator = "leapfrog"
        seed = 7
        allow-overlap = true
        max-balls = 6000
        [effects]
        collisions = { restitution = RESTITUTION }
        gravity = { g = [0.0, -9.81] }
        drag = { model = "quadratic", rho = 1.225, cd = 0.47 }
        [key-ball]
        position = [60.0, 75.0]
        velocity = [3.0, 0.0]
        mass = 5.0
        diameter = 1.2
        pull = 200.0
        [[balls]]
        position = [30.0, 40.0]
        velocity = [0.0, 20.0]
        mass = 500.0
        diameter = 9.0
        [[balls]]
        position = [90.0, 40.0]
        velocity = [-15.0, 0.0]
        mass = 800.0
        diameter = 7.0
        [[generate]]
        count = 5000
        diameter = 1.0
        mass = 1.0
        speed = 4.0
        layout = "lattice"
        gap = -0.01
        region = [0.0, 0.0, 120.0, 60.0]
    "#;
    let text = text.replace("RESTITUTION", &format!("{e:?}"));
    let scene = ballfield::Scene::from_toml_str(&text, &ballfield::scene::Origin("threads".into())).unwrap();
    assert!(scene.balls.len() >= ballfield::lockstep::PARALLEL_MIN_BALLS);
    let run = |threads: usize| {
        let mut engine = Lockstep::new(&scene);
        engine.set_threads(threads);
        engine.set_pull(glam::DVec2::new(150.0, -80.0));
        engine.run(200);
        let pairs_per_step = engine.counters().touching_pairs / engine.counters().steps;
        assert!(
            pairs_per_step >= ballfield::lockstep::PARALLEL_MIN_PAIRS as u64,
            "the contact solver ran in parallel: {pairs_per_step} pairs per step"
        );
        assert_eq!(engine.diagnostics().non_finite, 0);
        (engine.state_hash(), engine.wall_impulses())
    };
    let one = run(1);
    assert_eq!(run(2), one, "e {e}: 2 threads");
    assert_eq!(run(4), one, "e {e}: 4 threads");
}

/// Light balls struck by heavy ones beyond the broad phase's skin (the pairs lockstep's contact
/// solver adds mid-step for them: `StepCounters::pairs_reached`) and pairs the position passes
/// push together, in a field big enough to be shared out over threads: 4,400 balls of 1 kg on a
/// lattice, struck by 150 of 100 kg thrown at 90 m/s, at e = 0.99 under gravity. The bits after
/// 150 steps are the same on 1, 2 and 4 threads, and the run does take both paths (1,621 pairs
/// added, 264 pushed together). Seen to fail with the struck balls' pairs named by their working
/// index instead of their slot: 391,979 pairs added on one thread against 1,515 on two.
#[test]
fn the_same_bits_on_any_number_of_threads_when_struck_balls_leave_the_skin() {
    struck_beyond_the_skin(0.5, 0.99);
}

/// The same at e = 1 with walls of restitution 1, where the elastic passes take the contacts and
/// add the pairs of balls struck beyond the skin to the big balls' (`reach_struck` in
/// `elastic_contacts`, worked serially after the bands and seams): the bits after 150 steps are
/// the same on 1, 2 and 4 threads, and the run takes the path (measured: 886 pairs added).
/// Seen to fail with the struck balls' slots taken as the balls in them in the parallel passes:
/// 568,208 pairs added on two threads against 886 on one.
#[test]
fn the_same_bits_on_any_number_of_threads_when_the_elastic_passes_strike_balls_beyond_the_skin() {
    struck_beyond_the_skin(1.0, 1.0);
}

/// The field of the two tests above, walls of restitution `walls`, balls of `e`.
fn struck_beyond_the_skin(walls: f64, e: f64) {
    let text = r#"
        name = "struck beyond the skin"
        [field]
        width = 120.0
        height = 60.0
        restitution = WALLS
        [simulation]
        seed = 11
        max-balls = 6000
        [effects]
        collisions = { restitution = RESTITUTION }
        gravity = { g = [0.0, -9.81] }
        [[generate]]
        count = 4400
        diameter = 1.0
        mass = 1.0
        speed = 0.5
        layout = "lattice"
        gap = 0.05
        region = [0.0, 0.0, 120.0, 42.0]
        [[generate]]
        count = 150
        diameter = 1.0
        mass = 100.0
        speed = 90.0
        region = [0.0, 43.0, 120.0, 60.0]
    "#;
    let text = text.replace("WALLS", &format!("{walls:?}")).replace("RESTITUTION", &format!("{e:?}"));
    let scene = ballfield::Scene::from_toml_str(&text, &ballfield::scene::Origin("struck".into())).unwrap();
    assert!(scene.balls.len() >= ballfield::lockstep::PARALLEL_MIN_BALLS);
    let run = |threads: usize| {
        let mut engine = Lockstep::new(&scene);
        engine.set_threads(threads);
        engine.run(150);
        let c = engine.counters();
        eprintln!(
            "e {e}, {threads} thread(s): pairs reached {}, pushed together {}",
            c.pairs_reached, c.pushed_together
        );
        assert!(c.pairs_reached > 0, "no struck ball left the skin");
        assert_eq!(engine.diagnostics().non_finite, 0);
        (engine.state_hash(), engine.wall_impulses())
    };
    let one = run(1);
    assert_eq!(run(2), one, "e {e}: 2 threads");
    assert_eq!(run(4), one, "e {e}: 4 threads");
}
