//! Editor workflows (issue: "the editor"), driven through egui_kittest with the wgpu test
//! renderer (lavapipe in CI): open an asset, select a vertex by clicking its handle, drag the
//! gizmo, undo, change σ with its slider, switch to the comparison grid, save and reload. Each
//! step asserts on the scene and on what was rendered: the traced frames behind the viewport
//! and the window image kittest renders.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};

use eframe::egui::{self, Event, Modifiers, PointerButton, Pos2};
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use skeletrace::editor::{
    BackendChoice, DialogRequest, Document, Edit, Editor, FileDialogs, FilePurpose, Item, UiState,
    ViewMode,
};
use skeletrace_core::model::kernel::Kernel;

/// The frame request of `methods` side by side, `size` each, through `camera`.
fn frame_request(
    methods: &[skeletrace_render::GpuMethod],
    camera: skeletrace_core::model::scene::Camera,
    settings: &skeletrace_core::methods::TraceSettings,
    (width, height): (u32, u32),
    view: skeletrace_core::frame::View,
    shadows: bool,
) -> skeletrace_core::backend::FrameRequest {
    skeletrace_core::backend::FrameRequest {
        camera,
        width: width as usize,
        height: height as usize,
        methods: methods.iter().map(|m| m.id()).collect(),
        view,
        shadows,
        settings: *settings,
        cancel: skeletrace_core::backend::Cancel::new(),
    }
}

fn asset(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../assets/scenes/{name}.ron"))
}

fn harness(editor: Editor) -> Harness<'static, Editor> {
    Harness::builder()
        .with_size(egui::vec2(1280.0, 800.0))
        .wgpu()
        .build_ui_state(|ui, editor: &mut Editor| editor.ui(ui), editor)
}

/// Runs frames until the renderer has answered and its frames are on screen.
fn settle(h: &mut Harness<'static, Editor>) {
    h.step();
    let ctx = h.ctx.clone();
    h.state_mut().wait_for_frames(&ctx);
    h.step();
    h.step();
}

/// Runs frames until the full-resolution frames of the view as it is are on screen, every
/// panel's of one size (the grid shows each method's frame as it comes, so a panel may hold an
/// earlier request's frame for a while).
fn settle_at_full_resolution(h: &mut Harness<'static, Editor>) {
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(600);
    loop {
        // Past the time after an interaction when previews give way to full frames.
        std::thread::sleep(std::time::Duration::from_millis(300));
        settle(h);
        let frames = h.state().shown_frames();
        let sizes: Vec<(usize, usize)> = frames.iter().map(|(_, f)| (f.width, f.height)).collect();
        settle(h);
        let again: Vec<(usize, usize)> = h
            .state()
            .shown_frames()
            .iter()
            .map(|(_, f)| (f.width, f.height))
            .collect();
        if !sizes.is_empty() && sizes == again && sizes.windows(2).all(|w| w[0] == w[1]) {
            return;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "the frames never settled"
        );
    }
}

fn press(h: &mut Harness<'static, Editor>, pos: Pos2, pressed: bool) {
    h.event(Event::PointerButton {
        pos,
        button: PointerButton::Primary,
        pressed,
        modifiers: Modifiers::NONE,
    });
    h.step();
}

/// Clicks `item`'s handle and checks that it alone is selected; returns where the handle is.
fn click_to_select(h: &mut Harness<'static, Editor>, item: Item) -> Pos2 {
    let at = h
        .state()
        .screen_position(item)
        .unwrap_or_else(|| panic!("{item:?} is on screen"));
    h.hover_at(at);
    h.step();
    press(h, at, true);
    press(h, at, false);
    assert_eq!(
        h.state().selection().iter().copied().collect::<Vec<_>>(),
        vec![item]
    );
    at
}

/// Renders the window and writes it as a PNG (the README's screenshots).
fn save_window_image(h: &mut Harness<'static, Editor>, path: &Path) {
    let image = h.render().unwrap_or_else(|e| panic!("{e}"));
    let mut canvas =
        skeletrace::picture::Canvas::new(image.width() as usize, image.height() as usize, [0; 4]);
    for (x, y, p) in image.enumerate_pixels() {
        canvas.put(x as usize, y as usize, p.0);
    }
    canvas.save_png(path, &[]).unwrap_or_else(|e| panic!("{e}"));
}

fn hit_fraction(editor: &Editor) -> f64 {
    let frames = editor.shown_frames();
    let Some((_, frame)) = frames.first() else {
        return 0.0;
    };
    let hits = (0..frame.depth.len()).filter(|&i| frame.is_hit(i)).count();
    hits as f64 / frame.depth.len() as f64
}

/// Distinct colours in a window image region: a blank panel has one or two.
fn distinct_colours(image: &image::RgbaImage, x0: u32, y0: u32, x1: u32, y1: u32) -> usize {
    let mut seen = std::collections::HashSet::new();
    for y in (y0..y1.min(image.height())).step_by(3) {
        for x in (x0..x1.min(image.width())).step_by(3) {
            seen.insert(image.get_pixel(x, y).0);
        }
    }
    seen.len()
}

