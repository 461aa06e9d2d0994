//! Root-finding methods along rays: one [`Method`] trait, one file per method, one shared test
//! suite (`tests/methods.rs`). Every method traces a ray through the parts of its interval that
//! lie inside some primitive support (the CPU analogue of the scalis 2021 A-buffer; outside them
//! the field is 0 and no crossing can happen), counts its loop iterations as *steps* (as the
//! papers count them) and its point evaluations of the field, and reports crossings in order.
//!
//! Opaque mode stops at the first crossing; transparent mode reports all crossings (entries and
//! exits), as the forward-inclusion paper's transparency tables need.

mod affine_bisection;
mod bisection;
mod bottom_up_linear;
mod bottom_up_linear_bisection;
mod bottom_up_quadratic;
mod field_inversion;
mod id;
mod linear_mixed;
mod linear_taylor;
mod marching;
mod normalised_field;
mod protocol;
mod quadratic_mixed;
mod quadratic_taylor;
mod reference;
mod scalis_quadratic;
mod segment_original;
mod segment_tracing;
mod sherstyuk;
mod sphere;
mod sphere_accelerated;
mod sphere_enhanced;
mod sphere_normalized;

use crate::bounds::interval::Interval;
use crate::field::geometry::Ray;
use crate::field::program::FieldProgram;
use crate::field::ray_field::RayField;
use crate::scratch::ScratchPool;

pub use affine_bisection::AffineArithmetic;
pub use bottom_up_linear::BottomUpLinear;
pub use bottom_up_linear_bisection::BottomUpLinearBisection;
pub use bottom_up_quadratic::BottomUpQuadratic;
pub use field_inversion::FieldInversion;
pub use id::MethodId;
pub use linear_mixed::LinearMixed;
pub use linear_taylor::LinearTaylor;
pub use protocol::{Protocol, ScalisStop};
pub use quadratic_mixed::QuadraticMixed;
pub use quadratic_taylor::QuadraticTaylor;
pub use reference::{REFERENCE_STEP_BUDGET, Reference};
pub use scalis_quadratic::ScalisQuadratic;
pub use segment_original::SegmentOriginal;
pub use segment_tracing::SegmentTracing;
pub use sherstyuk::Sherstyuk;
pub use sphere::SphereTracing;
pub use sphere_accelerated::AcceleratedSphereTracing;
pub use sphere_enhanced::EnhancedSphereTracing;
pub use sphere_normalized::NormalizedSphereTracing;

/// Settings shared by every method.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceSettings {
    /// Convergence threshold on the ray parameter: a crossing is reported once the next safe
    /// step is shorter than this.
    pub epsilon: f64,
    /// Step taken past a crossing before marching on (transparent mode), and the shortest
    /// interval a bound is computed on.
    pub min_step: f64,
    /// Maximum loop iterations per ray.
    pub max_steps: u32,
    /// Next interval length = `growth` × last safe step (forward-inclusion §4.3: k = 2).
    pub growth: f64,
    /// First interval length of each support span (infinite: the whole span).
    pub initial_interval: f64,
    /// The profile these settings follow, for the choices particular to one method.
    pub protocol: Protocol,
}

impl TraceSettings {
    /// Defaults scaled to the scene: `epsilon` is 2·10⁻⁵ of the diagonal of the support box
    /// snapped to its grid (`FieldProgram::scale_bounds`, at most about a fifth longer than the
    /// box's own; well below the 10⁻⁴ depth accuracy the statistics check), 2048 steps at
    /// most, k = 2.
    #[must_use]
    pub fn for_program(program: &FieldProgram) -> Self {
        Self::for_protocol(program, Protocol::Default)
    }

    /// The settings of `protocol` ([`Protocol`]) scaled to the scene.
    #[must_use]
    pub fn for_protocol(program: &FieldProgram, protocol: Protocol) -> Self {
        let b = program.scale_bounds();
        let diagonal = if b.is_empty() { 1.0 } else { b.diagonal() };
        Self {
            epsilon: 2e-5 * diagonal,
            min_step: 1e-4 * diagonal,
            max_steps: 2048,
            growth: 2.0,
            initial_interval: if protocol.first_interval_is_whole_part() {
                f64::INFINITY
            } else {
                0.05 * diagonal
            },
            protocol,
        }
    }
}

/// Which crossings to report.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TraceMode {
    /// The first crossing only.
    Opaque,
    /// Every crossing, in order.
    Transparent,
}

