// Draws the trace's output over the editor's viewport rectangle, or over each panel of the
// comparison grid: one triangle covering the render pass's viewport (set per panel, the panel
// being the instance), each fragment reading its pixel from the storage buffers the trace
// wrote (viewport.rs). Shaded: the packed sRGB8 colour (main.wgsl). Heat map: the step count
// on the shared scale whose top step_statistics.wgsl computed, log or linear (core frame.rs
// StepScale). No copy, no texture, nothing read back.

struct Blit {
    width: u32,         // pixels of one panel
    height: u32,
    panels: u32,        // side by side in the output buffers
    mode: u32,          // 0: shaded colour, 1: heat map on a log scale, 2: on a linear scale
    srgb_target: u32,   // 1: the target format encodes sRGB itself, so write linear values
    pad0: u32,
    pad1: u32,
    pad2: u32,
};

@group(0) @binding(0) var<uniform> blit: Blit;
@group(0) @binding(1) var<storage, read> colour: array<u32>;
@group(0) @binding(2) var<storage, read> steps: array<u32>;
@group(0) @binding(3) var<storage, read> top: array<u32>;

struct VertexOut {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) @interpolate(flat) panel: u32,
};

@vertex
fn vs_main(@builtin(vertex_index) index: u32, @builtin(instance_index) panel: u32) -> VertexOut {
    // (0, 0), (2, 0), (0, 2): one triangle over the whole viewport.
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    var out: VertexOut;
    out.position = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0);
    out.uv = uv;
    out.panel = panel;
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
    let i = (y * blit.panels + in.panel) * blit.width + x;
    var c: vec3<f32>;
    if blit.mode == 0u {
        c = unpack4x8unorm(colour[i]).rgb;
    } else {
        let s = f32(steps[i]);
        let t = f32(max(top[0], 1u));
        var position = s / t;
        if blit.mode == 1u {
            position = log(1.0 + s) / log(1.0 + t);
        }
        c = heat_colour(position);
    }
    if blit.srgb_target == 1u {
        return vec4<f32>(linear_from_srgb(c), 1.0);
    }
    return vec4<f32>(c, 1.0);
}
