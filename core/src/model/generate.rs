//! Scene generators, deterministic per seed, mirroring the scenes of the papers' figures:
//! branching trees and random skeletons (scalis 2021 fig. 11), foams from Voronoi diagrams
//! (fig. 12) and lattice trusses (fig. 16), random point blobs blended as a max of sums
//! (forward-inclusion 2023 fig. 1) and Gaussian molecules (forward-inclusion §7.1, after
//! Bruckner 2019).

use std::collections::HashMap;

use glam::{DQuat, DVec3};

use crate::model::kernel::Kernel;
use crate::model::rng::SplitMix64;
use crate::model::scene::{
    Blend, Blob, Camera, Group, MAX_PRIMITIVES, Material, SCENE_VERSION, Scene, Skeleton,
    SkeletonField, Vertex,
};

/// What to generate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GeneratorKind {
    /// Branching skeleton with radii shrinking towards the tips.
    Tree,
    /// Random walk skeleton with branches.
    RandomSkeleton,
    /// Edges of a Voronoi diagram of random points in a box.
    Foam,
    /// Cubic lattice with face diagonals.
    Truss,
    /// Random point blobs, compact kernel, max of sums.
    Blobs,
    /// Thousands of Gaussian atoms along a folded chain.
    Molecule,
}

impl GeneratorKind {
    /// All kinds with their command-line names.
    pub const ALL: [(Self, &'static str); 6] = [
        (Self::Tree, "tree"),
        (Self::RandomSkeleton, "random-skeleton"),
        (Self::Foam, "foam"),
        (Self::Truss, "truss"),
        (Self::Blobs, "blobs"),
        (Self::Molecule, "molecule"),
    ];

    /// What a generated scene shows, for the comment at the top of its file.
    #[must_use]
    pub fn description(self) -> &'static str {
        match self {
            Self::Tree => {
                "A branching SCALIS tree whose radii shrink towards the tips, with end-point correctors (scalis 2021, trees of fig. 11)."
            }
            Self::RandomSkeleton => {
                "A random-walk SCALIS skeleton with branches (scalis 2021, fig. 11)."
            }
            Self::Foam => {
                "The edges of a Voronoi diagram of random points in a box as thin SCALIS segments (scalis 2021, foams of fig. 12)."
            }
            Self::Truss => {
                "A cubic lattice truss with face diagonals and no free ends (scalis 2021, fig. 15-16)."
            }
            Self::Blobs => {
                "Random point blobs with the degree-6 compact kernel, summed per group, groups combined by max (forward-inclusion 2023, fig. 1; one group: the summed blobs of fig. 10)."
            }
            Self::Molecule => {
                "Thousands of Gaussian atoms along a folded chain (forward-inclusion 2023, section 7.1, after Bruckner 2019)."
            }
        }
    }

    /// Command-line name.
    #[must_use]
    pub fn name(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(k, _)| *k == self)
            .map_or("?", |(_, n)| n)
    }
}

/// Generator options; `None` picks the kind's default.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GenerateOptions {
    /// Seed of the random generator.
    pub seed: u64,
    /// Size: tree depth, segments, Voronoi cells, lattice cells per side, blobs or atoms.
    pub size: Option<usize>,
    /// Groups of blobs (`blobs` only).
    pub groups: Option<usize>,
    /// Varying rather than constant radii (`random-skeleton`, `foam`).
    pub varying_radii: bool,
    /// Field type of skeletons (default SCALIS).
    pub field: Option<SkeletonField>,
    /// Build scenes larger than [`MAX_PRIMITIVES`] primitives.
    pub allow_large: bool,
}

/// Memory one generated primitive takes, scene and compiled scene together, rounded up: the
/// scene's vertex and edge, the compiled primitive, its BVH box and kernel (checked against
/// the types' sizes in `core/tests/scene_files.rs`).
pub const BYTES_PER_PRIMITIVE: u64 = 400;

/// How many primitives `generate(kind, options)` builds at most, before it builds anything:
/// exact for random skeletons, trusses, blobs and molecules; for trees the count if every
/// branch split in three (`(3^depth − 1)/2`); for foams 16 per Voronoi cell (generated foams
/// have up to about 13: 10.7 at 1 000 cells, 12.7 at 41 000).
#[must_use]
pub fn estimated_primitives(kind: GeneratorKind, options: &GenerateOptions) -> u64 {
    let size = options.size.unwrap_or_else(|| default_size(kind)).max(1) as u64;
    match kind {
        GeneratorKind::Tree => 3_u64
            .checked_pow(u32::try_from(size).unwrap_or(u32::MAX))
            .map_or(u64::MAX, |n| (n - 1) / 2),
        GeneratorKind::RandomSkeleton | GeneratorKind::Blobs | GeneratorKind::Molecule => size,
        GeneratorKind::Foam => size.saturating_mul(16),
        GeneratorKind::Truss => {
            // Axis edges 3c(c+1)², face diagonals 4c².
            let c = size;
            let n = c.saturating_add(1);
            (3_u64.saturating_mul(c))
                .saturating_mul(n.saturating_mul(n))
                .saturating_add(4_u64.saturating_mul(c.saturating_mul(c)))
        }
    }
}

