// Inclusions for segment tracing and the Taylor and bottom-up methods (core: primitives/point.rs,
// segment.rs, scalis.rs and shapes.rs ray_jet, inclusion.rs, bottom_up.rs; forward-inclusion
// 2023 §5–6, appendices A–C) over point blobs, distance and SCALIS segments and planes; scenes
// with other primitives run these methods on the CPU. `METHOD` is set by the composer: 0 segment, 1 linear-taylor,
// 2 quadratic-taylor, 3 bottom-up-quadratic.

struct Jet {
    value: vec2<f32>,
    d1: vec2<f32>,
    d2: vec2<f32>,
};

fn hull_with(i: vec2<f32>, v: f32) -> vec2<f32> {
    return vec2<f32>(min(i.x, v), max(i.y, v));
}

// The jet of point blob i over [lo, hi] (exact extrema, MATH.md §5).
fn point_jet(ray: Ray, i: u32, lo: f32, hi: f32) -> Jet {
    let prim = primitives[i];
    let k = kernels[prim.group];
    let rho = prim.a.w;
    let norm = prim.c.x;
    let t_closest = dot(prim.a.xyz - ray.origin, ray.dir);
    let off = ray.origin + t_closest * ray.dir - prim.a.xyz;
    let h2 = dot(off, off) / (rho * rho);
    let a = (lo - t_closest) / rho;
    let b = (hi - t_closest) / rho;
    let near = clamp(0.0, a, b);
    let far = select(b, a, abs(a) > abs(b));
    let value = vec2<f32>(norm * kernel_d1(k, min(far * far + h2, k.support_sq)).x,
                          norm * kernel_d1(k, min(near * near + h2, k.support_sq)).x);
    var d1 = vec2<f32>(INF, -INF);
    var d2 = vec2<f32>(INF, -INF);
    // Critical points of f′ and f″ (KernelProfile::point_critical_tau2).
    let s2 = 1.0 / k.inv_sigma2;
    var c1: f32;
    var c2: f32;
    if k.family == 0u {
        let p = max(s2 - h2, 0.0);
        let q = 2.0 * k.exponent - 1.0;
        c1 = p / q;
        c2 = 3.0 * p / q;
    } else if k.family == 1u {
        let bb = s2 + h2;
        let q = 2.0 * k.exponent + 1.0;
        c1 = bb / q;
        c2 = 3.0 * bb / q;
    } else {
        c1 = 0.5 * s2;
        c2 = 1.5 * s2;
    }
    var taus = array<f32, 7>(a, b, sqrt(c1), -sqrt(c1), 0.0, sqrt(c2), -sqrt(c2));
    for (var j = 0; j < 7; j++) {
        let tau = taus[j];
        if tau < a || tau > b {
            continue;
        }
        let kk = kernel_d2_inside(k, min(tau * tau + h2, k.support_sq));
        if j < 4 {
            d1 = hull_with(d1, norm * kk.y * 2.0 * tau / rho);
        }
        if j < 2 || j >= 4 {
            d2 = hull_with(d2, norm * (kk.z * 4.0 * tau * tau + 2.0 * kk.y) / (rho * rho));
        }
    }
    return Jet(value, d1, d2);
}

fn jet_add(a: Jet, b: Jet) -> Jet {
    return Jet(a.value + b.value, a.d1 + b.d1, a.d2 + b.d2);
}

fn jet_max(f: Jet, g: Jet) -> Jet {
    if f.value.x >= g.value.y {
        return f;
    } else if g.value.x >= f.value.y {
        return g;
    }
    return Jet(vec2<f32>(max(f.value.x, g.value.x), max(f.value.y, g.value.y)),
               vec2<f32>(min(f.d1.x, g.d1.x), max(f.d1.y, g.d1.y)),
               vec2<f32>(min(f.d2.x, g.d2.x), INF));
}

fn jet_neg(f: Jet) -> Jet {
    return Jet(-f.value.yx, -f.d1.yx, -f.d2.yx);
}

