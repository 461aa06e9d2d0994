//! SCALIS segments: `f(p) = N ∫₀^L K(|p − q(s)|²/τ(s)²) / τ(s) ds` (scalis 2021 eq. 8,
//! MATH.md §3), with the integral clipped to the kernel support and evaluated by Gauss–Legendre
//! quadrature in `u = ln τ` (or in arc length when the radius barely varies; with `m + 1` nodes,
//! exact, for a constant radius and a compact polynomial kernel).
//!
//! Derivative bounds along a ray differentiate under the integral:
//! `f′ = N∫ K′(x)·2w/τ³ ds` and `f″ = N∫ (K″(x)·4w²/τ⁵ + K′(x)·2/τ³) ds` with
//! `w = u·(p − q)`. The segment is split into pieces; on each piece × ray interval, `x`, `w` and
//! `τ` are enclosed exactly (distance between two segments, corners of an affine function), and
//! the integrand's range times the piece length encloses the piece's contribution.

use glam::DVec3;

use crate::bounds::interval::{Interval, Jet};
use crate::field::geometry::{
    Aabb, ChordToAxis, RELATIVE_SUPPORT_MARGIN, Ray, SphereCone, rounding_margin,
};
use crate::field::kernel::{FixedKernel, KernelLoop, KernelProfile};
use crate::field::quadrature::GaussLegendre;

/// Pieces per segment in the derivative bounds, at most.
const MAX_BOUND_PIECES: usize = 24;

/// The end of a piece in [`ScalisSegment::ray_jet`]: the radius there, its inverse and the
/// inverse's square and cube, and the squared distances from the skeleton point to the two
/// ends of the ray's chord.
#[derive(Clone, Copy)]
struct PieceEnd {
    tau: f64,
    inv_tau: f64,
    inv_tau2: f64,
    inv_tau3: f64,
    to_a: f64,
    to_b: f64,
}

/// A SCALIS segment primitive (also used for end-point correctors, with constant radius).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScalisSegment {
    /// Prescribed sphere-cone (radius growing from `start`).
    pub cone: SphereCone,
    /// Normalisation `N` (MATH.md §3).
    pub norm: f64,
}

impl ScalisSegment {
    /// Part `[l₁, l₂]` of the segment whose support ball contains `p` (MATH.md §3, stable roots).
    fn clipped_range(&self, p: DVec3, k: &KernelProfile) -> Option<(f64, f64)> {
        let c = &self.cone;
        let inv_r2 = 1.0 / k.support_sq();
        let w = p - c.start;
        let qa = inv_r2 - c.slope * c.slope;
        let qb = w.dot(c.axis) * inv_r2 + c.radius * c.slope;
        let qc = w.length_squared() * inv_r2 - c.radius * c.radius;
        let disc = qb * qb - qa * qc;
        if disc < 0.0 {
            return None;
        }
        let big = qb + disc.sqrt();
        if big <= 0.0 || c.length * big < qc {
            return None;
        }
        let l1 = (qc / big).max(0.0);
        let l2 = (big / qa).min(c.length);
        (l1 < l2).then_some((l1, l2))
    }

