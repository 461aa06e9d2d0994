//! The comparison grid: one panel per method of `UiState::compare_methods`, each the whole
//! view at the viewport's aspect, on one shared step-count colour scale with its colour bar;
//! hovering a pixel shows every panel's step count there, clicking it opens the ray inspector
//! on that pixel for every method of the grid. The heat maps come from the window's GPU where
//! it runs every method (`gpu_viewport.rs`: traced and coloured there, only the statistics read
//! back), else from the render thread's frames.

use eframe::egui;
use egui_plot::{Bar, BarChart, Plot};
use skeletrace_core::frame::{StepHistogram, StepScale, View};
use skeletrace_core::methods::MethodId;
use skeletrace_render::viewport::ViewportFrame;

use super::Editor;

/// What the grid knows of one panel.
struct PanelInfo {
    method: MethodId,
    on_gpu: bool,
    /// Its step counts' histogram, once known.
    histogram: Option<StepHistogram>,
    /// Its step count at the hovered pixel, once known.
    hovered_steps: Option<u32>,
    /// A frame below the grid's resolution or of an earlier request, while this method's
    /// frame is still being traced: how it stands.
    progress: Option<String>,
}

impl Editor {
    pub(super) fn comparison(&mut self, ui: &mut egui::Ui) {
        let rect = ui.available_rect_before_wrap();
        let bar = 44.0;
        // Every panel shows the whole view at the aspect the viewport has in this area.
        let area_h = (rect.height() - bar).max(16.0);
        let aspect = rect.width() / area_h;
        let ppp = ui.ctx().pixels_per_point();
        let methods = self.ui_state.compare_methods.clone();
        let layout = GridLayout::new(methods.len(), rect.width(), area_h, LABEL_HEIGHT, aspect);
        let full = (
            ((layout.panel_w * ppp) as u32).max(8),
            ((layout.panel_h * ppp) as u32).max(8),
        );
        let steps_view = View::Steps {
            steps_max: self.doc.compiled().settings.max_steps,
        };
        let (gpu_frame, compiling) = self.gpu_viewport_frame_or_compiling(steps_view, full);
        if gpu_frame.is_none() {
            // Heat maps trace every chosen method: half resolution keeps the grid responsive.
            self.request_frames(ui.ctx(), ((full.0 / 2) as usize, (full.1 / 2) as usize));
        }
        let response = ui.allocate_rect(rect, egui::Sense::click());
        let painter = ui.painter_at(rect);
        if let Some(frame) = compiling {
            self.keep_compiling(&painter, rect, frame);
        }
        let Some(GridPanels {
            size,
            mut infos,
            top,
        }) = self.panel_infos(&methods, gpu_frame.is_some(), full)
        else {
            painter.text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                "tracing…",
                egui::FontId::proportional(16.0),
                egui::Color32::GRAY,
            );
            return;
        };
        let (cells, panels) = panel_rects(rect, &layout, infos.len());
        self.view.hovered_pixel = response.hover_pos().and_then(|p| {
            let image = panels.iter().find(|r| r.contains(p))?;
            let u = (p.x - image.left()) / image.width() * size.0 as f32;
            let v = (p.y - image.top()) / image.height() * size.1 as f32;
            Some((
                (u as usize).min(size.0 as usize - 1),
                (v as usize).min(size.1 as usize - 1),
            ))
        });
        let top = match gpu_frame {
            Some(frame) => self.paint_gpu_panels(&painter, rect, frame, &panels, &mut infos),
            None => {
                self.paint_traced_panels(&painter, &panels, &mut infos);
                top
            }
        };
        for (i, (info, &cell)) in infos.iter().zip(&cells).enumerate() {
            panel_caption(ui, &painter, i, info, cell, layout.cell_w);
        }
        self.view.compare_layout = Some((
            egui::Rect::from_min_size(rect.min, egui::vec2(rect.width(), area_h)),
            panels,
        ));
        let hover_lines: Vec<String> = infos
            .iter()
            .filter_map(|i| Some(format!("{}: {} steps", i.method, i.hovered_steps?)))
            .collect();
        let inspect = self
            .view
            .hovered_pixel
            .filter(|_| response.clicked())
            .map(|pixel| {
                let methods: Vec<MethodId> = infos.iter().map(|i| i.method).collect();
                (pixel, (size.0 as usize, size.1 as usize), methods)
            });
        if let Some(top) = top {
            let clipped = infos
                .iter()
                .any(|i| i.histogram.as_ref().is_some_and(|h| h.summary().max > top));
            self.colour_bar(ui, &painter, rect, bar, (top, clipped));
        }
        if !hover_lines.is_empty() {
            response.on_hover_text(hover_lines.join("\n"));
        }
        if let Some((pixel, size, methods)) = inspect {
            self.inspect_ray(pixel, size, &methods);
        }
    }

    /// The panels' frame size, what is known of each panel, and the colour scale's top when
    /// the frames on screen give it: the GPU viewport's panels (statistics still to come), the
    /// render thread's last reply, or `None` before any frame.
    fn panel_infos(
        &self,
        methods: &[MethodId],
        on_gpu: bool,
        full: (u32, u32),
    ) -> Option<GridPanels> {
        if on_gpu {
            let infos = methods
                .iter()
                .map(|&method| PanelInfo {
                    method,
                    on_gpu: true,
                    histogram: None,
                    hovered_steps: None,
                    progress: None,
                })
                .collect();
            return Some(GridPanels {
                size: full,
                infos,
                top: None,
            });
        }
        let shown = if self.view.gpu_compiling {
            self.frames.shown_of(self.doc.revision())?
        } else {
            self.frames.shown.as_ref()?
        };
        // Panels may hold frames of different sizes (a slow method's preview beside the others'
        // full frames): the largest is the grid's.
        let size = shown
            .frames
            .iter()
            .map(|f| (f.frame.width as u32, f.frame.height as u32))
            .max_by_key(|&(w, h)| w * h)
            .unwrap_or((1, 1));
        let infos = shown
            .frames
            .iter()
            .map(|f| {
                let preview = (f.frame.width as u32) < size.0;
                let progress = match (f.earlier, preview) {
                    (false, false) => None,
                    (earlier, true) => Some(format!(
                        "preview 1/{}{}",
                        (size.0 as usize).div_ceil(f.frame.width.max(1)),
                        if earlier { ", refining…" } else { "" }
                    )),
                    (true, false) => Some("refining…".to_owned()),
                };
                PanelInfo {
                    method: f.method,
                    on_gpu: f.on_gpu,
                    histogram: Some(f.histogram.clone()),
                    hovered_steps: None,
                    progress,
                }
            })
            .collect();
        Some(GridPanels {
            size,
            infos,
            top: Some(shown.steps_max),
        })
    }

    /// Paints the GPU viewport's heat maps into `panels` and takes the statistics it read back
    /// (histograms, the hovered pixel's counts) into `infos`; returns the colour scale's top
    /// once they are there.
    fn paint_gpu_panels(
        &self,
        painter: &egui::Painter,
        area: egui::Rect,
        frame: ViewportFrame,
        panels: &[egui::Rect],
        infos: &mut [PanelInfo],
    ) -> Option<u32> {
        let probe = self.view.hovered_pixel.map(|(u, v)| (u as u32, v as u32));
        self.paint_gpu_viewport(
            painter,
            area,
            frame,
            panels.to_vec(),
            (self.ui_state.step_scale, probe),
        );
        let statistics = self.gpu_grid_statistics();
        if !statistics.as_ref().is_some_and(|(_, current)| *current) {
            // The statistics of this frame are on their way from the GPU.
            painter.ctx().request_repaint();
        }
        let (s, current) = statistics.filter(|(s, _)| s.histograms.len() == infos.len())?;
        for (k, info) in infos.iter_mut().enumerate() {
            info.histogram = Some(s.histograms[k].clone());
            if current && probe.is_some() {
                info.hovered_steps = s.probe_steps.get(k).copied();
            }
        }
        Some(s.top)
    }

    /// Paints the render thread's heat-map textures into `panels`, with the hovered pixel's
    /// counts into `infos`.
    fn paint_traced_panels(
        &self,
        painter: &egui::Painter,
        panels: &[egui::Rect],
        infos: &mut [PanelInfo],
    ) {
        if let (Some(shown), Some((u, v))) = (&self.frames.shown, self.view.hovered_pixel) {
            // The hovered pixel is in the largest frame's pixels: scaled to each frame's.
            let (w, h) = shown
                .frames
                .iter()
                .map(|f| (f.frame.width, f.frame.height))
                .max_by_key(|&(w, h)| w * h)
                .unwrap_or((1, 1));
            for (info, f) in infos.iter_mut().zip(&shown.frames) {
                let x = (u * f.frame.width / w.max(1)).min(f.frame.width.saturating_sub(1));
                let y = (v * f.frame.height / h.max(1)).min(f.frame.height.saturating_sub(1));
                info.hovered_steps = f.frame.steps.get(y * f.frame.width + x).copied();
            }
        }
        for (f, image_rect) in self.frames.shown.iter().flat_map(|s| &s.frames).zip(panels) {
            painter.image(
                f.texture.id(),
                *image_rect,
                egui::Rect::from_min_max(egui::Pos2::ZERO, egui::pos2(1.0, 1.0)),
                egui::Color32::WHITE,
            );
        }
    }

    /// The colour bar of the shared scale `[0, top]` along the bottom `bar` points of `rect`,
    /// with its ticks and caption; `clipped` when some pixel took more than `top` steps.
    fn colour_bar(
        &self,
        ui: &mut egui::Ui,
        painter: &egui::Painter,
        rect: egui::Rect,
        bar: f32,
        (top, clipped): (u32, bool),
    ) {
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
        let scale = self.ui_state.step_scale;
        for tick in scale_ticks(scale, top) {
            let x =
                bar_rect.left() + bar_rect.width() * scale.position(f64::from(tick), top) as f32;
            painter.line_segment(
                [
                    egui::pos2(x, bar_rect.bottom()),
                    egui::pos2(x, bar_rect.bottom() + 3.0),
                ],
                egui::Stroke::new(1.0, egui::Color32::LIGHT_GRAY),
            );
            let at_top = tick == top;
            painter.text(
                egui::pos2(x, bar_rect.bottom() + 3.0),
                if at_top {
                    egui::Align2::RIGHT_TOP
                } else {
                    egui::Align2::CENTER_TOP
                },
                if at_top && clipped {
                    format!(">={tick}")
                } else {
                    tick.to_string()
                },
                egui::FontId::proportional(11.0),
                egui::Color32::LIGHT_GRAY,
            );
        }
        let caption = match scale {
            StepScale::Log => "steps (log scale)",
            StepScale::Linear => "steps (linear scale)",
        };
        ui.put(
            egui::Rect::from_min_size(
                egui::pos2(bar_rect.center().x - 70.0, bar_rect.top() - 17.0),
                egui::vec2(140.0, 16.0),
            ),
            egui::Label::new(
                egui::RichText::new(caption)
                    .small()
                    .color(egui::Color32::WHITE),
            ),
        );
    }
}

