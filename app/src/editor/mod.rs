//! The editor (DESIGN.md, "Editor"): a skeleton overlay on the ray-traced surface, the
//! inspector, the method comparison grid, files, undo/redo, autosave and recovery.
//!
//! Layout: menu bar (top), inspector (left: file, selection, group kernel and material, scene
//! blend), viewport or comparison grid (centre), status bar (bottom: frame time per method,
//! adapter, where each method ran). [`Editor::ui`] draws one frame; eframe calls it through
//! [`EditorApp`] and the kittest tests call it directly.

mod blend_editor;
mod compare;
mod document;
mod files;
mod frames;
mod gizmo;
pub mod gpu_viewport;
mod group_tools;
mod groups;
mod inspector;
mod lights;
mod mesh_export;
mod ray_inspector;
mod selection;
mod shape_tools;
mod skeleton_edits;
use skeleton_edits::SkeletonEdit;
mod state;
mod symmetry;
mod templates;
mod view;
mod viewport;
mod worker;

use std::path::{Path, PathBuf};
use std::time::Instant;

use eframe::egui;
use skeletrace_core::Scene;
use skeletrace_core::backend::{Cancel, FrameRequest};
use skeletrace_core::frame::FieldShading;
use skeletrace_core::frame::Frame;
use skeletrace_core::methods::MethodId;

pub use document::{Document, Edit};
pub use files::{DialogRequest, FileDialogs, FilePurpose, SystemFileDialogs};
pub use selection::{Item, Selection};
pub use skeletrace_core::backend::BackendChoice;
use state::{MethodTag, Notice, TagsKey};
pub use state::{Mirror, UI_STATE_KEY, UiState, ViewMode};
pub use templates::Template;
pub use view::OrbitCamera;

use crate::picture::{Canvas, Panels, compose, shared_scale};
use worker::{RenderWorker, Request};

/// Seconds between autosaves of a dirty scene to the recovery file.
const AUTOSAVE_SECONDS: u64 = 20;

/// The editor's state.
pub struct Editor {
    doc: Document,
    selection: Selection,
    orbit: OrbitCamera,
    ui_state: UiState,
    /// The viewport's frames: requests to the render thread and the replies shown.
    frames: frames::ViewportFrames,
    /// The group new items go to.
    active_group: usize,
    /// Files, dialogs, recovery and autosave (`files.rs`).
    files: files::FileState,
    /// Messages, prompts and the help window (`inspector.rs`).
    prompts: inspector::Prompts,
    /// What the viewport and the comparison grid keep between frames (`viewport.rs`).
    view: viewport::ViewportState,
    /// The mesh export's estimate and running job (`mesh_export.rs`).
    mesh_export: mesh_export::MeshExport,
}

impl Editor {
    /// An editor on `doc`. `recovery_path` is where autosaves go (none in tests); a recovery
    /// file found there is offered for restore.
    #[must_use]
    pub fn new(
        doc: Document,
        ui_state: UiState,
        recovery_path: Option<PathBuf>,
        wake: impl Fn() + Send + 'static,
    ) -> Self {
        let recovery_offer = recovery_path
            .as_deref()
            .filter(|p| p.exists())
            .and_then(|p| Scene::load(p).ok());
        let orbit = OrbitCamera::from_camera(&doc.scene().camera);
        let path_field = doc
            .path()
            .map(|p| p.display().to_string())
            .unwrap_or_default();
        Self {
            doc,
            selection: Selection::new(),
            orbit,
            ui_state,
            frames: frames::ViewportFrames::new(wake),
            active_group: 0,
            files: files::FileState::new(recovery_offer, recovery_path, path_field),
            prompts: inspector::Prompts::default(),
            mesh_export: mesh_export::MeshExport::default(),
            view: viewport::ViewportState::default(),
        }
    }

    /// The document (tests inspect the scene through it).
    #[must_use]
    pub fn document(&self) -> &Document {
        &self.doc
    }

