//! The GPU [`FrameBackend`]: a [`GpuRenderer`] that uploads a compiled scene when it changes
//! (a new `Arc<Compiled>`; a camera never uploads anything) and traces the methods that have a
//! GPU implementation for the scene. Whether its adapter is a software rasteriser comes from
//! the adapter's device type ([`GpuRenderer::device_kind`]).

use std::sync::Arc;

use skeletrace_core::backend::{
    BackendError, Capabilities, DeviceKind, FrameBackend, FrameRequest, PassTimes,
    PipelineCacheState, TileLists,
};
use skeletrace_core::compile::Compiled;
use skeletrace_core::frame::Frame;
use skeletrace_core::methods::MethodId;

use crate::gpu_renderer::GpuRenderer;

/// The GPU as a frame backend.
pub struct GpuBackend {
    renderer: GpuRenderer,
}

impl GpuBackend {
    /// Opens the first adapter.
    ///
    /// # Errors
    /// [`BackendError::DeviceFailed`] when there is no adapter or device.
    pub fn new() -> Result<Self, BackendError> {
        GpuRenderer::new().map(Self::from_renderer)
    }

    /// Wraps a renderer (one built with [`GpuRenderer::with_device`], say).
    #[must_use]
    pub fn from_renderer(renderer: GpuRenderer) -> Self {
        Self { renderer }
    }

    /// The renderer, for its pass times and settings.
    #[must_use]
    pub fn renderer(&self) -> &GpuRenderer {
        &self.renderer
    }

    /// The renderer, mutably.
    pub fn renderer_mut(&mut self) -> &mut GpuRenderer {
        &mut self.renderer
    }
}

impl Capabilities for GpuBackend {
    fn device_kind(&self) -> DeviceKind {
        self.renderer.device_kind()
    }

    fn supports(
        &self,
        compiled: &Compiled,
        method: MethodId,
        request: &FrameRequest,
    ) -> Result<(), String> {
        self.renderer.supports(compiled, method, request)
    }
}

impl FrameBackend for GpuBackend {
    fn describe(&self) -> String {
        self.renderer.adapter_name().to_owned()
    }

    fn last_pass_times(&self) -> Option<PassTimes> {
        self.renderer.last_pass_times().cloned()
    }

    fn last_tile_lists(&self) -> Option<TileLists> {
        let items = self.renderer.last_tile_items();
        (items > 0).then(|| TileLists {
            items,
            tile_edge: self.renderer.tile_edge(),
        })
    }

    fn pipelines_compiled(&self) -> Option<u64> {
        Some(self.renderer.pipelines_compiled())
    }

    fn pipeline_cache(&self) -> Option<PipelineCacheState> {
        self.renderer.pipeline_cache().map(|c| PipelineCacheState {
            path: c.path().display().to_string(),
            loaded_bytes: c.loaded_bytes(),
        })
    }

    fn render(
        &mut self,
        compiled: &Arc<Compiled>,
        request: &FrameRequest,
    ) -> Result<Vec<Frame>, BackendError> {
        if self
            .renderer
            .scene()
            .is_none_or(|uploaded| !Arc::ptr_eq(uploaded, compiled))
        {
            self.renderer.set_scene(compiled)?;
        }
        self.renderer.render(request)
    }
}
