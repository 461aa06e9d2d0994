// Jets of each primitive kind over a ray interval, and of the blended field over a pixel's
// support window (core: field/primitives/point.rs, segment.rs, scalis.rs, shapes.rs
// ray_jet; field/program.rs ray_jet and summed_lipschitz), for point blobs, distance and
// SCALIS segments and planes; scenes with other primitives run these methods on the CPU.

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
    if k.family == KERNEL_COMPACT_POLYNOMIAL {
        let p = max(s2 - h2, 0.0);
        let q = 2.0 * k.exponent - 1.0;
        c1 = p / q;
        c2 = 3.0 * p / q;
    } else if k.family == KERNEL_CAUCHY {
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

// The support item overlaps [lo, hi].
fn overlaps(item: SupportItem, lo: f32, hi: f32) -> bool {
    return item.span.x <= item.span.y && item.span.x <= hi && item.span.y >= lo;
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
    if kind == KIND_POINT {
        return point_jet(ray, i, lo, hi);
    } else if kind == KIND_DISTANCE_SEGMENT {
        return distance_segment_jet(ray, i, lo, hi);
    } else if kind == KIND_SCALIS_SEGMENT {
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
// Each group's jet over [lo, hi]: the sum of its primitives'.
fn group_jets(sp: ptr<function, RaySupports>, ray: Ray, lo: f32, hi: f32) -> array<Jet, MAX_GROUPS> {
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
    return groups;
}

fn ray_jet(sp: ptr<function, RaySupports>, ray: Ray, lo: f32, hi: f32) -> Jet {
    let groups = group_jets(sp, ray, lo, hi);
    let n = globals.group_count;
    let op = globals.blend_operator;
    if op >= BLEND_SMOOTH_UNION {
        // The smooth intersection is −smooth_max(−a, −b).
        let intersection = op == BLEND_SMOOTH_INTERSECTION;
        var folded = groups[0];
        if intersection {
            folded = jet_neg(folded);
        }
        for (var g = 1u; g < n; g++) {
            var next = groups[g];
            if intersection {
                next = jet_neg(next);
            }
            folded = jet_smooth_max(folded, next, globals.blend_width);
        }
        if intersection {
            folded = jet_neg(folded);
        }
        return folded;
    }
    var out = groups[0];
    for (var g = 1u; g < n; g++) {
        if op == BLEND_SUM {
            out = jet_add(out, groups[g]);
        } else if op == BLEND_MAX {
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
    for (var g = 0u; g < globals.group_count; g++) {
        out = select(max(out, groups[g]), out + groups[g], globals.blend_operator == BLEND_SUM);
    }
    return out;
}
