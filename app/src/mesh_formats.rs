//! Mesh files other than glTF, for printers, CAD and game tools: binary STL (facets with their
//! normals; one solid, groups merged), Wavefront OBJ with its `.mtl` (one object and material
//! per group: colour, opacity, index of refraction; shared vertices with their normals) and
//! binary little-endian PLY (vertices with normals, faces with their group) and 3MF (one
//! watertight object whose triangles carry their group's colour, in a zip package). Each is
//! written
//! with `skeletrace_core::output::write_file` (atomically, never over an input); an OBJ's
//! material library is written first, so that the OBJ never names a library that is not there.

use std::fmt::Write as _;
use std::path::Path;

use skeletrace_core::Scene;
use skeletrace_core::output::write_file;

use crate::export::Extracted;

/// Every group's triangles, with the group's index.
fn triangles(mesh: &Extracted) -> impl Iterator<Item = (usize, [u32; 3])> + '_ {
    mesh.triangles
        .iter()
        .enumerate()
        .flat_map(|(g, t)| t.iter().map(move |&tri| (g, tri)))
}

fn f32s(v: glam::DVec3) -> [f32; 3] {
    v.as_vec3().to_array()
}

/// Binary STL: an 80-byte header, the facet count, then per facet its unit normal (the
/// triangle's, counter-clockwise seen from outside) and its three corners, in f32.
#[must_use]
pub fn stl_bytes(mesh: &Extracted) -> Vec<u8> {
    let count = triangles(mesh).count();
    let mut out = Vec::with_capacity(84 + 50 * count);
    let mut header = [b' '; 80];
    let title = b"binary STL written by skeletrace";
    header[..title.len()].copy_from_slice(title);
    out.extend_from_slice(&header);
    out.extend_from_slice(&(count as u32).to_le_bytes());
    for (_, [a, b, c]) in triangles(mesh) {
        let [pa, pb, pc] = [a, b, c].map(|i| mesh.positions[i as usize]);
        let normal = (pb - pa).cross(pc - pa).normalize_or_zero();
        for v in [normal, pa, pb, pc] {
            for x in f32s(v) {
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
        out.extend_from_slice(&0u16.to_le_bytes());
    }
    out
}

/// A name a material or an object can carry in OBJ and MTL (no white space).
fn token(name: &str, g: usize) -> String {
    let cleaned: String = name
        .chars()
        .map(|c| if c.is_whitespace() { '_' } else { c })
        .collect();
    format!("g{g}_{cleaned}")
}

/// The OBJ text (vertices and normals shared by the groups, one object per group using its
/// material) naming the library `mtl_name`, and the MTL text.
#[must_use]
pub fn obj_text(scene: &Scene, mesh: &Extracted, mtl_name: &str) -> (String, String) {
    let mut obj = format!("# written by skeletrace\nmtllib {mtl_name}\n");
    for p in &mesh.positions {
        let [x, y, z] = f32s(*p);
        let _ = writeln!(obj, "v {x} {y} {z}");
    }
    for n in &mesh.normals {
        let [x, y, z] = f32s(*n);
        let _ = writeln!(obj, "vn {x} {y} {z}");
    }
    let mut mtl = String::from("# written by skeletrace\n");
    for (g, tris) in mesh.triangles.iter().enumerate() {
        if tris.is_empty() {
            continue;
        }
        let group = &scene.groups[g];
        let name = token(&group.name, g);
        let m = group.material;
        let _ = writeln!(
            mtl,
            "newmtl {name}\nKd {} {} {}\nd {}\nNi {}\n",
            m.color[0], m.color[1], m.color[2], m.opacity, m.ior
        );
        let _ = writeln!(obj, "o {name}\nusemtl {name}");
        for [a, b, c] in tris {
            let (a, b, c) = (a + 1, b + 1, c + 1);
            let _ = writeln!(obj, "f {a}//{a} {b}//{b} {c}//{c}");
        }
    }
    (obj, mtl)
}

/// Binary little-endian PLY: vertices (x, y, z, nx, ny, nz as float), faces (a uchar-counted
/// list of three int vertex indices, and the face's group as an int).
#[must_use]
pub fn ply_bytes(mesh: &Extracted) -> Vec<u8> {
    let faces = triangles(mesh).count();
    let header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by skeletrace\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\n\
         element face {faces}\nproperty list uchar int vertex_indices\nproperty int group\n\
         end_header\n",
        mesh.positions.len()
    );
    let mut out = header.into_bytes();
    for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
        for x in f32s(*p).into_iter().chain(f32s(*n)) {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    for (g, tri) in triangles(mesh) {
        out.push(3);
        for i in tri {
            out.extend_from_slice(&(i as i32).to_le_bytes());
        }
        out.extend_from_slice(&(g as i32).to_le_bytes());
    }
    out
}

/// `text` with XML's five special characters escaped, for an attribute or element.
fn xml_escaped(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&apos;")
}

/// The 3MF model part (3MF core specification 1.3, `3D/3dmodel.model`): the scene's groups
/// as base materials with their colours, and the whole mesh as one object whose triangles
/// name their group's material. One object rather than one per group: where groups blend, a
/// group's triangles alone are an open surface, which slicers refuse; the whole is closed.
/// Lengths are the scene's units, declared as millimetres (3MF's default unit).
#[must_use]
pub fn three_mf_model(scene: &Scene, mesh: &Extracted) -> String {
    let mut xml = String::from(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n\
         <model unit=\"millimeter\" xml:lang=\"en-US\" \
         xmlns=\"http://schemas.microsoft.com/3dmanufacturing/core/2015/02\">\n\
         <metadata name=\"Application\">skeletrace</metadata>\n<resources>\n<basematerials id=\"1\">\n",
    );
    let groups = mesh.triangles.len();
    for g in 0..groups {
        let (name, colour) = scene.groups.get(g).map_or_else(
            || (format!("group {g}"), [0.8; 3]),
            |group| (group.name.clone(), group.material.color),
        );
        let [r, gr, b] = colour.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8);
        let _ = writeln!(
            xml,
            "<base name=\"{}\" displaycolor=\"#{r:02X}{gr:02X}{b:02X}\"/>",
            xml_escaped(&name)
        );
    }
    xml.push_str(
        "</basematerials>\n<object id=\"2\" type=\"model\" name=\"skeletrace isosurface\" pid=\"1\" pindex=\"0\">\n<mesh>\n<vertices>\n",
    );
    for p in &mesh.positions {
        let [x, y, z] = f32s(*p);
        let _ = writeln!(xml, "<vertex x=\"{x}\" y=\"{y}\" z=\"{z}\"/>");
    }
    xml.push_str("</vertices>\n<triangles>\n");
    for (g, [a, b, c]) in triangles(mesh) {
        let _ = writeln!(
            xml,
            "<triangle v1=\"{a}\" v2=\"{b}\" v3=\"{c}\" pid=\"1\" p1=\"{g}\"/>"
        );
    }
    xml.push_str("</triangles>\n</mesh>\n</object>\n</resources>\n<build>\n<item objectid=\"2\"/>\n</build>\n</model>\n");
    xml
}

/// A 3MF package: the OPC content types, the root relationship to the model, and the model
/// ([`three_mf_model`]), deflated.
///
/// # Errors
/// The zip writer's, which writes to memory.
pub fn three_mf_bytes(scene: &Scene, mesh: &Extracted) -> Result<Vec<u8>, String> {
    use std::io::Write as _;
    let content_types = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n\
        <Types xmlns=\"http://schemas.openxmlformats.org/package/2006/content-types\">\n\
        <Default Extension=\"rels\" ContentType=\"application/vnd.openxmlformats-package.relationships+xml\"/>\n\
        <Default Extension=\"model\" ContentType=\"application/vnd.ms-package.3dmanufacturing-3dmodel+xml\"/>\n\
        </Types>\n";
    let relationships = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n\
        <Relationships xmlns=\"http://schemas.openxmlformats.org/package/2006/relationships\">\n\
        <Relationship Target=\"/3D/3dmodel.model\" Id=\"rel0\" \
        Type=\"http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel\"/>\n\
        </Relationships>\n";
    let model = three_mf_model(scene, mesh);
    let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let options = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated);
    for (name, text) in [
        ("[Content_Types].xml", content_types),
        ("_rels/.rels", relationships),
        ("3D/3dmodel.model", model.as_str()),
    ] {
        zip.start_file(name, options)
            .and_then(|()| zip.write_all(text.as_bytes()).map_err(Into::into))
            .map_err(|e| format!("3MF package, {name}: {e}"))?;
    }
    zip.finish()
        .map(std::io::Cursor::into_inner)
        .map_err(|e| format!("3MF package: {e}"))
}

