//! Linear Taylor tracing (forward-inclusion 2023 §5.1, appendix A): asymmetric linear bounds
//! `f(t) + [min f′, max f′]·s` on `[t, t + h]`, from the field engine's exact per-primitive
//! derivative analysis composed through the blend tree.

use super::MethodId;
use crate::bounds::inclusion::ForwardInclusion;
use crate::bounds::interval::Interval;
use crate::field::program::FieldProgram;
use crate::field::ray_field::RayField;

use super::marching::{Marcher, Slope};
use super::{Method, RayTracer, TraceSettings};

/// `linear-taylor`.
pub struct LinearTaylor;

impl Method for LinearTaylor {
    fn id(&self) -> MethodId {
        MethodId::LinearTaylor
    }

    fn is_conservative(&self) -> bool {
        true
    }

    fn scene_inputs(&self, _: &FieldProgram) -> Vec<f64> {
        // The march's bounds come from the ray's own field.
        Vec::new()
    }

    fn prepare<'a>(
        &self,
        program: &'a FieldProgram,
        settings: TraceSettings,
    ) -> Box<dyn RayTracer + 'a> {
        Box::new(Marcher {
            program,
            settings,
            slope: Slope::Unused,
            bound: |field: &RayField, t, f, _, h| {
                ForwardInclusion::linear(f, &field.jet(Interval::new(t, t + h)), h)
            },
        })
    }
}
