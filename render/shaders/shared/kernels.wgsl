// Kernels: core field/kernel.rs (KernelProfile), in f32.

// (K, K′, K″) of the formula valid inside the support at x (clamped to [0, support]).
fn kernel_raw(k: Kernel, x_in: f32) -> vec3<f32> {
    let x = clamp(x_in, 0.0, k.support_sq);
    let a = k.inv_sigma2;
    if k.family == KERNEL_COMPACT_POLYNOMIAL {
        let base = max(1.0 - x * a, 0.0);
        let m = k.exponent;
        var p2 = 0.0;
        var p1 = 1.0;
        if m >= 2.0 {
            // pow(0, 0) is undefined in WGSL (NaN on lavapipe): at the support boundary the
            // degree-4 kernel's K″ would be NaN, and a NaN f″ bound stepped over surfaces.
            p2 = select(pow(base, m - 2.0), 1.0, m == 2.0);
            p1 = p2 * base;
        }
        return vec3<f32>(p1 * base, -m * a * p1, m * (m - 1.0) * a * a * p2);
    } else if k.family == KERNEL_CAUCHY {
        let base = 1.0 + x * a;
        let n = k.exponent;
        let v = pow(base, -n);
        let v1 = v / base;
        return vec3<f32>(v, -n * a * v1, n * (n + 1.0) * a * a * v1 / base);
    }
    let v = exp(-x * a);
    return vec3<f32>(v, -a * v, a * a * v);
}

// (K, K′) at x, zero outside the support (value_d1).
fn kernel_d1(k: Kernel, x: f32) -> vec2<f32> {
    if x >= k.support_sq {
        return vec2<f32>(0.0);
    }
    let r = kernel_raw(k, x);
    return vec2<f32>(max((r.x - k.clip) * k.clip_scale, 0.0), r.y * k.clip_scale);
}

// (K, K′, K″) of the inside formula, clipped value (value_d2_inside).
fn kernel_d2_inside(k: Kernel, x: f32) -> vec3<f32> {
    let r = kernel_raw(k, x);
    return vec3<f32>(max((r.x - k.clip) * k.clip_scale, 0.0), r.y * k.clip_scale, r.z * k.clip_scale);
}