    /// Integrates `g·ds/τ`-shaped integrands over the clipped range. Offsets are taken from the
    /// range's middle `q(s_m)`: `p − q(s) = w − σ·v` with `w = p − q(s_m)`, `σ = s − s_m`, so a
    /// node's squared distance is `|w|² + σ(σ − 2w·v)`, two operations and no cancellation
    /// beyond the support's size. `g` receives the squared homothetic distance, `σ`, `1/τ(s)`
    /// and the measure `ds/τ(s)` of the node; the result is `w`, or `None` where `p` is outside
    /// the support.
    #[inline]
    fn integrate(
        &self,
        p: DVec3,
        k: &KernelProfile,
        mut g: impl FnMut(f64, f64, f64, f64),
    ) -> Option<DVec3> {
        let (l1, l2) = self.clipped_range(p, k)?;
        let c = &self.cone;
        let tau1 = c.radius + c.slope * l1;
        let tau2 = c.radius + c.slope * l2;
        let middle = 0.5 * (l1 + l2);
        let w = p - (c.start + middle * c.axis);
        let (w_sq, twice_along) = (w.length_squared(), 2.0 * w.dot(c.axis));
        let plan = QuadraturePlan::new(k, c.slope, tau1, tau2, l2 - l1);
        let rule = plan.rule;
        let mut node = |sigma: f64, inv_tau: f64, measure: f64| {
            let x = (w_sq + sigma * (sigma - twice_along)) * inv_tau * inv_tau;
            g(x, sigma, inv_tau, measure);
        };
        if plan.arc_length {
            let h = (l2 - l1) / plan.panels as f64;
            let tau_middle = c.radius + c.slope * middle;
            for panel in 0..plan.panels {
                let centre = (panel as f64 + 0.5) * h - 0.5 * (l2 - l1);
                for (xi, wi) in rule.nodes.iter().zip(&rule.weights) {
                    let sigma = centre + 0.5 * h * xi;
                    let inv_tau = 1.0 / (tau_middle + c.slope * sigma);
                    node(sigma, inv_tau, 0.5 * h * wi * inv_tau);
                }
            }
        } else {
            // u = ln τ: σ = (τ − τ(s_m))/δ, ds/τ = du/δ. The rule's nodes come in pairs ±ξ
            // about a panel's middle, so `τ = τ_p·e^{±hξ/2}` takes one exponential per pair.
            let inv_slope = 1.0 / c.slope;
            let tau_middle = c.radius + c.slope * middle;
            let h = (tau2 / tau1).ln() / plan.panels as f64;
            let n = rule.nodes.len();
            for panel in 0..plan.panels {
                let tau_panel = tau1 * ((panel as f64 + 0.5) * h).exp();
                let inv_tau_panel = 1.0 / tau_panel;
                for i in n / 2..n {
                    let (xi, wi) = (rule.nodes[i], rule.weights[i]);
                    let measure = 0.5 * h * wi * inv_slope;
                    let grow = (0.5 * h * xi).exp();
                    let shrink = 1.0 / grow;
                    let tau = tau_panel * grow;
                    node(
                        (tau - tau_middle) * inv_slope,
                        inv_tau_panel * shrink,
                        measure,
                    );
                    // The middle node of an odd rule has no partner.
                    if n - 1 - i != i {
                        let tau = tau_panel * shrink;
                        node(
                            (tau - tau_middle) * inv_slope,
                            inv_tau_panel * grow,
                            measure,
                        );
                    }
                }
            }
        }
        Some(w)
    }

    /// Value at `p`.
    #[must_use]
    pub fn value(&self, p: DVec3, k: &KernelProfile) -> f64 {
        k.with_family(ValueAt {
            segment: self,
            p,
            profile: k,
        })
    }

    /// Value and gradient at `p`: `∇f = N∫ K′(x)·2(p − q)/τ² · ds/τ`.
    #[must_use]
    pub fn value_gradient(&self, p: DVec3, k: &KernelProfile) -> (f64, DVec3) {
        k.with_family(ValueGradientAt {
            segment: self,
            p,
            profile: k,
        })
    }

    /// The support sphere-cone.
    #[must_use]
    pub fn support(&self, k: &KernelProfile) -> SphereCone {
        self.cone.scaled(k.support_radius())
    }

    /// Bounding box of the support.
    #[must_use]
    pub fn support_aabb(&self, k: &KernelProfile) -> Aabb {
        self.support(k).aabb()
    }

    /// Interval of the ray inside the support.
    #[must_use]
    pub fn support_interval(&self, ray: &Ray, k: &KernelProfile) -> Option<Interval> {
        self.support(k).ray_interval(ray)
    }

    /// Whether the ray's line passes outside the support by [`RELATIVE_SUPPORT_MARGIN`] of its
    /// local radius plus [`rounding_margin`]: every quadrature node at every point `ray.at(t)`, `|t| ≤ t_max`,
    /// is then outside the kernel's support, so the value is exactly 0 (`±0`, which leaves any
    /// sum unchanged) and the gradient a zero vector.
    #[must_use]
    pub fn line_misses_support(&self, ray: &Ray, k: &KernelProfile, t_max: f64) -> bool {
        let reach = t_max * ray.direction.abs().element_sum();
        self.support_grown_for_reach(ray.origin, k, reach)
            .is_some_and(|grown| grown.ray_interval(ray).is_none())
    }

