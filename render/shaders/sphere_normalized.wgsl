// Sphere tracing on the normalised field (scalis 2021 §8 baseline and appendix B; core:
// methods/sphere_normalized.rs): √g∘f − 1 behaves like a homothetic distance minus 1, so its
// Lipschitz constant is 1/τ_min, τ_min the radius of the thinnest skeleton point whose support
// ball the ray meets among the segments crossed on the marching interval [t, t + h]; the step
// is |√g(f) − 1|·τ_min, as the symmetric inclusion f ± λ·s with λ = |f − c| / step, marched by
// march.wgsl. Not guaranteed: the constant is exact for an isolated straight segment only.

// Radius of the thinnest point of SCALIS segment `i` whose support ball (radius R·τ(s)) the ray
// meets; the segment's smaller radius when none does (normalised_field.rs thinnest_radius_met).
fn thinnest_radius_met(i: u32, ray: Ray) -> f32 {
    let cone = cone_of(primitives[i]);
    let r2 = kernels[primitives[i].group].support_sq;
    let m = cone.start - ray.origin;
    let m_p = m - dot(m, ray.dir) * ray.dir;
    let u_p = cone.axis - dot(cone.axis, ray.dir) * ray.dir;
    // |m⊥ + s·u⊥|² − R²(τ₀ + δs)² ≤ 0
    let a = dot(u_p, u_p) - r2 * cone.slope * cone.slope;
    let b = 2.0 * (dot(m_p, u_p) - r2 * cone.radius * cone.slope);
    let c = dot(m_p, m_p) - r2 * cone.radius * cone.radius;
    if c <= 0.0 {
        return cone.radius;
    }
    let roots = quadratic_roots(a, b, c);
    var first = INF;
    if roots.x <= roots.y {
        if roots.x >= 0.0 && roots.x <= cone.length {
            first = roots.x;
        }
        if roots.y >= 0.0 && roots.y <= cone.length {
            first = min(first, roots.y);
        }
    }
    if first == INF {
        return cone.radius;
    }
    return cone.radius + cone.slope * first;
}

fn method_bound(sp: ptr<function, RaySupports>, ray: Ray, t: f32, f: f32, d: f32, h: f32) -> Inclusion {
    var tau = INF;
    for (var j = 0u; j < support_count(sp); j++) {
        let item = support_item(sp, ray, j);
        if item.span.x <= item.span.y && item.span.x <= t + h && item.span.y >= t {
            tau = min(tau, thinnest_radius_met(item.id, ray));
        }
    }
    if tau >= INF {
        return symmetric(f, 0.0, h);
    }
    let g = normalisation(f).x;
    let distance = abs(sqrt(max(g, 0.0)) - 1.0) * tau;
    var lambda = INF;
    if distance > 0.0 {
        lambda = abs(f - frame.globals.isovalue) / distance;
    }
    return symmetric(f, lambda, h);
}
