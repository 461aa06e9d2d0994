//! Skeletons from elsewhere: an SWC morphology file read as a scene (`skeletrace import`, and
//! File > Open or a dropped `.swc` in the editor), framed by the camera `generate` gives a scene.

use std::path::Path;

use skeletrace_core::Scene;
use skeletrace_core::model::swc;

/// The scene of the SWC file at `path` (`core::model::swc`), its camera framing it, and how
/// many radii were brought within the kernel's slope limit.
///
/// # Errors
/// The file cannot be read, a line is bad (one line naming the file, the line and the value),
/// or the scene does not validate.
pub fn swc_scene(path: &Path) -> Result<(Scene, usize), String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let samples = swc::parse(&text, &path.display().to_string())?;
    let (mut scene, moved) = swc::scene(&samples);
    scene
        .validate()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    scene.camera = skeletrace_core::compile::framing_camera(&skeletrace_core::compile(&scene));
    Ok((scene, moved))
}

/// Whether `path` names an SWC file (by its extension).
#[must_use]
pub fn is_swc(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("swc"))
}