/// Writes `mesh` as `.stl`, `.obj` (with `NAME.mtl` beside it), `.ply` or `.3mf`, by `path`'s
/// extension; `Ok(false)` for another extension.
///
/// # Errors
/// An empty mesh, or a file that cannot be written (named in the message).
pub fn write(
    scene: &Scene,
    mesh: &Extracted,
    path: &Path,
    inputs: &[&Path],
) -> Result<bool, String> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let extension = match extension.as_deref() {
        Some(e @ ("stl" | "obj" | "ply" | "3mf")) => e.to_owned(),
        _ => return Ok(false),
    };
    if triangles(mesh).next().is_none() {
        return Err("the isosurface is empty at this resolution: nothing to export".into());
    }
    let fail = |e: skeletrace_core::output::WriteError| e.to_string();
    match extension.as_str() {
        "stl" => write_file(path, &stl_bytes(mesh), inputs).map_err(fail)?,
        "ply" => write_file(path, &ply_bytes(mesh), inputs).map_err(fail)?,
        "3mf" => write_file(path, &three_mf_bytes(scene, mesh)?, inputs).map_err(fail)?,
        _ => {
            let mtl_path = path.with_extension("mtl");
            let mtl_name = mtl_path.file_name().map_or_else(
                || "materials.mtl".to_owned(),
                |n| n.to_string_lossy().into_owned(),
            );
            let (obj, mtl) = obj_text(scene, mesh, &mtl_name);
            write_file(&mtl_path, mtl.as_bytes(), inputs).map_err(fail)?;
            write_file(path, obj.as_bytes(), inputs).map_err(fail)?;
        }
    }
    Ok(true)
}
