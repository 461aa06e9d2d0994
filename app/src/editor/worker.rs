//! The viewport's renderer thread: takes the latest render request, traces it through the
//! backend `skeletrace::backends::Backends::choose` picks for each method, and hands the frames
//! back with their timings, so the UI thread never waits for a frame. Stale requests are
//! dropped: only the newest one is traced. A newer request cancels a full-resolution frame in
//! flight (an edit does not wait for it); a preview in flight is left to finish, so that a
//! continuous drag shows a preview every preview time instead of none until it pauses (the UI
//! cancels one that overruns, `RenderWorker::cancel_all`).
//!
//! A request of several methods (the comparison grid) traces the cheapest first, by each
//! method's last time per pixel, and sends a partial reply after each method but the last, so
//! that no panel waits for the slowest: the grid shows each method's frame as it comes.
//!
//! A request carries the document's `Arc<Compiled>`, never a scene to compile: moving the
//! camera compiles nothing, and the GPU re-uploads only when the compiled scene changes. Every
//! frame says where it was traced. A GPU that fails (device lost, a shader that does not build)
//! is dropped with the reason in the reply, and the same request is traced on the CPU.

use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Instant;

use skeletrace_core::Compiled;
use skeletrace_core::backend::{BackendChoice, BackendError, Cancel, DeviceKind, FrameRequest};
use skeletrace_core::cpu::cpu_backend::CpuBackend;
use skeletrace_core::frame::{FieldShading, Frame, View};
use skeletrace_core::methods::MethodId;
use skeletrace_core::model::scene::Camera;

use crate::backends::Backends;

/// Longest a caller waits for one reply (a screenshot at a large size on a slow CPU): past it,
/// the wait ends with nothing rather than hanging.
pub const LONGEST_FRAME: std::time::Duration = std::time::Duration::from_secs(600);

/// One render: the compiled scene of a revision and the frame request (its methods, one frame
/// each), the backend choice, and whether it is a preview.
#[derive(Clone)]
pub struct Request {
    /// Identifies the request in its reply.
    pub id: u64,
    /// The compiled scene (the document's, shared).
    pub compiled: Arc<Compiled>,
    /// What to trace: camera, size, methods, view, shadows, settings. Its cancel flag is set
    /// by [`RenderWorker::request`] when a newer request replaces this one (unless this is a
    /// preview), or by [`RenderWorker::cancel_all`]: the CPU tracer stops mid-frame and no
    /// reply is sent.
    pub frame: FrameRequest,
    /// Backend choice.
    pub backend: BackendChoice,
    /// A reduced-resolution frame while the user interacts: a newer request does not cancel
    /// it once it is traced.
    pub preview: bool,
}

/// One traced frame.
#[derive(Clone)]
pub struct Traced {
    /// The method.
    pub method: MethodId,
    /// The frame.
    pub frame: Frame,
    /// Traced on the GPU.
    pub on_gpu: bool,
    /// Milliseconds spent tracing it.
    pub ms: f64,
    /// On the CPU, the share of its pixels copied from an earlier frame instead of traced
    /// (after an edit that did not reach them, `CpuBackend::reusing_tiles`).
    pub pixels_copied: Option<f64>,
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
    /// The kind of the GPU the thread has open, if any.
    pub gpu: Option<DeviceKind>,
    /// A device failure met while tracing this request (the GPU is then dropped and the
    /// request traced on the CPU).
    pub device_failure: Option<String>,
    /// More frames of this request follow: these are the methods traced so far.
    pub partial: bool,
}

/// The newest request sent to the thread.
struct Newest {
    cancel: Cancel,
    preview: bool,
    #[cfg_attr(
        not(test),
        expect(dead_code, reason = "the tests ask which request is the newest")
    )]
    id: u64,
}

/// Handle on the renderer thread.
pub struct RenderWorker {
    requests: Option<Sender<Request>>,
    /// The newest request sent: its cancel flag, whether it is a preview, its id. Held while
    /// a request is sent, so that the newest is the last in the channel also when several
    /// threads send at once (else the thread could take a cancelled one last and answer
    /// none).
    newest: Mutex<Option<Newest>>,
    /// The cancel flag of the request the thread is tracing.
    running: Arc<Mutex<Option<Cancel>>>,
    /// Behind a lock so that the handle can be shared by threads that send requests.
    replies: Mutex<Receiver<Reply>>,
    thread: Option<JoinHandle<()>>,
}

