//! The panels around the viewport: menu bar, inspector (file, selection, the active group's
//! field type, kernel, material and shapes, and the scene's isovalue and blend), method choice, status
//! bar, and the dialogs (help, unsaved changes, recovery). Every change is an [`Edit`] and is
//! live: the next frame is traced from the edited scene.

use eframe::egui;
use skeletrace_core::Compiled;
use skeletrace_core::backend::BackendChoice as Backend;
use skeletrace_core::backend::{
    BackendChoice, BackendError, Cancel, Capabilities, FrameRequest, Side, decide,
};
use skeletrace_core::frame::StepScale;
use skeletrace_core::methods::MethodId;
use skeletrace_core::model::kernel::Kernel;
use skeletrace_core::model::scene::{Blend, Hrbf, Shape, SkeletonField};
use skeletrace_render::GpuOfKind;

use super::files::{FilePurpose, Replacement};
use super::selection::{self, Item};
use super::{Edit, Editor, MethodTag, Notice, SkeletonEdit, TagsKey, ViewMode, worker};
use super::{blend_editor, group_tools, groups, shape_tools, symmetry};

/// Shortcuts listed by the help overlay.
pub const SHORTCUTS: [(&str, &str); 32] = [
    ("Left drag", "orbit (on a handle: move it)"),
    ("Right / middle drag", "pan"),
    ("Wheel", "zoom; over a selected handle: radius"),
    ("Click / Shift+click", "select / add to selection"),
    ("Shift+drag", "box selection"),
    (
        "Gizmo axis / centre",
        "move along an axis / in the view plane",
    ),
    ("Gizmo squares", "move in the yz, zx or xy plane"),
    ("Drag a selected circle", "scale the selection's radii"),
    ("Arrows, + / -", "orbit, zoom"),
    ("F", "frame the selection"),
    ("A or Home", "frame everything"),
    ("1 / 3 / 7 (Ctrl: opposite)", "front / right / top view"),
    (
        "S",
        "sketch mode: click adds a vertex joined to the selection",
    ),
    (
        "Mirror (menu bar)",
        "sketching, moves, radius changes and deletes reach each twin",
    ),
    ("C", "connect the two selected vertices"),
    ("X", "disconnect the selected vertices"),
    ("I", "insert a vertex into the segment of the two selected"),
    ("M", "merge the two selected vertices"),
    ("Shift+X", "dissolve a vertex: join its two neighbours"),
    ("B", "add a point blob"),
    ("Delete", "delete the selection"),
    ("Ctrl+D", "duplicate the selection"),
    ("Ctrl+Z", "undo"),
    ("Ctrl+Shift+Z / Ctrl+Y", "redo"),
    ("Ctrl+N", "new empty scene (File > New: templates)"),
    ("Ctrl+O", "open a scene (file dialog)"),
    ("Ctrl+S", "save (asks for a file when the scene has none)"),
    ("Ctrl+Shift+S", "save as (file dialog)"),
    ("Tab", "shaded view / method comparison"),
    ("Esc", "clear the selection, leave sketch mode"),
    ("F1 or ?", "this help"),
    (
        "Drop a .ron or .swc file",
        "open it (an SWC morphology is imported)",
    ),
];

/// Messages, prompts and the help window.
#[derive(Default)]
pub(super) struct Prompts {
    /// The status bar's message.
    pub notice: Option<Notice>,
    pub help: bool,
    /// The window's close asked while the scene has unsaved changes.
    pub close_prompt: bool,
    pub allow_close: bool,
    /// New / Open waiting for the user's answer about unsaved changes.
    pub replace_prompt: Option<Replacement>,
}

