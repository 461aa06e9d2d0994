//! Kernels (fall-off functions) and their normalisation.
//!
//! Theory (scalis 2021 eq. 2–3, forward-inclusion 2023 eq. 6–7, MATH.md §1–4): a kernel maps a
//! normalised distance `r` to a density in `[0, 1]`. Everything downstream works with the
//! *squared* normalised distance `x = r²`, because along a ray `x` is a quadratic for a point and
//! a polynomial-friendly quantity for every other primitive: `K(x) = k(√x)`.
//!
//! - compact polynomial, degree `i = 2m`, scale `σ > 1`: `K(x) = (1 − x/σ²)^m` for `x < σ²`;
//! - Cauchy, degree `i`, scale `σ`: `K(x) = (1 + x/σ²)^(−i/2)`;
//! - Gaussian, scale `σ`: `K(x) = exp(−x/σ²)` (the papers' sharpness is `s = 1/σ²`).
//!
//! Cauchy and Gaussian kernels have infinite support. They are *clipped* at
//! [`CLIP_EPSILON`] (scalis §7): `K_c = (K − ε)/(1 − ε)` where `K ≥ ε`, else 0. The clipped kernel
//! is continuous, differs from the exact one by at most `ε` everywhere (`|K_c − K| ≤ ε`), and has
//! a compact support, so the acceleration structure can skip far primitives. Its first derivative
//! jumps at the support boundary (a convex kink); so does the degree-2 compact kernel's. Second
//! derivative bounds account for that (see [`KernelProfile::compose`]).
//!
//! Practice: a scene stores a [`Kernel`] (`model/kernel.rs`: the file's spec and its
//! validation); a field program turns it into a [`KernelProfile`],
//! which evaluates `K`, `K′`, `K″` by value and over intervals and carries the normalisation
//! constants of points, SCALIS segments and end-point correctors.

use crate::bounds::interval::{Interval, Jet};
use crate::field::quadrature::GaussLegendre;
pub use crate::model::kernel::CLIP_EPSILON;
use crate::model::kernel::Kernel;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Family {
    /// `(1 − x/σ²)^m`.
    Compact { m: i32 },
    /// `(1 + x/σ²)^(−n)`, `n = i/2`.
    Cauchy { n: f64 },
    /// `exp(−x/σ²)`.
    Gaussian,
}

/// `x^n` for `n ≥ 0` by binary exponentiation, as `f64::powi` computes it with an exponent
/// known only at run time (the `__powidf2` routine of Rust's compiler builtins, bit for bit):
/// written out, it inlines into the kernel loops instead of costing a library call per node.
#[inline]
fn powi(mut x: f64, n: i32) -> f64 {
    let mut n = n.unsigned_abs();
    let mut product = 1.0;
    loop {
        if n & 1 != 0 {
            product *= x;
        }
        n >>= 1;
        if n == 0 {
            return product;
        }
        x *= x;
    }
}

/// Unclipped `K, K′, K″` of the compact kernel `(1 − a·x)^m` at `x`; inlined with a constant
/// `m`, the power unrolls.
#[inline(always)]
fn compact_raw(m: i32, a: f64, x: f64) -> (f64, f64, f64) {
    let base = (1.0 - x * a).max(0.0);
    let mf = f64::from(m);
    let p2 = if m >= 2 { powi(base, m - 2) } else { 0.0 };
    let p1 = if m >= 2 { p2 * base } else { 1.0 };
    (p1 * base, -mf * a * p1, mf * (mf - 1.0) * a * a * p2)
}

/// A kernel evaluated many times in one loop (a SCALIS segment's quadrature nodes):
/// [`KernelProfile::with_family`] hands the loop one whose family — and, for the compact
/// kernels of degree 4 and 6, whose power — is fixed at compile time, so that the loop does not
/// match the family at every node. Its values are [`KernelProfile::value`]'s and
/// [`KernelProfile::value_d1`]'s bit for bit.
pub trait FixedKernel {
    /// `K(x)`.
    fn value(&self, x: f64) -> f64;
    /// `(K(x), K′(x))`.
    fn value_d1(&self, x: f64) -> (f64, f64);
    /// [`KernelProfile::ranges`], bit for bit.
    fn ranges(&self, xs: Interval) -> (Interval, Interval, Interval, bool);
    /// [`KernelProfile::value_d2_inside`], bit for bit.
    fn value_d2_inside(&self, x: f64) -> (f64, f64, f64);
    /// [`KernelProfile::support_sq`].
    fn support_sq(&self) -> f64;
    /// [`KernelProfile::point_critical_tau2`], bit for bit.
    fn point_critical_tau2(&self, h2: f64) -> (f64, f64);
}

