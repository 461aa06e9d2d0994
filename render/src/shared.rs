//! Constants and enum codes shared by the Rust side of the GPU backend and its WGSL shaders.
//! Each is defined once, here or in core where the CPU uses it too (shading constants, the
//! Turbo colour map, the Gauss–Legendre rule), and [`wgsl_constants`] emits them as WGSL
//! `const`s at the top of every composed shader; the shaders name them, never their values.

use std::fmt::Write as _;

use skeletrace_core::field::quadrature::{GaussLegendre, SCALIS_ORDER};
use skeletrace_core::frame::MAX_BOUNCES;
use skeletrace_core::frame::{self as shading, TURBO};

/// Most groups the GPU backend takes. A scene's shaders hold one slot per group of its own
/// (`GROUPS`, emitted with its blend tree: [`crate::blend_wgsl::BlendWgsl`]) in every ray's
/// private memory, three arrays of them in the inclusion marches; past this count a hardware GPU
/// would spill them to slow memory at every step, and such scenes trace on the CPU.
pub const MAX_GROUPS: usize = 64;

/// `Primitive.kind`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum PrimitiveKind {
    /// A point blob.
    Point = 0,
    /// A distance segment (kernel of the homothetic distance).
    DistanceSegment = 1,
    /// A SCALIS segment.
    ScalisSegment = 2,
    /// A plane (kernel of the distance to it).
    Plane = 3,
    /// A box (kernel of the distance to it, shapes.rs).
    Box = 4,
    /// A box with rounded edges.
    RoundedBox = 5,
    /// A solid torus around its local `y` axis.
    Torus = 6,
    /// A capped solid cylinder along its local `y` axis.
    Cylinder = 7,
    /// One term of an HRBF set (hrbf.rs).
    Hrbf = 8,
}

impl PrimitiveKind {
    /// Every kind, in code order.
    pub const ALL: [Self; 9] = [
        Self::Point,
        Self::DistanceSegment,
        Self::ScalisSegment,
        Self::Plane,
        Self::Box,
        Self::RoundedBox,
        Self::Torus,
        Self::Cylinder,
        Self::Hrbf,
    ];

    /// The name of the kind's code in WGSL (`KIND_*`).
    #[must_use]
    pub const fn wgsl_name(self) -> &'static str {
        match self {
            Self::Point => "KIND_POINT",
            Self::DistanceSegment => "KIND_DISTANCE_SEGMENT",
            Self::ScalisSegment => "KIND_SCALIS_SEGMENT",
            Self::Plane => "KIND_PLANE",
            Self::Box => "KIND_BOX",
            Self::RoundedBox => "KIND_ROUNDED_BOX",
            Self::Torus => "KIND_TORUS",
            Self::Cylinder => "KIND_CYLINDER",
            Self::Hrbf => "KIND_HRBF",
        }
    }

    /// One of the four solid shapes (shapes.rs), which share the shaders' `HAS_SHAPE`.
    #[must_use]
    pub const fn is_shape(self) -> bool {
        matches!(
            self,
            Self::Box | Self::RoundedBox | Self::Torus | Self::Cylinder
        )
    }
}

/// The primitive kinds a scene's pipelines are compiled for: every shader dispatch on
/// `Primitive.kind` tests a `HAS_*` constant first ([`KindSet::wgsl`]), so the code of an
/// absent kind folds away before the driver compiles it. Lavapipe inlines every function and
/// compiles a pipeline for tens of seconds; one for point blobs alone compiles in about half
/// the time of one for every kind. A scene is compiled for the first of [`KindSet::TIERS`] that
/// holds its kinds ([`KindSet::covering`]), so that scenes of similar kinds share pipelines and
/// an edit seldom needs new ones; when it does (`GpuRenderer::set_scene`), as when the blend
/// tree changes, each method shown builds its pipeline again.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct KindSet(u32);

