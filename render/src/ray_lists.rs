//! The statistics rays as the GPU takes them ([`GpuStatsRay`]) and their candidate primitives
//! ([`RayLists`]): rays along an axis look theirs up in a grid of cells across the box (the
//! primitives whose support's bounding sphere, seen along that axis, covers the cell); other
//! rays take [`EVERY_PRIMITIVE`], and the shader finds theirs in the scene's hierarchy
//! ([`crate::ray_bvh`]). What a traced ray gives back is a [`RayCrossings`], with up to
//! [`CROSSING_SLOTS`] crossings. `gpu_stats` drives them through the protocol.

use bytemuck::{Pod, Zeroable};
use glam::DVec3;
use skeletrace_core::bounds::interval::Interval;
use skeletrace_core::field::geometry::Ray;

use crate::buffers::GpuPrimitive;
use crate::shared::EVERY_PRIMITIVE;

/// Crossings kept per ray in transparent statistics; a ray that crosses the surface more often
/// fails the run (its crossings could not all be compared).
pub const CROSSING_SLOTS: u32 = 32;

/// One ray of a transparent batch ([`GpuRenderer::trace_rays_through`]).
#[derive(Clone, Debug, PartialEq)]
pub struct RayCrossings {
    /// Steps of the whole march.
    pub steps: u32,
    /// Steps up to the last crossing (as core's `Trace::steps_to_last_crossing`).
    pub steps_to_last: u32,
    /// Crossings the march found.
    pub found: u32,
    /// The first [`CROSSING_SLOTS`] of them: parameter from the ray's start, and whether it
    /// enters the volume.
    pub kept: Vec<(f64, bool)>,
}

/// Cells along each side of an axis's grid.
const GRID: usize = 64;

/// Twin of `StatsRay` in main.wgsl: a ray from `origin` along unit `dir` over `[0, far]`,
/// among the primitives of list `list`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuStatsRay {
    /// Start of the traced interval.
    pub origin: [f32; 3],
    /// Its length.
    pub far: f32,
    /// Unit direction.
    pub dir: [f32; 3],
    /// Candidate list ([`RayLists`]), or [`EVERY_PRIMITIVE`].
    pub list: u32,
}

/// Candidate primitives of statistics rays along the axes: for each axis a [`GRID`]² grid of
/// cells across the box, lists `axis · GRID² + cell`.
pub struct RayLists {
    /// Per list, its range in `items`.
    pub ranges: Vec<[u32; 2]>,
    /// Primitive indices.
    pub items: Vec<u32>,
    min: DVec3,
    cell: DVec3,
}

/// [`RayLists`] on the GPU ([`GpuRenderer::upload_ray_lists`]).
pub struct UploadedRayLists {
    pub(crate) ranges: wgpu::Buffer,
    pub(crate) items: wgpu::Buffer,
}

