//! The comparison grid: one panel per method of `UiState::compare_methods`, each the whole
//! view at the viewport's aspect, on one shared step-count colour scale with its colour bar;
//! hovering a pixel shows every panel's step count there.

use eframe::egui;

use super::Editor;

impl Editor {
    pub(super) fn comparison(&mut self, ui: &mut egui::Ui) {
        let rect = ui.available_rect_before_wrap();
        let n = self.ui_state.compare_methods.len().max(1);
        let columns = n.min(crate::picture::COLUMNS);
        let rows = n.div_ceil(columns);
        let bar = 44.0;
        let label = 34.0;
        let cell_w = rect.width() / columns as f32;
        let cell_h = ((rect.height() - bar) / rows as f32 - label).max(16.0);
        let ppp = ui.ctx().pixels_per_point();
        // Heat maps trace every chosen method: half resolution keeps the grid responsive.
        let pixels = (
            ((cell_w * ppp) as usize / 2).max(8),
            ((cell_h * ppp) as usize / 2).max(8),
        );
        self.request_frames(ui.ctx(), pixels);
        let response = ui.allocate_rect(rect, egui::Sense::hover());
        let painter = ui.painter_at(rect);
        self.hovered_pixel = None;
        let Some(shown) = &self.frames.shown else {
            painter.text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                "tracing…",
                egui::FontId::proportional(16.0),
                egui::Color32::GRAY,
            );
            return;
        };
        let mut hover_lines = Vec::new();
        for (i, f) in shown.frames.iter().enumerate() {
            let x = rect.left() + (i % columns) as f32 * cell_w;
            let y = rect.top() + (i / columns) as f32 * (cell_h + label);
            let s = f.frame.step_summary();
            let backend = if f.on_gpu { "GPU" } else { "CPU" };
            painter.text(
                egui::pos2(x + 4.0, y + 2.0),
                egui::Align2::LEFT_TOP,
                format!("{} ({backend})", f.method),
                egui::FontId::proportional(14.0),
                egui::Color32::WHITE,
            );
            painter.text(
                egui::pos2(x + 4.0, y + 18.0),
                egui::Align2::LEFT_TOP,
                format!("avg {:.2}  median {}  max {}", s.average, s.median, s.max),
                egui::FontId::monospace(11.0),
                egui::Color32::LIGHT_GRAY,
            );
            let image_rect = fit_rect(
                egui::Rect::from_min_size(
                    egui::pos2(x, y + label),
                    egui::vec2(cell_w - 4.0, cell_h),
                ),
                f.frame.width as f32 / f.frame.height.max(1) as f32,
            );
            painter.image(
                f.texture.id(),
                image_rect,
                egui::Rect::from_min_max(egui::Pos2::ZERO, egui::pos2(1.0, 1.0)),
                egui::Color32::WHITE,
            );
            if let Some(p) = response.hover_pos().filter(|p| image_rect.contains(*p)) {
                let u = ((p.x - image_rect.left()) / image_rect.width() * f.frame.width as f32)
                    as usize;
                let v = ((p.y - image_rect.top()) / image_rect.height() * f.frame.height as f32)
                    as usize;
                self.hovered_pixel = Some((u, v));
            }
        }
        if let Some((u, v)) = self.hovered_pixel {
            for f in &shown.frames {
                let i = v.min(f.frame.height - 1) * f.frame.width + u.min(f.frame.width - 1);
                hover_lines.push(format!("{}: {} steps", f.method, f.frame.steps[i]));
            }
        }
        // Colour bar with the shared scale.
        let bar_rect = egui::Rect::from_min_size(
            egui::pos2(rect.left() + 8.0, rect.bottom() - bar + 6.0),
            egui::vec2(rect.width() - 16.0, 14.0),
        );
        let segments = 64;
        for k in 0..segments {
            let t = k as f64 / f64::from(segments - 1);
            let [r, g, b] = skeletrace_core::frame::heat_colour(t);
            let byte = |c: f32| (c * 255.0 + 0.5) as u8;
            let w = bar_rect.width() / segments as f32;
            painter.rect_filled(
                egui::Rect::from_min_size(
                    egui::pos2(bar_rect.left() + k as f32 * w, bar_rect.top()),
                    egui::vec2(w + 0.5, bar_rect.height()),
                ),
                0.0,
                egui::Color32::from_rgb(byte(r), byte(g), byte(b)),
            );
        }
        let clipped = shown
            .frames
            .iter()
            .any(|f| f.frame.step_summary().max > shown.steps_max);
        painter.text(
            egui::pos2(bar_rect.left(), bar_rect.bottom() + 2.0),
            egui::Align2::LEFT_TOP,
            "0 steps (log scale)",
            egui::FontId::proportional(12.0),
            egui::Color32::LIGHT_GRAY,
        );
        painter.text(
            egui::pos2(bar_rect.right(), bar_rect.bottom() + 2.0),
            egui::Align2::RIGHT_TOP,
            format!(
                "{}{} steps",
                if clipped { ">=" } else { "" },
                shown.steps_max
            ),
            egui::FontId::proportional(12.0),
            egui::Color32::LIGHT_GRAY,
        );
        if !hover_lines.is_empty() {
            response.on_hover_text(hover_lines.join("\n"));
        }
    }
}

/// The largest rectangle of aspect `aspect` centred in `outer`.
fn fit_rect(outer: egui::Rect, aspect: f32) -> egui::Rect {
    let (w, h) = (outer.width(), outer.height());
    let size = if w / h.max(1.0) > aspect {
        egui::vec2(h * aspect, h)
    } else {
        egui::vec2(w, w / aspect.max(1e-3))
    };
    egui::Rect::from_center_size(outer.center(), size)
}
