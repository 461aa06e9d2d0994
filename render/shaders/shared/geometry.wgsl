// Support intervals along a ray: core field/geometry.rs (balls, sphere-cones, boxes).

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
