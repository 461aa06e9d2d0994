//! The ray-marching loop shared by the methods that step on forward inclusion functions
//! (forward-inclusion 2023, algorithm 1): at `t`, a bound valid on `[t, t + h]` gives the first
//! point where the field could reach the isovalue — the first root of the upper bound when
//! outside, of the lower bound when inside. The march advances to it (or to `t + h` when there
//! is none), and the next interval is `k` times the step just taken. A crossing is reported when
//! the step falls below `epsilon` and the field is on the other side of the isovalue `min_step`
//! further on (otherwise the march goes on: the bound came close to `c`, the field did not).

use crate::bounds::inclusion::{self, ForwardInclusion, Offset};
use crate::bounds::interval::{Interval, Jet};
use crate::field::geometry::quadratic_roots;
use crate::field::program::FieldProgram;
use crate::field::ray_field::RayField;

use super::{
    Crossing, RayTracer, StepRecord, Trace, TraceMode, TraceSettings, trace_supports_into,
};

/// First `s ∈ [0, limit]` where `start + offset(s)` reaches `target`, if any.
pub(crate) fn first_reach(start: f64, offset: Offset, target: f64, limit: f64) -> Option<f64> {
    let roots = quadratic_roots(offset.b, offset.a, start - target)?;
    [roots.0, roots.1]
        .into_iter()
        .filter(|s| (0.0..=limit).contains(s))
        .reduce(f64::min)
}

/// Whether a marching method's bound uses `f′(t)`: where it does not, the march evaluates the
/// field without its gradient and passes NaN as `f′(t)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Slope {
    Used,
    Unused,
}

/// Marches over `part` with `bound(t, f(t), f′(t), h)`, appending to `trace`.
pub(crate) fn march(
    field: &RayField,
    part: Interval,
    (settings, slope): (&TraceSettings, Slope),
    mode: TraceMode,
    trace: &mut Trace,
    bound: impl Fn(f64, f64, f64, f64) -> ForwardInclusion,
) {
    let c = field.program().isovalue();
    let mut t = part.lo;
    let mut h = settings.initial_interval;
    // The previous sample and its side, to catch a step that landed on or past a crossing.
    let mut previous: Option<(f64, bool)> = None;
    while t < part.hi && trace.steps < settings.max_steps {
        trace.steps += 1;
        trace.evaluations += 1;
        // The derivative only where the bound or the step log uses it (`f` is the same).
        let (f, d) = if slope == Slope::Used || trace.log.is_some() {
            field.along(t)
        } else {
            (field.value(t), f64::NAN)
        };
        let inside = f >= c;
        if let Some((t_prev, was_inside)) = previous
            && was_inside != inside
        {
            let at = bisect_sign_change(field, (t_prev, t), was_inside, settings, trace);
            trace.push_crossing(Crossing {
                t: at,
                entering: inside,
            });
            if mode == TraceMode::Opaque {
                return;
            }
            // Past any crossing the march starts its intervals afresh, as after a confirmed
            // one below. Where a step lands on the surface, rounding puts it on either side:
            // just short, the crossing is confirmed and the march resumes `min_step` past it;
            // just past, it is this sign change, and the march resumes at the same place, so
            // that which side one ulp of the field falls on does not change the steps that
            // follow (in f32 on the GPU the second is as frequent as the first).
            h = settings.initial_interval;
            // The sample stays the previous one: a crossing back before `resume` is then a
            // sign change there.
            let resume = at + settings.min_step;
            if t < resume {
                previous = Some((t, inside));
                t = resume;
                continue;
            }
        }
        previous = Some((t, inside));
        let h_now = h.max(settings.min_step).min(part.hi - t);
        let inclusion = bound(t, f, d, h_now);
        let limit = inclusion.length.min(part.hi - t);
        let offset = if inside {
            inclusion.lower
        } else {
            inclusion.upper
        };
        let reach = first_reach(f, offset, c, limit);
        if let Some(log) = trace.log.as_mut() {
            log.push(StepRecord {
                t,
                f,
                slope: d,
                bound: inclusion,
                step: reach.unwrap_or(limit),
            });
        }
        match reach {
            Some(s) if s < settings.epsilon => {
                // Confirm: the field must be on the other side of c just past the root.
                trace.evaluations += 1;
                let beyond = t + s + settings.min_step;
                if (field.value(beyond) >= c) == inside {
                    t += s.max(f64::EPSILON * t.abs());
                    h = settings.min_step;
                    continue;
                }
                trace.push_crossing(Crossing {
                    t: t + s,
                    entering: !inside,
                });
                if mode == TraceMode::Opaque {
                    return;
                }
                t = beyond;
                h = settings.initial_interval;
                previous = None;
            }
            Some(s) => {
                t = advance(t, s, part.hi);
                h = settings.growth * s;
            }
            None => {
                t = advance(t, limit, part.hi);
                h = settings.growth * limit;
            }
        }
    }
}

