//! The CPU [`FrameBackend`]: every method, every scene, traced by [`Renderer`] on rayon
//! threads. It is the reference the GPU's frames are compared with.

use std::sync::Arc;

use crate::backend::{BackendError, DeviceKind, FrameBackend, FrameRequest};
use crate::compile::Compiled;
use crate::cpu::renderer::{RenderOptions, Renderer};
use crate::frame::{FieldShading, Frame, View, heat_colour};
use crate::methods::MethodId;

/// The CPU tracer as a frame backend.
#[derive(Clone, Copy, Debug, Default)]
pub struct CpuBackend;

impl FrameBackend for CpuBackend {
    fn describe(&self) -> String {
        format!("CPU, {} threads", rayon::current_num_threads())
    }

    fn device_kind(&self) -> DeviceKind {
        DeviceKind::Cpu
    }

    fn supports(
        &self,
        compiled: &Compiled,
        method: MethodId,
        _request: &FrameRequest,
    ) -> Result<(), String> {
        method.method().supports(&compiled.program)
    }

    fn render(
        &mut self,
        compiled: &Arc<Compiled>,
        request: &FrameRequest,
    ) -> Result<Vec<Frame>, BackendError> {
        let shading = match request.view {
            View::Shaded(shading) => shading,
            View::Steps { .. } => FieldShading::default(),
        };
        let options = RenderOptions {
            width: request.width,
            height: request.height,
            shadows: request.shadows,
            shading,
        };
        let mut frames = Vec::with_capacity(request.methods.len());
        for &id in &request.methods {
            let method = id.method();
            method
                .supports(&compiled.program)
                .map_err(|why| BackendError::Unsupported(format!("{id}: {why}")))?;
            let tracer = method.prepare(&compiled.program, request.settings);
            let mut frame = Renderer::new(compiled, tracer.as_ref(), request.settings)
                .render_unless_cancelled(&request.camera, options, &request.cancel)
                .ok_or(BackendError::Cancelled)?;
            if let View::Steps { steps_max } = request.view {
                let top = f64::from(steps_max.max(1));
                for (colour, &steps) in frame.colour.iter_mut().zip(&frame.steps) {
                    *colour = heat_colour(f64::from(steps) / top);
                }
            }
            frames.push(frame);
        }
        Ok(frames)
    }
}
