//! Mesh export (DESIGN.md, "Command line": `export`): the isosurface `f = c` extracted by
//! marching tetrahedra on a grid over the field's support (`skeletrace_core::isosurface`: watertight,
//! 2-manifold and outward by construction, vertices on the surface), with the analytic
//! normal, and measured ([`MeshReport`]). Each triangle goes to the group whose field is
//! largest at its centre: one glTF mesh per
//! material group, with its base colour and, for a transparent group, `KHR_materials_transmission`
//! and `KHR_materials_ior`. Written with the gltf crate's JSON types, as `.glb` or as `.gltf`
//! with a sibling `.bin`, atomically.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use glam::DVec3;
use gltf::json;
use json::validation::Checked::Valid;
use json::validation::USize64;
use rayon::prelude::*;
use skeletrace_core::field::geometry::Ray;
use skeletrace_core::output::write_file;
use skeletrace_core::{FieldProgram, Scene};

use skeletrace_core::isosurface::{self, Grid, MeshReport, TetraMesh};

/// Grid cells along the longest side that [`extract`] accepts: coarser grids lose whole
/// primitives; past 1 024 the grid's samples (a billion) take minutes and gigabytes.
pub const RESOLUTIONS: std::ops::RangeInclusive<usize> = 8..=1024;

/// A triangle mesh of the isosurface, split by group.
#[derive(Debug)]
pub struct Extracted {
    /// World positions.
    pub positions: Vec<DVec3>,
    /// Unit outward normals: −∇f/|∇f|, or the area-weighted normal of the vertex's triangles
    /// where the gradient vanishes.
    pub normals: Vec<DVec3>,
    /// Triangles, counter-clockwise seen from outside, per group.
    pub triangles: Vec<Vec<[u32; 3]>>,
    /// What the mesh is, measured: closed, manifold, oriented, how far from the surface.
    pub report: MeshReport,
    /// Grid cell size.
    pub cell: f64,
    /// An unbounded primitive (a plane) was cut at the box of the bounded ones' supports
    /// (a cell beyond it) and closed there by a cap.
    pub cut_at_box: bool,
}

/// Extracts the isosurface of `scene` on a grid of `resolution` cells along the longest side
/// of the box of the bounded primitives' supports (a plane is cut at that box and capped).
/// `progress` gets the fraction of the field sampled so far.
///
/// # Errors
/// A field without bounded primitives cannot be meshed; a resolution outside [`RESOLUTIONS`].
pub fn extract(
    scene: &Scene,
    resolution: usize,
    progress: &(dyn Fn(f64) + Sync),
) -> Result<Extracted, String> {
    extract_cancellable(scene, resolution, progress, &AtomicBool::new(false))
}

/// [`extract`], stopped with an error once `cancel` is set.
///
/// # Errors
/// As [`extract`], and "cancelled".
pub fn extract_cancellable(
    scene: &Scene,
    resolution: usize,
    progress: &(dyn Fn(f64) + Sync),
    cancel: &AtomicBool,
) -> Result<Extracted, String> {
    let (program, grid) = grid_of(scene, resolution)?;
    let TetraMesh {
        positions,
        triangles,
        lost_features,
    } = isosurface::extract(
        &program,
        grid,
        program.has_unbounded_support(),
        progress,
        cancel,
    )
    .ok_or("cancelled")?;
    let mut normals: Vec<DVec3> = positions
        .par_iter()
        .map(|&p| -program.value_gradient(p).1.normalize_or_zero())
        .collect();
    repair_normals(&positions, &mut normals, &triangles);
    let report = MeshReport::of(
        &program,
        &positions,
        &triangles,
        grid,
        program.has_unbounded_support(),
        lost_features,
    );
    let triangles = split_by_group(&program, &positions, triangles);
    Ok(Extracted {
        positions,
        normals,
        triangles,
        report,
        cell: grid.cell,
        cut_at_box: program.has_unbounded_support(),
    })
}

/// The coarse resolution [`estimate`] extracts at.
const ESTIMATE_RESOLUTION: usize = 24;