/// Relative distance below which a step's end is the part's end (64 ulps).
const SNAP_TO_END: f64 = 64.0 * f64::EPSILON;

/// `t + s`, or exactly `end` where that lands within rounding of it. A bound whose validity
/// ends where the part ends, computed another way (bottom-up-quadratic's interval for a ray
/// entering a blob's support ends at the point symmetric to the entry, the support's exit),
/// may land a few ulps short, and the march then took one more step over that sliver or not
/// by rounding: 1 % of the `blobs` pixels changed their counts under camera moves of 10⁻⁹.
fn advance(t: f64, s: f64, end: f64) -> f64 {
    let next = t + s;
    if end - next <= SNAP_TO_END * end.abs() {
        end
    } else {
        next
    }
}

/// The crossing between `lo` (on side `lo_inside`) and `hi` (on the other side), to within
/// `epsilon`, by bisection: where a step landed exactly on the surface (or, for the methods
/// without a guarantee, stepped over it).
fn bisect_sign_change(
    field: &RayField,
    (mut lo, mut hi): (f64, f64),
    lo_inside: bool,
    settings: &TraceSettings,
    trace: &mut Trace,
) -> f64 {
    while hi - lo > settings.epsilon {
        let mid = 0.5 * (lo + hi);
        trace.evaluations += 1;
        if (field.value(mid) >= field.program().isovalue()) == lo_inside {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

/// A symmetric linear bound `f(t) ± λ·s` on `[0, length]` (sphere and segment tracing as forward
/// inclusions, forward-inclusion eq. 10–11).
pub(crate) fn symmetric(start: f64, lambda: f64, length: f64) -> ForwardInclusion {
    ForwardInclusion {
        start,
        lower: Offset { a: -lambda, b: 0.0 },
        upper: Offset { a: lambda, b: 0.0 },
        length,
    }
}

/// A marching method bound to a scene: `bound(field, t, f(t), f′(t), h)` gives the forward
/// inclusion on `[t, t + h]`. Every inclusion-based method is this with its own bound.
pub(crate) struct Marcher<'a, B> {
    pub(crate) program: &'a FieldProgram,
    pub(crate) settings: TraceSettings,
    /// Whether `bound` uses `f′(t)`.
    pub(crate) slope: Slope,
    pub(crate) bound: B,
}

impl<B> RayTracer for Marcher<'_, B>
where
    B: Fn(&RayField, f64, f64, f64, f64) -> ForwardInclusion + Sync,
{
    fn program(&self) -> &FieldProgram {
        self.program
    }

    fn trace_field(&self, field: &RayField, mode: TraceMode) -> Trace {
        self.trace_into(Trace::default(), field, mode)
    }

    fn trace_field_logged(&self, field: &RayField, mode: TraceMode) -> Trace {
        let logged = Trace {
            log: Some(Vec::new()),
            ..Trace::default()
        };
        self.trace_into(logged, field, mode)
    }
}

impl<B> Marcher<'_, B>
where
    B: Fn(&RayField, f64, f64, f64, f64) -> ForwardInclusion + Sync,
{
    fn trace_into(&self, trace: Trace, field: &RayField, mode: TraceMode) -> Trace {
        let s = &self.settings;
        trace_supports_into(
            trace,
            field,
            field.span(),
            mode,
            s.max_steps,
            |part, trace| {
                march(field, part, (s, self.slope), mode, trace, |t, f, d, h| {
                    (self.bound)(field, t, f, d, h)
                });
            },
        )
    }
}

/// The mixed inclusion of forward-inclusion 2023 §7.2: `leaf(f_g(t), f_g′(t), jet_g, h)` for each
/// group, composed bottom-up through the blend tree; where the blend has no forward-inclusion
/// rule (smooth blends; Ricci where two operands may be positive), `leaf` applied to the whole field.
pub(crate) fn mixed_inclusion(
    field: &RayField,
    (t, f, d, h): (f64, f64, f64, f64),
    leaf: impl Fn(f64, f64, &Jet, f64) -> ForwardInclusion,
) -> ForwardInclusion {
    let span = Interval::new(t, t + h);
    let p = field.program();
    // Every group's value, slope and jet, then its inclusion, in slots on the stack.
    let composed = p.with_group_slots((0.0, 0.0), |values| {
        field.add_group_values(t, values);
        p.with_group_slots(Jet::ZERO, |jets| {
            field.add_group_jets(span, jets);
            p.with_group_slots(ForwardInclusion::zero(h), |groups| {
                for (group, (&(g, dg), jet)) in groups.iter_mut().zip(values.iter().zip(&*jets)) {
                    *group = leaf(g, dg, jet, h);
                }
                inclusion::blend(p.blend(), groups, p.isovalue())
            })
        })
    });
    composed.unwrap_or_else(|| leaf(f, d, &field.jet(span), h))
}
