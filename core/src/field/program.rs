//! The field program: a scene flattened into primitives with their kernels, a blend tree and a
//! BVH over the supports (DESIGN.md: `Scene` → `FieldProgram` → tracers).
//!
//! Lifetimes: a program is built once per scene edit and then only read, from any number of
//! threads. Point queries (`value`, `value_gradient`) visit the primitives whose support box
//! contains the point; ray queries (`ray_jet`, `ray_supports`) those whose box meets the ray
//! interval. Group fields are sums of their primitives; the blend tree combines groups.

use glam::{DMat3, DVec3, EulerRot};

use crate::bounds::interval::{Interval, Jet};
use crate::field::blend::{self, BlendOperand, BlendTree};
use crate::field::bvh::Bvh;
use crate::field::geometry::{Aabb, Ray, Similarity, SphereCone};
use crate::field::hrbf_solve;
use crate::field::kernel::KernelProfile;
use crate::field::primitives::{
    DistanceSegment, HrbfTerm, PointBlob, Primitive, ScalisSegment, ShapePrimitive, Solid,
};
use crate::model::kernel::Kernel;
use crate::model::scene::{Group, Hrbf, Scene, Shape, Skeleton, SkeletonField, Vec3};

/// Groups evaluated without heap allocation per query.
const INLINE_GROUPS: usize = 8;

/// The part of a ray inside one primitive's support.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SupportSpan {
    /// Ray parameter interval inside the support (clipped to the query interval).
    pub span: Interval,
    /// Index of the primitive.
    pub primitive: u32,
}

/// A key whose unsigned order is [`f64::total_cmp`]'s order of `x` (its sign bit flipped for
/// positive numbers, every bit for negative ones), for sorting without a comparison closure.
fn total_order_key(x: f64) -> u64 {
    let bits = x.to_bits();
    if bits >> 63 == 0 {
        bits | (1 << 63)
    } else {
        !bits
    }
}

/// Adds the closed interval `s` to `parts`, sorted disjoint closed intervals with a gap between
/// each two, keeping them so: the parts `s` meets or touches become one with `s`. Whatever the
/// order of the intervals added, the parts are the connected pieces of their union, each from
/// the least entry (in [`f64::total_cmp`]'s order, as sorting the entries would take it) to the
/// greatest exit.
fn merge_into_parts(parts: &mut Vec<Interval>, s: Interval) {
    // `s` joined to the parts from `first` to `last`, which it meets.
    let joined = |first: Interval, last: Interval| Interval {
        lo: if total_order_key(s.lo) < total_order_key(first.lo) {
            s.lo
        } else {
            first.lo
        },
        hi: last.hi.max(s.hi),
    };
    // The common cases first (the supports come in the BVH's order, mostly near the last
    // part): `s` after every part, or entering inside the last one.
    match parts.last_mut() {
        Some(last) if s.lo > last.hi => {
            parts.push(s);
            return;
        }
        Some(last) if last.lo <= s.lo => {
            *last = joined(*last, *last);
            return;
        }
        _ => {}
    }
    // The parts wholly before `s`, then those that meet it.
    let first = parts.partition_point(|p| p.hi < s.lo);
    let end = first + parts[first..].partition_point(|p| p.lo <= s.hi);
    if first == end {
        parts.insert(first, s);
        return;
    }
    parts[first] = joined(parts[first], parts[end - 1]);
    parts.drain(first + 1..end);
}

/// How segment tracing bounds one primitive's `|f′|` on a ray interval.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PrimitiveSlope {
    /// The range of the primitive's own derivative (its ray jet): `segment`.
    Exact,
    /// Galin et al. 2020's product bound ([`Primitive::published_slope_bound`]):
    /// `segment-original`.
    Published,
}

/// A scene compiled for evaluation.
#[derive(Clone, Debug)]
pub struct FieldProgram {
    isovalue: f64,
    primitives: Vec<Primitive>,
    groups_of: Vec<u32>,
    kernels: Vec<KernelProfile>,
    kernel_specs: Vec<Kernel>,
    blend: BlendTree,
    /// The blend is a plain sum of every group: point values skip the per-group slots.
    blend_is_total_sum: bool,
    bvh: Bvh,
    unbounded: Vec<u32>,
    /// Groups whose field is clamped at 0 (those holding an HRBF set, `crate::field::hrbf_solve`).
    clamped: Vec<bool>,
    /// One term of each HRBF set: the field may jump where a ray crosses a set's box, so
    /// marching parts are cut there.
    cut_boxes: Vec<HrbfTerm>,
}

fn v3(a: Vec3) -> DVec3 {
    DVec3::from_array(a)
}

/// Orthonormal frame whose `y` column is `axis`.
fn frame_from_axis(axis: Vec3) -> DMat3 {
    let y = v3(axis).normalize();
    let (x, z) = y.any_orthonormal_pair();
    DMat3::from_cols(x, y, z)
}

