//! Bounding volume hierarchy over primitive supports: the CPU analogue of the scalis 2021
//! paper's A-buffer (§6). A point query visits only the primitives whose support box contains
//! the point; a ray query visits those whose box meets a ray interval, so a query costs
//! O(log n + k) at fixed overlap.
//!
//! The leaves hold the items in one fixed order — the Morton code of each box's centre in the
//! root box snapped to its grid (`Aabb::snapped_to_grid`), then the id — and each node splits
//! its run of that order where the surface area heuristic is lowest (a median split past
//! [`MAX_SAH_DEPTH`]). Every query visits items in that order, so the order of the sums over a
//! ray's or a point's primitives depends on the primitives themselves only, not on how others
//! split the tree: after an edit that moves a few primitives within the same snapped root box,
//! every other primitive keeps its place relative to the rest, and the editor can copy the
//! rays the edit did not reach (`cpu/renderer.rs` `EditReach`). A binned split that
//! partitions the items freely reorders them all around the edit.

use glam::DVec3;

use crate::bounds::interval::Interval;
use crate::field::geometry::{Aabb, Ray};

const LEAF_SIZE: usize = 4;
/// Depth below which splits use the surface area heuristic; median splits after it.
const MAX_SAH_DEPTH: usize = 32;
/// Traversal stack size: enough for `MAX_SAH_DEPTH` plus a balanced tree of 2³⁰ items.
const STACK_SIZE: usize = 64;

#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: Aabb,
    /// Leaf: first item in `items`; inner: index of the right child (the left is next).
    first_or_right: u32,
    /// Number of items of a leaf; 0 for inner nodes.
    count: u32,
}

/// A BVH over a set of boxes identified by their index.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// Leaf items with their own boxes, tested before an item is visited.
    items: Vec<(u32, Aabb)>,
}

impl Bvh {
    /// Builds the hierarchy over `(id, box)` pairs.
    #[must_use]
    pub fn build(boxes: &[(u32, Aabb)]) -> Self {
        let mut bvh = Self {
            nodes: Vec::with_capacity(2 * boxes.len() / LEAF_SIZE + 1),
            items: Vec::with_capacity(boxes.len()),
        };
        if boxes.is_empty() {
            return bvh;
        }
        // Codes in the root box snapped to its grid: the same codes after an edit that moves
        // the root box within its grid cells.
        let root = boxes
            .iter()
            .fold(Aabb::EMPTY, |acc, b| acc.union(b.1))
            .snapped_to_grid();
        let mut work: Vec<(u64, u32, Aabb)> = boxes
            .iter()
            .map(|&(id, b)| (morton_code(b.center(), &root), id, b))
            .collect();
        work.sort_unstable_by_key(|w| (w.0, w.1));
        let work: Vec<(u32, Aabb)> = work.into_iter().map(|(_, id, b)| (id, b)).collect();
        let mut right_areas = vec![0.0; work.len()];
        bvh.build_node(&work, &mut right_areas, 0);
        bvh
    }

    /// Builds the node over `work`, a run of the leaf order; `right_areas` is scratch space
    /// of the run's length.
    fn build_node(&mut self, work: &[(u32, Aabb)], right_areas: &mut [f64], depth: usize) -> u32 {
        let bounds = work.iter().fold(Aabb::EMPTY, |acc, w| acc.union(w.1));
        let index = self.nodes.len() as u32;
        if work.len() <= LEAF_SIZE {
            self.nodes.push(Node {
                bounds,
                first_or_right: self.items.len() as u32,
                count: work.len() as u32,
            });
            self.items.extend_from_slice(work);
            return index;
        }
        self.nodes.push(Node {
            bounds,
            first_or_right: 0,
            count: 0,
        });
        // Deep in the tree, balanced median splits bound the remaining depth by log2(n), which
        // keeps the whole tree within the traversal stack.
        let mid = if depth < MAX_SAH_DEPTH {
            sah_split(work, right_areas)
        } else {
            work.len() / 2
        };
        let (left, right) = work.split_at(mid);
        let (left_scratch, right_scratch) = right_areas.split_at_mut(mid);
        self.build_node(left, left_scratch, depth + 1);
        let right_index = self.build_node(right, right_scratch, depth + 1);
        self.nodes[index as usize].first_or_right = right_index;
        index
    }

