//! The SCALIS ray tracer (scalis 2021 §5–7): the ray is cut at the support boundaries and at
//! the minima of each segment's homothetic distance along it (§5.2, eq. 16–19); on each piece
//! the normalised field `F = g∘f − 1` (§4) is interpolated from Hermite data at the ends by two
//! quadratic Bézier pieces that meet at the middle with the ordinate of eq. 20 (§6.1); the
//! first root of the interpolant is the estimate where the next Hermite data are taken, and the
//! piece shrinks towards the crossing (Algorithm 1, at most 32 iterations per piece, one step of
//! backtracking). Until a sign change isolates a root the oracle is the rational Bézier with
//! middle weight 3 (§6.2, figure 9), which hugs the control polygon and catches shallow dips.
//!
//! Steps are Hermite evaluations (value and gradient of the field, one each). At a support
//! limit (a part's end inside the ray's span) the field is 0 by construction and its data are
//! known without an evaluation (scalis 2021 §7): `F = σ² − 1`, and no slope, since `g′` is
//! unbounded where the field is 0 (evaluated a rounding error inside the support, `g′(f)·f′`
//! is a large number made of rounding errors, and whether the evaluation rounds to 0 or not
//! changed the march of up to 9 % of the pixels under camera moves of two f32 ulps). By
//! default the part starts at the limit, and the oracle takes the slope at such a flat end from
//! the quadratic through both ends' values and the other end's slope (the Hermite–Birkhoff
//! interpolant of §6.1, figure 7). Under `--protocol paper-2021` the part starts as the
//! paper's algorithm 2 does, one sphere-tracing step off the limit, and the slope at a flat end
//! is the secant of the piece. By default a crossing is accepted when the Newton distance `|F/F′|` is below
//! `epsilon`, and placed one Newton step from the last estimate; under `--protocol paper-2021`
//! it is accepted where `|F|` is small, at the estimate, as the paper's algorithm 1 does
//! ([`ScalisStop`]). Not guaranteed: the statistics count its misses.

use super::MethodId;
use crate::bounds::interval::Interval;
use crate::field::geometry::{Ray, SphereCone};
use crate::field::kernel::KernelProfile;
use crate::field::primitives::Primitive;
use crate::field::program::FieldProgram;
use crate::field::ray_field::RayField;
use crate::scratch::ScratchPool;

use super::normalised_field::{normalised, normalising_kernel, scalis_kernel, thinnest_radius_on};
use super::{
    Crossing, Method, RayTracer, ScalisStop, Trace, TraceMode, TraceSettings, trace_supports,
};

/// Iterations of Algorithm 1 per piece (scalis 2021 §6.2).
const ITERATIONS_PER_PIECE: u32 = 32;
/// Weight of the middle control point of the rational oracle (scalis 2021 §6.2).
const RATIONAL_WEIGHT: f64 = 3.0;

/// `scalis-quadratic`.
pub struct ScalisQuadratic;

struct Prepared<'a> {
    program: &'a FieldProgram,
    settings: TraceSettings,
    kernel: KernelProfile,
}

impl Method for ScalisQuadratic {
    fn id(&self) -> MethodId {
        MethodId::ScalisQuadratic
    }

    fn is_conservative(&self) -> bool {
        false
    }

    fn supports(&self, program: &FieldProgram) -> Result<(), String> {
        scalis_kernel(program, self.name()).map(|_| ())
    }

    fn scene_inputs(&self, _: &FieldProgram) -> Vec<f64> {
        // The normalising kernel is the groups' common one; the Hermite data are the ray's own.
        Vec::new()
    }

    fn prepare<'a>(
        &self,
        program: &'a FieldProgram,
        settings: TraceSettings,
    ) -> Box<dyn RayTracer + 'a> {
        let kernel = normalising_kernel(program);
        Box::new(Prepared {
            program,
            settings,
            kernel,
        })
    }
}

