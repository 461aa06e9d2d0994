//! Bottom-up linear inclusions with bisection (forward-inclusion 2023 §7.1, Table 1): the linear
//! bottom-up inclusion of [`crate::bounds::bottom_up`] built at the start of each interval encloses `f`
//! over it; intervals that cannot hold the isovalue are pruned, the others bisected.

use super::MethodId;
use crate::bounds::bottom_up::{Degree, field_inclusion};
use crate::bounds::interval::Interval;
use crate::field::program::FieldProgram;
use crate::field::ray_field::RayField;

use super::bisection::Bisector;
use super::{Method, RayTracer, Trace, TraceSettings};

/// `bottom-up-linear-bisection`.
pub struct BottomUpLinearBisection;

impl Method for BottomUpLinearBisection {
    fn id(&self) -> MethodId {
        MethodId::BottomUpLinearBisection
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
        Box::new(Bisector {
            program,
            settings,
            enclosure: |field: &RayField, i: Interval, trace: &mut Trace| {
                trace.evaluations += 1;
                let (f, d) = field.along(i.lo);
                let inc = field_inclusion(field, (i.lo, f, d, i.width()), Degree::Linear);
                // A shortened validity interval does not cover `i`: no enclosure.
                (inc.length >= i.width()).then(|| {
                    Interval::new(inc.start, inc.upper_at(inc.length))
                        .include(inc.lower_at(inc.length))
                })
            },
        })
    }
}
