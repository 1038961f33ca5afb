//! Golden-image tests of the offscreen renderer: fixed lockstep scenes are drawn through the same
//! `Renderer::render` path as the window and compared with the PNGs in `tests/golden/`; and the
//! window's whole frame, field and panel, drawn through the window's own panel code.
//!
//! They run for real on a CPU adapter (Mesa's llvmpipe or lavapipe, see ci-notes.md). With the
//! environment variable `CI` set, a missing adapter is a failure; elsewhere the tests say loudly
//! that they skipped. `BALLFIELD_BLESS=1 cargo test --release --test render` rewrites the goldens.
//!
//! **Tolerance.** Repeat renders on one backend are bit-identical, but Vulkan (lavapipe) and GL
//! (llvmpipe) round a few anti-aliased edge pixels differently by a level. So two channel values
//! count as equal when they differ by at most [`CHANNEL_TOLERANCE`] levels (of 255), and a frame
//! matches when at most [`MAX_DIFFERING_PIXELS`] pixels have a channel beyond that: an absolute
//! count, not a share of the frame, so that one small ball wrong fails however large the frame
//! is. `fault_*` below prove it: one ball moved by its diameter, removed, made larger or given
//! the nearest other colour of the palette fails, for the cradle's flying ball (2 m, 20 px
//! across) and for a ball of about 2 px, the smallest in any golden. On a mismatch the test
//! writes `NAME.actual.png` and `NAME.diff.png` (differing pixels in red over a dimmed copy of
//! the golden) to the target's temp directory and prints their paths. Every comparison prints its
//! score (`cargo test --release --test render -- --nocapture` shows them).

use std::path::{Path, PathBuf};

use ballfield::EngineKind;
use ballfield::app::{EnergySample, PANEL_WIDTH, PanelPainter, Readouts, Settings, run_ui};
use ballfield::physics::{Ball, BallId, BallKind, Field};
use ballfield::render::{
    BallPath, BallSprite, BallStyle, FrameBalls, FrameSnapshot, Layout, Offscreen, OffscreenRenderer, RenderError,
    SPLAT_MAX_RADIUS_PX, SPLAT_MIN_BALLS, ball_colour, palette, with_style,
};
use ballfield::{Lockstep, scenes};
use glam::DVec2;

/// A channel value differs when it is more than this many levels from the golden's. Vulkan and
/// GL differ by at most 1.
const CHANNEL_TOLERANCE: u8 = 2;
/// A frame matches the golden when at most this many of its pixels differ. Every correct frame
/// scores 0, on Vulkan (lavapipe) and on GL (llvmpipe) alike; the mildest faults
/// (`fault_in_a_two_pixel_ball_fails`: the 2 px ball missing, 20% larger or recoloured) score 7.
/// The limit is below half of that: some room for another driver's rounding, none for a ball.
const MAX_DIFFERING_PIXELS: usize = 3;

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

fn golden(name: &str) -> image::RgbaImage {
    let path = golden_dir().join(format!("{name}.png"));
    image::open(&path).unwrap_or_else(|e| panic!("{}: {e} (BALLFIELD_BLESS=1 writes it)", path.display())).to_rgba8()
}

/// How far a frame is from its golden.
struct Score {
    /// Pixels with a channel more than [`CHANNEL_TOLERANCE`] levels off.
    differing: usize,
    /// The largest difference of any channel, levels.
    worst: u8,
    /// Mean absolute difference over all channels, levels.
    mean: f64,
    /// The differing pixels in red over a dimmed copy of the golden.
    diff: image::RgbaImage,
}

