//! Quadratic Taylor tracing (forward-inclusion 2023 §6.1, appendix A): bounds
//! `f(t) + f′(t)·s + ½·[min f″, max f″]·s²` on `[t, t + h]`. Where the interval contains a kink
//! (a max blend switching operands, a clipped kernel's support boundary) the second derivative
//! is unbounded on one side and that side falls back to the linear Taylor bound.

use super::MethodId;
use crate::bounds::inclusion::ForwardInclusion;
use crate::bounds::interval::Interval;
use crate::field::program::FieldProgram;
use crate::field::ray_field::RayField;

use super::marching::{Marcher, Slope};
use super::{Method, RayTracer, TraceSettings};

/// `quadratic-taylor`.
pub struct QuadraticTaylor;

impl Method for QuadraticTaylor {
    fn id(&self) -> MethodId {
        MethodId::QuadraticTaylor
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
                ForwardInclusion::quadratic(f, d, &field.jet(Interval::new(t, t + h)), h)
            },
        })
    }
}
