//! Segment tracing as Galin et al. 2020 publish it, the baseline of the forward-inclusion
//! paper's Table 1 (2023 §7, appendix A): at `t`, the local Lipschitz bound `λ` of the candidate
//! segment `[t, t + s]` is the sum over primitives of the kernel's largest slope on the
//! segment's distance range times the largest cosine between ray and gradient of the distance
//! ([`PrimitiveSlope::Published`]); the march advances `max(min(|f − c|/λ, s), ε)` and the
//! next segment is 1.5 times that step. The first segment of each support part is the whole
//! part. A crossing is reported at the first sample on the other side of the isovalue (the
//! original's `v > 0` test), so the hit lies at most one minimum step `ε` past the surface, and
//! the minimum step may step over a sliver of the volume thinner than `ε`.
//!
//! `segment` is skeletrace's stronger variant: the exact range of each primitive's derivative,
//! growth 2, the shared march of the inclusion methods. Both are kept so that a comparison with
//! the paper uses the paper's baseline.

use super::MethodId;
use crate::bounds::interval::Interval;
use crate::field::program::{FieldProgram, PrimitiveSlope};
use crate::field::ray_field::RayField;

use super::{Crossing, Method, RayTracer, Trace, TraceMode, TraceSettings, trace_supports};

/// `segment-original`.
pub struct SegmentOriginal;

impl SegmentOriginal {
    /// Next segment length over last step (Galin et al. 2020, §5; the GPU's
    /// segment_original.wgsl takes it from here).
    pub const GROWTH: f64 = 1.5;
}

struct Prepared<'a> {
    program: &'a FieldProgram,
    settings: TraceSettings,
}

impl Method for SegmentOriginal {
    fn id(&self) -> MethodId {
        MethodId::SegmentOriginal
    }

    /// Its bound is conservative, but the minimum step is not: a part of the volume thinner
    /// than `ε` along the ray can be stepped over.
    fn is_conservative(&self) -> bool {
        false
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
        Box::new(Prepared { program, settings })
    }
}

impl Prepared<'_> {
    fn march(&self, field: &RayField, part: Interval, mode: TraceMode, trace: &mut Trace) {
        let c = self.program.isovalue();
        let min_step = self.settings.epsilon;
        let mut t = part.lo;
        let mut segment = part.hi - part.lo;
        let mut was_inside: Option<bool> = None;
        while t < part.hi && trace.steps < self.settings.max_steps {
            trace.steps += 1;
            trace.evaluations += 1;
            let f = field.value(t);
            let inside = f >= c;
            if was_inside.is_some_and(|w| w != inside) {
                trace.push_crossing(Crossing {
                    t,
                    entering: inside,
                });
                if mode == TraceMode::Opaque {
                    return;
                }
            }
            was_inside = Some(inside);
            let candidate = Interval::new(t, (t + segment).min(part.hi));
            let lambda = field.summed_lipschitz(candidate, PrimitiveSlope::Published);
            let step = ((f - c).abs() / lambda)
                .min(candidate.width())
                .max(min_step);
            t += step;
            segment = SegmentOriginal::GROWTH * step;
        }
    }
}

impl RayTracer for Prepared<'_> {
    fn program(&self) -> &FieldProgram {
        self.program
    }

    fn trace_field(&self, field: &RayField, mode: TraceMode) -> Trace {
        let span = field.span();
        trace_supports(field, span, mode, self.settings.max_steps, |part, trace| {
            self.march(field, part, mode, trace);
        })
    }
}
