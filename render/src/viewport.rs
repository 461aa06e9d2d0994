//! The editor's GPU viewport: frames traced on the window's own device and drawn
//! straight from the trace's outputs by a render pass, with no readback and no CPU copy.
//! [`ViewportPainter`] lives in egui_wgpu's callback resources; the editor's paint callback asks
//! it to [`ViewportPainter::prepare`] a frame (uploading only what an edit changed, tracing only
//! when the camera, the scene, the size or the methods changed) and to
//! [`ViewportPainter::paint`] it into the viewport's rectangle, or each method's heat map into
//! its panel of the comparison grid (`shaders/viewport_blit.wgsl`). A grid's step statistics
//! are counted on the GPU and only they are read back ([`crate::step_statistics`]).

use std::sync::Arc;

use skeletrace_core::backend::{BackendError, FrameRequest};
use skeletrace_core::compile::Compiled;
use skeletrace_core::frame::{StepScale, View};

use crate::gpu_renderer::GpuRenderer;
use crate::gpu_support::gpu_methods;
use crate::shaders::blit_source;
use crate::step_statistics::{GridStatistics, StatisticsShape, StatisticsTag, StepStatistics};
use crate::wgpu_util::entry;

/// A viewport frame: the compiled scene and the request, the same one the CPU and the GPU
/// backends take. The same frame again traces nothing.
#[derive(Clone, Debug)]
pub struct ViewportFrame {
    /// The compiled scene (compared by identity: one compile per edit).
    pub compiled: Arc<Compiled>,
    /// The shaded view's method, or the grid's methods (panels side by side), the camera, the
    /// size of each panel, the view and the trace settings.
    pub request: FrameRequest,
}

impl ViewportFrame {
    fn same_as(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.compiled, &other.compiled) && self.request.same_frame(&other.request)
    }
}

/// The GPU renderer on the window's device, the pipeline that draws its output, and what the
/// last frame was.
pub struct ViewportPainter {
    renderer: GpuRenderer,
    blit: wgpu::RenderPipeline,
    uniforms: wgpu::Buffer,
    /// Bound as the colour scale's top while no comparison was counted.
    no_top: wgpu::Buffer,
    bind_group: Option<wgpu::BindGroup>,
    srgb_target: bool,
    statistics: StepStatistics,
    last: Option<ViewportFrame>,
    traced: u64,
    failure: Option<String>,
    /// The frame asked for waits for its pipelines, compiled off the window's thread; nothing
    /// is drawn meanwhile (the editor shows the render thread's frame of the new scene).
    compiling: bool,
}

/// Bytes of the blit's uniforms (viewport_blit.wgsl `Blit`).
const BLIT_UNIFORM_BYTES: u64 = 32;

