//! Mesh export (issue "Mesh export to glTF"): the exported file is read back with the gltf
//! crate, and its meshes are checked against the scene and the field: one mesh per group
//! with the group's colour, bounds inside the support box, every vertex on the surface within
//! the stated tolerance with an outward unit normal, no degenerate triangle, and, for a closed
//! surface, a closed mesh (every edge shared by exactly two triangles, across the groups).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::DVec3;
use skeletrace::export;
use skeletrace_core::isosurface::MeshReport;
use skeletrace_core::model::generate::{GenerateOptions, GeneratorKind, generate};
use skeletrace_core::model::rng::SplitMix64;
use skeletrace_core::{FieldProgram, Scene};

#[path = "../../core/tests/common/mod.rs"]
mod common;

/// How far an exported vertex may be from the surface, as `|f − c| / |∇f|` relative to the
/// support's diagonal: the edge iterations converge far below it; the glTF's f32 positions add
/// about 10⁻⁷.
const SURFACE_TOLERANCE: f64 = 1e-5;

fn load(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../assets/scenes/{name}.ron"));
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// A test's own directory for the files it writes, removed when the test ends.
struct Scratch(PathBuf);

impl Scratch {
    fn new(test: &str) -> Self {
        let dir =
            std::env::temp_dir().join(format!("skeletrace-mesh-{}-{test}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
        Self(dir)
    }

    fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        // Best effort: a file left behind in the temporary directory is no failure.
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// One mesh of the file as read back.
struct MeshBack {
    name: String,
    colour: [f32; 4],
    /// Triangles as world positions.
    triangles: Vec<[DVec3; 3]>,
    /// Vertices with their normals.
    vertices: Vec<(DVec3, DVec3)>,
}

/// Every mesh in the file.
struct ReadBack {
    meshes: Vec<MeshBack>,
}

fn read_back(path: &Path) -> ReadBack {
    let (document, buffers, _) = gltf::import(path).unwrap_or_else(|e| panic!("{e}"));
    let mut meshes = Vec::new();
    for mesh in document.meshes() {
        for primitive in mesh.primitives() {
            let reader = primitive.reader(|b| Some(&buffers[b.index()]));
            let to_d = |p: [f32; 3]| DVec3::new(p[0].into(), p[1].into(), p[2].into());
            let positions: Vec<DVec3> = reader
                .read_positions()
                .unwrap_or_else(|| panic!("positions"))
                .map(to_d)
                .collect();
            let normals: Vec<DVec3> = reader
                .read_normals()
                .unwrap_or_else(|| panic!("normals"))
                .map(to_d)
                .collect();
            let indices: Vec<u32> = reader
                .read_indices()
                .unwrap_or_else(|| panic!("indices"))
                .into_u32()
                .collect();
            let triangles = indices
                .chunks_exact(3)
                .map(|t| [0, 1, 2].map(|k| positions[t[k] as usize]))
                .collect();
            let colour = primitive
                .material()
                .pbr_metallic_roughness()
                .base_color_factor();
            meshes.push(MeshBack {
                name: mesh.name().unwrap_or_default().to_owned(),
                colour,
                triangles,
                vertices: positions.into_iter().zip(normals).collect(),
            });
        }
    }
    ReadBack { meshes }
}

fn check(scene: &Scene, back: &ReadBack, closed: bool) {
    let program = FieldProgram::new(scene);
    let c = program.isovalue();
    let bounds = program.support_bounds();
    let diagonal = (bounds.max - bounds.min).length();
    let with_triangles = scene.groups.len();
    assert!(
        !back.meshes.is_empty() && back.meshes.len() <= with_triangles,
        "one mesh per group with triangles: {} meshes, {} groups",
        back.meshes.len(),
        with_triangles
    );
    let mut edges: HashMap<[[u64; 3]; 2], usize> = HashMap::new();
    let mut worst = 0.0f64;
    let mut inward = 0;
    for mesh in &back.meshes {
        let group = scene
            .groups
            .iter()
            .find(|g| g.name == mesh.name)
            .unwrap_or_else(|| panic!("mesh {} names a group", mesh.name));
        for (shown, wanted) in mesh.colour.iter().zip(group.material.color) {
            assert!((f64::from(*shown) - wanted).abs() < 1e-6);
        }
        for (p, n) in &mesh.vertices {
            let slack = DVec3::splat(1e-6 * diagonal);
            assert!(
                p.cmpge(bounds.min - slack).all() && p.cmple(bounds.max + slack).all(),
                "{p} inside the support box"
            );
            let (f, g) = program.value_gradient(*p);
            let distance = (f - c).abs() / g.length();
            worst = worst.max(distance / diagonal);
            assert!((n.length() - 1.0).abs() < 1e-4, "unit normal {n}");
            assert!(n.dot(-g.normalize()) > 0.999, "outward normal {n}");
        }
        for t in &mesh.triangles {
            let area = 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length();
            assert!(area > 0.0, "degenerate triangle {t:?}");
            // Counter-clockwise seen from outside: the face normal points outwards.
            let (_, g) = program.value_gradient((t[0] + t[1] + t[2]) / 3.0);
            if (t[1] - t[0]).cross(t[2] - t[0]).dot(-g) <= 0.0 {
                inward += 1;
            }
            for k in 0..3 {
                let (a, b) = (
                    t[k].to_array().map(f64::to_bits),
                    t[(k + 1) % 3].to_array().map(f64::to_bits),
                );
                *edges
                    .entry(if a < b { [a, b] } else { [b, a] })
                    .or_default() += 1;
            }
        }
    }
    assert!(
        worst <= SURFACE_TOLERANCE * (1.0 + 1e-3),
        "vertices on the surface: worst |f − c|/|∇f| = {worst:e} of the diagonal"
    );
    let triangles: usize = back.meshes.iter().map(|m| m.triangles.len()).sum();
    // A few faces at the creases of the max blend face against the gradient at their centre
    // (0.3 % on blobs at 48 cells): at most 1 %.
    assert!(
        inward * 100 <= triangles,
        "faces point outwards: {inward} of {triangles} point inwards"
    );
    // Closed: no boundary edge. Naive surface nets can join two sheets along an edge (four
    // triangles), which is closed but not manifold; those are counted and printed.
    let boundary = edges.values().filter(|&&n| n % 2 == 1).count();
    let non_manifold = edges.values().filter(|&&n| n > 2).count();
    if closed {
        assert_eq!(
            boundary, 0,
            "closed mesh: {boundary} edges with an odd triangle count"
        );
    }
    println!(
        "{} meshes, {triangles} triangles, {} edges ({non_manifold} non-manifold), {inward} \
         faces inwards, worst distance {worst:.1e} of the diagonal",
        back.meshes.len(),
        edges.len()
    );
}

#[test]
fn exported_blobs_are_closed_on_the_surface_and_coloured_per_group() {
    let scratch = Scratch::new("closed");
    let scene = load("blobs");
    let mesh = export::extract(&scene, 48, &|_| {}).unwrap_or_else(|e| panic!("{e}"));
    assert!(mesh.report.watertight, "{:?}", mesh.report);
    let path = scratch.path("blobs.glb");
    export::write_gltf(&scene, &mesh, &path, &[]).unwrap_or_else(|e| panic!("{e}"));
    let back = read_back(&path);
    let triangles: usize = back.meshes.iter().map(|m| m.triangles.len()).sum();
    assert_eq!(
        triangles,
        mesh.triangles.iter().map(Vec::len).sum::<usize>()
    );
    check(&scene, &back, true);
}

#[test]
fn a_gltf_with_its_bin_reads_back_and_a_transparent_group_keeps_transmission_and_ior() {
    let scratch = Scratch::new("glass");
    let mut scene = load("blobs");
    scene.groups[0].material.opacity = 0.4;
    scene.groups[0].material.ior = 1.33;
    let mesh = export::extract(&scene, 32, &|_| {}).unwrap_or_else(|e| panic!("{e}"));
    let path = scratch.path("glass.gltf");
    // Written twice: one buffer beside the .gltf, the one it names.
    for _ in 0..2 {
        export::write_gltf(&scene, &mesh, &path, &[]).unwrap_or_else(|e| panic!("{e}"));
    }
    let buffers: Vec<_> = std::fs::read_dir(path.parent().unwrap_or(&path))
        .map(|d| {
            d.filter_map(Result::ok)
                .map(|e| e.file_name().to_string_lossy().into_owned())
        })
        .map(|names| {
            names
                .filter(|n| n.ends_with(".bin") || n.ends_with(".tmp"))
                .collect()
        })
        .unwrap_or_default();
    assert_eq!(buffers.len(), 1, "{buffers:?}");
    let (document, _, _) = gltf::import(&path).unwrap_or_else(|e| panic!("{e}"));
    let glass = document
        .materials()
        .find(|m| m.name() == Some(scene.groups[0].name.as_str()))
        .unwrap_or_else(|| panic!("the group's material"));
    assert_eq!(glass.alpha_mode(), gltf::material::AlphaMode::Blend);
    let transmission = glass
        .transmission()
        .map(|t| t.transmission_factor())
        .unwrap_or_default();
    assert!((transmission - 0.6).abs() < 1e-6, "{transmission}");
    assert_eq!(glass.ior(), Some(1.33));
    check(&scene, &read_back(&path), true);
}

#[test]
fn a_wrong_extension_is_refused_with_the_path() {
    let scratch = Scratch::new("extension");
    let scene = load("blobs");
    let mesh = export::extract(&scene, 16, &|_| {}).unwrap_or_else(|e| panic!("{e}"));
    let path = scratch.path("mesh.fbx");
    let error = export::write_mesh(&scene, &mesh, &path, &[])
        .err()
        .unwrap_or_default();
    assert!(
        error.contains("mesh.fbx") && error.contains(".glb") && error.contains(".stl"),
        "{error}"
    );
    assert!(!path.exists());
}

/// The rules of the glTF 2.0 specification that our files touch, checked on the file as read
/// back: NORMAL vectors of unit length (within the Khronos validator's 0.0005), finite POSITION
/// values, POSITION accessors whose min/max are exactly those of the data, indices inside the
/// vertex range, buffer views aligned to 4 bytes, and every material extension in use declared
/// in `extensionsUsed`. Returns the number of meshes checked.
fn check_gltf_rules(path: &Path) -> usize {
    let (document, buffers, _) = gltf::import(path).unwrap_or_else(|e| panic!("{e}"));
    let label = path.display();
    for view in document.views() {
        assert_eq!(
            view.offset() % 4,
            0,
            "{label}: buffer view {} unaligned",
            view.index()
        );
    }
    let used: Vec<&str> = document.extensions_used().collect();
    for material in document.materials() {
        if material.transmission().is_some() {
            assert!(
                used.contains(&"KHR_materials_transmission"),
                "{label}: {used:?}"
            );
        }
        if material.ior().is_some() {
            assert!(used.contains(&"KHR_materials_ior"), "{label}: {used:?}");
        }
    }
    let mut meshes = 0;
    for mesh in document.meshes() {
        meshes += 1;
        for primitive in mesh.primitives() {
            let reader = primitive.reader(|b| Some(&buffers[b.index()]));
            let positions: Vec<[f32; 3]> = reader
                .read_positions()
                .unwrap_or_else(|| panic!("{label}: positions"))
                .collect();
            assert!(positions.iter().flatten().all(|v| v.is_finite()), "{label}");
            let accessor = primitive
                .get(&gltf::Semantic::Positions)
                .unwrap_or_else(|| panic!("{label}: POSITION accessor"));
            let bound = |value: Option<gltf::json::Value>| -> Vec<f32> {
                value
                    .and_then(|v| v.as_array().cloned())
                    .unwrap_or_default()
                    .iter()
                    .filter_map(|x| x.as_f64().map(|x| x as f32))
                    .collect()
            };
            let (min, max) = (bound(accessor.min()), bound(accessor.max()));
            for k in 0..3 {
                let lo = positions.iter().map(|p| p[k]).fold(f32::INFINITY, f32::min);
                let hi = positions
                    .iter()
                    .map(|p| p[k])
                    .fold(f32::NEG_INFINITY, f32::max);
                assert_eq!(
                    (min[k], max[k]),
                    (lo, hi),
                    "{label}: POSITION bounds, axis {k}"
                );
            }
            for n in reader
                .read_normals()
                .unwrap_or_else(|| panic!("{label}: normals"))
            {
                let length = n.iter().map(|v| v * v).sum::<f32>().sqrt();
                assert!(
                    n.iter().all(|v| v.is_finite()) && (length - 1.0).abs() <= 5e-4,
                    "{label}: NORMAL {n:?} of length {length}"
                );
            }
            let count = positions.len() as u32;
            let indices: Vec<u32> = reader
                .read_indices()
                .unwrap_or_else(|| panic!("{label}: indices"))
                .into_u32()
                .collect();
            assert_eq!(indices.len() % 3, 0, "{label}");
            assert!(
                indices.iter().all(|&i| i < count),
                "{label}: index out of range"
            );
        }
    }
    meshes
}

/// A scene of generator `kind` from a random seed and a size drawn for its kind (small enough
/// to export in a test).
fn random_generated(rng: &mut SplitMix64, kind: GeneratorKind) -> (GenerateOptions, Scene) {
    let size = match kind {
        GeneratorKind::Tree => 2 + rng.below(4),
        GeneratorKind::Truss => 1 + rng.below(3),
        GeneratorKind::Foam => 3 + rng.below(10),
        GeneratorKind::Molecule => 10 + rng.below(60),
        _ => 3 + rng.below(30),
    };
    let options = GenerateOptions {
        seed: rng.below(1 << 30) as u64,
        size: Some(size),
        ..GenerateOptions::default()
    };
    let scene = generate(kind, &options).unwrap_or_else(|e| panic!("{e}"));
    (options, scene)
}

/// Exports of scenes nobody tuned the exporter on: per generator, a dozen scenes from random
/// seeds and sizes, as `.glb` and `.gltf`, each checked against the glTF rules above (a vertex
/// where the analytic gradient vanishes once got a zero normal), and every asset.
#[test]
fn exports_of_generated_scenes_and_assets_follow_the_gltf_rules() {
    let scratch = Scratch::new("rules");
    let mut rng = SplitMix64::new(2026);
    let mut meshes = 0;
    let mut files = 0;
    for &(kind, name) in &GeneratorKind::ALL {
        for k in 0..12 {
            let (options, scene) = random_generated(&mut rng, kind);
            let mesh = export::extract(&scene, 24, &|_| {})
                .unwrap_or_else(|e| panic!("{name} {options:?}: {e}"));
            let path = scratch.path(&format!(
                "{name}-{k}.{}",
                if k % 2 == 0 { "glb" } else { "gltf" }
            ));
            export::write_gltf(&scene, &mesh, &path, &[]).unwrap_or_else(|e| panic!("{e}"));
            meshes += check_gltf_rules(&path);
            files += 1;
        }
    }
    for asset in [
        "blobs",
        "tree",
        "creature",
        "hand",
        "hrbf",
        "truss",
        "random-skeleton",
    ] {
        let scene = load(asset);
        let mesh = export::extract(&scene, 32, &|_| {}).unwrap_or_else(|e| panic!("{e}"));
        let path = scratch.path(&format!("asset-{asset}.glb"));
        export::write_gltf(&scene, &mesh, &path, &[]).unwrap_or_else(|e| panic!("{e}"));
        meshes += check_gltf_rules(&path);
        files += 1;
    }
    eprintln!("glTF rules hold on {meshes} meshes in {files} files");
    assert!(files >= 79);
}

/// Edges with other than two faces, edges whose two faces run them the same way, and vertices
/// whose faces form more than one fan, counted here independently of [`MeshReport`].
fn topology_defects(triangles: &[[u32; 3]]) -> (usize, usize, usize) {
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    for t in triangles {
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
        }
    }
    let mut undirected: HashMap<(u32, u32), (usize, usize)> = HashMap::new();
    for (&(a, b), &n) in &directed {
        let entry = undirected.entry((a.min(b), a.max(b))).or_default();
        if a < b {
            entry.0 += n;
        } else {
            entry.1 += n;
        }
    }
    let bad_edges = undirected.values().filter(|(f, b)| f + b != 2).count();
    let misoriented = undirected
        .values()
        .filter(|&&(f, b)| f + b == 2 && f != 1)
        .count();
    // A vertex's fans: its triangles joined where they share an edge at the vertex.
    let mut around: HashMap<u32, Vec<(u32, u32)>> = HashMap::new();
    for t in triangles {
        for k in 0..3 {
            around
                .entry(t[k])
                .or_default()
                .push((t[(k + 1) % 3], t[(k + 2) % 3]));
        }
    }
    let many_fans = around
        .values()
        .filter(|opposite| {
            let mut reached = vec![false; opposite.len()];
            let mut stack = vec![0];
            reached[0] = true;
            while let Some(i) = stack.pop() {
                for (j, other) in opposite.iter().enumerate() {
                    let shares = [other.0, other.1]
                        .iter()
                        .any(|v| *v == opposite[i].0 || *v == opposite[i].1);
                    if !reached[j] && shares {
                        reached[j] = true;
                        stack.push(j);
                    }
                }
            }
            reached.iter().any(|r| !r)
        })
        .count();
    (bad_edges, misoriented, many_fans)
}

/// Two blobs whose surfaces come within a hundredth of a cell of each other, under the max
/// (they do not merge), and a strut thinner than a cell between two large blobs: the cases
/// where a mesher that puts one vertex per cell joins two sheets in one vertex.
fn near_misses(rng: &mut SplitMix64, cell: f64) -> Scene {
    use skeletrace_core::model::scene::{Blend, Blob, Skeleton, SkeletonField, Vertex};
    let kernel = skeletrace_core::model::kernel::Kernel::default();
    let mut a = common::group(kernel);
    let mut b = common::group(kernel);
    let radius = 0.5 + 0.5 * rng.unit();
    let centre = |rng: &mut SplitMix64| [rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5];
    let first = centre(rng);
    let d = rng.direction();
    // The surface of a lone blob of radius r lies near r (the kernel normalised to it); the
    // gap is a small fraction of a cell, measured on the mesh's own grid below.
    let gap = 2.0 * radius + 0.01 * cell;
    a.blobs.push(Blob {
        center: first,
        radius,
    });
    b.blobs.push(Blob {
        center: [
            first[0] + gap * d[0],
            first[1] + gap * d[1],
            first[2] + gap * d[2],
        ],
        radius,
    });
    let strut_end = |s: f64| [first[0] - s * d[1], first[1] + s * d[0], first[2]];
    a.skeletons.push(Skeleton {
        name: "strut".into(),
        field: SkeletonField::Scalis,
        end_correctors: false,
        vertices: vec![
            Vertex {
                position: strut_end(0.0),
                radius: 0.3 * cell,
            },
            Vertex {
                position: strut_end(2.0),
                radius: 0.3 * cell,
            },
        ],
        edges: vec![[0, 1]],
    });
    a.blobs.push(Blob {
        center: strut_end(2.0),
        radius,
    });
    common::scene(
        vec![a, b],
        Some(Blend::Max(vec![Blend::Group(0), Blend::Group(1)])),
    )
}

/// Meshes a printer accepts, on scenes nobody tuned the mesher on: 200 scenes — every
/// generator at random seeds and sizes, random blend trees over every bounded primitive kind,
/// and nearly touching parts with struts thinner than a cell — at resolutions of 12 to 40
/// cells (planes are cut at the box of the other supports and capped there). Every mesh is watertight and 2-manifold (every edge has two faces, every vertex one
/// fan, counted here and by the exporter's report, which must agree), consistently oriented
/// outward (positive volume), without degenerate triangles, its vertices on the surface.
#[test]
fn two_hundred_random_scenes_export_watertight_manifold_outward_meshes() {
    let mut rng = SplitMix64::new(64);
    let (mut checked, mut triangles, mut cut_planes, mut at_jumps, mut lost) = (0, 0, 0, 0, 0);
    while checked < 200 {
        let resolution = 12 + rng.below(29);
        let (label, scene) = match checked % 4 {
            0 | 1 => {
                let (kind, name) = GeneratorKind::ALL[rng.below(GeneratorKind::ALL.len())];
                let (options, scene) = random_generated(&mut rng, kind);
                (format!("{name} {options:?}"), scene)
            }
            2 => {
                let scene = common::random_nested_scene(&mut rng);
                (format!("random blend tree {checked}"), scene)
            }
            _ => {
                // The cell the mesh will have: the box is the two blobs and the strut's.
                let scene = near_misses(&mut rng, 3.0 / resolution as f64);
                (format!("near misses {checked}"), scene)
            }
        };
        let mesh =
            export::extract(&scene, resolution, &|_| {}).unwrap_or_else(|e| panic!("{label}: {e}"));
        cut_planes += usize::from(mesh.cut_at_box);
        let all: Vec<[u32; 3]> = mesh.triangles.concat();
        let r: &MeshReport = &mesh.report;
        let (bad_edges, misoriented, many_fans) = topology_defects(&all);
        assert_eq!(
            (bad_edges, misoriented, many_fans),
            (0, 0, 0),
            "{label} at {resolution}: edges without two faces, misoriented edges, vertices of \
             several fans; report {r:?}"
        );
        assert!(
            r.watertight
                && r.boundary_edges + r.non_manifold_edges + r.non_manifold_vertices == 0
                && r.degenerate_triangles == 0
                && r.misoriented_edges == 0
                && r.triangles == all.len(),
            "{label} at {resolution}: {r:?}"
        );
        assert!(
            all.is_empty() || r.volume > 0.0,
            "{label} at {resolution}: faces inwards, volume {}",
            r.volume
        );
        assert!(
            r.max_distance_cells < 1e-3,
            "{label} at {resolution}: a vertex {} cells off the surface",
            r.max_distance_cells
        );
        triangles += all.len();
        at_jumps += r.vertices_at_jumps;
        lost += usize::from(r.lost_features > 0);
        checked += 1;
    }
    eprintln!(
        "{checked} meshes, {triangles} triangles: watertight, manifold, outward; \
         {cut_planes} with a plane cut and capped at the box; {at_jumps} vertices at jumps of the field; {lost} meshes report parts thinner than a cell lost"
    );
    assert!(triangles > 200 * 100, "only {triangles} triangles in all");
}

/// A strut thinner than a cell is reported lost (its skeleton is inside the surface, no grid
/// point around it is) and kept at a resolution whose cells are finer than it.
#[test]
fn parts_thinner_than_a_cell_are_reported_lost_until_the_grid_resolves_them() {
    use skeletrace_core::model::scene::{Blob, Skeleton, SkeletonField, Vertex};
    let mut group = common::group(skeletrace_core::model::kernel::Kernel::default());
    group.blobs.push(Blob {
        center: [0.0, 0.0, 0.0],
        radius: 1.0,
    });
    group.skeletons.push(Skeleton {
        name: "strut".into(),
        field: SkeletonField::Scalis,
        end_correctors: false,
        vertices: vec![
            Vertex {
                position: [1.5, -0.5, 0.0],
                radius: 0.03,
            },
            Vertex {
                position: [1.5, 0.5, 0.0],
                radius: 0.03,
            },
        ],
        edges: vec![[0, 1]],
    });
    let scene = common::scene(vec![group], None);
    let coarse = export::extract(&scene, 12, &|_| {}).unwrap_or_else(|e| panic!("{e}"));
    assert!(coarse.report.lost_features > 0, "{:?}", coarse.report);
    let fine = export::extract(&scene, 128, &|_| {}).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(fine.report.lost_features, 0, "{:?}", fine.report);
    assert!(fine.report.watertight, "{:?}", fine.report);
}
