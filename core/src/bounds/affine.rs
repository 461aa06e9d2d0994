//! Revised affine arithmetic of rank 1 along a ray (MATH.md §8; Fryazinov et al. 2010, the
//! baseline of forward-inclusion 2023 Table 1). On a ray interval `[a, b]`, `t = m + r·ε` with
//! `ε ∈ [−1, 1]`; a quantity is `x₀ + x₁ε + e·[−1, 1]`.
//!
//! Point blobs are evaluated exactly through the quadratic squared distance (`ε² ∈ [0, 1]`
//! becomes `½ + ½·[−1, 1]`), compact kernels by the product rule of MATH.md §8 on
//! `Q = 1 − x/σ²` clipped at 0, other kernels by the min-range linearisation of a decreasing
//! convex function. HRBF terms (2023 eq. 9) inside their set's box are evaluated through the
//! same squared distance: `ρ = √‖v‖²` by the Chebyshev linearisation of the concave root, then
//! `αρ³ + 3ρ(β·v) = ρ·(α‖v‖² + 3β·v)` by one product, and the affine term exactly. Other
//! primitives (and HRBF terms on spans that leave the box) enter as the interval of their
//! value enclosure. Sums add,
//! max and min keep the dominating operand when the ranges are disjoint and take the interval
//! hull otherwise.

use glam::DVec3;

use crate::bounds::interval::Interval;
use crate::field::blend::BlendTree;
use crate::field::geometry::Ray;
use crate::field::kernel::KernelProfile;
use crate::field::primitives::{HrbfTerm, PointBlob, Primitive};
use crate::field::ray_field::RayField;

use std::ops::{Add, Mul};

/// `x₀ + x₁ε + e·[−1, 1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AffineForm {
    /// Central value.
    pub x0: f64,
    /// Coefficient of the ray noise symbol.
    pub x1: f64,
    /// Accumulated error, `≥ 0`.
    pub e: f64,
}

impl AffineForm {
    /// The constant `c`.
    #[must_use]
    pub const fn constant(c: f64) -> Self {
        Self {
            x0: c,
            x1: 0.0,
            e: 0.0,
        }
    }

    /// An interval, with no correlation to the ray.
    #[must_use]
    pub fn from_interval(i: Interval) -> Self {
        Self {
            x0: 0.5 * (i.lo + i.hi),
            x1: 0.0,
            e: 0.5 * i.width(),
        }
    }

    /// The range `[x₀ − |x₁| − e, x₀ + |x₁| + e]`.
    #[must_use]
    pub fn range(&self) -> Interval {
        let r = self.x1.abs() + self.e;
        Interval::new(self.x0 - r, self.x0 + r)
    }

    /// `k·x + c`.
    #[must_use]
    pub fn affine(self, k: f64, c: f64) -> Self {
        Self {
            x0: k * self.x0 + c,
            x1: k * self.x1,
            e: k.abs() * self.e,
        }
    }

    /// `K(x)` for a kernel profile (decreasing, convex): min-range linearisation `αx + ζ ± δ`
    /// with `α = K′(hi)`, so that `K(x) − αx` is decreasing on the range (`x ≥ 0` always).
    #[must_use]
    pub fn kernel(self, k: &KernelProfile) -> Self {
        let r = self.range();
        let (lo, hi) = (r.lo.max(0.0), r.hi.max(0.0));
        let (k_lo, _) = k.convex_extension(lo);
        let (k_hi, alpha) = k.convex_extension(hi);
        let (top, bottom) = (k_lo - alpha * lo, k_hi - alpha * hi);
        let mut out = self.affine(alpha, 0.5 * (top + bottom));
        out.e += 0.5 * (top - bottom);
        out
    }

    /// `√x` for `x ≥ 0` (the range is clamped at 0): the chord of the concave root over the
    /// range, raised by half its largest gap to the root, `± half that gap` (Chebyshev
    /// approximation).
    #[must_use]
    pub fn sqrt(self) -> Self {
        let r = self.range();
        let (lo, hi) = (r.lo.max(0.0), r.hi.max(0.0));
        if hi <= lo {
            return Self::constant(lo.sqrt());
        }
        let slope = (hi.sqrt() - lo.sqrt()) / (hi - lo);
        // √x − chord(x) is largest where the root's slope equals the chord's.
        let tangent_at = 0.25 / (slope * slope);
        let gap = (tangent_at.sqrt() - (lo.sqrt() + slope * (tangent_at - lo))).max(0.0);
        let mut out = self.affine(slope, lo.sqrt() - slope * lo + 0.5 * gap);
        out.e += 0.5 * gap;
        out
    }