/// What [`ranges_over`] needs of a kernel.
struct RangeRule<F, G> {
    support_sq: f64,
    /// `(K, K′, K″)` at `x` inside the support, clipped and rescaled.
    value_d2: F,
    /// `K′` at the support boundary, seen from inside (asked only where the range reaches it).
    slope_at_edge: G,
    kinked: bool,
}

/// Exact ranges of `K`, `K′`, `K″` over `x ∈ xs`, using `K` decreasing, `K′` increasing
/// towards 0 and `K″ ≥ 0` decreasing on the support; the flag tells whether `xs` straddles
/// the support boundary of a kinked kernel. One body for [`KernelProfile::ranges`] and the
/// fixed kernels' (so the two agree bit for bit).
#[inline(always)]
fn ranges_over<F: Fn(f64) -> (f64, f64, f64), G: Fn() -> f64>(
    rule: &RangeRule<F, G>,
    xs: Interval,
) -> (Interval, Interval, Interval, bool) {
    let lo = xs.lo.max(0.0);
    let hi = xs.hi.max(lo);
    if lo >= rule.support_sq {
        return (Interval::ZERO, Interval::ZERO, Interval::ZERO, false);
    }
    let (k_lo, k1_lo, k2_lo) = (rule.value_d2)(lo);
    if hi >= rule.support_sq {
        // The range reaches the boundary: K and K″ reach 0, K′ reaches its value at the
        // boundary from inside (0 for m ≥ 2) and 0 outside.
        return (
            Interval::new(0.0, k_lo),
            Interval::new(k1_lo, (rule.slope_at_edge)().max(k1_lo)).include(0.0),
            Interval::new(0.0, k2_lo),
            rule.kinked,
        );
    }
    let (k_hi, k1_hi, k2_hi) = (rule.value_d2)(hi);
    (
        Interval::new(k_hi, k_lo),
        Interval::new(k1_lo, k1_hi),
        Interval::new(k2_hi, k2_lo),
        false,
    )
}

/// A loop over kernel evaluations, run by [`KernelProfile::with_family`].
pub trait KernelLoop {
    /// What the loop computes.
    type Output;
    /// Runs the loop with `kernel`.
    fn run<K: FixedKernel>(self, kernel: &K) -> Self::Output;
}

/// The compact kernel `(1 − a·x)^M`, its constants held by value: in a loop they stay in
/// registers, and the clip's steps (`(K − 0)·1`) are left out, being identities.
#[derive(Clone, Copy)]
struct CompactKernel<const M: i32> {
    a: f64,
    support_sq: f64,
}

impl<const M: i32> FixedKernel for CompactKernel<M> {
    #[inline(always)]
    fn value(&self, x: f64) -> f64 {
        if x >= self.support_sq {
            return 0.0;
        }
        compact_raw(M, self.a, x.max(0.0)).0.max(0.0)
    }
    #[inline(always)]
    fn value_d1(&self, x: f64) -> (f64, f64) {
        if x >= self.support_sq {
            return (0.0, 0.0);
        }
        let (k, k1, _) = compact_raw(M, self.a, x.max(0.0));
        (k.max(0.0), k1)
    }
    #[inline(always)]
    fn ranges(&self, xs: Interval) -> (Interval, Interval, Interval, bool) {
        ranges_over(
            &RangeRule {
                support_sq: self.support_sq,
                // Inside the support (the only place the rule calls it), as `value_d2`.
                value_d2: |x: f64| {
                    let (k, k1, k2) = compact_raw(M, self.a, x);
                    (k.max(0.0), k1, k2)
                },
                slope_at_edge: || compact_raw(M, self.a, self.support_sq).1,
                // `M ≥ 2`: `K′` is continuous at the boundary.
                kinked: false,
            },
            xs,
        )
    }
    #[inline(always)]
    fn value_d2_inside(&self, x: f64) -> (f64, f64, f64) {
        let (k, k1, k2) = compact_raw(M, self.a, x.clamp(0.0, self.support_sq));
        (k.max(0.0), k1, k2)
    }
    #[inline(always)]
    fn support_sq(&self) -> f64 {
        self.support_sq
    }
    #[inline(always)]
    fn point_critical_tau2(&self, h2: f64) -> (f64, f64) {
        compact_critical_tau2(M, 1.0 / self.a, h2)
    }
}