/// [`estimated_primitives`] in floating point, for messages about sizes past `u64`.
fn estimated_primitives_f64(kind: GeneratorKind, size: usize) -> f64 {
    let size = size.max(1) as f64;
    match kind {
        GeneratorKind::Tree => (3_f64.powf(size) - 1.0) / 2.0,
        GeneratorKind::RandomSkeleton | GeneratorKind::Blobs | GeneratorKind::Molecule => size,
        GeneratorKind::Foam => 16.0 * size,
        GeneratorKind::Truss => 3.0 * size * (size + 1.0).powi(2) + 4.0 * size * size,
    }
}

/// Default size of each kind.
#[must_use]
pub fn default_size(kind: GeneratorKind) -> usize {
    match kind {
        GeneratorKind::Tree => 6,
        GeneratorKind::RandomSkeleton => 60,
        GeneratorKind::Foam => 40,
        GeneratorKind::Truss => 4,
        GeneratorKind::Blobs => 80,
        GeneratorKind::Molecule => 3000,
    }
}

/// Generates a scene, with the default camera (`compile::framing_camera` frames it once
/// compiled: the model does not compile).
///
/// # Errors
/// One line with the estimate and the limit when [`estimated_primitives`] exceeds
/// [`MAX_PRIMITIVES`] and `options.allow_large` is not set; nothing is built then.
pub fn generate(kind: GeneratorKind, options: &GenerateOptions) -> Result<Scene, String> {
    check_options(kind, options)?;
    let estimate = estimated_primitives(kind, options);
    if estimate > MAX_PRIMITIVES && !options.allow_large {
        let size = options.size.unwrap_or_else(|| default_size(kind));
        let count = estimated_primitives_f64(kind, size);
        let (count, megabytes) = if estimate == u64::MAX || count >= 1e15 {
            (
                format!("{count:.3e}"),
                format!("{:.3e}", count * BYTES_PER_PRIMITIVE as f64 / 1e6),
            )
        } else {
            (
                estimate.to_string(),
                format!("{:.0}", estimate as f64 * BYTES_PER_PRIMITIVE as f64 / 1e6),
            )
        };
        return Err(format!(
            "{} of size {size} would build up to {count} primitives (about {megabytes} MB), over \
             the limit of {MAX_PRIMITIVES}; choose a smaller --size or pass --allow-large",
            kind.name(),
        ));
    }
    Ok(build(kind, options))
}

/// `Err` naming the option where `options` asks for what `kind` does not build: a size of 0
/// (a foam of no cell was an empty scene), blob groups beyond the blobs (empty groups) or for
/// another kind, varying radii where every radius is the generator's own, distance fields
/// where there is no skeleton. Before, each was ignored or clamped in silence.
fn check_options(kind: GeneratorKind, options: &GenerateOptions) -> Result<(), String> {
    if options.size == Some(0) {
        return Err(format!("{}: --size 0: expected at least 1", kind.name()));
    }
    let size = options.size.unwrap_or_else(|| default_size(kind));
    match (kind, options.groups) {
        (GeneratorKind::Blobs, Some(groups)) if groups == 0 || groups > size => {
            return Err(format!(
                "blobs: --groups {groups}: expected 1 to {size}, the number of blobs (each group \
                 holds at least one)"
            ));
        }
        (GeneratorKind::Blobs, _) | (_, None) => {}
        (_, Some(_)) => return Err(format!("{}: --groups applies to blobs only", kind.name())),
    }
    if options.varying_radii && !matches!(kind, GeneratorKind::RandomSkeleton | GeneratorKind::Foam)
    {
        return Err(format!(
            "{}: --radii varying applies to random-skeleton and foam only",
            kind.name()
        ));
    }
    if options.field == Some(SkeletonField::Distance)
        && matches!(kind, GeneratorKind::Blobs | GeneratorKind::Molecule)
    {
        return Err(format!(
            "{}: --field distance applies to skeletons (tree, random-skeleton, foam, truss)",
            kind.name()
        ));
    }
    Ok(())
}

fn build(kind: GeneratorKind, options: &GenerateOptions) -> Scene {
    let mut rng = SplitMix64::new(options.seed);
    let size = options.size.unwrap_or_else(|| default_size(kind)).max(1);
    let field = options.field.unwrap_or(SkeletonField::Scalis);
    let compact = Kernel::CompactPolynomial {
        degree: 6,
        scale: 2.0,
    };
    let (groups, blend) = match kind {
        GeneratorKind::Tree => (
            vec![skeleton_group(
                "tree",
                compact,
                [0.55, 0.42, 0.30],
                tree(&mut rng, size, field),
            )],
            None,
        ),
        GeneratorKind::RandomSkeleton => (
            vec![skeleton_group(
                "random skeleton",
                compact,
                [0.35, 0.55, 0.75],
                random_skeleton(&mut rng, size, options.varying_radii, field),
            )],
            None,
        ),
        GeneratorKind::Foam => (
            vec![skeleton_group(
                "foam",
                compact,
                [0.85, 0.80, 0.65],
                foam(&mut rng, size, options.varying_radii, field),
            )],
            None,
        ),
        GeneratorKind::Truss => (
            vec![skeleton_group(
                "truss",
                compact,
                [0.60, 0.62, 0.68],
                truss(size, field),
            )],
            None,
        ),
        GeneratorKind::Blobs => blobs(&mut rng, size, options.groups.unwrap_or(4).min(size)),
        GeneratorKind::Molecule => (vec![molecule(&mut rng, size)], None),
    };
    Scene {
        version: SCENE_VERSION,
        isovalue: 1.0,
        groups,
        blend,
        camera: Camera::default(),
        lights: Scene::default_lights(),
    }
}

