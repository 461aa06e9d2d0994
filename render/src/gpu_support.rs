//! What the GPU traces: the one answer the GPU gives to `skeletrace_core::backend::decide`,
//! whether it is asked of a [`GpuRenderer`] (the GPU backend, the editor's GPU viewport) or,
//! from another thread, of a GPU known only by its device kind ([`GpuOfKind`]: the editor's
//! method labels while the render thread holds the GPU).
//!
//! A method runs on the GPU when it has a WGSL implementation that takes the scene
//! ([`GpuMethod::supports`]), follows the request's settings profile ([`GpuMethod::follows`]),
//! the scene fits the GPU's limits (`PackedScene::check`), and on a software adapter the
//! shaded view's field shading stays within its loop budget.

use skeletrace_core::backend::{BackendError, Capabilities, DeviceKind, FrameRequest};
use skeletrace_core::compile::Compiled;
use skeletrace_core::frame::{FieldShading, View};
use skeletrace_core::methods::{MethodId, TraceSettings};

use crate::buffers::PackedScene;
use crate::gpu_renderer::{GpuRenderer, check_shading_walks};
use crate::ray_bvh::RayBvh;
use crate::shaders::GpuMethod;

/// The GPU method of `id`.
fn of_id(id: MethodId) -> Result<GpuMethod, String> {
    GpuMethod::from_id(id).ok_or_else(|| format!("{id} has no GPU implementation"))
}

/// `Err` with the reason when the GPU's `method` cannot trace `compiled` under `settings`,
/// whatever the device: a scene its WGSL does not take, a profile it does not follow, a scene
/// past the GPU's limits. The renderer checks this again before it builds pipelines.
///
/// # Errors
/// What the GPU lacks for this method, scene or profile.
pub fn check_method(
    compiled: &Compiled,
    method: GpuMethod,
    settings: &TraceSettings,
) -> Result<(), String> {
    method.supports(&compiled.program)?;
    method.follows(settings.protocol)?;
    PackedScene::check(&compiled.program)
}

/// The GPU methods of `ids`, in order.
///
/// # Errors
/// [`BackendError::Unsupported`] for a method without a GPU implementation.
pub fn gpu_methods(ids: &[MethodId]) -> Result<Vec<GpuMethod>, BackendError> {
    ids.iter()
        .map(|&id| of_id(id).map_err(BackendError::Unsupported))
        .collect()
}

/// What a GPU supports: [`check_method`] for `method` under `request`'s settings, and in the
/// shaded view its field shading within `budget` (the device's loop limit).
fn supports_within(
    compiled: &Compiled,
    method: MethodId,
    request: &FrameRequest,
    budget: impl FnOnce(FieldShading) -> Result<(), String>,
) -> Result<(), String> {
    check_method(compiled, of_id(method)?, &request.settings)?;
    match request.view {
        View::Shaded(shading) => budget(shading),
        View::Steps { .. } => Ok(()),
    }
}

impl Capabilities for GpuRenderer {
    fn device_kind(&self) -> DeviceKind {
        GpuRenderer::device_kind(self)
    }

    fn supports(
        &self,
        compiled: &Compiled,
        method: MethodId,
        request: &FrameRequest,
    ) -> Result<(), String> {
        supports_within(compiled, method, request, |shading| {
            self.check_shading_budget(compiled, shading)
        })
    }
}

/// A GPU known by its device kind, answering as a [`GpuRenderer`] of that kind would (on a
/// software adapter the shading budget comes from the scene's own hierarchy, built only when
/// the view has field shading).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpuOfKind(pub DeviceKind);

impl Capabilities for GpuOfKind {
    fn device_kind(&self) -> DeviceKind {
        self.0
    }

    fn supports(
        &self,
        compiled: &Compiled,
        method: MethodId,
        request: &FrameRequest,
    ) -> Result<(), String> {
        supports_within(compiled, method, request, |shading| {
            if self.0 == DeviceKind::HardwareGpu {
                return Ok(());
            }
            check_shading_walks(compiled, shading, || {
                RayBvh::new(&compiled.program).point_walk_bound()
            })
        })
    }
}
