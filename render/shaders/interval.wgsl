// Interval arithmetic on (lo, hi) pairs and jets of functions of t: enclosures of a
// function's value, first and second derivative over a ray interval (core:
// bounds/interval.rs; kernel composition field/kernel.rs; blends field/blend.rs jets).

struct Jet {
    value: vec2<f32>,
    d1: vec2<f32>,
    d2: vec2<f32>,
};

fn hull_with(i: vec2<f32>, v: f32) -> vec2<f32> {
    return vec2<f32>(min(i.x, v), max(i.y, v));
}

fn jet_add(a: Jet, b: Jet) -> Jet {
    return Jet(a.value + b.value, a.d1 + b.d1, a.d2 + b.d2);
}

fn jet_max(f: Jet, g: Jet) -> Jet {
    if f.value.x >= g.value.y {
        return f;
    } else if g.value.x >= f.value.y {
        return g;
    }
    return Jet(vec2<f32>(max(f.value.x, g.value.x), max(f.value.y, g.value.y)),
               vec2<f32>(min(f.d1.x, g.d1.x), max(f.d1.y, g.d1.y)),
               vec2<f32>(min(f.d2.x, g.d2.x), INF));
}

fn jet_neg(f: Jet) -> Jet {
    return Jet(-f.value.yx, -f.d1.yx, -f.d2.yx);
}

// Jet of the smooth maximum (blend.rs smooth_max_jet): the larger operand where their ranges
// stay `width` apart; otherwise value in [max, max + w/4], f′ in the hull of theirs, f″ in the
// hull of theirs widened up by max (a′ − b′)²/2w.
fn jet_smooth_max(a: Jet, b: Jet, width: f32) -> Jet {
    if a.value.x - b.value.y >= width {
        return a;
    }
    if b.value.x - a.value.y >= width {
        return b;
    }
    let spread = max(abs(a.d1.x - b.d1.y), abs(a.d1.y - b.d1.x));
    return Jet(vec2<f32>(max(a.value.x, b.value.x), max(a.value.y, b.value.y) + 0.25 * width),
               vec2<f32>(min(a.d1.x, b.d1.x), max(a.d1.y, b.d1.y)),
               vec2<f32>(min(a.d2.x, b.d2.x), max(a.d2.y, b.d2.y) + spread * spread / (2.0 * width)));
}

// ---- interval arithmetic on (lo, hi) pairs (interval.rs) ----

// End-point product with the interval conventions 0 · ∞ = 0 and x · ∞ = ±∞ for x ≠ 0: INF
// stands for ∞ and stays INF (an infinite f″ bound must still read as infinite after scaling).
fn mul_ends(a: f32, b: f32) -> f32 {
    if a == 0.0 || b == 0.0 {
        return 0.0;
    }
    if abs(a) >= INF || abs(b) >= INF {
        return sign(a) * sign(b) * INF;
    }
    return a * b;
}

fn i_mul(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    let p = vec4<f32>(mul_ends(a.x, b.x), mul_ends(a.x, b.y), mul_ends(a.y, b.x), mul_ends(a.y, b.y));
    return vec2<f32>(min(min(p.x, p.y), min(p.z, p.w)), max(max(p.x, p.y), max(p.z, p.w)));
}

fn i_scale(a: vec2<f32>, k: f32) -> vec2<f32> {
    let p = vec2<f32>(mul_ends(a.x, k), mul_ends(a.y, k));
    return vec2<f32>(min(p.x, p.y), max(p.x, p.y));
}

fn i_square(a: vec2<f32>) -> vec2<f32> {
    if a.x >= 0.0 {
        return a * a;
    }
    if a.y <= 0.0 {
        return vec2<f32>(a.y * a.y, a.x * a.x);
    }
    return vec2<f32>(0.0, max(a.x * a.x, a.y * a.y));
}

fn i_new(a: f32, b: f32) -> vec2<f32> {
    return vec2<f32>(min(a, b), max(a, b));
}

fn jet_scale(f: Jet, k: f32) -> Jet {
    return Jet(i_scale(f.value, k), i_scale(f.d1, k), i_scale(f.d2, k));
}

// Ranges of K, K′, K″ over x ∈ xs (kernel.rs KernelProfile::ranges), and whether xs straddles
// the support boundary of a kinked kernel.
struct KernelRanges {
    value: vec2<f32>,
    d1: vec2<f32>,
    d2: vec2<f32>,
    kink: bool,
};

fn kernel_ranges(k: Kernel, xs: vec2<f32>) -> KernelRanges {
    let lo = max(xs.x, 0.0);
    let hi = max(xs.y, lo);
    if lo >= k.support_sq {
        return KernelRanges(vec2<f32>(0.0), vec2<f32>(0.0), vec2<f32>(0.0), false);
    }
    let at_lo = kernel_d2_inside(k, lo);
    if hi >= k.support_sq {
        let edge = kernel_raw(k, k.support_sq).y * k.clip_scale;
        return KernelRanges(vec2<f32>(0.0, at_lo.x),
                            hull_with(vec2<f32>(at_lo.y, max(edge, at_lo.y)), 0.0),
                            vec2<f32>(0.0, at_lo.z), k.kinked != 0u);
    }
    let at_hi = kernel_d2_inside(k, hi);
    return KernelRanges(vec2<f32>(at_hi.x, at_lo.x), vec2<f32>(at_lo.y, at_hi.y),
                        vec2<f32>(at_hi.z, at_lo.z), false);
}

// ---- jets of functions of t (interval.rs Jet) ----

