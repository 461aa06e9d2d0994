//! The CPU tracer: the renderer (`renderer`: primary, reflected, refracted and shadow rays),
//! the field's soft shadows and ambient occlusion (`shading`, 2014 notes §12.4) and the CPU
//! [`crate::backend::FrameBackend`] (`cpu_backend`).

pub mod cpu_backend;
pub mod renderer;
pub mod shading;