/// Hermite data of the (oriented) normalised field.
#[derive(Clone, Copy, Debug)]
struct Hermite {
    t: f64,
    v: f64,
    d: f64,
    /// The field is 0 here: `d` is meaningless.
    flat: bool,
}

impl Hermite {
    fn flipped(self, sign: f64) -> Self {
        Self {
            v: sign * self.v,
            d: sign * self.d,
            ..self
        }
    }
}

/// Ray parameter of the minimum of the homothetic distance from `cone` to the ray (scalis 2021
/// §5.2): the minimum over the skeleton parameter `s` of `d⊥²(s)/τ(s)²` is at an end or where
/// the derivative of this rational function vanishes (a linear equation).
fn homothetic_argmin(cone: &SphereCone, ray: &Ray) -> f64 {
    let m = cone.start - ray.origin;
    let perp = |v: glam::DVec3| v - v.dot(ray.direction) * ray.direction;
    let (m_p, u_p) = (perp(m), perp(cone.axis));
    let (a, b, c) = (m_p.length_squared(), m_p.dot(u_p), u_p.length_squared());
    let (tau0, delta) = (cone.radius, cone.slope);
    let ratio = |s: f64| (a + s * (2.0 * b + c * s)) / (tau0 + delta * s).powi(2);
    let denominator = c * tau0 - delta * b;
    let mut best = (ratio(0.0), 0.0);
    let mut consider = |s: f64| {
        let r = ratio(s);
        if r < best.0 {
            best = (r, s);
        }
    };
    consider(cone.length);
    if denominator.abs() > 0.0 {
        let s = (delta * a - b * tau0) / denominator;
        if (0.0..=cone.length).contains(&s) {
            consider(s);
        }
    }
    (cone.start + best.1 * cone.axis - ray.origin).dot(ray.direction)
}

/// First root in `[0, 1]` of the rational quadratic Bézier `(p0, w·p1, p2)` and its abscissa
/// on the control abscissas `(x0, x1, x2)`.
fn bezier_root(p: [f64; 3], x: [f64; 3], w: f64) -> Option<f64> {
    // Numerator p0(1−u)² + 2w·p1·u(1−u) + p2·u².
    let (a, b, c) = (p[0] - 2.0 * w * p[1] + p[2], 2.0 * (w * p[1] - p[0]), p[0]);
    let u = crate::field::geometry::quadratic_roots(a, b, c)
        .map(|(r1, r2)| [r1, r2])
        .into_iter()
        .flatten()
        .filter(|u| (0.0..=1.0).contains(u))
        .reduce(f64::min)?;
    let basis = [(1.0 - u) * (1.0 - u), 2.0 * w * u * (1.0 - u), u * u];
    let weight: f64 = basis.iter().sum();
    Some((basis[0] * x[0] + basis[1] * x[1] + basis[2] * x[2]) / weight)
}

/// The slope the oracle gives a flat end (one without a slope: a support limit).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum FlatSlope {
    /// The secant of the piece.
    Secant,
    /// The slope of the quadratic through both values and the other end's slope (the
    /// Hermite–Birkhoff interpolant, scalis 2021 §6.1 figure 7); the secant when both are flat.
    Birkhoff,
}

/// The oracle: first root of the two-piece quadratic interpolation of `b`, `e` (eq. 20), with
/// middle weight `w` (1: polynomial, 3: rational).
fn oracle(b: Hermite, e: Hermite, w: f64, flat_slope: FlatSlope) -> Option<f64> {
    let l = e.t - b.t;
    let secant = (e.v - b.v) / l;
    let (bd, ed) = match (b.flat, e.flat, flat_slope) {
        (false, false, _) => (b.d, e.d),
        (true, true, _) => (secant, secant),
        (true, false, FlatSlope::Secant) => (secant, e.d),
        (false, true, FlatSlope::Secant) => (b.d, secant),
        (true, false, FlatSlope::Birkhoff) => (2.0 * secant - e.d, e.d),
        (false, true, FlatSlope::Birkhoff) => (b.d, 2.0 * secant - b.d),
    };
    let mid = 0.5 * (b.v + e.v) + 0.125 * l * (bd - ed);
    let tm = b.t + 0.5 * l;
    bezier_root(
        [b.v, b.v + 0.25 * l * bd, mid],
        [b.t, b.t + 0.25 * l, tm],
        w,
    )
    .or_else(|| {
        bezier_root(
            [mid, e.v - 0.25 * l * ed, e.v],
            [tm, e.t - 0.25 * l, e.t],
            w,
        )
    })
}

