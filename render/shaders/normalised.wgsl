// The normalised SCALIS field of scalis 2021 §4 (MATH.md §4; core: methods/normalised_field.rs),
// shared by scalis.wgsl and sphere_normalized.wgsl: F = g∘f − 1, with g the inverse of the
// field of an infinite constant-radius segment for the scene's one kernel.

// (g(f), g′(f)) for the common kernel (KernelProfile::field_normalisation).
fn normalisation(f: f32) -> vec2<f32> {
    let k = kernels[0];
    let cap = k.support_sq;
    if f <= 0.0 {
        return vec2<f32>(cap, 0.0);
    }
    let s2 = 1.0 / k.inv_sigma2;
    let ratio = f / frame.globals.isovalue;
    var g: f32;
    var d: f32;
    if k.family == KERNEL_COMPACT_POLYNOMIAL {
        let e = 2.0 / (2.0 * k.exponent + 1.0);
        let q = 1.0 - 1.0 / s2;
        let p = pow(ratio, e);
        g = s2 * (1.0 - q * p);
        d = -s2 * q * e * p / f;
    } else if k.family == KERNEL_CAUCHY && k.exponent > 0.5 {
        let e = 1.0 / (k.exponent - 0.5);
        let p = pow(ratio, -e);
        g = (1.0 + s2) * p - s2;
        d = -(1.0 + s2) * e * p / f;
    } else {
        g = 1.0 - s2 * log(ratio);
        d = -s2 / f;
    }
    if g >= cap {
        return vec2<f32>(cap, 0.0);
    }
    return vec2<f32>(g, d);
}