    /// `max(x, 0)`.
    #[must_use]
    pub fn positive_part(self) -> Self {
        let r = self.range();
        if r.lo >= 0.0 {
            self
        } else if r.hi <= 0.0 {
            Self::constant(0.0)
        } else {
            Self::from_interval(Interval::new(0.0, r.hi))
        }
    }

    fn max(self, o: Self) -> Self {
        let (a, b) = (self.range(), o.range());
        if a.lo >= b.hi {
            self
        } else if b.lo >= a.hi {
            o
        } else {
            Self::from_interval(Interval::new(a.lo.max(b.lo), a.hi.max(b.hi)))
        }
    }

    fn negate(self) -> Self {
        self.affine(-1.0, 0.0)
    }
}

impl Add for AffineForm {
    type Output = Self;

    fn add(self, o: Self) -> Self {
        Self {
            x0: self.x0 + o.x0,
            x1: self.x1 + o.x1,
            e: self.e + o.e,
        }
    }
}

impl Mul for AffineForm {
    type Output = Self;

    /// Product (MATH.md §8).
    fn mul(self, y: Self) -> Self {
        Self {
            x0: self.x0 * y.x0 + 0.5 * self.x1 * y.x1,
            x1: self.x0 * y.x1 + self.x1 * y.x0,
            e: self.e * y.e
                + y.e * (self.x0.abs() + self.x1.abs())
                + self.e * (y.x0.abs() + y.x1.abs())
                + 0.5 * (self.x1 * y.x1).abs(),
        }
    }
}

/// A point blob over `[a, b]` (exact squared distance, kernel as above).
fn point_form(blob: &PointBlob, k: &KernelProfile, ray: &Ray, span: Interval) -> AffineForm {
    let mid = 0.5 * (span.lo + span.hi);
    let r = 0.5 * span.width();
    let inv = 1.0 / (blob.radius * blob.radius);
    let w = ray.at(mid) - blob.center;
    let q = inv * r * r;
    let x = AffineForm {
        x0: w.length_squared() * inv + 0.5 * q,
        x1: 2.0 * w.dot(ray.direction) * inv * r,
        e: 0.5 * q,
    };
    let value = match k.compact_power() {
        Some((m, inv_sigma2)) => {
            let base = x.affine(-inv_sigma2, 1.0).positive_part();
            (1..m).fold(base, |acc, _| acc * base)
        }
        None => x.kernel(k),
    };
    value.affine(blob.norm, 0.0)
}

/// An HRBF term over `[a, b]` when the ray stays in its set's box there (see the module doc),
/// `None` otherwise (the field is cut at the box).
fn hrbf_form(term: &HrbfTerm, ray: &Ray, span: Interval) -> Option<AffineForm> {
    if !(term.contains(ray.at(span.lo)) && term.contains(ray.at(span.hi))) {
        return None;
    }
    let mid = 0.5 * (span.lo + span.hi);
    let r = 0.5 * span.width();
    let at = ray.at(mid);
    let w = at - term.center;
    let squared = AffineForm {
        x0: w.length_squared() + 0.5 * r * r,
        x1: 2.0 * w.dot(ray.direction) * r,
        e: 0.5 * r * r,
    };
    let along = |u: DVec3, c: f64| AffineForm {
        x0: u.dot(at) + c,
        x1: u.dot(ray.direction) * r,
        e: 0.0,
    };
    let beta_v = along(term.beta, -term.beta.dot(term.center));
    let radial = squared.sqrt() * (squared.affine(term.alpha, 0.0) + beta_v.affine(3.0, 0.0));
    Some(radial + along(term.linear, term.constant))
}