impl Score {
    fn of(golden: &image::RgbaImage, actual: &image::RgbaImage) -> Score {
        assert_eq!(golden.dimensions(), actual.dimensions(), "the frame's size differs from the golden's");
        let mut differing = 0usize;
        let mut worst = 0u8;
        let mut total_error = 0u64;
        let mut diff = image::RgbaImage::new(golden.width(), golden.height());
        for ((g, a), d) in golden.pixels().zip(actual.pixels()).zip(diff.pixels_mut()) {
            let mut pixel_worst = 0u8;
            for c in 0..4 {
                let e = g[c].abs_diff(a[c]);
                total_error += e as u64;
                pixel_worst = pixel_worst.max(e);
            }
            worst = worst.max(pixel_worst);
            *d = if pixel_worst > CHANNEL_TOLERANCE {
                differing += 1;
                image::Rgba([255, 0, 0, 255])
            } else {
                image::Rgba([g[0] / 3, g[1] / 3, g[2] / 3, 255])
            };
        }
        let mean = total_error as f64 / (golden.width() as f64 * golden.height() as f64 * 4.0);
        Score { differing, worst, mean, diff }
    }

    fn matches(&self) -> bool {
        self.differing <= MAX_DIFFERING_PIXELS
    }

    fn describe(&self) -> String {
        format!(
            "{} pixels differ by more than {CHANNEL_TOLERANCE} levels (limit {MAX_DIFFERING_PIXELS}), \
             largest difference {} levels, mean {:.4} levels",
            self.differing, self.worst, self.mean
        )
    }
}

fn compare(name: &str, actual: &image::RgbaImage) {
    compare_as(name, name, actual)
}

