//! The normalised SCALIS field of scalis 2021 §4 (MATH.md §4), shared by `sphere-normalized`
//! and `scalis-quadratic`: `F = g∘f − 1`, with `g` the inverse of the field of an infinite
//! constant-radius segment, is a signed squared homothetic distance (0 on the surface, positive
//! outside), exactly quadratic along a ray for a long segment whatever the kernel.

use crate::bounds::interval::Interval;
use crate::field::geometry::{Ray, SphereCone};
use crate::field::kernel::KernelProfile;
use crate::field::primitives::Primitive;
use crate::field::program::FieldProgram;
use crate::field::ray_field::RayField;

/// `Ok` with the common kernel when every primitive is a SCALIS segment and every group uses
/// the same kernel (one `g` for the whole field).
pub(crate) fn scalis_kernel(program: &FieldProgram, method: &str) -> Result<KernelProfile, String> {
    if program.primitives().is_empty() {
        return Err(format!("{method} needs at least one SCALIS skeleton"));
    }
    if !program
        .primitives()
        .iter()
        .all(|p| matches!(p, Primitive::Scalis(_)))
    {
        return Err(format!(
            "{method} needs SCALIS skeletons only (field: Scalis; no point blobs, distance \
             skeletons or shapes): its field normalisation is defined for SCALIS segments"
        ));
    }
    let kernel = program.common_kernel().ok_or_else(|| {
        format!("{method} needs one kernel for every group (the normalisation inverts one kernel)")
    })?;
    Ok(KernelProfile::new(kernel))
}

/// The kernel whose normalisation `g` the tracers invert: the scene's common kernel (checked by
/// [`scalis_kernel`] in `supports`); the default kernel for a scene the method refused.
pub(crate) fn normalising_kernel(program: &FieldProgram) -> KernelProfile {
    KernelProfile::new(program.common_kernel().unwrap_or_default())
}

/// `(F, F′)` along the ray at `t`, with `F = g(f) − 1`.
pub(crate) fn normalised(field: &RayField, kernel: &KernelProfile, t: f64) -> (f64, f64) {
    let (f, d) = field.along(t);
    let (g, dg) = kernel.field_normalisation(f, field.program().isovalue());
    (g - 1.0, dg * d)
}

/// Radius of the thinnest skeleton point of `cone` whose support ball (radius `R·τ(s)`) the
/// ray meets (scalis 2021 appendix B); `cone.radius` when none does.
pub(crate) fn thinnest_radius_met(cone: &SphereCone, support_radius: f64, ray: &Ray) -> f64 {
    let m = cone.start - ray.origin;
    let perp = |v: glam::DVec3| v - v.dot(ray.direction) * ray.direction;
    let (m_p, u_p) = (perp(m), perp(cone.axis));
    let r2 = support_radius * support_radius;
    // |m⊥ + s·u⊥|² − R²(τ₀ + δs)² ≤ 0
    let a = u_p.length_squared() - r2 * cone.slope * cone.slope;
    let b = 2.0 * (m_p.dot(u_p) - r2 * cone.radius * cone.slope);
    let c = m_p.length_squared() - r2 * cone.radius * cone.radius;
    if c <= 0.0 {
        return cone.radius;
    }
    let first = crate::field::geometry::quadratic_roots(a, b, c)
        .map(|(r1, r2)| [r1, r2])
        .into_iter()
        .flatten()
        .filter(|s| (0.0..=cone.length).contains(s))
        .reduce(f64::min);
    first.map_or(cone.radius, |s| cone.radius + cone.slope * s)
}

/// Smallest radius met by the ray among the segments whose support it crosses on `span`
/// (infinite when none).
pub(crate) fn thinnest_radius_on(field: &RayField, span: Interval) -> f64 {
    let mut thinnest = f64::INFINITY;
    field.for_each_primitive(span, |_, p, k, _| {
        if let Primitive::Scalis(s) = p {
            thinnest = thinnest.min(thinnest_radius_met(
                &s.cone,
                k.support_radius(),
                field.ray(),
            ));
        }
    });
    thinnest
}
