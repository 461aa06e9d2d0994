//! Segment tracing (Galin et al. 2020; forward-inclusion eq. 11): sphere tracing with a local
//! directional Lipschitz bound on the next ray interval `[t, t + h]`, computed as segment tracing
//! does — the sum of the primitives' own bounds ([`FieldProgram::summed_lipschitz`]); `h` grows
//! as `k ×` the last step.

use super::MethodId;
use crate::bounds::interval::Interval;
use crate::field::program::{FieldProgram, PrimitiveSlope};
use crate::field::ray_field::RayField;

use super::marching::{Marcher, Slope, symmetric};
use super::{Method, RayTracer, TraceSettings};

/// `segment`.
pub struct SegmentTracing;

impl Method for SegmentTracing {
    fn id(&self) -> MethodId {
        MethodId::Segment
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
                symmetric(
                    f,
                    field.summed_lipschitz(Interval::new(t, t + h), PrimitiveSlope::Exact),
                    h,
                )
            },
        })
    }
}
