//! The redesign's promise (DESIGN.md data flow): a scene is compiled once per edit, never per
//! frame and never for a camera move. Driven through the real editor with egui_kittest (no
//! renderer: no GPU needed), counting `skeletrace_core::compile::compile_count()`. This binary
//! holds a single test, so no other test compiles in between.

use std::path::Path;

use eframe::egui::{self, Event, Key, Modifiers, PointerButton, Pos2};
use egui_kittest::Harness;
use skeletrace::editor::{BackendChoice, Document, Editor, Item, UiState};
use skeletrace_core::compile::compile_count;

fn settle(h: &mut Harness<'static, Editor>) {
    h.step();
    let ctx = h.ctx.clone();
    h.state_mut().wait_for_frames(&ctx);
    h.step();
    h.step();
}

fn pointer(h: &mut Harness<'static, Editor>, pos: Pos2, pressed: Option<bool>) {
    h.event(Event::PointerMoved(pos));
    if let Some(pressed) = pressed {
        h.event(Event::PointerButton {
            pos,
            button: PointerButton::Primary,
            pressed,
            modifiers: Modifiers::NONE,
        });
    }
    h.step();
}

#[test]
fn orbiting_compiles_nothing_and_one_edit_compiles_once() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes/blobs.ron");
    let doc = Document::open(&path).unwrap_or_else(|e| panic!("{e}"));
    let ui_state = UiState {
        backend: BackendChoice::Cpu,
        ..UiState::default()
    };
    let mut h = Harness::builder()
        .with_size(egui::vec2(900.0, 600.0))
        .build_ui_state(
            |ui, editor: &mut Editor| editor.ui(ui),
            Editor::new(doc, ui_state, None, || {}),
        );
    settle(&mut h);
    let start = compile_count();
    assert!(!h.state().shown_frames().is_empty(), "a first frame");

    // Orbit: a left drag from an empty corner of the viewport, then the refined frame.
    let before = h.state().orbit().camera();
    let corner = Pos2::new(880.0, 60.0);
    pointer(&mut h, corner, Some(true));
    for k in 1..=10 {
        pointer(
            &mut h,
            corner - egui::vec2(12.0 * k as f32, 4.0 * k as f32),
            None,
        );
        let ctx = h.ctx.clone();
        h.state_mut().wait_for_frames(&ctx);
    }
    pointer(&mut h, corner - egui::vec2(120.0, 40.0), Some(false));
    std::thread::sleep(std::time::Duration::from_millis(300));
    settle(&mut h);
    let after = h.state().orbit().camera();
    assert_ne!(
        before.position, after.position,
        "the drag orbited the camera"
    );
    assert_eq!(
        compile_count(),
        start,
        "orbiting and the frames it traced compiled nothing"
    );

    // One edit: select a blob and delete it.
    let blob = Item::Blob { group: 0, blob: 0 };
    let at = h
        .state()
        .screen_position(blob)
        .unwrap_or_else(|| panic!("blob 0 is on screen"));
    pointer(&mut h, at, Some(true));
    pointer(&mut h, at, Some(false));
    assert!(h.state().selection().contains(&blob), "blob 0 selected");
    h.key_press(Key::Delete);
    settle(&mut h);
    assert!(
        h.state().document().undo_label().is_some(),
        "the delete is one edit"
    );
    assert_eq!(compile_count(), start + 1, "one edit compiles once");
    settle(&mut h);
    assert_eq!(compile_count(), start + 1, "later frames compile nothing");
}