    /// The support grown by the margin of [`Self::line_misses_support`] for lines through
    /// `origin` that reach `reach` from it (`t_max·|u|₁`), or `None` where the grown cone is no
    /// longer a sphere-cone (slope 1 or more: the test then never leaves the segment out).
    #[must_use]
    pub fn support_grown_for_reach(
        &self,
        origin: DVec3,
        k: &KernelProfile,
        reach: f64,
    ) -> Option<SphereCone> {
        let c = &self.cone;
        let absolute =
            rounding_margin(origin, c.start, reach).max(rounding_margin(origin, c.end(), reach));
        self.support(k).grown_by(RELATIVE_SUPPORT_MARGIN, absolute)
    }

    /// Enclosures of `f`, `f′`, `f″` over `span`.
    #[must_use]
    pub fn ray_jet(&self, ray: &Ray, span: Interval, k: &KernelProfile) -> Jet {
        k.with_family(RayJetOver {
            segment: self,
            ray,
            span,
            support: (k.support_sq(), k.support_radius()),
        })
    }

    /// [`Self::ray_jet`] with the kernel's family fixed.
    #[inline(always)]
    fn ray_jet_with<K: FixedKernel>(
        &self,
        (ray, span): (&Ray, Interval),
        (support_sq, support_radius): (f64, f64),
        kernel: &K,
    ) -> Jet {
        let c = &self.cone;
        let u = ray.direction;
        let (ray_a, ray_b) = (ray.at(span.lo), ray.at(span.hi));
        let pieces = self.bound_pieces();
        let ds = c.length / pieces as f64;
        let reached = self.pieces_within_reach((ray_a, ray_b), pieces, ds, support_radius);
        debug_assert!(ds > 0.0, "segments are longer than 1e-9");
        let w_origin = u.dot(ray.origin - c.start);
        let uv = u.dot(c.axis);
        let chord = ChordToAxis::new(ray_a, ray_b, c.start, c.axis);
        // What one boundary between pieces gives both pieces meeting there: computed once and
        // carried to the next piece, by the same expressions as when each piece computed its
        // own (the bound is unchanged bit for bit: the powers of `1/τ` are the products
        // `Interval::square` and `times_positive` take of positive ends).
        let boundary = |i: usize| {
            let s = i as f64 * ds;
            let tau = c.radius + c.slope * s;
            let q = c.start + s * c.axis;
            let inv_tau = 1.0 / tau;
            let inv_tau2 = inv_tau * inv_tau;
            PieceEnd {
                tau,
                inv_tau,
                inv_tau2,
                inv_tau3: inv_tau2 * inv_tau,
                to_a: (ray_a - q).length_squared(),
                to_b: (ray_b - q).length_squared(),
            }
        };
        let mut carried: Option<(usize, PieceEnd)> = None;
        let mut jet = Jet::ZERO;
        for piece in reached {
            let (sa, sb) = (piece as f64 * ds, (piece + 1) as f64 * ds);
            let tau_b = c.radius + c.slope * sb;
            let x_lo = chord.distance_sq_to_piece(sa, sb) / (tau_b * tau_b);
            if x_lo >= support_sq {
                continue;
            }
            let start = match carried {
                Some((at, end)) if at == piece => end,
                _ => boundary(piece),
            };
            let end = boundary(piece + 1);
            carried = Some((piece + 1, end));
            let tau_a = start.tau;
            // The largest squared distance between the chord and the piece is at one of the four
            // pairs of their end points (a convex function on a product of segments).
            let d_max = larger(larger(start.to_a, end.to_a), larger(start.to_b, end.to_b));
            let x = Interval::new(x_lo, d_max / (tau_a * tau_a));
            // `w` is increasing in `t` and monotone in `s` with the sign of `−uv`: its range is
            // at two corners, the same values the hull of all four rounds to.
            let w = |t: f64, s: f64| w_origin + t - s * uv;
            let (s_low, s_high) = if uv >= 0.0 { (sb, sa) } else { (sa, sb) };
            let w = Interval {
                lo: w(span.lo, s_low),
                hi: w(span.hi, s_high),
            };
            // The radius grows along the cone (`slope ≥ 0`): `τ_a ≤ τ_b`.
            let inv_tau = Interval {
                lo: end.inv_tau,
                hi: start.inv_tau,
            };
            let inv_tau2 = Interval {
                lo: end.inv_tau2,
                hi: start.inv_tau2,
            };
            let inv_tau3 = Interval {
                lo: end.inv_tau3,
                hi: start.inv_tau3,
            };
            let (kv, k1, k2, kink) = kernel.ranges(x);
            let signs = KnownSigns { kv, k1, k2 };
            let mut d2 = nonneg_times_positive(
                nonneg_times_positive(signs.k2_times_square(w.square()), inv_tau3),
                inv_tau2,
            )
            .scale(4.0)
                + signs.k1_times_positive(inv_tau3).scale(2.0);
            if kink {
                d2.hi = f64::INFINITY;
            }
            let piece = Jet {
                value: nonneg_times_positive(signs.kv, inv_tau),
                d1: signs.k1_times(w).times_positive(inv_tau3).scale(2.0),
                d2,
            };
            jet = jet
                + Jet {
                    value: scale_positive(piece.value, ds),
                    d1: scale_positive(piece.d1, ds),
                    d2: scale_positive(piece.d2, ds),
                };
        }
        // Sums of the pieces' scaled ends, never `−0`; the normalisation is positive.
        Jet {
            value: scale_positive(jet.value, self.norm),
            d1: scale_positive(jet.d1, self.norm),
            d2: scale_positive(jet.d2, self.norm),
        }
    }

