//! The scene packed for the GPU: `#[repr(C)]` + bytemuck twins of the WGSL structs in
//! `shaders/shared/scene.wgsl`, built from a [`Compiled`] scene.
//!
//! The GPU evaluates every primitive — point blobs, distance and SCALIS segments, planes, boxes,
//! rounded boxes, tori, cylinders and HRBF terms — in up to [`MAX_GROUPS`] groups under any
//! blend tree (compiled to WGSL with the scene's group count: [`BlendWgsl`]). Scenes with more
//! groups are refused with a message, and the caller falls back to the CPU tracer.

use crate::ray_bvh::RayBvh;
use bytemuck::{Pod, Zeroable};
use skeletrace_core::FieldProgram;
use skeletrace_core::compile::Compiled;
use skeletrace_core::field::blend::BlendTree;
use skeletrace_core::field::primitives::{Primitive, Solid};
use skeletrace_core::model::kernel::Kernel;
use skeletrace_core::model::scene::Light;

use crate::blend_wgsl::{BlendWgsl, blend_parameters};
pub use crate::shared::MAX_GROUPS;
use crate::shared::{KernelFamily, KindSet, LightKind, PrimitiveKind};

/// Twin of `Primitive` in shared/scene.wgsl.
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
    /// HRBF term: index in [`PackedScene::boxes`] of its set's box (three `vec4`s: the frame's
    /// local `y` axis, the box's local minimum and maximum corners).
    pub extra: u32,
    /// Point: centre and radius; segment: start (smaller radius) and radius; plane: normal,
    /// offset; other shapes: centre and radius `ρ`.
    pub a: [f32; 4],
    /// Segment: unit axis and length; plane: radius in `x`; other shapes: the solid's
    /// dimensions ([`solid_dimensions`]).
    pub b: [f32; 4],
    /// `x`: normalisation; segment: `y` radius slope; point blob and SCALIS segment: `z` the
    /// kernel's support radius in radii (the tile binning's hull of the support, core
    /// `Primitive::support_hull`); shapes but planes: `yzw` the local `y` axis.
    pub c: [f32; 4],
    /// Shapes but planes: the local `x` axis, and in `w` the frame's handedness (±1): the local
    /// `z` axis is `w·(x × y)`.
    pub d: [f32; 4],
    /// Bounding sphere of the support; `w < 0` for unbounded supports.
    pub bound: [f32; 4],
}

/// Twin of `Kernel` in shared/scene.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuKernel {
    /// 0 compact, 1 Cauchy, 2 Gaussian.
    pub family: u32,
    /// Whether `K′` jumps at the support boundary.
    pub kinked: u32,
    /// Whether the group's field is clamped at 0 (it holds an HRBF set).
    pub clamped: u32,
    /// Padding.
    pub pad: u32,
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

/// Twin of `Light` in shared/scene.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    /// Direction towards the light or position; `w`: 0 directional, 1 point.
    pub vector: [f32; 4],
    /// Colour; `w`: intensity.
    pub colour: [f32; 4],
}

/// Twin of `Material` in shared/scene.wgsl: a group's material.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    /// Base colour; `w`: opacity.
    pub colour: [f32; 4],
    /// `x`: index of refraction.
    pub ior: [f32; 4],
}

impl GpuMaterial {
    /// Whether light passes through the group (reflection and refraction, main.wgsl).
    #[must_use]
    pub fn transparent(&self) -> bool {
        self.colour[3] < 1.0
    }
}

/// A scene in GPU layout.
#[derive(Clone, Debug, PartialEq)]
pub struct PackedScene {
    /// Primitives, in program order.
    pub primitives: Vec<GpuPrimitive>,
    /// One kernel per group.
    pub kernels: Vec<GpuKernel>,
    /// One material per group.
    pub materials: Vec<GpuMaterial>,
    /// Lights.
    pub lights: Vec<GpuLight>,
    /// The blend tree's structure as WGSL.
    pub blend: BlendWgsl,
    /// Its operators' parameters, the slots its code reads ([`blend_parameters`]); never empty
    /// (a storage binding holds at least one value).
    pub blend_parameters: Vec<f32>,
    /// The kinds its pipelines are compiled for: the tier covering those of
    /// [`PackedScene::primitives`] ([`KindSet::covering`]).
    pub kinds: KindSet,
    /// The boxes of the HRBF sets, three `vec4`s each ([`GpuPrimitive::extra`]).
    pub boxes: Vec<[f32; 4]>,
    /// The hierarchy over the supports, for rays that leave the screen tiles.
    pub bvh: RayBvh,
}