/// [`KernelProfile::point_critical_tau2`] of the compact kernel `(1 − x/σ²)^m`, `s2 = σ²`.
#[inline(always)]
fn compact_critical_tau2(m: i32, s2: f64, h2: f64) -> (f64, f64) {
    let p = (s2 - h2).max(0.0);
    let q = f64::from(2 * m - 1);
    (p / q, 3.0 * p / q)
}

impl FixedKernel for KernelProfile {
    #[inline]
    fn value(&self, x: f64) -> f64 {
        Self::value(self, x)
    }
    #[inline]
    fn value_d1(&self, x: f64) -> (f64, f64) {
        Self::value_d1(self, x)
    }
    #[inline]
    fn ranges(&self, xs: Interval) -> (Interval, Interval, Interval, bool) {
        Self::ranges(self, xs)
    }
    #[inline]
    fn value_d2_inside(&self, x: f64) -> (f64, f64, f64) {
        Self::value_d2_inside(self, x)
    }
    #[inline]
    fn support_sq(&self) -> f64 {
        self.support_sq
    }
    #[inline]
    fn point_critical_tau2(&self, h2: f64) -> (f64, f64) {
        Self::point_critical_tau2(self, h2)
    }
}

/// Runtime form of a kernel as a function of the squared normalised distance `x`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KernelProfile {
    family: Family,
    inv_sigma2: f64,
    /// `x` beyond which the (clipped) kernel is zero.
    support_sq: f64,
    /// `√support_sq`, asked for once per candidate primitive of every ray.
    support_radius: f64,
    /// Subtracted before rescaling (0 for compact kernels).
    clip: f64,
    /// `1 / (1 − clip)`.
    clip_scale: f64,
    /// Whether `K′` jumps at the support boundary.
    kinked: bool,
}

impl KernelProfile {
    /// Builds the profile of a validated kernel.
    #[must_use]
    pub fn new(kernel: Kernel) -> Self {
        match kernel {
            Kernel::CompactPolynomial { degree, scale } => {
                let m = i32::try_from(degree / 2).unwrap_or(1);
                let s2 = scale * scale;
                Self::with(Family::Compact { m }, s2, kernel.support_sq(), 0.0, m == 1)
            }
            Kernel::Cauchy { degree, scale } => {
                let n = f64::from(degree) / 2.0;
                let s2 = scale * scale;
                Self::with(
                    Family::Cauchy { n },
                    s2,
                    kernel.support_sq(),
                    CLIP_EPSILON,
                    true,
                )
            }
            Kernel::Gaussian { scale } => {
                let s2 = scale * scale;
                Self::with(
                    Family::Gaussian,
                    s2,
                    kernel.support_sq(),
                    CLIP_EPSILON,
                    true,
                )
            }
        }
    }

    /// The profile of `family` at squared scale `s2`, clipped at `clip` (0 for compact kernels,
    /// whose rescaling `1 / (1 − 0)` is then exactly 1), with what is derived from them.
    fn with(family: Family, s2: f64, support_sq: f64, clip: f64, kinked: bool) -> Self {
        Self {
            family,
            inv_sigma2: 1.0 / s2,
            support_sq,
            support_radius: support_sq.sqrt(),
            clip,
            clip_scale: 1.0 / (1.0 - clip),
            kinked,
        }
    }

    /// Normalised distance beyond which the kernel vanishes (`σ` for compact kernels).
    #[must_use]
    pub fn support_radius(&self) -> f64 {
        self.support_radius
    }

    /// Squared normalised support radius.
    #[must_use]
    pub fn support_sq(&self) -> f64 {
        self.support_sq
    }

