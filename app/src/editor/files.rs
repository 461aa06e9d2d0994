//! Files ("Files and export"): New / Open / Save / Save As, screenshots and mesh
//! export through the system file dialog — rfd: the xdg desktop portal, zenity as its fallback —
//! and the File panel's path field when no dialog can be shown; recent and dropped files; the
//! prompt before unsaved changes are replaced or closed; autosave and recovery.
//!
//! A dialog blocks its thread until the user answers, so it runs on a thread of its own and the
//! editor polls for the answer every frame ([`Editor::poll_file_dialog`]).

use std::path::{Path, PathBuf};
use std::sync::{Arc, mpsc};
use std::time::{Duration, Instant};

use eframe::egui;
use skeletrace_core::Scene;

use super::{AUTOSAVE_SECONDS, Document, Editor, OrbitCamera};

/// What a file dialog is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilePurpose {
    /// Open a scene.
    Open,
    /// Save the scene under a new name.
    SaveAs,
    /// Write a screenshot PNG.
    Screenshot,
    /// Write the mesh as binary glTF.
    ExportMesh,
}

impl FilePurpose {
    /// The dialog's title.
    #[must_use]
    pub fn title(self) -> &'static str {
        match self {
            Self::Open => "Open scene",
            Self::SaveAs => "Save scene as",
            Self::Screenshot => "Save screenshot",
            Self::ExportMesh => "Export mesh",
        }
    }

    /// The file type offered: its name and extension.
    #[must_use]
    pub fn file_type(self) -> (&'static str, &'static str) {
        match self {
            Self::Open | Self::SaveAs => ("skeletrace scene", "ron"),
            Self::Screenshot => ("PNG image", "png"),
            Self::ExportMesh => ("binary glTF", "glb"),
        }
    }

    /// Whether the dialog names a file to write (a save dialog) rather than one to read.
    #[must_use]
    pub fn writes(self) -> bool {
        self != Self::Open
    }
}

/// One dialog to show.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DialogRequest {
    /// What the file is for.
    pub purpose: FilePurpose,
    /// The folder the dialog starts in.
    pub directory: Option<PathBuf>,
    /// The proposed file name (save dialogs).
    pub file_name: String,
}

/// A source of file dialogs: the system's ([`SystemFileDialogs`]) or, in tests, a scripted one.
pub trait FileDialogs: Send + Sync {
    /// Why no dialog can be shown here, or `None` when one can.
    fn unavailable(&self) -> Option<String>;

    /// Shows a dialog for `request` and blocks until the user answers.
    ///
    /// # Errors
    /// The dialog could not be shown; the reason is the message for the user.
    fn pick(&self, request: &DialogRequest) -> Result<Option<PathBuf>, String>;
}

/// An answer of "no file" sooner than this after the dialog was asked for never reached the
/// user: rfd answers `None` both for a cancelled dialog and for one it could not show.
const UNSHOWN_DIALOG: Duration = Duration::from_millis(300);

/// The system's file dialogs, through rfd.
pub struct SystemFileDialogs;

impl FileDialogs for SystemFileDialogs {
    fn unavailable(&self) -> Option<String> {
        dialog_missing(|key| std::env::var_os(key), Path::exists)
    }

    fn pick(&self, request: &DialogRequest) -> Result<Option<PathBuf>, String> {
        let (kind, extension) = request.purpose.file_type();
        let mut dialog = rfd::FileDialog::new()
            .set_title(request.purpose.title())
            .add_filter(kind, &[extension]);
        if request.purpose == FilePurpose::Open {
            dialog = dialog.add_filter("SWC morphology (imported)", &["swc"]);
        }
        if request.purpose == FilePurpose::ExportMesh {
            dialog = dialog
                .add_filter("glTF with a separate buffer", &["gltf"])
                .add_filter("binary STL", &["stl"])
                .add_filter("Wavefront OBJ (with a .mtl)", &["obj"])
                .add_filter("binary PLY", &["ply"])
                .add_filter("3MF (printers)", &["3mf"]);
        }
        if let Some(dir) = &request.directory {
            dialog = dialog.set_directory(dir);
        }
        let asked = Instant::now();
        let answer = if request.purpose.writes() {
            dialog.set_file_name(&request.file_name).save_file()
        } else {
            dialog.pick_file()
        };
        if answer.is_none() && asked.elapsed() < UNSHOWN_DIALOG {
            return Err(
                "the system file dialog did not open (no xdg desktop portal answered, no zenity)"
                    .into(),
            );
        }
        Ok(answer)
    }
}