    /// How many equal pieces [`Self::ray_jet`] cuts the segment into: about two per radius at
    /// the thin end, 2 to [`MAX_BOUND_PIECES`] (`⌈2L/r⌉` by an integer cast: `f64::ceil` is a
    /// library call on the baseline x86-64).
    #[inline]
    fn bound_pieces(&self) -> usize {
        let per_radius = 2.0 * self.cone.length / self.cone.radius;
        let whole = per_radius as usize;
        let pieces = if (whole as f64) < per_radius {
            whole + 1
        } else {
            whole
        };
        pieces.clamp(2, MAX_BOUND_PIECES)
    }

    /// The pieces `[i·ds, (i + 1)·ds]` of [`Self::ray_jet`] that the chord `[a, b]` may reach:
    /// the others are farther from it than `R·τ` at their far end (`R` the support radius), so
    /// their homothetic distance is past the support and the loop would skip them. Projection
    /// on the axis is 1-Lipschitz, so a piece whose axis range is `gap` away from the chord's
    /// projection is at least `gap` from the chord. The margins (10⁻⁹ relative to the scene's
    /// coordinates) keep every piece whose test could go either way by rounding, so the pieces
    /// kept are a superset of those the loop uses and the jet is unchanged bit for bit.
    #[inline(always)]
    fn pieces_within_reach(
        &self,
        (a, b): (DVec3, DVec3),
        pieces: usize,
        ds: f64,
        support_radius: f64,
    ) -> std::ops::Range<usize> {
        let c = &self.cone;
        let (pa, pb) = ((a - c.start).dot(c.axis), (b - c.start).dot(c.axis));
        let (low, high) = (pa.min(pb), pa.max(pb));
        let scale = c.start.abs().max_element() + a.abs().max_element() + b.abs().max_element();
        let margin = 1e-9 * (scale + c.length + c.radius + c.slope * c.length);
        let widest = support_radius * (c.radius + c.slope * c.length) * (1.0 + 1e-9) + margin;
        // Pieces ending before `low − R·τ_max` are out of reach. (Truncating casts, not
        // `floor` and `ceil`, which are library calls on the baseline x86-64; each bound
        // keeps a piece more than it needs.)
        let first = (low - widest) / ds - 1.0;
        // A piece starting at `s = i·ds` past `high` is out of reach once
        // `s − high ≥ R·(r + δ·(s + ds))`, that is `s·(1 − Rδ) ≥ high + R·(r + δ·ds)`.
        let shrink = 1.0 - support_radius * c.slope * (1.0 + 1e-9);
        let last = if shrink > 1e-6 {
            let reach = high + support_radius * (c.radius + c.slope * ds);
            let reach = reach + 1e-9 * reach.abs() + margin;
            reach / (ds * shrink) + 2.0
        } else {
            f64::INFINITY
        };
        // Float-to-integer casts saturate (NaN gives 0): a NaN bound keeps every piece.
        let first = if first.is_nan() {
            0
        } else {
            first.max(0.0) as usize
        };
        let last = if last.is_nan() {
            pieces
        } else {
            (last.max(0.0) as usize).min(pieces)
        };
        first.min(last)..last
    }
}