    /// Whether the kernel is an infinite-support kernel clipped at [`CLIP_EPSILON`].
    #[must_use]
    pub fn is_clipped(&self) -> bool {
        self.clip > 0.0
    }

    /// Whether the first derivative jumps at the support boundary (clipped kernels, degree 2).
    #[must_use]
    pub fn is_kinked(&self) -> bool {
        self.kinked
    }

    /// Unclipped `K, K′, K″` at `x` inside the support.
    #[inline]
    fn raw(&self, x: f64) -> (f64, f64, f64) {
        let a = self.inv_sigma2;
        match self.family {
            Family::Compact { m } => compact_raw(m, a, x),
            Family::Cauchy { n } => {
                let base = 1.0 + x * a;
                let k = base.powf(-n);
                let k1 = k / base;
                (k, -n * a * k1, n * (n + 1.0) * a * a * k1 / base)
            }
            Family::Gaussian => {
                let k = (-x * a).exp();
                (k, -a * k, a * a * k)
            }
        }
    }

    /// `K(x)`.
    #[must_use]
    #[inline]
    pub fn value(&self, x: f64) -> f64 {
        if x >= self.support_sq {
            return 0.0;
        }
        let (k, _, _) = self.raw(x.max(0.0));
        ((k - self.clip) * self.clip_scale).max(0.0)
    }

    /// `(K(x), K′(x))`; the one-sided derivative from inside at the support boundary is not
    /// returned: outside the support both are 0.
    #[must_use]
    #[inline]
    pub fn value_d1(&self, x: f64) -> (f64, f64) {
        if x >= self.support_sq {
            return (0.0, 0.0);
        }
        let (k, k1, _) = self.raw(x.max(0.0));
        (
            ((k - self.clip) * self.clip_scale).max(0.0),
            k1 * self.clip_scale,
        )
    }

    /// Runs `kernel_loop` with this kernel's family fixed ([`FixedKernel`]).
    pub fn with_family<L: KernelLoop>(&self, kernel_loop: L) -> L::Output {
        let (a, support_sq) = (self.inv_sigma2, self.support_sq);
        match self.family {
            Family::Compact { m: 2 } => kernel_loop.run(&CompactKernel::<2> { a, support_sq }),
            Family::Compact { m: 3 } => kernel_loop.run(&CompactKernel::<3> { a, support_sq }),
            _ => kernel_loop.run(self),
        }
    }

    /// `(K, K′, K″)` at `x`, zero outside the support.
    #[must_use]
    pub fn value_d2(&self, x: f64) -> (f64, f64, f64) {
        if x >= self.support_sq {
            return (0.0, 0.0, 0.0);
        }
        let (k, k1, k2) = self.raw(x.max(0.0));
        let s = self.clip_scale;
        (((k - self.clip) * s).max(0.0), k1 * s, k2 * s)
    }

    /// `(K, K′, K″)` of the formula valid inside the support, evaluated at `min(x, support)`:
    /// at the boundary it gives the one-sided derivatives seen from inside.
    #[must_use]
    pub fn value_d2_inside(&self, x: f64) -> (f64, f64, f64) {
        let (k, k1, k2) = self.raw(x.clamp(0.0, self.support_sq));
        let s = self.clip_scale;
        (((k - self.clip) * s).max(0.0), k1 * s, k2 * s)
    }

    /// Exact ranges of `K`, `K′`, `K″` over `x ∈ xs` ([`ranges_over`]); the flag tells whether
    /// `xs` straddles the support boundary of a kinked kernel.
    #[must_use]
    pub fn ranges(&self, xs: Interval) -> (Interval, Interval, Interval, bool) {
        ranges_over(
            &RangeRule {
                support_sq: self.support_sq,
                value_d2: |x: f64| self.value_d2(x),
                slope_at_edge: || self.raw(self.support_sq).1 * self.clip_scale,
                kinked: self.kinked,
            },
            xs,
        )
    }