/// Why rfd can show no dialog, from the environment (`env`) and the file system (`exists`):
/// it needs an xdg desktop portal on the session bus, or the `zenity` program.
fn dialog_missing(
    env: impl Fn(&str) -> Option<std::ffi::OsString>,
    exists: impl Fn(&Path) -> bool,
) -> Option<String> {
    let bus = match env("DBUS_SESSION_BUS_ADDRESS") {
        Some(address) => address.to_string_lossy().split(';').any(|entry| {
            entry.strip_prefix("unix:").is_some_and(|params| {
                params.split(',').any(|param| {
                    param.starts_with("abstract=")
                        || param
                            .strip_prefix("path=")
                            .is_some_and(|p| exists(Path::new(p)))
                })
            })
        }),
        None => env("XDG_RUNTIME_DIR").is_some_and(|dir| exists(&PathBuf::from(dir).join("bus"))),
    };
    let data_dirs = env("XDG_DATA_DIRS")
        .filter(|d| !d.is_empty())
        .unwrap_or_else(|| "/usr/local/share:/usr/share".into());
    let portal = std::env::split_paths(&data_dirs)
        .any(|dir| exists(&dir.join("dbus-1/services/org.freedesktop.portal.Desktop.service")));
    let zenity = env("PATH")
        .is_some_and(|path| std::env::split_paths(&path).any(|dir| exists(&dir.join("zenity"))));
    if (bus && portal) || zenity {
        None
    } else if bus {
        Some("no file dialog: no xdg desktop portal is installed and zenity is missing".into())
    } else {
        Some(
            "no file dialog: no session bus for the xdg desktop portal and zenity is missing"
                .into(),
        )
    }
}

/// Files, dialogs, recovery and autosave: what the editor keeps about the files it reads and
/// writes.
pub(super) struct FileState {
    /// A recovery file found at start, offered for restore.
    pub recovery_offer: Option<Scene>,
    /// Where autosaves go (none in tests).
    pub recovery_path: Option<PathBuf>,
    /// The File panel's path field.
    pub path_field: String,
    /// Give the path field the keyboard on the next frame (no file dialog could be shown).
    pub focus_path_field: bool,
    pub file_dialogs: Arc<dyn FileDialogs>,
    pub pending_dialog: Option<PendingDialog>,
    /// Why the system dialog failed to show, once it has: later requests use the path field.
    pub dialog_failure: Option<String>,
    /// Screenshots and meshes being written on threads of their own.
    pub background_writes: Vec<BackgroundWrite>,
    /// The title last sent to the window.
    pub window_title: Option<String>,
    pub last_interaction: Instant,
    pub last_autosave: Instant,
    /// The document revision the recovery file holds.
    pub autosaved_revision: Option<u64>,
}

impl FileState {
    /// The state of an editor started with `recovery_offer` found at `recovery_path`, and
    /// `path_field` in the File panel.
    pub fn new(
        recovery_offer: Option<Scene>,
        recovery_path: Option<PathBuf>,
        path_field: String,
    ) -> Self {
        Self {
            recovery_offer,
            recovery_path,
            path_field,
            focus_path_field: false,
            file_dialogs: Arc::new(SystemFileDialogs),
            pending_dialog: None,
            dialog_failure: None,
            background_writes: Vec::new(),
            window_title: None,
            last_interaction: Instant::now(),
            last_autosave: Instant::now(),
            autosaved_revision: None,
        }
    }
}

/// A dialog shown on its own thread.
pub(super) struct PendingDialog {
    purpose: FilePurpose,
    answer: mpsc::Receiver<Result<Option<PathBuf>, String>>,
}

/// A file written on a thread of its own (a screenshot, a mesh); its message when done.
pub(super) struct BackgroundWrite {
    what: String,
    done: mpsc::Receiver<Result<String, String>>,
}

/// What replaces the document once unsaved changes are dealt with.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) enum Replacement {
    /// A new scene from a template.
    New(super::Template),
    /// A scene file.
    Open(PathBuf),
}

