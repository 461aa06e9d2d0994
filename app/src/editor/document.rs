//! The edited scene, its file and its history (DESIGN.md, "Editor": every scene change is a
//! command on an undo stack, drags coalesced).
//!
//! An [`Edit`] names what changed; applying one records the scene before it, so undo and redo
//! restore whole scenes (scenes are small next to what the tracer does with them). Every edited
//! scene passes the loader's own rules (`Scene::validate`) before it replaces the current one,
//! so the editor can never hold a scene that would not load back.
//!
//! The document owns the compiled scene: [`Document::compiled`] compiles the current revision
//! once, on first use, and every view, the inspector and the render thread share that
//! `Arc<Compiled>`. A camera move is not an edit and compiles nothing.

use std::cell::OnceCell;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use skeletrace_core::{Compiled, Scene, compile};

/// Undo steps kept.
const HISTORY: usize = 200;

/// Revisions are unique across documents, so that what is cached for one revision (a traced
/// frame, the methods that apply) is never taken for another document's scene.
static NEXT_REVISION: AtomicU64 = AtomicU64::new(1);

fn next_revision() -> u64 {
    NEXT_REVISION.fetch_add(1, Ordering::Relaxed)
}

/// One change of the scene, as the history names it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Edit {
    /// What the user did, for the status bar and the Edit menu ("move 2 vertices").
    pub label: String,
    /// Edits with the same key inside one gesture (a drag, a slider) coalesce into one step.
    pub coalesce: Option<String>,
}

impl Edit {
    /// A single step.
    #[must_use]
    pub fn new(label: impl Into<String>) -> Self {
        Self {
            label: label.into(),
            coalesce: None,
        }
    }

    /// A step that merges with the previous edit of the same key until the gesture ends.
    #[must_use]
    pub fn gesture(label: impl Into<String>, key: impl Into<String>) -> Self {
        Self {
            label: label.into(),
            coalesce: Some(key.into()),
        }
    }
}

struct Step {
    label: String,
    before: Scene,
}

/// The scene being edited.
pub struct Document {
    scene: Scene,
    path: Option<PathBuf>,
    saved: Scene,
    undo: Vec<Step>,
    redo: Vec<Step>,
    open_gesture: Option<String>,
    revision: u64,
    /// The current revision compiled, once asked for.
    compiled: OnceCell<Arc<Compiled>>,
}

impl Document {
    /// A document on `scene`, read from `path` if any.
    #[must_use]
    pub fn new(scene: Scene, path: Option<PathBuf>) -> Self {
        Self {
            saved: scene.clone(),
            scene,
            path,
            undo: Vec::new(),
            redo: Vec::new(),
            open_gesture: None,
            revision: next_revision(),
            compiled: OnceCell::new(),
        }
    }

    /// Opens a scene file.
    ///
    /// # Errors
    /// The loader's message: file, line:column and the offending value.
    pub fn open(path: &Path) -> Result<Self, String> {
        let scene = Scene::load(path).map_err(|e| e.to_string())?;
        Ok(Self::new(scene, Some(path.to_path_buf())))
    }

    /// The current scene.
    #[must_use]
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The current scene compiled: built on the first call after each change, shared after.
    #[must_use]
    pub fn compiled(&self) -> Arc<Compiled> {
        Arc::clone(self.compiled.get_or_init(|| compile(&self.scene)))
    }

    /// A new revision: the scene changed.
    fn changed(&mut self) {
        self.revision = next_revision();
        self.compiled = OnceCell::new();
    }

    /// The file the scene was read from or last saved to.
    #[must_use]
    pub fn path(&self) -> Option<&Path> {
        self.path.as_deref()
    }

    /// Changes with every change of the scene (edits, undo, redo) and differs between
    /// documents.
    #[must_use]
    pub fn revision(&self) -> u64 {
        self.revision
    }

    /// The scene differs from the file.
    #[must_use]
    pub fn is_dirty(&self) -> bool {
        self.scene != self.saved
    }

    /// Applies `change` to a copy of the scene and keeps it if the loader accepts it.
    ///
    /// # Errors
    /// Why the edited scene is invalid (for instance a radius slope a SCALIS kernel cannot
    /// take); the scene is then unchanged.
    pub fn apply(&mut self, edit: Edit, change: impl FnOnce(&mut Scene)) -> Result<(), String> {
        let mut next = self.scene.clone();
        change(&mut next);
        if next == self.scene {
            return Ok(());
        }
        next.validate()?;
        let merges = edit.coalesce.is_some() && edit.coalesce == self.open_gesture;
        if !merges {
            let before = std::mem::replace(&mut self.scene, next);
            self.undo.push(Step {
                label: edit.label,
                before,
            });
            if self.undo.len() > HISTORY {
                self.undo.remove(0);
            }
        } else {
            self.scene = next;
        }
        self.open_gesture = edit.coalesce;
        self.redo.clear();
        self.changed();
        Ok(())
    }

    /// Ends the current gesture: the next edit starts a new undo step.
    pub fn end_gesture(&mut self) {
        self.open_gesture = None;
    }

