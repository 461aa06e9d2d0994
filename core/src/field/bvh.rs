//! Bounding volume hierarchy over primitive supports: the CPU analogue of the scalis 2021
//! paper's A-buffer (§6). A point query visits only the primitives whose support box contains
//! the point; a ray query visits those whose box meets a ray interval. Built top-down with the
//! binned surface area heuristic (falling back to a median split when it finds no useful split),
//! so a query costs O(log n + k) at fixed overlap.

use glam::DVec3;

use crate::bounds::interval::Interval;
use crate::field::geometry::{Aabb, Ray};

const LEAF_SIZE: usize = 4;
/// Centroid bins per axis of the surface area heuristic.
const SAH_BINS: usize = 16;
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
        let mut work: Vec<(u32, Aabb, DVec3)> =
            boxes.iter().map(|&(id, b)| (id, b, b.center())).collect();
        bvh.build_node(&mut work, 0);
        bvh
    }

    fn build_node(&mut self, work: &mut [(u32, Aabb, DVec3)], depth: usize) -> u32 {
        let bounds = work.iter().fold(Aabb::EMPTY, |acc, w| acc.union(w.1));
        let index = self.nodes.len() as u32;
        if work.len() <= LEAF_SIZE {
            self.nodes.push(Node {
                bounds,
                first_or_right: self.items.len() as u32,
                count: work.len() as u32,
            });
            self.items.extend(work.iter().map(|w| (w.0, w.1)));
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
            sah_split(work)
        } else {
            median_split(work)
        };
        let (left, right) = work.split_at_mut(mid);
        self.build_node(left, depth + 1);
        let right_index = self.build_node(right, depth + 1);
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

/// Reorders `work` and returns the split index chosen by the binned surface area heuristic;
/// a median split along the widest centroid axis when no bin boundary separates the items.
fn sah_split(work: &mut [(u32, Aabb, DVec3)]) -> usize {
    let (lo, hi) = centroid_bounds(work);
    let extent = hi - lo;
    let bin_of = |c: DVec3, axis: usize| {
        (((c[axis] - lo[axis]) / extent[axis] * SAH_BINS as f64) as usize).min(SAH_BINS - 1)
    };
    // (cost, axis, first bin of the right side)
    let mut best: Option<(f64, usize, usize)> = None;
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let mut bins = [(Aabb::EMPTY, 0_usize); SAH_BINS];
        for w in work.iter() {
            let b = &mut bins[bin_of(w.2, axis)];
            b.0 = b.0.union(w.1);
            b.1 += 1;
        }
        let mut right = [(0.0, 0_usize); SAH_BINS];
        let (mut acc, mut n) = (Aabb::EMPTY, 0);
        for i in (1..SAH_BINS).rev() {
            acc = acc.union(bins[i].0);
            n += bins[i].1;
            right[i] = (surface_area(&acc), n);
        }
        let (mut acc, mut n) = (Aabb::EMPTY, 0);
        for i in 1..SAH_BINS {
            acc = acc.union(bins[i - 1].0);
            n += bins[i - 1].1;
            if n == 0 || right[i].1 == 0 {
                continue;
            }
            let cost = surface_area(&acc) * n as f64 + right[i].0 * right[i].1 as f64;
            if best.is_none_or(|b| cost < b.0) {
                best = Some((cost, axis, i));
            }
        }
    }
    if let Some((_, axis, first_right)) = best {
        let mut split = 0;
        for i in 0..work.len() {
            if bin_of(work[i].2, axis) < first_right {
                work.swap(i, split);
                split += 1;
            }
        }
        return split;
    }
    // All centroids coincide: split the list in half.
    work.len() / 2
}

fn centroid_bounds(work: &[(u32, Aabb, DVec3)]) -> (DVec3, DVec3) {
    work.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), w| (lo.min(w.2), hi.max(w.2)),
    )
}

/// Median split of the centroids along the widest axis.
fn median_split(work: &mut [(u32, Aabb, DVec3)]) -> usize {
    let (lo, hi) = centroid_bounds(work);
    let axis = (hi - lo).max_position();
    let mid = work.len() / 2;
    work.select_nth_unstable_by(mid, |a, b| a.2[axis].total_cmp(&b.2[axis]));
    mid
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
}