    /// Jet of `K ∘ x` from a jet of `x`: `(K∘x)′ = K′x′`, `(K∘x)″ = K″x′² + K′x″`. Where the
    /// interval crosses the boundary of a kinked kernel, `(K∘x)′` jumps upwards there, so the
    /// upper second-derivative bound is infinite (the lower one stays valid).
    #[must_use]
    pub fn compose(&self, x: Jet) -> Jet {
        let (k, k1, k2, kink) = self.ranges(x.value);
        let mut d2 = k2 * x.d1.square() + k1 * x.d2;
        if kink {
            d2.hi = f64::INFINITY;
        }
        Jet {
            value: k,
            d1: k1 * x.d1,
            d2,
        }
    }

    /// Points of the ray parameter (as `τ²`, in units of the primitive radius, measured from
    /// the closest point to the centre) where the first and the second derivative of
    /// `K((τ² + ĥ²))` reach their extrema, for a point primitive at normalised distance `ĥ`
    /// from the ray (MATH.md §5, generalised to every degree).
    #[must_use]
    pub fn point_critical_tau2(&self, h2: f64) -> (f64, f64) {
        let s2 = 1.0 / self.inv_sigma2;
        match self.family {
            Family::Compact { m } => compact_critical_tau2(m, s2, h2),
            Family::Cauchy { n } => {
                let b = s2 + h2;
                let q = 2.0 * n + 1.0;
                (b / q, 3.0 * b / q)
            }
            Family::Gaussian => (0.5 * s2, 1.5 * s2),
        }
    }

    /// `max_r |d/dr K(r²)|`, the largest slope of the kernel as a function of the normalised
    /// distance (MATH.md §1: `K′` of the compact kernel). The extremum of `2r·K′(r²)` sits at
    /// `x = σ²/(i − 1)` (compact), `σ²/(i + 1)` (Cauchy) or `σ²/2` (Gaussian), or at the clip
    /// boundary when that comes first.
    #[must_use]
    pub fn max_slope(&self) -> f64 {
        self.slope_at(self.steepest_x())
    }

    /// `max |d/dr K(r²)|` over `r² ∈ xs` (Galin et al. 2020's kernel bound on a distance
    /// range): the slope `2r·|K′(r²)|` rises to its peak at [`Self::max_slope`]'s `x` and falls
    /// after it, so the maximum is there when `xs` holds it, else at the nearer end.
    #[must_use]
    pub fn max_slope_on(&self, xs: Interval) -> f64 {
        let peak = self.steepest_x();
        let lo = xs.lo.clamp(0.0, self.support_sq);
        let hi = xs.hi.clamp(lo, self.support_sq);
        self.slope_at(peak.clamp(lo, hi))
    }

    /// Where `2√x·|K′(x)|` peaks inside the support.
    fn steepest_x(&self) -> f64 {
        let s2 = 1.0 / self.inv_sigma2;
        let critical = match self.family {
            Family::Compact { m } => s2 / f64::from(2 * m - 1),
            Family::Cauchy { n } => s2 / (2.0 * n + 1.0),
            Family::Gaussian => 0.5 * s2,
        };
        critical.min(self.support_sq)
    }

    /// `2√x·|K′(x)|`, the slope in `r = √x`, from inside the support.
    fn slope_at(&self, x: f64) -> f64 {
        let (_, k1, _) = self.value_d2_inside(x);
        2.0 * x.sqrt() * k1.abs()
    }

    /// `(K(x), g)` with `g` a subgradient of the kernel at `x`, on the whole real line: for
    /// `x < 0` the tangent at 0 continues the kernel. Every profile is decreasing and convex in
    /// `x` (clipping is a maximum with 0 of a convex function), and so is this extension: the
    /// bottom-up inclusions (forward-inclusion 2023 §5.2, appendix B) rely on exactly that.
    #[must_use]
    pub fn convex_extension(&self, x: f64) -> (f64, f64) {
        if x < 0.0 {
            let (k0, d0) = self.value_d1(0.0);
            return (k0 + d0 * x, d0);
        }
        self.value_d1(x)
    }

    /// `(m, 1/σ²)` when the kernel is the compact polynomial `(1 − x/σ²)^m`.
    #[must_use]
    pub fn compact_power(&self) -> Option<(i32, f64)> {
        match self.family {
            Family::Compact { m } => Some((m, self.inv_sigma2)),
            _ => None,
        }
    }