fn f4(v: glam::DVec3, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

/// Whether each group's own field bounds the blended field from below wherever it is at least
/// the isovalue, which the tile binning's occluders need: some leaf of the group must be reached
/// from the root through sums, maxima, smooth unions (≥ the maximum) and Ricci blends (≥ their
/// largest positive operand) only, with every other operand of each sum on the way
/// non-negative (no difference or smooth intersection below it, which may go negative).
fn occluding_groups(tree: &BlendTree, groups: usize) -> Vec<bool> {
    fn non_negative(tree: &BlendTree) -> bool {
        match tree {
            BlendTree::Group(_) => true,
            BlendTree::Difference(..) | BlendTree::SmoothIntersection { .. } => false,
            BlendTree::Sum(v)
            | BlendTree::Max(v)
            | BlendTree::Min(v)
            | BlendTree::Ricci { of: v, .. }
            | BlendTree::SmoothUnion { of: v, .. } => v.iter().all(non_negative),
        }
    }
    fn mark(tree: &BlendTree, out: &mut [bool]) {
        match tree {
            BlendTree::Group(g) => {
                if let Some(o) = out.get_mut(*g as usize) {
                    *o = true;
                }
            }
            BlendTree::Sum(v) => {
                for (k, child) in v.iter().enumerate() {
                    let others = v.iter().enumerate().all(|(j, c)| j == k || non_negative(c));
                    if others {
                        mark(child, out);
                    }
                }
            }
            BlendTree::Max(v)
            | BlendTree::Ricci { of: v, .. }
            | BlendTree::SmoothUnion { of: v, .. } => {
                for child in v {
                    mark(child, out);
                }
            }
            BlendTree::Min(_)
            | BlendTree::Difference(..)
            | BlendTree::SmoothIntersection { .. } => {}
        }
    }
    let mut out = vec![false; groups];
    mark(tree, &mut out);
    out
}

/// The shader kind of a primitive (`Primitive.kind` in shared/scene.wgsl).
fn gpu_kind(p: &Primitive) -> PrimitiveKind {
    match p {
        Primitive::Point(_) => PrimitiveKind::Point,
        Primitive::Distance(_) => PrimitiveKind::DistanceSegment,
        Primitive::Scalis(_) => PrimitiveKind::ScalisSegment,
        Primitive::Shape(s) => match s.solid {
            Solid::Plane { .. } => PrimitiveKind::Plane,
            Solid::Box { .. } => PrimitiveKind::Box,
            Solid::RoundedBox { .. } => PrimitiveKind::RoundedBox,
            Solid::Torus { .. } => PrimitiveKind::Torus,
            Solid::Cylinder { .. } => PrimitiveKind::Cylinder,
        },
        Primitive::Hrbf(_) => PrimitiveKind::Hrbf,
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

/// The dimensions of a solid: a plane's normal and offset (its `GpuPrimitive.a`); as
/// `GpuPrimitive.b` of the other shapes, a box's half extents (and a rounded box's rounding in
/// `w`), a torus's major and minor radii, a cylinder's radius and half height.
fn solid_dimensions(solid: Solid) -> [f32; 4] {
    match solid {
        Solid::Box { half_extents } => f4(half_extents, 0.0),
        Solid::RoundedBox {
            half_extents,
            rounding,
        } => f4(half_extents, rounding),
        Solid::Torus { major, minor } => [major as f32, minor as f32, 0.0, 0.0],
        Solid::Cylinder {
            radius,
            half_height,
        } => [radius as f32, half_height as f32, 0.0, 0.0],
        Solid::Plane { normal, offset } => f4(normal, offset),
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
            skeletrace_core::model::kernel::CLIP_EPSILON,
        ),
        Kernel::Gaussian { scale } => (
            KernelFamily::Gaussian,
            0.0,
            scale,
            skeletrace_core::model::kernel::CLIP_EPSILON,
        ),
    };
    GpuKernel {
        family: family as u32,
        kinked: u32::from(profile.is_kinked()),
        clamped: 0,
        pad: 0,
        exponent: exponent as f32,
        inv_sigma2: (1.0 / (sigma * sigma)) as f32,
        support_sq: profile.support_sq() as f32,
        clip: clip as f32,
        clip_scale: (1.0 / (1.0 - clip)) as f32,
        pad2: [0.0; 3],
    }
}

impl PackedScene {
    /// `Err` with the reason when the GPU backend does not evaluate `program` (too many
    /// groups), without packing anything.
    ///
    /// # Errors
    /// What the GPU lacks for this scene.
    pub fn check(program: &FieldProgram) -> Result<(), String> {
        let groups = program.group_count();
        if groups > MAX_GROUPS {
            return Err(format!(
                "the GPU backend handles at most {MAX_GROUPS} groups (this scene has {groups})"
            ));
        }
        Ok(())
    }

    /// Packs a compiled scene.
    ///
    /// # Errors
    /// What the GPU backend does not evaluate in this scene.
    pub fn new(compiled: &Compiled) -> Result<Self, String> {
        let program = &compiled.program;
        let groups = program.group_count();
        Self::check(program)?;
        let blend = BlendWgsl::new(program.blend(), groups);
        let mut blend_parameters = blend_parameters(program.blend());
        if blend_parameters.is_empty() {
            blend_parameters.push(0.0);
        }
        let occluding = occluding_groups(program.blend(), groups);
        let mut primitives = Vec::with_capacity(program.primitives().len());
        let mut boxes = Vec::new();
        let mut kinds = KindSet::NONE;
        for (i, p) in program.primitives().iter().enumerate() {
            let k = program.kernel_of(i as u32);
            let group = program.group_of(i as u32) as u32;
            let bound = p.support_aabb(k).map_or([0.0, 0.0, 0.0, -1.0], |b| {
                f4(b.center(), 0.5 * b.diagonal())
            });
            let kind = gpu_kind(p);
            kinds = kinds.with(kind);
            let mut extra = 0;
            let (a, b, c, d) = match p {
                Primitive::Point(x) => (
                    f4(x.center, x.radius),
                    [0.0; 4],
                    [x.norm as f32, 0.0, k.support_radius() as f32, 0.0],
                    [0.0; 4],
                ),
                Primitive::Distance(x) => (
                    f4(x.cone.start, x.cone.radius),
                    f4(x.cone.axis, x.cone.length),
                    [x.norm as f32, x.cone.slope as f32, 0.0, 0.0],
                    [0.0; 4],
                ),
                Primitive::Scalis(x) => (
                    f4(x.cone.start, x.cone.radius),
                    f4(x.cone.axis, x.cone.length),
                    [
                        x.norm as f32,
                        x.cone.slope as f32,
                        k.support_radius() as f32,
                        0.0,
                    ],
                    [0.0; 4],
                ),
                Primitive::Shape(s) => match s.solid {
                    Solid::Plane { .. } => (
                        solid_dimensions(s.solid),
                        [s.radius as f32, 0.0, 0.0, 0.0],
                        [s.norm as f32, 0.0, 0.0, 0.0],
                        [0.0; 4],
                    ),
                    solid => {
                        let (x, y) = (s.frame.x_axis, s.frame.y_axis);
                        let handedness = x.cross(y).dot(s.frame.z_axis).signum();
                        (
                            f4(s.center, s.radius),
                            solid_dimensions(solid),
                            [s.norm as f32, y.x as f32, y.y as f32, y.z as f32],
                            f4(x, handedness),
                        )
                    }
                },
                Primitive::Hrbf(h) => {
                    let (x, y) = (h.frame.x_axis, h.frame.y_axis);
                    let handedness = x.cross(y).dot(h.frame.z_axis).signum();
                    let set_box = [f4(y, 0.0), f4(h.bounds.min, 0.0), f4(h.bounds.max, 0.0)];
                    // The terms of one set share its box: stored once.
                    if boxes.len() < 3 || boxes[boxes.len() - 3..] != set_box {
                        boxes.extend_from_slice(&set_box);
                    }
                    extra = (boxes.len() - 3) as u32;
                    (
                        f4(h.center, h.alpha),
                        f4(h.beta, h.constant),
                        f4(h.linear, 0.0),
                        f4(x, handedness),
                    )
                }
            };
            primitives.push(GpuPrimitive {
                kind: kind as u32,
                group,
                occluder: if occluding[group as usize] {
                    occluder_radius(p, k, program.isovalue())
                } else {
                    0.0
                },
                extra,
                a,
                b,
                c,
                d,
                bound,
            });
        }
        Ok(Self {
            bvh: RayBvh::new(program),
            kinds: kinds.covering(),
            primitives,
            kernels: (0..groups)
                .map(|g| GpuKernel {
                    clamped: u32::from(program.group_is_clamped(g)),
                    ..kernel(program.group_kernel_spec(g))
                })
                .collect(),
            // A storage buffer is never empty.
            boxes: if boxes.is_empty() {
                vec![[0.0; 4]]
            } else {
                boxes
            },
            materials: compiled
                .materials
                .iter()
                .map(|m| {
                    let c = m.color;
                    GpuMaterial {
                        colour: [c[0] as f32, c[1] as f32, c[2] as f32, m.opacity as f32],
                        ior: [m.ior as f32, 0.0, 0.0, 0.0],
                    }
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
            blend_parameters,
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

    fn groups(n: u32) -> Vec<BlendTree> {
        (0..n).map(BlendTree::Group).collect()
    }

    /// Generated blobs in `groups` groups under a max.
    fn blobs_in_groups(groups: usize) -> std::sync::Arc<Compiled> {
        use skeletrace_core::model::generate::{GenerateOptions, GeneratorKind, generate};
        let options = GenerateOptions {
            seed: 9,
            size: Some(2 * groups),
            groups: Some(groups),
            ..GenerateOptions::default()
        };
        let scene = generate(GeneratorKind::Blobs, &options).unwrap_or_else(|e| panic!("{e}"));
        skeletrace_core::compile(&scene)
    }

    /// The shaders hold one slot per group of the scene, up to [`MAX_GROUPS`]; past it the
    /// scene is refused with the limit and its own count.
    #[test]
    fn shaders_hold_a_slot_per_group_up_to_the_limit() {
        for groups in [1, 3, 9, MAX_GROUPS] {
            let packed =
                PackedScene::new(&blobs_in_groups(groups)).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(packed.blend.groups as usize, groups);
            assert_eq!(
                packed.blend.groups_constant(),
                format!("const GROUPS: u32 = {groups}u;\n")
            );
        }
        let too_many = MAX_GROUPS + 1;
        let refused = PackedScene::new(&blobs_in_groups(too_many))
            .err()
            .unwrap_or_else(|| panic!("{too_many} groups packed"));
        assert!(
            refused.contains(&format!("at most {MAX_GROUPS} groups"))
                && refused.contains(&format!("this scene has {too_many}")),
            "{refused}"
        );
    }

    /// Occluders are kept for the groups that bound the blend from below, and only those.
    #[test]
    fn occluders_are_kept_for_the_groups_that_bound_the_blend() {
        // Ricci(Difference(0, 1), 2): the carved group and the carving one do not.
        assert_eq!(
            occluding_groups(
                &BlendTree::Ricci {
                    p: 4.0,
                    of: vec![
                        BlendTree::Difference(
                            Box::new(BlendTree::Group(0)),
                            Box::new(BlendTree::Group(1))
                        ),
                        BlendTree::Group(2)
                    ]
                },
                3
            ),
            [false, false, true]
        );
        // A sum with an operand that may be negative: no operand bounds it.
        let difference =
            BlendTree::Difference(Box::new(BlendTree::Group(1)), Box::new(BlendTree::Group(2)));
        assert_eq!(
            occluding_groups(
                &BlendTree::Sum(vec![BlendTree::Group(0), difference.clone()]),
                3
            ),
            [false, false, false]
        );
        assert_eq!(
            occluding_groups(&BlendTree::Max(vec![BlendTree::Group(0), difference]), 3),
            [true, false, false]
        );
        assert_eq!(
            occluding_groups(
                &BlendTree::SmoothUnion {
                    width: 0.3,
                    of: vec![BlendTree::Sum(groups(2)), BlendTree::Min(groups(3))]
                },
                3
            ),
            [true, true, false]
        );
        assert_eq!(
            occluding_groups(
                &BlendTree::SmoothIntersection {
                    width: 0.3,
                    of: groups(2)
                },
                2
            ),
            [false, false]
        );
    }
}
