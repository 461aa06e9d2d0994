// Entry point: one invocation per pixel. Traces the pixel's ray with the composed method,
// writes depth and steps, and the colour of the chosen view: Blinn–Phong (core: cpu/renderer.rs,
// with its shadow rays, reflection and refraction when the frame has them: trace_path) or the step-count heat map (Turbo polynomial, the same as
// core::frame::heat_colour, coefficients TURBO_* emitted by shared.rs).
//
// Soft shadows and ambient occlusion (core: cpu/shading.rs, 2014 notes §12.4) sample the field at
// points off the pixel's ray, so they find the primitives whose support holds the point in the
// scene's hierarchy (bvh_nodes, ray_bvh.rs) rather than the tile list; the renderer refuses scenes
// where a pixel's walks together could pass lavapipe's loop limit (`RayBvh::point_walk_bound`).

// The shading constants (SOFT_SHADOW_STEPS, AO_*, ...) are core's, emitted by shared.rs.

// Blended value and gradient at any point: a walk entering the nodes whose boxes hold `p`, each
// item of their leaves and each unbounded primitive tested against its bounding sphere. The
// walk finds the next candidate in a loop of its own, so that `add_primitive` has one call site.
fn field_anywhere(p: vec3<f32>) -> vec4<f32> {
    var values: array<vec4<f32>, GROUPS>;
    let node_count = arrayLength(&bvh_nodes);
    var node = 0u;
    var j = 0u;
    var end = 0u;
    var unbounded = true;
    loop {
        var i = 0u;
        var found = false;
        loop {
            if j < end {
                i = bvh_items[j];
                j += 1u;
                found = true;
                break;
            }
            if node < node_count {
                let n = bvh_nodes[node];
                let count = n.leaf & 7u;
                if any(p < n.min) || any(p > n.max) {
                    node = n.skip;
                } else if count == 0u {
                    node += 1u;
                } else {
                    j = n.leaf >> 3u;
                    end = j + count;
                    node = n.skip;
                }
                continue;
            }
            if unbounded {
                unbounded = false;
                j = frame.globals.bvh_unbounded;
                end = frame.globals.bvh_items;
                continue;
            }
            break;
        }
        if !found {
            break;
        }
        let b = primitives[i].bound;
        let d = p - b.xyz;
        if b.w < 0.0 || dot(d, d) <= b.w * b.w {
            add_primitive(&values, i, p);
        }
    }
    return blend_groups(values);
}

// First-order distance to the isosurface (shading.rs distance_estimate).
fn distance_estimate(c: f32, field: vec4<f32>, scale: f32) -> f32 {
    let cap = SHADE_MAX_STEP * scale;
    let slope = length(field.yzw);
    if slope * cap <= c - field.x {
        return cap;
    }
    return (c - field.x) / slope;
}

fn soft_shadow(start: vec3<f32>, dir: vec3<f32>, distance: f32, scale: f32) -> f32 {
    let c = frame.globals.isovalue;
    let reach = min(distance, SHADOW_REACH * scale);
    var t = SHADE_MIN_STEP * scale;
    var lit = 1.0;
    for (var i = 0u; i < SOFT_SHADOW_STEPS; i++) {
        if t >= reach {
            break;
        }
        let field = field_anywhere(start + t * dir);
        if field.x >= c {
            return 0.0;
        }
        let e = distance_estimate(c, field, scale);
        if e < SHADE_MAX_STEP * scale {
            lit = min(lit, SOFTNESS * e / t);
        }
        t += clamp(e, SHADE_MIN_STEP * scale, SHADE_MAX_STEP * scale);
    }
    let x = clamp(lit, 0.0, 1.0);
    return x * x * (3.0 - 2.0 * x);
}

fn ambient_occlusion(p: vec3<f32>, normal: vec3<f32>, scale: f32) -> f32 {
    let c = frame.globals.isovalue;
    var occluded = 0.0;
    var total = 0.0;
    var weight = 1.0;
    for (var i = 1u; i <= AO_SAMPLES; i++) {
        let h = f32(i) * AO_STEP * scale;
        let field = field_anywhere(p + h * normal);
        var e = 0.0;
        if field.x < c {
            e = min(distance_estimate(c, field, scale), h);
        }
        occluded += weight * (h - e) / h;
        total += weight;
        weight *= AO_DECAY;
    }
    return 1.0 - occluded / total;
}