fn skeleton_group(name: &str, kernel: Kernel, color: [f64; 3], skeleton: Skeleton) -> Group {
    Group {
        name: name.to_owned(),
        kernel,
        material: Material {
            color,
            ..Material::default()
        },
        skeletons: vec![skeleton],
        blobs: Vec::new(),
        shapes: Vec::new(),
        hrbfs: Vec::new(),
        transform: crate::model::scene::Transform::IDENTITY,
        repeat: None,
    }
}

/// Builds skeletons vertex by vertex.
struct SkeletonBuilder {
    vertices: Vec<Vertex>,
    edges: Vec<[u32; 2]>,
}

impl SkeletonBuilder {
    fn new() -> Self {
        Self {
            vertices: Vec::new(),
            edges: Vec::new(),
        }
    }

    fn vertex(&mut self, p: DVec3, radius: f64) -> u32 {
        self.vertices.push(Vertex {
            position: p.to_array(),
            radius,
        });
        (self.vertices.len() - 1) as u32
    }

    fn edge(&mut self, a: u32, b: u32) {
        self.edges.push([a, b]);
    }

    fn finish(self, name: &str, field: SkeletonField, end_correctors: bool) -> Skeleton {
        Skeleton {
            name: name.to_owned(),
            field,
            end_correctors: end_correctors && field == SkeletonField::Scalis,
            vertices: self.vertices,
            edges: self.edges,
        }
    }
}

/// A random unit vector perpendicular to `d`.
fn perpendicular(rng: &mut SplitMix64, d: DVec3) -> DVec3 {
    let (a, b) = d.any_orthonormal_pair();
    let phi = rng.range(0.0, std::f64::consts::TAU);
    a * phi.cos() + b * phi.sin()
}

fn tree(rng: &mut SplitMix64, depth: usize, field: SkeletonField) -> Skeleton {
    let mut b = SkeletonBuilder::new();
    let root = b.vertex(DVec3::ZERO, 0.16);
    // (parent vertex, direction, length, level)
    let mut stack = vec![(root, DVec3::Y, 1.0, 0_usize)];
    while let Some((parent, dir, length, level)) = stack.pop() {
        let p = DVec3::from_array(b.vertices[parent as usize].position);
        let r = b.vertices[parent as usize].radius;
        let tip = b.vertex(p + dir * length, r * rng.range(0.62, 0.72));
        b.edge(parent, tip);
        if level + 1 >= depth {
            continue;
        }
        let children = if rng.unit() < 0.3 { 3 } else { 2 };
        for _ in 0..children {
            let angle = rng.range(20.0_f64, 45.0).to_radians();
            let axis = perpendicular(rng, dir);
            let child_dir =
                (DQuat::from_axis_angle(axis, angle) * dir + DVec3::Y * 0.15).normalize();
            stack.push((tip, child_dir, length * rng.range(0.68, 0.8), level + 1));
        }
    }
    b.finish("tree", field, true)
}

fn random_skeleton(
    rng: &mut SplitMix64,
    segments: usize,
    varying: bool,
    field: SkeletonField,
) -> Skeleton {
    let mut b = SkeletonBuilder::new();
    let mut dirs = vec![DVec3::from_array(rng.direction())];
    b.vertex(DVec3::ZERO, 0.1);
    for _ in 0..segments {
        let from = if rng.unit() < 0.8 {
            b.vertices.len() - 1
        } else {
            rng.below(b.vertices.len())
        };
        let p = DVec3::from_array(b.vertices[from].position);
        let r = b.vertices[from].radius;
        let dir = (dirs[from] + 0.8 * DVec3::from_array(rng.direction())).normalize();
        let length = rng.range(0.3, 0.6);
        let radius = if varying {
            // Keep |Δτ|/L below 0.4 < 1/σ.
            (r * rng.range(0.7, 1.4))
                .clamp(0.05, 0.2)
                .clamp(r - 0.4 * length, r + 0.4 * length)
        } else {
            r
        };
        let v = b.vertex(p + dir * length, radius);
        dirs.push(dir);
        b.edge(from as u32, v);
    }
    b.finish("random skeleton", field, true)
}

