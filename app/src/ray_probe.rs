//! One pixel's camera ray, traced by each chosen method with the step log of the marching methods
//! (forward-inclusion 2023, algorithm 1: the point, `f` and `f′` there, the bounds
//! `f(t) + a·s + b·s²` on `[t, t + length]` and the advance they allow), with the field sampled
//! densely along the ray and the support intervals it crosses. `skeletrace trace-ray` prints it;
//! the editor's ray inspector plots it. The ray and its span are the ones the CPU renderer
//! traces for that pixel, so each method's step count is the heat map's there.

use skeletrace_core::Interval;
use skeletrace_core::compile::Compiled;
use skeletrace_core::field::geometry::Ray;
use skeletrace_core::frame::{PinholeCamera, far_distance};
use skeletrace_core::methods::{MethodId, Trace, TraceMode};
use skeletrace_core::model::scene::Camera;

/// Field samples per probe: enough to show every crossing a method can find at the scale of a
/// support (the plot is zoomable).
const SAMPLES: usize = 1200;

/// One pixel's ray and what each method did along it.
#[derive(Clone, Debug)]
pub struct RayProbe {
    /// The pixel, from the top left.
    pub pixel: (usize, usize),
    /// The frame it belongs to.
    pub size: (usize, usize),
    /// The camera ray.
    pub ray: Ray,
    /// The interval the renderer traces.
    pub span: Interval,
    /// The isovalue `c`.
    pub isovalue: f64,
    /// The parts of the span inside some support (outside them the field is 0).
    pub supports: Vec<Interval>,
    /// `(t, f(t) − c)` sampled uniformly over the supports' hull.
    pub samples: Vec<[f64; 2]>,
    /// Each method's trace, with its step log where it has one.
    pub traces: Vec<(MethodId, Trace)>,
}

impl RayProbe {
    /// Traces pixel `(x, y)` of a `width × height` frame seen by `camera` with each of `methods`
    /// (opaque, as the heat maps are traced).
    #[must_use]
    pub fn new(
        compiled: &Compiled,
        camera: &Camera,
        (x, y): (usize, usize),
        (width, height): (usize, usize),
        methods: &[MethodId],
    ) -> Self {
        let program = &compiled.program;
        let ray = PinholeCamera::new(camera).ray(x, y, width, height);
        let span = Interval::new(0.0, far_distance(program, camera));
        let traces = methods
            .iter()
            .filter(|id| id.method().supports(program).is_ok())
            .map(|&id| {
                let tracer = id.method().prepare(program, compiled.settings);
                (id, tracer.trace_logged(&ray, span, TraceMode::Opaque))
            })
            .collect();
        let supports = program.ray_support_unions(&ray, span);
        let c = program.isovalue();
        let samples = match (supports.first(), supports.last()) {
            (Some(first), Some(last)) => {
                let (lo, hi) = (first.lo, last.hi);
                (0..=SAMPLES)
                    .map(|i| {
                        let t = lo + (hi - lo) * i as f64 / SAMPLES as f64;
                        [t, program.value(ray.at(t)) - c]
                    })
                    .collect()
            }
            _ => Vec::new(),
        };
        Self {
            pixel: (x, y),
            size: (width, height),
            ray,
            span,
            isovalue: c,
            supports,
            samples,
            traces,
        }
    }
}
