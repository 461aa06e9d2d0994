// The per-ray driver of the marching methods (core: methods/mod.rs trace_supports): the
// method file's `march_part` on each part of the ray inside the supports, in order, until a
// crossing or the step budget.

fn trace_ray(sp: ptr<function, RaySupports>, ray: Ray) -> Trace {
    var trace = Trace(0.0, false, false, 0u);
    var start_at = 0.0;
    loop {
        let part = next_part(sp, ray, start_at);
        if part.x > part.y || trace.steps >= globals.counts.w {
            break;
        }
        march_part(sp, ray, part, &trace);
        if trace.hit {
            break;
        }
        start_at = part.y;
    }
    return trace;
}
