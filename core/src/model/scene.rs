//! The scene model and its RON file format.
//!
//! A scene holds material *groups*; each group has one kernel and one material and sums its
//! primitives: skeletons (vertices with radii joined by edges, each skeleton a distance or a
//! SCALIS field, scalis 2021 eq. 7–8), point blobs and distance-based shapes. A blend tree
//! (sum, max, min, difference, Ricci p-blend) combines the groups. Camera and lights are stored
//! with the scene.
//!
//! Loading validates everything. Value constraints (finite numbers, positive radii, kernel
//! parameters) are checked while parsing, so the error carries the exact line and column of the
//! offending value; constraints between values (edge indices, segment lengths, the SCALIS slope
//! limit, blend references) are checked when the enclosing item is complete and point at its
//! end. [`Scene::validate`] checks the same rules (one [`Rule`] per kind of value) on a scene in
//! memory, as the editor does after every edit. Saving goes through [`crate::output`]: atomic,
//! and never over a symlink, a device or another file's permissions.

use std::fmt::Write as _;
use std::path::Path;

use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize};

use crate::model::kernel::Kernel;

/// Most primitives a generator builds unless asked for more, and most that the repetitions of
/// a scene file may expand it to: at about 400 bytes each (scene and compiled scene), 400 MB.
pub const MAX_PRIMITIVES: u64 = 1_000_000;

/// Version written by this build; files of other versions are refused with a clear message.
pub const SCENE_VERSION: u32 = 1;

/// A 3-vector as stored in files: `(x, y, z)`.
pub type Vec3 = [f64; 3];

/// Errors of loading and saving scenes; every message names the file.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{file}: cannot read the scene: {source}")]
    Read {
        /// File name.
        file: String,
        /// Cause.
        source: std::io::Error,
    },
    /// The text is not a valid scene.
    #[error("{file}:{line}:{column}: {message}")]
    Invalid {
        /// File name.
        file: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong, naming the item and the value.
        message: String,
    },
    /// The file could not be written.
    #[error("{file}: cannot save the scene: {source}")]
    Write {
        /// File name.
        file: String,
        /// Cause.
        source: std::io::Error,
    },
}

/// A complete scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// File format version ([`SCENE_VERSION`]).
    #[serde(deserialize_with = "de_version")]
    pub version: u32,
    /// Isovalue `c`: inside where `f ≥ c`.
    #[serde(default = "default_isovalue", deserialize_with = "de_positive")]
    pub isovalue: f64,
    /// Material groups; each sums its primitives.
    pub groups: Vec<Group>,
    /// How groups combine; `None` sums all groups.
    #[serde(default)]
    pub blend: Option<Blend>,
    /// Viewpoint.
    #[serde(default)]
    pub camera: Camera,
    /// Lights.
    #[serde(default = "default_lights")]
    pub lights: Vec<Light>,
}

/// A group of primitives sharing a kernel and a material, blended by summation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "GroupFile")]
pub struct Group {
    /// Display name.
    pub name: String,
    /// Kernel of every primitive of the group.
    pub kernel: Kernel,
    /// Surface material.
    pub material: Material,
    /// Skeletons.
    pub skeletons: Vec<Skeleton>,
    /// Point blobs.
    pub blobs: Vec<Blob>,
    /// Distance-based primitives.
    pub shapes: Vec<Shape>,
    /// Hermite radial basis function sets.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub hrbfs: Vec<Hrbf>,
    /// Similarity applied to the whole group after repetition.
    #[serde(default, skip_serializing_if = "Transform::is_identity")]
    pub transform: Transform,
    /// Copies of the group on a grid, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub repeat: Option<Repeat>,
}

/// A Hermite radial basis function set (forward inclusion 2023 eq. 9, `φ(r) = r³`): the surface
/// passes through every point with the given outward normal. Its weights are solved when the
/// scene is read and again whenever it is compiled, so they never go stale after an edit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Hrbf {
    /// Points with normals.
    pub points: Vec<HrbfPoint>,
}

/// A point of an HRBF set.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HrbfPoint {
    /// Position on the surface.
    #[serde(deserialize_with = "de_finite3")]
    pub position: Vec3,
    /// Outward normal there (normalised on use).
    #[serde(deserialize_with = "de_direction")]
    pub normal: Vec3,
}

/// Most points one HRBF set may have (the solve is a dense `4N + 4` system).
pub const MAX_HRBF_POINTS: usize = 400;

/// Similarity on a group (numerical ray tracing notes 2014 §11.5): uniform scale, then rotation
/// (XYZ Euler angles in degrees), then translation. A density field of radius-scaled primitives
/// is invariant under a similarity, so it is applied to the primitives when a scene is compiled
/// (no `det M` factor as for distance estimators).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[serde(default)]
pub struct Transform {
    /// Translation.
    #[serde(deserialize_with = "de_finite3")]
    pub translate: Vec3,
    /// Rotation as XYZ Euler angles in degrees.
    #[serde(deserialize_with = "de_finite3")]
    pub rotate: Vec3,
    /// Uniform scale (> 0).
    #[serde(deserialize_with = "de_positive")]
    pub scale: f64,
}

impl Default for Transform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Transform {
    /// No change.
    pub const IDENTITY: Self = Self {
        translate: [0.0; 3],
        rotate: [0.0; 3],
        scale: 1.0,
    };

    /// Whether this is the identity.
    #[must_use]
    pub fn is_identity(&self) -> bool {
        *self == Self::IDENTITY
    }
}

/// Most copies one [`Repeat`] may make.
pub const MAX_REPEAT_COPIES: u64 = 100_000;

