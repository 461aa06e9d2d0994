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

/// Below this radius change over the integrated part (`δ·ℓ`), integrate in arc length.
const ARC_LENGTH_THRESHOLD: f64 = 0.05;
/// Pieces per segment in the derivative bounds, at most.
const MAX_BOUND_PIECES: usize = 24;

/// The end of a piece in [`ScalisSegment::ray_jet`]: the radius there, its inverse, and the
/// squared distances from the skeleton point to the two ends of the ray's chord.
#[derive(Clone, Copy)]
struct PieceEnd {
    tau: f64,
    inv_tau: f64,
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

    /// Integrates `g(x, p − q, τ)·ds/τ`-shaped integrands over the clipped range; `g` receives
    /// the squared homothetic distance, the offset `p − q(s)`, `τ(s)` and the measure
    /// `ds/τ(s)` of the node.
    fn integrate(&self, p: DVec3, k: &KernelProfile, mut g: impl FnMut(f64, DVec3, f64, f64)) {
        let Some((l1, l2)) = self.clipped_range(p, k) else {
            return;
        };
        let c = &self.cone;
        // A constant radius and a compact polynomial kernel `(1 − x/σ²)^m` make the integrands
        // polynomials in `s` (of degree 2m for the value, 2m − 1 for the gradient), which
        // `m + 1` nodes integrate exactly (MATH.md §3); otherwise the 12-point rule.
        let rule = match k.compact_power() {
            Some((m, _)) if c.slope == 0.0 => {
                GaussLegendre::exact_for_degree(2 * usize::try_from(m).unwrap_or(0))
            }
            _ => GaussLegendre::scalis(),
        };
        let tau1 = c.radius + c.slope * l1;
        let panels = if k.is_clipped() {
            // Wide, non-polynomial kernels: panels about two local radii long.
            (((l2 - l1) / (2.0 * tau1)).ceil() as usize).clamp(1, 16)
        } else {
            1
        };
        if c.slope * (l2 - l1) < ARC_LENGTH_THRESHOLD {
            let h = (l2 - l1) / panels as f64;
            for panel in 0..panels {
                let mid = l1 + (panel as f64 + 0.5) * h;
                for (xi, wi) in rule.nodes.iter().zip(&rule.weights) {
                    let s = mid + 0.5 * h * xi;
                    let tau = c.radius + c.slope * s;
                    let offset = p - (c.start + s * c.axis);
                    g(
                        offset.length_squared() / (tau * tau),
                        offset,
                        tau,
                        0.5 * h * wi / tau,
                    );
                }
            }
        } else {
            // u = ln τ: ds/τ = du/δ.
            let (u1, u2) = (tau1.ln(), (c.radius + c.slope * l2).ln());
            let h = (u2 - u1) / panels as f64;
            for panel in 0..panels {
                let mid = u1 + (panel as f64 + 0.5) * h;
                for (xi, wi) in rule.nodes.iter().zip(&rule.weights) {
                    let tau = (mid + 0.5 * h * xi).exp();
                    let s = (tau - c.radius) / c.slope;
                    let offset = p - (c.start + s * c.axis);
                    g(
                        offset.length_squared() / (tau * tau),
                        offset,
                        tau,
                        0.5 * h * wi / c.slope,
                    );
                }
            }
        }
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
        let c = &self.cone;
        let reach = t_max * ray.direction.abs().element_sum();
        let absolute = rounding_margin(ray.origin, c.start, reach).max(rounding_margin(
            ray.origin,
            c.end(),
            reach,
        ));
        self.support(k)
            .line_misses_by(ray, RELATIVE_SUPPORT_MARGIN, absolute)
    }

    /// Enclosures of `f`, `f′`, `f″` over `span`.
    #[must_use]
    pub fn ray_jet(&self, ray: &Ray, span: Interval, k: &KernelProfile) -> Jet {
        let c = &self.cone;
        let u = ray.direction;
        let (ray_a, ray_b) = (ray.at(span.lo), ray.at(span.hi));
        let pieces = ((2.0 * c.length / c.radius).ceil() as usize).clamp(2, MAX_BOUND_PIECES);
        let ds = c.length / pieces as f64;
        let w_origin = u.dot(ray.origin - c.start);
        let uv = u.dot(c.axis);
        let chord = ChordToAxis::new(ray_a, ray_b, c.start, c.axis);
        // What one boundary between pieces gives both pieces meeting there: computed once and
        // carried to the next piece, by the same expressions as when each piece computed its
        // own (the bound is unchanged bit for bit).
        let boundary = |i: usize| {
            let s = i as f64 * ds;
            let tau = c.radius + c.slope * s;
            let q = c.start + s * c.axis;
            PieceEnd {
                tau,
                inv_tau: 1.0 / tau,
                to_a: (ray_a - q).length_squared(),
                to_b: (ray_b - q).length_squared(),
            }
        };
        let mut carried: Option<(usize, PieceEnd)> = None;
        let mut jet = Jet::ZERO;
        for piece in 0..pieces {
            let (sa, sb) = (piece as f64 * ds, (piece + 1) as f64 * ds);
            let tau_b = c.radius + c.slope * sb;
            let x_lo = chord.distance_sq_to_piece(sa, sb) / (tau_b * tau_b);
            if x_lo >= k.support_sq() {
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
            let d_max = [start.to_a, end.to_a, start.to_b, end.to_b]
                .into_iter()
                .fold(0.0, f64::max);
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
            let inv_tau2 = inv_tau.square();
            let inv_tau3 = inv_tau2.times_positive(inv_tau);
            let (kv, k1, k2, kink) = k.ranges(x);
            let mut d2 = (k2 * w.square())
                .times_positive(inv_tau3)
                .times_positive(inv_tau2)
                .scale(4.0)
                + k1.times_positive(inv_tau3).scale(2.0);
            if kink {
                d2.hi = f64::INFINITY;
            }
            jet = jet
                + Jet {
                    value: kv.times_positive(inv_tau),
                    d1: (k1 * w).times_positive(inv_tau3).scale(2.0),
                    d2,
                }
                .scale(ds);
        }
        jet.scale(self.norm)
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
        let mut sum = 0.0;
        let mut grad = DVec3::ZERO;
        self.segment
            .integrate(self.p, self.profile, |x, offset, tau, measure| {
                let (v, d1) = kernel.value_d1(x);
                sum += v * measure;
                grad += (2.0 * d1 * measure / (tau * tau)) * offset;
            });
        (self.segment.norm * sum, self.segment.norm * grad)
    }
}
