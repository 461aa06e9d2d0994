// Sherstyuk's fast ray tracing of convolution surfaces (Sherstyuk 1999, the comparison of scalis
// 2021 §2 and §8; core: methods/sherstyuk.rs): each primitive's field along the ray is a
// piecewise cubic Hermite polynomial over its support interval, from its value and derivative at
// the ends of SHERSTYUK_PIECES equal subintervals; the sum of the active pieces on each
// elementary interval between consecutive nodes is a cubic searched for a root on its monotone
// parts. A step is one elementary interval. SHERSTYUK_PIECES is emitted before this file from
// core's Sherstyuk::SUBDIVISIONS.
//
// The CPU sorts every node of the part once; here the march walks them in order, each step
// finding the next node and summing the pieces over the interval to it from the window's
// supports, which hold every primitive of the scene (GpuMethod::supports: at most RAY_SUPPORTS).

// Node `i` of a support interval (sherstyuk.rs trace_part, `node`).
fn sherstyuk_node(span: vec2<f32>, i: u32) -> f32 {
    return span.x + (span.y - span.x) * f32(i) / f32(SHERSTYUK_PIECES);
}

// One primitive's value and derivative along the ray at t.
fn sherstyuk_sample(ray: Ray, id: u32, t: f32) -> vec2<f32> {
    let v = primitive_value_gradient(id, ray.origin + t * ray.dir);
    return vec2<f32>(v.x, dot(v.yzw, ray.dir));
}

// Coefficients in s = (t − t0)/l of the cubic with values and derivatives `at0`, `at1` at the
// ends of an interval of length l (sherstyuk.rs Piece::monomial).
fn hermite_monomial(at0: vec2<f32>, at1: vec2<f32>, l: f32) -> vec4<f32> {
    let ld0 = l * at0.y;
    let ld1 = l * at1.y;
    return vec4<f32>(
        at0.x,
        ld0,
        -3.0 * at0.x - 2.0 * ld0 + 3.0 * at1.x - ld1,
        2.0 * at0.x + ld0 - 2.0 * at1.x + ld1,
    );
}

// Value and derivative at t of that cubic on [t0, t0 + l] (Piece::at).
fn hermite_at(m: vec4<f32>, t0: f32, l: f32, t: f32) -> vec2<f32> {
    let s = (t - t0) / l;
    return vec2<f32>(m.x + s * (m.y + s * (m.z + s * m.w)), (m.y + s * (2.0 * m.z + 3.0 * s * m.w)) / l);
}

fn cubic_minus(m: vec4<f32>, c: f32, s: f32) -> f32 {
    return m.x - c + s * (m.y + s * (m.z + s * m.w));
}

// The first crossing of c by the cubic `m` on s ∈ [0, 1] in or after its monotone part
// `first_part`, by 50 bisections (Piece::crossings): (s, entering, the part), s < 0 when there
// is none.
fn hermite_crossing(m: vec4<f32>, c: f32, first_part: u32) -> vec3<f32> {
    let roots = quadratic_roots(3.0 * m.w, 2.0 * m.z, m.y);
    var cuts = array<f32, 4>(0.0, 1.0, 1.0, 1.0);
    var count = 1u;
    if roots.x <= roots.y {
        for (var k = 0u; k < 2u; k++) {
            let r = select(roots.y, roots.x, k == 0u);
            if r > 0.0 && r < 1.0 && !(k == 1u && roots.y == roots.x) {
                cuts[count] = r;
                count += 1u;
            }
        }
    }
    cuts[count] = 1.0;
    for (var w = first_part; w < count; w++) {
        var lo = cuts[w];
        var hi = cuts[w + 1u];
        let below_lo = cubic_minus(m, c, lo) < 0.0;
        if below_lo == (cubic_minus(m, c, hi) < 0.0) {
            continue;
        }
        for (var i = 0; i < 50; i++) {
            let mid = 0.5 * (lo + hi);
            if (cubic_minus(m, c, mid) < 0.0) == below_lo {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        return vec3<f32>(0.5 * (lo + hi), select(0.0, 1.0, below_lo), f32(w));
    }
    return vec3<f32>(-1.0, 0.0, 0.0);
}

// State carried between dispatches (parts.wgsl): t, the start of the next elementary interval.
fn march_start(part: vec2<f32>) -> MarchState {
    return MarchState(part.x, 0.0, 0.0, 0u);
}

fn march_part(sp: ptr<function, RaySupports>, ray: Ray, part: vec2<f32>, trace: ptr<function, Trace>, state: ptr<function, MarchState>, allowance: u32) {
    let c = frame.globals.isovalue;
    let items = support_count(sp);
    var t = (*state).t;
    while t < part.y && (*trace).steps < allowance {
        // The next node of any support in the part.
        var next = INF;
        for (var j = 0u; j < items; j++) {
            let span = support_item(sp, ray, j).span;
            if sherstyuk_node(span, SHERSTYUK_PIECES) <= t || span.x > part.y || span.y <= span.x {
                continue;
            }
            for (var i = 0u; i <= SHERSTYUK_PIECES; i++) {
                let node = sherstyuk_node(span, i);
                if node > t {
                    next = min(next, node);
                    break;
                }
            }
        }
        if next == INF {
            // No node ahead: the last one rounded a few ulps below the part's end. The part
            // is done (the CPU has no interval past its last node either).
            t = part.y;
            break;
        }
        (*trace).steps += 1u;
        // The summed Hermite data at t and next: every piece covering [t, next].
        var at_t = vec2<f32>(0.0);
        var at_next = vec2<f32>(0.0);
        for (var j = 0u; j < items; j++) {
            let item = support_item(sp, ray, j);
            let span = item.span;
            // The pieces end at their computed nodes, the last a few ulps off span.y.
            if span.x > t || sherstyuk_node(span, SHERSTYUK_PIECES) < next || span.y <= span.x {
                continue;
            }
            var i = 0u;
            while i + 1u < SHERSTYUK_PIECES && sherstyuk_node(span, i + 1u) <= t {
                i += 1u;
            }
            let a = sherstyuk_node(span, i);
            let b = sherstyuk_node(span, i + 1u);
            let m = hermite_monomial(sherstyuk_sample(ray, item.id, a), sherstyuk_sample(ray, item.id, b), b - a);
            at_t += hermite_at(m, a, b - a, t);
            at_next += hermite_at(m, a, b - a, next);
        }
        let l = next - t;
        let m = hermite_monomial(at_t, at_next, l);
        // The interval's crossings, one per monotone part of its cubic: a frame's ray ends at
        // the first, transparent statistics take them all, as the CPU does.
        var first_part = 0u;
        loop {
            let crossing = hermite_crossing(m, c, first_part);
            if crossing.x < 0.0 {
                break;
            }
            if crossing_ends_march(trace, t + crossing.x * l, crossing.y > 0.5) {
                return;
            }
            first_part = u32(crossing.z) + 1u;
        }
        t = next;
    }
    *state = MarchState(t, 0.0, 0.0, 0u);
}