impl RenderWorker {
    /// Starts the thread; `wake` is called after each reply (to repaint the UI).
    #[must_use]
    pub fn start(wake: impl Fn() + Send + 'static) -> Self {
        let (request_tx, request_rx) = channel::<Request>();
        let (reply_tx, reply_rx) = channel();
        let running = Arc::new(Mutex::new(None));
        let tracing = Arc::clone(&running);
        let thread = std::thread::Builder::new()
            .name("skeletrace-render".to_owned())
            .spawn(move || serve(&request_rx, &reply_tx, &tracing, &wake))
            .ok();
        Self {
            requests: Some(request_tx),
            newest: Mutex::new(None),
            running,
            replies: Mutex::new(reply_rx),
            thread,
        }
    }

    /// Queues a request: the one sent before is cancelled unless it is a preview (a preview
    /// being traced finishes); older queued ones are dropped by the thread. The newest request
    /// is always answered (unless [`RenderWorker::cancel_all`] cancels it).
    pub fn request(&self, request: Request) {
        let mut newest = self
            .newest
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let now = Newest {
            cancel: request.frame.cancel.clone(),
            preview: request.preview,
            id: request.id,
        };
        if let Some(previous) = newest.replace(now)
            && !previous.preview
        {
            previous.cancel.cancel();
        }
        if let Some(tx) = &self.requests {
            // A closed channel means the thread ended; the UI then shows its last frame.
            let _ = tx.send(request);
        }
    }

    /// The id of the newest request sent.
    #[cfg(test)]
    fn newest_id(&self) -> Option<u64> {
        self.newest.lock().ok()?.as_ref().map(|n| n.id)
    }

    /// Cancels the request being traced and the newest one sent: none of them gets a reply
    /// (an overrunning preview, before a coarser one is asked for).
    pub fn cancel_all(&self) {
        if let Ok(newest) = self.newest.lock()
            && let Some(newest) = newest.as_ref()
        {
            newest.cancel.cancel();
        }
        if let Ok(running) = self.running.lock()
            && let Some(cancel) = running.as_ref()
        {
            cancel.cancel();
        }
    }

    /// The newest reply since the last call, if any.
    #[must_use]
    pub fn latest(&self) -> Option<Reply> {
        self.replies.lock().ok()?.try_iter().last()
    }

