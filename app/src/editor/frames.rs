//! The viewport renderer: asks the render thread (`worker.rs`) for frames when what they depend
//! on changes — the document's compiled revision, the camera, the size, the methods, the
//! options — never otherwise; traces previews at a reduced resolution while the user interacts,
//! the full frame once idle; and turns replies into textures.
//!
//! Previews start at half resolution and keep their divisor, a power of two, while
//! they take about [`PREVIEW_TARGET_MS`]: a drag then traces one resolution after the other, and
//! the CPU copies what each edit did not reach from the preview before it (a new resolution
//! copies nothing). A preview much slower than the target doubles the divisor, one much faster
//! halves it; a full frame traced without copying bounds it from below, and a preview left
//! unanswered for [`PREVIEW_OVERRUN`] is cancelled for a coarser one. Camera moves copy nothing:
//! they keep a divisor of their own, set from the full frame's time to the power of two nearest
//! to the target (the creature's: 1/4), as every preview's was before.

use std::sync::Arc;
use std::time::{Duration, Instant};

use eframe::egui;
use skeletrace_core::Compiled;
use skeletrace_core::backend::{BackendChoice, Cancel, DeviceKind, FrameRequest};
use skeletrace_core::frame::{Frame, StepHistogram, StepScale, shared_step_top};
use skeletrace_core::methods::MethodId;

use super::ViewMode;
use super::worker::{RenderWorker, Reply, Request, Traced};
use crate::picture::Canvas;

/// Preview resolution divisor at start: half the viewport's width and height.
const PREVIEW_DIVISOR: usize = 2;
/// Time one preview reply should take, all its methods together: what keeps a drag fluid.
const PREVIEW_TARGET_MS: f64 = 60.0;
/// A preview slower than this makes the next ones twice as coarse.
const COARSEN_ABOVE_MS: f64 = 2.5 * PREVIEW_TARGET_MS;
/// Half-resolution previews of edits (that copy pixels from the preview before) stay up to
/// this long (previews at half resolution or better while dragging; on two cores,
/// `bench assets/scenes/creature.ron --after-edits --size 398x367` moves each vertex of the
/// default creature in 36 ms (median), 166 ms at most; a drag that moves a body vertex farther
/// between previews takes up to about 300 ms). Camera moves copy nothing and keep
/// [`COARSEN_ABOVE_MS`].
const HALF_RESOLUTION_UP_TO_MS: f64 = 5.0 * PREVIEW_TARGET_MS;
/// A preview faster than this makes the next ones twice as fine (four times the pixels, still
/// below [`COARSEN_ABOVE_MS`]).
const REFINE_BELOW_MS: f64 = PREVIEW_TARGET_MS / 2.0;
/// A full frame traced without copying tells what a preview traced without copying costs: the
/// divisor is at least the one at which that is this long (an edit's preview copies most of
/// its pixels from the one before).
const FULL_TRACE_PREVIEW_MS: f64 = 10.0 * PREVIEW_TARGET_MS;
/// A camera move's preview, which copies nothing, takes at most this long at the divisor a full
/// frame traced in full sets (the power of two nearest to taking [`PREVIEW_TARGET_MS`]).
const CAMERA_PREVIEW_UP_TO_MS: f64 = 2.0 * PREVIEW_TARGET_MS;
/// The coarsest preview: 1/16 of the viewport's width and height.
const PREVIEW_DIVISOR_MAX: usize = 16;
/// A preview unanswered this long while the user interacts is cancelled, and the divisor
/// doubles.
const PREVIEW_OVERRUN: Duration = Duration::from_millis(500);
/// Idle time after which the full-resolution frame is requested.
pub(super) const REFINE_AFTER: Duration = Duration::from_millis(250);

/// A traced frame ready to draw.
pub(super) struct ShownFrame {
    pub method: MethodId,
    pub frame: Frame,
    /// Its step counts' histogram (the grid's statistics).
    pub histogram: StepHistogram,
    pub texture: egui::TextureHandle,
    pub on_gpu: bool,
    pub ms: f64,
    /// On the CPU, the share of pixels copied from an earlier frame.
    pub pixels_copied: Option<f64>,
    /// The frame of an earlier request, kept on screen while this method's frame of the newest
    /// one is being traced (the grid's other panels already show theirs).
    pub earlier: bool,
}