/// Width of a panel's step histogram, in points.
const HISTOGRAM_WIDTH: f32 = 96.0;

/// Bins of the step histograms: 0 steps, then powers of two (1, 2–3, 4–7, …, 2048 and more).
const HISTOGRAM_BINS: usize = 13;

/// The histogram bin of a step count.
fn histogram_bin(steps: u32) -> usize {
    if steps == 0 {
        0
    } else {
        (steps.ilog2() as usize + 1).min(HISTOGRAM_BINS - 1)
    }
}

/// A panel's step histogram in `rect` (egui_plot): the share of pixels in each power-of-two bin
/// of step counts (square-root heights, so rare long marches stay visible), bars in the heat
/// colour of the bin's lower count; hovering a bar names its bin and share.
fn histogram_plot(
    ui: &mut egui::Ui,
    id: impl std::hash::Hash + std::fmt::Debug,
    rect: egui::Rect,
    histogram: &StepHistogram,
) {
    let mut counts = [0_u64; HISTOGRAM_BINS];
    for (steps, &n) in histogram.counts().iter().enumerate() {
        counts[histogram_bin(steps as u32)] += n;
    }
    let total = histogram.pixels().max(1) as f64;
    let bars: Vec<Bar> = counts
        .iter()
        .enumerate()
        .filter(|&(_, &count)| count > 0)
        .map(|(k, &count)| {
            let low = if k == 0 { 0 } else { 1_u32 << (k - 1) };
            let [r, g, b] = skeletrace_core::frame::heat_colour(
                StepScale::Log.position(f64::from(low), 1 << (HISTOGRAM_BINS - 2)),
            );
            let byte = |c: f32| (c * 255.0 + 0.5) as u8;
            let bin = match k {
                0 => "0 steps".to_owned(),
                _ if k == HISTOGRAM_BINS - 1 => format!("{low}+ steps"),
                _ => format!("{low}–{} steps", 2 * low - 1),
            };
            let share = count as f64 / total;
            Bar::new(k as f64, share.sqrt())
                .width(0.85)
                .fill(egui::Color32::from_rgb(byte(r), byte(g), byte(b)))
                .name(format!("{bin}: {:.1} %", 100.0 * share))
        })
        .collect();
    ui.put(rect, |ui: &mut egui::Ui| {
        Plot::new(id)
            .width(rect.width())
            .height(rect.height())
            .show_axes(false)
            .show_grid(false)
            .show_x(false)
            .show_y(false)
            .allow_drag(false)
            .allow_zoom(false)
            .allow_scroll(false)
            .allow_boxed_zoom(false)
            .include_x(-0.5)
            .include_x(HISTOGRAM_BINS as f64 - 0.5)
            .include_y(0.0)
            .include_y(1.0)
            .set_margin_fraction(egui::Vec2::ZERO)
            .show(ui, |plot| plot.bar_chart(BarChart::new("steps", bars)))
            .response
    });
}