    /// Field normalisation of scalis 2021 §4 (MATH.md §4): `(g(f), g′(f))`, the squared
    /// homothetic distance at which an infinite constant-radius SCALIS segment has the value
    /// `f`, for isovalue `c`. `g(c) = 1`; capped at the squared support radius, where `f = 0`
    /// (there `g′` is reported as 0). Compact kernels: the line field is the compact kernel of
    /// degree `i + 1`; Cauchy: degree `i − 1` (a degree-1 Cauchy kernel has no finite line
    /// integral and uses the Gaussian-like logarithm below); Gaussian: a Gaussian again.
    #[must_use]
    pub fn field_normalisation(&self, f: f64, isovalue: f64) -> (f64, f64) {
        let cap = self.support_sq;
        if f <= 0.0 {
            return (cap, 0.0);
        }
        let s2 = 1.0 / self.inv_sigma2;
        let ratio = f / isovalue;
        let (g, d) = match self.family {
            Family::Compact { m } => {
                let e = 2.0 / f64::from(2 * m + 1);
                let q = 1.0 - 1.0 / s2;
                let p = ratio.powf(e);
                (s2 * (1.0 - q * p), -s2 * q * e * p / f)
            }
            Family::Cauchy { n } if n > 0.5 => {
                let e = 1.0 / (n - 0.5);
                let p = ratio.powf(-e);
                ((1.0 + s2) * p - s2, -(1.0 + s2) * e * p / f)
            }
            Family::Cauchy { .. } | Family::Gaussian => (1.0 - s2 * ratio.ln(), -s2 / f),
        };
        if g >= cap { (cap, 0.0) } else { (g, d) }
    }

    /// Normalisation of a point primitive: the field equals the isovalue at the prescribed
    /// radius (MATH.md §2).
    #[must_use]
    pub fn point_normalisation(&self, isovalue: f64) -> f64 {
        isovalue / self.value(1.0)
    }

    /// `∫ K(1 + u²) du` over the line: the SCALIS field of an infinite constant-radius segment at
    /// its prescribed radius, before normalisation (MATH.md §3).
    fn line_integral(&self) -> f64 {
        let half = (self.support_sq - 1.0).max(0.0).sqrt();
        GaussLegendre::scalis().integrate(-half, half, 64, |u| self.value(1.0 + u * u))
    }

    /// Normalisation `N` of a SCALIS segment: the surface of a long constant-radius segment sits
    /// at its prescribed radius (MATH.md §3, closed form for compact kernels there; computed by
    /// quadrature here for every kernel).
    #[must_use]
    pub fn scalis_normalisation(&self, isovalue: f64) -> f64 {
        isovalue / self.line_integral()
    }

    /// Length of an end-point corrector per unit of end radius (scalis §1.1, MATH.md §3): a
    /// constant-radius segment of this length × τ appended at a free end puts the surface at
    /// distance τ past the end along the axis. Solved by bisection on
    /// `∫_{1−λ}^{R} K(v²) dv = ∫ K(1 + u²) du`.
    #[must_use]
    pub fn end_corrector_ratio(&self) -> f64 {
        let target = self.line_integral();
        let r = self.support_radius();
        let rule = GaussLegendre::scalis();
        let tail = |a: f64| rule.integrate(a, r, 32, |v| self.value(v * v));
        let (mut lo, mut hi) = (-r, r);
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            if tail(mid) > target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        1.0 - 0.5 * (lo + hi)
    }
}

/// A kernel of every family and of several compact degrees, for the tests that hold the
/// kernels' fixed-family code to the profile's.
#[cfg(test)]
pub(crate) const EVERY_FAMILY: [Kernel; 7] = [
    Kernel::CompactPolynomial {
        degree: 2,
        scale: 2.0,
    },
    Kernel::CompactPolynomial {
        degree: 4,
        scale: 1.5,
    },
    Kernel::CompactPolynomial {
        degree: 6,
        scale: 2.0,
    },
    Kernel::CompactPolynomial {
        degree: 8,
        scale: 3.0,
    },
    Kernel::Cauchy {
        degree: 1,
        scale: 1.0,
    },
    Kernel::Cauchy {
        degree: 4,
        scale: 0.5,
    },
    Kernel::Gaussian { scale: 1.0 },
];

#[cfg(test)]
mod tests {
    use super::*;