/// The latest reply from the renderer thread.
pub(super) struct Shown {
    pub id: u64,
    /// The document revision it was traced from.
    pub revision: u64,
    pub frames: Vec<ShownFrame>,
    pub skipped: Vec<String>,
    pub adapter: String,
    /// The kind of the render thread's GPU, if it has one open.
    pub gpu: Option<DeviceKind>,
    pub steps_max: u32,
    /// The colour scale of the heat-map textures.
    pub scale: StepScale,
    /// The reply was traced at full resolution.
    pub refined: bool,
    /// A preview's resolution divisor (of the viewport's width and height).
    pub divisor: usize,
}

/// Everything a frame depends on: the document's revision, the frame request and the backend
/// choice. A request is sent only when it changes.
#[derive(Clone)]
struct RenderKey {
    revision: u64,
    frame: FrameRequest,
    backend: BackendChoice,
}

impl RenderKey {
    fn same_as(&self, other: &Self) -> bool {
        self.revision == other.revision
            && self.backend == other.backend
            && self.frame.same_frame(&other.frame)
    }
}

/// What the viewport shows now: the request at full resolution, which a preview divides.
pub(super) struct FrameOrder {
    /// The document's revision and its compiled scene.
    pub revision: u64,
    pub compiled: Arc<Compiled>,
    /// The frames at the viewport's (or one grid panel's) full resolution.
    pub frame: FrameRequest,
    pub backend: BackendChoice,
    /// The user is dragging or has just interacted: a preview will do.
    pub interacting: bool,
}

/// The viewport's frames: requests, replies, and the preview resolution.
pub(super) struct ViewportFrames {
    worker: RenderWorker,
    next_request: u64,
    /// What was last asked of the renderer.
    requested: Option<RenderKey>,
    /// The latest reply, on screen.
    pub shown: Option<Shown>,
    /// Resolution divisors while interacting (powers of two), adapted to the replies' trace
    /// times: one for edits, one for camera moves.
    divisors: PreviewDivisors,
    /// What the user's interaction changes now.
    interaction: PreviewKind,
    /// Pixels of the viewport (or of one grid panel) at full resolution.
    viewport_pixels: usize,
    /// The size of the last preview shown: a preview of another size had no earlier frame of
    /// its size to copy from, and its time does not tell what the next ones take.
    last_preview_size: Option<(usize, usize)>,
    /// Since when the renderer has had an unanswered request.
    waiting: Option<Instant>,
    /// The id of the newest request sent to the renderer.
    newest_sent: u64,
    /// The ids and kinds of the latest preview requests (a preview at full resolution is
    /// timed as a preview).
    preview_ids: std::collections::VecDeque<(u64, PreviewKind)>,
    /// The ids of the latest requests with the document revision and the methods each was
    /// for.
    revisions: std::collections::VecDeque<(u64, u64, Vec<MethodId>)>,
}

impl ViewportFrames {
    /// Starts the render thread; `wake` repaints the UI after each reply.
    pub fn new(wake: impl Fn() + Send + 'static) -> Self {
        Self {
            worker: RenderWorker::start(wake),
            next_request: 1,
            requested: None,
            shown: None,
            divisors: PreviewDivisors {
                edit: PREVIEW_DIVISOR,
                camera: PREVIEW_DIVISOR,
            },
            interaction: PreviewKind::Edit,
            viewport_pixels: 0,
            last_preview_size: None,
            waiting: None,
            newest_sent: 0,
            preview_ids: std::collections::VecDeque::new(),
            revisions: std::collections::VecDeque::new(),
        }
    }

    /// The frames on screen, when they are of the document's `revision`.
    #[must_use]
    pub fn shown_of(&self, revision: u64) -> Option<&Shown> {
        self.shown.as_ref().filter(|s| s.revision == revision)
    }

    /// A fresh request id.
    pub fn next_id(&mut self) -> u64 {
        let id = self.next_request;
        self.next_request += 1;
        id
    }

