//! Golden-image tests of the offscreen renderer: fixed lockstep scenes are drawn through the same
//! `Renderer::render` path as the window and compared with the PNGs in `tests/golden/`.
//!
//! They run for real on a CPU adapter (Mesa's llvmpipe or lavapipe, see ci-notes.md). With the
//! environment variable `CI` set, a missing adapter is a failure; elsewhere the tests say loudly
//! that they skipped. `BALLFIELD_BLESS=1 cargo test --release --test render` rewrites the goldens.
//!
//! **Tolerance.** Repeat renders on one backend are bit-identical, but Vulkan (lavapipe) and GL
//! (llvmpipe) round a few anti-aliased edge pixels differently by a level. So two channel values
//! count as equal when they differ by at most 2 levels (of 255), and a frame matches when at most
//! 0.5% of its pixels have a channel beyond that *and* the mean absolute difference over all
//! channels is below 0.25 levels. A misplaced ball (hundreds of pixels off by ~100 levels) fails
//! both. On a mismatch the test writes `NAME.actual.png` and `NAME.diff.png` (differing pixels in
//! red over a dimmed copy of the golden) to the target's temp directory and prints their paths.

use std::path::{Path, PathBuf};

use ballfield::Lockstep;
use ballfield::physics::{BallKind, Field};
use ballfield::render::{
    BallPath, BallSprite, BallStyle, FrameBalls, FrameSnapshot, Offscreen, OffscreenRenderer, RenderError,
    SPLAT_MAX_RADIUS_PX, SPLAT_MIN_BALLS, ball_colour, palette, with_style,
};
use ballfield::scenes;

const CHANNEL_TOLERANCE: u8 = 2;
const MAX_DIFFERING_PIXELS: f64 = 0.005;
const MAX_MEAN_ERROR: f64 = 0.25;

/// The offscreen renderer, or `None` (after a loud message) when this machine has no adapter and
/// we are not in CI.
fn renderer(width: u32, height: u32) -> Option<OffscreenRenderer> {
    match OffscreenRenderer::new(width, height) {
        Ok(r) => Some(r),
        Err(e @ RenderError::NoAdapter(_)) if std::env::var_os("CI").is_none() => {
            eprintln!("\n!!!!!!!! SKIPPED: {e}\n!!!!!!!! (in CI, with CI set, this is a failure)\n");
            None
        }
        Err(e) => panic!("cannot render offscreen: {e}"),
    }
}

fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

fn compare(name: &str, actual: &image::RgbaImage) {
    compare_as(name, name, actual)
}

/// Compares `actual`, reported as `name`, with the golden `golden`; blessing writes the golden
/// only from the frame named as it is.
fn compare_as(name: &str, golden: &str, actual: &image::RgbaImage) {
    let golden_path = golden_dir().join(format!("{golden}.png"));
    if std::env::var_os("BALLFIELD_BLESS").is_some() && name == golden {
        actual.save(&golden_path).unwrap();
        eprintln!("blessed {}", golden_path.display());
        return;
    }
    let golden = image::open(&golden_path)
        .unwrap_or_else(|e| panic!("{}: {e} (BALLFIELD_BLESS=1 writes it)", golden_path.display()))
        .to_rgba8();
    assert_eq!(golden.dimensions(), actual.dimensions(), "{name}: size differs from the golden");
    let mut differing = 0usize;
    let mut total_error = 0u64;
    let mut diff = image::RgbaImage::new(golden.width(), golden.height());
    for ((g, a), d) in golden.pixels().zip(actual.pixels()).zip(diff.pixels_mut()) {
        let mut worst = 0u8;
        for c in 0..4 {
            let e = g[c].abs_diff(a[c]);
            total_error += e as u64;
            worst = worst.max(e);
        }
        *d = if worst > CHANNEL_TOLERANCE {
            differing += 1;
            image::Rgba([255, 0, 0, 255])
        } else {
            image::Rgba([g[0] / 3, g[1] / 3, g[2] / 3, 255])
        };
    }
    let pixels = (golden.width() * golden.height()) as f64;
    let share = differing as f64 / pixels;
    let mean = total_error as f64 / (pixels * 4.0);
    if share > MAX_DIFFERING_PIXELS || mean > MAX_MEAN_ERROR {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("render");
        std::fs::create_dir_all(&dir).unwrap();
        let actual_path = dir.join(format!("{name}.actual.png"));
        let diff_path = dir.join(format!("{name}.diff.png"));
        actual.save(&actual_path).unwrap();
        diff.save(&diff_path).unwrap();
        panic!(
            "{name}: {differing} pixels ({:.3}%) differ by more than {CHANNEL_TOLERANCE} levels (limit {:.1}%), \
             mean error {mean:.3} levels (limit {MAX_MEAN_ERROR})\n  golden: {}\n  actual: {}\n  diff:   {}",
            share * 100.0,
            MAX_DIFFERING_PIXELS * 100.0,
            golden_path.display(),
            actual_path.display(),
            diff_path.display()
        );
    }
}

