// Shared prelude of every skeletrace compute shader: the scene as uploaded by
// `buffers.rs` (each struct names its Rust twin), kernels, primitives, support intervals,
// the field restricted to a pixel's ray and the support parts of that ray. f32 throughout.
// Mirrors skeletrace-core: kernel.rs, primitives/*.rs, geometry.rs, program.rs.

// Twin of `GpuGlobals` (renderer.rs): the frame's camera, scene counts, trace settings and
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

@group(0) @binding(0) var<uniform> globals: Globals;
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

// ---- kernels (kernel.rs: KernelProfile) ----

// (K, K′, K″) of the formula valid inside the support at x (clamped to [0, support]).
fn kernel_raw(k: Kernel, x_in: f32) -> vec3<f32> {
    let x = clamp(x_in, 0.0, k.support_sq);
    let a = k.inv_sigma2;
    if k.family == KERNEL_COMPACT_POLYNOMIAL {
        let base = max(1.0 - x * a, 0.0);
        let m = k.exponent;
        var p2 = 0.0;
        var p1 = 1.0;
        if m >= 2.0 {
            // pow(0, 0) is undefined in WGSL (NaN on lavapipe): at the support boundary the
            // degree-4 kernel's K″ would be NaN, and a NaN f″ bound stepped over surfaces.
            p2 = select(pow(base, m - 2.0), 1.0, m == 2.0);
            p1 = p2 * base;
        }
        return vec3<f32>(p1 * base, -m * a * p1, m * (m - 1.0) * a * a * p2);
    } else if k.family == KERNEL_CAUCHY {
        let base = 1.0 + x * a;
        let n = k.exponent;
        let v = pow(base, -n);
        let v1 = v / base;
        return vec3<f32>(v, -n * a * v1, n * (n + 1.0) * a * a * v1 / base);
    }
    let v = exp(-x * a);
    return vec3<f32>(v, -a * v, a * a * v);
}

// (K, K′) at x, zero outside the support (value_d1).
fn kernel_d1(k: Kernel, x: f32) -> vec2<f32> {
    if x >= k.support_sq {
        return vec2<f32>(0.0);
    }
    let r = kernel_raw(k, x);
    return vec2<f32>(max((r.x - k.clip) * k.clip_scale, 0.0), r.y * k.clip_scale);
}

// (K, K′, K″) of the inside formula, clipped value (value_d2_inside).
fn kernel_d2_inside(k: Kernel, x: f32) -> vec3<f32> {
    let r = kernel_raw(k, x);
    return vec3<f32>(max((r.x - k.clip) * k.clip_scale, 0.0), r.y * k.clip_scale, r.z * k.clip_scale);
}

// ---- primitives (primitives/*.rs) ----

// Value and gradient of one primitive at p.
fn primitive_value_gradient(i: u32, p: vec3<f32>) -> vec4<f32> {
    let prim = primitives[i];
    let k = kernels[prim.group];
    // The HAS_* constants (shared.rs KindSet) fold the absent kinds' code away.
    if HAS_POINT && prim.kind == KIND_POINT {
        let inv_r2 = 1.0 / (prim.a.w * prim.a.w);
        let d = p - prim.a.xyz;
        let v = kernel_d1(k, dot(d, d) * inv_r2);
        return vec4<f32>(prim.c.x * v.x, (2.0 * prim.c.x * v.y * inv_r2) * d);
    } else if HAS_DISTANCE_SEGMENT && prim.kind == KIND_DISTANCE_SEGMENT {
        return distance_segment(prim, k, p);
    } else if HAS_SCALIS_SEGMENT && prim.kind == KIND_SCALIS_SEGMENT {
        return scalis_segment(prim, k, p);
    } else if HAS_HRBF && prim.kind == KIND_HRBF {
        return hrbf(prim, p);
    } else if HAS_SHAPE && prim.kind != KIND_PLANE {
        return shape(prim, k, p);
    }
    if !HAS_PLANE {
        return vec4<f32>(0.0);
    }
    // Plane: kernel of the squared distance to the plane, over ρ².
    let n = prim.a.xyz;
    let s = dot(n, p) - prim.a.w;
    let inv_r2 = 1.0 / (prim.b.x * prim.b.x);
    let v = kernel_d1(k, s * s * inv_r2);
    return vec4<f32>(prim.c.x * v.x, (prim.c.x * v.y * inv_r2 * 2.0 * s) * n);
}