impl Prepared<'_> {
    fn hermite(&self, field: &RayField, t: f64, trace: &mut Trace) -> Hermite {
        trace.steps += 1;
        trace.evaluations += 1;
        let (v, d) = normalised(field, &self.kernel, t);
        Hermite {
            t,
            v,
            d,
            flat: v >= self.kernel.support_sq() - 1.0,
        }
    }

    /// Support boundaries and homothetic-distance minima inside `part`, sorted, at least
    /// `min_step` apart, into `points` (cleared first).
    fn breakpoints_into(&self, field: &RayField, part: Interval, points: &mut Vec<f64>) {
        points.clear();
        points.push(part.lo);
        field.for_each_primitive(part, |_, p, _, _| {
            if let Primitive::Scalis(s) = p {
                points.push(homothetic_argmin(&s.cone, field.ray()));
            }
        });
        points.retain(|t| (part.lo..part.hi).contains(t));
        points.sort_by(f64::total_cmp);
        // Keep each point at least `gap` past the last one kept (`dedup_by` compares a point
        // with the last one kept and removes it where that returns true).
        let gap = self.settings.min_step;
        points.dedup_by(|t, last| *t - *last < gap);
        if part.hi - points.last().copied().unwrap_or(part.lo) < gap && points.len() > 1 {
            points.pop();
        }
        points.push(part.hi);
    }

    /// Algorithm 1 on one piece whose start value is ≥ 0 after orienting by `sign`: the
    /// Hermite data at the crossing, if one is found.
    fn find_root(
        &self,
        field: &RayField,
        (mut b, mut e): (Hermite, Hermite),
        sign: f64,
        trace: &mut Trace,
    ) -> Option<Hermite> {
        let eps = self.settings.epsilon;
        let mut saved: Option<(Hermite, Hermite)> = None;
        for _ in 0..ITERATIONS_PER_PIECE {
            if trace.steps >= self.settings.max_steps {
                return None;
            }
            if e.t - b.t < eps {
                return (e.v < 0.0).then_some(e);
            }
            let w = if e.v < 0.0 { 1.0 } else { RATIONAL_WEIGHT };
            let Some(t) = oracle(b, e, w, self.flat_slope()) else {
                let (nb, ne) = saved.take()?;
                (b, e) = (nb, ne);
                continue;
            };
            let r = self.hermite(field, t, trace).flipped(sign);
            let converged = match self.settings.protocol.scalis_stop() {
                ScalisStop::NewtonDistance => r.v.abs() <= r.d.abs() * eps,
                ScalisStop::Value(threshold) => r.v.abs() < threshold,
            };
            if converged || r.v == 0.0 {
                return Some(r);
            }
            let rising = r.d > 0.0 && b.d < 0.0;
            if saved.is_none() && r.v >= 0.0 && e.v < 0.0 && rising {
                saved = Some((r, e));
            }
            if r.v < 0.0 || rising {
                e = r;
            } else {
                b = r;
            }
        }
        None
    }

    /// Crossings on the piece `[b, e]` (all of them in transparent mode).
    fn trace_piece(
        &self,
        field: &RayField,
        (mut b, e): (Hermite, Hermite),
        mode: TraceMode,
        trace: &mut Trace,
    ) {
        loop {
            let sign = if b.v >= 0.0 { 1.0 } else { -1.0 };
            let Some(r) = self.find_root(field, (b.flipped(sign), e.flipped(sign)), sign, trace)
            else {
                return;
            };
            let newton = match self.settings.protocol.scalis_stop() {
                ScalisStop::NewtonDistance if r.d != 0.0 => r.t - r.v / r.d,
                _ => r.t,
            };
            let t = if (b.t..=e.t).contains(&newton) {
                newton
            } else {
                r.t
            };
            trace.push_crossing(Crossing {
                t,
                entering: sign > 0.0,
            });
            let next = t + self.settings.min_step;
            if mode == TraceMode::Opaque || next >= e.t || trace.steps >= self.settings.max_steps {
                return;
            }
            b = self.hermite(field, next, trace);
        }
    }
}