impl Editor {
    /// Uses `dialogs` for file dialogs instead of the system's (tests script them).
    #[must_use]
    pub fn with_file_dialogs(mut self, dialogs: Arc<dyn FileDialogs>) -> Self {
        self.files.file_dialogs = dialogs;
        self
    }

    /// Asks for a file for `purpose`: a system dialog on its own thread, or, when none can be
    /// shown, the path field (scenes) or the default path beside the scene (screenshots, meshes).
    pub(super) fn ask_for_file(&mut self, ctx: &egui::Context, purpose: FilePurpose) {
        if self.files.pending_dialog.is_some() {
            self.complain("a file dialog is already open");
            return;
        }
        if let Some(reason) = self
            .files
            .dialog_failure
            .clone()
            .or_else(|| self.files.file_dialogs.unavailable())
        {
            self.without_dialog(ctx, purpose, &reason);
            return;
        }
        let request = self.dialog_request(purpose);
        let dialogs = Arc::clone(&self.files.file_dialogs);
        match answer_on_thread(ctx, "file dialog", move || dialogs.pick(&request)) {
            Ok(answer) => self.files.pending_dialog = Some(PendingDialog { purpose, answer }),
            Err(why) => self.without_dialog(ctx, purpose, &format!("no file dialog thread: {why}")),
        }
    }

    /// Whether a file dialog is waiting for the user.
    #[must_use]
    pub fn file_dialog_open(&self) -> bool {
        self.files.pending_dialog.is_some()
    }

    /// Takes the answer of the open dialog, if it has come.
    pub(super) fn poll_file_dialog(&mut self, ctx: &egui::Context) {
        let Some(pending) = &self.files.pending_dialog else {
            return;
        };
        let purpose = pending.purpose;
        let answer = match pending.answer.try_recv() {
            Ok(answer) => answer,
            Err(mpsc::TryRecvError::Empty) => return,
            Err(mpsc::TryRecvError::Disconnected) => {
                Err("the file dialog thread stopped without an answer".into())
            }
        };
        self.files.pending_dialog = None;
        match answer {
            Ok(Some(path)) => self.use_file(ctx, purpose, with_extension(path, purpose)),
            Ok(None) => {}
            Err(reason) => {
                self.files.dialog_failure = Some(reason.clone());
                self.without_dialog(ctx, purpose, &reason);
            }
        }
    }

    /// Runs `write` (a screenshot, a mesh export: seconds at large sizes) on a thread of its
    /// own; its message or error goes to the status bar when it is done.
    pub(super) fn write_in_background(
        &mut self,
        ctx: &egui::Context,
        what: String,
        write: impl FnOnce() -> Result<String, String> + Send + 'static,
    ) {
        match answer_on_thread(ctx, "file writer", write) {
            Ok(done) => {
                self.tell(format!("writing {what}…"));
                self.files
                    .background_writes
                    .push(BackgroundWrite { what, done });
            }
            Err(why) => self.complain(format!("cannot write {what}: {why}")),
        }
    }

    /// How many screenshots and meshes are still being written.
    #[must_use]
    pub fn background_writes(&self) -> usize {
        self.files.background_writes.len()
    }

    /// Reports the writes that have finished.
    pub(super) fn poll_background_writes(&mut self) {
        let mut finished = Vec::new();
        self.files
            .background_writes
            .retain(|write| match write.done.try_recv() {
                Ok(result) => {
                    finished.push(result);
                    false
                }
                Err(mpsc::TryRecvError::Empty) => true,
                Err(mpsc::TryRecvError::Disconnected) => {
                    finished.push(Err(format!("writing {} stopped", write.what)));
                    false
                }
            });
        for result in finished {
            match result {
                Ok(message) => self.tell(message),
                Err(why) => self.complain(why),
            }
        }
    }

    fn dialog_request(&self, purpose: FilePurpose) -> DialogRequest {
        let default = self.default_output(purpose);
        let directory = match purpose {
            FilePurpose::Open | FilePurpose::SaveAs => self
                .doc
                .path()
                .or_else(|| self.ui_state.recent.first().map(PathBuf::as_path))
                .and_then(Path::parent)
                .map(Path::to_path_buf),
            FilePurpose::Screenshot | FilePurpose::ExportMesh => {
                default.parent().map(Path::to_path_buf)
            }
        };
        DialogRequest {
            purpose,
            directory,
            file_name: default
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
        }
    }

