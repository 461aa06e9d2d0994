//! Linear mixed tracing (forward-inclusion 2023 §7.2): linear Taylor inclusions for each group
//! (the sums of primitives, where derivatives are easy to bound), composed bottom-up through the
//! blend tree — the max keeps its kink instead of widening the derivative bounds of the whole
//! field. Blends without a forward-inclusion rule (Ricci) use the whole-field Taylor bound.

use crate::geometry::Ray;
use crate::inclusion::{self, ForwardInclusion};
use crate::interval::Interval;
use crate::program::FieldProgram;

use super::marching::Marcher;
use super::{Method, RayTracer, TraceSettings};

/// `linear-mixed`.
pub struct LinearMixed;

impl Method for LinearMixed {
    fn name(&self) -> &'static str {
        "linear-mixed"
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
            bound: |p: &FieldProgram, ray: &Ray, t: f64, f: f64, _: f64, h: f64| {
                let span = Interval::new(t, t + h);
                let groups: Vec<ForwardInclusion> = p
                    .group_values_along_ray(ray, t)
                    .iter()
                    .zip(&p.ray_group_jets(ray, span))
                    .map(|(&(g, _), jet)| ForwardInclusion::linear(g, jet, h))
                    .collect();
                inclusion::blend(p.blend(), &groups, p.isovalue())
                    .unwrap_or_else(|| ForwardInclusion::linear(f, &p.ray_jet(ray, span), h))
            },
        })
    }
}