    /// Waits for the reply to request `id` (tests and offscreen screenshots), at most
    /// `deadline`; `None` when the thread stopped or the deadline passed.
    #[must_use]
    pub fn wait_for(&self, id: u64, deadline: std::time::Duration) -> Option<Reply> {
        let end = Instant::now() + deadline;
        let replies = self.replies.lock().ok()?;
        loop {
            let left = end.checked_duration_since(Instant::now())?;
            match replies.recv_timeout(left) {
                Ok(reply) if reply.id >= id && !reply.partial => return Some(reply),
                Ok(_) => {}
                Err(_) => return None,
            }
        }
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

fn serve(
    requests: &Receiver<Request>,
    replies: &Sender<Reply>,
    running: &Mutex<Option<Cancel>>,
    wake: &dyn Fn(),
) {
    let mut backends: Option<Backends> = None;
    let mut costs = MethodCosts::default();
    while let Ok(mut request) = requests.recv() {
        while let Ok(newer) = requests.try_recv() {
            request = newer;
        }
        // The GPU is opened once, on the first request that may use it. The CPU keeps its
        // last frames: after an edit it traces again only the tiles the edit reached.
        let backends = backends.get_or_insert_with(|| {
            let mut opened = Backends::open(request.backend);
            opened.cpu = CpuBackend::reusing_tiles();
            opened
        });
        backends.open_gpu_for(request.backend);
        if let Ok(mut running) = running.lock() {
            *running = Some(request.frame.cancel.clone());
        }
        let mut send_partial = |reply: Reply| {
            if replies.send(reply).is_ok() {
                wake();
            }
        };
        let traced = trace_cheapest_first(&request, backends, &mut costs, &mut send_partial);
        if let Ok(mut running) = running.lock() {
            *running = None;
        }
        // A cancelled request has a newer one behind it: that one gets the reply.
        let Some(reply) = traced else {
            continue;
        };
        if replies.send(reply).is_err() {
            return;
        }
        wake();
    }
}

/// Each method's last milliseconds per pixel on the render thread.
#[derive(Default)]
struct MethodCosts(std::collections::HashMap<MethodId, f64>);

impl MethodCosts {
    /// The methods of `request` cheapest first (those not timed yet first of all).
    fn order(&self, methods: &[MethodId]) -> Vec<MethodId> {
        let mut ordered = methods.to_vec();
        ordered.sort_by(|a, b| {
            let cost = |m| self.0.get(m).copied().unwrap_or(0.0);
            cost(a).total_cmp(&cost(b))
        });
        ordered
    }

    fn note(&mut self, traced: &[Traced]) {
        for t in traced {
            let pixels = (t.frame.width * t.frame.height).max(1) as f64;
            self.0.insert(t.method, t.ms / pixels);
        }
    }
}

/// [`trace`] of the request's methods, cheapest first by `costs`, handing a partial reply (the
/// frames so far, in request order) to `partial` after each method but the last; the full
/// reply, its frames in request order, at the end.
fn trace_cheapest_first(
    request: &Request,
    backends: &mut Backends,
    costs: &mut MethodCosts,
    partial: &mut dyn FnMut(Reply),
) -> Option<Reply> {
    let order = costs.order(&request.frame.methods);
    let mut reply = trace_in_order(request, backends, &order, partial)?;
    costs.note(&reply.frames);
    let position = |m: MethodId| request.frame.methods.iter().position(|&r| r == m);
    reply.frames.sort_by_key(|t| position(t.method));
    Some(reply)
}

/// Traces every method of `request` in its order, each on the backend chosen for it; `None`
/// when the request was cancelled meanwhile (the tests' way to trace as the thread does).
#[cfg(test)]
pub fn trace(request: &Request, backends: &mut Backends) -> Option<Reply> {
    trace_in_order(request, backends, &request.frame.methods, &mut |_| {})
}

/// [`trace`] of `order` (the request's methods), handing the frames so far to `partial` after
/// each method but the last.
fn trace_in_order(
    request: &Request,
    backends: &mut Backends,
    order: &[MethodId],
    partial: &mut dyn FnMut(Reply),
) -> Option<Reply> {
    let mut frames: Vec<Traced> = Vec::new();
    let mut skipped = Vec::new();
    let mut device_failure = None;
    for (k, &method) in order.iter().enumerate() {
        let frame_request = FrameRequest {
            methods: vec![method],
            ..request.frame.clone()
        };
        if let Err(why) = method.method().supports(&request.compiled.program) {
            skipped.push(format!("{method}: {why}"));
            continue;
        }
        let start = Instant::now();
        let attempt = |backends: &mut Backends,
                       choice: BackendChoice|
         -> Result<(Frame, bool), BackendError> {
            let backend = backends.choose(choice, &request.compiled, method, &frame_request)?;
            let on_gpu = backend.device_kind() != DeviceKind::Cpu;
            let frame = backend
                .render(&request.compiled, &frame_request)?
                .pop()
                .ok_or_else(|| BackendError::DeviceFailed("no frame came back".to_owned()))?;
            Ok((frame, on_gpu))
        };
        let traced = match attempt(backends, request.backend) {
            Err(BackendError::DeviceFailed(why)) => {
                // Say so, drop the GPU, and trace this and every later frame on the CPU.
                let why = format!("GPU failed, continuing on the CPU: {why}");
                backends.lose_gpu(&why);
                device_failure = Some(why);
                attempt(backends, BackendChoice::Cpu)
            }
            other => other,
        };
        match traced {
            Err(BackendError::Cancelled) => return None,
            Ok((frame, on_gpu)) => {
                frames.push(Traced {
                    method,
                    frame,
                    on_gpu,
                    ms: start.elapsed().as_secs_f64() * 1e3,
                    pixels_copied: (!on_gpu).then(|| backends.cpu.share_of_pixels_reused()),
                });
                if k + 1 < order.len() {
                    partial(Reply {
                        id: request.id,
                        frames: frames.iter().map(Traced::clone).collect(),
                        skipped: Vec::new(),
                        adapter: String::new(),
                        gpu: None,
                        device_failure: None,
                        partial: true,
                    });
                }
            }
            Err(e) => skipped.push(format!("{method}: {e}")),
        }
    }
    let (adapter, gpu) = match &backends.gpu {
        Ok(gpu) => (gpu.describe(), Some(gpu.device_kind())),
        Err(why) => (format!("no GPU ({why})"), None),
    };
    Some(Reply {
        id: request.id,
        frames,
        skipped,
        adapter,
        gpu,
        device_failure,
        partial: false,
    })
}

/// The frame request the render thread traces for `compiled` (no method yet): the shaded view
/// with `shading`, under the scene's own settings. The methods panel asks the backend decision
/// with the same request.
#[must_use]
pub fn frame_request(
    compiled: &Compiled,
    camera: Camera,
    (width, height): (usize, usize),
    shadows: bool,
    shading: FieldShading,
    cancel: Cancel,
) -> FrameRequest {
    FrameRequest {
        camera,
        width,
        height,
        methods: Vec::new(),
        view: View::Shaded(shading),
        shadows,
        settings: compiled.settings,
        cancel,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backends::FailingGpu;

    /// Longest a test waits for a reply.
    const TEST_DEADLINE: std::time::Duration = std::time::Duration::from_secs(120);

    /// A request of the default scene through its camera, on the CPU, a full frame with a
    /// cancel flag of its own; tests change what they need with `..`.
    fn default_request(id: u64, size: (usize, usize), methods: Vec<MethodId>) -> Request {
        let scene = crate::editor::default_scene();
        let compiled = skeletrace_core::compile(&scene);
        let frame = FrameRequest {
            methods,
            ..frame_request(
                &compiled,
                scene.camera,
                size,
                false,
                FieldShading::default(),
                Cancel::new(),
            )
        };
        Request {
            id,
            compiled,
            frame,
            backend: BackendChoice::Cpu,
            preview: false,
        }
    }

    /// A device failure is reported, the frame is traced on the CPU instead, and the GPU is not
    /// tried again.
    #[test]
    fn a_failing_gpu_is_reported_and_the_cpu_takes_over() {
        let mut backends = Backends::open(BackendChoice::Cpu);
        backends.gpu = Ok(Box::new(FailingGpu));
        let request = Request {
            backend: BackendChoice::Auto,
            ..default_request(
                1,
                (24, 16),
                vec![MethodId::Segment, MethodId::QuadraticTaylor],
            )
        };
        let reply = trace(&request, &mut backends).unwrap_or_else(|| panic!("not cancelled"));
        let failure = reply.device_failure.unwrap_or_default();
        assert!(failure.contains("device lost (injected)"), "{failure}");
        assert_eq!(
            reply.frames.len(),
            2,
            "both methods traced: {:?}",
            reply.skipped
        );
        assert!(reply.frames.iter().all(|t| !t.on_gpu));
        assert!(reply.frames.iter().all(|t| t.frame.steps.len() == 24 * 16));
        assert!(backends.gpu.is_err(), "the failed GPU is dropped");
        assert!(reply.adapter.contains("GPU failed"), "{}", reply.adapter);
        // Under an explicit GPU choice too, the editor keeps going on the CPU and says why.
        let again = trace(
            &Request {
                backend: BackendChoice::Gpu,
                ..request
            },
            &mut backends,
        )
        .unwrap_or_else(|| panic!("not cancelled"));
        assert_eq!(again.frames.len(), 2, "{:?}", again.skipped);
        assert!(again.frames.iter().all(|t| !t.on_gpu));
        let failure = again.device_failure.unwrap_or_default();
        assert!(failure.contains("GPU failed"), "{failure}");
    }

    /// A request cancelled while it is traced gets no reply, and the CPU tracer stops early.
    #[test]
    fn a_cancelled_request_gets_no_reply() {
        let mut backends = Backends::open(BackendChoice::Cpu);
        let request = default_request(1, (640, 480), vec![MethodId::Sphere]);
        request.frame.cancel.cancel();
        assert!(trace(&request, &mut backends).is_none());
        // Through the thread: the first request is cancelled by the second, which is answered.
        let worker = RenderWorker::start(|| {});
        let first = default_request(2, (640, 480), vec![MethodId::Sphere]);
        let second = default_request(3, (8, 6), vec![MethodId::Sphere]);
        let first_cancel = first.frame.cancel.clone();
        worker.request(first);
        worker.request(second);
        assert!(first_cancel.is_cancelled());
        let reply = worker
            .wait_for(3, TEST_DEADLINE)
            .unwrap_or_else(|| panic!("a reply to the newest request"));
        assert_eq!(reply.id, 3);
        assert_eq!(reply.frames.len(), 1);
    }

    /// A preview is left to finish when a newer request comes (a continuous drag shows
    /// previews), a full-resolution frame is not, and `cancel_all` cancels the one in flight
    /// and the newest.
    #[test]
    fn a_newer_request_leaves_a_preview_to_finish() {
        let request = |id, preview| Request {
            preview,
            ..default_request(id, (12, 8), vec![MethodId::QuadraticTaylor])
        };
        let worker = RenderWorker::start(|| {});
        let (preview, full, newest) = (request(1, true), request(2, false), request(3, true));
        let cancels = [&preview, &full, &newest].map(|r| r.frame.cancel.clone());
        worker.request(preview);
        worker.request(full);
        assert!(!cancels[0].is_cancelled(), "a superseded preview finishes");
        worker.request(newest);
        assert!(
            cancels[1].is_cancelled(),
            "a superseded full frame does not"
        );
        assert!(!cancels[2].is_cancelled());
        let reply = worker
            .wait_for(3, TEST_DEADLINE)
            .unwrap_or_else(|| panic!("a reply to the newest request"));
        assert_eq!(reply.id, 3);
        worker.cancel_all();
        assert!(cancels[2].is_cancelled(), "cancel_all cancels the newest");
    }

    /// A drag sends a preview request far more often than one is traced: previews come back
    /// while it goes on (when each request cancelled the one in flight, none did until the
    /// drag paused).
    #[test]
    fn a_continuous_drag_shows_previews() {
        let drag = Request {
            preview: true,
            ..default_request(0, (96, 72), vec![MethodId::QuadraticTaylor])
        };
        let worker = RenderWorker::start(|| {});
        let (mut answered, mut newest) = (0, 0);
        // A request every 2 ms for a second, each a frame of the creature that takes tens of
        // milliseconds to trace (or none, where the frame before it can be copied whole).
        for id in 1..=500 {
            let mut next = Request { id, ..drag.clone() };
            next.frame.cancel = Cancel::new();
            worker.request(next);
            for reply in worker
                .replies
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
                .try_iter()
            {
                answered += 1;
                newest = newest.max(reply.id);
            }
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        assert!(answered > 0, "no preview came back during the drag");
        // The newest request's reply, unless it already came back during the drag.
        if newest < 500 {
            let last = worker
                .wait_for(500, TEST_DEADLINE)
                .unwrap_or_else(|| panic!("a reply to the newest request"));
            assert_eq!(last.id, 500);
        }
    }

    /// Requests from racing threads (a UI and a screenshot, say), thousands of them in bursts
    /// that start together, with random delays, previews and full frames mixed: after each
    /// burst the newest request is answered, within a deadline. (When a request was sent after
    /// its cancel flag was registered, outside one lock, two senders could leave a cancelled
    /// request last in the channel: the thread took it, traced nothing and answered nothing.)
    #[test]
    fn the_newest_of_racing_requests_is_always_answered() {
        use skeletrace_core::model::rng::SplitMix64;
        use std::sync::Barrier;
        use std::sync::atomic::{AtomicU64, Ordering};
        const SENDERS: u64 = 4;
        let base = default_request(0, (8, 6), vec![MethodId::QuadraticTaylor]);
        let worker = RenderWorker::start(|| {});
        let ids = AtomicU64::new(1);
        let start = Barrier::new(SENDERS as usize);
        for burst in 0..300_u64 {
            std::thread::scope(|scope| {
                for sender in 0..SENDERS {
                    let (worker, ids, base, start) = (&worker, &ids, &base, &start);
                    scope.spawn(move || {
                        let mut rng = SplitMix64::new(burst * SENDERS + sender + 1);
                        start.wait();
                        for _ in 0..1 + rng.below(4) {
                            let mut request = Request {
                                id: ids.fetch_add(1, Ordering::Relaxed),
                                preview: rng.unit() < 0.3,
                                ..base.clone()
                            };
                            request.frame.cancel = Cancel::new();
                            worker.request(request);
                            let pause = (rng.unit() * 200.0) as u64;
                            std::thread::sleep(std::time::Duration::from_micros(pause));
                        }
                    });
                }
            });
            let newest = worker
                .newest_id()
                .unwrap_or_else(|| panic!("requests were sent"));
            let end = Instant::now() + TEST_DEADLINE;
            let replies = worker
                .replies
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            loop {
                let left = end
                    .checked_duration_since(Instant::now())
                    .unwrap_or_else(|| panic!("burst {burst}: request {newest} never answered"));
                match replies.recv_timeout(left) {
                    Ok(reply) if reply.id == newest => break,
                    Ok(_) => {}
                    Err(e) => panic!("burst {burst}: request {newest} never answered ({e})"),
                }
            }
        }
    }
}