fn lockstep_after(scene: &str, steps: u64) -> Lockstep {
    let scene = scenes::resolve(scene).unwrap();
    let mut engine = Lockstep::new(&scene);
    engine.run(steps);
    engine
}

/// Newton's cradle, 2 s in: the striker has stopped at the row and the last ball flies off.
#[test]
fn cradle_at_default_size() {
    let Some(mut out) = renderer(720, 520) else { return };
    let engine = lockstep_after("cradle", 2000);
    let mut snapshot = FrameSnapshot::default();
    snapshot.fill_from_bodies(*engine.field(), engine.bodies());
    let image = out.render_image(&snapshot).unwrap();
    // A direct check besides the golden: the field's centre is field-coloured and the corner
    // outside the walls is not.
    assert_ne!(image.get_pixel(0, 0), image.get_pixel(360, 100));
    compare("cradle", &image);
}

/// The default scene (key ball, 40 balls, gravity, drag) 1 s in, letterboxed into 16:9, with
/// velocity vectors and the centre of mass drawn over it.
#[test]
fn default_scene_letterboxed_with_overlays() {
    let Some(mut out) = renderer(640, 360) else { return };
    let engine = lockstep_after("default", 1000);
    let b = engine.bodies();
    let mut snapshot = FrameSnapshot::default();
    snapshot.fill_from_bodies(*engine.field(), b);
    snapshot.add_velocity_vectors((0..b.len()).map(|i| (b.position[i], b.velocity[i])), 0.25);
    let total_mass: f64 = b.mass.iter().sum();
    let com = (0..b.len()).map(|i| b.position[i] * b.mass[i]).sum::<glam::DVec2>() / total_mass;
    snapshot.add_cross(com, 1.5, palette::CENTRE_OF_MASS);
    let image = out.render_image(&snapshot).unwrap();
    compare("default-letterboxed", &image);
}

/// A 500-ball gas, 0.3 s in, in a square target (letterboxed above and below).
#[test]
fn gas_in_a_square() {
    let Some(mut out) = renderer(400, 400) else { return };
    let engine = lockstep_after("gas", 300);
    let mut snapshot = FrameSnapshot::default();
    snapshot.fill_from_bodies(*engine.field(), engine.bodies());
    let image = out.render_image(&snapshot).unwrap();
    compare("gas-square", &image);
}

/// Drawing only reads: rendering twice gives the same pixels, and the engine is untouched.
#[test]
fn rendering_is_repeatable_and_read_only() {
    let Some(mut out) = renderer(200, 150) else { return };
    let engine = lockstep_after("default", 10);
    let hash = engine.state_hash();
    let mut snapshot = FrameSnapshot::default();
    snapshot.fill_from_bodies(*engine.field(), engine.bodies());
    let a = out.render_image(&snapshot).unwrap();
    let b = out.render_image(&snapshot).unwrap();
    assert_eq!(a, b);
    assert_eq!(engine.state_hash(), hash);
}

