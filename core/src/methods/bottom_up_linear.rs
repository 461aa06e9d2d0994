//! Bottom-up linear tracing (forward-inclusion 2023 §5.2): Algorithm 1 marching on linear
//! inclusions built bottom-up from the field's arithmetic ([`crate::bounds::bottom_up`]).

use super::MethodId;
use crate::bounds::bottom_up::{Degree, field_inclusion};
use crate::field::program::FieldProgram;
use crate::field::ray_field::RayField;

use super::marching::{Marcher, Slope};
use super::{Method, RayTracer, TraceSettings};

/// `bottom-up-linear`.
pub struct BottomUpLinear;

impl Method for BottomUpLinear {
    fn id(&self) -> MethodId {
        MethodId::BottomUpLinear
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
            // Each primitive's own value at `t` enters its inclusion; the field's `f′(t)`
            // enters none.
            slope: Slope::Unused,
            bound: |field: &RayField, t, f, d, h| {
                field_inclusion(field, (t, f, d, h), Degree::Linear)
            },
        })
    }
}
