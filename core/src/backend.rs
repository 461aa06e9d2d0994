//! One interface for tracing frames: [`FrameBackend`], implemented by the CPU tracer
//! (`crate::cpu::cpu_backend::CpuBackend`) and the GPU (`skeletrace_render::GpuBackend`), and
//! [`decide`], the one place that decides which backend traces a method ([`choose`] picks the
//! backend it names), asked by `render`, `bench`, `stats` and the editor.
//!
//! Errors keep two cases apart: a backend that does not support a scene or method
//! ([`BackendError::Unsupported`], a fact about the scene) and a device that failed
//! ([`BackendError::DeviceFailed`], a fault to show the user); neither is swallowed.

use std::fmt;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::compile::Compiled;
use crate::frame::{Frame, View};
use crate::methods::{MethodId, TraceSettings};
use crate::model::scene::Camera;

/// What kind of device a backend traces on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DeviceKind {
    /// The CPU tracer (rayon threads).
    Cpu,
    /// A GPU API on a software rasteriser (Mesa's lavapipe, `wgpu::DeviceType::Cpu`).
    SoftwareGpu,
    /// A hardware GPU.
    HardwareGpu,
}

/// Which backend the user asked for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum BackendChoice {
    /// The GPU on a hardware adapter for the methods it supports on the scene, the CPU
    /// otherwise (on a software adapter the CPU tracer is faster).
    #[default]
    Auto,
    /// The GPU; a method it does not support is an error, never silently traced on the CPU.
    Gpu,
    /// The CPU tracer.
    Cpu,
}

/// Set by whoever asked for a frame once it is no longer wanted (the editor: a newer edit or
/// camera); a backend that sees it stops and answers [`BackendError::Cancelled`].
#[derive(Clone, Debug, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl Cancel {
    /// A fresh flag, not set.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Asks the backend to stop.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// Whether the frame is no longer wanted.
    #[must_use]
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

/// One frame request: a camera, a size, the methods (one frame each) and what to show.
#[derive(Clone, Debug)]
pub struct FrameRequest {
    /// The camera, always separate from the compiled scene.
    pub camera: Camera,
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Methods, one frame each, in this order.
    pub methods: Vec<MethodId>,
    /// Shaded view or step heat map.
    pub view: View,
    /// Exact shadow rays towards every light.
    pub shadows: bool,
    /// Trace settings (normally the compiled scene's).
    pub settings: TraceSettings,
    /// Set when the frame is no longer wanted (the CPU backend checks it per pixel).
    pub cancel: Cancel,
}

impl FrameRequest {
    /// Whether `other` asks for the same frames (everything but the cancel flag): the editor's
    /// frame caches key on it, beside the scene's revision.
    #[must_use]
    pub fn same_frame(&self, other: &Self) -> bool {
        self.camera == other.camera
            && self.width == other.width
            && self.height == other.height
            && self.methods == other.methods
            && self.view == other.view
            && self.shadows == other.shadows
            && self.settings == other.settings
    }
}

/// How long the last frame's passes ran on the device, from GPU timestamp queries: the
/// wall-clock frame time also holds submissions, the readback and the conversion to
/// [`Frame`]s, which dominate on a fast GPU.
#[derive(Clone, Debug, PartialEq)]
pub struct PassTimes {
    /// Counting and filling the tile lists, in milliseconds.
    pub binning_ms: f64,
    /// One trace pass per method, in the order asked, in milliseconds.
    pub trace_ms: Vec<f64>,
}

/// The screen-tile lists a GPU frame traced from (`docs/gpu.md`): their size is what a frame
/// of many primitives runs into first (one storage binding holds them, at most 2 GB on Vulkan).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileLists {
    /// (primitive, tile) pairs in the lists.
    pub items: u64,
    /// Edge of the tiles in pixels: 4, wider where the lists did not fit one binding.
    pub tile_edge: u32,
}

impl TileLists {
    /// Bytes the lists' items take (one `u32` each).
    #[must_use]
    pub fn bytes(&self) -> u64 {
        self.items * 4
    }
}

/// Why a backend gave no frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BackendError {
    /// The backend has no implementation for this scene, method or option.
    Unsupported(String),
    /// The device failed (lost, out of memory, a shader that did not build): a fault.
    DeviceFailed(String),
    /// The request was cancelled before its frames were done.
    Cancelled,
}

impl fmt::Display for BackendError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Unsupported(why) => write!(f, "not supported: {why}"),
            Self::DeviceFailed(why) => write!(f, "device failed: {why}"),
            Self::Cancelled => write!(f, "cancelled"),
        }
    }
}

impl std::error::Error for BackendError {}

