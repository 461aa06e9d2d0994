// The per-ray driver of the marching methods (core: methods/mod.rs trace_supports): the
// method file's `march_part` on each part of the ray inside the supports, in order, until a
// crossing or the step budget (in transparent statistics, until the ray's end or the budget:
// main.wgsl `crossing_ends_march`).
//
// A dispatch marches at most `steps_left` steps (frame.globals.steps_per_dispatch at its start; main.wgsl). Lavapipe stops an invocation's
// loops once they reach 65 535 iterations in all, and each step loops over the support window,
// so a ray near the 2 048-step budget would be cut short in one dispatch. A ray whose
// allowance runs out with budget left is suspended: its march state, the end of its part and
// the floor of its support window go to its `Suspension`, and the next dispatch gathers the
// same window (main.wgsl resumed_floor, one fill per dispatch) and goes on from the top of the
// same loop iteration. The renderer dispatches a marching method until every budget is spent,
// so the result does not depend on the allowance.

// Where a method's march stands at the top of its loop: the position, two numbers and flags of
// the method's own (march.wgsl, sphere_enhanced.wgsl).
struct MarchState {
    t: f32,
    carry0: f32,
    carry1: f32,
    flags: u32,
};

fn trace_ray(sp: ptr<function, RaySupports>, ray: Ray, resume: ptr<function, Suspension>) -> Trace {
    var trace = Trace(0.0, false, false, (*resume).steps);
    let allowance = min(trace.steps + steps_left, frame.globals.max_steps);
    var part: vec2<f32>;
    var state: MarchState;
    if ((*resume).flags & SUSPENDED) != 0u {
        // The window was gathered at the suspension's floor (main.wgsl resumed_floor).
        part = vec2<f32>((*resume).t, (*resume).part_end);
        state = MarchState((*resume).t, (*resume).carry0, (*resume).carry1, (*resume).flags & ~SUSPENDED);
    } else {
        part = next_part(sp, ray, 0.0);
        state = march_start(part);
    }
    (*resume).flags = 0u;
    while part.x <= part.y && trace.steps < frame.globals.max_steps {
        if trace.steps >= allowance {
            *resume = Suspension(state.t, state.carry0, state.carry1, part.y, (*sp).floor, trace.steps, state.flags | SUSPENDED);
            return trace;
        }
        march_part(sp, ray, part, &trace, &state, allowance);
        if trace.hit {
            break;
        }
        if state.t >= part.y {
            let end = part.y;
            part = next_part(sp, ray, end);
            state = march_start(part);
            // Parts that touch meet at an HRBF set's box, where the field may jump across the
            // isovalue: a crossing at the cut, which no march sees as a sign change inside one
            // part (methods/mod.rs trace_supports, jump_crossing; the inset a few f32 ulps).
            if part.x == end && part.x <= part.y {
                let inset = 5.0e-7 * (1.0 + abs(end));
                let before = along_ray(sp, ray, end - inset).x >= frame.globals.isovalue;
                let after = along_ray(sp, ray, end + inset).x >= frame.globals.isovalue;
                if before != after && !repeats_last_crossing(after)
                    && crossing_ends_march(&trace, end, after) {
                    break;
                }
            }
        }
    }
    return trace;
}