/// A trace's crossings: up to two inline, more on the heap.
pub type Crossings = smallvec::SmallVec<[Crossing; 2]>;

/// A point where the field crosses the isovalue.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossing {
    /// Ray parameter.
    pub t: f64,
    /// `true` when the ray enters the volume (`f` rises through `c`).
    pub entering: bool,
}

/// The outcome of tracing one ray.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trace {
    /// Crossings found, in order: the first two inline, so that an opaque trace allocates
    /// nothing.
    pub crossings: Crossings,
    /// Loop iterations.
    pub steps: u32,
    /// Point evaluations of the field (value and gradient count as one).
    pub evaluations: u32,
    /// Loop iterations up to and including the one that found the last crossing (transparent
    /// statistics count these, as the forward-inclusion paper's Table 3 does).
    pub steps_to_last_crossing: u32,
    /// Point evaluations up to the last crossing.
    pub evaluations_to_last_crossing: u32,
    /// Every step of a marching method, when asked for ([`RayTracer::trace_logged`]).
    pub log: Option<Vec<StepRecord>>,
}

/// One step of a marching method (forward-inclusion 2023, algorithm 1): where it stood, the
/// field there, the bound it computed on `[t, t + bound.length]` and how far that bound let it
/// go (`step`: to the first point where the bound reaches `c`, or the bound's whole length).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepRecord {
    /// Ray parameter of the step's start.
    pub t: f64,
    /// `f(t)`.
    pub f: f64,
    /// `f′(t)` along the ray.
    pub slope: f64,
    /// The bounds: `f(t) + lower(s) ≤ f(t + s) ≤ f(t) + upper(s)` for `s ≤ length`.
    pub bound: crate::bounds::inclusion::ForwardInclusion,
    /// The advance the bound allows.
    pub step: f64,
}

impl Trace {
    /// Records a crossing found at the current step.
    pub(crate) fn push_crossing(&mut self, crossing: Crossing) {
        self.crossings.push(crossing);
        self.steps_to_last_crossing = self.steps;
        self.evaluations_to_last_crossing = self.evaluations;
    }

    /// The first crossing, if any.
    #[must_use]
    pub fn first(&self) -> Option<Crossing> {
        self.crossings.first().copied()
    }
}

/// A root-finding method.
pub trait Method: Sync {
    /// The method's identity.
    fn id(&self) -> MethodId;

    /// Command-line name (DESIGN.md).
    fn name(&self) -> &'static str {
        self.id().name()
    }

    /// Whether the method is guaranteed never to miss a crossing.
    fn is_conservative(&self) -> bool;

    /// `Err` with a reason when the method cannot trace this scene (wrong kernel, wrong
    /// primitive types).
    ///
    /// # Errors
    /// A message saying what the method needs.
    fn supports(&self, program: &FieldProgram) -> Result<(), String> {
        let _ = program;
        Ok(())
    }

    /// `Err` with a reason when the method cannot trace rays in `mode`: every method finds a
    /// ray's first crossing (opaque rays); one that stops there cannot trace transparent rays.
    ///
    /// # Errors
    /// A message saying what the method finds instead.
    fn traces(&self, mode: TraceMode) -> Result<(), String> {
        let _ = mode;
        Ok(())
    }

    /// What a ray's trace takes from the scene beyond the primitives among its candidates,
    /// the program's globals (isovalue, kernels, blend, groups, bounds) and the settings (none
    /// for a method whose march is the ray's own). The CPU backend traces again only the
    /// screen tiles of an edited scene whose candidates changed when these numbers are the
    /// same before and after the edit (`cpu_backend.rs`); a method must list here whatever
    /// else of the scene it reads, or reused tiles would be stale (`frame_reuse.rs` holds
    /// every method to a full trace).
    fn scene_inputs(&self, program: &FieldProgram) -> Vec<f64>;

    /// Prepares per-scene data (global Lipschitz constants and the like).
    fn prepare<'a>(
        &self,
        program: &'a FieldProgram,
        settings: TraceSettings,
    ) -> Box<dyn RayTracer + 'a>;
}

/// A method bound to one scene, ready to trace rays from any thread.
pub trait RayTracer: Sync {
    /// The scene.
    fn program(&self) -> &FieldProgram;

    /// Traces the ray of `field` over the span it was gathered for: the caller chose where
    /// the ray's candidate primitives come from ([`RayField::new`] walks the BVH;
    /// [`RayField::from_tile`] filters a screen tile's list, as the renderer does for camera
    /// rays). The march is the same either way.
    fn trace_field(&self, field: &RayField, mode: TraceMode) -> Trace;