/// Copies of a group on a `count[0] × count[1] × count[2]` grid with `spacing` between
/// neighbours, in the group's own frame (before its transform). The notes' repetition (2014
/// §11.4) tiles space with `X mod v`; a modelling tool wants a finite array, and finite copies
/// keep every support bounded, so each copy is a set of primitives of its own.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Repeat {
    /// Copies along x, y and z (each ≥ 1).
    pub count: [u32; 3],
    /// Offset between neighbouring copies.
    #[serde(deserialize_with = "de_finite3")]
    pub spacing: Vec3,
}

impl Repeat {
    /// Offsets of every copy, the first at the origin.
    #[must_use]
    pub fn offsets(&self) -> Vec<Vec3> {
        let [nx, ny, nz] = self.count;
        let mut out = Vec::with_capacity((nx * ny * nz) as usize);
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    out.push([
                        f64::from(i) * self.spacing[0],
                        f64::from(j) * self.spacing[1],
                        f64::from(k) * self.spacing[2],
                    ]);
                }
            }
        }
        out
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "Group")]
struct GroupFile {
    #[serde(default)]
    name: String,
    #[serde(default)]
    kernel: Kernel,
    #[serde(default)]
    material: Material,
    #[serde(default)]
    skeletons: Vec<Skeleton>,
    #[serde(default)]
    blobs: Vec<Blob>,
    #[serde(default)]
    shapes: Vec<Shape>,
    #[serde(default)]
    hrbfs: Vec<Hrbf>,
    #[serde(default)]
    transform: Transform,
    #[serde(default)]
    repeat: Option<Repeat>,
}

impl TryFrom<GroupFile> for Group {
    type Error = String;

    fn try_from(g: GroupFile) -> Result<Self, String> {
        let group = Self {
            name: g.name,
            kernel: g.kernel,
            material: g.material,
            skeletons: g.skeletons,
            blobs: g.blobs,
            shapes: g.shapes,
            hrbfs: g.hrbfs,
            transform: g.transform,
            repeat: g.repeat,
        };
        group.check_items()?;
        Ok(group)
    }
}

impl Group {
    /// Constraints between a group's items: the SCALIS radius slope, rounding against half
    /// extents, HRBF sets alone in their group and solvable, repetition counts.
    fn check_items(&self) -> Result<(), String> {
        let support = self.kernel.support_sq().sqrt();
        for (si, skeleton) in self.skeletons.iter().enumerate() {
            for (ei, &[a, b]) in skeleton.edges.iter().enumerate() {
                let (va, vb) = (
                    &skeleton.vertices[a as usize],
                    &skeleton.vertices[b as usize],
                );
                let length = distance(va.position, vb.position);
                let slope = (va.radius - vb.radius).abs() / length;
                if slope * support >= 1.0 {
                    return Err(format!(
                        "group '{}', skeleton {si} '{}', edge {ei} ({a}, {b}): radius slope \
                         |Δτ|/L = {slope:.4} must be below 1/σ = {:.4} for this kernel (the \
                         support would not be a sphere-cone)",
                        self.name,
                        skeleton.name,
                        1.0 / support
                    ));
                }
            }
        }
        for (i, shape) in self.shapes.iter().enumerate() {
            if let Shape::RoundedBox {
                half_extents,
                rounding,
                ..
            } = shape
            {
                let smallest = half_extents.iter().copied().fold(f64::INFINITY, f64::min);
                if *rounding > smallest {
                    return Err(format!(
                        "group '{}', shape {i}: rounding {rounding} exceeds the smallest half \
                         extent {smallest}",
                        self.name
                    ));
                }
            }
        }
        if !self.hrbfs.is_empty()
            && (!self.skeletons.is_empty() || !self.blobs.is_empty() || !self.shapes.is_empty())
        {
            return Err(format!(
                "group '{}': a group with HRBF sets holds nothing else (its field is the sets' \
                 clamped density); move the skeletons, blobs and shapes to another group",
                self.name
            ));
        }
        for (i, set) in self.hrbfs.iter().enumerate() {
            if set.points.len() > MAX_HRBF_POINTS {
                return Err(format!(
                    "group '{}', HRBF set {i}: {} points, at most {MAX_HRBF_POINTS} are allowed",
                    self.name,
                    set.points.len()
                ));
            }
            check_hrbf_points(&set.points)
                .map_err(|e| format!("group '{}', HRBF set {i}: {e}", self.name))?;
        }
        if let Some(repeat) = &self.repeat {
            let copies: u64 = repeat.count.iter().map(|&n| u64::from(n)).product();
            if repeat.count.contains(&0) || copies > MAX_REPEAT_COPIES {
                return Err(format!(
                    "group '{}', repeat: count ({}, {}, {}) must be at least 1 along each axis \
                     and make at most {MAX_REPEAT_COPIES} copies",
                    self.name, repeat.count[0], repeat.count[1], repeat.count[2]
                ));
            }
        }
        Ok(())
    }
}

/// How a skeleton turns into a field.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum SkeletonField {
    /// Kernel of the homothetic distance to each segment (scalis eq. 7).
    Distance,
    /// SCALIS integral along each segment (scalis eq. 8).
    #[default]
    Scalis,
}

/// Vertices with radii joined by segments.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "SkeletonFile")]
pub struct Skeleton {
    /// Display name.
    pub name: String,
    /// Field type of every segment.
    pub field: SkeletonField,
    /// Add end-point correctors at free ends (SCALIS only; scalis §1.1).
    pub end_correctors: bool,
    /// Vertices.
    pub vertices: Vec<Vertex>,
    /// Segments as pairs of vertex indices.
    pub edges: Vec<[u32; 2]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "Skeleton")]
struct SkeletonFile {
    #[serde(default)]
    name: String,
    #[serde(default)]
    field: SkeletonField,
    #[serde(default)]
    end_correctors: bool,
    vertices: Vec<Vertex>,
    #[serde(default)]
    edges: Vec<[u32; 2]>,
}

