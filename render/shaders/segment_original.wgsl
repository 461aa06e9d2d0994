// Segment tracing as Galin et al. 2020 publish it, the baseline of forward-inclusion 2023's
// Table 1 (core: methods/segment_original.rs): at t, the Lipschitz bound λ of the candidate
// segment [t, t + s] sums each primitive's bound — for point blobs the kernel's largest slope on
// the segment's distance range times the largest cosine between ray and the direction from the
// centre (point.rs kernel_slope_times_cosine), for the others the range of their own derivative
// — through the blend (blend_lipschitz); the march advances max(min(|f − c|/λ, s), ε) and the
// next segment is 1.5 times that step. A part's first segment is the whole part. A crossing is
// reported at the first sample on the other side of the isovalue. SEGMENT_GROWTH is emitted
// before this file from core's SegmentOriginal::GROWTH.

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
    let rho = prim.a.w;
    let t_closest = dot(prim.a.xyz - ray.origin, ray.dir);
    let off = ray.origin + t_closest * ray.dir - prim.a.xyz;
    let h2 = dot(off, off) / (rho * rho);
    let a = (max(lo, item.span.x) - t_closest) / rho;
    let b = (min(hi, item.span.y) - t_closest) / rho;
    let nearest = clamp(0.0, a, b);
    let farthest = max(abs(a), abs(b));
    let distances = vec2<f32>(nearest * nearest + h2, farthest * farthest + h2);
    let cosine = select(0.0, farthest / sqrt(farthest * farthest + h2), farthest > 0.0);
    return prim.c.x * kernel_max_slope_on(k, distances) * cosine / rho;
}

// λ over [lo, hi] (program.rs summed_lipschitz with PrimitiveSlope::Published).
fn published_lipschitz(sp: ptr<function, RaySupports>, ray: Ray, lo: f32, hi: f32) -> f32 {
    var groups: array<f32, MAX_GROUPS>;
    let items = support_count(sp);
    for (var j = 0u; j < items; j++) {
        let item = support_item(sp, ray, j);
        if !overlaps(item, lo, hi) {
            continue;
        }
        var slope: f32;
        if HAS_POINT && primitives[item.id].kind == KIND_POINT {
            slope = point_published_slope(ray, item, lo, hi);
        } else {
            let d1 = item_jet(ray, item, lo, hi).d1;
            slope = max(abs(d1.x), abs(d1.y));
        }
        groups[primitives[item.id].group] += slope;
    }
    return blend_lipschitz(groups);
}

// State carried between dispatches (parts.wgsl): carry0 the next segment's length; flags 1: a
// side was seen, 2: it was inside.
fn march_start(part: vec2<f32>) -> MarchState {
    return MarchState(part.x, part.y - part.x, 0.0, 0u);
}

fn march_part(sp: ptr<function, RaySupports>, ray: Ray, part: vec2<f32>, trace: ptr<function, Trace>, state: ptr<function, MarchState>, allowance: u32) {
    let c = globals.isovalue;
    var t = (*state).t;
    var segment = (*state).carry0;
    var has_side = ((*state).flags & 1u) != 0u;
    var side = ((*state).flags & 2u) != 0u;
    while t < part.y && (*trace).steps < allowance {
        (*trace).steps += 1u;
        let f = along_ray(sp, ray, t).x;
        let inside = f >= c;
        if has_side && side != inside {
            (*trace).t = t;
            (*trace).hit = true;
            (*trace).entering = inside;
            return;
        }
        has_side = true;
        side = inside;
        let hi = min(t + segment, part.y);
        let lambda = published_lipschitz(sp, ray, t, hi);
        let width = hi - t;
        let step = max(select(width, min(abs(f - c) / lambda, width), lambda > 0.0), globals.epsilon);
        t += step;
        segment = SEGMENT_GROWTH * step;
    }
    *state = MarchState(t, segment, 0.0, select(0u, 1u, has_side) | select(0u, 2u, side));
}