// A shape's local frame (shapes.rs ShapePrimitive.frame), its axes as columns; `v * m` takes a
// world vector to the local frame, `m * v` back.
fn shape_frame(prim: Primitive) -> mat3x3<f32> {
    let x = prim.d.xyz;
    let y = prim.c.yzw;
    return mat3x3<f32>(x, y, prim.d.w * cross(x, y));
}

// Per axis, how far q lies outside the slab |q| ≤ e, signed as q.
fn box_excess(q: vec3<f32>, e: vec3<f32>) -> vec3<f32> {
    return sign(q) * max(abs(q) - e, vec3<f32>(0.0));
}

// Unit vector from the local y axis towards q, in the xz plane (0 on the axis).
fn radial_direction(q: vec3<f32>) -> vec3<f32> {
    let rho = length(q.xz);
    if rho > 0.0 {
        return vec3<f32>(q.x / rho, 0.0, q.z / rho);
    }
    return vec3<f32>(0.0);
}

// Squared distance from p to the solid of a box, rounded box, torus or cylinder, and its world
// gradient (shapes.rs distance_sq).
fn shape_distance_sq(prim: Primitive, p: vec3<f32>) -> vec4<f32> {
    let m = shape_frame(prim);
    let q = (p - prim.a.xyz) * m;
    let e = prim.b;
    var d2 = 0.0;
    var g = vec3<f32>(0.0);
    if prim.kind == KIND_BOX {
        let x = box_excess(q, e.xyz);
        d2 = dot(x, x);
        g = 2.0 * x;
    } else if prim.kind == KIND_ROUNDED_BOX {
        let x = box_excess(q, e.xyz - vec3<f32>(e.w));
        let inner = length(x);
        let out = max(inner - e.w, 0.0);
        if out > 0.0 {
            d2 = out * out;
            g = (2.0 * out / inner) * x;
        }
    } else if prim.kind == KIND_TORUS {
        let a = length(q.xz) - e.x;
        let tube = length(vec2<f32>(a, q.y));
        let out = max(tube - e.y, 0.0);
        if out > 0.0 {
            d2 = out * out;
            g = (2.0 * out / tube) * (a * radial_direction(q) + vec3<f32>(0.0, q.y, 0.0));
        }
    } else {
        let gr = max(length(q.xz) - e.x, 0.0);
        let gy = sign(q.y) * max(abs(q.y) - e.y, 0.0);
        d2 = gr * gr + gy * gy;
        g = 2.0 * (gr * radial_direction(q) + vec3<f32>(0.0, gy, 0.0));
    }
    return vec4<f32>(d2, m * g);
}

// A box, rounded box, torus or cylinder (shapes.rs value_gradient): N₀·K(d²/ρ²).
fn shape(prim: Primitive, k: Kernel, p: vec3<f32>) -> vec4<f32> {
    let inv_r2 = 1.0 / (prim.a.w * prim.a.w);
    let d = shape_distance_sq(prim, p);
    let v = kernel_d1(k, d.x * inv_r2);
    return vec4<f32>(prim.c.x * v.x, (prim.c.x * v.y * inv_r2) * d.yzw);
}

// The frame of an HRBF term's box, its axes as columns, and the box's local corners
// (hrbf.rs HrbfTerm bounds, frame).
struct HrbfBox {
    frame: mat3x3<f32>,
    lo: vec3<f32>,
    hi: vec3<f32>,
};

fn hrbf_box(prim: Primitive) -> HrbfBox {
    let x = prim.d.xyz;
    let y = boxes[prim.extra].xyz;
    return HrbfBox(mat3x3<f32>(x, y, prim.d.w * cross(x, y)), boxes[prim.extra + 1u].xyz,
                   boxes[prim.extra + 2u].xyz);
}