impl RayLists {
    /// The lists of `primitives` (as packed for the GPU) for rays inside the box `[min, max]`.
    #[must_use]
    pub fn new(primitives: &[GpuPrimitive], min: DVec3, max: DVec3) -> Self {
        let cell = ((max - min) / GRID as f64).max(DVec3::splat(1e-12));
        // Bounding spheres are stored in f32: a margin keeps every covered cell.
        let margin = 1e-5 * (max - min).length();
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); 3 * GRID * GRID];
        for (i, p) in primitives.iter().enumerate() {
            let i = i as u32;
            let [x, y, z, r] = p.bound.map(f64::from);
            for axis in 0..3 {
                let base = axis * GRID * GRID;
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                if r < 0.0 {
                    // Unbounded support: every cell.
                    for k in 0..GRID * GRID {
                        lists[base + k].push(i);
                    }
                    continue;
                }
                let centre = DVec3::new(x, y, z);
                let span = |a: usize| {
                    let lo = (centre[a] - r - margin - min[a]) / cell[a];
                    let hi = (centre[a] + r + margin - min[a]) / cell[a];
                    let clamp = |c: f64| (c.floor().max(0.0) as usize).min(GRID - 1);
                    (hi >= 0.0 && lo < GRID as f64).then(|| (clamp(lo), clamp(hi)))
                };
                let (Some((u0, u1)), Some((v0, v1))) = (span(u), span(v)) else {
                    continue;
                };
                for cu in u0..=u1 {
                    for cv in v0..=v1 {
                        lists[base + cu * GRID + cv].push(i);
                    }
                }
            }
        }
        let mut ranges = Vec::with_capacity(lists.len());
        let mut items = Vec::new();
        for list in lists {
            let start = items.len() as u32;
            items.extend(list);
            ranges.push([start, items.len() as u32]);
        }
        Self {
            ranges,
            items,
            min,
            cell,
        }
    }

    /// The GPU ray of `ray` over `span`: started at the span's beginning, its list the cell it
    /// runs through when it follows an axis, else [`EVERY_PRIMITIVE`].
    #[must_use]
    pub fn ray(&self, ray: &Ray, span: Interval) -> GpuStatsRay {
        let d = ray.direction;
        let axis = (0..3).find(|&a| {
            let (u, v) = ((a + 1) % 3, (a + 2) % 3);
            d[a] != 0.0 && d[u] == 0.0 && d[v] == 0.0
        });
        let start = ray.at(span.lo);
        let list = match axis {
            Some(a) => {
                let (u, v) = ((a + 1) % 3, (a + 2) % 3);
                let cell = |k: usize| {
                    (((start[k] - self.min[k]) / self.cell[k]).floor().max(0.0) as usize)
                        .min(GRID - 1)
                };
                (a * GRID * GRID + cell(u) * GRID + cell(v)) as u32
            }
            None => EVERY_PRIMITIVE,
        };
        GpuStatsRay {
            origin: start.as_vec3().to_array(),
            far: (span.hi - span.lo) as f32,
            dir: d.as_vec3().to_array(),
            list,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blob(centre: [f32; 3], radius: f32) -> GpuPrimitive {
        GpuPrimitive {
            bound: [centre[0], centre[1], centre[2], radius],
            ..GpuPrimitive::zeroed()
        }
    }

    /// An axis ray's list holds every primitive whose bounding sphere the ray meets, sampled
    /// over random spheres and rays; other rays get every primitive.
    #[test]
    fn an_axis_rays_list_holds_every_sphere_it_meets() {
        let mut state = 7_u64;
        let mut unit = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1_u64 << 53) as f64
        };
        let (min, max) = (DVec3::new(-1.0, -2.0, 0.0), DVec3::new(3.0, 1.0, 5.0));
        let spheres: Vec<GpuPrimitive> = (0..200)
            .map(|_| {
                let c = min + (max - min) * DVec3::new(unit(), unit(), unit());
                blob(c.as_vec3().to_array(), (0.05 + 0.6 * unit()) as f32)
            })
            .collect();
        let lists = RayLists::new(&spheres, min, max);
        for k in 0..3000 {
            let axis = k % 3;
            let mut origin = min + (max - min) * DVec3::new(unit(), unit(), unit());
            origin[axis] = min[axis];
            let mut direction = DVec3::ZERO;
            direction[axis] = 1.0;
            let ray = Ray { origin, direction };
            let gpu = lists.ray(&ray, Interval::new(0.0, (max - min)[axis]));
            let [a, b] = lists.ranges[gpu.list as usize];
            let listed = &lists.items[a as usize..b as usize];
            for (i, p) in spheres.iter().enumerate() {
                let c = DVec3::new(p.bound[0].into(), p.bound[1].into(), p.bound[2].into());
                let off = (c - origin) - direction * (c - origin).dot(direction);
                if off.length() <= f64::from(p.bound[3]) {
                    assert!(listed.contains(&(i as u32)), "ray {k} misses sphere {i}");
                }
            }
        }
        let slanted = Ray {
            origin: min,
            direction: DVec3::ONE.normalize(),
        };
        let gpu = lists.ray(&slanted, Interval::new(0.0, 1.0));
        assert_eq!(gpu.list, EVERY_PRIMITIVE);
    }
}
