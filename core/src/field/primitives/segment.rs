//! Segment distance primitives: `f(p) = N₀·K(h²)` with `h` the homothetic distance to a segment
//! of linearly varying radius (scalis 2021 eq. 5–7, MATH.md §3).
//!
//! With the radius growing from `τ₀` at the start by `δ` per unit length, write `a` for the axial
//! coordinate of `p`, `b` for its distance to the axis and `Y = τ₀ + δa`. The squared homothetic
//! distance to a skeleton point is a convex quadratic in `1/τ(s)`, so its minimiser is unique:
//! `s* = a + δb²/Y` clamped to `[0, L]` (`s* = L` when `Y ≤ 0`), and where it is interior the
//! minimum is `h² = b²/(Y² + δ²b²)`. Along a ray, `h²` is therefore one of three closed forms
//! (start cap, cone, end cap); a bound over an interval is the hull of the forms that can be
//! active there, each evaluated with interval jets.

use glam::DVec3;

use crate::bounds::interval::{Interval, Jet};
use crate::field::geometry::{Aabb, Ray, SphereCone};
use crate::field::kernel::KernelProfile;

/// A segment with varying radius whose field is the kernel of the homothetic distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DistanceSegment {
    /// Prescribed sphere-cone (radius growing from `start`).
    pub cone: SphereCone,
    /// Normalisation `N₀ = c / K(1)`.
    pub norm: f64,
}

impl DistanceSegment {
    /// Squared homothetic distance and the closest (homothetic) skeleton point with its radius.
    fn closest(&self, p: DVec3) -> (f64, DVec3, f64) {
        let c = &self.cone;
        let w = p - c.start;
        let a = w.dot(c.axis);
        let b2 = (w.length_squared() - a * a).max(0.0);
        let y = c.radius + c.slope * a;
        let s = if y > 0.0 {
            (a + c.slope * b2 / y).clamp(0.0, c.length)
        } else {
            c.length
        };
        let q = c.start + s * c.axis;
        let tau = c.radius + c.slope * s;
        ((p - q).length_squared() / (tau * tau), q, tau)
    }

    /// Value and gradient at `p` (the envelope theorem gives `∇h² = 2(p − q*)/τ*²`).
    #[must_use]
    pub fn value_gradient(&self, p: DVec3, k: &KernelProfile) -> (f64, DVec3) {
        let (x, q, tau) = self.closest(p);
        let (v, d1) = k.value_d1(x);
        (
            self.norm * v,
            (2.0 * self.norm * d1 / (tau * tau)) * (p - q),
        )
    }

    /// Value at `p`.
    #[must_use]
    pub fn value(&self, p: DVec3, k: &KernelProfile) -> f64 {
        self.norm * k.value(self.closest(p).0)
    }

    /// The support: the prescribed sphere-cone scaled by the kernel's support radius.
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

    /// Enclosures of `f`, `f′`, `f″` over `span` (inside the support interval).
    #[must_use]
    pub fn ray_jet(&self, ray: &Ray, span: Interval, k: &KernelProfile) -> Jet {
        let c = &self.cone;
        let d = c.slope;
        let u = ray.direction;
        let w0 = ray.origin - c.start;
        let (a0, a1) = (w0.dot(c.axis), u.dot(c.axis));
        let a = Jet::affine(a0, a1, span);
        let b2 = Jet::quadratic(
            1.0 - a1 * a1,
            2.0 * (w0.dot(u) - a0 * a1),
            (w0.length_squared() - a0 * a0).max(0.0),
            span,
        );
        let (y0, y1) = (c.radius + d * a0, d * a1);
        let y = Jet::affine(y0, y1, span);
        let s_star = if d > 0.0 { a + (b2 / y).scale(d) } else { a };
        let s_range = s_star.value;
        let y_may_vanish = y.value.lo <= 0.0;

        let cap = |center: DVec3, tau: f64| {
            let wc = ray.origin - center;
            Jet::quadratic(1.0, 2.0 * wc.dot(u), wc.length_squared(), span).scale(1.0 / (tau * tau))
        };
        let mut x: Option<Jet> = None;
        let mut add = |j: Jet| x = Some(x.map_or(j, |h| h.hull(j)));
        if s_range.lo <= 0.0 && !y_may_vanish {
            add(cap(c.start, c.radius));
        }
        if s_range.hi >= c.length || y_may_vanish {
            add(cap(c.end(), c.end_radius()));
        }
        if (s_range.hi > 0.0 && s_range.lo < c.length) || y_may_vanish {
            let denominator = Jet::quadratic(
                y1 * y1 + d * d * (1.0 - a1 * a1),
                2.0 * y0 * y1 + d * d * 2.0 * (w0.dot(u) - a0 * a1),
                y0 * y0 + d * d * (w0.length_squared() - a0 * a0).max(0.0),
                span,
            );
            add(b2 / denominator);
        }
        let x = x.unwrap_or(Jet {
            value: Interval::ENTIRE,
            d1: Interval::ENTIRE,
            d2: Interval::ENTIRE,
        });
        k.compose(Jet {
            value: Interval {
                lo: x.value.lo.max(0.0),
                hi: x.value.hi,
            },
            ..x
        })
        .scale(self.norm)
    }
}
