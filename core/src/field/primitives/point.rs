//! Point blobs: `f(p) = N₀·K(|p − c|²/ρ²)` (scalis eq. 1–2, forward-inclusion eq. 6–7,
//! MATH.md §2). Along a ray the squared distance is a quadratic, so the extrema of `f′` and `f″`
//! on an interval are found exactly among its end points and the kernel's critical points
//! (forward-inclusion appendix A; MATH.md §5).

use glam::DVec3;

use crate::bounds::interval::{Interval, Jet};
use crate::field::geometry::{Aabb, RELATIVE_SUPPORT_MARGIN, Ray, ball_interval, rounding_margin};
use crate::field::kernel::KernelProfile;

/// A point primitive with its normalisation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointBlob {
    /// Centre `c`.
    pub center: DVec3,
    /// Prescribed radius `ρ`: the surface of an isolated blob.
    pub radius: f64,
    /// Normalisation `N₀ = c / K(1)`.
    pub norm: f64,
}

impl PointBlob {
    /// Value and gradient at `p`.
    #[must_use]
    pub fn value_gradient(&self, p: DVec3, k: &KernelProfile) -> (f64, DVec3) {
        let inv_r2 = 1.0 / (self.radius * self.radius);
        let d = p - self.center;
        let (v, d1) = k.value_d1(d.length_squared() * inv_r2);
        (self.norm * v, (2.0 * self.norm * d1 * inv_r2) * d)
    }

    /// Value at `p`.
    #[must_use]
    #[inline]
    pub fn value(&self, p: DVec3, k: &KernelProfile) -> f64 {
        // The arithmetic of `value_gradient`'s value, bit for bit.
        let inv_r2 = 1.0 / (self.radius * self.radius);
        self.norm * k.value((p - self.center).length_squared() * inv_r2)
    }

    /// Bounding box of the support.
    #[must_use]
    pub fn support_aabb(&self, k: &KernelProfile) -> Aabb {
        Aabb::ball(self.center, self.radius * k.support_radius())
    }

    /// Interval of the ray inside the support ball.
    #[must_use]
    pub fn support_interval(&self, ray: &Ray, k: &KernelProfile) -> Option<Interval> {
        ball_interval(ray, self.center, self.radius * k.support_radius())
    }

    /// Whether the ray's line passes outside the support ball by [`RELATIVE_SUPPORT_MARGIN`]
    /// of its radius plus [`rounding_margin`]: the value at every point `ray.at(t)`, `|t| ≤ t_max`, is then exactly
    /// 0 (`±0`, which leaves any sum unchanged) and the gradient a zero vector.
    #[must_use]
    pub fn line_misses_support(&self, ray: &Ray, k: &KernelProfile, t_max: f64) -> bool {
        let support = self.radius * k.support_radius();
        let reach = t_max * ray.direction.abs().element_sum();
        let margin =
            RELATIVE_SUPPORT_MARGIN * support + rounding_margin(ray.origin, self.center, reach);
        let to_center = self.center - ray.origin;
        let across =
            to_center.cross(ray.direction).length_squared() / ray.direction.length_squared();
        across > (support + margin) * (support + margin)
    }

    /// Exact enclosures of `f`, `f′`, `f″` over `span`, which must lie in the support interval.
    #[must_use]
    pub fn ray_jet(&self, ray: &Ray, span: Interval, k: &KernelProfile) -> Jet {
        let rho = self.radius;
        let t_closest = (self.center - ray.origin).dot(ray.direction);
        let h2 = (ray.at(t_closest) - self.center).length_squared() / (rho * rho);
        // Normalised offset from the closest point: x = τ² + ĥ².
        let (a, b) = ((span.lo - t_closest) / rho, (span.hi - t_closest) / rho);
        let x_of = |tau: f64| (tau * tau + h2).min(k.support_sq());
        // `f′` and `f″` at `τ` from the kernel's `K′` and `K″` there.
        let d1_of = |tau: f64, k1: f64| self.norm * k1 * 2.0 * tau / rho;
        let d2_of = |tau: f64, k1: f64, k2: f64| {
            self.norm * (k2 * 4.0 * tau * tau + 2.0 * k1) / (rho * rho)
        };
        let d1_at = |tau: f64| {
            let (_, k1, _) = k.value_d2_inside(x_of(tau));
            d1_of(tau, k1)
        };
        let d2_at = |tau: f64| {
            let (_, k1, k2) = k.value_d2_inside(x_of(tau));
            d2_of(tau, k1, k2)
        };
        let nearest = 0.0_f64.clamp(a, b);
        let farthest = if a.abs() > b.abs() { a } else { b };
        let value = Interval::new(
            self.norm * k.value(x_of(farthest)),
            self.norm * k.value(x_of(nearest)),
        );
        let (c1, c2) = k.point_critical_tau2(h2);
        // The kernel once per end point, for both derivatives.
        let ((_, k1_a, k2_a), (_, k1_b, k2_b)) =
            (k.value_d2_inside(x_of(a)), k.value_d2_inside(x_of(b)));
        let mut d1 = Interval::new(d1_of(a, k1_a), d1_of(b, k1_b));
        let mut d2 = Interval::new(d2_of(a, k1_a, k2_a), d2_of(b, k1_b, k2_b));
        for tau in [c1.sqrt(), -c1.sqrt()] {
            if (a..=b).contains(&tau) {
                d1 = d1.include(d1_at(tau));
            }
        }
        for tau in [0.0, c2.sqrt(), -c2.sqrt()] {
            if (a..=b).contains(&tau) {
                d2 = d2.include(d2_at(tau));
            }
        }
        Jet { value, d1, d2 }
    }

    /// Galin et al. 2020's bound on `|f′|` over `span` (inside the support), as the 2023 paper's
    /// appendix A describes it: the largest kernel slope over the span's distance range times
    /// the largest `|cos|` between the ray and the direction from the centre, each bounded on
    /// its own. `|cos| = |τ|/√(τ² + ĥ²)` grows with the distance `|τ|` from the closest point,
    /// so it peaks at the span's end farther from it. Never below the exact bound of
    /// [`Self::ray_jet`], which bounds the product itself.
    #[must_use]
    pub fn kernel_slope_times_cosine(&self, ray: &Ray, span: Interval, k: &KernelProfile) -> f64 {
        let rho = self.radius;
        let t_closest = (self.center - ray.origin).dot(ray.direction);
        let h2 = (ray.at(t_closest) - self.center).length_squared() / (rho * rho);
        let (a, b) = ((span.lo - t_closest) / rho, (span.hi - t_closest) / rho);
        let nearest = 0.0_f64.clamp(a, b);
        let farthest = a.abs().max(b.abs());
        let distances = Interval::new(nearest * nearest + h2, farthest * farthest + h2);
        let cosine = if farthest > 0.0 {
            farthest / (farthest * farthest + h2).sqrt()
        } else {
            0.0
        };
        self.norm * k.max_slope_on(distances) * cosine / rho
    }
}
