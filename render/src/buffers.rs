//! The scene packed for the GPU: `#[repr(C)]` + bytemuck twins of the WGSL structs in
//! `shaders/prelude.wgsl`, built from a [`Compiled`] scene.
//!
//! The GPU evaluates point blobs, distance and SCALIS segments and planes, up to
//! [`MAX_GROUPS`] groups combined by one sum, max, min, smooth union or smooth intersection
//! (flat blend trees: every asset's, and every one the editor's blend menu builds except
//! difference and Ricci). Other scenes (boxes, tori, cylinders, HRBF sets, difference or Ricci
//! blends, nested trees) are refused with a message, and the caller falls back to the CPU
//! tracer.

use bytemuck::{Pod, Zeroable};
use skeletrace_core::FieldProgram;
use skeletrace_core::compile::Compiled;
use skeletrace_core::field::blend::BlendTree;
use skeletrace_core::field::kernel::Kernel;
use skeletrace_core::field::primitives::{Primitive, Solid};
use skeletrace_core::model::scene::Light;

pub use crate::shared::BlendOperator;
pub use crate::shared::MAX_GROUPS;
use crate::shared::{KernelFamily, LightKind, PrimitiveKind};

/// Twin of `Primitive` in prelude.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuPrimitive {
    /// 0 point blob, 1 distance segment, 2 SCALIS segment, 3 plane.
    pub kind: u32,
    /// Group index.
    pub group: u32,
    /// Radius of the occluder sphere (0: none): a ball inside the surface, centred on a point
    /// blob or on a distance segment's larger end ([`occluder_radius`]).
    pub occluder: f32,
    /// Padding.
    pub pad: u32,
    /// Point: centre and radius; segment: start (smaller radius) and radius; plane: normal, offset.
    pub a: [f32; 4],
    /// Segment: unit axis and length; plane: radius in `x`.
    pub b: [f32; 4],
    /// `x`: normalisation, `y`: radius slope.
    pub c: [f32; 4],
    /// Bounding sphere of the support; `w < 0` for unbounded supports.
    pub bound: [f32; 4],
}

/// Twin of `Kernel` in prelude.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuKernel {
    /// 0 compact, 1 Cauchy, 2 Gaussian.
    pub family: u32,
    /// Whether `K′` jumps at the support boundary.
    pub kinked: u32,
    /// Padding.
    pub pad: [u32; 2],
    /// `m` (compact) or `n = i/2` (Cauchy).
    pub exponent: f32,
    /// `1/σ²`.
    pub inv_sigma2: f32,
    /// Squared support radius.
    pub support_sq: f32,
    /// Clipping value ε (0 for compact kernels).
    pub clip: f32,
    /// `1/(1 − ε)`.
    pub clip_scale: f32,
    /// Padding.
    pub pad2: [f32; 3],
}

/// Twin of `Light` in prelude.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    /// Direction towards the light or position; `w`: 0 directional, 1 point.
    pub vector: [f32; 4],
    /// Colour; `w`: intensity.
    pub colour: [f32; 4],
}

/// A scene in GPU layout.
#[derive(Clone, Debug, PartialEq)]
pub struct PackedScene {
    /// Primitives, in program order.
    pub primitives: Vec<GpuPrimitive>,
    /// One kernel per group.
    pub kernels: Vec<GpuKernel>,
    /// Base colour per group (`w`: opacity).
    pub materials: Vec<[f32; 4]>,
    /// Lights.
    pub lights: Vec<GpuLight>,
    /// Blend operator over all groups.
    pub blend: BlendOperator,
    /// Width of the smooth operators (0 for the others).
    pub blend_width: f32,
}