fn background(dir: vec3<f32>) -> vec3<f32> {
    let up = 0.5 * (dir.y + 1.0);
    return mix(vec3<f32>(0.16, 0.17, 0.20), vec3<f32>(0.42, 0.47, 0.55), up);
}

fn srgb(c: f32) -> f32 {
    let v = clamp(c, 0.0, 1.0);
    return select(1.055 * pow(v, 1.0 / 2.4) - 0.055, 12.92 * v, v <= 0.0031308);
}

fn pack(c: vec3<f32>) -> u32 {
    let b = vec3<u32>(clamp(c, vec3<f32>(0.0), vec3<f32>(1.0)) * 255.0 + 0.5);
    return b.x | (b.y << 8u) | (b.z << 16u) | (255u << 24u);
}

// What a hit shows: the outward normal and the group contributing most (cpu/renderer.rs
// material_at).
struct Surface {
    normal: vec3<f32>,
    group: u32,
};

fn surface_at(sp: ptr<function, RaySupports>, ray: Ray, t: f32) -> Surface {
    let groups = groups_at(sp, ray, t);
    let field = blend_groups(groups);
    var best = 0u;
    for (var g = 1u; g < frame.globals.group_count; g++) {
        if groups[g].x > groups[best].x {
            best = g;
        }
    }
    return Surface(normalize(-field.yzw), best);
}

// The direction towards light `l` from `p` and its distance.
fn towards_light(l: u32, p: vec3<f32>) -> vec4<f32> {
    let light = lights[l];
    if u32(light.vector.w) == LIGHT_POINT {
        let d = light.vector.xyz - p;
        return vec4<f32>(normalize(d), length(d));
    }
    return vec4<f32>(normalize(light.vector.xyz), frame.globals.far);
}

// Where a hit's shadow rays and field shadows start: lifted off the surface.
fn lifted_point(p: vec3<f32>, normal: vec3<f32>) -> vec3<f32> {
    return p + 2.0 * frame.globals.min_step * normal;
}

fn occlusion_at(p: vec3<f32>, normal: vec3<f32>) -> f32 {
    if (frame.globals.shading_flags & 2u) != 0u {
        return ambient_occlusion(p, normal, frame.globals.shading_scale);
    }
    return 1.0;
}

// Light `l`'s Blinn–Phong term at a hit seen along `view`, `transmitted` the fraction of it an
// exact shadow ray lets through (1 without shadow rays), times the field's soft shadow.
fn light_term(l: u32, p: vec3<f32>, normal: vec3<f32>, view: vec3<f32>, albedo: vec3<f32>, occlusion: f32, transmitted_exactly: f32) -> vec3<f32> {
    let towards = towards_light(l, p);
    let diffuse = dot(normal, towards.xyz);
    var transmitted = transmitted_exactly;
    if diffuse <= 0.0 || transmitted <= 0.0 {
        return vec3<f32>(0.0);
    }
    if (frame.globals.shading_flags & 1u) != 0u {
        transmitted *= soft_shadow(lifted_point(p, normal), towards.xyz, towards.w, frame.globals.shading_scale);
    }
    let half_vector = normalize(towards.xyz - view);
    let specular = pow(max(dot(normal, half_vector), 0.0), 48.0) * 0.35;
    let light = lights[l];
    return transmitted * (0.5 + 0.5 * occlusion) * light.colour.w * light.colour.xyz * (diffuse * albedo + specular);
}

// Writes a pixel's steps, depth and the colour of the chosen view (`shaded`: linear, or the
// background where nothing was hit).
fn write_pixel(px: u32, py: u32, steps: u32, depth: f32, shaded: vec3<f32>) {
    let out = py * frame.globals.output_width + frame.globals.panel_x + px;
    out_steps[out] = steps;
    out_depth[out] = depth;
    var colour: vec3<f32>;
    if frame.globals.heat_view == 1u {
        colour = heat_colour(f32(steps) / max(frame.globals.heat_max, 1.0));
    } else {
        colour = vec3<f32>(srgb(shaded.x), srgb(shaded.y), srgb(shaded.z));
    }
    out_colour[out] = pack(colour);
}