impl ViewportPainter {
    /// A painter on `device`, drawing into targets of `format`.
    ///
    /// # Errors
    /// When the GPU renderer cannot be built on the device.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        info: &wgpu::AdapterInfo,
        format: wgpu::TextureFormat,
    ) -> Result<Self, BackendError> {
        let renderer = GpuRenderer::with_device(device.clone(), queue.clone(), info)?;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("viewport blit"),
            source: wgpu::ShaderSource::Wgsl(blit_source().into()),
        });
        let blit = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("viewport blit"),
            layout: None,
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: wgpu::PipelineCompilationOptions::default(),
                buffers: &[],
            },
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: wgpu::PipelineCompilationOptions::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            multiview_mask: None,
            cache: None,
        });
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("viewport blit"),
            size: BLIT_UNIFORM_BYTES,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let no_top = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("no step top"),
            size: 4,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        Ok(Self {
            statistics: StepStatistics::new(device),
            renderer,
            blit,
            uniforms,
            no_top,
            bind_group: None,
            srgb_target: format.is_srgb(),
            last: None,
            traced: 0,
            failure: None,
            compiling: false,
        })
    }

    /// Records the trace of `frame` into `encoder` unless the last frame was the same; uploads
    /// the scene first when it is not the one on the device (only the primitives an edit
    /// changed are written). A comparison's heat maps are drawn on `scale`, and its statistics
    /// (with the counts at pixel `probe` of a panel) are read back over the next frames
    /// ([`ViewportPainter::statistics`]). A failure is kept for [`ViewportPainter::failure`]
    /// and nothing is drawn until the next frame that succeeds.
    pub fn prepare(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        frame: &ViewportFrame,
        scale: StepScale,
        probe: Option<(u32, u32)>,
    ) {
        let _ = self.renderer.device().poll(wgpu::PollType::Poll);
        self.statistics.poll();
        match self.renderer.poll_tile_lists(encoder) {
            // The frame on screen missed part of its tile lists: traced again, in full.
            Ok(true) => self.last = None,
            Ok(false) => {}
            Err(e) => {
                self.failure = Some(e);
                self.bind_group = None;
                return;
            }
        }
        let same = self.last.as_ref().is_some_and(|l| l.same_as(frame));
        if !same || self.bind_group.is_none() {
            // A new blend structure or primitive kind, or a method not shown before, needs
            // pipelines, which the driver takes seconds to compile: they are compiled on
            // threads of their own, and the window draws the render thread's frames of the new
            // scene instead of waiting for them.
            match self.pipelines_compiling(frame) {
                Ok(true) => {
                    self.compiling = true;
                    return;
                }
                Ok(false) => self.compiling = false,
                Err(e) => {
                    self.compiling = false;
                    self.failure = Some(e.to_string());
                    self.bind_group = None;
                    return;
                }
            }
            self.bind_group = None;
            self.last = None;
            match self.trace(queue, encoder, frame) {
                Ok(()) => {
                    self.failure = None;
                    self.last = Some(frame.clone());
                    self.traced += 1;
                }
                Err(e) => {
                    self.failure = Some(e.to_string());
                    return;
                }
            }
        }
        let request = &frame.request;
        let mode = match (request.view, scale) {
            (View::Shaded(_), _) => 0_u32,
            (View::Steps { .. }, StepScale::Log) => 1,
            (View::Steps { .. }, StepScale::Linear) => 2,
        };
        let panels = request.methods.len() as u32;
        let uniforms = [
            request.width as u32,
            request.height as u32,
            panels,
            mode,
            u32::from(self.srgb_target),
            0,
            0,
            0,
        ];
        queue.write_buffer(&self.uniforms, 0, bytemuck::cast_slice(&uniforms));
        if matches!(request.view, View::Steps { .. })
            && let Some((_, steps)) = self.renderer.output_buffers()
        {
            let tag = StatisticsTag {
                frame: self.traced,
                probe,
            };
            self.statistics.request(encoder, steps, tag);
        }
    }

    /// Uploads `frame`'s scene where it is not the one on the device, and whether its methods'
    /// pipelines are still being compiled ([`GpuRenderer::pipelines_compiling`]).
    fn pipelines_compiling(&mut self, frame: &ViewportFrame) -> Result<bool, BackendError> {
        let uploaded = self
            .renderer
            .scene()
            .is_some_and(|s| Arc::ptr_eq(s, &frame.compiled));
        if !uploaded {
            self.renderer.set_scene(&frame.compiled)?;
        }
        let methods = gpu_methods(&frame.request.methods)?;
        Ok(self.renderer.pipelines_compiling(&methods))
    }

    fn trace(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        frame: &ViewportFrame,
    ) -> Result<(), BackendError> {
        let request = &frame.request;
        self.renderer.encode_frame(encoder, request)?;
        let (colour, steps) = self
            .renderer
            .output_buffers()
            .ok_or_else(|| BackendError::DeviceFailed("no trace output".to_owned()))?;
        let top = if matches!(request.view, View::Steps { .. }) {
            let shape = StatisticsShape {
                width: request.width as u32,
                height: request.height as u32,
                panels: request.methods.len() as u32,
                bins: request.settings.max_steps + 1,
            };
            let device = self.renderer.device();
            self.statistics.encode(device, queue, encoder, steps, shape);
            self.statistics.top_buffer().unwrap_or(&self.no_top)
        } else {
            &self.no_top
        };
        self.bind_group = Some(self.renderer.device().create_bind_group(
            &wgpu::BindGroupDescriptor {
                label: Some("viewport blit"),
                layout: &self.blit.get_bind_group_layout(0),
                entries: &[
                    entry(0, &self.uniforms),
                    entry(1, colour),
                    entry(2, steps),
                    entry(3, top),
                ],
            },
        ));
        Ok(())
    }

    /// Draws the last prepared frame: panel `k` into `panels[k]`, a rectangle `[x, y, width,
    /// height]` in physical pixels of the render target (the shaded view is one panel).
    pub fn paint(&self, pass: &mut wgpu::RenderPass<'static>, panels: &[[f32; 4]]) {
        let Some(group) = self.bind_group.as_ref().filter(|_| !self.compiling) else {
            return;
        };
        let count = self.last.as_ref().map_or(0, |f| f.request.methods.len());
        pass.set_pipeline(&self.blit);
        pass.set_bind_group(0, group, &[]);
        for (k, &[x, y, w, h]) in panels.iter().enumerate().take(count) {
            if w >= 1.0 && h >= 1.0 {
                pass.set_viewport(x, y, w, h, 0.0, 1.0);
                pass.draw(0..3, k as u32..k as u32 + 1);
            }
        }
    }

    /// The latest step statistics of a comparison read back, and whether they describe the
    /// frame on screen with the probe asked for (if not, newer ones are on their way: keep
    /// repainting).
    #[must_use]
    pub fn statistics(&self, probe: Option<(u32, u32)>) -> (Option<&GridStatistics>, bool) {
        let published = self.statistics.published();
        let current = published.is_some_and(|p| {
            p.tag
                == StatisticsTag {
                    frame: self.traced,
                    probe,
                }
        });
        (published, current)
    }

    /// Whether a frame's tile lists are still to be checked, or the frame asked for waits for
    /// its pipelines: the window should draw again soon, for a frame that missed part of its
    /// lists is traced again, and a waiting one is traced once they are compiled.
    #[must_use]
    pub fn settling(&self) -> bool {
        self.renderer.tile_lists_unchecked() || self.compiling
    }

    /// Whether `frame` is the frame traced last (its scene and request).
    #[must_use]
    pub fn last_is(&self, frame: &ViewportFrame) -> bool {
        self.last.as_ref().is_some_and(|l| l.same_as(frame))
    }

    /// Whether the frame asked for last waits for its pipelines (nothing is drawn meanwhile:
    /// the editor shows the render thread's frame of the new scene).
    #[must_use]
    pub fn compiling(&self) -> bool {
        self.compiling
    }

    /// Frames traced so far (a frame whose key did not change is not traced again).
    #[must_use]
    pub fn traced(&self) -> u64 {
        self.traced
    }

    /// Why the last frame could not be traced, if it could not.
    #[must_use]
    pub fn failure(&self) -> Option<&str> {
        self.failure.as_deref()
    }

    /// Primitive bytes uploaded so far (only what edits changed after the first upload).
    #[must_use]
    pub fn uploaded_primitive_bytes(&self) -> u64 {
        self.renderer.uploaded_primitive_bytes()
    }

    /// The renderer the painter traces with (what it supports: its `Capabilities`).
    #[must_use]
    pub fn renderer(&self) -> &GpuRenderer {
        &self.renderer
    }

    /// The adapter, as the renderer names it.
    #[must_use]
    pub fn adapter_name(&self) -> &str {
        self.renderer.adapter_name()
    }
}
