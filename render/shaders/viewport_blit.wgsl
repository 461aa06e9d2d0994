// Draws the trace's colour output (packed sRGB8 per pixel, row-major; main.wgsl) over the
// editor's viewport rectangle: one triangle covering the render pass's viewport, each fragment
// reading its pixel from the storage buffer the trace wrote (viewport.rs). No copy, no texture.

struct Blit {
    width: u32,
    height: u32,
    srgb_target: u32,   // 1: the target format encodes sRGB itself, so write linear values
    pad: u32,
};

@group(0) @binding(0) var<uniform> blit: Blit;
@group(0) @binding(1) var<storage, read> colour: array<u32>;

struct VertexOut {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
};

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> VertexOut {
    // (0, 0), (2, 0), (0, 2): one triangle over the whole viewport.
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    var out: VertexOut;
    out.position = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0);
    out.uv = uv;
    return out;
}

fn linear_from_srgb(c: vec3<f32>) -> vec3<f32> {
    let low = c / 12.92;
    let high = pow((c + vec3<f32>(0.055)) / 1.055, vec3<f32>(2.4));
    return select(high, low, c <= vec3<f32>(0.04045));
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    let x = min(u32(in.uv.x * f32(blit.width)), blit.width - 1u);
    let y = min(u32(in.uv.y * f32(blit.height)), blit.height - 1u);
    let c = unpack4x8unorm(colour[y * blit.width + x]).rgb;
    if blit.srgb_target == 1u {
        return vec4<f32>(linear_from_srgb(c), 1.0);
    }
    return vec4<f32>(c, 1.0);
}
