// Segment tracing as Galin et al. 2020 publish it, the baseline of forward-inclusion 2023's Table 1
// (core: methods/segment_original.rs): at t, the Lipschitz bound λ of the candidate segment
// [t, t + s] sums each primitive's bound — for point blobs the kernel's largest slope on the
// segment's distance range times the largest cosine between ray and the direction from the centre
// (point.rs kernel_slope_times_cosine), for the others the range of their own derivative — through
// the blend (primitive_jets.wgsl summed_lipschitz, published); the march advances
// max(min(|f − c|/λ, s), ε) and the next segment is 1.5 times that step. A part's first segment
// is the whole part. A crossing is reported at the first sample on the other side of the
// isovalue. SEGMENT_GROWTH is emitted before this file from core's SegmentOriginal::GROWTH.

// State carried between dispatches (parts.wgsl): carry0 the next segment's length; flags 1: a
// side was seen, 2: it was inside.
fn march_start(part: vec2<f32>) -> MarchState {
    return MarchState(part.x, part.y - part.x, 0.0, 0u);
}

fn march_part(sp: ptr<function, RaySupports>, ray: Ray, part: vec2<f32>, trace: ptr<function, Trace>, state: ptr<function, MarchState>, allowance: u32) {
    let c = frame.globals.isovalue;
    var t = (*state).t;
    var segment = (*state).carry0;
    var has_side = ((*state).flags & 1u) != 0u;
    var side = ((*state).flags & 2u) != 0u;
    while t < part.y && (*trace).steps < allowance {
        (*trace).steps += 1u;
        let f = along_ray(sp, ray, t).x;
        let inside = f >= c;
        if has_side && side != inside && crossing_ends_march(trace, t, inside) {
            return;
        }
        has_side = true;
        side = inside;
        let hi = min(t + segment, part.y);
        let lambda = summed_lipschitz(sp, ray, t, hi, true);
        let width = hi - t;
        let step = max(select(width, min(abs(f - c) / lambda, width), lambda > 0.0), frame.globals.epsilon);
        t += step;
        segment = SEGMENT_GROWTH * step;
    }
    *state = MarchState(t, segment, 0.0, select(0u, 1u, has_side) | select(0u, 2u, side));
}
