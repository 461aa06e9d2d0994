//! Isosurface extraction for export: marching tetrahedra on the Kuhn (Freudenthal) subdivision
//! of a grid over the field's support. Each cube is cut into six tetrahedra around its main
//! diagonal, the same way in every cube, so two neighbouring cubes cut their shared face along
//! the same diagonal and the tetrahedra tile space. Inside a tetrahedron the field's linear
//! interpolant has one planar zero set, so each tetrahedron contributes at most two triangles
//! with no ambiguous case; a vertex is made once per grid edge that changes sign and shared by
//! every tetrahedron around that edge. The mesh of a closed surface is therefore watertight and
//! 2-manifold by construction, and every triangle is wound so that its normal points from the
//! tetrahedron's inside corners to its outside ones: outward. docs/architecture.md says why
//! this method was chosen over dual contouring or surface nets.
//!
//! Vertices are then moved along their grid edge onto `f = c` of the true field (the sign
//! change on the edge brackets a root, so the false-position iteration always converges) and
//! kept a little inside the edge, so that no two vertices coincide and no triangle is
//! degenerate. [`MeshReport`] measures what the construction promises, on any mesh.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::FieldProgram;
use glam::DVec3;
use rayon::prelude::*;

/// The six tetrahedra of a unit cube, as paths from corner 0 to corner 7 (corners numbered by
/// their bits x = 1, y = 2, z = 4): one per order in which the three axes are stepped.
const KUHN_TETRAHEDRA: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 1, 5, 7],
    [0, 2, 3, 7],
    [0, 2, 6, 7],
    [0, 4, 5, 7],
    [0, 4, 6, 7],
];

/// How close to a grid point a vertex may come along its edge, as a fraction of the edge:
/// vertices of different edges never coincide.
const EDGE_MARGIN: f64 = 1e-6;

/// False-position iterations that move a vertex onto the surface along its edge.
const EDGE_ITERATIONS: usize = 40;

/// A triangle mesh of `f = c` with one vertex per sign-changing grid edge.
#[derive(Debug)]
pub struct TetraMesh {
    /// Positions.
    pub positions: Vec<DVec3>,
    /// Triangles, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    /// Skeleton points inside the surface that the grid did not see ([`lost_features`]).
    pub lost_features: usize,
}

/// The grid: `dims` points along each axis from `origin`, `cell` apart.
#[derive(Clone, Copy, Debug)]
pub struct Grid {
    /// The first grid point.
    pub origin: DVec3,
    /// The spacing.
    pub cell: f64,
    /// Points along x, y and z.
    pub dims: [usize; 3],
}

impl Grid {
    fn point(&self, index: usize) -> DVec3 {
        let [nx, ny, _] = self.dims;
        let (x, y, z) = (index % nx, (index / nx) % ny, index / (nx * ny));
        self.origin + DVec3::new(x as f64, y as f64, z as f64) * self.cell
    }
}

