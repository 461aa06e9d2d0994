//! `Scene` → `Arc<Compiled>`: everything a backend needs to trace a scene, built once per edit
//! (DESIGN.md's data flow). A camera is never part of it, so moving the camera never compiles.
//!
//! [`compile_count`] counts the compiles of this process, so that tests can check that orbiting
//! compiles nothing and an edit compiles once.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::field::program::FieldProgram;
use crate::methods::TraceSettings;
use crate::model::scene::{Light, Material, Scene};

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
