//! The CPU tracer: the renderer (`renderer`: primary, reflected, refracted and shadow rays),
//! the field's soft shadows and ambient occlusion (`shading`, 2014 notes §12.4), the papers'
//! statistics protocol (`stats`) and the CPU [`crate::backend::FrameBackend`] (`backend`).

pub mod cpu_backend;
pub mod renderer;
pub mod shading;
pub mod stats;