// Jet of the smooth maximum (blend.rs smooth_max_jet): the larger operand where their ranges
// stay `width` apart; otherwise value in [max, max + w/4], f′ in the hull of theirs, f″ in the
// hull of theirs widened up by max (a′ − b′)²/2w.
fn jet_smooth_max(a: Jet, b: Jet, width: f32) -> Jet {
    if a.value.x - b.value.y >= width {
        return a;
    }
    if b.value.x - a.value.y >= width {
        return b;
    }
    let spread = max(abs(a.d1.x - b.d1.y), abs(a.d1.y - b.d1.x));
    return Jet(vec2<f32>(max(a.value.x, b.value.x), max(a.value.y, b.value.y) + 0.25 * width),
               vec2<f32>(min(a.d1.x, b.d1.x), max(a.d1.y, b.d1.y)),
               vec2<f32>(min(a.d2.x, b.d2.x), max(a.d2.y, b.d2.y) + spread * spread / (2.0 * width)));
}

// The support item overlaps [lo, hi].
fn overlaps(item: SupportItem, lo: f32, hi: f32) -> bool {
    return item.span.x <= item.span.y && item.span.x <= hi && item.span.y >= lo;
}

// ---- interval arithmetic on (lo, hi) pairs (interval.rs) ----

// End-point product with the interval convention 0 · ∞ = 0.
fn mul_ends(a: f32, b: f32) -> f32 {
    if a == 0.0 || b == 0.0 {
        return 0.0;
    }
    return a * b;
}

fn i_mul(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    let p = vec4<f32>(mul_ends(a.x, b.x), mul_ends(a.x, b.y), mul_ends(a.y, b.x), mul_ends(a.y, b.y));
    return vec2<f32>(min(min(p.x, p.y), min(p.z, p.w)), max(max(p.x, p.y), max(p.z, p.w)));
}

fn i_scale(a: vec2<f32>, k: f32) -> vec2<f32> {
    let p = vec2<f32>(mul_ends(a.x, k), mul_ends(a.y, k));
    return vec2<f32>(min(p.x, p.y), max(p.x, p.y));
}

fn i_square(a: vec2<f32>) -> vec2<f32> {
    if a.x >= 0.0 {
        return a * a;
    }
    if a.y <= 0.0 {
        return vec2<f32>(a.y * a.y, a.x * a.x);
    }
    return vec2<f32>(0.0, max(a.x * a.x, a.y * a.y));
}

fn i_new(a: f32, b: f32) -> vec2<f32> {
    return vec2<f32>(min(a, b), max(a, b));
}

fn jet_scale(f: Jet, k: f32) -> Jet {
    return Jet(i_scale(f.value, k), i_scale(f.d1, k), i_scale(f.d2, k));
}

// Ranges of K, K′, K″ over x ∈ xs (kernel.rs KernelProfile::ranges), and whether xs straddles
// the support boundary of a kinked kernel.
struct KernelRanges {
    value: vec2<f32>,
    d1: vec2<f32>,
    d2: vec2<f32>,
    kink: bool,
};

fn kernel_ranges(k: Kernel, xs: vec2<f32>) -> KernelRanges {
    let lo = max(xs.x, 0.0);
    let hi = max(xs.y, lo);
    if lo >= k.support_sq {
        return KernelRanges(vec2<f32>(0.0), vec2<f32>(0.0), vec2<f32>(0.0), false);
    }
    let at_lo = kernel_d2_inside(k, lo);
    if hi >= k.support_sq {
        let edge = kernel_raw(k, k.support_sq).y * k.clip_scale;
        return KernelRanges(vec2<f32>(0.0, at_lo.x),
                            hull_with(vec2<f32>(at_lo.y, max(edge, at_lo.y)), 0.0),
                            vec2<f32>(0.0, at_lo.z), k.kinked != 0u);
    }
    let at_hi = kernel_d2_inside(k, hi);
    return KernelRanges(vec2<f32>(at_hi.x, at_lo.x), vec2<f32>(at_lo.y, at_hi.y),
                        vec2<f32>(at_hi.z, at_lo.z), false);
}