    /// Label of the step [`Document::undo`] would revert.
    #[must_use]
    pub fn undo_label(&self) -> Option<&str> {
        self.undo.last().map(|s| s.label.as_str())
    }

    /// Label of the step [`Document::redo`] would re-apply.
    #[must_use]
    pub fn redo_label(&self) -> Option<&str> {
        self.redo.last().map(|s| s.label.as_str())
    }

    /// Reverts the last step; false when there is none.
    pub fn undo(&mut self) -> bool {
        self.travel(true)
    }

    /// Re-applies the last undone step; false when there is none.
    pub fn redo(&mut self) -> bool {
        self.travel(false)
    }

    fn travel(&mut self, back: bool) -> bool {
        let (from, to) = if back {
            (&mut self.undo, &mut self.redo)
        } else {
            (&mut self.redo, &mut self.undo)
        };
        let Some(step) = from.pop() else {
            return false;
        };
        let current = std::mem::replace(&mut self.scene, step.before);
        to.push(Step {
            label: step.label,
            before: current,
        });
        self.open_gesture = None;
        self.changed();
        true
    }

    /// Saves atomically to `path`, which becomes the document's file.
    ///
    /// # Errors
    /// The file system's message, naming the file.
    pub fn save_as(&mut self, path: &Path) -> Result<(), String> {
        self.scene.save(path).map_err(|e| e.to_string())?;
        self.path = Some(path.to_path_buf());
        self.saved = self.scene.clone();
        Ok(())
    }