// ---- Secondary rays (cpu/renderer.rs shade_trace and transmittance; forward-inclusion 2023
// §7.2 for transparency) ----
//
// With shadow rays or transparent groups, a pixel's colour needs more rays than its own: a
// shadow ray from each hit towards each light, and at a transparent group's crossing a
// reflected and a refracted ray, up to MAX_BOUNCES levels. The colour is linear in what each
// ray sees, so each ray carries its weight in the pixel's colour and the pixel's `Path` keeps
// the sum, the hit being shaded and the rays still to trace. One ray is traced at a time,
// through the same suspended marches as the camera ray (parts.wgsl): a dispatch finishes at
// most one ray of a path, and the renderer dispatches enough for the longest path. Rays other
// than the camera ray leave the screen tiles and are traced against every primitive, as the
// CPU traces them. Steps count the camera, reflected and refracted rays, not shadow rays.

// A ray of a pixel's path.
struct PathRay {
    origin: vec3<f32>,
    bounce: u32,         // reflection/refraction level
    dir: vec3<f32>,
    kind: u32,           // RAY_CAMERA (a cleared path starts with it), RAY_BOUNCE, RAY_SHADOW
    weight: vec3<f32>,   // of what the ray sees in the pixel's colour
    far: f32,            // end of its interval
};

// Twin of the renderer's PATH_BYTES: cleared before each method's pass.
struct Path {
    ray: PathRay,        // being traced
    colour: vec3<f32>,   // sum so far, linear
    depth: f32,          // of the camera ray's crossing
    point: vec3<f32>,    // the hit being shaded
    steps: u32,          // of the camera and bounce rays finished
    normal: vec3<f32>,
    occlusion: f32,
    view: vec3<f32>,     // direction of the ray that hit
    light: u32,          // next light of the hit's shading
    lit: vec3<f32>,      // the hit's shading so far
    group: u32,          // its material
    lit_weight: vec3<f32>,
    stacked: u32,
    stack: array<PathRay, PATH_STACK>,
};

@group(0) @binding(13) var<storage, read_write> paths: array<Path>;
// [0]: non-zero once a dispatch has left a path unfinished (a ray still marching); the renderer
// clears it before the last dispatch of a batch and reads it after (gpu_renderer/encode.rs
// `dispatch_marches`), to stop dispatching once every path is done. [1]: the invocations that
// passed lavapipe's loop limit (note_loop_limit), which fail the frame.
@group(0) @binding(14) var<storage, read_write> unfinished_paths: array<atomic<u32>, 2>;

fn push_ray(path: ptr<function, Path>, ray: PathRay) {
    if (*path).stacked < PATH_STACK {
        (*path).stack[(*path).stacked] = ray;
        (*path).stacked += 1u;
    }
}