/// The kernel's ranges over a piece of [`ScalisSegment::ray_jet`], whose signs are known:
/// `K ≥ 0`, `K′ ≤ 0`, `K″ ≥ 0` on the support (`ranges_over`'s contract), all finite. Their
/// products with the piece's other factors (`w` of either sign, powers of `1/τ`, positive)
/// take the end products the general interval products would select, without testing the
/// signs again: the same numbers, bit for bit (rounding is monotone). The general products
/// give `+0` for a zero factor; products that may meet a zero of either sign here (those of
/// `K′`, whose upper end is `−0` at the support's boundary, and `w`) do the same
/// ([`mul_finite`]); the others multiply non-negative factors that are never `−0`, whose
/// plain products are already `+0` there. The test `scalis_piece_products_are_the_general_ones`
/// compares them with the general products.
#[derive(Clone, Copy)]
struct KnownSigns {
    kv: Interval,
    k1: Interval,
    k2: Interval,
}

impl KnownSigns {
    /// `K″ · w²`, both non-negative.
    #[inline(always)]
    fn k2_times_square(self, w2: Interval) -> Interval {
        debug_assert!(self.k2.lo >= 0.0 && w2.lo >= 0.0, "{:?} {w2:?}", self.k2);
        Interval {
            lo: self.k2.lo * w2.lo,
            hi: self.k2.hi * w2.hi,
        }
    }

    /// `K′ · o` for `o > 0`: `K′ ≤ 0`, so its low end meets `o`'s high end.
    #[inline(always)]
    fn k1_times_positive(self, o: Interval) -> Interval {
        debug_assert!(self.k1.hi <= 0.0 && o.lo > 0.0, "{:?} {o:?}", self.k1);
        Interval {
            lo: mul_finite(self.k1.lo, o.hi),
            hi: mul_finite(self.k1.hi, o.lo),
        }
    }

    /// `K′ · w`, `w` of either sign: with `K′ ∈ [a, b]`, `b ≤ 0`, the smallest product is `a·w.hi`
    /// where `w.hi ≥ 0` (else `b·w.hi`), the largest `a·w.lo` where `w.lo ≤ 0` (else `b·w.lo`).
    #[inline(always)]
    fn k1_times(self, w: Interval) -> Interval {
        debug_assert!(self.k1.hi <= 0.0, "{:?}", self.k1);
        let (a, b) = (self.k1.lo, self.k1.hi);
        Interval {
            lo: mul_finite(if w.hi >= 0.0 { a } else { b }, w.hi),
            hi: mul_finite(if w.lo <= 0.0 { a } else { b }, w.lo),
        }
    }
}

/// `v · o` for `v ≥ 0`, never `−0`, and `o > 0` (`Interval::times_positive`'s non-negative
/// case).
#[inline(always)]
fn nonneg_times_positive(v: Interval, o: Interval) -> Interval {
    debug_assert!(
        v.lo >= 0.0 && no_negative_zero(v) && o.lo > 0.0,
        "{v:?} {o:?}"
    );
    Interval {
        lo: v.lo * o.lo,
        hi: v.hi * o.hi,
    }
}

/// `Interval::scale` by a positive factor, of an interval whose ends are never `−0` (the
/// general products' zeros are `+0`).
#[inline(always)]
fn scale_positive(v: Interval, k: f64) -> Interval {
    debug_assert!(k > 0.0 && no_negative_zero(v), "{v:?}");
    Interval {
        lo: v.lo * k,
        hi: v.hi * k,
    }
}

/// Whether neither end of `v` is `−0`.
fn no_negative_zero(v: Interval) -> bool {
    [v.lo, v.hi]
        .iter()
        .all(|e| *e != 0.0 || e.is_sign_positive())
}

/// The interval products' end product `a·b` (a zero factor gives `+0`) for finite factors
/// whose product does not underflow: one test of the product instead of one per factor.
/// An infinite factor (a kinked `K″` bound) times a positive one stays infinite, as there.
#[inline(always)]
fn mul_finite(a: f64, b: f64) -> f64 {
    let product = a * b;
    if product == 0.0 { 0.0 } else { product }
}

/// `a.max(b)` for numbers that are not NaN (squared distances), without NaN's tests.
#[inline(always)]
fn larger(a: f64, b: f64) -> f64 {
    if a > b { a } else { b }
}

/// [`ScalisSegment::ray_jet`], run with the kernel's family fixed.
struct RayJetOver<'a> {
    segment: &'a ScalisSegment,
    ray: &'a Ray,
    span: Interval,
    /// The kernel's squared support radius and the radius.
    support: (f64, f64),
}

impl KernelLoop for RayJetOver<'_> {
    type Output = Jet;
    fn run<K: FixedKernel>(self, kernel: &K) -> Jet {
        self.segment
            .ray_jet_with((self.ray, self.span), self.support, kernel)
    }
}