/// What an export will take, stated before it starts.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Estimate {
    /// Grid points sampled.
    pub grid_points: u64,
    /// Triangles, roughly: a coarse extraction's, scaled with the area in cells.
    pub triangles: u64,
    /// Peak memory of the extraction in bytes, roughly: the samples, the edge map and the mesh.
    pub bytes: u64,
}

/// The [`Estimate`] of an export of `scene` at `resolution`: the grid's size exactly, the
/// triangles of an extraction at [`ESTIMATE_RESOLUTION`] cells times the square of the ratio of
/// the resolutions (a surface's triangles grow with its area in cells; parts thinner than the
/// coarse cell are missed, so it is low for them), and the bytes that makes.
///
/// # Errors
/// As [`extract`].
pub fn estimate(scene: &Scene, resolution: usize) -> Result<Estimate, String> {
    let (_, grid) = grid_of(scene, resolution)?;
    let grid_points = grid.dims.iter().map(|&n| n as u64).product::<u64>();
    let coarse = extract(scene, ESTIMATE_RESOLUTION.min(resolution), &|_| {})?;
    let ratio = resolution as f64 / ESTIMATE_RESOLUTION.min(resolution) as f64;
    let triangles = (coarse.report.triangles as f64 * ratio * ratio).round() as u64;
    // Per grid point its f64 sample; per vertex (about half the triangles) its position,
    // normal, edge-map entry and crossing; per triangle its indices, its outward vector while
    // it is built, and the edge counts of the report.
    let bytes = grid_points * 8 + triangles / 2 * (24 + 24 + 40 + 16) + triangles * (12 + 24 + 64);
    Ok(Estimate {
        grid_points,
        triangles,
        bytes,
    })
}

/// The field of `scene` and the grid of `resolution` cells along the longest side of its
/// bounded supports' box, with a padding cell on each side.
fn grid_of(scene: &Scene, resolution: usize) -> Result<(FieldProgram, Grid), String> {
    let program = FieldProgram::new(scene);
    let bounds = program.support_bounds();
    let (lo, hi) = (bounds.min, bounds.max);
    let extent = hi - lo;
    if extent.max_element().is_nan() || extent.max_element() <= 0.0 {
        return Err("the field has no bounded primitive: nothing to mesh".into());
    }
    if !RESOLUTIONS.contains(&resolution) {
        return Err(format!(
            "a resolution of {resolution} cells is outside {} to {}",
            RESOLUTIONS.start(),
            RESOLUTIONS.end()
        ));
    }
    let cell = extent.max_element() / resolution as f64;
    // One padding cell on each side, so the surface never touches the grid's border.
    let grid = Grid {
        origin: lo - DVec3::splat(cell),
        cell,
        dims: ((extent / cell).ceil() + DVec3::splat(3.0))
            .to_array()
            .map(|n| n as usize),
    };
    Ok((program, grid))
}

/// Gives every vertex a unit normal (glTF requires NORMAL to be unit length): where the
/// analytic gradient vanished or was not finite, the area-weighted normal of the vertex's
/// outward-facing triangles; where those cancel too, any unit vector.
fn repair_normals(positions: &[DVec3], normals: &mut [DVec3], triangles: &[[u32; 3]]) {
    let is_unit = |n: DVec3| n.is_finite() && (n.length() - 1.0).abs() < 1e-6;
    if normals.iter().all(|&n| is_unit(n)) {
        return;
    }
    let mut faces = vec![DVec3::ZERO; normals.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        // The cross product's length is twice the area: an area-weighted sum.
        let n = (b - a).cross(c - a);
        for &i in t {
            faces[i as usize] += n;
        }
    }
    for (n, face) in normals.iter_mut().zip(faces) {
        if !is_unit(*n) {
            *n = face.try_normalize().unwrap_or(DVec3::Z);
        }
    }
}

