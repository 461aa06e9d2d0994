//! Quadratic mixed tracing (forward-inclusion 2023 §7.2, appendix C): quadratic Taylor
//! inclusions for each group, composed bottom-up through the blend tree (the maximum of
//! quadratic inclusions takes the maxima of their Bézier control points). Blends without a
//! forward-inclusion rule (Ricci) use the whole-field quadratic Taylor bound.

use crate::geometry::Ray;
use crate::inclusion::{self, ForwardInclusion};
use crate::interval::Interval;
use crate::program::FieldProgram;

use super::marching::march;
use super::{Method, RayTracer, Trace, TraceMode, TraceSettings, trace_supports};

/// `quadratic-mixed`.
pub struct QuadraticMixed;

struct Prepared<'a> {
    program: &'a FieldProgram,
    settings: TraceSettings,
}

impl Method for QuadraticMixed {
    fn name(&self) -> &'static str {
        "quadratic-mixed"
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
        let p = self.program;
        trace_supports(p, ray, span, mode, s.max_steps, |part, trace| {
            march(p, ray, part, s, mode, trace, |t, f, d, h| {
                let span = Interval::new(t, t + h);
                let jets = p.ray_group_jets(ray, span);
                let groups: Vec<ForwardInclusion> = p
                    .group_values_along_ray(ray, t)
                    .iter()
                    .zip(&jets)
                    .map(|(&(g, dg), jet)| ForwardInclusion::quadratic(g, dg, jet, h))
                    .collect();
                inclusion::blend(p.blend(), &groups, p.isovalue())
                    .unwrap_or_else(|| ForwardInclusion::quadratic(f, d, &p.ray_jet(ray, span), h))
            });
        })
    }
}