// Squared distance between the segments [p0, p1] and [q0, q1] (geometry.rs).
fn segment_segment_distance_sq(p0: vec3<f32>, p1: vec3<f32>, q0: vec3<f32>, q1: vec3<f32>) -> f32 {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let a = dot(d1, d1);
    let e = dot(d2, d2);
    let f = dot(d2, r);
    let tiny = 1.2e-7;
    var s = 0.0;
    var t = 0.0;
    if a <= tiny && e <= tiny {
        return dot(r, r);
    }
    if a <= tiny {
        t = clamp(f / e, 0.0, 1.0);
    } else {
        let c = dot(d1, r);
        if e <= tiny {
            s = clamp(-c / a, 0.0, 1.0);
        } else {
            let b = dot(d1, d2);
            let denom = a * e - b * b;
            var s0 = 0.0;
            if denom > 0.0 {
                s0 = clamp((b * f - c * e) / denom, 0.0, 1.0);
            }
            let t0 = (b * s0 + f) / e;
            if t0 < 0.0 {
                s = clamp(-c / a, 0.0, 1.0);
            } else if t0 > 1.0 {
                t = 1.0;
                s = clamp((b - c) / a, 0.0, 1.0);
            } else {
                t = t0;
                s = s0;
            }
        }
    }
    let gap = (p0 + s * d1) - (q0 + t * d2);
    return dot(gap, gap);
}

const MAX_BOUND_PIECES: f32 = 24.0;

// The jet of SCALIS segment i over [lo, hi] (scalis.rs ray_jet): the segment cut into pieces;
// on each, the ranges of the squared homothetic distance, of the kernel and of 1/τ enclose the
// integrand's value and derivatives.
fn scalis_jet(ray: Ray, i: u32, lo: f32, hi: f32) -> Jet {
    let prim = primitives[i];
    let cone = cone_of(prim);
    let k = kernels[prim.group];
    let ray_a = ray.origin + lo * ray.dir;
    let ray_b = ray.origin + hi * ray.dir;
    let pieces = u32(clamp(ceil(2.0 * cone.length / cone.radius), 2.0, MAX_BOUND_PIECES));
    let ds = cone.length / f32(pieces);
    let w_origin = dot(ray.dir, ray.origin - cone.start);
    let uv = dot(ray.dir, cone.axis);
    var jet = Jet(vec2<f32>(0.0), vec2<f32>(0.0), vec2<f32>(0.0));
    for (var piece = 0u; piece < pieces; piece++) {
        let sa = f32(piece) * ds;
        let sb = f32(piece + 1u) * ds;
        let qa = cone.start + sa * cone.axis;
        let qb = cone.start + sb * cone.axis;
        let tau_a = cone.radius + cone.slope * sa;
        let tau_b = cone.radius + cone.slope * sb;
        let d_min = segment_segment_distance_sq(ray_a, ray_b, qa, qb);
        let corners = vec4<f32>(dot(ray_a - qa, ray_a - qa), dot(ray_a - qb, ray_a - qb),
                                dot(ray_b - qa, ray_b - qa), dot(ray_b - qb, ray_b - qb));
        let d_max = max(max(corners.x, corners.y), max(corners.z, corners.w));
        let x = i_new(d_min / (tau_b * tau_b), d_max / (tau_a * tau_a));
        if x.x >= k.support_sq {
            continue;
        }
        let w = hull_with(hull_with(i_new(w_origin + lo - sa * uv, w_origin + lo - sb * uv),
                                    w_origin + hi - sa * uv), w_origin + hi - sb * uv);
        let inv_tau = i_new(1.0 / tau_b, 1.0 / tau_a);
        let inv_tau3 = i_mul(i_square(inv_tau), inv_tau);
        let kr = kernel_ranges(k, x);
        var d2 = i_scale(i_mul(i_mul(i_mul(kr.d2, i_square(w)), inv_tau3), i_square(inv_tau)), 4.0)
            + i_scale(i_mul(kr.d1, inv_tau3), 2.0);
        if kr.kink {
            d2.y = INF;
        }
        let piece_jet = Jet(i_mul(kr.value, inv_tau), i_scale(i_mul(i_mul(kr.d1, w), inv_tau3), 2.0), d2);
        jet = jet_add(jet, jet_scale(piece_jet, ds));
    }
    return jet_scale(jet, prim.c.x);
}