impl Editor {
    pub(super) fn menu_bar(&mut self, ui: &mut egui::Ui) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| self.file_menu(ui));
            ui.menu_button("Edit", |ui| self.edit_menu(ui));
            ui.menu_button("View", |ui| self.view_menu(ui));
            ui.separator();
            ui.selectable_value(&mut self.ui_state.view, ViewMode::Shaded, "Shaded");
            ui.selectable_value(
                &mut self.ui_state.view,
                ViewMode::Compare,
                "Compare methods",
            );
            ui.separator();
            ui.toggle_value(&mut self.view.sketch, "Sketch");
            let mirror_label = self.ui_state.mirror.map_or("off", super::Mirror::label);
            egui::ComboBox::from_id_salt("mirror")
                .selected_text(format!("Mirror: {mirror_label}"))
                .show_ui(ui, |ui| {
                    ui.selectable_value(&mut self.ui_state.mirror, None, "off");
                    for m in super::Mirror::ALL {
                        ui.selectable_value(&mut self.ui_state.mirror, Some(m), m.label());
                    }
                })
                .response
                .on_hover_text(
                    "mirror symmetry: sketching, moves, radius changes and deletes reach each \
                     item's twin across this plane",
                );
            if ui.button("Help").clicked() {
                self.prompts.help = !self.prompts.help;
            }
        });
    }

    /// The File menu: new, open, save, screenshot, mesh export, recent files.
    fn file_menu(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        ui.menu_button("New", |ui| {
            for template in super::Template::ALL {
                let mut button = egui::Button::new(template.label());
                if template == super::Template::Empty {
                    button = button.shortcut_text(ui.ctx().format_shortcut(
                        &egui::KeyboardShortcut::new(egui::Modifiers::COMMAND, egui::Key::N),
                    ));
                }
                if ui.add(button).clicked() {
                    self.replace_document(Replacement::New(template));
                }
            }
        });
        if ui.button("Open…").clicked() {
            self.ask_for_file(&ctx, FilePurpose::Open);
        }
        if ui.button("Save").clicked() {
            self.save_or_ask(&ctx);
        }
        if ui.button("Save As…").clicked() {
            self.ask_for_file(&ctx, FilePurpose::SaveAs);
        }
        ui.separator();
        ui.horizontal(|ui| {
            if ui.button("Screenshot…").clicked() {
                self.ask_for_file(&ctx, FilePurpose::Screenshot);
            }
            let (w, h) = &mut self.ui_state.screenshot_size;
            ui.add(egui::DragValue::new(w).range(16..=8192).suffix(" px"));
            ui.label("×");
            ui.add(egui::DragValue::new(h).range(16..=8192).suffix(" px"));
        });
        self.export_menu_entry(ui);
        ui.separator();
        let recent = self.ui_state.recent.clone();
        ui.menu_button("Recent", |ui| {
            if recent.is_empty() {
                ui.label("(none)");
            }
            for p in recent {
                if ui.button(p.display().to_string()).clicked() {
                    self.replace_document(Replacement::Open(p));
                }
            }
        });
    }

    /// The Edit menu: undo and redo, the selection's edits, symmetrize.
    fn edit_menu(&mut self, ui: &mut egui::Ui) {
        let undo = self.doc.undo_label().map(|l| format!("Undo {l}"));
        if ui
            .add_enabled(
                undo.is_some(),
                egui::Button::new(undo.unwrap_or("Undo".into())),
            )
            .clicked()
        {
            self.undo();
        }
        let redo = self.doc.redo_label().map(|l| format!("Redo {l}"));
        if ui
            .add_enabled(
                redo.is_some(),
                egui::Button::new(redo.unwrap_or("Redo".into())),
            )
            .clicked()
        {
            self.redo();
        }
        ui.separator();
        if ui.button("Duplicate").clicked() {
            self.duplicate();
        }
        if ui.button("Delete").clicked() {
            self.delete();
        }
        if ui.button("Connect").clicked() {
            self.connect();
        }
        if ui.button("Disconnect").clicked() {
            self.disconnect();
        }
        for (label, key, edit) in [
            ("Insert vertex", "I", SkeletonEdit::Insert),
            ("Merge vertices", "M", SkeletonEdit::Merge),
            ("Dissolve vertex", "Shift+X", SkeletonEdit::Dissolve),
        ] {
            if ui
                .add(egui::Button::new(label).shortcut_text(key))
                .on_hover_text(edit.hint())
                .clicked()
            {
                self.edit_skeleton(edit);
            }
        }
        if ui.button("Add blob").clicked() {
            self.add_blob();
        }
        ui.separator();
        let symmetrize = ui
            .add_enabled(
                self.ui_state.mirror.is_some(),
                egui::Button::new("Symmetrize group"),
            )
            .on_hover_text(
                "rebuild the edited group's skeletons and blobs from the positive side of \
                 the mirror plane",
            );
        if symmetrize.clicked()
            && let Some(mirror) = self.ui_state.mirror
        {
            let g = self.active_group;
            if self.apply(Edit::new("symmetrize"), |s| {
                symmetry::symmetrize(s, g, mirror);
            }) {
                self.selection.clear();
            }
        }
    }

    /// The View menu: framing, standard views, the scene camera.
    fn view_menu(&mut self, ui: &mut egui::Ui) {
        if ui.button("Frame all").clicked() {
            self.frame_all();
        }
        if ui.button("Frame selection").clicked() {
            self.frame_selection();
        }
        ui.separator();
        for view in super::view::StandardView::ALL {
            let (_, _, key) = view.key();
            if ui
                .add(egui::Button::new(view.label()).shortcut_text(key))
                .clicked()
            {
                self.look_from(view);
            }
        }
        ui.separator();
        if ui
            .button("Use this view as the scene camera")
            .on_hover_text("the scene file's camera (renders, exports, the next opening)")
            .clicked()
        {
            let camera = self.orbit.camera();
            self.apply(Edit::new("scene camera"), |s| s.camera = camera);
        }
    }

    pub(super) fn inspector(&mut self, ui: &mut egui::Ui) {
        ui.heading("File");
        ui.horizontal(|ui| {
            ui.label("Path");
            let field = ui.add(
                egui::TextEdit::singleline(&mut self.files.path_field)
                    .hint_text("scene.ron")
                    .desired_width(f32::INFINITY),
            );
            if std::mem::take(&mut self.files.focus_path_field) {
                field.request_focus();
            }
        });
        ui.horizontal(|ui| {
            if ui.button("Open").clicked() {
                let path = std::path::PathBuf::from(self.files.path_field.trim());
                self.replace_document(Replacement::Open(path));
            }
            if ui.button("Save As").clicked() {
                let path = std::path::PathBuf::from(self.files.path_field.trim());
                self.save(Some(path));
            }
            let dirty = if self.doc.is_dirty() {
                "modified"
            } else {
                "saved"
            };
            ui.weak(dirty);
        });
        ui.separator();
        self.methods_panel(ui);
        ui.separator();
        self.selection_panel(ui);
        ui.separator();
        self.group_panel(ui);
        ui.separator();
        self.scene_panel(ui);
    }

    /// Which methods apply to the scene and where the render thread traces each for the
    /// backend choice, as `skeletrace_core::backend::decide` decides with the render thread's
    /// GPU ([`method_sides`]); found once per revision, choice, shading and GPU (the checks
    /// visit every primitive).
    pub(super) fn method_tags(&mut self) -> &[MethodTag] {
        let key = TagsKey {
            revision: self.doc.revision(),
            backend: self.ui_state.backend,
            shadows: self.ui_state.shadows,
            shading: self.ui_state.shading,
            gpu: self.frames.render_thread_gpu(),
        };
        if self
            .view
            .method_tags
            .as_ref()
            .is_none_or(|(k, _)| *k != key)
        {
            let compiled = self.doc.compiled();
            let request = worker::frame_request(
                &compiled,
                self.orbit.camera(),
                (1, 1),
                key.shadows,
                key.shading,
                Cancel::new(),
            );
            let gpu = key.gpu.map(GpuOfKind);
            let capabilities = gpu
                .as_ref()
                .map(|g| g as &dyn Capabilities)
                .ok_or("the render thread has no GPU open");
            let tags = method_sides(key.backend, capabilities, &compiled, &request)
                .into_iter()
                .map(|(id, side)| MethodTag {
                    id,
                    applies: id.method().supports(&compiled.program).is_ok(),
                    side,
                })
                .collect();
            self.view.method_tags = Some((key, tags));
        }
        self.view.method_tags.as_ref().map_or(&[], |(_, tags)| tags)
    }

    fn methods_panel(&mut self, ui: &mut egui::Ui) {
        ui.heading("Methods");
        let names = self.method_tags().to_vec();
        let tag = |side: &Result<Side, String>| match side {
            Ok(Side::Gpu) => "GPU",
            Ok(Side::Cpu) => "CPU",
            Err(_) => "not on the GPU",
        };
        egui::ComboBox::from_label("shaded view")
            .selected_text(self.ui_state.shaded_method.name())
            .show_ui(ui, |ui| {
                for MethodTag { id, applies, side } in &names {
                    if *applies {
                        ui.selectable_value(
                            &mut self.ui_state.shaded_method,
                            *id,
                            format!("{id}  ({})", tag(side)),
                        )
                        .on_hover_text(side_help(side));
                    }
                }
            });
        ui.label("comparison grid:");
        egui::Grid::new("compare-methods")
            .num_columns(2)
            .show(ui, |ui| {
                for (k, MethodTag { id, applies, side }) in names.iter().enumerate() {
                    let (id, applies) = (*id, *applies);
                    let mut on = self.ui_state.compare_methods.contains(&id);
                    let label = format!("{id} ({})", tag(side));
                    if ui
                        .add_enabled(applies, egui::Checkbox::new(&mut on, label))
                        .on_hover_text(side_help(side))
                        .changed()
                    {
                        if on {
                            self.ui_state.compare_methods.push(id);
                        } else {
                            self.ui_state.compare_methods.retain(|&m| m != id);
                        }
                    }
                    if k % 2 == 1 {
                        ui.end_row();
                    }
                }
            });
        ui.horizontal(|ui| {
            ui.label("grid colour scale");
            ui.selectable_value(&mut self.ui_state.step_scale, StepScale::Log, "log");
            ui.selectable_value(&mut self.ui_state.step_scale, StepScale::Linear, "linear");
        });
        ui.weak("click a grid pixel (Alt+click the shaded view) to inspect its ray");
        ui.horizontal(|ui| {
            ui.label("backend");
            ui.selectable_value(&mut self.ui_state.backend, Backend::Auto, "auto");
            ui.selectable_value(&mut self.ui_state.backend, Backend::Gpu, "GPU");
            ui.selectable_value(&mut self.ui_state.backend, Backend::Cpu, "CPU");
        });
        ui.horizontal_wrapped(|ui| {
            ui.checkbox(&mut self.ui_state.shadows, "shadow rays");
            ui.checkbox(&mut self.ui_state.shading.soft_shadows, "soft shadows");
            ui.checkbox(
                &mut self.ui_state.shading.ambient_occlusion,
                "ambient occlusion",
            );
        });
    }

    fn selection_panel(&mut self, ui: &mut egui::Ui) {
        ui.heading("Selection");
        let scene = self.doc.scene().clone();
        match self.selection.len() {
            0 => {
                ui.weak("click a handle; Shift+drag for a box");
            }
            1 => {
                let Some(&item) = self.selection.iter().next() else {
                    return;
                };
                let Some((mut position, mut radius)) = item.ball(&scene) else {
                    return;
                };
                let what = match item {
                    Item::Vertex {
                        skeleton, vertex, ..
                    } => format!(
                        "vertex {vertex} of skeleton '{}'",
                        scene.groups[item.group()].skeletons[skeleton].name
                    ),
                    Item::Blob { blob, .. } => format!("blob {blob}"),
                    Item::HrbfPoint { set, point, .. } => {
                        format!("point {point} of HRBF set {set} (normal: group panel)")
                    }
                };
                ui.label(format!(
                    "{what}, group '{}'",
                    scene.groups[item.group()].name
                ));
                let mut changed = false;
                ui.horizontal(|ui| {
                    for (axis, v) in ["x", "y", "z"].iter().zip(position.iter_mut()) {
                        ui.label(*axis);
                        changed |= ui.add(egui::DragValue::new(v).speed(0.01)).changed();
                    }
                });
                if !matches!(item, Item::HrbfPoint { .. }) {
                    ui.horizontal(|ui| {
                        ui.label("radius");
                        changed |= ui
                            .add(
                                egui::DragValue::new(&mut radius)
                                    .speed(0.005)
                                    .range(1e-3..=1e3),
                            )
                            .changed();
                    });
                }
                if changed {
                    let chosen = self.selection.clone();
                    self.apply(Edit::gesture("edit vertex", "inspector-item"), |s| {
                        let Some((old, old_r)) = item.ball(s) else {
                            return;
                        };
                        let delta = [
                            position[0] - old[0],
                            position[1] - old[1],
                            position[2] - old[2],
                        ];
                        selection::translate(s, &chosen, delta);
                        if old_r > 0.0 {
                            selection::scale_radius(s, &chosen, radius / old_r);
                        }
                    });
                }
            }
            n => {
                ui.label(format!("{n} items"));
            }
        }
        if !self.selection.is_empty() && scene.groups.len() > 1 {
            let mut target = self.selection.iter().next().map_or(0, |i| i.group());
            let before = target;
            egui::ComboBox::from_label("group of selection")
                .selected_text(scene.groups[target].name.clone())
                .show_ui(ui, |ui| {
                    for (k, g) in scene.groups.iter().enumerate() {
                        ui.selectable_value(&mut target, k, g.name.clone());
                    }
                });
            if target != before {
                let chosen = self.selection.clone();
                let mut moved = selection::Selection::new();
                if self.apply(Edit::new("assign group"), |s| {
                    moved = selection::assign_group(s, &chosen, target);
                }) {
                    self.selection = moved;
                    self.active_group = target;
                }
            }
        }
    }

    /// Kernel family, degree and scale σ of group `g`.
    fn kernel_controls(&mut self, ui: &mut egui::Ui, g: usize, current: Kernel) {
        let mut kernel = current;
        let family = match kernel {
            Kernel::CompactPolynomial { .. } => 0,
            Kernel::Cauchy { .. } => 1,
            Kernel::Gaussian { .. } => 2,
        };
        let mut chosen = family;
        ui.horizontal(|ui| {
            ui.label("kernel");
            ui.selectable_value(&mut chosen, 0, "compact");
            ui.selectable_value(&mut chosen, 1, "Cauchy");
            ui.selectable_value(&mut chosen, 2, "Gaussian");
        });
        let scale_of = |k: Kernel| match k {
            Kernel::CompactPolynomial { scale, .. }
            | Kernel::Cauchy { scale, .. }
            | Kernel::Gaussian { scale } => scale,
        };
        if chosen != family {
            let scale = scale_of(kernel);
            kernel = match chosen {
                0 => Kernel::CompactPolynomial {
                    degree: 6,
                    scale: scale.max(1.1),
                },
                1 => Kernel::Cauchy { degree: 4, scale },
                _ => Kernel::Gaussian { scale },
            };
        }
        match &mut kernel {
            Kernel::CompactPolynomial { degree, scale } => {
                ui.add(
                    egui::Slider::new(degree, 2..=12)
                        .step_by(2.0)
                        .text("degree"),
                );
                ui.add(egui::Slider::new(scale, 1.05..=6.0).text("scale σ"));
            }
            Kernel::Cauchy { degree, scale } => {
                ui.add(egui::Slider::new(degree, 1..=12).text("degree"));
                ui.add(egui::Slider::new(scale, 0.05..=6.0).text("scale σ"));
            }
            Kernel::Gaussian { scale } => {
                ui.add(egui::Slider::new(scale, 0.05..=6.0).text("scale σ"));
            }
        }
        if kernel != current {
            self.apply(Edit::gesture("kernel", format!("kernel-{g}")), |s| {
                s.groups[g].kernel = kernel;
            });
        }
    }

    fn group_panel(&mut self, ui: &mut egui::Ui) {
        let scene = self.doc.scene().clone();
        if scene.groups.is_empty() {
            return;
        }
        let g = self.active_group.min(scene.groups.len() - 1);
        ui.heading("Group");
        egui::ComboBox::from_label("edited group")
            .selected_text(scene.groups[g].name.clone())
            .show_ui(ui, |ui| {
                for (k, group) in scene.groups.iter().enumerate() {
                    ui.selectable_value(&mut self.active_group, k, group.name.clone());
                }
            });
        self.group_list_controls(ui, g, &scene);
        let scene = self.doc.scene().clone();
        let g = self.active_group.min(scene.groups.len() - 1);
        let group = &scene.groups[g];
        // Field type and correctors of the group's skeletons.
        if !group.skeletons.is_empty() {
            let mut field = group.skeletons[0].field;
            let mut correctors = group.skeletons[0].end_correctors;
            ui.horizontal(|ui| {
                ui.label("field");
                ui.selectable_value(&mut field, SkeletonField::Distance, "distance");
                ui.selectable_value(&mut field, SkeletonField::Scalis, "SCALIS");
            });
            ui.checkbox(&mut correctors, "end-point correctors");
            if field != group.skeletons[0].field || correctors != group.skeletons[0].end_correctors
            {
                self.apply(Edit::new("field type"), |s| {
                    for sk in &mut s.groups[g].skeletons {
                        sk.field = field;
                        sk.end_correctors = correctors;
                    }
                });
            }
        }
        if group.hrbfs.is_empty() {
            self.kernel_controls(ui, g, group.kernel);
        } else {
            ui.weak("kernel: not used by HRBF sets (the interpolant is the field)");
        }
        // Material.
        let mut material = group.material;
        let shown_rgb = material.color.map(|c| c as f32);
        let mut rgb = shown_rgb;
        ui.horizontal(|ui| {
            ui.label("colour");
            ui.color_edit_button_rgb(&mut rgb);
        });
        // Only a real change goes back: the colour button's f32 round trip moves the value by
        // an ulp or so every frame, which would edit the scene without the user.
        if rgb.iter().zip(shown_rgb).any(|(a, b)| (a - b).abs() > 1e-5) {
            material.color = rgb.map(f64::from);
        }
        ui.add(egui::Slider::new(&mut material.opacity, 0.05..=1.0).text("opacity"));
        ui.add(egui::Slider::new(&mut material.ior, 1.0..=2.5).text("index of refraction"));
        if material != group.material {
            self.apply(Edit::gesture("material", format!("material-{g}")), |s| {
                s.groups[g].material = material;
            });
        }
        self.shapes_panel(ui, g, &group.shapes);
        self.hrbf_panel(ui, g, &group.hrbfs);
        let (mut transform, mut repeat) = (group.transform, group.repeat);
        egui::CollapsingHeader::new("Transform and repetition")
            .id_salt(("operators", g))
            .show(ui, |ui| {
                group_tools::edit_operators(ui, &mut transform, &mut repeat)
            });
        if (transform, repeat) != (group.transform, group.repeat) {
            self.apply(Edit::gesture("transform", format!("operators-{g}")), |s| {
                s.groups[g].transform = transform;
                s.groups[g].repeat = repeat;
            });
        }
    }

    /// Add, duplicate, delete, move and rename groups (`groups.rs`: the blend tree follows).
    /// A change of the list clears the selection, whose items name groups by index.
    fn group_list_controls(&mut self, ui: &mut egui::Ui, g: usize, scene: &skeletrace_core::Scene) {
        let n = scene.groups.len();
        ui.horizontal(|ui| {
            if ui
                .button("Add group")
                .on_hover_text("a new, empty group with this group's kernel and material")
                .clicked()
            {
                let mut added = 0;
                if self.apply(Edit::new("add group"), |s| {
                    let group = groups::new_group(s, g);
                    added = groups::add(s, group);
                }) {
                    self.active_group = added;
                    self.selection.clear();
                }
            }
            if ui
                .button("Duplicate group")
                .on_hover_text("a copy of this group, with everything in it")
                .clicked()
            {
                let mut added = 0;
                if self.apply(Edit::new("duplicate group"), |s| {
                    let mut copy = s.groups[g].clone();
                    copy.name = format!("{} copy", copy.name);
                    added = groups::add(s, copy);
                }) {
                    self.active_group = added;
                    self.selection.clear();
                }
            }
            let delete = ui
                .add_enabled(n > 1, egui::Button::new("Delete group"))
                .on_hover_text(
                    "remove this group and its leaves in the blend tree (undo brings it back)",
                );
            if delete.clicked() {
                let mut result = Ok(());
                if self.apply(Edit::new("delete group"), |s| {
                    result = groups::delete(s, g);
                }) {
                    match result {
                        Ok(()) => {
                            self.active_group = g.saturating_sub(1);
                            self.selection.clear();
                        }
                        Err(why) => self.complain(why),
                    }
                }
            }
            if ui
                .add_enabled(g > 0, egui::Button::new("Up"))
                .on_hover_text("move up in the list")
                .clicked()
                && self.apply(Edit::new("move group"), |s| groups::swap(s, g, g - 1))
            {
                self.active_group = g - 1;
                self.selection.clear();
            }
            if ui
                .add_enabled(g + 1 < n, egui::Button::new("Down"))
                .on_hover_text("move down in the list")
                .clicked()
                && self.apply(Edit::new("move group"), |s| groups::swap(s, g, g + 1))
            {
                self.active_group = g + 1;
                self.selection.clear();
            }
        });
        let mut name = scene.groups[g].name.clone();
        ui.horizontal(|ui| {
            ui.label("name");
            ui.text_edit_singleline(&mut name)
                .on_hover_text("the group's name in lists, files and exports");
        });
        if name != scene.groups[g].name {
            self.apply(Edit::gesture("rename group", format!("name-{g}")), |s| {
                s.groups[g].name = name;
            });
        }
    }

    /// The group's HRBF sets: add a set (in a group of its own: the loader refuses a set among
    /// other primitives, and the edit with it), move points, turn normals, add and remove points.
    fn hrbf_panel(&mut self, ui: &mut egui::Ui, g: usize, current: &[Hrbf]) {
        ui.horizontal(|ui| {
            ui.strong(format!("HRBF sets ({})", current.len()));
            if ui.button("Add HRBF set").clicked() {
                // At the view's target, in the group's frame.
                let (target, size) = (self.orbit.target, 3.0 * self.typical_radius());
                self.apply(Edit::new("add HRBF set"), |s| {
                    let centre = selection::to_group_frame(s, g, target);
                    let size = size / selection::placement(s, g).scale;
                    s.groups[g]
                        .hrbfs
                        .push(group_tools::new_hrbf_set(centre, size));
                });
            }
        });
        for (k, set) in current.iter().enumerate() {
            let mut edited = set.clone();
            let mut remove_set = false;
            egui::CollapsingHeader::new(format!("HRBF set {k} ({} points)", set.points.len()))
                .id_salt(("hrbf", g, k))
                .show(ui, |ui| {
                    let mut remove_point = None;
                    for (i, point) in edited.points.iter_mut().enumerate() {
                        ui.label(format!("point {i}"));
                        group_tools::edit_point(ui, point);
                        if ui.small_button("remove point").clicked() {
                            remove_point = Some(i);
                        }
                    }
                    if let Some(i) = remove_point {
                        edited.points.remove(i);
                    }
                    ui.horizontal(|ui| {
                        if ui.button("Add point").clicked()
                            && let Some(last) = edited.points.last().copied()
                        {
                            let mut point = last;
                            point.position[1] += 0.1 * self.typical_radius().max(0.1);
                            edited.points.push(point);
                        }
                        remove_set = ui.button("Remove set").clicked();
                    });
                });
            if remove_set {
                self.apply(Edit::new("remove HRBF set"), |s| {
                    s.groups[g].hrbfs.remove(k);
                });
                break;
            }
            if edited != *set {
                self.apply(Edit::gesture("HRBF point", format!("hrbf-{g}-{k}")), |s| {
                    s.groups[g].hrbfs[k] = edited;
                });
            }
        }
    }

    /// The group's distance primitives: add one of each kind at the orbit target, edit every
    /// field, remove.
    fn shapes_panel(&mut self, ui: &mut egui::Ui, g: usize, current: &[Shape]) {
        ui.horizontal(|ui| {
            ui.strong(format!("Shapes ({})", current.len()));
            ui.menu_button("Add shape", |ui| {
                for (kind, name) in shape_tools::KINDS.iter().enumerate() {
                    if ui.button(*name).clicked() {
                        let radius = self.typical_radius();
                        let shape = shape_tools::new_shape(
                            kind,
                            self.orbit.target,
                            6.0 * radius,
                            0.5 * radius,
                        );
                        self.apply(Edit::new(format!("add {name}")), |s| {
                            s.groups[g].shapes.push(shape);
                        });
                    }
                }
            });
        });
        for (k, shape) in current.iter().enumerate() {
            let mut edited = *shape;
            let mut remove = false;
            egui::CollapsingHeader::new(format!("{} {k}", shape_tools::kind_name(shape)))
                .id_salt(("shape", g, k))
                .show(ui, |ui| {
                    shape_tools::edit_fields(ui, &mut edited);
                    remove = ui.button("Remove").clicked();
                });
            if remove {
                self.apply(Edit::new("remove shape"), |s| {
                    s.groups[g].shapes.remove(k);
                });
                break;
            }
            if edited != *shape {
                self.apply(Edit::gesture("shape", format!("shape-{g}-{k}")), |s| {
                    s.groups[g].shapes[k] = edited;
                });
            }
        }
    }

    fn scene_panel(&mut self, ui: &mut egui::Ui) {
        ui.heading("Scene");
        let scene = self.doc.scene().clone();
        let mut isovalue = scene.isovalue;
        ui.add(egui::Slider::new(&mut isovalue, 0.05..=2.0).text("isovalue"));
        if isovalue != scene.isovalue {
            self.apply(Edit::gesture("isovalue", "isovalue"), |s| {
                s.isovalue = isovalue
            });
        }
        // The blend tree (blend_editor.rs): operators as nodes, groups as leaves.
        ui.strong("Blend");
        let names: Vec<String> = scene.groups.iter().map(|g| g.name.clone()).collect();
        match scene.blend.clone() {
            None => {
                ui.horizontal(|ui| {
                    ui.label("sum of every group");
                    if ui
                        .button("Edit as a tree")
                        .on_hover_text("start a blend tree: a sum of every group, to change")
                        .clicked()
                    {
                        let leaves = (0..names.len() as u32).map(Blend::Group).collect();
                        self.apply(Edit::new("blend tree"), |s| {
                            s.blend = Some(Blend::Sum(leaves));
                        });
                    }
                });
            }
            Some(mut tree) => {
                if blend_editor::edit(ui, &mut tree, &names) {
                    self.apply(Edit::gesture("blend", "blend"), |s| s.blend = Some(tree));
                }
                if ui
                    .small_button("sum every group")
                    .on_hover_text("drop the tree: every group summed")
                    .clicked()
                {
                    self.apply(Edit::new("blend: sum"), |s| s.blend = None);
                }
            }
        }
        ui.separator();
        self.lights_panel(ui);
    }

    pub(super) fn status_bar(&mut self, ui: &mut egui::Ui) {
        ui.horizontal_wrapped(|ui| {
            let gpu = self
                .view
                .viewport_on_gpu
                .then(|| self.gpu_viewport_counts())
                .flatten();
            if let Some((traced, _, adapter)) = gpu {
                let what = match self.ui_state.view {
                    ViewMode::Shaded => self.ui_state.shaded_method.to_string(),
                    ViewMode::Compare => {
                        format!("{} heat maps", self.ui_state.compare_methods.len())
                    }
                };
                ui.monospace(format!(
                    "{what} on the window's GPU ({traced} frames traced, no frame read back)"
                ));
                ui.separator();
                ui.weak(adapter);
            } else if let Some(shown) = &self.frames.shown {
                if self.view.gpu_compiling {
                    ui.colored_label(
                        egui::Color32::from_rgb(240, 180, 90),
                        "the window's GPU compiles this scene's pipelines: traced on the CPU meanwhile",
                    );
                    ui.separator();
                }
                for f in &shown.frames {
                    let backend = if f.on_gpu { "GPU" } else { "CPU" };
                    let copied = f.pixels_copied.filter(|share| *share > 0.0).map_or(
                        String::new(),
                        |share| {
                            format!(
                                ", {:.0} % of pixels kept from the last frame",
                                100.0 * share
                            )
                        },
                    );
                    ui.monospace(format!(
                        "{} {:.0} ms ({backend}, {}x{}{copied})",
                        f.method, f.ms, f.frame.width, f.frame.height
                    ));
                }
                ui.separator();
                ui.weak(&shown.adapter);
                if !shown.refined {
                    ui.weak(format!("(preview, 1/{} resolution)", shown.divisor));
                }
                for s in &shown.skipped {
                    ui.colored_label(egui::Color32::from_rgb(240, 180, 90), s);
                }
            }
            if let Some(n) = &self.prompts.notice {
                ui.separator();
                let colour = if n.error {
                    egui::Color32::from_rgb(255, 120, 110)
                } else {
                    egui::Color32::LIGHT_GREEN
                };
                ui.colored_label(colour, &n.text);
            }
        });
    }

    pub(super) fn dialogs(&mut self, ctx: &egui::Context) {
        self.replace_dialog(ctx);
        if self.prompts.help {
            let mut open = true;
            egui::Window::new("Shortcuts")
                .open(&mut open)
                .collapsible(false)
                .show(ctx, |ui| {
                    egui::Grid::new("shortcuts").striped(true).show(ui, |ui| {
                        for (keys, what) in SHORTCUTS {
                            ui.strong(keys);
                            ui.label(what);
                            ui.end_row();
                        }
                    });
                });
            self.prompts.help = open;
        }
        if let Some(scene) = self.files.recovery_offer.clone() {
            egui::Modal::new(egui::Id::unique("recovery")).show(ctx, |ui| {
                ui.heading("Restore unsaved work?");
                ui.label("skeletrace did not close cleanly last time. A recovery copy of the scene was kept.");
                ui.horizontal(|ui| {
                    if ui.button("Restore").clicked() {
                        self.doc.replace(scene, "restore recovery");
                        self.files.recovery_offer = None;
                        self.tell("restored the recovery copy (not yet saved)");
                    }
                    if ui.button("Discard").clicked() {
                        if let Some(p) = &self.files.recovery_path {
                            let _ = std::fs::remove_file(p);
                        }
                        self.files.recovery_offer = None;
                    }
                });
            });
        }
        if self.prompts.close_prompt {
            egui::Modal::new(egui::Id::unique("close")).show(ctx, |ui| {
                ui.heading("Save changes before closing?");
                ui.horizontal(|ui| {
                    if ui.button("Save").clicked() && self.save(None) {
                        self.prompts.close_prompt = false;
                        self.prompts.allow_close = true;
                        ctx.send_viewport_cmd(egui::ViewportCommand::Close);
                    }
                    if ui.button("Discard").clicked() {
                        self.prompts.close_prompt = false;
                        self.prompts.allow_close = true;
                        ctx.send_viewport_cmd(egui::ViewportCommand::Close);
                    }
                    if ui.button("Cancel").clicked() {
                        self.prompts.close_prompt = false;
                    }
                });
            });
        }
    }
}