    /// Union of all boxes.
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        self.nodes.first().map_or(Aabb::EMPTY, |n| n.bounds)
    }

    /// Visits, depth first, every item whose box `hit` accepts (`Some`) below nodes it
    /// accepts, with what `hit` returned for the item's box.
    fn traverse<H>(&self, hit: impl Fn(&Aabb) -> Option<H>, mut visit: impl FnMut(u32, &Aabb, H)) {
        if self.nodes.is_empty() {
            return;
        }
        // Depth-first, left child first; the depth bound of the build fits in the stack.
        let mut stack = [0_u32; STACK_SIZE];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let i = stack[top];
            let node = &self.nodes[i as usize];
            if hit(&node.bounds).is_none() {
                continue;
            }
            if node.count > 0 {
                let first = node.first_or_right as usize;
                for (item, bounds) in &self.items[first..first + node.count as usize] {
                    if let Some(h) = hit(bounds) {
                        visit(*item, bounds, h);
                    }
                }
            } else {
                stack[top] = node.first_or_right;
                stack[top + 1] = i + 1;
                top += 2;
            }
        }
    }

    /// Calls `visit` with every item whose box contains `p`.
    pub fn for_each_containing(&self, p: DVec3, mut visit: impl FnMut(u32)) {
        self.traverse(|b| b.contains(p).then_some(()), |i, _, ()| visit(i));
    }

    /// Calls `visit` with every item whose box overlaps `region`.
    pub fn for_each_overlapping(&self, region: &Aabb, mut visit: impl FnMut(u32)) {
        self.traverse(
            |b| (b.min.cmple(region.max).all() && region.min.cmple(b.max).all()).then_some(()),
            |i, _, ()| visit(i),
        );
    }

    /// Calls `visit` with every item whose box meets the ray on `span`.
    pub fn for_each_on_ray(&self, ray: &Ray, span: Interval, mut visit: impl FnMut(u32)) {
        let inv = ray.direction.recip();
        self.traverse(|b| b.ray_interval_with(ray, inv, span), |i, _, _| visit(i));
    }

    /// Calls `visit(item, box, interval)` for every item whose box, widened as `near` widens it,
    /// meets `near`'s ray on its span — on `interval` — in the order of every other query
    /// (depth first, left child first): a superset, in the same order, of the items any point
    /// or interval query on the ray within the span visits. A point `ray.at(t)` inside an
    /// item's box has `t` in its `interval` (the widening absorbs the rounding of `ray.at`).
    pub fn for_each_near(&self, near: &NearRay, visit: impl FnMut(u32, &Aabb, Interval)) {
        self.traverse(|b| near.interval(b), visit);
    }

    /// Calls `visit(item, box)` for every item whose box may meet a ray of `beam`, in the order
    /// of every other query: items whose boxes no ray of the beam meets are left out, the
    /// others kept (see [`Beam`]).
    pub fn for_each_in_beam(&self, beam: &Beam, mut visit: impl FnMut(u32, &Aabb)) {
        self.traverse(|b| beam.may_meet(b).then_some(()), |i, b, ()| visit(i, b));
    }
}

/// The test of [`Bvh::for_each_near`] on one box: where the ray is inside the box widened
/// by `pad` on `span`. Without the exact handling of a zero direction component: `f64::min` and
/// `max` ignore NaN (an origin on a slab plane).
#[derive(Clone, Copy, Debug)]
pub struct NearRay {
    inv: DVec3,
    low: DVec3,
    high: DVec3,
    span: Interval,
}

impl NearRay {
    /// The test for `ray` on `span`, boxes widened by `pad`.
    #[must_use]
    pub fn new(ray: &Ray, span: Interval, pad: f64) -> Self {
        Self {
            inv: ray.direction.recip(),
            low: ray.origin + pad,
            high: ray.origin - pad,
            span,
        }
    }

    /// The part of the span where the ray is inside the widened box `b`, if any.
    #[inline]
    #[must_use]
    pub fn interval(&self, b: &Aabb) -> Option<Interval> {
        near_slab_interval(
            (b.min - self.low) * self.inv,
            (b.max - self.high) * self.inv,
            self.span,
        )
    }

    /// The widened box's lower corner minus the origin, `min − (o + pad)`, and its upper
    /// corner's, `max − (o − pad)`: what [`NearRay::interval`] multiplies by the direction's
    /// reciprocal (rays from one origin share them).
    #[must_use]
    pub fn offsets(origin: DVec3, pad: f64, b: &Aabb) -> (DVec3, DVec3) {
        (b.min - (origin + pad), b.max - (origin - pad))
    }
}

/// [`NearRay::interval`] from the widened box's planes' parameters on the ray.
#[inline]
#[must_use]
pub fn near_slab_interval(t_a: DVec3, t_b: DVec3, span: Interval) -> Option<Interval> {
    let enter = t_a.min(t_b).max_element().max(span.lo);
    let exit = t_a.max(t_b).min_element().min(span.hi);
    (enter <= exit).then_some(Interval {
        lo: enter,
        hi: exit,
    })
}