/// Samples `f − c` at every grid point (slices in parallel; `progress` gets the fraction done)
/// and extracts the triangles of its zero set. With `close_at_border` the grid's outermost
/// points count as outside, so that a surface the grid cuts (a plane's) is closed by a cap on
/// the grid's box, as a printer needs a solid. `None` once `cancel` is set (checked per slice
/// of the grid).
pub fn extract(
    program: &FieldProgram,
    grid: Grid,
    close_at_border: bool,
    progress: &(dyn Fn(f64) + Sync),
    cancel: &AtomicBool,
) -> Option<TetraMesh> {
    let [nx, ny, nz] = grid.dims;
    let c = program.isovalue();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let mut values = vec![0.0f64; nx * ny * nz];
    values
        .par_chunks_mut(nx * ny)
        .enumerate()
        .for_each(|(z, slice)| {
            if cancel.load(Ordering::Relaxed) {
                return;
            }
            for (i, value) in slice.iter_mut().enumerate() {
                let (x, y) = (i % nx, i / nx);
                let border =
                    x == 0 || y == 0 || z == 0 || x == nx - 1 || y == ny - 1 || z == nz - 1;
                *value = program.value(grid.point(z * nx * ny + i)) - c;
                if close_at_border && border {
                    *value = value.min(0.0);
                }
            }
            let n = done.fetch_add(1, Ordering::Relaxed) + 1;
            progress(n as f64 / nz as f64);
        });
    if cancel.load(Ordering::Relaxed) {
        return None;
    }
    let inside = |i: usize| values[i] > 0.0;
    let corner_offsets = [
        0,
        1,
        nx,
        nx + 1,
        nx * ny,
        nx * ny + 1,
        nx * ny + nx,
        nx * ny + nx + 1,
    ];
    let mut edges: HashMap<(usize, usize), u32> = HashMap::new();
    let mut crossings: Vec<(usize, usize)> = Vec::new();
    let mut triangles = Vec::new();
    let mut vertex_of = |a: usize, b: usize| -> u32 {
        // (inside, outside) identifies the edge and the direction of its crossing.
        *edges.entry((a, b)).or_insert_with(|| {
            crossings.push((a, b));
            (crossings.len() - 1) as u32
        })
    };
    for z in 0..nz.saturating_sub(1) {
        for y in 0..ny - 1 {
            for x in 0..nx - 1 {
                let base = x + nx * (y + ny * z);
                let corners = corner_offsets.map(|o| base + o);
                let flags = corners.map(inside);
                if flags.iter().all(|&f| f) || flags.iter().all(|&f| !f) {
                    continue;
                }
                for tetra in KUHN_TETRAHEDRA {
                    let points = tetra.map(|k| corners[k]);
                    let (ins, outs): (Vec<usize>, Vec<usize>) =
                        points.iter().partition(|&&p| inside(p));
                    if ins.is_empty() || outs.is_empty() {
                        continue;
                    }
                    let mut cut: Vec<u32> = Vec::with_capacity(4);
                    // The 2–2 case's four crossings in order round their quadrilateral.
                    if ins.len() == 2 {
                        for (a, b) in [(0, 0), (0, 1), (1, 1), (1, 0)] {
                            cut.push(vertex_of(ins[a], outs[b]));
                        }
                    } else {
                        for &a in &ins {
                            for &b in &outs {
                                cut.push(vertex_of(a, b));
                            }
                        }
                    }
                    let centre = |set: &[usize]| {
                        set.iter().map(|&p| grid.point(p)).sum::<DVec3>() / set.len() as f64
                    };
                    let outward = centre(&outs) - centre(&ins);
                    let mut push = |t: [u32; 3]| triangles.push((t, outward));
                    push([cut[0], cut[1], cut[2]]);
                    if cut.len() == 4 {
                        push([cut[0], cut[2], cut[3]]);
                    }
                }
            }
        }
    }
    let positions: Vec<DVec3> = crossings
        .par_iter()
        .map(|&(a, b)| onto_surface(program, grid.point(a), grid.point(b), values[a], values[b]))
        .collect();
    let triangles = triangles
        .into_iter()
        .map(|(t, outward)| {
            let [p, q, r] = t.map(|i| positions[i as usize]);
            if (q - p).cross(r - p).dot(outward) < 0.0 {
                [t[0], t[2], t[1]]
            } else {
                t
            }
        })
        .collect();
    let lost_features = lost_features(program, grid, &values);
    Some(TetraMesh {
        positions,
        triangles,
        lost_features,
    })
}

/// Points of the skeleton — blob centres, segment ends and midpoints — where the field is inside
/// the surface but no corner of the grid cell around them is: a part thinner than a cell there,
/// which the mesh lacks. `values` are the grid's samples of `f − c`.
fn lost_features(program: &FieldProgram, grid: Grid, values: &[f64]) -> usize {
    use crate::field::primitives::Primitive;
    let c = program.isovalue();
    let [nx, ny, nz] = grid.dims;
    let probes = program.primitives().iter().flat_map(|p| match p {
        Primitive::Point(b) => vec![b.center],
        Primitive::Scalis(s) => cone_points(&s.cone),
        Primitive::Distance(s) => cone_points(&s.cone),
        Primitive::Shape(_) | Primitive::Hrbf(_) => Vec::new(),
    });
    probes
        .filter(|&p| program.value(p) > c)
        .filter(|&p| {
            let cell = ((p - grid.origin) / grid.cell).floor();
            let [x, y, z] = cell.to_array().map(|v| v.max(0.0) as usize);
            if x + 1 >= nx || y + 1 >= ny || z + 1 >= nz {
                return false;
            }
            let corner_inside = (0..8).any(|k| {
                let i = (x + (k & 1)) + nx * ((y + ((k >> 1) & 1)) + ny * (z + (k >> 2)));
                values[i] > 0.0
            });
            !corner_inside
        })
        .count()
}

/// A segment's ends and midpoint.
fn cone_points(cone: &crate::field::geometry::SphereCone) -> Vec<DVec3> {
    [0.0, 0.5, 1.0]
        .map(|f| cone.start + cone.axis * (f * cone.length))
        .to_vec()
}