fn f4(v: glam::DVec3, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

/// The blend operator of a flat tree whose leaves are every group once, if it is one, with the
/// width of the smooth operators. Sums, maxima and minima take their leaves in any order; the
/// smooth operators fold their operands left to right (blend.rs), and the shaders fold groups
/// in index order, so their leaves must be the groups in that order.
fn flat_blend(blend: &BlendTree, groups: usize) -> Option<(BlendOperator, f32)> {
    let (op, width, children) = match blend {
        BlendTree::Group(0) if groups == 1 => return Some((BlendOperator::Sum, 0.0)),
        BlendTree::Sum(v) => (BlendOperator::Sum, 0.0, v),
        BlendTree::Max(v) => (BlendOperator::Max, 0.0, v),
        BlendTree::Min(v) => (BlendOperator::Min, 0.0, v),
        BlendTree::SmoothUnion { width, of } => (BlendOperator::SmoothUnion, *width as f32, of),
        BlendTree::SmoothIntersection { width, of } => {
            (BlendOperator::SmoothIntersection, *width as f32, of)
        }
        _ => return None,
    };
    if matches!(
        op,
        BlendOperator::SmoothUnion | BlendOperator::SmoothIntersection
    ) {
        let in_order = children.len() == groups
            && children
                .iter()
                .enumerate()
                .all(|(k, c)| *c == BlendTree::Group(k as u32));
        return in_order.then_some((op, width));
    }
    let mut seen = vec![false; groups];
    for c in children {
        match c {
            BlendTree::Group(i) if (*i as usize) < groups && !seen[*i as usize] => {
                seen[*i as usize] = true;
            }
            _ => return None,
        }
    }
    seen.iter().all(|s| *s).then_some((op, width))
}

/// The shader kind of a primitive, or why the GPU backend does not evaluate it: the one place
/// that says which primitives the GPU has shaders for.
fn gpu_kind(p: &Primitive) -> Result<PrimitiveKind, String> {
    match p {
        Primitive::Point(_) => Ok(PrimitiveKind::Point),
        Primitive::Distance(_) => Ok(PrimitiveKind::DistanceSegment),
        Primitive::Scalis(_) => Ok(PrimitiveKind::ScalisSegment),
        Primitive::Shape(s) => match s.solid {
            Solid::Plane { .. } => Ok(PrimitiveKind::Plane),
            other => Err(format!(
                "the GPU backend does not evaluate {} shapes yet",
                match other {
                    Solid::Box { .. } => "box",
                    Solid::RoundedBox { .. } => "rounded box",
                    Solid::Torus { .. } => "torus",
                    _ => "cylinder",
                }
            )),
        },
        Primitive::Hrbf(_) => Err("the GPU backend does not evaluate HRBF sets yet".to_owned()),
    }
}

/// Fraction of a primitive's own surface radius that its occluder sphere takes: the sphere
/// stays inside the isolated primitive's surface by a margin that f32 rounding cannot cross.
const OCCLUDER_SHRINK: f64 = 0.999;

/// The radius of a ball inside the surface for the occluding depth of the tile binning (scalis
/// 2021 §7, "toward output sensitivity"; built from primitives in isolation, as that paper's
/// limitations suggest): a point blob's `N₀·K(d²/ρ²)` is at least `c` within `ρ` (MATH.md §2),
/// a distance segment's `N₀·K(h²)` within its larger end sphere (`h ≤ |p − end|/τ_end` there).
/// The radius is checked on the primitive's own field at the point of the ball's boundary where
/// that field is least over the ball (beyond the end along the axis for a segment); 0 where the
/// check fails and for other primitives (a SCALIS segment's isolated surface is not its
/// sphere-cone: scalis 2021 appendix A).
fn occluder_radius(
    primitive: &Primitive,
    k: &skeletrace_core::field::kernel::KernelProfile,
    isovalue: f64,
) -> f32 {
    let (centre, radius, outward) = match primitive {
        Primitive::Point(x) => (x.center, x.radius, glam::DVec3::X),
        Primitive::Distance(x) => (
            x.cone.start + x.cone.length * x.cone.axis,
            x.cone.radius + x.cone.slope * x.cone.length,
            x.cone.axis,
        ),
        _ => return 0.0,
    };
    let r = OCCLUDER_SHRINK * radius;
    if r > 0.0 && primitive.value(centre + r * outward, k) >= isovalue {
        r as f32
    } else {
        0.0
    }
}

fn kernel(k: Kernel) -> GpuKernel {
    let profile = skeletrace_core::field::kernel::KernelProfile::new(k);
    let (family, exponent, sigma, clip) = match k {
        Kernel::CompactPolynomial { degree, scale } => (
            KernelFamily::CompactPolynomial,
            f64::from(degree / 2),
            scale,
            0.0,
        ),
        Kernel::Cauchy { degree, scale } => (
            KernelFamily::Cauchy,
            f64::from(degree) / 2.0,
            scale,
            skeletrace_core::field::kernel::CLIP_EPSILON,
        ),
        Kernel::Gaussian { scale } => (
            KernelFamily::Gaussian,
            0.0,
            scale,
            skeletrace_core::field::kernel::CLIP_EPSILON,
        ),
    };
    GpuKernel {
        family: family as u32,
        kinked: u32::from(profile.is_kinked()),
        pad: [0; 2],
        exponent: exponent as f32,
        inv_sigma2: (1.0 / (sigma * sigma)) as f32,
        support_sq: profile.support_sq() as f32,
        clip: clip as f32,
        clip_scale: (1.0 / (1.0 - clip)) as f32,
        pad2: [0.0; 3],
    }
}

impl PackedScene {
    /// `Err` with the reason when the GPU backend does not evaluate `program` (too many groups,
    /// a nested blend, a primitive it has no shader for), without packing anything; otherwise
    /// the blend operator over the groups and its width.
    ///
    /// # Errors
    /// What the GPU lacks for this scene.
    pub fn check(program: &FieldProgram) -> Result<(BlendOperator, f32), String> {
        let groups = program.group_count();
        if groups > MAX_GROUPS {
            return Err(format!(
                "the GPU backend handles at most {MAX_GROUPS} groups (this scene has {groups})"
            ));
        }
        let blend = flat_blend(program.blend(), groups).ok_or_else(|| {
            "the GPU backend handles one sum, max, min or smooth union/intersection (of the \
             groups in order) over all groups; this scene's blend tree is nested or uses \
             difference/Ricci"
                .to_owned()
        })?;
        for p in program.primitives() {
            gpu_kind(p)?;
        }
        Ok(blend)
    }

    /// Packs a compiled scene.
    ///
    /// # Errors
    /// What the GPU backend does not evaluate in this scene.
    pub fn new(compiled: &Compiled) -> Result<Self, String> {
        let program = &compiled.program;
        let groups = program.group_count();
        let (blend, blend_width) = Self::check(program)?;
        // Occluders hold where a primitive's own field bounds the blended field from below:
        // sums of non-negative kernels, maxima and the smooth union (≥ the maximum).
        let occluding = matches!(
            blend,
            BlendOperator::Sum | BlendOperator::Max | BlendOperator::SmoothUnion
        );
        let mut primitives = Vec::with_capacity(program.primitives().len());
        for (i, p) in program.primitives().iter().enumerate() {
            let k = program.kernel_of(i as u32);
            let group = program.group_of(i as u32) as u32;
            let bound = p.support_aabb(k).map_or([0.0, 0.0, 0.0, -1.0], |b| {
                f4(b.center(), 0.5 * b.diagonal())
            });
            let kind = gpu_kind(p)?;
            let (a, b, c) = match p {
                Primitive::Point(x) => (
                    f4(x.center, x.radius),
                    [0.0; 4],
                    [x.norm as f32, 0.0, 0.0, 0.0],
                ),
                Primitive::Distance(x) => (
                    f4(x.cone.start, x.cone.radius),
                    f4(x.cone.axis, x.cone.length),
                    [x.norm as f32, x.cone.slope as f32, 0.0, 0.0],
                ),
                Primitive::Scalis(x) => (
                    f4(x.cone.start, x.cone.radius),
                    f4(x.cone.axis, x.cone.length),
                    [x.norm as f32, x.cone.slope as f32, 0.0, 0.0],
                ),
                Primitive::Shape(s) => match s.solid {
                    Solid::Plane { normal, offset } => (
                        f4(normal, offset),
                        [s.radius as f32, 0.0, 0.0, 0.0],
                        [s.norm as f32, 0.0, 0.0, 0.0],
                    ),
                    // `gpu_kind` refused every other shape above.
                    _ => continue,
                },
                Primitive::Hrbf(_) => continue,
            };
            primitives.push(GpuPrimitive {
                kind: kind as u32,
                group,
                occluder: if occluding {
                    occluder_radius(p, k, program.isovalue())
                } else {
                    0.0
                },
                pad: 0,
                a,
                b,
                c,
                bound,
            });
        }
        Ok(Self {
            primitives,
            kernels: (0..groups)
                .map(|g| kernel(program.group_kernel_spec(g)))
                .collect(),
            materials: compiled
                .materials
                .iter()
                .map(|m| {
                    let c = m.color;
                    [c[0] as f32, c[1] as f32, c[2] as f32, m.opacity as f32]
                })
                .collect(),
            lights: compiled
                .lights
                .iter()
                .map(|l| match l {
                    Light::Directional {
                        direction,
                        color,
                        intensity,
                    } => GpuLight {
                        vector: [
                            direction[0] as f32,
                            direction[1] as f32,
                            direction[2] as f32,
                            LightKind::Directional as u32 as f32,
                        ],
                        colour: [
                            color[0] as f32,
                            color[1] as f32,
                            color[2] as f32,
                            *intensity as f32,
                        ],
                    },
                    Light::Point {
                        position,
                        color,
                        intensity,
                    } => GpuLight {
                        vector: [
                            position[0] as f32,
                            position[1] as f32,
                            position[2] as f32,
                            LightKind::Point as u32 as f32,
                        ],
                        colour: [
                            color[0] as f32,
                            color[1] as f32,
                            color[2] as f32,
                            *intensity as f32,
                        ],
                    },
                })
                .collect(),
            blend,
            blend_width,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn packed(asset: &str) -> PackedScene {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join(format!("../assets/scenes/{asset}.ron"));
        let scene = skeletrace_core::Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        PackedScene::new(&skeletrace_core::compile(&scene)).unwrap_or_else(|e| panic!("{e}"))
    }

    /// Every point blob of the blob assets (compact and Gaussian kernels, under a sum) gets an
    /// occluder of its own radius, shrunk; SCALIS segments get none.
    #[test]
    fn point_blobs_occlude_and_scalis_segments_do_not() {
        for asset in ["blobs", "molecule"] {
            let scene = packed(asset);
            for p in &scene.primitives {
                assert_eq!(p.kind, PrimitiveKind::Point as u32, "{asset}");
                let expected = (OCCLUDER_SHRINK * f64::from(p.a[3])) as f32;
                assert!(
                    (p.occluder - expected).abs() <= 1e-6 * expected,
                    "{asset}: occluder {} for a blob of radius {}",
                    p.occluder,
                    p.a[3]
                );
            }
        }
        assert!(packed("tree").primitives.iter().all(|p| p.occluder == 0.0));
    }
}
