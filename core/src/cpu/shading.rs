//! Soft shadows and ambient occlusion from the field itself (numerical ray tracing notes 2014
//! §12.4): both read how close a point is to the surface instead of tracing many rays. A density
//! field is not a distance, so the distance to the isosurface is estimated to first order,
//! `e = (c − f)/|∇f|` (capped at [`MAX_STEP`] of the scene scale where the field is flat).
//!
//! - Soft shadow towards a light: march from the shaded point with steps of `e` (clamped to
//!   `[MIN_STEP, MAX_STEP]` × scale, at most [`SOFT_SHADOW_STEPS`]), keep the smallest
//!   `SOFTNESS · e / t` over the uncapped estimates (the cone of directions that clears the
//!   surface, Quílez's penumbra), 0
//!   as soon as a sample is inside. An approximation: unlike `--shadows`, which traces exact
//!   shadow rays with the chosen method, a thin occluder may be stepped over.
//! - Ambient occlusion: [`AO_SAMPLES`] points at heights `h = i·AO_STEP·scale` along the
//!   normal; a point whose estimated distance to the surface is below `h` is occluded by
//!   `(h − e)/h`, with weights decaying by [`AO_DECAY`]. It darkens the ambient term fully and
//!   the direct light by half.
//!
//! The scale is the diagonal of the bounded supports (`frame::shading_scale`). The GPU backend
//! (`render/shaders/main.wgsl`) runs the same loops with the same constants (`frame.rs`) in f32.

use glam::DVec3;

use crate::field::program::FieldProgram;
use crate::frame::{
    AO_DECAY, AO_SAMPLES, AO_STEP, MAX_STEP, MIN_STEP, SHADOW_REACH, SOFT_SHADOW_STEPS, SOFTNESS,
};

/// First-order distance from a point with field `f`, gradient `g` to the isosurface `c`.
fn distance_estimate(c: f64, f: f64, g: DVec3, scale: f64) -> f64 {
    let cap = MAX_STEP * scale;
    let slope = g.length();
    if slope * cap <= c - f {
        cap
    } else {
        (c - f) / slope
    }
}

/// Light reaching `from` along the unit `direction` within `distance`, in `[0, 1]`.
#[must_use]
pub fn soft_shadow(
    program: &FieldProgram,
    from: DVec3,
    direction: DVec3,
    distance: f64,
    scale: f64,
) -> f64 {
    let c = program.isovalue();
    let reach = distance.min(SHADOW_REACH * scale);
    let mut t = MIN_STEP * scale;
    let mut lit: f64 = 1.0;
    for _ in 0..SOFT_SHADOW_STEPS {
        if t >= reach {
            break;
        }
        let (f, g) = program.value_gradient(from + t * direction);
        if f >= c {
            return 0.0;
        }
        let e = distance_estimate(c, f, g, scale);
        if e < MAX_STEP * scale {
            // A capped estimate says only "far from the surface": no penumbra from it.
            lit = lit.min(SOFTNESS * e / t);
        }
        t += e.clamp(MIN_STEP * scale, MAX_STEP * scale);
    }
    let x = lit.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// Unoccluded fraction of the hemisphere above a surface point `p` with outward `normal`.
#[must_use]
pub fn ambient_occlusion(program: &FieldProgram, p: DVec3, normal: DVec3, scale: f64) -> f64 {
    let c = program.isovalue();
    let (mut occluded, mut total, mut weight) = (0.0, 0.0, 1.0);
    for i in 1..=AO_SAMPLES {
        let h = f64::from(i) * AO_STEP * scale;
        let (f, g) = program.value_gradient(p + h * normal);
        let e = if f >= c {
            0.0
        } else {
            distance_estimate(c, f, g, scale).min(h)
        };
        occluded += weight * (h - e) / h;
        total += weight;
        weight *= AO_DECAY;
    }
    1.0 - occluded / total
}
