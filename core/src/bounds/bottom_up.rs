//! Bottom-up forward inclusions (forward-inclusion 2023 §5.2, §6.2, appendix B): the bounds are
//! built from the arithmetic structure of the field along the ray instead of from derivative
//! bounds of the whole field.
//!
//! For a point blob `N·K(x(s))`, `x(s) = |o + (t₀ + s)u − c|²/ρ²` is an exact quadratic in `s`
//! and every kernel profile `K` is decreasing and convex in `x` (clipped kernels included, see
//! [`KernelProfile::convex_extension`]). So the blob is a monotone convex function of a convex
//! quadratic, the building block of §5.2 and appendix B:
//!
//! - linear (§5.2): `x` lies between its tangent at `s = 0` and its chord; `K` decreasing turns
//!   those into an upper and a lower function of `s`, both convex, bounded by their chord (upper)
//!   and their tangent (lower);
//! - quadratic (appendix B): `K` lies below its chord and above its tangent over the range of
//!   `x`; composed with the exact quadratic `x(s)` these are quadratics in `s`, exact at `s = 0`
//!   when `x(0)` is an end of that range. Where the ray passes the blob's closest point inside
//!   the interval, the interval is shortened to the symmetric point `x(s) = x(0)` (the validity
//!   interval of §4.2 and figure 20).
//!
//! Compact kernels are handled by the same rule rather than by the paper's repeated products
//! `Q·Q·Q`: the clipped part of the kernel is part of the convex profile, which gives the
//! per-primitive extension of §6.2.1 (bounds computed on the support, extended over the whole
//! interval) without a special case. Primitives without a closed form along the ray (segments,
//! SCALIS integrals, shapes) contribute their own Taylor inclusion (appendix A), so a scene
//! mixing them still gets a valid bound. Group sums add (eq. 16) and the blend tree composes
//! them with [`crate::bounds::inclusion::blend`] (appendix C for max).

use glam::DVec3;

use crate::bounds::inclusion::{self, ForwardInclusion, Offset};
use crate::bounds::interval::Interval;
use crate::field::geometry::Ray;
use crate::field::kernel::KernelProfile;
use crate::field::primitives::{PointBlob, Primitive};
use crate::field::ray_field::RayField;

/// Degree of the bottom-up bounds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Degree {
    /// Lines (§5.2).
    Linear,
    /// Quadratics (§6.2, appendix B).
    Quadratic,
}

/// `x(s) = x0 + x1·s + x2·s²` for a blob along the ray from `t0`.
fn squared_distance(blob: &PointBlob, ray: &Ray, t0: f64) -> (f64, f64, f64) {
    let inv = 1.0 / (blob.radius * blob.radius);
    let w = ray.at(t0) - blob.center;
    (
        w.length_squared() * inv,
        2.0 * w.dot(ray.direction) * inv,
        inv,
    )
}

/// Linear bottom-up inclusion of a point blob on `[t0, t0 + h]` (§5.2).
#[must_use]
pub fn point_linear(
    blob: &PointBlob,
    k: &KernelProfile,
    ray: &Ray,
    t0: f64,
    h: f64,
) -> ForwardInclusion {
    let (x0, x1, x2) = squared_distance(blob, ray, t0);
    let n = blob.norm;
    let (k0, _) = k.convex_extension(x0);
    // x ≥ x0 + x1·s (tangent) ⇒ f ≤ N·K(x0 + x1·s), convex in s: its chord.
    let (k_end, _) = k.convex_extension(x0 + x1 * h);
    let upper = if h > 0.0 { n * (k_end - k0) / h } else { 0.0 };
    // x ≤ x0 + (x1 + x2·h)·s (chord) ⇒ f ≥ N·K(x0 + (x1 + x2 h)s), convex in s: its tangent.
    let (_, slope0) = k.convex_extension(x0);
    let lower = n * slope0 * (x1 + x2 * h);
    ForwardInclusion {
        start: n * k0,
        lower: Offset { a: lower, b: 0.0 },
        upper: Offset { a: upper, b: 0.0 },
        length: h,
    }
}