    /// The kind of GPU the render thread has open, as its last reply said; `None` before a
    /// reply or without a GPU.
    #[must_use]
    pub fn render_thread_gpu(&self) -> Option<DeviceKind> {
        self.shown.as_ref().and_then(|shown| shown.gpu)
    }

    /// Sends a request for `order` unless the same one was sent last.
    pub fn request(&mut self, ctx: &egui::Context, order: FrameOrder) {
        let FrameOrder {
            revision,
            compiled,
            frame,
            backend,
            interacting,
        } = order;
        let pixels = (frame.width, frame.height);
        self.viewport_pixels = pixels.0 * pixels.1;
        if interacting && let Some(last) = &self.requested {
            if last.frame.camera != frame.camera {
                self.interaction = PreviewKind::CameraMove;
            } else if last.revision != revision {
                self.interaction = PreviewKind::Edit;
            }
        }
        let kind = self.interaction;
        if interacting
            && self.newest_is_preview()
            && let Some(since) = self.waiting
            && since.elapsed() > PREVIEW_OVERRUN
            && *self.divisors.of(kind) < PREVIEW_DIVISOR_MAX
        {
            // Too slow to show anything while the user drags: ask for a coarser one now.
            self.worker.cancel_all();
            let divisor = self.divisors.of(kind);
            *divisor = next_divisor(*divisor, Timing::Overrun);
            self.waiting = None;
            self.requested = None;
        }
        let divisor = if interacting {
            *self.divisors.of(kind)
        } else {
            1
        };
        let key = RenderKey {
            revision,
            frame: FrameRequest {
                width: (pixels.0 / divisor).max(8),
                height: (pixels.1 / divisor).max(8),
                cancel: Cancel::new(),
                ..frame
            },
            backend,
        };
        if interacting {
            ctx.request_repaint_after(REFINE_AFTER);
        }
        if self.requested.as_ref().is_some_and(|r| r.same_as(&key)) {
            return;
        }
        let id = self.next_id();
        self.worker.request(Request {
            id,
            compiled,
            frame: key.frame.clone(),
            backend,
            preview: interacting,
        });
        // A preview in flight goes on (the worker leaves it to finish); a full frame in flight
        // is cancelled by this request, which starts the wait afresh.
        let since = match self.waiting {
            Some(since) if self.newest_is_preview() => since,
            _ => Instant::now(),
        };
        self.waiting = Some(since);
        self.newest_sent = id;
        if self.revisions.len() == 16 {
            self.revisions.pop_front();
        }
        self.revisions
            .push_back((id, revision, key.frame.methods.clone()));
        if interacting {
            if self.preview_ids.len() == 8 {
                self.preview_ids.pop_front();
            }
            self.preview_ids.push_back((id, kind));
        }
        self.requested = Some(key);
    }

    /// Whether the newest request sent is a preview.
    fn newest_is_preview(&self) -> bool {
        self.preview_ids
            .back()
            .is_some_and(|(id, _)| *id == self.newest_sent)
    }

    /// Shows the newest reply, if one came; returns the device failure it reports, if any.
    pub fn receive(
        &mut self,
        ctx: &egui::Context,
        view: ViewMode,
        scale: StepScale,
    ) -> Option<String> {
        self.restyle(ctx, view, scale);
        let reply = self.worker.latest()?;
        self.show(ctx, reply, view, scale)
    }

    /// Redraws the shown heat maps' textures on `scale` when it changed (no new trace).
    fn restyle(&mut self, ctx: &egui::Context, view: ViewMode, scale: StepScale) {
        let Some(shown) = self.shown.as_mut().filter(|s| s.scale != scale) else {
            return;
        };
        shown.scale = scale;
        for f in &mut shown.frames {
            let image = frame_image(&f.frame, view, shown.steps_max, scale);
            f.texture = ctx.load_texture(
                format!("frame-{}", f.method),
                image,
                egui::TextureOptions::LINEAR,
            );
        }
    }

