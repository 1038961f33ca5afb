// Small balls splatted by a compute shader, then composited by one rectangle.
//
// A CPU rasteriser (Mesa's lavapipe and llvmpipe) pays about a microsecond per primitive for
// setup, binning and a fragment-shader call per 4×4 block, whatever the primitive's size: a
// 100,000-ball frame of one triangle (or one point) per ball took ~100 ms. Balls a few pixels
// across are drawn here instead, with no primitive each:
//
// 1. `splat` (compute, one invocation per ball): for every pixel of the ball's box, the same
//    coverage and colour as `fs_main` in balls.wgsl computes, added with atomics into an
//    accumulation buffer covering a rectangle of the target (premultiplied RGB and coverage in
//    8-bit fixed point, two 16-bit fields per u32). Integer addition commutes, so the result does
//    not depend on the order the invocations run in: frames are repeatable.
// 2. `vs_resolve` / `fs_resolve` (one rectangle): each pixel reads its sums and is blended over
//    the target with premultiplied alpha.
//
// Compositing by sums instead of drawing one ball over another: where the anti-aliased edges of
// two balls that do not overlap share a pixel, each covers its own part of it, and the sums are
// the exact mix (drawing them one over the other darkens such pixels, "conflation"). Where balls
// truly overlap, total coverage above 1 is normalised: the pixel shows their average colour
// rather than the one drawn last. Each 16-bit field holds up to 257 fully covering balls on one
// pixel; more would carry into the next field (balls of a physical field do not stack so).

struct Globals {
    // pixels per metre, and the pixel position of the field's origin (lower-left corner)
    scale: f32,
    srgb_target: u32,
    origin: vec2<f32>,
    // size of the target, pixels
    target_size: vec2<f32>,
    _pad: vec2<f32>,
};

struct Splat {
    // the accumulation rectangle: its top-left pixel and its size, pixels (top-left origin, y down)
    rect_min: vec2<i32>,
    rect_size: vec2<i32>,
    // balls in `balls`
    count: u32,
    // invocations in one row of the dispatch grid (a large count is dispatched in 2-D)
    row: u32,
    _pad: vec2<u32>,
};

// As `BallSprite` in src/render/snapshot.rs: centre and radius in metres, `0xSSBBGGRR`.
struct Ball {
    centre: vec2<f32>,
    radius: f32,
    colour: u32,
};

@group(0) @binding(0) var<uniform> globals: Globals;
@group(0) @binding(1) var<uniform> splat_params: Splat;
@group(0) @binding(2) var<storage, read> balls: array<Ball>;
@group(0) @binding(3) var<storage, read_write> sums: array<atomic<u32>>;

fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    let lo = c / 12.92;
    let hi = pow((c + 0.055) / 1.055, vec3<f32>(2.4));
    return select(hi, lo, c <= vec3<f32>(0.04045));
}

// The colour of a ball at distance `d` (pixels) from its centre: fs_main of balls.wgsl.
fn shade(rgb: vec3<f32>, style: u32, radius_px: f32, d: f32) -> vec3<f32> {
    if style != 0u {
        let width = max(1.5, radius_px * 0.22);
        let inner = radius_px - width;
        let ring = clamp(d - inner + 0.5, 0.0, 1.0);
        var ring_colour = vec3<f32>(1.0, 1.0, 1.0);
        if style == 2u {
            ring_colour = vec3<f32>(1.0, 0.85, 0.1);
        }
        return mix(rgb, ring_colour, ring);
    }
    let rim = clamp(d - (radius_px - 1.5) + 0.5, 0.0, 1.0);
    return rgb * (1.0 - 0.35 * rim);
}

@compute @workgroup_size(64)
fn splat(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * splat_params.row;
    if i >= splat_params.count {
        return;
    }
    let ball = balls[i];
    let radius_px = ball.radius * globals.scale;
    let from_bottom = globals.origin + ball.centre * globals.scale;
    // y of the field points up, y of the target points down
    let centre = vec2<f32>(from_bottom.x, globals.target_size.y - from_bottom.y);
    // pixels whose centre is within radius + ½ of the ball's centre have some coverage
    let reach = radius_px + 0.5;
    let lo = max(vec2<i32>(floor(centre - reach)), splat_params.rect_min);
    let hi = min(vec2<i32>(ceil(centre + reach)), splat_params.rect_min + splat_params.rect_size);
    var rgb = unpack4x8unorm(ball.colour).rgb;
    if globals.srgb_target != 0u {
        rgb = srgb_to_linear(rgb);
    }
    let style = ball.colour >> 24u;
    for (var y = lo.y; y < hi.y; y++) {
        let row = u32(y - splat_params.rect_min.y) * u32(splat_params.rect_size.x);
        for (var x = lo.x; x < hi.x; x++) {
            let d = length(vec2<f32>(f32(x) + 0.5, f32(y) + 0.5) - centre);
            let coverage = clamp(radius_px - d + 0.5, 0.0, 1.0);
            if coverage > 0.0 {
                let v = vec4<u32>(vec4<f32>(shade(rgb, style, radius_px, d) * coverage, coverage) * 255.0 + 0.5);
                let k = 2u * (row + u32(x - splat_params.rect_min.x));
                atomicAdd(&sums[k], v.r | (v.g << 16u));
                atomicAdd(&sums[k + 1u], v.b | (v.a << 16u));
            }
        }
    }
}

// The resolve reads the same buffer, read-only (a fragment shader may not write storage
// everywhere). Its own binding number: the two pipelines have their own bind group layouts.
@group(0) @binding(4) var<storage, read> sums_in: array<u32>;

@vertex
fn vs_resolve(@builtin(vertex_index) vertex: u32) -> @builtin(position) vec4<f32> {
    // two triangles over the rectangle: corners 0 1 2, 2 1 3
    let corner_index = array<u32, 6>(0u, 1u, 2u, 2u, 1u, 3u)[vertex];
    let corner = vec2<f32>(f32(corner_index & 1u), f32(corner_index >> 1u));
    let pixel = vec2<f32>(splat_params.rect_min) + corner * vec2<f32>(splat_params.rect_size);
    return vec4<f32>(pixel.x / globals.target_size.x * 2.0 - 1.0, 1.0 - pixel.y / globals.target_size.y * 2.0, 0.0, 1.0);
}

@fragment
fn fs_resolve(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let p = vec2<i32>(position.xy) - splat_params.rect_min;
    let k = 2u * (u32(p.y) * u32(splat_params.rect_size.x) + u32(p.x));
    let rg = sums_in[k];
    let ba = sums_in[k + 1u];
    let sum = vec4<f32>(vec4<u32>(rg & 0xFFFFu, rg >> 16u, ba & 0xFFFFu, ba >> 16u)) / 255.0;
    if sum.a <= 0.0 {
        // no ball here: leave the pixel alone
        discard;
    }
    // coverage above 1 (overlapping balls): their average colour, opaque
    return sum / max(sum.a, 1.0);
}
