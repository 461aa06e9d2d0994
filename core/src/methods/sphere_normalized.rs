//! Sphere tracing on the normalised field (scalis 2021 §8 baseline and appendix B; similar in
//! spirit to Bruckner 2019): `√g∘f − 1` behaves like a homothetic distance minus 1, so its
//! Lipschitz constant is `1/τ_min`, with `τ_min` the radius of the thinnest skeleton point whose
//! support the ray meets — computed per ray and per primitive as appendix B describes, here on
//! each marching interval `[t, t + h]` (`h` grows as `k ×` the last step, as for the other
//! marching methods); under `--protocol paper-2021` once per ray, as the paper does. The step is
//! `|√g(f) − 1|·τ_min`.
//!
//! The constant is exact for an isolated segment of constant radius, not for blended or bent
//! skeletons, so the method is not guaranteed; the statistics count its misses.

use super::MethodId;
use crate::bounds::interval::Interval;
use crate::field::program::FieldProgram;
use crate::field::ray_field::RayField;

use super::marching::{Marcher, Slope, symmetric};
use super::normalised_field::{normalising_kernel, scalis_kernel, thinnest_radius_on};
use super::{Method, RayTracer, TraceSettings};

/// `sphere-normalized`.
pub struct NormalizedSphereTracing;

impl Method for NormalizedSphereTracing {
    fn id(&self) -> MethodId {
        MethodId::SphereNormalized
    }

    fn is_conservative(&self) -> bool {
        false
    }

    fn supports(&self, program: &FieldProgram) -> Result<(), String> {
        scalis_kernel(program, self.name()).map(|_| ())
    }

    fn scene_inputs(&self, _: &FieldProgram) -> Vec<f64> {
        // The normalising kernel is the groups' common one; the thinnest radius is the ray's own.
        Vec::new()
    }

    fn prepare<'a>(
        &self,
        program: &'a FieldProgram,
        settings: TraceSettings,
    ) -> Box<dyn RayTracer + 'a> {
        let kernel = normalising_kernel(program);
        let per_ray = settings.protocol.thinnest_radius_per_ray();
        Box::new(Marcher {
            program,
            settings,
            slope: Slope::Unused,
            bound: move |field: &RayField, t, f, _, h| {
                let window = if per_ray {
                    field.span()
                } else {
                    Interval::new(t, t + h)
                };
                let tau = thinnest_radius_on(field, window);
                if !tau.is_finite() {
                    return symmetric(f, 0.0, h);
                }
                let c = field.program().isovalue();
                let (g, _) = kernel.field_normalisation(f, c);
                let distance = (g.max(0.0).sqrt() - 1.0).abs() * tau;
                let lambda = if distance > 0.0 {
                    (f - c).abs() / distance
                } else {
                    f64::MAX
                };
                symmetric(f, lambda, h)
            },
        })
    }
}