impl KindSet {
    /// Every kind: shaders that serve any scene.
    pub const ALL: Self = Self((1 << (PrimitiveKind::Hrbf as u32 + 1)) - 1);

    /// No kind.
    pub const NONE: Self = Self(0);

    /// The sets pipelines are compiled for, smallest first: point blobs; point blobs and
    /// segments (the skeletons); every kind.
    pub const TIERS: [Self; 3] = [
        Self::NONE.with(PrimitiveKind::Point),
        Self::NONE
            .with(PrimitiveKind::Point)
            .with(PrimitiveKind::DistanceSegment)
            .with(PrimitiveKind::ScalisSegment),
        Self::ALL,
    ];

    /// The first of [`KindSet::TIERS`] that holds this set.
    #[must_use]
    pub fn covering(self) -> Self {
        Self::TIERS
            .into_iter()
            .find(|tier| tier.0 & self.0 == self.0)
            .unwrap_or(Self::ALL)
    }

    /// This set with `kind` added.
    #[must_use]
    pub const fn with(self, kind: PrimitiveKind) -> Self {
        Self(self.0 | 1 << kind as u32)
    }

    /// Whether the set holds `kind`.
    #[must_use]
    pub const fn has(self, kind: PrimitiveKind) -> bool {
        self.0 & (1 << kind as u32) != 0
    }

    /// The `HAS_*` constants of the shaders: one per kind, `HAS_SHAPE` for any of the four
    /// solid shapes.
    #[must_use]
    pub fn wgsl(self) -> String {
        let mut out = String::new();
        let shape = PrimitiveKind::ALL
            .into_iter()
            .any(|k| k.is_shape() && self.has(k));
        for (name, present) in [
            ("HAS_POINT", self.has(PrimitiveKind::Point)),
            (
                "HAS_DISTANCE_SEGMENT",
                self.has(PrimitiveKind::DistanceSegment),
            ),
            ("HAS_SCALIS_SEGMENT", self.has(PrimitiveKind::ScalisSegment)),
            ("HAS_PLANE", self.has(PrimitiveKind::Plane)),
            ("HAS_SHAPE", shape),
            ("HAS_HRBF", self.has(PrimitiveKind::Hrbf)),
        ] {
            let _ = writeln!(out, "const {name}: bool = {present};");
        }
        out
    }
}

/// `Kernel.family`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum KernelFamily {
    /// Compact polynomial.
    CompactPolynomial = 0,
    /// Cauchy.
    Cauchy = 1,
    /// Gaussian.
    Gaussian = 2,
}

/// `Light.vector.w`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum LightKind {
    /// `vector.xyz` is the direction towards the light.
    Directional = 0,
    /// `vector.xyz` is the light's position.
    Point = 1,
}

/// `METHOD` of the inclusion marching family (inclusion.wgsl): which bound the march uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum MarchBound {
    /// Segment tracing's summed Lipschitz bound.
    Segment = 0,
    /// Linear Taylor inclusion.
    LinearTaylor = 1,
    /// Quadratic Taylor inclusion.
    QuadraticTaylor = 2,
    /// Bottom-up quadratic inclusion.
    BottomUpQuadratic = 3,
    /// Bottom-up linear inclusion.
    BottomUpLinear = 4,
    /// Per-group linear Taylor inclusions composed through the blend.
    LinearMixed = 5,
    /// Per-group quadratic Taylor inclusions composed through the blend.
    QuadraticMixed = 6,
}

/// Workgroups in a row of the `trace_rays` dispatch (main.wgsl `STATS_ROW`).
pub const STATS_ROW: u32 = 1024;

/// The list of a statistics ray off the axes: every primitive, which the shader walks the
/// scene's hierarchy for (main.wgsl `trace_rays`, shared/supports.wgsl `gather_every`).
pub const EVERY_PRIMITIVE: u32 = u32::MAX;