/// [`ScalisSegment::value`]'s quadrature, run with the kernel's family fixed.
struct ValueAt<'a> {
    segment: &'a ScalisSegment,
    p: DVec3,
    profile: &'a KernelProfile,
}

impl KernelLoop for ValueAt<'_> {
    type Output = f64;
    fn run<K: FixedKernel>(self, kernel: &K) -> f64 {
        let mut sum = 0.0;
        self.segment
            .integrate(self.p, self.profile, |x, _, _, measure| {
                sum += kernel.value(x) * measure;
            });
        self.segment.norm * sum
    }
}

/// [`ScalisSegment::value_gradient`]'s quadrature, run with the kernel's family fixed.
struct ValueGradientAt<'a> {
    segment: &'a ScalisSegment,
    p: DVec3,
    profile: &'a KernelProfile,
}

impl KernelLoop for ValueGradientAt<'_> {
    type Output = (f64, DVec3);
    fn run<K: FixedKernel>(self, kernel: &K) -> (f64, DVec3) {
        // `∇f = N∫ 2K′(x)/τ²·(w − σv)·ds/τ`: two scalar sums, `Σc` and `Σcσ`.
        let (mut sum, mut slope, mut slope_along) = (0.0, 0.0, 0.0);
        let w = self
            .segment
            .integrate(self.p, self.profile, |x, sigma, inv_tau, measure| {
                let (v, d1) = kernel.value_d1(x);
                sum += v * measure;
                let c = 2.0 * d1 * measure * inv_tau * inv_tau;
                slope += c;
                slope_along += c * sigma;
            });
        let Some(w) = w else {
            return (0.0, DVec3::ZERO);
        };
        let norm = self.segment.norm;
        (
            norm * sum,
            norm * (slope * w - slope_along * self.segment.cone.axis),
        )
    }
}

/// How one clipped SCALIS integral is evaluated: which Gauss–Legendre rule, in how many equal
/// panels, and in arc length or in `u = ln τ` (MATH.md §3).
///
/// The integrands are analytic, so Gauss–Legendre converges geometrically, at a rate set by the
/// radius ratio `V = τ(l₂)/τ(l₁)` over the clipped range and, for compact kernels `(1 − x/σ²)^m`,
/// by the power `m`. [`COMPACT_NODES`] gives, per `m`, the fewest nodes that keep the
/// normalised field within 10⁻¹³ of converged (measured over random segments and points,
/// plus one node of margin; `field_accuracy.rs` checks it against adaptive quadrature),
/// so a nearly constant radius costs the degree-6 kernel 6–8 nodes instead of 12. Past the table's last ratio the
/// range is split into panels of at most that ratio. Constant radii use the rule exact for the
/// degree-`2m` polynomial integrand (`m + 1` nodes). Other kernels (Cauchy, Gaussian, compact
/// powers past the table) use the 12-point rule, in panels about two local radii long for the
/// clipped infinite-support kernels.
struct QuadraturePlan {
    rule: &'static GaussLegendre,
    panels: usize,
    arc_length: bool,
}

/// Up to which radius ratio a rule of `nodes` points is used, and whether in arc length.
struct NodeStep {
    ratio: f64,
    nodes: usize,
    arc_length: bool,
}

const fn step(ratio: f64, nodes: usize, arc_length: bool) -> NodeStep {
    NodeStep {
        ratio,
        nodes,
        arc_length,
    }
}