impl TryFrom<SkeletonFile> for Skeleton {
    type Error = String;

    fn try_from(s: SkeletonFile) -> Result<Self, String> {
        let skeleton = Self {
            name: s.name,
            field: s.field,
            end_correctors: s.end_correctors,
            vertices: s.vertices,
            edges: s.edges,
        };
        skeleton.check_edges()?;
        Ok(skeleton)
    }
}

impl Skeleton {
    /// Edge indices in range, no zero-length segment, no edge joining two vertices already
    /// joined (its segment would count twice in the field: the editor refuses it too).
    fn check_edges(&self) -> Result<(), String> {
        let n = self.vertices.len();
        let mut joined = std::collections::HashMap::with_capacity(self.edges.len());
        for (i, &[a, b]) in self.edges.iter().enumerate() {
            if let Some(first) = joined.insert((a.min(b), a.max(b)), i) {
                let [fa, fb] = self.edges[first];
                return Err(format!(
                    "skeleton '{}', edge {i} ({a}, {b}): repeats edge {first} ({fa}, {fb}): two \
                     segments between the same vertices count twice in the field",
                    self.name
                ));
            }
            for v in [a, b] {
                if v as usize >= n {
                    return Err(format!(
                        "skeleton '{}', edge {i} ({a}, {b}): vertex index {v} out of range \
                         (the skeleton has {n} vertices)",
                        self.name
                    ));
                }
            }
            let length = distance(
                self.vertices[a as usize].position,
                self.vertices[b as usize].position,
            );
            if length <= 1e-9 {
                return Err(format!(
                    "skeleton '{}', edge {i} ({a}, {b}): zero-length segment (length {length:e})",
                    self.name
                ));
            }
        }
        Ok(())
    }
}

/// A skeleton vertex.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Vertex {
    /// Position.
    #[serde(deserialize_with = "de_finite3")]
    pub position: Vec3,
    /// Prescribed radius `τ > 0`.
    #[serde(deserialize_with = "de_radius")]
    pub radius: f64,
}

/// A point blob.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Blob {
    /// Centre.
    #[serde(deserialize_with = "de_finite3")]
    pub center: Vec3,
    /// Prescribed radius `ρ > 0`.
    #[serde(deserialize_with = "de_radius")]
    pub radius: f64,
}

/// A distance-based primitive; `radius` is the distance from the solid to the surface.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Shape {
    /// Infinite plane `normal·p = offset`; the surface is a slab of half-width `radius`.
    Plane {
        /// Normal (normalised on use).
        #[serde(deserialize_with = "de_direction")]
        normal: Vec3,
        /// Offset along the normal.
        #[serde(deserialize_with = "de_finite")]
        offset: f64,
        /// Prescribed radius.
        #[serde(deserialize_with = "de_radius")]
        radius: f64,
    },
    /// Box.
    Box {
        /// Centre.
        #[serde(deserialize_with = "de_finite3")]
        center: Vec3,
        /// Half extents (> 0).
        #[serde(deserialize_with = "de_positive3")]
        half_extents: Vec3,
        /// Rotation as XYZ Euler angles in degrees.
        #[serde(default, deserialize_with = "de_finite3")]
        rotation: Vec3,
        /// Prescribed radius.
        #[serde(deserialize_with = "de_radius")]
        radius: f64,
    },
    /// Box with rounded edges.
    RoundedBox {
        /// Centre.
        #[serde(deserialize_with = "de_finite3")]
        center: Vec3,
        /// Half extents of the outer box (> 0).
        #[serde(deserialize_with = "de_positive3")]
        half_extents: Vec3,
        /// Rounding radius (≤ the smallest half extent).
        #[serde(deserialize_with = "de_positive")]
        rounding: f64,
        /// Rotation as XYZ Euler angles in degrees.
        #[serde(default, deserialize_with = "de_finite3")]
        rotation: Vec3,
        /// Prescribed radius.
        #[serde(deserialize_with = "de_radius")]
        radius: f64,
    },
    /// Solid torus.
    Torus {
        /// Centre.
        #[serde(deserialize_with = "de_finite3")]
        center: Vec3,
        /// Axis of symmetry.
        #[serde(deserialize_with = "de_direction")]
        axis: Vec3,
        /// Radius of the tube's centre line.
        #[serde(deserialize_with = "de_positive")]
        major: f64,
        /// Tube radius.
        #[serde(deserialize_with = "de_positive")]
        minor: f64,
        /// Prescribed radius.
        #[serde(deserialize_with = "de_radius")]
        radius: f64,
    },
    /// Capped solid cylinder.
    Cylinder {
        /// Centre.
        #[serde(deserialize_with = "de_finite3")]
        center: Vec3,
        /// Axis.
        #[serde(deserialize_with = "de_direction")]
        axis: Vec3,
        /// Radius of the solid cylinder.
        #[serde(deserialize_with = "de_positive")]
        cylinder_radius: f64,
        /// Half height.
        #[serde(deserialize_with = "de_positive")]
        half_height: f64,
        /// Prescribed radius.
        #[serde(deserialize_with = "de_radius")]
        radius: f64,
    },
}

/// Surface material of a group.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Base colour, linear RGB in `[0, 1]`.
    #[serde(deserialize_with = "de_color")]
    pub color: Vec3,
    /// Opacity in `[0, 1]`; below 1 the group is rendered transparent.
    #[serde(default = "one", deserialize_with = "de_unit")]
    pub opacity: f64,
    /// Index of refraction (≥ 1).
    #[serde(default = "default_ior", deserialize_with = "de_ior")]
    pub ior: f64,
}

impl Default for Material {
    fn default() -> Self {
        Self {
            color: [0.80, 0.55, 0.45],
            opacity: 1.0,
            ior: 1.5,
        }
    }
}