// One term of an HRBF set (hrbf.rs value_gradient), 0 outside its set's box:
// α r³ + 3r β·v + a·p + b with v = p − centre, r = |v|.
fn hrbf(prim: Primitive, p: vec3<f32>) -> vec4<f32> {
    let bx = hrbf_box(prim);
    let q = p * bx.frame;
    if any(q < bx.lo) || any(q > bx.hi) {
        return vec4<f32>(0.0);
    }
    return hrbf_inside(prim, p);
}

// An HRBF term's formula inside its box, wherever p is (hrbf.rs value_gradient_inside): for a
// point the caller knows to be inside by the ray's interval in the box.
fn hrbf_inside(prim: Primitive, p: vec3<f32>) -> vec4<f32> {
    let alpha = prim.a.w;
    let beta = prim.b.xyz;
    let v = p - prim.a.xyz;
    let r = length(v);
    let bv = dot(beta, v);
    let value = alpha * r * r * r + 3.0 * r * bv + dot(prim.c.xyz, p) + prim.b.w;
    var gradient = 3.0 * alpha * r * v + 3.0 * r * beta + prim.c.xyz;
    if r > 0.0 {
        gradient += (3.0 * bv / r) * v;
    }
    return vec4<f32>(value, gradient);
}

// Homothetic-distance segment (segment.rs): closest homothetic point and the envelope gradient.
fn distance_segment(prim: Primitive, k: Kernel, p: vec3<f32>) -> vec4<f32> {
    let cone = cone_of(prim);
    let w = p - cone.start;
    let a = dot(w, cone.axis);
    let b2 = max(dot(w, w) - a * a, 0.0);
    let y = cone.radius + cone.slope * a;
    var s = cone.length;
    if y > 0.0 {
        s = clamp(a + cone.slope * b2 / y, 0.0, cone.length);
    }
    let q = cone.start + s * cone.axis;
    let tau = cone.radius + cone.slope * s;
    let d = p - q;
    let inv_t2 = 1.0 / (tau * tau);
    let v = kernel_d1(k, dot(d, d) * inv_t2);
    return vec4<f32>(prim.c.x * v.x, (2.0 * prim.c.x * v.y * inv_t2) * d);
}

// 12-point Gauss–Legendre nodes and weights on [−1, 1] (quadrature.rs, SCALIS_ORDER).

// SCALIS segment (scalis.rs): N ∫ K(h²) ds/τ over the part of the segment whose support ball
// contains p, in u = ln τ (or arc length when the radius barely varies), in panels for clipped
// kernels.
fn scalis_segment(prim: Primitive, k: Kernel, p: vec3<f32>) -> vec4<f32> {
    let cone = cone_of(prim);
    let inv_r2 = 1.0 / k.support_sq;
    let w = p - cone.start;
    let qa = inv_r2 - cone.slope * cone.slope;
    let qb = dot(w, cone.axis) * inv_r2 + cone.radius * cone.slope;
    let qc = dot(w, w) * inv_r2 - cone.radius * cone.radius;
    let disc = qb * qb - qa * qc;
    if disc < 0.0 {
        return vec4<f32>(0.0);
    }
    let big = qb + sqrt(disc);
    if big <= 0.0 || cone.length * big < qc {
        return vec4<f32>(0.0);
    }
    let l1 = max(qc / big, 0.0);
    let l2 = min(big / qa, cone.length);
    if l1 >= l2 {
        return vec4<f32>(0.0);
    }
    let tau1 = cone.radius + cone.slope * l1;
    var panels = 1u;
    if k.clip > 0.0 {
        panels = u32(clamp(ceil((l2 - l1) / (2.0 * tau1)), 1.0, 16.0));
    }
    var sum = 0.0;
    var grad = vec3<f32>(0.0);
    let arc = cone.slope * (l2 - l1) < 0.05;
    var lo = l1;
    var hi = l2;
    if !arc {
        lo = log(tau1);
        hi = log(cone.radius + cone.slope * l2);
    }
    let h = (hi - lo) / f32(panels);
    for (var panel = 0u; panel < panels; panel++) {
        let mid = lo + (f32(panel) + 0.5) * h;
        for (var j = 0u; j < SCALIS_ORDER; j++) {
            var xi = GL_NODES[j % GL_HALF];
            if j >= GL_HALF {
                xi = -xi;
            }
            let wi = GL_WEIGHTS[j % GL_HALF];
            var s: f32;
            var tau: f32;
            var measure: f32;
            if arc {
                s = mid + 0.5 * h * xi;
                tau = cone.radius + cone.slope * s;
                measure = 0.5 * h * wi / tau;
            } else {
                tau = exp(mid + 0.5 * h * xi);
                s = (tau - cone.radius) / cone.slope;
                measure = 0.5 * h * wi / cone.slope;
            }
            let offset = p - (cone.start + s * cone.axis);
            let kv = kernel_d1(k, dot(offset, offset) / (tau * tau));
            sum += kv.x * measure;
            grad += (2.0 * kv.y * measure / (tau * tau)) * offset;
        }
    }
    return prim.c.x * vec4<f32>(sum, grad);
}