    /// The selection.
    #[must_use]
    pub fn selection(&self) -> &Selection {
        &self.selection
    }

    /// The persisted UI state.
    #[must_use]
    pub fn ui_state(&self) -> &UiState {
        &self.ui_state
    }

    /// The viewport camera.
    #[must_use]
    pub fn orbit(&self) -> &OrbitCamera {
        &self.orbit
    }

    /// Where the comparison grid was last drawn: its area less the colour bar, and each
    /// panel's image (window points).
    #[must_use]
    pub fn compare_layout(&self) -> Option<&(egui::Rect, Vec<egui::Rect>)> {
        self.view.compare_layout.as_ref()
    }

    /// Where the shaded viewport was last drawn (window points).
    #[must_use]
    pub fn viewport_rect(&self) -> Option<egui::Rect> {
        self.view.viewport_rect
    }

    /// The pixel of the comparison grid's frames under the pointer, if any.
    #[must_use]
    pub fn hovered_pixel(&self) -> Option<(usize, usize)> {
        self.view.hovered_pixel
    }

    /// Frames currently shown, with their methods.
    #[must_use]
    pub fn shown_frames(&self) -> Vec<(MethodId, &Frame)> {
        self.frames
            .shown
            .as_ref()
            .map(|s| s.frames.iter().map(|f| (f.method, &f.frame)).collect())
            .unwrap_or_default()
    }

    /// How many of the render thread's frames on screen were traced on a GPU and read back (the
    /// GPU viewport reads none back: its frames stay on the device).
    #[must_use]
    pub fn render_thread_gpu_frames(&self) -> usize {
        self.frames
            .shown
            .iter()
            .flat_map(|s| &s.frames)
            .filter(|f| f.on_gpu)
            .count()
    }

    /// What the shaded viewport or the grid shows: `Some(true)` the window's GPU, `Some(false)`
    /// the render thread's frames of the document's current revision while the window's GPU
    /// compiles its pipelines, `None` otherwise (the render thread's frames without a GPU
    /// viewport, or nothing yet).
    #[must_use]
    pub fn viewport_source(&self) -> Option<bool> {
        if self.view.viewport_on_gpu {
            Some(true)
        } else if self.view.gpu_compiling {
            self.frames
                .shown_of(self.doc.revision())
                .is_some_and(|s| !s.frames.is_empty())
                .then_some(false)
        } else {
            None
        }
    }

    /// Blocks until the renderer has answered every request sent so far and shows the answer
    /// (tests: the frame then reflects the current scene).
    pub fn wait_for_frames(&mut self, ctx: &egui::Context) {
        let failure = self
            .frames
            .wait_for_all(ctx, self.ui_state.view, self.ui_state.step_scale);
        self.report_device_failure(failure);
    }

    /// Where `item`'s handle is drawn in the shaded viewport (window points), if visible.
    #[must_use]
    pub fn screen_position(&self, item: Item) -> Option<egui::Pos2> {
        self.screen_circle(item).map(|(at, _)| at)
    }

    /// `item`'s handle and the radius of its radius circle in the shaded viewport (window
    /// points), if visible.
    #[must_use]
    pub fn screen_circle(&self, item: Item) -> Option<(egui::Pos2, f32)> {
        let (projection, to_screen) = self.viewport_projection()?;
        let (centre, radius) = item.world_ball(self.doc.scene())?;
        let (x, y, z) = projection.project(centre)?;
        Some((to_screen(x, y), projection.pixels(radius, z) as f32))
    }

    /// The screen end of HRBF point `item`'s drawn normal (window points), if visible: drag it
    /// around the point's handle to turn the normal.
    #[must_use]
    pub fn screen_normal_tip(&self, item: Item) -> Option<egui::Pos2> {
        let (projection, to_screen) = self.viewport_projection()?;
        viewport::normal_tip(&projection, &to_screen, self.doc.scene(), item)
    }