fn truss(cells: usize, field: SkeletonField) -> Skeleton {
    let mut b = SkeletonBuilder::new();
    let n = cells + 1;
    let spacing = 2.0 / cells as f64;
    let index = |i: usize, j: usize, k: usize| ((i * n + j) * n + k) as u32;
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let p = DVec3::new(i as f64, j as f64, k as f64) * spacing - DVec3::ONE;
                b.vertex(p, 0.045);
            }
        }
    }
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let here = index(i, j, k);
                if i + 1 < n {
                    b.edge(here, index(i + 1, j, k));
                }
                if j + 1 < n {
                    b.edge(here, index(i, j + 1, k));
                }
                if k + 1 < n {
                    b.edge(here, index(i, j, k + 1));
                }
                // Alternating diagonals on the side faces make it a truss.
                if i + 1 < n && j + 1 < n && (k == 0 || k + 1 == n) {
                    if (i + j) % 2 == 0 {
                        b.edge(here, index(i + 1, j + 1, k));
                    } else {
                        b.edge(index(i + 1, j, k), index(i, j + 1, k));
                    }
                }
                if j + 1 < n && k + 1 < n && (i == 0 || i + 1 == n) {
                    if (j + k) % 2 == 0 {
                        b.edge(here, index(i, j + 1, k + 1));
                    } else {
                        b.edge(index(i, j + 1, k), index(i, j, k + 1));
                    }
                }
            }
        }
    }
    b.finish("truss", field, false)
}

/// Convex polyhedron as a list of faces (vertex loops), for Voronoi cell clipping.
struct Polyhedron {
    faces: Vec<Vec<DVec3>>,
}

impl Polyhedron {
    fn cube(half: f64) -> Self {
        let c = |x: f64, y: f64, z: f64| DVec3::new(x, y, z) * half;
        let faces = vec![
            vec![
                c(-1., -1., -1.),
                c(-1., 1., -1.),
                c(-1., 1., 1.),
                c(-1., -1., 1.),
            ],
            vec![
                c(1., -1., -1.),
                c(1., 1., -1.),
                c(1., 1., 1.),
                c(1., -1., 1.),
            ],
            vec![
                c(-1., -1., -1.),
                c(1., -1., -1.),
                c(1., -1., 1.),
                c(-1., -1., 1.),
            ],
            vec![
                c(-1., 1., -1.),
                c(1., 1., -1.),
                c(1., 1., 1.),
                c(-1., 1., 1.),
            ],
            vec![
                c(-1., -1., -1.),
                c(1., -1., -1.),
                c(1., 1., -1.),
                c(-1., 1., -1.),
            ],
            vec![
                c(-1., -1., 1.),
                c(1., -1., 1.),
                c(1., 1., 1.),
                c(-1., 1., 1.),
            ],
        ];
        Self { faces }
    }

    /// Keeps the part where `n·x ≤ d` (Sutherland–Hodgman per face, then a cap face).
    fn clip(&mut self, n: DVec3, d: f64) {
        let mut cut: Vec<DVec3> = Vec::new();
        let mut faces = Vec::with_capacity(self.faces.len() + 1);
        for face in &self.faces {
            let mut out = Vec::with_capacity(face.len() + 1);
            for (i, &a) in face.iter().enumerate() {
                let b = face[(i + 1) % face.len()];
                let (da, db) = (n.dot(a) - d, n.dot(b) - d);
                if da <= 0.0 {
                    out.push(a);
                }
                if (da <= 0.0) != (db <= 0.0) {
                    let p = a + (b - a) * (da / (da - db));
                    out.push(p);
                    if !cut.iter().any(|q| q.distance_squared(p) < 1e-20) {
                        cut.push(p);
                    }
                }
            }
            if out.len() >= 3 {
                faces.push(out);
            }
        }
        if cut.len() >= 3 {
            let center = cut.iter().copied().sum::<DVec3>() / cut.len() as f64;
            let (e1, e2) = n.normalize().any_orthonormal_pair();
            cut.sort_by(|p, q| {
                let angle = |v: DVec3| (v - center).dot(e2).atan2((v - center).dot(e1));
                angle(*p).total_cmp(&angle(*q))
            });
            faces.push(cut);
        }
        self.faces = faces;
    }

    fn max_distance_sq(&self, p: DVec3) -> f64 {
        self.faces
            .iter()
            .flatten()
            .map(|v| v.distance_squared(p))
            .fold(0.0, f64::max)
    }
}

/// Size of a foam's cells (the cube root of the box's volume per cell) up to which
/// [`FOAM_STRUT_RADIUS`] holds: 0.2, the cells of a 1 000-cell foam in the box `[-1, 1]³`.
const FOAM_REFERENCE_CELL: f64 = 0.2;

/// Strut radius of foams of up to 1 000 cells (varying radii: 0.016 to 0.03). Denser foams scale
/// it with the cell size `2/∛cells`, which keeps the struts' share of a cell (the foam's
/// relative density) as at 1 000 cells: a foam of 41 000 cells is the same open foam at a finer
/// scale, as the paper's 526 000-segment foam (scalis 2021 fig. 12), not one whose kernel
/// supports (4 radii across at σ = 2) fill its cells.
pub const FOAM_STRUT_RADIUS: f64 = 0.022;

