//! skeletrace-render: the wgpu backend (DESIGN.md, "GPU backend"; `docs/gpu.md`). A compiled
//! scene is packed into storage buffers ([`buffers`]); a compute pass bins primitive supports
//! into screen tiles (the analogue of the scalis 2021 A-buffer); one compute shader per method,
//! composed from WGSL files ([`shaders`]), traces every pixel against its tile's supports
//! sorted by entry, and writes colour, depth and steps ([`renderer`]). [`backend::GpuBackend`]
//! is the GPU's `FrameBackend`. The CPU tracer of skeletrace-core is the reference these
//! frames are compared with.

pub mod backend;
pub mod buffers;
pub mod renderer;
pub mod shaders;
pub mod shared;

pub use backend::GpuBackend;
pub use renderer::GpuRenderer;
pub use shaders::GpuMethod;