/// The root of `f = c` on the edge from `inside` (where `f − c` is `d_in > 0`) to `outside`
/// (`d_out ≤ 0`), by false position with the Illinois rule, kept [`EDGE_MARGIN`] inside the
/// edge.
fn onto_surface(
    program: &FieldProgram,
    inside: DVec3,
    outside: DVec3,
    d_in: f64,
    d_out: f64,
) -> DVec3 {
    let c = program.isovalue();
    let (mut lo, mut hi) = (0.0, 1.0);
    let (mut f_lo, mut f_hi) = (d_in, d_out);
    let mut t = d_in / (d_in - d_out);
    let mut last_side = 0i8;
    for _ in 0..EDGE_ITERATIONS {
        if hi - lo <= 1e-12 {
            break;
        }
        let f = program.value(inside.lerp(outside, t)) - c;
        if f == 0.0 {
            break;
        }
        if f > 0.0 {
            (lo, f_lo) = (t, f);
            if last_side == 1 {
                f_hi *= 0.5;
            }
            last_side = 1;
        } else {
            (hi, f_hi) = (t, f);
            if last_side == -1 {
                f_lo *= 0.5;
            }
            last_side = -1;
        }
        t = lo + (hi - lo) * f_lo / (f_lo - f_hi);
        if !t.is_finite() || t <= lo || t >= hi {
            t = 0.5 * (lo + hi);
        }
    }
    inside.lerp(outside, t.clamp(EDGE_MARGIN, 1.0 - EDGE_MARGIN))
}

/// What a mesh is, measured: its size, whether it is closed and 2-manifold, its orientation
/// and how far its vertices are from the surface.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MeshReport {
    /// Triangles.
    pub triangles: usize,
    /// Vertices.
    pub vertices: usize,
    /// Every edge has exactly two faces, no vertex more than one fan, no triangle zero area.
    pub watertight: bool,
    /// Edges of one face only.
    pub boundary_edges: usize,
    /// Edges of more than two faces.
    pub non_manifold_edges: usize,
    /// Vertices whose faces form more than one fan.
    pub non_manifold_vertices: usize,
    /// Triangles of zero area.
    pub degenerate_triangles: usize,
    /// Edges whose two faces run them the same way (the faces disagree on the side they face).
    pub misoriented_edges: usize,
    /// The signed volume enclosed: positive when the triangles face outwards.
    pub volume: f64,
    /// The largest `|f(v) − c| / |∇f(v)|` over the vertices (a first-order distance to the
    /// surface), in grid cells, leaving out those at a jump of the field.
    pub max_distance_cells: f64,
    /// Vertices where the field jumps across `c` (an HRBF set cut at its box, say): `f − c`
    /// changes sign within [`JUMP_PROBE`] cells of the vertex though the first-order distance
    /// says it is further than that. The surface is the jump there.
    pub vertices_at_jumps: usize,
    /// Vertices of the cap that closes a surface cut at the grid's box (a plane's): on the box,
    /// where the field is inside, left out of the distance.
    pub vertices_on_cut: usize,
    /// Points of the skeleton inside the surface where the grid saw nothing: parts thinner than
    /// a cell, missing from the mesh there (a finer resolution keeps them).
    pub lost_features: usize,
}

/// How close to a vertex, in cells, [`MeshReport`] looks for a sign change of `f − c` where the
/// first-order distance is large.
pub const JUMP_PROBE: f64 = 1e-5;