impl FieldProgram {
    /// Compiles a validated scene.
    #[must_use]
    pub fn new(scene: &Scene) -> Self {
        let c = scene.isovalue;
        let mut primitives = Vec::new();
        let mut groups_of = Vec::new();
        let mut kernels = Vec::with_capacity(scene.groups.len());
        let clamped: Vec<bool> = scene.groups.iter().map(|g| !g.hrbfs.is_empty()).collect();
        let kernel_specs = scene.groups.iter().map(|g| g.kernel).collect();
        for (gi, group) in scene.groups.iter().enumerate() {
            let k = KernelProfile::new(group.kernel);
            let gi = gi as u32;
            let mut local = Vec::new();
            let mut push = |p: Primitive| local.push(p);
            let point_norm = k.point_normalisation(c);
            let scalis_norm = k.scalis_normalisation(c);
            let corrector = k.end_corrector_ratio();
            for skeleton in &group.skeletons {
                skeleton_primitives(skeleton, point_norm, scalis_norm, corrector, &mut push);
            }
            for blob in &group.blobs {
                push(Primitive::Point(PointBlob {
                    center: v3(blob.center),
                    radius: blob.radius,
                    norm: point_norm,
                }));
            }
            for shape in &group.shapes {
                push(Primitive::Shape(shape_primitive(shape, point_norm)));
            }
            for set in &group.hrbfs {
                hrbf_terms(set, c, &mut push);
            }
            for placement in group_placements(group) {
                for p in &local {
                    primitives.push(if placement == Similarity::IDENTITY {
                        *p
                    } else {
                        p.transformed(&placement)
                    });
                    groups_of.push(gi);
                }
            }
            kernels.push(k);
        }
        let blend = BlendTree::compile(scene.blend.as_ref(), scene.groups.len());
        let mut boxes = Vec::with_capacity(primitives.len());
        let mut unbounded = Vec::new();
        for (i, p) in primitives.iter().enumerate() {
            match p.support_aabb(&kernels[groups_of[i] as usize]) {
                Some(b) => boxes.push((i as u32, b)),
                None => unbounded.push(i as u32),
            }
        }
        let mut cut_boxes: Vec<HrbfTerm> = Vec::new();
        for p in &primitives {
            if let Primitive::Hrbf(term) = p
                && cut_boxes
                    .last()
                    .is_none_or(|b| (b.bounds, b.frame) != (term.bounds, term.frame))
            {
                cut_boxes.push(*term);
            }
        }
        let blend_is_total_sum =
            is_total_sum(&blend, scene.groups.len()) && !clamped.iter().any(|&c| c);
        Self {
            isovalue: c,
            blend_is_total_sum,
            bvh: Bvh::build(&boxes),
            primitives,
            groups_of,
            kernels,
            kernel_specs,
            blend,
            unbounded,
            clamped,
            cut_boxes,
        }
    }

    /// Isovalue `c`.
    #[must_use]
    pub fn isovalue(&self) -> f64 {
        self.isovalue
    }

    /// The primitives (skeleton segments, end-point correctors, blobs, shapes).
    #[must_use]
    pub fn primitives(&self) -> &[Primitive] {
        &self.primitives
    }

    /// Kernel profile of primitive `i`.
    #[must_use]
    pub fn kernel_of(&self, i: u32) -> &KernelProfile {
        &self.kernels[self.groups_of[i as usize] as usize]
    }

    /// Group of primitive `i`.
    #[must_use]
    pub fn group_of(&self, i: u32) -> usize {
        self.groups_of[i as usize] as usize
    }

    /// Union of the bounded supports (planes excluded).
    #[must_use]
    pub fn support_bounds(&self) -> Aabb {
        self.bvh.bounds()
    }

    /// The box the scene's tolerances and reach are measured from: [`Self::support_bounds`]
    /// snapped to a power-of-two grid ([`Aabb::snapped_to_grid`]). It scales the trace settings
    /// (`TraceSettings::for_protocol`), the rays' reach (`frame::far_distance`), field
    /// shading, the candidate tests' padding and the BVH's leaf order, so an edit that moves
    /// the support bounds within their grid cells (an extremal vertex moved a little) changes
    /// none of them, and the editor traces again only the rays the edit reaches.
    #[must_use]
    pub fn scale_bounds(&self) -> Aabb {
        self.support_bounds().snapped_to_grid()
    }

    /// Whether some primitive has an unbounded support (a plane).
    #[must_use]
    pub fn has_unbounded_support(&self) -> bool {
        !self.unbounded.is_empty()
    }