    /// Blocks until every request sent so far is answered and shows the answer (tests: the
    /// frame then reflects the current scene); returns a reported device failure.
    pub fn wait_for_all(
        &mut self,
        ctx: &egui::Context,
        view: ViewMode,
        scale: StepScale,
    ) -> Option<String> {
        let last = self.next_request.checked_sub(1).filter(|&id| id > 0)?;
        if self.shown.as_ref().is_some_and(|s| s.id >= last) {
            return None;
        }
        let reply = self.worker.wait_for(last, super::worker::LONGEST_FRAME)?;
        self.show(ctx, reply, view, scale)
    }

    fn show(
        &mut self,
        ctx: &egui::Context,
        reply: Reply,
        view: ViewMode,
        scale: StepScale,
    ) -> Option<String> {
        // Full resolution for the viewport (or grid panel) as it is now: the layout may have
        // moved since the request, and a newer request does not make this frame a preview.
        let refined = reply
            .frames
            .first()
            .is_some_and(|t| t.frame.width * t.frame.height >= self.viewport_pixels);
        let divisor = reply.frames.first().map_or(1, |t| {
            let shown = (t.frame.width * t.frame.height).max(1);
            (self.viewport_pixels as f64 / shown as f64)
                .sqrt()
                .round()
                .max(1.0) as usize
        });
        // The newest request answered, the renderer is idle; an older one, it starts the next.
        if !reply.partial {
            self.waiting = (reply.id < self.newest_sent).then(Instant::now);
        }
        if let Some(first) = reply.frames.first().filter(|_| !reply.partial) {
            let ms = reply.frames.iter().map(|t| t.ms).sum();
            let size = (first.frame.width, first.frame.height);
            let copied = reply.frames.iter().any(|t| t.pixels_copied > Some(0.0));
            let preview = self
                .preview_ids
                .iter()
                .find(|(id, _)| *id == reply.id)
                .map(|(_, kind)| *kind);
            // A frame copied whole (a camera back where a kept frame was) traced nothing and
            // tells nothing.
            let traced_nothing = reply.frames.iter().all(|t| t.pixels_copied == Some(1.0));
            match preview {
                _ if traced_nothing => {}
                Some(kind) => {
                    let first_at_size = self.last_preview_size != Some(size);
                    self.last_preview_size = Some(size);
                    let divisor = self.divisors.of(kind);
                    *divisor = next_divisor(
                        *divisor,
                        Timing::Preview {
                            ms,
                            first_at_size,
                            copied,
                        },
                    );
                }
                None if !copied => {
                    // A full frame traced in full: what a camera move's preview, which copies
                    // nothing, takes at each divisor, and a bound for an edit's.
                    self.divisors.camera = least_divisor(ms, CAMERA_PREVIEW_UP_TO_MS);
                    self.divisors.edit =
                        next_divisor(self.divisors.edit, Timing::Full { ms, copied });
                }
                None => {}
            }
        }
        let (revision, methods) = self
            .revisions
            .iter()
            .find(|(id, _, _)| *id == reply.id)
            .map_or((0, Vec::new()), |(_, revision, methods)| {
                (*revision, methods.clone())
            });
        let previous = self.shown.take();
        // A partial reply's methods not traced yet keep their frames of an earlier request.
        let (mut kept, adapter, gpu, skipped) = match previous {
            Some(p) if reply.partial => (p.frames, p.adapter, p.gpu, p.skipped),
            _ => (Vec::new(), reply.adapter, reply.gpu, reply.skipped),
        };
        // Each panel's frame in the request's order: (traced, its histogram, earlier).
        let mut traced = reply.frames;
        let mut panels: Vec<(Traced, StepHistogram, bool)> = Vec::new();
        for method in methods {
            if let Some(k) = traced.iter().position(|t| t.method == method) {
                let t = traced.swap_remove(k);
                let histogram = t.frame.step_histogram();
                panels.push((t, histogram, false));
            } else if let Some(k) = kept.iter().position(|f| f.method == method) {
                let f = kept.swap_remove(k);
                let t = Traced {
                    method: f.method,
                    frame: f.frame,
                    on_gpu: f.on_gpu,
                    ms: f.ms,
                    pixels_copied: f.pixels_copied,
                };
                panels.push((t, f.histogram, true));
            }
        }
        let histograms: Vec<StepHistogram> = panels.iter().map(|p| p.1.clone()).collect();
        let steps_max = shared_step_top(&histograms);
        let frames = panels
            .into_iter()
            .map(|(t, histogram, earlier)| {
                let image = frame_image(&t.frame, view, steps_max, scale);
                let texture = ctx.load_texture(
                    format!("frame-{}", t.method),
                    image,
                    egui::TextureOptions::LINEAR,
                );
                ShownFrame {
                    method: t.method,
                    histogram,
                    frame: t.frame,
                    texture,
                    on_gpu: t.on_gpu,
                    ms: t.ms,
                    pixels_copied: t.pixels_copied,
                    earlier,
                }
            })
            .collect();
        self.shown = Some(Shown {
            id: reply.id,
            revision,
            frames,
            skipped,
            adapter,
            gpu,
            steps_max,
            scale,
            refined,
            divisor,
        });
        reply.device_failure
    }
}

