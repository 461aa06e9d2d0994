// Primitives' values and gradients: core field/primitives/*.rs (points, segments, SCALIS
// segments, shapes, HRBF terms), in f32.

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