/// Assigns each triangle to the group whose field is largest at its centre.
fn split_by_group(
    program: &FieldProgram,
    positions: &[DVec3],
    triangles: Vec<[u32; 3]>,
) -> Vec<Vec<[u32; 3]>> {
    let mut groups = vec![Vec::new(); program.group_count().max(1)];
    for t in triangles {
        let centre =
            (positions[t[0] as usize] + positions[t[1] as usize] + positions[t[2] as usize]) / 3.0;
        let ray = Ray::new(centre, DVec3::X);
        let g = program
            .group_values_along_ray(&ray, 0.0)
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.0.total_cmp(&b.1.0))
            .map_or(0, |(g, _)| g);
        groups[g].push(t);
    }
    groups
}

/// Writes `mesh` in the format `path`'s extension names: `.glb` or `.gltf` ([`write_gltf`]),
/// `.stl`, `.obj` with its `.mtl`, `.ply` or `.3mf` (`crate::mesh_formats`).
///
/// # Errors
/// An unknown extension (the message lists the formats), an empty mesh, or a file that cannot
/// be written.
pub fn write_mesh(
    scene: &Scene,
    mesh: &Extracted,
    path: &Path,
    inputs: &[&Path],
) -> Result<(), String> {
    if crate::mesh_formats::write(scene, mesh, path, inputs)? {
        return Ok(());
    }
    write_gltf(scene, mesh, path, inputs)
}

/// Writes `mesh` to `path` (`.glb`, or `.gltf` with its buffer `NAME.ID.bin` beside it), one
/// mesh per group with its material; groups without triangles are left out. Never over one of
/// `inputs` (`skeletrace_core::output`). A `.gltf`'s buffer has a name of its own for each
/// write and is written before the `.gltf` that names it; the buffer of the `.gltf` it replaced
/// is removed after, so that a `.gltf` never names a buffer it does not describe.
///
/// # Errors
/// An unknown extension, or a file that cannot be written (named in the message).
pub fn write_gltf(
    scene: &Scene,
    mesh: &Extracted,
    path: &Path,
    inputs: &[&Path],
) -> Result<(), String> {
    let binary = match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("glb") => true,
        Some(e) if e.eq_ignore_ascii_case("gltf") => false,
        _ => {
            return Err(format!(
                "{}: the output must end in .glb, .gltf, .stl, .obj, .ply or .3mf",
                path.display()
            ));
        }
    };
    let bin_name = buffer_name(path);
    let mut root = json::Root {
        asset: json::Asset {
            generator: Some(format!("skeletrace {}", env!("CARGO_PKG_VERSION"))),
            ..Default::default()
        },
        ..Default::default()
    };
    let mut bytes: Vec<u8> = Vec::new();
    let mut nodes = Vec::new();
    let mut transparent = false;
    for (g, triangles) in mesh.triangles.iter().enumerate() {
        if triangles.is_empty() {
            continue;
        }
        // This group's vertices, renumbered.
        let mut local: BTreeMap<u32, u32> = BTreeMap::new();
        for &i in triangles.iter().flatten() {
            let next = local.len() as u32;
            local.entry(i).or_insert(next);
        }
        let mut order = vec![0u32; local.len()];
        for (&global, &l) in &local {
            order[l as usize] = global;
        }
        let positions: Vec<[f32; 3]> = order
            .iter()
            .map(|&i| mesh.positions[i as usize].as_vec3().to_array())
            .collect();
        let normals: Vec<[f32; 3]> = order
            .iter()
            .map(|&i| mesh.normals[i as usize].as_vec3().to_array())
            .collect();
        let indices: Vec<u32> = triangles.iter().flatten().map(|i| local[i]).collect();
        let (min, max) = positions.iter().fold(
            ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
            |(lo, hi), p| {
                (
                    [lo[0].min(p[0]), lo[1].min(p[1]), lo[2].min(p[2])],
                    [hi[0].max(p[0]), hi[1].max(p[1]), hi[2].max(p[2])],
                )
            },
        );
        let position = push_accessor(
            &mut root,
            &mut bytes,
            bytemuck_f32(&positions),
            positions.len(),
            json::accessor::Type::Vec3,
            json::accessor::ComponentType::F32,
            Some((min, max)),
            json::buffer::Target::ArrayBuffer,
        );
        let normal = push_accessor(
            &mut root,
            &mut bytes,
            bytemuck_f32(&normals),
            normals.len(),
            json::accessor::Type::Vec3,
            json::accessor::ComponentType::F32,
            None,
            json::buffer::Target::ArrayBuffer,
        );
        let index = push_accessor(
            &mut root,
            &mut bytes,
            indices.iter().flat_map(|i| i.to_le_bytes()).collect(),
            indices.len(),
            json::accessor::Type::Scalar,
            json::accessor::ComponentType::U32,
            None,
            json::buffer::Target::ElementArrayBuffer,
        );
        let group = &scene.groups[g];
        transparent |= group.material.opacity < 1.0;
        let material = root.push(group_material(group));
        let primitive = json::mesh::Primitive {
            attributes: BTreeMap::from([
                (Valid(json::mesh::Semantic::Positions), position),
                (Valid(json::mesh::Semantic::Normals), normal),
            ]),
            extensions: None,
            extras: Default::default(),
            indices: Some(index),
            material: Some(material),
            mode: Valid(json::mesh::Mode::Triangles),
            targets: None,
        };
        let mesh_index = root.push(json::Mesh {
            extensions: None,
            extras: Default::default(),
            name: Some(group.name.clone()),
            primitives: vec![primitive],
            weights: None,
        });
        nodes.push(root.push(json::Node {
            mesh: Some(mesh_index),
            name: Some(group.name.clone()),
            ..Default::default()
        }));
    }
    if nodes.is_empty() {
        return Err("the isosurface is empty at this resolution: nothing to export".into());
    }
    if transparent {
        root.extensions_used = vec![
            "KHR_materials_transmission".into(),
            "KHR_materials_ior".into(),
        ];
    }
    let scene_index = root.push(json::Scene {
        extensions: None,
        extras: Default::default(),
        name: None,
        nodes,
    });
    root.scene = Some(scene_index);
    root.push(json::Buffer {
        byte_length: USize64::from(bytes.len()),
        extensions: None,
        extras: Default::default(),
        name: None,
        uri: (!binary).then(|| {
            bin_name
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default()
        }),
    });
    write_gltf_files(path, binary, &root, bytes, &bin_name, inputs)
}

