//! Quadratic mixed tracing (forward-inclusion 2023 §7.2, appendix C): quadratic Taylor
//! inclusions for each group, composed bottom-up through the blend tree (the maximum of
//! quadratic inclusions takes the maxima of their Bézier control points). Blends without a
//! forward-inclusion rule (Ricci) use the whole-field quadratic Taylor bound.

use crate::geometry::Ray;
use crate::inclusion::{self, ForwardInclusion};
use crate::interval::Interval;
use crate::program::FieldProgram;

use super::marching::Marcher;
use super::{Method, RayTracer, TraceSettings};

/// `quadratic-mixed`.
pub struct QuadraticMixed;

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
        Box::new(Marcher {
            program,
            settings,
            bound: |p: &FieldProgram, ray: &Ray, t: f64, f: f64, d: f64, h: f64| {
                let span = Interval::new(t, t + h);
                let groups: Vec<ForwardInclusion> = p
                    .group_values_along_ray(ray, t)
                    .iter()
                    .zip(&p.ray_group_jets(ray, span))
                    .map(|(&(g, dg), jet)| ForwardInclusion::quadratic(g, dg, jet, h))
                    .collect();
                inclusion::blend(p.blend(), &groups, p.isovalue())
                    .unwrap_or_else(|| ForwardInclusion::quadratic(f, d, &p.ray_jet(ray, span), h))
            },
        })
    }
}
