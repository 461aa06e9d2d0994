//! Accelerated sphere tracing (Bálint & Valasek 2018; MATH.md §6): the step extrapolates from the
//! last two unbounding radii, `dt = r₁ + β·r₁·(d + r₁ − r₀)/(d − r₁ + r₀)` with `β = 0.95` and `d`
//! the previous step. The step is accepted when the sphere at the new point overlaps the current
//! one (`dt ≤ r₁ + r(t + dt)`), so nothing is skipped; otherwise the plain step `r₁` is taken.
//! The first step of every span is a plain one. A crossing is reported when `r₁ < epsilon` and
//! the field is on the other side of the isovalue `min_step` further on; where it is not, the
//! march goes on by `r₁`, but by no less than two f32 ulps of `t` ([`progress_floor`]).

use super::MethodId;
use crate::field::program::FieldProgram;
use crate::field::ray_field::RayField;

use super::{Crossing, Method, RayTracer, Trace, TraceMode, TraceSettings, trace_supports};

/// `sphere-accelerated`.
pub struct AcceleratedSphereTracing;

impl AcceleratedSphereTracing {
    /// The extrapolation weight β (the GPU's sphere_accelerated.wgsl takes it from here).
    pub const BETA: f64 = 0.95;
}

/// The least step below `ε` where the crossing is not confirmed: two f32 ulps of `t`, the least
/// the GPU's f32 march can take (sphere_accelerated.wgsl `progress_floor`). On rays grazing a
/// surface at a shallow angle the unbounding radius decays geometrically below `ε` long before
/// the surface is within `min_step`; with a floor of an f64 ulp the CPU crept on by radii of
/// 10⁻⁸ for some 1 400 steps where the GPU could not follow (creature, ground plane, 7 % more
/// steps than the GPU), and neither step is large enough to matter to the hit (both ≪ `ε`).
fn progress_floor(t: f64) -> f64 {
    let x = t.abs().max(1e-30) as f32;
    2.0 * f64::from(x.next_up() - x)
}

struct Prepared<'a> {
    program: &'a FieldProgram,
    settings: TraceSettings,
    lipschitz: f64,
}

impl Method for AcceleratedSphereTracing {
    fn id(&self) -> MethodId {
        MethodId::SphereAccelerated
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

impl Prepared<'_> {
    fn radius(&self, field: &RayField, t: f64, trace: &mut Trace) -> (f64, bool) {
        trace.evaluations += 1;
        let f = field.value(t);
        let c = self.program.isovalue();
        ((f - c).abs() / self.lipschitz, f >= c)
    }
}

impl RayTracer for Prepared<'_> {
    fn program(&self) -> &FieldProgram {
        self.program
    }

    fn trace_field(&self, field: &RayField, mode: TraceMode) -> Trace {
        let span = field.span();
        let s = &self.settings;
        trace_supports(field, span, mode, s.max_steps, |part, trace| {
            let mut t = part.lo;
            // (previous radius, previous step); None right after a start or a crossing.
            let mut history: Option<(f64, f64)> = None;
            let mut current = self.radius(field, t, trace);
            while t < part.hi && trace.steps < s.max_steps {
                trace.steps += 1;
                let (r1, inside) = current;
                if r1 < s.epsilon {
                    // Confirm the crossing on the other side, as the marching methods do.
                    if self.radius(field, t + s.min_step, trace).1 == inside {
                        t += r1.max(progress_floor(t));
                        history = None;
                        current = self.radius(field, t, trace);
                        continue;
                    }
                    trace.push_crossing(Crossing {
                        t,
                        entering: !inside,
                    });
                    if mode == TraceMode::Opaque {
                        return;
                    }
                    t += r1 + s.min_step;
                    history = None;
                    current = self.radius(field, t, trace);
                    continue;
                }
                let mut dt = r1;
                if let Some((r0, d)) = history {
                    let denominator = d - r1 + r0;
                    if denominator > 0.0 {
                        dt = (r1
                            + AcceleratedSphereTracing::BETA * r1 * (d + r1 - r0) / denominator)
                            .max(r1);
                    }
                }
                let mut next = self.radius(field, t + dt, trace);
                if dt > r1 && (dt > r1 + next.0 || next.1 != inside) {
                    dt = r1;
                    next = self.radius(field, t + dt, trace);
                }
                history = Some((r1, dt));
                t += dt;
                current = next;
            }
        })
    }
}