/// Blend tree over groups.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Blend {
    /// A group's field (index into `groups`).
    Group(u32),
    /// Sum (smooth union).
    Sum(Vec<Blend>),
    /// Maximum (sharp union).
    Max(Vec<Blend>),
    /// Minimum (intersection).
    Min(Vec<Blend>),
    /// First minus second: `min(f₁, 2c − f₂)`.
    Difference(Box<Blend>, Box<Blend>),
    /// Ricci p-blend `(Σ fᵢ^p)^(1/p)`, `p ≥ 1` (p = 1 is the sum, p → ∞ the max).
    Ricci {
        /// Exponent.
        #[serde(deserialize_with = "de_ricci")]
        p: f64,
        /// Operands.
        of: Vec<Blend>,
    },
    /// Smooth union: the polynomial smooth minimum of the 2014 notes (§11.6) turned into a
    /// smooth maximum for densities. Equal to `max` where the operands differ by more than
    /// `width` (in field units), at most `width/4` above it in between.
    SmoothUnion {
        /// Blend width in field units (> 0).
        #[serde(deserialize_with = "de_positive")]
        width: f64,
        /// Operands.
        of: Vec<Blend>,
    },
    /// Smooth intersection: the notes' polynomial smooth minimum, at most `width/4` below `min`.
    SmoothIntersection {
        /// Blend width in field units (> 0).
        #[serde(deserialize_with = "de_positive")]
        width: f64,
        /// Operands.
        of: Vec<Blend>,
    },
}

/// Pinhole camera.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Camera {
    /// Eye position.
    #[serde(deserialize_with = "de_finite3")]
    pub position: Vec3,
    /// Point looked at.
    #[serde(deserialize_with = "de_finite3")]
    pub target: Vec3,
    /// Up direction.
    #[serde(default = "default_up", deserialize_with = "de_direction")]
    pub up: Vec3,
    /// Vertical field of view in degrees, in `(0, 180)`.
    #[serde(default = "default_fov", deserialize_with = "de_fov")]
    pub fov_degrees: f64,
}

impl Default for Camera {
    fn default() -> Self {
        Self {
            position: [0.0, 0.0, 6.0],
            target: [0.0; 3],
            up: default_up(),
            fov_degrees: default_fov(),
        }
    }
}

/// A light source.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Light {
    /// Light from a direction (towards the light).
    Directional {
        /// Direction towards the light.
        #[serde(deserialize_with = "de_direction")]
        direction: Vec3,
        /// Colour in `[0, 1]`.
        #[serde(deserialize_with = "de_color")]
        color: Vec3,
        /// Intensity (≥ 0).
        #[serde(deserialize_with = "de_nonnegative")]
        intensity: f64,
    },
    /// Point light.
    Point {
        /// Position.
        #[serde(deserialize_with = "de_finite3")]
        position: Vec3,
        /// Colour in `[0, 1]`.
        #[serde(deserialize_with = "de_color")]
        color: Vec3,
        /// Intensity (≥ 0).
        #[serde(deserialize_with = "de_nonnegative")]
        intensity: f64,
    },
}

fn default_isovalue() -> f64 {
    1.0
}
fn one() -> f64 {
    1.0
}
fn default_ior() -> f64 {
    1.5
}
fn default_up() -> Vec3 {
    [0.0, 1.0, 0.0]
}
fn default_fov() -> f64 {
    40.0
}
fn default_lights() -> Vec<Light> {
    Scene::default_lights()
}

fn distance(a: Vec3, b: Vec3) -> f64 {
    let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

/// A constraint on one number of a scene: the parser (`de_*`, which knows the value's line and
/// column) and [`Scene::validate`] (which the editor calls after every edit) both check values
/// through these, so the two can never disagree.
#[derive(Clone, Copy)]
struct Rule {
    ok: fn(f64) -> bool,
    what: &'static str,
}

/// Largest magnitude of a coordinate, length or other scene number. Past it the compiled
/// scene's sums of squares and support boxes leave the range where `f64` (and the GPU's `f32`)
/// keep a modelling scene's detail, and at 10³⁰⁸ they overflow: one clear error instead.
const MAX_MAGNITUDE: f64 = 1e6;
/// Smallest radius or other positive length: below it inverses and squares of radii overflow
/// or underflow (a radius of 10⁻³²⁰ has no finite inverse).
const MIN_LENGTH: f64 = 1e-6;

fn is_coordinate(v: f64) -> bool {
    v.is_finite() && v.abs() <= MAX_MAGNITUDE
}

fn is_length(v: f64) -> bool {
    (MIN_LENGTH..=MAX_MAGNITUDE).contains(&v)
}

const FINITE: Rule = Rule {
    ok: is_coordinate,
    what: "expected a finite number within ±1e6",
};
const FINITE3: Rule = Rule {
    ok: is_coordinate,
    what: "expected three finite numbers within ±1e6",
};
const POSITIVE: Rule = Rule {
    ok: is_length,
    what: "expected a number between 1e-6 and 1e6",
};
const POSITIVE3: Rule = Rule {
    ok: is_length,
    what: "expected three numbers between 1e-6 and 1e6",
};
const NONNEGATIVE: Rule = Rule {
    ok: |v| (0.0..=MAX_MAGNITUDE).contains(&v),
    what: "expected a number between 0 and 1e6",
};
const RADIUS: Rule = Rule {
    ok: is_length,
    what: "radius must be between 1e-6 and 1e6",
};
const UNIT: Rule = Rule {
    ok: |v| (0.0..=1.0).contains(&v),
    what: "expected a number in [0, 1]",
};
const IOR: Rule = Rule {
    ok: |v| v.is_finite() && v >= 1.0,
    what: "index of refraction must be finite and ≥ 1",
};
const RICCI: Rule = Rule {
    ok: |v| v.is_finite() && v >= 1.0,
    what: "Ricci exponent p must be finite and ≥ 1",
};
const FOV: Rule = Rule {
    ok: |v| v > 0.0 && v < 180.0,
    what: "field of view must be in (0, 180) degrees",
};
const COLOR: Rule = Rule {
    ok: |v| (0.0..=1.0).contains(&v),
    what: "colour components must be in [0, 1]",
};

impl Rule {
    fn check(self, v: f64) -> Result<(), String> {
        if (self.ok)(v) {
            Ok(())
        } else {
            Err(format!("{}, got {}", self.what, shown(v)))
        }
    }

    fn check3(self, v: Vec3) -> Result<(), String> {
        if v.iter().all(|&x| (self.ok)(x)) {
            Ok(())
        } else {
            Err(format!(
                "{}, got ({}, {}, {})",
                self.what,
                shown(v[0]),
                shown(v[1]),
                shown(v[2])
            ))
        }
    }
}

/// A number as an error message shows it: as written for everyday magnitudes, in scientific
/// notation for huge and tiny ones (`1e308`, not its 309 digits).
fn shown(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-5..1e7).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// An HRBF set's points are solvable: at least one, no two at the same place (the cubic
/// Hermite system is then non-singular; it is solved when the scene is compiled,
/// `field::hrbf_solve`).
fn check_hrbf_points(points: &[HrbfPoint]) -> Result<(), String> {
    if points.is_empty() {
        return Err("an HRBF set needs at least one point".to_owned());
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p.position[k]);
            hi[k] = hi[k].max(p.position[k]);
        }
    }
    let tolerance = 1e-9 * distance(lo, hi).max(1.0);
    for (a, pa) in points.iter().enumerate() {
        for (b, pb) in points.iter().enumerate().skip(a + 1) {
            if distance(pa.position, pb.position) <= tolerance {
                let [x, y, z] = pa.position;
                return Err(format!(
                    "points {a} and {b} coincide at ({x}, {y}, {z}): the interpolation system \
                     would be singular"
                ));
            }
        }
    }
    Ok(())
}