/// What a backend says about a frame before tracing it: the device it traces on and whether it
/// can trace a method of a request. [`decide`] asks this of the GPU, whether it is a
/// [`FrameBackend`] (the command line, the editor's render thread) or the editor's GPU
/// viewport, so that every caller decides the same way.
pub trait Capabilities {
    /// What the backend traces on.
    fn device_kind(&self) -> DeviceKind;

    /// `Err` with the reason when this backend cannot trace `method` on `compiled` with the
    /// options of `request`.
    ///
    /// # Errors
    /// What the backend lacks.
    fn supports(
        &self,
        compiled: &Compiled,
        method: MethodId,
        request: &FrameRequest,
    ) -> Result<(), String>;
}

/// A persistent pipeline cache as a backend opened it.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct PipelineCacheState {
    /// Its file.
    pub path: String,
    /// Bytes of compiled pipelines it started from: 0 when cold.
    pub loaded_bytes: u64,
}

/// A way of tracing frames of a compiled scene.
pub trait FrameBackend: Capabilities {
    /// The device in words (adapter name, or the CPU with its threads).
    fn describe(&self) -> String;

    /// The device's own time for the passes of the last frame, where the backend measures it
    /// (GPU timestamp queries); `None` otherwise.
    fn last_pass_times(&self) -> Option<PassTimes> {
        None
    }

    /// The tile lists of the last frame, where the backend bins into screen tiles and read
    /// their size back (the GPU, for frames it reads back); `None` otherwise.
    fn last_tile_lists(&self) -> Option<TileLists> {
        None
    }

    /// Pipelines the backend has compiled since it was opened, where it compiles any (the
    /// GPU's trace pipelines); `None` otherwise.
    fn pipelines_compiled(&self) -> Option<u64> {
        None
    }

    /// The pipeline cache the backend keeps across runs, as it was when it opened; `None`
    /// where it keeps none.
    fn pipeline_cache(&self) -> Option<PipelineCacheState> {
        None
    }

    /// Traces one frame per method of `request`.
    ///
    /// # Errors
    /// [`BackendError::Unsupported`] for a method or option the backend lacks,
    /// [`BackendError::DeviceFailed`] when the device fails.
    fn render(
        &mut self,
        compiled: &Arc<Compiled>,
        request: &FrameRequest,
    ) -> Result<Vec<Frame>, BackendError>;
}

/// Where a method's frames are traced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// The CPU tracer.
    Cpu,
    /// The GPU.
    Gpu,
}

/// The one decision of which side traces `method` on `compiled` for `choice`: the CPU; the
/// GPU (`gpu`: what the opened GPU says of itself, or why none could be opened); or under
/// [`BackendChoice::Auto`] the GPU on a hardware adapter when it supports the method here,
/// the CPU otherwise. `render`, `bench`, `stats`, the editor's render thread, its method
/// labels and its GPU viewport all ask it.
///
/// # Errors
/// Under [`BackendChoice::Gpu`]: [`BackendError::DeviceFailed`] when no GPU could be opened,
/// [`BackendError::Unsupported`] when the GPU does not support the method here.
pub fn decide(
    choice: BackendChoice,
    gpu: Result<&dyn Capabilities, &str>,
    compiled: &Compiled,
    method: MethodId,
    request: &FrameRequest,
) -> Result<Side, BackendError> {
    match choice {
        BackendChoice::Cpu => Ok(Side::Cpu),
        BackendChoice::Gpu => {
            let gpu = gpu.map_err(|why| BackendError::DeviceFailed(why.to_owned()))?;
            gpu.supports(compiled, method, request)
                .map_err(|why| BackendError::Unsupported(format!("{method} on the GPU: {why}")))?;
            Ok(Side::Gpu)
        }
        BackendChoice::Auto => match gpu {
            Ok(gpu)
                if gpu.device_kind() == DeviceKind::HardwareGpu
                    && gpu.supports(compiled, method, request).is_ok() =>
            {
                Ok(Side::Gpu)
            }
            _ => Ok(Side::Cpu),
        },
    }
}

/// The backend that traces `method` for `choice`, as [`decide`] decides: `gpu` is the opened
/// GPU backend, or why none could be opened.
///
/// # Errors
/// As [`decide`].
pub fn choose<'a>(
    choice: BackendChoice,
    gpu: Result<&'a mut dyn FrameBackend, &str>,
    cpu: &'a mut dyn FrameBackend,
    compiled: &Compiled,
    method: MethodId,
    request: &FrameRequest,
) -> Result<&'a mut dyn FrameBackend, BackendError> {
    let capabilities = match &gpu {
        Ok(g) => Ok(&**g as &dyn Capabilities),
        Err(why) => Err(*why),
    };
    match (
        decide(choice, capabilities, compiled, method, request)?,
        gpu,
    ) {
        (Side::Gpu, Ok(gpu)) => Ok(gpu),
        _ => Ok(cpu),
    }
}