impl Prepared<'_> {
    fn flat_slope(&self) -> FlatSlope {
        if self.settings.protocol.scalis_sphere_step_entry() {
            FlatSlope::Secant
        } else {
            FlatSlope::Birkhoff
        }
    }

    /// Hermite data at a support limit, where the field is 0: known without an evaluation
    /// (scalis 2021 §7, algorithm 2).
    fn at_support_limit(&self, t: f64) -> Hermite {
        Hermite {
            t,
            v: self.kernel.support_sq() - 1.0,
            d: 0.0,
            flat: true,
        }
    }

    /// The paper's entry into a support part: one sphere-tracing step off the support limit,
    /// where the normalised distance is `σ − 1` radii and the normalised field is
    /// `1/τ_min`-Lipschitz (appendix B), without an evaluation; `None` when it leaves the part.
    fn sphere_step_in(&self, field: &RayField, part: Interval) -> Option<f64> {
        let tau = thinnest_radius_on(field, part);
        let step = (self.kernel.support_radius() - 1.0) * tau;
        let start = part.lo + if step.is_finite() { step.max(0.0) } else { 0.0 };
        (start < part.hi).then_some(start)
    }
}

impl RayTracer for Prepared<'_> {
    fn program(&self) -> &FieldProgram {
        self.program
    }

    fn trace_field(&self, field: &RayField, mode: TraceMode) -> Trace {
        let span = field.span();
        let s = &self.settings;
        let sphere_step_entry = s.protocol.scalis_sphere_step_entry();
        thread_local! {
            static BREAKPOINTS: ScratchPool<Vec<f64>> = const { ScratchPool::new() };
        }
        let mut points = ScratchPool::take(&BREAKPOINTS);
        let trace = trace_supports(field, span, mode, s.max_steps, |part, trace| {
            self.breakpoints_into(field, part, &mut points);
            if sphere_step_entry {
                let Some(start) = self.sphere_step_in(field, part) else {
                    return;
                };
                points.retain(|&t| t > start);
                points.insert(0, start);
            }
            // A part's ends inside the span are support limits; under the paper's protocol,
            // every part's end is taken as one, as its algorithm 2 does.
            let at_limit = |t: f64| {
                (t == part.lo && part.lo > span.lo && !sphere_step_entry)
                    || (t == part.hi && (part.hi < span.hi || sphere_step_entry))
            };
            let data = |t: f64, trace: &mut Trace| {
                if at_limit(t) {
                    self.at_support_limit(t)
                } else {
                    self.hermite(field, t, trace)
                }
            };
            let mut b = data(points[0], trace);
            for &t in &points[1..] {
                if trace.steps >= s.max_steps {
                    return;
                }
                let e = data(t, trace);
                let found = trace.crossings.len();
                self.trace_piece(field, (b, e), mode, trace);
                if mode == TraceMode::Opaque && trace.crossings.len() > found {
                    return;
                }
                b = e;
            }
        });
        ScratchPool::give_back(&BREAKPOINTS, points);
        trace
    }
}