// The jet of plane i over [lo, hi] (shapes.rs ray_jet): the kernel of the exact squared
// distance, an affine function of t squared, over ρ².
fn plane_jet(ray: Ray, i: u32, lo: f32, hi: f32) -> Jet {
    let prim = primitives[i];
    let k = kernels[prim.group];
    let a = dot(prim.a.xyz, ray.origin) - prim.a.w;
    let b = dot(prim.a.xyz, ray.dir);
    let distance = i_new(a + b * lo, a + b * hi);
    let inv_r2 = 1.0 / (prim.b.x * prim.b.x);
    // x = d²/ρ²: value, x′ = 2 d d′/ρ², x″ = 2 d′²/ρ².
    let x = Jet(i_scale(i_square(distance), inv_r2), i_scale(distance, 2.0 * b * inv_r2),
                vec2<f32>(2.0 * b * b * inv_r2));
    return jet_scale(jet_compose(k, x), prim.c.x);
}

// ---- jets of functions of t (interval.rs Jet) ----

const ENTIRE: vec2<f32> = vec2<f32>(-INF, INF);

fn i_recip(a: vec2<f32>) -> vec2<f32> {
    if a.x > 0.0 || a.y < 0.0 {
        return i_new(1.0 / a.x, 1.0 / a.y);
    }
    return ENTIRE;
}

fn jet_affine(a: f32, b: f32, lo: f32, hi: f32) -> Jet {
    return Jet(i_new(a + b * lo, a + b * hi), vec2<f32>(b), vec2<f32>(0.0));
}

// Exact jet of a t² + b t + c over [lo, hi].
fn jet_quadratic(a: f32, b: f32, c: f32, lo: f32, hi: f32) -> Jet {
    var value = i_new((a * lo + b) * lo + c, (a * hi + b) * hi + c);
    if a != 0.0 {
        let apex = -b / (2.0 * a);
        if apex >= lo && apex <= hi {
            value = hull_with(value, (a * apex + b) * apex + c);
        }
    }
    return Jet(value, i_new(2.0 * a * lo + b, 2.0 * a * hi + b), vec2<f32>(2.0 * a));
}

fn jet_hull(f: Jet, g: Jet) -> Jet {
    return Jet(vec2<f32>(min(f.value.x, g.value.x), max(f.value.y, g.value.y)),
               vec2<f32>(min(f.d1.x, g.d1.x), max(f.d1.y, g.d1.y)),
               vec2<f32>(min(f.d2.x, g.d2.x), max(f.d2.y, g.d2.y)));
}

// The hull of x and j, or j alone when x holds nothing yet.
fn hull_or(x: Jet, any: bool, j: Jet) -> Jet {
    if any {
        return jet_hull(x, j);
    }
    return j;
}

fn jet_mul(f: Jet, g: Jet) -> Jet {
    return Jet(i_mul(f.value, g.value),
               i_mul(f.d1, g.value) + i_mul(f.value, g.d1),
               i_mul(f.d2, g.value) + i_scale(i_mul(f.d1, g.d1), 2.0) + i_mul(f.value, g.d2));
}

// 1/f: (1/f)′ = −f′ r², (1/f)″ = 2 f′² r³ − f″ r² with r = 1/f.
fn jet_recip(f: Jet) -> Jet {
    let r = i_recip(f.value);
    let r2 = i_square(r);
    let d2a = i_mul(i_mul(i_scale(i_square(f.d1), 2.0), r2), r);
    let d2b = i_mul(f.d2, r2);
    return Jet(r, -i_mul(f.d1, r2).yx, vec2<f32>(d2a.x - d2b.y, d2a.y - d2b.x));
}

fn jet_div(f: Jet, g: Jet) -> Jet {
    return jet_mul(f, jet_recip(g));
}

// K ∘ x from a jet of x (kernel.rs compose): (K∘x)′ = K′x′, (K∘x)″ = K″x′² + K′x″, the upper
// f″ bound infinite where x straddles a kinked kernel's support boundary.
fn jet_compose(k: Kernel, x: Jet) -> Jet {
    let kr = kernel_ranges(k, x.value);
    var d2 = i_mul(kr.d2, i_square(x.d1)) + i_mul(kr.d1, x.d2);
    if kr.kink {
        d2.y = INF;
    }
    return Jet(kr.value, i_mul(kr.d1, x.d1), d2);
}

// The jet of |ray(t) − centre|² / radius² over [lo, hi]: a distance segment's squared
// homothetic distance where the closest point is an end cap (segment.rs `cap`).
fn cap_jet(ray: Ray, centre: vec3<f32>, radius: f32, lo: f32, hi: f32) -> Jet {
    let wc = ray.origin - centre;
    let x = jet_quadratic(1.0, 2.0 * dot(wc, ray.dir), dot(wc, wc), lo, hi);
    return jet_scale(x, 1.0 / (radius * radius));
}