/// Where each method of `MethodId::ALL` is traced on `compiled` for `choice` with `gpu` (the
/// render thread's, or why it has none), or why it cannot be: the methods panel's labels, from
/// the decision every backend caller takes (`skeletrace_core::backend::decide`).
#[must_use]
pub fn method_sides(
    choice: BackendChoice,
    gpu: Result<&dyn Capabilities, &str>,
    compiled: &Compiled,
    request: &FrameRequest,
) -> Vec<(MethodId, Result<Side, String>)> {
    MethodId::ALL
        .into_iter()
        .map(|id| {
            let side = decide(choice, gpu, compiled, id, request).map_err(|e| match e {
                BackendError::Unsupported(why) | BackendError::DeviceFailed(why) => why,
                BackendError::Cancelled => "cancelled".to_owned(),
            });
            (id, side)
        })
        .collect()
}

/// The hover text of a method's label.
fn side_help(side: &Result<Side, String>) -> String {
    match side {
        Ok(Side::Gpu) => "traced on the GPU with this backend choice".to_owned(),
        Ok(Side::Cpu) => "traced on the CPU with this backend choice".to_owned(),
        Err(why) => why.clone(),
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};

    use skeletrace_core::backend::{DeviceKind, FrameBackend};
    use skeletrace_core::frame::{FieldShading, Frame};
    use skeletrace_core::model::generate::{GenerateOptions, GeneratorKind, generate};
    use skeletrace_core::model::scene::SkeletonField;
    use skeletrace_core::{Scene, compile};
    use skeletrace_render::GpuBackend;

    use super::*;
    use crate::backends::Backends;

    /// The GPU backend, answering as a hardware GPU while `as_hardware` is set (lavapipe taken
    /// as a hardware adapter, so that `auto` picks it).
    struct TakenAs {
        gpu: GpuBackend,
        as_hardware: Arc<AtomicBool>,
    }

    impl Capabilities for TakenAs {
        fn device_kind(&self) -> DeviceKind {
            if self.as_hardware.load(Ordering::Relaxed) {
                DeviceKind::HardwareGpu
            } else {
                self.gpu.device_kind()
            }
        }

        fn supports(&self, c: &Compiled, m: MethodId, r: &FrameRequest) -> Result<(), String> {
            self.gpu.supports(c, m, r)
        }
    }

    impl FrameBackend for TakenAs {
        fn describe(&self) -> String {
            self.gpu.describe()
        }

        fn render(
            &mut self,
            compiled: &Arc<Compiled>,
            request: &FrameRequest,
        ) -> Result<Vec<Frame>, BackendError> {
            self.gpu.render(compiled, request)
        }
    }

    /// Every asset and scenes generated from seeds the assets do not use (one of them with more
    /// groups than the GPU takes, one with distance segments).
    fn scenes() -> Vec<(String, Scene)> {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes");
        let mut out: Vec<(String, Scene)> = std::fs::read_dir(&dir)
            .map(|d| {
                d.filter_map(Result::ok)
                    .map(|e| e.path())
                    .collect::<Vec<_>>()
            })
            .unwrap_or_default()
            .into_iter()
            .filter(|p| p.extension().is_some_and(|e| e == "ron"))
            .map(|p| {
                let scene = Scene::load(&p).unwrap_or_else(|e| panic!("{e}"));
                (p.display().to_string(), scene)
            })
            .collect();
        assert!(out.len() >= 10, "assets: {}", out.len());
        for (kind, seed, size, groups, field) in [
            (GeneratorKind::Blobs, 17, 90, Some(70), None),
            (GeneratorKind::Blobs, 23, 30, Some(3), None),
            (GeneratorKind::Tree, 29, 3, None, None),
            (
                GeneratorKind::RandomSkeleton,
                31,
                25,
                None,
                Some(SkeletonField::Distance),
            ),
            (GeneratorKind::Molecule, 37, 60, None, None),
        ] {
            let options = GenerateOptions {
                seed,
                size: Some(size),
                groups,
                varying_radii: false,
                field,
                allow_large: false,
            };
            let scene = generate(kind, &options).unwrap_or_else(|e| panic!("{e}"));
            out.push((format!("{} seed {seed}", kind.name()), scene));
        }
        out
    }

    /// The methods panel's label of every method, on every asset and generated scenes, for
    /// the CPU, the GPU and auto, with and without field shading, with no GPU, a software GPU
    /// and one taken as hardware, is what the render thread's backend choice then does: the
    /// CPU, the GPU, or an error. A few frames are traced to see the label borne out.
    /// Without a GPU adapter the GPU cases are skipped (unless `SKELETRACE_REQUIRE_GPU=1`).
    #[test]
    fn the_method_labels_say_where_the_render_thread_traces() {
        let as_hardware = Arc::new(AtomicBool::new(false));
        let gpu = match GpuBackend::new() {
            Ok(gpu) => Some(TakenAs {
                gpu,
                as_hardware: Arc::clone(&as_hardware),
            }),
            Err(e) => {
                assert!(
                    std::env::var("SKELETRACE_REQUIRE_GPU").as_deref() != Ok("1"),
                    "no GPU adapter: {e}"
                );
                eprintln!("SKIPPED the GPU cases: no GPU adapter ({e})");
                None
            }
        };
        let has_gpu = gpu.is_some();
        let mut backends = Backends::open(BackendChoice::Cpu);
        backends.gpu = gpu.map_or_else(
            || Err("no adapter".to_owned()),
            |g| Ok(Box::new(g) as Box<dyn FrameBackend + Send>),
        );
        let mut no_gpu = Backends::open(BackendChoice::Cpu);
        let (mut checked, mut on_gpu, mut refused) = (0, 0, 0);
        let kinds: &[Option<DeviceKind>] = if has_gpu {
            &[
                None,
                Some(DeviceKind::SoftwareGpu),
                Some(DeviceKind::HardwareGpu),
            ]
        } else {
            &[None]
        };
        for (name, scene) in scenes() {
            let compiled = compile(&scene);
            for shading in [
                FieldShading::default(),
                FieldShading {
                    soft_shadows: true,
                    ambient_occlusion: true,
                },
            ] {
                let request = worker::frame_request(
                    &compiled,
                    scene.camera,
                    (8, 8),
                    false,
                    shading,
                    Cancel::new(),
                );
                for &kind in kinds {
                    // Lavapipe taken as hardware keeps its own loop limit, which a hardware
                    // GPU has not: field shading is asked of the real kinds only.
                    if kind == Some(DeviceKind::HardwareGpu) && shading.any() {
                        continue;
                    }
                    as_hardware.store(kind == Some(DeviceKind::HardwareGpu), Ordering::Relaxed);
                    let label_gpu = kind.map(GpuOfKind);
                    let capabilities = label_gpu
                        .as_ref()
                        .map(|g| g as &dyn Capabilities)
                        .ok_or("no GPU");
                    for choice in [BackendChoice::Cpu, BackendChoice::Gpu, BackendChoice::Auto] {
                        let labels = method_sides(choice, capabilities, &compiled, &request);
                        for (id, label) in labels {
                            if id.method().supports(&compiled.program).is_err() {
                                continue;
                            }
                            let mut asked = request.clone();
                            asked.methods = vec![id];
                            let chosen = if kind.is_some() {
                                &mut backends
                            } else {
                                &mut no_gpu
                            };
                            let done =
                                chosen.choose(choice, &compiled, id, &asked).map(|b| {
                                    match b.device_kind() {
                                        DeviceKind::Cpu => Side::Cpu,
                                        _ => Side::Gpu,
                                    }
                                });
                            let case =
                                format!("{name}, {id}, {choice:?}, GPU {kind:?}, {shading:?}");
                            match (&label, &done) {
                                (Ok(l), Ok(d)) => assert_eq!(l, d, "{case}"),
                                (Err(_), Err(_)) => refused += 1,
                                _ => panic!("{case}: label {label:?}, backend {done:?}"),
                            }
                            on_gpu += usize::from(label == Ok(Side::Gpu));
                            checked += 1;
                        }
                    }
                }
            }
        }
        assert!(checked > 500, "{checked} cases");
        if has_gpu {
            assert!(
                on_gpu > 100 && refused > 50,
                "{on_gpu} on the GPU, {refused} refused"
            );
            // The label borne out by frames: traced where it says, or refused.
            as_hardware.store(false, Ordering::Relaxed);
            let scene = Scene::load(
                &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("../assets/scenes/blobs.ron"),
            )
            .unwrap_or_else(|e| panic!("{e}"));
            let compiled = compile(&scene);
            let request = worker::frame_request(
                &compiled,
                scene.camera,
                (12, 10),
                false,
                FieldShading::default(),
                Cancel::new(),
            );
            let methods = vec![MethodId::Sphere, MethodId::SphereNormalized];
            let labels = method_sides(
                BackendChoice::Gpu,
                Ok(&GpuOfKind(DeviceKind::SoftwareGpu)),
                &compiled,
                &request,
            );
            let reply = worker::trace(
                &worker::Request {
                    id: 1,
                    compiled: Arc::clone(&compiled),
                    frame: FrameRequest {
                        methods: methods.clone(),
                        ..request.clone()
                    },
                    backend: BackendChoice::Gpu,
                    preview: false,
                },
                &mut backends,
            )
            .unwrap_or_else(|| panic!("cancelled"));
            for id in methods {
                let label = labels
                    .iter()
                    .find(|(m, _)| *m == id)
                    .map(|(_, s)| s.clone());
                let traced = reply.frames.iter().find(|t| t.method == id);
                match (label, traced) {
                    (Some(Ok(Side::Gpu)), Some(t)) => assert!(t.on_gpu, "{id}"),
                    (Some(Ok(Side::Cpu)), Some(t)) => assert!(!t.on_gpu, "{id}"),
                    (Some(Err(_)), None) => {
                        assert!(
                            reply.skipped.iter().any(|s| s.starts_with(id.name())),
                            "{id}"
                        );
                    }
                    (label, traced) => panic!(
                        "{id}: label {label:?}, traced on the GPU: {:?}",
                        traced.map(|t| t.on_gpu)
                    ),
                }
            }
        }
    }
}
