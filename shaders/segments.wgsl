// Thick line segments with square ends: the field, its walls and the overlays
// (velocity vectors, traces, the centre of mass). Instanced, 4 vertices per segment.

struct Globals {
    scale: f32,
    srgb_target: u32,
    origin: vec2<f32>,
    target_size: vec2<f32>,
    _pad: vec2<f32>,
};

@group(0) @binding(0) var<uniform> globals: Globals;

struct SegmentIn {
    // the two ends, m
    @location(0) ends: vec4<f32>,
    // half the thickness: x in metres, y in pixels (they add up)
    @location(1) half_width: vec2<f32>,
    // RGBA in sRGB (alpha straight)
    @location(2) colour: u32,
    @builtin(vertex_index) vertex: u32,
};

struct VertexOut {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) colour: vec4<f32>,
};

fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    let lo = c / 12.92;
    let hi = pow((c + 0.055) / 1.055, vec3<f32>(2.4));
    return select(hi, lo, c <= vec3<f32>(0.04045));
}

@vertex
fn vs_main(in: SegmentIn) -> VertexOut {
    let corner_index = in.vertex & 3u;
    let along = f32(corner_index & 1u);
    let side = f32(corner_index >> 1u) * 2.0 - 1.0;
    let a = globals.origin + in.ends.xy * globals.scale;
    let b = globals.origin + in.ends.zw * globals.scale;
    let half = in.half_width.x * globals.scale + in.half_width.y;
    var dir = b - a;
    let len = length(dir);
    if len < 1e-6 {
        dir = vec2<f32>(1.0, 0.0);
    } else {
        dir = dir / len;
    }
    let normal = vec2<f32>(-dir.y, dir.x);
    // square caps: both ends extended by the pixel part of the half width only, so that a band
    // with a metric half width (the field) ends exactly at its ends
    let cap = in.half_width.y;
    let p = mix(a - dir * cap, b + dir * cap, along) + normal * side * half;
    let pixel = vec2<f32>(p.x, globals.target_size.y - p.y);
    var out: VertexOut;
    out.position = vec4<f32>(pixel.x / globals.target_size.x * 2.0 - 1.0, 1.0 - pixel.y / globals.target_size.y * 2.0, 0.0, 1.0);
    let c = unpack4x8unorm(in.colour);
    var rgb = c.rgb;
    if globals.srgb_target != 0u {
        rgb = srgb_to_linear(rgb);
    }
    out.colour = vec4<f32>(rgb * c.a, c.a);
    return out;
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    return in.colour;
}
