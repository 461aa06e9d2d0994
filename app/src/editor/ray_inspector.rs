//! The ray inspector: click a pixel of the comparison grid (or Alt-click the shaded view) and a
//! window plots `f(t) − c` along that pixel's ray, the support intervals it crosses, and for
//! each method the points it evaluated in order; for the marching methods also the lower and
//! upper bounds of each step (forward-inclusion 2023, algorithm 1: lines or parabolas from the
//! step's start over its interval), so that a loose bound shows where it leaves the field. A
//! table below lists every step. The same data as `skeletrace trace-ray` ([`RayProbe`]).

use eframe::egui;
use egui_plot::{Corner, Legend, Line, Plot, PlotPoints, Points};
use skeletrace_core::methods::MethodId;

use super::Editor;
use crate::ray_probe::RayProbe;

/// Points per drawn bound curve.
const BOUND_SAMPLES: usize = 16;

/// One colour per method, in the order they were chosen.
const PALETTE: [egui::Color32; 8] = [
    egui::Color32::from_rgb(230, 85, 60),
    egui::Color32::from_rgb(70, 150, 230),
    egui::Color32::from_rgb(90, 190, 90),
    egui::Color32::from_rgb(230, 180, 50),
    egui::Color32::from_rgb(180, 110, 220),
    egui::Color32::from_rgb(60, 200, 200),
    egui::Color32::from_rgb(240, 120, 180),
    egui::Color32::from_rgb(160, 160, 160),
];

impl Editor {
    /// Traces pixel `pixel` of a `size` frame of the current view with `methods` and opens the
    /// inspector on it.
    pub(super) fn inspect_ray(
        &mut self,
        pixel: (usize, usize),
        size: (usize, usize),
        methods: &[MethodId],
    ) {
        let compiled = self.doc.compiled();
        let camera = self.orbit.camera();
        self.view.ray_probe = Some(RayProbe::new(&compiled, &camera, pixel, size, methods));
    }

    /// Opens the inspector on the shaded view's pixel under `at` (window points in `rect`), for
    /// the shaded view's method, in the frame shown: the GPU viewport's (`gpu_pixels`) or the
    /// render thread's.
    pub(super) fn inspect_viewport_pixel(
        &mut self,
        at: egui::Pos2,
        rect: egui::Rect,
        gpu_pixels: Option<(usize, usize)>,
    ) {
        let shown = self
            .frames
            .shown
            .as_ref()
            .and_then(|s| s.frames.first())
            .map(|f| (f.frame.width, f.frame.height));
        let Some((width, height)) = gpu_pixels.or(shown).filter(|&(w, h)| w > 0 && h > 0) else {
            return;
        };
        let u = ((at.x - rect.left()) / rect.width() * width as f32) as usize;
        let v = ((at.y - rect.top()) / rect.height() * height as f32) as usize;
        let pixel = (u.min(width - 1), v.min(height - 1));
        let method = self.ui_state.shaded_method;
        self.inspect_ray(pixel, (width, height), &[method]);
    }

    /// The inspected ray, if the inspector is open.
    #[must_use]
    pub fn ray_probe(&self) -> Option<&RayProbe> {
        self.view.ray_probe.as_ref()
    }

    pub(super) fn ray_inspector(&mut self, ctx: &egui::Context) {
        let Some(probe) = &self.view.ray_probe else {
            return;
        };
        let mut open = true;
        let corner = ctx.content_rect().right_bottom();
        egui::Window::new("Ray inspector")
            .open(&mut open)
            .default_pos(corner - egui::vec2(600.0, 520.0))
            .default_size([580.0, 480.0])
            .show(ctx, |ui| show_probe(ui, probe));
        if !open {
            self.view.ray_probe = None;
        }
    }
}

