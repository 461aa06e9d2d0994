//! The shaded viewport: the traced frame, the skeleton overlay (vertex handles, segments,
//! radius circles, blobs, hover and selection highlights), the translate gizmo (`gizmo.rs`),
//! click and box selection, sketch
//! mode, radius editing (drag a selected item's radius circle, or the wheel over its handle),
//! HRBF normals (drag the tip of a selected point's normal around it) and the mouse camera
//! (left drag orbit, right or middle drag pan, wheel zoom).

use eframe::egui::{self, Color32, Pos2, Rect, Sense, Stroke, StrokeKind, Vec2};
use skeletrace_core::frame::{StepScale, View};
use skeletrace_render::viewport::ViewportFrame;

use super::gizmo::{Gizmo, Handle};
use super::selection::{self, Item, Selection};
use super::state::{MethodTag, TagsKey};
use super::symmetry;
use super::view::Projection;
use super::{Edit, Editor};

/// What a mouse drag in the viewport is doing.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Gesture {
    /// Nothing.
    #[default]
    None,
    /// Turning the camera.
    Orbit,
    /// Moving the camera target.
    Pan,
    /// Moving the selection with a gizmo handle.
    Move(Handle),
    /// Scaling the selection's radii by dragging a radius circle about this centre.
    Radius(Pos2),
    /// Box selection from this corner.
    Box(Pos2),
    /// Turning this HRBF point's normal about the viewing axis by dragging its tip.
    Normal(Item),
}

impl Gesture {
    /// A drag is under way.
    #[must_use]
    pub fn is_active(self) -> bool {
        self != Self::None
    }
}

/// Pick distance, points.
const PICK: f32 = 9.0;
/// Most items the overlay draws: past it (a million-segment foam), only the selection is drawn
/// and picked, so that the frame's mesh stays within what the GPU accepts (egui's index buffer
/// once exceeded wgpu's 256 MiB buffer limit) and the UI stays interactive.
const OVERLAY_ITEMS_MAX: usize = 20_000;
const SELECTED: Color32 = Color32::from_rgb(255, 200, 60);

/// An item as drawn: screen position (points), radius on screen, and for an HRBF point the
/// screen end of its normal.
struct Drawn {
    item: Item,
    at: Pos2,
    radius: f32,
    tip: Option<Pos2>,
}

/// What the viewport and the comparison grid keep between frames.
#[derive(Default)]
pub(super) struct ViewportState {
    pub gesture: Gesture,
    /// Clicks in the viewport add vertices.
    pub sketch: bool,
    pub hovered_pixel: Option<(usize, usize)>,
    /// Where the shaded viewport was last drawn.
    pub viewport_rect: Option<egui::Rect>,
    /// The methods' tags, and what they were found for: the scene revision, the backend
    /// choice, the shading and the render thread's GPU.
    pub method_tags: Option<(TagsKey, Vec<MethodTag>)>,
    /// The ray the inspector window shows.
    pub ray_probe: Option<crate::ray_probe::RayProbe>,
    /// Where the comparison grid was last drawn: its area (less the colour bar) and each
    /// panel's image.
    pub compare_layout: Option<(egui::Rect, Vec<egui::Rect>)>,
    /// The window's wgpu state when the shaded viewport is traced on its device
    /// (`gpu_viewport.rs`).
    pub gpu_viewport: Option<eframe::egui_wgpu::RenderState>,
    /// The shaded viewport or the comparison grid was last drawn by the GPU viewport.
    pub viewport_on_gpu: bool,
    /// The GPU viewport compiles the pipelines of the frame asked for: the render thread
    /// traces the view on the CPU meanwhile, and its frames of this revision are shown.
    pub gpu_compiling: bool,
}