const ENTIRE: vec2<f32> = vec2<f32>(-INF, INF);

fn i_recip(a: vec2<f32>) -> vec2<f32> {
    if a.x > 0.0 || a.y < 0.0 {
        return i_new(1.0 / a.x, 1.0 / a.y);
    }
    return ENTIRE;
}

fn jet_affine(a: f32, b: f32, lo: f32, hi: f32) -> Jet {
    return Jet(i_new(a + b * lo, a + b * hi), vec2<f32>(b), vec2<f32>(0.0));
}

// Exact jet of a t² + b t + c over [lo, hi].
fn jet_quadratic(a: f32, b: f32, c: f32, lo: f32, hi: f32) -> Jet {
    var value = i_new((a * lo + b) * lo + c, (a * hi + b) * hi + c);
    if a != 0.0 {
        let apex = -b / (2.0 * a);
        if apex >= lo && apex <= hi {
            value = hull_with(value, (a * apex + b) * apex + c);
        }
    }
    return Jet(value, i_new(2.0 * a * lo + b, 2.0 * a * hi + b), vec2<f32>(2.0 * a));
}

fn jet_hull(f: Jet, g: Jet) -> Jet {
    return Jet(vec2<f32>(min(f.value.x, g.value.x), max(f.value.y, g.value.y)),
               vec2<f32>(min(f.d1.x, g.d1.x), max(f.d1.y, g.d1.y)),
               vec2<f32>(min(f.d2.x, g.d2.x), max(f.d2.y, g.d2.y)));
}

// The hull of x and j, or j alone when x holds nothing yet.
fn hull_or(x: Jet, any: bool, j: Jet) -> Jet {
    if any {
        return jet_hull(x, j);
    }
    return j;
}

fn jet_mul(f: Jet, g: Jet) -> Jet {
    return Jet(i_mul(f.value, g.value),
               i_mul(f.d1, g.value) + i_mul(f.value, g.d1),
               i_mul(f.d2, g.value) + i_scale(i_mul(f.d1, g.d1), 2.0) + i_mul(f.value, g.d2));
}

// 1/f: (1/f)′ = −f′ r², (1/f)″ = 2 f′² r³ − f″ r² with r = 1/f.
fn jet_recip(f: Jet) -> Jet {
    let r = i_recip(f.value);
    let r2 = i_square(r);
    let d2a = i_mul(i_mul(i_scale(i_square(f.d1), 2.0), r2), r);
    let d2b = i_mul(f.d2, r2);
    return Jet(r, -i_mul(f.d1, r2).yx, vec2<f32>(d2a.x - d2b.y, d2a.y - d2b.x));
}

fn jet_constant(c: f32) -> Jet {
    return Jet(vec2<f32>(c), vec2<f32>(0.0), vec2<f32>(0.0));
}

fn jet_sub(f: Jet, g: Jet) -> Jet {
    return Jet(f.value - g.value.yx, f.d1 - g.d1.yx, f.d2 - g.d2.yx);
}

// f², exact in the value.
fn jet_square(f: Jet) -> Jet {
    return Jet(i_square(f.value), i_scale(i_mul(f.value, f.d1), 2.0),
               i_scale(i_square(f.d1) + i_mul(f.value, f.d2), 2.0));
}

fn i_sqrt(a: vec2<f32>) -> vec2<f32> {
    return sqrt(max(a, vec2<f32>(0.0)));
}

// √f on the non-negative part of f: r′ = f′/2r, r″ = (f″ − 2r′²)/2r.
fn jet_sqrt(f: Jet) -> Jet {
    let r = i_sqrt(f.value);
    let half_inv = i_scale(i_recip(r), 0.5);
    let d1 = i_mul(f.d1, half_inv);
    let d2 = i_mul(f.d2 - i_scale(i_square(d1), 2.0).yx, half_inv);
    return Jet(r, d1, d2);
}

// √f where √f ≥ floor > 0 (interval.rs sqrt_above): f clamped below at floor², for results
// that feed max(√f − floor′, 0) with floor′ ≥ floor.
fn jet_sqrt_above(f: Jet, floor: f32) -> Jet {
    let f2 = floor * floor;
    return jet_sqrt(Jet(max(f.value, vec2<f32>(f2)), f.d1, f.d2));
}

// max(f, 0)², C¹ in f; a lower end of exactly 0 (from a clamp) counts as straddling 0.
fn jet_positive_part_squared(f: Jet) -> Jet {
    if f.value.x > 0.0 {
        return jet_square(f);
    } else if f.value.y <= 0.0 {
        return jet_constant(0.0);
    }
    let pos = vec2<f32>(0.0, f.value.y);
    return Jet(i_square(pos), hull_with(i_scale(i_mul(pos, f.d1), 2.0), 0.0),
               hull_with(i_scale(i_square(f.d1) + i_mul(pos, f.d2), 2.0), 0.0));
}

fn jet_div(f: Jet, g: Jet) -> Jet {
    return jet_mul(f, jet_recip(g));
}

// K ∘ x from a jet of x (kernel.rs compose): (K∘x)′ = K′x′, (K∘x)″ = K″x′² + K′x″, the upper
// f″ bound infinite where x straddles a kinked kernel's support boundary.
fn jet_compose(k: Kernel, x: Jet) -> Jet {
    let kr = kernel_ranges(k, x.value);
    var d2 = i_mul(kr.d2, i_square(x.d1)) + i_mul(kr.d1, x.d2);
    if kr.kink {
        d2.y = INF;
    }
    return Jet(kr.value, i_mul(kr.d1, x.d1), d2);
}
