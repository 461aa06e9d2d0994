// Over-relaxed sphere tracing (Keinert et al. 2014; core: methods/sphere_enhanced.rs): steps
// of ω·r with ω = 1.6; when consecutive unbounding spheres do not overlap (or the side
// changed), go back and continue with ω = 1.

// State carried between dispatches (parts.wgsl): carry0 the previous radius, carry1 the last
// step; flags 1: a side was seen, 2: it was inside, 4: over-relaxed (ω = 1.6, else 1).
fn march_start(part: vec2<f32>) -> MarchState {
    return MarchState(part.x, 0.0, 0.0, 4u);
}

fn march_part(sp: ptr<function, RaySupports>, ray: Ray, part: vec2<f32>, trace: ptr<function, Trace>, state: ptr<function, MarchState>, allowance: u32) {
    let c = frame.globals.isovalue;
    let lipschitz = frame.globals.lipschitz;
    var t = (*state).t;
    var omega = select(1.0, 1.6, ((*state).flags & 4u) != 0u);
    var previous_radius = (*state).carry0;
    var step = (*state).carry1;
    var has_side = ((*state).flags & 1u) != 0u;
    var side = ((*state).flags & 2u) != 0u;
    while t < part.y && (*trace).steps < allowance {
        (*trace).steps += 1u;
        let f = along_ray(sp, ray, t).x;
        let inside = f >= c;
        let radius = abs(f - c) / lipschitz;
        let crossed_side = has_side && side != inside;
        if omega > 1.0 && (radius + previous_radius < step || crossed_side) {
            t -= step;
            step = 0.0;
            omega = 1.0;
            previous_radius = 0.0;
            continue;
        }
        has_side = true;
        side = inside;
        if radius < frame.globals.epsilon {
            let beyond = along_ray(sp, ray, t + frame.globals.min_step).x >= c;
            if beyond == inside {
                t += max(radius, 1.2e-7 * abs(t));
                omega = 1.0;
                step = radius;
                previous_radius = radius;
                continue;
            }
            if crossing_ends_march(trace, t, !inside) {
                return;
            }
            // Transparent statistics go on past the crossing, over-relaxed again.
            t += radius + frame.globals.min_step;
            omega = 1.6;
            previous_radius = 0.0;
            step = 0.0;
            has_side = false;
            continue;
        }
        step = omega * radius;
        previous_radius = radius;
        t += step;
    }
    *state = MarchState(t, previous_radius, step, select(0u, 1u, has_side) | select(0u, 2u, side) | select(0u, 4u, omega > 1.0));
}