/// Affine form of the field over `span`; `None` where the blend has no rule (the smooth blends;
/// Ricci where two operands may be positive).
#[must_use]
pub fn field_form(field: &RayField, span: Interval) -> Option<AffineForm> {
    let (program, ray) = (field.program(), field.ray());
    let mut groups = vec![AffineForm::constant(0.0); program.group_count()];
    field.for_each_primitive(span, |g, primitive, k, _| {
        let form = match primitive {
            Primitive::Point(b) => point_form(b, k, ray, span),
            Primitive::Hrbf(term) => hrbf_form(term, ray, span).unwrap_or_else(|| {
                AffineForm::from_interval(primitive.ray_jet(ray, span, k).value)
            }),
            other => AffineForm::from_interval(other.ray_jet(ray, span, k).value),
        };
        groups[g] = groups[g] + form;
    });
    program.clamp_group_slots(&mut groups, |group| *group = group.positive_part());
    blend(program.blend(), &groups, program.isovalue())
}

fn blend(b: &BlendTree, groups: &[AffineForm], isovalue: f64) -> Option<AffineForm> {
    let fold = |v: &[BlendTree], op: fn(AffineForm, AffineForm) -> AffineForm| {
        let mut it = v.iter().map(|c| blend(c, groups, isovalue));
        let first = it.next()??;
        it.try_fold(first, |acc, c| Some(op(acc, c?)))
    };
    match b {
        BlendTree::Group(i) => groups.get(*i as usize).copied(),
        BlendTree::Sum(v) => fold(v, |a, b| a + b),
        BlendTree::Max(v) => fold(v, AffineForm::max),
        BlendTree::Min(v) => fold(v, |a, b| a.negate().max(b.negate()).negate()),
        BlendTree::Difference(a, c) => {
            let a = blend(a, groups, isovalue)?;
            let complement = blend(c, groups, isovalue)?.affine(-1.0, 2.0 * isovalue);
            Some(a.negate().max(complement.negate()).negate())
        }
        BlendTree::Ricci { of, .. } => {
            // At most one operand positive: that operand's positive part (`blend::ricci_jet`).
            let items: Option<Vec<_>> = of.iter().map(|c| blend(c, groups, isovalue)).collect();
            let mut positive = items?.into_iter().filter(|f| f.range().hi > 0.0);
            match (positive.next(), positive.next()) {
                (None, _) => Some(AffineForm::constant(0.0)),
                (Some(only), None) => Some(only.positive_part()),
                (Some(_), Some(_)) => None,
            }
        }
        BlendTree::SmoothUnion { .. } | BlendTree::SmoothIntersection { .. } => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_root_form_encloses_the_root() {
        for (x0, x1, e) in [
            (2.0, 1.5, 0.5),
            (1.0, 1e-4, 0.0),
            (4.6, 3.0, 1.35),
            (0.3, 0.4, 0.2),
        ] {
            let x = AffineForm { x0, x1, e };
            let root = x.sqrt();
            for i in 0..=40 {
                let eps = -1.0 + f64::from(i) / 20.0;
                for j in 0..=4 {
                    let noise = -1.0 + f64::from(j) / 2.0;
                    let value = x0 + x1 * eps + e * noise;
                    if value < 0.0 {
                        continue;
                    }
                    let centre = root.x0 + root.x1 * eps;
                    assert!(
                        (value.sqrt() - centre).abs() <= root.e + 1e-12,
                        "√{value} = {} outside {centre} ± {}",
                        value.sqrt(),
                        root.e
                    );
                }
            }
        }
    }

    #[test]
    fn product_encloses_sampled_products() {
        let x = AffineForm {
            x0: 0.3,
            x1: -0.5,
            e: 0.1,
        };
        let y = AffineForm {
            x0: -1.0,
            x1: 0.25,
            e: 0.05,
        };
        let p = (x * y).range();
        for i in 0..=40 {
            let eps = -1.0 + f64::from(i) / 20.0;
            for (ex, ey) in [
                (-1.0, -1.0),
                (-1.0, 1.0),
                (1.0, -1.0),
                (1.0, 1.0),
                (0.0, 0.0),
            ] {
                let v = (x.x0 + x.x1 * eps + x.e * ex) * (y.x0 + y.x1 * eps + y.e * ey);
                // Rounding of the exact boundary value is allowed.
                assert!(
                    Interval::new(p.lo - 1e-12, p.hi + 1e-12).contains(v),
                    "{v} not in {p:?}"
                );
            }
        }
    }
}
