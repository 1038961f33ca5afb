// Shared helpers for the integration tests (each test file includes it with `mod common;`).
#![allow(dead_code)]

use std::time::{Duration, Instant};

use ballfield::Lockstep;
use ballfield::physics::{Ball, BallId, BallKind, Effects, Field, Integrator};
use ballfield::runtime::BallRecord;
use glam::DVec2;

pub fn ball(id: u32, x: f64, y: f64, vx: f64, vy: f64, mass: f64, diameter: f64) -> Ball {
    Ball {
        id: BallId(id),
        kind: BallKind::Ball,
        position: DVec2::new(x, y),
        velocity: DVec2::new(vx, vy),
        mass,
        diameter,
    }
}

pub fn engine(field: Field, effects: Effects, integrator: Integrator, dt: f64, balls: &[Ball]) -> Lockstep {
    Lockstep::from_parts(field, effects, integrator, dt, balls.len().max(1), balls)
}

/// A big field with elastic walls, so that a test's balls never reach a wall.
pub fn open_field() -> Field {
    Field { width: 1.0e6, height: 1.0e6, restitution: 1.0 }
}

pub fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(f64::MIN_POSITIVE)
}

/// The fuzzer's seed-12 finding (tests/fuzz.rs), shrunk by proptest: `(x, y, vx, vy, mass,
/// diameter)` in a 20 m × 10 m field, under gravity, quadratic drag and attraction with G = 1.
/// Ball 7 (1.6 g, 2.2 m) is pulled into its drag by ball 2 (2e5 kg, 1.5 mm) passing inside it.
pub const PULLED_INTO_DRAG: [(f64, f64, f64, f64, f64, f64); 10] = [
    (0.5, 0.5, 0.0, 19.98469997170511, 1.0, 1.0),
    (
        7.059324430865294,
        5.989446160235999,
        172.58317190949356,
        -207.20719717756145,
        28.675137913826017,
        0.273960105834647,
    ),
    (
        12.875145798562006,
        5.038438580992614,
        -12.52064583385878,
        -252.02413668337556,
        208396.70201951882,
        0.0015028692559669386,
    ),
    (0.5, 0.5, 0.0, 0.0, 1.0, 1.0),
    (
        16.189124680615766,
        7.014978389554498,
        51.73733967008698,
        -10.924901360025366,
        172948.510085571,
        0.8913997411471628,
    ),
    (0.5, 0.5, 0.0, 0.0, 1.0, 1.0),
    (0.5, 0.5, 0.0, 0.0, 11614.631797359905, 1.0),
    (13.763962743160123, 1.205493956857447, 287.37145920317283, 0.0, 0.0016165245376088056, 2.1941680547019975),
    (0.5, 0.5, 0.0, 0.0, 1.0, 1.0),
    (0.5, 0.5, 0.0, 0.0, 1.0, 1.0),
];

/// Polls `done` every millisecond until it holds or `timeout` has passed (for what the threaded
/// runtime does asynchronously); returns whether it held.
pub fn wait_until(timeout: Duration, mut done: impl FnMut() -> bool) -> bool {
    let end = Instant::now() + timeout;
    while Instant::now() < end {
        if done() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    done()
}

/// The total momentum of a snapshot of the threaded runtime's table, kg·m/s.
pub fn momentum_of(records: &[BallRecord]) -> DVec2 {
    records.iter().map(|r| r.ball.momentum()).sum()
}

/// 150 balls of 1 m and 1 kg dropped from up to 12 m into a 14 m wide box, everything at
/// e = 0.8, gravity and air drag: the shipped `pile` but a seventh of it.
pub const SMALL_PILE: &str = r#"
name = "small-pile"
[field]
width = 14.0
height = 20.0
restitution = 0.8
[simulation]
seed = 3
[effects]
collisions = { restitution = 0.8 }
gravity = { g = [0.0, -9.81] }
drag = { model = "quadratic", rho = 1.225, cd = 0.47 }
[[generate]]
count = 150
diameter = 1.0
mass = 1.0
speed = 1.0
layout = "lattice"
gap = 0.2
region = [0.0, 4.0, 14.0, 20.0]
"#;

/// The small pile as dropped (see [`SMALL_PILE`]).
pub fn small_pile() -> ballfield::Scene {
    ballfield::Scene::from_toml_str(SMALL_PILE, &ballfield::scene::Origin("test".into())).unwrap()
}

/// The small pile after 15 s on lockstep (dt = 1 ms), when it has settled (its kinetic energy
/// about 1e-8 J), as a scene of its balls; and the lockstep engine that settled it.
pub fn settled_small_pile() -> (ballfield::Scene, Lockstep) {
    let mut scene = small_pile();
    let mut l = Lockstep::new(&scene);
    l.run(15_000);
    scene.balls = (0..l.bodies().len()).map(|i| l.bodies().get(i)).collect();
    (scene, l)
}

/// The largest overlap of any two balls, relative to their contact distance.
pub fn largest_overlap(b: &ballfield::physics::Bodies) -> f64 {
    let mut worst = 0.0f64;
    for i in 0..b.len() {
        for j in i + 1..b.len() {
            let reach = b.radius[i] + b.radius[j];
            worst = worst.max((reach - b.position[i].distance(b.position[j])) / reach);
        }
    }
    worst
}

/// Heavy and light balls landing together: 80 balls of 100 kg and 80 of 1 kg, all 1 m across,
/// falling from up to 30 m into a 20 m wide box, at ball restitution `e` (walls 0.5), dt 1 ms,
/// generated from `seed` (`landing_heavy_and_light.rs` on lockstep, `threaded_landing.rs` on the
/// threaded runtime).
pub fn heavy_and_light(e: f64, seed: u64) -> ballfield::Scene {
    let source = format!(
        "name = \"heavy and light\"\n[field]\nwidth = 20\nheight = 30\nrestitution = 0.5\n\
         [simulation]\ndt = 0.001\nseed = {seed}\n[effects]\ncollisions = {{ restitution = {e} }}\n\
         gravity = {{ g = [0.0, -9.81] }}\n\
         [[generate]]\ncount = 80\ndiameter = 1.0\nmass = 100.0\nspeed = 1.0\nregion = [0.0, 10.0, 20.0, 30.0]\n\
         [[generate]]\ncount = 80\ndiameter = 1.0\nmass = 1.0\nspeed = 1.0\nregion = [0.0, 10.0, 20.0, 30.0]\n"
    );
    ballfield::Scene::from_toml_str(&source, &ballfield::scene::Origin("heavy and light".into()))
        .expect("the scene loads")
}
