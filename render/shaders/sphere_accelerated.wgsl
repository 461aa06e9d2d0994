// Accelerated sphere tracing (Bálint & Valasek 2018; core: methods/sphere_accelerated.rs): the
// step extrapolates from the last two unbounding radii, dt = r₁ + β·r₁·(d + r₁ − r₀)/(d − r₁ + r₀),
// accepted when the sphere at the new point overlaps the current one (dt ≤ r₁ + r(t + dt)) and
// the side is the same; otherwise the plain step r₁. The first step of every part is plain.

// State carried between dispatches (parts.wgsl): carry0 the previous radius r₀, carry1 the
// previous step d; flags 1: they exist (no start or crossing since).
fn march_start(part: vec2<f32>) -> MarchState {
    return MarchState(part.x, 0.0, 0.0, 0u);
}

// (|f − c| / L, 1 when inside) at t.
fn unbounding_radius(sp: ptr<function, RaySupports>, ray: Ray, t: f32) -> vec2<f32> {
    let f = along_ray(sp, ray, t).x;
    return vec2<f32>(abs(f - globals.isovalue) / globals.lipschitz, select(0.0, 1.0, f >= globals.isovalue));
}

fn march_part(sp: ptr<function, RaySupports>, ray: Ray, part: vec2<f32>, trace: ptr<function, Trace>, state: ptr<function, MarchState>, allowance: u32) {
    var t = (*state).t;
    var r0 = (*state).carry0;
    var d = (*state).carry1;
    var has_history = ((*state).flags & 1u) != 0u;
    var current = unbounding_radius(sp, ray, t);
    while t < part.y && (*trace).steps < allowance {
        (*trace).steps += 1u;
        let r1 = current.x;
        let inside = current.y > 0.5;
        if r1 < globals.epsilon {
            // Confirm the crossing on the other side, as the marching methods do.
            let beyond = unbounding_radius(sp, ray, t + globals.min_step).y > 0.5;
            if beyond == inside {
                t += max(r1, 1.2e-7 * abs(t));
                has_history = false;
                current = unbounding_radius(sp, ray, t);
                continue;
            }
            (*trace).t = t;
            (*trace).hit = true;
            (*trace).entering = !inside;
            return;
        }
        var dt = r1;
        if has_history {
            let denominator = d - r1 + r0;
            if denominator > 0.0 {
                dt = max(r1 + SPHERE_ACCELERATED_BETA * r1 * (d + r1 - r0) / denominator, r1);
            }
        }
        var next = unbounding_radius(sp, ray, t + dt);
        if dt > r1 && (dt > r1 + next.x || (next.y > 0.5) != inside) {
            dt = r1;
            next = unbounding_radius(sp, ray, t + dt);
        }
        r0 = r1;
        d = dt;
        has_history = true;
        t += dt;
        current = next;
    }
    *state = MarchState(t, r0, d, select(0u, 1u, has_history));
}
