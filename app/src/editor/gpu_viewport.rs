//! The viewport and the comparison grid traced on the window's own GPU: an
//! `egui_wgpu` paint callback asks the [`ViewportPainter`] in the renderer's callback resources
//! to trace the frame into its output buffers and draw it into the viewport's rectangle, or each
//! method's heat map into its grid panel, with no readback of a frame and no texture upload; an
//! edit uploads only the primitives it changed. The grid's step statistics and the hovered
//! pixel's counts are counted on the GPU and read back a frame or two later (a few kilobytes).
//! Taken on a hardware adapter when the GPU runs every method shown on the scene and the
//! backend choice allows it; the render thread (the CPU, or a GPU frame read back) serves
//! everything else: software adapters, shadow rays, methods the GPU lacks.
//! `SKELETRACE_GPU_VIEWPORT=1` takes the path on a software adapter too (tests on lavapipe).

use eframe::egui;
use eframe::egui_wgpu::{self, CallbackResources, CallbackTrait, RenderState};
use eframe::wgpu;
use skeletrace_core::Compiled;
use skeletrace_core::backend::{
    BackendChoice, Capabilities, DeviceKind, FrameRequest, Side, decide,
};
use skeletrace_core::frame::{StepScale, View};
use skeletrace_core::methods::MethodId;
use skeletrace_render::GpuRenderer;
use skeletrace_render::step_statistics::GridStatistics;
use skeletrace_render::viewport::{ViewportFrame, ViewportPainter};

use super::Editor;