/// Node counts of compact kernels of power `m = 1..=4` (index `m − 1`), by increasing radius
/// ratio: in arc length as long as 12 nodes suffice there (a node costs about half of one in
/// `ln τ`, which needs an exponential), then in `ln τ`, which converges faster. Printed by
/// `scripts/scalis-nodes` (σ = 2, 30 000 random segments and points per power).
const COMPACT_NODES: [&[NodeStep]; 4] = [
    &[
        step(1.001, 4, true),
        step(1.015, 5, true),
        step(1.057, 6, true),
        step(1.14, 7, true),
        step(1.22, 8, true),
        step(1.346, 9, true),
        step(1.543, 10, true),
        step(1.681, 11, true),
        step(1.855, 12, true),
        step(3.113, 8, false),
        step(6.225, 9, false),
        step(17.2, 10, false),
        step(26.48, 11, false),
    ],
    &[
        step(1.001, 5, true),
        step(1.012, 6, true),
        step(1.045, 7, true),
        step(1.111, 8, true),
        step(1.175, 9, true),
        step(1.276, 10, true),
        step(1.433, 11, true),
        step(1.543, 12, true),
        step(2.072, 9, false),
        step(3.113, 10, false),
        step(5.167, 11, false),
        step(9.217, 12, false),
    ],
    &[
        step(1.001, 6, true),
        step(1.012, 7, true),
        step(1.045, 8, true),
        step(1.089, 9, true),
        step(1.175, 10, true),
        step(1.276, 11, true),
        step(1.346, 12, true),
        step(1.681, 10, false),
        step(2.344, 11, false),
        step(3.113, 12, false),
    ],
    &[
        step(1.001, 7, true),
        step(1.012, 8, true),
        step(1.036, 9, true),
        step(1.089, 10, true),
        step(1.14, 11, true),
        step(1.22, 12, true),
        step(1.276, 10, false),
        step(1.543, 11, false),
        step(2.072, 12, false),
    ],
];

impl QuadraturePlan {
    /// The plan for the clipped range `[l₁, l₂]` of a segment of radius slope `δ`, with
    /// `τ₁ = τ(l₁)`, `τ₂ = τ(l₂)`.
    #[inline]
    fn new(k: &KernelProfile, slope: f64, tau1: f64, tau2: f64, range: f64) -> Self {
        let ratio = tau2 / tau1;
        let compact = k
            .compact_power()
            .map(|(m, _)| usize::try_from(m).unwrap_or(0));
        match compact {
            Some(m) if slope == 0.0 => Self {
                rule: GaussLegendre::exact_for_degree(2 * m),
                panels: 1,
                arc_length: true,
            },
            Some(m @ 1..=4) => {
                let steps = COMPACT_NODES[m - 1];
                if let Some(fit) = steps.iter().find(|s| ratio <= s.ratio) {
                    return Self {
                        rule: GaussLegendre::with_nodes(fit.nodes),
                        panels: 1,
                        arc_length: fit.arc_length,
                    };
                }
                let last = &steps[steps.len() - 1];
                Self {
                    rule: GaussLegendre::with_nodes(last.nodes),
                    panels: ((ratio.ln() / last.ratio.ln()).ceil() as usize).max(1),
                    arc_length: false,
                }
            }
            _ => {
                let panels = if k.is_clipped() {
                    // Wide, non-polynomial kernels: panels about two local radii long.
                    ((range / (2.0 * tau1)).ceil() as usize).clamp(1, 16)
                } else {
                    1
                };
                Self {
                    rule: GaussLegendre::scalis(),
                    panels,
                    arc_length: ratio <= ARC_LENGTH_RATIO,
                }
            }
        }
    }
}

