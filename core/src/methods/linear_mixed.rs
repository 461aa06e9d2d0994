//! Linear mixed tracing (forward-inclusion 2023 §7.2): linear Taylor inclusions for each group
//! (the sums of primitives, where derivatives are easy to bound), composed bottom-up through the
//! blend tree — the max keeps its kink instead of widening the derivative bounds of the whole
//! field. Blends without a forward-inclusion rule (smooth blends; Ricci where two operands may be positive) use the whole-field Taylor bound.

use super::MethodId;
use crate::bounds::inclusion::ForwardInclusion;
use crate::field::program::FieldProgram;
use crate::field::ray_field::RayField;

use super::marching::{Marcher, Slope, mixed_inclusion};
use super::{Method, RayTracer, TraceSettings};

/// `linear-mixed`.
pub struct LinearMixed;

impl Method for LinearMixed {
    fn id(&self) -> MethodId {
        MethodId::LinearMixed
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
            slope: Slope::Used,
            bound: |field: &RayField, t, f, d, h| {
                mixed_inclusion(field, (t, f, d, h), |g, _, jet, h| {
                    ForwardInclusion::linear(g, jet, h)
                })
            },
        })
    }
}
