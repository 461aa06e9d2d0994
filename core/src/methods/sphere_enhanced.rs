//! Over-relaxed ("enhanced") sphere tracing (numerical ray tracing notes 2014 §12.1; Keinert et
//! al. 2014; MATH.md §6): steps of `ω·r` with `ω = 1.6` (`1.2`, the value the notes quote, under
//! `--protocol paper-2014`), where `r = |f − c|/L` is the unbounding
//! sphere radius. When the spheres at the old and new points do not overlap
//! (`r + r_prev < step`), the over-relaxed step may have skipped a crossing: the march goes back
//! to the previous point and continues with `ω = 1` (plain sphere tracing), so no crossing is
//! missed. A crossing is reported when `r < epsilon` and the field is on the other side of the
//! isovalue `min_step` further on.

use super::MethodId;
use crate::field::program::FieldProgram;
use crate::field::ray_field::RayField;

use super::{Crossing, Method, RayTracer, Trace, TraceMode, TraceSettings, trace_supports};

/// `sphere-enhanced`.
pub struct EnhancedSphereTracing;

struct Prepared<'a> {
    program: &'a FieldProgram,
    settings: TraceSettings,
    lipschitz: f64,
}

impl Method for EnhancedSphereTracing {
    fn id(&self) -> MethodId {
        MethodId::SphereEnhanced
    }

    fn is_conservative(&self) -> bool {
        true
    }

    fn scene_inputs(&self, program: &FieldProgram) -> Vec<f64> {
        vec![program.global_lipschitz()]
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
    fn program(&self) -> &FieldProgram {
        self.program
    }

    fn trace_field(&self, field: &RayField, mode: TraceMode) -> Trace {
        let span = field.span();
        let s = &self.settings;
        let c = self.program.isovalue();
        trace_supports(field, span, mode, s.max_steps, |part, trace| {
            let mut t = part.lo;
            let relaxed = s.protocol.over_relaxation();
            let mut omega = relaxed;
            let (mut previous_radius, mut step) = (0.0, 0.0);
            let mut side: Option<bool> = None;
            while t < part.hi && trace.steps < s.max_steps {
                trace.steps += 1;
                trace.evaluations += 1;
                let f = field.value(t);
                let inside = f >= c;
                let radius = (f - c).abs() / self.lipschitz;
                let crossed_side = side.is_some_and(|was| was != inside);
                if omega > 1.0 && (radius + previous_radius < step || crossed_side) {
                    // The spheres do not overlap: go back and stop over-relaxing.
                    t -= step;
                    step = 0.0;
                    omega = 1.0;
                    previous_radius = 0.0;
                    continue;
                }
                side = Some(inside);
                if radius < s.epsilon {
                    // Confirm the crossing on the other side, as the marching methods do.
                    trace.evaluations += 1;
                    let beyond = field.value(t + s.min_step) >= c;
                    if beyond == inside {
                        t += radius.max(f64::EPSILON * t.abs());
                        omega = 1.0;
                        step = radius;
                        previous_radius = radius;
                        continue;
                    }
                    trace.push_crossing(Crossing {
                        t,
                        entering: !inside,
                    });
                    if mode == TraceMode::Opaque {
                        return;
                    }
                    t += radius + s.min_step;
                    omega = relaxed;
                    previous_radius = 0.0;
                    step = 0.0;
                    side = None;
                    continue;
                }
                step = omega * radius;
                previous_radius = radius;
                t += step;
            }
        })
    }
}