// ---- support intervals along a ray (geometry.rs) ----

fn ball_interval(ray: Ray, centre: vec3<f32>, radius: f32) -> vec2<f32> {
    let oc = ray.origin - centre;
    let b = dot(oc, ray.dir);
    // r² − (distance from the centre to the line)², without the cancellation of b² − c.
    let perp = oc - b * ray.dir;
    let disc = radius * radius - dot(perp, perp);
    if disc < 0.0 {
        return vec2<f32>(INF, -INF);
    }
    let s = sqrt(disc);
    return vec2<f32>(-b - s, -b + s);
}

// Real roots of a t² + b t + c, increasing; x > y when none.
fn quadratic_roots(a: f32, b: f32, c: f32) -> vec2<f32> {
    if a == 0.0 {
        if b == 0.0 {
            return vec2<f32>(INF, -INF);
        }
        let r = -c / b;
        return vec2<f32>(r, r);
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return vec2<f32>(INF, -INF);
    }
    let q = -0.5 * (b + select(-sqrt(disc), sqrt(disc), b >= 0.0));
    var r1 = q / a;
    var r2 = r1;
    if q != 0.0 {
        r2 = c / q;
    }
    return vec2<f32>(min(r1, r2), max(r1, r2));
}

// Exact interval of the ray inside a sphere-cone scaled by `scale` (SphereCone::ray_interval).
fn cone_interval(ray: Ray, prim: Primitive, scale: f32) -> vec2<f32> {
    let cone = cone_of(prim);
    let r0 = cone.radius * scale;
    let d = cone.slope * scale;
    var hull = ball_interval(ray, cone.start, r0);
    let e1 = ball_interval(ray, cone.start + cone.length * cone.axis, r0 + d * cone.length);
    hull = vec2<f32>(min(hull.x, e1.x), max(hull.y, e1.y));
    let w0 = ray.origin - cone.start;
    let a0 = dot(w0, cone.axis);
    let a1 = dot(ray.dir, cone.axis);
    let b0 = dot(w0, w0) - a0 * a0;
    let b1 = 2.0 * (dot(w0, ray.dir) - a0 * a1);
    let b2 = 1.0 - a1 * a1;
    let e = 1.0 - d * d;
    let y0 = r0 + d * a0;
    let roots = quadratic_roots(e * b2 - d * d * a1 * a1, e * b1 - 2.0 * d * a1 * y0, e * b0 - y0 * y0);
    if roots.x <= roots.y {
        for (var i = 0; i < 2; i++) {
            let t = select(roots.y, roots.x, i == 0);
            let a = a0 + a1 * t;
            let s = (a + d * r0) / e;
            if r0 + d * a > 0.0 && s >= 0.0 && s <= cone.length {
                hull = vec2<f32>(min(hull.x, t), max(hull.y, t));
            }
        }
    }
    return hull;
}

