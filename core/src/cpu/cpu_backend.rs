//! The CPU [`FrameBackend`]: every method, every scene, traced by [`Renderer`] on rayon
//! threads. It is the reference the GPU's frames are compared with.
//!
//! In the editor it keeps its last frames ([`CpuBackend::reusing_tiles`]): after an edit that
//! moved a few primitives, a frame through the same camera copies the screen tiles whose
//! candidates did not change and, in the other tiles, the rays that no changed primitive
//! reaches, and traces again only the rest (`Renderer::render_reusing`; the edit
//! loop). It does so only where every ray's trace is known to depend on nothing else:
//! the same method, camera, size, view and settings; a program that differs only in some
//! bounded primitives (`FieldProgram::primitives_changed_since`), with the same materials,
//! lights and method inputs (`Method::scene_inputs`); no shadow rays, no field shading and no
//! transparent group, whose rays leave the tile. The frames are those a full trace gives, bit
//! for bit (`cpu_backend` tests).

use std::sync::Arc;

use crate::backend::{BackendError, Capabilities, DeviceKind, FrameBackend, FrameRequest};
use crate::compile::Compiled;
use crate::cpu::renderer::{EarlierFrame, RenderOptions, Renderer, TracedFrame};
use crate::frame::{FieldShading, Frame, View, heat_colour};
use crate::methods::{Method, MethodId, TraceSettings};
use crate::model::scene::Camera;

/// Frames of how many recent sizes are kept besides the largest (the full frame's): those of
/// the previews at the resolutions the editor moves between while the user drags.
const KEPT_PREVIEW_SIZES: usize = 2;

/// The CPU tracer as a frame backend.
#[derive(Default)]
pub struct CpuBackend {
    /// Whether frames are kept for later frames to reuse.
    reuse: bool,
    /// The kept frames, oldest first.
    kept: Vec<KeptFrame>,
    /// The last request's screen tiles, all methods together: how many were copied whole from
    /// earlier frames, and how many there were.
    reused: (usize, usize),
    /// The last request's pixels, all methods together: how many were copied from earlier
    /// frames (in tiles copied whole, or rays of other tiles that no edit reached), and how
    /// many there were.
    reused_pixels: (usize, usize),
}

/// One method's frame, kept with what decides whether a later one may reuse its tiles.
struct KeptFrame {
    compiled: Arc<Compiled>,
    view: ViewOf,
    method: MethodId,
    scene_inputs: Vec<f64>,
    traced: TracedFrame,
}

/// What a frame was traced through, besides the scene and the method.
#[derive(Clone, Copy, PartialEq)]
struct ViewOf {
    camera: Camera,
    width: usize,
    height: usize,
    view: View,
    settings: TraceSettings,
}

impl CpuBackend {
    /// A backend that traces every frame in full (`render`, `bench`, the tests' references).
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// A backend that keeps its last frames and, after an edit, traces again only the tiles
    /// it must (the editor).
    #[must_use]
    pub fn reusing_tiles() -> Self {
        Self {
            reuse: true,
            ..Self::default()
        }
    }

    /// The share of the last request's screen tiles (all its methods together) copied whole
    /// from earlier frames instead of traced: 0 when none was.
    #[must_use]
    pub fn share_of_tiles_reused(&self) -> f64 {
        share(self.reused)
    }

    /// The share of the last request's pixels (all its methods together) copied from earlier
    /// frames instead of traced: those of the tiles copied whole, and the rays of the others
    /// that no changed primitive reaches.
    #[must_use]
    pub fn share_of_pixels_reused(&self) -> f64 {
        share(self.reused_pixels)
    }

    /// The frame kept for `method` through `view` whose tiles a frame of `compiled` may reuse,
    /// with the primitives changed since.
    fn earlier(
        &self,
        compiled: &Compiled,
        view: &ViewOf,
        method: &dyn Method,
        inputs: &[f64],
    ) -> Option<(&KeptFrame, Vec<bool>)> {
        self.kept.iter().rev().find_map(|kept| {
            if kept.method != method.id()
                || kept.view != *view
                || kept.scene_inputs != inputs
                || kept.compiled.materials != compiled.materials
                || kept.compiled.lights != compiled.lights
            {
                return None;
            }
            let changed = compiled
                .program
                .primitives_changed_since(&kept.compiled.program)?;
            Some((kept, changed))
        })
    }

    /// Keeps `frame`, dropping a frame of the same method and view, and the frames of sizes
    /// other than the largest (the full frame, which a drag's previews must not push out)
    /// and the [`KEPT_PREVIEW_SIZES`] most recent.
    fn keep(&mut self, frame: KeptFrame) {
        self.kept
            .retain(|k| !(k.method == frame.method && k.view == frame.view));
        self.kept.push(frame);
        let size_of = |k: &KeptFrame| (k.view.width, k.view.height);
        let sizes = sizes_to_keep(self.kept.iter().rev().map(size_of));
        self.kept.retain(|k| sizes.contains(&size_of(k)));
    }
}

/// `part / whole`, 0 for an empty whole.
fn share((part, whole): (usize, usize)) -> f64 {
    if whole == 0 {
        0.0
    } else {
        part as f64 / whole as f64
    }
}

