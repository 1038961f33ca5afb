// Balls as anti-aliased discs (signed distance, one pixel of edge ramp).
//
// One ball is one quad of four vertices. The same shader serves both ways of feeding it:
// - instanced: a triangle strip of 4 vertices per instance, the ball's data stepping per instance;
// - expanded: one non-instanced indexed draw, the ball's data repeated on its 4 vertices.
// Either way the corner is `vertex_index & 3`, so both paths draw exactly the same pixels.

struct Globals {
    // pixels per metre, and the pixel position of the field's origin (lower-left corner)
    scale: f32,
    srgb_target: u32,
    origin: vec2<f32>,
    // size of the target, pixels
    target_size: vec2<f32>,
    _pad: vec2<f32>,
};

@group(0) @binding(0) var<uniform> globals: Globals;

struct BallIn {
    // centre (m) and radius (m)
    @location(0) centre_radius: vec3<f32>,
    // RGB in sRGB, and the style in the top byte: 0 plain, 1 ringed (the key ball), 2 highlighted
    @location(1) colour: u32,
    @builtin(vertex_index) vertex: u32,
};

struct VertexOut {
    @builtin(position) position: vec4<f32>,
    // offset from the centre, pixels
    @location(0) local: vec2<f32>,
    // RGB (in the target's encoding) and the radius in pixels. Few interpolants: a CPU
    // rasteriser sets up every one of them for every triangle.
    @location(1) @interpolate(flat) colour_radius: vec4<f32>,
    @location(2) @interpolate(flat) style: u32,
};

fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    let lo = c / 12.92;
    let hi = pow((c + 0.055) / 1.055, vec3<f32>(2.4));
    return select(hi, lo, c <= vec3<f32>(0.04045));
}

@vertex
fn vs_main(in: BallIn) -> VertexOut {
    let corner_index = in.vertex & 3u;
    // 0 (-1,-1), 1 (1,-1), 2 (-1,1), 3 (1,1): a strip, and the two triangles 0-1-2, 2-1-3
    let corner = vec2<f32>(f32(corner_index & 1u) * 2.0 - 1.0, f32(corner_index >> 1u) * 2.0 - 1.0);
    return ball_vertex(in, corner);
}

// One triangle per ball: the equilateral triangle around the disc (its corners at twice the
// radius from the centre). Half the triangles of a quad, for ~30% more pixels.
@vertex
fn vs_triangle(in: BallIn) -> VertexOut {
    let k = in.vertex % 3u;
    var corner = vec2<f32>(0.0, 2.0);
    if k == 1u {
        corner = vec2<f32>(-1.7320508, -1.0);
    } else if k == 2u {
        corner = vec2<f32>(1.7320508, -1.0);
    }
    return ball_vertex(in, corner);
}

fn ball_vertex(in: BallIn, corner: vec2<f32>) -> VertexOut {
    let radius_px = in.centre_radius.z * globals.scale;
    // one pixel beyond the edge, for the anti-aliasing ramp
    let half = radius_px + 1.0;
    let centre_px = globals.origin + in.centre_radius.xy * globals.scale;
    // y of the field points up, y of the target points down
    let pixel = vec2<f32>(centre_px.x + corner.x * half, globals.target_size.y - (centre_px.y + corner.y * half));
    var out: VertexOut;
    out.position = vec4<f32>(pixel.x / globals.target_size.x * 2.0 - 1.0, 1.0 - pixel.y / globals.target_size.y * 2.0, 0.0, 1.0);
    out.local = corner * half;
    let unpacked = unpack4x8unorm(in.colour);
    var rgb = unpacked.rgb;
    if globals.srgb_target != 0u {
        rgb = srgb_to_linear(rgb);
    }
    out.colour_radius = vec4<f32>(rgb, radius_px);
    out.style = in.colour >> 24u;
    return out;
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    let radius_px = in.colour_radius.w;
    let d = length(in.local);
    // coverage of the pixel by the disc: 1 inside, 0 outside, linear across one pixel at the edge
    let coverage = clamp(radius_px - d + 0.5, 0.0, 1.0);
    if coverage <= 0.0 {
        // outside the disc (the quad's or triangle's corners): no blend, no write
        discard;
    }
    var rgb = in.colour_radius.rgb;
    if in.style != 0u {
        // a white ring just inside the edge (the key ball; or a highlighted, grabbed ball)
        let width = max(1.5, radius_px * 0.22);
        let inner = radius_px - width;
        let ring = clamp(d - inner + 0.5, 0.0, 1.0);
        var ring_colour = vec3<f32>(1.0, 1.0, 1.0);
        if in.style == 2u {
            ring_colour = vec3<f32>(1.0, 0.85, 0.1);
        }
        rgb = mix(rgb, ring_colour, ring);
    } else {
        // a slightly darker rim so touching balls stay apart
        let rim = clamp(d - (radius_px - 1.5) + 0.5, 0.0, 1.0);
        rgb = rgb * (1.0 - 0.35 * rim);
    }
    // premultiplied alpha
    return vec4<f32>(rgb * coverage, coverage);
}