fn foam(rng: &mut SplitMix64, cells: usize, varying: bool, field: SkeletonField) -> Skeleton {
    let half = 1.0;
    let sites: Vec<DVec3> = (0..cells)
        .map(|_| {
            DVec3::new(
                rng.range(-half, half),
                rng.range(-half, half),
                rng.range(-half, half),
            )
        })
        .collect();
    let cell_size = 2.0 * half / (cells as f64).cbrt();
    let radius_scale = if cell_size < FOAM_REFERENCE_CELL {
        cell_size / FOAM_REFERENCE_CELL
    } else {
        1.0
    };
    let mut b = SkeletonBuilder::new();
    let mut ids: HashMap<[i64; 3], u32> = HashMap::new();
    let quantum = 1e-7;
    let mut vertex_id = |b: &mut SkeletonBuilder, p: DVec3, rng: &mut SplitMix64| {
        let q = (p / quantum).round();
        let key = [q.x as i64, q.y as i64, q.z as i64];
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(&id) = ids.get(&[key[0] + dx, key[1] + dy, key[2] + dz]) {
                        return id;
                    }
                }
            }
        }
        let radius = if varying {
            rng.range(0.016, 0.03)
        } else {
            FOAM_STRUT_RADIUS
        };
        let id = b.vertex(p, radius * radius_scale);
        ids.insert(key, id);
        id
    };
    let mut seen = std::collections::HashSet::new();
    let on_boundary = |p: DVec3, q: DVec3| {
        (0..3).any(|axis| {
            ((p[axis] - half).abs() < 1e-9 && (q[axis] - half).abs() < 1e-9)
                || ((p[axis] + half).abs() < 1e-9 && (q[axis] + half).abs() < 1e-9)
        })
    };
    let grid = SiteGrid::new(&sites, half);
    let mut neighbours = Vec::new();
    for i in 0..sites.len() {
        let mut cell = Polyhedron::cube(half);
        grid.clip_to_voronoi_cell(&sites, i, &mut cell, &mut neighbours);
        for face in &cell.faces {
            for (k, &p) in face.iter().enumerate() {
                let q = face[(k + 1) % face.len()];
                if on_boundary(p, q) || p.distance_squared(q) < 1e-8 {
                    continue;
                }
                let (a, c) = (vertex_id(&mut b, p, rng), vertex_id(&mut b, q, rng));
                if a != c && seen.insert((a.min(c), a.max(c))) {
                    b.edge(a, c);
                }
            }
        }
    }
    // Radii must respect the slope limit |Δτ|/L < 1/σ on every edge.
    for &[a, c] in &b.edges {
        let (va, vc) = (b.vertices[a as usize], b.vertices[c as usize]);
        let length = distance(va.position, vc.position);
        if (va.radius - vc.radius).abs() >= 0.4 * length {
            let r = va.radius.min(vc.radius);
            b.vertices[a as usize].radius = r;
            b.vertices[c as usize].radius = r;
        }
    }
    b.finish("foam", field, true)
}

/// Voronoi sites binned in a uniform grid over the box `[-half, half]³` (about one site per
/// grid cell), so that a site's cell is clipped by its neighbours in order of distance without
/// sorting every other site: a foam of 41 000 cells is built in seconds, not minutes.
struct SiteGrid {
    per_side: usize,
    width: f64,
    half: f64,
    bins: Vec<Vec<u32>>,
}

impl SiteGrid {
    fn new(sites: &[DVec3], half: f64) -> Self {
        let per_side = ((sites.len() as f64).cbrt() as usize).max(1);
        let width = 2.0 * half / per_side as f64;
        let mut grid = Self {
            per_side,
            width,
            half,
            bins: vec![Vec::new(); per_side * per_side * per_side],
        };
        for (i, &site) in sites.iter().enumerate() {
            let bin = grid.bin_index(grid.bin_of(site));
            grid.bins[bin].push(i as u32);
        }
        grid
    }

    fn bin_of(&self, p: DVec3) -> [usize; 3] {
        let axis =
            |x: f64| (((x + self.half) / self.width).max(0.0) as usize).min(self.per_side - 1);
        [axis(p.x), axis(p.y), axis(p.z)]
    }

    fn bin_index(&self, [x, y, z]: [usize; 3]) -> usize {
        (z * self.per_side + y) * self.per_side + x
    }

    /// Calls `visit` with every site of the bins at Chebyshev distance `ring` from `centre`.
    fn visit_ring(&self, centre: [usize; 3], ring: usize, mut visit: impl FnMut(u32)) {
        let range = |c: usize| c.saturating_sub(ring)..=(c + ring).min(self.per_side - 1);
        for z in range(centre[2]) {
            for y in range(centre[1]) {
                for x in range(centre[0]) {
                    let away = x
                        .abs_diff(centre[0])
                        .max(y.abs_diff(centre[1]))
                        .max(z.abs_diff(centre[2]));
                    if away == ring {
                        self.bins[self.bin_index([x, y, z])]
                            .iter()
                            .copied()
                            .for_each(&mut visit);
                    }
                }
            }
        }
    }