/// The frame sizes to keep, given the kept frames' sizes, latest first: the largest and the
/// [`KEPT_PREVIEW_SIZES`] latest.
fn sizes_to_keep(latest_first: impl Iterator<Item = (usize, usize)>) -> Vec<(usize, usize)> {
    let mut recent: Vec<(usize, usize)> = Vec::new();
    let mut largest = None;
    for size in latest_first {
        if !recent.contains(&size) {
            recent.push(size);
        }
        if largest.is_none_or(|(w, h)| size.0 * size.1 > w * h) {
            largest = Some(size);
        }
    }
    recent.truncate(KEPT_PREVIEW_SIZES);
    recent.extend(largest.filter(|l| !recent.contains(l)));
    recent
}

/// Whether every ray of a frame stays within its tile's candidates: no shadow rays, no field
/// shading (soft shadows, occlusion), no transparent group (reflected and refracted rays).
fn rays_stay_in_their_tiles(compiled: &Compiled, options: &RenderOptions) -> bool {
    !options.shadows
        && !options.shading.any()
        && compiled.materials.iter().all(|m| m.opacity >= 1.0)
}

impl Capabilities for CpuBackend {
    fn device_kind(&self) -> DeviceKind {
        DeviceKind::Cpu
    }

    fn supports(
        &self,
        compiled: &Compiled,
        method: MethodId,
        _request: &FrameRequest,
    ) -> Result<(), String> {
        method.method().supports(&compiled.program)
    }
}

impl FrameBackend for CpuBackend {
    fn describe(&self) -> String {
        format!("CPU, {} threads", rayon::current_num_threads())
    }

    fn render(
        &mut self,
        compiled: &Arc<Compiled>,
        request: &FrameRequest,
    ) -> Result<Vec<Frame>, BackendError> {
        let shading = match request.view {
            View::Shaded(shading) => shading,
            View::Steps { .. } => FieldShading::default(),
        };
        let options = RenderOptions {
            width: request.width,
            height: request.height,
            shadows: request.shadows,
            shading,
        };
        let view = ViewOf {
            camera: request.camera,
            width: request.width,
            height: request.height,
            view: request.view,
            settings: request.settings,
        };
        let reuse = self.reuse && rays_stay_in_their_tiles(compiled, &options);
        self.reused = (0, 0);
        self.reused_pixels = (0, 0);
        let mut frames = Vec::with_capacity(request.methods.len());
        for &id in &request.methods {
            let method = id.method();
            method
                .supports(&compiled.program)
                .map_err(|why| BackendError::Unsupported(format!("{id}: {why}")))?;
            let tracer = method.prepare(&compiled.program, request.settings);
            let renderer = Renderer::new(compiled, tracer.as_ref(), request.settings);
            let inputs = reuse.then(|| method.scene_inputs(&compiled.program));
            let earlier = inputs
                .as_deref()
                .and_then(|inputs| self.earlier(compiled, &view, method.as_ref(), inputs));
            let mut traced = renderer
                .render_reusing(
                    &request.camera,
                    options,
                    &request.cancel,
                    earlier
                        .as_ref()
                        .map(|(kept, changed)| EarlierFrame {
                            frame: &kept.traced.frame,
                            tile_primitives: &kept.traced.tile_primitives,
                            changed,
                            program: &kept.compiled.program,
                        })
                        .as_ref(),
                )
                .ok_or(BackendError::Cancelled)?;
            self.reused.0 += traced.reused_tiles;
            self.reused.1 += traced.tile_primitives.len();
            self.reused_pixels.0 += traced.reused_pixels;
            self.reused_pixels.1 += traced.frame.width * traced.frame.height;
            if let View::Steps { steps_max } = request.view {
                let top = f64::from(steps_max.max(1));
                for (colour, &steps) in traced.frame.colour.iter_mut().zip(&traced.frame.steps) {
                    *colour = heat_colour(f64::from(steps) / top);
                }
            }
            match inputs {
                Some(scene_inputs) => {
                    frames.push(traced.frame.clone());
                    self.keep(KeptFrame {
                        compiled: Arc::clone(compiled),
                        view,
                        method: id,
                        scene_inputs,
                        traced,
                    });
                }
                None => frames.push(traced.frame),
            }
        }
        Ok(frames)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A drag's previews at several resolutions do not push the full frame out.
    #[test]
    fn the_full_frame_and_the_latest_previews_are_kept() {
        let full = (800, 600);
        let previews = [(160, 120), (200, 150), (266, 200)];
        // Latest first: the full frame was traced before the drag's three previews.
        let kept = sizes_to_keep([previews[2], previews[1], previews[0], full].into_iter());
        assert_eq!(kept, vec![previews[2], previews[1], full]);
        // The full frame traced last, after two previews: those stay too.
        let kept = sizes_to_keep([full, previews[1], previews[0]].into_iter());
        assert_eq!(kept, vec![full, previews[1]]);
        assert_eq!(sizes_to_keep([full, full].into_iter()), vec![full]);
    }
}