// Interval of the ray inside primitive i's support (empty: x > y).
fn support_interval(ray: Ray, i: u32) -> vec2<f32> {
    let prim = primitives[i];
    let k = kernels[prim.group];
    let reach = sqrt(k.support_sq);
    if HAS_POINT && prim.kind == KIND_POINT {
        return ball_interval(ray, prim.a.xyz, prim.a.w * reach);
    } else if HAS_PLANE && prim.kind == KIND_PLANE {
        let n = prim.a.xyz;
        let s0 = dot(n, ray.origin) - prim.a.w;
        let su = dot(n, ray.dir);
        let r = prim.b.x * reach;
        if su == 0.0 {
            return select(vec2<f32>(INF, -INF), vec2<f32>(-INF, INF), abs(s0) < r);
        }
        let t0 = (-r - s0) / su;
        let t1 = (r - s0) / su;
        return vec2<f32>(min(t0, t1), max(t0, t1));
    } else if (HAS_DISTANCE_SEGMENT || HAS_SCALIS_SEGMENT)
        && (prim.kind == KIND_DISTANCE_SEGMENT || prim.kind == KIND_SCALIS_SEGMENT) {
        return cone_interval(ray, prim, reach);
    } else if HAS_HRBF && prim.kind == KIND_HRBF {
        // The set's box (hrbf.rs support_interval).
        let bx = hrbf_box(prim);
        return box_interval(ray.origin * bx.frame, ray.dir * bx.frame, bx.lo, bx.hi);
    }
    if !HAS_SHAPE {
        return vec2<f32>(INF, -INF);
    }
    return shape_interval(ray, prim, prim.a.w * reach);
}

// Interval of the line o + t u inside the box [lo, hi] (geometry.rs Aabb::ray_interval);
// empty: x > y.
fn box_interval(o: vec3<f32>, u: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>) -> vec2<f32> {
    var span = vec2<f32>(-INF, INF);
    for (var axis = 0; axis < 3; axis++) {
        if u[axis] == 0.0 {
            // Parallel to the slab: all of the line or none of it.
            if o[axis] < lo[axis] || o[axis] > hi[axis] {
                return vec2<f32>(INF, -INF);
            }
            continue;
        }
        let ta = (lo[axis] - o[axis]) / u[axis];
        let tb = (hi[axis] - o[axis]) / u[axis];
        span = vec2<f32>(max(span.x, min(ta, tb)), min(span.y, max(ta, tb)));
    }
    return span;
}

// Interval of the ray inside the local box bounding a shape's support (shapes.rs
// support_interval, local_bound): a superset of the support's own interval.
fn shape_interval(ray: Ray, prim: Primitive, reach: f32) -> vec2<f32> {
    let e = prim.b;
    var half = e.xyz + vec3<f32>(reach);
    if prim.kind == KIND_TORUS {
        let r = e.x + e.y + reach;
        half = vec3<f32>(r, e.y + reach, r);
    } else if prim.kind == KIND_CYLINDER {
        half = vec3<f32>(e.x + reach, e.y + reach, e.x + reach);
    }
    let m = shape_frame(prim);
    return box_interval((ray.origin - prim.a.xyz) * m, ray.dir * m, -half, half);
}

// ---- the pixel's ray and its supports ----

// A window of the supports a ray crosses within [0, far]: the RAY_SUPPORTS of them with the
// smallest entries among those leaving after `floor`, sorted by entry. Every support that
// overlaps [floor, horizon) is in the window; when the ray gets past `horizon`, `next_part`
// refills the window from the tile list (the 2021 paper §7 keeps a heap of the
// primitives overlapping the current interval, algorithm 2). Refilling
// instead of walking the whole tile list keeps a ray's loop iterations far below lavapipe's
// per-invocation limit of 65 535.
struct RaySupports {
    count: u32,
    list: u32,     // the first of the ray's lists in tile_ranges (one per depth band)
    horizon: f32,
    floor: f32,    // of the last fill, kept for a suspended march to refill the same window
    far: f32,      // end of the ray's interval
    listed: bool,  // the supports come from a tile list; false: every primitive (gather_every)
    ids: array<u32, RAY_SUPPORTS>,
    spans: array<vec2<f32>, RAY_SUPPORTS>,
};