// The hit of `job` at `trace`: starts its shading and, at a transparent group below the last
// bounce, stacks the reflected and refracted rays with their Fresnel weights.
fn begin_hit(path: ptr<function, Path>, surface: Surface, ray: Ray, job: PathRay, trace: Trace) {
    let material = materials[surface.group];
    let p = ray.origin + trace.t * ray.dir;
    let occlusion = occlusion_at(p, surface.normal);
    (*path).point = p;
    (*path).normal = surface.normal;
    (*path).occlusion = occlusion;
    (*path).view = ray.dir;
    (*path).light = 0u;
    (*path).group = surface.group;
    (*path).lit = 0.12 * occlusion * material.colour.xyz;
    let opacity = material.colour.w;
    if opacity >= 1.0 || job.bounce >= MAX_BOUNCES {
        (*path).lit_weight = job.weight;
        return;
    }
    (*path).lit_weight = job.weight * opacity;
    let glass = job.weight * (1.0 - opacity);
    let ior = material.ior.x;
    let facing = select(-surface.normal, surface.normal, dot(surface.normal, ray.dir) < 0.0);
    let eta = select(ior, 1.0 / ior, trace.entering);
    let cos_i = -dot(facing, ray.dir);
    let r0 = (1.0 - ior) / (1.0 + ior);
    let f0 = r0 * r0;
    let fresnel = f0 + (1.0 - f0) * pow(1.0 - cos_i, 5.0);
    let offset = 2.0 * frame.globals.min_step;
    let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    var reflected_weight = glass * fresnel;
    if k < 0.0 {
        // Total internal reflection: what passes through is the reflection too.
        reflected_weight = glass;
    } else {
        let refracted = normalize(eta * ray.dir + (eta * cos_i - sqrt(k)) * facing);
        let tint = mix(material.colour.xyz, vec3<f32>(1.0), 0.5);
        push_ray(path, PathRay(p - offset * facing, job.bounce + 1u, refracted, RAY_BOUNCE, glass * (1.0 - fresnel) * tint, frame.globals.far));
    }
    let reflected = normalize(ray.dir + 2.0 * cos_i * facing);
    push_ray(path, PathRay(p + offset * facing, job.bounce + 1u, reflected, RAY_BOUNCE, reflected_weight, frame.globals.far));
}

// Goes on with the hit's lights from `path.light`: the next one facing the hit becomes the
// shadow ray to trace (true), or, without shadow rays, each is lit directly; once every light
// is done, the hit's shading joins the pixel's colour (false). `shadow` ≥ 0 is what the shadow
// ray towards light `path.light`, which has just ended, let through; negative when none has.
fn next_light(path: ptr<function, Path>, shadow: f32) -> bool {
    var transmitted = shadow;
    while (*path).light < frame.globals.light_count {
        let l = (*path).light;
        if transmitted < 0.0 {
            let towards = towards_light(l, (*path).point);
            if dot((*path).normal, towards.xyz) > 0.0 && (frame.globals.secondary & SECONDARY_SHADOW_RAYS) != 0u {
                (*path).ray = PathRay(lifted_point((*path).point, (*path).normal), 0u, towards.xyz, RAY_SHADOW, vec3<f32>(0.0), towards.w);
                return true;
            }
            transmitted = 1.0;
        }
        let albedo = materials[(*path).group].colour.xyz;
        (*path).lit += light_term(l, (*path).point, (*path).normal, (*path).view, albedo, (*path).occlusion, transmitted);
        (*path).light += 1u;
        transmitted = -1.0;
    }
    (*path).colour += (*path).lit_weight * (*path).lit;
    (*path).lit_weight = vec3<f32>(0.0);
    return false;
}

// Steps this invocation may still march: the dispatch's allowance (parts.wgsl), shared by the
// rays of a path that end in one dispatch (trace_path). A method that traces a ray in one
// dispatch (RESUMABLE false) spends it all on one ray.
var<private> steps_left: u32;

// Marches `ray` over its gathered supports from where suspension `k` left it, its outcome in
// `trace`; whether the march finished in this dispatch (a marching method is dispatched until
// every ray's budget is spent, parts.wgsl).
fn march_resumed(k: u32, sp: ptr<function, RaySupports>, ray: Ray, trace: ptr<function, Trace>) -> bool {
    var resume = suspensions[k];
    let before = resume.steps;
    *trace = trace_ray(sp, ray, &resume);
    if (resume.flags & SUSPENDED) != 0u {
        suspensions[k] = resume;
        return false;
    }
    suspensions[k].flags = FINISHED;
    // A ray that ends counts at least one step, so that the rays of a path are finitely many
    // per dispatch.
    let spent = max((*trace).steps - before, 1u);
    steps_left = select(0u, steps_left - min(spent, steps_left), RESUMABLE);
    return true;
}