    /// The shaded viewport's projection and its pixel → window-point map, once it was drawn.
    fn viewport_projection(
        &self,
    ) -> Option<(view::Projection, impl Fn(f64, f64) -> egui::Pos2 + use<>)> {
        let rect = self.view.viewport_rect?;
        let projection = view::Projection::new(
            &self.orbit.camera(),
            f64::from(rect.width()),
            f64::from(rect.height()),
        );
        let to_screen =
            move |x: f64, y: f64| egui::pos2(rect.left() + x as f32, rect.top() + y as f32);
        Some((projection, to_screen))
    }

    /// The message in the status bar, if any.
    #[must_use]
    pub fn notice(&self) -> Option<&str> {
        self.prompts.notice.as_ref().map(|n| n.text.as_str())
    }

    fn tell(&mut self, text: impl Into<String>) {
        self.prompts.notice = Some(Notice {
            text: text.into(),
            error: false,
        });
    }

    fn complain(&mut self, text: impl Into<String>) {
        self.prompts.notice = Some(Notice {
            text: text.into(),
            error: true,
        });
    }

    /// Applies an edit as the inspector does (undoable, compiled once), reporting a refused
    /// one in the status bar; whether it was applied.
    pub fn apply(&mut self, edit: Edit, change: impl FnOnce(&mut Scene)) -> bool {
        match self.doc.apply(edit, change) {
            Ok(()) => true,
            Err(why) => {
                self.complain(why);
                false
            }
        }
    }