    /// Runs `f` on one slot per group, each `zero`: on the stack for up to [`INLINE_GROUPS`]
    /// groups, so that a question asked at every step allocates nothing.
    pub(crate) fn with_group_slots<T: Copy, R>(&self, zero: T, f: impl FnOnce(&mut [T]) -> R) -> R {
        let n = self.kernels.len();
        if n <= INLINE_GROUPS {
            let mut slots = [zero; INLINE_GROUPS];
            f(&mut slots[..n])
        } else {
            f(&mut vec![zero; n])
        }
    }

    /// Field value at `p`.
    #[must_use]
    pub fn value(&self, p: DVec3) -> f64 {
        if self.blend_is_total_sum {
            let mut sum = 0.0;
            self.near(p, |i| {
                sum += self.primitives[i as usize].value(p, self.kernel_of(i));
            });
            return sum;
        }
        self.value_gradient(p).0
    }

    /// Field value and gradient at `p`.
    #[must_use]
    pub fn value_gradient(&self, p: DVec3) -> (f64, DVec3) {
        self.value_gradient_in(self, p)
    }

    pub(crate) fn value_gradient_in(&self, lookup: &impl PointLookup, p: DVec3) -> (f64, DVec3) {
        self.blended_at(lookup, p, |primitive, k| primitive.value_gradient(p, k))
    }

    /// The value of [`FieldProgram::value_gradient_in`], bit for bit, without the gradients
    /// (the blends' values never depend on their operands' gradients).
    pub(crate) fn value_in(&self, lookup: &impl PointLookup, p: DVec3) -> f64 {
        self.blended_at(lookup, p, |primitive, k| primitive.value(p, k))
    }

    /// The blend of the groups' sums of `primitive_at` (values, or values with gradients) over
    /// the primitives `lookup` finds at `p` (negative group sums clamped to 0).
    fn blended_at<T: BlendOperand>(
        &self,
        lookup: &impl PointLookup,
        p: DVec3,
        primitive_at: impl Fn(&Primitive, &KernelProfile) -> T,
    ) -> T {
        self.with_group_slots(T::ZERO, |slots| {
            lookup.near(p, |i| {
                let operand = primitive_at(&self.primitives[i as usize], self.kernel_of(i));
                let slot = &mut slots[self.groups_of[i as usize] as usize];
                *slot = slot.plus(operand);
            });
            self.clamp_group_slots(slots, |slot| {
                if slot.value() < 0.0 {
                    *slot = T::ZERO;
                }
            });
            blend::evaluate(&self.blend, slots, self.isovalue)
        })
    }

    /// Restriction to a ray: `(f(t), f′(t))`.
    #[must_use]
    pub fn along_ray(&self, ray: &Ray, t: f64) -> (f64, f64) {
        let (v, g) = self.value_gradient(ray.at(t));
        (v, g.dot(ray.direction))
    }

    /// Enclosures of `f`, `f′` and `f″` along the ray over `span` (MATH.md §5; the bounds the
    /// marching methods need).
    #[must_use]
    pub fn ray_jet(&self, ray: &Ray, span: Interval) -> Jet {
        self.ray_jet_in(&BvhOnRay(self, ray), ray, span)
    }

    pub(crate) fn ray_jet_in(&self, lookup: &impl RayLookup, ray: &Ray, span: Interval) -> Jet {
        self.with_group_slots(Jet::ZERO, |slots| {
            self.accumulate_group_jets(lookup, ray, span, slots);
            blend::jet(&self.blend, slots, self.isovalue)
        })
    }

    /// Jets of every group's field (the sums of their primitives) over `span`.
    #[must_use]
    pub fn ray_group_jets(&self, ray: &Ray, span: Interval) -> Vec<Jet> {
        let mut slots = vec![Jet::ZERO; self.kernels.len()];
        self.accumulate_ray_group_jets(ray, span, &mut slots);
        slots
    }

    /// [`FieldProgram::ray_group_jets`] added into `slots`, one per group.
    pub(crate) fn accumulate_ray_group_jets(&self, ray: &Ray, span: Interval, slots: &mut [Jet]) {
        self.accumulate_group_jets(&BvhOnRay(self, ray), ray, span, slots);
    }

    pub(crate) fn accumulate_group_jets(
        &self,
        lookup: &impl RayLookup,
        ray: &Ray,
        span: Interval,
        slots: &mut [Jet],
    ) {
        lookup.on_ray(span, |i, inside| {
            let jet =
                self.primitives[i as usize].ray_jet_inside(ray, span, inside, self.kernel_of(i));
            let slot = &mut slots[self.groups_of[i as usize] as usize];
            *slot = *slot + jet;
        });
        self.clamp_group_slots(slots, |slot| *slot = slot.max(Jet::ZERO));
    }

    /// Whether group `g`'s field is clamped at 0 (it holds an HRBF set).
    #[must_use]
    pub fn group_is_clamped(&self, g: usize) -> bool {
        self.clamped[g]
    }