/// Compares `actual`, reported as `name`, with the golden `golden`; blessing writes the golden
/// only from the frame named as it is.
fn compare_as(name: &str, golden_name: &str, actual: &image::RgbaImage) {
    let golden_path = golden_dir().join(format!("{golden_name}.png"));
    if std::env::var_os("BALLFIELD_BLESS").is_some() && name == golden_name {
        actual.save(&golden_path).unwrap();
        eprintln!("blessed {}", golden_path.display());
        return;
    }
    let score = Score::of(&golden(golden_name), actual);
    eprintln!("{name}: {}", score.describe());
    if !score.matches() {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("render");
        std::fs::create_dir_all(&dir).unwrap();
        let actual_path = dir.join(format!("{name}.actual.png"));
        let diff_path = dir.join(format!("{name}.diff.png"));
        actual.save(&actual_path).unwrap();
        score.diff.save(&diff_path).unwrap();
        panic!(
            "{name}: {}\n  golden: {}\n  actual: {}\n  diff:   {}",
            score.describe(),
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

/// The balls of `tests/golden/NAME.csv` and the field of `scene`.
///
/// The goldens of whole scenes draw fixed states, written once by the lockstep engine
/// (`ballfield headless --scene SCENE --steps N --engine lockstep --state-out NAME.csv`): the
/// tests check the drawing, and a change to the physics, which moves a ball by a fraction of a
/// pixel, does not fail them.
fn state(name: &str, scene: &str) -> (Field, Vec<Ball>) {
    let path = golden_dir().join(format!("{name}.csv"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let balls = text
        .lines()
        .skip(1)
        .map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            assert_eq!(f.len(), 8, "{}: {line}", path.display());
            let n = |k: usize| f[k].parse::<f64>().unwrap_or_else(|e| panic!("{}: {line}: {e}", path.display()));
            let kind = if f[1] == "key" { BallKind::Key } else { BallKind::Ball };
            Ball {
                id: BallId(f[0].parse().unwrap()),
                kind,
                position: DVec2::new(n(2), n(3)),
                velocity: DVec2::new(n(4), n(5)),
                mass: n(6),
                diameter: n(7),
            }
        })
        .collect();
    (scenes::resolve(scene).unwrap().field, balls)
}

/// Newton's cradle, 2 s in (2,000 steps): the striker has stopped at the row and the last ball
/// flies off.
fn cradle() -> (FrameSnapshot, Vec<Ball>) {
    let (field, balls) = state("cradle", "cradle");
    let mut snapshot = FrameSnapshot::default();
    snapshot.fill(field, &balls);
    (snapshot, balls)
}

#[test]
fn cradle_at_default_size() {
    let Some(mut out) = renderer(720, 520) else { return };
    let (snapshot, balls) = cradle();
    let image = out.render_image(&snapshot).unwrap();
    // Direct checks besides the golden: the corner outside the walls has the letterbox's colour,
    // the field its own, and the centre of the flying ball (id 5, a plain ball, unshaded but
    // within 1.5 px of its edge) is the palette's last colour, as the id hash picks it. Seen to
    // fail by drawing every ball in the first palette colour (`% 1` for `% palette::BALLS.len()`
    // in `ball_colour`).
    let rgb = |c: u32| [c & 255, (c >> 8) & 255, (c >> 16) & 255].map(|v| v as u8);
    let near = |p: &image::Rgba<u8>, want: [u8; 3]| (0..3).all(|c| p[c].abs_diff(want[c]) <= 1) && p[3] == 255;
    assert!(near(image.get_pixel(0, 0), rgb(palette::OUTSIDE_PACKED)), "corner {:?}", image.get_pixel(0, 0));
    let field = palette::FIELD_RGB.map(|c| (c * 255.0).round() as u8);
    assert!(near(image.get_pixel(360, 100), field), "field {:?}", image.get_pixel(360, 100));
    let flying = balls.iter().max_by(|a, b| a.velocity.length().total_cmp(&b.velocity.length())).unwrap();
    assert_eq!(flying.id, BallId(5));
    let centre = snapshot.layout(720, 520).to_pixels(flying.position);
    let pixel = image.get_pixel(centre.x as u32, centre.y as u32);
    assert!(near(pixel, [170, 120, 220]), "the flying ball's centre is {pixel:?}");
    compare("cradle", &image);
}

/// The default scene (key ball, 40 balls, gravity, drag) 1 s in (1,000 steps), letterboxed into
/// 16:9, with velocity vectors and the centre of mass drawn over it.
#[test]
fn default_scene_letterboxed_with_overlays() {
    let Some(mut out) = renderer(640, 360) else { return };
    let (field, balls) = state("default-letterboxed", "default");
    let mut snapshot = FrameSnapshot::default();
    snapshot.fill(field, &balls);
    snapshot.add_velocity_vectors(&balls, 0.25);
    snapshot.add_centre_of_mass(&balls);
    let image = out.render_image(&snapshot).unwrap();
    compare("default-letterboxed", &image);
}

/// A 500-ball gas, 0.3 s in (300 steps), in a square target (letterboxed above and below).
#[test]
fn gas_in_a_square() {
    let Some(mut out) = renderer(400, 400) else { return };
    let (field, balls) = state("gas-square", "gas");
    let mut snapshot = FrameSnapshot::default();
    snapshot.fill(field, &balls);
    let image = out.render_image(&snapshot).unwrap();
    compare("gas-square", &image);
}

/// Drawing only reads: rendering twice gives the same pixels, and the engine is untouched.
#[test]
fn rendering_is_repeatable_and_read_only() {
    let Some(mut out) = renderer(200, 150) else { return };
    let engine = lockstep_after("default", 10);
    let hash = engine.state_hash();
    let bodies = engine.bodies();
    let mut snapshot = FrameSnapshot::default();
    snapshot.fill(*engine.field(), (0..bodies.len()).map(|i| bodies.get(i)));
    let a = out.render_image(&snapshot).unwrap();
    let b = out.render_image(&snapshot).unwrap();
    assert_eq!(a, b);
    assert_eq!(engine.state_hash(), hash);
}

/// The frame of `many_small_balls`: 12,000 balls about 2 px across and 300 of 6 px scattered
/// over a 400 m × 225 m field (overlapping freely, some on the walls and corners), a small key
/// ball and a held one with their rings, then five 18 px balls and the overlays over them. The
/// balls are sprites, not engine balls: their order is the test's.
const TINY: usize = 12_000;
const LARGE: usize = 5;
fn small_balls() -> FrameSnapshot {
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
    for i in 0..TINY as u32 {
        snapshot.balls.push(ball(0.65, ball_colour(BallKind::Ball, i)));
    }
    for i in 0..300 {
        snapshot.balls.push(ball(2.0, ball_colour(BallKind::Ball, i)));
    }
    // On the walls and in the corners.
    for (x, y) in [(0.0, 0.0), (400.0, 225.0), (0.0, 100.0), (200.0, 225.0), (399.5, 0.3)] {
        snapshot.balls.push(BallSprite { x, y, radius: 2.0, colour: ball_colour(BallKind::Ball, 7) });
    }
    let held = with_style(ball_colour(BallKind::Ball, 3), BallStyle::Held);
    snapshot.balls.push(BallSprite { x: 150.0, y: 60.0, radius: 4.0, colour: held });
    snapshot.balls.push(BallSprite { x: 100.0, y: 100.0, radius: 4.0, colour: ball_colour(BallKind::Key, 0) });
    for i in 0..LARGE as u32 {
        snapshot.balls.push(ball(12.0, ball_colour(BallKind::Ball, i)));
    }
    snapshot.add_cross(DVec2::new(200.0, 112.5), 6.0, palette::CENTRE_OF_MASS);
    let arrow = Ball {
        id: BallId(0),
        kind: BallKind::Ball,
        position: DVec2::new(100.0, 100.0),
        velocity: DVec2::new(40.0, 30.0),
        mass: 1.0,
        diameter: 1.0,
    };
    snapshot.add_velocity_vectors([arrow], 0.5);
    snapshot
}

/// Many small balls, the way a large field looks fitted to a small target (see [`small_balls`]).
/// On a CPU adapter the default path splats the small balls (`BallPath::Auto`, see
/// src/render/splat.rs) and draws the large ones as triangles; the same frame drawn all as
/// triangles, and all splatted, must match the same golden.
#[test]
fn many_small_balls() {
    let Some(mut out) = renderer(640, 360) else { return };
    let snapshot = small_balls();
    let scale = snapshot.layout(640, 360).scale as f32;
    assert!(12.0 * scale > SPLAT_MAX_RADIUS_PX && 4.0 * scale <= SPLAT_MAX_RADIUS_PX, "scale {scale}");
    const { assert!(TINY + 300 > SPLAT_MIN_BALLS) };

    let n = snapshot.balls.len();
    let auto = out.render_image(&snapshot).unwrap();
    let cpu = out.gpu.adapter.get_info().device_type == wgpu::DeviceType::Cpu;
    let expected = if cpu {
        FrameBalls { splatted: n - LARGE, primitives: LARGE }
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

// ---- faults the comparison must catch ------------------------------------------------------

/// What can be wrong with one ball of a frame.
#[derive(Clone, Copy, Debug)]
enum Fault {
    /// Moved by its diameter along x, towards the middle of the field.
    Moved,
    Missing,
    /// 20% larger in radius.
    Resized,
    /// In the colour of the palette nearest its own.
    Recoloured,
}

const FAULTS: [Fault; 4] = [Fault::Moved, Fault::Missing, Fault::Resized, Fault::Recoloured];

/// `snapshot` with ball `i` wrong as `fault` says.
fn with_fault(snapshot: &FrameSnapshot, i: usize, fault: Fault) -> FrameSnapshot {
    let mut s = snapshot.clone();
    let field_middle = 0.5 * s.field.width as f32;
    let b = &mut s.balls[i];
    match fault {
        Fault::Moved => b.x += 2.0 * b.radius * if b.x < field_middle { 1.0 } else { -1.0 },
        Fault::Missing => {
            s.balls.remove(i);
        }
        Fault::Resized => b.radius *= 1.2,
        Fault::Recoloured => {
            let rgb = |c: u32| [c & 255, (c >> 8) & 255, (c >> 16) & 255];
            let own = rgb(b.colour);
            let distance = |c: &u32| (0..3).map(|k| rgb(*c)[k].abs_diff(own[k])).max().unwrap();
            let nearest = palette::BALLS.iter().filter(|c| distance(c) > 0).min_by_key(|c| distance(c)).unwrap();
            b.colour = (nearest & 0x00FF_FFFF) | (b.colour & 0xFF00_0000);
        }
    }
    s
}

/// Draws `snapshot` with each fault in ball `i` and expects each frame to fail against the
/// golden `name` (which the unchanged snapshot matches: its own test checks that).
fn expect_every_fault_to_fail(out: &mut OffscreenRenderer, name: &str, snapshot: &FrameSnapshot, i: usize) {
    let golden = golden(name);
    let mut passed = Vec::new();
    for fault in FAULTS {
        let image = out.render_image(&with_fault(snapshot, i, fault)).unwrap();
        let score = Score::of(&golden, &image);
        eprintln!("{name}, ball {i} {fault:?}: {}", score.describe());
        if score.matches() {
            passed.push(fault);
        }
    }
    assert!(passed.is_empty(), "{name}: the comparison lets these faults of ball {i} pass: {passed:?}");
}

/// The cradle's flying ball wrong in each way: every frame fails (they score 276–664 pixels,
/// with a mean error of 0.01–0.16 levels). A limit of 0.5% of the pixels (1,872 here) or of a
/// mean error of 0.25 levels lets all four pass: seen to fail with MAX_DIFFERING_PIXELS = 1,872.
#[test]
fn fault_in_the_cradle_flying_ball_fails() {
    let Some(mut out) = renderer(720, 520) else { return };
    let (snapshot, balls) = cradle();
    let flying = balls.iter().max_by(|a, b| a.velocity.length().total_cmp(&b.velocity.length())).unwrap();
    let i = snapshot.balls.iter().position(|s| *s == BallSprite::of(flying)).unwrap();
    expect_every_fault_to_fail(&mut out, "cradle", &snapshot, i);
}

/// The smallest balls of any golden, about 2 px across: one of them wrong in each way fails.
/// The ball is the last tiny one clear of every ball drawn after it, at its place and at its
/// moved place, so the fault shows. The faults score 7 pixels (missing, resized, recoloured) and
/// 12 (moved), splatted or drawn as triangles alike. Seen to fail by setting
/// MAX_DIFFERING_PIXELS to 7, and, separately, by making `Fault::Resized` a no-op.
#[test]
fn fault_in_a_two_pixel_ball_fails() {
    let Some(mut out) = renderer(640, 360) else { return };
    let snapshot = small_balls();
    let scale = snapshot.layout(640, 360).scale as f32;
    let clear = |i: usize| {
        let b = snapshot.balls[i];
        let step = 2.0 * b.radius * if b.x < 200.0 { 1.0 } else { -1.0 };
        let reach = |o: &BallSprite| 1.25 * b.radius + o.radius + 2.0 / scale;
        let apart = |x: f32, o: &BallSprite| ((o.x - x).powi(2) + (o.y - b.y).powi(2)).sqrt() > reach(o);
        let margin = 3.0 * b.radius;
        let inside = b.x > margin && b.x < 400.0 - margin && b.y > margin && b.y < 225.0 - margin;
        inside && snapshot.balls[i + 1..].iter().all(|o| apart(b.x, o) && apart(b.x + step, o))
    };
    let i = (0..TINY).rev().find(|&i| clear(i)).expect("a tiny ball clear of the later ones");
    let diameter_px = 2.0 * snapshot.balls[i].radius * scale;
    assert!((1.5..2.5).contains(&diameter_px), "the ball is {diameter_px} px across");
    out.renderer.set_ball_path(BallPath::Auto);
    expect_every_fault_to_fail(&mut out, "small-balls", &snapshot, i);
    // The triangles draw it too, with the same result.
    out.renderer.set_ball_path(BallPath::Triangles);
    expect_every_fault_to_fail(&mut out, "small-balls", &snapshot, i);
}

// ---- the window's frame: field and panel ---------------------------------------------------

/// Fixed readouts for the panel's golden: what a window would show 20 s into the default scene,
/// with a made-up but smooth energy history (every number fixed, none measured, so the picture
/// is the same on every run and machine).
fn fixed_readouts() -> Readouts {
    let history = (0..200)
        .map(|k| {
            let t = k as f64 * 0.1;
            let kinetic = 900.0 + 300.0 * (0.7 * t).sin();
            let potential = 2400.0 - 300.0 * (0.7 * t).sin() - 2.0 * t;
            EnergySample { t, kinetic, potential, total: kinetic + potential, momentum: 40.0 + 10.0 * (0.3 * t).cos() }
        })
        .collect();
    Readouts {
        scene: "default — The original game: the key ball and a few dozen balls under gravity and air drag".into(),
        engine: Some(EngineKind::Lockstep),
        balls: 41,
        frame_rate: 66.0,
        frame_ms: 8.4,
        sim_rate: 1000.0,
        sim_rate_unit: "steps/s",
        paused: false,
        kinetic: 1234.5678,
        potential: 2345.6789,
        total: 3580.2467,
        momentum: [12.345, -6.789],
        pressure: 4.321,
        history,
        adapter: "llvmpipe (LLVM 15.0.6, 256 bits), Vulkan".into(),
        message: String::new(),
    }
}

fn default_settings() -> Settings {
    Settings {
        pull: 200.0,
        key_mass: 5.0,
        restitution: 0.9,
        time_scale: 1.0,
        gravity: true,
        drag: true,
        attraction: false,
        collisions: true,
        vectors: false,
        centre_of_mass: false,
        traces: false,
        scene: 0,
    }
}

/// The window's frame at its default size for the default scene, drawn offscreen through the
/// window's own code: `run_ui` lays out the panel (readouts, the energy plot, the sliders, the
/// toggles and buttons), the renderer draws the field into what the panel leaves, and
/// `PanelPainter` draws the panel over it. Three frames, the last compared: egui clips panels
/// on the first. The readouts are fixed ([`fixed_readouts`]), so the picture is too.
/// Seen to fail by swapping the plot's kinetic and total colours in src/app/panel.rs.
#[test]
fn window_frame_with_panel() {
    let scene = scenes::resolve("default").unwrap();
    let (w, h) = Layout::default_size(&scene.field);
    let (w, h) = (w + PANEL_WIDTH as u32, h.max(680));
    let Some(mut out) = renderer(w, h) else { return };
    let (field, balls) = state("default-letterboxed", "default");
    let mut snapshot = FrameSnapshot::default();
    snapshot.fill(field, &balls);

    let ctx = egui::Context::default();
    let painter = &mut PanelPainter::new(&out.gpu.device, out.renderer.format());
    let (readouts, settings) = (fixed_readouts(), default_settings());
    let mut image = None;
    for frame in 0..3 {
        let raw = egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(w as f32, h as f32))),
            // A second apart: any animation egui starts is over by the next frame.
            time: Some(frame as f64),
            max_texture_side: Some(out.gpu.device.limits().max_texture_dimension_2d as usize),
            ..Default::default()
        };
        let mut show_help = false;
        let ui = run_ui(&ctx, raw, &readouts, &settings, true, &mut show_help);
        assert!(ui.commands.is_empty(), "no input, yet the panel asked for {:?}", ui.commands);
        let panel_px = (ui.width_points * ui.output.pixels_per_point).ceil() as f64;
        assert_eq!(panel_px, PANEL_WIDTH as f64, "the panel's width");
        snapshot.viewport = Some([0.0, 0.0, w as f64 - panel_px, h as f64]);
        let (device, queue) = (&out.gpu.device, &out.gpu.queue);
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        out.renderer.encode(&mut encoder, out.target.view(), &snapshot);
        let output = ui.output;
        let extra = painter.encode(
            &ctx,
            device,
            queue,
            &mut encoder,
            out.target.view(),
            [w, h],
            output.shapes,
            &output.textures_delta,
            output.pixels_per_point,
        );
        queue.submit(extra.into_iter().chain([encoder.finish()]));
        painter.free(&output.textures_delta);
        image = Some(out.target.read(device, queue).unwrap());
    }
    compare("window-with-panel", &image.unwrap());
}