// The jet of distance segment i over [lo, hi] (segment.rs ray_jet): the squared homothetic
// distance x is the hull of the formulas that can hold on the interval — either end cap, the
// side of the cone — as jets of t, composed with the kernel.
fn distance_segment_jet(ray: Ray, i: u32, lo: f32, hi: f32) -> Jet {
    let prim = primitives[i];
    let cone = cone_of(prim);
    let k = kernels[prim.group];
    let u = ray.dir;
    let w0 = ray.origin - cone.start;
    let a0 = dot(w0, cone.axis);
    let a1 = dot(u, cone.axis);
    let along = jet_affine(a0, a1, lo, hi);
    let lateral = max(dot(w0, w0) - a0 * a0, 0.0);
    let b2 = jet_quadratic(1.0 - a1 * a1, 2.0 * (dot(w0, u) - a0 * a1), lateral, lo, hi);
    let y0 = cone.radius + cone.slope * a0;
    let y1 = cone.slope * a1;
    let y = jet_affine(y0, y1, lo, hi);
    var s_star = along;
    if cone.slope > 0.0 {
        s_star = jet_add(along, jet_scale(jet_div(b2, y), cone.slope));
    }
    let s_range = s_star.value;
    let y_may_vanish = y.value.x <= 0.0;
    var x = Jet(ENTIRE, ENTIRE, ENTIRE);
    var any = false;
    if s_range.x <= 0.0 && !y_may_vanish {
        x = cap_jet(ray, cone.start, cone.radius, lo, hi);
        any = true;
    }
    if s_range.y >= cone.length || y_may_vanish {
        let end = cone.start + cone.length * cone.axis;
        x = hull_or(x, any, cap_jet(ray, end, cone.radius + cone.slope * cone.length, lo, hi));
        any = true;
    }
    if (s_range.y > 0.0 && s_range.x < cone.length) || y_may_vanish {
        let d2 = cone.slope * cone.slope;
        let denominator = jet_quadratic(y1 * y1 + d2 * (1.0 - a1 * a1),
                                        2.0 * y0 * y1 + d2 * 2.0 * (dot(w0, u) - a0 * a1),
                                        y0 * y0 + d2 * lateral, lo, hi);
        let side = jet_div(b2, denominator);
        x = hull_or(x, any, side);
    }
    x.value.x = max(x.value.x, 0.0);
    return jet_scale(jet_compose(k, x), prim.c.x);
}

fn primitive_jet(ray: Ray, i: u32, lo: f32, hi: f32) -> Jet {
    let kind = primitives[i].kind;
    if kind == 0u {
        return point_jet(ray, i, lo, hi);
    } else if kind == 1u {
        return distance_segment_jet(ray, i, lo, hi);
    } else if kind == 2u {
        return scalis_jet(ray, i, lo, hi);
    }
    return plane_jet(ray, i, lo, hi);
}

// The jet of an overlapping item over [lo, hi] (primitives/mod.rs ray_jet): taken on the part
// inside the support and extended by zero; where a kinked kernel's support boundary lies in
// [lo, hi], the upper f″ bound is infinite.
fn item_jet(ray: Ray, item: SupportItem, lo: f32, hi: f32) -> Jet {
    let inside = vec2<f32>(max(lo, item.span.x), min(hi, item.span.y));
    let jet = primitive_jet(ray, item.id, inside.x, inside.y);
    if inside.x == lo && inside.y == hi {
        return jet;
    }
    let kinked = kernels[primitives[item.id].group].kinked != 0u;
    return Jet(hull_with(jet.value, 0.0), hull_with(jet.d1, 0.0),
               vec2<f32>(min(jet.d2.x, 0.0), select(max(jet.d2.y, 0.0), INF, kinked)));
}