/// Tick values of the colour bar: 0, then 1, 2, 5, 10, 20, 50, … (log) or quarters (linear), and
/// the top, leaving out those too close to the top to be read.
fn scale_ticks(scale: StepScale, top: u32) -> Vec<u32> {
    let top = top.max(1);
    let mut ticks: Vec<u32> = match scale {
        StepScale::Linear => (0..4).map(|k| top * k / 4).collect(),
        StepScale::Log => {
            let mut out = vec![0];
            let mut decade = 1_u32;
            while decade < top {
                for m in [1, 2, 5] {
                    let v = decade.saturating_mul(m);
                    if v < top {
                        out.push(v);
                    }
                }
                decade = decade.saturating_mul(10);
            }
            out
        }
    };
    let near_top = |v: u32| scale.position(f64::from(v), top) > 0.9;
    ticks.retain(|&v| !near_top(v));
    ticks.dedup();
    ticks.push(top);
    ticks
}

/// The comparison grid's arrangement: the number of columns that makes `n` panels of aspect
/// `aspect` (width over height, each with a label strip of `label` above it) largest in a
/// `width × height` area, and the panels' size.
#[derive(Clone, Copy, Debug, PartialEq)]
struct GridLayout {
    columns: usize,
    rows: usize,
    /// Width of a column.
    cell_w: f32,
    panel_w: f32,
    panel_h: f32,
}

