// Field inversion for Gaussian blobs (Bruckner 2019; core: methods/field_inversion.rs):
// D = ρ(σ√(−ln F) − 1), steps of 1.2·D, hit when D < 0.0125ρ or inside, 32 steps per part.
// globals.method: (unused, σ, smallest radius ρ, N0).

// Traced in one dispatch: never suspends (`resume` is unused; parts.wgsl).
fn trace_ray(sp: ptr<function, RaySupports>, ray: Ray, resume: ptr<function, Suspension>) -> Trace {
    var trace = Trace(0.0, false, false, 0u);
    let c = globals.isovalue;
    let sigma = globals.gauss_sigma;
    let radius = globals.gauss_radius;
    let norm = globals.gauss_norm;
    var start_at = 0.0;
    loop {
        let part = next_part(sp, ray, start_at);
        if part.x > part.y || trace.steps >= globals.max_steps {
            break;
        }
        var t = part.x;
        var in_span = 0u;
        while t < part.y && in_span < 32u && trace.steps < globals.max_steps {
            trace.steps += 1u;
            in_span += 1u;
            let f = along_ray(sp, ray, t).x;
            let unit = (f / norm) * (1.0 - 0.005) + 0.005;
            let distance = radius * (sigma * sqrt(max(-log(unit), 0.0)) - 1.0);
            if distance < 0.0125 * radius || f >= c {
                trace.t = t;
                trace.hit = true;
                trace.entering = true;
                return trace;
            }
            t += 1.2 * distance;
        }
        start_at = part.y;
    }
    return trace;
}