    /// Where a file for `purpose` goes when nobody names one: beside the scene, named after it.
    pub(super) fn default_output(&self, purpose: FilePurpose) -> PathBuf {
        let stem = self.doc.path().and_then(|p| p.file_stem()).map_or_else(
            || "skeletrace".to_owned(),
            |s| s.to_string_lossy().into_owned(),
        );
        let name = match purpose {
            FilePurpose::Open | FilePurpose::SaveAs => format!("{stem}.ron"),
            FilePurpose::Screenshot => format!("{stem}-{}.png", self.ui_state.view.file_suffix()),
            FilePurpose::ExportMesh => format!("{stem}.glb"),
        };
        let dir = self
            .doc
            .path()
            .and_then(Path::parent)
            .map_or_else(|| PathBuf::from("."), Path::to_path_buf);
        dir.join(name)
    }

    fn use_file(&mut self, ctx: &egui::Context, purpose: FilePurpose, path: PathBuf) {
        match purpose {
            FilePurpose::Open => self.replace_document(Replacement::Open(path)),
            FilePurpose::SaveAs => {
                self.save(Some(path));
            }
            FilePurpose::Screenshot => self.screenshot(ctx, path),
            FilePurpose::ExportMesh => self.export_mesh(ctx, path),
        }
    }

    fn without_dialog(&mut self, ctx: &egui::Context, purpose: FilePurpose, reason: &str) {
        match purpose {
            FilePurpose::Open | FilePurpose::SaveAs => {
                let button = if purpose == FilePurpose::Open {
                    "Open"
                } else {
                    "Save As"
                };
                self.files.focus_path_field = true;
                self.complain(format!(
                    "{reason}: type the path in the File panel, then {button}"
                ));
            }
            FilePurpose::Screenshot | FilePurpose::ExportMesh => {
                let path = self.default_output(purpose);
                self.use_file(ctx, purpose, path);
            }
        }
    }

    /// Replaces the document, first asking what to do with unsaved changes.
    pub(super) fn replace_document(&mut self, replacement: Replacement) {
        if self.doc.is_dirty() {
            self.prompts.replace_prompt = Some(replacement);
        } else {
            self.carry_out(replacement);
        }
    }

    fn carry_out(&mut self, replacement: Replacement) {
        match replacement {
            Replacement::New(template) => self.load_new_scene(template),
            Replacement::Open(path) => self.load_path(&path),
        }
    }

    /// Saves to the document's file, or asks for one when it has none.
    pub(super) fn save_or_ask(&mut self, ctx: &egui::Context) {
        if self.doc.path().is_some() {
            self.save(None);
        } else {
            self.ask_for_file(ctx, FilePurpose::SaveAs);
        }
    }

    /// The prompt before unsaved changes are replaced by New, Open, a recent or a dropped file.
    pub(super) fn replace_dialog(&mut self, ctx: &egui::Context) {
        let Some(replacement) = self.prompts.replace_prompt.clone() else {
            return;
        };
        let what = match &replacement {
            Replacement::New(template) => {
                format!("starting a new scene ({})", template.label().to_lowercase())
            }
            Replacement::Open(path) => format!("opening {}", path.display()),
        };
        let named = self.doc.path().map(Path::to_path_buf);
        egui::Modal::new(egui::Id::unique("replace")).show(ctx, |ui| {
            ui.heading("Unsaved changes");
            match &named {
                Some(path) => ui.label(format!(
                    "Save the changes to {} before {what}?",
                    path.display()
                )),
                None => ui.label(format!(
                    "This scene has no file yet. Discard it before {what}, or keep editing and \
                     Save As first?"
                )),
            };
            ui.horizontal(|ui| {
                if named.is_some() && ui.button("Save").clicked() {
                    self.prompts.replace_prompt = None;
                    if self.save(None) {
                        self.carry_out(replacement.clone());
                    }
                }
                if ui.button("Discard").clicked() {
                    self.prompts.replace_prompt = None;
                    self.carry_out(replacement.clone());
                }
                if ui.button("Keep editing").clicked() {
                    self.prompts.replace_prompt = None;
                }
            });
        });
    }

