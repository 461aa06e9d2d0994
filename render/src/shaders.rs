//! WGSL composition: one file per method family plus the shared prelude (`shaders/`), put
//! together in Rust. The methods that run on the GPU, and what each needs of a scene.

use skeletrace_core::FieldProgram;
use skeletrace_core::field::kernel::Kernel;
use skeletrace_core::field::primitives::{Primitive, Solid};
use skeletrace_core::methods::MethodId;

const PRELUDE: &str = include_str!("../shaders/prelude.wgsl");
const MARCH: &str = include_str!("../shaders/march.wgsl");
const PARTS: &str = include_str!("../shaders/parts.wgsl");
const SPHERE: &str = include_str!("../shaders/sphere.wgsl");
const SPHERE_ENHANCED: &str = include_str!("../shaders/sphere_enhanced.wgsl");
const TAYLOR: &str = include_str!("../shaders/taylor.wgsl");
const SCALIS: &str = include_str!("../shaders/scalis.wgsl");
const FIELD_INVERSION: &str = include_str!("../shaders/field_inversion.wgsl");
const MAIN: &str = include_str!("../shaders/main.wgsl");
/// The tile-binning passes (standalone).
pub const BINNING: &str = include_str!("../shaders/binning.wgsl");

/// A method with a GPU implementation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum GpuMethod {
    /// `sphere`.
    Sphere,
    /// `sphere-enhanced`.
    SphereEnhanced,
    /// `segment` (point blobs, segments, planes).
    Segment,
    /// `linear-taylor` (point blobs, segments, planes).
    LinearTaylor,
    /// `quadratic-taylor` (point blobs, segments, planes).
    QuadraticTaylor,
    /// `bottom-up-quadratic` (point blobs; Taylor for segments and planes).
    BottomUpQuadratic,
    /// `scalis-quadratic` (SCALIS skeletons).
    ScalisQuadratic,
    /// `field-inversion` (Gaussian blobs).
    FieldInversion,
}

impl GpuMethod {
    /// Every GPU method.
    pub const ALL: [Self; 8] = [
        Self::Sphere,
        Self::SphereEnhanced,
        Self::Segment,
        Self::LinearTaylor,
        Self::QuadraticTaylor,
        Self::BottomUpQuadratic,
        Self::ScalisQuadratic,
        Self::FieldInversion,
    ];

    /// The method's identity.
    #[must_use]
    pub const fn id(self) -> MethodId {
        match self {
            Self::Sphere => MethodId::Sphere,
            Self::SphereEnhanced => MethodId::SphereEnhanced,
            Self::Segment => MethodId::Segment,
            Self::LinearTaylor => MethodId::LinearTaylor,
            Self::QuadraticTaylor => MethodId::QuadraticTaylor,
            Self::BottomUpQuadratic => MethodId::BottomUpQuadratic,
            Self::ScalisQuadratic => MethodId::ScalisQuadratic,
            Self::FieldInversion => MethodId::FieldInversion,
        }
    }