/// The paint callback of one viewport frame or comparison grid.
struct ViewportCallback {
    frame: ViewportFrame,
    /// Where each panel goes, in window points (the shaded view is one panel).
    panels: Vec<egui::Rect>,
    scale: StepScale,
    /// The hovered pixel of a grid panel, whose counts are read back.
    probe: Option<(u32, u32)>,
}

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
            painter.prepare(queue, encoder, &self.frame, self.scale, self.probe);
        }
        Vec::new()
    }

    fn paint(
        &self,
        info: egui::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &CallbackResources,
    ) {
        let ppp = info.pixels_per_point;
        let [screen_w, screen_h] = info.screen_size_px.map(|v| v as f32);
        // Physical pixels, inside the render target as wgpu's viewports must be.
        let panels: Vec<[f32; 4]> = self
            .panels
            .iter()
            .map(|r| {
                let (x0, y0) = ((r.left() * ppp).max(0.0), (r.top() * ppp).max(0.0));
                let (x1, y1) = (
                    (r.right() * ppp).min(screen_w),
                    (r.bottom() * ppp).min(screen_h),
                );
                [x0, y0, (x1 - x0).max(0.0), (y1 - y0).max(0.0)]
            })
            .collect();
        if let Some(painter) = resources.get::<ViewportPainter>() {
            painter.paint(pass, &panels);
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

/// The window's GPU as the backend decision sees it: a viewport is enabled on a hardware
/// adapter, or on a software one taken as a hardware one would be (`SKELETRACE_GPU_VIEWPORT=1`),
/// so it answers as a hardware GPU; what it supports is its renderer's answer.
struct WindowGpu<'a>(&'a GpuRenderer);

impl Capabilities for WindowGpu<'_> {
    fn device_kind(&self) -> DeviceKind {
        DeviceKind::HardwareGpu
    }

    fn supports(
        &self,
        compiled: &Compiled,
        method: MethodId,
        request: &FrameRequest,
    ) -> Result<(), String> {
        self.0.supports(compiled, method, request)
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
        self.view.gpu_viewport = Some(render_state.clone());
        Ok(())
    }

    /// Frames the GPU viewport traced so far, the primitive bytes it uploaded and the adapter;
    /// `None` without a GPU viewport.
    #[must_use]
    pub fn gpu_viewport_counts(&self) -> Option<(u64, u64, String)> {
        self.with_viewport_painter(|painter| {
            (
                painter.traced(),
                painter.uploaded_primitive_bytes(),
                painter.adapter_name().to_owned(),
            )
        })
    }

    /// Whether the GPU viewport is still checking its last frame's tile lists (and may trace
    /// it again), or compiling the pipelines of the frame asked for.
    #[must_use]
    pub fn gpu_viewport_settling(&self) -> bool {
        self.with_viewport_painter(ViewportPainter::settling)
            .unwrap_or(false)
    }

    /// Whether the GPU viewport waits for the pipelines of the frame asked for, compiled off
    /// the window's thread (the render thread's CPU frame of the scene is shown meanwhile).
    #[must_use]
    pub fn gpu_viewport_compiling(&self) -> bool {
        self.with_viewport_painter(ViewportPainter::compiling)
            .unwrap_or(false)
    }

    fn with_viewport_painter<T>(&self, f: impl FnOnce(&ViewportPainter) -> T) -> Option<T> {
        let state = self.view.gpu_viewport.as_ref()?;
        let renderer = state.renderer.read();
        renderer.callback_resources.get::<ViewportPainter>().map(f)
    }

    /// The GPU viewport's frame of what the window shows ([`Editor::view_request`]) in `view`
    /// at `size`, when it takes this frame: a GPU viewport exists, its last frame did not fail,
    /// and the backend decision (`skeletrace_core::backend::decide`, asked of the window's
    /// GPU) puts every method on the GPU.
    pub(super) fn gpu_viewport_frame(
        &mut self,
        view: View,
        size: (u32, u32),
    ) -> Option<ViewportFrame> {
        let state = self.view.gpu_viewport.as_ref()?;
        let request = FrameRequest {
            view,
            ..self.view_request((size.0.max(1) as usize, size.1.max(1) as usize))
        };
        if self.ui_state.backend == BackendChoice::Cpu || request.methods.is_empty() {
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
            self.view.gpu_viewport = None;
            return None;
        }
        let compiled = self.doc.compiled();
        let choice = self.ui_state.backend;
        let on_gpu = self.with_viewport_painter(|painter| {
            let window = WindowGpu(painter.renderer());
            request
                .methods
                .iter()
                .all(|&m| decide(choice, Ok(&window), &compiled, m, &request) == Ok(Side::Gpu))
        })?;
        on_gpu.then_some(ViewportFrame { compiled, request })
    }

    /// [`Editor::gpu_viewport_frame`] split by whether the GPU viewport draws it now:
    /// `(drawn, compiling)`. While the GPU viewport compiles the frame's pipelines (a new blend
    /// structure or primitive kind), the frame is `compiling`, for [`Editor::keep_compiling`],
    /// and the view is traced by the render thread on the CPU meanwhile. Notes which of the two
    /// the view shows.
    pub(super) fn gpu_viewport_frame_or_compiling(
        &mut self,
        view: View,
        size: (u32, u32),
    ) -> (Option<ViewportFrame>, Option<ViewportFrame>) {
        let frame = self.gpu_viewport_frame(view, size);
        let compiling = frame.is_some() && self.gpu_viewport_compiling();
        self.view.gpu_compiling = compiling;
        self.view.viewport_on_gpu = frame.is_some() && !compiling;
        if compiling {
            (None, frame)
        } else {
            (frame, None)
        }
    }

    /// Hands `frame`, whose pipelines the GPU viewport compiles, to its paint callback, which
    /// polls the compilation and draws nothing until it traces the frame.
    pub(super) fn keep_compiling(
        &self,
        painter: &egui::Painter,
        area: egui::Rect,
        frame: ViewportFrame,
    ) {
        self.paint_gpu_viewport(painter, area, frame, Vec::new(), (StepScale::Log, None));
    }

    /// The comparison grid's statistics the GPU viewport read back last, and whether they are
    /// those of the frame on screen with the hovered pixel's counts.
    #[must_use]
    pub fn gpu_grid_statistics(&self) -> Option<(GridStatistics, bool)> {
        let probe = self.view.hovered_pixel.map(|(u, v)| (u as u32, v as u32));
        self.with_viewport_painter(|painter| {
            let (published, current) = painter.statistics(probe);
            published.map(|p| (p.clone(), current))
        })
        .flatten()
    }

    /// Adds the paint callback of `frame` over `area`, panel `k` drawn into `panels[k]`; asks
    /// for another frame while the last one's tile lists are being checked, and every 50 ms
    /// while its pipelines compile or until the painter has taken it up (it may start
    /// compiling pipelines for it).
    pub(super) fn paint_gpu_viewport(
        &self,
        painter: &egui::Painter,
        area: egui::Rect,
        frame: ViewportFrame,
        panels: Vec<egui::Rect>,
        (scale, probe): (StepScale, Option<(u32, u32)>),
    ) {
        let taken_up = self
            .with_viewport_painter(|p| p.last_is(&frame))
            .unwrap_or(true);
        if self.gpu_viewport_compiling() || !taken_up {
            painter
                .ctx()
                .request_repaint_after(std::time::Duration::from_millis(50));
        } else if self.gpu_viewport_settling() {
            painter.ctx().request_repaint();
        }
        painter.add(egui_wgpu::Callback::new_paint_callback(
            area,
            ViewportCallback {
                frame,
                panels,
                scale,
                probe,
            },
        ));
    }
}
