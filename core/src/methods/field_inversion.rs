//! Field inversion for Gaussian blobs (Bruckner 2019; forward-inclusion 2023 §7.1; MATH.md §6).
//! With `F = (1 − ε)·f/N₀ + ε` (the sum of unit Gaussians, clipping undone as for one atom) `exp(−|x − a|²/(σ²ρ²))`, `D = ρ·(σ·√(−ln F) − 1)`
//! approximates the distance to the surface (exact for an isolated atom of radius `ρ`). The march
//! steps by `1.2·D` and reports a hit when `D < 0.0125·ρ`, with at most 32 steps per support
//! span. Where a step overshoots into the volume (`f ≥ c`), the listing reports that sample;
//! skeletrace by default bisects between it and the sample before, to within ε (evaluations
//! counted, steps not), and reports the listing's sample under `--protocol paper-2023`. Not a
//! guaranteed bound for the blended surface: the statistics count its misses.

use super::MethodId;
use crate::field::blend::BlendTree;
use crate::field::primitives::Primitive;
use crate::field::program::FieldProgram;
use crate::field::ray_field::RayField;
use crate::model::kernel::{CLIP_EPSILON, Kernel};

use super::{Crossing, Method, RayTracer, Trace, TraceMode, TraceSettings, trace_supports};

/// Step over-relaxation and hit threshold of Bruckner's listing.
const STEP_FACTOR: f64 = 1.2;
const HIT_THRESHOLD: f64 = 0.0125;
const STEPS_PER_SPAN: u32 = 32;

/// `field-inversion`.
pub struct FieldInversion;

struct Prepared<'a> {
    program: &'a FieldProgram,
    settings: TraceSettings,
    /// σ of the (single) Gaussian kernel.
    sigma: f64,
    /// Smallest atom radius.
    radius: f64,
    /// Point normalisation `N₀`.
    norm: f64,
}

/// The Gaussian scale σ when every group is Gaussian with only point blobs, summed.
fn gaussian_blobs(program: &FieldProgram) -> Result<(f64, f64, f64), String> {
    let groups = program.group_count();
    let summed = matches!(program.blend(), BlendTree::Group(_))
        || matches!(program.blend(), BlendTree::Sum(v) if v.iter().all(|b| matches!(b, BlendTree::Group(_))));
    if !summed {
        return Err("field inversion needs groups blended by a plain sum".to_owned());
    }
    let mut sigma = None;
    let (mut radius, mut norm) = (f64::INFINITY, 0.0);
    for g in 0..groups {
        for p in program.group_primitives(g) {
            let Primitive::Point(blob) = p else {
                return Err("field inversion needs a scene of point blobs only".to_owned());
            };
            radius = radius.min(blob.radius);
            norm = blob.norm;
        }
    }
    for g in 0..groups {
        let Kernel::Gaussian { scale } = program.group_kernel_spec(g) else {
            return Err("field inversion needs Gaussian kernels".to_owned());
        };
        if sigma.is_some_and(|s| s != scale) {
            return Err("field inversion needs one Gaussian scale for all groups".to_owned());
        }
        sigma = Some(scale);
    }
    match sigma {
        Some(s) if radius.is_finite() => Ok((s, radius, norm)),
        _ => Err("field inversion needs at least one Gaussian blob".to_owned()),
    }
}

impl Method for FieldInversion {
    fn id(&self) -> MethodId {
        MethodId::FieldInversion
    }

    fn is_conservative(&self) -> bool {
        false
    }

    fn supports(&self, program: &FieldProgram) -> Result<(), String> {
        gaussian_blobs(program).map(|_| ())
    }

    fn traces(&self, mode: TraceMode) -> Result<(), String> {
        match mode {
            TraceMode::Opaque => Ok(()),
            TraceMode::Transparent => Err(
                "field inversion finds the first crossing only (Bruckner 2019 steps towards entries, never exits)"
                    .to_owned(),
            ),
        }
    }

    fn scene_inputs(&self, program: &FieldProgram) -> Vec<f64> {
        let (sigma, radius, norm) = gaussian_blobs(program).unwrap_or((1.0, 1.0, 1.0));
        vec![sigma, radius, norm]
    }

    fn prepare<'a>(
        &self,
        program: &'a FieldProgram,
        settings: TraceSettings,
    ) -> Box<dyn RayTracer + 'a> {
        let (sigma, radius, norm) = gaussian_blobs(program).unwrap_or((1.0, 1.0, 1.0));
        Box::new(Prepared {
            program,
            settings,
            sigma,
            radius,
            norm,
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
            let mut previous = t;
            let mut in_span = 0;
            while t < part.hi && in_span < STEPS_PER_SPAN && trace.steps < s.max_steps {
                trace.steps += 1;
                in_span += 1;
                trace.evaluations += 1;
                let f = field.value(t);
                // Undo the clipping as for a single atom: K = (1 − ε)·K_c + ε.
                let unit = (f / self.norm) * (1.0 - CLIP_EPSILON) + CLIP_EPSILON;
                let distance = self.radius * (self.sigma * (-unit.ln()).max(0.0).sqrt() - 1.0);
                if f >= c && s.protocol.refines_field_inversion() {
                    let t = self.refine(field, (previous, t), trace);
                    trace.push_crossing(Crossing { t, entering: true });
                    return;
                }
                if distance < HIT_THRESHOLD * self.radius || f >= c {
                    trace.push_crossing(Crossing { t, entering: true });
                    return;
                }
                previous = t;
                t += STEP_FACTOR * distance;
            }
        })
    }
}

impl Prepared<'_> {
    /// The crossing between `outside` (the last sample outside) and `inside` (the sample that
    /// overshot into the volume), to within ε, by bisection.
    fn refine(
        &self,
        field: &RayField,
        (mut outside, mut inside): (f64, f64),
        trace: &mut Trace,
    ) -> f64 {
        let c = self.program.isovalue();
        while inside - outside > self.settings.epsilon {
            let mid = 0.5 * (outside + inside);
            trace.evaluations += 1;
            if field.value(mid) >= c {
                inside = mid;
            } else {
                outside = mid;
            }
        }
        inside
    }
}