    /// Loads `path` into the editor, replacing the document (callers guard unsaved changes).
    /// An SWC morphology is imported as a new, unsaved scene.
    pub(super) fn load_path(&mut self, path: &Path) {
        if crate::import::is_swc(path) {
            match crate::import::swc_scene(path) {
                Ok((scene, moved)) => {
                    self.orbit = OrbitCamera::from_camera(&scene.camera);
                    let c = scene.counts();
                    self.doc = Document::new(scene, None);
                    self.selection.clear();
                    self.active_group = 0;
                    self.files.path_field.clear();
                    self.tell(format!(
                        "imported {}: {} groups, {} skeletons, {} vertices, {moved} radii brought within the kernel's slope limit (Save As to keep it as a scene)",
                        path.display(),
                        c.groups,
                        c.skeletons,
                        c.vertices
                    ));
                }
                Err(why) => self.complain(why),
            }
            return;
        }
        match Document::open(path) {
            Ok(doc) => {
                self.orbit = OrbitCamera::from_camera(&doc.scene().camera);
                self.doc = doc;
                self.selection.clear();
                self.active_group = 0;
                self.files.path_field = path.display().to_string();
                self.remember(path);
                self.tell(format!("opened {}", path.display()));
            }
            Err(why) => self.complain(why),
        }
    }

    fn load_new_scene(&mut self, template: super::Template) {
        let scene = template.scene();
        self.orbit = OrbitCamera::from_camera(&scene.camera);
        self.doc = Document::new(scene, None);
        self.selection.clear();
        self.active_group = 0;
        self.files.path_field.clear();
        // An empty scene has nothing to select: sketching starts where the user clicks, on the
        // plane through the view's focus.
        let empty = self.doc.scene().counts().vertices + self.doc.scene().counts().blobs == 0;
        self.view.sketch = empty;
        self.tell(if empty {
            format!(
                "new scene: {} — sketch mode: click to place the first vertex",
                template.label().to_lowercase()
            )
        } else {
            format!("new scene: {}", template.label().to_lowercase())
        });
    }

    /// Saves to `path` (the path field when `None` is given and the document has no file).
    pub(super) fn save(&mut self, path: Option<PathBuf>) -> bool {
        let target = path
            .or_else(|| self.doc.path().map(Path::to_path_buf))
            .or_else(|| {
                let typed = self.files.path_field.trim();
                (!typed.is_empty()).then(|| PathBuf::from(typed))
            });
        let Some(target) = target else {
            self.complain("type a file name in the path field, then Save As");
            return false;
        };
        match self.doc.save_as(&target) {
            Ok(()) => {
                self.files.path_field = target.display().to_string();
                self.remember(&target);
                if let Some(p) = &self.files.recovery_path {
                    let _ = std::fs::remove_file(p);
                }
                self.tell(format!("saved {}", target.display()));
                true
            }
            Err(why) => {
                self.complain(why);
                false
            }
        }
    }

    fn remember(&mut self, path: &Path) {
        let path = path.to_path_buf();
        self.ui_state.recent.retain(|p| *p != path);
        self.ui_state.recent.insert(0, path);
        self.ui_state.recent.truncate(8);
    }

    pub(super) fn handle_dropped_files(&mut self, ctx: &egui::Context) {
        let dropped: Vec<PathBuf> = ctx.input(|i| {
            i.raw
                .dropped_files
                .iter()
                .map(|f| f.path().to_path_buf())
                .collect()
        });
        if let Some(path) = dropped
            .iter()
            .find(|p| p.extension().is_some_and(|e| e == "ron") || crate::import::is_swc(p))
        {
            self.replace_document(Replacement::Open(path.clone()));
        } else if !dropped.is_empty() {
            self.complain("only .ron scene files and .swc morphologies can be dropped here");
        }
    }