    /// Draws one frame of the whole window.
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        let failure = self
            .frames
            .receive(&ctx, self.ui_state.view, self.ui_state.step_scale);
        self.report_device_failure(failure);
        self.poll_file_dialog(&ctx);
        self.poll_background_writes();
        self.handle_dropped_files(&ctx);
        self.handle_shortcuts(&ctx);
        self.handle_close(&ctx);
        self.update_title(&ctx);
        egui::Panel::top("menu").show(ui, |ui| self.menu_bar(ui));
        egui::Panel::bottom("status").show(ui, |ui| self.status_bar(ui));
        egui::Panel::left("inspector")
            .default_size(290.0)
            .resizable(true)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| self.inspector(ui));
            });
        egui::CentralPanel::default().show(ui, |ui| match self.ui_state.view {
            ViewMode::Shaded => self.viewport(ui),
            ViewMode::Compare => self.comparison(ui),
        });
        self.ray_inspector(&ctx);
        self.dialogs(&ctx);
        self.export_progress_window(&ctx);
        self.autosave(&ctx);
        if ui.input(|i| i.pointer.any_released()) {
            self.doc.end_gesture();
        }
    }

    /// Asks for the frames of the viewport (or of one grid panel of `pixels`) as they should be
    /// now; nothing is sent when nothing they depend on changed.
    fn request_frames(&mut self, ctx: &egui::Context, pixels: (usize, usize)) {
        // While the window's GPU compiles the scene's pipelines, the CPU traces previews of it
        // (a GPU on the render thread would compile the same pipelines first).
        let compiling = self.view.gpu_compiling;
        let interacting = compiling
            || self.view.gesture.is_active()
            || self.files.last_interaction.elapsed() < frames::REFINE_AFTER;
        let order = frames::FrameOrder {
            revision: self.doc.revision(),
            compiled: self.doc.compiled(),
            frame: self.view_request(pixels),
            backend: if compiling {
                BackendChoice::Cpu
            } else {
                self.ui_state.backend
            },
            interacting,
        };
        self.frames.request(ctx, order);
    }

    /// The frame request of what the window shows, `size` pixels per panel: the shaded view's
    /// method with its shadows and field shading, or the grid's methods as step counts, under
    /// the scene's settings. The viewport, the grid and screenshots all ask for this one.
    fn view_request(&self, size: (usize, usize)) -> FrameRequest {
        let compiled = self.doc.compiled();
        let (methods, shadows, shading) = match self.ui_state.view {
            ViewMode::Shaded => (
                vec![self.ui_state.shaded_method],
                self.ui_state.shadows,
                self.ui_state.shading,
            ),
            ViewMode::Compare => (
                self.ui_state.compare_methods.clone(),
                false,
                FieldShading::default(),
            ),
        };
        FrameRequest {
            methods,
            ..worker::frame_request(
                &compiled,
                self.orbit.camera(),
                size,
                shadows,
                shading,
                Cancel::new(),
            )
        }
    }

    /// The window's title: the document's file name (or "untitled"), `*` while it has unsaved
    /// changes, sent to the window when it changes.
    #[must_use]
    pub fn title(&self) -> String {
        let name = self.doc.path().and_then(|p| p.file_name()).map_or_else(
            || "untitled".to_owned(),
            |n| n.to_string_lossy().into_owned(),
        );
        let dirty = if self.doc.is_dirty() { "*" } else { "" };
        format!("{name}{dirty} — skeletrace")
    }

    fn update_title(&mut self, ctx: &egui::Context) {
        let title = self.title();
        if self.files.window_title.as_deref() != Some(title.as_str()) {
            ctx.send_viewport_cmd(egui::ViewportCommand::Title(title.clone()));
            self.files.window_title = Some(title);
        }
    }

    /// Shows a device failure the render thread reported: the frames came from the CPU.
    fn report_device_failure(&mut self, failure: Option<String>) {
        if let Some(text) = failure {
            self.prompts.notice = Some(Notice { text, error: true });
        }
    }

    fn touch(&mut self) {
        self.files.last_interaction = Instant::now();
    }

    // ---- keyboard ----

    fn handle_shortcuts(&mut self, ctx: &egui::Context) {
        use egui::{Key, KeyboardShortcut, Modifiers};
        let shortcut = |m: Modifiers, k: Key| {
            ctx.input_mut(|i| i.consume_shortcut(&KeyboardShortcut::new(m, k)))
        };
        if shortcut(Modifiers::COMMAND | Modifiers::SHIFT, Key::Z)
            || shortcut(Modifiers::COMMAND, Key::Y)
        {
            self.redo();
        }
        if shortcut(Modifiers::COMMAND, Key::Z) {
            self.undo();
        }
        if shortcut(Modifiers::COMMAND | Modifiers::SHIFT, Key::S) {
            self.ask_for_file(ctx, files::FilePurpose::SaveAs);
        }
        if shortcut(Modifiers::COMMAND, Key::S) {
            self.save_or_ask(ctx);
        }
        if shortcut(Modifiers::COMMAND, Key::O) {
            self.ask_for_file(ctx, files::FilePurpose::Open);
        }
        if shortcut(Modifiers::COMMAND, Key::N) {
            self.replace_document(files::Replacement::New(Template::Empty));
        }
        if shortcut(Modifiers::COMMAND, Key::D) {
            self.duplicate();
        }
        if ctx.egui_wants_keyboard_input() {
            return;
        }
        let pressed = |k: Key| ctx.input(|i| i.key_pressed(k) && i.modifiers.is_none());
        if pressed(Key::Delete) || pressed(Key::Backspace) {
            self.delete();
        }
        if pressed(Key::F1) || ctx.input(|i| i.events.contains(&egui::Event::Text("?".into()))) {
            self.prompts.help = !self.prompts.help;
        }
        if pressed(Key::F) {
            self.frame_selection();
        }
        if pressed(Key::Home) || pressed(Key::A) {
            self.frame_all();
        }
        for view in view::StandardView::ALL {
            let (key, ctrl, _) = view.key();
            let hit = if ctrl {
                shortcut(Modifiers::COMMAND, key)
            } else {
                pressed(key)
            };
            if hit {
                self.look_from(view);
            }
        }
        if pressed(Key::S) {
            self.view.sketch = !self.view.sketch;
        }
        if pressed(Key::C) {
            self.connect();
        }
        if pressed(Key::X) {
            self.disconnect();
        }
        if pressed(Key::I) {
            self.edit_skeleton(SkeletonEdit::Insert);
        }
        if pressed(Key::M) {
            self.edit_skeleton(SkeletonEdit::Merge);
        }
        if ctx.input(|i| i.key_pressed(Key::X) && i.modifiers.shift_only()) {
            self.edit_skeleton(SkeletonEdit::Dissolve);
        }
        if pressed(Key::B) {
            self.add_blob();
        }
        if pressed(Key::Tab) {
            self.ui_state.view = match self.ui_state.view {
                ViewMode::Shaded => ViewMode::Compare,
                ViewMode::Compare => ViewMode::Shaded,
            };
        }
        if pressed(Key::Escape) {
            self.selection.clear();
            self.view.sketch = false;
        }
        let step = 0.08;
        let mut turned = false;
        for (key, dx, dy) in [
            (Key::ArrowLeft, -1.0, 0.0),
            (Key::ArrowRight, 1.0, 0.0),
            (Key::ArrowUp, 0.0, -1.0),
            (Key::ArrowDown, 0.0, 1.0),
        ] {
            if pressed(key) {
                self.orbit.orbit(dx * step * 100.0, dy * step * 100.0);
                turned = true;
            }
        }
        if pressed(Key::Plus) || pressed(Key::Equals) {
            self.orbit.zoom(0.85);
            turned = true;
        }
        if pressed(Key::Minus) {
            self.orbit.zoom(1.0 / 0.85);
            turned = true;
        }
        if turned {
            self.touch();
        }
    }

    fn undo(&mut self) {
        let label = self.doc.undo_label().map(str::to_owned);
        if self.doc.undo() {
            self.prune_selection();
            self.tell(format!("undid {}", label.unwrap_or_default()));
        }
    }

    fn redo(&mut self) {
        let label = self.doc.redo_label().map(str::to_owned);
        if self.doc.redo() {
            self.prune_selection();
            self.tell(format!("redid {}", label.unwrap_or_default()));
        }
    }

    fn prune_selection(&mut self) {
        let scene = self.doc.scene().clone();
        self.selection.retain(|i| i.ball(&scene).is_some());
        self.active_group = self.active_group.min(scene.groups.len().saturating_sub(1));
    }

    // ---- selection commands ----

    fn delete(&mut self) {
        if self.selection.is_empty() {
            return;
        }
        let chosen = self.selection.clone();
        let label = format!("delete {} items", chosen.len());
        let mirror = self.ui_state.mirror;
        if self.apply(Edit::new(label), |s| symmetry::delete(s, &chosen, mirror)) {
            self.selection.clear();
        }
    }

    fn duplicate(&mut self) {
        if self.selection.is_empty() {
            return;
        }
        let chosen = self.selection.clone();
        let offset = 0.15 * self.typical_radius();
        let mut copies = Selection::new();
        let label = format!("duplicate {} items", chosen.len());
        if self.apply(Edit::new(label), |s| {
            copies = selection::duplicate(s, &chosen, [offset, offset, 0.0]);
        }) {
            self.selection = copies;
        }
    }

    fn connect(&mut self) {
        let chosen = self.selection.clone();
        let mut outcome = Ok(());
        let applied = self.apply(Edit::new("connect"), |s| {
            outcome = selection::connect(s, &chosen);
        });
        match outcome {
            Err(why) => self.complain(why),
            Ok(()) if applied => self.tell("connected two vertices"),
            Ok(()) => {}
        }
    }

    /// Inserts, merges or dissolves vertices of the selection's skeleton; the result is
    /// selected, or the reason it cannot be done shown.
    fn edit_skeleton(&mut self, edit: SkeletonEdit) {
        let chosen = self.selection.clone();
        let mut outcome = Ok(None);
        let applied = self.apply(Edit::new(edit.name()), |s| {
            outcome = match edit {
                SkeletonEdit::Insert => skeleton_edits::insert_vertex(s, &chosen).map(Some),
                SkeletonEdit::Merge => skeleton_edits::merge_vertices(s, &chosen).map(Some),
                SkeletonEdit::Dissolve => {
                    skeleton_edits::dissolve_vertex(s, &chosen).map(|()| None)
                }
            };
        });
        match outcome {
            Err(why) => self.complain(why),
            Ok(item) if applied => {
                self.selection = item.into_iter().collect();
                self.tell(edit.name());
            }
            Ok(_) => {}
        }
    }

    fn disconnect(&mut self) {
        let chosen = self.selection.clone();
        self.apply(Edit::new("disconnect"), |s| {
            selection::disconnect(s, &chosen);
        });
    }

    fn add_blob(&mut self) {
        let group = self.active_group;
        let centre =
            selection::centroid(self.doc.scene(), &self.selection).unwrap_or(self.orbit.target);
        let radius = self.typical_radius();
        let mut added = None;
        let applied = self.apply(Edit::new("add blob"), |s| {
            // The new blob sits beside the selection in the viewport, in the group's frame.
            let center =
                selection::to_group_frame(s, group, [centre[0] + radius, centre[1], centre[2]]);
            let radius = radius / selection::placement(s, group).scale;
            if let Some(g) = s.groups.get_mut(group) {
                g.blobs
                    .push(skeletrace_core::model::scene::Blob { center, radius });
                added = Some(Item::Blob {
                    group,
                    blob: g.blobs.len() - 1,
                });
            }
        });
        if let (true, Some(item)) = (applied, added) {
            self.selection = Selection::from([item]);
        }
    }

    /// Mean radius of the selected items (of every item when none has one; 0.2 in an empty
    /// scene), in world units: the size of new vertices, blobs and sets.
    fn typical_radius(&self) -> f64 {
        let mean = |balls: Vec<([f64; 3], f64)>| {
            let radii: Vec<f64> = balls
                .into_iter()
                .map(|(_, r)| r)
                .filter(|r| *r > 0.0)
                .collect();
            (!radii.is_empty()).then(|| radii.iter().sum::<f64>() / radii.len() as f64)
        };
        let scene = self.doc.scene();
        let selected = self
            .selection
            .iter()
            .filter_map(|i| i.world_ball(scene))
            .collect();
        mean(selected)
            .or_else(|| mean(view::scene_balls(scene)))
            .unwrap_or(0.2)
    }

    fn look_from(&mut self, view: view::StandardView) {
        self.orbit.look_from(view);
        self.touch();
    }

    fn frame_all(&mut self) {
        self.orbit.frame(view::scene_balls(self.doc.scene()));
        self.touch();
    }

    fn frame_selection(&mut self) {
        let balls: Vec<_> = self
            .selection
            .iter()
            .filter_map(|i| i.world_ball(self.doc.scene()))
            .collect();
        if balls.is_empty() {
            self.frame_all();
        } else {
            self.orbit.frame(balls);
            self.touch();
        }
    }

    // ---- screenshots ----

    /// Renders the current view (the shaded method, or the comparison grid) offscreen at the
    /// screenshot size and writes a PNG, on a thread of its own.
    fn screenshot(&mut self, ctx: &egui::Context, path: PathBuf) {
        let (width, height) = self.ui_state.screenshot_size;
        let view = self.ui_state.view;
        let panels = self.view_request((1, 1)).methods.len();
        let per_panel = if view == ViewMode::Compare {
            let n = panels.clamp(1, crate::picture::COLUMNS);
            (
                width / n,
                height * panels.div_ceil(n).max(1) / panels.max(1),
            )
        } else {
            (width, height)
        };
        let id = self.frames.next_id();
        let request = Request {
            id,
            compiled: self.doc.compiled(),
            frame: self.view_request((per_panel.0.max(8), per_panel.1.max(8))),
            backend: self.ui_state.backend,
            preview: false,
        };
        let scale = self.ui_state.step_scale;
        let what = format!("screenshot {}", path.display());
        self.write_in_background(ctx, what, move || {
            let offscreen = RenderWorker::start(|| {});
            offscreen.request(request);
            let reply = offscreen
                .wait_for(id, worker::LONGEST_FRAME)
                .ok_or("the renderer stopped before the screenshot was traced")?;
            let named: Vec<(&str, Frame)> = reply
                .frames
                .iter()
                .map(|t| (t.method.name(), t.frame.clone()))
                .collect();
            let panels = match view {
                ViewMode::Shaded => Panels::Shaded { labelled: false },
                ViewMode::Compare => {
                    let steps_max = shared_scale(&named).max(1);
                    let clipped = named.iter().any(|(_, f)| f.step_summary().max > steps_max);
                    Panels::Steps {
                        steps_max,
                        scale,
                        clipped,
                    }
                }
            };
            let canvas: Canvas = compose(&named, panels);
            canvas.save_png(&path, &[])?;
            Ok(format!(
                "screenshot {} ({}x{})",
                path.display(),
                canvas.width,
                canvas.height
            ))
        });
    }
}