    /// Clips `cell` (the box) to the Voronoi cell of `sites[i]`: by the bisector planes of the
    /// other sites in order of distance (ties by index), until a site is farther than twice the
    /// cell's extent and so cannot cut it. Rings of bins are added outward; after ring `k` every
    /// site closer than `(k − 1)` bin widths has been seen (one bin of slack for rounding), and
    /// those are clipped in order, so the planes and their order are those of sorting every
    /// site, bit for bit. `pending` is scratch space.
    fn clip_to_voronoi_cell(
        &self,
        sites: &[DVec3],
        i: usize,
        cell: &mut Polyhedron,
        pending: &mut Vec<(f64, u32)>,
    ) {
        let site = sites[i];
        let centre = self.bin_of(site);
        pending.clear();
        for ring in 0.. {
            self.visit_ring(centre, ring, |j| {
                if j as usize != i {
                    pending.push((sites[j as usize].distance_squared(site), j));
                }
            });
            let every_bin = ring + 1 >= self.per_side;
            let complete = if every_bin {
                f64::INFINITY
            } else {
                let reach = ring.saturating_sub(1) as f64 * self.width;
                reach * reach
            };
            pending.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let ready = pending.partition_point(|&(d2, _)| d2 < complete);
            for &(d2, j) in &pending[..ready] {
                // Security radius: a site farther than twice the cell's extent cannot cut it.
                if d2 > 4.0 * cell.max_distance_sq(site) {
                    return;
                }
                let n = sites[j as usize] - site;
                cell.clip(n, n.dot(0.5 * (site + sites[j as usize])));
            }
            // Every site not yet seen is at least `complete` away.
            if every_bin || complete > 4.0 * cell.max_distance_sq(site) {
                return;
            }
            pending.drain(..ready);
        }
    }
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    DVec3::from_array(a).distance(DVec3::from_array(b))
}

fn blobs(rng: &mut SplitMix64, count: usize, groups: usize) -> (Vec<Group>, Option<Blend>) {
    let palette = [
        [0.85, 0.35, 0.30],
        [0.30, 0.60, 0.85],
        [0.40, 0.75, 0.40],
        [0.90, 0.75, 0.30],
        [0.65, 0.45, 0.80],
        [0.35, 0.75, 0.75],
    ];
    let mut out: Vec<Group> = (0..groups)
        .map(|g| Group {
            name: format!("blobs {g}"),
            kernel: Kernel::CompactPolynomial {
                degree: 6,
                scale: 2.0,
            },
            material: Material {
                color: palette[g % palette.len()],
                ..Material::default()
            },
            skeletons: Vec::new(),
            blobs: Vec::new(),
            shapes: Vec::new(),
            hrbfs: Vec::new(),
            transform: crate::model::scene::Transform::IDENTITY,
            repeat: None,
        })
        .collect();
    let centers: Vec<DVec3> = (0..groups)
        .map(|_| {
            DVec3::new(
                rng.range(-0.6, 0.6),
                rng.range(-0.6, 0.6),
                rng.range(-0.6, 0.6),
            )
        })
        .collect();
    for i in 0..count {
        let g = i % groups;
        let offset = DVec3::from_array(rng.direction()) * rng.range(0.0, 0.7);
        out[g].blobs.push(Blob {
            center: (centers[g] + offset).to_array(),
            radius: rng.range(0.08, 0.2),
        });
    }
    let blend = (groups > 1).then(|| Blend::Max((0..groups as u32).map(Blend::Group).collect()));
    (out, blend)
}