    /// Applies `clamp_at_zero` to the per-group slots (values, jets, inclusions, affine forms) of
    /// the groups whose field is clamped at 0: the one place each evaluation mode takes the HRBF
    /// group's positive part.
    pub fn clamp_group_slots<T>(&self, slots: &mut [T], clamp_at_zero: impl Fn(&mut T)) {
        for (slot, _) in slots.iter_mut().zip(&self.clamped).filter(|(_, c)| **c) {
            clamp_at_zero(slot);
        }
    }

    /// Every group's `(f(t), f′(t))` along the ray.
    #[must_use]
    pub fn group_values_along_ray(&self, ray: &Ray, t: f64) -> Vec<(f64, f64)> {
        let mut slots = vec![(0.0, 0.0); self.kernels.len()];
        self.group_values_in(self, ray, t, &mut slots);
        slots
    }

    pub(crate) fn group_values_in(
        &self,
        lookup: &impl PointLookup,
        ray: &Ray,
        t: f64,
        slots: &mut [(f64, f64)],
    ) {
        let p = ray.at(t);
        lookup.near(p, |i| {
            let (v, g) = self.primitives[i as usize].value_gradient(p, self.kernel_of(i));
            let slot = &mut slots[self.groups_of[i as usize] as usize];
            slot.0 += v;
            slot.1 += g.dot(ray.direction);
        });
        self.clamp_group_slots(slots, |slot| {
            if slot.0 < 0.0 {
                *slot = (0.0, 0.0);
            }
        });
    }

    /// The blend tree over groups (a sum of all groups when the scene gives none).
    #[must_use]
    pub fn blend(&self) -> &BlendTree {
        &self.blend
    }

    /// Number of groups.
    #[must_use]
    pub fn group_count(&self) -> usize {
        self.kernels.len()
    }

    /// Kernel profile of group `g`.
    #[must_use]
    pub fn group_kernel(&self, g: usize) -> &KernelProfile {
        &self.kernels[g]
    }

    /// The kernel of group `g` as the scene states it.
    #[must_use]
    pub fn group_kernel_spec(&self, g: usize) -> Kernel {
        self.kernel_specs[g]
    }

    /// The primitives of group `g`.
    pub fn group_primitives(&self, g: usize) -> impl Iterator<Item = &Primitive> {
        self.primitives
            .iter()
            .zip(&self.groups_of)
            .filter(move |(_, gi)| **gi as usize == g)
            .map(|(p, _)| p)
    }

    /// A global Lipschitz bound of the blended field (sphere tracing, Hart 1996). Each blend
    /// operator's gradient is bounded through [`blend::lipschitz`], a monotone, subadditive and
    /// positively homogeneous function of its groups' bounds `Lᵍ`, so it is at most
    /// `Σ_g w_g·Lᵍ` with `w_g` the tree's bound for `Lᵍ = 1` and the others 0 (1 for every group
    /// of a sum or max tree; more where a group appears twice, as in `Sum([G0, G0])`). At any
    /// point only primitives whose support boxes overlap each other contribute to `Lᵍ`, so the
    /// largest weighted sum over a primitive and the primitives overlapping it bounds `|∇f|`
    /// everywhere.
    #[must_use]
    pub fn global_lipschitz(&self) -> f64 {
        let weights: Vec<f64> = (0..self.group_count())
            .map(|g| {
                let mut unit = vec![0.0; self.group_count()];
                unit[g] = 1.0;
                blend::lipschitz(&self.blend, &unit)
            })
            .collect();
        let lipschitz: Vec<f64> = self
            .primitives
            .iter()
            .enumerate()
            .map(|(i, p)| {
                weights[self.groups_of[i] as usize] * p.lipschitz(self.kernel_of(i as u32))
            })
            .collect();
        let unbounded: f64 = self.unbounded.iter().map(|&i| lipschitz[i as usize]).sum();
        let mut worst = unbounded;
        for (i, p) in self.primitives.iter().enumerate() {
            if let Some(b) = p.support_aabb(self.kernel_of(i as u32)) {
                let mut sum = unbounded;
                self.bvh
                    .for_each_overlapping(&b, |j| sum += lipschitz[j as usize]);
                worst = worst.max(sum);
            }
        }
        worst
    }

    /// The parts of `span` inside at least one support, as disjoint sorted intervals: outside
    /// them the field is 0, below any positive isovalue. Parts are also cut where the ray
    /// crosses the box of an HRBF set, where the field may jump, so that the field is
    /// continuous on each part (the methods' bounds hold on spans inside one part).
    #[must_use]
    pub fn ray_support_unions(&self, ray: &Ray, span: Interval) -> Vec<Interval> {
        let mut parts = Vec::new();
        self.ray_support_unions_in(&BvhOnRay(self, ray), ray, span, &mut parts);
        parts
    }

