//! The exact engine on fields of any size the scene checker accepts (it takes any finite width
//! and height above zero): a field 1e20 m wide for 1 m balls, one 1e20 m by 50 m, one f64::MAX m
//! wide, and balls of 1 µm in a field of 1e6 m. The grid's cell counts there overflow any integer
//! (1e20 cells across, or 1e12 across and 1e24 in all), so `Cells::new` sizes it in f64 under a
//! cap of cells a ball. Each run starts, goes through events (bounces in the corner two balls are
//! placed in, a collision between the tiny balls) and ends with every ball finite and inside the
//! field — through the engine interface and through the command line.
//!
//! Seen to fail on the broken builds this fixes: `Cells::new` counting the cells in `usize`
//! (`nx * ny` wrapped to a grid of one slot at 1e20 m, and `fill` indexed past its end: "index out
//! of bounds: the len is 1 but the index is 1" in the engine test, a panic on the command line;
//! the 1 µm balls pass there, their product wrapping to a count the halving brings under the
//! cap); `entry_time` with the discriminant left to overflow (f64::MAX m: the generated balls
//! "reach" the floor and their cells' boundaries at t = 0, 12 wall bounces and 30 cell crossings
//! instead of the corner's 4 and none); and the broad phase of the start's diagnostics
//! (`BroadPhase::layout`) without its cap on a long field's cells (1e20 m by 50 m: 2.7e9 cells,
//! "memory allocation of 33941125504 bytes failed" on the command line).

use std::process::Command;

use ballfield::engine::{self, EngineKind};
use ballfield::headless::read_state;
use ballfield::physics::Ball;
use ballfield::scene::{Origin, Scene};

/// A field `width` × `height` m with gravity, `listed` balls given by hand (TOML) and `count`
/// more of `diameter` m placed at random.
fn scene_text(width: &str, height: &str, listed: &str, count: usize, diameter: f64) -> String {
    format!(
        r#"
name = "exact-fields"
[field]
width = {width}
height = {height}
restitution = 1.0
[simulation]
dt = 0.001
seed = 3
[effects]
collisions = {{ restitution = 1.0 }}
gravity = {{ g = [0.0, -9.81] }}
{listed}
[[generate]]
count = {count}
diameter = {diameter}
mass = 1.0
speed = 5.0
"#
    )
}

/// Two 1 m balls in the bottom-left corner, one thrown at the left wall, one dropped on the floor.
const CORNER: &str = r#"
[[balls]]
position = [3.0, 0.5]
velocity = [-4.0, 0.0]
mass = 1.0
diameter = 1.0
[[balls]]
position = [6.0, 2.0]
mass = 2.0
diameter = 1.0
"#;

/// Two 1 µm balls 10 µm apart, head on at 1 mm/s, near the floor.
const TINY_PAIR: &str = r#"
[[balls]]
position = [10.0, 1.0e-6]
velocity = [1.0e-3, 0.0]
mass = 1.0
diameter = 1.0e-6
[[balls]]
position = [10.00001, 1.0e-6]
velocity = [-1.0e-3, 0.0]
mass = 1.0
diameter = 1.0e-6
"#;

/// The scenes: `(what, TOML)`.
fn scenes() -> Vec<(&'static str, String)> {
    vec![
        ("1e20 m field, 1 m balls", scene_text("1.0e20", "1.0e20", CORNER, 20, 1.0)),
        ("1e20 m by 50 m field, 1 m balls", scene_text("1.0e20", "50.0", CORNER, 20, 1.0)),
        (
            "f64::MAX m field, 1 m balls",
            scene_text("1.7976931348623157e308", "1.7976931348623157e308", CORNER, 20, 1.0),
        ),
        ("1e6 m field, 1 µm balls", scene_text("1.0e6", "1.0e6", TINY_PAIR, 200, 1.0e-6)),
    ]
}

fn parse(what: &str, text: &str) -> Scene {
    Scene::from_toml_str(text, &Origin(format!("{what}.toml"))).unwrap_or_else(|e| panic!("{what}: {e}"))
}

/// Every ball finite and inside the field.
#[track_caller]
fn check_inside(what: &str, balls: &[Ball], width: f64, height: f64) {
    for b in balls {
        let (p, v, r) = (b.position, b.velocity, 0.5 * b.diameter);
        assert!(p.is_finite() && v.is_finite(), "{what}: ball {:?} at {p}, {v}", b.id);
        assert!(
            p.x >= r && p.x <= width - r && p.y >= r && p.y <= height - r,
            "{what}: ball {:?} at {p} outside the field",
            b.id
        );
    }
}

/// Measured: in 2 s the corner's balls bounce 4 times on the square fields of 1e20 m and
/// f64::MAX m (the thrown ball off the left wall, the dropped one off the floor), with no cell
/// crossed and nothing from the generated balls, which are
/// far from every wall and boundary; 15 bounces on the 1e20 m by 50 m field (its generated balls
/// reach the floor and the ceiling); the tiny pair collides once and bounces 6,264 times on the
/// floor it starts half a radius above. Bounds: exactly 4 bounces and no crossing on the square
/// fields, at least 2 bounces on each, at least 1 collision in the tiny field.
#[test]
fn huge_fields_and_tiny_balls_run_through_events() {
    for (what, text) in scenes() {
        let scene = parse(what, &text);
        let (width, height) = (scene.field.width, scene.field.height);
        let n = scene.balls.len();
        let mut engine = engine::start(EngineKind::Exact, &scene, None).unwrap_or_else(|e| panic!("{what}: {e}"));
        engine.advance_steps(2000);
        let mut balls = Vec::new();
        engine.sample(&mut balls);
        assert_eq!(balls.len(), n, "{what}");
        check_inside(what, &balls, width, height);
        let stats = engine.figures().exact.expect("the exact engine's figures");
        eprintln!("{what}: {:?}", stats.counters);
        assert!(stats.counters.wall_bounces >= 2, "{what}: {} wall bounces", stats.counters.wall_bounces);
        if what.contains("1 m balls") && !what.contains("by") {
            assert_eq!((stats.counters.wall_bounces, stats.counters.cell_crossings), (4, 0), "{what}");
        }
        if what.contains("µm") {
            assert!(stats.counters.collisions >= 1, "{what}: {} collisions", stats.counters.collisions);
        }
    }
}

/// The same scenes from a file on the command line, with the end state written and read back.
#[test]
fn huge_fields_on_the_command_line() {
    let dir = std::env::temp_dir().join(format!("ballfield-exact-fields-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (k, (what, text)) in scenes().into_iter().enumerate() {
        let scene = parse(what, &text);
        let (file, state) = (dir.join(format!("scene-{k}.toml")), dir.join(format!("state-{k}.csv")));
        std::fs::write(&file, &text).unwrap();
        let (f, s) = (file.display().to_string(), state.display().to_string());
        let args = ["headless", "--engine", "exact", "--scene", &f, "--steps", "2000", "--state-out", &s, "--quiet"];
        let out = Command::new(env!("CARGO_BIN_EXE_ballfield")).args(args).env_remove("RUST_LOG").output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{what}: `ballfield {}` failed:\n{stderr}", args.join(" "));
        let balls = read_state(&state, &scene.field).unwrap_or_else(|e| panic!("{what}: {e}"));
        assert_eq!(balls.len(), scene.balls.len(), "{what}");
        check_inside(what, &balls, scene.field.width, scene.field.height);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