    /// As [`RayTracer::trace_field`], with the step log of the marching methods
    /// ([`StepRecord`]); the other methods give none (`log` stays `None`).
    fn trace_field_logged(&self, field: &RayField, mode: TraceMode) -> Trace {
        self.trace_field(field, mode)
    }

    /// Traces `ray` over `span`.
    fn trace(&self, ray: &Ray, span: Interval, mode: TraceMode) -> Trace {
        self.trace_field(&RayField::new(self.program(), ray, span), mode)
    }

    /// As [`RayTracer::trace`], with the step log of the marching methods.
    fn trace_logged(&self, ray: &Ray, span: Interval, mode: TraceMode) -> Trace {
        self.trace_field_logged(&RayField::new(self.program(), ray, span), mode)
    }
}

/// The crossing at `t` where the field jumps across the isovalue, if it does (values just
/// before and just after `t`).
fn jump_crossing(field: &RayField, t: f64, trace: &mut Trace) -> Option<Crossing> {
    let inset = 1e-9 * (1.0 + t.abs());
    let c = field.program().isovalue();
    trace.evaluations += 2;
    let before = field.value(t - inset) >= c;
    let after = field.value(t + inset) >= c;
    (before != after).then_some(Crossing { t, entering: after })
}

/// Relative slack on an enclosure's rounding error (the interval and affine arithmetic round to
/// nearest, not outwards): where a bisection point lands on the surface, `f` there may round
/// to exactly `c` and an enclosure a few ulps above it.
const ROUNDING_SLACK: f64 = 1e-10;

/// Whether `range` (an enclosure of `f` over an interval) excludes the isovalue `c` by more than
/// its rounding error: only then may a bisection drop the interval.
pub(crate) fn excludes_isovalue(range: Interval, c: f64) -> bool {
    let slack = ROUNDING_SLACK * (1.0 + c.abs() + range.magnitude());
    range.hi < c - slack || range.lo > c + slack
}

/// Every method's CPU implementation, in the order of DESIGN.md's table.
#[must_use]
pub fn all() -> Vec<Box<dyn Method>> {
    MethodId::ALL.into_iter().map(MethodId::method).collect()
}

/// Calls `trace_span` on each part of `span` inside some support, collecting crossings and
/// counts; stops after the first crossing in opaque mode or when the step budget is spent.
///
/// Parts that touch are cut at an HRBF set's box, where the field may jump (the surface is cut
/// there, scene-format.md): a jump across the isovalue is a crossing at the cut, which no method
/// sees as a sign change inside one part. It is recorded here, once for every method, unless the
/// part before already ended on it (its last crossing points the same way: crossings alternate).
pub(crate) fn trace_supports(
    field: &RayField,
    span: Interval,
    mode: TraceMode,
    max_steps: u32,
    trace_span: impl FnMut(Interval, &mut Trace),
) -> Trace {
    trace_supports_into(Trace::default(), field, span, mode, max_steps, trace_span)
}

/// [`trace_supports`] appending to `trace` (one whose `log` is on).
pub(crate) fn trace_supports_into(
    mut trace: Trace,
    field: &RayField,
    span: Interval,
    mode: TraceMode,
    max_steps: u32,
    mut trace_span: impl FnMut(Interval, &mut Trace),
) -> Trace {
    thread_local! {
        static PARTS: ScratchPool<Vec<Interval>> = const { ScratchPool::new() };
    }
    let mut parts = ScratchPool::take(&PARTS);
    field.support_unions_into(span, &mut parts);
    let mut previous_end = None;
    for &part in &parts {
        if previous_end == Some(part.lo)
            && let Some(jump) = jump_crossing(field, part.lo, &mut trace)
            && trace
                .crossings
                .last()
                .is_none_or(|last| last.entering != jump.entering)
        {
            trace.push_crossing(jump);
            if mode == TraceMode::Opaque {
                break;
            }
        }
        previous_end = Some(part.hi);
        trace_span(part, &mut trace);
        if (mode == TraceMode::Opaque && !trace.crossings.is_empty()) || trace.steps >= max_steps {
            break;
        }
    }
    ScratchPool::give_back(&PARTS, parts);
    if mode == TraceMode::Opaque {
        trace.crossings.truncate(1);
    }
    trace
}