    /// [`Self::ray_support_unions`] through `lookup`, into `out` (cleared first): a ray's
    /// tracer passes an array it reuses.
    pub(crate) fn ray_support_unions_in(
        &self,
        lookup: &impl RayLookup,
        ray: &Ray,
        span: Interval,
        out: &mut Vec<Interval>,
    ) {
        // Each support is merged into the parts as the lookup visits it: no sort of the
        // supports, the parts are few.
        out.clear();
        lookup.on_ray(span, |_, span| merge_into_parts(out, span));
        for b in &self.cut_boxes {
            let Some(inside) = b.box_interval(ray, span) else {
                continue;
            };
            for cut in [inside.lo, inside.hi] {
                if let Some(i) = out.iter().position(|p| p.lo < cut && cut < p.hi) {
                    let hi = out[i].hi;
                    out[i].hi = cut;
                    out.insert(i + 1, Interval { lo: cut, hi });
                }
            }
        }
    }

    /// Local directional Lipschitz bound on `span`: `max |f′|` (segment tracing; forward
    /// inclusion eq. 11).
    #[must_use]
    pub fn directional_lipschitz(&self, ray: &Ray, span: Interval) -> f64 {
        self.ray_jet(ray, span).d1.magnitude()
    }

    /// Segment tracing's local Lipschitz bound on `span` (Galin et al. 2020; MATH.md §5): the sum
    /// of the primitives' own bounds `max |fᵢ′|` within a group (the bound of a sum is the sum of
    /// the bounds), combined through the blend tree (sum: sum; Ricci: p-norm; max, min,
    /// difference: the largest). Looser than [`FieldProgram::directional_lipschitz`], which
    /// bounds the derivative of the sum itself.
    #[must_use]
    pub fn summed_lipschitz(&self, ray: &Ray, span: Interval, slope: PrimitiveSlope) -> f64 {
        self.summed_lipschitz_in(&BvhOnRay(self, ray), ray, span, slope)
    }

    pub(crate) fn summed_lipschitz_in(
        &self,
        lookup: &impl RayLookup,
        ray: &Ray,
        span: Interval,
        slope: PrimitiveSlope,
    ) -> f64 {
        self.with_group_slots(0.0, |slots| {
            lookup.on_ray(span, |i, inside| {
                let (primitive, kernel) = (&self.primitives[i as usize], self.kernel_of(i));
                slots[self.groups_of[i as usize] as usize] += match slope {
                    PrimitiveSlope::Exact => primitive
                        .ray_jet_inside(ray, span, inside, kernel)
                        .d1
                        .magnitude(),
                    PrimitiveSlope::Published => {
                        primitive.published_slope_bound(ray, (span, inside), kernel)
                    }
                };
            });
            blend::lipschitz(&self.blend, slots)
        })
    }

    /// Calls `visit(group, primitive, kernel, support ∩ span)` for every primitive whose support
    /// the ray crosses on `span` (in no particular order).
    pub fn for_each_primitive_on_ray(
        &self,
        ray: &Ray,
        span: Interval,
        visit: impl FnMut(usize, &Primitive, &KernelProfile, Interval),
    ) {
        self.for_each_primitive_in(&BvhOnRay(self, ray), span, visit);
    }

    pub(crate) fn for_each_primitive_in(
        &self,
        lookup: &impl RayLookup,
        span: Interval,
        mut visit: impl FnMut(usize, &Primitive, &KernelProfile, Interval),
    ) {
        lookup.on_ray(span, |i, s| {
            visit(
                self.groups_of[i as usize] as usize,
                &self.primitives[i as usize],
                self.kernel_of(i),
                s,
            );
        });
    }

    /// The kernel shared by every group, if they all use the same one.
    #[must_use]
    pub fn common_kernel(&self) -> Option<Kernel> {
        let first = *self.kernel_specs.first()?;
        self.kernel_specs
            .iter()
            .all(|k| *k == first)
            .then_some(first)
    }

    /// The supports the ray crosses on `span`, sorted by entry (then by primitive).
    #[must_use]
    pub fn ray_supports(&self, ray: &Ray, span: Interval) -> Vec<SupportSpan> {
        self.ray_supports_in(&BvhOnRay(self, ray), span)
    }

    pub(crate) fn ray_supports_in(
        &self,
        lookup: &impl RayLookup,
        span: Interval,
    ) -> Vec<SupportSpan> {
        let mut out = Vec::new();
        lookup.on_ray(span, |primitive, span| {
            out.push(SupportSpan { span, primitive });
        });
        out.sort_unstable_by_key(|s| {
            (u128::from(total_order_key(s.span.lo)) << 32) | u128::from(s.primitive)
        });
        out
    }

