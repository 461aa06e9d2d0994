// Blend operators on values with gradients, and every group's value along a ray: core
// field/blend.rs (value_gradient).

// Polynomial smooth maximum of two values with gradients (blend.rs smooth_max).
fn smooth_max(a: vec4<f32>, b: vec4<f32>, width: f32) -> vec4<f32> {
    let h = clamp(0.5 + (a.x - b.x) / (2.0 * width), 0.0, 1.0);
    return vec4<f32>(b.x + h * (a.x - b.x) + width * h * (1.0 - h), h * a.yzw + (1.0 - h) * b.yzw);
}

// The operators of the blend (blend.rs value_gradient) on values with gradients, which
// `blend_groups` (blend_wgsl.rs, generated per scene) nests in the shape of the scene's tree.

// max and min keep the first of equal values.
fn value_max(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    return select(a, b, b.x > a.x);
}

fn value_min(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    return select(a, b, b.x < a.x);
}

// min(a, 2c − b), a on ties.
fn value_difference(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    let complement = 2.0 * frame.globals.isovalue - b.x;
    return select(vec4<f32>(complement, -b.yzw), a, a.x <= complement);
}

// The Ricci blend R = (Σ max(fᵢ, 0)^p)^(1/p) with ∇R = Σ (fᵢ/R)^(p−1) ∇fᵢ over the positive
// operands: the largest operand value m, the terms (fᵢ/m)^p of the sum, its root m·(Σ)^(1/p)
// (0 when nothing is positive), the gradient's terms. Relative to m the powers neither overflow
// nor underflow f32 (with a plain sum, 0.01^32 is 0 and 16^32 infinite: blend.rs p_norm).
fn ricci_scale(largest: f32, f: vec4<f32>) -> f32 {
    return max(largest, f.x);
}

fn ricci_power(f: vec4<f32>, scale: f32, p: f32) -> f32 {
    return select(0.0, pow(f.x / scale, p), f.x > 0.0);
}

fn ricci_root(sum: f32, scale: f32, p: f32) -> f32 {
    return select(0.0, scale * pow(sum, 1.0 / p), sum > 0.0);
}

fn ricci_slope(f: vec4<f32>, root: f32, p: f32) -> vec3<f32> {
    if f.x > 0.0 && root > 0.0 {
        return pow(f.x / root, p - 1.0) * f.yzw;
    }
    return vec3<f32>(0.0);
}

fn add_primitive(values: ptr<function, array<vec4<f32>, GROUPS>>, i: u32, p: vec3<f32>) {
    let g = primitives[i].group;
    (*values)[g] += primitive_value_gradient(i, p);
}

// Every group's value and gradient at ray parameter t: only the primitives of the window
// whose support contains the point.
fn groups_at(sp: ptr<function, RaySupports>, ray: Ray, t: f32) -> array<vec4<f32>, GROUPS> {
    let p = ray.origin + t * ray.dir;
    var values: array<vec4<f32>, GROUPS>;
    for (var j = 0u; j < (*sp).count; j++) {
        let s = (*sp).spans[j];
        if s.x > t {
            break;
        }
        if t <= s.y {
            add_primitive(&values, (*sp).ids[j], p);
        }
    }
    // Groups holding an HRBF set are clamped at 0 (program.rs clamp_group_slots).
    for (var g = 0u; g < frame.globals.group_count; g++) {
        if kernels[g].clamped != 0u && values[g].x < 0.0 {
            values[g] = vec4<f32>(0.0);
        }
    }
    return values;
}

fn field_at(sp: ptr<function, RaySupports>, ray: Ray, t: f32) -> vec4<f32> {
    return blend_groups(groups_at(sp, ray, t));
}

// (f(t), f′(t)) along the ray.
fn along_ray(sp: ptr<function, RaySupports>, ray: Ray, t: f32) -> vec2<f32> {
    let v = field_at(sp, ray, t);
    return vec2<f32>(v.x, dot(v.yzw, ray.dir));
}