/// A group's material: its colour and opacity, and where it is see-through the transmission
/// and index of refraction of `KHR_materials_transmission` and `KHR_materials_ior`.
fn group_material(group: &skeletrace_core::model::scene::Group) -> json::Material {
    let m = group.material;
    let see_through = m.opacity < 1.0;
    json::Material {
        name: Some(group.name.clone()),
        alpha_mode: Valid(if see_through {
            json::material::AlphaMode::Blend
        } else {
            json::material::AlphaMode::Opaque
        }),
        pbr_metallic_roughness: json::material::PbrMetallicRoughness {
            base_color_factor: json::material::PbrBaseColorFactor([
                m.color[0] as f32,
                m.color[1] as f32,
                m.color[2] as f32,
                m.opacity as f32,
            ]),
            metallic_factor: json::material::StrengthFactor(0.0),
            roughness_factor: json::material::StrengthFactor(0.5),
            ..Default::default()
        },
        extensions: see_through.then(|| json::extensions::material::Material {
            transmission: Some(json::extensions::material::Transmission {
                transmission_factor: json::extensions::material::TransmissionFactor(
                    (1.0 - m.opacity) as f32,
                ),
                transmission_texture: None,
                extras: Default::default(),
            }),
            ior: Some(json::extensions::material::Ior {
                ior: json::extensions::material::IndexOfRefraction(m.ior as f32),
                extras: Default::default(),
            }),
        }),
        ..Default::default()
    }
}

