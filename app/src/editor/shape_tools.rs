//! The distance primitives (planes, boxes, rounded boxes, tori, cylinders; scene `Shape`) in
//! the editor: a new one of each kind sized to the skeleton around it, and the inspector's
//! fields for one. They have no handles in the viewport; every parameter is edited here.

use eframe::egui;
use skeletrace_core::model::scene::{Shape, Vec3};

/// The kinds the "Add shape" menu offers, in its order.
pub const KINDS: [&str; 5] = ["plane", "box", "rounded box", "torus", "cylinder"];

/// A shape of kind `KINDS[kind]` centred at `centre`, about `size` across, with prescribed
/// radius `radius`. A plane goes through `centre` facing up.
#[must_use]
pub fn new_shape(kind: usize, centre: Vec3, size: f64, radius: f64) -> Shape {
    let half = [0.5 * size; 3];
    match kind {
        0 => Shape::Plane {
            normal: [0.0, 1.0, 0.0],
            offset: centre[1],
            radius,
        },
        1 => Shape::Box {
            center: centre,
            half_extents: half,
            rotation: [0.0; 3],
            radius,
        },
        2 => Shape::RoundedBox {
            center: centre,
            half_extents: half,
            rounding: 0.2 * size,
            rotation: [0.0; 3],
            radius,
        },
        3 => Shape::Torus {
            center: centre,
            axis: [0.0, 1.0, 0.0],
            major: 0.5 * size,
            minor: 0.15 * size,
            radius,
        },
        _ => Shape::Cylinder {
            center: centre,
            axis: [0.0, 1.0, 0.0],
            cylinder_radius: 0.3 * size,
            half_height: 0.5 * size,
            radius,
        },
    }
}

/// The kind's name as the inspector shows it.
#[must_use]
pub fn kind_name(shape: &Shape) -> &'static str {
    match shape {
        Shape::Plane { .. } => KINDS[0],
        Shape::Box { .. } => KINDS[1],
        Shape::RoundedBox { .. } => KINDS[2],
        Shape::Torus { .. } => KINDS[3],
        Shape::Cylinder { .. } => KINDS[4],
    }
}

/// The shape's fields as drag values; the caller applies a changed copy as an edit (which the
/// document validates: a non-positive extent is refused with the loader's message).
pub fn edit_fields(ui: &mut egui::Ui, shape: &mut Shape) {
    let speed = 0.01;
    match shape {
        Shape::Plane {
            normal,
            offset,
            radius,
        } => {
            vector(ui, "normal", normal, speed);
            scalar(ui, "offset", offset, speed);
            scalar(ui, "radius", radius, speed);
        }
        Shape::Box {
            center,
            half_extents,
            rotation,
            radius,
        } => {
            vector(ui, "centre", center, speed);
            vector(ui, "half extents", half_extents, speed);
            vector(ui, "rotation °", rotation, 1.0);
            scalar(ui, "radius", radius, speed);
        }
        Shape::RoundedBox {
            center,
            half_extents,
            rounding,
            rotation,
            radius,
        } => {
            vector(ui, "centre", center, speed);
            vector(ui, "half extents", half_extents, speed);
            scalar(ui, "rounding", rounding, speed);
            vector(ui, "rotation °", rotation, 1.0);
            scalar(ui, "radius", radius, speed);
        }
        Shape::Torus {
            center,
            axis,
            major,
            minor,
            radius,
        } => {
            vector(ui, "centre", center, speed);
            vector(ui, "axis", axis, speed);
            scalar(ui, "major radius", major, speed);
            scalar(ui, "minor radius", minor, speed);
            scalar(ui, "radius", radius, speed);
        }
        Shape::Cylinder {
            center,
            axis,
            cylinder_radius,
            half_height,
            radius,
        } => {
            vector(ui, "centre", center, speed);
            vector(ui, "axis", axis, speed);
            scalar(ui, "cylinder radius", cylinder_radius, speed);
            scalar(ui, "half height", half_height, speed);
            scalar(ui, "radius", radius, speed);
        }
    }
}

pub fn scalar(ui: &mut egui::Ui, label: &str, value: &mut f64, speed: f64) {
    ui.horizontal(|ui| {
        ui.label(label);
        ui.add(egui::DragValue::new(value).speed(speed));
    });
}

pub fn vector(ui: &mut egui::Ui, label: &str, value: &mut Vec3, speed: f64) {
    ui.horizontal(|ui| {
        ui.label(label);
        for v in value {
            ui.add(egui::DragValue::new(v).speed(speed));
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use skeletrace_core::Scene;

    /// Every kind the menu adds passes the scene loader's validation and names its kind.
    #[test]
    fn every_new_shape_is_a_valid_scene_shape() {
        let mut scene = crate::editor::default_scene();
        for (kind, name) in KINDS.iter().enumerate() {
            let shape = new_shape(kind, [0.1, 0.2, 0.3], 1.0, 0.1);
            assert_eq!(kind_name(&shape), *name);
            scene.groups[0].shapes.push(shape);
        }
        let back = Scene::from_ron(&scene.to_ron(), "shapes");
        assert!(back.is_ok(), "{back:?}");
    }
}