impl GridLayout {
    fn new(n: usize, width: f32, height: f32, label: f32, aspect: f32) -> Self {
        let n = n.max(1);
        let aspect = aspect.max(1e-3);
        (1..=n)
            .map(|columns| {
                let rows = n.div_ceil(columns);
                let cell_w = width / columns as f32;
                let cell_h = (height / rows as f32 - label).max(1.0);
                let panel_w = (cell_w - 4.0).max(1.0).min(cell_h * aspect);
                Self {
                    columns,
                    rows,
                    cell_w,
                    panel_w,
                    panel_h: panel_w / aspect,
                }
            })
            .max_by(|a, b| a.panel_w.total_cmp(&b.panel_w))
            .unwrap_or(Self {
                columns: 1,
                rows: 1,
                cell_w: width,
                panel_w: width,
                panel_h: height,
            })
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

/// What the grid knows of its panels before drawing them.
struct GridPanels {
    /// Pixels of each panel's frame.
    size: (u32, u32),
    infos: Vec<PanelInfo>,
    /// The shared colour scale's top, once known.
    top: Option<u32>,
}

/// Height of a panel's caption strip, in points.
const LABEL_HEIGHT: f32 = 34.0;

/// Each of `n` panels' cell (the top left of its caption strip) and its image rectangle.
fn panel_rects(
    rect: egui::Rect,
    layout: &GridLayout,
    n: usize,
) -> (Vec<egui::Pos2>, Vec<egui::Rect>) {
    let cells: Vec<egui::Pos2> = (0..n)
        .map(|i| {
            egui::pos2(
                rect.left() + (i % layout.columns) as f32 * layout.cell_w,
                rect.top() + (i / layout.columns) as f32 * (layout.panel_h + LABEL_HEIGHT),
            )
        })
        .collect();
    let panels = cells
        .iter()
        .map(|&egui::Pos2 { x, y }| {
            fit_rect(
                egui::Rect::from_min_size(
                    egui::pos2(x, y + LABEL_HEIGHT),
                    egui::vec2(layout.cell_w - 4.0, layout.panel_h),
                ),
                // The panel keeps the grid's aspect whatever the resolution traced (a preview
                // rounds its size), so the layout does not move when the full frame arrives.
                layout.panel_w / layout.panel_h,
            )
        })
        .collect();
    (cells, panels)
}

/// Panel `i`'s caption at `cell`: the method and where it was traced, its step summary and
/// its step histogram.
fn panel_caption(
    ui: &mut egui::Ui,
    painter: &egui::Painter,
    index: usize,
    info: &PanelInfo,
    egui::Pos2 { x, y }: egui::Pos2,
    cell_w: f32,
) {
    let backend = if info.on_gpu { "GPU" } else { "CPU" };
    let progress = info
        .progress
        .as_ref()
        .map_or(String::new(), |p| format!(", {p}"));
    painter.text(
        egui::pos2(x + 4.0, y + 2.0),
        egui::Align2::LEFT_TOP,
        format!("{} ({backend}{progress})", info.method),
        egui::FontId::proportional(14.0),
        egui::Color32::WHITE,
    );
    let summary = info.histogram.as_ref().map_or_else(
        || "counting…".to_owned(),
        |h| {
            let s = h.summary();
            format!(
                "avg {:.2}  median {}  p95 {}  max {}",
                s.average, s.median, s.p95, s.max
            )
        },
    );
    painter.text(
        egui::pos2(x + 4.0, y + 18.0),
        egui::Align2::LEFT_TOP,
        summary,
        egui::FontId::monospace(11.0),
        egui::Color32::LIGHT_GRAY,
    );
    if let Some(h) = &info.histogram {
        histogram_plot(
            ui,
            ("step histogram", index),
            egui::Rect::from_min_size(
                egui::pos2(x + cell_w - 4.0 - HISTOGRAM_WIDTH, y + 2.0),
                egui::vec2(HISTOGRAM_WIDTH, LABEL_HEIGHT - 6.0),
            ),
            h,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_bar_ticks_are_increasing_end_at_the_top_and_follow_the_scale() {
        for top in [1, 7, 64, 100, 2048] {
            for scale in [StepScale::Log, StepScale::Linear] {
                let ticks = scale_ticks(scale, top);
                assert_eq!(ticks.first(), Some(&0));
                assert_eq!(ticks.last(), Some(&top));
                assert!(
                    ticks.windows(2).all(|w| w[0] < w[1]),
                    "{scale:?} {top}: {ticks:?}"
                );
            }
        }
        assert_eq!(
            scale_ticks(StepScale::Log, 2048),
            vec![0, 1, 2, 5, 10, 20, 50, 100, 200, 500, 2048]
        );
        assert_eq!(
            scale_ticks(StepScale::Linear, 100),
            vec![0, 25, 50, 75, 100]
        );
    }

    #[test]
    fn histogram_bins_are_powers_of_two() {
        let bins: Vec<usize> = [0, 1, 2, 3, 4, 7, 8, 1024, 2047, 2048, 100_000]
            .map(histogram_bin)
            .to_vec();
        assert_eq!(bins, vec![0, 1, 2, 2, 3, 3, 4, 11, 11, 12, 12]);
    }

    /// For 1, 2, 4, 9 and 16 panels in wide and tall areas, every panel keeps the viewport's
    /// aspect, the grid fits the area, and no other column count gives larger panels.
    #[test]
    fn the_grid_keeps_the_viewports_aspect_for_any_number_of_panels() {
        for (width, height) in [(1200.0, 700.0), (700.0, 1100.0), (1600.0, 500.0)] {
            let (label, aspect) = (34.0, width / height);
            for n in [1, 2, 4, 9, 16] {
                let g = GridLayout::new(n, width, height, label, aspect);
                assert!(g.columns * g.rows >= n, "{n} panels in {g:?}");
                assert!(
                    ((g.panel_w / g.panel_h) - aspect).abs() < 1e-3 * aspect,
                    "{n} panels: {g:?} against aspect {aspect}"
                );
                assert!(g.panel_w <= g.cell_w && g.columns as f32 * g.cell_w <= width + 1e-3);
                assert!(
                    g.rows as f32 * (g.panel_h + label) <= height + 1e-3,
                    "{g:?}"
                );
                for columns in 1..=n {
                    let rows = n.div_ceil(columns);
                    let fits = ((width / columns as f32 - 4.0)
                        .min((height / rows as f32 - label) * aspect))
                    .max(0.0);
                    assert!(
                        fits <= g.panel_w + 1e-3,
                        "{columns} columns would be larger"
                    );
                }
            }
        }
        // One panel is the whole area, less its label.
        let one = GridLayout::new(1, 1000.0, 634.0, 34.0, 1000.0 / 634.0);
        assert!(one.panel_w > 940.0, "{one:?}");
    }
}
