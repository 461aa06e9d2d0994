//! A bounding volume hierarchy over the primitives' support boxes for the GPU's rays that leave
//! the screen tiles: a frame's shadow, reflected and refracted rays (main.wgsl
//! `trace_path`) and the statistics rays off the axes (gpu_stats.rs). Their window of supports
//! (shared/supports.wgsl `fill_window`) visits the primitives whose boxes the ray meets past the
//! window's floor, instead of testing every primitive at each refill.
//!
//! Median splits on the boxes' centres along their widest axis, leaves of up to [`LEAF`]
//! primitives, nodes in depth-first order with the index just past each subtree (`skip`), so
//! the shader walks it without a stack: a node the ray misses is skipped whole. The boxes are
//! the supports' f64 boxes widened outwards by a relative margin before rounding to f32, so a
//! primitive whose support the f32 ray meets is never skipped. Unbounded primitives (planes)
//! are listed after the tree's items and visited on every walk.
//!
//! The field shading terms (main.wgsl `field_anywhere`: soft shadows and ambient occlusion)
//! walk the same hierarchy for points, entering the nodes whose boxes hold the point.
//! [`RayBvh::point_walk_bound`] bounds the loop iterations such a walk takes anywhere, which
//! the renderer holds under lavapipe's per-invocation limit on software adapters.

use bytemuck::{Pod, Zeroable};
use glam::DVec3;
use skeletrace_core::field::geometry::Aabb;
use skeletrace_core::field::program::FieldProgram;

/// Primitives per leaf, at most (the count takes the low three bits of [`GpuBvhNode::leaf`]).
pub const LEAF: usize = 4;

/// Margin added to every side of a support box, relative to the box's size and its distance
/// from the origin: about a hundred f32 ulps of either.
const RELATIVE_MARGIN: f64 = 1e-5;

/// Twin of `BvhNode` in shared/scene.wgsl (a layout test checks every field's offset).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuBvhNode {
    /// Lower corner of the node's box.
    pub min: [f32; 3],
    /// Index of the node just past this node's subtree.
    pub skip: u32,
    /// Upper corner.
    pub max: [f32; 3],
    /// A leaf: `first << 3 | count`, its items `items[first..first + count]`; 0: an inner node,
    /// whose first child is the next node.
    pub leaf: u32,
}

/// The hierarchy of a scene, as uploaded.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RayBvh {
    /// Nodes in depth-first order (none without a bounded primitive).
    pub nodes: Vec<GpuBvhNode>,
    /// Primitive indices: the leaves' items, then the unbounded primitives.
    pub items: Vec<u32>,
    /// Where the unbounded primitives start in `items`.
    pub unbounded: u32,
}

impl RayBvh {
    /// The hierarchy over `program`'s primitives (indices as packed: program order).
    #[must_use]
    pub fn new(program: &FieldProgram) -> Self {
        let mut bounded = Vec::new();
        let mut unbounded = Vec::new();
        for (i, p) in program.primitives().iter().enumerate() {
            match p.support_aabb(program.kernel_of(i as u32)) {
                Some(b) => bounded.push((i as u32, widened(b))),
                None => unbounded.push(i as u32),
            }
        }
        let mut bvh = Self::default();
        if !bounded.is_empty() {
            bvh.build(&mut bounded);
        }
        bvh.unbounded = bvh.items.len() as u32;
        bvh.items.extend(unbounded);
        bvh
    }