/// The embedded default scene.
#[must_use]
pub fn default_scene() -> Scene {
    // The embedded file is checked by the asset tests; a failure here is a build defect.
    Scene::from_ron(crate::DEFAULT_SCENE, crate::DEFAULT_SCENE_NAME)
        .unwrap_or_else(|e| unreachable!("embedded scene: {e}"))
}

/// eframe's side of the editor: persistence and the window.
pub struct EditorApp {
    editor: Editor,
}

impl eframe::App for EditorApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        self.editor.ui(ui);
    }

    fn save(&mut self, storage: &mut dyn eframe::Storage) {
        eframe::set_value(storage, UI_STATE_KEY, &self.editor.ui_state);
    }

    fn on_exit(&mut self) {
        self.editor.on_exit();
    }
}

/// Where the recovery file lives: `$XDG_STATE_HOME/skeletrace` or `~/.local/state/skeletrace`.
fn recovery_file() -> Option<PathBuf> {
    let base = std::env::var_os("XDG_STATE_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".local/state")))?;
    Some(base.join("skeletrace").join("recovery.ron"))
}

/// Opens the editor window on `path`, or on the embedded scene.
///
/// # Errors
/// A scene that does not load, or no window (no display).
pub fn run(path: Option<&Path>) -> Result<(), String> {
    let doc = match path {
        Some(p) => Document::open(p)?,
        None => Document::new(default_scene(), None),
    };
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title("skeletrace")
            .with_inner_size([1280.0, 800.0])
            .with_drag_and_drop(true),
        wgpu_options: gpu_viewport::wgpu_configuration(),
        ..Default::default()
    };
    eframe::run_native(
        "skeletrace",
        options,
        Box::new(move |cc| {
            let ui_state: UiState = cc
                .storage
                .and_then(|s| eframe::get_value(s, UI_STATE_KEY))
                .unwrap_or_default();
            let ctx = cc.egui_ctx.clone();
            let mut editor = Editor::new(doc, ui_state, recovery_file(), move || {
                ctx.request_repaint();
            });
            if let Some(state) = cc
                .wgpu_render_state
                .as_ref()
                .filter(|s| gpu_viewport::wanted(s))
                && let Err(why) = editor.enable_gpu_viewport(state)
            {
                editor.complain(format!("GPU viewport unavailable: {why}"));
            }
            if let Some(p) = path_recent(&editor) {
                editor.files.path_field = p;
            }
            Ok(Box::new(EditorApp { editor }))
        }),
    )
    .map_err(|e| format!("cannot open the editor window: {e}"))
}

fn path_recent(editor: &Editor) -> Option<String> {
    if editor.doc.path().is_some() {
        return None;
    }
    editor
        .ui_state
        .recent
        .first()
        .map(|p| p.display().to_string())
}