/// Radius ratio up to which the 12-point rule integrates in arc length: MATH.md §3's `δ·ℓ < 0.05`
/// at a unit radius, made scale-invariant.
const ARC_LENGTH_RATIO: f64 = 1.05;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::kernel::EVERY_FAMILY;
    use crate::model::kernel::Kernel;
    use crate::model::rng::SplitMix64;

    /// [`ScalisSegment::pieces_within_reach`] leaves out only pieces that [`ScalisSegment::ray_jet`]'s
    /// loop skips (its own test, the same expressions), on random cones and chords, near and
    /// far, short and long, with kernels whose support radius times the cone's slope is below
    /// and above 1; and it does leave pieces out.
    #[test]
    fn pieces_out_of_reach_are_pieces_the_bound_skips() {
        let mut rng = SplitMix64::new(18);
        let kernels = [
            Kernel::CompactPolynomial {
                degree: 6,
                scale: 2.0,
            },
            Kernel::Cauchy {
                degree: 4,
                scale: 1.0,
            },
        ];
        let mut left_out = 0;
        for case in 0..20_000 {
            let k = KernelProfile::new(kernels[case % 2]);
            let unit = |rng: &mut SplitMix64| {
                DVec3::new(
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                )
                .normalize()
            };
            let cone = SphereCone {
                start: DVec3::new(
                    rng.range(-3.0, 3.0),
                    rng.range(-3.0, 3.0),
                    rng.range(-3.0, 3.0),
                ),
                axis: unit(&mut rng),
                length: rng.range(0.05, 3.0),
                radius: rng.range(0.02, 0.5),
                slope: rng.range(0.0, 0.6),
            };
            let segment = ScalisSegment { cone, norm: 1.0 };
            let ray = Ray::new(
                cone.start + unit(&mut rng) * rng.range(0.0, 4.0),
                unit(&mut rng),
            );
            let lo = rng.range(-3.0, 3.0);
            let span = Interval::new(lo, lo + rng.range(0.0, 2.0).powi(3));
            let (a, b) = (ray.at(span.lo), ray.at(span.hi));
            let pieces = segment.bound_pieces();
            assert_eq!(
                pieces,
                ((2.0 * cone.length / cone.radius).ceil() as usize).clamp(2, MAX_BOUND_PIECES)
            );
            let ds = cone.length / pieces as f64;
            let reached = segment.pieces_within_reach((a, b), pieces, ds, k.support_radius());
            let chord = ChordToAxis::new(a, b, cone.start, cone.axis);
            for piece in (0..pieces).filter(|i| !reached.contains(i)) {
                left_out += 1;
                let (sa, sb) = (piece as f64 * ds, (piece + 1) as f64 * ds);
                let tau_b = cone.radius + cone.slope * sb;
                let x_lo = chord.distance_sq_to_piece(sa, sb) / (tau_b * tau_b);
                assert!(
                    x_lo >= k.support_sq(),
                    "case {case}: piece {piece} of {pieces} ({reached:?}) is in reach: {x_lo}"
                );
            }
        }
        assert!(left_out > 10_000, "{left_out}");
    }

    /// [`KnownSigns`]' products and [`scale_positive`] are the general interval products of
    /// [`ScalisSegment::ray_jet`] before them, bit for bit: on every kernel's ranges over random
    /// intervals across the support and its boundary, `w` of either sign and with zero ends,
    /// powers of `1/τ` from random radii, and infinite (kinked) `K″` bounds scaled by a piece.
    #[test]
    fn scalis_piece_products_are_the_general_ones() {
        let mut rng = SplitMix64::new(2218);
        let bits = |v: Interval| (v.lo.to_bits(), v.hi.to_bits());
        for case in 0..60_000 {
            let k = KernelProfile::new(EVERY_FAMILY[case % EVERY_FAMILY.len()]);
            let s2 = k.support_sq();
            let x0 = rng.range(-0.1, 1.1) * s2;
            let x = Interval::new(x0, x0 + rng.range(0.0, 0.5).powi(2) * s2);
            let (kv, k1, k2, _) = k.ranges(x);
            let w = match case % 4 {
                0 => Interval::new(0.0, rng.range(0.0, 3.0)),
                1 => Interval::new(-rng.range(0.0, 3.0), 0.0),
                _ => Interval::new(rng.range(-3.0, 3.0), rng.range(-3.0, 3.0)),
            };
            let (tau_a, tau_b) = (rng.range(0.01, 2.0), rng.range(0.0, 0.5));
            let power = |tau: f64, n: i32| (1.0 / tau).powi(n);
            let inv = |n| Interval {
                lo: power(tau_a + tau_b, n),
                hi: power(tau_a, n),
            };
            let (inv_tau, inv_tau2, inv_tau3) = (inv(1), inv(2), inv(3));
            let signs = KnownSigns { kv, k1, k2 };
            let general_d2 = (k2 * w.square())
                .times_positive(inv_tau3)
                .times_positive(inv_tau2)
                .scale(4.0)
                + k1.times_positive(inv_tau3).scale(2.0);
            let known_d2 = nonneg_times_positive(
                nonneg_times_positive(signs.k2_times_square(w.square()), inv_tau3),
                inv_tau2,
            )
            .scale(4.0)
                + signs.k1_times_positive(inv_tau3).scale(2.0);
            assert_eq!(bits(known_d2), bits(general_d2), "case {case}: {x:?} {w:?}");
            assert_eq!(
                bits(nonneg_times_positive(kv, inv_tau)),
                bits(kv.times_positive(inv_tau)),
                "case {case}"
            );
            assert_eq!(
                bits(signs.k1_times(w)),
                bits(k1 * w),
                "case {case}: {k1:?} {w:?}"
            );
            let ds = rng.range(1e-3, 1.0);
            let kinked = Interval {
                lo: general_d2.lo,
                hi: f64::INFINITY,
            };
            for v in [general_d2, kinked, kv, k1 * w] {
                assert_eq!(
                    bits(scale_positive(v, ds)),
                    bits(v.scale(ds)),
                    "case {case}"
                );
            }
        }
    }
}