/// A direction: three finite numbers whose length normalises them to unit length in `f64`
/// (within [`DIRECTION_TOLERANCE`]). `(0, 0, 0)`, and lengths so small that their square
/// underflows (`(0, 1e-300, 0)`), are refused instead of turning into NaN.
fn check_direction(v: Vec3) -> Result<(), String> {
    FINITE3.check3(v)?;
    let length = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let unit = v.map(|x| x / length);
    let unit_length = unit.iter().map(|x| x * x).sum::<f64>().sqrt();
    if v.iter().all(|&x| x == 0.0) {
        Err("a direction must not be (0, 0, 0)".to_owned())
    } else if !length.is_normal() || (unit_length - 1.0).abs() > DIRECTION_TOLERANCE {
        Err(format!(
            "a direction must have a length that normalises it; ({}, {}, {}) is too short \
             (length {length:e})",
            v[0], v[1], v[2]
        ))
    } else {
        Ok(())
    }
}

/// How far from 1 a direction divided by its length may be.
pub const DIRECTION_TOLERANCE: f64 = 1e-9;

fn de_version<'de, D: Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    let v = u32::deserialize(d)?;
    check_version(v).map(|()| v).map_err(D::Error::custom)
}
fn check_version(v: u32) -> Result<(), String> {
    if v == SCENE_VERSION {
        Ok(())
    } else {
        Err(format!(
            "scene version {v} is not supported: this build reads version {SCENE_VERSION}"
        ))
    }
}
fn de_rule<'de, D: Deserializer<'de>>(d: D, rule: Rule) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    rule.check(v).map(|()| v).map_err(D::Error::custom)
}
fn de_rule3<'de, D: Deserializer<'de>>(d: D, rule: Rule) -> Result<Vec3, D::Error> {
    let v = Vec3::deserialize(d)?;
    rule.check3(v).map(|()| v).map_err(D::Error::custom)
}
fn de_finite<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    de_rule(d, FINITE)
}
fn de_positive<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    de_rule(d, POSITIVE)
}
fn de_nonnegative<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    de_rule(d, NONNEGATIVE)
}
fn de_radius<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    de_rule(d, RADIUS)
}
fn de_unit<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    de_rule(d, UNIT)
}
fn de_ior<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    de_rule(d, IOR)
}
fn de_ricci<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    de_rule(d, RICCI)
}
fn de_fov<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    de_rule(d, FOV)
}
fn de_finite3<'de, D: Deserializer<'de>>(d: D) -> Result<Vec3, D::Error> {
    de_rule3(d, FINITE3)
}
fn de_positive3<'de, D: Deserializer<'de>>(d: D) -> Result<Vec3, D::Error> {
    de_rule3(d, POSITIVE3)
}
fn de_color<'de, D: Deserializer<'de>>(d: D) -> Result<Vec3, D::Error> {
    de_rule3(d, COLOR)
}
fn de_direction<'de, D: Deserializer<'de>>(d: D) -> Result<Vec3, D::Error> {
    let v = Vec3::deserialize(d)?;
    check_direction(v).map(|()| v).map_err(D::Error::custom)
}

/// Prefixes an error with the item it is about.
fn at(item: &str, result: Result<(), String>) -> Result<(), String> {
    result.map_err(|e| format!("{item}: {e}"))
}

