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
use skeletrace_core::frame::View;
use skeletrace_core::methods::MethodId;

use crate::buffers::PackedScene;
use crate::gpu_renderer::{GpuRenderer, check_shading_walks};
use crate::ray_bvh::RayBvh;
use crate::shaders::GpuMethod;

/// The GPU method that traces `method` on `compiled` under `request`'s settings, whatever the
/// device.
///
/// # Errors
/// What the GPU lacks for this method, scene or profile.
pub fn gpu_method(
    compiled: &Compiled,
    method: MethodId,
    request: &FrameRequest,
) -> Result<GpuMethod, String> {
    let gpu =
        GpuMethod::from_id(method).ok_or_else(|| format!("{method} has no GPU implementation"))?;
    gpu.supports(&compiled.program)?;
    gpu.follows(request.settings.protocol)?;
    PackedScene::check(&compiled.program)?;
    Ok(gpu)
}

/// The GPU methods of `ids`, in order.
///
/// # Errors
/// [`BackendError::Unsupported`] for a method without a GPU implementation.
pub fn gpu_methods(ids: &[MethodId]) -> Result<Vec<GpuMethod>, BackendError> {
    ids.iter()
        .map(|&id| {
            GpuMethod::from_id(id)
                .ok_or_else(|| BackendError::Unsupported(format!("{id} has no GPU implementation")))
        })
        .collect()
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
        gpu_method(compiled, method, request)?;
        if let View::Shaded(shading) = request.view {
            self.check_shading_budget(compiled, shading)?;
        }
        Ok(())
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
        gpu_method(compiled, method, request)?;
        match request.view {
            View::Shaded(shading) if self.0 != DeviceKind::HardwareGpu => {
                check_shading_walks(compiled, shading, || {
                    RayBvh::new(&compiled.program).point_walk_bound()
                })
            }
            _ => Ok(()),
        }
    }
}
