//! One term of an HRBF set in a field program (forward inclusion 2023 eq. 9; the set and its
//! solve: `crate::field::hrbf_solve`). A set of `N` points compiles to `N` centre terms
//! `α r³ + β·∇φ(p − pᵢ)`, `∇φ(v) = 3‖v‖v`, and one affine term `a·p + b`, all with the
//! weights already scaled into the density `c − (c/ℓ)h`, and all evaluated only inside the
//! set's box (0 outside). Splitting the set keeps primitives small and `Copy`, and lets the
//! acceleration structure and the per-primitive bounds treat it like any other primitive.
//!
//! Along a ray, with `s` the parameter from the point closest to the centre, `h` the distance of
//! the line to it, `r = √(s² + h²)` and `β·(p − pᵢ) = A + Bs`:
//! `f = αr³ + 3r(A + Bs)`, `f′ = 3αrs + 3(s/r)(A + Bs) + 3rB`,
//! `f″ = 3α(2s² + h²)/r + 3(A/h)(h/r)³ + 3B(s/r)(h/r)² + 6B(s/r)`.
//! Each factor (`r`, `rs`, `s/r`, `s²/r`, `(2s² + h²)/r`, `h/r`) is monotone in `s` or in `s²`,
//! so its range over an interval comes from the interval's ends; `|A/h| ≤ |β|` and
//! `0 ≤ h/r ≤ 1` keep the bounds finite where the ray passes through a centre.

use glam::{DMat3, DVec3};

use crate::bounds::interval::{Interval, Jet};
use crate::field::geometry::{Aabb, Ray, Similarity};

/// A centre term (`linear = 0`, `constant = 0`) or the affine term (`alpha = 0`, `beta = 0`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HrbfTerm {
    /// Centre `pᵢ`.
    pub center: DVec3,
    /// Scaled `αᵢ`.
    pub alpha: f64,
    /// Scaled `βᵢ`.
    pub beta: DVec3,
    /// Scaled `a`.
    pub linear: DVec3,
    /// Scaled `b`, plus the isovalue.
    pub constant: f64,
    /// Where the set is evaluated: the box `bounds` in the frame whose axes are the columns of
    /// `frame` (`frameᵀ·p ∈ bounds`; identity until the set is rotated).
    pub bounds: Aabb,
    /// Orthonormal frame of `bounds`.
    pub frame: DMat3,
}

/// `q/√(q + h²)` (0 where both vanish).
fn ratio_sq(q: f64, h2: f64) -> f64 {
    let r = (q + h2).sqrt();
    if r > 0.0 { q / r } else { 0.0 }
}

impl HrbfTerm {
    /// Whether `p` lies in the set's box.
    #[must_use]
    pub fn contains(&self, p: DVec3) -> bool {
        self.bounds.contains(self.frame.transpose() * p)
    }

    /// World-axis box around the set's box (for the acceleration structure).
    #[must_use]
    pub fn support_aabb(&self) -> Aabb {
        let (lo, hi) = (self.bounds.min, self.bounds.max);
        (0..8).fold(Aabb::EMPTY, |acc, i| {
            let corner = DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            acc.union(Aabb::ball(self.frame * corner, 0.0))
        })
    }

    /// Value and gradient at `p` (0 outside the set's box).
    #[must_use]
    pub fn value_gradient(&self, p: DVec3) -> (f64, DVec3) {
        if !self.contains(p) {
            return (0.0, DVec3::ZERO);
        }
        self.value_gradient_inside(p)
    }

    /// Value and gradient at `p` of the formula that holds inside the box, wherever `p` is: a
    /// point the caller knows to be inside (by the ray's interval in the box, which a point
    /// test on the box's face would settle by rounding).
    #[must_use]
    pub fn value_gradient_inside(&self, p: DVec3) -> (f64, DVec3) {
        let v = p - self.center;
        let r = v.length();
        let bv = self.beta.dot(v);
        let value = self.alpha * r * r * r + 3.0 * r * bv + self.linear.dot(p) + self.constant;
        // ∇(αr³) = 3αrv; ∇(3r β·v) = 3(β·v)v/r + 3rβ.
        let mut gradient = 3.0 * self.alpha * r * v + 3.0 * r * self.beta + self.linear;
        if r > 0.0 {
            gradient += (3.0 * bv / r) * v;
        }
        (value, gradient)
    }

    /// A bound of `|∇f|` over the set's box.
    #[must_use]
    pub fn lipschitz(&self) -> f64 {
        let local = self.frame.transpose() * self.center;
        let reach = (local - self.bounds.min)
            .abs()
            .max((self.bounds.max - local).abs())
            .length();
        3.0 * self.alpha.abs() * reach * reach
            + 6.0 * self.beta.length() * reach
            + self.linear.length()
    }

