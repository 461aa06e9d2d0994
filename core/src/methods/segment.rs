//! Segment tracing (Galin et al. 2020; forward-inclusion eq. 11): sphere tracing with a local
//! directional Lipschitz bound on the next ray interval `[t, t + h]`, computed as segment tracing
//! does — the sum of the primitives' own bounds ([`FieldProgram::summed_lipschitz`]); `h` grows
//! as `k ×` the last step.

use crate::geometry::Ray;
use crate::interval::Interval;
use crate::program::FieldProgram;

use super::marching::{march, symmetric};
use super::{Method, RayTracer, Trace, TraceMode, TraceSettings, trace_supports};

/// `segment`.
pub struct SegmentTracing;

struct Prepared<'a> {
    program: &'a FieldProgram,
    settings: TraceSettings,
}

impl Method for SegmentTracing {
    fn name(&self) -> &'static str {
        "segment"
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
        let s = &self.settings;
        trace_supports(self.program, ray, span, mode, s.max_steps, |part, trace| {
            march(self.program, ray, part, s, mode, trace, |t, f, _, h| {
                let lambda = self
                    .program
                    .directional_lipschitz(ray, Interval::new(t, t + h));
                symmetric(f, lambda, h)
            });
        })
    }
}
