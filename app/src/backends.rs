//! The backends one process traces with: the CPU tracer, and the GPU once opened (or why it
//! could not be). `render`, `bench` and the editor's render thread all pick a backend per
//! method through [`Backends::choose`], i.e. `skeletrace_core::backend::choose`.

use std::sync::Arc;

use skeletrace_core::backend::{
    self, BackendChoice, BackendError, Capabilities, DeviceKind, FrameBackend, FrameRequest,
};
use skeletrace_core::compile::Compiled;
use skeletrace_core::cpu::cpu_backend::CpuBackend;
use skeletrace_core::frame::Frame;
use skeletrace_core::methods::MethodId;
use skeletrace_render::GpuBackend;

/// The CPU backend and the GPU backend, if one could be opened.
pub struct Backends {
    /// The CPU tracer.
    pub cpu: CpuBackend,
    /// The GPU, or why there is none (not asked for yet, no adapter, a failed device). Any
    /// `FrameBackend` fits, so that tests can put a failing one here.
    pub gpu: Result<Box<dyn FrameBackend + Send>, String>,
    /// Whether opening the GPU was tried (a failed or lost GPU is not opened again).
    gpu_tried: bool,
}

impl Backends {
    /// Opens the GPU unless `choice` is the CPU.
    #[must_use]
    pub fn open(choice: BackendChoice) -> Self {
        let mut backends = Self {
            cpu: CpuBackend::new(),
            gpu: Err("the CPU backend was chosen".to_owned()),
            gpu_tried: false,
        };
        backends.open_gpu_for(choice);
        backends
    }

    /// Opens the GPU the first time a choice other than the CPU asks for it.
    pub fn open_gpu_for(&mut self, choice: BackendChoice) {
        if choice != BackendChoice::Cpu && !self.gpu_tried {
            self.gpu_tried = true;
            self.gpu = GpuBackend::new()
                .map(|g| Box::new(g) as Box<dyn FrameBackend + Send>)
                .map_err(|e| e.to_string());
        }
    }

    /// The backend that traces `method` (see `skeletrace_core::backend::choose`).
    ///
    /// # Errors
    /// As `choose`.
    pub fn choose(
        &mut self,
        choice: BackendChoice,
        compiled: &Compiled,
        method: MethodId,
        request: &FrameRequest,
    ) -> Result<&mut dyn FrameBackend, BackendError> {
        let gpu = match &mut self.gpu {
            Ok(g) => Ok(g.as_mut() as &mut dyn FrameBackend),
            Err(why) => Err(why.as_str()),
        };
        backend::choose(choice, gpu, &mut self.cpu, compiled, method, request)
    }

    /// Drops the GPU after a device failure, keeping `why` as the reason there is none: what
    /// follows is traced on the CPU.
    pub fn lose_gpu(&mut self, why: &str) {
        self.gpu_tried = true;
        self.gpu = Err(why.to_owned());
    }
}

/// Parses a `--backend` value.
///
/// # Errors
/// The value and the accepted ones.
pub fn parse_backend_choice(text: &str) -> Result<BackendChoice, String> {
    match text {
        "auto" => Ok(BackendChoice::Auto),
        "cpu" => Ok(BackendChoice::Cpu),
        "gpu" => Ok(BackendChoice::Gpu),
        other => Err(format!(
            "unknown backend '{other}'; expected cpu, gpu or auto"
        )),
    }
}

/// A stand-in hardware GPU that supports everything and whose device fails at every frame, for
/// the tests of fault handling (the editor's render thread, `render`, `bench`): put it in
/// [`Backends::gpu`].
pub struct FailingGpu;

impl Capabilities for FailingGpu {
    fn device_kind(&self) -> DeviceKind {
        DeviceKind::HardwareGpu
    }

    fn supports(&self, _: &Compiled, _: MethodId, _: &FrameRequest) -> Result<(), String> {
        Ok(())
    }
}

impl FrameBackend for FailingGpu {
    fn describe(&self) -> String {
        "failing GPU (injected)".to_owned()
    }

    fn render(&mut self, _: &Arc<Compiled>, _: &FrameRequest) -> Result<Vec<Frame>, BackendError> {
        Err(BackendError::DeviceFailed(
            "device lost (injected)".to_owned(),
        ))
    }
}
