//! [`MethodId`]: the one identity of a root-finding method across the crates — its command-line
//! name (DESIGN.md's method table), whether it is conservative, which backends implement it,
//! and the CPU implementation. The GPU crate, the CLI, the editor and the tests name methods
//! through it; no crate compares method names as strings.

use std::fmt;
use std::str::FromStr;

use super::{
    AcceleratedSphereTracing, AffineArithmetic, BottomUpLinear, BottomUpLinearBisection,
    BottomUpQuadratic, EnhancedSphereTracing, FieldInversion, LinearMixed, LinearTaylor, Method,
    NormalizedSphereTracing, QuadraticMixed, QuadraticTaylor, Reference, ScalisQuadratic,
    SegmentOriginal, SegmentTracing, Sherstyuk, SphereTracing,
};

/// A root-finding method, in the order of DESIGN.md's table.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum MethodId {
    /// `sphere`: global Lipschitz bound (2014 notes §6).
    Sphere,
    /// `sphere-enhanced`: over-relaxed sphere tracing (2014 notes §12.1).
    SphereEnhanced,
    /// `sphere-accelerated`: Bálint & Valasek 2018 (MATH.md §6).
    SphereAccelerated,
    /// `sphere-normalized`: sphere tracing on the normalised field (2021 app. B).
    SphereNormalized,
    /// `segment-original`: segment tracing as Galin et al. 2020 publish it (2023 Table 1's
    /// baseline).
    SegmentOriginal,
    /// `segment`: segment tracing with local directional Lipschitz bounds.
    Segment,
    /// `linear-taylor` (2023 §5.1).
    LinearTaylor,
    /// `quadratic-taylor` (2023 §6.1).
    QuadraticTaylor,
    /// `bottom-up-linear` (2023 §5.2).
    BottomUpLinear,
    /// `bottom-up-linear-bisection` (2023 §5.2, validity intervals §4.2).
    BottomUpLinearBisection,
    /// `bottom-up-quadratic` (2023 §6.2).
    BottomUpQuadratic,
    /// `linear-mixed` (2023 §7.2).
    LinearMixed,
    /// `quadratic-mixed` (2023 §7.2).
    QuadraticMixed,
    /// `affine`: revised affine arithmetic with bisection (MATH.md §8).
    Affine,
    /// `field-inversion`: Bruckner 2019 (2023 §7.1).
    FieldInversion,
    /// `scalis-quadratic`: the SCALIS quadratic-interpolation tracer (2021 §5–7).
    ScalisQuadratic,
    /// `sherstyuk`: polynomial approximation per primitive (2021 comparison).
    Sherstyuk,
    /// `reference`: robust interval bisection, the ground truth (MATH.md §7).
    Reference,
}

impl MethodId {
    /// Every method, in the order of DESIGN.md's table.
    pub const ALL: [Self; 18] = [
        Self::Sphere,
        Self::SphereEnhanced,
        Self::SphereAccelerated,
        Self::SphereNormalized,
        Self::SegmentOriginal,
        Self::Segment,
        Self::LinearTaylor,
        Self::QuadraticTaylor,
        Self::BottomUpLinear,
        Self::BottomUpLinearBisection,
        Self::BottomUpQuadratic,
        Self::LinearMixed,
        Self::QuadraticMixed,
        Self::Affine,
        Self::FieldInversion,
        Self::ScalisQuadratic,
        Self::Sherstyuk,
        Self::Reference,
    ];

    /// The command-line name.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Sphere => "sphere",
            Self::SphereEnhanced => "sphere-enhanced",
            Self::SphereAccelerated => "sphere-accelerated",
            Self::SphereNormalized => "sphere-normalized",
            Self::SegmentOriginal => "segment-original",
            Self::Segment => "segment",
            Self::LinearTaylor => "linear-taylor",
            Self::QuadraticTaylor => "quadratic-taylor",
            Self::BottomUpLinear => "bottom-up-linear",
            Self::BottomUpLinearBisection => "bottom-up-linear-bisection",
            Self::BottomUpQuadratic => "bottom-up-quadratic",
            Self::LinearMixed => "linear-mixed",
            Self::QuadraticMixed => "quadratic-mixed",
            Self::Affine => "affine",
            Self::FieldInversion => "field-inversion",
            Self::ScalisQuadratic => "scalis-quadratic",
            Self::Sherstyuk => "sherstyuk",
            Self::Reference => "reference",
        }
    }

    /// The CPU implementation.
    #[must_use]
    pub fn method(self) -> Box<dyn Method> {
        match self {
            Self::Sphere => Box::new(SphereTracing),
            Self::SphereEnhanced => Box::new(EnhancedSphereTracing),
            Self::SphereAccelerated => Box::new(AcceleratedSphereTracing),
            Self::SphereNormalized => Box::new(NormalizedSphereTracing),
            Self::SegmentOriginal => Box::new(SegmentOriginal),
            Self::Segment => Box::new(SegmentTracing),
            Self::LinearTaylor => Box::new(LinearTaylor),
            Self::QuadraticTaylor => Box::new(QuadraticTaylor),
            Self::BottomUpLinear => Box::new(BottomUpLinear),
            Self::BottomUpLinearBisection => Box::new(BottomUpLinearBisection),
            Self::BottomUpQuadratic => Box::new(BottomUpQuadratic),
            Self::LinearMixed => Box::new(LinearMixed),
            Self::QuadraticMixed => Box::new(QuadraticMixed),
            Self::Affine => Box::new(AffineArithmetic),
            Self::FieldInversion => Box::new(FieldInversion),
            Self::ScalisQuadratic => Box::new(ScalisQuadratic),
            Self::Sherstyuk => Box::new(Sherstyuk),
            Self::Reference => Box::new(Reference),
        }
    }

    /// Whether the method is guaranteed never to miss a crossing.
    #[must_use]
    pub fn is_conservative(self) -> bool {
        self.method().is_conservative()
    }

    /// Whether the GPU backend (`skeletrace-render`) has an implementation; which scenes it
    /// runs on is the GPU backend's `supports`. The render crate checks in a test that its
    /// shaders cover exactly these methods.
    #[must_use]
    pub const fn has_gpu_implementation(self) -> bool {
        matches!(
            self,
            Self::Sphere
                | Self::SphereEnhanced
                | Self::SphereAccelerated
                | Self::SphereNormalized
                | Self::SegmentOriginal
                | Self::Segment
                | Self::LinearTaylor
                | Self::QuadraticTaylor
                | Self::BottomUpQuadratic
                | Self::BottomUpLinear
                | Self::LinearMixed
                | Self::QuadraticMixed
                | Self::ScalisQuadratic
                | Self::Sherstyuk
                | Self::FieldInversion
        )
    }

    /// Parses a comma-separated list of names (spaces around names allowed).
    ///
    /// # Errors
    /// The first unknown name, with the known ones.
    pub fn parse_list(list: &str) -> Result<Vec<Self>, String> {
        list.split(',').map(|name| name.trim().parse()).collect()
    }
}

impl fmt::Display for MethodId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for MethodId {
    type Err = String;

    fn from_str(name: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|m| m.name() == name)
            .ok_or_else(|| {
                let known: Vec<&str> = Self::ALL.iter().map(|m| m.name()).collect();
                format!("unknown method '{name}'; available: {}", known.join(", "))
            })
    }
}
