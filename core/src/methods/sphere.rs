//! Sphere tracing with a global Lipschitz bound (numerical ray tracing notes 2014 §6; Hart 1996):
//! from `t`, no crossing lies closer than `|f(t) − c| / L`, so the ray advances by that much; a
//! crossing is reported when the step falls below `epsilon` and the field is on the other side of
//! the isovalue `min_step` further on. `L` is
//! [`FieldProgram::global_lipschitz`]: the largest sum of primitive Lipschitz constants over
//! overlapping supports.

use crate::geometry::Ray;
use crate::interval::Interval;
use crate::program::FieldProgram;

use super::marching::{march, symmetric};
use super::{Method, RayTracer, Trace, TraceMode, TraceSettings, trace_supports};

/// `sphere`.
pub struct SphereTracing;

struct Prepared<'a> {
    program: &'a FieldProgram,
    settings: TraceSettings,
    lipschitz: f64,
}

impl Method for SphereTracing {
    fn name(&self) -> &'static str {
        "sphere"
    }

    fn is_conservative(&self) -> bool {
        true
    }

    fn prepare<'a>(
        &self,
        program: &'a FieldProgram,
        settings: TraceSettings,
    ) -> Box<dyn RayTracer + 'a> {
        Box::new(Prepared {
            program,
            settings,
            lipschitz: program.global_lipschitz(),
        })
    }
}

impl RayTracer for Prepared<'_> {
    fn trace(&self, ray: &Ray, span: Interval, mode: TraceMode) -> Trace {
        let s = &self.settings;
        trace_supports(self.program, ray, span, mode, s.max_steps, |part, trace| {
            march(self.program, ray, part, s, mode, trace, |_, f, _, _| {
                symmetric(f, self.lipschitz, f64::INFINITY)
            });
        })
    }
}
