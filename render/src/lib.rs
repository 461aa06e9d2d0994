//! skeletrace-render: the wgpu backend (built in the GPU issue).
