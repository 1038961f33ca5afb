//! Criterion bench of one offscreen frame: `Renderer::render` into a 1280×720 texture and a wait
//! for the GPU to finish it (no readback, no PNG write), at 1,000, 10,000 and 100,000 balls.
//!
//! On machines without a GPU the adapter is Mesa's CPU rasteriser (lavapipe with Vulkan installed,
//! else llvmpipe through GL; `WGPU_BACKEND=gl|vulkan` picks one). The targets there: ≤ 20 ms
//! for 10,000 balls, and a 100,000-ball frame (in the 1,585 m × 991 m field of the scale benches,
//! 2 m balls about 1.6 px across) within the window's 15 ms cadence. Every way of drawing the
//! balls is measured (see `BallPath`): `auto` (the default: on a CPU adapter, balls of at most
//! 16 px radius splatted, larger ones as triangles), `splat` (all splatted), `triangles` (one
//! triangle per ball), `expanded` (4 vertices and 6 indices per ball) and `instanced` (one
//! 4-vertex instance per ball).
//!
//! The balls are the same in every run: a field of 70 m × 50 m filled by a fixed-seed LCG,
//! diameter 1 m for 1,000 balls (7 px radius) and 0.5 m for 10,000 (3.5 px; about a third of the
//! field covered in both); 100,000 balls: see above. The key ball is among them. Velocity vectors
//! are off (the window's default).

use std::hint::black_box;

use ballfield::physics::{BallKind, Field};
use ballfield::render::{BallPath, BallSprite, FrameSnapshot, OffscreenRenderer, ball_colour};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};

fn snapshot(n: usize) -> FrameSnapshot {
    // 100,000 balls: the scale benches' field (2 m balls covering 20 %), drawn whole.
    let (field, diameter) = match n {
        0..=1_000 => (Field::default(), 1.0),
        1_001..=10_000 => (Field::default(), 0.5),
        _ => (Field { width: 1585.3, height: 990.8, ..Field::default() }, 2.0),
    };
    let r = 0.5 * diameter as f32;
    let mut state: u64 = 0x2545_F491_4F6C_DD1D;
    let mut next = || {
        state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut snapshot = FrameSnapshot::new(field);
    snapshot.balls = (0..n)
        .map(|i| {
            let kind = if i == n - 1 { BallKind::Key } else { BallKind::Ball };
            BallSprite {
                x: r + (next() * (field.width - diameter)) as f32,
                y: r + (next() * (field.height - diameter)) as f32,
                radius: if kind == BallKind::Key { 1.0 } else { r },
                colour: ball_colour(kind, i as u32),
            }
        })
        .collect();
    snapshot
}

fn frame(c: &mut Criterion) {
    let mut out = match OffscreenRenderer::new(1280, 720) {
        Ok(out) => out,
        Err(e) => {
            eprintln!("render bench skipped: {e}");
            return;
        }
    };
    eprintln!("adapter: {}", out.gpu.describe());
    let mut group = c.benchmark_group("frame_1280x720");
    group.sample_size(30);
    // The field alone: the fixed cost of a frame (clear, walls, letterbox, submit, wait).
    let empty = snapshot(0);
    group.bench_function("empty", |b| b.iter(|| out.render(black_box(&empty)).unwrap()));
    for n in [1_000usize, 10_000, 100_000] {
        let snap = snapshot(n);
        group.throughput(Throughput::Elements(n as u64));
        for (name, path) in [
            ("auto", BallPath::Auto),
            ("splat", BallPath::Splat),
            ("triangles", BallPath::Triangles),
            ("expanded", BallPath::Expanded),
            ("instanced", BallPath::Instanced),
        ] {
            out.renderer.set_ball_path(path);
            group.bench_with_input(BenchmarkId::new(name, n), &snap, |b, snap| {
                b.iter(|| out.render(black_box(snap)).unwrap())
            });
        }
    }
    group.finish();
}

criterion_group!(benches, frame);
criterion_main!(benches);
