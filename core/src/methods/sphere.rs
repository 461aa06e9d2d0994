//! Sphere tracing with a global Lipschitz bound (numerical ray tracing notes 2014 §6; Hart 1996):
//! from `t`, no crossing lies closer than `|f(t) − c| / L`, so the ray advances by that much; a
//! crossing is reported when the step falls below `epsilon` and the field is on the other side of
//! the isovalue `min_step` further on. `L` is
//! [`FieldProgram::global_lipschitz`]: the largest sum of primitive Lipschitz constants over
//! overlapping supports.

use super::MethodId;
use crate::field::program::FieldProgram;
use crate::field::ray_field::RayField;

use super::marching::{Marcher, Slope, symmetric};
use super::{Method, RayTracer, TraceSettings};

/// `sphere`.
pub struct SphereTracing;

impl Method for SphereTracing {
    fn id(&self) -> MethodId {
        MethodId::Sphere
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
        let lipschitz = program.global_lipschitz();
        Box::new(Marcher {
            program,
            settings,
            slope: Slope::Unused,
            bound: move |_: &RayField, _, f, _, _| symmetric(f, lipschitz, f64::INFINITY),
        })
    }
}
