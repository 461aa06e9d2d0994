//! Point blobs: `f(p) = N₀·K(|p − c|²/ρ²)` (scalis eq. 1–2, forward-inclusion eq. 6–7,
//! MATH.md §2). Along a ray the squared distance is a quadratic, so the extrema of `f′` and `f″`
//! on an interval are found exactly among its end points and the kernel's critical points
//! (forward-inclusion appendix A; MATH.md §5).

use glam::DVec3;

use crate::bounds::interval::{Interval, Jet};
use crate::field::geometry::{Aabb, RELATIVE_SUPPORT_MARGIN, Ray, ball_interval, rounding_margin};
use crate::field::kernel::{FixedKernel, KernelLoop, KernelProfile};

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
        k.with_family(ValueGradientAt { blob: self, p })
    }

    fn value_gradient_with<K: FixedKernel>(&self, p: DVec3, k: &K) -> (f64, DVec3) {
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

    /// Radius of the support ball.
    #[must_use]
    pub fn support_radius(&self, k: &KernelProfile) -> f64 {
        self.radius * k.support_radius()
    }

    /// Interval of the ray inside the support ball.
    #[must_use]
    pub fn support_interval(&self, ray: &Ray, k: &KernelProfile) -> Option<Interval> {
        ball_interval(ray, self.center, self.support_radius(k))
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
        k.with_family(RayJetOver {
            blob: self,
            ray,
            span,
        })
    }

    /// [`Self::ray_jet`] with the kernel's family fixed (the compact kernels'
    /// powers unrolled), bit for bit.
    fn ray_jet_with<K: FixedKernel>(&self, ray: &Ray, span: Interval, k: &K) -> Jet {
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
        // The kernel once per end point, for the value and both derivatives.
        let (x_a, x_b) = (x_of(a), x_of(b));
        let ((k_a, k1_a, k2_a), (k_b, k1_b, k2_b)) =
            (k.value_d2_inside(x_a), k.value_d2_inside(x_b));
        // `K(x)` from the terms inside the support, as `FixedKernel::value` gives it: 0 from the
        // support's boundary on.
        let support_sq = k.support_sq();
        let value_of = |x: f64, k_inside: f64| if x >= support_sq { 0.0 } else { k_inside };
        // The largest value is at the point of the span nearest the closest point (`τ = 0`);
        // where that is inside the span, the kernel there serves `f″`'s critical point too.
        let mut closest = None;
        let nearest = if 0.0 < a {
            value_of(x_a, k_a)
        } else if 0.0 > b {
            value_of(x_b, k_b)
        } else {
            let x = x_of(0.0);
            let terms = k.value_d2_inside(x);
            closest = Some(terms);
            value_of(x, terms.0)
        };
        let farthest = if a.abs() > b.abs() {
            value_of(x_a, k_a)
        } else {
            value_of(x_b, k_b)
        };
        let value = Interval::new(self.norm * farthest, self.norm * nearest);
        let (c1, c2) = k.point_critical_tau2(h2);
        let mut d1 = Interval::new(d1_of(a, k1_a), d1_of(b, k1_b));
        let mut d2 = Interval::new(d2_of(a, k1_a, k2_a), d2_of(b, k1_b, k2_b));
        for tau in [c1.sqrt(), -c1.sqrt()] {
            if (a..=b).contains(&tau) {
                d1 = d1.include(d1_at(tau));
            }
        }
        if let Some((_, k1, k2)) = closest {
            d2 = d2.include(d2_of(0.0, k1, k2));
        }
        for tau in [c2.sqrt(), -c2.sqrt()] {
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

/// [`PointBlob::value_gradient`] as a [`KernelLoop`].
struct ValueGradientAt<'a> {
    blob: &'a PointBlob,
    p: DVec3,
}

impl KernelLoop for ValueGradientAt<'_> {
    type Output = (f64, DVec3);
    fn run<K: FixedKernel>(self, kernel: &K) -> (f64, DVec3) {
        self.blob.value_gradient_with(self.p, kernel)
    }
}

/// [`PointBlob::ray_jet`] as a [`KernelLoop`].
struct RayJetOver<'a> {
    blob: &'a PointBlob,
    ray: &'a Ray,
    span: Interval,
}

impl KernelLoop for RayJetOver<'_> {
    type Output = Jet;
    fn run<K: FixedKernel>(self, kernel: &K) -> Jet {
        self.blob.ray_jet_with(self.ray, self.span, kernel)
    }
}