    /// Appends the subtree over `work` in depth-first order.
    fn build(&mut self, work: &mut [(u32, [[f32; 3]; 2])]) {
        let index = self.nodes.len();
        let (min, max) = work.iter().fold(
            ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
            |(lo, hi), (_, [a, b])| {
                (
                    [lo[0].min(a[0]), lo[1].min(a[1]), lo[2].min(a[2])],
                    [hi[0].max(b[0]), hi[1].max(b[1]), hi[2].max(b[2])],
                )
            },
        );
        let leaf = if work.len() <= LEAF {
            let first = self.items.len() as u32;
            self.items.extend(work.iter().map(|(i, _)| *i));
            first << 3 | work.len() as u32
        } else {
            0
        };
        self.nodes.push(GpuBvhNode {
            min,
            skip: 0,
            max,
            leaf,
        });
        if leaf == 0 {
            let centre = |b: &[[f32; 3]; 2], axis: usize| b[0][axis] + b[1][axis];
            let axis = (0..3)
                .max_by(|&a, &b| (max[a] - min[a]).total_cmp(&(max[b] - min[b])))
                .unwrap_or(0);
            let mid = work.len() / 2;
            work.select_nth_unstable_by(mid, |(_, a), (_, b)| {
                centre(a, axis).total_cmp(&centre(b, axis))
            });
            let (left, right) = work.split_at_mut(mid);
            self.build(left);
            self.build(right);
        }
        self.nodes[index].skip = self.nodes.len() as u32;
    }
}

/// Calls [`RayBvh::point_walk_bound`] may spend on overlapping siblings before it settles for
/// the walk through every node.
const BOUND_CALLS: usize = 1 << 20;

/// A box as `[min, max]`.
type Corners = [[f32; 3]; 2];

fn intersection(a: Corners, b: Corners) -> Option<Corners> {
    let lo = [0, 1, 2].map(|k| a[0][k].max(b[0][k]));
    let hi = [0, 1, 2].map(|k| a[1][k].min(b[1][k]));
    (0..3).all(|k| lo[k] <= hi[k]).then_some([lo, hi])
}

impl RayBvh {
    /// Loop iterations of a point walk (main.wgsl `field_anywhere`), at most, wherever the
    /// point: each node visited takes one, each item of an entered leaf two (the iteration that
    /// finds it and the one that adds it), the unbounded primitives two each, and two more to
    /// turn to them and to end.
    ///
    /// A node is visited when its parent holds the point, so a walk's cost is a sum over the
    /// boxes holding the point. The bound follows the tree: where two siblings' boxes are
    /// disjoint the point is in one of them at most, where they overlap it may be in both, in
    /// their intersection (narrowed further at each level). Where overlaps multiply past
    /// [`BOUND_CALLS`], it is the walk through every node and item.
    #[must_use]
    pub fn point_walk_bound(&self) -> usize {
        let fixed = 2 * (self.items.len() - self.unbounded as usize) + 2;
        if self.nodes.is_empty() {
            return fixed;
        }
        let every = [[f32::NEG_INFINITY; 3], [f32::INFINITY; 3]];
        let mut calls = 0;
        let tree = self
            .subtree_bound(0, every, &mut calls)
            .unwrap_or(self.nodes.len() + 2 * self.unbounded as usize);
        tree + fixed
    }

    /// Iterations within the subtree of `node` (visited) for points in `region`; `None` past
    /// [`BOUND_CALLS`].
    fn subtree_bound(&self, node: usize, region: Corners, calls: &mut usize) -> Option<usize> {
        *calls += 1;
        if *calls > BOUND_CALLS {
            return None;
        }
        let n = self.nodes[node];
        let Some(inside) = intersection(region, [n.min, n.max]) else {
            return Some(1);
        };
        let count = (n.leaf & 7) as usize;
        if count > 0 {
            return Some(1 + 2 * count);
        }
        // The first child follows its parent; the second follows the first's subtree.
        let (first, second) = (node + 1, self.nodes[node + 1].skip as usize);
        let boxes = |i: usize| [self.nodes[i].min, self.nodes[i].max];
        // In the first child's box only, in the second's only, or in both.
        let mut most = (self.subtree_bound(first, inside, calls)? + 1)
            .max(1 + self.subtree_bound(second, inside, calls)?);
        if let Some(both) =
            intersection(inside, boxes(first)).and_then(|r| intersection(r, boxes(second)))
        {
            most = most.max(
                self.subtree_bound(first, both, calls)?
                    + self.subtree_bound(second, both, calls)?,
            );
        }
        Some(1 + most)
    }
}