impl Shape {
    /// Every number of the shape within its rule.
    fn check_values(&self) -> Result<(), String> {
        match *self {
            Self::Plane {
                normal,
                offset,
                radius,
            } => {
                at("normal", check_direction(normal))?;
                at("offset", FINITE.check(offset))?;
                at("radius", RADIUS.check(radius))
            }
            Self::Box {
                center,
                half_extents,
                rotation,
                radius,
            } => {
                at("center", FINITE3.check3(center))?;
                at("half_extents", POSITIVE3.check3(half_extents))?;
                at("rotation", FINITE3.check3(rotation))?;
                at("radius", RADIUS.check(radius))
            }
            Self::RoundedBox {
                center,
                half_extents,
                rounding,
                rotation,
                radius,
            } => {
                at("center", FINITE3.check3(center))?;
                at("half_extents", POSITIVE3.check3(half_extents))?;
                at("rounding", POSITIVE.check(rounding))?;
                at("rotation", FINITE3.check3(rotation))?;
                at("radius", RADIUS.check(radius))
            }
            Self::Torus {
                center,
                axis,
                major,
                minor,
                radius,
            } => {
                at("center", FINITE3.check3(center))?;
                at("axis", check_direction(axis))?;
                at("major", POSITIVE.check(major))?;
                at("minor", POSITIVE.check(minor))?;
                at("radius", RADIUS.check(radius))
            }
            Self::Cylinder {
                center,
                axis,
                cylinder_radius,
                half_height,
                radius,
            } => {
                at("center", FINITE3.check3(center))?;
                at("axis", check_direction(axis))?;
                at("cylinder_radius", POSITIVE.check(cylinder_radius))?;
                at("half_height", POSITIVE.check(half_height))?;
                at("radius", RADIUS.check(radius))
            }
        }
    }
}

impl Group {
    /// Every number of the group within its rule, then the constraints between items.
    fn validate(&self) -> Result<(), String> {
        at("kernel", self.kernel.validate())?;
        let m = &self.material;
        at("material color", COLOR.check3(m.color))?;
        at("material opacity", UNIT.check(m.opacity))?;
        at("material ior", IOR.check(m.ior))?;
        for (si, skeleton) in self.skeletons.iter().enumerate() {
            for (vi, v) in skeleton.vertices.iter().enumerate() {
                let item = format!("skeleton {si} '{}', vertex {vi}", skeleton.name);
                at(&format!("{item} position"), FINITE3.check3(v.position))?;
                at(&format!("{item} radius"), RADIUS.check(v.radius))?;
            }
            skeleton.check_edges()?;
        }
        for (bi, b) in self.blobs.iter().enumerate() {
            at(&format!("blob {bi} center"), FINITE3.check3(b.center))?;
            at(&format!("blob {bi} radius"), RADIUS.check(b.radius))?;
        }
        for (i, shape) in self.shapes.iter().enumerate() {
            at(&format!("shape {i}"), shape.check_values())?;
        }
        for (hi, set) in self.hrbfs.iter().enumerate() {
            for (pi, p) in set.points.iter().enumerate() {
                let item = format!("HRBF set {hi}, point {pi}");
                at(&format!("{item} position"), FINITE3.check3(p.position))?;
                at(&format!("{item} normal"), check_direction(p.normal))?;
            }
        }
        let t = &self.transform;
        at("transform translate", FINITE3.check3(t.translate))?;
        at("transform rotate", FINITE3.check3(t.rotate))?;
        at("transform scale", POSITIVE.check(t.scale))?;
        if let Some(repeat) = &self.repeat {
            at("repeat spacing", FINITE3.check3(repeat.spacing))?;
        }
        self.check_items()
    }
}

impl Scene {
    /// Parses and validates a scene; `file` names the source in error messages.
    ///
    /// # Errors
    /// [`SceneError::Invalid`] with the position, item and value of the first problem.
    pub fn from_ron(text: &str, file: &str) -> Result<Self, SceneError> {
        // A byte-order mark, as some editors on Windows write one, is not part of the text.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let scene: Self = ron::Options::default()
            .with_recursion_limit(RON_NESTING_LIMIT)
            .from_str(text)
            .map_err(|e| SceneError::Invalid {
                file: file.to_owned(),
                line: e.span.start.line,
                column: e.span.start.col,
                message: parse_error_message(&e.code),
            })?;
        scene.validate_blend().map_err(|message| {
            let (line, column) = position_of(text, "blend");
            SceneError::Invalid {
                file: file.to_owned(),
                line,
                column,
                message,
            }
        })?;
        // Values were checked where they were parsed, with their positions; this pass checks
        // the same rules once more on the whole scene, as the editor does after every edit.
        scene.validate().map_err(|message| SceneError::Invalid {
            file: file.to_owned(),
            line: text.lines().count().max(1),
            column: 1,
            message,
        })?;
        Ok(scene)
    }

