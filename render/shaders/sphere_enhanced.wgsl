// Over-relaxed sphere tracing (Keinert et al. 2014; core: methods/sphere_enhanced.rs): steps
// of ω·r with ω = 1.6; when consecutive unbounding spheres do not overlap (or the side
// changed), go back and continue with ω = 1.

fn march_part(sp: ptr<function, RaySupports>, ray: Ray, part: vec2<f32>, trace: ptr<function, Trace>) {
    let c = globals.up.w;
    let lipschitz = globals.method.x;
    var t = part.x;
    var omega = 1.6;
    var previous_radius = 0.0;
    var step = 0.0;
    var has_side = false;
    var side = false;
    while t < part.y && (*trace).steps < globals.counts.w {
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
        if radius < globals.march.x {
            let beyond = along_ray(sp, ray, t + globals.march.y).x >= c;
            if beyond == inside {
                t += max(radius, 1.2e-7 * abs(t));
                omega = 1.0;
                step = radius;
                previous_radius = radius;
                continue;
            }
            (*trace).t = t;
            (*trace).hit = true;
            (*trace).entering = !inside;
            return;
        }
        step = omega * radius;
        previous_radius = radius;
        t += step;
    }
}