fn pixel_ray(px: u32, py: u32) -> Ray {
    let w = f32(globals.width);
    let h = f32(globals.height);
    let u = (2.0 * (f32(px) + 0.5) / w - 1.0) * globals.tan_half_fov * globals.aspect;
    let v = (1.0 - 2.0 * (f32(py) + 0.5) / h) * globals.tan_half_fov;
    let dir = normalize(globals.forward + u * globals.right + v * globals.up);
    return Ray(globals.origin, dir);
}

// Fills the window with the supports of the ray's list (a tile's, or with gather_every the
// primitives the hierarchy finds on the ray, then the unbounded ones) that the ray leaves after
// `floor`. Each candidate goes to one call of `window_take`, which the shader compilers inline
// with `support_interval`, the largest function a pipeline holds; the walk finds the next
// candidate in a loop of its own, so that a SIMD row's rays take theirs together.
fn fill_window(sp: ptr<function, RaySupports>, ray: Ray, floor: f32) {
    (*sp).count = 0u;
    (*sp).horizon = INF;
    (*sp).floor = floor;
    let listed = (*sp).listed;
    var j = 0u;
    var end = 0u;
    var band = 0u;
    if listed {
        let range = band_range((*sp).list);
        j = range.x;
        end = range.y;
    }
    let node_count = select(arrayLength(&bvh_nodes), 0u, listed);
    var node = 0u;
    var unbounded = !listed;
    loop {
        var i = 0u;
        var found = false;
        loop {
            if j < end {
                if listed {
                    i = tile_items[j];
                } else {
                    i = bvh_items[j];
                }
                j += 1u;
                found = true;
                break;
            }
            if listed && band + 1u < globals.list_bands {
                // The next band's supports are at least `nearest` from the eye (binning.wgsl
                // band_list), less a margin for rounding. Where that is past the ray's end, or
                // past the horizon of a full window, none of them would be taken, nor move the
                // horizon (window_take): the window is complete.
                band += 1u;
                let lower = globals.band_near + f32(band - 1u) * globals.band_width;
                let nearest = lower - 1e-3 * (lower + globals.band_width);
                if nearest > (*sp).far || ((*sp).count == RAY_SUPPORTS && nearest >= (*sp).horizon) {
                    break;
                }
                let range = band_range((*sp).list + band);
                j = range.x;
                end = range.y;
                continue;
            }
            if node < node_count {
                // A node whose box the ray's line misses, or meets only before the floor or
                // past the ray's end, holds no support the window takes: skipped whole. A
                // leaf's items are the next candidates.
                let n = bvh_nodes[node];
                let span = box_interval(ray.origin, ray.dir, n.min, n.max);
                let count = n.leaf & 7u;
                if span.x > span.y || span.y < max(floor, 0.0) || span.x > (*sp).far {
                    node = n.skip;
                } else if count == 0u {
                    node += 1u;
                } else {
                    j = n.leaf >> 3u;
                    end = j + count;
                    node = n.skip;
                }
                continue;
            }
            if unbounded {
                unbounded = false;
                j = globals.bvh_unbounded;
                end = globals.bvh_items;
                continue;
            }
            break;
        }
        if !found {
            break;
        }
        window_take(sp, ray, i);
    }
}

// Takes primitive `i` into the window if the ray leaves its support after the window's
// floor: the window keeps the RAY_SUPPORTS earliest entries, sorted, and its horizon is the
// earliest entry it could not keep.
fn window_take(sp: ptr<function, RaySupports>, ray: Ray, i: u32) {
    var span = support_interval(ray, i);
    span = vec2<f32>(max(span.x, 0.0), min(span.y, (*sp).far));
    if span.x > span.y || span.y <= (*sp).floor {
        return;
    }
    var k = (*sp).count;
    if k == RAY_SUPPORTS {
        // Full: the later entry of the newcomer and the last kept one bounds the window.
        let last = (*sp).spans[k - 1u].x;
        if span.x >= last {
            (*sp).horizon = min((*sp).horizon, span.x);
            return;
        }
        (*sp).horizon = min((*sp).horizon, last);
        k -= 1u;
    } else {
        (*sp).count += 1u;
    }
    // Insertion by entry.
    while k > 0u && (*sp).spans[k - 1u].x > span.x {
        (*sp).spans[k] = (*sp).spans[k - 1u];
        (*sp).ids[k] = (*sp).ids[k - 1u];
        k -= 1u;
    }
    (*sp).spans[k] = span;
    (*sp).ids[k] = i;
}

