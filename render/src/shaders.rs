//! WGSL composition: one file per method family plus the shared WGSL (`shaders/shared/`), put
//! together in Rust. The methods that run on the GPU, and what each needs of a scene.

use skeletrace_core::FieldProgram;
use skeletrace_core::field::primitives::Primitive;
use skeletrace_core::methods::{
    AcceleratedSphereTracing, Method, MethodId, Protocol, SegmentOriginal, Sherstyuk,
};
use skeletrace_core::model::kernel::Kernel;

use crate::blend_wgsl::BlendWgsl;
use crate::shared::{KindSet, MarchBound, RAY_SUPPORTS, wgsl_constants};

/// The WGSL every compute shader shares (`shaders/shared/`), one file per core module it
/// mirrors, in the order they are composed.
const SHARED: [(&str, &str); 6] = [
    (
        "shared/scene.wgsl",
        include_str!("../shaders/shared/scene.wgsl"),
    ),
    (
        "shared/kernels.wgsl",
        include_str!("../shaders/shared/kernels.wgsl"),
    ),
    (
        "shared/primitives.wgsl",
        include_str!("../shaders/shared/primitives.wgsl"),
    ),
    (
        "shared/geometry.wgsl",
        include_str!("../shaders/shared/geometry.wgsl"),
    ),
    (
        "shared/supports.wgsl",
        include_str!("../shaders/shared/supports.wgsl"),
    ),
    (
        "shared/blend.wgsl",
        include_str!("../shaders/shared/blend.wgsl"),
    ),
];

/// The shared WGSL, composed.
fn shared_wgsl() -> String {
    SHARED.map(|(_, text)| text).join("\n")
}
const MARCH: &str = include_str!("../shaders/march.wgsl");
const PARTS: &str = include_str!("../shaders/parts.wgsl");
const SPHERE: &str = include_str!("../shaders/sphere.wgsl");
const SPHERE_ENHANCED: &str = include_str!("../shaders/sphere_enhanced.wgsl");
const SPHERE_ACCELERATED: &str = include_str!("../shaders/sphere_accelerated.wgsl");
const SEGMENT_ORIGINAL: &str = include_str!("../shaders/segment_original.wgsl");
const SHERSTYUK: &str = include_str!("../shaders/sherstyuk.wgsl");
const INTERVAL: &str = include_str!("../shaders/interval.wgsl");
const PRIMITIVE_JETS: &str = include_str!("../shaders/primitive_jets.wgsl");
const INCLUSION: &str = include_str!("../shaders/inclusion.wgsl");
const SCALIS: &str = include_str!("../shaders/scalis.wgsl");
const NORMALISED: &str = include_str!("../shaders/normalised.wgsl");
const SPHERE_NORMALIZED: &str = include_str!("../shaders/sphere_normalized.wgsl");
const FIELD_INVERSION: &str = include_str!("../shaders/field_inversion.wgsl");
const HEAT: &str = include_str!("../shaders/heat.wgsl");
const MAIN: &str = include_str!("../shaders/main.wgsl");
const BLIT: &str = include_str!("../shaders/viewport_blit.wgsl");
const STEP_STATISTICS: &str = include_str!("../shaders/step_statistics.wgsl");
const BINNING: &str = include_str!("../shaders/binning.wgsl");

/// The tile-binning passes: the shared constants and binning.wgsl.
#[must_use]
pub fn binning_source() -> String {
    format!("{}\n{BINNING}", wgsl_constants())
}

/// The viewport's blit (shaded frames and heat maps): the shared constants, heat.wgsl and
/// viewport_blit.wgsl.
#[must_use]
pub fn blit_source() -> String {
    format!("{}\n{HEAT}\n{BLIT}", wgsl_constants())
}

/// The step statistics of a comparison on the GPU (step_statistics.wgsl).
#[must_use]
pub fn step_statistics_source() -> String {
    STEP_STATISTICS.to_owned()
}