/// What a preview shows: a camera move traces every pixel again; an edit copies from the
/// preview before it what it did not reach.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum PreviewKind {
    CameraMove,
    Edit,
}

/// The preview divisor of each kind of interaction.
struct PreviewDivisors {
    edit: usize,
    camera: usize,
}

impl PreviewDivisors {
    fn of(&mut self, kind: PreviewKind) -> &mut usize {
        match kind {
            PreviewKind::CameraMove => &mut self.camera,
            PreviewKind::Edit => &mut self.edit,
        }
    }
}

/// The finest power-of-two divisor (up to [`PREVIEW_DIVISOR_MAX`]) at which a frame that took
/// `ms` at full resolution, all its pixels traced, takes at most `budget` ms.
fn least_divisor(ms: f64, budget: f64) -> usize {
    let mut least = 1;
    while least < PREVIEW_DIVISOR_MAX && ms / (least * least) as f64 > budget {
        least *= 2;
    }
    least
}

/// What a reply or its absence tells about the preview divisor.
#[derive(Clone, Copy, Debug)]
pub(super) enum Timing {
    /// A preview took `ms`, all its methods together; `first_at_size`: none of its size came
    /// before it, so it copied nothing from an earlier frame; `copied`: some of its pixels
    /// came from an earlier frame (an edit's preview, not a camera move's).
    Preview {
        ms: f64,
        first_at_size: bool,
        copied: bool,
    },
    /// A full-resolution frame took `ms`; `copied`: some of its pixels came from an earlier
    /// frame.
    Full { ms: f64, copied: bool },
    /// A preview went unanswered for [`PREVIEW_OVERRUN`].
    Overrun,
}

/// The preview divisor after `timing`, from `divisor`: a power of two from 1 to
/// [`PREVIEW_DIVISOR_MAX`], moved by one factor of two at a time, kept while previews take
/// between [`REFINE_BELOW_MS`] and [`COARSEN_ABOVE_MS`] (so that a drag keeps its resolution,
/// and with it the frames its edits copy from), an edit's at half resolution up to
/// [`HALF_RESOLUTION_UP_TO_MS`].
pub(super) fn next_divisor(divisor: usize, timing: Timing) -> usize {
    let coarser = (divisor * 2).min(PREVIEW_DIVISOR_MAX);
    match timing {
        Timing::Preview { ms, .. } if !ms.is_finite() => divisor,
        Timing::Preview {
            first_at_size: true,
            ..
        } => divisor,
        Timing::Preview { ms, copied, .. }
            if ms > COARSEN_ABOVE_MS
                && (divisor != PREVIEW_DIVISOR || !copied || ms > HALF_RESOLUTION_UP_TO_MS) =>
        {
            coarser
        }
        Timing::Preview { ms, .. } if ms < REFINE_BELOW_MS => (divisor / 2).max(1),
        Timing::Preview { .. } | Timing::Full { copied: true, .. } => divisor,
        Timing::Full { ms, copied: false } => divisor.max(least_divisor(ms, FULL_TRACE_PREVIEW_MS)),
        Timing::Overrun => coarser,
    }
}

