// Forward inclusions of the marching methods over one interval (core: bounds/inclusion.rs,
// bounds/bottom_up.rs; forward-inclusion 2023 §5–6, appendices A–C) and the bound each
// method marches with. `METHOD` (BOUND_*) is set by the composer (shaders.rs).

// ---- bottom-up quadratic (bottom_up.rs point_quadratic, inclusion.rs max) ----

fn kernel_convex(k: Kernel, x: f32) -> vec2<f32> {
    if x < 0.0 {
        let d0 = kernel_d1(k, 0.0);
        return vec2<f32>(d0.x + d0.y * x, d0.y);
    }
    return kernel_d1(k, x);
}

// x(s) = x0 + x1·s + x2·s², the squared distance to point blob `prim` in units of its radius
// along the ray from t0 (bottom_up.rs squared_distance).
fn blob_squared_distance(ray: Ray, prim: Primitive, t0: f32) -> vec3<f32> {
    let inv = 1.0 / (prim.a.w * prim.a.w);
    let w = ray.origin + t0 * ray.dir - prim.a.xyz;
    return vec3<f32>(dot(w, w) * inv, 2.0 * dot(w, ray.dir) * inv, inv);
}

fn point_quadratic(ray: Ray, i: u32, t0: f32, h_in: f32) -> Inclusion {
    let prim = primitives[i];
    let k = kernels[prim.group];
    let x = blob_squared_distance(ray, prim, t0);
    let x0 = x.x;
    let x1 = x.y;
    let x2 = x.z;
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

// Linear bottom-up inclusion of a point blob (bottom_up.rs point_linear, §5.2): the chord of
// the convex K(tangent of x) above, the tangent of K(chord of x) below.
fn point_linear(ray: Ray, i: u32, t0: f32, h: f32) -> Inclusion {
    let prim = primitives[i];
    let k = kernels[prim.group];
    let x = blob_squared_distance(ray, prim, t0);
    let x0 = x.x;
    let x1 = x.y;
    let x2 = x.z;
    let n = prim.c.x;
    let k0 = kernel_convex(k, x0);
    var upper = 0.0;
    if h > 0.0 {
        upper = n * (kernel_convex(k, x0 + x1 * h).x - k0.x) / h;
    }
    let lower = n * k0.y * (x1 + x2 * h);
    return Inclusion(n * k0.x, vec2<f32>(lower, 0.0), vec2<f32>(upper, 0.0), h);
}

// Linear Taylor inclusion (inclusion.rs ForwardInclusion::linear).
fn linear_taylor(f: f32, jet: Jet, h: f32) -> Inclusion {
    return Inclusion(f, vec2<f32>(jet.d1.x, 0.0), vec2<f32>(jet.d1.y, 0.0), h);
}

// The lines under and over an inclusion's parabolas on its interval
// (inclusion.rs ForwardInclusion::linearized).
fn linearized(a: Inclusion) -> Inclusion {
    let h = a.length;
    var lower = vec2<f32>(a.lower.x, 0.0);
    if a.lower.y < 0.0 {
        lower.x = a.lower.x + a.lower.y * h;
    }
    var upper = vec2<f32>(a.upper.x, 0.0);
    if a.upper.y > 0.0 {
        upper.x = a.upper.x + a.upper.y * h;
    }
    return Inclusion(a.start, lower, upper, h);
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

// The groups' inclusions composed through the blend (inclusion.rs blend), which
// `compose_groups` (blend_wgsl.rs, generated per scene) nests in the shape of the scene's tree:
// sums add, maxima, minima and differences take the Bézier hull, a Ricci blend with at most one
// operand that may be positive is that operand's positive part. `valid` is false where no rule
// applies (the smooth operators, a Ricci blend of several positive operands, an operator
// without operands), and the caller bounds the whole field instead.
struct Composed {
    inclusion: Inclusion,
    valid: bool,
};

fn composed_add(a: Composed, b: Composed) -> Composed {
    return Composed(inclusion_add(a.inclusion, b.inclusion), a.valid && b.valid);
}

fn composed_neg(a: Composed) -> Composed {
    return Composed(inclusion_neg(a.inclusion), a.valid);
}

fn composed_shift(a: Composed, by: f32) -> Composed {
    var out = a;
    out.inclusion.start += by;
    return out;
}

// The maximum of inclusions (appendix C): one Bézier hull over all of them on the shortest of
// their intervals h, as inclusion.rs ForwardInclusion::max (a pairwise fold would differ: each
// partial hull is re-evaluated on a shorter interval). Started with the first operand, each
// further one added, then ended.
struct Hull {
    best: Inclusion,
    c: vec3<f32>,
    valid: bool,
};

fn hull_start(a: Composed, h: f32) -> Hull {
    let i = a.inclusion;
    return Hull(i, vec3<f32>(i.start, i.start + 0.5 * h * i.upper.x, i.start + offset_at(i.upper, h)),
                a.valid);
}

fn hull_add(acc: Hull, a: Composed, h: f32) -> Hull {
    let i = a.inclusion;
    var out = acc;
    // The last of equal starts, as Iterator::max_by.
    if i.start >= acc.best.start {
        out.best = i;
    }
    out.c = max(acc.c, vec3<f32>(i.start, i.start + 0.5 * h * i.upper.x, i.start + offset_at(i.upper, h)));
    out.valid = acc.valid && a.valid;
    return out;
}

fn hull_end(acc: Hull, h: f32) -> Composed {
    var upper = acc.best.upper;
    if h > 0.0 {
        upper = vec2<f32>(2.0 * (acc.c.y - acc.c.x) / h, (acc.c.x - 2.0 * acc.c.y + acc.c.z) / (h * h));
    }
    return Composed(Inclusion(acc.c.x, acc.best.lower, upper, h), acc.valid);
}

// max(f, 0) (inclusion.rs positive_part).
fn positive_part(a: Composed) -> Composed {
    let h = a.inclusion.length;
    let zero = Composed(Inclusion(0.0, vec2<f32>(0.0), vec2<f32>(0.0), h), true);
    return hull_end(hull_add(hull_start(a, h), zero, h), h);
}

// The largest value of an inclusion's upper parabola on its interval (inclusion.rs upper_max).
fn upper_max(a: Inclusion) -> f32 {
    let h = a.length;
    var top = max(a.start, a.start + offset_at(a.upper, h));
    if a.upper.y < 0.0 {
        let apex = -a.upper.x / (2.0 * a.upper.y);
        if apex > 0.0 && apex < h {
            top = max(top, a.start + offset_at(a.upper, apex));
        }
    }
    return top;
}

// A Ricci blend's inclusion: the operands that may be positive are counted, the last kept.
struct RicciInclusion {
    positive: u32,
    only: Composed,
    h: f32,
    valid: bool,
};

fn ricci_inclusion_start() -> RicciInclusion {
    return RicciInclusion(0u, Composed(Inclusion(0.0, vec2<f32>(0.0), vec2<f32>(0.0), INF), true),
                          INF, true);
}

fn ricci_inclusion_add(acc: RicciInclusion, a: Composed) -> RicciInclusion {
    var out = acc;
    out.h = min(acc.h, a.inclusion.length);
    out.valid = acc.valid && a.valid;
    if upper_max(a.inclusion) > 0.0 {
        out.positive += 1u;
        out.only = a;
    }
    return out;
}

fn ricci_inclusion_end(acc: RicciInclusion) -> Composed {
    if acc.positive == 0u {
        return Composed(Inclusion(0.0, vec2<f32>(0.0), vec2<f32>(0.0), acc.h), acc.valid);
    } else if acc.positive == 1u {
        var out = positive_part(acc.only);
        out.valid = acc.valid;
        return out;
    }
    return Composed(acc.only.inclusion, false);
}

// Bottom-up inclusion of the field (bottom_up.rs field_inclusion): point blobs by their own
// rule, other primitives by their Taylor inclusion of the same degree, summed per group and
// composed; the linear one is linearized after the composition.
fn bottom_up(sp: ptr<function, RaySupports>, ray: Ray, t: f32, h: f32, quadratic: bool) -> Composed {
    var groups: array<Inclusion, GROUPS>;
    for (var g = 0u; g < GROUPS; g++) {
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
        if HAS_POINT && primitives[i].kind == KIND_POINT {
            if quadratic {
                own = point_quadratic(ray, i, t, h);
            } else {
                own = point_linear(ray, i, t, h);
            }
        } else {
            // No bottom-up rule: the primitive's own Taylor inclusion (primitive_taylor); an
            // HRBF term is evaluated at t by the ray's interval in its box, not a point test.
            let p = ray.origin + t * ray.dir;
            var vg: vec4<f32>;
            if HAS_HRBF && primitives[i].kind == KIND_HRBF {
                vg = select(vec4<f32>(0.0), hrbf_inside(primitives[i], p), item.span.x <= t);
            } else {
                vg = primitive_value_gradient(i, p);
            }
            let jet = item_jet(ray, item, t, t + h);
            if quadratic {
                own = quadratic_taylor(vg.x, dot(vg.yzw, ray.dir), jet, h);
            } else {
                own = linear_taylor(vg.x, jet, h);
            }
        }
        groups[g] = inclusion_add(groups[g], own);
    }
    // Groups holding an HRBF set are clamped at 0: max(f, 0) (bottom_up.rs field_inclusion).
    for (var g = 0u; g < frame.globals.group_count; g++) {
        if kernels[g].clamped != 0u {
            groups[g] = positive_part(Composed(groups[g], true)).inclusion;
        }
    }
    var out = compose_groups(groups);
    if !quadratic {
        out.inclusion = linearized(out.inclusion);
    }
    return out;
}

// Mixed inclusion (forward-inclusion 2023 §7.2; marching.rs mixed_inclusion): each group's own
// Taylor inclusion from its value, slope and jet, composed through the blend.
fn mixed(sp: ptr<function, RaySupports>, ray: Ray, t: f32, h: f32, quadratic: bool) -> Composed {
    let values = groups_at(sp, ray, t);
    let jets = group_jets(sp, ray, t, t + h);
    var groups: array<Inclusion, GROUPS>;
    for (var g = 0u; g < GROUPS; g++) {
        if quadratic {
            groups[g] = quadratic_taylor(values[g].x, dot(values[g].yzw, ray.dir), jets[g], h);
        } else {
            groups[g] = linear_taylor(values[g].x, jets[g], h);
        }
    }
    return compose_groups(groups);
}

fn method_bound(sp: ptr<function, RaySupports>, ray: Ray, t: f32, f: f32, d: f32, h: f32) -> Inclusion {
    if METHOD == BOUND_SEGMENT {
        return symmetric(f, summed_lipschitz(sp, ray, t, t + h, false), h);
    }
    var composed = Composed(Inclusion(f, vec2<f32>(0.0), vec2<f32>(0.0), h), false);
    if METHOD == BOUND_BOTTOM_UP_QUADRATIC {
        composed = bottom_up(sp, ray, t, h, true);
    } else if METHOD == BOUND_BOTTOM_UP_LINEAR {
        composed = bottom_up(sp, ray, t, h, false);
    } else if METHOD == BOUND_LINEAR_MIXED {
        composed = mixed(sp, ray, t, h, false);
    } else if METHOD == BOUND_QUADRATIC_MIXED {
        composed = mixed(sp, ray, t, h, true);
    }
    if composed.valid {
        return composed.inclusion;
    }
    // Below: Taylor inclusions of the whole field, also the bottom-up and mixed methods'
    // fallback where the blend has no forward-inclusion composition rule (bottom_up.rs
    // field_inclusion, marching.rs mixed_inclusion).
    let jet = ray_jet(sp, ray, t, t + h);
    if METHOD == BOUND_LINEAR_TAYLOR || METHOD == BOUND_BOTTOM_UP_LINEAR
        || METHOD == BOUND_LINEAR_MIXED {
        return linear_taylor(f, jet, h);
    }
    return quadratic_taylor(f, d, jet, h);
}