/// Quadratic bottom-up inclusion of a point blob on `[t0, t0 + h]` (appendix B), on a possibly
/// shorter validity interval.
#[must_use]
pub fn point_quadratic(
    blob: &PointBlob,
    k: &KernelProfile,
    ray: &Ray,
    t0: f64,
    h: f64,
) -> ForwardInclusion {
    let (x0, x1, x2) = squared_distance(blob, ray, t0);
    let n = blob.norm;
    // Validity: x0 must be an end of the range of x on [0, h]. Where the ray passes the
    // closest point inside the interval, it is cut at the symmetric point x(h) = x0, and the
    // range is [x(closest), x0].
    let closest = -x1 / (2.0 * x2);
    let (h, x_other) = if closest > 0.0 && closest < h {
        (2.0 * closest, x0 + closest * (x1 + x2 * closest))
    } else {
        (h, x0 + h * (x1 + x2 * h))
    };
    let (k0, slope0) = k.convex_extension(x0);
    let chord = if (x_other - x0).abs() > 1e-12 * (1.0 + x0.abs()) {
        (k.convex_extension(x_other).0 - k0) / (x_other - x0)
    } else {
        slope0
    };
    ForwardInclusion {
        start: n * k0,
        lower: Offset {
            a: n * slope0 * x1,
            b: n * slope0 * x2,
        },
        upper: Offset {
            a: n * chord * x1,
            b: n * chord * x2,
        },
        length: h,
    }
}

/// Taylor inclusion of one primitive (appendix A), for primitives without a bottom-up rule.
fn primitive_taylor(
    primitive: &Primitive,
    k: &KernelProfile,
    ray: &Ray,
    (span, inside): (Interval, Interval),
    degree: Degree,
) -> ForwardInclusion {
    // An HRBF term is evaluated at t by the ray's interval in its box (`inside`): where a part
    // starts on the box's face, a point test would put t inside or outside by rounding.
    let (v, g) = match primitive {
        Primitive::Hrbf(term) if inside.lo <= span.lo => {
            term.value_gradient_inside(ray.at(span.lo))
        }
        Primitive::Hrbf(_) => (0.0, DVec3::ZERO),
        _ => primitive.value_gradient(ray.at(span.lo), k),
    };
    // `inside` is the support's part of `span`, which `Primitive::ray_jet` would compute again.
    let jet = primitive.ray_jet_inside(ray, span, inside, k);
    match degree {
        Degree::Linear => ForwardInclusion::linear(v, &jet, span.width()),
        Degree::Quadratic => {
            ForwardInclusion::quadratic(v, g.dot(ray.direction), &jet, span.width())
        }
    }
}

/// Bottom-up inclusion of the whole field on `[t, t + h]`: per primitive, summed per group,
/// composed through the blend tree; where the tree has no composition rule (smooth blends;
/// Ricci where two operands may be positive), the Taylor inclusion of the whole field (`f` at
/// `t` given, and `f′` where the march computed it: NaN otherwise, and the quadratic fallback
/// computes it, the same bits as the march's `RayField::along`).
#[must_use]
pub fn field_inclusion(
    field: &RayField,
    (t, f, d, h): (f64, f64, f64, f64),
    degree: Degree,
) -> ForwardInclusion {
    let span = Interval::new(t, t + h);
    let (program, ray) = (field.program(), field.ray());
    let composed = program.with_group_slots(ForwardInclusion::zero(h), |groups| {
        field.for_each_primitive(span, |g, primitive, k, inside| {
            let own = match (primitive, degree) {
                (Primitive::Point(b), Degree::Linear) => point_linear(b, k, ray, t, h),
                (Primitive::Point(b), Degree::Quadratic) => point_quadratic(b, k, ray, t, h),
                (other, _) => primitive_taylor(other, k, ray, (span, inside), degree),
            };
            groups[g] = groups[g] + own;
        });
        program.clamp_group_slots(groups, |group| *group = group.positive_part());
        inclusion::blend(program.blend(), groups, program.isovalue())
    });
    let blended = composed.unwrap_or_else(|| {
        let jet = field.jet(span);
        match degree {
            Degree::Linear => ForwardInclusion::linear(f, &jet, h),
            Degree::Quadratic => {
                let d = if d.is_nan() { field.along(t).1 } else { d };
                ForwardInclusion::quadratic(f, d, &jet, h)
            }
        }
    });
    match degree {
        Degree::Linear => blended.linearized(),
        Degree::Quadratic => blended,
    }
}