impl Editor {
    /// The shaded viewport: the frame (on the window's GPU where it can, else the render
    /// thread's), the skeleton overlay and gizmo, and what the mouse does there.
    pub(super) fn viewport(&mut self, ui: &mut egui::Ui) {
        let rect = ui.available_rect_before_wrap();
        self.view.viewport_rect = Some(rect);
        let ppp = ui.ctx().pixels_per_point();
        let pixels = (
            (rect.width() * ppp) as usize,
            (rect.height() * ppp) as usize,
        );
        let (gpu_frame, compiling) = self.gpu_viewport_frame_or_compiling(
            View::Shaded(self.ui_state.shading),
            (pixels.0 as u32, pixels.1 as u32),
        );
        let on_gpu = gpu_frame.is_some();
        if gpu_frame.is_none() {
            self.request_frames(ui.ctx(), pixels);
        }
        let response = ui.allocate_rect(rect, Sense::click_and_drag());
        let painter = ui.painter_at(rect);
        if let Some(frame) = compiling {
            self.keep_compiling(&painter, rect, frame);
        }
        self.paint_viewport_frame(&painter, rect, gpu_frame);
        let Some((projection, to_screen)) = self.viewport_projection() else {
            return;
        };
        let drawn = self.draw_overlay(&painter, &projection, &to_screen);
        let hovered = response.hover_pos().and_then(|p| nearest(&drawn, p));
        if let Some(d) = hovered.and_then(|h| drawn.iter().find(|d| d.item == h)) {
            painter.circle_stroke(d.at, 7.0, Stroke::new(2.0, Color32::WHITE));
        }
        let gizmo = selection::centroid(self.doc.scene(), &self.selection)
            .and_then(|c| Gizmo::place(c, &projection, &to_screen));
        if let Some(gizmo) = &gizmo {
            let active = match self.view.gesture {
                Gesture::Move(handle) => Some(handle),
                _ => None,
            };
            gizmo.draw(&painter, active, SELECTED);
        }
        if self.view.sketch {
            painter.text(
                rect.left_top() + Vec2::new(10.0, 10.0),
                egui::Align2::LEFT_TOP,
                "SKETCH: click to add a vertex joined to the selected one (S or Esc to leave)",
                egui::FontId::proportional(14.0),
                SELECTED,
            );
        }
        let shift = ui.input(|i| i.modifiers.shift);
        if response.drag_started() {
            self.begin_gesture(ui, &response, gizmo.as_ref(), &drawn);
        }
        if response.dragged() {
            self.continue_gesture(&response, &painter, gizmo.as_ref(), &projection, &drawn);
        }
        if response.drag_stopped() {
            self.end_gesture(&response, &drawn, shift);
        }
        if response.clicked() {
            let at = response.interact_pointer_pos().unwrap_or_default();
            if ui.input(|i| i.modifiers.alt) {
                self.inspect_viewport_pixel(at, rect, on_gpu.then_some(pixels));
            } else {
                self.viewport_click(at, rect, &projection, hovered, shift);
            }
        }
        let scroll = ui.input(|i| i.smooth_scroll_delta.y);
        if response.hovered() && scroll != 0.0 {
            let factor = (f64::from(scroll) * 0.002).exp();
            if hovered.is_some_and(|h| self.selection.contains(&h)) {
                let chosen = self.selection.clone();
                let mirror = self.ui_state.mirror;
                self.apply(Edit::gesture("radius", "scroll-radius"), |s| {
                    symmetry::scale_radius(s, &chosen, factor, mirror);
                });
            } else {
                self.orbit.zoom(1.0 / factor);
            }
            self.touch();
        }
    }