// Advances pixel `pixel`'s path: marches its current ray from where the last dispatch left
// it and, each time a ray ends, takes in what it saw and goes on with the next ray while the
// dispatch's allowance lasts; writes the pixel once the path is done.
//
// Every pixel goes through here, with secondary rays or without: one copy of the march and
// of the shading in the pipeline, which lavapipe compiles in a fraction of the time two
// copies take. Without secondary rays (frame.globals.secondary) the path is the camera ray alone,
// and nothing of it outlives a dispatch but the march's own suspension: it starts cleared
// (a camera ray, nothing summed) and is not kept, and its colour is the Blinn–Phong sum of
// cpu/renderer.rs shade, each light's term added in turn to the hit's ambient term.
fn trace_path(pixel: u32, px: u32, py: u32) {
    let kept = (frame.globals.secondary & SECONDARY_PATHS) != 0u;
    var path: Path;
    if kept {
        path = paths[pixel];
    }
    var supports: RaySupports;
    let sp = &supports;
    loop {
        var job = path.ray;
        var ray: Ray;
        if job.kind == RAY_CAMERA {
            ray = pixel_ray(px, py);
            job.weight = vec3<f32>(1.0);
            gather_supports(sp, ray, px, py, resumed_floor(pixel));
        } else {
            ray = Ray(job.origin, job.dir);
            gather_every(sp, ray, job.far, resumed_floor(pixel));
        }
        var trace: Trace;
        if !march_resumed(pixel, sp, ray, &trace) {
            break;
        }
        // The ray has ended: the next one starts afresh.
        suspensions[pixel] = Suspension(0.0, 0.0, 0.0, 0.0, 0.0, 0u, 0u);
        // What the ray hit, whatever its kind: one copy of the evaluation in the pipeline.
        var surface: Surface;
        if trace.hit {
            surface = surface_at(sp, ray, trace.t);
        }
        var shadow = -1.0;
        if job.kind == RAY_SHADOW {
            // Opaque groups stop the light, a transparent one lets 1 − opacity through.
            shadow = 1.0;
            if trace.hit {
                shadow = 1.0 - materials[surface.group].colour.w;
            }
        } else {
            path.steps += trace.steps;
            if job.kind == RAY_CAMERA {
                path.depth = select(INF, trace.t, trace.hit);
            }
            if trace.hit {
                begin_hit(&path, surface, ray, job, trace);
            } else {
                path.colour += job.weight * background(ray.dir);
                path.light = frame.globals.light_count;
                path.lit = vec3<f32>(0.0);
                path.lit_weight = vec3<f32>(0.0);
            }
        }
        if !next_light(&path, shadow) {
            if path.stacked == 0u {
                write_pixel(px, py, path.steps, path.depth, path.colour);
                suspensions[pixel].flags = FINISHED;
                return;
            }
            path.stacked -= 1u;
            path.ray = path.stack[path.stacked];
        }
        if steps_left == 0u {
            break;
        }
    }
    if kept {
        paths[pixel] = path;
    }
    note_unfinished();
}

// Another dispatch is needed: one store per dispatch, not one per ray.
fn note_unfinished() {
    if atomicLoad(&unfinished_paths[0]) == 0u {
        atomicStore(&unfinished_paths[0], 1u);
    }
}

// Mesa's llvmpipe (lavapipe) counts the iterations of all the loops of an invocation against
// one limit of 65 535, and past it leaves every loop after its first iteration (gallivm
// LP_MAX_TGSI_LOOP_ITERATIONS): a fill, a step or a march cut short would miss surfaces
// silently. A loop of frame.globals.loop_probe (2) iterations, which the compiler cannot count ahead,
// runs once only past that limit; such invocations are counted in unfinished_paths[1].
// Hardware GPUs have no such limit.
fn note_loop_limit() {
    var runs = 0u;
    for (var i = 0u; i < frame.globals.loop_probe; i++) {
        runs += 1u;
    }
    if runs < frame.globals.loop_probe {
        atomicAdd(&unfinished_paths[1], 1u);
    }
}

@compute @workgroup_size(8, 8, 1)
fn trace_pixels(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.globals.width || id.y >= frame.globals.height {
        return;
    }
    let pixel = id.y * frame.globals.width + id.x;
    if (suspensions[pixel].flags & FINISHED) != 0u {
        return;
    }
    steps_left = frame.globals.steps_per_dispatch;
    trace_path(pixel, id.x, id.y);
    note_loop_limit();
}

