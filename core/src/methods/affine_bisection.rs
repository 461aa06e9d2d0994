//! Revised affine arithmetic with bisection (forward-inclusion 2023 Table 1 baseline;
//! MATH.md §8): the affine form of the field over each interval ([`crate::bounds::affine`]) prunes the
//! intervals that cannot hold the isovalue; the others are bisected.

use super::MethodId;
use crate::bounds::affine::field_form;
use crate::bounds::interval::Interval;
use crate::field::program::FieldProgram;
use crate::field::ray_field::RayField;

use super::bisection::Bisector;
use super::{Method, RayTracer, Trace, TraceSettings};

/// `affine`.
pub struct AffineArithmetic;

impl Method for AffineArithmetic {
    fn id(&self) -> MethodId {
        MethodId::Affine
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
                Some(field_form(field, i).map_or_else(|| field.jet(i).value, |f| f.range()))
            },
        })
    }
}