    /// The GPU implementation of `id`, if there is one.
    #[must_use]
    pub fn from_id(id: MethodId) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.id() == id)
    }

    /// The command-line name.
    #[must_use]
    pub const fn name(self) -> &'static str {
        self.id().name()
    }

    /// `Err` with the reason when this GPU method cannot trace `program` (the CPU method may).
    ///
    /// # Errors
    /// What the GPU implementation needs.
    pub fn supports(self, program: &FieldProgram) -> Result<(), String> {
        let only_points = program
            .primitives()
            .iter()
            .all(|p| matches!(p, Primitive::Point(_)));
        // The inclusion shaders bound point blobs, distance and SCALIS segments and planes.
        let bounded = program.primitives().iter().all(|p| match p {
            Primitive::Point(_) | Primitive::Distance(_) | Primitive::Scalis(_) => true,
            Primitive::Shape(s) => matches!(s.solid, Solid::Plane { .. }),
            Primitive::Hrbf(_) => false,
        });
        match self {
            Self::Segment
            | Self::LinearTaylor
            | Self::QuadraticTaylor
            | Self::BottomUpQuadratic
                if !bounded =>
            {
                Err(format!(
                    "{} runs on the GPU for point blobs, segments and planes only (its bounds for \
                     HRBF sets and other shapes are CPU-only)",
                    self.name()
                ))
            }
            Self::FieldInversion
                if !only_points
                    || (0..program.group_count()).any(|g| {
                        !matches!(program.group_kernel_spec(g), Kernel::Gaussian { .. })
                    }) =>
            {
                Err("field-inversion needs Gaussian point blobs".to_owned())
            }
            Self::ScalisQuadratic
                if !program
                    .primitives()
                    .iter()
                    .all(|p| matches!(p, Primitive::Scalis(_)))
                    || program.common_kernel().is_none() =>
            {
                Err("scalis-quadratic needs SCALIS skeletons with one kernel".to_owned())
            }
            _ => Ok(()),
        }
    }

    /// Whether the method marches through parts.wgsl, which suspends a ray after a dispatch's
    /// allowance of steps and resumes it in the next dispatch; the others trace in one.
    #[must_use]
    pub fn resumable(self) -> bool {
        !matches!(self, Self::ScalisQuadratic | Self::FieldInversion)
    }

    /// The composed compute shader: prelude, the method family, the entry point.
    #[must_use]
    pub fn source(self) -> String {
        let family = match self {
            Self::Sphere => format!("{MARCH}\n{SPHERE}\n{PARTS}"),
            Self::SphereEnhanced => format!("{SPHERE_ENHANCED}\n{PARTS}"),
            Self::Segment
            | Self::LinearTaylor
            | Self::QuadraticTaylor
            | Self::BottomUpQuadratic => {
                let id = match self {
                    Self::Segment => 0,
                    Self::LinearTaylor => 1,
                    Self::QuadraticTaylor => 2,
                    _ => 3,
                };
                format!("const METHOD: u32 = {id}u;\n{MARCH}\n{TAYLOR}\n{PARTS}")
            }
            Self::ScalisQuadratic => SCALIS.to_owned(),
            Self::FieldInversion => FIELD_INVERSION.to_owned(),
        };
        format!("{PRELUDE}\n{family}\n{MAIN}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn validate(name: &str, source: &str) {
        let module = match naga::front::wgsl::parse_str(source) {
            Ok(m) => m,
            Err(e) => panic!("{name}: {}", e.emit_to_string(source)),
        };
        let mut validator = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::empty(),
        );
        if let Err(e) = validator.validate(&module) {
            panic!("{name}: {}", e.emit_to_string(source));
        }
    }

    /// The renderer sizes the suspension buffer by `SUSPENSION_BYTES`; naga's layout of the
    /// WGSL struct must agree.
    #[test]
    fn suspension_bytes_match_the_wgsl_struct() {
        let source = GpuMethod::Sphere.source();
        let module = naga::front::wgsl::parse_str(&source).unwrap_or_else(|e| panic!("{e}"));
        let span = module
            .types
            .iter()
            .find_map(|(_, ty)| match &ty.inner {
                naga::TypeInner::Struct { span, .. }
                    if ty.name.as_deref() == Some("Suspension") =>
                {
                    Some(*span)
                }
                _ => None,
            })
            .unwrap_or_else(|| panic!("no Suspension struct in the prelude"));
        assert_eq!(u64::from(span), crate::renderer::SUSPENSION_BYTES);
    }

    /// Core's `MethodId::has_gpu_implementation` names exactly the methods with shaders here.
    #[test]
    fn gpu_methods_are_the_ones_core_says_have_a_gpu_implementation() {
        let with_shaders: Vec<MethodId> = GpuMethod::ALL.iter().map(|m| m.id()).collect();
        let said: Vec<MethodId> = MethodId::ALL
            .into_iter()
            .filter(|m| m.has_gpu_implementation())
            .collect();
        assert_eq!(with_shaders, said);
    }

    #[test]
    fn every_composed_shader_parses_and_validates() {
        for method in GpuMethod::ALL {
            validate(method.name(), &method.source());
        }
        validate("binning", BINNING);
    }
}
