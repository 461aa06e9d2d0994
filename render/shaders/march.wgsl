// Algorithm 1 of forward-inclusion 2023 (core: methods/marching.rs): march on forward
// inclusions given by the method file's `method_bound(sp, ray, t, f, d, h)`, next interval
// k × last step, crossing confirmed min_step further on, a step that lands on the surface
// caught by the sign change.

struct Inclusion {
    start: f32,
    lower: vec2<f32>,  // offset a·s + b·s²
    upper: vec2<f32>,
    length: f32,
};

// First s in [0, limit] where start + a s + b s² reaches target; −1 when none.
fn first_reach(start: f32, offset: vec2<f32>, goal: f32, limit: f32) -> f32 {
    let r = quadratic_roots(offset.y, offset.x, start - goal);
    if r.x > r.y {
        return -1.0;
    }
    if r.x >= 0.0 && r.x <= limit {
        return r.x;
    }
    if r.y >= 0.0 && r.y <= limit {
        return r.y;
    }
    return -1.0;
}

fn symmetric(start: f32, lambda: f32, length: f32) -> Inclusion {
    return Inclusion(start, vec2<f32>(-lambda, 0.0), vec2<f32>(lambda, 0.0), length);
}

// Relative distance below which a step's end is the part's end: 8 f32 ulps.
const SNAP_TO_END: f32 = 9.5e-7;

// t + s, or exactly `end` where that lands within rounding of it: a bound whose validity ends
// where the part ends, computed another way, may land a few ulps short, and the march would
// take one more step over that sliver or not by rounding (core: marching.rs `advance`).
fn march_advance(t: f32, s: f32, end: f32) -> f32 {
    let next = t + s;
    return select(next, end, end - next <= SNAP_TO_END * abs(end));
}

// State carried between dispatches (parts.wgsl): carry0 the next interval h, carry1 the
// previous sample's t; flags 1: there is a previous sample, 2: it was inside.
fn march_start(part: vec2<f32>) -> MarchState {
    return MarchState(part.x, frame.globals.initial_interval, 0.0, 0u);
}

fn march_part(sp: ptr<function, RaySupports>, ray: Ray, part: vec2<f32>, trace: ptr<function, Trace>, state: ptr<function, MarchState>, allowance: u32) {
    let c = frame.globals.isovalue;
    let eps = frame.globals.epsilon;
    let min_step = frame.globals.min_step;
    var t = (*state).t;
    var h = (*state).carry0;
    var has_previous = ((*state).flags & 1u) != 0u;
    var previous_t = (*state).carry1;
    var previous_inside = ((*state).flags & 2u) != 0u;
    while t < part.y && (*trace).steps < allowance {
        (*trace).steps += 1u;
        let fd = along_ray(sp, ray, t);
        let inside = fd.x >= c;
        if has_previous && previous_inside != inside {
            var lo = previous_t;
            var hi = t;
            while hi - lo > eps {
                let mid = 0.5 * (lo + hi);
                if (along_ray(sp, ray, mid).x >= c) == previous_inside {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            if crossing_ends_march(trace, hi, inside) {
                return;
            }
            // A step that landed just past the surface resumes min_step past the crossing,
            // as a confirmed one does (core: marching.rs).
            h = frame.globals.initial_interval;
            // The sample stays the previous one: a crossing back before the resumption is
            // then a sign change there.
            let resume = hi + min_step;
            if t < resume {
                has_previous = true;
                previous_t = t;
                previous_inside = inside;
                t = resume;
                continue;
            }
        }
        has_previous = true;
        previous_t = t;
        previous_inside = inside;
        let h_now = min(max(h, min_step), part.y - t);
        let inc = method_bound(sp, ray, t, fd.x, fd.y, h_now);
        let limit = min(inc.length, part.y - t);
        let offset = select(inc.upper, inc.lower, inside);
        let s = first_reach(fd.x, offset, c, limit);
        if s >= 0.0 && s < eps {
            let beyond = t + s + min_step;
            if (along_ray(sp, ray, beyond).x >= c) == inside {
                t += max(s, 1.2e-7 * abs(t));
                h = min_step;
                continue;
            }
            if crossing_ends_march(trace, t + s, !inside) {
                return;
            }
            // Transparent statistics go on past the crossing, as core's march does.
            t = beyond;
            h = frame.globals.initial_interval;
            has_previous = false;
        } else if s >= 0.0 {
            t = march_advance(t, s, part.y);
            h = frame.globals.growth * s;
        } else {
            t = march_advance(t, limit, part.y);
            h = frame.globals.growth * limit;
        }
    }
    *state = MarchState(t, h, previous_t, select(0u, 1u, has_previous) | select(0u, 2u, previous_inside));
}
