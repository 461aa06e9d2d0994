//! Linear Taylor tracing (forward-inclusion 2023 §5.1, appendix A): asymmetric linear bounds
//! `f(t) + [min f′, max f′]·s` on `[t, t + h]`, from the field engine's exact per-primitive
//! derivative analysis composed through the blend tree.

use crate::geometry::Ray;
use crate::inclusion::ForwardInclusion;
use crate::interval::Interval;
use crate::program::FieldProgram;

use super::marching::Marcher;
use super::{Method, RayTracer, TraceSettings};

/// `linear-taylor`.
pub struct LinearTaylor;

impl Method for LinearTaylor {
    fn name(&self) -> &'static str {
        "linear-taylor"
    }

    fn is_conservative(&self) -> bool {
        true
    }

    fn prepare<'a>(
        &self,
        program: &'a FieldProgram,
        settings: TraceSettings,
    ) -> Box<dyn RayTracer + 'a> {
        Box::new(Marcher {
            program,
            settings,
            bound: |p: &FieldProgram, ray: &Ray, t, f, _, h| {
                ForwardInclusion::linear(f, &p.ray_jet(ray, Interval::new(t, t + h)), h)
            },
        })
    }
}