impl MeshReport {
    /// Measures the mesh of `positions` and `triangles` against `program`'s surface, with
    /// distances in cells of `grid`; `closed_at_border` as given to [`extract`].
    #[must_use]
    pub fn of(
        program: &FieldProgram,
        positions: &[DVec3],
        triangles: &[[u32; 3]],
        grid: Grid,
        closed_at_border: bool,
        lost_features: usize,
    ) -> Self {
        let cell = grid.cell;
        let box_max = grid.origin
            + DVec3::new(
                (grid.dims[0] - 1) as f64,
                (grid.dims[1] - 1) as f64,
                (grid.dims[2] - 1) as f64,
            ) * cell;
        let on_cut = |p: DVec3| {
            closed_at_border
                && ((p - grid.origin).min_element() < 1e-5 * cell
                    || (box_max - p).min_element() < 1e-5 * cell)
                && program.value(p) > program.isovalue()
        };
        let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
        for t in triangles {
            for k in 0..3 {
                *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        let (mut boundary_edges, mut non_manifold_edges, mut misoriented_edges) = (0, 0, 0);
        for (&(a, b), &forward) in &directed {
            let backward = directed.get(&(b, a)).copied().unwrap_or(0);
            // Each undirected edge once: from its smaller end, or where only (b, a) is absent.
            if a > b && backward > 0 {
                continue;
            }
            match forward + backward {
                1 => boundary_edges += 1,
                2 if forward == 2 || backward == 2 => misoriented_edges += 1,
                2 => {}
                _ => non_manifold_edges += 1,
            }
        }
        let degenerate_triangles = triangles
            .iter()
            .filter(|t| {
                let [a, b, c] = t.map(|i| positions[i as usize]);
                (b - a).cross(c - a).length_squared() == 0.0
            })
            .count();
        let non_manifold_vertices = count_non_manifold_vertices(positions.len(), triangles);
        let volume = triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| positions[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum();
        let c = program.isovalue();
        let distances: Vec<Option<f64>> = positions
            .par_iter()
            .map(|&p| {
                if on_cut(p) {
                    return Some(0.0);
                }
                let (f, g) = program.value_gradient(p);
                let g = g.length();
                let distance = if g > 0.0 {
                    (f - c).abs() / g / cell
                } else {
                    0.0
                };
                if distance <= JUMP_PROBE {
                    return Some(distance);
                }
                let h = JUMP_PROBE * cell;
                let at_jump = [DVec3::X, DVec3::Y, DVec3::Z].iter().any(|&axis| {
                    (program.value(p + h * axis) > c) != (program.value(p - h * axis) > c)
                });
                (!at_jump).then_some(distance)
            })
            .collect();
        let vertices_at_jumps = distances.iter().filter(|d| d.is_none()).count();
        let vertices_on_cut = positions.par_iter().filter(|&&p| on_cut(p)).count();
        let max_distance_cells = distances.iter().flatten().copied().fold(0.0, f64::max);
        Self {
            triangles: triangles.len(),
            vertices: positions.len(),
            watertight: boundary_edges == 0
                && non_manifold_edges == 0
                && non_manifold_vertices == 0
                && degenerate_triangles == 0,
            boundary_edges,
            non_manifold_edges,
            non_manifold_vertices,
            degenerate_triangles,
            misoriented_edges,
            volume,
            max_distance_cells,
            vertices_at_jumps,
            vertices_on_cut,
            lost_features,
        }
    }
}

/// Vertices whose incident triangles form more than one fan: the edges opposite a vertex in its
/// triangles (its link) fall apart into more than one connected piece.
fn count_non_manifold_vertices(vertices: usize, triangles: &[[u32; 3]]) -> usize {
    let mut link: Vec<Vec<(u32, u32)>> = vec![Vec::new(); vertices];
    for t in triangles {
        for k in 0..3 {
            link[t[k] as usize].push((t[(k + 1) % 3], t[(k + 2) % 3]));
        }
    }
    link.iter()
        .filter(|edges| {
            let mut parent: HashMap<u32, u32> = HashMap::new();
            for &(a, b) in edges.iter() {
                let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
                if ra != rb {
                    parent.insert(ra, rb);
                }
            }
            let ends: Vec<u32> = edges.iter().flat_map(|&(a, b)| [a, b]).collect();
            let mut roots: Vec<u32> = ends.into_iter().map(|v| find(&mut parent, v)).collect();
            roots.sort_unstable();
            roots.dedup();
            roots.len() > 1
        })
        .count()
}

/// The representative of `v` in the union-find forest `parent` (a vertex absent from it is its
/// own), with the path to it compressed.
fn find(parent: &mut HashMap<u32, u32>, v: u32) -> u32 {
    let mut root = v;
    while let Some(&p) = parent.get(&root) {
        if p == root {
            break;
        }
        root = p;
    }
    let mut at = v;
    while at != root {
        let next = parent.get(&at).copied().unwrap_or(root);
        parent.insert(at, root);
        at = next;
    }
    root
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Kuhn tetrahedra fill the cube: their volumes add to one, none is flat.
    #[test]
    fn the_six_tetrahedra_tile_the_cube() {
        let corner = |k: usize| DVec3::new((k & 1) as f64, ((k >> 1) & 1) as f64, (k >> 2) as f64);
        let mut total = 0.0;
        for t in KUHN_TETRAHEDRA {
            let [a, b, c, d] = t.map(corner);
            let v = (b - a).dot((c - a).cross(d - a)).abs() / 6.0;
            assert!(v > 0.1, "{t:?} is flat");
            total += v;
        }
        assert!((total - 1.0).abs() < 1e-12, "{total}");
    }
}