    /// Reads and validates a scene file.
    ///
    /// # Errors
    /// [`SceneError::Read`] when the file cannot be read, [`SceneError::Invalid`] otherwise.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
            file: file.clone(),
            source,
        })?;
        Self::from_ron(&text, &file)
    }

    /// The scene as RON text.
    #[must_use]
    pub fn to_ron(&self) -> String {
        let config = ron::ser::PrettyConfig::new()
            .depth_limit(6)
            .indentor("  ".to_owned())
            .separate_tuple_members(false);
        let mut text = ron::ser::to_string_pretty(self, config)
            .unwrap_or_else(|e| format!("// serialisation failed: {e}"));
        text.push('\n');
        text
    }

    /// Writes the scene atomically: a temporary file next to the target, flushed to disk, then
    /// renamed over it. A crash leaves either the old or the new file, never a partial one.
    ///
    /// # Errors
    /// [`SceneError::Write`] when the file cannot be written or renamed.
    pub fn save(&self, path: &Path) -> Result<(), SceneError> {
        self.save_with_comment(path, "")
    }

    /// Like [`Scene::save`], with `comment` written first as `//` lines (what the file shows,
    /// how it was made).
    ///
    /// # Errors
    /// [`SceneError::Write`] when the file cannot be written or renamed.
    pub fn save_with_comment(&self, path: &Path, comment: &str) -> Result<(), SceneError> {
        self.write_atomically(path, comment, |_| Ok(()))
    }

    /// The write of [`Scene::save_with_comment`] through [`crate::output`]; `before_rename`
    /// runs on the written, flushed temporary file just before the rename (the tests make it
    /// fail there).
    fn write_atomically(
        &self,
        path: &Path,
        comment: &str,
        before_rename: impl FnOnce(&Path) -> std::io::Result<()>,
    ) -> Result<(), SceneError> {
        let mut text = String::new();
        for line in comment.lines() {
            text.push_str("// ");
            text.push_str(line);
            text.push('\n');
        }
        text.push_str(&self.to_ron());
        crate::output::write_file_with(path, text.as_bytes(), &[], before_rename).map_err(|e| {
            SceneError::Write {
                file: path.display().to_string(),
                source: std::io::Error::other(e.reason),
            }
        })
    }

    /// Checks everything the file loader checks — every value within its rule, the constraints
    /// between items, the blend tree — on a scene in memory: the editor calls it after every
    /// edit, the loader after parsing.
    ///
    /// # Errors
    /// The item (group, skeleton, vertex, field) and the value that breaks a rule.
    pub fn validate(&self) -> Result<(), String> {
        at("version", check_version(self.version))?;
        at("isovalue", POSITIVE.check(self.isovalue))?;
        for (gi, group) in self.groups.iter().enumerate() {
            at(&format!("group {gi} '{}'", group.name), group.validate())?;
        }
        self.check_expansion()?;
        self.validate_blend()?;
        let c = &self.camera;
        at("camera position", FINITE3.check3(c.position))?;
        at("camera target", FINITE3.check3(c.target))?;
        at("camera up", check_direction(c.up))?;
        at("camera fov_degrees", FOV.check(c.fov_degrees))?;
        for (li, light) in self.lights.iter().enumerate() {
            let item = format!("light {li}");
            let (color, intensity) = match *light {
                Light::Directional {
                    direction,
                    color,
                    intensity,
                } => {
                    at(&format!("{item} direction"), check_direction(direction))?;
                    (color, intensity)
                }
                Light::Point {
                    position,
                    color,
                    intensity,
                } => {
                    at(&format!("{item} position"), FINITE3.check3(position))?;
                    (color, intensity)
                }
            };
            at(&format!("{item} color"), COLOR.check3(color))?;
            at(&format!("{item} intensity"), NONNEGATIVE.check(intensity))?;
        }
        Ok(())
    }

    /// Repetitions multiply primitives without making the file any longer: a scene whose
    /// repetitions expand it past [`MAX_PRIMITIVES`] is refused before anything is compiled.
    fn check_expansion(&self) -> Result<(), String> {
        if self.groups.iter().all(|g| g.repeat.is_none()) {
            return Ok(());
        }
        let mut total: u64 = 0;
        for g in &self.groups {
            let items = g.skeletons.iter().map(|s| s.edges.len()).sum::<usize>()
                + g.blobs.len()
                + g.shapes.len()
                + g.hrbfs.iter().map(|h| h.points.len() + 1).sum::<usize>();
            let copies: u64 = g
                .repeat
                .map_or(1, |r| r.count.iter().map(|&n| u64::from(n)).product());
            total = total.saturating_add((items as u64).saturating_mul(copies));
        }
        if total > MAX_PRIMITIVES {
            return Err(format!(
                "the groups' repetitions expand the scene to {total} primitives, over the limit \
                 of {MAX_PRIMITIVES}; lower the repeat counts"
            ));
        }
        Ok(())
    }

    /// Checks the blend tree: group indices in range, operators with operands and valid
    /// parameters.
    fn validate_blend(&self) -> Result<(), String> {
        fn walk(b: &Blend, groups: usize, path: &mut String) -> Result<(), String> {
            let depth = path.matches('[').count();
            if depth > MAX_BLEND_DEPTH {
                return Err(format!(
                    "blend {path}: {depth} operators nested; a blend tree nests at most \
                     {MAX_BLEND_DEPTH}"
                ));
            }
            match b {
                Blend::Group(i) => {
                    if *i as usize >= groups {
                        return Err(format!(
                            "blend {path}: Group({i}) does not exist (the scene has {groups} groups)"
                        ));
                    }
                }
                Blend::Ricci { p, .. } if !(RICCI.ok)(*p) => {
                    return Err(format!("blend {path}: {}, got {p}", RICCI.what));
                }
                Blend::SmoothUnion { width, .. } | Blend::SmoothIntersection { width, .. }
                    if !(POSITIVE.ok)(*width) =>
                {
                    return Err(format!(
                        "blend {path}: width: {}, got {width}",
                        POSITIVE.what
                    ));
                }
                Blend::Sum(v)
                | Blend::Max(v)
                | Blend::Min(v)
                | Blend::Ricci { of: v, .. }
                | Blend::SmoothUnion { of: v, .. }
                | Blend::SmoothIntersection { of: v, .. } => {
                    if v.is_empty() {
                        return Err(format!(
                            "blend {path}: an operator needs at least one operand"
                        ));
                    }
                    for (i, c) in v.iter().enumerate() {
                        let len = path.len();
                        let _ = write!(path, "[{i}]");
                        walk(c, groups, path)?;
                        path.truncate(len);
                    }
                }
                Blend::Difference(a, b) => {
                    for (i, c) in [a, b].into_iter().enumerate() {
                        let len = path.len();
                        let _ = write!(path, "[{i}]");
                        walk(c, groups, path)?;
                        path.truncate(len);
                    }
                }
            }
            Ok(())
        }
        if self.groups.is_empty() {
            return Err("the scene has no groups".to_owned());
        }
        match &self.blend {
            Some(b) => walk(b, self.groups.len(), &mut "root".to_owned()),
            None => Ok(()),
        }
    }

    /// A key light and a dimmer, cooler fill light.
    #[must_use]
    pub fn default_lights() -> Vec<Light> {
        vec![
            Light::Directional {
                direction: [0.5, 0.8, 0.6],
                color: [1.0, 1.0, 1.0],
                intensity: 1.0,
            },
            Light::Directional {
                direction: [-0.6, 0.2, -0.4],
                color: [0.6, 0.7, 1.0],
                intensity: 0.35,
            },
        ]
    }

    /// Number of skeleton vertices, segments, blobs, shapes and HRBF points.
    #[must_use]
    pub fn counts(&self) -> SceneCounts {
        let mut c = SceneCounts {
            groups: self.groups.len(),
            ..SceneCounts::default()
        };
        for g in &self.groups {
            c.skeletons += g.skeletons.len();
            c.vertices += g.skeletons.iter().map(|s| s.vertices.len()).sum::<usize>();
            c.segments += g.skeletons.iter().map(|s| s.edges.len()).sum::<usize>();
            c.blobs += g.blobs.len();
            c.shapes += g.shapes.len();
            c.hrbf_points += g.hrbfs.iter().map(|h| h.points.len()).sum::<usize>();
        }
        c
    }
}

