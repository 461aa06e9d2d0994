//! Quadratic Taylor tracing (forward-inclusion 2023 §6.1, appendix A): bounds
//! `f(t) + f′(t)·s + ½·[min f″, max f″]·s²` on `[t, t + h]`. Where the interval contains a kink
//! (a max blend switching operands, a clipped kernel's support boundary) the second derivative
//! is unbounded on one side and that side falls back to the linear Taylor bound.

use crate::geometry::Ray;
use crate::inclusion::ForwardInclusion;
use crate::interval::Interval;
use crate::program::FieldProgram;

use super::marching::march;
use super::{Method, RayTracer, Trace, TraceMode, TraceSettings, trace_supports};

/// `quadratic-taylor`.
pub struct QuadraticTaylor;

struct Prepared<'a> {
    program: &'a FieldProgram,
    settings: TraceSettings,
}

impl Method for QuadraticTaylor {
    fn name(&self) -> &'static str {
        "quadratic-taylor"
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
            march(self.program, ray, part, s, mode, trace, |t, f, d, h| {
                let jet = self.program.ray_jet(ray, Interval::new(t, t + h));
                ForwardInclusion::quadratic(f, d, &jet, h)
            });
        })
    }
}