/// The shader family of each method: the one table of which methods run on the GPU and which
/// WGSL each composes. [`GpuMethod::ALL`] is [`MethodId::ALL`] filtered by it, so a new method is
/// given a shader (or none) here and nowhere else.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum ShaderFamily {
    Sphere,
    SphereEnhanced,
    SphereAccelerated,
    SphereNormalized,
    SegmentOriginal,
    /// march.wgsl with inclusion.wgsl's bound of this kind.
    Inclusion(MarchBound),
    Sherstyuk,
    Scalis,
    FieldInversion,
}

impl ShaderFamily {
    /// The family of `id`'s shader; `None` for the CPU-only methods.
    const fn of(id: MethodId) -> Option<Self> {
        Some(match id {
            MethodId::Sphere => Self::Sphere,
            MethodId::SphereEnhanced => Self::SphereEnhanced,
            MethodId::SphereAccelerated => Self::SphereAccelerated,
            MethodId::SphereNormalized => Self::SphereNormalized,
            MethodId::SegmentOriginal => Self::SegmentOriginal,
            MethodId::Segment => Self::Inclusion(MarchBound::Segment),
            MethodId::LinearTaylor => Self::Inclusion(MarchBound::LinearTaylor),
            MethodId::QuadraticTaylor => Self::Inclusion(MarchBound::QuadraticTaylor),
            MethodId::BottomUpLinear => Self::Inclusion(MarchBound::BottomUpLinear),
            MethodId::BottomUpQuadratic => Self::Inclusion(MarchBound::BottomUpQuadratic),
            MethodId::LinearMixed => Self::Inclusion(MarchBound::LinearMixed),
            MethodId::QuadraticMixed => Self::Inclusion(MarchBound::QuadraticMixed),
            MethodId::ScalisQuadratic => Self::Scalis,
            MethodId::Sherstyuk => Self::Sherstyuk,
            MethodId::FieldInversion => Self::FieldInversion,
            MethodId::BottomUpLinearBisection | MethodId::Affine | MethodId::Reference => {
                return None;
            }
        })
    }
}

/// How many of [`MethodId::ALL`] have a shader.
const GPU_METHOD_COUNT: usize = {
    let mut count = 0;
    let mut i = 0;
    while i < MethodId::ALL.len() {
        if ShaderFamily::of(MethodId::ALL[i]).is_some() {
            count += 1;
        }
        i += 1;
    }
    count
};

/// A method with a GPU implementation: a [`MethodId`] that has a [`ShaderFamily`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct GpuMethod(MethodId);

impl GpuMethod {
    /// Every GPU method, in [`MethodId::ALL`]'s order.
    pub const ALL: [Self; GPU_METHOD_COUNT] = {
        let mut all = [Self(MethodId::Sphere); GPU_METHOD_COUNT];
        let (mut i, mut n) = (0, 0);
        while i < MethodId::ALL.len() {
            if ShaderFamily::of(MethodId::ALL[i]).is_some() {
                all[n] = Self(MethodId::ALL[i]);
                n += 1;
            }
            i += 1;
        }
        all
    };

    /// The method's identity.
    #[must_use]
    pub const fn id(self) -> MethodId {
        self.0
    }

    /// The GPU implementation of `id`, if there is one.
    #[must_use]
    pub const fn from_id(id: MethodId) -> Option<Self> {
        match ShaderFamily::of(id) {
            Some(_) => Some(Self(id)),
            None => None,
        }
    }

    /// This method's shader family.
    fn family(self) -> ShaderFamily {
        ShaderFamily::of(self.0).unwrap_or(ShaderFamily::Sphere)
    }