    /// Records what [`KernelProfile::with_family`] hands its loop on sampled arguments.
    struct Sample(Vec<f64>);

    impl KernelLoop for Sample {
        type Output = Vec<((f64, f64, f64), RangeBits, [u64; 6])>;
        fn run<K: FixedKernel>(self, kernel: &K) -> Self::Output {
            self.0
                .iter()
                .zip(self.0.iter().cycle().skip(1))
                .map(|(x, y)| {
                    let (v, d1) = kernel.value_d1(*x);
                    let range = kernel.ranges(Interval::new(*x, *y));
                    let point = point_bits(
                        kernel.value_d2_inside(*x),
                        kernel.point_critical_tau2(*x),
                        kernel.support_sq(),
                    );
                    ((kernel.value(*x), v, d1), range_bits(range), point)
                })
                .collect()
        }
    }

    /// `K, K′, K″` inside the support, the critical `τ²` of a point blob at `ĥ² = x` and the
    /// support, as bits.
    fn point_bits((k, k1, k2): (f64, f64, f64), (c1, c2): (f64, f64), support_sq: f64) -> [u64; 6] {
        [k, k1, k2, c1, c2, support_sq].map(f64::to_bits)
    }

    /// The ends of [`KernelProfile::ranges`]'s intervals as bits (signs of zeros included) and
    /// its kink flag.
    type RangeBits = ([u64; 6], bool);

    fn range_bits((k, k1, k2, kink): (Interval, Interval, Interval, bool)) -> RangeBits {
        let ends = [k.lo, k.hi, k1.lo, k1.hi, k2.lo, k2.hi];
        (ends.map(f64::to_bits), kink)
    }

    /// The kernel a loop gets with its family fixed is the profile's own, equal number for
    /// equal number, on every family and degree, inside, at and beyond the support: values,
    /// slopes, and ranges over intervals between the samples, and a point blob's terms (bit for
    /// bit).
    #[test]
    fn kernels_with_their_family_fixed_are_the_profiles() {
        let mut rng = crate::model::rng::SplitMix64::new(41);
        for kernel in EVERY_FAMILY {
            let profile = KernelProfile::new(kernel);
            let s2 = profile.support_sq();
            let mut xs: Vec<f64> = (0..2000).map(|_| rng.range(-0.1, 1.2) * s2).collect();
            xs.extend([0.0, -0.0, s2, s2 * (1.0 - 1e-16), f64::INFINITY]);
            let fixed = profile.with_family(Sample(xs.clone()));
            let next = xs.iter().cycle().skip(1);
            for ((x, y), ((v, v1, d1), range, point)) in xs.iter().zip(next).zip(fixed) {
                let want = point_bits(
                    profile.value_d2_inside(*x),
                    profile.point_critical_tau2(*x),
                    profile.support_sq(),
                );
                assert_eq!(point, want, "{kernel:?}: point blob terms at {x}");
                let (w1, e1) = profile.value_d1(*x);
                assert!(
                    v == profile.value(*x) && v1 == w1 && d1 == e1,
                    "{kernel:?} at {x}: {v} {v1} {d1} vs {} {w1} {e1}",
                    profile.value(*x)
                );
                let want = profile.ranges(Interval::new(*x, *y));
                assert_eq!(
                    range,
                    range_bits(want),
                    "{kernel:?} over {x}, {y}: {want:?}"
                );
            }
        }
    }

    /// The written-out power is `f64::powi` bit for bit (so the kernels, and every march, are
    /// unchanged by it), on bases across the support and exponents of every kernel degree.
    #[test]
    fn written_out_powi_is_the_library_powi_bit_for_bit() {
        let mut rng = crate::model::rng::SplitMix64::new(3);
        for _ in 0..20_000 {
            let x = rng.range(0.0, 1.0).powf(rng.range(0.2, 5.0));
            // `black_box` keeps the exponent unknown at compile time, as in the kernels.
            let n = std::hint::black_box(rng.below(12) as i32);
            assert_eq!(powi(x, n).to_bits(), x.powi(n).to_bits(), "{x}^{n}");
        }
    }

