//! skeletrace-render: the wgpu backend (DESIGN.md, "GPU backend"). A scene's field program is
//! packed into storage buffers ([`buffers`]); a compute pass bins primitive supports into
//! screen tiles (the analogue of the scalis 2021 A-buffer); one compute shader per method,
//! composed from WGSL files ([`shaders`]), traces every pixel against its tile's supports
//! sorted by entry, and writes colour, depth and steps ([`renderer`]). The CPU tracer of
//! skeletrace-core is the reference these frames are compared with.

pub mod buffers;
pub mod renderer;
pub mod shaders;

pub use renderer::{GpuRenderer, PassTimes, View};
pub use shaders::GpuMethod;
