//! The reference root finder (MATH.md §7): interval bisection with the field engine's value
//! enclosures. An interval `[a, b]` holds no crossing, and is dropped, when the enclosure of `f`
//! lies on one side of the isovalue or when `|f(m) − c| > λ(b − a)/2` with `m` the midpoint and
//! `λ` the local Lipschitz bound (the test of MATH.md §7, which tightens as intervals shrink),
//! both with a slack of 10⁻¹⁰ for rounding. Others are split, left half first, down to a width
//! of 10⁻⁷ of the scene diagonal, where a sign change between the end points locates a crossing
//! (refined by bisection on the sign change); jumps across `c` at an HRBF set's box are
//! crossings (`trace_supports`). Every true crossing is found, except pairs closer together
//! than that width. Slow; it is the ground truth of the statistics and the tests.

use super::MethodId;
use crate::bounds::interval::Interval;
use crate::field::program::FieldProgram;
use crate::field::ray_field::RayField;

use super::{
    Crossing, Method, RayTracer, Trace, TraceMode, TraceSettings, excludes_isovalue, trace_supports,
};

/// `reference`.
pub struct Reference;

/// Most bisection steps the reference takes on one ray: a ray of a sound field needs far fewer
/// (the depth of the bisection is `log2(span / resolution)`, about 24, times the intervals
/// near the surface); one that spends them all is reported by the statistics instead of
/// spinning for minutes.
pub const REFERENCE_STEP_BUDGET: u32 = 1 << 22;

struct Prepared<'a> {
    program: &'a FieldProgram,
    settings: TraceSettings,
    resolution: f64,
}

impl Method for Reference {
    fn id(&self) -> MethodId {
        MethodId::Reference
    }

    fn is_conservative(&self) -> bool {
        true
    }

    fn scene_inputs(&self, _: &FieldProgram) -> Vec<f64> {
        // Its resolution follows the scale bounds, a global the caller compares.
        Vec::new()
    }

    fn prepare<'a>(
        &self,
        program: &'a FieldProgram,
        settings: TraceSettings,
    ) -> Box<dyn RayTracer + 'a> {
        let b = program.scale_bounds();
        let diagonal = if b.is_empty() { 1.0 } else { b.diagonal() };
        Box::new(Prepared {
            program,
            settings: TraceSettings {
                max_steps: REFERENCE_STEP_BUDGET,
                ..settings
            },
            resolution: 1e-7 * diagonal,
        })
    }
}

impl Prepared<'_> {
    fn below(&self, field: &RayField, t: f64, trace: &mut Trace) -> bool {
        trace.evaluations += 1;
        field.value(t) < self.program.isovalue()
    }
}

impl RayTracer for Prepared<'_> {
    fn program(&self) -> &FieldProgram {
        self.program
    }

    fn trace_field(&self, field: &RayField, mode: TraceMode) -> Trace {
        let span = field.span();
        let c = self.program.isovalue();
        trace_supports(field, span, mode, self.settings.max_steps, |part, trace| {
            let mut stack = vec![part];
            while let Some(i) = stack.pop() {
                trace.steps += 1;
                let jet = field.jet(i);
                let mid = 0.5 * (i.lo + i.hi);
                trace.evaluations += 1;
                let f_mid = field.value(mid);
                // The Lipschitz test: `f` stays within `reach` of `f(mid)` on the interval.
                let reach = 0.5 * i.width() * jet.d1.magnitude();
                let lipschitz_range = Interval::new(f_mid - reach, f_mid + reach);
                if excludes_isovalue(jet.value, c) || excludes_isovalue(lipschitz_range, c) {
                    continue;
                }
                if i.width() > self.resolution {
                    stack.push(Interval::new(mid, i.hi));
                    stack.push(Interval::new(i.lo, mid));
                    continue;
                }
                let (mut lo, mut hi) = (i.lo, i.hi);
                let below_lo = self.below(field, lo, trace);
                if below_lo == self.below(field, hi, trace) {
                    continue;
                }
                for _ in 0..20 {
                    let mid = 0.5 * (lo + hi);
                    if self.below(field, mid, trace) == below_lo {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                trace.push_crossing(Crossing {
                    t: 0.5 * (lo + hi),
                    entering: below_lo,
                });
                if mode == TraceMode::Opaque {
                    return;
                }
            }
        })
    }
}