/// The texture image of a frame: shaded colours, or the heat map on `[0, steps_max]` on
/// `scale`, as the grid's colour bar says.
fn frame_image(
    frame: &Frame,
    view: ViewMode,
    steps_max: u32,
    scale: StepScale,
) -> egui::ColorImage {
    let mut canvas = Canvas::new(frame.width, frame.height, [0, 0, 0, 255]);
    match view {
        ViewMode::Shaded => canvas.draw_shaded(frame, 0, 0),
        ViewMode::Compare => canvas.draw_steps(frame, steps_max, scale, 0, 0),
    }
    egui::ColorImage::from_rgba_unmultiplied([frame.width, frame.height], canvas.bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn previews_keep_half_resolution_while_they_take_about_the_target() {
        let preview = |ms| Timing::Preview {
            ms,
            first_at_size: false,
            copied: true,
        };
        // Within the band, the divisor stays: a drag keeps its resolution.
        for ms in [35.0_f64, 60.0, 140.0, 290.0] {
            assert_eq!(next_divisor(4, preview(ms.min(140.0))), 4, "{ms}");
            assert_eq!(next_divisor(PREVIEW_DIVISOR, preview(ms)), 2, "{ms}");
        }
        // An edit's half resolution holds up to HALF_RESOLUTION_UP_TO_MS, a camera move's
        // (nothing copied) and other divisors to COARSEN_ABOVE_MS.
        assert_eq!(next_divisor(2, preview(250.0)), 2);
        let camera_move = Timing::Preview {
            ms: 250.0,
            first_at_size: false,
            copied: false,
        };
        assert_eq!(next_divisor(2, camera_move), 4);
        assert_eq!(next_divisor(1, preview(200.0)), 2);
        assert_eq!(next_divisor(4, preview(200.0)), 8);
        // Much slower: twice as coarse, at most once per reply, up to the coarsest.
        assert_eq!(next_divisor(2, preview(400.0)), 4);
        assert_eq!(next_divisor(2, preview(1e6)), 4);
        assert_eq!(next_divisor(16, preview(1e6)), PREVIEW_DIVISOR_MAX);
        // Much faster: twice as fine, down to full resolution.
        assert_eq!(next_divisor(4, preview(5.0)), 2);
        assert_eq!(next_divisor(1, preview(5.0)), 1);
        // The first preview of a size copied nothing: its time says nothing of the next ones.
        let first = Timing::Preview {
            ms: 1e4,
            first_at_size: true,
            copied: false,
        };
        assert_eq!(next_divisor(2, first), 2);
        assert_eq!(next_divisor(2, preview(f64::NAN)), 2);
        // A full frame traced in full bounds the divisor from below: the default creature's
        // full editor frame (about 1 s on two cores) keeps half resolution, a grid of slow
        // methods (a minute) starts at the coarsest.
        let full = |ms| Timing::Full { ms, copied: false };
        assert_eq!(next_divisor(2, full(1_000.0)), 2);
        assert_eq!(next_divisor(2, full(3_000.0)), 4);
        assert_eq!(next_divisor(2, full(60_000.0)), 16);
        assert_eq!(next_divisor(1, full(30.0)), 1);
        assert_eq!(next_divisor(8, full(30.0)), 8, "only previews refine");
        // A full frame that copied pixels says nothing of what a preview traces.
        let copied = Timing::Full {
            ms: 60_000.0,
            copied: true,
        };
        assert_eq!(next_divisor(2, copied), 2);
        // A camera move's divisor after a full frame: the power of two nearest to the target.
        assert_eq!(least_divisor(950.0, CAMERA_PREVIEW_UP_TO_MS), 4);
        assert_eq!(least_divisor(100.0, CAMERA_PREVIEW_UP_TO_MS), 1);
        assert_eq!(least_divisor(1e9, CAMERA_PREVIEW_UP_TO_MS), 16);
        // An overrunning preview: twice as coarse.
        assert_eq!(next_divisor(2, Timing::Overrun), 4);
        assert_eq!(next_divisor(16, Timing::Overrun), 16);
    }
}
