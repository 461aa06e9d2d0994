// Accelerated sphere tracing (Bálint & Valasek 2018, MATH.md §6; core:
// methods/sphere_accelerated.rs): the step extrapolates from the last two unbounding radii,
// dt = r₁ + β·r₁·(d + r₁ − r₀)/(d − r₁ + r₀) with β = 0.95 and d the previous step, and is
// accepted when the sphere at the new point overlaps the current one (dt ≤ r₁ + r(t + dt)) on
// the same side; otherwise the plain step r₁. The first step of a part is a plain one. Below ε,
// where the crossing is not confirmed, the march goes on by r₁ but by no less than two f32 ulps
// of t (`progress_floor`, the CPU's too).
// ACCELERATION_BETA is emitted before this file from core's AcceleratedSphereTracing::BETA.

// Two f32 ulps of t (core: sphere_accelerated.rs progress_floor).
fn progress_floor(t: f32) -> f32 {
    let x = max(abs(t), 1.0e-30);
    return 2.0 * (bitcast<f32>(bitcast<u32>(x) + 1u) - x);
}

// State carried between dispatches (parts.wgsl): carry0 the previous radius r₀, carry1 the
// previous step d; flags 1: they are known (not right after a part's start or a rejected
// crossing). The current radius is the field at t, evaluated again when a dispatch resumes.
fn march_start(part: vec2<f32>) -> MarchState {
    return MarchState(part.x, 0.0, 0.0, 0u);
}

fn march_part(sp: ptr<function, RaySupports>, ray: Ray, part: vec2<f32>, trace: ptr<function, Trace>, state: ptr<function, MarchState>, allowance: u32) {
    let c = frame.globals.isovalue;
    let lipschitz = frame.globals.lipschitz;
    var t = (*state).t;
    var previous_radius = (*state).carry0;
    var previous_step = (*state).carry1;
    var has_history = ((*state).flags & 1u) != 0u;
    var f = along_ray(sp, ray, t).x;
    while t < part.y && (*trace).steps < allowance {
        (*trace).steps += 1u;
        let inside = f >= c;
        let radius = abs(f - c) / lipschitz;
        if radius < frame.globals.epsilon {
            // Confirm the crossing on the other side, as the marching methods do.
            if (along_ray(sp, ray, t + frame.globals.min_step).x >= c) == inside {
                t += max(radius, progress_floor(t));
                has_history = false;
                f = along_ray(sp, ray, t).x;
                continue;
            }
            if crossing_ends_march(trace, t, !inside) {
                return;
            }
            // Transparent statistics go on past the crossing.
            t += radius + frame.globals.min_step;
            has_history = false;
            f = along_ray(sp, ray, t).x;
            continue;
        }
        var step = radius;
        if has_history {
            let denominator = previous_step - radius + previous_radius;
            if denominator > 0.0 {
                step = max(radius + ACCELERATION_BETA * radius * (previous_step + radius - previous_radius) / denominator, radius);
            }
        }
        var next = along_ray(sp, ray, t + step).x;
        if step > radius && (step > radius + abs(next - c) / lipschitz || (next >= c) != inside) {
            step = radius;
            next = along_ray(sp, ray, t + step).x;
        }
        has_history = true;
        previous_radius = radius;
        previous_step = step;
        t += step;
        f = next;
    }
    *state = MarchState(t, previous_radius, previous_step, select(0u, 1u, has_history));
}