fn show_probe(ui: &mut egui::Ui, probe: &RayProbe) {
    ui.label(format!(
        "pixel ({}, {}) of {}×{}, c = {}",
        probe.pixel.0, probe.pixel.1, probe.size.0, probe.size.1, probe.isovalue
    ));
    for (k, (id, trace)) in probe.traces.iter().enumerate() {
        let hit = trace
            .first()
            .map_or_else(|| "no hit".to_owned(), |c| format!("hit at t = {:.5}", c.t));
        ui.colored_label(
            PALETTE[k % PALETTE.len()],
            format!(
                "{id}: {} steps, {} evaluations, {hit}",
                trace.steps, trace.evaluations
            ),
        );
    }
    if probe.supports.is_empty() {
        ui.label("The ray crosses no support: the field is 0 all along it.");
        return;
    }
    let hull = (
        probe.supports.first().map_or(0.0, |s| s.lo),
        probe.supports.last().map_or(0.0, |s| s.hi),
    );
    Plot::new("ray inspector plot")
        .legend(Legend::default().position(Corner::LeftBottom))
        .height(ui.available_height() * 0.6)
        .x_axis_label("t")
        .y_axis_label("f − c")
        .show(ui, |plot| {
            plot.line(
                Line::new("f − c", PlotPoints::from(probe.samples.clone()))
                    .color(egui::Color32::LIGHT_GRAY),
            );
            for s in &probe.supports {
                plot.line(
                    Line::new("supports", PlotPoints::from(vec![[s.lo, 0.0], [s.hi, 0.0]]))
                        .color(egui::Color32::DARK_GRAY)
                        .width(4.0),
                );
            }
            for (k, (id, trace)) in probe.traces.iter().enumerate() {
                let colour = PALETTE[k % PALETTE.len()];
                let name = id.name();
                let Some(log) = &trace.log else {
                    let crossings: Vec<[f64; 2]> =
                        trace.crossings.iter().map(|c| [c.t, 0.0]).collect();
                    plot.points(Points::new(name, crossings).color(colour).radius(4.0));
                    continue;
                };
                let c = probe.isovalue;
                let steps: Vec<[f64; 2]> = log.iter().map(|s| [s.t, s.f - c]).collect();
                plot.points(Points::new(name, steps).color(colour).radius(3.0));
                for step in log {
                    let length = step.bound.length.min(hull.1 - step.t).max(0.0);
                    for offset in [step.bound.lower, step.bound.upper] {
                        let curve: Vec<[f64; 2]> = (0..=BOUND_SAMPLES)
                            .map(|i| {
                                let s = length * i as f64 / BOUND_SAMPLES as f64;
                                [step.t + s, step.f - c + s * (offset.a + offset.b * s)]
                            })
                            .collect();
                        plot.line(
                            Line::new(format!("{name} bounds"), PlotPoints::from(curve))
                                .color(colour.gamma_multiply(0.6))
                                .width(1.0),
                        );
                    }
                }
            }
        });
    egui::ScrollArea::vertical()
        .id_salt("ray inspector steps")
        .show(ui, |ui| {
            for (id, trace) in &probe.traces {
                let Some(log) = &trace.log else {
                    continue;
                };
                egui::CollapsingHeader::new(format!("{id}: steps"))
                    .id_salt(id.name())
                    .show(ui, |ui| {
                        egui::Grid::new(("steps", id.name()))
                            .striped(true)
                            .show(ui, |ui| {
                                for heading in ["#", "t", "f", "f′", "advance", "interval"] {
                                    ui.strong(heading);
                                }
                                ui.end_row();
                                for (k, s) in log.iter().enumerate() {
                                    ui.monospace(format!("{}", k + 1));
                                    ui.monospace(format!("{:.6}", s.t));
                                    ui.monospace(format!("{:.5}", s.f));
                                    ui.monospace(format!("{:.4}", s.slope));
                                    ui.monospace(format!("{:.6}", s.step));
                                    ui.monospace(format!("{:.6}", s.bound.length));
                                    ui.end_row();
                                }
                            });
                    });
            }
        });
}
