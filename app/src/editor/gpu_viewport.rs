//! The shaded viewport traced on the window's own GPU (issue 19): an `egui_wgpu` paint callback
//! asks the [`ViewportPainter`] in the renderer's callback resources to trace the frame into its
//! output buffer and draw it into the viewport's rectangle, with no readback and no texture
//! upload; an edit uploads only the primitives it changed. Taken on a hardware adapter when
//! the GPU runs the shaded method on the scene and the backend choice allows it; the render
//! thread (the CPU, or a GPU frame read back) serves everything else: software adapters, the
//! comparison grid, shadow rays, methods the GPU lacks. `SKELETRACE_GPU_VIEWPORT=1` takes the
//! path on a software adapter too (tests on lavapipe).

use eframe::egui;
use eframe::egui_wgpu::{self, CallbackResources, CallbackTrait, RenderState};
use eframe::wgpu;
use skeletrace_core::backend::BackendChoice;
use skeletrace_core::frame::View;
use skeletrace_render::GpuMethod;
use skeletrace_render::viewport::{ViewportFrame, ViewportPainter};

use super::Editor;

/// The paint callback of one viewport frame.
struct ViewportCallback(ViewportFrame);

impl CallbackTrait for ViewportCallback {
    fn prepare(
        &self,
        _device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen: &egui_wgpu::ScreenDescriptor,
        encoder: &mut wgpu::CommandEncoder,
        resources: &mut CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        if let Some(painter) = resources.get_mut::<ViewportPainter>() {
            painter.prepare(queue, encoder, &self.0);
        }
        Vec::new()
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &CallbackResources,
    ) {
        if let Some(painter) = resources.get::<ViewportPainter>() {
            painter.paint(pass);
        }
    }
}

/// eframe's wgpu set-up with a device the viewport can trace on
/// ([`skeletrace_render::gpu_renderer::device_descriptor`]: the adapter's limits).
#[must_use]
pub fn wgpu_configuration() -> egui_wgpu::WgpuConfiguration {
    let mut setup = egui_wgpu::WgpuSetupCreateNew::without_display_handle();
    setup.device_descriptor = std::sync::Arc::new(|adapter: &wgpu::Adapter| {
        skeletrace_render::gpu_renderer::device_descriptor(adapter)
    });
    egui_wgpu::WgpuConfiguration {
        wgpu_setup: egui_wgpu::WgpuSetup::CreateNew(setup),
        ..Default::default()
    }
}

/// Whether the window's adapter gets the GPU viewport: a hardware one, or any when
/// `SKELETRACE_GPU_VIEWPORT=1`.
#[must_use]
pub fn wanted(render_state: &RenderState) -> bool {
    render_state.adapter.get_info().device_type != wgpu::DeviceType::Cpu
        || std::env::var("SKELETRACE_GPU_VIEWPORT").is_ok_and(|v| v == "1")
}

impl Editor {
    /// Traces the shaded viewport on `render_state`'s device through a paint callback from now
    /// on, where the GPU can.
    ///
    /// # Errors
    /// When the GPU renderer cannot be built on the window's device.
    pub fn enable_gpu_viewport(&mut self, render_state: &RenderState) -> Result<(), String> {
        let painter = ViewportPainter::new(
            &render_state.device,
            &render_state.queue,
            &render_state.adapter.get_info(),
            render_state.target_format,
        )
        .map_err(|e| e.to_string())?;
        render_state
            .renderer
            .write()
            .callback_resources
            .insert(painter);
        self.gpu_viewport = Some(render_state.clone());
        Ok(())
    }

    /// Frames the GPU viewport traced so far, the primitive bytes it uploaded and the adapter;
    /// `None` without a GPU viewport.
    #[must_use]
    pub fn gpu_viewport_counts(&self) -> Option<(u64, u64, String)> {
        let state = self.gpu_viewport.as_ref()?;
        let renderer = state.renderer.read();
        let painter = renderer.callback_resources.get::<ViewportPainter>()?;
        Some((
            painter.traced(),
            painter.uploaded_primitive_bytes(),
            painter.adapter_name().to_owned(),
        ))
    }

    /// The GPU viewport's frame for the viewport as it is, when it takes this frame: a GPU
    /// viewport exists, the backend choice is not the CPU, no shadow rays are asked for, the
    /// GPU runs the shaded method on the scene and its last frame did not fail.
    pub(super) fn gpu_viewport_frame(&mut self, size: (u32, u32)) -> Option<ViewportFrame> {
        let state = self.gpu_viewport.as_ref()?;
        if self.ui_state.backend == BackendChoice::Cpu || self.ui_state.shadows {
            return None;
        }
        let failure = state
            .renderer
            .read()
            .callback_resources
            .get::<ViewportPainter>()
            .and_then(|p| p.failure().map(str::to_owned));
        if let Some(why) = failure {
            self.complain(format!("GPU viewport: {why}; tracing on the render thread"));
            self.gpu_viewport = None;
            return None;
        }
        let shaded = self.ui_state.shaded_method;
        if !self
            .method_tags()
            .iter()
            .any(|t| t.id == shaded && t.on_gpu)
        {
            return None;
        }
        let method = GpuMethod::from_id(shaded)?;
        let compiled = self.doc.compiled();
        let settings = compiled.settings;
        Some(ViewportFrame {
            compiled,
            method,
            camera: self.orbit.camera(),
            settings,
            size: (size.0.max(1), size.1.max(1)),
            view: View::Shaded(self.ui_state.shading),
        })
    }

    /// Adds the paint callback of `frame` over `rect`.
    pub(super) fn paint_gpu_viewport(
        painter: &egui::Painter,
        rect: egui::Rect,
        frame: ViewportFrame,
    ) {
        painter.add(egui_wgpu::Callback::new_paint_callback(
            rect,
            ViewportCallback(frame),
        ));
    }
}