    /// The viewport's frame: the GPU viewport's paint callback, the render thread's last
    /// frame (while the GPU viewport compiles, only one of the scene as it is now), or
    /// "tracing…" before the first.
    fn paint_viewport_frame(
        &self,
        painter: &egui::Painter,
        rect: Rect,
        gpu_frame: Option<ViewportFrame>,
    ) {
        painter.rect_filled(rect, 0.0, Color32::from_rgb(20, 22, 26));
        let shown = if self.view.gpu_compiling {
            self.frames.shown_of(self.doc.revision())
        } else {
            self.frames.shown.as_ref()
        };
        if let Some(frame) = gpu_frame {
            self.paint_gpu_viewport(painter, rect, frame, vec![rect], (StepScale::Log, None));
        } else if let Some(f) = shown.and_then(|s| s.frames.first()) {
            painter.image(
                f.texture.id(),
                rect,
                Rect::from_min_max(Pos2::ZERO, egui::pos2(1.0, 1.0)),
                Color32::WHITE,
            );
        } else {
            painter.text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                "tracing…",
                egui::FontId::proportional(16.0),
                Color32::GRAY,
            );
        }
    }

    /// What a drag that starts here does: pan (secondary or middle button), move by a gizmo
    /// handle, turn a normal by its tip, change a radius by its ring, move the picked items,
    /// draw a selection box (Shift) or orbit.
    fn begin_gesture(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        gizmo: Option<&Gizmo>,
        drawn: &[Drawn],
    ) {
        let shift = ui.input(|i| i.modifiers.shift);
        // Where the button went down: the drag is recognised only after some movement.
        let start = ui
            .input(|i| i.pointer.press_origin())
            .or(response.interact_pointer_pos())
            .unwrap_or_default();
        let secondary = ui.input(|i| {
            i.pointer.button_down(egui::PointerButton::Secondary)
                || i.pointer.button_down(egui::PointerButton::Middle)
        });
        self.view.gesture = if secondary {
            Gesture::Pan
        } else if let Some(handle) = gizmo.and_then(|g| g.axis_or_plane_at(start)) {
            Gesture::Move(handle)
        } else if let Some(item) = tip_under(drawn, &self.selection, start) {
            Gesture::Normal(item)
        } else if let Some(centre) = ring_under(drawn, &self.selection, start) {
            Gesture::Radius(centre)
        } else if gizmo.is_some_and(|g| g.centre_at(start, PICK)) {
            Gesture::Move(Handle::ViewPlane)
        } else if let Some(item) = nearest(drawn, start) {
            if !self.selection.contains(&item) {
                if !shift {
                    self.selection.clear();
                }
                self.selection.insert(item);
            }
            Gesture::Move(Handle::ViewPlane)
        } else if shift {
            Gesture::Box(start)
        } else {
            Gesture::Orbit
        };
    }

    /// One step of the drag under way.
    fn continue_gesture(
        &mut self,
        response: &egui::Response,
        painter: &egui::Painter,
        gizmo: Option<&Gizmo>,
        projection: &Projection,
        drawn: &[Drawn],
    ) {
        let delta = response.drag_delta();
        let (dx, dy) = (f64::from(delta.x), f64::from(delta.y));
        let now = response.interact_pointer_pos();
        match self.view.gesture {
            Gesture::Orbit => self.orbit.orbit(dx, dy),
            Gesture::Pan => self.orbit.pan(dx, dy, f64::from(response.rect.height())),
            Gesture::Move(handle) => {
                if let (Some(gizmo), Some(now)) = (gizmo, now) {
                    let moved = gizmo.drag(
                        handle,
                        projection,
                        response.rect.left_top(),
                        now - delta,
                        now,
                    );
                    self.move_selection(moved);
                }
            }
            Gesture::Radius(centre) => {
                if let Some(now) = now {
                    let before = (now - delta - centre).length();
                    let after = (now - centre).length();
                    if before > 1.0 && after > 1.0 {
                        let chosen = self.selection.clone();
                        let factor = f64::from(after / before);
                        let mirror = self.ui_state.mirror;
                        self.apply(Edit::gesture("radius", "drag-radius"), |s| {
                            symmetry::scale_radius(s, &chosen, factor, mirror);
                        });
                    }
                }
            }
            Gesture::Normal(item) => {
                let at = drawn.iter().find(|d| d.item == item).map(|d| d.at);
                if let (Some(at), Some(now)) = (at, now) {
                    self.turn_normal(item, projection, now - delta - at, now - at);
                }
            }
            Gesture::Box(start) => {
                if let Some(now) = now {
                    painter.rect_stroke(
                        Rect::from_two_pos(start, now),
                        0.0,
                        Stroke::new(1.0, SELECTED),
                        StrokeKind::Middle,
                    );
                }
            }
            Gesture::None => {}
        }
        self.touch();
    }

    /// The end of a drag: a selection box selects what it holds (adds to it with Shift).
    fn end_gesture(&mut self, response: &egui::Response, drawn: &[Drawn], shift: bool) {
        if let (Gesture::Box(start), Some(end)) =
            (self.view.gesture, response.interact_pointer_pos())
        {
            let area = Rect::from_two_pos(start, end);
            if !shift {
                self.selection.clear();
            }
            self.selection
                .extend(drawn.iter().filter(|d| area.contains(d.at)).map(|d| d.item));
        }
        self.view.gesture = Gesture::None;
        self.doc.end_gesture();
        self.touch();
    }

    /// A click at `at`: in sketch mode on empty space, a new vertex on the plane through the
    /// selection (or the orbit target); else it picks `hovered` (Shift toggles it).
    fn viewport_click(
        &mut self,
        at: Pos2,
        rect: Rect,
        projection: &Projection,
        hovered: Option<Item>,
        shift: bool,
    ) {
        if self.view.sketch && hovered.is_none() {
            let anchor =
                selection::centroid(self.doc.scene(), &self.selection).unwrap_or(self.orbit.target);
            let position = projection.unproject_on_plane(
                f64::from(at.x - rect.left()),
                f64::from(at.y - rect.top()),
                anchor,
            );
            self.sketch_at(position);
            return;
        }
        match hovered {
            Some(item) if shift && !self.selection.remove(&item) => {
                self.selection.insert(item);
            }
            Some(_) if shift => {}
            Some(item) => self.selection = Selection::from([item]),
            None if !shift => self.selection.clear(),
            None => {}
        }
        if let Some(item) = hovered {
            self.active_group = item.group();
        }
    }

    fn move_selection(&mut self, delta: [f64; 3]) {
        if self.selection.is_empty() || delta == [0.0; 3] {
            return;
        }
        let chosen = self.selection.clone();
        let label = format!("move {} items", chosen.len());
        let mirror = self.ui_state.mirror;
        self.apply(Edit::gesture(label, "move"), |s| {
            symmetry::translate(s, &chosen, delta, mirror);
        });
    }

    /// Turns HRBF point `item`'s normal as its tip is dragged from screen offset `from` to `to`
    /// (from the point's handle).
    fn turn_normal(&mut self, item: Item, projection: &Projection, from: Vec2, to: Vec2) {
        if from.length() < 1.0 || to.length() < 1.0 {
            return;
        }
        let Item::HrbfPoint { group, set, point } = item else {
            return;
        };
        let pair = |v: Vec2| (f64::from(v.x), f64::from(v.y));
        self.apply(Edit::gesture("turn normal", "drag-normal"), |s| {
            let place = selection::placement(s, group);
            let Some(p) = s.groups[group]
                .hrbfs
                .get_mut(set)
                .and_then(|h| h.points.get_mut(point))
            else {
                return;
            };
            let world = place.direction(glam::DVec3::from_array(p.normal));
            let turned = projection.turn_in_view(world, pair(from), pair(to));
            p.normal = place.inverse_direction(turned).to_array();
        });
    }

    pub(super) fn sketch_at(&mut self, position: [f64; 3]) {
        let radius = self.typical_radius();
        let group = self.active_group;
        let chosen = self.selection.clone();
        let mut added = None;
        let mirror = self.ui_state.mirror;
        if self.apply(Edit::new("sketch vertex"), |s| {
            added = Some(symmetry::sketch_vertex(
                s, &chosen, group, position, radius, mirror,
            ));
        }) && let Some(item) = added
        {
            self.selection = Selection::from([item]);
        }
    }

    /// Draws segments, radius circles, handles, blobs and HRBF points with their normals;
    /// returns what can be picked.
    fn draw_overlay(
        &self,
        painter: &egui::Painter,
        projection: &Projection,
        to_screen: &dyn Fn(f64, f64) -> Pos2,
    ) -> Vec<Drawn> {
        let scene = self.doc.scene();
        let mut drawn = Vec::new();
        let line = Stroke::new(1.5, Color32::from_rgba_unmultiplied(235, 235, 245, 170));
        let ring = Stroke::new(1.0, Color32::from_rgba_unmultiplied(140, 190, 255, 90));
        let counts = scene.counts();
        let items = counts.vertices + counts.blobs + counts.hrbf_points;
        let full = items + counts.segments <= OVERLAY_ITEMS_MAX;
        let shown: Vec<Item> = if full {
            selection::all_items(scene)
        } else {
            painter.text(
                painter.clip_rect().left_bottom() + Vec2::new(10.0, -10.0),
                egui::Align2::LEFT_BOTTOM,
                format!(
                    "{items} handles and {} segments: over {OVERLAY_ITEMS_MAX}, only the \
                     selection is drawn",
                    counts.segments
                ),
                egui::FontId::proportional(13.0),
                Color32::LIGHT_GRAY,
            );
            self.selection.iter().copied().collect()
        };
        for item in shown {
            let Some((c, r)) = item.world_ball(scene) else {
                continue;
            };
            let Some((x, y, z)) = projection.project(c) else {
                continue;
            };
            drawn.push(Drawn {
                item,
                at: to_screen(x, y),
                radius: projection.pixels(r, z) as f32,
                tip: normal_tip(projection, to_screen, scene, item),
            });
        }
        for (group, g) in scene.groups.iter().enumerate().filter(|_| full) {
            let place = selection::placement(scene, group);
            let world = |p: [f64; 3]| place.point(glam::DVec3::from_array(p)).to_array();
            for s in &g.skeletons {
                for &[a, b] in &s.edges {
                    let pa = projection.project(world(s.vertices[a as usize].position));
                    let pb = projection.project(world(s.vertices[b as usize].position));
                    if let (Some(pa), Some(pb)) = (pa, pb) {
                        painter.line_segment([to_screen(pa.0, pa.1), to_screen(pb.0, pb.1)], line);
                    }
                }
            }
        }
        for d in &drawn {
            let selected = self.selection.contains(&d.item);
            if let Some(tip) = d.tip {
                let colour = if selected { SELECTED } else { NORMAL };
                painter.line_segment([d.at, tip], Stroke::new(1.5, colour));
                if selected {
                    painter.circle_stroke(tip, 3.0, Stroke::new(1.5, SELECTED));
                }
            } else {
                painter.circle_stroke(d.at, d.radius, ring);
            }
            let (fill, size) = match d.item {
                Item::Vertex { .. } => (Color32::from_rgb(240, 240, 250), 4.0),
                Item::Blob { .. } => (Color32::from_rgb(120, 220, 200), 4.5),
                Item::HrbfPoint { .. } => (NORMAL, 3.5),
            };
            if selected {
                painter.circle_filled(d.at, size + 1.5, SELECTED);
                if d.radius > 0.0 {
                    painter.circle_stroke(d.at, d.radius, Stroke::new(1.5, SELECTED));
                }
            } else {
                painter.circle_filled(d.at, size, fill);
            }
        }
        drawn
    }
}