    /// Writes the recovery file when the document changed since the last one was written and
    /// the autosave period has passed; before that, asks egui to wake up when it will have, so
    /// that an edit followed by no input at all is still saved within the period.
    pub(super) fn autosave(&mut self, ctx: &egui::Context) {
        let Some(path) = self.files.recovery_path.clone() else {
            return;
        };
        let revision = self.doc.revision();
        if !self.doc.is_dirty()
            || self.files.recovery_offer.is_some()
            || self.files.autosaved_revision == Some(revision)
        {
            return;
        }
        let period = Duration::from_secs(AUTOSAVE_SECONDS);
        let waited = self.files.last_autosave.elapsed();
        if waited < period {
            ctx.request_repaint_after(period - waited);
            return;
        }
        self.files.last_autosave = Instant::now();
        if let Some(dir) = path.parent() {
            let _ = std::fs::create_dir_all(dir);
        }
        let origin = self.doc.path().map_or_else(
            || "an unsaved scene".to_owned(),
            |p| p.display().to_string(),
        );
        match self
            .doc
            .scene()
            .save_with_comment(&path, &format!("skeletrace recovery of {origin}"))
        {
            Ok(()) => self.files.autosaved_revision = Some(revision),
            Err(why) => self.complain(format!("autosave failed: {why}")),
        }
    }

    /// A clean exit: the recovery file is no longer needed.
    /// Screenshots and meshes still being written are finished first.
    pub fn on_exit(&mut self) {
        for write in self.files.background_writes.drain(..) {
            let _ = write.done.recv();
        }
        if let Some(p) = &self.files.recovery_path {
            let _ = std::fs::remove_file(p);
        }
    }

    pub(super) fn handle_close(&mut self, ctx: &egui::Context) {
        if ctx.input(|i| i.viewport().close_requested())
            && !self.prompts.allow_close
            && self.doc.is_dirty()
        {
            ctx.send_viewport_cmd(egui::ViewportCommand::CancelClose);
            self.prompts.close_prompt = true;
        }
    }
}

/// Runs `work` on a thread named `name`; its result arrives on the returned channel, and the UI
/// is woken to take it.
fn answer_on_thread<T: Send + 'static>(
    ctx: &egui::Context,
    name: &str,
    work: impl FnOnce() -> T + Send + 'static,
) -> std::io::Result<mpsc::Receiver<T>> {
    let (send, answer) = mpsc::channel();
    let repaint = ctx.clone();
    std::thread::Builder::new()
        .name(name.to_owned())
        .spawn(move || {
            let _ = send.send(work());
            repaint.request_repaint();
        })?;
    Ok(answer)
}

