//! The viewport renderer: asks the render thread (`worker.rs`) for frames when what they depend
//! on changes — the document's compiled revision, the camera, the size, the methods, the
//! options — never otherwise; traces previews at a reduced resolution while the user interacts
//! (the divisor adapted so that one takes about [`PREVIEW_TARGET_MS`]), the full frame once
//! idle; and turns replies into textures.

use std::sync::Arc;
use std::time::Duration;

use eframe::egui;
use skeletrace_core::Compiled;
use skeletrace_core::backend::{BackendChoice, Cancel};
use skeletrace_core::frame::{FieldShading, Frame, StepHistogram, StepScale, shared_step_top};
use skeletrace_core::methods::MethodId;
use skeletrace_core::model::scene::Camera;

use super::ViewMode;
use super::worker::{RenderWorker, Reply, Request};
use crate::picture::Canvas;

/// Preview resolution divisor at start, before any preview was timed.
const PREVIEW_DIVISOR: usize = 4;
/// Time one preview reply should take, all its methods together: what keeps a drag fluid.
const PREVIEW_TARGET_MS: f64 = 60.0;
/// The coarsest preview: 1/16 of the viewport's width and height.
const PREVIEW_DIVISOR_MAX: usize = 16;
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
}

/// The latest reply from the renderer thread.
pub(super) struct Shown {
    pub id: u64,
    pub frames: Vec<ShownFrame>,
    pub skipped: Vec<String>,
    pub adapter: String,
    pub steps_max: u32,
    /// The colour scale of the heat-map textures.
    pub scale: StepScale,
    /// The reply was traced at full resolution.
    pub refined: bool,
}

/// Everything a frame depends on; a request is sent only when it changes.
#[derive(Clone, PartialEq)]
struct RenderKey {
    revision: u64,
    camera: Camera,
    size: (usize, usize),
    methods: Vec<MethodId>,
    backend: BackendChoice,
    shadows: bool,
    shading: FieldShading,
}

/// What the viewport shows now.
pub(super) struct FrameOrder {
    /// The document's revision and its compiled scene.
    pub revision: u64,
    pub compiled: Arc<Compiled>,
    pub camera: Camera,
    /// Pixels of the viewport (or of one grid panel) at full resolution.
    pub pixels: (usize, usize),
    pub methods: Vec<MethodId>,
    pub backend: BackendChoice,
    pub shadows: bool,
    pub shading: FieldShading,
    pub view: ViewMode,
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
    /// Resolution divisor while interacting, adapted to the last reply's trace time.
    pub preview_divisor: usize,
    /// Pixels of the viewport (or of one grid panel) at full resolution.
    viewport_pixels: usize,
}

impl ViewportFrames {
    /// Starts the render thread; `wake` repaints the UI after each reply.
    pub fn new(wake: impl Fn() + Send + 'static) -> Self {
        Self {
            worker: RenderWorker::start(wake),
            next_request: 1,
            requested: None,
            shown: None,
            preview_divisor: PREVIEW_DIVISOR,
            viewport_pixels: 0,
        }
    }

    /// A fresh request id.
    pub fn next_id(&mut self) -> u64 {
        let id = self.next_request;
        self.next_request += 1;
        id
    }

    /// Sends a request for `order` unless the same one was sent last.
    pub fn request(&mut self, ctx: &egui::Context, order: FrameOrder) {
        let FrameOrder {
            revision,
            compiled,
            camera,
            pixels,
            methods,
            backend,
            shadows,
            shading,
            view,
            interacting,
        } = order;
        self.viewport_pixels = pixels.0 * pixels.1;
        let divisor = if interacting { self.preview_divisor } else { 1 };
        let size = ((pixels.0 / divisor).max(8), (pixels.1 / divisor).max(8));
        let shaded = view == ViewMode::Shaded;
        let key = RenderKey {
            revision,
            camera,
            size,
            methods: methods.clone(),
            backend,
            shadows: shadows && shaded,
            shading: if shaded {
                shading
            } else {
                FieldShading::default()
            },
        };
        if interacting {
            ctx.request_repaint_after(REFINE_AFTER);
        }
        if self.requested.as_ref() == Some(&key) {
            return;
        }
        let id = self.next_id();
        self.worker.request(Request {
            id,
            compiled,
            camera,
            size,
            methods,
            backend: key.backend,
            shadows: key.shadows,
            shading: key.shading,
            cancel: Cancel::new(),
        });
        self.requested = Some(key);
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
        let reply = self.worker.wait_for(last)?;
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
        if let Some(first) = reply.frames.first() {
            let ms = reply.frames.iter().map(|t| t.ms).sum();
            let traced = first.frame.width * first.frame.height;
            self.preview_divisor =
                adapted_divisor(self.preview_divisor, ms, traced, self.viewport_pixels);
        }
        let histograms: Vec<StepHistogram> = reply
            .frames
            .iter()
            .map(|t| t.frame.step_histogram())
            .collect();
        let steps_max = shared_step_top(&histograms);
        let frames = reply
            .frames
            .into_iter()
            .zip(histograms)
            .map(|(t, histogram)| {
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
                }
            })
            .collect();
        self.shown = Some(Shown {
            id: reply.id,
            frames,
            skipped: reply.skipped,
            adapter: reply.adapter,
            steps_max,
            scale,
            refined,
        });
        reply.device_failure
    }
}

/// The preview divisor that makes a preview take about [`PREVIEW_TARGET_MS`], given that the
/// last reply took `ms` for `traced` pixels (per method) and the viewport has `viewport`
/// pixels: trace time goes with the pixel count, 1/divisor². It changes by at most a factor
/// of two per reply, so one slow frame does not swing it.
pub(super) fn adapted_divisor(divisor: usize, ms: f64, traced: usize, viewport: usize) -> usize {
    if !ms.is_finite() || ms <= 0.0 || traced == 0 || viewport == 0 {
        return divisor;
    }
    let ideal = (viewport as f64 * ms / (traced as f64 * PREVIEW_TARGET_MS)).sqrt();
    let bounded = ideal.clamp(divisor as f64 / 2.0, divisor as f64 * 2.0);
    (bounded.round() as usize).clamp(1, PREVIEW_DIVISOR_MAX)
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
    fn the_preview_divisor_follows_the_trace_time_by_at_most_a_factor_of_two() {
        let full = 800 * 600;
        let quarter = full / 16;
        // A quarter-resolution preview at 4× the target: twice as coarse.
        assert_eq!(
            adapted_divisor(4, 4.0 * PREVIEW_TARGET_MS, quarter, full),
            8
        );
        // 100× the target: capped at doubling, and at the coarsest divisor.
        assert_eq!(
            adapted_divisor(4, 100.0 * PREVIEW_TARGET_MS, quarter, full),
            8
        );
        assert_eq!(
            adapted_divisor(12, 100.0 * PREVIEW_TARGET_MS, quarter, full),
            PREVIEW_DIVISOR_MAX
        );
        // A full-resolution frame tells as much: 16× the target there is divisor 4.
        assert_eq!(adapted_divisor(4, 16.0 * PREVIEW_TARGET_MS, full, full), 4);
        // Much faster than needed: finer, down to full resolution.
        assert_eq!(adapted_divisor(4, 0.01, quarter, full), 2);
        assert_eq!(adapted_divisor(1, 0.01, full, full), 1);
        assert_eq!(adapted_divisor(4, f64::NAN, quarter, full), 4);
        assert_eq!(adapted_divisor(4, 10.0, 0, full), 4);
    }
}