fn molecule(rng: &mut SplitMix64, atoms: usize) -> Group {
    // Element radii in nm-like units (C, N, O, S), bond length 0.15.
    let elements = [(0.17, 0.62), (0.155, 0.2), (0.152, 0.15), (0.18, 0.03)];
    let bond = 0.15;
    let confinement = (atoms as f64 * 0.012 * 3.0 / (4.0 * std::f64::consts::PI)).cbrt();
    let mut p = DVec3::ZERO;
    let mut dir = DVec3::X;
    let mut blobs = Vec::with_capacity(atoms);
    for _ in 0..atoms {
        let mut pick = rng.unit();
        let mut radius = elements[0].0;
        for (r, share) in elements {
            if pick < share {
                radius = r;
                break;
            }
            pick -= share;
        }
        blobs.push(Blob {
            center: p.to_array(),
            radius,
        });
        dir = (dir + 0.9 * DVec3::from_array(rng.direction())).normalize();
        let next = p + dir * bond;
        if next.length() > confinement {
            dir = (-next.normalize() + 0.5 * DVec3::from_array(rng.direction())).normalize();
        }
        p += dir * bond;
    }
    Group {
        name: "molecule".to_owned(),
        kernel: Kernel::Gaussian { scale: 1.0 },
        material: Material {
            color: [0.55, 0.70, 0.90],
            ..Material::default()
        },
        skeletons: Vec::new(),
        blobs,
        shapes: Vec::new(),
        hrbfs: Vec::new(),
        transform: crate::model::scene::Transform::IDENTITY,
        repeat: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each option a kind does not use, and sizes and group counts that would build empty
    /// scenes or groups, are refused naming the option; the defaults always build.
    #[test]
    fn options_a_kind_does_not_use_are_refused() {
        let refused = |kind: GeneratorKind, options: GenerateOptions, expected: &str| {
            let err = generate(kind, &options).err().unwrap_or_default();
            assert!(
                err.contains(expected),
                "{kind:?} {options:?}: {err:?} lacks {expected:?}"
            );
        };
        let none = GenerateOptions::default();
        for (kind, _) in GeneratorKind::ALL {
            refused(
                kind,
                GenerateOptions {
                    size: Some(0),
                    ..none
                },
                "--size 0",
            );
            if kind != GeneratorKind::Blobs {
                refused(
                    kind,
                    GenerateOptions {
                        groups: Some(2),
                        ..none
                    },
                    "--groups applies",
                );
            }
        }
        let blobs = GenerateOptions {
            size: Some(5),
            ..none
        };
        refused(
            GeneratorKind::Blobs,
            GenerateOptions {
                groups: Some(0),
                ..blobs
            },
            "1 to 5",
        );
        refused(
            GeneratorKind::Blobs,
            GenerateOptions {
                groups: Some(6),
                ..blobs
            },
            "1 to 5",
        );
        let built = generate(
            GeneratorKind::Blobs,
            &GenerateOptions {
                groups: Some(5),
                ..blobs
            },
        );
        assert!(built.is_ok_and(|s| s.groups.iter().all(|g| g.blobs.len() == 1)));
        let few = generate(
            GeneratorKind::Blobs,
            &GenerateOptions {
                size: Some(2),
                ..none
            },
        );
        assert!(
            few.is_ok_and(|s| s.groups.len() == 2),
            "4 groups by default, at most one per blob"
        );
        let varying = GenerateOptions {
            varying_radii: true,
            ..none
        };
        refused(GeneratorKind::Tree, varying, "--radii varying applies");
        refused(GeneratorKind::Truss, varying, "--radii varying applies");
        let distance = GenerateOptions {
            field: Some(SkeletonField::Distance),
            ..none
        };
        refused(
            GeneratorKind::Molecule,
            distance,
            "--field distance applies",
        );
        refused(GeneratorKind::Blobs, distance, "--field distance applies");
        assert!(generate(GeneratorKind::Truss, &distance).is_ok());
    }

    #[test]
    fn generators_are_deterministic_and_produce_valid_scenes() {
        for (kind, name) in GeneratorKind::ALL {
            let options = GenerateOptions {
                seed: 7,
                size: Some(match kind {
                    GeneratorKind::Molecule => 200,
                    GeneratorKind::Foam => 12,
                    GeneratorKind::Tree => 4,
                    _ => default_size(kind),
                }),
                ..GenerateOptions::default()
            };
            let a = generate(kind, &options).unwrap_or_else(|e| panic!("{e}"));
            let b = generate(kind, &options).unwrap_or_else(|e| panic!("{e}"));
            assert!(a == b, "{name} is not deterministic");
            let reparsed = Scene::from_ron(&a.to_ron(), name);
            assert!(reparsed.is_ok(), "{name}: {reparsed:?}");
            assert!(
                reparsed.ok().as_ref() == Some(&a),
                "{name} does not round-trip"
            );
            let counts = a.counts();
            assert!(counts.segments + counts.blobs > 0, "{name} is empty");
            if kind != GeneratorKind::Truss {
                let other = generate(kind, &GenerateOptions { seed: 8, ..options })
                    .unwrap_or_else(|e| panic!("{e}"));
                assert!(a != other, "{name} ignores the seed");
            }
        }
    }

    /// The grid's clipping order is the order of sorting every site by distance (ties by index),
    /// so the cells are those of that order bit for bit: on uniform sites, on sites crowded
    /// into a corner (most bins empty, rings far larger than a cell), and on sites with equal
    /// distances (a lattice).
    #[test]
    fn voronoi_cells_from_the_grid_are_those_of_sorting_every_site() {
        let cell_by_sorting = |sites: &[DVec3], i: usize| {
            let mut cell = Polyhedron::cube(1.0);
            let mut others: Vec<(f64, usize)> = (0..sites.len())
                .filter(|&j| j != i)
                .map(|j| (sites[j].distance_squared(sites[i]), j))
                .collect();
            others.sort_by(|a, b| a.0.total_cmp(&b.0));
            for (d2, j) in others {
                if d2 > 4.0 * cell.max_distance_sq(sites[i]) {
                    break;
                }
                let n = sites[j] - sites[i];
                cell.clip(n, n.dot(0.5 * (sites[i] + sites[j])));
            }
            cell.faces
        };
        let mut rng = SplitMix64::new(41);
        let mut layouts: Vec<Vec<DVec3>> = Vec::new();
        for count in [1, 2, 9, 70, 400] {
            let uniform = (0..count)
                .map(|_| {
                    DVec3::new(
                        rng.range(-1.0, 1.0),
                        rng.range(-1.0, 1.0),
                        rng.range(-1.0, 1.0),
                    )
                })
                .collect();
            let crowded = (0..count)
                .map(|_| {
                    DVec3::new(
                        rng.range(0.7, 1.0),
                        rng.range(-1.0, -0.8),
                        rng.range(-1.0, 1.0),
                    )
                })
                .collect();
            layouts.push(uniform);
            layouts.push(crowded);
        }
        let lattice = (0..216)
            .map(|k| DVec3::new((k % 6) as f64, ((k / 6) % 6) as f64, (k / 36) as f64) / 3.0 - 0.8)
            .collect();
        layouts.push(lattice);
        let mut scratch = Vec::new();
        for sites in &layouts {
            let grid = SiteGrid::new(sites, 1.0);
            for i in 0..sites.len() {
                let mut cell = Polyhedron::cube(1.0);
                grid.clip_to_voronoi_cell(sites, i, &mut cell, &mut scratch);
                assert!(
                    cell.faces == cell_by_sorting(sites, i),
                    "site {i} of {}",
                    sites.len()
                );
            }
        }
    }

    /// Foams keep the struts' share of the box (their relative density, `Σ πr²L` over the box's
    /// volume) as the cells shrink: denser foams have thinner struts, not struts whose supports
    /// fill the cells (fixed struts would make the foam of 9 000 cells 9^(2/3) ≈ 4.3 times as
    /// dense). The share is not exactly constant: edges on the box's faces are left out, and
    /// more of a small foam's cells meet the box. Up to 1 000 cells the radius is the fixed 0.022.
    #[test]
    fn denser_foams_keep_their_relative_density() {
        let density = |cells: usize, seed: u64| {
            let scene = generate(
                GeneratorKind::Foam,
                &GenerateOptions {
                    seed,
                    size: Some(cells),
                    ..GenerateOptions::default()
                },
            )
            .unwrap_or_else(|e| panic!("{e}"));
            let skeleton = &scene.groups[0].skeletons[0];
            let strut_volume: f64 = skeleton
                .edges
                .iter()
                .map(|&[a, b]| {
                    let (va, vb) = (
                        &skeleton.vertices[a as usize],
                        &skeleton.vertices[b as usize],
                    );
                    let r = 0.5 * (va.radius + vb.radius);
                    std::f64::consts::PI * r * r * distance(va.position, vb.position)
                })
                .sum();
            strut_volume / 8.0
        };
        let at_reference = density(1000, 4);
        for (cells, seed) in [(3000, 5), (9000, 6)] {
            let ratio = density(cells, seed) / at_reference;
            assert!(
                (0.85..1.2).contains(&ratio),
                "{cells} cells: {ratio} of 1 000 cells' density"
            );
        }
        // Below the reference size, the radius is the fixed one.
        let small = density(300, 4) / at_reference;
        assert!(small < 0.8, "300 cells: {small}");
    }

    #[test]
    fn foam_edges_form_a_connected_lattice_of_voronoi_vertices() {
        let s = generate(
            GeneratorKind::Foam,
            &GenerateOptions {
                seed: 3,
                size: Some(20),
                ..GenerateOptions::default()
            },
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let skeleton = &s.groups[0].skeletons[0];
        let mut degree = vec![0; skeleton.vertices.len()];
        for &[a, b] in &skeleton.edges {
            degree[a as usize] += 1;
            degree[b as usize] += 1;
        }
        // Interior Voronoi vertices join exactly three edges... in 3D, four cells meet at a
        // vertex and four edges: most vertices must have degree 4.
        let interior = degree.iter().filter(|&&d| d == 4).count();
        assert!(
            interior * 2 > degree.len(),
            "{interior} of {} vertices have degree 4",
            degree.len()
        );
        assert!(degree.iter().all(|&d| d >= 1));
    }

    /// Every generator's estimate bounds what it builds, on sizes and seeds it was not tuned on,
    /// and sizes past the limit are refused before anything is built.
    #[test]
    fn estimates_bound_the_built_scenes_and_the_limit_refuses_early() {
        let mut rng = SplitMix64::new(99);
        for &(kind, name) in &GeneratorKind::ALL {
            for _ in 0..4 {
                let size = match kind {
                    GeneratorKind::Tree => 2 + rng.below(7),
                    GeneratorKind::Truss => 1 + rng.below(5),
                    GeneratorKind::Foam => 2 + rng.below(60),
                    _ => 1 + rng.below(400),
                };
                let options = GenerateOptions {
                    seed: rng.below(1000) as u64,
                    size: Some(size),
                    ..GenerateOptions::default()
                };
                let scene = generate(kind, &options).unwrap_or_else(|e| panic!("{e}"));
                let c = scene.counts();
                let built = (c.segments + c.blobs) as u64;
                let estimate = estimated_primitives(kind, &options);
                assert!(
                    built <= estimate,
                    "{name} size {size}: {built} > {estimate}"
                );
            }
        }
        // A tree of depth 40 (the out-of-memory case) is refused in one line.
        let deep = GenerateOptions {
            size: Some(40),
            ..GenerateOptions::default()
        };
        let err = generate(GeneratorKind::Tree, &deep)
            .err()
            .unwrap_or_default();
        assert!(
            err.contains("tree of size 40")
                && err.contains("1000000")
                && err.contains("--allow-large"),
            "{err}"
        );
        assert!(!err.contains('\n'));
        for (kind, size) in [
            (GeneratorKind::Truss, 100),
            (GeneratorKind::Foam, 100_000),
            (GeneratorKind::Molecule, 2_000_000),
        ] {
            let options = GenerateOptions {
                size: Some(size),
                ..GenerateOptions::default()
            };
            assert!(generate(kind, &options).is_err(), "{kind:?} {size}");
        }
        // The explicit option lifts the limit (checked on a size that is quick to build).
        let over = GenerateOptions {
            size: Some(1_000_001),
            allow_large: true,
            ..GenerateOptions::default()
        };
        assert!(estimated_primitives(GeneratorKind::RandomSkeleton, &over) > MAX_PRIMITIVES);
        assert!(
            generate(
                GeneratorKind::RandomSkeleton,
                &GenerateOptions {
                    allow_large: false,
                    ..over
                }
            )
            .is_err()
        );
    }
}
