//! `Scene` → `Arc<Compiled>`: everything a backend needs to trace a scene, built once per edit
//! (DESIGN.md's data flow). A camera is never part of it, so moving the camera never compiles.
//!
//! [`compile_count`] counts the compiles of this process, so that tests can check that orbiting
//! compiles nothing and an edit compiles once.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;

use crate::field::program::FieldProgram;
use crate::methods::TraceSettings;
use crate::model::scene::{Camera, Light, Material, Scene};

static COMPILES: AtomicU64 = AtomicU64::new(0);

/// A scene compiled for tracing: the field program with its BVH (and the HRBF weights inside
/// it), one material per group, the lights, and the default trace settings for its size.
/// Read-only once built; shared between the UI, the render thread and the backends.
#[derive(Debug)]
pub struct Compiled {
    /// The field: primitives, kernels, blend tree, BVH.
    pub program: FieldProgram,
    /// Material of each group, in group order.
    pub materials: Vec<Material>,
    /// The scene's lights, or the default key and fill lights when it has none.
    pub lights: Vec<Light>,
    /// Trace settings scaled to the scene ([`TraceSettings::for_program`]).
    pub settings: TraceSettings,
}

/// Compiles a validated scene.
#[must_use]
pub fn compile(scene: &Scene) -> Arc<Compiled> {
    COMPILES.fetch_add(1, Ordering::Relaxed);
    let program = FieldProgram::new(scene);
    let settings = TraceSettings::for_program(&program);
    Arc::new(Compiled {
        materials: scene.groups.iter().map(|g| g.material).collect(),
        lights: if scene.lights.is_empty() {
            Scene::default_lights()
        } else {
            scene.lights.clone()
        },
        settings,
        program,
    })
}

/// Number of [`compile`] calls in this process so far.
#[must_use]
pub fn compile_count() -> u64 {
    COMPILES.load(Ordering::Relaxed)
}

/// A camera looking at the centre of the scene's supports from a three-quarter view, far
/// enough to see all of it.
#[must_use]
pub fn framing_camera(compiled: &Compiled) -> Camera {
    let bounds = compiled.program.support_bounds();
    if bounds.is_empty() {
        return Camera::default();
    }
    let center = bounds.center();
    let fov = 40.0_f64;
    // The support box is wider than the surface (by σ radii): frame 80 % of the distance at
    // which its bounding sphere would just fit, which keeps the surface in view.
    let radius = 0.5 * bounds.diagonal();
    let distance = 0.8 * radius / (0.5 * fov.to_radians()).sin();
    let eye = center + DVec3::new(0.45, 0.35, 0.82).normalize() * distance;
    Camera {
        position: eye.to_array(),
        target: center.to_array(),
        up: [0.0, 1.0, 0.0],
        fov_degrees: fov,
    }
}
