//! Linear Taylor tracing (forward-inclusion 2023 §5.1, appendix A): asymmetric linear bounds
//! `f(t) + [min f′, max f′]·s` on `[t, t + h]`, from the field engine's exact per-primitive
//! derivative analysis composed through the blend tree.

use crate::geometry::Ray;
use crate::inclusion::ForwardInclusion;
use crate::interval::Interval;
use crate::program::FieldProgram;

use super::marching::march;
use super::{Method, RayTracer, Trace, TraceMode, TraceSettings, trace_supports};

/// `linear-taylor`.
pub struct LinearTaylor;

struct Prepared<'a> {
    program: &'a FieldProgram,
    settings: TraceSettings,
}

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
        Box::new(Prepared { program, settings })
    }
}

impl RayTracer for Prepared<'_> {
    fn trace(&self, ray: &Ray, span: Interval, mode: TraceMode) -> Trace {
        let s = &self.settings;
        trace_supports(self.program, ray, span, mode, s.max_steps, |part, trace| {
            march(self.program, ray, part, s, mode, trace, |t, f, _, h| {
                let jet = self.program.ray_jet(ray, Interval::new(t, t + h));
                ForwardInclusion::linear(f, &jet, h)
            });
        })
    }
}