/// Item counts of a scene.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SceneCounts {
    /// Groups.
    pub groups: usize,
    /// Skeletons.
    pub skeletons: usize,
    /// Skeleton vertices.
    pub vertices: usize,
    /// Skeleton segments.
    pub segments: usize,
    /// Point blobs.
    pub blobs: usize,
    /// Distance-based shapes.
    pub shapes: usize,
    /// Points of all HRBF sets.
    pub hrbf_points: usize,
}

/// 1-based line and column of the first occurrence of `key` followed by `:`, or of the end
/// of the text.
fn position_of(text: &str, key: &str) -> (usize, usize) {
    for (i, line) in text.lines().enumerate() {
        if let Some(col) = line.find(key)
            && line[col + key.len()..].trim_start().starts_with(':')
        {
            return (i + 1, col + 1);
        }
    }
    (text.lines().count().max(1), 1)
}

/// Most operators nested in a blend tree (`docs/scene-format.md`): far deeper than a model
/// needs, and shallow enough for the recursive walks of the tree on every thread's stack.
pub const MAX_BLEND_DEPTH: usize = 64;

/// The parser's nesting limit: a blend tree of [`MAX_BLEND_DEPTH`] operators, each of which
/// takes up to six of the parser's levels (the variant, its fields, its operand list and the
/// operand's own variant), within the scene, so that the validation names the limit.
const RON_NESTING_LIMIT: usize = 6 * MAX_BLEND_DEPTH + 32;

/// A parse error in the project's words: an unknown field or variant names the nearest known
/// one, too deep a nesting names the limit.
fn parse_error_message(code: &ron::Error) -> String {
    let inside = |outer: &Option<String>| {
        outer
            .as_ref()
            .map_or_else(String::new, |o| format!(" in `{o}`"))
    };
    match code {
        ron::Error::NoSuchStructField {
            expected,
            found,
            outer,
        } => format!(
            "unknown field `{found}`{}{}",
            inside(outer),
            suggestion(found, expected)
        ),
        ron::Error::NoSuchEnumVariant {
            expected,
            found,
            outer,
        } => format!(
            "unknown variant `{found}`{}{}",
            inside(outer),
            suggestion(found, expected)
        ),
        ron::Error::DuplicateStructField { field, outer } => {
            format!("the field `{field}` is given twice{}", inside(outer))
        }
        ron::Error::ExceededRecursionLimit => {
            format!("nested too deeply: a blend tree nests at most {MAX_BLEND_DEPTH} operators")
        }
        other => other.to_string(),
    }
}

/// `; did you mean `X`?` for the known name nearest `found`, else the list of known names.
fn suggestion(found: &str, known: &[&str]) -> String {
    match super::names::nearest(found, known) {
        Some(k) => format!("; did you mean `{k}`?"),
        None if known.is_empty() => String::new(),
        None => format!("; expected one of {}", known.join(", ")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A save that fails between the write and the rename leaves the old file as it was, no
    /// temporary file behind, and says which file could not be written.
    #[test]
    fn a_save_failing_before_the_rename_keeps_the_old_file() {
        let dir = std::env::temp_dir().join(format!("skeletrace-save-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
        let path = dir.join("scene.ron");
        let mut scene = Scene {
            version: SCENE_VERSION,
            isovalue: 1.0,
            groups: vec![Group {
                name: "g".to_owned(),
                kernel: Kernel::default(),
                material: Material::default(),
                skeletons: Vec::new(),
                blobs: vec![Blob {
                    center: [0.0; 3],
                    radius: 1.0,
                }],
                shapes: Vec::new(),
                hrbfs: Vec::new(),
                transform: Transform::default(),
                repeat: None,
            }],
            blend: None,
            camera: Camera::default(),
            lights: Vec::new(),
        };
        scene.save(&path).unwrap_or_else(|e| panic!("{e}"));
        let old = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{e}"));
        scene.groups[0].blobs[0].radius = 2.0;
        let mut written = None;
        let err = scene
            .write_atomically(&path, "", |temp| {
                written = std::fs::read_to_string(temp).ok();
                Err(std::io::Error::other("injected failure before the rename"))
            })
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            written.is_some_and(|t| t.contains("radius: 2.0")),
            "the new text was written in full before the failure"
        );
        assert!(
            err.contains("scene.ron") && err.contains("injected"),
            "{err}"
        );
        assert_eq!(std::fs::read_to_string(&path).ok(), Some(old));
        let left: Vec<_> = std::fs::read_dir(&dir)
            .map(|d| d.filter_map(Result::ok).map(|e| e.file_name()).collect())
            .unwrap_or_default();
        assert_eq!(left.len(), 1, "temporary file left behind: {left:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
