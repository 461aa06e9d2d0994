// Field inversion for Gaussian blobs (Bruckner 2019; core: methods/field_inversion.rs):
// D = ρ(σ√(−ln F) − 1), steps of 1.2·D, hit when D < 0.0125ρ or inside, 32 steps per union of
// supports; a step that lands inside is refined by bisection with the sample before it, to
// within ε, as the CPU's default profile does (the unrefined hit of `--protocol paper-2023` is
// CPU only). A union holds one crossing at most: transparent statistics go on with the next
// union, as the CPU does. Where the window's horizon cuts a union into parts, the march goes on
// in the next part with its samples and count (the CPU's union is one part).
// globals: σ, smallest radius ρ, N0 (gauss_*).

// Traced in one dispatch: never suspends (`resume` is unused; parts.wgsl).
fn trace_ray(sp: ptr<function, RaySupports>, ray: Ray, resume: ptr<function, Suspension>) -> Trace {
    var trace = Trace(0.0, false, false, 0u);
    let c = frame.globals.isovalue;
    let sigma = frame.globals.gauss_sigma;
    let radius = frame.globals.gauss_radius;
    let norm = frame.globals.gauss_norm;
    var start_at = 0.0;
    var t = 0.0;
    var previous = 0.0;
    var in_span = 0u;
    // The last part ended at the window's horizon, inside its union; its union's crossing was found.
    var cut = false;
    var union_done = false;
    loop {
        let part = next_part(sp, ray, start_at);
        if part.x > part.y || trace.steps >= frame.globals.max_steps {
            break;
        }
        let continues = cut && part.x == start_at;
        cut = part.y >= (*sp).horizon && part.y < (*sp).far;
        start_at = part.y;
        if !continues {
            t = part.x;
            previous = t;
            in_span = 0u;
            union_done = false;
        }
        if union_done {
            continue;
        }
        while t < part.y && in_span < 32u && trace.steps < frame.globals.max_steps {
            trace.steps += 1u;
            in_span += 1u;
            let f = along_ray(sp, ray, t).x;
            let unit = (f / norm) * (1.0 - 0.005) + 0.005;
            let distance = radius * (sigma * sqrt(max(-log(unit), 0.0)) - 1.0);
            if f >= c {
                var outside = previous;
                var inside = t;
                while inside - outside > frame.globals.epsilon {
                    let mid = 0.5 * (outside + inside);
                    if along_ray(sp, ray, mid).x >= c {
                        inside = mid;
                    } else {
                        outside = mid;
                    }
                }
                if crossing_ends_march(&trace, inside, true) {
                    return trace;
                }
                union_done = true;
                break;
            }
            if distance < 0.0125 * radius {
                if crossing_ends_march(&trace, t, true) {
                    return trace;
                }
                union_done = true;
                break;
            }
            previous = t;
            t += 1.2 * distance;
        }
    }
    return trace;
}