// A ray of `stats --backend gpu` (gpu_stats.rs): traced over [0, far] among the primitives of
// tile list `list`, which the host built for rays of its kind (StatsRay in gpu_stats.rs), or
// with EVERY_PRIMITIVE among those the scene's hierarchy finds on it.
struct StatsRay {
    origin: vec3<f32>,
    far: f32,
    dir: vec3<f32>,
    list: u32,
};

@group(0) @binding(11) var<storage, read> stats_rays: array<StatsRay>;

// The statistics ray this invocation traces (trace_rays), whose slots a transparent trace
// fills.
var<private> stats_ray: u32;

// A march found a crossing at `t`; returns whether the march ends there. It does in frames
// and in opaque statistics (frame.globals.stats_crossings = 0), with the crossing in `trace`.
// Transparent statistics (core TraceMode::Transparent, forward-inclusion 2023 Tables 3–4)
// go on to the ray's end: the crossing goes to the ray's slots — out_steps[4k..4k + 4]: steps,
// steps to the last crossing, crossings found, bit i set where crossing i enters;
// out_depth[k·slots + i]: crossing i's t — and `trace` is left without a hit. Crossings past
// the slots are counted, not kept (the host refuses such a ray's statistics).
fn crossing_ends_march(trace: ptr<function, Trace>, t: f32, entering: bool) -> bool {
    let slots = frame.globals.stats_crossings;
    if slots == 0u {
        (*trace).t = t;
        (*trace).hit = true;
        (*trace).entering = entering;
        return true;
    }
    let words = 4u * stats_ray;
    let found = out_steps[words + 2u];
    if found < slots {
        out_depth[stats_ray * slots + found] = t;
        out_steps[words + 3u] |= select(0u, 1u << found, entering);
    }
    out_steps[words + 1u] = (*trace).steps;
    out_steps[words + 2u] = found + 1u;
    return false;
}

// Whether a transparent trace's last crossing entered as one `entering` would (a jump at an
// HRBF cut repeats the crossing that ended the part before; core methods/mod.rs
// trace_supports). Never in frames and opaque statistics, which stop at their first crossing.
fn repeats_last_crossing(entering: bool) -> bool {
    let slots = frame.globals.stats_crossings;
    if slots == 0u {
        return false;
    }
    let found = out_steps[4u * stats_ray + 2u];
    if found == 0u || found > slots {
        return false;
    }
    return ((out_steps[4u * stats_ray + 3u] >> (found - 1u)) & 1u) == select(0u, 1u, entering);
}

// One thread per ray of the batch (frame.globals.width rays), in rows of STATS_ROW workgroups;
// writes steps and depth (the first crossing's t) at the ray's index, or in transparent
// statistics the ray's total steps at out_steps[4k] after the slots of each crossing
// (`crossing_ends_march`).
@compute @workgroup_size(64, 1, 1)
fn trace_rays(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.y * STATS_ROW * 64u + id.x;
    if k >= frame.globals.width {
        return;
    }
    if (suspensions[k].flags & FINISHED) != 0u {
        return;
    }
    steps_left = frame.globals.steps_per_dispatch;
    stats_ray = k;
    trace_statistics_ray(k);
    note_loop_limit();
}

// trace_rays' ray `k`.
fn trace_statistics_ray(k: u32) {
    let r = stats_rays[k];
    let ray = Ray(r.origin, r.dir);
    var supports: RaySupports;
    let sp = &supports;
    if r.list == EVERY_PRIMITIVE {
        gather_every(sp, ray, r.far, resumed_floor(k));
    } else {
        gather_list(sp, ray, r.list, r.far, resumed_floor(k));
    }
    var trace: Trace;
    if !march_resumed(k, sp, ray, &trace) {
        note_unfinished();
        return;
    }
    if frame.globals.stats_crossings != 0u {
        out_steps[4u * k] = trace.steps;
        return;
    }
    out_steps[k] = trace.steps;
    out_depth[k] = select(INF, trace.t, trace.hit);
}