// Group jets over [lo, hi], blended (ray_jet), and the summed Lipschitz bound (summed_lipschitz).
fn ray_jet(sp: ptr<function, RaySupports>, ray: Ray, lo: f32, hi: f32) -> Jet {
    var groups: array<Jet, MAX_GROUPS>;
    for (var g = 0u; g < MAX_GROUPS; g++) {
        groups[g] = Jet(vec2<f32>(0.0), vec2<f32>(0.0), vec2<f32>(0.0));
    }
    let items = support_count(sp);
    for (var j = 0u; j < items; j++) {
        let item = support_item(sp, ray, j);
        if !overlaps(item, lo, hi) {
            continue;
        }
        let g = primitives[item.id].group;
        groups[g] = jet_add(groups[g], item_jet(ray, item, lo, hi));
    }
    let n = globals.counts.y;
    let op = globals.counts.z;
    if op >= 3u {
        // The smooth intersection is −smooth_max(−a, −b).
        let intersection = op == 4u;
        var folded = groups[0];
        if intersection {
            folded = jet_neg(folded);
        }
        for (var g = 1u; g < n; g++) {
            var next = groups[g];
            if intersection {
                next = jet_neg(next);
            }
            folded = jet_smooth_max(folded, next, globals.blend.x);
        }
        if intersection {
            folded = jet_neg(folded);
        }
        return folded;
    }
    var out = groups[0];
    for (var g = 1u; g < n; g++) {
        if op == 0u {
            out = jet_add(out, groups[g]);
        } else if op == 1u {
            out = jet_max(out, groups[g]);
        } else {
            out = jet_neg(jet_max(jet_neg(out), jet_neg(groups[g])));
        }
    }
    return out;
}

fn summed_lipschitz(sp: ptr<function, RaySupports>, ray: Ray, lo: f32, hi: f32) -> f32 {
    var groups: array<f32, MAX_GROUPS>;
    let items = support_count(sp);
    for (var j = 0u; j < items; j++) {
        let item = support_item(sp, ray, j);
        if !overlaps(item, lo, hi) {
            continue;
        }
        let d1 = item_jet(ray, item, lo, hi).d1;
        groups[primitives[item.id].group] += max(abs(d1.x), abs(d1.y));
    }
    var out = 0.0;
    for (var g = 0u; g < globals.counts.y; g++) {
        out = select(max(out, groups[g]), out + groups[g], globals.counts.z == 0u);
    }
    return out;
}

// ---- bottom-up quadratic (bottom_up.rs point_quadratic, inclusion.rs max) ----

fn kernel_convex(k: Kernel, x: f32) -> vec2<f32> {
    if x < 0.0 {
        let d0 = kernel_d1(k, 0.0);
        return vec2<f32>(d0.x + d0.y * x, d0.y);
    }
    return kernel_d1(k, x);
}

fn point_quadratic(ray: Ray, i: u32, t0: f32, h_in: f32) -> Inclusion {
    let prim = primitives[i];
    let k = kernels[prim.group];
    let inv = 1.0 / (prim.a.w * prim.a.w);
    let w = ray.origin + t0 * ray.dir - prim.a.xyz;
    let x0 = dot(w, w) * inv;
    let x1 = 2.0 * dot(w, ray.dir) * inv;
    let x2 = inv;
    let n = prim.c.x;
    let closest = -x1 / (2.0 * x2);
    var h = h_in;
    var x_other = x0 + h * (x1 + x2 * h);
    if closest > 0.0 && closest < h_in {
        h = 2.0 * closest;
        x_other = x0 + closest * (x1 + x2 * closest);
    }
    let k0 = kernel_convex(k, x0);
    var chord = k0.y;
    if abs(x_other - x0) > 1e-12 * (1.0 + abs(x0)) {
        chord = (kernel_convex(k, x_other).x - k0.x) / (x_other - x0);
    }
    return Inclusion(n * k0.x, vec2<f32>(n * k0.y * x1, n * k0.y * x2),
                     vec2<f32>(n * chord * x1, n * chord * x2), h);
}

// Quadratic Taylor inclusion (inclusion.rs ForwardInclusion::quadratic): a side whose f″ bound
// is infinite falls back to linear Taylor.
fn quadratic_taylor(f: f32, d: f32, jet: Jet, h: f32) -> Inclusion {
    var lower = vec2<f32>(d, 0.5 * jet.d2.x);
    var upper = vec2<f32>(d, 0.5 * jet.d2.y);
    if abs(jet.d2.x) >= INF {
        lower = vec2<f32>(jet.d1.x, 0.0);
    }
    if abs(jet.d2.y) >= INF {
        upper = vec2<f32>(jet.d1.y, 0.0);
    }
    return Inclusion(f, lower, upper, h);
}