/// The rays from one origin whose directions lie in the cone over a convex quadrilateral of
/// directions (a screen tile's pixels: the quadrilateral through the tile's outer pixel
/// corners), on a span that reaches at most `behind` before the origin. A box that one of them
/// meets, widened by `pad` as [`NearRay`] widens it, is never left out: the tile's pixel centres
/// lie half a pixel inside the cone, far more than the rounding of the slab test; within
/// `behind` of the origin, where that margin vanishes, every box is kept.
#[derive(Clone, Copy, Debug)]
pub struct Beam {
    origin: DVec3,
    /// Inward normals of the cone's four sides (planes through the origin).
    sides: [DVec3; 4],
    pad: f64,
    behind: f64,
}

impl Beam {
    /// The beam from `origin` over the directions `corners` (in order around the quadrilateral).
    #[must_use]
    pub fn new(origin: DVec3, corners: [DVec3; 4], pad: f64, behind: f64) -> Self {
        let centre = corners
            .iter()
            .fold(DVec3::ZERO, |a, &c| a + c.normalize_or_zero());
        let sides = std::array::from_fn(|k| {
            let n = corners[k].cross(corners[(k + 1) % 4]);
            if n.dot(centre) < 0.0 { -n } else { n }
        });
        Self {
            origin,
            sides,
            pad,
            behind,
        }
    }

    /// Whether a ray of the beam may meet box `b` widened by `pad`.
    #[must_use]
    pub fn may_meet(&self, b: &Aabb) -> bool {
        let centre = 0.5 * (b.min + b.max) - self.origin;
        let half = 0.5 * (b.max - b.min) + self.pad;
        // Near the origin: the box within `behind` of it (a generous per-axis test).
        let reach = DVec3::splat(2.0 * (self.behind + self.pad));
        if (centre.abs() - half).cmple(reach).all() {
            return true;
        }
        let scale = centre.abs().element_sum() + half.element_sum();
        self.sides.iter().all(|n| {
            let farthest = n.dot(centre) + n.abs().dot(half);
            farthest >= -1e-9 * n.length() * scale
        })
    }

    /// Whether every ray of the beam passes outside the convex hull of `balls` by more than
    /// `margin`: the hull lies beyond one side of the cone by that much (the rays' points at
    /// `t ≥ 0` are inside the cone), and farther than `behind` from the origin (the points
    /// before it are within `behind`).
    #[must_use]
    pub fn misses_hull(&self, balls: [(DVec3, f64); 2], margin: f64) -> bool {
        let [(a, ra), (b, rb)] = balls;
        let (a, b) = (a - self.origin, b - self.origin);
        let beyond_a_side = self.sides.iter().any(|n| {
            let length = n.length();
            n.dot(a) < -(ra + margin) * length && n.dot(b) < -(rb + margin) * length
        });
        if !beyond_a_side {
            return false;
        }
        let along = b - a;
        let closest = if along.length_squared() > 0.0 {
            a + along * (-a.dot(along) / along.length_squared()).clamp(0.0, 1.0)
        } else {
            a
        };
        closest.length() - ra.max(rb) > self.behind + margin
    }
}

fn surface_area(b: &Aabb) -> f64 {
    if b.is_empty() {
        return 0.0;
    }
    let d = b.max - b.min;
    d.x * d.y + d.y * d.z + d.z * d.x
}

/// The split of the run `work` (at least two items) with the lowest surface area heuristic:
/// `area(left)·|left| + area(right)·|right|`, by one sweep from each end; among equal costs
/// the split nearest the middle (all boxes alike: halves).
fn sah_split(work: &[(u32, Aabb)], right_areas: &mut [f64]) -> usize {
    let n = work.len();
    let mut acc = Aabb::EMPTY;
    for i in (1..n).rev() {
        acc = acc.union(work[i].1);
        right_areas[i] = surface_area(&acc);
    }
    let mut acc = Aabb::EMPTY;
    let mut best = (f64::INFINITY, n / 2);
    for i in 1..n {
        acc = acc.union(work[i - 1].1);
        let cost = surface_area(&acc) * i as f64 + right_areas[i] * (n - i) as f64;
        let nearer = i.abs_diff(n / 2) < best.1.abs_diff(n / 2);
        if cost < best.0 || (cost == best.0 && nearer) {
            best = (cost, i);
        }
    }
    best.1
}