    /// The BVH and the unbounded primitives, for [`crate::field::ray_field::RayField`].
    pub(crate) fn lookup_parts(&self) -> (&Bvh, &[u32]) {
        (&self.bvh, &self.unbounded)
    }

    /// Which primitives of `self` differ from those of `before`, an earlier compilation of an
    /// edited scene (one flag per primitive), when nothing else does: as many primitives, in
    /// the same groups, with the same isovalue, kernels, blend tree, HRBF cuts and unbounded
    /// primitives, and the same [`Self::scale_bounds`] (which scale the trace settings, the
    /// rays' reach and the tiles' padding). `None` where anything else changed, or an unbounded
    /// primitive (every ray has those among its candidates): then any ray may trace
    /// differently. The BVH is left out: a ray's candidates are compared where they are
    /// gathered (`cpu/renderer.rs`).
    #[must_use]
    pub fn primitives_changed_since(&self, before: &FieldProgram) -> Option<Vec<bool>> {
        // Every field named, so that a new one must be placed here.
        let FieldProgram {
            isovalue,
            primitives,
            groups_of,
            kernels,
            kernel_specs,
            blend,
            blend_is_total_sum,
            bvh: _,
            unbounded,
            clamped,
            cut_boxes,
        } = self;
        let same_elsewhere = primitives.len() == before.primitives.len()
            && *isovalue == before.isovalue
            && *groups_of == before.groups_of
            && *kernels == before.kernels
            && *kernel_specs == before.kernel_specs
            && *blend == before.blend
            && *blend_is_total_sum == before.blend_is_total_sum
            && *unbounded == before.unbounded
            && *clamped == before.clamped
            && *cut_boxes == before.cut_boxes
            && self.scale_bounds() == before.scale_bounds();
        if !same_elsewhere {
            return None;
        }
        let changed: Vec<bool> = primitives
            .iter()
            .zip(&before.primitives)
            .map(|(now, then)| now != then)
            .collect();
        (!unbounded.iter().any(|&i| changed[i as usize])).then_some(changed)
    }
}

/// Where a point query finds the primitives that may be non-zero at `p`: the program's BVH, or
/// one ray's gathered candidates (`RayField`). Every lookup visits in the same order (the
/// BVH's depth-first order, then the unbounded primitives), so that sums agree bit for bit.
pub(crate) trait PointLookup {
    /// `visit(i)` for every primitive whose support box contains `p`, and every unbounded one.
    fn near(&self, p: DVec3, visit: impl FnMut(u32));
}

/// Where an interval query along one ray finds the primitives whose support it meets.
pub(crate) trait RayLookup {
    /// `visit(i, support ∩ span)` for every primitive whose box meets the ray on `span` and
    /// whose exact support meets it there (a primitive whose box meets the ray but whose
    /// support does not is exactly 0 there; a clipped kernel's one-sided derivative at the
    /// boundary must not widen the bounds).
    fn on_ray(&self, span: Interval, visit: impl FnMut(u32, Interval));
}

impl PointLookup for FieldProgram {
    fn near(&self, p: DVec3, mut visit: impl FnMut(u32)) {
        self.bvh.for_each_containing(p, &mut visit);
        self.unbounded.iter().copied().for_each(visit);
    }
}

/// The BVH queried along one ray.
struct BvhOnRay<'a>(&'a FieldProgram, &'a Ray);

impl RayLookup for BvhOnRay<'_> {
    fn on_ray(&self, span: Interval, mut visit: impl FnMut(u32, Interval)) {
        let (program, ray) = (self.0, self.1);
        let mut add = |i: u32| {
            let p = &program.primitives[i as usize];
            if let Some(s) = p
                .support_interval(ray, program.kernel_of(i))
                .and_then(|s| s.intersect(span))
            {
                visit(i, s);
            }
        };
        program.bvh.for_each_on_ray(ray, span, &mut add);
        program.unbounded.iter().copied().for_each(add);
    }
}

/// The group's [`Transform`] as a similarity (the placement of its first copy, whose
/// [`Repeat`] offset is the origin).
#[must_use]
pub fn group_transform(group: &Group) -> Similarity {
    let t = &group.transform;
    Similarity {
        scale: t.scale,
        rotation: DMat3::from_euler(
            EulerRot::XYZ,
            t.rotate[0].to_radians(),
            t.rotate[1].to_radians(),
            t.rotate[2].to_radians(),
        ),
        translation: v3(t.translate),
    }
}

/// Where the copies of a group go: one similarity per copy of its [`Repeat`] grid (the offset in
/// the group's frame, then the group's [`Transform`]), or the transform alone.
#[must_use]
pub fn group_placements(group: &Group) -> Vec<Similarity> {
    let transform = group_transform(group);
    match &group.repeat {
        None => vec![transform],
        Some(r) => r
            .offsets()
            .into_iter()
            .map(|o| {
                transform.after(&Similarity {
                    translation: v3(o),
                    ..Similarity::IDENTITY
                })
            })
            .collect(),
    }
}