    /// Enclosures of `f`, `f′`, `f″` over `span` (inside the box).
    #[must_use]
    pub fn ray_jet(&self, ray: &Ray, span: Interval) -> Jet {
        let u = ray.direction;
        let affine = Jet::affine(
            self.linear.dot(ray.origin) + self.constant,
            self.linear.dot(u),
            span,
        );
        if self.alpha == 0.0 && self.beta == DVec3::ZERO {
            return affine;
        }
        let w = ray.origin - self.center;
        let along = w.dot(u);
        let perpendicular = w - along * u;
        let h2 = perpendicular.length_squared();
        let h = h2.sqrt();
        let b = self.beta.dot(u);
        let a = self.beta.dot(perpendicular);
        let a_over_h = if h > 0.0 { a / h } else { 0.0 };
        let (s0, s1) = (span.lo + along, span.hi + along);
        let q = Interval::new(s0, s1).square();
        let root = |q: f64| (q + h2).sqrt();
        // Monotone in s: r·s and s/r.
        let rs = Interval::new(s0 * root(s0 * s0), s1 * root(s1 * s1));
        let s_over_r = |s: f64| {
            let r = root(s * s);
            if r > 0.0 { s / r } else { 0.0 }
        };
        let sr = Interval::new(s_over_r(s0), s_over_r(s1));
        // Monotone in s²: r, s²/r, (2s² + h²)/r and h/r.
        let r = Interval::new(root(q.lo), root(q.hi));
        let s2r = Interval::new(ratio_sq(q.lo, h2), ratio_sq(q.hi, h2));
        let bend_at = |q: f64| {
            let r = root(q);
            if r > 0.0 { (2.0 * q + h2) / r } else { 0.0 }
        };
        let bend = Interval::new(bend_at(q.lo), bend_at(q.hi));
        let h_over_r2 = if h2 > 0.0 {
            Interval::new(h2 / (q.hi + h2), h2 / (q.lo + h2))
        } else {
            Interval::ZERO
        };
        let h_over_r3 = Interval::new(h_over_r2.lo.powf(1.5), h_over_r2.hi.powf(1.5));
        let cube = Interval::new(r.lo.powi(3), r.hi.powi(3));
        let value = cube.scale(self.alpha) + r.scale(3.0 * a) + rs.scale(3.0 * b);
        let d1 =
            rs.scale(3.0 * self.alpha) + sr.scale(3.0 * a) + s2r.scale(3.0 * b) + r.scale(3.0 * b);
        let d2 = bend.scale(3.0 * self.alpha)
            + h_over_r3.scale(3.0 * a_over_h)
            + (sr * h_over_r2).scale(3.0 * b)
            + sr.scale(6.0 * b);
        Jet { value, d1, d2 } + affine
    }

    /// The term moved by a similarity `M: p ↦ sRp + t`, so that its field is the original
    /// composed with `M⁻¹`: `‖M⁻¹p − c‖ = ‖p − Mc‖/s` gives `α/s³` and `Rβ/s²`, the affine part
    /// becomes `(Ra/s)·(p − t)`; the box turns with its frame, `F′ = RF`, and its local bounds
    /// become `s·bounds + F′ᵀt`.
    #[must_use]
    pub fn transformed(&self, m: &Similarity) -> Self {
        let s = m.scale;
        let linear = m.direction(self.linear) / s;
        let frame = m.rotation * self.frame;
        let shift = frame.transpose() * m.translation;
        let bounds = Aabb {
            min: s * self.bounds.min + shift,
            max: s * self.bounds.max + shift,
        };
        Self {
            center: m.point(self.center),
            alpha: self.alpha / (s * s * s),
            beta: m.direction(self.beta) / (s * s),
            linear,
            constant: self.constant - linear.dot(m.translation),
            bounds,
            frame,
        }
    }

    /// Interval of the whole line of the ray inside the set's box.
    #[must_use]
    pub fn support_interval(&self, ray: &Ray) -> Option<Interval> {
        self.box_interval(ray, Interval::ENTIRE)
    }

    /// Part of `span` where the ray is inside the set's box.
    #[must_use]
    pub fn box_interval(&self, ray: &Ray, span: Interval) -> Option<Interval> {
        let local = Ray {
            origin: self.frame.transpose() * ray.origin,
            direction: self.frame.transpose() * ray.direction,
        };
        self.bounds.ray_interval(&local, span)
    }
}
