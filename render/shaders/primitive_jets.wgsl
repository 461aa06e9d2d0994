// Jets of each primitive kind over a ray interval, and of the blended field over a pixel's
// support window (core: field/primitives/point.rs, segment.rs, scalis.rs, shapes.rs
// ray_jet; hrbf.rs ray_jet; field/program.rs ray_jet and summed_lipschitz), for every
// primitive kind, blended by the scene's generated code (blend_wgsl.rs).

// A point blob seen along a ray over [lo, hi] (point.rs): the squared distance h² from the ray
// to its centre, and a and b, lo and hi measured from the ray's closest point, in radii.
fn point_along(ray: Ray, prim: Primitive, lo: f32, hi: f32) -> vec3<f32> {
    let rho = prim.a.w;
    let t_closest = dot(prim.a.xyz - ray.origin, ray.dir);
    let off = ray.origin + t_closest * ray.dir - prim.a.xyz;
    return vec3<f32>(dot(off, off) / (rho * rho), (lo - t_closest) / rho, (hi - t_closest) / rho);
}

// The jet of point blob i over [lo, hi] (exact extrema, MATH.md §5).
fn point_jet(ray: Ray, i: u32, lo: f32, hi: f32) -> Jet {
    let prim = primitives[i];
    let k = kernels[prim.group];
    let rho = prim.a.w;
    let norm = prim.c.x;
    let along = point_along(ray, prim, lo, hi);
    let h2 = along.x;
    let a = along.y;
    let b = along.z;
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

// The jet of max(c − e, 0)² + max(−e − c, 0)² for the local coordinate c = o + u t: the
// squared distance to the slab |c| ≤ e along one axis.
fn slab_excess_sq(o: f32, u: f32, e: f32, lo: f32, hi: f32) -> Jet {
    let c = jet_affine(o, u, lo, hi);
    return jet_add(jet_positive_part_squared(jet_sub(c, jet_constant(e))),
                   jet_positive_part_squared(jet_sub(jet_constant(-e), c)));
}

// The jet of a box, rounded box, torus or cylinder over [lo, hi] (shapes.rs ray_jet and
// distance_sq_jet): the squared distance to the solid built from jets of the local
// coordinates, over ρ², composed with the kernel.
fn shape_jet(ray: Ray, i: u32, lo: f32, hi: f32) -> Jet {
    let prim = primitives[i];
    let k = kernels[prim.group];
    let m = shape_frame(prim);
    let o = (ray.origin - prim.a.xyz) * m;
    let u = ray.dir * m;
    let e = prim.b;
    var d2: Jet;
    if prim.kind == KIND_BOX || prim.kind == KIND_ROUNDED_BOX {
        let rounded = prim.kind == KIND_ROUNDED_BOX;
        let half = e.xyz - select(vec3<f32>(0.0), vec3<f32>(e.w), rounded);
        d2 = jet_add(jet_add(slab_excess_sq(o.x, u.x, half.x, lo, hi),
                             slab_excess_sq(o.y, u.y, half.y, lo, hi)),
                     slab_excess_sq(o.z, u.z, half.z, lo, hi));
        if rounded {
            d2 = jet_positive_part_squared(jet_sub(jet_sqrt_above(d2, e.w), jet_constant(e.w)));
        }
    } else {
        let radial_sq = jet_quadratic(u.x * u.x + u.z * u.z, 2.0 * (o.x * u.x + o.z * u.z),
                                      o.x * o.x + o.z * o.z, lo, hi);
        if prim.kind == KIND_TORUS {
            // Distance to the local y axis: 1-Lipschitz along a line and convex, which keeps its
            // jet finite where the ray passes through the axis.
            let lateral = length(u.xz);
            var rho = jet_sqrt(radial_sq);
            let d1 = vec2<f32>(max(rho.d1.x, -lateral), min(rho.d1.y, lateral));
            rho.d1 = select(vec2<f32>(-lateral, lateral), d1, d1.x <= d1.y);
            rho.d2.x = max(rho.d2.x, 0.0);
            let a = jet_sub(rho, jet_constant(e.x));
            let tube = jet_sqrt_above(jet_add(jet_square(a), jet_square(jet_affine(o.y, u.y, lo, hi))), e.y);
            d2 = jet_positive_part_squared(jet_sub(tube, jet_constant(e.y)));
        } else {
            d2 = jet_add(jet_positive_part_squared(jet_sub(jet_sqrt_above(radial_sq, e.x), jet_constant(e.x))),
                         slab_excess_sq(o.y, u.y, e.y, lo, hi));
        }
    }
    return jet_scale(jet_compose(k, jet_scale(d2, 1.0 / (prim.a.w * prim.a.w))), prim.c.x);
}

// q/√(q + h²), 0 where both vanish (hrbf.rs ratio_sq).
fn ratio_sq(q: f32, h2: f32) -> f32 {
    let r = sqrt(q + h2);
    return select(0.0, q / r, r > 0.0);
}

// s/√(s² + h²), 0 where both vanish.
fn s_over_r(s: f32, h2: f32) -> f32 {
    let r = sqrt(s * s + h2);
    return select(0.0, s / r, r > 0.0);
}

// (2q + h²)/√(q + h²), 0 where both vanish.
fn bend_at(q: f32, h2: f32) -> f32 {
    let r = sqrt(q + h2);
    return select(0.0, (2.0 * q + h2) / r, r > 0.0);
}

// The jet of HRBF term i over [lo, hi] inside its set's box (hrbf.rs ray_jet, whose docs derive
// it): with s the parameter from the point of the line closest to the centre, h the line's
// distance to it and r = √(s² + h²), every factor of f, f′, f″ is monotone in s or in s², so
// its range comes from the interval's ends.
fn hrbf_jet(ray: Ray, i: u32, lo: f32, hi: f32) -> Jet {
    let prim = primitives[i];
    let u = ray.dir;
    let affine = jet_affine(dot(prim.c.xyz, ray.origin) + prim.b.w, dot(prim.c.xyz, u), lo, hi);
    let alpha = prim.a.w;
    let beta = prim.b.xyz;
    if alpha == 0.0 && all(beta == vec3<f32>(0.0)) {
        return affine;
    }
    let w = ray.origin - prim.a.xyz;
    let along = dot(w, u);
    let perpendicular = w - along * u;
    let h2 = dot(perpendicular, perpendicular);
    let h = sqrt(h2);
    let b = dot(beta, u);
    let a = dot(beta, perpendicular);
    let a_over_h = select(0.0, a / h, h > 0.0);
    let s0 = lo + along;
    let s1 = hi + along;
    let q = i_square(i_new(s0, s1));
    // Monotone in s: r·s and s/r.
    let rs = i_new(s0 * sqrt(s0 * s0 + h2), s1 * sqrt(s1 * s1 + h2));
    let sr = i_new(s_over_r(s0, h2), s_over_r(s1, h2));
    // Monotone in s²: r, s²/r, (2s² + h²)/r and h/r.
    let r = i_new(sqrt(q.x + h2), sqrt(q.y + h2));
    let s2r = i_new(ratio_sq(q.x, h2), ratio_sq(q.y, h2));
    let bend = i_new(bend_at(q.x, h2), bend_at(q.y, h2));
    var h_over_r2 = vec2<f32>(0.0);
    if h2 > 0.0 {
        h_over_r2 = i_new(h2 / (q.y + h2), h2 / (q.x + h2));
    }
    let h_over_r3 = i_new(pow_end(h_over_r2.x, 1.5), pow_end(h_over_r2.y, 1.5));
    let cube = i_new(r.x * r.x * r.x, r.y * r.y * r.y);
    let value = i_scale(cube, alpha) + i_scale(r, 3.0 * a) + i_scale(rs, 3.0 * b);
    let d1 = i_scale(rs, 3.0 * alpha) + i_scale(sr, 3.0 * a) + i_scale(s2r, 3.0 * b)
        + i_scale(r, 3.0 * b);
    let d2 = i_scale(bend, 3.0 * alpha) + i_scale(h_over_r3, 3.0 * a_over_h)
        + i_scale(i_mul(sr, h_over_r2), 3.0 * b) + i_scale(sr, 6.0 * b);
    return jet_add(Jet(value, d1, d2), affine);
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
    if HAS_POINT && kind == KIND_POINT {
        return point_jet(ray, i, lo, hi);
    } else if HAS_DISTANCE_SEGMENT && kind == KIND_DISTANCE_SEGMENT {
        return distance_segment_jet(ray, i, lo, hi);
    } else if HAS_SCALIS_SEGMENT && kind == KIND_SCALIS_SEGMENT {
        return scalis_jet(ray, i, lo, hi);
    } else if HAS_PLANE && kind == KIND_PLANE {
        return plane_jet(ray, i, lo, hi);
    } else if HAS_HRBF && kind == KIND_HRBF {
        return hrbf_jet(ray, i, lo, hi);
    }
    if !HAS_SHAPE {
        return jet_constant(0.0);
    }
    return shape_jet(ray, i, lo, hi);
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
fn group_jets(sp: ptr<function, RaySupports>, ray: Ray, lo: f32, hi: f32) -> array<Jet, GROUPS> {
    var groups: array<Jet, GROUPS>;
    for (var g = 0u; g < GROUPS; g++) {
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
    // Groups holding an HRBF set are clamped at 0 (program.rs clamp_group_slots).
    for (var g = 0u; g < frame.globals.group_count; g++) {
        if kernels[g].clamped != 0u {
            groups[g] = jet_max(groups[g], jet_constant(0.0));
        }
    }
    return groups;
}

// x^q for an interval end x ≥ 0 (Rust's powf at 0: 0^0 = 1, 0^q = ∞ for q < 0).
fn pow_end(x: f32, q: f32) -> f32 {
    if q == 0.0 {
        return 1.0;
    } else if x <= 0.0 {
        return select(INF, 0.0, q > 0.0);
    }
    return pow(x, q);
}

// The blend's operators on jets (blend.rs jet), which `blend_jets` (blend_wgsl.rs, generated
// per scene) nests in the shape of the scene's tree.

// min(f, g) = −max(−f, −g).
fn jet_min(f: Jet, g: Jet) -> Jet {
    return jet_neg(jet_max(jet_neg(f), jet_neg(g)));
}

// min(a, 2c − b).
fn jet_difference(a: Jet, b: Jet) -> Jet {
    return jet_min(a, jet_sub(jet_constant(2.0 * frame.globals.isovalue), b));
}

// The Ricci blend's jet (blend.rs ricci_jet, whose docs derive it) in two passes over the
// operands. The first gathers the operands that may be positive: how many, the last of them,
// the sum of their positive parts (the blend for p = 1) and the p-th powers of the ends of their
// clamped values gᵢ = max(fᵢ, 0).
struct RicciEnds {
    positive: u32,
    only: Jet,
    sum: Jet,
    lo: f32,
    hi: f32,
};

fn ricci_ends_start() -> RicciEnds {
    return RicciEnds(0u, jet_constant(0.0), jet_constant(0.0), 0.0, 0.0);
}

// gᵢ with the C¹ clamp: where fᵢ crosses 0, gᵢ′ and gᵢ″ are hulled with 0.
fn ricci_part(f: Jet) -> Jet {
    if f.value.x >= 0.0 {
        return f;
    }
    return Jet(vec2<f32>(0.0, f.value.y), hull_with(f.d1, 0.0), hull_with(f.d2, 0.0));
}

// A p-norm's terms relative to its largest term `scale` and its root, so that p-th powers of
// values far from 1 neither overflow nor underflow f32 (blend.rs p_norm): a term is 0 where
// every term is 0, the root infinite where a term is.
fn p_norm_term(x: f32, scale: f32, p: f32) -> f32 {
    return select(0.0, pow_end(x / scale, p), scale > 0.0 && scale < INF);
}

fn p_norm_root(sum: f32, scale: f32, p: f32) -> f32 {
    if scale >= INF {
        return INF;
    }
    return mul_ends(scale, pow_end(sum, 1.0 / p));
}

// The largest ends of the clamped values gᵢ, the scales of the two p-norms below.
fn ricci_scale_add(scale: vec2<f32>, f: Jet) -> vec2<f32> {
    return max(scale, vec2<f32>(max(f.value.x, 0.0), f.value.y));
}

fn ricci_ends_add(acc: RicciEnds, f: Jet, p: f32, scale: vec2<f32>) -> RicciEnds {
    if f.value.y <= 0.0 {
        return acc;
    }
    let g = ricci_part(f);
    return RicciEnds(acc.positive + 1u, f, jet_add(acc.sum, jet_max(f, jet_constant(0.0))),
                     acc.lo + p_norm_term(g.value.x, scale.x, p),
                     acc.hi + p_norm_term(g.value.y, scale.y, p));
}

// The second pass: the blend's value range, the weights uᵢ^(p−1) on the operands' slopes and
// curvatures, and the convexity term's sup Σ uᵢ^(p−2) gᵢ′².
struct RicciWeights {
    value: vec2<f32>,
    d1: vec2<f32>,
    weighted_d2: vec2<f32>,
    curvature: f32,
};

fn ricci_weights_start(ends: RicciEnds, p: f32, scale: vec2<f32>) -> RicciWeights {
    return RicciWeights(vec2<f32>(p_norm_root(ends.lo, scale.x, p),
                                  p_norm_root(ends.hi, scale.y, p)),
                        vec2<f32>(0.0), vec2<f32>(0.0), 0.0);
}

fn ricci_weights_add(acc: RicciWeights, f: Jet, p: f32) -> RicciWeights {
    if f.value.y <= 0.0 {
        return acc;
    }
    let g = ricci_part(f);
    var u = vec2<f32>(g.value.x / acc.value.y, 1.0);
    if acc.value.x > 0.0 {
        u.y = min(g.value.y / acc.value.x, 1.0);
    }
    let weight = vec2<f32>(pow_end(u.x, p - 1.0), pow_end(u.y, p - 1.0));
    var out = acc;
    out.d1 += i_mul(weight, g.d1);
    out.weighted_d2 += i_mul(weight, g.d2);
    let slope_squared = i_square(g.d1).y;
    if slope_squared > 0.0 {
        out.curvature += mul_ends(pow_end(select(u.x, u.y, p >= 2.0), p - 2.0), slope_squared);
    }
    return out;
}

fn ricci_jet_finish(ends: RicciEnds, w: RicciWeights, p: f32) -> Jet {
    if ends.positive == 0u {
        return jet_constant(0.0);
    } else if ends.positive == 1u {
        return jet_max(ends.only, jet_constant(0.0));
    } else if p == 1.0 {
        return ends.sum;
    }
    let curvature = max(w.curvature - i_square(w.d1).x, 0.0);
    var t_hi = 0.0;
    if curvature > 0.0 {
        t_hi = select(INF, (p - 1.0) * curvature / w.value.x, w.value.x > 0.0 && curvature < INF);
    }
    return Jet(w.value, w.d1, vec2<f32>(w.weighted_d2.x, w.weighted_d2.y + t_hi));
}

// The field's jet over [lo, hi] (blend.rs jet): the group jets through the scene's blend.
fn ray_jet(sp: ptr<function, RaySupports>, ray: Ray, lo: f32, hi: f32) -> Jet {
    return blend_jets(group_jets(sp, ray, lo, hi));
}

// Segment tracing's Lipschitz bound over [lo, hi] (blend.rs lipschitz, program.rs
// summed_lipschitz): per group, the sum of its items' largest |f′| — the range of their jets'
// derivative, or for point blobs when `published`, Galin et al.'s bound (PrimitiveSlope::
// Published, point_published_slope) — through the scene's blend (`blend_lipschitz`).
fn summed_lipschitz(sp: ptr<function, RaySupports>, ray: Ray, lo: f32, hi: f32, published: bool) -> f32 {
    var groups: array<f32, GROUPS>;
    let items = support_count(sp);
    for (var j = 0u; j < items; j++) {
        let item = support_item(sp, ray, j);
        if !overlaps(item, lo, hi) {
            continue;
        }
        var slope: f32;
        if published && HAS_POINT && primitives[item.id].kind == KIND_POINT {
            slope = point_published_slope(ray, item, lo, hi);
        } else {
            let d1 = item_jet(ray, item, lo, hi).d1;
            slope = max(abs(d1.x), abs(d1.y));
        }
        groups[primitives[item.id].group] += slope;
    }
    return blend_lipschitz(groups);
}

// Where 2√x·|K′(x)| peaks inside the support (kernel.rs steepest_x).
fn kernel_steepest_x(k: Kernel) -> f32 {
    let s2 = 1.0 / k.inv_sigma2;
    var critical = 0.5 * s2;
    if k.family == KERNEL_COMPACT_POLYNOMIAL {
        critical = s2 / (2.0 * k.exponent - 1.0);
    } else if k.family == KERNEL_CAUCHY {
        critical = s2 / (2.0 * k.exponent + 1.0);
    }
    return min(critical, k.support_sq);
}

// The largest slope in r = √x of the kernel over x ∈ xs (kernel.rs max_slope_on).
fn kernel_max_slope_on(k: Kernel, xs: vec2<f32>) -> f32 {
    let lo = clamp(xs.x, 0.0, k.support_sq);
    let hi = clamp(xs.y, lo, k.support_sq);
    let x = clamp(kernel_steepest_x(k), lo, hi);
    return 2.0 * sqrt(x) * abs(kernel_d2_inside(k, x).y);
}

// Galin et al.'s bound of a point blob's |f′| over [lo, hi] ∩ its support (point.rs
// kernel_slope_times_cosine): the kernel's largest slope times the largest |cos|.
fn point_published_slope(ray: Ray, item: SupportItem, lo: f32, hi: f32) -> f32 {
    let prim = primitives[item.id];
    let k = kernels[prim.group];
    let along = point_along(ray, prim, max(lo, item.span.x), min(hi, item.span.y));
    let h2 = along.x;
    let a = along.y;
    let b = along.z;
    let nearest = clamp(0.0, a, b);
    let farthest = max(abs(a), abs(b));
    let distances = vec2<f32>(nearest * nearest + h2, farthest * farthest + h2);
    let cosine = select(0.0, farthest / sqrt(farthest * farthest + h2), farthest > 0.0);
    return prim.c.x * kernel_max_slope_on(k, distances) * cosine / prim.a.w;
}
