// The SCALIS tracer (scalis 2021 §5–7; core: methods/scalis_quadratic.rs, normalised.rs):
// breakpoints at support boundaries and homothetic-distance minima, Hermite data of the
// normalised field F = g∘f − 1, the two-piece Bézier oracle of eq. 20 (rational weight 3 until
// a sign change), Algorithm 1 with one backtracking step, 32 iterations per piece. At a support
// limit the data are known without an evaluation (F = σ² − 1, flat), and the oracle gives a
// flat end the slope of the quadratic through both values and the other end's slope, as the
// CPU's default protocol does. In transparent statistics a piece's march goes on `min_step` past
// each crossing, as the CPU's does.

struct Hermite {
    t: f32,
    v: f32,
    d: f32,
    flat: bool,
};

var<private> scalis_steps: u32;

fn hermite(sp: ptr<function, RaySupports>, ray: Ray, t: f32) -> Hermite {
    scalis_steps += 1u;
    let fd = along_ray(sp, ray, t);
    let g = normalisation(fd.x);
    let v = g.x - 1.0;
    return Hermite(t, v, g.y * fd.y, v >= kernels[0].support_sq - 1.0);
}

// At a support limit, where the field is 0 by construction: no evaluation, no slope.
fn at_support_limit(t: f32) -> Hermite {
    return Hermite(t, kernels[0].support_sq - 1.0, 0.0, true);
}

fn flip(h: Hermite, sign: f32) -> Hermite {
    return Hermite(h.t, sign * h.v, sign * h.d, h.flat);
}

// Ray parameter of the minimum of the homothetic distance of segment i to the ray (eq. 16–19).
fn homothetic_argmin(ray: Ray, i: u32) -> f32 {
    let prim = primitives[i];
    let cone = cone_of(prim);
    let m = cone.start - ray.origin;
    let m_p = m - dot(m, ray.dir) * ray.dir;
    let u_p = cone.axis - dot(cone.axis, ray.dir) * ray.dir;
    let a = dot(m_p, m_p);
    let b = dot(m_p, u_p);
    let c = dot(u_p, u_p);
    var best_s = 0.0;
    var best = a / (cone.radius * cone.radius);
    let tau_end = cone.radius + cone.slope * cone.length;
    let at_end = (a + cone.length * (2.0 * b + c * cone.length)) / (tau_end * tau_end);
    if at_end < best {
        best = at_end;
        best_s = cone.length;
    }
    let den = c * cone.radius - cone.slope * b;
    if abs(den) > 0.0 {
        let s = (cone.slope * a - b * cone.radius) / den;
        if s >= 0.0 && s <= cone.length {
            let tau = cone.radius + cone.slope * s;
            let r = (a + s * (2.0 * b + c * s)) / (tau * tau);
            if r < best {
                best_s = s;
            }
        }
    }
    return dot(cone.start + best_s * cone.axis - ray.origin, ray.dir);
}

// First root in [0, 1] of the rational quadratic Bézier (p, weight w) and its abscissa; −INF if none.
fn bezier_root(p: vec3<f32>, x: vec3<f32>, w: f32) -> f32 {
    let r = quadratic_roots(p.x - 2.0 * w * p.y + p.z, 2.0 * (w * p.y - p.x), p.x);
    if r.x > r.y {
        return -INF;
    }
    var u = -1.0;
    if r.x >= 0.0 && r.x <= 1.0 {
        u = r.x;
    } else if r.y >= 0.0 && r.y <= 1.0 {
        u = r.y;
    }
    if u < 0.0 {
        return -INF;
    }
    let basis = vec3<f32>((1.0 - u) * (1.0 - u), 2.0 * w * u * (1.0 - u), u * u);
    return dot(basis, x) / (basis.x + basis.y + basis.z);
}

fn oracle(b: Hermite, e: Hermite, w: f32) -> f32 {
    let l = e.t - b.t;
    let secant = (e.v - b.v) / l;
    // A flat end's slope: the Hermite–Birkhoff quadratic's (the secant when both are flat).
    var bd = b.d;
    var ed = e.d;
    if b.flat && e.flat {
        bd = secant;
        ed = secant;
    } else if b.flat {
        bd = 2.0 * secant - e.d;
    } else if e.flat {
        ed = 2.0 * secant - b.d;
    }
    let mid = 0.5 * (b.v + e.v) + 0.125 * l * (bd - ed);
    let tm = b.t + 0.5 * l;
    let first = bezier_root(vec3<f32>(b.v, b.v + 0.25 * l * bd, mid), vec3<f32>(b.t, b.t + 0.25 * l, tm), w);
    if first > -INF {
        return first;
    }
    return bezier_root(vec3<f32>(mid, e.v - 0.25 * l * ed, e.v), vec3<f32>(tm, e.t - 0.25 * l, e.t), w);
}