/// Writes `root` and its buffer `bytes`: one `.glb`, or the `.gltf` after its buffer `bin_name`
/// (then the buffer of the `.gltf` it replaced is removed).
fn write_gltf_files(
    path: &Path,
    binary: bool,
    root: &json::Root,
    bytes: Vec<u8>,
    bin_name: &Path,
    inputs: &[&Path],
) -> Result<(), String> {
    if binary {
        let json_text = json::serialize::to_string(root).map_err(|e| e.to_string())?;
        let json_len = json_text.len().next_multiple_of(4);
        let glb = gltf::binary::Glb {
            header: gltf::binary::Header {
                magic: *b"glTF",
                version: 2,
                length: u32::try_from(12 + 8 + json_len + 8 + bytes.len())
                    .map_err(|_| format!("{}: the mesh exceeds glb's 4 GiB", path.display()))?,
            },
            json: Cow::Owned(json_text.into_bytes()),
            bin: Some(Cow::Owned(bytes)),
        };
        let mut out = Vec::new();
        glb.to_writer(&mut out).map_err(|e| e.to_string())?;
        write_file(path, &out, inputs).map_err(|e| e.to_string())
    } else {
        let json_text = json::serialize::to_string_pretty(root).map_err(|e| e.to_string())?;
        let old_buffers = buffers_named_by(path);
        write_file(bin_name, &bytes, inputs).map_err(|e| e.to_string())?;
        if let Err(e) = write_file(path, json_text.as_bytes(), inputs) {
            let _ = std::fs::remove_file(bin_name);
            return Err(e.to_string());
        }
        for old in old_buffers.into_iter().filter(|old| old != bin_name) {
            let _ = std::fs::remove_file(old);
        }
        Ok(())
    }
}

/// `NAME.ID.bin` beside `NAME.gltf`, with an ID no other write uses.
fn buffer_name(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .map_or_else(|| "mesh".into(), |s| s.to_string_lossy().into_owned());
    path.with_file_name(format!(
        "{stem}.{}.bin",
        skeletrace_core::output::unique_id()
    ))
}

/// The buffer files an existing `.gltf` at `path` names beside itself (plain file names of the
/// form `NAME.*.bin` or `NAME.bin` written by this program): removed once a new `.gltf` replaced it.
fn buffers_named_by(path: &Path) -> Vec<PathBuf> {
    let Ok(text) = std::fs::read_to_string(path) else {
        return Vec::new();
    };
    let Ok(root) = serde_json::from_str::<serde_json::Value>(&text) else {
        return Vec::new();
    };
    let stem = path
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    let buffers = root["buffers"].as_array().cloned().unwrap_or_default();
    buffers
        .iter()
        .filter_map(|b| b["uri"].as_str())
        .filter(|uri| {
            !uri.contains(['/', '\\', ':'])
                && uri.starts_with(&format!("{stem}."))
                && uri.ends_with(".bin")
        })
        .map(|uri| path.with_file_name(uri))
        .collect()
}

/// Appends `data` (padded to 4 bytes) to the buffer and an accessor over it.
#[expect(
    clippy::too_many_arguments,
    reason = "one glTF accessor is these eight values; a struct would only rename them"
)]
fn push_accessor(
    root: &mut json::Root,
    bytes: &mut Vec<u8>,
    data: Vec<u8>,
    count: usize,
    kind: json::accessor::Type,
    component: json::accessor::ComponentType,
    bounds: Option<([f32; 3], [f32; 3])>,
    target: json::buffer::Target,
) -> json::Index<json::Accessor> {
    let offset = bytes.len();
    let length = data.len();
    bytes.extend(data);
    bytes.resize(bytes.len().next_multiple_of(4), 0);
    let view = root.push(json::buffer::View {
        buffer: json::Index::new(0),
        byte_length: USize64::from(length),
        byte_offset: Some(USize64::from(offset)),
        byte_stride: None,
        extensions: None,
        extras: Default::default(),
        name: None,
        target: Some(Valid(target)),
    });
    root.push(json::Accessor {
        buffer_view: Some(view),
        byte_offset: Some(USize64(0)),
        count: USize64::from(count),
        component_type: Valid(json::accessor::GenericComponentType(component)),
        extensions: None,
        extras: Default::default(),
        type_: Valid(kind),
        min: bounds.map(|(lo, _)| json::Value::from(lo.to_vec())),
        max: bounds.map(|(_, hi)| json::Value::from(hi.to_vec())),
        name: None,
        normalized: false,
        sparse: None,
    })
}

fn bytemuck_f32(values: &[[f32; 3]]) -> Vec<u8> {
    values
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect()
}