    /// Replaces the scene wholesale (restoring a recovery file): one undo step, dirty.
    pub fn replace(&mut self, scene: Scene, label: &str) {
        let before = std::mem::replace(&mut self.scene, scene);
        self.undo.push(Step {
            label: label.to_owned(),
            before,
        });
        self.redo.clear();
        self.open_gesture = None;
        self.changed();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> Scene {
        Scene::from_ron(crate::DEFAULT_SCENE, "creature").unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn a_gesture_is_one_undo_step_and_redo_restores_it() {
        let mut doc = Document::new(scene(), None);
        let start = doc.scene().clone();
        for i in 1..=5 {
            doc.apply(Edit::gesture("move", "drag"), |s| {
                s.groups[0].skeletons[0].vertices[0].position[0] += 0.01 * f64::from(i);
            })
            .unwrap_or_else(|e| panic!("{e}"));
        }
        doc.end_gesture();
        assert!(doc.is_dirty());
        let moved = doc.scene().clone();
        assert!(doc.undo());
        assert_eq!(doc.scene(), &start);
        assert!(!doc.undo(), "five drag updates are one step");
        assert!(doc.redo());
        assert_eq!(doc.scene(), &moved);
    }

    #[test]
    fn an_invalid_edit_is_refused_and_leaves_the_scene() {
        let mut doc = Document::new(scene(), None);
        let start = doc.scene().clone();
        let Err(err) = doc.apply(Edit::new("radius"), |s| {
            s.groups[0].skeletons[0].vertices[0].radius = -1.0;
        }) else {
            panic!("a negative radius must be refused");
        };
        assert!(err.contains("radius"), "{err}");
        assert!(err.contains("vertex 0"), "the error names the item: {err}");
        assert_eq!(doc.scene(), &start);
        assert!(doc.undo_label().is_none());
    }

    /// The compiled scene is built once per revision, however often it is asked for; an edit,
    /// an undo and a redo each make one new compile. (The counter is per process; the tests
    /// of this binary that compile run in their own threads, so only differences are read
    /// between calls made here, which no other test can interleave with: each compile here
    /// is checked through `Arc::ptr_eq` as well.)
    #[test]
    fn one_edit_compiles_once_and_reading_compiles_nothing() {
        let mut doc = Document::new(scene(), None);
        let first = doc.compiled();
        for _ in 0..10 {
            assert!(
                Arc::ptr_eq(&first, &doc.compiled()),
                "reading again compiles nothing"
            );
        }
        doc.apply(Edit::new("move"), |s| {
            s.groups[0].skeletons[0].vertices[0].position[0] += 0.1;
        })
        .unwrap_or_else(|e| panic!("{e}"));
        let edited = doc.compiled();
        assert!(!Arc::ptr_eq(&first, &edited), "an edit compiles anew");
        assert!(Arc::ptr_eq(&edited, &doc.compiled()));
        assert!(doc.undo());
        let undone = doc.compiled();
        assert!(!Arc::ptr_eq(&edited, &undone));
        assert_eq!(undone.program.primitives(), first.program.primitives());
    }

    /// Random editing sequences on generated scenes (moves, radius drags, deletes, duplicates,
    /// kernel, blend and field-type changes, new blobs — valid or not — undo and redo): no
    /// panic, a refused edit leaves the scene as it was, every kept scene validates, undoing to
    /// the start restores the generated scene exactly and redoing to the end the last one.
    #[test]
    fn random_editing_sequences_keep_valid_scenes_and_undo_redo_exactly() {
        use skeletrace_core::model::generate::{GenerateOptions, GeneratorKind, generate};
        use skeletrace_core::model::kernel::Kernel;
        use skeletrace_core::model::rng::SplitMix64;
        use skeletrace_core::model::scene::{Blend, Blob, SkeletonField};

        use crate::editor::selection::{self, Selection};

        let mut rng = SplitMix64::new(4242);
        let (mut kept, mut refused, mut travels) = (0, 0, 0);
        let sequences = 2000;
        for s in 0..sequences {
            let (kind, _) = GeneratorKind::ALL[s % GeneratorKind::ALL.len()];
            let size = match kind {
                GeneratorKind::Tree => 3,
                GeneratorKind::Truss | GeneratorKind::Foam => 2,
                _ => 6,
            };
            let options = GenerateOptions {
                seed: s as u64,
                size: Some(size),
                groups: (kind == GeneratorKind::Blobs).then_some(2),
                ..GenerateOptions::default()
            };
            let start = generate(kind, &options).unwrap_or_else(|e| panic!("{e}"));
            let mut doc = Document::new(start.clone(), None);
            for _ in 0..5 + rng.below(25) {
                let items = selection::all_items(doc.scene());
                let mut chosen = Selection::new();
                for _ in 0..1 + rng.below(3) {
                    if !items.is_empty() {
                        chosen.insert(items[rng.below(items.len())]);
                    }
                }
                let groups = doc.scene().groups.len();
                let g = rng.below(groups);
                let x = rng.range(-1.0, 1.0);
                let before = doc.scene().clone();
                let result = match rng.below(10) {
                    0 => doc.apply(Edit::new("move"), |sc| {
                        selection::translate(sc, &chosen, [x, 0.5 * x, -x]);
                    }),
                    1 => doc.apply(Edit::new("radius"), |sc| {
                        selection::scale_radius(sc, &chosen, 2.0_f64.powf(2.0 * x));
                    }),
                    2 => doc.apply(Edit::new("delete"), |sc| selection::delete(sc, &chosen)),
                    3 => doc.apply(Edit::new("duplicate"), |sc| {
                        selection::duplicate(sc, &chosen, [0.1, x, 0.0]);
                    }),
                    4 => {
                        let kernel = match rng.below(3) {
                            0 => Kernel::CompactPolynomial {
                                degree: 1 + rng.below(10) as u32,
                                scale: rng.range(0.5, 4.0),
                            },
                            1 => Kernel::Cauchy {
                                degree: rng.below(8) as u32,
                                scale: rng.range(-0.5, 3.0),
                            },
                            _ => Kernel::Gaussian {
                                scale: rng.range(0.1, 3.0),
                            },
                        };
                        doc.apply(Edit::new("kernel"), |sc| sc.groups[g].kernel = kernel)
                    }
                    5 => {
                        let leaf = |k: usize| Blend::Group(k as u32);
                        let blend = match rng.below(6) {
                            0 => None,
                            1 => Some(Blend::Max((0..groups).map(leaf).collect())),
                            2 => Some(Blend::Min((0..=groups).map(leaf).collect())),
                            3 => Some(Blend::Ricci {
                                p: rng.range(0.5, 4.0),
                                of: (0..groups).map(leaf).collect(),
                            }),
                            4 => Some(Blend::SmoothUnion {
                                width: x,
                                of: (0..groups).map(leaf).collect(),
                            }),
                            _ => Some(Blend::Difference(
                                Box::new(leaf(0)),
                                Box::new(leaf(groups - 1)),
                            )),
                        };
                        doc.apply(Edit::new("blend"), |sc| sc.blend = blend)
                    }
                    6 => doc.apply(Edit::new("field type"), |sc| {
                        for skeleton in &mut sc.groups[g].skeletons {
                            skeleton.field = match skeleton.field {
                                SkeletonField::Scalis => SkeletonField::Distance,
                                SkeletonField::Distance => SkeletonField::Scalis,
                            };
                        }
                    }),
                    7 => doc.apply(Edit::new("add blob"), |sc| {
                        sc.groups[g].blobs.push(Blob {
                            center: [x, x * x, 0.3],
                            radius: x,
                        });
                    }),
                    8 => {
                        travels += usize::from(doc.undo());
                        Ok(())
                    }
                    _ => {
                        travels += usize::from(doc.redo());
                        Ok(())
                    }
                };
                match result {
                    Ok(()) => kept += 1,
                    Err(_) => {
                        refused += 1;
                        assert_eq!(doc.scene(), &before, "a refused edit changed the scene");
                    }
                }
                if let Err(e) = doc.scene().validate() {
                    panic!("sequence {s}: a kept scene does not validate: {e}");
                }
            }
            while doc.redo() {}
            let end = doc.scene().clone();
            while doc.undo() {}
            assert_eq!(doc.scene(), &start, "sequence {s}: undo to the start");
            while doc.redo() {}
            assert_eq!(doc.scene(), &end, "sequence {s}: redo to the end");
        }
        eprintln!(
            "{sequences} sequences: {kept} operations kept, {refused} refused, {travels} undo/redo"
        );
        assert!(
            refused > 100 && kept > refused,
            "{kept} kept, {refused} refused"
        );
    }
}