// Algorithm 1 on [b, e] oriented so that b.v ≥ 0; the root's Hermite data (t = −INF: none).
fn find_root(sp: ptr<function, RaySupports>, ray: Ray, b_in: Hermite, e_in: Hermite, sign: f32) -> Hermite {
    var b = b_in;
    var e = e_in;
    var has_saved = false;
    var saved_b = b;
    var saved_e = e;
    let none = Hermite(-INF, 0.0, 0.0, false);
    for (var n = 0u; n < 32u; n++) {
        if scalis_steps >= frame.globals.max_steps {
            return none;
        }
        if e.t - b.t < frame.globals.epsilon {
            if e.v < 0.0 {
                return e;
            }
            return none;
        }
        let w = select(3.0, 1.0, e.v < 0.0);
        let t = oracle(b, e, w);
        if t == -INF {
            if !has_saved {
                return none;
            }
            b = saved_b;
            e = saved_e;
            has_saved = false;
            continue;
        }
        let r = flip(hermite(sp, ray, t), sign);
        if abs(r.v) <= abs(r.d) * frame.globals.epsilon || r.v == 0.0 {
            return r;
        }
        let rising = r.d > 0.0 && b.d < 0.0;
        if !has_saved && r.v >= 0.0 && e.v < 0.0 && rising {
            has_saved = true;
            saved_b = r;
            saved_e = e;
        }
        if r.v < 0.0 || rising {
            e = r;
        } else {
            b = r;
        }
    }
    return none;
}

// Breakpoints inside part (support boundaries and argmins), sorted, at least min_step apart.
const MAX_BREAKPOINTS: u32 = 50u;

// Traced in one dispatch: never suspends (`resume` is unused; parts.wgsl).
fn trace_ray(sp: ptr<function, RaySupports>, ray: Ray, resume: ptr<function, Suspension>) -> Trace {
    var trace = Trace(0.0, false, false, 0u);
    scalis_steps = 0u;
    var start_at = 0.0;
    let gap = frame.globals.min_step;
    loop {
        let part = next_part(sp, ray, start_at);
        if part.x > part.y || scalis_steps >= frame.globals.max_steps {
            break;
        }
        var points: array<f32, MAX_BREAKPOINTS>;
        var count = 1u;
        points[0] = part.x;
        let items = support_count(sp);
        for (var j = 0u; j < items; j++) {
            let item = support_item(sp, ray, j);
            let s = item.span;
            if s.x > s.y || s.y < part.x || s.x > part.y {
                continue;
            }
            let t = homothetic_argmin(ray, item.id);
            if t > part.x && t < part.y && count < MAX_BREAKPOINTS - 1u {
                var k = count;
                loop {
                    if k <= 1u {
                        break;
                    }
                    let before = points[k - 1u];
                    if before <= t {
                        break;
                    }
                    points[k] = before;
                    k -= 1u;
                }
                points[k] = t;
                count += 1u;
            }
        }
        // Drop points closer than `gap` to the previous kept one, then close with part.y.
        var kept = 1u;
        for (var j = 1u; j < count; j++) {
            if points[j] - points[kept - 1u] >= gap {
                points[kept] = points[j];
                kept += 1u;
            }
        }
        if kept > 1u && part.y - points[kept - 1u] < gap {
            kept -= 1u;
        }
        points[kept] = part.y;
        // Support limits: a part's start past where the search began, its end short of the
        // window's horizon and of the ray's end (next_part cuts parts there too).
        var b: Hermite;
        if part.x > start_at {
            b = at_support_limit(part.x);
        } else {
            b = hermite(sp, ray, points[0]);
        }
        let end_is_limit = part.y < (*sp).horizon && part.y < (*sp).far;
        for (var j = 1u; j <= kept; j++) {
            if scalis_steps >= frame.globals.max_steps {
                break;
            }
            var e: Hermite;
            if j == kept && end_is_limit {
                e = at_support_limit(part.y);
            } else {
                e = hermite(sp, ray, points[j]);
            }
            // The piece's crossings (core: scalis_quadratic.rs trace_piece): a frame's ray ends
            // at the first; transparent statistics go on `min_step` past each.
            loop {
                let sign = select(-1.0, 1.0, b.v >= 0.0);
                let r = find_root(sp, ray, flip(b, sign), flip(e, sign), sign);
                if r.t == -INF {
                    break;
                }
                var t = r.t;
                if r.d != 0.0 {
                    let newton = r.t - r.v / r.d;
                    if newton >= b.t && newton <= e.t {
                        t = newton;
                    }
                }
                trace.steps = scalis_steps;
                if crossing_ends_march(&trace, t, sign > 0.0) {
                    return trace;
                }
                let next = t + gap;
                if next >= e.t || scalis_steps >= frame.globals.max_steps {
                    break;
                }
                b = hermite(sp, ray, next);
            }
            b = e;
        }
        start_at = part.y;
    }
    trace.steps = scalis_steps;
    return trace;
}