    /// The command-line name.
    #[must_use]
    pub const fn name(self) -> &'static str {
        self.id().name()
    }

    /// `Err` with the reason when this GPU method does not follow `protocol`: the profiles reach
    /// the GPU through the trace settings only, and these methods make choices of their own
    /// under some of them on the CPU (`core/src/methods/protocol.rs`).
    ///
    /// # Errors
    /// The choice the GPU lacks.
    pub fn follows(self, protocol: Protocol) -> Result<(), String> {
        let lacks = match (self.0, protocol) {
            (MethodId::ScalisQuadratic, Protocol::Paper2021) => {
                "the paper's |F| < 10⁻³ stop and sphere-step entry"
            }
            (MethodId::FieldInversion, Protocol::Paper2023) => {
                "the unrefined hit of Bruckner's listing"
            }
            (MethodId::SphereEnhanced, Protocol::Paper2014) => "ω = 1.2",
            (MethodId::SphereNormalized, Protocol::Paper2021) => "the thinnest radius once per ray",
            _ => return Ok(()),
        };
        Err(format!(
            "{} under --protocol {protocol} runs on the CPU only (the GPU lacks {lacks})",
            self.name()
        ))
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
        match self.0 {
            MethodId::FieldInversion
                if !only_points
                    || (0..program.group_count()).any(|g| {
                        !matches!(program.group_kernel_spec(g), Kernel::Gaussian { .. })
                    }) =>
            {
                Err("field-inversion needs Gaussian point blobs".to_owned())
            }
            // Galin et al.'s first segment is the whole part of the ray inside the supports, and
            // its bound sums every primitive over it; a window of RAY_SUPPORTS supports cuts
            // a part at its horizon where more overlap, and the march then differs from the
            // CPU's (molecule, 3 000 blobs: 84 % equal step counts). With at most that many
            // primitives no window is ever cut.
            MethodId::SegmentOriginal => {
                self.within_one_window(program, "its first segment is a whole support part")
            }
            // Each primitive's Hermite pieces span its whole support interval; the march walks
            // their nodes from the ray's window, which holds every support when the scene has
            // at most RAY_SUPPORTS primitives.
            // (Summed groups, no HRBF set: the CPU method's own requirements.)
            MethodId::Sherstyuk => {
                Sherstyuk.supports(program)?;
                self.within_one_window(program, "its pieces span whole support intervals")
            }
            MethodId::ScalisQuadratic | MethodId::SphereNormalized
                if !program
                    .primitives()
                    .iter()
                    .all(|p| matches!(p, Primitive::Scalis(_)))
                    || program.common_kernel().is_none() =>
            {
                Err(format!(
                    "{} needs SCALIS skeletons with one kernel",
                    self.name()
                ))
            }
            _ => Ok(()),
        }
    }

    /// `Err` when `program` has more primitives than a ray's window of [`RAY_SUPPORTS`]
    /// supports holds, for a method that must see every support of a part at once (`needs`
    /// says why).
    fn within_one_window(self, program: &FieldProgram, needs: &str) -> Result<(), String> {
        let count = program.primitives().len();
        if count <= RAY_SUPPORTS {
            return Ok(());
        }
        Err(format!(
            "{} runs on the GPU for scenes of at most {RAY_SUPPORTS} primitives ({needs}, which \
             a ray's window of {RAY_SUPPORTS} supports cannot see beyond); this scene has {count}",
            self.name()
        ))
    }

    /// Whether the method marches through parts.wgsl, which suspends a ray after a dispatch's
    /// allowance of steps and resumes it in the next dispatch; the others trace in one.
    #[must_use]
    pub fn resumable(self) -> bool {
        !matches!(
            self.family(),
            ShaderFamily::Scalis | ShaderFamily::FieldInversion
        )
    }

    /// The composed compute shader for a scene whose blend tree compiles to `blend` and whose
    /// primitives are of the kinds in `kinds`: the shared constants, the shared WGSL, the blend, the
    /// method family, the entry point.
    #[must_use]
    pub fn source(self, blend: &BlendWgsl, kinds: KindSet) -> String {
        let family = match self.family() {
            ShaderFamily::Sphere => format!("{MARCH}\n{SPHERE}\n{PARTS}"),
            ShaderFamily::SphereEnhanced => format!("{SPHERE_ENHANCED}\n{PARTS}"),
            ShaderFamily::SphereAccelerated => format!(
                "const ACCELERATION_BETA: f32 = {:?};\n{SPHERE_ACCELERATED}\n{PARTS}",
                AcceleratedSphereTracing::BETA as f32
            ),
            ShaderFamily::SphereNormalized => {
                format!("{MARCH}\n{NORMALISED}\n{SPHERE_NORMALIZED}\n{PARTS}")
            }
            ShaderFamily::SegmentOriginal => format!(
                "const SEGMENT_GROWTH: f32 = {:?};\n{INTERVAL}\n{PRIMITIVE_JETS}\n{}\n{SEGMENT_ORIGINAL}\n{PARTS}",
                SegmentOriginal::GROWTH as f32,
                blend.jets_and_lipschitz
            ),
            ShaderFamily::Inclusion(bound) => format!(
                "const METHOD: u32 = {}u;\n{MARCH}\n{INTERVAL}\n{PRIMITIVE_JETS}\n{INCLUSION}\n{}\n{PARTS}",
                bound as u32,
                blend.bounds()
            ),
            ShaderFamily::Sherstyuk => format!(
                "const SHERSTYUK_PIECES: u32 = {}u;\n{SHERSTYUK}\n{PARTS}",
                Sherstyuk::SUBDIVISIONS
            ),
            ShaderFamily::Scalis => format!("{NORMALISED}\n{SCALIS}"),
            ShaderFamily::FieldInversion => FIELD_INVERSION.to_owned(),
        };
        format!(
            "{}{}{}\nconst RESUMABLE: bool = {};\n{}\n{}\n{family}\n{HEAT}\n{MAIN}",
            wgsl_constants(),
            blend.groups_constant(),
            kinds.wgsl(),
            self.resumable(),
            shared_wgsl(),
            blend.values
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use skeletrace_core::field::blend::BlendTree;

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

    /// Every GPU method follows the default profile; the three whose profile choices are
    /// CPU-only refuse those profiles, naming what the GPU lacks.
    #[test]
    fn methods_refuse_the_profiles_whose_choices_the_gpu_lacks() {
        for method in GpuMethod::ALL {
            assert!(
                method.follows(Protocol::Default).is_ok(),
                "{}",
                method.name()
            );
        }
        for (method, protocol) in [
            (GpuMethod(MethodId::ScalisQuadratic), Protocol::Paper2021),
            (GpuMethod(MethodId::FieldInversion), Protocol::Paper2023),
            (GpuMethod(MethodId::SphereEnhanced), Protocol::Paper2014),
            (GpuMethod(MethodId::SphereNormalized), Protocol::Paper2021),
        ] {
            let why = method.follows(protocol).err().unwrap_or_default();
            assert!(why.contains("runs on the CPU only"), "{why}");
        }
        assert!(
            GpuMethod(MethodId::QuadraticTaylor)
                .follows(Protocol::Paper2023)
                .is_ok()
        );
    }

    /// Every shared constant is emitted once, and none is typed again in a WGSL file.
    #[test]
    fn shared_constants_are_defined_only_in_rust() {
        let emitted = wgsl_constants();
        let names: Vec<&str> = emitted
            .lines()
            .filter_map(|l| l.strip_prefix("const ")?.split(':').next())
            .collect();
        assert!(names.len() >= 30, "{emitted}");
        for (file, text) in SHARED.into_iter().chain([
            ("march.wgsl", MARCH),
            ("parts.wgsl", PARTS),
            ("sphere.wgsl", SPHERE),
            ("sphere_enhanced.wgsl", SPHERE_ENHANCED),
            ("sphere_accelerated.wgsl", SPHERE_ACCELERATED),
            ("segment_original.wgsl", SEGMENT_ORIGINAL),
            ("sherstyuk.wgsl", SHERSTYUK),
            ("interval.wgsl", INTERVAL),
            ("primitive_jets.wgsl", PRIMITIVE_JETS),
            ("inclusion.wgsl", INCLUSION),
            ("scalis.wgsl", SCALIS),
            ("normalised.wgsl", NORMALISED),
            ("sphere_normalized.wgsl", SPHERE_NORMALIZED),
            ("field_inversion.wgsl", FIELD_INVERSION),
            ("main.wgsl", MAIN),
            ("binning.wgsl", BINNING),
            ("heat.wgsl", HEAT),
            ("viewport_blit.wgsl", BLIT),
            ("step_statistics.wgsl", STEP_STATISTICS),
        ]) {
            for name in &names {
                assert!(
                    !text.contains(&format!("const {name}:")),
                    "{file} defines {name} again"
                );
            }
        }
    }

    /// The renderer sizes the suspension and path buffers by `SUSPENSION_BYTES` and
    /// `PATH_BYTES`; naga's layout of the WGSL structs must agree.
    #[test]
    fn per_pixel_state_bytes_match_the_wgsl_structs() {
        let source = GpuMethod(MethodId::Sphere).source(&summed(2), KindSet::ALL);
        let module = naga::front::wgsl::parse_str(&source).unwrap_or_else(|e| panic!("{e}"));
        let span_of = |name: &str| {
            module
                .types
                .iter()
                .find_map(|(_, ty)| match &ty.inner {
                    naga::TypeInner::Struct { span, .. } if ty.name.as_deref() == Some(name) => {
                        Some(u64::from(*span))
                    }
                    _ => None,
                })
                .unwrap_or_else(|| panic!("no {name} struct in the shader"))
        };
        assert_eq!(span_of("Suspension"), crate::shared::SUSPENSION_BYTES);
        assert_eq!(span_of("Path"), crate::shared::PATH_BYTES);
    }

    /// Core's `MethodId::has_gpu_implementation` names exactly the methods with shaders here.
    #[test]
    fn gpu_methods_are_the_ones_core_says_have_a_gpu_implementation() {
        let mut with_shaders: Vec<MethodId> = GpuMethod::ALL.iter().map(|m| m.id()).collect();
        with_shaders.sort();
        let said: Vec<MethodId> = MethodId::ALL
            .into_iter()
            .filter(|m| m.has_gpu_implementation())
            .collect();
        assert_eq!(with_shaders, said);
    }

    /// The blend of a scene without one: the sum of its groups.
    fn summed(groups: u32) -> BlendWgsl {
        BlendWgsl::new(
            &BlendTree::Sum((0..groups).map(BlendTree::Group).collect()),
            groups as usize,
        )
    }

    /// Every method's shader with the default blend, for every kind and for each kind alone
    /// (the `HAS_*` constants cut the others' code), and the inclusion family's (which holds
    /// every blend function) with a tree of every operator, nested, and with empty operators.
    #[test]
    fn every_composed_shader_parses_and_validates() {
        for method in GpuMethod::ALL {
            validate(method.name(), &method.source(&summed(3), KindSet::ALL));
            for kind in crate::shared::PrimitiveKind::ALL {
                let source = method.source(&summed(3), KindSet::NONE.with(kind));
                validate(&format!("{} ({kind:?} only)", method.name()), &source);
            }
        }
        let g = BlendTree::Group;
        let every = BlendTree::SmoothIntersection {
            width: 0.3,
            of: vec![
                BlendTree::Ricci {
                    p: 2.5,
                    of: vec![
                        BlendTree::Difference(
                            Box::new(g(0)),
                            Box::new(BlendTree::Max(vec![g(1), g(2)])),
                        ),
                        BlendTree::Min(vec![g(2), g(0), BlendTree::Sum(vec![])]),
                    ],
                },
                BlendTree::SmoothUnion {
                    width: 0.5,
                    of: vec![g(1), BlendTree::Max(vec![])],
                },
            ],
        };
        for method in [
            GpuMethod(MethodId::QuadraticMixed),
            GpuMethod(MethodId::Sphere),
        ] {
            validate(
                method.name(),
                &method.source(&BlendWgsl::new(&every, 3), KindSet::ALL),
            );
        }
        validate("binning", &binning_source());
        validate("blit", &blit_source());
        validate("step statistics", &step_statistics_source());
    }
}