    #[test]
    fn compact_scalis_normalisation_matches_the_closed_form() {
        let n6 = KernelProfile::new(Kernel::CompactPolynomial {
            degree: 6,
            scale: 2.0,
        })
        .scalis_normalisation(1.0);
        let n4 = KernelProfile::new(Kernel::CompactPolynomial {
            degree: 4,
            scale: 2.0,
        })
        .scalis_normalisation(1.0);
        assert!((n6 - 1.496_834_0).abs() < 1e-7, "{n6}");
        assert!((n4 - 0.962_250_4).abs() < 1e-7, "{n4}");
    }

    /// One kernel of each family and shape the slope bounds distinguish: smooth compact,
    /// kinked compact (degree 2), clipped Cauchy, clipped Gaussian.
    const SLOPE_KERNELS: [Kernel; 4] = [
        Kernel::CompactPolynomial {
            degree: 6,
            scale: 2.0,
        },
        Kernel::CompactPolynomial {
            degree: 2,
            scale: 1.5,
        },
        Kernel::Cauchy {
            degree: 3,
            scale: 1.0,
        },
        Kernel::Gaussian { scale: 0.7 },
    ];

    #[test]
    fn max_slope_matches_the_closed_form_and_dense_sampling() {
        let compact = KernelProfile::new(Kernel::default());
        assert!((compact.max_slope() - 0.858_65).abs() < 1e-5);
        for kernel in SLOPE_KERNELS {
            let p = KernelProfile::new(kernel);
            let sampled = (1..100_000)
                .map(|i| {
                    let r = p.support_radius() * f64::from(i) / 100_000.0;
                    2.0 * r * p.value_d1(r * r).1.abs()
                })
                .fold(0.0, f64::max);
            assert!(sampled <= p.max_slope() * (1.0 + 1e-12), "{kernel:?}");
            assert!(sampled >= p.max_slope() * 0.999, "{kernel:?}");
        }
    }

    #[test]
    fn max_slope_on_a_range_matches_dense_sampling_of_that_range() {
        let mut rng = crate::model::rng::SplitMix64::new(7);
        for kernel in SLOPE_KERNELS {
            let p = KernelProfile::new(kernel);
            for _ in 0..200 {
                let (a, b) = (rng.unit() * p.support_sq(), rng.unit() * p.support_sq());
                let xs = Interval::new(a.min(b), a.max(b));
                let sampled = (0..=2000)
                    .map(|i| {
                        let x = xs.lo + (xs.hi - xs.lo) * f64::from(i) / 2000.0;
                        2.0 * x.sqrt() * p.value_d2_inside(x).1.abs()
                    })
                    .fold(0.0, f64::max);
                let bound = p.max_slope_on(xs);
                assert!(sampled <= bound * (1.0 + 1e-12), "{kernel:?} {xs:?}");
                assert!(sampled >= bound * 0.999, "{kernel:?} {xs:?}");
            }
        }
    }

    #[test]
    fn point_normalisation_puts_the_isovalue_at_the_radius() {
        for kernel in [
            Kernel::default(),
            Kernel::Cauchy {
                degree: 3,
                scale: 1.0,
            },
            Kernel::Gaussian { scale: 1.0 },
        ] {
            let p = KernelProfile::new(kernel);
            let n = p.point_normalisation(0.5);
            assert!((n * p.value(1.0) - 0.5).abs() < 1e-12);
        }
        let compact = KernelProfile::new(Kernel::default());
        assert!((compact.point_normalisation(1.0) - 2.370_370_37).abs() < 1e-7);
    }

    #[test]
    fn clipped_kernels_stay_within_epsilon_of_the_exact_kernel() {
        let cauchy = KernelProfile::new(Kernel::Cauchy {
            degree: 3,
            scale: 1.0,
        });
        for i in 0..1000 {
            let x = f64::from(i) * 0.05;
            let exact = (1.0 + x).powf(-1.5);
            assert!((cauchy.value(x) - exact).abs() <= CLIP_EPSILON + 1e-15);
        }
    }

    #[test]
    fn end_corrector_ratio_is_positive_and_shorter_than_the_support() {
        let p = KernelProfile::new(Kernel::default());
        let lambda = p.end_corrector_ratio();
        assert!(lambda > 0.0 && lambda < 3.0, "{lambda}");
    }
}
