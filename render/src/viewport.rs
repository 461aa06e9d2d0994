//! The editor's GPU viewport (issue 19): frames traced on the window's own device and drawn
//! straight from the trace's colour output by a render pass, with no readback and no CPU copy.
//! [`ViewportPainter`] lives in egui_wgpu's callback resources; the editor's paint callback asks
//! it to [`ViewportPainter::prepare`] a frame (uploading only what an edit changed, tracing only
//! when the camera, the scene, the size or the method changed) and to [`ViewportPainter::paint`]
//! it into the viewport's rectangle (`shaders/viewport_blit.wgsl`).

use std::sync::Arc;

use skeletrace_core::backend::BackendError;
use skeletrace_core::compile::Compiled;
use skeletrace_core::frame::View;
use skeletrace_core::methods::TraceSettings;
use skeletrace_core::model::scene::Camera;

use crate::gpu_renderer::{GpuRenderer, entry};
use crate::shaders::GpuMethod;

const BLIT: &str = include_str!("../shaders/viewport_blit.wgsl");

/// What a viewport frame depends on: the same key traces nothing again.
#[derive(Clone, Debug)]
pub struct ViewportFrame {
    /// The compiled scene (compared by identity: one compile per edit).
    pub compiled: Arc<Compiled>,
    /// Method of the shaded view.
    pub method: GpuMethod,
    /// The camera.
    pub camera: Camera,
    /// Trace settings.
    pub settings: TraceSettings,
    /// Frame size in pixels.
    pub size: (u32, u32),
    /// Shaded or steps.
    pub view: View,
}

impl ViewportFrame {
    fn same_as(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.compiled, &other.compiled)
            && self.method == other.method
            && self.camera == other.camera
            && self.settings == other.settings
            && self.size == other.size
            && self.view == other.view
    }
}

/// The GPU renderer on the window's device, the pipeline that draws its output, and what the
/// last frame was.
pub struct ViewportPainter {
    renderer: GpuRenderer,
    blit: wgpu::RenderPipeline,
    uniforms: wgpu::Buffer,
    bind_group: Option<wgpu::BindGroup>,
    srgb_target: bool,
    last: Option<ViewportFrame>,
    traced: u64,
    failure: Option<String>,
}

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
            source: wgpu::ShaderSource::Wgsl(BLIT.into()),
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
            size: 16,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Ok(Self {
            renderer,
            blit,
            uniforms,
            bind_group: None,
            srgb_target: format.is_srgb(),
            last: None,
            traced: 0,
            failure: None,
        })
    }

    /// Records the trace of `frame` into `encoder` unless the last frame was the same; uploads
    /// the scene first when it is not the one on the device (only the primitives an edit
    /// changed are written). A failure is kept for [`ViewportPainter::failure`] and nothing is
    /// drawn until the next frame that succeeds.
    pub fn prepare(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        frame: &ViewportFrame,
    ) {
        if self.last.as_ref().is_some_and(|l| l.same_as(frame)) && self.bind_group.is_some() {
            return;
        }
        self.bind_group = None;
        self.last = None;
        match self.trace(queue, encoder, frame) {
            Ok(()) => {
                self.failure = None;
                self.last = Some(frame.clone());
                self.traced += 1;
            }
            Err(e) => self.failure = Some(e.to_string()),
        }
    }

    fn trace(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        frame: &ViewportFrame,
    ) -> Result<(), BackendError> {
        let uploaded = self
            .renderer
            .scene()
            .is_some_and(|s| Arc::ptr_eq(s, &frame.compiled));
        if !uploaded {
            self.renderer.set_scene(&frame.compiled)?;
        }
        self.renderer.encode_frame(
            encoder,
            frame.method,
            &frame.camera,
            &frame.settings,
            frame.size,
            frame.view,
        )?;
        let (colour, _) = self
            .renderer
            .colour_output()
            .ok_or_else(|| BackendError::DeviceFailed("no colour output".to_owned()))?;
        let uniforms = [frame.size.0, frame.size.1, u32::from(self.srgb_target), 0];
        queue.write_buffer(&self.uniforms, 0, bytemuck::cast_slice(&uniforms));
        self.bind_group = Some(self.renderer.device().create_bind_group(
            &wgpu::BindGroupDescriptor {
                label: Some("viewport blit"),
                layout: &self.blit.get_bind_group_layout(0),
                entries: &[entry(0, &self.uniforms), entry(1, colour)],
            },
        ));
        Ok(())
    }

    /// Draws the last prepared frame over the render pass's viewport.
    pub fn paint(&self, pass: &mut wgpu::RenderPass<'static>) {
        if let Some(group) = &self.bind_group {
            pass.set_pipeline(&self.blit);
            pass.set_bind_group(0, group, &[]);
            pass.draw(0..3, 0..1);
        }
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

    /// The adapter, as the renderer names it.
    #[must_use]
    pub fn adapter_name(&self) -> &str {
        self.renderer.adapter_name()
    }
}
