//! skeletrace-render: the wgpu backend (DESIGN.md, "GPU backend"; `docs/gpu.md`). A compiled
//! scene is packed into storage buffers ([`buffers`]); a compute pass bins primitive supports
//! into screen tiles (the analogue of the scalis 2021 A-buffer); one compute shader per method,
//! composed from WGSL files ([`shaders`]), traces every pixel against its tile's supports
//! sorted by entry, and writes colour, depth and steps ([`gpu_renderer`]). [`gpu_backend::GpuBackend`]
//! is the GPU's `FrameBackend`. The CPU tracer of skeletrace-core is the reference these
//! frames are compared with.

pub mod async_readback;
pub mod blend_wgsl;
pub mod buffers;
pub mod gpu_backend;
pub mod gpu_renderer;
pub mod gpu_stats;
pub mod gpu_support;
#[cfg(test)]
mod layout_tests;
pub mod pipeline_cache;
pub mod ray_bvh;
pub mod ray_lists;
pub mod shaders;
pub mod shared;
pub mod step_statistics;
pub mod tile_binning;
pub mod viewport;
mod wgpu_util;

pub use gpu_backend::GpuBackend;
pub use gpu_renderer::GpuRenderer;
pub use gpu_support::GpuOfKind;
pub use shaders::GpuMethod;
/// The wgpu the renderer is built on, for naming its types (the adapter's graphics API).
pub use wgpu;