/// `path` with the purpose's extension when the user typed none.
fn with_extension(path: PathBuf, purpose: FilePurpose) -> PathBuf {
    if purpose.writes() && path.extension().is_none() {
        path.with_extension(purpose.file_type().1)
    } else {
        path
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;
    use std::ffi::OsString;

    use skeletrace_core::Scene;

    use crate::editor::Edit;

    fn missing(vars: &[(&str, &str)], files: &[&str]) -> Option<String> {
        let files: HashSet<PathBuf> = files.iter().map(PathBuf::from).collect();
        dialog_missing(
            |key| {
                vars.iter()
                    .find(|(k, _)| *k == key)
                    .map(|(_, v)| OsString::from(v))
            },
            |p| files.contains(p),
        )
    }

    const SERVICE: &str = "/usr/share/dbus-1/services/org.freedesktop.portal.Desktop.service";

    #[test]
    fn a_dialog_needs_a_portal_on_a_session_bus_or_zenity() {
        let bus = [("DBUS_SESSION_BUS_ADDRESS", "unix:path=/run/user/1/bus")];
        assert_eq!(missing(&bus, &["/run/user/1/bus", SERVICE]), None);
        let abstract_bus = [(
            "DBUS_SESSION_BUS_ADDRESS",
            "unix:abstract=/tmp/dbus-x,guid=1",
        )];
        assert_eq!(missing(&abstract_bus, &[SERVICE]), None);
        let runtime = [("XDG_RUNTIME_DIR", "/run/user/1")];
        assert_eq!(missing(&runtime, &["/run/user/1/bus", SERVICE]), None);
        let zenity = [("PATH", "/bin:/usr/bin")];
        assert_eq!(missing(&zenity, &["/usr/bin/zenity"]), None);

        // A bus whose socket is gone, a bus without the portal, nothing at all.
        assert!(missing(&bus, &[SERVICE]).is_some_and(|m| m.contains("no session bus")));
        assert!(
            missing(&bus, &["/run/user/1/bus"])
                .is_some_and(|m| m.contains("no xdg desktop portal"))
        );
        assert!(missing(&[("PATH", "/bin")], &[]).is_some_and(|m| m.contains("zenity")));
    }

    #[test]
    fn saved_files_get_their_purposes_extension_when_none_was_typed() {
        let scene = with_extension(PathBuf::from("/tmp/model"), FilePurpose::SaveAs);
        assert_eq!(scene, PathBuf::from("/tmp/model.ron"));
        let picture = with_extension(PathBuf::from("/tmp/model.v2.png"), FilePurpose::Screenshot);
        assert_eq!(picture, PathBuf::from("/tmp/model.v2.png"));
        let opened = with_extension(PathBuf::from("/tmp/README"), FilePurpose::Open);
        assert_eq!(opened, PathBuf::from("/tmp/README"));
    }

    /// A save that fails tells the user, keeps the document (still dirty, still editable), and
    /// the recovery file autosaved before it loads back as the edited scene.
    #[test]
    fn a_failed_save_is_reported_and_the_recovery_file_loads() {
        let dir = std::env::temp_dir().join(format!("skeletrace-crash-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
        let recovery = dir.join("recovery.ron");
        let doc = Document::new(super::super::default_scene(), None);
        let mut editor = Editor::new(
            doc,
            super::super::UiState::default(),
            Some(recovery.clone()),
            || {},
        );
        assert!(editor.apply(Edit::new("move"), |s| {
            s.groups[0].skeletons[0].vertices[0].position[1] += 0.25;
        }));
        let edited = editor.doc.scene().clone();
        editor.files.last_autosave = Instant::now() - Duration::from_secs(AUTOSAVE_SECONDS + 1);
        editor.autosave(&egui::Context::default());
        // The rename onto an existing directory fails after the text was written, even as root.
        let target = dir.join("taken.ron");
        std::fs::create_dir_all(target.join("inside")).unwrap_or_else(|e| panic!("{e}"));
        assert!(!editor.save(Some(target.clone())));
        let notice = editor.notice().unwrap_or_default().to_owned();
        assert!(
            editor.prompts.notice.as_ref().is_some_and(|n| n.error),
            "{notice}"
        );
        assert!(notice.contains("taken.ron"), "{notice}");
        assert!(
            editor.doc.is_dirty(),
            "the document still holds the unsaved edit"
        );
        assert_eq!(editor.doc.scene(), &edited);
        let restored = Scene::load(&recovery).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(restored, edited, "the recovery file holds the edited scene");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// An edit followed by no input at all: the editor asks egui to wake it when the autosave
    /// period ends (egui then runs a frame without any event), and that frame writes the
    /// recovery file; an unchanged document is not written again.
    #[test]
    fn an_edit_followed_by_idleness_is_autosaved() {
        let dir = std::env::temp_dir().join(format!("skeletrace-idle-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
        let recovery = dir.join("recovery.ron");
        let mut editor = Editor::new(
            Document::new(super::super::default_scene(), None),
            super::super::UiState::default(),
            Some(recovery.clone()),
            || {},
        );
        let ctx = egui::Context::default();
        let wake_up = std::sync::Arc::new(std::sync::Mutex::new(None));
        let heard = wake_up.clone();
        ctx.set_request_repaint_callback(move |info| {
            if let Ok(mut slot) = heard.lock() {
                *slot = Some(info.delay);
            }
        });
        assert!(editor.apply(Edit::new("move"), |s| {
            s.groups[0].skeletons[0].vertices[0].position[1] += 0.25;
        }));
        editor.files.last_autosave = Instant::now() - Duration::from_secs(AUTOSAVE_SECONDS - 2);
        editor.autosave(&ctx);
        assert!(!recovery.exists(), "written before the period ended");
        let delay = wake_up.lock().ok().and_then(|d| *d);
        assert!(
            delay.is_some_and(|d| d > Duration::from_secs(1) && d <= Duration::from_secs(2)),
            "no wake-up asked for the end of the period: {delay:?}"
        );
        // The frame egui runs at that time, without input.
        editor.files.last_autosave -= Duration::from_secs(2);
        editor.autosave(&ctx);
        let restored = Scene::load(&recovery).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(&restored, editor.doc.scene());
        // Nothing changed since: no new write, no new wake-up.
        std::fs::remove_file(&recovery).unwrap_or_else(|e| panic!("{e}"));
        editor.files.last_autosave -= Duration::from_secs(AUTOSAVE_SECONDS + 1);
        editor.autosave(&ctx);
        assert!(
            !recovery.exists(),
            "an unchanged document was written again"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