fn gather_supports(sp: ptr<function, RaySupports>, ray: Ray, px: u32, py: u32, floor: f32) {
    let ts = globals.tile_size;
    gather_list(sp, ray, (py / ts) * globals.tiles_x + px / ts, globals.far, floor);
}

// The supports along `ray` over [floor, far] among those of list `list` (a tile's, made of
// globals.list_bands lists in tile_ranges).
fn gather_list(sp: ptr<function, RaySupports>, ray: Ray, list: u32, far: f32, floor: f32) {
    (*sp).far = far;
    (*sp).list = list * globals.list_bands;
    (*sp).listed = true;
    fill_window(sp, ray, floor);
}

// The items of list `list` in tile_items. A list past the items' end (the host grows them and
// traces again, tile_binning.rs) is read only as far as it was written.
fn band_range(list: u32) -> vec2<u32> {
    let range = tile_ranges[list];
    let written = arrayLength(&tile_items);
    return vec2<u32>(min(range.x, written), min(range.y, written));
}

// The supports along `ray` over [floor, far] among every primitive: a secondary ray (main.wgsl
// trace_path) or a statistics ray off the axes leaves the screen tiles, and is traced against
// the whole scene as on the CPU, whose primitives the hierarchy (bvh_nodes) finds.
fn gather_every(sp: ptr<function, RaySupports>, ray: Ray, far: f32, floor: f32) {
    (*sp).far = far;
    (*sp).listed = false;
    fill_window(sp, ray, floor);
}

// Where the window of ray `k`'s march starts: the floor its suspended march left (parts.wgsl),
// whose window the march goes on with, or 0 for a march that begins. One fill per dispatch.
fn resumed_floor(k: u32) -> f32 {
    let s = suspensions[k];
    return select(0.0, s.window_floor, (s.flags & SUSPENDED) != 0u);
}

fn support_count(sp: ptr<function, RaySupports>) -> u32 {
    return (*sp).count;
}

struct SupportItem {
    id: u32,
    span: vec2<f32>,
};

fn support_item(sp: ptr<function, RaySupports>, ray: Ray, j: u32) -> SupportItem {
    return SupportItem((*sp).ids[j], (*sp).spans[j]);
}

// Polynomial smooth maximum of two values with gradients (blend.rs smooth_max).
fn smooth_max(a: vec4<f32>, b: vec4<f32>, width: f32) -> vec4<f32> {
    let h = clamp(0.5 + (a.x - b.x) / (2.0 * width), 0.0, 1.0);
    return vec4<f32>(b.x + h * (a.x - b.x) + width * h * (1.0 - h), h * a.yzw + (1.0 - h) * b.yzw);
}

// The operators of the blend (blend.rs value_gradient) on values with gradients, which
// `blend_groups` (blend_wgsl.rs, generated per scene) nests in the shape of the scene's tree.

// max and min keep the first of equal values.
fn value_max(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    return select(a, b, b.x > a.x);
}

fn value_min(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    return select(a, b, b.x < a.x);
}

// min(a, 2c − b), a on ties.
fn value_difference(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    let complement = 2.0 * globals.isovalue - b.x;
    return select(vec4<f32>(complement, -b.yzw), a, a.x <= complement);
}

// The Ricci blend R = (Σ max(fᵢ, 0)^p)^(1/p) with ∇R = Σ (fᵢ/R)^(p−1) ∇fᵢ over the positive
// operands: the largest operand value m, the terms (fᵢ/m)^p of the sum, its root m·(Σ)^(1/p)
// (0 when nothing is positive), the gradient's terms. Relative to m the powers neither overflow
// nor underflow f32 (with a plain sum, 0.01^32 is 0 and 16^32 infinite: blend.rs p_norm).
fn ricci_scale(largest: f32, f: vec4<f32>) -> f32 {
    return max(largest, f.x);
}

