// The scene as the host uploads it (render/src/buffers.rs, gpu_renderer/mod.rs): every struct
// names its Rust twin; the bindings every compute shader shares. f32 throughout.

// Twin of `GpuGlobals` (gpu_renderer/mod.rs): the frame's camera, scene counts, trace settings and
// view, one named field each.
struct Globals {
    origin: vec3<f32>,          // eye
    far: f32,                   // length of the primary rays
    forward: vec3<f32>,
    tan_half_fov: f32,
    right: vec3<f32>,
    aspect: f32,
    up: vec3<f32>,
    isovalue: f32,
    width: u32,                 // of one panel
    height: u32,
    tiles_x: u32,
    tiles_y: u32,
    primitive_count: u32,
    group_count: u32,
    max_steps: u32,
    epsilon: f32,
    min_step: f32,
    growth: f32,
    initial_interval: f32,
    lipschitz: f32,             // global Lipschitz bound (sphere tracing)
    gauss_sigma: f32,           // field inversion: σ, smallest radius ρ, normalisation N0
    gauss_radius: f32,
    gauss_norm: f32,
    tile_size: u32,             // pixels
    light_count: u32,
    panel_x: u32,               // x offset of this method's panel in the output
    output_width: u32,
    heat_max: f32,              // top of the step scale
    heat_view: u32,             // 0 shaded, 1 step heat map
    shading_flags: u32,         // 1 soft shadows, 2 ambient occlusion
    shading_scale: f32,
    steps_per_dispatch: u32,    // of a marching method (parts.wgsl)
    secondary: u32,             // SECONDARY_*: the frame's secondary rays (main.wgsl trace_path)
    stats_crossings: u32,       // transparent statistics: crossing slots per ray (main.wgsl trace_rays); 0 elsewhere
    bvh_unbounded: u32,         // bvh_items[bvh_unbounded..bvh_items]: the unbounded primitives
    bvh_items: u32,
    band_near: f32,             // the tile lists' depth bands (binning.wgsl band_list)
    band_width: f32,
    list_bands: u32,            // lists per tile in tile_ranges: DEPTH_BANDS, 1 for statistics rays
    loop_probe: u32,            // 2: the iterations of main.wgsl note_loop_limit's probe
};

// Twin of `GpuPrimitive`. kind: KIND_*.
struct Primitive {
    kind: u32,
    group: u32,
    occluder: f32,     // radius of a ball inside the surface (0: none; buffers.rs occluder_radius)
    extra: u32,        // HRBF term: its set's box in `boxes`
    a: vec4<f32>,      // point: centre, radius | segment: start (smaller radius), radius | plane: normal, offset | shape: centre, radius | HRBF: centre, α
    b: vec4<f32>,      // segment: axis, length | plane: radius | shape: dimensions (buffers.rs solid_dimensions) | HRBF: β, constant
    c: vec4<f32>,      // x: normalisation | segment: y radius slope | shape: yzw local y axis | HRBF: linear part
    d: vec4<f32>,      // shape, HRBF box: local x axis, w handedness
    bound: vec4<f32>,  // bounding sphere of the support; w < 0: unbounded
};

// A segment's sphere-cone (segment.rs, scalis.rs), unpacked from its `Primitive`: the start
// (smaller radius) end, the unit axis, the length, the radius at the start and its growth per
// unit length.
struct Cone {
    start: vec3<f32>,
    axis: vec3<f32>,
    length: f32,
    radius: f32,
    slope: f32,
};

fn cone_of(prim: Primitive) -> Cone {
    return Cone(prim.a.xyz, prim.b.xyz, prim.b.w, prim.a.w, prim.c.y);
}

// Twin of `GpuKernel`. family: 0 compact (1 − x/σ²)^m, 1 Cauchy (1 + x/σ²)^(−n), 2 Gaussian.
struct Kernel {
    family: u32,
    kinked: u32,
    clamped: u32,      // the group's field is clamped at 0 (it holds an HRBF set)
    pad1: u32,
    exponent: f32,     // m (compact) or n (Cauchy)
    inv_sigma2: f32,
    support_sq: f32,
    clip: f32,
    clip_scale: f32,
    pad2: f32,
    pad3: f32,
    pad4: f32,
};

// Twin of `GpuMaterial`: a group's material.
struct Material {
    colour: vec4<f32>, // w: opacity
    ior: vec4<f32>,    // x: index of refraction
};

// Twin of `GpuLight`. kind 0: directional (vector towards the light), 1: point (position).
struct Light {
    vector: vec4<f32>, // w: kind
    colour: vec4<f32>, // w: intensity
};

// The frame's constants and the blend operators' parameters (smooth widths, Ricci exponents),
// one slot per parametrised operator in pre-order, which the generated blend functions read at
// constant indices (blend_wgsl.rs): a parameter's new value is an upload, not a new pipeline. Storage, not uniform: lavapipe inlines the uniform
// values a loop condition reads and compiles the pipeline again for every new set of them (every
// scene, every frame size), seconds each; storage reads are never inlined. One buffer: wgpu's
// OpenGL backend allows 16 storage buffers per stage, which the trace shaders use up.
struct FrameConstants {
    globals: Globals,
    blend_parameters: array<f32>,
};

@group(0) @binding(0) var<storage, read> frame: FrameConstants;
@group(0) @binding(1) var<storage, read> primitives: array<Primitive>;
@group(0) @binding(2) var<storage, read> kernels: array<Kernel>;
@group(0) @binding(3) var<storage, read> materials: array<Material>;
@group(0) @binding(4) var<storage, read> lights: array<Light>;
@group(0) @binding(5) var<storage, read> tile_ranges: array<vec2<u32>>;
@group(0) @binding(6) var<storage, read> tile_items: array<u32>;
@group(0) @binding(7) var<storage, read_write> out_colour: array<u32>;
@group(0) @binding(8) var<storage, read_write> out_depth: array<f32>;
@group(0) @binding(9) var<storage, read_write> out_steps: array<u32>;
@group(0) @binding(10) var<storage, read_write> suspensions: array<Suspension>;
// The HRBF sets' boxes, three per set: local y axis, local minimum and maximum corners.
@group(0) @binding(12) var<storage, read> boxes: array<vec4<f32>>;

// Twin of `GpuBvhNode` (ray_bvh.rs): a box, the index past its subtree, and for a leaf
// `first << 3 | count` (its items bvh_items[first..first + count]), 0 for an inner node.
struct BvhNode {
    min: vec3<f32>,
    skip: u32,
    max: vec3<f32>,
    leaf: u32,
};

// The hierarchy over the supports, nodes in depth-first order, for rays that leave the screen
// tiles (gather_every).
@group(0) @binding(15) var<storage, read> bvh_nodes: array<BvhNode>;
@group(0) @binding(16) var<storage, read> bvh_items: array<u32>;

const INF: f32 = 3.0e38;

struct Ray {
    origin: vec3<f32>,
    dir: vec3<f32>,
};

// A pixel's march between two dispatches of a marching method (parts.wgsl); zeroed by the
// renderer before the first. The renderer sizes the buffer by SUSPENSION_BYTES (renderer.rs).
struct Suspension {
    t: f32,
    carry0: f32,
    carry1: f32,
    part_end: f32,
    window_floor: f32,
    steps: u32,
    flags: u32,        // SUSPENDED, FINISHED, and the method's own flags (MarchState)
};

const SUSPENDED: u32 = 0x40000000u;
const FINISHED: u32 = 0x80000000u;

// The outcome of tracing one ray (first crossing).
struct Trace {
    t: f32,
    hit: bool,
    entering: bool,
    steps: u32,
};
