//! Revised affine arithmetic with bisection (forward-inclusion 2023 Table 1 baseline;
//! MATH.md §8): the affine form of the field over each interval ([`crate::affine`]) prunes the
//! intervals that cannot hold the isovalue; the others are bisected.

use crate::affine::field_form;
use crate::geometry::Ray;
use crate::interval::Interval;
use crate::program::FieldProgram;

use super::bisection::bisect;
use super::{Method, RayTracer, Trace, TraceMode, TraceSettings, trace_supports};

/// `affine`.
pub struct AffineArithmetic;

struct Prepared<'a> {
    program: &'a FieldProgram,
    settings: TraceSettings,
}

impl Method for AffineArithmetic {
    fn name(&self) -> &'static str {
        "affine"
    }

    fn is_conservative(&self) -> bool {
        true
    }

    fn prepare<'a>(
        &self,
        program: &'a FieldProgram,
        settings: TraceSettings,
    ) -> Box<dyn RayTracer + 'a> {
        Box::new(Prepared { program, settings })
    }
}

impl RayTracer for Prepared<'_> {
    fn trace(&self, ray: &Ray, span: Interval, mode: TraceMode) -> Trace {
        let (p, s) = (self.program, &self.settings);
        trace_supports(p, ray, span, mode, s.max_steps, |part, trace| {
            bisect(p, ray, part, s, mode, trace, |i, trace| {
                trace.evaluations += 1;
                Some(field_form(p, ray, i).map_or_else(|| p.ray_jet(ray, i).value, |f| f.range()))
            });
        })
    }
}
