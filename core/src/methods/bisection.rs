//! Interval bisection with pruning, the root finder of the self-validated baselines
//! (forward-inclusion 2023 Table 1: revised affine arithmetic and bottom-up linear bisection):
//! an interval whose enclosure of `f` excludes the isovalue (by more than its rounding error) is
//! dropped, others are split, left
//! half first, until they are shorter than `epsilon`; there a sign change between the end points
//! is a crossing. One step is one enclosure computed.

use crate::bounds::interval::Interval;
use crate::field::program::FieldProgram;
use crate::field::ray_field::RayField;

use super::{
    Crossing, RayTracer, Trace, TraceMode, TraceSettings, excludes_isovalue, trace_supports,
};

/// Bisects `part`; `enclosure(interval, trace)` returns a range of `f` over the interval, or
/// `None` when it cannot bound it (the interval is then split).
fn bisect(
    field: &RayField,
    part: Interval,
    settings: &TraceSettings,
    mode: TraceMode,
    trace: &mut Trace,
    enclosure: impl Fn(Interval, &mut Trace) -> Option<Interval>,
) {
    let c = field.program().isovalue();
    let mut stack = vec![part];
    while let Some(i) = stack.pop() {
        if trace.steps >= settings.max_steps {
            return;
        }
        trace.steps += 1;
        if enclosure(i, trace).is_some_and(|r| excludes_isovalue(r, c)) {
            continue;
        }
        if i.width() > settings.epsilon {
            let mid = 0.5 * (i.lo + i.hi);
            stack.push(Interval::new(mid, i.hi));
            stack.push(Interval::new(i.lo, mid));
            continue;
        }
        trace.evaluations += 2;
        let below_lo = field.value(i.lo) < c;
        if below_lo == (field.value(i.hi) < c) {
            continue;
        }
        trace.push_crossing(Crossing {
            t: 0.5 * (i.lo + i.hi),
            entering: below_lo,
        });
        if mode == TraceMode::Opaque {
            return;
        }
    }
}

/// A bisection method bound to a scene: `enclosure(field, interval, trace)` encloses
/// `f` over an interval. Every bisection-based method is this with its own enclosure.
pub(crate) struct Bisector<'a, E> {
    pub(crate) program: &'a FieldProgram,
    pub(crate) settings: TraceSettings,
    pub(crate) enclosure: E,
}

impl<E> RayTracer for Bisector<'_, E>
where
    E: Fn(&RayField, Interval, &mut Trace) -> Option<Interval> + Sync,
{
    fn program(&self) -> &FieldProgram {
        self.program
    }

    fn trace_field(&self, field: &RayField, mode: TraceMode) -> Trace {
        let span = field.span();
        let s = &self.settings;
        trace_supports(field, span, mode, s.max_steps, |part, trace| {
            bisect(field, part, s, mode, trace, |i, trace| {
                (self.enclosure)(field, i, trace)
            });
        })
    }
}
