//! The editor's mesh export: the File menu's resolution with what an export there will take
//! (`crate::export::estimate`, made once per edit), and the export itself on a thread of its
//! own with a progress window and Cancel; editing goes on meanwhile.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use eframe::egui;

use super::{Editor, FilePurpose};
use crate::export::{Estimate, RESOLUTIONS};

/// What the export part of the editor keeps between frames.
#[derive(Default)]
pub(super) struct MeshExport {
    /// The estimate, with the document revision and resolution it was made for.
    estimate: Option<(u64, usize, Result<Estimate, String>)>,
    /// The export running, if any.
    job: Option<ExportJob>,
}

/// An export on its thread: its file, its progress (sampling, in millionths), whether the user
/// cancelled it and whether it has finished.
struct ExportJob {
    path: PathBuf,
    progress: Arc<AtomicU32>,
    cancel: Arc<AtomicBool>,
    finished: Arc<AtomicBool>,
}

impl Editor {
    /// The File menu's export entry: the button, the resolution and the estimate.
    pub(super) fn export_menu_entry(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        ui.horizontal(|ui| {
            if ui
                .button("Export mesh…")
                .on_hover_text(
                    "a watertight mesh of the surface: glTF, STL, OBJ, PLY or 3MF by the \
                     file's extension",
                )
                .clicked()
            {
                self.ask_for_file(&ctx, FilePurpose::ExportMesh);
            }
            ui.add(
                egui::DragValue::new(&mut self.ui_state.export_resolution)
                    .range(RESOLUTIONS)
                    .suffix(" cells"),
            )
            .on_hover_text("grid cells along the longest side of the scene's support box");
        });
        let line = match self.mesh_estimate() {
            Ok(e) => format!(
                "about {} triangles, {:.0} MB",
                e.triangles,
                e.bytes as f64 / 1e6
            ),
            Err(why) => why,
        };
        ui.weak(line);
    }

    /// The estimate of an export of the document at the chosen resolution, made again only
    /// after an edit or a change of resolution (a coarse extraction: milliseconds).
    fn mesh_estimate(&mut self) -> Result<Estimate, String> {
        let key = (self.doc.revision(), self.ui_state.export_resolution);
        match &self.mesh_export.estimate {
            Some((revision, resolution, estimate)) if (*revision, *resolution) == key => {
                estimate.clone()
            }
            _ => {
                let estimate = crate::export::estimate(self.doc.scene(), key.1);
                self.mesh_export.estimate = Some((key.0, key.1, estimate.clone()));
                estimate
            }
        }
    }

    /// Writes the isosurface at the chosen resolution to `path` in the format its extension
    /// names, on a thread of its own; the progress window follows it.
    pub(super) fn export_mesh(&mut self, ctx: &egui::Context, path: PathBuf) {
        if self.mesh_export.job.is_some() {
            self.complain("a mesh is being exported: wait for it or cancel it first".to_owned());
            return;
        }
        let scene = self.doc.scene().clone();
        let resolution = self.ui_state.export_resolution;
        let job = ExportJob {
            path: path.clone(),
            progress: Arc::new(AtomicU32::new(0)),
            cancel: Arc::new(AtomicBool::new(false)),
            finished: Arc::new(AtomicBool::new(false)),
        };
        let (progress, cancel, finished) = (
            Arc::clone(&job.progress),
            Arc::clone(&job.cancel),
            Arc::clone(&job.finished),
        );
        let repaint = ctx.clone();
        let what = format!("mesh {}", path.display());
        self.write_in_background(ctx, what, move || {
            let report = |fraction: f64| {
                progress.store((fraction * 1e6) as u32, Ordering::Relaxed);
                repaint.request_repaint();
            };
            let written = crate::export::extract_cancellable(&scene, resolution, &report, &cancel)
                .and_then(|mesh| {
                    crate::export::write_mesh(&scene, &mesh, &path, &[])?;
                    Ok(format!(
                        "exported {} ({} triangles, {})",
                        path.display(),
                        mesh.report.triangles,
                        if mesh.report.watertight {
                            "watertight"
                        } else {
                            "not watertight"
                        }
                    ))
                })
                .map_err(|e| format!("mesh {}: {e}", path.display()));
            finished.store(true, Ordering::Relaxed);
            written
        });
        self.mesh_export.job = Some(job);
    }

    /// The export's progress window, with Cancel, while one runs.
    pub(super) fn export_progress_window(&mut self, ctx: &egui::Context) {
        let Some(job) = &self.mesh_export.job else {
            return;
        };
        if job.finished.load(Ordering::Relaxed) {
            self.mesh_export.job = None;
            return;
        }
        let fraction = job.progress.load(Ordering::Relaxed) as f32 / 1e6;
        let cancelled = job.cancel.load(Ordering::Relaxed);
        let mut cancel = false;
        egui::Window::new("Exporting mesh")
            .collapsible(false)
            .resizable(false)
            .show(ctx, |ui| {
                ui.label(job.path.display().to_string());
                ui.add(
                    egui::ProgressBar::new(fraction)
                        .show_percentage()
                        .text(if cancelled {
                            "cancelling".to_owned()
                        } else {
                            format!("sampling the field {:.0} %", 100.0 * fraction)
                        }),
                );
                cancel = ui
                    .add_enabled(!cancelled, egui::Button::new("Cancel export"))
                    .clicked();
            });
        if cancel {
            job.cancel.store(true, Ordering::Relaxed);
        }
        ctx.request_repaint_after(std::time::Duration::from_millis(100));
    }

    /// Sets the export's resolution (as the File menu's field does), within [`RESOLUTIONS`].
    pub fn set_export_resolution(&mut self, cells: usize) {
        self.ui_state.export_resolution = cells.clamp(*RESOLUTIONS.start(), *RESOLUTIONS.end());
    }

    /// Whether a mesh export is running.
    #[must_use]
    pub fn exporting_mesh(&self) -> bool {
        self.mesh_export.job.is_some()
    }
}
