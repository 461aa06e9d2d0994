//! The viewport's renderer thread: takes the latest render request, traces it on the GPU
//! backend or the CPU tracer, and hands the frames back with their timings, so the UI thread
//! never waits for a frame. Stale requests are dropped: only the newest one is traced.
//!
//! Backend choice: `Auto` uses the GPU for the methods with a GPU implementation for the scene
//! when the adapter is a real GPU; on a software adapter (lavapipe) the rayon CPU tracer is
//! several times faster (README, "GPU backend"), so `Auto` traces on the CPU there. Every
//! frame says where it was traced; a method the GPU cannot run is labelled CPU, never swapped
//! silently.

use std::sync::Arc;
use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;
use std::time::Instant;

use skeletrace_core::methods::{self, TraceSettings};
use skeletrace_core::render::{Frame, RenderOptions, Renderer};
use skeletrace_core::scene::Camera;
use skeletrace_core::shading::FieldShading;
use skeletrace_core::{FieldProgram, Scene};
use skeletrace_render::{GpuMethod, GpuRenderer, View};

/// Where frames are traced.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Backend {
    /// GPU on a hardware adapter, CPU otherwise.
    Auto,
    /// The GPU backend for every method it implements for the scene.
    Gpu,
    /// The CPU tracer.
    Cpu,
}

/// One render: the scene at a revision, a camera, methods and a size.
#[derive(Clone)]
pub struct Request {
    /// Identifies the request in its reply.
    pub id: u64,
    /// The scene.
    pub scene: Arc<Scene>,
    /// Camera.
    pub camera: Camera,
    /// Frame size in pixels.
    pub size: (usize, usize),
    /// Methods, one frame each.
    pub methods: Vec<String>,
    /// Backend choice.
    pub backend: Backend,
    /// Shadow rays in the shaded view (CPU only).
    pub shadows: bool,
    /// Field soft shadows and ambient occlusion in the shaded view.
    pub shading: FieldShading,
}

/// One traced frame.
pub struct Traced {
    /// Method name.
    pub method: String,
    /// The frame.
    pub frame: Frame,
    /// Traced on the GPU.
    pub on_gpu: bool,
    /// Milliseconds spent tracing it.
    pub ms: f64,
}

/// The answer to a request.
pub struct Reply {
    /// The request's id.
    pub id: u64,
    /// One entry per method that applies, in request order.
    pub frames: Vec<Traced>,
    /// Methods that do not apply to the scene, with why.
    pub skipped: Vec<String>,
    /// The GPU adapter, or why there is none.
    pub adapter: String,
}

/// Handle on the renderer thread.
pub struct RenderWorker {
    requests: Option<Sender<Request>>,
    replies: Receiver<Reply>,
    thread: Option<JoinHandle<()>>,
}

impl RenderWorker {
    /// Starts the thread; `wake` is called after each reply (to repaint the UI).
    #[must_use]
    pub fn start(wake: impl Fn() + Send + 'static) -> Self {
        let (request_tx, request_rx) = channel::<Request>();
        let (reply_tx, reply_rx) = channel();
        let thread = std::thread::Builder::new()
            .name("skeletrace-render".to_owned())
            .spawn(move || serve(&request_rx, &reply_tx, &wake))
            .ok();
        Self {
            requests: Some(request_tx),
            replies: reply_rx,
            thread,
        }
    }

    /// Queues a request (older queued ones are dropped by the thread).
    pub fn request(&self, request: Request) {
        if let Some(tx) = &self.requests {
            // A closed channel means the thread ended; the UI then shows its last frame.
            let _ = tx.send(request);
        }
    }

    /// The newest reply since the last call, if any.
    #[must_use]
    pub fn latest(&self) -> Option<Reply> {
        self.replies.try_iter().last()
    }

    /// Waits for the reply to request `id` (tests and offscreen screenshots).
    #[must_use]
    pub fn wait_for(&self, id: u64) -> Option<Reply> {
        self.replies.iter().find(|r| r.id >= id)
    }
}

impl Drop for RenderWorker {
    fn drop(&mut self) {
        self.requests = None;
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

fn serve(requests: &Receiver<Request>, replies: &Sender<Reply>, wake: &dyn Fn()) {
    let mut gpu: Option<Result<GpuRenderer, String>> = None;
    while let Ok(mut request) = requests.recv() {
        while let Ok(newer) = requests.try_recv() {
            request = newer;
        }
        let reply = trace(&request, &mut gpu);
        if replies.send(reply).is_err() {
            return;
        }
        wake();
    }
}

fn trace(request: &Request, gpu: &mut Option<Result<GpuRenderer, String>>) -> Reply {
    let scene = request.scene.as_ref();
    let program = FieldProgram::new(scene);
    let settings = TraceSettings::for_program(&program);
    let mut frames = Vec::new();
    let mut skipped = Vec::new();
    let wants_gpu = request.backend != Backend::Cpu;
    if wants_gpu && gpu.is_none() {
        *gpu = Some(GpuRenderer::new());
    }
    let adapter = match gpu.as_ref() {
        Some(Ok(g)) => g.adapter_name().to_owned(),
        Some(Err(why)) => format!("no GPU ({why})"),
        None => "GPU not used".to_owned(),
    };
    let software = adapter.contains("llvmpipe") || adapter.contains("(Cpu)");
    let use_gpu = match request.backend {
        Backend::Gpu => true,
        Backend::Auto => !software,
        Backend::Cpu => false,
    };
    let mut uploaded = false;
    for name in &request.methods {
        let cpu_method = match methods::by_name(name) {
            Ok(m) => m,
            Err(why) => {
                skipped.push(why);
                continue;
            }
        };
        if let Err(why) = cpu_method.supports(&program) {
            skipped.push(format!("{name}: {why}"));
            continue;
        }
        let start = Instant::now();
        let on_gpu = GpuMethod::by_name(name)
            .filter(|m| use_gpu && m.supports(&program).is_ok())
            .and_then(|m| {
                let Some(Ok(renderer)) = gpu.as_mut() else {
                    return None;
                };
                if !uploaded {
                    renderer.set_scene(scene, &program).ok()?;
                    uploaded = true;
                }
                let size = (request.size.0 as u32, request.size.1 as u32);
                renderer
                    .render(
                        &program,
                        &[m],
                        &request.camera,
                        &settings,
                        size,
                        View::Shaded(request.shading),
                    )
                    .ok()?
                    .pop()
            });
        let (frame, on_gpu) = match on_gpu {
            Some(frame) => (frame, true),
            None => {
                let tracer = cpu_method.prepare(&program, settings);
                let frame = Renderer::new(scene, &program, tracer.as_ref(), settings).render(
                    &request.camera,
                    RenderOptions {
                        width: request.size.0,
                        height: request.size.1,
                        shadows: request.shadows,
                        shading: request.shading,
                    },
                );
                (frame, false)
            }
        };
        frames.push(Traced {
            method: name.clone(),
            frame,
            on_gpu,
            ms: start.elapsed().as_secs_f64() * 1e3,
        });
    }
    Reply {
        id: request.id,
        frames,
        skipped,
        adapter,
    }
}