/// The size of a ray's window of supports (shared/supports.wgsl `RaySupports`; emitted as
/// `RAY_SUPPORTS` by `shared::wgsl_constants`): a ray that crosses more supports marches parts
/// cut at the window's horizon.
pub const RAY_SUPPORTS: usize = 64;

/// Depth bands per tile list (binning.wgsl): a tile lists its primitives band by band, by the
/// distance from the eye to their bounding spheres, so that a ray's window fill (shared/supports.wgsl
/// `fill_window`) stops at the first band that begins past what the window could still take.
pub const DEPTH_BANDS: u32 = 16;

/// Size of `Suspension` in shared/scene.wgsl: one per pixel of a panel, carrying a marching
/// method's rays from one dispatch to the next.
pub const SUSPENSION_BYTES: u64 = 28;

/// Size of `Path` in main.wgsl: one per pixel of a panel when the frame has secondary rays
/// (shadow rays, or transparent groups), the pixel's colour so far and the rays still to trace.
pub const PATH_BYTES: u64 = 384;

/// `Globals.secondary`: which secondary rays a frame traces (main.wgsl `trace_path`).
pub mod secondary {
    /// Exact shadow rays towards every light (core `RenderOptions::shadows`).
    pub const SHADOW_RAYS: u32 = 1;
    /// Each pixel follows its path of rays (shadow rays, or reflection and refraction at
    /// transparent groups) in `Path`, one ray after another.
    pub const PATHS: u32 = 2;
}

/// `PathRay.kind`: what a ray of a pixel's path is for. A cleared path starts with the pixel's
/// camera ray (kind 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum PathRayKind {
    /// The pixel's camera ray.
    Camera = 0,
    /// A reflected or refracted ray at a transparent group.
    Bounce = 1,
    /// A shadow ray from a hit towards a light.
    Shadow = 2,
}

/// Rays a path keeps pending (main.wgsl `Path.stack`): a transparent hit pushes at most two
/// and the next one taken is one of them, so the stack holds at most one per bounce level,
/// plus one.
pub const PATH_STACK: u32 = MAX_BOUNCES + 1;

/// A WGSL `const` of type `f32`.
fn f32_const(out: &mut String, name: &str, value: f64) {
    let _ = writeln!(out, "const {name}: f32 = {value:?};");
}

/// A WGSL `const` of type `u32`.
fn u32_const(out: &mut String, name: &str, value: u32) {
    let _ = writeln!(out, "const {name}: u32 = {value}u;");
}

/// A WGSL `const` array of `f32`.
fn f32_array(out: &mut String, name: &str, values: &[f64]) {
    let list: Vec<String> = values.iter().map(|v| format!("{v:?}")).collect();
    let _ = writeln!(
        out,
        "const {name}: array<f32, {n}> = array<f32, {n}>({});",
        list.join(", "),
        n = values.len()
    );
}