/// The 63-bit Morton code of `p` in `root`: 21 bits per axis, interleaved (a flat axis and a
/// non-finite coordinate give 0 on that axis).
fn morton_code(p: DVec3, root: &Aabb) -> u64 {
    const CELLS: f64 = ((1_u64 << 21) - 1) as f64;
    let spread = |v: u64| {
        // Bit `k` of `v` to bit `3k`.
        let mut v = v & 0x1f_ffff;
        v = (v | v << 32) & 0x1f_0000_0000_ffff;
        v = (v | v << 16) & 0x1f_0000_ff00_00ff;
        v = (v | v << 8) & 0x100f_00f0_0f00_f00f;
        v = (v | v << 4) & 0x10c3_0c30_c30c_30c3;
        (v | v << 2) & 0x1249_2492_4924_9249
    };
    let extent = root.max - root.min;
    let cell = |axis: usize| {
        let unit = (p[axis] - root.min[axis]) / extent[axis];
        // Saturating cast: NaN (a flat axis, 0/0) gives 0.
        spread((unit * CELLS).clamp(0.0, CELLS) as u64)
    };
    cell(0) << 2 | cell(1) << 1 | cell(2)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute(boxes: &[(u32, Aabb)], p: DVec3) -> Vec<u32> {
        let mut v: Vec<u32> = boxes
            .iter()
            .filter(|b| b.1.contains(p))
            .map(|b| b.0)
            .collect();
        v.sort_unstable();
        v
    }

    #[test]
    fn degenerate_inputs_build_shallow_trees_that_answer_like_brute_force() {
        // Geometric spacing drives the surface area heuristic towards deep trees; identical
        // boxes leave it nothing to split.
        let geometric: Vec<(u32, Aabb)> = (0..5000)
            .map(|i| {
                (
                    i,
                    Aabb::ball(DVec3::new(1.001_f64.powi(i as i32 * 20), 0.0, 0.0), 0.5),
                )
            })
            .collect();
        let identical: Vec<(u32, Aabb)> = (0..1000)
            .map(|i| (i, Aabb::ball(DVec3::ONE, 1.0)))
            .collect();
        for boxes in [geometric, identical] {
            let bvh = Bvh::build(&boxes);
            for x in [0.5, 1.0, 2.0, 10.0, 1e3, 1e8] {
                let p = DVec3::new(x, 0.1, 0.0);
                let mut got = Vec::new();
                bvh.for_each_containing(p, |i| got.push(i));
                got.sort_unstable();
                assert_eq!(got, brute(&boxes, p));
            }
        }
    }

    /// Moving one box within the root box leaves every other item's place in the leaf order
    /// relative to the rest (what the editor's reuse of rays after an edit relies on), on
    /// random scenes of every size, and queries still answer like brute force.
    #[test]
    fn moving_one_box_keeps_the_others_in_their_order() {
        use crate::model::rng::SplitMix64;
        let mut rng = SplitMix64::new(8123);
        for case in 0..40 {
            let n = 2 + rng.below(400);
            let mut boxes: Vec<(u32, Aabb)> = (0..n as u32)
                .map(|i| {
                    let c = DVec3::new(
                        rng.range(-5.0, 5.0),
                        rng.range(-5.0, 5.0),
                        rng.range(-1.0, 1.0),
                    );
                    (i, Aabb::ball(c, rng.range(0.05, 1.0)))
                })
                .collect();
            // Two far corners keep the root box when the moved box stays inside it.
            boxes.push((n as u32, Aabb::ball(DVec3::splat(-20.0), 1.0)));
            boxes.push((n as u32 + 1, Aabb::ball(DVec3::splat(20.0), 1.0)));
            let before = Bvh::build(&boxes);
            let moved = rng.below(n) as u32;
            let b = &mut boxes[moved as usize].1;
            let shift = DVec3::new(
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
                rng.range(-0.5, 0.5),
            );
            *b = Aabb {
                min: b.min + shift,
                max: b.max + shift,
            };
            let after = Bvh::build(&boxes);
            assert_eq!(before.bounds(), after.bounds(), "case {case}");
            let others = |bvh: &Bvh| -> Vec<u32> {
                bvh.items
                    .iter()
                    .map(|item| item.0)
                    .filter(|&i| i != moved)
                    .collect()
            };
            assert_eq!(
                others(&before),
                others(&after),
                "case {case}: {n} boxes, {moved} moved"
            );
            for _ in 0..20 {
                let p = DVec3::new(
                    rng.range(-6.0, 6.0),
                    rng.range(-6.0, 6.0),
                    rng.range(-2.0, 2.0),
                );
                let mut got = Vec::new();
                after.for_each_containing(p, |i| got.push(i));
                got.sort_unstable();
                assert_eq!(got, brute(&boxes, p), "case {case}");
            }
        }
    }
}
