// The splatted field's pixels (src/render/splat.rs), drawn as one opaque rectangle onto a target
// they cannot be copied into: a GL surface (its only usage is as a render target) or an sRGB one
// (the texture is then sRGB too: a load decodes what the target's write encodes again).

struct Blit {
    // the rectangle, pixels from the target's top-left corner: x, y, width, height
    rect: vec4<f32>,
    // size of the target, pixels
    target_size: vec2<f32>,
    _pad: vec2<f32>,
};

@group(0) @binding(0) var<uniform> blit: Blit;
@group(0) @binding(1) var pixels: texture_2d<f32>;

@vertex
fn vs_main(@builtin(vertex_index) vertex: u32) -> @builtin(position) vec4<f32> {
    // a strip of four corners: 0 (0,0), 1 (1,0), 2 (0,1), 3 (1,1)
    let corner = vec2<f32>(f32(vertex & 1u), f32(vertex >> 1u));
    let p = blit.rect.xy + corner * blit.rect.zw;
    return vec4<f32>(p.x / blit.target_size.x * 2.0 - 1.0, 1.0 - p.y / blit.target_size.y * 2.0, 0.0, 1.0);
}

@fragment
fn fs_main(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    return textureLoad(pixels, vec2<i32>(position.xy - blit.rect.xy), 0);
}