/// Every shared constant as WGSL source.
#[must_use]
pub fn wgsl_constants() -> String {
    let mut out = String::from("// Emitted by render/src/shared.rs from the Rust definitions.\n");
    u32_const(&mut out, "STATS_ROW", STATS_ROW);
    u32_const(&mut out, "EVERY_PRIMITIVE", EVERY_PRIMITIVE);
    u32_const(&mut out, "RAY_SUPPORTS", RAY_SUPPORTS as u32);
    for kind in PrimitiveKind::ALL {
        u32_const(&mut out, kind.wgsl_name(), kind as u32);
    }
    for (name, family) in [
        ("KERNEL_COMPACT_POLYNOMIAL", KernelFamily::CompactPolynomial),
        ("KERNEL_CAUCHY", KernelFamily::Cauchy),
        ("KERNEL_GAUSSIAN", KernelFamily::Gaussian),
    ] {
        u32_const(&mut out, name, family as u32);
    }
    u32_const(&mut out, "LIGHT_DIRECTIONAL", LightKind::Directional as u32);
    u32_const(&mut out, "LIGHT_POINT", LightKind::Point as u32);
    for (name, bound) in [
        ("BOUND_SEGMENT", MarchBound::Segment),
        ("BOUND_LINEAR_TAYLOR", MarchBound::LinearTaylor),
        ("BOUND_QUADRATIC_TAYLOR", MarchBound::QuadraticTaylor),
        ("BOUND_BOTTOM_UP_QUADRATIC", MarchBound::BottomUpQuadratic),
        ("BOUND_BOTTOM_UP_LINEAR", MarchBound::BottomUpLinear),
        ("BOUND_LINEAR_MIXED", MarchBound::LinearMixed),
        ("BOUND_QUADRATIC_MIXED", MarchBound::QuadraticMixed),
    ] {
        u32_const(&mut out, name, bound as u32);
    }
    u32_const(&mut out, "DEPTH_BANDS", DEPTH_BANDS);
    u32_const(&mut out, "SECONDARY_SHADOW_RAYS", secondary::SHADOW_RAYS);
    u32_const(&mut out, "SECONDARY_PATHS", secondary::PATHS);
    u32_const(&mut out, "RAY_CAMERA", PathRayKind::Camera as u32);
    u32_const(&mut out, "RAY_BOUNCE", PathRayKind::Bounce as u32);
    u32_const(&mut out, "RAY_SHADOW", PathRayKind::Shadow as u32);
    u32_const(&mut out, "MAX_BOUNCES", MAX_BOUNCES);
    u32_const(&mut out, "PATH_STACK", PATH_STACK);
    // Field shading (2014 notes §12.4), the CPU's constants (core frame.rs).
    u32_const(&mut out, "SOFT_SHADOW_STEPS", shading::SOFT_SHADOW_STEPS);
    f32_const(&mut out, "SOFTNESS", shading::SOFTNESS);
    f32_const(&mut out, "SHADE_MIN_STEP", shading::MIN_STEP);
    f32_const(&mut out, "SHADE_MAX_STEP", shading::MAX_STEP);
    f32_const(&mut out, "SHADOW_REACH", shading::SHADOW_REACH);
    u32_const(&mut out, "AO_SAMPLES", shading::AO_SAMPLES);
    f32_const(&mut out, "AO_STEP", shading::AO_STEP);
    f32_const(&mut out, "AO_DECAY", shading::AO_DECAY);
    // The SCALIS quadrature rule (MATH.md §3): its positive half, nodes increasing; the rule is
    // symmetric, so node j and −node j share weight j.
    let rule = GaussLegendre::scalis();
    let half = SCALIS_ORDER / 2;
    u32_const(&mut out, "SCALIS_ORDER", SCALIS_ORDER as u32);
    u32_const(&mut out, "GL_HALF", half as u32);
    f32_array(&mut out, "GL_NODES", &rule.nodes[SCALIS_ORDER - half..]);
    f32_array(&mut out, "GL_WEIGHTS", &rule.weights[SCALIS_ORDER - half..]);
    // The step-count colour map (core frame.rs heat_colour).
    for (name, row) in ["TURBO_RED", "TURBO_GREEN", "TURBO_BLUE"]
        .into_iter()
        .zip(TURBO)
    {
        f32_array(&mut out, name, &row);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::KindSet;

    /// Every set of kinds is compiled for a tier that holds it, and for the smallest such.
    #[test]
    fn every_kind_set_is_compiled_for_the_smallest_tier_holding_it() {
        for bits in 0..=KindSet::ALL.0 {
            let set = KindSet(bits);
            let tier = set.covering();
            assert!(KindSet::TIERS.contains(&tier));
            assert_eq!(tier.0 & bits, bits, "{set:?} not in {tier:?}");
            let smallest = KindSet::TIERS.iter().find(|t| t.0 & bits == bits);
            assert_eq!(Some(&tier), smallest);
        }
        assert_eq!(KindSet::ALL.0.count_ones(), 9);
    }
}