/// `b` widened by [`RELATIVE_MARGIN`] of its size and of its distance from the origin, then
/// rounded outwards to f32.
fn widened(b: Aabb) -> [[f32; 3]; 2] {
    let margin = RELATIVE_MARGIN * (b.diagonal() + b.min.abs().max(b.max.abs()).max_element());
    let lo = b.min - DVec3::splat(margin);
    let hi = b.max + DVec3::splat(margin);
    let down = |x: f64| {
        let f = x as f32;
        if f64::from(f) > x { f.next_down() } else { f }
    };
    let up = |x: f64| {
        let f = x as f32;
        if f64::from(f) < x { f.next_up() } else { f }
    };
    [
        [down(lo.x), down(lo.y), down(lo.z)],
        [up(hi.x), up(hi.y), up(hi.z)],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use skeletrace_core::Scene;
    use skeletrace_core::bounds::interval::Interval;
    use skeletrace_core::field::geometry::Ray;
    use skeletrace_core::model::generate::{GenerateOptions, GeneratorKind, generate};

    /// The primitives a stackless walk visits for a ray: those of every leaf whose box, and
    /// every enclosing box, the ray's line meets (f64 slab test on the f32 boxes).
    fn walk(bvh: &RayBvh, ray: &Ray) -> Vec<u32> {
        let mut out = Vec::new();
        let mut node = 0;
        while node < bvh.nodes.len() {
            let n = bvh.nodes[node];
            let b = Aabb {
                min: DVec3::from(n.min.map(f64::from)),
                max: DVec3::from(n.max.map(f64::from)),
            };
            if b.ray_interval(ray, Interval::ENTIRE).is_none() {
                node = n.skip as usize;
                continue;
            }
            let count = (n.leaf & 7) as usize;
            if count > 0 {
                let first = (n.leaf >> 3) as usize;
                out.extend_from_slice(&bvh.items[first..first + count]);
            }
            node = if count > 0 { n.skip as usize } else { node + 1 };
        }
        out.extend_from_slice(&bvh.items[bvh.unbounded as usize..]);
        out
    }

    fn random_units(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1_u64 << 53) as f64
        }
    }

    /// Generated scenes of several kinds, seeds and sizes, and the assets with shapes, HRBF
    /// terms and a plane, and the 3 000 overlapping atoms of `molecule`.
    fn scenes() -> Vec<(String, Scene)> {
        let mut scenes: Vec<(String, Scene)> = [
            (GeneratorKind::Blobs, 3, 300),
            (GeneratorKind::RandomSkeleton, 8, 40),
            (GeneratorKind::Tree, 5, 5),
            (GeneratorKind::Truss, 2, 4),
            (GeneratorKind::Foam, 6, 30),
        ]
        .into_iter()
        .map(|(kind, seed, size)| {
            let options = GenerateOptions {
                seed,
                size: Some(size),
                ..Default::default()
            };
            let scene = generate(kind, &options).unwrap_or_else(|e| panic!("{e}"));
            (format!("{kind:?} {seed}"), scene)
        })
        .collect();
        for asset in ["operators", "hrbf", "creature", "molecule"] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join(format!("../assets/scenes/{asset}.ron"));
            scenes.push((
                asset.to_owned(),
                Scene::load(&path).unwrap_or_else(|e| panic!("{e}")),
            ));
        }
        scenes
    }

    /// On [`scenes`]: every primitive is listed once; skip pointers and leaves are well
    /// formed; and a walk visits every primitive whose support the ray's line meets (random rays
    /// through the scene, half of them aimed at a primitive).
    #[test]
    fn a_walk_visits_every_support_the_ray_meets() {
        let mut unit = random_units(99);
        for (kind, scene) in scenes() {
            let program = FieldProgram::new(&scene);
            let bvh = RayBvh::new(&program);
            let mut listed = bvh.items.clone();
            listed.sort_unstable();
            let every: Vec<u32> = (0..program.primitives().len() as u32).collect();
            assert_eq!(listed, every, "{kind}: every primitive once");
            for (i, n) in bvh.nodes.iter().enumerate() {
                assert!(n.skip as usize > i && n.skip as usize <= bvh.nodes.len());
                let count = n.leaf & 7;
                assert!(count as usize <= LEAF);
                assert_eq!(count == 0, n.skip as usize > i + 1, "{kind}: node {i}");
            }
            let bounds = program.support_bounds();
            for k in 0..400 {
                let target = if k % 2 == 0 {
                    let i = (unit() * program.primitives().len() as f64) as u32;
                    program.primitives()[i as usize]
                        .support_aabb(program.kernel_of(i))
                        .map_or(bounds.center(), |b| b.center())
                } else {
                    bounds.min + (bounds.max - bounds.min) * DVec3::new(unit(), unit(), unit())
                };
                let direction =
                    DVec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5).normalize_or(DVec3::X);
                let ray = Ray {
                    origin: target - direction * bounds.diagonal(),
                    direction,
                };
                let visited = walk(&bvh, &ray);
                for (i, p) in program.primitives().iter().enumerate() {
                    if p.support_interval(&ray, program.kernel_of(i as u32))
                        .is_some()
                    {
                        assert!(
                            visited.contains(&(i as u32)),
                            "{kind} ray {k}: primitive {i} not visited"
                        );
                    }
                }
            }
        }
    }

    /// Loop iterations of main.wgsl `field_anywhere` at `p`, counted as
    /// [`RayBvh::point_walk_bound`] counts them (f32 comparisons, as the shader's).
    fn point_walk_iterations(bvh: &RayBvh, p: [f32; 3]) -> usize {
        let mut iterations = 2 * (bvh.items.len() - bvh.unbounded as usize) + 2;
        let mut node = 0;
        while node < bvh.nodes.len() {
            iterations += 1;
            let n = bvh.nodes[node];
            let inside = (0..3).all(|k| n.min[k] <= p[k] && p[k] <= n.max[k]);
            let count = (n.leaf & 7) as usize;
            if !inside {
                node = n.skip as usize;
            } else if count == 0 {
                node += 1;
            } else {
                iterations += 2 * count;
                node = n.skip as usize;
            }
        }
        iterations
    }

    /// On [`scenes`], no point walk takes more iterations than the bound: at random points of
    /// the scene, at primitives' centres and at the corners and centres of where two nodes'
    /// boxes overlap (where walks are longest). The bound is never above a walk through every
    /// node and item.
    #[test]
    fn the_point_walk_bound_holds_wherever_the_point() {
        let mut unit = random_units(17);
        for (kind, scene) in scenes() {
            let program = FieldProgram::new(&scene);
            let bvh = RayBvh::new(&program);
            let bound = bvh.point_walk_bound();
            let bounds = program.support_bounds();
            let mut points: Vec<[f32; 3]> = Vec::new();
            for _ in 0..2000 {
                let p = bounds.min + (bounds.max - bounds.min) * DVec3::new(unit(), unit(), unit());
                points.push(p.as_vec3().to_array());
            }
            for (i, p) in program.primitives().iter().enumerate() {
                if let Some(b) = p.support_aabb(program.kernel_of(i as u32)) {
                    points.push(b.center().as_vec3().to_array());
                }
            }
            let n = bvh.nodes.len();
            for _ in 0..4000.min(n * n) {
                let pick = |u: f64| bvh.nodes[((u * n as f64) as usize).min(n - 1)];
                let (a, b) = (pick(unit()), pick(unit()));
                if let Some([lo, hi]) = intersection([a.min, a.max], [b.min, b.max]) {
                    points.push([0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k])));
                    for corner in 0..8 {
                        points.push(
                            [0, 1, 2].map(|k| if corner >> k & 1 == 0 { lo[k] } else { hi[k] }),
                        );
                    }
                }
            }
            let longest = points
                .iter()
                .map(|&p| point_walk_iterations(&bvh, p))
                .max()
                .unwrap_or(0);
            let every = n + 2 * bvh.items.len() + 2;
            eprintln!("{kind}: longest walk sampled {longest}, bound {bound}, every node {every}");
            assert!(
                longest <= bound,
                "{kind}: a walk of {longest} iterations, bound {bound}"
            );
            assert!(bound <= every, "{kind}: bound {bound} against {every}");
        }
    }
}