fn inclusion_add(a: Inclusion, b: Inclusion) -> Inclusion {
    return Inclusion(a.start + b.start, a.lower + b.lower, a.upper + b.upper, min(a.length, b.length));
}

fn inclusion_neg(a: Inclusion) -> Inclusion {
    return Inclusion(-a.start, -a.upper, -a.lower, a.length);
}

fn offset_at(o: vec2<f32>, s: f32) -> f32 {
    return s * (o.x + o.y * s);
}

// Maximum of the groups' inclusions (appendix C), or their minimum when `negated` (the
// maximum of the negations, negated): one Bézier hull over all of them on the shortest of their
// intervals, as inclusion.rs ForwardInclusion::max. A pairwise fold would differ: each partial
// hull is re-evaluated on a shorter interval.
fn groups_max(groups: array<Inclusion, MAX_GROUPS>, negated: bool) -> Inclusion {
    var h = groups[0].length;
    for (var g = 1u; g < globals.counts.y; g++) {
        h = min(h, groups[g].length);
    }
    var best = groups[0];
    var c0 = -INF;
    var c1 = -INF;
    var c2 = -INF;
    for (var g = 0u; g < globals.counts.y; g++) {
        var item = groups[g];
        if negated {
            item = inclusion_neg(item);
        }
        // The last of equal starts, as Iterator::max_by.
        if g == 0u || item.start >= best.start {
            best = item;
        }
        c0 = max(c0, item.start);
        c1 = max(c1, item.start + 0.5 * h * item.upper.x);
        c2 = max(c2, item.start + offset_at(item.upper, h));
    }
    var upper = best.upper;
    if h > 0.0 {
        upper = vec2<f32>(2.0 * (c1 - c0) / h, (c0 - 2.0 * c1 + c2) / (h * h));
    }
    let out = Inclusion(c0, best.lower, upper, h);
    if negated {
        return inclusion_neg(out);
    }
    return out;
}

fn bottom_up_quadratic(sp: ptr<function, RaySupports>, ray: Ray, t: f32, h: f32) -> Inclusion {
    var groups: array<Inclusion, MAX_GROUPS>;
    for (var g = 0u; g < MAX_GROUPS; g++) {
        groups[g] = Inclusion(0.0, vec2<f32>(0.0), vec2<f32>(0.0), h);
    }
    let items = support_count(sp);
    for (var j = 0u; j < items; j++) {
        let item = support_item(sp, ray, j);
        if !overlaps(item, t, t + h) {
            continue;
        }
        let i = item.id;
        let g = primitives[i].group;
        var own: Inclusion;
        if primitives[i].kind == 0u {
            own = point_quadratic(ray, i, t, h);
        } else {
            // No bottom-up rule: the primitive's own quadratic Taylor inclusion (primitive_taylor).
            let vg = primitive_value_gradient(i, ray.origin + t * ray.dir);
            own = quadratic_taylor(vg.x, dot(vg.yzw, ray.dir), item_jet(ray, item, t, t + h), h);
        }
        groups[g] = inclusion_add(groups[g], own);
    }
    if globals.counts.z == 0u {
        var out = groups[0];
        for (var g = 1u; g < globals.counts.y; g++) {
            out = inclusion_add(out, groups[g]);
        }
        return out;
    }
    return groups_max(groups, globals.counts.z == 2u);
}

fn method_bound(sp: ptr<function, RaySupports>, ray: Ray, t: f32, f: f32, d: f32, h: f32) -> Inclusion {
    if METHOD == 0u {
        return symmetric(f, summed_lipschitz(sp, ray, t, t + h), h);
    } else if METHOD == 3u && globals.counts.z < 3u {
        return bottom_up_quadratic(sp, ray, t, h);
    }
    // Below: Taylor inclusions, also bottom-up-quadratic's fallback for the smooth operators,
    // which have no forward-inclusion composition rule (bottom_up.rs field_inclusion).
    let jet = ray_jet(sp, ray, t, t + h);
    if METHOD == 1u {
        return Inclusion(f, vec2<f32>(jet.d1.x, 0.0), vec2<f32>(jet.d1.y, 0.0), h);
    }
    return quadratic_taylor(f, d, jet, h);
}
