//! The scene's lights in the inspector: listed, added (directional or point), removed and
//! edited — direction towards the light or position, colour, intensity — each change one
//! undoable edit (a drag of one value, one step).

use eframe::egui;
use skeletrace_core::model::scene::Light;

use super::shape_tools::vector;
use super::{Edit, Editor};

impl Editor {
    pub(super) fn lights_panel(&mut self, ui: &mut egui::Ui) {
        let lights = self.doc.scene().lights.clone();
        let mut edited = lights.clone();
        let mut remove = None;
        ui.horizontal_wrapped(|ui| {
            ui.strong(format!("Lights ({})", lights.len()));
            if ui
                .button("Add directional light")
                .on_hover_text("light from a direction, as the sun")
                .clicked()
            {
                edited.push(Light::Directional {
                    direction: [-0.5, 0.8, 0.4],
                    color: [1.0, 1.0, 1.0],
                    intensity: 0.5,
                });
            }
            if ui
                .button("Add point light")
                .on_hover_text("light from a point, at the view's focus raised above it")
                .clicked()
            {
                let t = self.orbit.target;
                edited.push(Light::Point {
                    position: [t[0], t[1] + 2.0 * self.typical_radius().max(0.5), t[2]],
                    color: [1.0, 1.0, 1.0],
                    intensity: 1.0,
                });
            }
        });
        for (k, light) in edited.iter_mut().enumerate() {
            let kind = match light {
                Light::Directional { .. } => "directional",
                Light::Point { .. } => "point",
            };
            egui::CollapsingHeader::new(format!("light {} ({kind})", k + 1))
                .id_salt(("light", k))
                .show(ui, |ui| {
                    let (color, intensity) = match light {
                        Light::Directional {
                            direction,
                            color,
                            intensity,
                        } => {
                            vector(ui, "towards", direction, 0.01);
                            (color, intensity)
                        }
                        Light::Point {
                            position,
                            color,
                            intensity,
                        } => {
                            vector(ui, "position", position, 0.02);
                            (color, intensity)
                        }
                    };
                    let shown = color.map(|c| c as f32);
                    let mut rgb = shown;
                    ui.horizontal(|ui| {
                        ui.label("colour");
                        ui.color_edit_button_rgb(&mut rgb);
                    });
                    // As the group colours: only a real change goes back.
                    if rgb.iter().zip(shown).any(|(a, b)| (a - b).abs() > 1e-5) {
                        *color = rgb.map(f64::from);
                    }
                    ui.add(egui::Slider::new(intensity, 0.0..=4.0).text("intensity"));
                    if ui
                        .small_button("remove light")
                        .on_hover_text("take this light out of the scene")
                        .clicked()
                    {
                        remove = Some(k);
                    }
                });
        }
        if let Some(k) = remove {
            edited.remove(k);
        }
        if edited != lights {
            let added = edited.len() != lights.len();
            let edit = if added {
                Edit::new("lights")
            } else {
                Edit::gesture("light", "lights")
            };
            self.apply(edit, |s| s.lights = edited);
        }
    }
}