/// Colour of HRBF point handles and their normals.
const NORMAL: Color32 = Color32::from_rgb(250, 200, 90);

/// Screen length of an HRBF normal seen side-on.
const NORMAL_PIXELS: f64 = 24.0;

/// The screen end of HRBF point `item`'s normal, drawn from its handle where the viewport
/// shows it (through its group's placement): [`NORMAL_PIXELS`] long when the normal lies in the
/// image plane, shorter as it turns towards the camera. `None` for other items and points
/// behind the camera.
pub(super) fn normal_tip(
    projection: &Projection,
    to_screen: &dyn Fn(f64, f64) -> Pos2,
    scene: &skeletrace_core::Scene,
    item: Item,
) -> Option<Pos2> {
    let point = item.hrbf_point(scene)?;
    let place = selection::placement(scene, item.group());
    let p = place.point(glam::DVec3::from_array(point.position));
    let n = place
        .direction(glam::DVec3::from_array(point.normal))
        .normalize_or_zero();
    let probe = 1e-3;
    let (x0, y0, z0) = projection.project(p.to_array())?;
    let at = to_screen(x0, y0);
    let Some((x1, y1, _)) = projection.project((p + probe * n).to_array()) else {
        return Some(at);
    };
    let per_unit = projection.pixels(probe, z0).max(1e-9);
    Some(at + (to_screen(x1, y1) - at) * (NORMAL_PIXELS / per_unit) as f32)
}

/// The drawn item nearest to `p` within the pick distance.
fn nearest(drawn: &[Drawn], p: Pos2) -> Option<Item> {
    drawn
        .iter()
        .map(|d| (d, (d.at - p).length()))
        .filter(|(_, dist)| *dist <= PICK)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(d, _)| d.item)
}

/// The selected HRBF point whose normal tip lies within the pick distance of `p`.
fn tip_under(drawn: &[Drawn], selection: &Selection, p: Pos2) -> Option<Item> {
    drawn
        .iter()
        .filter(|d| selection.contains(&d.item))
        .filter_map(|d| Some((d.item, (d.tip? - p).length())))
        .filter(|(_, dist)| *dist <= PICK)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(item, _)| item)
}

/// The centre of the selected item whose radius circle passes within the pick distance of
/// `p` (circles too small to tell from their handle do not count).
fn ring_under(drawn: &[Drawn], selection: &Selection, p: Pos2) -> Option<Pos2> {
    drawn
        .iter()
        .filter(|d| selection.contains(&d.item) && d.radius > 2.0 * PICK)
        .map(|d| (d.at, ((p - d.at).length() - d.radius).abs()))
        .filter(|(_, off)| *off <= PICK * 0.6)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(at, _)| at)
}