#[test]
fn open_select_drag_undo_tune_compare_save_and_reload() {
    if skeletrace_tests::skip_without_gpu("open_select_drag_undo_tune_compare_save_and_reload") {
        return;
    }
    let ui_state = UiState {
        backend: BackendChoice::Cpu,
        ..UiState::default()
    };
    let doc = Document::open(&asset("creature")).unwrap_or_else(|e| panic!("{e}"));
    let mut h = harness(Editor::new(doc, ui_state, None, || {}));
    settle(&mut h);
    assert!(
        hit_fraction(h.state()) > 0.05,
        "the creature covers the viewport"
    );
    // Drawing the panels does not edit the scene (the colour button once did, every frame).
    assert_eq!(h.state().document().undo_label(), None);
    assert!(!h.state().document().is_dirty());

    // Select a vertex by clicking its handle.
    let item = Item::Vertex {
        group: 0,
        skeleton: 0,
        vertex: 0,
    };
    click_to_select(&mut h, item);

    // Drag the gizmo's view-plane handle 60 points to the right: one undo step.
    let before = h.state().document().scene().clone();
    let start = h.state().screen_position(item).unwrap_or_default();
    h.hover_at(start);
    h.step();
    press(&mut h, start, true);
    for k in 1..=6 {
        h.hover_at(start + egui::vec2(10.0 * k as f32, 0.0));
        h.step();
    }
    press(&mut h, start + egui::vec2(60.0, 0.0), false);
    let moved = h.state().document().scene().groups[0].skeletons[0].vertices[0].position;
    let original = before.groups[0].skeletons[0].vertices[0].position;
    let shift: f64 = (0..3)
        .map(|k| (moved[k] - original[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(
        shift > 1e-3,
        "the drag moved the vertex ({original:?} -> {moved:?})"
    );
    let now = h.state().screen_position(item).unwrap_or_default();
    assert!(
        (now.x - start.x - 60.0).abs() < 3.0 && (now.y - start.y).abs() < 3.0,
        "the handle follows the mouse: {start:?} -> {now:?}"
    );

    // Undo restores the scene in one step.
    h.key_press_modifiers(Modifiers::COMMAND, egui::Key::Z);
    h.step();
    assert_eq!(h.state().document().scene(), &before);

    // Select the vertex with the largest circle on screen, and drag its radius circle
    // outwards by half its radius: the radius follows the pointer's distance from the
    // handle, and undo restores it.
    let count = before.groups[0].skeletons[0].vertices.len();
    let (big, (centre, ring)) = (0..count)
        .map(|vertex| Item::Vertex {
            group: 0,
            skeleton: 0,
            vertex,
        })
        .filter_map(|i| Some((i, h.state().screen_circle(i)?)))
        .max_by(|a, b| a.1.1.total_cmp(&b.1.1))
        .unwrap_or_else(|| panic!("the skeleton is on screen"));
    assert!(
        ring > 20.0,
        "a radius circle is large enough to grab ({ring})"
    );
    h.hover_at(centre);
    h.step();
    press(&mut h, centre, true);
    press(&mut h, centre, false);
    assert_eq!(
        h.state().selection().iter().copied().collect::<Vec<_>>(),
        vec![big]
    );
    let Item::Vertex {
        vertex: big_index, ..
    } = big
    else {
        unreachable!("a vertex was chosen")
    };
    let radius_of =
        |e: &Editor| e.document().scene().groups[0].skeletons[0].vertices[big_index].radius;
    // Up and to the left of the handle, away from the gizmo's handles (right and above).
    let direction = egui::vec2(-0.6, 0.8);
    let grab = centre + direction * ring;
    h.hover_at(grab);
    h.step();
    press(&mut h, grab, true);
    for k in 1..=5 {
        h.hover_at(grab + direction * (0.1 * ring * k as f32));
        h.step();
    }
    press(&mut h, grab + direction * (0.5 * ring), false);
    let ratio = radius_of(h.state()) / before.groups[0].skeletons[0].vertices[big_index].radius;
    assert!(
        (ratio - 1.5).abs() < 0.1,
        "dragging the circle out by half its radius scales the radius by 1.5, got {ratio}"
    );
    h.key_press_modifiers(Modifiers::COMMAND, egui::Key::Z);
    h.step();
    assert_eq!(h.state().document().scene(), &before);

    // σ with the slider: the kernel changes and the traced surface grows.
    settle(&mut h);
    let covered = hit_fraction(h.state());
    let scale = |e: &Editor| match e.document().scene().groups[0].kernel {
        Kernel::CompactPolynomial { scale, .. }
        | Kernel::Cauchy { scale, .. }
        | Kernel::Gaussian { scale } => scale,
    };
    let sigma = scale(h.state());
    h.get_by_role_and_label(egui::accesskit::Role::Slider, "scale σ")
        .set_value_accesskit(sigma * 1.3);
    h.step();
    assert!(
        (scale(h.state()) - sigma * 1.3).abs() < 1e-6,
        "σ {sigma} -> {}",
        scale(h.state())
    );
    settle(&mut h);
    let grown = hit_fraction(h.state());
    assert!(
        grown > covered,
        "a larger σ covers more pixels: {covered} -> {grown}"
    );

    // The comparison grid: one heat map per chosen method, drawn.
    h.get_by_label("Compare methods").click();
    h.step();
    assert_eq!(h.state().ui_state().view, ViewMode::Compare);
    settle(&mut h);
    let names: Vec<_> = h.state().shown_frames().iter().map(|(m, _)| *m).collect();
    assert_eq!(
        names,
        h.state().ui_state().compare_methods,
        "every chosen method is traced"
    );
    let image = h.render().unwrap_or_else(|e| panic!("{e}"));
    assert!(
        distinct_colours(&image, 320, 80, 1270, 700) > 40,
        "the grid shows heat maps"
    );

    // Save As to a new file, then open it again.
    let dir = std::env::temp_dir().join(format!("skeletrace-editor-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let path = dir.join("edited.ron");
    // The File panel's path field: the text input holding the scene's path (the group's name
    // is another).
    h.get_all_by_role(egui::accesskit::Role::TextInput)
        .find(|n| n.value().is_some_and(|v| v.ends_with(".ron")))
        .unwrap_or_else(|| panic!("the path field"))
        .focus();
    h.step();
    h.key_press_modifiers(Modifiers::COMMAND, egui::Key::A);
    h.get_all_by_role(egui::accesskit::Role::TextInput)
        .find(|n| n.is_focused())
        .unwrap_or_else(|| panic!("the focused path field"))
        .type_text(&path.display().to_string());
    h.step();
    h.get_by_label("Save As").click();
    h.step();
    assert!(!h.state().document().is_dirty(), "{:?}", h.state().notice());
    let saved = h.state().document().scene().clone();
    h.get_by_label("Open").click();
    h.step();
    assert_eq!(h.state().document().path(), Some(path.as_path()));
    assert_eq!(h.state().document().scene(), &saved);
    let _ = std::fs::remove_dir_all(&dir);
}

/// HRBF points in a rotated, scaled group: click a point's handle, drag it with the gizmo (the
/// handle follows the pointer, so the move lands in the group's frame), then drag the tip of its
/// normal a quarter turn around it (the drawn normal follows), and undo both.
#[test]
fn hrbf_point_and_normal_drags_in_a_transformed_group() {
    if skeletrace_tests::skip_without_gpu("hrbf_point_and_normal_drags_in_a_transformed_group") {
        return;
    }
    let ui_state = UiState {
        backend: BackendChoice::Cpu,
        ..UiState::default()
    };
    let mut scene = skeletrace_core::Scene::load(&asset("hrbf")).unwrap_or_else(|e| panic!("{e}"));
    scene.groups[0].transform = skeletrace_core::model::scene::Transform {
        translate: [0.2, 0.1, 0.0],
        rotate: [0.0, 0.0, 30.0],
        scale: 1.3,
    };
    let before = scene.clone();
    let doc = Document::new(scene, None);
    let mut h = harness(Editor::new(doc, ui_state, None, || {}));
    settle(&mut h);
    let item = Item::HrbfPoint {
        group: 0,
        set: 0,
        point: 0,
    };
    let at = click_to_select(&mut h, item);

    // Move it 40 points down with the gizmo's view-plane handle.
    press(&mut h, at, true);
    for k in 1..=4 {
        h.hover_at(at + egui::vec2(0.0, 10.0 * k as f32));
        h.step();
    }
    press(&mut h, at + egui::vec2(0.0, 40.0), false);
    let now = h.state().screen_position(item).unwrap_or_default();
    assert!(
        (now.x - at.x).abs() < 2.0 && (now.y - at.y - 40.0).abs() < 2.0,
        "the point's handle follows the pointer in a transformed group: {at:?} -> {now:?}"
    );

    // Drag the normal's tip a quarter turn around the handle, in small steps.
    let tip = h
        .state()
        .screen_normal_tip(item)
        .unwrap_or_else(|| panic!("the normal is drawn"));
    let arm = tip - now;
    assert!(arm.length() > 5.0, "the normal is visible: {arm:?}");
    h.hover_at(tip);
    h.step();
    press(&mut h, tip, true);
    let turned = |angle: f32| {
        let (s, c) = angle.sin_cos();
        now + egui::vec2(c * arm.x - s * arm.y, s * arm.x + c * arm.y)
    };
    let quarter = std::f32::consts::FRAC_PI_2;
    for k in 1..=9 {
        h.hover_at(turned(quarter * k as f32 / 9.0));
        h.step();
    }
    press(&mut h, turned(quarter), false);
    let new_arm = h.state().screen_normal_tip(item).unwrap_or_default() - now;
    let expected = turned(quarter) - now;
    let cos = new_arm.normalized().dot(expected.normalized());
    assert!(
        cos > 0.99,
        "the drawn normal follows the dragged tip: {new_arm:?} vs {expected:?}"
    );
    let normal = h.state().document().scene().groups[0].hrbfs[0].points[0].normal;
    let old = before.groups[0].hrbfs[0].points[0].normal;
    assert_ne!(normal, old);

    // Two undo steps restore the scene.
    for _ in 0..2 {
        h.key_press_modifiers(Modifiers::COMMAND, egui::Key::Z);
        h.step();
    }
    assert_eq!(h.state().document().scene(), &before);
}

/// File dialogs that answer from a script, in order, and record what they were asked.
struct ScriptedDialogs {
    answers: Mutex<VecDeque<Result<Option<PathBuf>, String>>>,
    asked: Mutex<Vec<DialogRequest>>,
}

impl FileDialogs for ScriptedDialogs {
    fn unavailable(&self) -> Option<String> {
        None
    }

    fn pick(&self, request: &DialogRequest) -> Result<Option<PathBuf>, String> {
        self.asked
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push(request.clone());
        self.answers
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .pop_front()
            .unwrap_or(Ok(None))
    }
}

/// File > New > Empty scene starts from nothing: one empty group over the ground and sketch
/// mode on. Clicks in the viewport start a skeleton where the user clicks (on the plane through
/// the view's focus) and extend it, each new vertex with its parent's radius. The window title
/// names the document and marks unsaved changes.
#[test]
fn file_new_empty_scene_then_sketch_a_skeleton() {
    if skeletrace_tests::skip_without_gpu("file_new_empty_scene_then_sketch_a_skeleton") {
        return;
    }
    let doc = Document::open(&asset("creature")).unwrap_or_else(|e| panic!("{e}"));
    let ui_state = UiState {
        backend: BackendChoice::Cpu,
        ..UiState::default()
    };
    let mut h = harness(Editor::new(doc, ui_state, None, || {}));
    settle(&mut h);
    assert_eq!(h.state().title(), "creature.ron — skeletrace");
    h.get_by_role_and_label(egui::accesskit::Role::Button, "File")
        .click();
    h.step();
    h.step();
    h.get_by_label("New").hover();
    for _ in 0..4 {
        h.step();
    }
    let ctrl_n = h.ctx.format_shortcut(&egui::KeyboardShortcut::new(
        Modifiers::COMMAND,
        egui::Key::N,
    ));
    h.get_by_label(&format!("Empty scene {ctrl_n}")).click();
    h.step();
    settle(&mut h);
    let scene = h.state().document().scene().clone();
    assert_eq!(scene.groups.len(), 2, "a group to sketch in and the ground");
    assert_eq!(scene.counts().vertices + scene.counts().blobs, 0);
    assert_eq!(h.state().document().path(), None);
    assert_eq!(h.state().title(), "untitled — skeletrace");
    assert!(
        h.state()
            .notice()
            .is_some_and(|n| n.contains("sketch mode")),
        "{:?}",
        h.state().notice()
    );
    let rect = h
        .state()
        .viewport_rect()
        .unwrap_or_else(|| panic!("the viewport is drawn"));
    let click = |h: &mut Harness<'static, Editor>, at: Pos2| {
        h.hover_at(at);
        h.step();
        press(h, at, true);
        press(h, at, false);
        h.step();
    };
    click(&mut h, rect.center());
    click(&mut h, rect.center() + egui::vec2(80.0, -40.0));
    let scene = h.state().document().scene();
    let skeleton = &scene.groups[0].skeletons[..];
    assert_eq!(skeleton.len(), 1, "one skeleton started");
    let vertices = &skeleton[0].vertices;
    assert_eq!(vertices.len(), 2);
    assert_eq!(
        skeleton[0].edges.len(),
        1,
        "the second vertex grows from the first"
    );
    assert_eq!(
        vertices[1].radius, vertices[0].radius,
        "its parent's radius"
    );
    // Both on the plane through the focus, facing the camera: the click to the right is to the
    // right of the first vertex and above it.
    assert!(vertices[1].position[0] > vertices[0].position[0]);
    assert!(vertices[1].position[1] > vertices[0].position[1]);
    assert!(h.state().document().is_dirty());
    assert_eq!(h.state().title(), "untitled* — skeletrace");
}

/// Sketching with mirror symmetry (x = 0): from File > New > Empty scene, a click on the plane
/// starts the spine (no twin), a click to its right adds a vertex and its mirror image, each
/// joined to the spine; deleting one deletes its twin.
#[test]
fn sketching_with_mirror_symmetry_adds_the_twin() {
    if skeletrace_tests::skip_without_gpu("sketching_with_mirror_symmetry_adds_the_twin") {
        return;
    }
    let doc = Document::new(skeletrace::editor::Template::Empty.scene(), None);
    let ui_state = UiState {
        backend: BackendChoice::Cpu,
        mirror: Some(skeletrace::editor::Mirror::X),
        ..UiState::default()
    };
    let mut h = harness(Editor::new(doc, ui_state, None, || {}));
    settle(&mut h);
    h.key_press(egui::Key::S);
    h.step();
    let rect = h
        .state()
        .viewport_rect()
        .unwrap_or_else(|| panic!("the viewport is drawn"));
    for at in [rect.center(), rect.center() + egui::vec2(90.0, -30.0)] {
        h.hover_at(at);
        h.step();
        press(&mut h, at, true);
        press(&mut h, at, false);
        h.step();
    }
    let skeletons = &h.state().document().scene().groups[0].skeletons;
    let vertices: Vec<[f64; 3]> = skeletons
        .iter()
        .flat_map(|k| k.vertices.iter().map(|v| v.position))
        .collect();
    assert_eq!(vertices.len(), 3, "{vertices:?}");
    let edges: usize = skeletons.iter().map(|k| k.edges.len()).sum();
    assert_eq!(edges, 2, "both joined to the spine");
    let (a, b) = (vertices[1], vertices[2]);
    assert!(a[0] > 0.0, "{a:?}");
    assert!(
        (a[0] + b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9 && (a[2] - b[2]).abs() < 1e-9,
        "{a:?} and {b:?} mirror each other"
    );
    // The new vertex is selected: Delete takes its twin too.
    h.key_press(egui::Key::Delete);
    h.step();
    let left: usize = h.state().document().scene().groups[0]
        .skeletons
        .iter()
        .map(|k| k.vertices.len())
        .sum();
    assert_eq!(left, 1, "the spine is left");
}

/// View > "Use this view as the scene camera": after orbiting, the scene's camera is the view's
/// (an undoable edit), so renders and the next opening start from it.
#[test]
fn the_view_becomes_the_scene_camera() {
    if skeletrace_tests::skip_without_gpu("the_view_becomes_the_scene_camera") {
        return;
    }
    let doc = Document::open(&asset("blobs")).unwrap_or_else(|e| panic!("{e}"));
    let ui_state = UiState {
        backend: BackendChoice::Cpu,
        ..UiState::default()
    };
    let mut h = harness(Editor::new(doc, ui_state, None, || {}));
    settle(&mut h);
    let before = h.state().document().scene().camera;
    h.key_press(egui::Key::ArrowLeft);
    h.step();
    let view = h.state().orbit().camera();
    assert_ne!(view, before, "the arrow orbits");
    h.get_by_role_and_label(egui::accesskit::Role::Button, "View")
        .click();
    h.step();
    h.step();
    h.get_by_label("Use this view as the scene camera").click();
    h.step();
    assert_eq!(h.state().document().scene().camera, view);
    assert!(h.state().document().is_dirty());
}

/// Lights from the inspector: "Add point light" and "Add directional light" put a light in
/// the scene (a valid one), each an undoable edit.
#[test]
fn lights_are_added_from_the_inspector_with_undo() {
    if skeletrace_tests::skip_without_gpu("lights_are_added_from_the_inspector_with_undo") {
        return;
    }
    let doc = Document::open(&asset("operators")).unwrap_or_else(|e| panic!("{e}"));
    let ui_state = UiState {
        backend: BackendChoice::Cpu,
        ..UiState::default()
    };
    // Tall enough for the inspector to show the scene panel at its bottom without scrolling.
    let mut h = Harness::builder()
        .with_size(egui::vec2(1280.0, 1600.0))
        .wgpu()
        .build_ui_state(
            |ui, editor: &mut Editor| editor.ui(ui),
            Editor::new(doc, ui_state, None, || {}),
        );
    settle(&mut h);
    let before = h.state().document().scene().lights.len();
    for label in ["Add point light", "Add directional light"] {
        h.get_by_label(label).click();
        h.step();
        h.step();
    }
    let scene = h.state().document().scene().clone();
    assert_eq!(scene.lights.len(), before + 2);
    scene.validate().unwrap_or_else(|e| panic!("{e}"));
    for _ in 0..2 {
        h.key_press_modifiers(Modifiers::COMMAND, egui::Key::Z);
        h.step();
    }
    assert_eq!(h.state().document().scene().lights.len(), before);
}

/// Groups from the inspector: "Add group" puts an empty group with the edited group's kernel
/// in the list and in the blend tree's root, "Delete group" takes the edited group and its
/// leaves out, each one undoable step, and the scene stays valid throughout.
#[test]
fn groups_are_added_and_deleted_from_the_inspector_with_undo() {
    if skeletrace_tests::skip_without_gpu("groups_are_added_and_deleted_from_the_inspector") {
        return;
    }
    let doc = Document::open(&asset("operators")).unwrap_or_else(|e| panic!("{e}"));
    let ui_state = UiState {
        backend: BackendChoice::Cpu,
        ..UiState::default()
    };
    let mut h = harness(Editor::new(doc, ui_state, None, || {}));
    settle(&mut h);
    let before = h.state().document().scene().clone();
    h.get_by_label("Add group").click();
    h.step();
    let added = h.state().document().scene().clone();
    assert_eq!(added.groups.len(), 4);
    assert_eq!(added.groups[3].name, "group 4");
    added.validate().unwrap_or_else(|e| panic!("{e}"));
    assert!(
        format!("{:?}", added.blend).contains("Group(3)"),
        "{:?}",
        added.blend
    );
    // The new group is the edited one: deleting takes it out again.
    h.get_by_label("Delete group").click();
    h.step();
    assert_eq!(h.state().document().scene(), &before);
    h.key_press_modifiers(Modifiers::COMMAND, egui::Key::Z);
    h.step();
    assert_eq!(
        h.state().document().scene(),
        &added,
        "undo brings the group back"
    );
    h.key_press_modifiers(Modifiers::COMMAND, egui::Key::Z);
    h.step();
    assert_eq!(h.state().document().scene(), &before);
}

/// The blend tree from the inspector, nested as the operators asset's
/// `Ricci(p: 4, [Difference(0, 1), 2])`: "+ group" adds a leaf to the Ricci blend (a difference
/// takes no more), "sum every group" drops the tree, "Edit as a tree" starts one again as a sum
/// of every group; each an undoable edit of a valid scene.
#[test]
fn the_blend_tree_is_edited_from_the_inspector() {
    if skeletrace_tests::skip_without_gpu("the_blend_tree_is_edited_from_the_inspector") {
        return;
    }
    use skeletrace_core::model::scene::Blend;
    let doc = Document::open(&asset("operators")).unwrap_or_else(|e| panic!("{e}"));
    let ui_state = UiState {
        backend: BackendChoice::Cpu,
        ..UiState::default()
    };
    // Tall enough for the inspector to show the scene panel at its bottom without scrolling.
    let mut h = Harness::builder()
        .with_size(egui::vec2(1280.0, 1600.0))
        .wgpu()
        .build_ui_state(
            |ui, editor: &mut Editor| editor.ui(ui),
            Editor::new(doc, ui_state, None, || {}),
        );
    settle(&mut h);
    let g = Blend::Group;
    let difference = Blend::Difference(Box::new(g(0)), Box::new(g(1)));
    h.get_by_label("+ group").click();
    h.step();
    h.step();
    let scene = h.state().document().scene().clone();
    assert_eq!(
        scene.blend,
        Some(Blend::Ricci {
            p: 4.0,
            of: vec![difference.clone(), g(2), g(0)]
        })
    );
    scene.validate().unwrap_or_else(|e| panic!("{e}"));
    h.get_by_label("sum every group").click();
    h.step();
    h.step();
    assert_eq!(h.state().document().scene().blend, None);
    h.get_by_label("Edit as a tree").click();
    h.step();
    h.step();
    assert_eq!(
        h.state().document().scene().blend,
        Some(Blend::Sum(vec![g(0), g(1), g(2)]))
    );
    for _ in 0..3 {
        h.key_press_modifiers(Modifiers::COMMAND, egui::Key::Z);
        h.step();
    }
    assert_eq!(
        h.state().document().scene().blend,
        Some(Blend::Ricci {
            p: 4.0,
            of: vec![difference, g(2)]
        }),
        "three undos"
    );
}

/// Clicks File → `entry` and runs frames until the dialog's answer has been taken.
fn file_menu(h: &mut Harness<'static, Editor>, entry: &str) {
    h.get_by_role_and_label(egui::accesskit::Role::Button, "File")
        .click();
    h.step();
    h.step();
    h.get_by_label(entry).click();
    h.step();
    for _ in 0..400 {
        if !h.state().file_dialog_open() {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
        h.step();
    }
    assert!(!h.state().file_dialog_open(), "the dialog answered");
    h.step();
}

/// Runs frames until the screenshots and meshes written in the background are done. They share
/// the CPU (and rayon's pool) with the other tests' renders, so the deadline is generous.
fn wait_for_writes(h: &mut Harness<'static, Editor>) {
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(300);
    while h.state().background_writes() > 0 {
        assert!(
            std::time::Instant::now() < deadline,
            "the background writes did not finish in 300 s"
        );
        std::thread::sleep(std::time::Duration::from_millis(10));
        h.step();
    }
}

/// The standard views: 7 looks down from the top, Ctrl+3 from the left, and View → Front view
/// along −z; each keeps the target and the distance.
#[test]
fn standard_views_by_key_and_menu() {
    if skeletrace_tests::skip_without_gpu("standard_views_by_key_and_menu") {
        return;
    }
    let ui_state = UiState {
        backend: BackendChoice::Cpu,
        ..UiState::default()
    };
    let doc = Document::open(&asset("blobs")).unwrap_or_else(|e| panic!("{e}"));
    let mut h = harness(Editor::new(doc, ui_state, None, || {}));
    h.step();
    let before = *h.state().orbit();
    let from = |h: &Harness<'static, Editor>| {
        let c = h.state().orbit().camera();
        let d = [0, 1, 2].map(|k| c.position[k] - c.target[k]);
        let n = d.iter().map(|x| x * x).sum::<f64>().sqrt();
        d.map(|x| x / n)
    };
    h.key_press(egui::Key::Num7);
    h.step();
    assert!(from(&h)[1] > 0.999, "top: {:?}", from(&h));
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Num3);
    h.step();
    assert!(from(&h)[0] < -0.999, "left: {:?}", from(&h));
    h.get_by_role_and_label(egui::accesskit::Role::Button, "View")
        .click();
    h.step();
    h.step();
    h.get_by_label_contains("Front view").click();
    h.step();
    assert!(from(&h)[2] > 0.999, "front: {:?}", from(&h));
    let after = h.state().orbit();
    assert_eq!(after.target, before.target);
    assert!((after.distance - before.distance).abs() < 1e-12);
}

/// File → Export mesh…: the menu shows what an export at its resolution will take; the export
/// runs on its own thread under a progress window while the editor goes on, and writes a
/// watertight 3MF; a second one, cancelled from the window, leaves no file and says so.
#[test]
fn mesh_export_states_its_estimate_shows_progress_and_can_be_cancelled() {
    if skeletrace_tests::skip_without_gpu(
        "mesh_export_states_its_estimate_shows_progress_and_can_be_cancelled",
    ) {
        return;
    }
    let dir = std::env::temp_dir().join(format!("skeletrace-export-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let dialogs = Arc::new(ScriptedDialogs {
        answers: Mutex::new(VecDeque::from([
            Ok(Some(dir.join("blobs.3mf"))),
            Ok(Some(dir.join("cancelled.stl"))),
        ])),
        asked: Mutex::new(Vec::new()),
    });
    let ui_state = UiState {
        backend: BackendChoice::Cpu,
        export_resolution: 40,
        ..UiState::default()
    };
    let doc = Document::open(&asset("blobs")).unwrap_or_else(|e| panic!("{e}"));
    let editor = Editor::new(doc, ui_state, None, || {}).with_file_dialogs(dialogs.clone());
    let mut h = harness(editor);
    h.step();
    h.get_by_role_and_label(egui::accesskit::Role::Button, "File")
        .click();
    h.step();
    h.step();
    assert!(
        h.query_by_label_contains("triangles,").is_some(),
        "the File menu states the export's estimate"
    );
    h.key_press(egui::Key::Escape);
    h.step();

    file_menu(&mut h, "Export mesh…");
    assert!(h.state().exporting_mesh());
    wait_for_writes(&mut h);
    h.step();
    assert!(!h.state().exporting_mesh(), "the progress window closes");
    let notice = h.state().notice().unwrap_or_default().to_owned();
    assert!(notice.contains("watertight"), "{notice}");
    let package = std::fs::read(dir.join("blobs.3mf")).unwrap_or_else(|e| panic!("{e}"));
    assert!(package.starts_with(b"PK"), "a zip package");

    // A fine grid takes long enough to cancel from the window.
    h.state_mut().set_export_resolution(400);
    file_menu(&mut h, "Export mesh…");
    assert!(
        h.query_by_label("Exporting mesh").is_some(),
        "the progress window"
    );
    h.get_by_label("Cancel export").click();
    h.step();
    wait_for_writes(&mut h);
    h.step();
    let notice = h.state().notice().unwrap_or_default().to_owned();
    assert!(notice.contains("cancelled"), "{notice}");
    assert!(!dir.join("cancelled.stl").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The File menu through (scripted) system dialogs: Save As names a file without an extension
/// and gets `.ron`; a screenshot and a mesh are written (in the background) where their dialogs
/// say; Open on unsaved changes asks first;
/// a dialog that cannot be shown sends the user to the path field, and later requests go there
/// directly.
#[test]
fn file_dialogs_save_open_and_fall_back_to_the_path_field() {
    if skeletrace_tests::skip_without_gpu("file_dialogs_save_open_and_fall_back_to_the_path_field")
    {
        return;
    }
    let dir = std::env::temp_dir().join(format!("skeletrace-dialogs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let dialogs = Arc::new(ScriptedDialogs {
        answers: Mutex::new(VecDeque::from([
            Ok(Some(dir.join("copy"))),
            Ok(Some(dir.join("shot.png"))),
            Ok(Some(dir.join("mesh"))),
            Ok(Some(asset("blobs"))),
            Err("no portal in this test".to_owned()),
        ])),
        asked: Mutex::new(Vec::new()),
    });
    let ui_state = UiState {
        backend: BackendChoice::Cpu,
        screenshot_size: (64, 48),
        ..UiState::default()
    };
    let doc = Document::open(&asset("blobs")).unwrap_or_else(|e| panic!("{e}"));
    let editor = Editor::new(doc, ui_state, None, || {}).with_file_dialogs(dialogs.clone());
    let mut h = harness(editor);
    h.step();

    file_menu(&mut h, "Save As…");
    let copy = dir.join("copy.ron");
    assert_eq!(h.state().document().path(), Some(copy.as_path()));
    assert!(copy.exists() && !h.state().document().is_dirty());

    // Screenshots and meshes are written on threads of their own; the UI goes on meanwhile.
    file_menu(&mut h, "Screenshot…");
    file_menu(&mut h, "Export mesh…");
    wait_for_writes(&mut h);
    let shot = std::fs::read(dir.join("shot.png")).unwrap_or_else(|e| panic!("{e}"));
    assert!(shot.starts_with(b"\x89PNG"), "{:?}", h.state().notice());
    let mesh = std::fs::read(dir.join("mesh.glb")).unwrap_or_else(|e| panic!("{e}"));
    assert!(mesh.starts_with(b"glTF"), "{:?}", h.state().notice());

    // An unsaved edit: Open asks first, and Discard opens.
    h.key_press(egui::Key::B);
    h.step();
    assert!(h.state().document().is_dirty());
    file_menu(&mut h, "Open…");
    assert_eq!(h.state().document().path(), Some(copy.as_path()));
    h.get_by_label("Discard").click();
    h.step();
    assert_eq!(h.state().document().path(), Some(asset("blobs").as_path()));

    // No dialog: the path field takes over.
    file_menu(&mut h, "Open…");
    let notice = h.state().notice().unwrap_or_default().to_owned();
    assert!(
        notice.contains("no portal in this test") && notice.contains("File panel"),
        "{notice}"
    );
    file_menu(&mut h, "Save As…");
    let asked: Vec<(FilePurpose, String)> = dialogs
        .asked
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .iter()
        .map(|r| (r.purpose, r.file_name.clone()))
        .collect();
    assert_eq!(
        asked,
        [
            (FilePurpose::SaveAs, "blobs.ron".to_owned()),
            (FilePurpose::Screenshot, "copy-shaded.png".to_owned()),
            (FilePurpose::ExportMesh, "copy.glb".to_owned()),
            (FilePurpose::Open, "copy.ron".to_owned()),
            (FilePurpose::Open, "blobs.ron".to_owned()),
        ],
        "after a failure the dialog is not asked again"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The comparison grid's colour bar says its scale (logarithmic by default), hovering
/// a pixel of a panel finds it, and clicking it opens the ray inspector on that pixel: every
/// panel's method is traced there with the step count its heat map shows (the same trace as
/// `skeletrace trace-ray`), with one logged step per step for the marching methods, and the
/// plot window is on screen. Switching to the linear scale relabels the bar without a retrace.
#[test]
fn clicking_a_grid_pixel_inspects_its_ray_with_the_heat_maps_step_counts() {
    if skeletrace_tests::skip_without_gpu("clicking_a_grid_pixel_inspects_its_ray") {
        return;
    }
    let ui_state = UiState {
        backend: BackendChoice::Cpu,
        view: ViewMode::Compare,
        compare_methods: vec![
            skeletrace_core::MethodId::Segment,
            skeletrace_core::MethodId::QuadraticTaylor,
        ],
        ..UiState::default()
    };
    let doc = Document::open(&asset("creature")).unwrap_or_else(|e| panic!("{e}"));
    let mut h = harness(Editor::new(doc, ui_state, None, || {}));
    settle_at_full_resolution(&mut h);
    assert!(h.query_by_label("steps (log scale)").is_some());

    // Scan the central area for a pixel on the surface that segment tracing needs several
    // steps at.
    let mut target = None;
    'scan: for y in (120..700).step_by(20) {
        for x in (340..1260).step_by(20) {
            let at = Pos2::new(x as f32, y as f32);
            h.hover_at(at);
            h.step();
            let Some((u, v)) = h.state().hovered_pixel() else {
                continue;
            };
            let frames = h.state().shown_frames();
            let (_, frame) = frames[0];
            let i = v * frame.width + u;
            if frame.is_hit(i) && frame.steps[i] >= 6 {
                target = Some((at, (u, v)));
                break 'scan;
            }
        }
    }
    let (at, (u, v)) = target.unwrap_or_else(|| panic!("no pixel with several steps"));
    press(&mut h, at, true);
    press(&mut h, at, false);
    h.step();
    let probe = h
        .state()
        .ray_probe()
        .unwrap_or_else(|| panic!("the click opens the inspector"))
        .clone();
    assert_eq!(probe.pixel, (u, v));
    let frames = h.state().shown_frames();
    assert_eq!(probe.traces.len(), frames.len());
    for ((id, trace), (method, frame)) in probe.traces.iter().zip(&frames) {
        assert_eq!(id, method);
        assert_eq!(probe.size, (frame.width, frame.height));
        assert_eq!(
            trace.steps,
            frame.steps[v * frame.width + u],
            "{id}: the inspector traces the heat map's ray"
        );
        let log = trace.log.as_ref().map_or(0, Vec::len);
        assert_eq!(log, trace.steps as usize, "{id}: one logged step per step");
    }
    assert!(probe.samples.len() > 100 && !probe.supports.is_empty());
    assert!(h.query_by_label("Ray inspector").is_some());
    // `SKELETRACE_SCREENSHOTS=docs/images` keeps the window image for the README.
    if let Some(dir) = std::env::var_os("SKELETRACE_SCREENSHOTS") {
        h.step();
        save_window_image(&mut h, &Path::new(&dir).join("ray-inspector.png"));
    }

    // The linear scale: the bar says so, and nothing is traced again.
    let shown = h.state().shown_frames().len();
    h.get_by_label("linear").click();
    h.step();
    h.step();
    assert!(h.query_by_label("steps (linear scale)").is_some());
    assert_eq!(h.state().shown_frames().len(), shown);
}

/// The comparison grid keeps the viewport's aspect for 1, 2, 4 and 9 panels: every
/// chosen method gets a panel, each panel has the aspect of the grid's area (the whole view,
/// not a strip of it), and the panels lie inside the area without overlapping.
#[test]
fn the_comparison_grid_keeps_the_views_aspect_for_one_to_nine_panels() {
    if skeletrace_tests::skip_without_gpu("the_comparison_grid_keeps_the_views_aspect") {
        return;
    }
    use skeletrace_core::MethodId;
    let nine = [
        MethodId::Segment,
        MethodId::SegmentOriginal,
        MethodId::LinearTaylor,
        MethodId::QuadraticTaylor,
        MethodId::BottomUpLinear,
        MethodId::BottomUpQuadratic,
        MethodId::LinearMixed,
        MethodId::QuadraticMixed,
        MethodId::SphereAccelerated,
    ];
    for n in [1, 2, 4, 9] {
        let ui_state = UiState {
            backend: BackendChoice::Cpu,
            view: ViewMode::Compare,
            compare_methods: nine[..n].to_vec(),
            ..UiState::default()
        };
        let doc = Document::open(&asset("blobs")).unwrap_or_else(|e| panic!("{e}"));
        let mut h = harness(Editor::new(doc, ui_state, None, || {}));
        settle(&mut h);
        let (area, panels) = h
            .state()
            .compare_layout()
            .cloned()
            .unwrap_or_else(|| panic!("{n} panels: the grid is drawn"));
        assert_eq!(panels.len(), n, "every method has its panel");
        let aspect = area.width() / area.height();
        for (k, p) in panels.iter().enumerate() {
            let own = p.width() / p.height();
            assert!(
                (own / aspect - 1.0).abs() < 0.04,
                "{n} panels: panel {k} has aspect {own:.3}, the view {aspect:.3}"
            );
            assert!(
                area.expand(1.0).contains_rect(*p),
                "{n} panels: {p:?} outside {area:?}"
            );
            for q in &panels[k + 1..] {
                assert!(
                    !p.shrink(1.0).intersects(q.shrink(1.0)),
                    "{n} panels overlap: {p:?} {q:?}"
                );
            }
        }
        // Panels use the space: together they cover a good part of the area.
        let covered: f32 = panels.iter().map(|p| p.area()).sum();
        assert!(
            covered > 0.3 * area.area(),
            "{n} panels cover {covered} of {}",
            area.area()
        );
        // `SKELETRACE_SCREENSHOTS=…/docs/images` keeps the four-panel grid for the README.
        if let Some(dir) = std::env::var_os("SKELETRACE_SCREENSHOTS").filter(|_| n == 4) {
            // The full-resolution frames follow the previews once the view is still.
            std::thread::sleep(std::time::Duration::from_millis(400));
            settle(&mut h);
            save_window_image(&mut h, &Path::new(&dir).join("compare-grid.png"));
        }
    }
}

/// The editor in a window rendered by kittest's software adapter, with the device the editor
/// asks eframe for and the GPU viewport on it (taken on lavapipe as `SKELETRACE_GPU_VIEWPORT=1`
/// would); `ppp` small, for lavapipe must trace the whole view within kittest's 10 s wait.
/// Lavapipe compiles a shader when it first runs: a small frame of every method the window
/// will trace, on a renderer of its own that waits as long as it takes, leaves them in Mesa's
/// shader cache first.
fn gpu_viewport_harness(mut editor: Editor, ppp: f32) -> Harness<'static, Editor> {
    let compiled = editor.document().compiled();
    let mut warm = skeletrace_render::GpuRenderer::new().unwrap_or_else(|e| panic!("{e}"));
    warm.set_scene(&compiled).unwrap_or_else(|e| panic!("{e}"));
    let ui = editor.ui_state();
    let shown = match ui.view {
        ViewMode::Shaded => vec![ui.shaded_method],
        ViewMode::Compare => ui.compare_methods.clone(),
    };
    let methods: Vec<_> = shown
        .into_iter()
        .filter_map(skeletrace_render::GpuMethod::from_id)
        .collect();
    warm.render(&frame_request(
        &methods,
        editor.orbit().camera(),
        &compiled.settings,
        (8, 8),
        skeletrace_core::frame::View::Shaded(ui.shading),
        false,
    ))
    .unwrap_or_else(|e| panic!("{e}"));
    let mut setup = egui_kittest::wgpu::default_wgpu_setup();
    if let eframe::egui_wgpu::WgpuSetup::CreateNew(new) = &mut setup {
        new.device_descriptor = std::sync::Arc::new(|adapter: &eframe::wgpu::Adapter| {
            skeletrace_render::gpu_renderer::device_descriptor(adapter)
        });
    }
    let render_state = egui_kittest::wgpu::create_render_state(
        setup,
        eframe::egui_wgpu::RendererOptions::PREDICTABLE,
    );
    editor
        .enable_gpu_viewport(&render_state)
        .unwrap_or_else(|e| panic!("{e}"));
    Harness::builder()
        .with_size(egui::vec2(720.0, 480.0))
        .with_pixels_per_point(ppp)
        .renderer(egui_kittest::wgpu::WgpuTestRenderer::from_render_state(
            render_state,
        ))
        .build_ui_state(|ui, editor: &mut Editor| editor.ui(ui), editor)
}

/// Draws the window until the GPU viewport has its frame's pipelines (compiled off the
/// window's thread, up to tens of seconds each on lavapipe: draws meanwhile return at once)
/// and has checked its last frame's tile lists (tracing it again if they were cut short); the
/// window's image then. A frame that lavapipe takes longer than kittest's 10 s wait to trace
/// is waited for by the next draws.
fn settle_gpu_viewport(h: &mut Harness<'static, Editor>) -> image::RgbaImage {
    draw_until(h, "the GPU viewport settled", |h, image| {
        (!h.state().gpu_viewport_settling()).then_some(image)
    })
}

/// Draws the window until `done` gives an answer from the state and the image drawn, for at
/// most ten minutes; waits 50 ms between draws while pipelines compile, and prints the longest
/// of those draws (the window's thread does not wait for the driver).
fn draw_until<T>(
    h: &mut Harness<'static, Editor>,
    what: &str,
    mut done: impl FnMut(&mut Harness<'static, Editor>, image::RgbaImage) -> Option<T>,
) -> T {
    use std::time::{Duration, Instant};
    let deadline = Instant::now() + Duration::from_secs(600);
    let (mut waits, mut longest) = (0, Duration::ZERO);
    while Instant::now() < deadline {
        let compiling = h.state().gpu_viewport_compiling();
        let start = Instant::now();
        h.step();
        let image = h.render();
        if compiling {
            waits += 1;
            longest = longest.max(start.elapsed());
        }
        if let Ok(image) = image
            && let Some(answer) = done(h, image)
        {
            if waits > 0 {
                eprintln!(
                    "{what}: {waits} draws while pipelines compiled, the longest {} ms",
                    longest.as_millis()
                );
            }
            return answer;
        }
        if h.state().gpu_viewport_compiling() {
            std::thread::sleep(Duration::from_millis(50));
        }
    }
    panic!("never: {what}")
}

/// Every third pixel each way of the GPU viewport: the colour of the same view read back from
/// `reference`, a renderer of the test's own (the window's shaded method and shading, with or
/// without shadow rays), and the window's colour there.
fn viewport_samples(
    h: &Harness<'static, Editor>,
    image: &image::RgbaImage,
    ppp: f32,
    reference: &mut skeletrace_render::GpuRenderer,
    shadows: bool,
) -> Vec<([u8; 3], [u8; 3])> {
    let rect = h
        .state()
        .viewport_rect()
        .unwrap_or_else(|| panic!("the viewport is drawn"));
    let size = ((rect.width() * ppp) as u32, (rect.height() * ppp) as u32);
    let compiled = h.state().document().compiled();
    let ui = h.state().ui_state();
    let method = skeletrace_render::GpuMethod::from_id(ui.shaded_method)
        .unwrap_or_else(|| panic!("the shaded method runs on the GPU"));
    reference
        .set_scene(&compiled)
        .unwrap_or_else(|e| panic!("{e}"));
    let frame = reference
        .render(&frame_request(
            &[method],
            h.state().orbit().camera(),
            &compiled.settings,
            size,
            skeletrace_core::frame::View::Shaded(ui.shading),
            shadows,
        ))
        .unwrap_or_else(|e| panic!("{e}"))
        .remove(0);
    let (x0, y0) = (
        (rect.left() * ppp).round() as u32,
        (rect.top() * ppp).round() as u32,
    );
    let mut samples = Vec::new();
    for y in (0..size.1).step_by(3) {
        for x in (0..size.0).step_by(3) {
            let want = frame.colour[(y * size.0 + x) as usize].map(skeletrace_core::frame::srgb8);
            let got = image.get_pixel(x0 + x, y0 + y).0;
            samples.push((want, [got[0], got[1], got[2]]));
        }
    }
    samples
}

/// Two sRGB colours within 3 of 255 in every channel.
fn same_colour(a: [u8; 3], b: [u8; 3]) -> bool {
    (0..3).all(|k| a[k].abs_diff(b[k]) <= 3)
}

/// The shaded viewport traced on the window's own device through an `egui_wgpu` paint
/// callback (taken on lavapipe here as `SKELETRACE_GPU_VIEWPORT=1` would): the window shows the
/// same picture as the GPU renderer's read-back frame of that view, hovering traces nothing
/// again, and orbiting traces once per new view without uploading the scene again.
#[test]
fn the_gpu_viewport_paints_the_traced_frame_in_the_window() {
    if skeletrace_tests::skip_without_gpu("the_gpu_viewport_paints_the_traced_frame") {
        return;
    }
    const PPP: f32 = 0.3;
    let ui_state = UiState {
        backend: BackendChoice::Auto,
        shaded_method: skeletrace_core::MethodId::QuadraticTaylor,
        ..UiState::default()
    };
    let doc = Document::open(&asset("blobs")).unwrap_or_else(|e| panic!("{e}"));
    let mut h = gpu_viewport_harness(Editor::new(doc, ui_state, None, || {}), PPP);
    let image = settle_gpu_viewport(&mut h);
    let (traced, uploaded, adapter) = h
        .state()
        .gpu_viewport_counts()
        .unwrap_or_else(|| panic!("the GPU viewport is on"));
    // The first frame's tile lists outgrow the items buffer's first size: it is traced again
    // in full once the total comes back, without a frame waiting for the GPU.
    assert_eq!(
        traced,
        2,
        "the viewport was traced on {adapter}, then again with every list ({:?})",
        h.state().notice()
    );
    assert_eq!(
        h.state().render_thread_gpu_frames(),
        0,
        "no frame read back from a GPU (the render thread traces only the CPU's previews while \
         pipelines compile)"
    );

    // The same view read back from a renderer of its own: the window shows its colours.
    let mut reference = skeletrace_render::GpuRenderer::new().unwrap_or_else(|e| panic!("{e}"));
    let samples = viewport_samples(&h, &image, PPP, &mut reference, false);
    let (same, total) = (
        samples.iter().filter(|(w, g)| same_colour(*w, *g)).count(),
        samples.len(),
    );
    // The blobs' handles (the overlay) cover about a fifth of this small viewport; the rest is
    // the traced frame.
    assert!(
        same as f64 > 0.7 * total as f64,
        "{same} of {total} viewport pixels match the read-back frame"
    );

    // Hovering redraws the window, not the frame.
    let rect = h
        .state()
        .viewport_rect()
        .unwrap_or_else(|| panic!("the viewport is drawn"));
    h.hover_at(rect.center());
    h.step();
    settle_gpu_viewport(&mut h);
    assert_eq!(h.state().gpu_viewport_counts().map(|c| c.0), Some(traced));

    // Orbiting from the background: a new view is traced; the scene is not uploaded again.
    let start = rect.left_top() + egui::vec2(12.0, 12.0);
    press(&mut h, start, true);
    for k in 1..=3 {
        h.hover_at(start + egui::vec2(15.0 * k as f32, 0.0));
        h.step();
    }
    press(&mut h, start + egui::vec2(45.0, 0.0), false);
    settle_gpu_viewport(&mut h);
    let (orbited, uploaded_orbit, _) = h.state().gpu_viewport_counts().unwrap_or_default();
    assert!(
        orbited > traced,
        "orbiting traces the new view: {traced} -> {orbited}"
    );
    assert_eq!(uploaded_orbit, uploaded, "orbiting uploads nothing");

    // Dragging a blob is an edit: traced again, and only that blob's primitive is uploaded.
    let item = Item::Blob { group: 0, blob: 0 };
    let at = h
        .state()
        .screen_position(item)
        .unwrap_or_else(|| panic!("the blob's handle is on screen"));
    h.hover_at(at);
    h.step();
    press(&mut h, at, true);
    for k in 1..=3 {
        h.hover_at(at + egui::vec2(0.0, 6.0 * k as f32));
        h.step();
    }
    press(&mut h, at + egui::vec2(0.0, 18.0), false);
    settle_gpu_viewport(&mut h);
    let (edited, uploaded_edit, _) = h.state().gpu_viewport_counts().unwrap_or_default();
    assert!(h.state().document().is_dirty(), "the drag moved the blob");
    assert!(edited > orbited, "the edit is traced");
    let one = std::mem::size_of::<skeletrace_render::buffers::GpuPrimitive>() as u64;
    assert_eq!(
        uploaded_edit - uploaded_orbit,
        one,
        "an edit of one blob uploads one primitive"
    );
}

/// The comparison grid never waits for its slowest panel: the render thread traces the grid's
/// methods cheapest first and hands each frame over as it comes, so quadratic Taylor's panel is
/// at full resolution while sphere tracing's (tens of times slower on the creature) still shows
/// its preview; then both are at full resolution.
#[test]
fn the_grid_shows_fast_panels_at_full_resolution_while_a_slow_one_refines() {
    if skeletrace_tests::skip_without_gpu("the_grid_shows_fast_panels_at_full_resolution") {
        return;
    }
    use skeletrace_core::MethodId;
    let ui_state = UiState {
        backend: BackendChoice::Cpu,
        view: ViewMode::Compare,
        compare_methods: vec![MethodId::Sphere, MethodId::QuadraticTaylor],
        ..UiState::default()
    };
    let doc = Document::open(&asset("creature")).unwrap_or_else(|e| panic!("{e}"));
    let mut h = Harness::builder()
        .with_size(egui::vec2(720.0, 420.0))
        .wgpu()
        .build_ui_state(
            |ui, editor: &mut Editor| editor.ui(ui),
            Editor::new(doc, ui_state, None, || {}),
        );
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(600);
    let (mut mixed, mut first) = (None, None);
    loop {
        h.step();
        let frames = h.state().shown_frames();
        let pixels = |method| {
            frames
                .iter()
                .find(|(m, _)| *m == method)
                .map(|(_, f)| f.width * f.height)
        };
        if let (Some(sphere), Some(taylor)) =
            (pixels(MethodId::Sphere), pixels(MethodId::QuadraticTaylor))
        {
            let smallest = *first.get_or_insert(sphere.min(taylor));
            if taylor > sphere {
                mixed.get_or_insert((sphere, taylor));
            } else if sphere == taylor && sphere > smallest {
                // Both past the first preview's size: both at full resolution.
                break;
            }
        }
        assert!(
            std::time::Instant::now() < deadline,
            "the grid never reached both panels at full resolution"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let (sphere, taylor) =
        mixed.unwrap_or_else(|| panic!("quadratic Taylor's panel never led sphere tracing's"));
    eprintln!(
        "quadratic-taylor at {taylor} pixels while sphere tracing showed {sphere}; then both full"
    );
}

/// A structural edit (a blend tree of another shape: new pipelines) in the GPU viewport on
/// lavapipe: until the new pipelines are compiled, the window shows the new scene traced on the
/// CPU at a preview's resolution, never the last GPU frame, and the status bar says so; then
/// the GPU traces the new scene. The new tree nests the blobs' tree in sums and Ricci blends of
/// one operand, as many and in the order the clock's nanoseconds pick, so that Mesa's shader
/// cache has not seen its shaders and their compilation is as cold as on a fresh machine.
#[test]
fn a_structural_edit_shows_the_new_scene_on_the_cpu_while_the_gpu_compiles() {
    if skeletrace_tests::skip_without_gpu("a_structural_edit_shows_the_new_scene_on_the_cpu") {
        return;
    }
    const PPP: f32 = 0.3;
    let ui_state = UiState {
        backend: BackendChoice::Auto,
        shaded_method: skeletrace_core::MethodId::QuadraticTaylor,
        ..UiState::default()
    };
    let doc = Document::open(&asset("blobs")).unwrap_or_else(|e| panic!("{e}"));
    let mut h = gpu_viewport_harness(Editor::new(doc, ui_state, None, || {}), PPP);
    settle_gpu_viewport(&mut h);
    assert_eq!(
        h.state().viewport_source(),
        Some(true),
        "the GPU draws the view"
    );
    let (traced, _, _) = h.state().gpu_viewport_counts().unwrap_or_default();
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    // Shallow (a deep Ricci nesting compiles for minutes on a loaded lavapipe), and still one
    // of several hundred trees.
    let depth = 1 + nanos % 8;
    let applied = h.state_mut().apply(Edit::new("nest the blend"), |scene| {
        use skeletrace_core::model::scene::Blend;
        let mut blend = scene.blend.take().unwrap_or_else(|| panic!("blobs blend"));
        for level in 0..depth {
            // A sum or a Ricci blend of one operand (the blobs' fields are not negative):
            // the field stays, the code grows.
            blend = if (nanos >> (6 + level)) & 1 == 0 {
                Blend::Sum(vec![blend])
            } else {
                Blend::Ricci {
                    p: 2.0,
                    of: vec![blend],
                }
            };
        }
        scene.blend = Some(blend);
    });
    assert!(applied, "the edit is applied");
    let (mut cpu_draws, mut labelled) = (0, false);
    draw_until(&mut h, "the GPU frame of the new scene", |h, _| {
        let editor = h.state();
        if editor.gpu_viewport_compiling() && editor.viewport_source() == Some(false) {
            cpu_draws += 1;
            labelled |= h
                .query_by_label_contains("traced on the CPU meanwhile")
                .is_some();
        }
        let (now, _, _) = editor.gpu_viewport_counts().unwrap_or_default();
        (now > traced && !editor.gpu_viewport_compiling()).then_some(())
    });
    eprintln!("{cpu_draws} draws showed the CPU's frame of the new scene (nesting {depth})");
    assert!(
        cpu_draws > 0,
        "the new scene's CPU frame was shown before its GPU pipelines were compiled"
    );
    assert!(labelled, "the status bar says the CPU traces meanwhile");
    settle_gpu_viewport(&mut h);
    assert_eq!(
        h.state().viewport_source(),
        Some(true),
        "the GPU draws again"
    );
}

/// With "shadow rays" on, the GPU viewport traces a shadow ray from each hit to each
/// light: the window shows the read-back frame of that view, which differs from the frame
/// without them. (Reflection and refraction through transparent groups are held to the CPU by
/// `gpu_agreement.rs`; the viewport, which never waits, records the dispatches of a full tree of
/// rays for them, minutes per frame on lavapipe.)
#[test]
fn the_gpu_viewport_traces_shadow_rays() {
    if skeletrace_tests::skip_without_gpu("the_gpu_viewport_traces_shadow_rays") {
        return;
    }
    const PPP: f32 = 0.3;
    let ui_state = UiState {
        backend: BackendChoice::Auto,
        shaded_method: skeletrace_core::MethodId::QuadraticTaylor,
        shadows: true,
        ..UiState::default()
    };
    // The blobs' lights and camera; a large blob, and a small one between it and the key
    // light, far enough out that the camera sees its shadow. Two handles, off the shadow.
    let mut scene = Document::open(&asset("blobs"))
        .unwrap_or_else(|e| panic!("{e}"))
        .scene()
        .clone();
    scene.groups.truncate(2);
    scene.blend = None;
    scene.groups[0].blobs = vec![skeletrace_core::model::scene::Blob {
        center: [0.0; 3],
        radius: 1.0,
    }];
    let towards_light = glam::DVec3::new(0.5, 0.8, 0.6).normalize() * 2.3;
    scene.groups[1].blobs = vec![skeletrace_core::model::scene::Blob {
        center: towards_light.to_array(),
        radius: 0.4,
    }];
    let doc = Document::new(scene, None);
    let mut h = gpu_viewport_harness(Editor::new(doc, ui_state, None, || {}), PPP);
    let image = settle_gpu_viewport(&mut h);
    let mut reference = skeletrace_render::GpuRenderer::new().unwrap_or_else(|e| panic!("{e}"));
    let with = viewport_samples(&h, &image, PPP, &mut reference, true);
    let without = viewport_samples(&h, &image, PPP, &mut reference, false);
    // The pixels the shadow rays darken: the window shows each nearer its shadowed colour.
    let distance = |a: [u8; 3], b: [u8; 3]| (0..3).map(|k| a[k].abs_diff(b[k]) as u32).sum::<u32>();
    let shadowed: Vec<usize> = (0..with.len())
        .filter(|&i| !same_colour(with[i].0, without[i].0))
        .collect();
    let shown = shadowed
        .iter()
        .filter(|&&i| distance(with[i].0, with[i].1) < distance(without[i].0, with[i].1))
        .count();
    eprintln!(
        "{} sampled pixels in shadow, {shown} of them shown nearer their shadowed colour",
        shadowed.len()
    );
    assert!(
        shadowed.len() >= 10,
        "only {} sampled pixels are in shadow",
        shadowed.len()
    );
    assert!(
        shown * 10 >= shadowed.len() * 9,
        "the window shows {shown} of the {} shadowed pixels nearer their shadowed colour",
        shadowed.len()
    );
    let all = with.iter().filter(|(w, g)| same_colour(*w, *g)).count();
    assert!(
        all as f64 > 0.7 * with.len() as f64,
        "{all} of {} viewport pixels match the read-back frame with shadow rays",
        with.len()
    );
}

/// The comparison grid on the window's GPU. The heat maps are traced and coloured
/// there (the render thread traces nothing) and only the statistics come back: each panel's
/// histogram equals that of the same frame read back from a renderer of its own, the shared
/// top is the CPU's rule applied to those frames, the window shows each frame's heat colours
/// on that top, the hovered pixel's counts are the frames' counts there, and switching to the
/// linear scale recolours the panels without tracing again.
#[test]
fn the_comparison_grid_on_the_gpu_reads_back_only_its_statistics() {
    if skeletrace_tests::skip_without_gpu("the_comparison_grid_on_the_gpu") {
        return;
    }
    use skeletrace_core::MethodId;
    use skeletrace_core::frame::{StepScale, heat_colour, shared_step_top};
    use skeletrace_render::GpuMethod;
    const PPP: f32 = 0.3;
    let methods = [
        MethodId::Segment,
        MethodId::QuadraticTaylor,
        MethodId::BottomUpQuadratic,
    ];
    let ui_state = UiState {
        backend: BackendChoice::Auto,
        view: ViewMode::Compare,
        compare_methods: methods.to_vec(),
        ..UiState::default()
    };
    let doc = Document::open(&asset("blobs")).unwrap_or_else(|e| panic!("{e}"));
    let mut h = gpu_viewport_harness(Editor::new(doc, ui_state, None, || {}), PPP);
    // A frame traces and records the copy, the next maps it, a later one reads it.
    let current = |h: &mut Harness<'static, Editor>| {
        draw_until(h, "the grid's statistics came back", |h, image| {
            match h.state().gpu_grid_statistics() {
                Some((s, true)) if !h.state().gpu_viewport_settling() => Some((s, image)),
                _ => None,
            }
        })
    };
    let (stats, image) = current(&mut h);
    assert_eq!(
        h.state().render_thread_gpu_frames(),
        0,
        "no frame read back from a GPU (the render thread traces only the CPU's previews while \
         pipelines compile)"
    );
    let traced = h.state().gpu_viewport_counts().map(|c| c.0);
    let size = (stats.shape.width, stats.shape.height);
    assert_eq!(stats.histograms.len(), methods.len());

    // The same frames read back from a renderer of its own.
    let compiled = h.state().document().compiled();
    let mut reference = skeletrace_render::GpuRenderer::new().unwrap_or_else(|e| panic!("{e}"));
    reference
        .set_scene(&compiled)
        .unwrap_or_else(|e| panic!("{e}"));
    let gpu_methods: Vec<GpuMethod> = methods
        .iter()
        .map(|&m| GpuMethod::from_id(m).unwrap_or_else(|| panic!("{m} runs on the GPU")))
        .collect();
    let frames = reference
        .render(&frame_request(
            &gpu_methods,
            h.state().orbit().camera(),
            &compiled.settings,
            size,
            skeletrace_core::frame::View::Steps {
                steps_max: compiled.settings.max_steps,
            },
            false,
        ))
        .unwrap_or_else(|e| panic!("{e}"));
    let histograms: Vec<_> = frames.iter().map(|f| f.step_histogram()).collect();
    for (k, (got, want)) in stats.histograms.iter().zip(&histograms).enumerate() {
        assert_eq!(got.pixels(), u64::from(size.0 * size.1));
        assert_eq!(got, want, "{}: the GPU's histogram", methods[k]);
    }
    assert_eq!(stats.top, shared_step_top(&histograms));

    // The window's panels show the frames' heat colours on that top, log scale first, at the
    // pixels whose ray met a support.
    let (_, panels) = h
        .state()
        .compare_layout()
        .cloned()
        .unwrap_or_else(|| panic!("the grid is drawn"));
    let shows = |image: &image::RgbaImage, scale: StepScale| {
        let (mut same, mut total) = (0, 0);
        for (panel, frame) in panels.iter().zip(&frames) {
            let (x0, y0) = (panel.left() * PPP, panel.top() * PPP);
            for y in (1..size.1 - 1).step_by(3) {
                for x in (1..size.0 - 1).step_by(3) {
                    let s = frame.steps[(y * size.0 + x) as usize];
                    if s == 0 {
                        // Rays that meet no support: one colour, which proves little.
                        continue;
                    }
                    let want = heat_colour(scale.position(f64::from(s), stats.top))
                        .map(|c| (c * 255.0 + 0.5) as u8);
                    let got = image
                        .get_pixel((x0 + x as f32 + 0.5) as u32, (y0 + y as f32 + 0.5) as u32)
                        .0;
                    total += 1;
                    same += usize::from((0..3).all(|k| want[k].abs_diff(got[k]) <= 3));
                }
            }
        }
        same as f64 / total as f64
    };
    let log = shows(&image, StepScale::Log);
    assert!(
        log > 0.9,
        "{log:.3} of the sampled pixels show the log heat colour"
    );

    // Hovering a pixel of the second panel reads back every panel's count there.
    h.hover_at(panels[1].center());
    let (probed, _) = current(&mut h);
    let (u, v) = h
        .state()
        .hovered_pixel()
        .unwrap_or_else(|| panic!("a grid pixel is hovered"));
    let at = v * size.0 as usize + u;
    let want: Vec<u32> = frames.iter().map(|f| f.steps[at]).collect();
    assert_eq!(probed.probe_steps, want, "the counts at pixel {u}, {v}");
    assert!(
        want.iter().any(|&s| s > 0),
        "the centre's ray meets a support"
    );
    assert_eq!(h.state().gpu_viewport_counts().map(|c| c.0), traced);

    // The linear scale: recoloured on the GPU, not traced again.
    h.get_by_label("linear").click();
    h.hover_at(Pos2::new(2.0, 2.0));
    let (_, image) = current(&mut h);
    assert!(h.query_by_label("steps (linear scale)").is_some());
    let linear = shows(&image, StepScale::Linear);
    assert!(linear > 0.9, "{linear:.3} show the linear heat colour");
    assert_eq!(h.state().gpu_viewport_counts().map(|c| c.0), traced);
}

/// The editor traces the default creature, the hand, the HRBF scene and the scene with
/// every shape and operator on the window's GPU (forced on lavapipe as a hardware adapter would
/// take it): the frame goes through the paint callback, the render thread traces nothing, and no
/// failure sends it back to the CPU.
#[test]
fn the_editor_traces_the_creature_and_the_hand_on_the_gpu() {
    if skeletrace_tests::skip_without_gpu("the_editor_traces_the_creature_and_the_hand") {
        return;
    }
    for name in ["creature", "hand", "operators", "hrbf"] {
        let ui_state = UiState {
            backend: BackendChoice::Auto,
            shaded_method: skeletrace_core::MethodId::QuadraticTaylor,
            ..UiState::default()
        };
        let doc = Document::open(&asset(name)).unwrap_or_else(|e| panic!("{e}"));
        let mut h = gpu_viewport_harness(Editor::new(doc, ui_state, None, || {}), 0.2);
        settle_gpu_viewport(&mut h);
        let (traced, _, _) = h
            .state()
            .gpu_viewport_counts()
            .unwrap_or_else(|| panic!("{name}: the GPU viewport is on"));
        assert!(
            traced >= 1,
            "{name}: traced on the GPU ({:?})",
            h.state().notice()
        );
        assert_eq!(
            h.state().render_thread_gpu_frames(),
            0,
            "{name}: no frame read back from a GPU"
        );
        assert!(
            h.state().gpu_viewport_counts().is_some(),
            "{name}: no failure sent the viewport back to the CPU ({:?})",
            h.state().notice()
        );
    }
}

/// An edit made in the window, then no input at all: within the autosave period (and
/// a little) the recovery file holds the edited scene.
#[test]
fn an_edit_followed_by_idleness_leaves_a_recovery_file() {
    if skeletrace_tests::skip_without_gpu("an_edit_followed_by_idleness_leaves_a_recovery_file") {
        return;
    }
    let dir = std::env::temp_dir().join(format!("skeletrace-idle-kittest-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let recovery = dir.join("recovery.ron");
    let ui_state = UiState {
        backend: BackendChoice::Cpu,
        ..UiState::default()
    };
    let doc = Document::open(&asset("creature")).unwrap_or_else(|e| panic!("{e}"));
    let mut h = harness(Editor::new(doc, ui_state, Some(recovery.clone()), || {}));
    settle(&mut h);
    h.get_by_label("end-point correctors").click();
    h.step();
    assert!(h.state().document().is_dirty(), "the click edits the scene");
    let edited = h.state().document().scene().clone();
    let start = std::time::Instant::now();
    while !recovery.exists() && start.elapsed() < std::time::Duration::from_secs(40) {
        std::thread::sleep(std::time::Duration::from_millis(500));
        h.step();
    }
    let restored = skeletrace_core::Scene::load(&recovery)
        .unwrap_or_else(|e| panic!("no recovery file after {:?}: {e}", start.elapsed()));
    assert_eq!(restored, edited);
    let _ = std::fs::remove_dir_all(&dir);
}