fn ricci_power(f: vec4<f32>, scale: f32, p: f32) -> f32 {
    return select(0.0, pow(f.x / scale, p), f.x > 0.0);
}

fn ricci_root(sum: f32, scale: f32, p: f32) -> f32 {
    return select(0.0, scale * pow(sum, 1.0 / p), sum > 0.0);
}

fn ricci_slope(f: vec4<f32>, root: f32, p: f32) -> vec3<f32> {
    if f.x > 0.0 && root > 0.0 {
        return pow(f.x / root, p - 1.0) * f.yzw;
    }
    return vec3<f32>(0.0);
}

fn add_primitive(values: ptr<function, array<vec4<f32>, GROUPS>>, i: u32, p: vec3<f32>) {
    let g = primitives[i].group;
    (*values)[g] += primitive_value_gradient(i, p);
}

// Every group's value and gradient at ray parameter t: only the primitives of the window
// whose support contains the point.
fn groups_at(sp: ptr<function, RaySupports>, ray: Ray, t: f32) -> array<vec4<f32>, GROUPS> {
    let p = ray.origin + t * ray.dir;
    var values: array<vec4<f32>, GROUPS>;
    for (var j = 0u; j < (*sp).count; j++) {
        let s = (*sp).spans[j];
        if s.x > t {
            break;
        }
        if t <= s.y {
            add_primitive(&values, (*sp).ids[j], p);
        }
    }
    // Groups holding an HRBF set are clamped at 0 (program.rs clamp_group_slots).
    for (var g = 0u; g < globals.group_count; g++) {
        if kernels[g].clamped != 0u && values[g].x < 0.0 {
            values[g] = vec4<f32>(0.0);
        }
    }
    return values;
}

fn field_at(sp: ptr<function, RaySupports>, ray: Ray, t: f32) -> vec4<f32> {
    return blend_groups(groups_at(sp, ray, t));
}

// (f(t), f′(t)) along the ray.
fn along_ray(sp: ptr<function, RaySupports>, ray: Ray, t: f32) -> vec2<f32> {
    let v = field_at(sp, ray, t);
    return vec2<f32>(v.x, dot(v.yzw, ray.dir));
}

// The part of the ray inside the union of supports that starts at or after `start_at`: (lo, hi),
// empty (x > y) when none is left. A part is cut at the window's horizon; the next call then
// refills the window from there.
fn next_part(sp: ptr<function, RaySupports>, ray: Ray, start_at: f32) -> vec2<f32> {
    if start_at >= (*sp).horizon {
        fill_window(sp, ray, start_at);
    }
    var lo = INF;
    var hi = -INF;
    for (var j = 0u; j < (*sp).count; j++) {
        let s = (*sp).spans[j];
        if s.y <= start_at {
            continue;
        }
        if lo == INF {
            lo = max(s.x, start_at);
            hi = s.y;
        } else if s.x <= hi {
            hi = max(hi, s.y);
        } else {
            break;
        }
    }
    if lo == INF {
        return vec2<f32>(INF, -INF);
    }
    // The part is cut where the ray enters or leaves an HRBF set's box inside it: the field may
    // jump there (program.rs ray_support_unions_in, cut_boxes).
    for (var j = 0u; j < select(0u, (*sp).count, HAS_HRBF); j++) {
        if primitives[(*sp).ids[j]].kind != KIND_HRBF {
            continue;
        }
        let s = (*sp).spans[j];
        if lo < s.x && s.x < hi {
            hi = s.x;
        }
        if lo < s.y && s.y < hi {
            hi = s.y;
        }
    }
    // More than RAY_SUPPORTS supports overlap at lo: the window is incomplete there; march a
    // minimum step with what it holds rather than stall.
    return vec2<f32>(lo, min(hi, max((*sp).horizon, lo + globals.min_step)));
}