/// Whether `blend` adds every group exactly once and nothing else.
fn is_total_sum(blend: &BlendTree, groups: usize) -> bool {
    let mut seen = vec![false; groups];
    let mut mark = |i: &u32| !std::mem::replace(&mut seen[*i as usize], true);
    let all_distinct = match blend {
        BlendTree::Group(i) => mark(i),
        BlendTree::Sum(children) => children.iter().all(|c| match c {
            BlendTree::Group(i) => mark(i),
            _ => false,
        }),
        _ => false,
    };
    all_distinct && seen.iter().all(|&s| s)
}

/// Primitives of one skeleton: a segment per edge and, for SCALIS skeletons with end-point
/// correctors, a constant-radius segment of length `λ·τ` beyond each free end (scalis §1.1).
fn skeleton_primitives(
    skeleton: &Skeleton,
    point_norm: f64,
    scalis_norm: f64,
    corrector_ratio: f64,
    push: &mut impl FnMut(Primitive),
) {
    let position = |i: u32| v3(skeleton.vertices[i as usize].position);
    let radius = |i: u32| skeleton.vertices[i as usize].radius;
    let cone = |a: DVec3, ra: f64, b: DVec3, rb: f64| {
        let (start, r0, end, r1) = if ra <= rb {
            (a, ra, b, rb)
        } else {
            (b, rb, a, ra)
        };
        let length = (end - start).length();
        SphereCone {
            start,
            axis: (end - start) / length,
            length,
            radius: r0,
            slope: (r1 - r0) / length,
        }
    };
    for &[a, b] in &skeleton.edges {
        let c = cone(position(a), radius(a), position(b), radius(b));
        push(match skeleton.field {
            SkeletonField::Distance => Primitive::Distance(DistanceSegment {
                cone: c,
                norm: point_norm,
            }),
            SkeletonField::Scalis => Primitive::Scalis(ScalisSegment {
                cone: c,
                norm: scalis_norm,
            }),
        });
    }
    if skeleton.field == SkeletonField::Scalis && skeleton.end_correctors {
        let mut degree = vec![0_u32; skeleton.vertices.len()];
        let mut neighbour = vec![0_u32; skeleton.vertices.len()];
        for &[a, b] in &skeleton.edges {
            degree[a as usize] += 1;
            degree[b as usize] += 1;
            neighbour[a as usize] = b;
            neighbour[b as usize] = a;
        }
        for (end, &d) in degree.iter().enumerate() {
            if d != 1 {
                continue;
            }
            let end = end as u32;
            let tip = position(end);
            let outward = (tip - position(neighbour[end as usize])).normalize();
            let tau = radius(end);
            push(Primitive::Scalis(ScalisSegment {
                cone: SphereCone {
                    start: tip,
                    axis: outward,
                    length: corrector_ratio * tau,
                    radius: tau,
                    slope: 0.0,
                },
                norm: scalis_norm,
            }));
        }
    }
}

/// The terms of an HRBF set, scaled into the density `c − (c/ℓ)h` (`field::hrbf_solve`). The
/// weights are solved here, when the scene is compiled (`hrbf_solve::solve_shared` keeps the
/// latest sets, so an edit elsewhere does not solve them again). Validation guarantees distinct
/// points, for which the system is non-singular; a set in a scene built in code without
/// validation that does not solve gives no terms.
fn hrbf_terms(set: &Hrbf, c: f64, push: &mut impl FnMut(Primitive)) {
    let Ok(weights) = hrbf_solve::solve_shared(&set.points) else {
        return;
    };
    let bounds = weights.bounds();
    let scale = -c / weights.length_scale();
    for ((&center, &alpha), &beta) in weights
        .centers
        .iter()
        .zip(&weights.alpha)
        .zip(&weights.beta)
    {
        push(Primitive::Hrbf(HrbfTerm {
            center,
            alpha: scale * alpha,
            beta: scale * beta,
            linear: DVec3::ZERO,
            constant: 0.0,
            bounds,
            frame: DMat3::IDENTITY,
        }));
    }
    push(Primitive::Hrbf(HrbfTerm {
        center: bounds.center(),
        alpha: 0.0,
        beta: DVec3::ZERO,
        linear: scale * weights.linear,
        constant: scale * weights.constant + c,
        bounds,
        frame: DMat3::IDENTITY,
    }));
}