/// Many small balls, the way a large field looks fitted to a small target: 12,000 balls about
/// 2 px across and 300 of 6 px scattered over a 400 m × 225 m field (overlapping freely, some on
/// the walls and corners), a small key ball and a held one with their rings, then five 18 px
/// balls and the overlays over them. On a CPU adapter the default path splats the small balls
/// (`BallPath::Auto`, see src/render/splat.rs) and draws the large ones as triangles; the same
/// frame drawn all as triangles, and all splatted, must match the same golden.
#[test]
fn many_small_balls() {
    let Some(mut out) = renderer(640, 360) else { return };
    let field = Field { width: 400.0, height: 225.0, ..Field::default() };
    let mut snapshot = FrameSnapshot::new(field);
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = || {
        state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f32 / (1u64 << 53) as f32
    };
    let mut ball = |radius: f32, colour: u32| BallSprite {
        x: next() * field.width as f32,
        y: next() * field.height as f32,
        radius,
        colour,
    };
    let (tiny, small, large) = (12_000, 300, 5);
    for i in 0..tiny {
        snapshot.balls.push(ball(0.65, ball_colour(BallKind::Ball, i)));
    }
    for i in 0..small {
        snapshot.balls.push(ball(2.0, ball_colour(BallKind::Ball, i)));
    }
    // On the walls and in the corners.
    for (x, y) in [(0.0, 0.0), (400.0, 225.0), (0.0, 100.0), (200.0, 225.0), (399.5, 0.3)] {
        snapshot.balls.push(BallSprite { x, y, radius: 2.0, colour: ball_colour(BallKind::Ball, 7) });
    }
    let held = with_style(ball_colour(BallKind::Ball, 3), BallStyle::Held);
    snapshot.balls.push(BallSprite { x: 150.0, y: 60.0, radius: 4.0, colour: held });
    snapshot.balls.push(BallSprite { x: 100.0, y: 100.0, radius: 4.0, colour: ball_colour(BallKind::Key, 0) });
    for i in 0..large {
        snapshot.balls.push(ball(12.0, ball_colour(BallKind::Ball, i)));
    }
    snapshot.add_cross(glam::DVec2::new(200.0, 112.5), 6.0, palette::CENTRE_OF_MASS);
    snapshot.add_velocity_vectors([(glam::DVec2::new(100.0, 100.0), glam::DVec2::new(40.0, 30.0))], 0.5);
    let scale = snapshot.layout(640, 360).scale as f32;
    assert!(12.0 * scale > SPLAT_MAX_RADIUS_PX && 4.0 * scale <= SPLAT_MAX_RADIUS_PX, "scale {scale}");
    assert!(tiny + small > SPLAT_MIN_BALLS as u32);

    let n = snapshot.balls.len();
    let auto = out.render_image(&snapshot).unwrap();
    let cpu = out.gpu.adapter.get_info().device_type == wgpu::DeviceType::Cpu;
    let expected = if cpu {
        FrameBalls { splatted: n - large as usize, primitives: large as usize }
    } else {
        FrameBalls { splatted: 0, primitives: n }
    };
    assert_eq!(out.renderer.last_frame(), expected, "adapter {}", out.gpu.describe());
    compare("small-balls", &auto);

    out.renderer.set_ball_path(BallPath::Splat);
    let splat = out.render_image(&snapshot).unwrap();
    assert_eq!(out.renderer.last_frame(), FrameBalls { splatted: n, primitives: 0 });
    compare_as("small-balls-all-splatted", "small-balls", &splat);

    out.renderer.set_ball_path(BallPath::Triangles);
    let triangles = out.render_image(&snapshot).unwrap();
    assert_eq!(out.renderer.last_frame(), FrameBalls { splatted: 0, primitives: n });
    compare_as("small-balls-as-triangles", "small-balls", &triangles);

    // The splat is repeatable too.
    out.renderer.set_ball_path(BallPath::Auto);
    assert_eq!(out.render_image(&snapshot).unwrap(), auto);

    // Onto a target that cannot be copied into (as a GL window's surface): the splatted pixels
    // are drawn as one textured rectangle instead, the very same pixels.
    out.target = Offscreen::draw_only(&out.gpu.device, 640, 360).unwrap();
    let drawn = out.render_image(&snapshot).unwrap();
    assert_eq!(out.renderer.last_frame(), expected);
    assert!(drawn == auto, "drawn onto the target, the frame differs from the one copied into it");
}
