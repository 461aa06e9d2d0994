//! Interval bisection with pruning, the root finder of the self-validated baselines
//! (forward-inclusion 2023 Table 1: revised affine arithmetic and bottom-up linear bisection):
//! an interval whose enclosure of `f` excludes the isovalue (by more than its rounding error) is
//! dropped, others are split, left
//! half first, until they are shorter than `epsilon`; there a sign change between the end points
//! is a crossing. One step is one enclosure computed.

use crate::bounds::interval::Interval;
use crate::field::geometry::Ray;
use crate::field::program::FieldProgram;

use super::{
    Crossing, RayTracer, Trace, TraceMode, TraceSettings, excludes_isovalue, trace_supports,
};

/// Bisects `part`; `enclosure(interval, trace)` returns a range of `f` over the interval, or
/// `None` when it cannot bound it (the interval is then split).
fn bisect(
    program: &FieldProgram,
    ray: &Ray,
    part: Interval,
    settings: &TraceSettings,
    mode: TraceMode,
    trace: &mut Trace,
    enclosure: impl Fn(Interval, &mut Trace) -> Option<Interval>,
) {
    let c = program.isovalue();
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
        let below_lo = program.along_ray(ray, i.lo).0 < c;
        if below_lo == (program.along_ray(ray, i.hi).0 < c) {
            continue;
        }
        trace.crossings.push(Crossing {
            t: 0.5 * (i.lo + i.hi),
            entering: below_lo,
        });
        if mode == TraceMode::Opaque {
            return;
        }
    }
}

/// A bisection method bound to a scene: `enclosure(program, ray, interval, trace)` encloses
/// `f` over an interval. Every bisection-based method is this with its own enclosure.
pub(crate) struct Bisector<'a, E> {
    pub(crate) program: &'a FieldProgram,
    pub(crate) settings: TraceSettings,
    pub(crate) enclosure: E,
}

impl<E> RayTracer for Bisector<'_, E>
where
    E: Fn(&FieldProgram, &Ray, Interval, &mut Trace) -> Option<Interval> + Sync,
{
    fn trace(&self, ray: &Ray, span: Interval, mode: TraceMode) -> Trace {
        let (p, s) = (self.program, &self.settings);
        trace_supports(p, ray, span, mode, s.max_steps, |part, trace| {
            bisect(p, ray, part, s, mode, trace, |i, trace| {
                (self.enclosure)(p, ray, i, trace)
            });
        })
    }
}