fn shape_primitive(shape: &Shape, norm: f64) -> ShapePrimitive {
    let euler = |r: Vec3| {
        DMat3::from_euler(
            EulerRot::XYZ,
            r[0].to_radians(),
            r[1].to_radians(),
            r[2].to_radians(),
        )
    };
    let (solid, center, frame, radius) = match *shape {
        Shape::Plane {
            normal,
            offset,
            radius,
        } => {
            let n = v3(normal);
            let len = n.length();
            (
                Solid::Plane {
                    normal: n / len,
                    offset: offset / len,
                },
                DVec3::ZERO,
                DMat3::IDENTITY,
                radius,
            )
        }
        Shape::Box {
            center,
            half_extents,
            rotation,
            radius,
        } => (
            Solid::Box {
                half_extents: v3(half_extents),
            },
            v3(center),
            euler(rotation),
            radius,
        ),
        Shape::RoundedBox {
            center,
            half_extents,
            rounding,
            rotation,
            radius,
        } => (
            Solid::RoundedBox {
                half_extents: v3(half_extents),
                rounding,
            },
            v3(center),
            euler(rotation),
            radius,
        ),
        Shape::Torus {
            center,
            axis,
            major,
            minor,
            radius,
        } => (
            Solid::Torus { major, minor },
            v3(center),
            frame_from_axis(axis),
            radius,
        ),
        Shape::Cylinder {
            center,
            axis,
            cylinder_radius,
            half_height,
            radius,
        } => (
            Solid::Cylinder {
                radius: cylinder_radius,
                half_height,
            },
            v3(center),
            frame_from_axis(axis),
            radius,
        ),
    };
    ShapePrimitive {
        solid,
        center,
        frame,
        radius,
        norm,
    }
}

#[cfg(test)]
mod tests {
    use super::{Interval, merge_into_parts, total_order_key};
    use crate::model::rng::SplitMix64;

    /// Sorting by the key orders numbers as `f64::total_cmp` does: negative and positive, both
    /// zeros, subnormals and infinities, random magnitudes.
    #[test]
    fn the_sort_key_orders_as_total_cmp() {
        let mut rng = SplitMix64::new(7);
        let mut values = vec![
            0.0,
            -0.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            5e-324,
            -5e-324,
            f64::MAX,
            f64::MIN,
        ];
        for _ in 0..2000 {
            let magnitude = 10f64.powf(rng.range(-300.0, 300.0));
            values.push(if rng.unit() < 0.5 {
                -magnitude
            } else {
                magnitude
            });
        }
        for a in &values {
            for b in values.iter().step_by(7) {
                assert_eq!(
                    total_order_key(*a).cmp(&total_order_key(*b)),
                    a.total_cmp(b),
                    "{a} vs {b}"
                );
            }
        }
    }

    /// Merging intervals into parts one at a time, in any order, gives the parts of sorting
    /// them by entry and sweeping: on random sets with shared and touching ends, signed zeros,
    /// nested and point intervals.
    #[test]
    fn parts_merged_one_at_a_time_are_the_sorted_sweep() {
        let sweep = |mut spans: Vec<Interval>| {
            spans.sort_unstable_by_key(|s| total_order_key(s.lo));
            let mut out: Vec<Interval> = Vec::new();
            for s in spans {
                match out.last_mut() {
                    Some(last) if s.lo <= last.hi => last.hi = last.hi.max(s.hi),
                    _ => out.push(s),
                }
            }
            out
        };
        let mut rng = SplitMix64::new(11);
        let mut merged_any = false;
        for case in 0..20_000 {
            let count = 1 + case % 40;
            // Ends on a coarse grid, so that ends coincide and intervals touch often.
            let grid = [1.0, 0.25, 1e-3][case % 3];
            let end = |rng: &mut SplitMix64| {
                let x = (rng.range(-8.0, 8.0) / grid).round() * grid;
                if x == 0.0 && rng.unit() < 0.5 {
                    -0.0
                } else {
                    x
                }
            };
            let spans: Vec<Interval> = (0..count)
                .map(|_| {
                    let (a, b) = (end(&mut rng), end(&mut rng));
                    let lo = if total_order_key(a) < total_order_key(b) {
                        a
                    } else {
                        b
                    };
                    let hi = if total_order_key(a) < total_order_key(b) {
                        b
                    } else {
                        a
                    };
                    Interval { lo, hi }
                })
                .collect();
            let mut parts = Vec::new();
            for s in &spans {
                merge_into_parts(&mut parts, *s);
            }
            merged_any |= parts.len() < spans.len();
            let want = sweep(spans.clone());
            assert_eq!(parts.len(), want.len(), "{spans:?}");
            for (got, want) in parts.iter().zip(&want) {
                assert_eq!(
                    (got.lo.to_bits(), got.hi.to_bits()),
                    (want.lo.to_bits(), want.hi.to_bits()),
                    "{spans:?}"
                );
            }
        }
        assert!(merged_any);
    }
}
