//! Bounding volume hierarchy over primitive supports: the CPU analogue of the scalis 2021
//! paper's A-buffer (§6). A point query visits only the primitives whose support box contains
//! the point; a ray query visits those whose box meets a ray interval. Built by median splits
//! of the box centres along the widest axis, so a query costs O(log n + k) at fixed overlap.

use glam::DVec3;

use crate::geometry::{Aabb, Ray};
use crate::interval::Interval;

const LEAF_SIZE: usize = 4;

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
    items: Vec<u32>,
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
        bvh.build_node(&mut work);
        bvh
    }

    fn build_node(&mut self, work: &mut [(u32, Aabb, DVec3)]) -> u32 {
        let bounds = work.iter().fold(Aabb::EMPTY, |acc, w| acc.union(w.1));
        let index = self.nodes.len() as u32;
        if work.len() <= LEAF_SIZE {
            self.nodes.push(Node {
                bounds,
                first_or_right: self.items.len() as u32,
                count: work.len() as u32,
            });
            self.items.extend(work.iter().map(|w| w.0));
            return index;
        }
        self.nodes.push(Node {
            bounds,
            first_or_right: 0,
            count: 0,
        });
        let (lo, hi) = work.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), w| (lo.min(w.2), hi.max(w.2)),
        );
        let extent = hi - lo;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let mid = work.len() / 2;
        work.select_nth_unstable_by(mid, |a, b| a.2[axis].total_cmp(&b.2[axis]));
        let (left, right) = work.split_at_mut(mid);
        self.build_node(left);
        let right_index = self.build_node(right);
        self.nodes[index as usize].first_or_right = right_index;
        index
    }

    /// Union of all boxes.
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        self.nodes.first().map_or(Aabb::EMPTY, |n| n.bounds)
    }

    fn traverse(&self, hit: impl Fn(&Aabb) -> bool, mut visit: impl FnMut(u32)) {
        if self.nodes.is_empty() {
            return;
        }
        // Median splits bound the depth by log2(n) + 1, far below the stack size.
        let mut stack = [0_u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let i = stack[top];
            let node = &self.nodes[i as usize];
            if !hit(&node.bounds) {
                continue;
            }
            if node.count > 0 {
                let first = node.first_or_right as usize;
                for &item in &self.items[first..first + node.count as usize] {
                    visit(item);
                }
            } else {
                stack[top] = node.first_or_right;
                stack[top + 1] = i + 1;
                top += 2;
            }
        }
    }

    /// Calls `visit` with every item whose box contains `p`.
    pub fn for_each_containing(&self, p: DVec3, visit: impl FnMut(u32)) {
        self.traverse(|b| b.contains(p), visit);
    }

    /// Calls `visit` with every item whose box meets the ray on `span`.
    pub fn for_each_on_ray(&self, ray: &Ray, span: Interval, visit: impl FnMut(u32)) {
        self.traverse(|b| b.ray_interval(ray, span).is_some(), visit);
    }
}
