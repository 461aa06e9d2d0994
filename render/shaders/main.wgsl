// Entry point: one invocation per pixel. Traces the pixel's ray with the composed method,
// writes depth and steps, and the colour of the chosen view: Blinn–Phong (core: cpu/renderer.rs,
// without shadows and refraction) or the step-count heat map (Turbo polynomial, the same as
// core::frame::heat_colour, coefficients TURBO_* emitted by shared.rs).
//
// Soft shadows and ambient occlusion (core: cpu/shading.rs, 2014 notes §12.4) sample the field at
// points off the pixel's ray, so they visit every primitive whose bounding sphere holds the point
// rather than the tile list; the renderer refuses scenes where that would be too many visits.

// The shading constants (SOFT_SHADOW_STEPS, AO_*, ...) are core's, emitted by shared.rs.

// Blended value and gradient at any point.
fn field_anywhere(p: vec3<f32>) -> vec4<f32> {
    var values: array<vec4<f32>, MAX_GROUPS>;
    for (var i = 0u; i < globals.primitive_count; i++) {
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
    let c = globals.isovalue;
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
    let c = globals.isovalue;
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

fn shade(sp: ptr<function, RaySupports>, ray: Ray, t: f32) -> vec3<f32> {
    let groups = groups_at(sp, ray, t);
    let field = blend_groups(groups);
    let normal = normalize(-field.yzw);
    var best = 0u;
    for (var g = 1u; g < globals.group_count; g++) {
        if groups[g].x > groups[best].x {
            best = g;
        }
    }
    let albedo = materials[best].xyz;
    let p = ray.origin + t * ray.dir;
    let flags = globals.shading_flags;
    let scale = globals.shading_scale;
    let lifted = p + 2.0 * globals.min_step * normal;
    var occlusion = 1.0;
    if (flags & 2u) != 0u {
        occlusion = ambient_occlusion(p, normal, scale);
    }
    var colour = 0.12 * occlusion * albedo;
    for (var l = 0u; l < globals.light_count; l++) {
        let light = lights[l];
        var to_light = normalize(light.vector.xyz);
        var distance = globals.far;
        if u32(light.vector.w) == LIGHT_POINT {
            to_light = normalize(light.vector.xyz - p);
            distance = length(light.vector.xyz - p);
        }
        let diffuse = dot(normal, to_light);
        if diffuse <= 0.0 {
            continue;
        }
        var transmitted = 0.5 + 0.5 * occlusion;
        if (flags & 1u) != 0u {
            transmitted *= soft_shadow(lifted, to_light, distance, scale);
        }
        let half_vector = normalize(to_light - ray.dir);
        let specular = pow(max(dot(normal, half_vector), 0.0), 48.0) * 0.35;
        colour += transmitted * light.colour.w * light.colour.xyz * (diffuse * albedo + specular);
    }
    return colour;
}

// Marches `ray` over its gathered supports from where suspension `k` left it, its outcome in
// `trace`; whether the march finished in this dispatch (a marching method is dispatched until
// every ray's budget is spent, parts.wgsl).
fn march_resumed(k: u32, sp: ptr<function, RaySupports>, ray: Ray, trace: ptr<function, Trace>) -> bool {
    var resume = suspensions[k];
    *trace = trace_ray(sp, ray, &resume);
    if (resume.flags & SUSPENDED) != 0u {
        suspensions[k] = resume;
        return false;
    }
    suspensions[k].flags = FINISHED;
    return true;
}

@compute @workgroup_size(8, 8, 1)
fn trace_pixels(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= globals.width || id.y >= globals.height {
        return;
    }
    let pixel = id.y * globals.width + id.x;
    if (suspensions[pixel].flags & FINISHED) != 0u {
        return;
    }
    let ray = pixel_ray(id.x, id.y);
    var supports: RaySupports;
    let sp = &supports;
    gather_supports(sp, ray, id.x, id.y);
    var trace: Trace;
    if !march_resumed(pixel, sp, ray, &trace) {
        return;
    }
    let out = id.y * globals.output_width + globals.panel_x + id.x;
    out_steps[out] = trace.steps;
    out_depth[out] = select(INF, trace.t, trace.hit);
    var colour: vec3<f32>;
    if globals.heat_view == 1u {
        colour = heat_colour(f32(trace.steps) / max(globals.heat_max, 1.0));
    } else if trace.hit {
        let c = shade(sp, ray, trace.t);
        colour = vec3<f32>(srgb(c.x), srgb(c.y), srgb(c.z));
    } else {
        let c = background(ray.dir);
        colour = vec3<f32>(srgb(c.x), srgb(c.y), srgb(c.z));
    }
    out_colour[out] = pack(colour);
}

// A ray of `stats --backend gpu` (gpu_stats.rs): traced over [0, far] among the primitives of
// tile list `list`, which the host built for rays of its kind (StatsRay in gpu_stats.rs).
struct StatsRay {
    origin: vec3<f32>,
    far: f32,
    dir: vec3<f32>,
    list: u32,
};

@group(0) @binding(11) var<storage, read> stats_rays: array<StatsRay>;

// One thread per ray of the batch (globals.width rays), in rows of STATS_ROW workgroups;
// writes steps and depth (the first crossing's t) at the ray's index.
@compute @workgroup_size(64, 1, 1)
fn trace_rays(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.y * STATS_ROW * 64u + id.x;
    if k >= globals.width {
        return;
    }
    if (suspensions[k].flags & FINISHED) != 0u {
        return;
    }
    let r = stats_rays[k];
    let ray = Ray(r.origin, r.dir);
    var supports: RaySupports;
    let sp = &supports;
    gather_list(sp, ray, r.list, r.far);
    var trace: Trace;
    if !march_resumed(k, sp, ray, &trace) {
        return;
    }
    out_steps[k] = trace.steps;
    out_depth[k] = select(INF, trace.t, trace.hit);
}
